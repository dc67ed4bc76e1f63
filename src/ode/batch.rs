//! The batch integrator: `W` integrations of one kind of small system stepped side by side,
//! one per vector lane, by Dormand–Prince 5(4) (with envelope following where a job asks for
//! it).
//!
//! Each lane is an integration of its own: its own time, step size, controller history, accept
//! or reject, dense output, tolerances, envelope strobe, observer and end. Only the arithmetic
//! of an attempt (six right-hand sides, the stage combinations, the error norm, the dense
//! output's coefficients) runs on all lanes at once, through the code the scalar
//! [`Method::Dopri5`] runs on one point (`Stages::step`,
//! `dense_coefficients`, [`Lanewise::rhs_lanes`] generic over [`Real`]); everything between
//! two attempts is the scalar driver's own code (`Drive`), run lane by lane, and the step
//! controller is the scalar one (`Control`). So a job's result is bit for bit the result of
//! [`Solver::solve_envelope`](super::Solver::solve_envelope) with `Method::Dopri5` on the same
//! job alone, whatever the lane, the batch or the jobs beside it.
//!
//! A lane whose job ends takes the next job at once, so lanes idle only once the jobs run out.
//! Jobs whose system cannot run in these lanes (another dimension, or another
//! [`Lanewise::Shape`] than the systems in busy lanes) are integrated by the scalar solver in
//! their turn; [`Path`] says which served a job.
//!
//! The vector instruction set is found at run time (`pulp`: AVX2 and FMA where the machine has
//! them); without one the same generic code runs as scalar loops, with the same results.
// The kernels below step several arrays of one state (stages, weights, tolerances) with one
// index, as the method's equations are written.
#![allow(clippy::needless_range_loop)]

use super::dopri5::{Control, Eval, Judged, Powers, Stages, dense_coefficients, dense_value};
use super::lanes::{Lanes, Real};
use super::{Drive, Envelope, Method, OdeSystem, Options, OutputGrid, RunReport, Shared};
use super::{Solver, Span, Stats, StepOutcome, Stepper, Stepping};

impl<S: Lanewise> Lanewise for &S {
    type Pack<const W: usize> = S::Pack<W>;
    type Shape = S::Shape;
    fn shape(&self) -> S::Shape {
        (**self).shape()
    }
    fn pack<const W: usize>(&self, pack: &mut Self::Pack<W>, lane: usize) {
        (**self).pack(pack, lane);
    }
    #[inline(always)]
    fn forcing_lanes<const W: usize>(pack: &Self::Pack<W>, t: Lanes<W>) -> Lanes<W> {
        S::forcing_lanes(pack, t)
    }
    #[inline(always)]
    fn rhs_lanes<const W: usize>(
        pack: &Self::Pack<W>,
        t: Lanes<W>,
        forcing: Lanes<W>,
        y: &[Lanes<W>],
        dy: &mut [Lanes<W>],
    ) {
        S::rhs_lanes(pack, t, forcing, y, dy);
    }
}

/// A system whose right-hand side can also be evaluated for `W` systems of its kind at once.
pub trait Lanewise: OdeSystem {
    /// The coefficients of `W` systems, one per lane.
    type Pack<const W: usize>: Default;
    /// What the systems in one batch's lanes must share besides their dimension (the terms of
    /// their right-hand side): a system whose shape differs from that of the systems in busy
    /// lanes runs on the scalar path.
    type Shape: Copy + PartialEq;
    /// This system's shape.
    fn shape(&self) -> Self::Shape;
    /// Puts this system's coefficients in lane `lane` of `pack`.
    fn pack<const W: usize>(&self, pack: &mut Self::Pack<W>, lane: usize);
    /// The part of the right-hand sides of the `W` systems of `pack` that depends on time
    /// alone, each at its own time (the rig's substrate velocity): computed for all stages of
    /// an attempt before the first.
    fn forcing_lanes<const W: usize>(pack: &Self::Pack<W>, t: Lanes<W>) -> Lanes<W>;
    /// The right-hand sides of the `W` systems of `pack`, each at its own time, given
    /// [`Lanewise::forcing_lanes`] there: the same operations, lane by lane, as
    /// [`OdeSystem::rhs`] of each.
    fn rhs_lanes<const W: usize>(
        pack: &Self::Pack<W>,
        t: Lanes<W>,
        forcing: Lanes<W>,
        y: &[Lanes<W>],
        dy: &mut [Lanes<W>],
    );
}

