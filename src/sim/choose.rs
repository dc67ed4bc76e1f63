//! The tier policy: which model serves a run with vibration, and why. One place decides;
//! [`crate::sim`]'s run policy calls it, sweeps ask it whether a point needs a table.

use crate::averaged::store::TableStore;
use crate::averaged::table::Table;
use crate::model::Params;
use crate::sim::tier::{Tier, TierReason};

/// Least ratio of the forcing frequency `f` to the drive oscillator's `√(k_d/m)/2π` for
/// [`Tier::Auto`] to average: the averaged law freezes the drive force over a period, which
/// then moves by at most `2π · 1/20` of its oscillation's phase. The study of the averaged
/// law (`../shared/research/AVERAGING.md`) covers ratios of 20 to 600.
pub const SEPARATION: f64 = 20.0;

/// Least `v_a/v_d` for [`Tier::Auto`] to average. Below it the vibration hardly shrinks the
/// stick-slip, and at breakaway the body accelerates through the law's rise (`0 ≤ V ≲ v_a`)
/// within a fraction of a forcing period, where the period-mean law does not hold: on a
/// 1024-point slice of `sweeps/overnight.toml` the averaged points at `v_a/v_d` 0.03 (2000 Hz,
/// `u0` = 5 nm, `v_d` = 2 mm/s) gave `r` 0.023 above the full model's, while those from 0.05 on
/// stayed within 0.0033. The study of the averaged law covered 0.1 to 4.
pub const MIN_VA_RATIO: f64 = 0.1;

/// Whether [`choose`] looks up the table of `p` for a run asked for with `tier` (with model
/// extensions on where `!none`): the rules that need no table hold.
pub fn needs_table(p: &Params, none: bool, tier: Tier) -> bool {
    prechecks(p, none, tier).is_none()
}

/// The tier and reason where a rule that needs no table decides; `None` where the table must.
pub(crate) fn prechecks(p: &Params, none: bool, tier: Tier) -> Option<TierReason> {
    if tier == Tier::Full {
        return Some(TierReason::Asked);
    }
    if !p.vibrates() {
        return Some(TierReason::NoVibration);
    }
    if p.two_stage() {
        return Some(TierReason::TwoStage);
    }
    if !none {
        return Some(TierReason::Effects);
    }
    let f_drive = (p.k_d / p.m).sqrt() / (2.0 * std::f64::consts::PI);
    if tier == Tier::Auto && p.f < SEPARATION * f_drive {
        return Some(TierReason::Separation);
    }
    if tier == Tier::Auto && p.f < contact_resonance(p) {
        return Some(TierReason::BelowResonance);
    }
    if tier == Tier::Auto && p.v_a() < MIN_VA_RATIO * p.v_d {
        return Some(TierReason::SmallAmplitude);
    }
    None
}

/// Share of `v_d` about it within which no zone of the law may lie (no mean velocity whose
/// fast orbit does not contract, [`Table::valid_at`]) for [`Tier::Auto`] to average or to use
/// hybrid windows ([`TierReason::NearZone`]). A body that accelerates from rest through a zone
/// can stay on the attractor it found there (a period-doubled or chaotic fast motion) past the
/// zone's edge, where the period-1 orbit the law holds contracts again: on the overnight grid's
/// even sixteenth at 2639 Hz, `u0` = 12.6 nm, `v_d` = 0.149 mm/s (a zone up to 13 % below
/// `v_d`, the orbit at `v_d` contracting with multiplier 0.87) the full model, every period
/// integrated, slides at 4.79 N and the averaged law gives 8.60 N; at 2000 Hz, `u0` = 12.6 nm,
/// `v_d` = 0.149 mm/s, `k_d` = 10 986 N/m (`v_d` inside a zone) hybrid windows gave `r` = 0.50
/// for 0. 25 % is about twice the farthest such reach seen there.
pub const ZONE_MARGIN: f64 = 0.25;

/// The contact resonance `√(k_t/m)/2π` \[Hz\] (1649 Hz on the defaults). Below it the fast
/// orbit of body and contact period-doubles and turns chaotic in zones of the mean velocity
/// that a table's nodes can straddle unseen, and attractors other than the period-1 orbit
/// coexist with it: on a 1024-point slice of `sweeps/overnight.toml` the full model settled at
/// 500 Hz, `u0` = 0.5 µm, `v_d` = 0.1 mm/s to a mean force of 4.17 N where the averaged law
/// (its orbits contracting at every node) gave 5.27 N, while every averaged point at 2000 and
/// 4000 Hz kept `r` within 0.0073 and the mean force within 1.3 %. [`Tier::Auto`] therefore
/// averages above it only; [`Tier::Averaged`] averages below it too.
pub fn contact_resonance(p: &Params) -> f64 {
    (p.k_t / p.m).sqrt() / (2.0 * std::f64::consts::PI)
}

/// The tier that serves a run of `p` (with `effects` on, `none` where there are none) asked
/// for with `tier`, why, and the law where it is the averaged one. [`Tier::Auto`] averages where
/// the run vibrates from the start without model extensions, `f ≥` [`SEPARATION`] times the
/// drive oscillator's frequency and above the contact resonance ([`contact_resonance`]), and
/// the law was found from rest on; [`Tier::Averaged`] drops
/// the separation rule. Under auto the law must also hold within [`ZONE_MARGIN`] of `v_d`
/// ([`TierReason::NearZone`]). The run itself then checks that its steady window stays where the law
/// may serve ([`SlowRun::left_law`](crate::sim::slow::SlowRun::left_law)), and hands over to the full model where it does not
/// ([`TierReason::LeftLaw`]).
pub fn choose(
    p: &Params,
    none: bool,
    tier: Tier,
    store: &TableStore,
) -> (Tier, TierReason, Option<std::sync::Arc<Table>>) {
    let full = |r| (Tier::Full, r, None);
    if let Some(why) = prechecks(p, none, tier) {
        return full(why);
    }
    match store.table(p) {
        Ok(t) if t.nodes.len() >= 2 => {
            let m = ZONE_MARGIN * p.v_d;
            if tier == Tier::Auto && t.first_invalid(p.v_d - m, p.v_d + m).is_some() {
                return full(TierReason::NearZone);
            }
            let (tier, why) = match tier {
                Tier::Auto => (Tier::Averaged, TierReason::Valid),
                Tier::Hybrid => (Tier::Hybrid, TierReason::AskedHybrid),
                _ => (Tier::Averaged, TierReason::AskedAveraged),
            };
            (tier, why, Some(t))
        }
        _ => full(TierReason::NoLaw),
    }
}

#[cfg(test)]
mod tests {
    use crate::model::Params;
    use crate::sim::choose::prechecks;
    use crate::sim::tier::{Tier, TierReason};

    #[test]
    fn auto_leaves_small_amplitudes_to_the_full_model() {
        let mut p = Params {
            f: 3000.0,
            v_d: 5e-4,
            ..Params::default()
        };
        for (ratio, want) in [(0.05, Some(TierReason::SmallAmplitude)), (0.2, None)] {
            p.set_v_a(ratio * p.v_d);
            assert_eq!(prechecks(&p, true, Tier::Auto), want, "v_a/v_d = {ratio}");
            // Asked for, the averaged tier is tried whatever the amplitude.
            assert_eq!(prechecks(&p, true, Tier::Averaged), None);
        }
    }
}
