//! The sim-to-real diagnosis: calibrate the base model, locate the gap (features, phases,
//! conditions), attribute it to the effect (or the two effects) whose fit shrinks the gap most
//! on held-out recordings, decide, and quantify.
//!
//! **Cross-validation over groups of conditions** ([`folds`]). No campaign design is assumed.
//! Each recording has a *kind*: no vibration, partial reduction (`v_a < v_d`) or elimination
//! (`v_a ≥ v_d`), with its frequency band (octaves from 250 Hz) for the last two; a two-stage
//! recording takes the kind of its vibrated stage. A *group* is the recordings of one kind at
//! one drive (`v_d`, `k_d`, load). The groups of each kind are dealt round-robin into
//! [`FOLDS`] folds (fewer where the campaign has fewer groups), so every fold's calibration
//! holds recordings of every kind its held-out part holds, wherever the campaign has two groups
//! of that kind or more. A kind with a single group cannot be checked on held-out data: its
//! recordings still calibrate the other folds, are left out of the held-out gaps, and the
//! report names them ([`Diagnosis::not_checked`]).
//!
//! **Fits shared across folds.** Each model (the base, every candidate) is fitted once on all
//! recordings, a candidate only after a screening fit (on [`SCREEN_RECORDINGS`] of them in a
//! larger campaign, else on all) from the global scan of its starts ([`scan::starts`](super::scan::starts); a
//! sensor's resonance is scanned again densely about the screen's optimum,
//! [`scan::line_search`](super::scan::line_search)), with a fresh finite-difference Jacobian at its optimum; each fold's
//! model is that fit refitted to the fold's calibration residuals by one damped Gauss–Newton
//! step on the same Jacobian's rows ([`fit::refit_rows`]; halved where it raises the fold's
//! calibration cost), and simulated once. A held-out gap is `√(mean z²)` over every held-out
//! unit of every fold (each recording held out once); its spread is the standard deviation of
//! the folds' own gaps.
//!
//! **Gap.** `E = √(mean z²)` over the standardised feature differences ([`super::fit`]); 1 means
//! "within noise and floors".
//!
//! **Evidence** ([`evidence`]). Two models are compared on the held-out recordings by the
//! log-likelihood ratio `Λ = Σ_i n_i ln(E_B,i/E_A,i) − `[`PARAM_NATS`]` (k_A − k_B)` over the
//! recordings (`n_i` held-out residuals each, `E_i` the recording's held-out gap): each residual
//! is taken as Gaussian with the model's own mean square in its recording as variance, and each
//! added parameter costs a nat. A recording's residuals share one stick-slip history,
//! so the standard error is the jackknife over recordings (leave one recording out), and a
//! preference that one recording carries is not clear. `Λ` is "how many times as likely":
//! `e^Λ`. A preference is **clear** ([`Evidence::clear`]) where `Λ ≥ ln 20`
//! ([`LN_PRIOR_ODDS`]: prior odds of 1 to 20 against any one explanation), `Λ − SE ≥ 0`
//! ([`EVIDENCE_SE`]), and `Λ ≥ ln 20` still with any one recording left out.
//!
//! **Decision** ([`super::decide`]). With `E0`, `E1` the held-out gaps of the calibrated base
//! model and of the leader (the qualifying candidate of best evidence against the base model,
//! where evidence and held-out gap must agree for one candidate to beat another):
//! - `no_significant_gap` when `E0 <` [`SIGNIFICANT_GAP`] and no single feature's held-out
//!   gap reaches [`FEATURE_GAP`] on two recordings or more (decided before any candidate is
//!   fitted: then none is, unless [`DiagnoseOptions::rank_always`]);
//! - `unexplained` when no candidate is clearly more likely than the base model and explains
//!   at least [`MIN_PARTIAL`] of the gap (where only a concentrated feature makes the gap
//!   significant, of the gap beyond noise, `E − 1`, [`NOISE_GAP`]);
//! - `tie` when the leader does not beat some plausible candidate (clearly more likely and no
//!   lower held-out gap), or a candidate of better evidence did not qualify: those are listed
//!   ([`Diagnosis::tie`]) and none is named;
//! - `effect` otherwise, with `partial` where the named effects leave a significant gap
//!   (`E1 ≥` [`SIGNIFICANT_GAP`], or, where only a concentrated feature made the gap
//!   significant, a feature that still concentrates it) or a
//!   named effect's fitted parameter ends on a bound of the campaign's plausible range
//!   ([`fit::Plausible`], [`fit::at_bounds`]; with a warning).
//!
//! After a named effect, its fit is polished further from its optimum ([`fit::refine`], on its
//! Jacobian there); where that fit converged inside its plausible range, carries every feature
//! family held out of it ([`held_out_families`]) and a significant gap remains, every other
//! candidate is fitted together with it (forward selection), and a second
//! effect is named by the same rule against the first (at least [`MIN_SECOND`] of the gap the
//! first leaves; a tie among seconds names none, with a warning), and, where its fingerprints
//! can test it, only where one of them is present in the recordings ([`fingerprint`](super::fingerprint)): beside
//! a first effect of another form than the data's, any candidate can take up part of that
//! form's misfit.
//!
//! **Two effects that need each other** (`try_pair`). Where no candidate passed its screen,
//! forward selection has no first step, yet two effects can act together with neither enough
//! alone. The two best screens of different effects are screened together and, where the pair
//! passes the bar, fitted on every recording with each member alone; both are named only where
//! the pair passes the rule of a first effect against the base model and that of a second
//! effect against each member alone.
//!
//! **Fingerprints.** Every candidate the rule would name or tie is checked on the recorded
//! traces ([`fingerprint`](super::fingerprint): the ringing after slips, absent rejects it; the breakaway's
//! vibration phase, stick time and position, read slip by slip) and on each feature family of
//! [`FAMILIES`] held out of its fit ([`held_out_families`]); a slip-by-slip or held-out family
//! absent names it only as partial, with a warning (`held_out_absent`), and no second effect
//! is tried beside it. A second effect needs the ringing present where it can test it.

