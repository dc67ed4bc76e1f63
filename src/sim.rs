//! One simulated test: the run policy (simulated time, sampling), the integration, the measures,
//! and the reduction coefficient `r` against the automatic run without vibration.

use crate::averaged::{Tier, TierReason};
use crate::cycle::LimitCycle;
use crate::measures::{Analyzer, DROP_THRESHOLD, Measures, STICK_VELOCITY, Trend};
use crate::model::{Effects, Params, Rig, RigError, V, X};
use crate::ode::{
    Envelope, Method, OdeSystem, OptionError, Options, OutputGrid, Solver, Stats, Status,
};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// How a run is made. Every field documents its unit, default and range;
/// [`RunOptions::validate`] quotes the violated bound.
#[derive(Clone, Debug, PartialEq)]
pub struct RunOptions {
    /// Integration method. Default [`Method::Auto`] (Dopri5 that hands the stretches where
    /// stiffness, not accuracy, limits its step to Radau5): with envelope following it is the
    /// fastest setting of `stickslip bench` that meets docs/model.md's accuracy on its cases
    /// ([`DEFAULT_ENVELOPE`]).
    pub method: Method,
    /// Integrator options (tolerances, step limits). Default `rtol = 1e-6`, `atol = 1e-6`
    /// (in units of each state's characteristic size, see `Rig::scale`).
    pub ode: Options,
    /// Stick-slip cycles (of the run without vibration) the steady window must hold.
    /// Default 3. Range 1 to 1000.
    pub min_cycles: u32,
    /// Simulated time \[s\]; `None` (default) chooses it from the run (see [`planned_time`]).
    /// Range: > 0 and at most [`T_END_MAX`], and past `t_on` in a two-stage run.
    pub t_end: Option<f64>,
    /// Samples per vibration period for the smoothing (more when the stick-slip needs a finer
    /// grid). Default 16. Range 4 to 4096.
    pub samples_per_period: usize,
    /// Keep the time traces (for `run`, plots and chosen sweep points). Default false.
    pub trace: bool,
    /// Most trace points kept; longer runs are decimated evenly. Default 400 000. Range ≥ 100.
    pub trace_points: usize,
    /// End a run with vibration early once its answer is known: once steady sliding is
    /// established (see [`EARLY_STOP_RANGE`]), or once the steady window of the run so far holds
    /// `min_cycles` stick-slip cycles of the run without vibration and gives dF to
    /// [`EARLY_STOP_STDERR`]. Default [`EarlyStop::Automatic`]. A two-stage run (`t_on > 0`)
    /// always runs its whole time.
    pub early_stop: EarlyStop,
    /// Without vibration (base model): once two successive slips pass the same state, with a
    /// stick between them, read the rest of the samples off that limit cycle instead of
    /// integrating them (see [`cycle`](crate::cycle); `RunResult::continued_from` says from
    /// when). The measures are those of the integrated run to 1e-4 of dF (4e-5 on the paper's
    /// ranges; the re-stick is a kink between samples). The averaged slow model
    /// ([`crate::averaged::simulate_slow_with`]) is continued along its limit cycle alike.
    /// Default true.
    pub periodic: bool,
    /// Envelope following for runs with vibration: the extrapolation tolerance of one jump over
    /// whole vibration periods (see [`ode::Envelope`](crate::ode::Envelope)), in units of each
    /// state's characteristic size; `None` integrates every period. Default
    /// [`DEFAULT_ENVELOPE`]. Range 1e-8 to 0.1. A two-stage run (`t_on > 0`) integrates every
    /// period.
    pub envelope: Option<f64>,
    /// Which model serves a run with vibration ([`averaged::choose`](crate::averaged::choose)):
    /// `auto` (default) averages the vibration out where the averaged law is valid and the
    /// forcing fast against the drive, `averaged` wherever the law exists, `full` never. The
    /// result records the tier and why ([`RunResult::tier`]).
    pub tier: Tier,
}

/// When a run with vibration may end before its simulated time ([`RunOptions::early_stop`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EarlyStop {
    /// Always run the whole simulated time.
    Off,
    /// End early only where the simulated time is chosen automatically (`t_end` not given):
    /// a given `t_end` is run in full, so its window is the one asked for.
    #[default]
    Automatic,
    /// End early also where `t_end` is given, which then is the longest simulated time: the
    /// checks and the stick-slip rule are planned on it as on an automatic time.
    Always,
}

/// Longest simulated time a run may be given \[s\]: 1e5 s, over a day of the rig and some
/// 170 times the longest automatic time of the paper's ranges (576 s at v_d = 0.1 mm/s,
/// k_d = 1000 N/m), continued runs included (8 times that).
pub const T_END_MAX: f64 = 1e5;

/// Most forcing periods a run may simulate: 1e7, some minutes of one core at the ~13 µs a
/// period costs (1500 Hz, 0.5 mm/s, 11 700 N/m: 3 738 periods in 50 ms), and four times the
/// most of the paper's ranges (576 s at 4000 Hz).
pub const PERIODS_MAX: f64 = 1e7;

