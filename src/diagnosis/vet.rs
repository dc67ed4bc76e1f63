//! The checks a candidate the decision would name or tie must pass beyond its evidence
//! (`vetted`): its fingerprints in the traces and each feature family held out of its fit
//! ([`held_out_families`]).

use super::decide::{Side, decide};
use super::features::Feature;
use super::fingerprint;
use super::fit::{self, FitResult, Target};
use super::folds::*;
use super::verdict::*;

/// What candidates are vetted against: the model they extend (`from`), its side of the
/// decision, the share of its gap a candidate removes (as a function of the candidate's gap)
/// with the least share that names it, and whether a candidate's fingerprint must be present
/// (a second effect beside a named one).
pub(crate) struct Against<'a, F: Fn(f64) -> f64> {
    pub from: &'a FitResult,
    pub side: Side<'a>,
    pub share: F,
    pub min_share: f64,
    pub need_present: bool,
}

/// [`decide`] (with its disagreements between evidence and gap in `disagreements`), with
/// every candidate it would name or tie checked for its fingerprints against
/// `against.from`, the model the candidates extend ([`fingerprint::check`]): one whose ringing is
/// absent is rejected (with the reason) and the decision taken again without it. With
/// `need_present` (a second effect beside a named one) a candidate whose ringing can test it is
/// rejected too unless it is present ([`fingerprint::Check::decisive`]): beside a first effect whose form differs
/// from the data's, any other candidate can take up the rest of that form's misfit, so only one
/// that shows its own physics in the trace is named (one that predicts nothing the ringing could
/// show, a screw error's, stands on its features as a first effect does). The ranking is then
/// reordered so that the candidates not rejected come first, in their order of evidence.
pub(crate) fn vetted<F: Fn(f64) -> f64>(
    ranked: &mut [Ranked],
    all: &Target,
    against: Against<'_, F>,
    disagreements: &mut Vec<Disagreement>,
) -> Option<Vec<usize>> {
    let Against {
        from,
        side: from_side,
        share,
        min_share,
        need_present,
    } = against;
    let recs = &all.recs;
    let names: Vec<String> = recs.iter().map(|r| r.name.clone()).collect();
    // The measured statistics and `from`'s, made once for every candidate checked here.
    let mut reference: Option<fingerprint::Reference> = None;
    let out = loop {
        let (t, found) = decide(ranked, from_side, &names, &share, min_share);
        // The disagreements of the last decision (candidates rejected since take no part).
        *disagreements = found;
        let Some(t) = t else {
            break None;
        };
        let mut any = false;
        for &j in &t {
            if ranked[j].fingerprints.is_empty() {
                let r =
                    reference.get_or_insert_with(|| fingerprint::Reference::of(recs, &from.model));
                let mut checks = r.check(recs, &ranked[j].fit.model);
                checks.extend(held_out_families(all, from, &ranked[j].fit));
                ranked[j].fingerprints = checks;
            }
            if let Some(c) = ranked[j]
                .fingerprints
                .iter()
                .find(|c| c.decisive() && c.seen == fingerprint::Seen::Absent)
            {
                ranked[j].rejected = Some(format!("its fingerprint is absent: {}", c.line()));
                any = true;
            } else if need_present
                && ranked[j]
                    .fingerprints
                    .iter()
                    .any(|c| c.decisive() && c.seen != fingerprint::Seen::NotTestable)
                && !ranked[j]
                    .fingerprints
                    .iter()
                    .any(|c| c.decisive() && c.seen == fingerprint::Seen::Present)
            {
                let seen: Vec<String> = ranked[j]
                    .fingerprints
                    .iter()
                    .filter(|c| c.decisive())
                    .map(|c| c.line())
                    .collect();
                ranked[j].rejected = Some(format!(
                    "a second effect needs a fingerprint present, none is: {}",
                    if seen.is_empty() {
                        "none checked".to_string()
                    } else {
                        seen.join("; ")
                    }
                ));
                any = true;
            }
        }
        if !any {
            break Some(t);
        }
    };
    // Stable: the live candidates first, the named (or tied) ones at the head, the rejected
    // last (also where none is named: the ranking's head is the best candidate not rejected).
    let named: Vec<String> = out
        .iter()
        .flatten()
        .map(|&j| ranked[j].name.clone())
        .collect();
    ranked.sort_by_key(|r| (r.rejected.is_some(), !named.contains(&r.name)));
    let mut order: Vec<usize> = named
        .iter()
        .map(|n| ranked.iter().position(|r| r.name == *n).unwrap())
        .collect();
    order.sort_unstable();
    out.map(|_| order)
}