use super::candidate::{Folds, Round};
use super::candidate::{Pair, try_candidate, try_pair};
use super::decide::{Side, between};
pub use super::evidence::GAPPED;
use super::evidence::breadth_of;
use super::features::{FEATURES, Feature, N_FEATURES, PHASES};
use super::fit::{self, FitOptions, FitResult, Model, StepLog, Target};
use super::folds::*;
use super::forms::{Try, charge_forms, form_choice, forms_of_one, other_forms, try_forms};
use super::limits::{self, Limits};
use super::screen::Screen;
use super::vet::{Against, held_out_absent, vetted};
use crate::campaign::{Campaign, CampaignError};
use crate::model::EffectKind;
use rayon::prelude::*;
use std::cmp::Ordering;

pub use super::evidence::*;
pub use super::folds::{BIAS_T, BIAS_UNITS, BIAS_Z, folds, spearman};
pub use super::screen::{
    RANK_REL_TOL, SCREEN_BAR, SCREEN_ITERATIONS, SCREEN_RECORDINGS, SCREEN_REL_TOL,
};
pub use super::verdict::*;
pub use super::vet::{FAMILIES, family_of, held_out_families};

/// Diagnoses a campaign. A campaign none of whose recordings can be checked on held-out data
/// (no kind of condition recorded at two drives) is refused: it names what is missing. The
/// stages, in order: the base model calibrated and cross-validated (`calibrate`); the
/// candidates, their forms and the decision, and two effects together where none passed
/// alone (`first_round`); a second effect beside a named first one (`second_round`);
/// where the gap lies; the detection limits (`limits_of`).
pub fn diagnose(c: &Campaign, opts: &DiagnoseOptions) -> Result<Diagnosis, CampaignError> {
    let start = std::time::Instant::now();
    let (fold, k_folds, checked, not_checked) = folds(c);
    if !checked.iter().any(|&x| x) {
        return Err(CampaignError::Malformed {
            file: c.dir.display().to_string(),
            line: 0,
            msg: format!(
                "campaign of {} recording(s) too small to hold anything out: no kind of condition (no vibration; v_a < v_d; v_a >= v_d, per octave of f) is recorded at two drives (v_d, k_d) or more, so no recording can be checked on data its calibration did not see; record at least one kind at two drives",
                c.recordings.len()
            ),
        });
    }
    let all = Target::new(c.recordings.iter().collect());
    let cx = Ctx {
        all: &all,
        folds: Folds {
            fold: &fold,
            k: k_folds,
            checked: &checked,
        },
        fo: FitOptions {
            final_jacobian: true,
            ..opts.fit
        },
        opts,
    };
    let mut log = Log {
        steps: StepLog::new(&all),
        warnings: vec![],
        disagreements: vec![],
    };
    let base = calibrate(&cx, &mut log);
    let first = first_round(&cx, &base, &mut log);
    let named = second_round(&cx, &base, &first, &mut log);
    log.steps.end("second effect", &all);
    // Where the gap lies: the base model over all recordings; the gap left by the named effects.
    let top_model = first.ranking.first().map(|b| b.fit.model.clone());
    let location = locate(
        c,
        &all,
        &fold,
        &checked,
        &base.fit.model,
        top_model.as_ref(),
    );
    let remaining = if named.effects.is_empty() {
        String::new()
    } else {
        let m = if named.effects.len() > 1 {
            &named.second[0].fit.model
        } else {
            &first.ranking[0].fit.model
        };
        locate(c, &all, &fold, &checked, m, None).summary
    };
    log.steps.end("location", &all);
    log.warnings
        .extend(log.disagreements.iter().map(|d| d.line()));
    let limits = limits_of(&cx, &base, first.verdict, &named);
    log.steps.end("limits", &all);
    let First {
        ranking,
        verdict,
        tie,
        mut forms,
        breadth,
        evidence_best,
        evidence_runner_up,
        ..
    } = first;
    let Named {
        effects,
        second,
        gap_after,
        gap_after_spread,
        partial,
        forms: second_forms,
        ..
    } = named;
    forms.extend(second_forms);
    let share = base.share();
    Ok(Diagnosis {
        verdict,
        disagreements: log.disagreements,
        limits,
        concentrated: base.concentrated,
        systematic: systematic(&base.cv),
        reduction_beyond_noise: (base.noise > 0.0 && verdict != Verdict::NoSignificantGap)
            .then(|| share(gap_after)),
        best_effect: effects.first().copied(),
        partial,
        effects,
        gap_before: base.gap,
        gap_before_spread: base.cv.spread,
        gap_after,
        gap_after_spread,
        reduction: (base.gap - gap_after) / base.gap,
        breadth,
        evidence: evidence_best,
        evidence_runner_up,
        tie,
        forms,
        warnings: log.warnings,
        bounds: all.bounds.clone(),
        base_per_feature: base.cv.per_feature.iter().map(|p| p.0).collect(),
        base: base.fit,
        ranking,
        second,
        location,
        remaining,
        folds: k_folds,
        held_out: c
            .recordings
            .iter()
            .zip(&checked)
            .filter(|(_, h)| **h)
            .map(|(r, _)| r.name.clone())
            .collect(),
        not_checked,
        wall_time: start.elapsed().as_secs_f64(),
        work: all.work(),
        steps: log.steps.steps,
    })
}

/// What every stage of a diagnosis reads: the recordings, their folds, the fit options.
#[derive(Clone, Copy)]
struct Ctx<'a> {
    all: &'a Target<'a>,
    folds: Folds<'a>,
    fo: FitOptions,
    opts: &'a DiagnoseOptions,
}

/// What the stages of a diagnosis add to as they go: the steps' clock, the warnings, the
/// disagreements between evidence and held-out gap.
struct Log {
    steps: StepLog,
    warnings: Vec<String>,
    disagreements: Vec<Disagreement>,
}

