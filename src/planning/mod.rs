//! Planning the next recordings: the recordings that best tell apart the explanations a
//! diagnosis leaves standing ([`rivals()`]), chosen one after another from the rig's design space
//! ([`space`]) by the discrimination criterion ([`criterion`]), then checked by simulation:
//! each rival taken as the truth, the planned recordings simulated from it with the campaign's
//! noise and every rival refitted ([`verify`]). [`report`] writes the plan (one conditions file
//! per recording, `plan.json`, `plan.png`) and its summary.
//!
//! This room sits beside [`crate::diagnosis`] and imports it (and [`crate::campaign`]); neither
//! imports this one.
//!
//! # Choice of recordings
//! Greedy maximin: each recording maximises, given the ones chosen before it, the smallest
//! pairwise discrimination `min(D_ij, D_ji)` over the pairs of rivals the existing evidence
//! leaves open ([`criterion`] module docs), ties broken by the sum over pairs. Maximin rather
//! than Box and Hill's weighting by the rivals' current probabilities: a diagnosis that ends in a
//! tie or `unexplained` is exactly one whose probabilities do not separate the rivals, and a
//! verdict needs *every* open pair told apart, so the pair worst told apart is what to improve.
//! A pair is closed (left out of the maximin, still reported) where one of its rivals is the
//! base model and the other's held-out evidence against it is clear.

pub mod choice;
pub mod criterion;
pub mod report;
pub mod rivals;
pub mod second;
pub mod simulate;
pub mod space;
pub mod types;
pub mod verify;

use crate::campaign::{Campaign, Recording};
use crate::diagnosis::features::FeatureSet;
use crate::diagnosis::fit::{Model, StepLog, Target};
use crate::diagnosis::linearised::{Linearised, linearise};
use crate::diagnosis::record::DiagnosisRecord;
use crate::diagnosis::verdict::Verdict;
use crate::model::EffectKind;
use choice::{Choice, Strategy};
use criterion::{Existing, Predicted, Rows, covariance, refit_alone};
use rayon::prelude::*;
pub use rivals::{MAX_RIVALS, Rival, Role, rivals};
use rivals::{kept_names, open_pairs};
pub use simulate::{blank, noise_of, noisy};
use simulate::{features_of, simulate_on};
use space::{Candidate, Space};
pub use types::*;

/// A plan's steps as they end: the diagnosis's step clock ([`StepLog`]: each step's wall time
/// and the simulations the target counted in it), and what each ran past the target's cache.
struct Steps {
    log: StepLog,
    /// Per step of `log`, the simulations run past the target's cache.
    outside: Vec<usize>,
}

impl Steps {
    fn new(target: &Target) -> Self {
        Steps {
            log: StepLog::new(target),
            outside: vec![],
        }
    }

    /// Ends the step `step`: its wall time, and the simulations the target counted in it plus
    /// `outside` run past the target's cache.
    fn end(&mut self, step: &'static str, target: &Target, outside: usize) {
        self.log.end(step, target);
        let k = self
            .log
            .steps
            .iter()
            .position(|s| s.step == step)
            .expect("the step just ended");
        self.outside.resize(self.log.steps.len(), 0);
        self.outside[k] += outside;
    }

    /// The steps in the order they ran.
    fn list(&self) -> Vec<PlanStep> {
        self.log
            .steps
            .iter()
            .zip(&self.outside)
            .map(|(s, o)| PlanStep {
                step: s.step,
                wall: s.wall,
                simulations: s.work.simulations + o,
            })
            .collect()
    }

    fn total(&self) -> usize {
        let inside: usize = self.log.steps.iter().map(|s| s.work.simulations).sum();
        inside + self.outside.iter().sum::<usize>()
    }
}

