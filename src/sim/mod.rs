//! One simulated test: the run policy. It decides the tier that serves a run
//! ([`choose`]), hands the run to the full integration ([`full`]), the averaged slow model
//! ([`slow`]) or hybrid windows ([`hybrid`]), siblings that never import this policy, and
//! computes the reduction coefficient `r` against the automatic run without vibration. What the
//! tiers share (the options, the run's time and sampling, traces, results) sits below them all.

pub mod batch;
pub mod choose;
pub mod full;
pub mod hybrid;
pub mod options;
pub mod result;
pub mod slow;
pub mod tier;
pub mod trace;
pub mod window;

pub use self::full::*;
pub use self::options::*;
pub use self::result::*;
pub use self::tier::{Tier, TierReason};
pub use self::trace::Trace;
pub use self::window::*;

use crate::averaged::orbit::AveragingError;
use crate::averaged::store::TableStore;
use crate::averaged::table::Table;
use crate::measures::Measures;
use crate::model::{Effects, Params, Rig};
use crate::ode::Solver;
use std::time::Instant;

/// Simulates the rig once (no reference run) with the given solver; the run owns the table of
/// the averaged law it may build.
pub fn simulate(p: &Params, opts: &RunOptions, solver: &mut Solver) -> Result<RunResult, SimError> {
    simulate_with(p, &Effects::none(), opts, solver)
}

/// [`simulate`] with model extensions.
pub fn simulate_with(
    p: &Params,
    fx: &Effects,
    opts: &RunOptions,
    solver: &mut Solver,
) -> Result<RunResult, SimError> {
    simulate_in(p, fx, opts, solver, &TableStore::new())
}

/// [`simulate_with`] taking the averaged law's tables from `store` (and leaving there the one it
/// builds): the runs handed one store share its tables.
pub fn simulate_in(
    p: &Params,
    fx: &Effects,
    opts: &RunOptions,
    solver: &mut Solver,
    store: &TableStore,
) -> Result<RunResult, SimError> {
    opts.validate()?;
    let rig = Rig::with_effects(*p, fx)?;
    let t_end = end_time(p, opts)?;
    Ok(serve(&rig, fx.is_empty(), t_end, opts, solver, store))
}

/// A run of `rig` (without model extensions where `none`) to `t_end`, served by the tier
/// [`choose::choose`] picks for `opts.tier` (its tables from `store`): the full integration
/// ([`full::integrate_full`]), the averaged slow model ([`slow::simulate_slow_with`]) or hybrid
/// windows ([`hybrid`]), with the tier and its reason recorded. Where an averaged run's
/// window leaves the law, `auto` goes on with hybrid windows and `averaged` with the full model
/// (both with the full model where the slow model diverged);
/// where a hybrid run finds the law's continuation stopped short (`partial_law`) or its slow
/// model diverges (`left_law`), the full model serves.
fn serve(
    rig: &Rig,
    none: bool,
    t_end: f64,
    opts: &RunOptions,
    solver: &mut Solver,
    store: &TableStore,
) -> RunResult {
    let clock = Instant::now();
    let (tier, tier_reason, table) = choose::choose(&rig.p, none, opts.tier, store);
    let full =
        |solver: &mut Solver, why| (integrate_full(rig, t_end, opts, solver), Tier::Full, why);
    let hybrid = |solver: &mut Solver, t, why| match hybrid_run(rig, t, t_end, opts, solver) {
        Ok(r) => (r, Tier::Hybrid, why),
        Err(AveragingError::Diverged(_)) => full(solver, TierReason::LeftLaw),
        Err(_) => full(solver, TierReason::PartialLaw),
    };
    // The full model serves where no law was handed over; the time of a try that failed
    // counts too.
    let (mut r, tier, tier_reason) = match (tier, table) {
        (_, None) => full(solver, tier_reason),
        (Tier::Hybrid, Some(t)) => hybrid(solver, &t, tier_reason),
        (_, Some(t)) => match averaged_run(&rig.p, &t, t_end, opts) {
            Ok(r) => (r, tier, tier_reason),
            // Where the slow model diverged (an infinite velocity), hybrid windows would hand
            // back to it: the full model serves.
            Err(v) if opts.tier == Tier::Auto && v.is_finite() => {
                hybrid(solver, &t, TierReason::Zones)
            }
            Err(_) => full(solver, TierReason::LeftLaw),
        },
    };
    r.tier = tier;
    r.tier_reason = tier_reason;
    r.wall_time = clock.elapsed().as_secs_f64();
    r
}

/// Sampling of the averaged slow model \[s\]: as a run without vibration samples (its force
/// carries no ripple either: 40 samples per slip, 2000 per cycle, [`sampling`]), never finer than
/// one forcing period (the slow model holds nothing within one). Against sampling every period,
/// dF and the mean force move by at most 1.1e-4 (relative) on six cases from 2000 to 4000 Hz,
/// `k_d` 1000 to 40 000 N/m, at up to 8 times fewer samples.
fn slow_dt(p: &Params) -> f64 {
    sampling(&p.without_vibration(), 1).0.max(1.0 / p.f)
}

