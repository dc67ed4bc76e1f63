//! How a run is made: its options, their documented ranges, and the constants of its budget
//! and early stop.

use crate::ode::{Method, OptionError, Options};
use crate::sim::tier::Tier;
use serde::{Deserialize, Serialize};

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
    /// Simulated time \[s\]; `None` (default) chooses it from the run (see [`planned_time`](crate::sim::planned_time)).
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
    /// ([`simulate_slow_with`](crate::sim::slow::simulate_slow_with)) is continued along its limit cycle alike.
    /// Default true.
    pub periodic: bool,
    /// Envelope following for runs with vibration: the extrapolation tolerance of one jump over
    /// whole vibration periods (see [`ode::Envelope`](crate::ode::Envelope)), in units of each
    /// state's characteristic size; `None` integrates every period. Default
    /// [`DEFAULT_ENVELOPE`]. Range 1e-8 to 0.1. A two-stage run (`t_on > 0`) integrates every
    /// period.
    pub envelope: Option<f64>,
    /// Which model serves a run with vibration ([`choose`](crate::sim::choose::choose)):
    /// `auto` (default) averages the vibration out where the averaged law is valid and the
    /// forcing fast against the drive, `averaged` wherever the law exists, `full` never. The
    /// result records the tier and why ([`RunResult::tier`](crate::sim::RunResult::tier)).
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
/// Early stop of a settling sliding run ([`Analyzer::settling`](crate::measures::Analyzer::settling)): two exponential fits must
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
/// Envelope following in [`simulate`](crate::sim::simulate): the slopes are measured over this many vibration periods
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