/// What a job's output samples go to: called at every output time, as the closure of
/// [`Solver::solve_until`](super::Solver::solve_until) is (false ends the job). Closures are
/// observers; a type of the caller's own comes back with its job, whatever it gathered.
pub trait Observe {
    fn observe(&mut self, t: f64, y: &[f64]) -> bool;
}

impl<F: FnMut(f64, &[f64]) -> bool> Observe for F {
    fn observe(&mut self, t: f64, y: &[f64]) -> bool {
        self(t, y)
    }
}

/// One integration handed to [`solve_batch`]: the problem, its options and its observer, and,
/// when it comes back, its final state.
pub struct Job<S, O> {
    /// The caller's name for the job (a sweep point's index, say).
    pub id: usize,
    /// The system.
    pub sys: S,
    /// Span.
    pub t0: f64,
    pub t1: f64,
    /// Initial state; the state reached when the job comes back.
    pub y: Vec<f64>,
    /// Options (validated by the caller).
    pub opts: Options,
    /// Output times.
    pub grid: OutputGrid,
    /// Envelope following, if any (`grid.start == t0`).
    pub envelope: Option<Envelope>,
    /// Takes the output samples.
    pub observe: O,
}

/// Which integrator served a job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Path {
    /// A vector lane of the batch integrator.
    Lanes,
    /// The scalar Dormand–Prince (a system that cannot run in lanes).
    Scalar,
}

/// Lanes of the batch integrator on this machine: 4 (AVX2 holds four doubles; without it the
/// same width runs as scalar loops).
pub const WIDTH: usize = 4;

/// The vector instructions the lanes run on, as found on this machine at run time.
pub fn vector_set() -> &'static str {
    // `pulp` names its levels V3 (AVX2 and FMA) and V4 (AVX-512); anything else runs the
    // portable scalar loops.
    let level = format!("{:?}", pulp::Arch::new());
    if level.starts_with("V4") {
        "AVX-512 (x86-64-v4)"
    } else if level.starts_with("V3") {
        "AVX2 and FMA (x86-64-v3)"
    } else {
        "no vector set found: portable scalar loops"
    }
}

/// Largest state dimension [`solve_batch_dim`] runs in lanes; larger systems (a rig with many
/// extensions at once) run on the scalar path. Why 8: a fourth-order sensor is the base
/// model's three states and four of its own, and with ageing or a lag eight; each dimension
/// served is one more copy of the attempt in the build.
pub const MAX_LANE_DIM: usize = 8;

/// [`solve_batch`] for systems of `dim` states, the dimension chosen at run time (3 to
/// [`MAX_LANE_DIM`]; jobs of any other dimension are served by the scalar path).
pub fn solve_batch_dim<S, O>(
    dim: usize,
    jobs: impl IntoIterator<Item = Job<S, O>>,
    done: impl FnMut(Job<S, O>, RunReport, Path),
) where
    S: Lanewise,
    O: Observe,
{
    match dim {
        4 => solve_batch::<S, O, 4>(jobs, done),
        5 => solve_batch::<S, O, 5>(jobs, done),
        6 => solve_batch::<S, O, 6>(jobs, done),
        7 => solve_batch::<S, O, 7>(jobs, done),
        8 => solve_batch::<S, O, 8>(jobs, done),
        _ => solve_batch::<S, O, 3>(jobs, done),
    }
}