/// Relative tolerance of the averaged slow model's integration: a tenth of the run's `rtol`,
/// within 1e-10 to 1e-6. At the default's 1e-7, dF and the mean force lie within 3e-5 N of
/// those at 1e-10 on five cases from 2000 to 4000 Hz, `k_d` 1000 to 40 000 N/m (the table's own
/// error is 1e-3 N), at 0.7 of the steps of 1e-8.
fn slow_rtol(opts: &RunOptions) -> f64 {
    (opts.ode.rtol * 1e-1).clamp(1e-10, 1e-6)
}

/// A run of the averaged slow model over the full run's simulated time `t_end`, the drive
/// force sampled as [`slow_dt`] says (no ripple: it stands for a full run's force smoothed over one period); `Err`
/// with the mean velocity where its steady window left the law
/// ([`slow::SlowRun::left_law`]).
fn averaged_run(
    p: &Params,
    table: &Table,
    t_end: f64,
    opts: &RunOptions,
) -> Result<RunResult, f64> {
    let trace = opts.trace.then_some(opts.trace_points);
    let slow = slow::simulate_slow_with(
        p,
        table,
        t_end,
        slow_dt(p),
        slow_rtol(opts),
        trace,
        opts.periodic,
    )
    .map_err(|_| 0.0)?;
    if let Some(v) = slow.left_law {
        return Err(v);
    }
    Ok(RunResult {
        status: slow.status,
        stats: slow.stats,
        measures: slow.measures,
        t_end,
        window_start: window_start(p, t_end),
        // Set by serve, the table's share of it included.
        wall_time: 0.0,
        continued_from: slow.continued_from,
        level_error: None,
        tier: Tier::Averaged,
        tier_reason: TierReason::Valid,
        trace: slow.trace,
    })
}

/// A hybrid run ([`hybrid`]) over the full run's simulated time `t_end`: the slow model at
/// [`slow_rtol`], the full windows with `solver` at the run's options and sampling.
fn hybrid_run(
    rig: &Rig,
    table: &Table,
    t_end: f64,
    opts: &RunOptions,
    solver: &mut Solver,
) -> Result<RunResult, AveragingError> {
    let (_, k) = sampling(&rig.p, opts.samples_per_period);
    let envelope = opts.envelope.map(|tol| envelope_for(&rig.p, k, tol));
    let trace = opts.trace.then_some(opts.trace_points);
    let ho = hybrid::HybridOptions {
        slow_rtol: slow_rtol(opts),
        ode: &opts.ode,
        samples_per_period: k,
        envelope: envelope.as_ref(),
        trace,
    };
    let h = hybrid::simulate_hybrid(rig, table, t_end, &ho, solver)?;
    Ok(RunResult {
        status: h.status,
        stats: h.stats,
        measures: h.measures,
        t_end,
        window_start: window_start(&rig.p, t_end),
        wall_time: 0.0,
        continued_from: None,
        level_error: None,
        tier: Tier::Hybrid,
        tier_reason: TierReason::AskedHybrid,
        trace: h.trace,
    })
}

/// Reduction coefficient and its standard error from a run and its reference (NaN where a
/// vibrated run's window holds a single cycle: [`Measures::varying_cycles`]).
pub fn reduction(run: &Measures, reference: &Measures) -> (f64, f64) {
    let r = run.d_f / reference.d_f;
    let rel = ((run.d_f_stderr / run.d_f).powi(2) + (reference.d_f_stderr / reference.d_f).powi(2))
        .sqrt();
    let se = if run.d_f > 0.0 {
        r * rel
    } else {
        r * reference.d_f_stderr / reference.d_f
    };
    (r, se)
}

/// Runs a case: the run with vibration and, when `u0 > 0`, its reference without vibration over
/// the same simulated time; computes `r`.
pub fn run_case(
    p: &Params,
    opts: &RunOptions,
    solver: &mut Solver,
) -> Result<CaseResult, SimError> {
    run_case_with(p, &Effects::none(), opts, solver)
}

/// [`run_case`] with model extensions (the reference run carries the same effects); the case
/// owns the table of the averaged law it may build.
pub fn run_case_with(
    p: &Params,
    fx: &Effects,
    opts: &RunOptions,
    solver: &mut Solver,
) -> Result<CaseResult, SimError> {
    run_case_in(p, fx, opts, solver, &TableStore::new())
}

/// [`run_case_with`] taking the averaged law's tables from `store` (and leaving there the one it
/// builds).
pub fn run_case_in(
    p: &Params,
    fx: &Effects,
    opts: &RunOptions,
    solver: &mut Solver,
    store: &TableStore,
) -> Result<CaseResult, SimError> {
    opts.validate()?;
    let rig = Rig::with_effects(*p, fx)?;
    let t_end = end_time(p, opts)?;
    let run = serve(&rig, fx.is_empty(), t_end, opts, solver, store);
    if !p.vibrates() {
        // Without vibration the run is its own reference: r = 1 by definition.
        return Ok(CaseResult {
            params: *p,
            run,
            reference: None,
            r: 1.0,
            r_stderr: 0.0,
        });
    }
    let ref_opts = RunOptions {
        trace: false,
        ..opts.clone()
    };
    let reference = serve(
        &rig.without_vibration(),
        fx.is_empty(),
        t_end,
        &ref_opts,
        solver,
        store,
    );
    let (r, r_stderr) = reduction(&run.measures, &reference.measures);
    Ok(CaseResult {
        params: *p,
        run,
        reference: Some(reference),
        r,
        r_stderr,
    })
}