/// Plans `opts.recordings` recordings for the campaign `c` whose diagnosis is `diag`, within
/// `space`. `say` gets a line at each stage. The stages, in order: the rivals ([`rivals()`], and
/// those the plan fits itself), the campaign's noise, the open pairs and the design space's
/// candidates; then either a random draw ([`PlanOptions::random`]) or the rivals linearised,
/// simulated on every candidate, screened, differenced on the finalists, the recordings chosen
/// one after another and every pair's expected outcome; last the check by simulation.
pub fn plan(
    c: &Campaign,
    diag: &DiagnosisRecord,
    space: &Space,
    opts: &PlanOptions,
    say: &(dyn Fn(&str) + Sync),
) -> Result<Plan, PlanError> {
    opts.validate()?;
    let mut p = Planning::new(c, space, opts, say);
    let rivals = p.rivals(diag)?;
    let noise = noise_checked(c)?;
    let (open, why) = open_pairs(&rivals);
    p.warnings.extend(why);
    let cands = space.candidates(&c.recordings[0].params);
    if cands.len() < opts.recordings {
        return Err(PlanError::Nothing(format!(
            "the design space admits {} candidate recordings, fewer than the {} asked",
            cands.len(),
            opts.recordings
        )));
    }
    if Strategy::of(opts) == Strategy::Random {
        return Ok(p.random(rivals, open, cands, noise));
    }
    let lins = p.linearise(&rivals)?;
    let row_rec = p.target.row_recordings();
    let ex: Vec<Existing> = lins
        .iter()
        .map(|l| Existing {
            lin: l,
            row_rec: &row_rec,
            n_recs: c.recordings.len(),
        })
        .collect();
    let delta0: Vec<Vec<f64>> = ex.iter().map(refit_alone).collect();
    let on = p.simulate_candidates(&lins, &cands, noise);
    let screened = on.screen(&cands, &open);
    let fin = p.finalists(&cands, &screened, on.r)?;
    let rows = p.differenced(&lins, &cands, &fin, &on);
    let choice = Choice {
        rivals: &rivals,
        open: &open,
        cands: &cands,
        fin: &fin,
        rows: &rows,
        ex: &ex,
        delta0: &delta0,
    };
    say(&format!("choosing {} recordings", opts.recordings));
    let (chosen, planned) = choice.maximin(c, opts.recordings);
    let outcomes = choice.outcomes(&chosen);
    p.work.end("choice", &p.target, 0);
    let mut plan = Plan {
        rivals,
        open,
        recordings: planned,
        outcomes,
        space: space.clone(),
        candidates: cands.len(),
        finalists: fin.len(),
        screened,
        noise,
        simulations: 0,
        wall_time: 0.0,
        steps: vec![],
        warnings: std::mem::take(&mut p.warnings),
        random: false,
    };
    if opts.check {
        say("checking the plan: each rival as the truth, every rival refitted");
        let outside = verify::check(&p.target, &lins, &mut plan, opts.seed, say);
        p.work.end("check", &p.target, outside);
    }
    plan.simulations = p.work.total();
    plan.steps = p.work.list();
    plan.wall_time = p.start.elapsed().as_secs_f64();
    Ok(plan)
}

/// The campaign's noise (force \[N\], displacement \[m\]), refused where it cannot be
/// estimated.
fn noise_checked(c: &Campaign) -> Result<(f64, Option<f64>), PlanError> {
    let noise = noise_of(c);
    if !noise.0.is_finite() || noise.0 <= 0.0 {
        return Err(PlanError::Diagnosis(
            "the campaign's force noise could not be estimated (flat recordings?)".into(),
        ));
    }
    Ok(noise)
}

/// What the stages of a plan share: the campaign and its target, the options, the clock of the
/// steps, what the reader must know.
struct Planning<'a> {
    c: &'a Campaign,
    space: &'a Space,
    opts: &'a PlanOptions,
    say: &'a (dyn Fn(&str) + Sync),
    target: Target<'a>,
    work: Steps,
    warnings: Vec<String>,
    start: std::time::Instant,
}

/// The rivals simulated on every candidate recording: per candidate and rival (index
/// `k * r + j`), the noiseless features and those measured on a noisy recording.
struct OnCandidates {
    blanks: Vec<Recording>,
    per: Vec<(Vec<FeatureSet>, Vec<FeatureSet>)>,
    r: usize,
}

impl OnCandidates {
    /// Rival `j`'s noiseless features on candidate `k`.
    fn pred0(&self, k: usize, j: usize) -> &Vec<FeatureSet> {
        &self.per[k * self.r + j].0
    }

    /// The features measured on candidate `k` recorded from rival `i` with noise.
    fn meas(&self, k: usize, i: usize) -> &Vec<FeatureSet> {
        &self.per[k * self.r + i].1
    }

