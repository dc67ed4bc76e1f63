//! Rivals a plan fits itself. Second effects: where a diagnosis names an effect only in part and
//! fitted nothing beside it (its fit leaves a fingerprint absent, or ends on a bound, and the
//! diagnosis then tries no second effect: it would be credited with the first's misfit), the
//! plan still needs the hypotheses "the named effect and another" to aim at. They are
//! hypotheses to tell apart, not verdicts: each is fitted here on the campaign's recordings
//! (in-sample, from the named fit with the other effect at the best start of the diagnosis's
//! scan of its parameters), and only those
//! that lower the named fit's gap by [`MIN_GAIN`] of it on a screen of the recordings it misses
//! most are kept, the best [`MAX_SECOND`]. And an unexplained gap's best three candidates where
//! the diagnosis's screens fitted fewer (each fell short of the bar a verdict needs): fitted
//! beside the base model the same way, kept where they lower its gap by
//! [`crate::diagnosis::evidence::UNCHANGED`] at least.

use super::{Rival, per_recording};
use crate::diagnosis::evidence::evidence;
use crate::diagnosis::fit::{self, FitOptions, FitResult, Target, gap};
use crate::model::EffectKind;

/// Share of the named fit's gap on the screen's recordings a second effect must remove to be
/// kept as a rival (the diagnosis's screen bar).
pub const MIN_GAIN: f64 = crate::diagnosis::screen::SCREEN_BAR;
/// Second-effect rivals kept at most.
pub const MAX_SECOND: usize = 2;
/// Recordings of the screen (the diagnosis's).
pub const SCREEN_RECORDINGS: usize = crate::diagnosis::screen::SCREEN_RECORDINGS;

/// Which candidates fitted beside a rival are kept.
#[derive(Clone, Copy, Debug)]
pub struct Keep {
    /// Share of the rival's gap on the screen's recordings a candidate must remove.
    pub min_gain: f64,
    /// Candidates kept at most, the lowest gaps first.
    pub most: usize,
}

impl Keep {
    /// Second effects beside a named one: [`MIN_GAIN`], [`MAX_SECOND`].
    pub const SECOND: Keep = Keep {
        min_gain: MIN_GAIN,
        most: MAX_SECOND,
    };
}

/// The rivals fitted beside `named` (a named effect, or the base model), among `candidates`,
/// kept as `keep` says (module docs).
pub fn rivals(
    target: &Target,
    named: &Rival,
    candidates: &[EffectKind],
    keep: Keep,
    say: &(dyn Fn(&str) + Sync),
) -> Vec<Rival> {
    let z = target.residuals(&target.predict(&named.model));
    if z.is_empty() {
        return vec![];
    }
    let sub = fit::subset(target, &z, SCREEN_RECORDINGS);
    // The named fit as the scans take it: its model and its residuals on every recording.
    let from = FitResult {
        model: named.model.clone(),
        estimates: vec![],
        gap: gap(&z),
        residuals: z.len(),
        evaluations: 0,
        effect_params: 0,
        iterations: 0,
        converged: true,
        stalled: false,
        theta: vec![],
        z: z.clone(),
        jacobian: faer::Mat::zeros(0, 0),
        jacobian_fresh: false,
        effects: named.effects.clone(),
    };
    let g0 = gap(&sub.residuals(&sub.predict(&named.model)));
    let bar = (1.0 - keep.min_gain) * g0;
    let screen = FitOptions {
        max_iter: crate::diagnosis::screen::SCREEN_ITERATIONS,
        rel_tol: crate::diagnosis::screen::SCREEN_REL_TOL,
        final_jacobian: false,
        reach: bar,
    };
    let mut kept = vec![];
    for &k in candidates {
        if named.effects.contains(&k) {
            continue;
        }
        let mut effects = named.effects.clone();
        effects.push(k);
        // The diagnosis's scan of the candidate's parameters beside the named fit chooses the
        // screen's starts (its best, and a per-frequency scan's runner-up); the lowest screen
        // goes on.
        let fr = fit::starts(target, &from, k, k.default_form())
            .iter()
            .map(|start| fit::fit(&sub, start, &effects, screen))
            .min_by(|a, b| a.gap.total_cmp(&b.gap))
            .expect("a scan gives a start");
        say(&format!(
            "  {} beside {}: gap {:.2} on the screen's {} recordings (to keep: at most {:.2})",
            k.name(),
            named.name,
            fr.gap,
            sub.recs.len(),
            bar
        ));
        if fr.gap <= bar {
            kept.push((fr.gap, k, effects, fr.model));
        }
    }
    kept.sort_by(|a, b| a.0.total_cmp(&b.0));
    kept.truncate(keep.most);
    let (g_named, n_named) = per_recording(target, &z);
    kept.into_iter()
        .map(|(_, k, effects, model)| {
            let opts = FitOptions {
                max_iter: 6,
                final_jacobian: false,
                ..FitOptions::default()
            };
            let fr = fit::fit(target, &model, &effects, opts);
            let (g, n) = per_recording(target, &fr.z);
            let extra = fit::effect_params(&[k], &fr.model.effects) as f64;
            let ev = evidence(&g, &n, &g_named, &n_named, extra);
            let beside_base = named.effects.is_empty();
            Rival {
                name: if beside_base {
                    k.name().to_string()
                } else {
                    format!("{}+{}", named.name, k.name())
                },
                role: if beside_base {
                    "one of the best three of an unexplained gap, fitted by the plan (in-sample \
                     evidence: the diagnosis's screen fell short)"
                } else {
                    "a second effect beside the named one, fitted by the plan (in-sample \
                     evidence: the diagnosis tried none)"
                }
                .into(),
                model: fr.model,
                effects,
                ln_odds: named.ln_odds + ev.ln_odds,
                clear: false,
            }
        })
        .collect()
}
