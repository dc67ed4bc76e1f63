//! The full model integrated: the per-sample recorder (measures, trace, limit cycle, early
//! stop), envelope following, and the two stages of a switched-on vibration.

use crate::cycle::LimitCycle;
use crate::measures::{Analyzer, DROP_THRESHOLD, Measures, STICK_VELOCITY, Trend};
use crate::model::{Params, Rig, V, X};
use crate::ode::lanes::cos;
use crate::ode::{Envelope, OdeSystem, Options, OutputGrid, RunReport, Solver, Span, Status};
use crate::sim::options::*;
use crate::sim::result::RunResult;
use crate::sim::tier::{Tier, TierReason};
use crate::sim::trace::Trace;
use crate::sim::window::{first_check, first_loading, sampling, window_start};
use std::time::Instant;

/// The per-sample work of a run: the measures, the trace, the limit-cycle watch and the
/// early-stop checks, fed one output sample at a time by the integrator.
pub(crate) struct Recorder {
    rig: Rig,
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
    /// The substrate velocity at the samples of one period, `u0 ω cos(2π j / k)` for
    /// `j = 0 … k−1` (this project's cosine), where the vibration runs from `t = 0`; empty
    /// otherwise. Sample `i` at `t = i dt` takes entry `i mod k`: a cosine per sample was a
    /// tenth of a sweep's time below the resonance.
    u_dot: Vec<f64>,
    /// The sample spacing `dt = 1 / (k f)` \[s\].
    dt: f64,
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

impl Recorder {
    /// Takes sample `(t, y)`; false ends the integration (limit cycle found, answer known).
    pub(crate) fn observe(&mut self, t: f64, y: &[f64]) -> bool {
        // The force the sensor records (the drive force itself without sensor dynamics).
        let f = self.rig.measured_force(t, y);
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

    /// The entry of [`Recorder::u_dot`] for sample `i` at time `t`, where the table serves it
    /// (the vibration runs from 0 and `t` is the sample's grid time `i dt`).
    #[inline]
    fn phase(&self, i: u64, t: f64) -> Option<usize> {
        (!self.u_dot.is_empty() && t == i as f64 * self.dt).then(|| (i % self.k as u64) as usize)
    }

    /// Feeds sample `i` (time `t`, measured force `f`, state `y`) to the analyzer and, every
    /// `stride` samples, to the trace.
    fn record(&mut self, i: u64, t: f64, f: f64, y: &[f64]) {
        let v_r = match self.phase(i, t) {
            Some(j) => y[V] - self.u_dot[j],
            None => self.rig.relative_velocity(t, y),
        };
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
        let rig = &self.rig;
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
/// following ended in slips without a stick ([`needs_every_period`]: the body oscillating
/// about its slide). There the envelope's jumps can have made the oscillation: a
/// jump is a forward-Euler step of the once-per-period map, which pumps a lightly damped slow
/// oscillation up to the size the tolerance allows, and a slide near its stability limit then
/// falls into it (`docs/methods.md`, "Near a slide's stability limit"). At 2000 Hz,
/// `u0` = 79 nm, `v_d` = 1.1 mm/s the envelope at 1e-4 gave `r` = 0.073 where every period
/// integrated gives 0. The statistics count both integrations ([`serve`] times the whole).
pub(crate) fn integrate_full(
    rig: &Rig,
    t_end: f64,
    opts: &RunOptions,
    solver: &mut Solver,
) -> RunResult {
    let first = integrate(rig, t_end, opts, solver);
    if !needs_every_period(&first, &rig.p, opts) {
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

/// A run of the full model between its setup and its measures: the recorder, the state and
/// the sampling. [`integrate`] makes one, integrates it ([`Run::solve`]) and measures it
/// ([`Run::finish`]); the batch path ([`crate::sim::batch`]) integrates many side by side in
/// vector lanes between the same two steps.
pub(crate) struct Run {
    pub(crate) rec: Recorder,
    pub(crate) y: Vec<f64>,
    pub(crate) grid: OutputGrid,
    pub(crate) envelope: Option<Envelope>,
    /// The integration options (the run's tolerances).
    pub(crate) ode: Options,
    two_stage: bool,
    t_end: f64,
    t_cap: f64,
    nominal: f64,
    start: Instant,
    /// The share of the wall time since `start` this run counts as its own (1, or one over
    /// the lanes it shared a batch with).
    pub(crate) share: f64,
}

impl Run {
    /// Sets up a run of `rig` over `t_end` with `opts` (the run keeps a copy of the rig).
    pub(crate) fn new(rig: &Rig, t_end: f64, opts: &RunOptions) -> Self {
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
        // The solver integrates the periods that feed the envelope's slopes finer
        // (`Envelope::inner_tolerance`), the rest at the run's own tolerance.
        let ode = opts.ode.clone();
        // Without vibration the base model is autonomous: watch for its limit cycle.
        let cycle = (opts.periodic && !p.vibrates() && !rig.has_effects())
            .then(|| LimitCycle::new(rig, dt, &ode));
        // The table of the substrate velocity: one cosine per sample of a period instead of one
        // per sample of the run (the same operations as the right-hand side's, at the exact
        // phase `2π j / k`).
        let u_dot = match rig.substrate_velocity_terms() {
            (a, t_on) if a != 0.0 && t_on == 0.0 && k > 1 => (0..k)
                .map(|j| a * cos(std::f64::consts::TAU * j as f64 / k as f64))
                .collect(),
            _ => vec![],
        };
        let rec = Recorder {
            rig: rig.clone(),
            an,
            trace,
            stride,
            trace_points: opts.trace_points,
            idx: 0,
            k,
            u_dot,
            dt,
            cycle,
            early: checks,
            stopped: None,
        };
        let y = rig.initial_state();
        let grid = OutputGrid {
            start: 0.0,
            step: dt,
            count,
        };
        Run {
            rec,
            y,
            grid,
            envelope,
            ode,
            two_stage,
            t_end,
            t_cap,
            nominal,
            start,
            share: 1.0,
        }
    }

    /// The main integration, on one solver.
    fn solve(&mut self, solver: &mut Solver) -> RunReport {
        let Run {
            rec,
            y,
            grid,
            envelope,
            ode,
            two_stage,
            t_end,
            ..
        } = self;
        let rig = rec.rig.clone();
        let (rig, t_end, grid) = (&rig, *t_end, *grid);
        if *two_stage {
            // The substrate velocity jumps from 0 to u0 ω at t_on (docs/model.md): integrate the
            // stages apart, so the step control restarts at the jump instead of rejecting its
            // way down to it.
            integrate_stages(
                solver,
                rig,
                rig.p.t_on,
                Span::new(0.0, t_end, grid),
                y,
                ode,
                |t, y| rec.observe(t, y),
            )
        } else {
            solver.solve_envelope(
                rig,
                Span::new(0.0, t_end, grid),
                y,
                ode,
                envelope.as_ref(),
                |t, y| rec.observe(t, y),
            )
        }
    }

    /// Measures the run after its main integration ended with `rep`: a limit cycle's replay,
    /// the continuation of a run still settling (on `solver`), the measures.
    pub(crate) fn finish(
        self,
        rep: RunReport,
        opts: &RunOptions,
        solver: &mut Solver,
    ) -> RunResult {
        let Run {
            mut rec,
            mut y,
            grid,
            envelope,
            ode,
            t_end,
            t_cap,
            nominal,
            start,
            share,
            ..
        } = self;
        let mut rep = rep;
        let rig = rec.rig.clone();
        let rig = &rig;
        let p = &rig.p;
        let env = envelope.as_ref();
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
            let more = extend(solver, rig, &mut y, &ode, env, t_stop..t_next, &mut rec);
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
            (Status::Success, None, None) if extended => {
                (rec.an.window_measures(window_start), None)
            }
            (Status::Success, None, None) => (rec.an.finish(), None),
            _ => (crate::measures::Measures::nan(), None),
        };
        let measures = if p.vibrates() {
            measures.varying_cycles()
        } else {
            measures
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
            wall_time: share * start.elapsed().as_secs_f64(),
            continued_from,
            level_error,
            tier: Tier::Full,
            tier_reason: TierReason::Asked,
            trace: rec.trace,
        }
    }
}

/// A slide under envelope following whose smoothed force still swings by more than this share
/// of the nominal amplitude `2 (F_s − F_c)` (`r` about 0.005, docs/model.md's accuracy) is
/// integrated again with every period, drops counted as cycles or not.
pub const SLIDE_SWING: f64 = 0.005;

/// Whether a run of `p` under envelope following ended without a stick but with the force
/// swinging (slips counted as cycles, or a smoothed force whose range exceeds [`SLIDE_SWING`]
/// of the nominal amplitude), so that [`integrate_full`] integrates it again with every period.
/// The second test catches an oscillation whose swings fall short of the cycle detector's drop:
/// at 500 Hz, `u0` = 79 nm, `v_d` = 0.149 mm/s, `k_d` = 10 986 N/m the envelope at 1e-4 gave a
/// 2.4 N swing (`r` = 0.381, no cycle counted) where every period integrated gives 0.0003.
pub(crate) fn needs_every_period(first: &RunResult, p: &Params, opts: &RunOptions) -> bool {
    let m = &first.measures;
    let swing = m.peak_force - m.trough_force;
    opts.envelope.is_some()
        && first.status == Status::Success
        && m.stick_fraction == 0.0
        && (m.cycles > 0 || swing > SLIDE_SWING * 2.0 * (p.f_s - p.f_c))
}

/// A run of the full model on one solver: set up, integrated, measured.
pub(crate) fn integrate(
    rig: &Rig,
    t_end: f64,
    opts: &RunOptions,
    solver: &mut Solver,
) -> RunResult {
    let mut run = Run::new(rig, t_end, opts);
    let rep = run.solve(solver);
    run.finish(rep, opts, solver)
}

/// Continues a run from `t` (state `y`, samples up to `rec.idx` recorded) to the last sample
/// at or before `t_next` (`span` = `t..t_next`): first to the next sample's time without
/// output, then along the samples, so that sample `i` stays at `i dt` and envelope jumps start
/// on a sample.
fn extend(
    solver: &mut Solver,
    rig: &Rig,
    y: &mut [f64],
    ode: &Options,
    env: Option<&Envelope>,
    span: std::ops::Range<f64>,
    rec: &mut Recorder,
) -> crate::ode::RunReport {
    let (t, t_next, dt) = (span.start, span.end, rec.dt);
    let first = rec.idx;
    let last = (t_next / dt).floor() as u64;
    let t0 = first as f64 * dt;
    let mut rep = solver.solve_until(rig, Span::new(t, t0, OutputGrid::NONE), y, ode, |_, _| true);
    if rep.status != Status::Success || last < first {
        return rep;
    }
    let grid = OutputGrid {
        start: t0,
        step: dt,
        count: last - first + 1,
    };
    let more = solver.solve_envelope(
        rig,
        Span::new(t0, last as f64 * dt, grid),
        y,
        ode,
        env,
        |t, y| rec.observe(t, y),
    );
    rep.stats += more.stats;
    rep.status = more.status;
    rep.t = more.t;
    rep
}

/// Integrates from `span.t0` to `t_on` and from `t_on` to `span.t1` one after the other,
/// restarting the step control at the switch-on, where the substrate velocity jumps from 0 to
/// `u0 ω` (docs/model.md); the output times of `span.grid` are shared out by index: those up to
/// `t_on` to the first stage. The work is added up.
pub fn integrate_stages<S: crate::ode::OdeSystem>(
    solver: &mut Solver,
    rig: &S,
    t_on: f64,
    span: Span,
    y: &mut [f64],
    ode: &Options,
    mut observe: impl FnMut(f64, &[f64]) -> bool,
) -> crate::ode::RunReport {
    let Span {
        t0,
        t1: t_end,
        grid,
    } = span;
    let first = if t_on < grid.start {
        0
    } else {
        (((t_on - grid.start) / grid.step).floor() as u64 + 1).min(grid.count)
    };
    let g1 = OutputGrid {
        count: first,
        ..grid
    };
    let mut rep = solver.solve_until(rig, Span::new(t0, t_on, g1), y, ode, &mut observe);
    if rep.status != Status::Success || rep.t < t_on {
        return rep;
    }
    let g2 = OutputGrid {
        start: grid.start + first as f64 * grid.step,
        step: grid.step,
        count: grid.count - first,
    };
    let second = solver.solve_until(rig, Span::new(t_on, t_end, g2), y, ode, &mut observe);
    rep.stats += second.stats;
    rep.status = second.status;
    rep.t = second.t;
    rep
}

/// Envelope following in [`simulate`](crate::sim::simulate) where a stick-slip cycle spans many vibration periods:
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The recorder's relative velocity from its table of one period is the rig's own
    /// `v − u0 ω cos(ω t)` at every sample (within rounding: the table's phase is exact), in
    /// order, after a jump over samples (as envelope following makes) and at the first sample.
    #[test]
    fn the_table_gives_the_substrate_velocity_at_every_sample() {
        let p = Params {
            f: 1282.0,
            u0: 3e-8,
            ..Params::default()
        };
        let rig = Rig::new(p).unwrap();
        let opts = RunOptions {
            trace: true,
            ..RunOptions::default()
        };
        let mut run = Run::new(&rig, 0.05, &opts);
        let (k, dt) = (run.rec.k, run.rec.dt);
        assert_eq!(run.rec.u_dot.len(), k);
        let amp = p.u0 * p.omega();
        let y = [0.0, 1e-4, 0.0];
        // Samples 0 to 3k in order, then a jump to 7k + 3 and on.
        let idx: Vec<u64> = (0..3 * k as u64)
            .chain(7 * k as u64 + 3..8 * k as u64)
            .collect();
        for &i in &idx {
            run.rec.idx = i;
            assert!(run.rec.observe(i as f64 * dt, &y));
        }
        let tr = run.rec.trace.as_ref().unwrap();
        assert_eq!(tr.v_r.len(), idx.len());
        for (n, &i) in idx.iter().enumerate() {
            let t = i as f64 * dt;
            let want = rig.relative_velocity(t, &y);
            assert!(
                (tr.v_r[n] - want).abs() <= 1e-12 * amp,
                "sample {i}: {} against {want}",
                tr.v_r[n]
            );
        }
    }
}