    /// The screen: each candidate's smallest open-pair distance before any refit (NaN where a
    /// rival could not be simulated on it).
    fn screen(&self, cands: &[Candidate], open: &[(usize, usize)]) -> Vec<(Candidate, f64)> {
        let (r, pred0, meas) = (self.r, |k, j| self.pred0(k, j), |k, i| self.meas(k, i));
        (0..cands.len())
            .map(|k| {
                let ok = (0..r).all(|j| {
                    pred0(k, j)
                        .iter()
                        .any(|f| f.value.iter().any(|v| v.is_finite()))
                });
                let s = if !ok {
                    f64::NAN
                } else {
                    open.iter()
                        .map(|&(a, b)| {
                            let d = |i: usize, j: usize| {
                                let (z, _) = criterion::rows_raw(meas(k, i), pred0(k, j));
                                let n = z.len() as f64;
                                let ss: f64 = z.iter().map(|v| v * v).sum();
                                if n > 0.0 {
                                    0.5 * n * (1.0 + ss / n).ln()
                                } else {
                                    0.0
                                }
                            };
                            d(a, b).min(d(b, a))
                        })
                        .fold(f64::INFINITY, f64::min)
                };
                (cands[k], s)
            })
            .collect()
    }
}

impl<'a> Planning<'a> {
    fn new(
        c: &'a Campaign,
        space: &'a Space,
        opts: &'a PlanOptions,
        say: &'a (dyn Fn(&str) + Sync),
    ) -> Self {
        let recs: Vec<&Recording> = c.recordings.iter().collect();
        let target = Target::new(recs);
        let work = Steps::new(&target);
        Planning {
            c,
            space,
            opts,
            say,
            target,
            work,
            warnings: vec![],
            start: std::time::Instant::now(),
        }
    }