/// The feature families a named candidate is judged on held out: `(family, what it holds)`,
/// each the features of some phases of [`PHASES`](super::features::PHASES) ([`family_of`]).
pub const FAMILIES: [(&str, &str); 3] = [
    (
        "held_out_cycle",
        "the stick-slip cycle's features (stick slope, period, peak, rounding, dF, slip time, trough, re-stick ripple) predicted by fits without them",
    ),
    (
        "held_out_level",
        "the whole-cycle features (mean force, drive ripple, r) predicted by fits without them",
    ),
    (
        "held_out_forcing",
        "the harmonics at f and 2f (force, body displacement) predicted by fits without them",
    ),
];

/// The family of [`FAMILIES`] a feature belongs to: the cycle's phases (loading to re-stick),
/// the whole cycle, the forcing frequency.
pub fn family_of(f: Feature) -> usize {
    match f.phase() {
        0..=3 => 0,
        4 => 1,
        _ => 2,
    }
}

/// The held-out feature families of candidate `cand` against the model `from` it extends
/// (both fitted on every recording of `all`): per family of [`FAMILIES`], the candidate's own
/// parameters are refitted without that family's rows (`refit_without`; the parameters it
/// shares with `from` held at its fit's values) and judged on those rows as the trace
/// fingerprints are ([`fingerprint`]'s rule), with `d_obs = −z_from` and
/// `d_pred = z_cand − z_from` per held-out row (`z` in standard errors): the share of the
/// departure from `from` that the candidate, its effect set by the other families, predicts
/// there and the data carry. Absent: the other families put the effect where it does not
/// explain this one, which names a stand-in, not the effect (a slow sensor that smooths the
/// cycles, pulled back by the harmonics it would damp). The base parameters are held because
/// refitting them without a family that alone pins one (the mean force pins `F_c`) moves
/// both models apart in ways that say nothing of the effect. The refit keeps parameters that
/// only the held-out family determines where the full fit put them (the step's damping), so a
/// family can be present because it set them: a second effect is not named on a held-out
/// family alone (`vetted`). A family the full fits tell apart by less than
/// [`fingerprint::MIN_STRENGTH`] is not testable, and not refitted. Rows of failed runs
/// (|z| of 1000) are left out.
pub fn held_out_families(
    all: &Target,
    from: &FitResult,
    cand: &FitResult,
) -> Vec<fingerprint::Check> {
    let fam: Vec<usize> = all.row_features().into_iter().map(family_of).collect();
    let n = fam.len();
    if from.z.len() != n || cand.z.len() != n {
        return vec![];
    }
    // The candidate's own coordinates: those beyond the ones of the model it extends.
    let first_free = fit::BASE_FITTED.len() + from.effect_params;
    let pairs = |zc: &[f64], k: usize| -> Vec<(f64, f64)> {
        (0..n)
            .filter(|&i| fam[i] == k && from.z[i].abs() < 1e3 && zc[i].abs() < 1e3)
            .map(|i| (-from.z[i], zc[i] - from.z[i]))
            .collect()
    };
    let mut out = vec![];
    for (k, &(family, what)) in FAMILIES.iter().enumerate() {
        if fam.iter().all(|&f| f == k) || !fam.contains(&k) {
            continue;
        }
        let full = pairs(&cand.z, k);
        if full.iter().map(|p| p.1 * p.1).sum::<f64>().sqrt() < fingerprint::MIN_STRENGTH {
            out.push(fingerprint::judge(family, what, &full));
            continue;
        }
        let keep: Vec<bool> = fam.iter().map(|&f| f != k).collect();
        let zc = refit_without(all, cand, &cand.model, &keep, first_free);
        out.push(fingerprint::judge(family, what, &pairs(&zc, k)));
    }
    out
}

/// The warning for a named effect with a weaker fingerprint absent (a held-out feature family,
/// [`held_out_families`], or a trace family read slip by slip): the effect is then named only
/// as partial. Not a veto, as an absent ringing is ([`fingerprint::Check::decisive`]): the
/// held-out refit is one damped step and holds the base parameters, so a family can also be
/// absent where the effect is right but its fit trades that family for the others (a resonance
/// fitted off its true value); a slip-by-slip statistic is a slope or a coefficient per stage
/// over a few stages, and an effect of the library's kind in another form (the second rig's
/// delayed load path) can move it the other way; either way the fit does not explain the whole
/// campaign.
pub(crate) fn held_out_absent(r: &Ranked) -> Option<String> {
    let absent: Vec<String> = r
        .fingerprints
        .iter()
        .filter(|c| !c.decisive() && c.seen == fingerprint::Seen::Absent)
        .map(|c| c.line())
        .collect();
    (!absent.is_empty()).then(|| {
        format!(
            "{}: named only as partial, as a fingerprint it predicts (a feature family held out from its fit, or a statistic of the trace read slip by slip) is not in the data ({}): it stands in for another physics there, its form differs from the rig's, or its fit has not found the rig's values",
            r.effect.name(),
            absent.join("; ")
        )
    })
}
