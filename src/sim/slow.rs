//! The averaged slow model: the drive spring and the body's mean velocity, with the vibration
//! replaced by the averaged law `F_eff(V)` ([`crate::averaged`]).

use crate::averaged::orbit::AveragingError;
use crate::averaged::table::Table;
use crate::model::Params;
use crate::ode::{Method, OdeSystem, Options, OutputGrid, Solver, Span, Status};
use std::cmp::Ordering;

/// The slow model of the averaged rig: the spring's stretch `z = v_d t − x` and the body's
/// mean velocity `V`, with the vibration replaced by `F_eff`:
/// `z' = v_d − V`, `m V' = k_d z + h_d (v_d − V) − F_eff(V)`.
pub(crate) struct Slow<'a> {
    pub(crate) p: &'a Params,
    pub(crate) table: &'a Table,
}

impl Slow<'_> {
    fn law(&self, v: f64) -> (f64, f64) {
        // Beyond the table the vibration's share of the friction has faded and the Stribeck
        // term decayed (table_span): the law goes on with the viscous slope.
        let last = self.table.nodes.last().expect("a table has nodes");
        match self.table.law(v) {
            Some(fd) => fd,
            None => (
                (last.force + self.p.h_v * (v.abs() - last.v_mean).max(0.0)).copysign(v),
                self.p.h_v,
            ),
        }
    }
}

impl OdeSystem for Slow<'_> {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let p = self.p;
        let (f, _) = self.law(y[1]);
        dy[0] = p.v_d - y[1];
        dy[1] = (p.k_d * y[0] + p.h_d * (p.v_d - y[1]) - f) / p.m;
    }
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut [f64]) {
        let p = self.p;
        let (_, d) = self.law(y[1]);
        jac.copy_from_slice(&[0.0, -1.0, p.k_d / p.m, (-p.h_d - d) / p.m]);
    }
    fn time_derivative(&self, _t: f64, _y: &[f64], dfdt: &mut [f64], _scratch: &mut [f64]) {
        dfdt.fill(0.0);
    }
    fn scale(&self, i: usize) -> f64 {
        if i == 0 {
            (self.p.f_s / self.p.k_d).max(1e-12)
        } else {
            self.p.v_d
        }
    }
}

/// A run of the averaged slow model: the measures of docs/model.md from its drive force, and
/// its work.
#[derive(Clone, Debug)]
pub struct SlowRun {
    /// The measures over the steady window (the drive force needs no smoothing: it carries no
    /// ripple at `f`), the mean force over the window's whole stick-slip cycles where it holds
    /// two drops or more ([`crate::measures::Analyzer::cycle_mean`]). Where the slide at `v_d` is stable and the run ends on it, or settles
    /// onto it (no slip in the window, the force's swing shrinking from the window's first half
    /// to its second), the mean force is the averaged law's `F_eff(v_d)` itself, and dF, where
    /// no slip fell in the window, 0: the settled slide has no oscillation left.
    pub measures: crate::measures::Measures,
    /// How the integration ended.
    pub status: Status,
    /// The slow integration's work.
    pub stats: crate::ode::Stats,
    /// The slow states sampled (where asked for): `t`, `F_d = k_d z + h_d (v_d − V)`, the same
    /// as `F_d_smooth`, `x_s = v_d t − z`, `x_d`, `v = V`; the fast channels `s`, `v_r` and `u`
    /// are NaN, as the slow model does not hold them.
    pub trace: Option<crate::sim::trace::Trace>,
    /// The first mean velocity \[m/s\] of the steady window (as sampled) where the
    /// law may not stand for the vibration ([`Table::valid_at`]: an orbit that does not
    /// contract, a gap, past a failed continuation); `None` where it may all along. The run's
    /// measures are then not the averaged model's to give: the full model must serve. The
    /// transient before the window is not checked: the stick-slip forgets it, and a start from
    /// rest passes the law at zero force, where the orbit of a small vibration need not
    /// contract. Infinite where the slow model diverged: its window ran past
    /// [`divergence_bound`], or through non-finite values (the full model must serve; hybrid
    /// windows would hand back to the same slow model).
    pub left_law: Option<f64>,
    /// Time \[s\] from which the samples were read off the slow model's limit cycle instead of
    /// integrated ([`simulate_slow_with`]'s `periodic`); `None` where every one was integrated.
    pub continued_from: Option<f64>,
}

/// Integrates the averaged slow model of `p` from rest to `t_end` with Radau IIA at `rtol`,
/// sampling the drive force every `dt` seconds for the measures (window: the second half, as a
/// full run's), and says where the window left the valid law ([`SlowRun::left_law`](crate::sim::slow::SlowRun::left_law)). A table
/// of fewer than two nodes is refused.
pub fn simulate_slow(
    p: &Params,
    table: &Table,
    t_end: f64,
    dt: f64,
    rtol: f64,
) -> Result<SlowRun, AveragingError> {
    simulate_slow_with(p, table, t_end, dt, rtol, None, true)
}