    /// The rivals: the diagnosis's ([`rivals`]), and those the plan fits itself (second
    /// effects beside an effect named in part, with [`PlanOptions::second_effects`]; an
    /// unexplained gap's best three).
    fn rivals(&mut self, diag: &DiagnosisRecord) -> Result<Vec<Rival>, PlanError> {
        let p = self;
        let mut rivals = rivals(diag);
        let tried_second = !diag.second.is_empty();
        let named = rivals.iter().position(|x| x.role == Role::Named);
        if diag.partial
            && !tried_second
            && let Some(i) = named
        {
            if p.opts.second_effects {
                (p.say)(&format!(
                    "the diagnosis names {} only in part and fitted nothing beside it: fitting second effects",
                    rivals[i].name
                ));
                let extra = second::rivals(
                    &p.target,
                    &rivals[i],
                    &EffectKind::candidates(),
                    second::Keep::SECOND,
                    p.say,
                );
                p.warnings.push(format!(
                    "the diagnosis named {} only in part and tried no second effect; the plan fitted \
                     each candidate beside it (in-sample) and kept {}: {}",
                    rivals[i].name,
                    extra.len(),
                    kept_names(&extra, "none lowered its gap enough")
                ));
                rivals.extend(extra);
                rivals.truncate(MAX_RIVALS);
            } else {
                p.warnings.push(format!(
                    "the diagnosis named {} only in part and tried no second effect beside it: the \
                     plan tells apart only the rivals the diagnosis fitted and cannot aim at a second \
                     effect (--second-effects fits each candidate beside it first, minutes more; \
                     docs/planning.md says what that found on the bench)",
                    rivals[i].name
                ));
            }
        }
        // An unexplained gap's best three candidates, where the diagnosis's screens left fewer
        // fitted: the plan fits the candidates itself (hypotheses to tell apart, not verdicts).
        let fitted = rivals.len() - 1;
        // (Recordings drawn at random need no rivals: the baseline costs no fit.)
        if diag.verdict == Verdict::Unexplained && fitted < 3 && !p.opts.random {
            (p.say)(&format!(
                "the diagnosis fitted {fitted} candidate{} of the unexplained gap: the best of the others for the best three",
                if fitted == 1 { "" } else { "s" }
            ));
            let have: Vec<EffectKind> = rivals.iter().flat_map(|x| x.effects.clone()).collect();
            let keep = second::Keep {
                min_gain: crate::diagnosis::evidence::UNCHANGED,
                most: 3 - fitted,
            };
            // The diagnosis's own screens where it recorded them, else screened here.
            let (extra, how) = match second::from_screens(
                &p.target,
                &rivals[0],
                &diag.ranking,
                &have,
                keep,
                p.say,
            ) {
                Some(x) => (
                    x,
                    "took the others from the diagnosis's screens, refitted on every recording",
                ),
                None => (
                    second::rivals(
                        &p.target,
                        &rivals[0],
                        &EffectKind::candidates()
                            .into_iter()
                            .filter(|k| !have.contains(k))
                            .collect::<Vec<_>>(),
                        keep,
                        p.say,
                    ),
                    "screened each other candidate beside the base model itself",
                ),
            };
            p.warnings.push(format!(
                "on this unexplained gap {fitted} of the diagnosis's candidates passed its screen; the \
                 plan {how} (in-sample), keeping those that lower the base model's gap by {:.0} % \
                 (at most {}): {}",
                100.0 * keep.min_gain,
                keep.most,
                kept_names(&extra, "none did")
            ));
            rivals.extend(extra);
        }
        if rivals.len() < 2 && !p.opts.random {
            return Err(PlanError::Nothing(format!(
                "the diagnosis ({}) leaves no candidate standing beside the base model, so there \
                 is nothing to tell apart; its detection limits say what the campaign could not \
                 have seen (`limits` in diagnosis.json)",
                diag.verdict.name()
            )));
        }
        p.work.end("rivals", &p.target, 0);
        (p.say)(&format!(
            "{} rivals: {}",
            rivals.len(),
            rivals
                .iter()
                .map(|x| x.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
        Ok(rivals)
    }

    /// Each rival linearised on the campaign's recordings.
    fn linearise(&mut self, rivals: &[Rival]) -> Result<Vec<Linearised>, PlanError> {
        (self.say)("linearising each rival on the campaign's recordings");
        let lins: Vec<Linearised> = rivals
            .iter()
            .map(|x| linearise(&self.target, &x.model, &x.effects))
            .collect();
        for (x, l) in rivals.iter().zip(&lins) {
            if l.z.is_empty() {
                return Err(PlanError::Diagnosis(format!(
                    "rival {} cannot be simulated on every recording of the campaign",
                    x.name
                )));
            }
        }
        self.work.end("linearisation", &self.target, 0);
        Ok(lins)
    }

    /// Every rival simulated on every candidate recording.
    fn simulate_candidates(
        &mut self,
        lins: &[Linearised],
        cands: &[Candidate],
        noise: (f64, Option<f64>),
    ) -> OnCandidates {
        let (opts, space, r) = (self.opts, self.space, lins.len());
        let has_x = noise.1.is_some();
        let blanks: Vec<Recording> = cands
            .iter()
            .enumerate()
            .map(|(k, x)| blank(&format!("candidate{k}"), x, space.rate, has_x))
            .collect();
        (self.say)(&format!(
            "simulating {} rivals on {} candidate recordings",
            r,
            cands.len()
        ));
        let tol = crate::campaign::FIT_TOLERANCE;
        let asks: Vec<(Model, &Recording)> = blanks
            .iter()
            .flat_map(|b| lins.iter().map(move |l| (l.at(&l.theta), b)))
            .collect();
        let traces = simulate_on(&asks, tol);
        // Per candidate and rival: noiseless features, and the measured ones of a noisy recording.
        let per: Vec<(Vec<FeatureSet>, Vec<FeatureSet>)> = (0..asks.len())
            .into_par_iter()
            .map(|q| {
                let rec = asks[q].1;
                let clean = features_of(rec, traces[q].as_ref());
                let meas = match &traces[q] {
                    Some(tr) => {
                        let nz = noisy(
                            tr,
                            noise,
                            opts.seed.wrapping_mul(7919).wrapping_add(q as u64),
                        );
                        let mut m = features_of(rec, Some(&nz));
                        for (mm, cl) in m.iter_mut().zip(&clean) {
                            mm.value = cl.value;
                            mm.cycles = cl.cycles;
                        }
                        criterion::without_r(m)
                    }
                    None => clean.clone(),
                };
                (clean, meas)
            })
            .collect();
        drop(traces);
        OnCandidates { blanks, per, r }
    }

    /// The finalists: the best by the screen, and the best of each frequency and rest so that
    /// a recording the refit favours is not lost to one the screen favours.
    fn finalists(
        &mut self,
        cands: &[Candidate],
        screened: &[(Candidate, f64)],
        rivals: usize,
    ) -> Result<Vec<usize>, PlanError> {
        let opts = self.opts;
        let mut order: Vec<usize> = (0..cands.len())
            .filter(|&k| screened[k].1.is_finite())
            .collect();
        let failed = cands.len() - order.len();
        if failed > 0 {
            self.warnings.push(format!(
                "{failed} candidate recordings could not be simulated under every rival and were left out"
            ));
        }
        order.sort_by(|&a, &b| screened[b].1.total_cmp(&screened[a].1));
        self.work
            .end("candidates", &self.target, cands.len() * rivals);
        let mut fin: Vec<usize> = vec![];
        let mut kinds: Vec<(u64, u64)> = vec![];
        for &k in &order {
            let kind = (cands[k].params.f.to_bits(), cands[k].params.k_d.to_bits());
            if !kinds.contains(&kind) {
                kinds.push(kind);
                fin.push(k);
            }
        }
        for &k in &order {
            if fin.len() >= opts.finalists {
                break;
            }
            if !fin.contains(&k) {
                fin.push(k);
            }
        }
        fin.truncate(opts.finalists.max(opts.recordings));
        if fin.len() < opts.recordings {
            return Err(PlanError::Nothing(format!(
                "only {} candidate recordings could be simulated under every rival, fewer than the {} asked",
                fin.len(),
                opts.recordings
            )));
        }
        Ok(fin)
    }

    /// The rows of every (finalist, truth, rival): each rival's predictions on each finalist
    /// differenced in its parameters.
    fn differenced(
        &mut self,
        lins: &[Linearised],
        cands: &[Candidate],
        fin: &[usize],
        on: &OnCandidates,
    ) -> Vec<Vec<Vec<Rows>>> {
        (self.say)(&format!(
            "differencing the rivals' predictions on {} finalists",
            fin.len()
        ));
        let (r, blanks, tol) = (on.r, &on.blanks, crate::campaign::FIT_TOLERANCE);
        let (pred0, meas) = (|k, j| on.pred0(k, j), |k, i| on.meas(k, i));
        let covs: Vec<Option<faer::Mat<f64>>> = lins.iter().map(covariance).collect();
        let mut fd_asks: Vec<(Model, &Recording)> = vec![];
        let mut fd_index: Vec<(usize, usize, usize)> = vec![];
        let mut steps: Vec<Vec<f64>> = vec![];
        for l in lins {
            steps.push((0..l.theta.len()).map(|k| l.step_at(k, &l.theta)).collect());
        }
        for (fi, &k) in fin.iter().enumerate() {
            for (j, l) in lins.iter().enumerate() {
                for c_ in 0..l.theta.len() {
                    let mut th = l.theta.clone();
                    th[c_] += steps[j][c_];
                    fd_asks.push((l.at(&th), &blanks[k]));
                    fd_index.push((fi, j, c_));
                }
            }
        }
        let fd_traces = simulate_on(&fd_asks, tol);
        let fd_feats: Vec<Vec<FeatureSet>> = fd_asks
            .par_iter()
            .zip(&fd_traces)
            .map(|((_, rec), tr)| features_of(rec, tr.as_ref()))
            .collect();
        drop(fd_traces);
        let mut predicted: Vec<Predicted> = fin
            .iter()
            .map(|&k| Predicted {
                candidate: cands[k],
                pred: (0..r).map(|j| vec![pred0(k, j).clone()]).collect(),
                steps: steps.clone(),
                meas: (0..r).map(|i| meas(k, i).clone()).collect(),
            })
            .collect();
        for (q, &(fi, j, _)) in fd_index.iter().enumerate() {
            predicted[fi].pred[j].push(fd_feats[q].clone());
        }
        // Rows of every (finalist, truth, rival).
        let rows: Vec<Vec<Vec<Rows>>> = predicted
            .par_iter()
            .map(|pr| {
                (0..r)
                    .map(|i| (0..r).map(|j| pr.rows(i, j, covs[i].as_ref())).collect())
                    .collect()
            })
            .collect();
        self.work.end("finalists", &self.target, fd_asks.len());
        rows
    }

    /// [`Strategy::Random`]: the recordings drawn ([`choice::draw`]), nothing simulated.
    fn random(
        self,
        rivals: Vec<Rival>,
        open: Vec<(usize, usize)>,
        cands: Vec<Candidate>,
        noise: (f64, Option<f64>),
    ) -> Plan {
        let Planning {
            c,
            space,
            opts,
            start,
            mut warnings,
            work,
            ..
        } = self;
        let recordings = choice::draw(c, &cands, &open, opts.recordings, opts.seed);
        warnings.push("recordings drawn at random: no discrimination computed".into());
        Plan {
            rivals,
            open,
            recordings,
            outcomes: vec![],
            space: space.clone(),
            candidates: cands.len(),
            finalists: 0,
            screened: cands.iter().map(|x| (*x, f64::NAN)).collect(),
            noise,
            simulations: 0,
            wall_time: start.elapsed().as_secs_f64(),
            steps: work.list(),
            warnings,
            random: true,
        }
    }
}
