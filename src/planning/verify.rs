//! The plan checked by simulation, not by the criterion's linearisation: each rival taken as
//! the truth, the planned recordings simulated from it (at the synthetic campaigns' tolerance,
//! 1e-6) with the campaign's noise, every rival refitted (Levenberg–Marquardt from its fitted
//! parameters, on the existing recordings and the planned ones), and the evidence computed
//! as the diagnosis computes it ([`evidence`]: one scale per recording, the jackknife over
//! recordings) on the planned recordings and on what the refit changed on the existing ones.

use super::simulate::{blank, noisy, per_recording};
use super::types::Plan;
use crate::campaign::Recording;
use crate::diagnosis::evidence::{LN_PRIOR_ODDS, evidence};
use crate::diagnosis::fit::{FitOptions, Target, fit};
use crate::diagnosis::linearised::Linearised;

/// Iterations of each refit: they start at the rival's optimum on the existing recordings.
pub const REFIT_ITERATIONS: usize = 4;

/// Checks `plan` by simulation (module docs) and fills each outcome's simulated evidence.
/// Returns the simulations of the planned recordings from each truth, which run outside
/// `target`'s cache (its own counter holds the refits').
pub fn check(
    target: &Target,
    lins: &[Linearised],
    plan: &mut Plan,
    seed: u64,
    say: &(dyn Fn(&str) + Sync),
) -> usize {
    let r = plan.rivals.len();
    let has_x = plan.noise.1.is_some();
    let n_old = target.recs.len();
    let mut sims = 0;
    // The existing recordings' per-recording gaps of each rival at its fit.
    let old: Vec<(Vec<f64>, Vec<usize>)> =
        lins.iter().map(|l| per_recording(target, &l.z)).collect();
    // Every truth's planned recordings live until the end: the simulation cache knows a
    // recording by its address, and a recording of another truth at a freed address would be
    // served this one's measured features.
    let mut kept: Vec<Vec<Recording>> = Vec::with_capacity(r);
    for i in 0..r {
        say(&format!(
            "  {} as the truth: simulating the planned recordings, refitting {} rivals",
            plan.rivals[i].name, r
        ));
        let blanks: Vec<Recording> = plan
            .recordings
            .iter()
            .map(|p| blank(&p.name, &p.candidate, plan.space.rate, has_x))
            .collect();
        let truth = lins[i].at(&lins[i].theta);
        let asks: Vec<(crate::diagnosis::fit::Model, &Recording)> =
            blanks.iter().map(|b| (truth.clone(), b)).collect();
        let traces = super::simulate_on(&asks, 1e-6);
        sims += asks.len();
        let planned: Vec<Recording> = blanks
            .iter()
            .zip(&traces)
            .enumerate()
            .filter_map(|(k, (b, tr))| {
                let tr = tr.as_ref()?;
                let nz = noisy(
                    tr,
                    plan.noise,
                    seed ^ (0x9e37_79b9 * (i as u64 + 1)) ^ k as u64,
                );
                Some(Recording {
                    f_d: nz.f_d,
                    x_s: b.x_s.as_ref().map(|_| nz.x_s),
                    x_d: b.x_d.as_ref().map(|_| nz.x_d),
                    ..b.clone()
                })
            })
            .collect();
        if planned.len() < blanks.len() {
            plan.warnings.push(format!(
                "with {} as the truth, {} planned recordings could not be simulated",
                plan.rivals[i].name,
                blanks.len() - planned.len()
            ));
        }
        kept.push(planned);
        let planned = &kept[i];
        let mut recs: Vec<&Recording> = target.recs.clone();
        recs.extend(planned.iter());
        let ext = target.sub(recs);
        let opts = FitOptions {
            max_iter: REFIT_ITERATIONS,
            final_jacobian: false,
            ..FitOptions::default()
        };
        let refits: Vec<(Vec<f64>, Vec<usize>)> = lins
            .iter()
            .map(|l| {
                let fr = fit(&ext, &l.model, &l.effects, opts);
                per_recording(&ext, &fr.z)
            })
            .collect();
        // Per recording: the planned ones' gaps as they are; an existing one's as the ratio of
        // its gap after the refit to its gap before, so that its term is what the refit changed.
        let terms = |j: usize| -> (Vec<f64>, Vec<usize>) {
            let (g, n) = &refits[j];
            let mut a = vec![];
            let mut k = vec![];
            for rec in 0..g.len() {
                if rec < n_old {
                    a.push(g[rec] / old[j].0[rec]);
                } else {
                    a.push(g[rec]);
                }
                k.push(n[rec]);
            }
            (a, k)
        };
        for o in plan.outcomes.iter_mut().filter(|o| o.truth == i) {
            let (a, na) = terms(i);
            let (b, nb) = terms(o.other);
            let ev = evidence(&a, &na, &b, &nb, 0.0);
            let total = o.now + ev.ln_odds;
            o.simulated = Some(total);
            o.simulated_stderr = Some(ev.stderr);
            o.clear = Some(total >= LN_PRIOR_ODDS && o.now + ev.least_left_out >= LN_PRIOR_ODDS);
        }
    }
    sims
}