/// How far past the larger of the table's upper end ([`table_span`](crate::averaged::table_span)) and the fastest slip
/// ([`slip_speed`]) the slow model's mean velocity may run in the steady window before the run
/// counts as diverged and leaves the law ([`SlowRun::left_law`](crate::sim::slow::SlowRun::left_law)): a window beyond four times
/// both is a runaway of the integration, not friction. On the overnight grid's even sixteenth
/// (2000 Hz, `u0` = 12.6 nm, `v_d` = 0.15 mm/s) the slow model ran off to `V` ≈ 1e17 m/s and,
/// without this bound, reported `r` ≈ 5e21 as a success. (Four times the table alone was too
/// tight: a soft drive's slips outrun it, at 2000 Hz, `u0` = 5 nm, `v_d` = 0.27 mm/s,
/// `k_d` = 5000 N/m by ten times, and 33 points of a 1024-point slice of the overnight grid went to
/// the full model for nothing.)
pub const DIVERGED: f64 = 4.0;

/// The mean velocity \[m/s\] past which a slow model has diverged: [`DIVERGED`] times the
/// larger of the table's upper end and [`slip_speed`].
pub fn divergence_bound(p: &Params, table: &Table) -> f64 {
    DIVERGED * table.at.last().copied().unwrap_or(0.0).max(slip_speed(p))
}

/// A bound on the body's speed in a slip \[m/s\]: `v_d + 2 F_s / √(k_d m)`. The spring's energy
/// at breakaway, `F²/(2 k_d)` with `F` below `2 F_s`, is all a slip can turn into the body's
/// kinetic energy `m V²/2` relative to the drive.
pub fn slip_speed(p: &Params) -> f64 {
    p.v_d + 2.0 * p.f_s / (p.k_d * p.m).sqrt()
}

/// Share of the nominal stick-slip amplitude `2 (F_s − F_c)` (and of `v_d`) within which the
/// slow model's end state must lie of the steady slide at `v_d` for its mean force to be
/// reported as `F_eff(v_d)`.
pub const SLIDE_TOL: f64 = 1e-4;

/// The analyser of a run sampled once every `dt` seconds without ripple (the slow model's, a
/// hybrid run's): no smoothing, the window of a full run of `t_end`, blocks as a full run keeps
/// them (for the mean over whole cycles).
pub(crate) fn slow_analyzer(p: &Params, t_end: f64, dt: f64) -> crate::measures::Analyzer {
    use crate::measures::{Analyzer, DROP_THRESHOLD, STICK_VELOCITY};
    let block = (t_end / 4000.0).max(dt);
    Analyzer::with_blocks(
        1,
        crate::sim::window::window_start(p, t_end),
        DROP_THRESHOLD * (p.f_s - p.f_c),
        STICK_VELOCITY * p.v_d,
        block,
        (t_end / block) as usize + 2,
    )
}