/// Integrates every job of `jobs` with Dormand–Prince 5(4), `WIDTH` at a time, and hands each
/// back to `done` with its report and the path that served it, in the order the jobs end.
pub fn solve_batch<S, O, const N: usize>(
    jobs: impl IntoIterator<Item = Job<S, O>>,
    mut done: impl FnMut(Job<S, O>, RunReport, Path),
) where
    S: Lanewise,
    O: Observe,
{
    let arch = pulp::Arch::new();
    let mut jobs = jobs.into_iter();
    let mut b = Batch::<WIDTH, N>::new();
    let mut pack = S::Pack::<WIDTH>::default();
    let mut lanes: [Option<Lane<S, O>>; WIDTH] = std::array::from_fn(|_| None);
    let mut scalar: Option<Solver> = None;
    let mut shape: Option<S::Shape> = None;
    loop {
        // Every idle lane takes the next job that still needs a step.
        for i in 0..WIDTH {
            loop {
                if lanes[i].is_none() {
                    let Some(mut job) = jobs.next() else { break };
                    if lanes.iter().all(|l| l.is_none()) {
                        shape = Some(job.sys.shape());
                    }
                    if job.sys.dim() != N || shape != Some(job.sys.shape()) {
                        let s = scalar.get_or_insert_with(|| Solver::new(Method::Dopri5));
                        let r = s.solve_envelope(
                            &job.sys,
                            Span::new(job.t0, job.t1, job.grid),
                            &mut job.y,
                            &job.opts,
                            job.envelope.as_ref(),
                            |t, y| job.observe.observe(t, y),
                        );
                        done(job, r, Path::Scalar);
                        continue;
                    }
                    job.sys.pack(&mut pack, i);
                    match Lane::begin(job, &mut b, i) {
                        Ok(l) => lanes[i] = Some(l),
                        Err(b) => {
                            let (job, r) = *b;
                            done(job, r, Path::Lanes);
                            continue;
                        }
                    }
                }
                let l = lanes[i].as_mut().expect("a lane with a job");
                let mut view = LaneView { b: &mut b, i };
                match l.drive.before(&mut view, &mut l.job.y) {
                    None => break,
                    Some(r) => {
                        let l = lanes[i].take().expect("a lane with a job");
                        done(l.job, r, Path::Lanes);
                    }
                }
            }
        }
        let active: [bool; WIDTH] = std::array::from_fn(|i| lanes[i].is_some());
        if !active.iter().any(|a| *a) {
            return;
        }
        let judged = arch.dispatch(Attempt::<S, WIDTH, N> {
            b: &mut b,
            pack: &pack,
            active,
        });
        for (i, slot) in lanes.iter_mut().enumerate() {
            let Some(l) = slot.as_mut() else { continue };
            let outcome = l.count(judged[i]);
            let mut view = LaneView { b: &mut b, i };
            let Lane {
                job,
                drive,
                shared,
                inner,
            } = l;
            let Job {
                sys,
                y,
                opts,
                envelope,
                observe,
                ..
            } = job;
            let st = Stepping {
                opts: inner,
                env: envelope.as_ref().map(|e| (e, &*opts)),
            };
            let mut observe = |t: f64, y: &[f64]| observe.observe(t, y);
            let end = match outcome {
                StepOutcome::Accepted => {
                    drive.accepted(&mut view, sys, st, &mut observe, shared, y)
                }
                other => drive.unaccepted(&mut view, other, y),
            };
            if let Some(r) = end {
                let l = slot.take().expect("a lane with a job");
                done(l.job, r, Path::Lanes);
            }
        }
    }
}

/// A job in a lane, with its driver state and buffers.
struct Lane<S, O> {
    job: Job<S, O>,
    drive: Drive,
    shared: Shared,
    /// The options integrated with (the envelope's inner tolerance where it has one).
    inner: Options,
}

/// A job that ended before its first step, with its report.
type EndedAtStart<S, O> = Box<(Job<S, O>, RunReport)>;

impl<S: Lanewise, O: Observe> Lane<S, O> {
    /// Starts `job` in lane `i` (its coefficients already packed); `Err` where it ends before
    /// a step.
    fn begin<const W: usize, const N: usize>(
        mut job: Job<S, O>,
        b: &mut Batch<W, N>,
        i: usize,
    ) -> Result<Self, EndedAtStart<S, O>> {
        let mut shared = Shared::sized(N);
        let inner = shared.prepare(&job.sys, &job.opts, job.envelope.as_ref());
        let mut view = LaneView { b, i };
        match Drive::begin(
            &mut view,
            &job.sys,
            Span::new(job.t0, job.t1, job.grid),
            &job.y,
            &inner,
            &mut |t, y| job.observe.observe(t, y),
            &mut shared,
        ) {
            Ok(drive) => Ok(Lane {
                job,
                drive,
                shared,
                inner,
            }),
            Err(r) => Err(Box::new((job, r))),
        }
    }