/// The base model calibrated on every recording and cross-validated, and what its gap asks.
struct Base {
    fit: FitResult,
    cv: CrossValidated,
    /// Its held-out gap.
    gap: f64,
    /// The feature in which it concentrates, where one does.
    concentrated: Option<(Feature, f64, usize)>,
    /// The verdict `no_significant_gap` stands before any candidate.
    no_gap: bool,
    /// Where only a concentrated feature makes the gap significant, shares are of the gap
    /// beyond noise (1): a whole gap of 1.3 cannot fall by more than 23 % of itself.
    noise: f64,
}

impl Base {
    /// The share of the base model's gap a held-out gap `e1` removes (of the gap beyond noise,
    /// where only a concentrated feature makes it significant).
    fn share(&self) -> impl Fn(f64) -> f64 + Copy + use<> {
        let (gap_before, noise) = (self.gap, self.noise);
        move |e1: f64| (gap_before - e1) / (gap_before - noise).max(0.1 * gap_before)
    }

    /// A round of candidates extending it, screened by `screen`.
    fn round<'a>(&'a self, cx: &Ctx<'a>, screen: &'a Screen<'a>) -> Round<'a> {
        Round {
            all: cx.all,
            screen,
            from: &self.fit,
            from_cv: &self.cv,
            with: &[],
            e0: self.gap,
            folds: cx.folds,
            opts: cx.fo,
        }
    }

    /// Its side in a decision.
    fn side(&self) -> Side<'_> {
        Side {
            name: "base",
            per_recording: &self.cv.per_recording,
            n: &self.cv.per_recording_n,
        }
    }
}

/// The base model calibrated and cross-validated.
fn calibrate(cx: &Ctx<'_>, log: &mut Log) -> Base {
    let all = cx.all;
    let fit = fit::fit(all, &Model::default(), &[], cx.fo);
    log.steps.end("calibration", all);
    let f = cx.folds;
    let cv = cross_validate(all, &fit, &Model::default(), f.fold, f.k, f.checked);
    log.steps.end("cross-validation", all);
    let gap = cv.gap;
    let concentrated = concentrated(&cv);
    // The verdict `no_significant_gap` needs no candidate: fit them only on request.
    let no_gap = !matches!(
        gap.partial_cmp(&SIGNIFICANT_GAP),
        Some(Ordering::Greater | Ordering::Equal)
    ) && concentrated.is_none();
    let noise = if gap >= SIGNIFICANT_GAP {
        0.0
    } else {
        NOISE_GAP
    };
    Base {
        fit,
        cv,
        gap,
        concentrated,
        no_gap,
        noise,
    }
}

/// Best evidence first (ties by the informative score, then the library's order).
fn by_evidence(a: &Ranked, b: &Ranked) -> Ordering {
    b.evidence
        .ln_odds
        .total_cmp(&a.evidence.ln_odds)
        .then(a.score.total_cmp(&b.score))
}

/// The first round's outcome: the ranked candidates, the verdict they carry, and what a
/// report and the second round take from them.
struct First {
    ranking: Vec<Ranked>,
    verdict: Verdict,
    tie: Vec<EffectKind>,
    /// Two effects named together where none passed its screen alone.
    pair: Option<Pair>,
    forms: Vec<FormChoice>,
    breadth: f64,
    evidence_best: Option<Evidence>,
    evidence_runner_up: Option<(EffectKind, Evidence)>,
}

/// The candidates beside the base model: screened, fitted and ranked in parallel (they are
/// independent and deterministic, so the ranking does not depend on the thread count), their
/// other forms, the decision with its fingerprints, and two effects together where none passed
/// its screen alone.
fn first_round(cx: &Ctx<'_>, base: &Base, log: &mut Log) -> First {
    let (all, opts) = (cx.all, cx.opts);
    let fitted: &[EffectKind] = if base.no_gap && !opts.rank_always {
        &[]
    } else {
        &opts.candidates
    };
    let share = base.share();
    let screen = (!fitted.is_empty()).then(|| Screen::of(all, &base.fit, cx.fo));
    let round = |cands: &[Try]| -> Vec<Ranked> {
        let Some(screen) = &screen else {
            return vec![];
        };
        let r = base.round(cx, screen);
        cands.par_iter().map(|t| try_candidate(&r, t)).collect()
    };
    let defaults: Vec<Try> = fitted.iter().map(|&k| Try::default_form(k)).collect();
    let mut ranking = round(&defaults);
    log.steps.end("candidates", all);
    ranking.sort_by(by_evidence);
    log.warnings.extend(fit::base_at_bounds(&base.fit)
        .into_iter()
        .map(|b| format!("the base calibration ends on a bound of its range ({b}): the base model has not found this rig's values, and every comparison with it is weaker for it")));
    let mut tie: Vec<EffectKind> = vec![];
    let base_side = base.side();
    let decide_first = |ranking: &mut Vec<Ranked>, found: &mut Vec<_>| {
        let against = Against {
            from: &base.fit,
            side: base_side,
            share,
            min_share: MIN_PARTIAL,
            need_present: false,
        };
        vetted(ranking, all, against, found)
    };
    let (steps, disagreements) = (&mut log.steps, &mut log.disagreements);
    let decided = (!base.no_gap).then(|| {
        let first_try = decide_first(&mut ranking, disagreements);
        steps.end("fingerprints", all);
        // How the effects scale: the other forms of the effects in reach, fitted as candidates
        // of their own, and of every effect with forms where the default forms name none
        // (or tie) (forms::other_forms); then the decision again over all.
        let named = matches!(&first_try, Some(t) if t.len() == 1);
        let decided: Vec<EffectKind> = first_try
            .iter()
            .flatten()
            .map(|&j| ranking[j].effect)
            .collect();
        let others = other_forms(&ranking, !named);
        let between = |ranking: &mut Vec<Ranked>| {
            ranking.sort_by(by_evidence);
            let t = decide_first(ranking, &mut vec![]);
            t.iter().flatten().map(|&j| ranking[j].effect).collect()
        };
        if !try_forms(&mut ranking, &base.fit, &decided, others, round, between) {
            return first_try;
        }
        steps.end("forms", all);
        charge_forms(&mut ranking);
        ranking.sort_by(by_evidence);
        let decided = decide_first(&mut ranking, disagreements);
        steps.end("fingerprints", all);
        decided
    });
    let mut verdict = match decided {
        None => Verdict::NoSignificantGap,
        Some(None) => Verdict::Unexplained,
        Some(Some(t)) if t.len() > 1 => match forms_of_one(&mut ranking, &t, share, MIN_PARTIAL) {
            Some(kinds) => {
                tie = kinds;
                Verdict::Tie
            }
            None => Verdict::Effect,
        },
        Some(Some(_)) => Verdict::Effect,
    };
    // Two effects together where none passed its screen alone; its time counts in the step
    // `second effect`.
    let mut pair = None;
    if verdict == Verdict::Unexplained
        && let Some(screen) = &screen
    {
        pair = pair_round(cx, base, screen, &mut ranking, log);
        if pair.is_some() {
            verdict = Verdict::Effect;
        }
    }
    let mut forms: Vec<FormChoice> = vec![];
    if verdict == Verdict::Effect && pair.is_none() {
        forms.extend(form_choice(&ranking));
    }
    let breadth = ranking.first().map_or(0.0, |b| {
        breadth_of(&base.cv.per_recording, &b.per_recording)
    });
    let evidence_best = ranking.first().map(|b| b.evidence);
    // The runner-up: the best candidate of another effect (another form of the leader's is in
    // `forms`).
    let evidence_runner_up = ranking.first().and_then(|b| {
        let r = ranking[1..].iter().find(|r| r.effect != b.effect)?;
        Some((r.effect, between(b, r)))
    });
    // A pair named together: its own evidence against the base model, and against its second
    // member alone (the first alone is in the second effect's entry).
    let (evidence_best, evidence_runner_up) = match &pair {
        Some(p) => (Some(p.vs_base), Some((p.alone.effect, p.vs_alone))),
        None => (evidence_best, evidence_runner_up),
    };
    First {
        ranking,
        verdict,
        tie,
        pair,
        forms,
        breadth,
        evidence_best,
        evidence_runner_up,
    }
}

