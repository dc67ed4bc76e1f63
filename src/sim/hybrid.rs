//! Hybrid windows: the averaged slow model where its law holds, the full model where it does not.
//!
//! Below the contact resonance the fast orbit of body and contact period-doubles or turns
//! chaotic in zones of the mean velocity `V` ([`Table::valid_at`] false), and a pure averaged
//! run slips at the wrong force (1500 Hz, `v_a/v_d` 0.4: `r` 0.52 for 0.37). A hybrid run follows
//! the slow model `z' = v_d − V`, `m V' = k_d z + h_d (v_d − V) − F_eff(V)` and hands over to the
//! full model wherever `V` enters such a zone, and back where the full motion has settled onto a
//! contracting period-1 orbit again:
//!
//! - **slow → full**, at the first period boundary `t = nT` (phase 0 of `u' = v_a cos ωt`) whose
//!   `V` lies in a zone: `x = v_d t − z`, and the body velocity and contact deformation of the
//!   table's orbit at `V` ([`Table::start_at`]);
//! - **full → slow**, at the end of a whole period whose mean velocity `V̄` lies where the law
//!   holds, once the stroboscopic body velocity `v(nT)` changes steadily (its change over the
//!   last period differs from the one before by at most [`SETTLE_STROBE`] `· max(v_a, |V̄|)`,
//!   and is at most [`SETTLE_DRIFT`] times that: a period-1 orbit drifting with `V`): the slow
//!   state restarts from the period's means, moved from the period's middle to its end (`z = z̄ +
//!   (v_d − V̄) T/2`, `V = V̄ + (V̄ − V̄_prev)/2`, consistent to second order).
//!
//! Both models feed one [`Analyzer`](crate::measures::Analyzer) one sample per period: the slow
//! model's drive force (it stands for the force smoothed over a period), and in full windows the
//! period mean of the measured force, which is the full run's smoothed force at the period's end. The measures are
//! those of docs/model.md on that series; the mean force is the mean over the window's whole
//! cycles ([`Analyzer::cycle_mean`](crate::measures::Analyzer::cycle_mean)).
//!
//! The rules follow `../shared/research/AVERAGING.md` §4.3 (a prototype written apart from this
//! code); `benches/tiers/README.md` measures them against the full model.

use crate::averaged::orbit::AveragingError;
use crate::averaged::table::Table;
use crate::measures::Measures;
use crate::model::{Rig, V, X};
use crate::ode::{Envelope, Method, OdeSystem, Options, OutputGrid, Solver, Span, Stats, Status};
use crate::sim::slow::Slow;
use crate::sim::trace::Trace;
use std::cmp::Ordering;

/// Largest difference between the stroboscopic body velocity's changes over the last two
/// periods, relative to `max(v_a, |V̄|)`, for a full window to hand back to the slow model: the
/// motion has settled onto a period-1 orbit (a period-2 orbit alternates, ringing decays). The
/// averaging study's bound (which it put on the changes themselves).
pub const SETTLE_STROBE: f64 = 1e-3;

/// Largest change of the stroboscopic body velocity over one period, in units of the
/// [`SETTLE_STROBE`] bound, for a full window to hand back: the drift of a period-1 orbit whose
/// mean velocity moves with the drive force (2.5e-7 m/s per period where the stick's creep
/// approaches a zone at 1500 Hz, `v_a/v_d` 0.4: 1.25 units).
pub const SETTLE_DRIFT: f64 = 10.0;

/// A hybrid run: its measures, work and windows.
#[derive(Clone, Debug)]
pub struct HybridRun {
    /// The measures of docs/model.md over the steady window, from one sample per period.
    pub measures: Measures,
    /// How the run ended: the first failure of either model, else success.
    pub status: Status,
    /// The work of both models together.
    pub stats: Stats,
    /// One sample per period (decimated to the trace's length where asked for): the fast
    /// channels `s`, `v_r` and `u` are NaN, `F_d` is the period's mean.
    pub trace: Option<Trace>,
    /// Full windows opened.
    pub windows: u32,
    /// Forcing periods integrated by the full model.
    pub full_periods: u64,
    /// Forcing periods in the run.
    pub periods: u64,
}

/// Where the run stands: the slow state `(z, V)` or the full state.
enum Mode {
    Slow([f64; 2]),
    Full([f64; 3]),
}

/// How a hybrid run integrates its two models.
#[derive(Clone, Copy, Debug)]
pub struct HybridOptions<'a> {
    /// Relative (and absolute) tolerance of the slow model; positive.
    pub slow_rtol: f64,
    /// The full windows' integrator options.
    pub ode: &'a Options,
    /// Samples per vibration period in the windows (the full run's sampling,
    /// [`crate::sim::sampling`]); at least 1.
    pub samples_per_period: usize,
    /// Envelope following in the windows, where given.
    pub envelope: Option<&'a Envelope>,
    /// At most this many trace samples kept, where given.
    pub trace: Option<usize>,
}