/// [`simulate_slow`], keeping at most `trace` samples of the slow states (evenly decimated)
/// where given. Where `periodic`, once the stick-slip repeats (two successive downward crossings
/// of the level `F_eff(v_d)` in the same state, the orbit contracting:
/// [`LimitCycle::slow`](crate::cycle::LimitCycle::slow)) the rest of the samples are read off
/// the last cycle instead of integrated, as a run without vibration does
/// ([`RunOptions::periodic`](crate::sim::RunOptions::periodic)). The slow model is planar and
/// autonomous, so its periodic orbit, once reached, repeats exactly.
pub fn simulate_slow_with(
    p: &Params,
    table: &Table,
    t_end: f64,
    dt: f64,
    rtol: f64,
    trace: Option<usize>,
    periodic: bool,
) -> Result<SlowRun, AveragingError> {
    if table.nodes.len() < 2 {
        return Err(AveragingError::Invalid(format!(
            "the averaged law has {} node(s) (continuation stopped at {:?} m/s): use the full model",
            table.nodes.len(),
            table.stopped_at
        )));
    }
    let sys = Slow { p, table };
    let window = crate::sim::window::window_start(p, t_end);
    let mid = 0.5 * (window + t_end);
    // The range of V the window visits (V is continuous: every value between is visited too).
    let mut seen = (f64::INFINITY, f64::NEG_INFINITY);
    // The drive force's range over each half of the window: a decaying approach to the slide.
    let mut halves = [(f64::INFINITY, f64::NEG_INFINITY); 2];
    let mut an = slow_analyzer(p, t_end, dt);
    let mut y = [0.0, 0.0];
    let opts = Options {
        rtol,
        atol: rtol,
        ..Options::default()
    };
    let count = (t_end / dt).floor() as u64 + 1;
    let grid = OutputGrid {
        start: 0.0,
        step: dt,
        count,
    };
    let stride = trace.map(|n| count.div_ceil(n.max(1) as u64).max(1));
    let mut tr = stride.map(|_| crate::sim::trace::Trace::default());
    let mut i = 0u64;
    // Sample `i` at `t` with drive force `f`, stretch `z` and mean velocity `v`.
    let mut finite = true;
    let mut record = |i: u64, t: f64, f: f64, z: f64, v: f64| {
        an.push(t, f, v);
        finite &= f.is_finite() && v.is_finite();
        if t >= window {
            seen = (seen.0.min(v), seen.1.max(v));
            let h = &mut halves[usize::from(t >= mid)];
            *h = (h.0.min(f), h.1.max(f));
        }
        if let (Some(tr), Some(k)) = (tr.as_mut(), stride)
            && i.is_multiple_of(k)
        {
            tr.push_slow(t, f, p.v_d * t - z, p.v_d * t, v);
        }
    };
    let mut cycle = table.force(p.v_d).filter(|_| periodic).map(|level| {
        crate::cycle::LimitCycle::slow(p, level, dt, rtol, [sys.scale(0), sys.scale(1)])
    });
    let mut solver = Solver::new(Method::Radau5);
    let rep = solver.solve_until(&sys, Span::new(0.0, t_end, grid), &mut y, &opts, |t, y| {
        let f = p.k_d * y[0] + p.h_d * (p.v_d - y[1]);
        record(i, t, f, y[0], y[1]);
        i += 1;
        // Once periodic the integration ends here; the samples after it are the cycle's.
        !cycle
            .as_mut()
            .is_some_and(|c| c.push(t, f, &[p.v_d * t - y[0], y[1], 0.0]))
    });
    let continued_from = cycle.as_ref().and_then(|c| c.continued_from());
    if let Some(c) = cycle.as_ref()
        && rep.status == Status::Success
    {
        c.replay(&grid, i, t_end, |i, t, f, x| {
            record(i, t, f, p.v_d * t - x[0], x[1]);
        });
    }
    // A window that runs far past both the table and the fastest slip, or through non-finite
    // values, has diverged: no law holds it there.
    let reach = divergence_bound(p, table);
    let left_law = if !finite
        || !matches!(
            (seen.0.abs().max(seen.1.abs())).partial_cmp(&reach),
            Some(Ordering::Less | Ordering::Equal)
        ) {
        Some(f64::INFINITY)
    } else {
        (seen.0 <= seen.1)
            .then(|| table.first_invalid(seen.0, seen.1))
            .flatten()
    };
    let mut measures = an.finish();
    // The window's mean over its whole cycles: a full run ends where the window's mean agrees
    // with it (its early stop), while the slow run's window ends where its planned time does,
    // and a cut cycle biases the plain mean by up to 0.7 % (3000 Hz, v_a/v_d 0.4).
    if let Some(m) = an.cycle_mean(window) {
        measures.mean_force = m;
    }
    // The steady slide: stable where F_eff' + h_d > 0 (the linearised slow model's damping);
    // reached where the end state lies on it, or settling onto it where no slip falls in the
    // window and the force's swing shrinks from the window's first half to its second (a
    // decaying approach: its settled level has no oscillation, as docs/model.md measures it).
    if let (Some(level), Some(slope)) = (table.force(p.v_d), table.slope(p.v_d)) {
        let nominal = 2.0 * (p.f_s - p.f_c);
        // A repeating cycle is no slide, wherever the run stopped on it.
        let on_slide = continued_from.is_none()
            && (y[1] - p.v_d).abs() <= SLIDE_TOL * p.v_d
            && (p.k_d * y[0] - level).abs() <= SLIDE_TOL * nominal;
        let swing = |h: (f64, f64)| h.1 - h.0;
        let settling = measures.cycles == 0
            && (swing(halves[1]) <= 0.9 * swing(halves[0])
                || swing(halves[1]) <= SLIDE_TOL * nominal);
        if rep.status == Status::Success && slope + p.h_d > 0.0 && (on_slide || settling) {
            measures.mean_force = level;
            // No slip in the window and the slide reached: the settled level carries no
            // oscillation (docs/model.md: dF about the settled level, never the approach to it).
            if measures.cycles == 0 {
                measures.d_f = 0.0;
                measures.d_f_stderr = 0.0;
            }
        }
    }
    Ok(SlowRun {
        measures,
        status: rep.status,
        stats: rep.stats,
        trace: tr,
        left_law,
        continued_from,
    })
}
