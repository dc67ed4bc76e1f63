//! A run's time: the simulated time, the steady window, the sampling and the work budget,
//! shared by every tier.

use crate::model::Params;
use crate::sim::options::{
    EARLY_STOP_EARLIEST, EARLY_STOP_FIRST, EARLY_STOP_SETTLED, PERIODS_MAX, RunOptions, T_END_MAX,
};
use crate::sim::result::SimError;
use std::cmp::Ordering;

/// Simulated time chosen for a run \[s\]: long enough that the second half (the steady window)
/// holds `min_cycles` stick-slip cycles of the run without vibration plus a spare 1.5, and that
/// the first loading of the spring from rest (`F_s / (k_d v_d)`) and one more cycle lie before it:
///
/// ```text
/// T = 2 · max( (n + 1.5) T_c,  F_s/(k_d v_d) + 2 T_c,  20 π √(m/k_d) ),   T_c = 2 (F_s − F_c)/(k_d v_d)
/// ```
///
/// It depends on `v_d`, `k_d`, `F_s`, `F_c` and `m` only, so a run and its reference without
/// vibration share it.
pub fn simulated_time(p: &Params, min_cycles: u32) -> f64 {
    let tc = p.cycle_estimate();
    let t_load = first_loading(p);
    let a = (min_cycles as f64 + 1.5) * tc;
    let b = t_load + 2.0 * tc;
    let c = 20.0 * p.slip_duration();
    2.0 * a.max(b).max(c)
}

/// Simulated time of a run chosen automatically \[s\]: [`simulated_time`], after the first
/// stage of a two-stage run (`t_on > 0`, docs/model.md), so that the steady window, the second half
/// of the second stage, holds as many cycles as a run vibrated from the start.
pub fn planned_time(p: &Params, min_cycles: u32) -> f64 {
    let stage = simulated_time(p, min_cycles);
    if p.two_stage() { p.t_on + stage } else { stage }
}

/// Start of the steady window of a run ending at `t_end` \[s\]: the second half of the run, or
/// of its second stage where the vibration is switched on at `t_on > 0` (docs/model.md).
pub fn window_start(p: &Params, t_end: f64) -> f64 {
    if p.two_stage() && p.t_on < t_end {
        p.t_on + 0.5 * (t_end - p.t_on)
    } else {
        0.5 * t_end
    }
}

/// The first early-stop check \[s\] of a run planned for `t_plan` with blocks `block` wide:
/// [`EARLY_STOP_FIRST`] of `t_plan`, or sooner where vibration well above the drive velocity
/// (`v_a > 2 v_d`) makes the friction viscous-like and the drive force settles fast. Averaged
/// over the vibration phase, Coulomb friction at a body velocity `v` near `v_d` is
/// `(2 F_c / π) asin(v / v_a)`, whose slope `2 F_c / (π √(v_a² − v_d²))` against the drive
/// spring `k_d` gives the settling time `τ`; the first check waits [`EARLY_STOP_SETTLED`] `τ`
/// (the window, the run's second half, then spans five), a window of 16 blocks, and
/// [`EARLY_STOP_EARLIEST`] of `t_plan`.
pub(crate) fn first_check(p: &Params, t_plan: f64, block: f64) -> f64 {
    let late = EARLY_STOP_FIRST * t_plan;
    let (v_a, v_d) = (p.v_a(), p.v_d);
    if v_a <= 2.0 * v_d {
        return late;
    }
    let tau = 2.0 * p.f_c / (std::f64::consts::PI * p.k_d * (v_a * v_a - v_d * v_d).sqrt());
    (EARLY_STOP_SETTLED * tau)
        .max(32.0 * block)
        .max(EARLY_STOP_EARLIEST * t_plan)
        .min(late)
}

/// Time for the drive to load the spring from rest to `F_s` \[s\]: `F_s / (k_d v_d)`.
pub(crate) fn first_loading(p: &Params) -> f64 {
    p.f_s / (p.k_d * p.v_d)
}

/// The sampling of a run: spacing \[s\] and samples per vibration period (1 without vibration).
pub fn sampling(p: &Params, samples_per_period: usize) -> (f64, usize) {
    // Fine enough for the slip (40 samples per slip: a trough error below 0.05 % of dF) and for
    // the cycle (2000 per cycle).
    let dt0 = (p.cycle_estimate() / 2000.0).min(p.slip_duration() / 40.0);
    if !p.vibrates() {
        return (dt0, 1);
    }
    let k = samples_per_period.max((1.0 / (p.f * dt0)).ceil() as usize);
    (1.0 / (k as f64 * p.f), k)
}

/// The simulated time of a run: the given `t_end`, or [`planned_time`]. A two-stage run must
/// reach its second stage, and every run must keep within the work budget: at most
/// [`T_END_MAX`] of simulated time, chosen automatically or given, and at most
/// [`PERIODS_MAX`] forcing periods. Every route to a run (`run`, case files, sweep points,
/// refinements, campaigns) checks it here, before anything runs.
pub fn end_time(p: &Params, opts: &RunOptions) -> Result<f64, SimError> {
    let t_end = match opts.t_end {
        Some(t) => t,
        None => {
            let t = planned_time(p, opts.min_cycles);
            if !matches!(
                t.partial_cmp(&T_END_MAX),
                Some(Ordering::Less | Ordering::Equal)
            ) {
                return Err(SimError::Budget(format!(
                    "the automatic simulated time is {t:.3e} s ({} stick-slip cycles of \
                     2 (F_s - F_c)/(k_d v_d) = {:.3e} s at k_d = {} N/m, v_d = {} m/s), over the \
                     budget of {T_END_MAX:.0e} s; raise k_d or v_d, or give a shorter t_end",
                    opts.min_cycles,
                    p.cycle_estimate(),
                    p.k_d,
                    p.v_d
                )));
            }
            t
        }
    };
    if p.two_stage() && p.t_on.partial_cmp(&t_end) != Some(Ordering::Less) {
        return Err(SimError::SwitchOnAfterEnd {
            t_on: p.t_on,
            t_end,
        });
    }
    if p.vibrates() {
        let vibrated = t_end - if p.two_stage() { p.t_on } else { 0.0 };
        let periods = p.f * vibrated;
        if !matches!(
            periods.partial_cmp(&PERIODS_MAX),
            Some(Ordering::Less | Ordering::Equal)
        ) {
            return Err(SimError::Budget(format!(
                "{periods:.3e} forcing periods (f = {} Hz over {vibrated:.3e} s of vibration) \
                 are over the budget of {PERIODS_MAX:.0e} periods; lower f or t_end",
                p.f
            )));
        }
    }
    Ok(t_end)
}