    /// Counts an attempt in the lane's statistics, as the scalar method does.
    fn count(&mut self, judged: Option<bool>) -> StepOutcome {
        let st = &mut self.drive.stats;
        st.rhs_evals += 6;
        match judged {
            Some(true) => {
                st.steps += 1;
                StepOutcome::Accepted
            }
            _ => {
                st.rejected += 1;
                StepOutcome::Rejected
            }
        }
    }
}

/// The Dormand–Prince state of `W` integrations of dimension `N`, one per lane.
struct Batch<const W: usize, const N: usize> {
    t: Lanes<W>,
    h: Lanes<W>,
    h_prev: [f64; W],
    y: [Lanes<W>; N],
    k: [[Lanes<W>; N]; 7],
    ynew: [Lanes<W>; N],
    ytmp: [Lanes<W>; N],
    rc: [[Lanes<W>; N]; 5],
    rc_new: [[Lanes<W>; N]; 5],
    atol: [Lanes<W>; N],
    rtol: Lanes<W>,
    control: [Control; W],
    /// Each lane's state as one slice ([`Stepper::y`]).
    y_lane: [[f64; N]; W],
}

impl<const W: usize, const N: usize> Batch<W, N> {
    fn new() -> Self {
        let z = [Lanes::<W>::default(); N];
        Batch {
            t: Lanes::default(),
            h: Lanes::splat(1.0),
            h_prev: [1.0; W],
            y: z,
            k: [z; 7],
            ynew: z,
            ytmp: z,
            rc: [z; 5],
            rc_new: [z; 5],
            atol: [Lanes::splat(1.0); N],
            rtol: Lanes::splat(1.0),
            control: [Control::new(); W],
            y_lane: [[0.0; N]; W],
        }
    }

    /// One attempt in every lane (idle ones included: their results are dropped). For each
    /// active lane `Some(accepted)`, with the lane advanced where accepted.
    #[inline(always)]
    fn attempt<S: Lanewise>(&mut self, pack: &S::Pack<W>, active: [bool; W]) -> [Option<bool>; W] {
        let [k1, k2, k3, k4, k5, k6, k7] = &mut self.k;
        let ks = Stages {
            k1: &*k1,
            k2,
            k3,
            k4,
            k5,
            k6,
            k7,
            ynew: &mut self.ynew,
            ytmp: &mut self.ytmp,
        };
        let (t, h) = (self.t, self.h);
        let err = ks.step(&InLanes::<S, W>(pack), t, h, &self.y, &self.atol, self.rtol);
        let mut out = [None; W];
        let mut acc = [false; W];
        // The controller's powers of the error in every lane at once; the rest per lane.
        let pw = Powers::of(err);
        for i in 0..W {
            if !active[i] {
                continue;
            }
            let pw_i = Powers {
                fac11: pw.fac11.get(i),
                facold_beta: pw.facold_beta.get(i),
            };
            match self.control[i].judge_with(err.get(i), h.get(i), pw_i) {
                Judged::Accepted(h_next) => {
                    acc[i] = true;
                    self.h.set(i, h_next);
                }
                Judged::Rejected(h_next) => self.h.set(i, h_next),
            }
            out[i] = Some(acc[i]);
        }
        if !acc.iter().any(|a| *a) {
            return out;
        }
        let [k1, _, k3, k4, k5, k6, k7] = &self.k;
        let [r0, r1, r2, r3, r4] = &mut self.rc_new;
        dense_coefficients(
            h,
            &self.y,
            &self.ynew,
            [k1, k3, k4, k5, k6, k7],
            [r0, r1, r2, r3, r4],
        );
        let acc_mask: [u64; W] = std::array::from_fn(|i| if acc[i] { !0 } else { 0 });
        for j in 0..N {
            for c in 0..5 {
                self.rc[c][j] = Lanes::select(acc_mask, self.rc_new[c][j], self.rc[c][j]);
            }
            self.y[j] = Lanes::select(acc_mask, self.ynew[j], self.y[j]);
            self.k[0][j] = Lanes::select(acc_mask, self.k[6][j], self.k[0][j]);
        }
        for i in 0..W {
            if acc[i] {
                self.h_prev[i] = h.get(i);
                self.t.set(i, t.get(i) + h.get(i));
                for j in 0..N {
                    self.y_lane[i][j] = self.y[j].get(i);
                }
            }
        }
        out
    }
}