/// Early stop: the smoothed drive force over the second half of the run so far must stay within
/// this share of the nominal stick-slip amplitude `2 (F_s − F_c)` (so `r` below it, a tenth of
/// the elimination threshold) ...
pub const EARLY_STOP_RANGE: f64 = 0.005;
/// ... and the window's mean force must lie within this relative distance of the asymptote
/// extrapolated from its thirds, a fifth of the 0.5 % accuracy of the mean force.
pub const EARLY_STOP_DRIFT: f64 = 0.001;
/// Early stop of a settling sliding run ([`Analyzer::settling`]): two exponential fits must
/// predict the planned window's max − min of the smoothed force to this share of the nominal
/// amplitude `2 (F_s − F_c)` (`r` to about 0.002, a fifth of docs/model.md's 0.01), and the ripple
/// about the exponential must stay below it too.
pub const SETTLING_TOL: f64 = 0.002;
/// ... and the force may change by at most this share of `k_d v_d` per second: the body slides
/// within 5 % of `v_d`, where the friction's relaxation is linear, with one time constant
/// (further from it the approach follows the friction's nonlinear dependence on the velocity,
/// and an exponential through the run so far aims at the wrong level).
pub const SETTLING_SLOPE: f64 = 0.05;
/// Early stop: the first check comes at this share of the planned simulated time (its window,
/// the second half of the run so far, is then 2.5 % of the planned time long, at least 8
/// blocks of one vibration period each) ...
pub const EARLY_STOP_FIRST: f64 = 0.05;
/// ... and the next ones every planned time over this (or, from an earlier first check, a
/// quarter of the time so far apart while that is shorter: [`EARLY_STOP_GROWTH`]).
pub const EARLY_STOP_CHECKS: f64 = 256.0;
/// Early stop where vibration well above the drive velocity (`v_a > 2 v_d`) makes the force
/// settle fast: the first check waits this many settling times
/// `τ = 2 F_c / (π k_d √(v_a² − v_d²))` (vibration-averaged Coulomb friction against the drive
/// spring), if that is sooner than [`EARLY_STOP_FIRST`] ...
pub const EARLY_STOP_SETTLED: f64 = 10.0;
/// ... and at least this share of the planned time (a window of 0.2 % of it) and 32 blocks ...
pub const EARLY_STOP_EARLIEST: f64 = 0.004;
/// ... and the checks after it are this share of the time so far apart, up to the planned time
/// over [`EARLY_STOP_CHECKS`]. Sliding runs whose force settles in milliseconds (large `v_a`,
/// a small mean friction) end at the first checks.
pub const EARLY_STOP_GROWTH: f64 = 0.25;
/// Envelope following in [`simulate`]: the slopes are measured over this many vibration periods
/// ([`Envelope::baseline`](crate::ode::Envelope::baseline)). Averaging over four periods removes
/// most of the integrator's period-to-period noise and of the alternating mode a jump excites
/// while sticking (the bristle relaxation, a stroboscopic eigenvalue near −0.7), which read as
/// curvature and shorten the jumps. At k_d = 11 700 N/m, v_d = 0.5 mm/s, f = 1500 Hz, 6 s,
/// envelope 1e-4: right-hand sides 746 698 → 462 862 with v_a/v_d = 0.4 and 966 436 → 646 878
/// with v_a/v_d = 2 against one-period slopes; on the 16 × 16 Fig. 11 plane the same cost within
/// the machine's noise, with 98.8 % of the points within 0.01 in `r` of the run without jumps
/// (largest difference 0.013) against 93.8 % (0.069).
pub const ENVELOPE_BASELINE: u32 = 4;
/// Early stop with stick-slip: the window `[t/2, t]` must be at least `min_cycles` cycle
/// estimates long, start after the first loading and one more cycle, hold at least `min_cycles`
/// drops, and give their mean with a standard error of at most this share of the nominal
/// amplitude `2 (F_s − F_c)`: a standard error of `r` of about 0.005, docs/model.md's allowance for
/// the convergence of `r` (so `r` within about 0.01 at two standard errors). The window's mean
/// force must also agree with the mean over its whole cycles to [`EARLY_STOP_DRIFT`].
pub const EARLY_STOP_STDERR: f64 = 0.005;

/// The default envelope tolerance. `stickslip bench --methods radau5,dopri5,auto --envelopes
/// none,1e-4 --tolerances 1e-4,1e-5,1e-6,1e-7 --reference-tolerance 1e-10` at rtol = atol = 1e-6
/// against the tight reference: partial reduction (v_a/v_d = 0.4, 1500 Hz) 73 ms with `auto` and
/// this envelope against 200 ms without it and 664 ms with Radau5, |Δr| 0.0029, 0.0041 and
/// 0.0028; eliminated (v_a/v_d = 2) 42, 141 and 418 ms, |Δr| below 1e-5; low frequency
/// (100 Hz, v_a/v_d = 3) 52, 66 and 31 ms, |Δr| 1.1e-4; without vibration 1.4 to 1.5 ms each
/// (the envelope acts only with vibration). Every mean force within 0.1 %.
pub const DEFAULT_ENVELOPE: f64 = 1e-4;

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            method: Method::Auto,
            ode: Options::default(),
            min_cycles: 3,
            t_end: None,
            samples_per_period: 16,
            trace: false,
            trace_points: 400_000,
            early_stop: EarlyStop::Automatic,
            periodic: true,
            envelope: Some(DEFAULT_ENVELOPE),
            tier: Tier::Auto,
        }
    }
}