/// Two effects fitted together where none passed its screen alone ([`try_pair`]), named
/// together where the pair passes; `ranking` then holds each fitted alone, the first member at
/// its head.
fn pair_round(
    cx: &Ctx<'_>,
    base: &Base,
    screen: &Screen<'_>,
    ranking: &mut [Ranked],
    log: &mut Log,
) -> Option<Pair> {
    let share = base.share();
    let mut pair = None;
    let r = base.round(cx, screen);
    match try_pair(&r, ranking, share, &mut log.disagreements) {
        None => {}
        Some(Err(why)) => log.warnings.push(why),
        Some(Ok(p)) => {
            for r in [&p.first, &p.alone] {
                if let Some(x) = ranking.iter_mut().find(|x| x.name == r.name) {
                    *x = r.clone();
                }
            }
            ranking.sort_by(by_evidence);
            // The first member heads the ranking, as a named first effect does.
            if let Some(i) = ranking.iter().position(|x| x.name == p.first.name) {
                ranking[..=i].rotate_right(1);
            }
            log.warnings.push(format!(
                "{} and {} are named together: neither passed its screen alone, the pair explains {:.0} % of the gap (ln odds {:.1} ± {:.1} against {} alone, {:.1} ± {:.1} against {} alone)",
                p.first.name,
                p.both.name,
                100.0 * p.both.reduction,
                p.both.evidence.ln_odds,
                p.both.evidence.stderr,
                p.first.name,
                p.vs_alone.ln_odds,
                p.vs_alone.stderr,
                p.alone.name,
            ));
            pair = Some(p);
        }
    }
    pair
}

/// What the named effects leave: the effects in order, the second effects tried, their
/// held-out gap, whether they explain only part of it, and the fit of the named effects (the
/// first, or the first with a second), for the limits.
struct Named {
    effects: Vec<EffectKind>,
    second: Vec<Ranked>,
    gap_after: f64,
    gap_after_spread: f64,
    /// The named effects leave a significant gap (or the feature it concentrated in), or a
    /// parameter ends on a bound of its plausible range.
    partial: bool,
    named_fit: Option<FitResult>,
    /// The forms of the second effect named, where one is.
    forms: Vec<FormChoice>,
}