/// The run's fixed facts: its models, its options and its clock.
struct Hybrid<'a> {
    rig: &'a Rig,
    table: &'a Table,
    o: &'a HybridOptions<'a>,
    /// The vibration period \[s\].
    period: f64,
    /// Whole periods in the run.
    periods: u64,
    /// The slow model's velocity beyond which it has run away \[m/s\].
    reach: f64,
}

/// The one-sample-per-period series both models feed, with its trace.
struct Sampler {
    an: crate::measures::Analyzer,
    tr: Option<Trace>,
    stride: Option<u64>,
    period: f64,
    v_d: f64,
}

impl Sampler {
    /// The sample at the end of period `n`: force `f`, velocity `v`, spring extension `z`.
    fn push(&mut self, n: u64, f: f64, v: f64, z: f64) {
        let t = n as f64 * self.period;
        self.an.push(t, f, v);
        if let (Some(tr), Some(s)) = (self.tr.as_mut(), self.stride)
            && n.is_multiple_of(s)
        {
            tr.push_slow(t, f, self.v_d * t - z, self.v_d * t, v);
        }
    }
}

/// What the segments have done so far.
struct Tally {
    stats: Stats,
    status: Status,
    windows: u32,
    full_periods: u64,
}

/// A hybrid run of `rig` (the base model, vibrating from `t = 0`) to `t_end`: the slow model
/// and the full windows (with `solver`) as `o` says.
pub fn simulate_hybrid(
    rig: &Rig,
    table: &Table,
    t_end: f64,
    o: &HybridOptions<'_>,
    solver: &mut Solver,
) -> Result<HybridRun, AveragingError> {
    let p = &rig.p;
    refuse_unfit(rig, table)?;
    let period = 1.0 / p.f;
    let periods = (t_end / period).floor() as u64;
    let h = Hybrid {
        rig,
        table,
        o,
        period,
        periods,
        reach: crate::sim::slow::divergence_bound(p, table),
    };
    let stride = o
        .trace
        .map(|n| (periods + 1).div_ceil(n.max(1) as u64).max(1));
    let mut s = Sampler {
        an: crate::sim::slow::slow_analyzer(p, t_end, period),
        tr: stride.map(|_| Trace::default()),
        stride,
        period,
        v_d: p.v_d,
    };
    let mut tally = Tally {
        stats: Stats::default(),
        status: Status::Success,
        windows: 0,
        full_periods: 0,
    };
    let mut slow = Solver::new(Method::Radau5);
    let (mut n, mut mode) = (0u64, Mode::Slow([0.0, 0.0]));
    s.push(0, 0.0, 0.0, 0.0);
    while n < periods && tally.status == Status::Success {
        let from = n;
        (n, mode) = match mode {
            Mode::Slow(y) => h.slow_segment(&mut s, &mut slow, n, y, &mut tally)?,
            Mode::Full(y) => h.full_segment(&mut s, solver, n, y, &mut tally),
        };
        // Every segment ends a period or more on; one that did not cannot go on.
        if n == from && tally.status == Status::Success {
            tally.status = Status::StepTooSmall;
        }
    }
    // Hybrid windows serve runs with vibration only.
    let mut measures = s.an.finish().varying_cycles();
    if let Some(m) = s.an.cycle_mean(crate::sim::window::window_start(p, t_end)) {
        measures.mean_force = m;
    }
    Ok(HybridRun {
        measures,
        status: tally.status,
        stats: tally.stats,
        trace: s.tr,
        windows: tally.windows,
        full_periods: tally.full_periods,
        periods,
    })
}

/// A hybrid run needs a law that spans its range, and the base model vibrating from `t = 0`.
fn refuse_unfit(rig: &Rig, table: &Table) -> Result<(), AveragingError> {
    let p = &rig.p;
    if let Some(v) = table.stopped_at {
        return Err(AveragingError::Invalid(format!(
            "the averaged law's continuation stopped at {v} m/s, short of its span: use the full \
             model"
        )));
    }
    if table.nodes.len() < 2 || rig.dim() != 3 || p.two_stage() || !p.vibrates() {
        return Err(AveragingError::Invalid(
            "a hybrid run needs the base model vibrating from t = 0 and a law of two nodes or \
             more"
                .into(),
        ));
    }
    Ok(())
}