/// The right-hand sides of a pack of systems.
struct InLanes<'a, S: Lanewise, const W: usize>(&'a S::Pack<W>);

impl<S: Lanewise, const W: usize> Eval<Lanes<W>> for InLanes<'_, S, W> {
    type Forcing = Lanes<W>;
    #[inline(always)]
    fn forcing(&self, t: Lanes<W>) -> Lanes<W> {
        S::forcing_lanes(self.0, t)
    }
    #[inline(always)]
    fn eval(&self, t: Lanes<W>, forcing: Lanes<W>, y: &[Lanes<W>], dy: &mut [Lanes<W>]) {
        S::rhs_lanes(self.0, t, forcing, y, dy);
    }
}

/// [`Batch::attempt`] compiled for the machine's vector instruction set.
struct Attempt<'a, S: Lanewise, const W: usize, const N: usize> {
    b: &'a mut Batch<W, N>,
    pack: &'a S::Pack<W>,
    active: [bool; W],
}

impl<S: Lanewise, const W: usize, const N: usize> pulp::WithSimd for Attempt<'_, S, W, N> {
    type Output = [Option<bool>; W];
    #[inline(always)]
    fn with_simd<Sd: pulp::Simd>(self, _simd: Sd) -> Self::Output {
        self.b.attempt::<S>(self.pack, self.active)
    }
}

/// Lane `i` of a batch seen as a scalar method, for the driver's code between attempts.
struct LaneView<'a, const W: usize, const N: usize> {
    b: &'a mut Batch<W, N>,
    i: usize,
}

impl<const W: usize, const N: usize> Stepper for LaneView<'_, W, N> {
    const ORDER: f64 = 4.0;

    fn set_tolerances(&mut self, rtol: f64, atol: &[f64]) {
        self.b.rtol.set(self.i, rtol);
        for j in 0..N {
            self.b.atol[j].set(self.i, atol[j]);
        }
    }

    fn start<Sy: OdeSystem>(&mut self, sys: &Sy, t0: f64, y0: &[f64], h: f64, st: &mut Stats) {
        let (b, i) = (&mut *self.b, self.i);
        b.t.set(i, t0);
        b.h.set(i, h);
        b.h_prev[i] = h;
        let mut k1 = [0.0; N];
        sys.rhs(t0, y0, &mut k1);
        st.rhs_evals += 1;
        for j in 0..N {
            b.y[j].set(i, y0[j]);
            b.k[0][j].set(i, k1[j]);
            b.rc[0][j].set(i, y0[j]);
            for c in 1..5 {
                b.rc[c][j].set(i, 0.0);
            }
            b.y_lane[i][j] = y0[j];
        }
        b.control[i] = Control::new();
    }

    fn t(&self) -> f64 {
        self.b.t.get(self.i)
    }
    fn y(&self) -> &[f64] {
        &self.b.y_lane[self.i]
    }
    fn h(&self) -> f64 {
        self.b.h.get(self.i)
    }
    fn set_h(&mut self, h: f64) {
        self.b.h.set(self.i, h);
    }

    /// Never called: the lanes attempt together ([`Batch::attempt`]).
    fn attempt<Sy: OdeSystem>(&mut self, _sys: &Sy, _st: &mut Stats) -> StepOutcome {
        unreachable!("a lane's attempt is the batch's")
    }

    fn dense(&self, t: f64, out: &mut [f64]) {
        let (b, i) = (&*self.b, self.i);
        for j in 0..N {
            let rc = std::array::from_fn(|c| b.rc[c][j].get(i));
            out[j] = dense_value(t, b.t.get(i), b.h_prev[i], rc);
        }
    }
}