/// Forward selection: a second effect with the first, where a clear gap remains; or the pair
/// named together by the first round.
fn second_round(cx: &Ctx<'_>, base: &Base, first_round: &First, log: &mut Log) -> Named {
    let all = cx.all;
    let (ranking, verdict, noise) = (&first_round.ranking, first_round.verdict, base.noise);
    let (warnings, disagreements) = (&mut log.warnings, &mut log.disagreements);
    let mut second: Vec<Ranked> = vec![];
    let mut effects = vec![];
    let mut forms = vec![];
    let (mut gap_after, mut gap_after_spread) = (base.gap, base.cv.spread);
    let mut partial = false;
    let mut named_fit: Option<FitResult> = None;
    if let Some(Pair { both, .. }) = &first_round.pair {
        let both = both.clone();
        // Named together (`try_pair`): the pair's fit is the named one, its entry the second's.
        effects = vec![ranking[0].effect, both.effect];
        for b in &both.at_bound {
            warnings.push(format!(
                "{} + {}: the fit ends on a bound of the plausible range ({b})",
                ranking[0].name, both.name
            ));
        }
        partial = !both.at_bound.is_empty()
            || both.gap_after >= SIGNIFICANT_GAP
            || (noise > 0.0 && both.concentrated.is_some());
        if let Some(w) = held_out_absent(&both) {
            warnings.push(w);
            partial = true;
        }
        (gap_after, gap_after_spread) = (both.gap_after, both.gap_spread);
        named_fit = Some(both.fit.clone());
        second = vec![both];
    } else if verdict == Verdict::Effect {
        // The first effect's fit, polished further from its optimum (on its Jacobian there):
        // a second effect is credited only with what the first cannot reach by itself.
        let first = &ranking[0];
        let (first_fit, first_cv) = polished(cx, first);
        effects.push(first.effect);
        gap_after = first_cv.gap.min(first.gap_after);
        gap_after_spread = if first_cv.gap < first.gap_after {
            first_cv.spread
        } else {
            first.gap_spread
        };
        let mut named_concentrated = first.concentrated.is_some();
        let first_bounds = fit::at_bounds(&all.bounds, &first_fit);
        let first_absent = held_out_absent(first);
        if let Some(w) = &first_absent {
            warnings.push(w.clone());
        }
        for b in &first_bounds {
            warnings.push(format!(
                "{}: the fit ends on a bound of the plausible range ({b}); the effect is named only as partial: within what this rig can have, it does not explain the whole gap",
                first.effect.name()
            ));
        }
        // A second effect only beside a converged first one inside its plausible range that
        // carries every feature family held out of it: else the second would be credited with
        // what the first's fit has not reached (a resonance fitted off its value, which trades
        // one family for the others, leaves a misfit any candidate can take up part of).
        let first_settled =
            first_fit.converged && first_bounds.is_empty() && first_absent.is_none();
        if !first_settled && first_cv.gap >= SIGNIFICANT_GAP {
            warnings.push(format!(
                "no second effect tried: the fit of {} {}",
                first.effect.name(),
                if !first_bounds.is_empty() {
                    "ends on a bound"
                } else if !first_fit.converged {
                    "did not converge"
                } else {
                    "does not carry a fingerprint it predicts (a feature family held out of it, or one read slip by slip)"
                }
            ));
        }
        if first_settled && first_cv.gap >= SIGNIFICANT_GAP {
            let decided;
            (second, decided) = second_candidates(cx, first, &first_fit, &first_cv, disagreements);
            match decided {
                Some(t) if t.len() == 1 => {
                    let s2 = &second[0];
                    for b in &s2.at_bound {
                        warnings.push(format!(
                            "{}: the fit ends on a bound of the plausible range ({b})",
                            s2.effect.name()
                        ));
                    }
                    partial |= !s2.at_bound.is_empty();
                    if let Some(w) = held_out_absent(s2) {
                        warnings.push(w);
                        partial = true;
                    }
                    named_concentrated = s2.concentrated.is_some();
                    named_fit = Some(s2.fit.clone());
                    forms.extend(form_choice(&second));
                    effects.push(s2.effect);
                    gap_after = s2.gap_after;
                    gap_after_spread = s2.gap_spread;
                }
                Some(t) => warnings.push(format!(
                    "a second effect acts beside {}, but the data cannot tell which: {}",
                    first.name,
                    t.iter()
                        .map(|&j| second[j].name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )),
                None => {}
            }
        }
        if named_fit.is_none() {
            named_fit = Some(first_fit.clone());
        }
        partial |= !first_bounds.is_empty()
            || first_absent.is_some()
            || gap_after >= SIGNIFICANT_GAP
            || (noise > 0.0 && named_concentrated);
    }
    Named {
        effects,
        second,
        gap_after,
        gap_after_spread,
        partial,
        named_fit,
        forms,
    }
}

/// The first effect's fit, polished further from its optimum (on its Jacobian there), and its
/// cross-validation: a second effect is credited only with what the first cannot reach by
/// itself. Where polishing gains nothing, the fit and its held-out results as ranked.
fn polished(cx: &Ctx<'_>, first: &Ranked) -> (FitResult, CrossValidated) {
    let (all, f) = (cx.all, cx.folds);
    let polished = fit::refine(all, &first.fit, cx.fo);
    if polished.gap < first.fit.gap {
        let cv = cross_validate(all, &polished, &first.fit.model, f.fold, f.k, f.checked);
        (polished, cv)
    } else {
        let cv = CrossValidated {
            gap: first.gap_after,
            spread: first.gap_spread,
            per_recording: first.per_recording.clone(),
            per_recording_n: first.per_recording_n.clone(),
            held: vec![],
            per_feature: vec![],
            per_feature_bias: vec![],
        };
        (first.fit.clone(), cv)
    }
}

/// The candidates beside a settled first effect `first` (its fit `first_fit`, cross-validated
/// as `first_cv`): screened, fitted and ranked as a second effect, their forms, and the
/// decision over them (indices into the ranking returned; forms of one effect tied are that
/// effect). Their disagreements are named as extensions of the first.
fn second_candidates(
    cx: &Ctx<'_>,
    first: &Ranked,
    first_fit: &FitResult,
    first_cv: &CrossValidated,
    disagreements: &mut Vec<Disagreement>,
) -> (Vec<Ranked>, Option<Vec<usize>>) {
    let (all, opts, fo, folds) = (cx.all, cx.opts, cx.fo, cx.folds);
    let second_screen = Screen::of(all, first_fit, fo);
    let round = |cands: &[Try]| -> Vec<Ranked> {
        let r = Round {
            all,
            screen: &second_screen,
            from: first_fit,
            from_cv: first_cv,
            with: &[first.effect],
            e0: first_cv.gap,
            folds,
            opts: fo,
        };
        cands.par_iter().map(|t| try_candidate(&r, t)).collect()
    };
    let defaults: Vec<Try> = opts
        .candidates
        .iter()
        .filter(|&&k| k != first.effect)
        .map(|&k| Try::default_form(k))
        .collect();
    let first_share = |e2: f64| (first_cv.gap - e2) / first_cv.gap;
    let mut second = round(&defaults);
    let qualifies = second
        .iter()
        .any(|r| r.evidence.clear() && first_share(r.gap_after) >= MIN_SECOND);
    let others = other_forms(&second, !qualifies);
    let between = |s: &mut Vec<Ranked>| {
        s.sort_by(by_evidence);
        vec![]
    };
    try_forms(&mut second, first_fit, &[], others, round, between);
    charge_forms(&mut second);
    second.sort_by(by_evidence);
    let first_side = Side {
        name: first.effect.name(),
        per_recording: &first_cv.per_recording,
        n: &first_cv.per_recording_n,
    };
    let mut found = vec![];
    let against = Against {
        from: first_fit,
        side: first_side,
        share: first_share,
        min_share: MIN_SECOND,
        need_present: true,
    };
    let decided = vetted(&mut second, all, against, &mut found);
    // A second effect's disagreements are named as extensions of the first.
    disagreements.extend(found.into_iter().map(|mut d| {
        for n in [&mut d.by_evidence, &mut d.by_gap] {
            if *n != first.name {
                *n = format!("{} + {n}", first.name);
            }
        }
        d
    }));
    // Forms of one effect tied: that effect.
    let decided = match decided {
        Some(t) if t.len() > 1 => match forms_of_one(&mut second, &t, first_share, MIN_SECOND) {
            None => Some(vec![0]),
            Some(_) => Some(t),
        },
        d => d,
    };
    (second, decided)
}

/// What the campaign could not have seen, where the model in hand leaves no gap.
fn limits_of(cx: &Ctx<'_>, base: &Base, verdict: Verdict, named: &Named) -> Limits {
    let (all, opts, f) = (cx.all, cx.opts, cx.folds);
    let (fold, k_folds, checked, partial) = (f.fold, f.k, f.checked, named.partial);
    let (base, base_cv) = (&base.fit, &base.cv);
    match (verdict, &named.named_fit) {
        _ if !opts.limits => Limits::none("not asked for"),
        (Verdict::NoSignificantGap, _) => {
            limits::limits(all, base, base_cv, fold, k_folds, limits::Test::Gap)
        }
        (Verdict::Effect, Some(m)) if !partial => {
            let cv = cross_validate(all, m, &m.model, fold, k_folds, checked);
            limits::limits(all, m, &cv, fold, k_folds, limits::Test::Second)
        }
        _ => Limits::none(format!(
            "the campaign shows a gap the models in hand do not explain in full ({}{}): detection limits say what a campaign without a gap could not have seen; what this one leaves open is for recordings planned to decide it",
            verdict.name(),
            if partial { ", partial" } else { "" }
        )),
    }
}

/// Where the gap of `base` lies, over all recordings.
fn locate(
    c: &Campaign,
    all: &Target,
    fold: &[usize],
    checked: &[bool],
    base: &Model,
    best: Option<&Model>,
) -> Where {
    let pred = all.predict(base);
    let pred_best = best.map(|m| all.predict(m));
    let mut recordings = vec![];
    let mut feat_sum = [0.0; N_FEATURES];
    let mut feat_n = [0usize; N_FEATURES];
    for (i, rec) in c.recordings.iter().enumerate() {
        let mut z_base = [f64::NAN; N_FEATURES];
        let mut zs = vec![];
        let mut zs_best = vec![];
        for u in all.units_of(i) {
            let m = &all.measured[u];
            for f in FEATURES {
                if let Some(z) = fit::zscore(m, &pred[u], f) {
                    let zb = &mut z_base[f as usize];
                    if !matches!(
                        zb.abs().partial_cmp(&z.abs()),
                        Some(Ordering::Greater | Ordering::Equal)
                    ) {
                        *zb = z;
                    }
                    feat_sum[f as usize] += z * z;
                    feat_n[f as usize] += 1;
                    zs.push(z);
                }
            }
            if let Some(pb) = &pred_best {
                zs_best.extend(fit::zscores(m, &pb[u]));
            }
        }
        let gap_best = if pred_best.is_some() {
            fit::gap(&zs_best)
        } else {
            f64::NAN
        };
        let p = &rec.params;
        // Stick time from the recording's first stage (without vibration where it has two).
        let m = &all.measured[all.units_of(i).next().expect("a recording has a stage")];
        let period = m.get(Feature::Period);
        let slip = m.get(Feature::SlipTime);
        let stick = if period.is_finite() && slip.is_finite() {
            period - slip
        } else {
            0.0
        };
        recordings.push(RecordingGap {
            name: rec.name.clone(),
            gap_base: fit::gap(&zs),
            gap_best,
            held_out: checked[i],
            fold: fold[i],
            conditions: [
                p.v_d,
                p.k_d,
                if p.vibrates() { p.f } else { 0.0 },
                p.v_a() / p.v_d,
                stick,
                p.k_t * p.u0 / base.f_c,
            ],
            z_base,
        });
    }
    let total: f64 = feat_sum.iter().sum::<f64>().max(1e-300);
    let features: Vec<(Feature, f64, f64)> = FEATURES
        .iter()
        .map(|&f| {
            let i = f as usize;
            let rms = if feat_n[i] > 0 {
                (feat_sum[i] / feat_n[i] as f64).sqrt()
            } else {
                0.0
            };
            (f, rms, feat_sum[i] / total)
        })
        .collect();
    let phases: Vec<(&'static str, f64, f64)> = PHASES
        .iter()
        .enumerate()
        .map(|(k, &name)| {
            let (s, n) = FEATURES
                .iter()
                .filter(|f| f.phase() == k)
                .fold((0.0, 0usize), |(s, n), f| {
                    (s + feat_sum[*f as usize], n + feat_n[*f as usize])
                });
            (
                name,
                if n > 0 { (s / n as f64).sqrt() } else { 0.0 },
                s / total,
            )
        })
        .collect();
    let gaps: Vec<f64> = recordings.iter().map(|r| r.gap_base).collect();
    let conditions: Vec<(&'static str, f64)> = CONDITIONS
        .iter()
        .enumerate()
        .map(|(k, &name)| {
            let x: Vec<f64> = recordings.iter().map(|r| r.conditions[k]).collect();
            (name, spearman(&x, &gaps))
        })
        .collect();
    let mean_gap = |vib: bool| {
        let z: Vec<f64> = recordings
            .iter()
            .filter(|r| (r.conditions[2] > 0.0) == vib)
            .map(|r| r.gap_base * r.gap_base)
            .collect();
        if z.is_empty() {
            f64::NAN
        } else {
            (z.iter().sum::<f64>() / z.len() as f64).sqrt()
        }
    };
    let with_vibration = (mean_gap(true), mean_gap(false));
    let mut summary = describe(&features, &phases, &conditions, with_vibration);
    let sq: Vec<f64> = recordings.iter().map(|r| r.gap_base * r.gap_base).collect();
    let total_sq: f64 = sq.iter().sum();
    if let Some(i) = (0..sq.len()).max_by(|&a, &b| sq[a].total_cmp(&sq[b]))
        && total_sq > 0.0
        && sq[i] / total_sq > 0.3
    {
        summary += &format!(
            " Recording {} alone carries {:.0} % of it (gap {:.2}).",
            recordings[i].name,
            100.0 * sq[i] / total_sq,
            recordings[i].gap_base
        );
    }
    Where {
        features,
        phases,
        conditions,
        recordings,
        with_vibration,
        summary,
    }
}

fn describe(
    features: &[(Feature, f64, f64)],
    phases: &[(&str, f64, f64)],
    conditions: &[(&str, f64)],
    vib: (f64, f64),
) -> String {
    let mut f: Vec<_> = features.to_vec();
    f.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut ph: Vec<_> = phases.to_vec();
    ph.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut cs: Vec<_> = conditions.to_vec();
    cs.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    let mut s = format!(
        "The gap concentrates in {} ({:.0} % of the squared gap) and {} ({:.0} %), i.e. in the {} phase ({:.0} %)",
        f[0].0.name(),
        100.0 * f[0].2,
        f[1].0.name(),
        100.0 * f[1].2,
        ph[0].0,
        100.0 * ph[0].2
    );
    if ph[1].2 > 0.2 {
        s += &format!(" and the {} phase ({:.0} %)", ph[1].0, 100.0 * ph[1].2);
    }
    s += ". ";
    if vib.0.is_finite() && vib.1.is_finite() {
        let (a, b) = vib;
        if a > 1.5 * b {
            s += &format!("It is larger with vibration (gap {a:.2}) than without ({b:.2}). ");
        } else if b > 1.5 * a {
            s += &format!("It is larger without vibration (gap {b:.2}) than with ({a:.2}). ");
        } else {
            s += &format!("It is alike with vibration (gap {a:.2}) and without ({b:.2}). ");
        }
    }
    if let Some((name, rho)) = cs.first() {
        if rho.abs() >= 0.4 {
            s += &format!(
                "Over the conditions it {} with {name} (Spearman ρ = {rho:.2}).",
                if *rho > 0.0 { "grows" } else { "shrinks" }
            );
        } else {
            s += "It follows no single condition (|ρ| < 0.4 for all).";
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::Recording;
    use crate::model::Params;

    fn campaign(conds: &[(f64, f64, f64, f64)]) -> Campaign {
        let recordings = conds
            .iter()
            .enumerate()
            .map(|(i, &(k_d, v_d, f, ratio))| {
                let mut p = Params {
                    k_d,
                    v_d,
                    f: if f > 0.0 { f } else { 1500.0 },
                    ..Params::default()
                };
                if f > 0.0 {
                    p.set_v_a(ratio * v_d);
                }
                Recording {
                    name: format!("r{i:02}"),
                    params: p,
                    t: vec![],
                    f_d: vec![],
                    x_s: None,
                    x_d: None,
                }
            })
            .collect();
        Campaign {
            dir: "mem".into(),
            recordings,
            planned: vec![],
            acquisition: Default::default(),
        }
    }

    fn with_features(gaps: &[(Feature, f64, usize)]) -> CrossValidated {
        let mut per_feature = vec![(f64::NAN, 0); N_FEATURES];
        for &(f, g, n) in gaps {
            per_feature[f as usize] = (g, n);
        }
        CrossValidated {
            gap: 1.5,
            spread: 0.1,
            per_recording: vec![],
            per_recording_n: vec![],
            held: vec![],
            per_feature,
            per_feature_bias: vec![],
        }
    }

    /// The evidence's closed forms: models whose gaps differ by a constant factor `c` on every
    /// one of `n` recordings give `n ln c` less the parameter charge, with no spread; the same
    /// preference carried by one recording alone is as strong on average but not clear.
    #[test]
    fn evidence_weighs_the_spread_over_recordings() {
        let n = 12;
        let counts = vec![17; n];
        let a = vec![1.5; n];
        let b = vec![3.0; n];
        let e = evidence(&a, &counts, &b, &counts, 2.0);
        let residuals = (n * 17) as f64;
        assert!((e.ln_odds - (residuals * 2f64.ln() - 2.0 * PARAM_NATS)).abs() < 1e-9);
        assert!(e.stderr.abs() < 1e-9, "{e:?}");
        assert_eq!(e.recordings, n);
        assert!(e.clear());
        // Against itself with two parameters more: two nats against, never clear.
        let same = evidence(&a, &counts, &a, &counts, 2.0);
        assert!((same.ln_odds + 2.0 * PARAM_NATS).abs() < 1e-12 && !same.clear());
        // One recording far off under B, the others alike: strong evidence, but the jackknife
        // sees that it rests on one recording.
        let mut b1 = a.clone();
        b1[3] = 40.0;
        let one = evidence(&a, &counts, &b1, &counts, 0.0);
        assert!(one.ln_odds > LN_PRIOR_ODDS, "{one:?}");
        assert!(one.least_left_out.abs() < 1e-9, "{one:?}");
        assert!(!one.clear(), "{one:?}");
        // Two recordings carrying it alike: it holds with either left out, and is clear.
        let mut b2 = b1.clone();
        b2[7] = 40.0;
        let two = evidence(&a, &counts, &b2, &counts, 0.0);
        assert!(
            (two.least_left_out - 0.5 * two.ln_odds).abs() < 1e-9,
            "{two:?}"
        );
        assert!(two.clear(), "{two:?}");
        // Recordings either model leaves undefined (NaN, no residuals) do not count.
        let mut a2 = a.clone();
        a2[0] = f64::NAN;
        let mut c2 = counts.clone();
        c2[1] = 0;
        let fewer = evidence(&a2, &c2, &b, &counts, 0.0);
        assert_eq!(fewer.recordings, n - 2);
        assert!((fewer.ln_odds - ((n - 2) * 17) as f64 * 2f64.ln()).abs() < 1e-9);
    }

    /// A gap concentrated in one feature counts on two recordings or more, never on one, and
    /// the largest such feature is the one reported.
    #[test]
    fn a_concentrated_gap_needs_two_recordings() {
        let one = with_features(&[(Feature::ForceAmp1, 8.0, 1), (Feature::DF, 1.2, 0)]);
        assert_eq!(concentrated(&one), None);
        let low = with_features(&[(Feature::ForceAmp1, 2.9, 6)]);
        assert_eq!(concentrated(&low), None);
        let two = with_features(&[
            (Feature::ForceAmp1, 5.3, 5),
            (Feature::SlipTime, 3.3, 2),
            (Feature::R, 9.0, 1),
        ]);
        assert_eq!(concentrated(&two), Some((Feature::ForceAmp1, 5.3, 5)));
        // Without per-feature gaps (a cross-validation carried over), nothing is concentrated.
        let none = CrossValidated {
            per_feature: vec![],
            ..with_features(&[])
        };
        assert_eq!(concentrated(&none), None);
    }

    /// Every fold's calibration holds every kind its checked held-out part holds.
    fn calibration_covers_held_out(c: &Campaign) {
        let (fold, k, checked, _) = folds(c);
        assert!(k >= 2);
        for f in 0..k {
            for (i, r) in c.recordings.iter().enumerate() {
                if fold[i] != f || !checked[i] {
                    continue;
                }
                let kind = kind_of(&r.params);
                assert!(
                    c.recordings
                        .iter()
                        .zip(&fold)
                        .any(|(q, &g)| g != f && kind_of(&q.params) == kind),
                    "fold {f}: {} ({}) has no kin in its calibration",
                    r.name,
                    kind_name(kind)
                );
            }
        }
    }

    /// The paper's design: vibration tests at one stiffness only, yet every fold calibrates on
    /// vibrated recordings of each kind it holds out, and every recording is checked.
    #[test]
    fn paper_like_design_is_checked_everywhere() {
        let mut conds = vec![];
        for k_d in [11_700.0, 17_900.0, 20_000.0] {
            for v_d in [1e-3, 2e-3] {
                conds.push((k_d, v_d, 0.0, 0.0));
            }
        }
        for v_d in [1e-3, 2e-3] {
            for f in [500.0, 1500.0, 3000.0] {
                for ratio in [0.4, 0.8, 1.3, 2.0] {
                    conds.push((11_700.0, v_d, f, ratio));
                }
            }
        }
        let c = campaign(&conds);
        calibration_covers_held_out(&c);
        let (fold, k, checked, not_checked) = folds(&c);
        assert_eq!(k, FOLDS);
        assert!(checked.iter().all(|&x| x) && not_checked.is_empty());
        // Balanced: no fold holds more than a third of the recordings.
        for f in 0..k {
            let n = fold.iter().filter(|&&g| g == f).count();
            assert!((4..=10).contains(&n), "fold {f}: {n}");
        }
    }

    /// The factorial design and a small unbalanced one; a lone vibrated recording (one drive,
    /// one frequency band, v_a >= v_d) is named as not checked instead of being decided on.
    #[test]
    fn unbalanced_designs_say_what_they_cannot_check() {
        let mut conds = vec![];
        for (k_d, v_d) in [
            (11_700.0, 0.7e-3),
            (11_700.0, 1e-3),
            (20_000.0, 1e-3),
            (17_900.0, 2e-3),
        ] {
            conds.push((k_d, v_d, 0.0, 0.0));
            for (f, ratio) in [(1000.0, 0.5), (2000.0, 0.8), (1500.0, 1.5)] {
                conds.push((k_d, v_d, f, ratio));
            }
        }
        let c = campaign(&conds);
        calibration_covers_held_out(&c);
        assert!(folds(&c).3.is_empty());

        let c = campaign(&[
            (11_700.0, 1e-3, 0.0, 0.0),
            (17_900.0, 2e-3, 0.0, 0.0),
            (20_000.0, 1e-3, 0.0, 0.0),
            (11_700.0, 1e-3, 1500.0, 0.5),
            (17_900.0, 2e-3, 1500.0, 0.4),
            (11_700.0, 1e-3, 1500.0, 1.4),
            (20_000.0, 1e-3, 1200.0, 0.9),
            (20_000.0, 1e-3, 3000.0, 1.2),
            (17_900.0, 2e-3, 2500.0, 1.8),
            (17_900.0, 2e-3, 2500.0, 0.3),
        ]);
        calibration_covers_held_out(&c);
        let (_, _, checked, not_checked) = folds(&c);
        // 1400 Hz at v_a = 1.4 v_d is alone in its band and kind.
        assert!(!checked[5], "{checked:?}");
        assert!(
            not_checked
                .iter()
                .any(|s| s.contains("r05") && s.contains("v_a >= v_d")),
            "{not_checked:?}"
        );
        assert!(checked[0] && checked[3] && checked[4]);
    }

    /// A campaign with nothing to hold out is refused before any fit, saying what is missing.
    #[test]
    fn a_campaign_too_small_to_hold_out_is_refused() {
        for conds in [
            vec![(11_700.0, 1e-3, 0.0, 0.0)],
            vec![(11_700.0, 1e-3, 0.0, 0.0), (11_700.0, 1e-3, 1500.0, 0.5)],
        ] {
            let c = campaign(&conds);
            let e = diagnose(&c, &DiagnoseOptions::default())
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("too small to hold anything out") && e.contains("two drives"),
                "{e}"
            );
        }
    }
}