impl Hybrid<'_> {
    /// The slow model from period `n` on, until `V` enters a zone where the law fails (then a
    /// full window opens at that period's end) or the run ends.
    fn slow_segment(
        &self,
        s: &mut Sampler,
        slow: &mut Solver,
        n: u64,
        mut y: [f64; 2],
        tally: &mut Tally,
    ) -> Result<(u64, Mode), AveragingError> {
        let (p, table, period) = (&self.rig.p, self.table, self.period);
        let force = |z: f64, v: f64| p.k_d * z + p.h_d * (p.v_d - v);
        let slow_sys = Slow { p, table };
        let slow_opts = Options {
            rtol: self.o.slow_rtol,
            atol: self.o.slow_rtol,
            ..Options::default()
        };
        let t0 = n as f64 * period;
        let grid = OutputGrid {
            start: t0,
            step: period,
            count: self.periods - n + 1,
        };
        let mut i = n;
        let mut into_zone = false;
        let mut ran_away = None;
        // The grid's own last time: a span end computed apart can fall short of it by a
        // rounding and leave the last sample out.
        let t_stop = grid.time(grid.count - 1);
        let reach = self.reach;
        let rep = slow.solve_until(
            &slow_sys,
            Span::new(t0, t_stop, grid),
            &mut y,
            &slow_opts,
            |_, y| {
                if i > n {
                    s.push(i, force(y[0], y[1]), y[1], y[0]);
                }
                i += 1;
                // A runaway of the slow integration is no friction: the run stops and the full
                // model serves (as for an averaged run that diverged).
                if !matches!(
                    y[1].abs().partial_cmp(&reach),
                    Some(Ordering::Less | Ordering::Equal)
                ) {
                    ran_away = Some(y[1]);
                    return false;
                }
                into_zone = !table.valid_at(y[1]);
                // The sample at t0 is the state handed over, already taken.
                !into_zone || i == n + 1
            },
        );
        if let Some(v) = ran_away {
            return Err(AveragingError::Diverged(v));
        }
        tally.stats += rep.stats;
        tally.status = rep.status;
        let n = i - 1;
        Ok(if into_zone && n < self.periods {
            let t = n as f64 * period;
            let [v0, s0] = table.start_at(y[1]);
            tally.windows += 1;
            (n, Mode::Full([p.v_d * t - y[0], v0, s0]))
        } else {
            (n, Mode::Slow(y))
        })
    }

    /// A full window from period `n` on, until the motion has settled onto a period-1 orbit
    /// where the law holds (then the slow model restarts from the period's means) or the run
    /// ends.
    fn full_segment(
        &self,
        s: &mut Sampler,
        solver: &mut Solver,
        n: u64,
        mut y: [f64; 3],
        tally: &mut Tally,
    ) -> (u64, Mode) {
        let (rig, p, period) = (self.rig, &self.rig.p, self.period);
        let (table, k, v_a) = (self.table, self.o.samples_per_period, p.v_a());
        let t0 = n as f64 * period;
        let dt = period / k as f64;
        let grid = OutputGrid {
            start: t0,
            step: dt,
            count: (self.periods - n) * k as u64 + 1,
        };
        let t_stop = grid.time(grid.count - 1);
        // Sums over the current period, the last two strobes' changes, the last means.
        let (mut sf, mut sv, mut sz) = (0.0, 0.0, 0.0);
        let mut strobe = y[V];
        let mut steps = [f64::INFINITY, f64::NEG_INFINITY];
        let mut last_mean = f64::NAN;
        let mut j = 0usize;
        let mut m = n;
        let mut handed: Option<[f64; 2]> = None;
        let (ode, envelope) = (self.o.ode, self.o.envelope);
        let rep = solver.solve_envelope(
            rig,
            Span::new(t0, t_stop, grid),
            &mut y,
            ode,
            envelope,
            |t, y| {
                if j == 0 {
                    j = 1;
                    return true;
                }
                sf += rig.measured_force(t, y);
                sv += y[V];
                sz += p.v_d * t - y[X];
                if j < k {
                    j += 1;
                    return true;
                }
                j = 1;
                m += 1;
                let kf = k as f64;
                let (f_bar, v_bar, z_bar) = (sf / kf, sv / kf, sz / kf);
                (sf, sv, sz) = (0.0, 0.0, 0.0);
                s.push(m, f_bar, v_bar, z_bar);
                steps = [steps[1], y[V] - strobe];
                strobe = y[V];
                let tol = SETTLE_STROBE * v_a.max(v_bar.abs());
                let prev = last_mean;
                last_mean = v_bar;
                // Settled onto a period-1 orbit that may drift with the mean velocity: the strobe's
                // change steady from period to period, and small.
                let settled =
                    (steps[1] - steps[0]).abs() <= tol && steps[1].abs() <= SETTLE_DRIFT * tol;
                if settled && table.valid_at(v_bar) {
                    let v_end = if prev.is_finite() {
                        v_bar + 0.5 * (v_bar - prev)
                    } else {
                        v_bar
                    };
                    handed = Some([z_bar + (p.v_d - v_bar) * 0.5 * period, v_end]);
                    return false;
                }
                true
            },
        );
        tally.stats += rep.stats;
        tally.status = rep.status;
        tally.full_periods += m - n;
        (
            m,
            match handed {
                Some(h) => Mode::Slow(h),
                None => Mode::Full(y),
            },
        )
    }
}