impl RunOptions {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), OptionError> {
        self.ode.validate()?;
        let bad = |field, value: f64, allowed| {
            Err(OptionError {
                field,
                value,
                allowed,
            })
        };
        if !(1..=1000).contains(&self.min_cycles) {
            return bad(
                "min_cycles",
                self.min_cycles as f64,
                "1 <= min_cycles <= 1000",
            );
        }
        if let Some(t) = self.t_end
            && !(t > 0.0 && t <= T_END_MAX)
        {
            return bad("t_end", t, "0 < t_end <= 1e5 s");
        }
        if !(4..=4096).contains(&self.samples_per_period) {
            return bad(
                "samples_per_period",
                self.samples_per_period as f64,
                "4 <= samples_per_period <= 4096",
            );
        }
        if let Some(tol) = self.envelope
            && !(1e-8..=0.1).contains(&tol)
        {
            return bad("envelope", tol, "1e-8 <= envelope <= 0.1");
        }
        if self.trace_points < 100 {
            return bad(
                "trace_points",
                self.trace_points as f64,
                "trace_points >= 100",
            );
        }
        Ok(())
    }
}

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
fn first_check(p: &Params, t_plan: f64, block: f64) -> f64 {
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
fn first_loading(p: &Params) -> f64 {
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

/// Time traces of a run, in SI units.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trace {
    /// Time \[s\].
    pub t: Vec<f64>,
    /// Drive force `F_d` \[N\].
    pub f_d: Vec<f64>,
    /// Drive force smoothed over one vibration period \[N\] (NaN during the first period).
    pub f_d_smooth: Vec<f64>,
    /// Body displacement `x_s` \[m\].
    pub x_s: Vec<f64>,
    /// Drive displacement `x_d = v_d t` \[m\].
    pub x_d: Vec<f64>,
    /// Contact deformation `s` \[m\].
    pub s: Vec<f64>,
    /// Relative velocity `v_r = v − u'(t)` [m/s].
    pub v_r: Vec<f64>,
    /// Body velocity `v` [m/s].
    pub v: Vec<f64>,
    /// Substrate displacement `u` \[m\].
    pub u: Vec<f64>,
}

impl Trace {
    /// Appends a sample of a model without the fast states (the averaged slow model, a hybrid
    /// run's period samples): the force also as the smoothed one, `s`, `v_r` and `u` NaN.
    pub(crate) fn push_slow(&mut self, t: f64, f: f64, x_s: f64, x_d: f64, v: f64) {
        self.t.push(t);
        self.f_d.push(f);
        self.f_d_smooth.push(f);
        self.x_s.push(x_s);
        self.x_d.push(x_d);
        self.s.push(f64::NAN);
        self.v_r.push(f64::NAN);
        self.v.push(v);
        self.u.push(f64::NAN);
    }

    /// Channel names, units and meanings, in file order.
    pub const CHANNELS: [(&'static str, &'static str, &'static str); 9] = [
        ("t", "s", "time"),
        ("F_d", "N", "drive force"),
        (
            "F_d_smooth",
            "N",
            "drive force, moving average over one vibration period",
        ),
        ("x_s", "m", "body (specimen) displacement"),
        ("x_d", "m", "drive displacement v_d t"),
        ("s", "m", "elastic deformation of the contact"),
        ("v_r", "m/s", "relative velocity of body and substrate"),
        ("v", "m/s", "body velocity"),
        ("u", "m", "substrate displacement"),
    ];

    /// The channels in [`Trace::CHANNELS`] order.
    pub fn columns(&self) -> [&[f64]; 9] {
        [
            &self.t,
            &self.f_d,
            &self.f_d_smooth,
            &self.x_s,
            &self.x_d,
            &self.s,
            &self.v_r,
            &self.v,
            &self.u,
        ]
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the trace is empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Keeps every second sample (the first, third, ...) of every channel.
    fn halve(&mut self) {
        for c in [
            &mut self.t,
            &mut self.f_d,
            &mut self.f_d_smooth,
            &mut self.x_s,
            &mut self.x_d,
            &mut self.s,
            &mut self.v_r,
            &mut self.v,
            &mut self.u,
        ] {
            let mut i = 0;
            c.retain(|_| {
                i += 1;
                i % 2 == 1
            });
        }
    }
}

/// The outcome of one integration of the rig.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// How the integration ended.
    pub status: Status,
    /// Work done.
    pub stats: Stats,
    /// The measures (NaN where the run failed).
    pub measures: Measures,
    /// Simulated time \[s\].
    pub t_end: f64,
    /// Start of the steady window \[s\].
    pub window_start: f64,
    /// Wall-clock time of the integration and analysis \[s\].
    pub wall_time: f64,
    /// Time from which the samples were read off the run's limit cycle instead of integrated
    /// ([`RunOptions::periodic`]) \[s\]; `None` where every sample was integrated.
    #[serde(default)]
    pub continued_from: Option<f64>,
    /// Error bound of the mean force \[N\] where the measures are those of the settled level,
    /// extrapolated from the force settling along one exponential in the window
    /// `[window_start, t_end]` ([`Analyzer::settling`](crate::measures::Analyzer::settling))
    /// instead of integrated: the larger of the two fits' levels' difference and a share of the
    /// extrapolated distance. `None` where the level was not extrapolated.
    #[serde(default)]
    pub level_error: Option<f64>,
    /// The model that served the run: [`Tier::Full`] (every period integrated) or
    /// [`Tier::Averaged`] (the averaged slow model; its statistics are the slow integration's,
    /// the law's table is counted apart).
    #[serde(default = "full_tier")]
    pub tier: Tier,
    /// Why that tier served ([`averaged::choose`](crate::averaged::choose)).
    #[serde(default)]
    pub tier_reason: TierReason,
    /// Time traces, when asked for.
    #[serde(skip)]
    pub trace: Option<Trace>,
}

fn full_tier() -> Tier {
    Tier::Full
}

impl RunResult {
    /// Whether the measures are an extrapolated settled level ([`RunResult::level_error`]).
    pub fn predicted(&self) -> bool {
        self.level_error.is_some()
    }
}

/// Simulates the rig once (no reference run) with the given solver.
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
    opts.validate()?;
    let rig = Rig::with_effects(*p, fx)?;
    let t_end = end_time(p, opts)?;
    Ok(serve(&rig, fx.is_empty(), t_end, opts, solver))
}

/// A run of `rig` (without model extensions where `none`) to `t_end`, served by the tier
/// [`averaged::choose`](crate::averaged::choose) picks for `opts.tier`: the full integration
/// ([`integrate`]), the averaged slow model ([`crate::averaged::simulate_slow_with`]) or hybrid
/// windows ([`crate::hybrid`]), with the tier and its reason recorded. Where an averaged run's
/// window leaves the law, `auto` goes on with hybrid windows and `averaged` with the full model
/// (both with the full model where the slow model diverged);
/// where a hybrid run finds the law's continuation stopped short (`partial_law`) or its slow
/// model diverges (`left_law`), the full model serves.
fn serve(rig: &Rig, none: bool, t_end: f64, opts: &RunOptions, solver: &mut Solver) -> RunResult {
    let clock = Instant::now();
    let (tier, tier_reason, table) = crate::averaged::choose(&rig.p, none, opts.tier);
    let full =
        |solver: &mut Solver, why| (integrate_full(rig, t_end, opts, solver), Tier::Full, why);
    let hybrid = |solver: &mut Solver, t, why| match hybrid_run(rig, t, t_end, opts, solver) {
        Ok(r) => (r, Tier::Hybrid, why),
        Err(crate::averaged::AveragingError::Diverged(_)) => full(solver, TierReason::LeftLaw),
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
/// ([`SlowRun::left_law`](crate::averaged::SlowRun::left_law)).
fn averaged_run(
    p: &Params,
    table: &crate::averaged::Table,
    t_end: f64,
    opts: &RunOptions,
) -> Result<RunResult, f64> {
    let trace = opts.trace.then_some(opts.trace_points);
    let slow = crate::averaged::simulate_slow_with(
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

/// A hybrid run ([`crate::hybrid`]) over the full run's simulated time `t_end`: the slow model at
/// [`slow_rtol`], the full windows with `solver` at the run's options and sampling.
fn hybrid_run(
    rig: &Rig,
    table: &crate::averaged::Table,
    t_end: f64,
    opts: &RunOptions,
    solver: &mut Solver,
) -> Result<RunResult, crate::averaged::AveragingError> {
    let (_, k) = sampling(&rig.p, opts.samples_per_period);
    let envelope = opts.envelope.map(|tol| envelope_for(&rig.p, k, tol));
    let trace = opts.trace.then_some(opts.trace_points);
    let h = crate::hybrid::simulate_hybrid(
        rig,
        table,
        t_end,
        slow_rtol(opts),
        &opts.ode,
        k,
        envelope.as_ref(),
        solver,
        trace,
    )?;
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
            if !(t <= T_END_MAX) {
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
    if p.two_stage() && !(p.t_on < t_end) {
        return Err(SimError::SwitchOnAfterEnd {
            t_on: p.t_on,
            t_end,
        });
    }
    if p.vibrates() {
        let vibrated = t_end - if p.two_stage() { p.t_on } else { 0.0 };
        let periods = p.f * vibrated;
        if !(periods <= PERIODS_MAX) {
            return Err(SimError::Budget(format!(
                "{periods:.3e} forcing periods (f = {} Hz over {vibrated:.3e} s of vibration) \
                 are over the budget of {PERIODS_MAX:.0e} periods; lower f or t_end",
                p.f
            )));
        }
    }
    Ok(t_end)
}

/// The per-sample work of a run: the measures, the trace, the limit-cycle watch and the
/// early-stop checks, fed one output sample at a time by the integrator.
struct Recorder<'a> {
    rig: &'a Rig,
    an: Analyzer,
    trace: Option<Trace>,
    /// Every `stride`-th sample goes to the trace (0: no trace).
    stride: u64,
    /// Most samples the trace keeps; beyond them it is halved and `stride` doubled.
    trace_points: usize,
    /// Index of the next sample (sample `i` lies at `i dt`).
    idx: u64,
    /// Samples per vibration period.
    k: usize,
    cycle: Option<LimitCycle>,
    early: Option<EarlyChecks>,
    /// Where an early check ended the run: its time, measures and the error bound of an
    /// extrapolated level (`Some` only when extrapolated).
    stopped: Option<(f64, Measures, Option<f64>)>,
}

/// The early-stop checks of a run ([`RunOptions::early_stop`]).
struct EarlyChecks {
    next_check: f64,
    check_every: f64,
    /// Largest max − min of the smoothed force of steady sliding \[N\].
    range: f64,
    /// Nominal stick-slip amplitude `2 (F_s − F_c)` \[N\].
    nominal: f64,
    /// Slope bound of a settling force \[N/s\].
    slope: f64,
    /// Time from which the window can hold the stick-slip cycles of the planned time \[s\].
    cycles_from: f64,
    min_cycles: usize,
}

impl Recorder<'_> {
    /// Takes sample `(t, y)`; false ends the integration (limit cycle found, answer known).
    fn observe(&mut self, t: f64, y: &[f64]) -> bool {
        let rig = self.rig;
        // The force the sensor records (the drive force itself without sensor dynamics).
        let f = rig.measured_force(t, y);
        let i = self.idx;
        self.record(i, t, f, y);
        self.idx += 1;
        if let Some(c) = self.cycle.as_mut()
            && c.push(t, f, y)
        {
            return false;
        }
        let Some(e) = self.early.as_mut() else {
            return true;
        };
        if t < e.next_check {
            return true;
        }
        e.next_check += e.check_every.min(EARLY_STOP_GROWTH * e.next_check);
        let an = &self.an;
        let known = an
            .steady_sliding(t, e.range, EARLY_STOP_DRIFT)
            .map(|m| (m, None))
            .or_else(|| {
                an.settling(0.5 * t, e.slope, SETTLING_TOL * e.nominal, EARLY_STOP_DRIFT)
                    .map(|(m, err)| (m, Some(err)))
            })
            .or_else(|| {
                if t < e.cycles_from {
                    return None;
                }
                an.steady_cycles(
                    t,
                    e.min_cycles,
                    EARLY_STOP_STDERR * e.nominal,
                    EARLY_STOP_DRIFT,
                )
                .map(|m| (m, None))
            });
        match known {
            Some((m, err)) => {
                self.stopped = Some((t, m, err));
                false
            }
            None => true,
        }
    }

    /// Feeds sample `i` (time `t`, measured force `f`, state `y`) to the analyzer and, every
    /// `stride` samples, to the trace.
    fn record(&mut self, i: u64, t: f64, f: f64, y: &[f64]) {
        let rig = self.rig;
        let v_r = rig.relative_velocity(t, y);
        let smooth = self.an.push(t, f, v_r);
        let Some(tr) = self.trace.as_mut() else {
            return;
        };
        if !i.is_multiple_of(self.stride) {
            return;
        }
        if tr.len() >= self.trace_points {
            // A run continued past its planned time: keep every second sample.
            tr.halve();
            self.stride *= 2;
            if !i.is_multiple_of(self.stride) {
                return;
            }
        }
        tr.t.push(t);
        tr.f_d.push(f);
        tr.f_d_smooth.push(if self.k > 1 { smooth } else { f });
        tr.x_s.push(y[X]);
        tr.x_d.push(rig.drive_displacement(t));
        tr.s.push(rig.deformation(y));
        tr.v_r.push(v_r);
        tr.v.push(y[V]);
        tr.u.push(rig.substrate_displacement(t));
    }
}

/// A run whose window still holds a trend (docs/model.md: the measures describe the settled state)
/// goes on by this share of its time so far at a time, judged after each step ...
pub const SETTLE_GROWTH: f64 = 0.25;
/// ... up to this many times its planned simulated time; a run that has not settled then ends
/// with [`Status::Unsettled`]. Only an automatic simulated time is continued: a given `t_end`
/// is the run's time (or, with [`EarlyStop::Always`], its longest).
pub const SETTLE_CAP: f64 = 8.0;
/// A window without stick-slip is settled when its smoothed force changes across it by at most
/// this share of the nominal amplitude `2 (F_s − F_c)` (so `r` by about 0.0025, half of
/// docs/model.md's allowance) ...
pub const SETTLED_TREND: f64 = 0.0025;
/// ... and its mean lies within this relative distance of the level its thirds approach (a
/// fifth of docs/model.md's 0.5 %).
pub const SETTLED_MEAN: f64 = 0.001;

/// A run of the full model ([`integrate`]), integrated again with every period where envelope
/// following ended in slips without a stick (`cycles > 0`, `stick_fraction` 0: the body
/// oscillating about its slide). There the envelope's jumps can have made the oscillation: a
/// jump is a forward-Euler step of the once-per-period map, which pumps a lightly damped slow
/// oscillation up to the size the tolerance allows, and a slide near its stability limit then
/// falls into it (`docs/methods.md`, "Near a slide's stability limit"). At 2000 Hz,
/// `u0` = 79 nm, `v_d` = 1.1 mm/s the envelope at 1e-4 gave `r` = 0.073 where every period
/// integrated gives 0. The statistics count both integrations ([`serve`] times the whole).
fn integrate_full(rig: &Rig, t_end: f64, opts: &RunOptions, solver: &mut Solver) -> RunResult {
    let first = integrate(rig, t_end, opts, solver);
    let m = &first.measures;
    if opts.envelope.is_none()
        || first.status != Status::Success
        || !(m.cycles > 0 && m.stick_fraction == 0.0)
    {
        return first;
    }
    let every = RunOptions {
        envelope: None,
        ..opts.clone()
    };
    let mut again = integrate(rig, t_end, &every, solver);
    again.stats += first.stats;
    again
}

fn integrate(rig: &Rig, t_end: f64, opts: &RunOptions, solver: &mut Solver) -> RunResult {
    let start = Instant::now();
    let p = &rig.p;
    let (dt, k) = sampling(p, opts.samples_per_period);
    let count = (t_end / dt).floor() as u64 + 1;
    // A two-stage run is integrated every period: the early-stop checks and the envelope's
    // jumps assume the forcing ran from t = 0.
    let two_stage = p.two_stage();
    let early = p.vibrates()
        && !two_stage
        && match opts.early_stop {
            EarlyStop::Off => false,
            EarlyStop::Automatic => opts.t_end.is_none(),
            EarlyStop::Always => true,
        };
    // The longest time: an automatic one may be continued until the force settles.
    let t_cap = if opts.t_end.is_none() {
        SETTLE_CAP * t_end
    } else {
        t_end
    };
    // Blocks for the window checks: a few thousand over the run, at least a vibration period.
    let block = (t_end / 4000.0).max(k as f64 * dt);
    let an = Analyzer::with_blocks(
        k,
        window_start(p, t_end),
        DROP_THRESHOLD * (p.f_s - p.f_c),
        STICK_VELOCITY * p.v_d,
        block,
        (t_end / block) as usize + 2,
    );
    let nominal = 2.0 * (p.f_s - p.f_c);
    let tc = p.cycle_estimate();
    // Checkpoints: every 1/256 of the planned time, from a twentieth of it on; sooner, and at
    // first a quarter of the time so far apart, where the force settles fast (`first_check`).
    let checks = early.then(|| EarlyChecks {
        next_check: first_check(p, t_end, block),
        check_every: t_end / EARLY_STOP_CHECKS,
        range: EARLY_STOP_RANGE * nominal,
        nominal,
        slope: SETTLING_SLOPE * p.k_d * p.v_d,
        // Stick-slip is judged once the window can hold the cycles the planned time is made for.
        cycles_from: 2.0 * (opts.min_cycles as f64 * tc).max(first_loading(p) + tc),
        min_cycles: opts.min_cycles as usize,
    });
    let stride = if opts.trace {
        count.div_ceil(opts.trace_points as u64).max(1)
    } else {
        0
    };
    let trace = opts.trace.then(|| {
        let n = (count / stride.max(1) + 1) as usize;
        let v = || Vec::with_capacity(n);
        Trace {
            t: v(),
            f_d: v(),
            f_d_smooth: v(),
            x_s: v(),
            x_d: v(),
            s: v(),
            v_r: v(),
            v: v(),
            u: v(),
        }
    });
    let envelope = opts
        .envelope
        .filter(|_| p.vibrates() && !two_stage)
        .map(|tol| envelope_for(p, k, tol));
    let env = envelope.as_ref();
    // The solver integrates the periods that feed the envelope's slopes finer
    // (`Envelope::inner_tolerance`), the rest at the run's own tolerance.
    let ode = opts.ode.clone();
    // Without vibration the base model is autonomous: watch for its limit cycle.
    let cycle = (opts.periodic && !p.vibrates() && !rig.has_effects())
        .then(|| LimitCycle::new(rig, dt, &ode));
    let mut rec = Recorder {
        rig,
        an,
        trace,
        stride,
        trace_points: opts.trace_points,
        idx: 0,
        k,
        cycle,
        early: checks,
        stopped: None,
    };
    let mut y = rig.initial_state();
    let grid = OutputGrid {
        start: 0.0,
        step: dt,
        count,
    };
    let mut rep = if two_stage {
        // The substrate velocity jumps from 0 to u0 ω at t_on (docs/model.md): integrate the stages
        // apart, so the step control restarts at the jump instead of rejecting its way down to it.
        integrate_stages(solver, rig, p.t_on, t_end, &mut y, &ode, grid, |t, y| {
            rec.observe(t, y)
        })
    } else {
        solver.solve_envelope(rig, 0.0, t_end, &mut y, &ode, grid, env, |t, y| {
            rec.observe(t, y)
        })
    };
    // A periodic run: the remaining samples are the last cycle's.
    let continued_from = rec.cycle.as_ref().and_then(LimitCycle::continued_from);
    if let Some(c) = rec.cycle.take()
        && rep.status == Status::Success
    {
        c.replay(&grid, rec.idx, t_end, |i, t, f, y| rec.record(i, t, f, y));
        rec.cycle = Some(c);
    }
    // docs/model.md: a window that still holds a trend does not count. Extrapolate the level where
    // the force plainly settles along one exponential (not in a run asked to run in full), else
    // go on, up to the cap.
    let mut t_stop = t_end;
    let mut extrapolated: Option<(Measures, f64)> = None;
    let mut unsettled = false;
    while rep.status == Status::Success && rec.stopped.is_none() && continued_from.is_none() {
        let ws = window_start(p, t_stop);
        if rec.an.trend(ws, SETTLED_TREND * nominal, SETTLED_MEAN) != Trend::Trending {
            break;
        }
        if opts.early_stop != EarlyStop::Off {
            extrapolated = rec.an.settling(
                ws,
                SETTLING_SLOPE * p.k_d * p.v_d,
                SETTLING_TOL * nominal,
                SETTLED_MEAN,
            );
            if extrapolated.is_some() {
                break;
            }
        }
        if t_stop >= t_cap {
            unsettled = true;
            break;
        }
        let t_next = ((1.0 + SETTLE_GROWTH) * t_stop).min(t_cap);
        let more = extend(solver, rig, &mut y, &ode, env, dt, t_stop, t_next, &mut rec);
        rep.stats += more.stats;
        rep.status = more.status;
        t_stop = more.t;
    }
    let extended = t_stop > t_end;
    // An early stop's window is the second half of the run so far.
    let (t_end, window_start) = match &rec.stopped {
        Some((t, ..)) => (*t, 0.5 * t),
        None => (t_stop, window_start(p, t_stop)),
    };
    let (measures, level_error) = match (rep.status, &rec.stopped, extrapolated) {
        (Status::Success, Some((_, m, err)), _) => (*m, *err),
        (Status::Success, None, Some((m, err))) => (m, Some(err)),
        (Status::Success, None, None) if extended => (rec.an.window_measures(window_start), None),
        (Status::Success, None, None) => (rec.an.finish(), None),
        _ => (nan_measures(), None),
    };
    let status = if unsettled && rep.status == Status::Success {
        Status::Unsettled
    } else {
        rep.status
    };
    debug_assert_eq!(rig.dim(), y.len());
    RunResult {
        status,
        stats: rep.stats,
        measures,
        t_end,
        window_start,
        wall_time: start.elapsed().as_secs_f64(),
        continued_from,
        level_error,
        tier: Tier::Full,
        tier_reason: TierReason::Asked,
        trace: rec.trace,
    }
}

/// Continues a run from `t` (state `y`, samples up to `rec.idx` recorded) to the last sample
/// at or before `t_next`: first to the next sample's time without output, then along the
/// samples, so that sample `i` stays at `i dt` and envelope jumps start on a sample.
#[allow(clippy::too_many_arguments)]
fn extend(
    solver: &mut Solver,
    rig: &Rig,
    y: &mut [f64],
    ode: &Options,
    env: Option<&Envelope>,
    dt: f64,
    t: f64,
    t_next: f64,
    rec: &mut Recorder,
) -> crate::ode::RunReport {
    let first = rec.idx;
    let last = (t_next / dt).floor() as u64;
    let t0 = first as f64 * dt;
    let mut rep = solver.solve_until(rig, t, t0, y, ode, OutputGrid::NONE, |_, _| true);
    if rep.status != Status::Success || last < first {
        return rep;
    }
    let grid = OutputGrid {
        start: t0,
        step: dt,
        count: last - first + 1,
    };
    let more = solver.solve_envelope(rig, t0, last as f64 * dt, y, ode, grid, env, |t, y| {
        rec.observe(t, y)
    });
    rep.stats += more.stats;
    rep.status = more.status;
    rep.t = more.t;
    rep
}

/// Integrates from 0 to `t_on` and from `t_on` to `t_end` one after the other, restarting the
/// step control at the switch-on, where the substrate velocity jumps from 0 to `u0 ω`
/// (docs/model.md); the output times of `grid` (at or after 0) are shared out by index: those up to
/// `t_on` to the first stage. The work is added up.
pub fn integrate_stages(
    solver: &mut Solver,
    rig: &Rig,
    t_on: f64,
    t_end: f64,
    y: &mut [f64],
    ode: &Options,
    grid: OutputGrid,
    mut observe: impl FnMut(f64, &[f64]) -> bool,
) -> crate::ode::RunReport {
    let first = if t_on < grid.start {
        0
    } else {
        (((t_on - grid.start) / grid.step).floor() as u64 + 1).min(grid.count)
    };
    let g1 = OutputGrid {
        count: first,
        ..grid
    };
    let mut rep = solver.solve_until(rig, 0.0, t_on, y, ode, g1, &mut observe);
    if rep.status != Status::Success || rep.t < t_on {
        return rep;
    }
    let g2 = OutputGrid {
        start: grid.start + first as f64 * grid.step,
        step: grid.step,
        count: grid.count - first,
    };
    let second = solver.solve_until(rig, t_on, t_end, y, ode, g2, &mut observe);
    rep.stats += second.stats;
    rep.status = second.status;
    rep.t = second.t;
    rep
}

/// Envelope following in [`simulate`] where a stick-slip cycle spans many vibration periods:
/// from this longest jump on ([`Envelope::max_jump`], a fiftieth of the cycle estimate in
/// periods) the periods after a landing and the integration tolerance are those of
/// [`ENVELOPE_LONG_SETTLE`] and [`ENVELOPE_LONG_INNER`]. On the overnight sample
/// `benches/overnight/even.toml` long settings from a longest jump of 100 on cost 2.3 times the
/// right-hand sides at 100–200, 1.33 times at 200–400, 0.80 at 400–800, 0.48 at 800–1600 and
/// 0.34 above (docs/methods.md).
pub const ENVELOPE_LONG_JUMP: u64 = 400;
/// Periods integrated after each landing where jumps may be long ([`ENVELOPE_LONG_JUMP`]).
/// While the body slides under vibration the period map of the rig has a pair of complex
/// eigenvalues of modulus near 0.785 (the contact's ringing; at v_d = 0.1 mm/s,
/// k_d = 3314 N/m, f = 2000 Hz, v_a = 1.58 v_d, by finite differences at rtol 1e-11): a landing
/// excites it, and a jump of `M` periods multiplies what is left of it in the next slope by
/// about `M / L`, so jumps stay near `L / 0.785^S` periods (4 to 6 with `S = 1`). Twenty-four
/// periods let it decay by a factor of 330.
pub const ENVELOPE_LONG_SETTLE: u32 = 24;
/// [`Envelope::inner`] where jumps may be long ([`ENVELOPE_LONG_JUMP`]): the periods that feed a
/// slope are integrated at a ten-thousandth of the envelope's tolerance (stretches where the
/// envelope keeps refusing to jump, at the run's own: see [`Envelope`]). The sampled velocity's
/// period-to-period noise is about a hundred times the integration tolerance (1.1e-4, 1.5e-5,
/// 2.4e-6 and 1.5e-7 of its scale at rtol 1e-6 to 1e-9 in the case above), and a jump of `M`
/// periods needs it below a few `tol / M`.
pub const ENVELOPE_LONG_INNER: f64 = 1e-4;

/// Envelope settings of a run: `k` samples per period, the given tolerance, jumps of at most
/// a fiftieth of the stick-slip cycle (so a jump never hides more than 2 % of a loading ramp),
/// and, where that allows long jumps, a long settling and a tight integration tolerance
/// ([`ENVELOPE_LONG_JUMP`]).
pub fn envelope_for(p: &Params, k: usize, tol: f64) -> Envelope {
    let per_cycle = p.cycle_estimate() * p.f;
    let max_jump = ((per_cycle / 50.0).floor() as u64).max(2);
    let base = Envelope::new(k as u64);
    let (settle, inner) = if max_jump >= ENVELOPE_LONG_JUMP {
        (ENVELOPE_LONG_SETTLE, ENVELOPE_LONG_INNER)
    } else {
        (base.settle, base.inner)
    };
    Envelope {
        tol,
        max_jump,
        baseline: ENVELOPE_BASELINE,
        settle,
        inner,
        ..base
    }
}

fn nan_measures() -> Measures {
    Measures {
        d_f: f64::NAN,
        d_f_stderr: f64::NAN,
        mean_force: f64::NAN,
        stick_fraction: f64::NAN,
        period: f64::NAN,
        peak_force: f64::NAN,
        trough_force: f64::NAN,
        cycles: 0,
    }
}

/// A run with vibration and its reference without vibration, and the reduction coefficient.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    /// The parameters of the run.
    pub params: Params,
    /// The run itself.
    pub run: RunResult,
    /// The run without vibration at the same `v_d`, `k_d` and load (absent when `u0 = 0`: the
    /// run is its own reference).
    pub reference: Option<RunResult>,
    /// Reduction coefficient `r = dF_sd / dF_ss` (5.1).
    pub r: f64,
    /// Standard error of `r`, propagated from the two dF standard errors.
    pub r_stderr: f64,
}

impl CaseResult {
    /// The worse of the two runs' statuses (success only when both succeeded).
    pub fn status(&self) -> Status {
        match &self.reference {
            Some(r) if r.status != Status::Success => r.status,
            _ => self.run.status,
        }
    }

    /// Work of both runs together.
    pub fn total_stats(&self) -> Stats {
        let mut s = self.run.stats;
        if let Some(r) = &self.reference {
            s += r.stats;
        }
        s
    }
}

/// Reduction coefficient and its standard error from a run and its reference.
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

/// [`run_case`] with model extensions (the reference run carries the same effects).
pub fn run_case_with(
    p: &Params,
    fx: &Effects,
    opts: &RunOptions,
    solver: &mut Solver,
) -> Result<CaseResult, SimError> {
    opts.validate()?;
    let rig = Rig::with_effects(*p, fx)?;
    let t_end = end_time(p, opts)?;
    let run = serve(&rig, fx.is_empty(), t_end, opts, solver);
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

/// Bad parameters or options.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A model or effect parameter is out of range.
    #[error(transparent)]
    Model(#[from] RigError),
    /// A solver or run option is out of range.
    #[error(transparent)]
    Option(#[from] OptionError),
    /// A two-stage run that ends before its vibration is switched on.
    #[error(
        "parameter `t_on` = {t_on} s is not allowed: the vibration must be switched on before the run ends (t_end = {t_end} s); give t_on < t_end, or t_on = 0 to vibrate from the start"
    )]
    SwitchOnAfterEnd {
        /// Switch-on time \[s\].
        t_on: f64,
        /// End of the run \[s\].
        t_end: f64,
    },
    /// A run over the work budget ([`T_END_MAX`], [`PERIODS_MAX`]): the message names the
    /// parameters that make it long.
    #[error("{0}")]
    Budget(String),
}
