//! Initial-value-problem solvers for small stiff systems.
//!
//! The pieces are kept apart, as in RADAU5, SUNDIALS and diffsol:
//! - the **problem**: an [`OdeSystem`] (right-hand side and Jacobian) plus an initial state and a
//!   time span, given to [`Solver::solve`];
//! - the **method** and its knobs: [`Method`];
//! - the **workspace**: buffers and controller history, allocated once per [`Solver`] and reused
//!   across runs (the inner loop allocates nothing);
//! - the per-call **options**: [`Options`] (tolerances, step limits) and the output grid
//!   [`OutputGrid`].
//!
//! Every run returns a [`RunReport`]: a [`Status`] and [`Stats`].
//!
//! # Error norm
//! All methods measure a local error estimate `e` (and Newton increments) in the same weighted
//! root-mean-square norm
//!
//! ```text
//! ‖e‖ = sqrt( (1/n) Σ_i ( e_i / sc_i )² ),   sc_i = atol · w_i + rtol · max(|y_i|, |ŷ_i|)
//! ```
//!
//! where `y` is the state at the start of the step, `ŷ` the proposed state at its end (implicit
//! methods use `ŷ = y`, since the scale must be fixed before the Newton iteration), and
//! `w_i = OdeSystem::scale(i)` is the component's characteristic size (1 unless the system says
//! otherwise). A step is accepted when `‖e‖ ≤ 1`.

mod auto;
pub mod batch;
mod dopri5;
mod envelope;
pub mod lanes;
mod linalg;
mod options;
mod radau5;
mod rodas;

pub use linalg::{DenseLu, LuError};
pub use options::{Envelope, OptionError, Options};

use std::fmt;

/// A system of ordinary differential equations `y' = f(t, y)` of fixed dimension.
///
/// Implementations must not allocate in [`rhs`](Self::rhs) or [`jacobian`](Self::jacobian):
/// both run in the integrators' inner loops.
pub trait OdeSystem {
    /// Number of state components `n` (at least 1).
    fn dim(&self) -> usize;

    /// Right-hand side: writes `f(t, y)` into `dy` (both of length `n`).
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]);

    /// Jacobian `∂f/∂y` at `(t, y)`, written row-major into `jac` (length `n·n`):
    /// `jac[i * n + j] = ∂f_i / ∂y_j`.
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]);

    /// Partial time derivative `∂f/∂t` at `(t, y)`, needed by Rosenbrock methods.
    ///
    /// The default is a one-sided finite difference with step `√ε·max(|t|, 1e-3)`; `scratch` has
    /// length `n`. Systems with an explicit time dependence should override it.
    fn time_derivative(&self, t: f64, y: &[f64], dfdt: &mut [f64], scratch: &mut [f64]) {
        fd_time_derivative(self, t, y, dfdt, scratch);
    }

    /// Characteristic size of component `i`, in its own unit (default 1).
    ///
    /// The absolute tolerance of component `i` is `atol · scale(i)`, so one dimensionless `atol`
    /// serves components of very different magnitude (a displacement of 1e-3 m beside a contact
    /// deformation of 1e-7 m).
    fn scale(&self, _i: usize) -> f64 {
        1.0
    }

    /// Number `k` of identical diagonal blocks the Newton iteration may use for the Jacobian
    /// (default 1: the whole matrix). With `k > 1` (and `n` a multiple of `k`), Radau IIA factorises
    /// only the leading `(n/k) × (n/k)` block of [`jacobian`](Self::jacobian) and solves each of
    /// the `k` consecutive slices of the state with it: the iteration matrix of a system and its
    /// forward sensitivities stored column by column, where the simplified Newton iteration drops
    /// the second derivatives. The step's result and error control are those of the whole
    /// system; only the linear algebra shrinks (by `k³` in the factorisation).
    fn jacobian_blocks(&self) -> usize {
        1
    }
}

/// A borrowed system is the system (so that jobs of the batch integrator can borrow theirs).
impl<S: OdeSystem + ?Sized> OdeSystem for &S {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    #[inline(always)]
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        (**self).rhs(t, y, dy)
    }
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) {
        (**self).jacobian(t, y, jac)
    }
    fn time_derivative(&self, t: f64, y: &[f64], dfdt: &mut [f64], scratch: &mut [f64]) {
        (**self).time_derivative(t, y, dfdt, scratch)
    }
    fn scale(&self, i: usize) -> f64 {
        (**self).scale(i)
    }
    fn jacobian_blocks(&self) -> usize {
        (**self).jacobian_blocks()
    }
}

/// `∂f/∂t` by a forward difference in `t` (the default of [`OdeSystem::time_derivative`],
/// callable by systems that have an analytic form only for some configurations).
pub fn fd_time_derivative<S: OdeSystem + ?Sized>(
    sys: &S,
    t: f64,
    y: &[f64],
    dfdt: &mut [f64],
    scratch: &mut [f64],
) {
    let dt = f64::EPSILON.sqrt() * t.abs().max(1e-3);
    sys.rhs(t, y, scratch);
    sys.rhs(t + dt, y, dfdt);
    for (d, s) in dfdt.iter_mut().zip(scratch.iter()) {
        *d = (*d - *s) / dt;
    }
}

/// Integration method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Radau IIA, 3 stages, order 5, L-stable, with the simplified Newton iteration, Jacobian
    /// reuse, the predictive (Gustafsson) step controller and a continuous extension of order 3
    /// (Hairer & Wanner, *Solving ODEs II*, Sect. IV.8; the RADAU5 code).
    Radau5,
    /// Rodas4: a 6-stage L-stable, stiffly accurate Rosenbrock method of order 4(3)
    /// (Hairer & Wanner, Sect. VI.4) with a cubic Hermite continuous extension.
    Rodas4,
    /// Dormand–Prince 5(4), explicit, with the PI step controller and the 4th-order continuous
    /// extension (Hairer, Nørsett & Wanner, *Solving ODEs I*, Sect. II.5; the DOPRI5 code).
    Dopri5,
    /// Dopri5 while the step is set by accuracy, Radau5 while it is set by stability: DOPRI5's
    /// stiffness estimate `h λ̃` above 2.5 on 16 of the last 32 accepted steps hands over to
    /// Radau5, which hands back after 20 steps, a wait that doubles (up to 2560) each time
    /// Dopri5 finds the problem still stiff within 100 steps. Without stiffness it is Dopri5,
    /// step for step; under envelope following it stays Dopri5.
    Auto,
}

impl Method {
    /// All methods, in the order tables and benchmarks list them.
    pub const ALL: [Method; 4] = [Method::Radau5, Method::Rodas4, Method::Dopri5, Method::Auto];

    /// The name used on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Method::Radau5 => "radau5",
            Method::Rodas4 => "rodas4",
            Method::Dopri5 => "dopri5",
            Method::Auto => "auto",
        }
    }

    /// Whether the method is implicit (uses the Jacobian; `auto` does while the problem is
    /// stiff).
    pub fn is_implicit(self) -> bool {
        !matches!(self, Method::Dopri5)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                format!("unknown solver '{s}': allowed are radau5, rodas4, dopri5, auto")
            })
    }
}

/// Times at which the solution is reported, by dense output: `t_k = start + k · step` for
/// `k = 0 .. count` (computed by index, never by accumulating `step`). Times outside the span
/// are skipped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputGrid {
    /// First output time.
    pub start: f64,
    /// Spacing (> 0).
    pub step: f64,
    /// Number of output times.
    pub count: u64,
}

/// The span of one integration and the times it reports at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    /// Start of the integration \[s\].
    pub t0: f64,
    /// End of the integration \[s\] (earlier where the observer stops it).
    pub t1: f64,
    /// The output times, by dense output ([`OutputGrid::NONE`] for none).
    pub grid: OutputGrid,
}

impl Span {
    /// From `t0` to `t1`, reporting at the times of `grid` inside.
    pub fn new(t0: f64, t1: f64, grid: OutputGrid) -> Self {
        Span { t0, t1, grid }
    }
}

impl OutputGrid {
    /// No output at all.
    pub const NONE: OutputGrid = OutputGrid {
        start: 0.0,
        step: 1.0,
        count: 0,
    };

    /// `count` equally spaced times from `t0` to `t1` inclusive.
    pub fn linspace(t0: f64, t1: f64, count: u64) -> Self {
        let step = if count > 1 {
            (t1 - t0) / (count - 1) as f64
        } else {
            1.0
        };
        OutputGrid {
            start: t0,
            step,
            count,
        }
    }

    /// The `k`-th output time.
    #[inline]
    pub fn time(&self, k: u64) -> f64 {
        self.start + k as f64 * self.step
    }
}

/// How a run ended.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Reached the end of the span.
    #[default]
    Success,
    /// The step size fell below the round-off limit of `t`.
    StepTooSmall,
    /// `Options::max_steps` steps were taken.
    MaxSteps,
    /// The Newton iteration failed repeatedly (or the iteration matrix stayed singular).
    NewtonFailure,
    /// The state or the right-hand side became NaN or infinite.
    NonFinite,
    /// A run of the rig (never the integrator itself) reached its longest simulated time with
    /// the smoothed force still on its way to its level (docs/model.md: the measures describe the
    /// settled state); the measures are those of its last window.
    Unsettled,
    /// Stopped on request ([`crate::interrupt`]): no measures, never recorded by a sweep.
    Interrupted,
}

impl Status {
    /// The name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Status::Success => "success",
            Status::StepTooSmall => "step_too_small",
            Status::MaxSteps => "max_steps",
            Status::NewtonFailure => "newton_failure",
            Status::NonFinite => "non_finite",
            Status::Unsettled => "unsettled",
            Status::Interrupted => "interrupted",
        }
    }

    /// A small integer code for files: 0 success, 1 step too small, 2 max steps,
    /// 3 Newton failure, 4 non-finite, 5 unsettled, 6 interrupted.
    pub fn code(self) -> i32 {
        self as i32
    }

    /// Whether a run with this status has measures: it succeeded, or it is
    /// [`Unsettled`](Status::Unsettled) (measured, flagged).
    pub fn has_measures(self) -> bool {
        matches!(self, Status::Success | Status::Unsettled)
    }

    /// The status with the given [`code`](Self::code).
    pub fn from_code(c: i32) -> Option<Status> {
        [
            Status::Success,
            Status::StepTooSmall,
            Status::MaxSteps,
            Status::NewtonFailure,
            Status::NonFinite,
            Status::Unsettled,
            Status::Interrupted,
        ]
        .into_iter()
        .find(|s| s.code() == c)
    }
}

/// Work done by one run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Stats {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps (error test or Newton failure).
    pub rejected: u64,
    /// Right-hand-side evaluations (Jacobians by finite differences not counted here).
    pub rhs_evals: u64,
    /// Jacobian evaluations.
    pub jac_evals: u64,
    /// LU factorisations (for Radau5 a real and a complex one count as two).
    pub lu_decomps: u64,
    /// Newton iterations (Radau5 only).
    pub newton_iters: u64,
    /// Forcing periods skipped by envelope following (see [`Envelope`]); 0 without it.
    #[serde(default)]
    pub skipped_periods: u64,
}

impl std::ops::AddAssign for Stats {
    fn add_assign(&mut self, o: Stats) {
        for c in Counter::ALL {
            *c.slot(self) += c.of(&o);
        }
    }
}

/// A counter of [`Stats`]: its one definition (name, meaning, field), from which the journal,
/// the sweep file's datasets and the sums of work are all written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Counter {
    /// [`Stats::steps`].
    Steps,
    /// [`Stats::rejected`].
    Rejected,
    /// [`Stats::rhs_evals`].
    RhsEvals,
    /// [`Stats::jac_evals`].
    JacEvals,
    /// [`Stats::lu_decomps`].
    LuDecomps,
    /// [`Stats::newton_iters`].
    NewtonIters,
    /// [`Stats::skipped_periods`].
    SkippedPeriods,
}

impl Counter {
    /// Every counter of [`Stats`], in the order files write them.
    pub const ALL: [Counter; 7] = [
        Counter::Steps,
        Counter::Rejected,
        Counter::RhsEvals,
        Counter::JacEvals,
        Counter::LuDecomps,
        Counter::NewtonIters,
        Counter::SkippedPeriods,
    ];

    /// Its name in files (the field's).
    pub fn name(self) -> &'static str {
        match self {
            Counter::Steps => "steps",
            Counter::Rejected => "rejected",
            Counter::RhsEvals => "rhs_evals",
            Counter::JacEvals => "jac_evals",
            Counter::LuDecomps => "lu_decomps",
            Counter::NewtonIters => "newton_iters",
            Counter::SkippedPeriods => "skipped_periods",
        }
    }

    /// What it counts, as the files describe it.
    pub fn doc(self) -> &'static str {
        match self {
            Counter::Steps => "accepted steps",
            Counter::Rejected => "rejected steps",
            Counter::RhsEvals => "right-hand-side evaluations",
            Counter::JacEvals => "Jacobian evaluations",
            Counter::LuDecomps => "LU factorisations",
            Counter::NewtonIters => "Newton iterations of the implicit methods",
            Counter::SkippedPeriods => "vibration periods jumped by envelope following",
        }
    }

    /// The counter named `name`, if any.
    pub fn from_name(name: &str) -> Option<Counter> {
        Counter::ALL.into_iter().find(|c| c.name() == name)
    }

    /// Its value in `s`.
    pub fn of(self, s: &Stats) -> u64 {
        match self {
            Counter::Steps => s.steps,
            Counter::Rejected => s.rejected,
            Counter::RhsEvals => s.rhs_evals,
            Counter::JacEvals => s.jac_evals,
            Counter::LuDecomps => s.lu_decomps,
            Counter::NewtonIters => s.newton_iters,
            Counter::SkippedPeriods => s.skipped_periods,
        }
    }

    /// Its field in `s`.
    pub fn slot(self, s: &mut Stats) -> &mut u64 {
        match self {
            Counter::Steps => &mut s.steps,
            Counter::Rejected => &mut s.rejected,
            Counter::RhsEvals => &mut s.rhs_evals,
            Counter::JacEvals => &mut s.jac_evals,
            Counter::LuDecomps => &mut s.lu_decomps,
            Counter::NewtonIters => &mut s.newton_iters,
            Counter::SkippedPeriods => &mut s.skipped_periods,
        }
    }
}

/// One [`Solver`] per method, each made when first asked for and kept across runs: a worker's
/// solvers where its runs ask for different methods.
#[derive(Default)]
pub struct Solvers {
    list: Vec<Solver>,
}

impl Solvers {
    /// The solver of method `m`.
    pub fn get(&mut self, m: Method) -> &mut Solver {
        match self.list.iter().position(|s| s.method() == m) {
            Some(i) => &mut self.list[i],
            None => {
                self.list.push(Solver::new(m));
                self.list.last_mut().expect("just pushed")
            }
        }
    }
}

/// The outcome of one call to [`Solver::solve`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunReport {
    /// How the run ended.
    pub status: Status,
    /// The time reached (the end of the span on success).
    pub t: f64,
    /// Work done.
    pub stats: Stats,
    /// The step size the method proposed after its last step (units of t; 0 where it took
    /// none): a good `h0` for an integration that continues from where this one ended.
    pub h_next: f64,
}

/// Weighted RMS norm of `e` (see the module docs): the single definition all methods use, for
/// one point or one per lane.
#[inline(always)]
pub(crate) fn error_norm<T: lanes::Real>(e: &[T], y: &[T], y_new: &[T], atol: &[T], rtol: T) -> T {
    let mut sum = T::splat(0.0);
    for i in 0..e.len() {
        let sc = atol[i] + rtol * y[i].abs().max(y_new[i].abs());
        let q = e[i] / sc;
        sum = sum + q * q;
    }
    (sum / T::splat(e.len() as f64)).sqrt()
}

/// What a method's step attempt produced.
pub(crate) enum StepOutcome {
    /// Step accepted: the method advanced from `t` to `t + h` and its dense output covers it.
    Accepted,
    /// Step rejected; the method has chosen a smaller step and will retry.
    Rejected,
    /// The method gives up.
    Failed(Status),
}

/// Internal interface between the shared driver and one method.
pub(crate) trait Stepper {
    /// Order used to choose the initial step.
    const ORDER: f64;
    /// Sets the tolerances (per-component absolute ones already scaled).
    fn set_tolerances(&mut self, rtol: f64, atol: &[f64]);
    /// Prepares for a run from `(t0, y0)` with the given first step.
    fn start<S: OdeSystem>(&mut self, sys: &S, t0: f64, y0: &[f64], h: f64, st: &mut Stats);
    /// Current time and state.
    fn t(&self) -> f64;
    fn y(&self) -> &[f64];
    /// Step size of the next attempt.
    fn h(&self) -> f64;
    /// Caps the next attempt's step (to land on the end of the span).
    fn set_h(&mut self, h: f64);
    /// One attempt with step `h()`.
    fn attempt<S: OdeSystem>(&mut self, sys: &S, st: &mut Stats) -> StepOutcome;
    /// Dense output over the last accepted step, at `t` in `[t_prev, t]`.
    fn dense(&self, t: f64, out: &mut [f64]);
}

/// What the initial step is chosen for: the method's order, the tolerances and the largest step.
struct StepGuess<'a> {
    order: f64,
    atol: &'a [f64],
    rtol: f64,
    h_max: f64,
}

/// Chooses an initial step from the first two derivatives (Hairer, Nørsett & Wanner,
/// *Solving ODEs I*, Sect. II.4, algorithm of the HINIT routine).
fn initial_step<S: OdeSystem>(
    sys: &S,
    t0: f64,
    y0: &[f64],
    guess: &StepGuess<'_>,
    buf: &mut [Vec<f64>; 3],
    st: &mut Stats,
) -> f64 {
    let StepGuess {
        order,
        atol,
        rtol,
        h_max,
    } = *guess;
    let n = y0.len();
    let [f0, y1, f1] = buf;
    sys.rhs(t0, y0, f0);
    st.rhs_evals += 1;
    let d0 = error_norm(y0, y0, y0, atol, rtol);
    let d1 = error_norm(f0, y0, y0, atol, rtol);
    let mut h = if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    };
    h = h.min(h_max);
    for i in 0..n {
        y1[i] = y0[i] + h * f0[i];
    }
    sys.rhs(t0 + h, y1, f1);
    st.rhs_evals += 1;
    for i in 0..n {
        y1[i] = f1[i] - f0[i];
    }
    let d2 = error_norm(y1, y0, y0, atol, rtol) / h;
    let dm = d1.max(d2);
    let h1 = if dm <= 1e-15 {
        (h * 1e-3).max(1e-6)
    } else {
        (0.01 / dm).powf(1.0 / (order + 1.0))
    };
    (100.0 * h).min(h1).min(h_max)
}

/// A reusable integrator: the method plus its workspace. Create one per worker thread and call
/// [`Solver::solve`] for every run; buffers are allocated when the dimension changes only.
pub struct Solver {
    method: Method,
    dim: usize,
    ws: Workspace,
    shared: Shared,
}

/// The method's own buffers and controller state (made once per solver, so the size of the
/// largest variant does not matter).
#[allow(clippy::large_enum_variant)]
enum Workspace {
    Empty,
    Radau5(radau5::Radau5),
    Rodas4(rodas::Rodas4),
    Dopri5(dopri5::Dopri5),
    Auto(auto::Auto),
}

/// Buffers the driver needs whatever the method.
pub(crate) struct Shared {
    atol: Vec<f64>,
    out: Vec<f64>,
    init: [Vec<f64>; 3],
    strobe: envelope::Strobe,
}

impl Shared {
    /// Readies the buffers for an integration of `sys` with `opts` (under `envelope`, if any):
    /// the scaled absolute tolerances and the envelope's strobe. Returns the options to
    /// integrate with: the periods whose slopes feed a jump are integrated at the envelope's
    /// inner tolerance, stretches the envelope gives up on at the one asked for.
    pub(crate) fn prepare<S: OdeSystem>(
        &mut self,
        sys: &S,
        opts: &Options,
        envelope: Option<&Envelope>,
    ) -> Options {
        let n = sys.dim();
        let inner = match envelope {
            Some(e) => Options {
                rtol: e.inner_tolerance(opts.rtol),
                atol: e.inner_tolerance(opts.atol),
                ..opts.clone()
            },
            None => opts.clone(),
        };
        for i in 0..n {
            self.atol[i] = inner.atol * sys.scale(i);
        }
        if let Some(e) = envelope {
            let loosen = inner.rtol < opts.rtol || inner.atol < opts.atol;
            self.strobe
                .reset(n, e.period_samples, e.baseline, loosen, |i| sys.scale(i));
        }
        inner
    }

    /// Buffers for an `n`-dimensional system (the strobe sizes itself per run).
    pub(crate) fn sized(n: usize) -> Self {
        Shared {
            atol: vec![0.0; n],
            out: vec![0.0; n],
            init: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            strobe: envelope::Strobe::default(),
        }
    }
}

impl Solver {
    /// A solver for `method`; the workspace is sized on the first call.
    pub fn new(method: Method) -> Self {
        Solver {
            method,
            dim: 0,
            ws: Workspace::Empty,
            shared: Shared::sized(0),
        }
    }

    /// The method this solver runs.
    pub fn method(&self) -> Method {
        self.method
    }

    fn ensure(&mut self, n: usize) {
        if self.dim == n {
            return;
        }
        self.dim = n;
        self.ws = match self.method {
            Method::Radau5 => Workspace::Radau5(radau5::Radau5::new(n)),
            Method::Rodas4 => Workspace::Rodas4(rodas::Rodas4::new(n)),
            Method::Dopri5 => Workspace::Dopri5(dopri5::Dopri5::new(n)),
            Method::Auto => Workspace::Auto(auto::Auto::new(n)),
        };
        self.shared = Shared::sized(n);
    }

    /// Integrates `sys` from `(span.t0, y0)` to `span.t1 > span.t0`, calling `observe(t, y)` at
    /// every time of `span.grid` inside `[t0, t1]` (by dense output). On return `y0` holds the
    /// state reached.
    ///
    /// Options must be valid ([`Options::validate`]); invalid options panic in debug builds
    /// only, so validate once before a batch.
    pub fn solve<S: OdeSystem>(
        &mut self,
        sys: &S,
        span: Span,
        y0: &mut [f64],
        opts: &Options,
        mut observe: impl FnMut(f64, &[f64]),
    ) -> RunReport {
        self.solve_until(sys, span, y0, opts, |t, y| {
            observe(t, y);
            true
        })
    }

    /// As [`Solver::solve`], but `observe` returns whether to go on: the run ends with
    /// [`Status::Success`] at the first output time where it returns `false` (`RunReport::t`
    /// tells where), and `y0` holds the state there.
    pub fn solve_until<S: OdeSystem>(
        &mut self,
        sys: &S,
        span: Span,
        y0: &mut [f64],
        opts: &Options,
        observe: impl FnMut(f64, &[f64]) -> bool,
    ) -> RunReport {
        self.solve_envelope(sys, span, y0, opts, None, observe)
    }

    /// As [`Solver::solve_until`], with [`Envelope`] following when `envelope` is given: whole
    /// forcing periods are skipped where the stroboscopic samples drift smoothly
    /// ([`Stats::skipped_periods`] counts them). `span.grid` must start at `span.t0` with
    /// `envelope.period_samples` samples per period; `observe` sees every grid time, those
    /// inside a jump with the synthesised samples.
    pub fn solve_envelope<S: OdeSystem>(
        &mut self,
        sys: &S,
        span: Span,
        y0: &mut [f64],
        opts: &Options,
        envelope: Option<&Envelope>,
        mut observe: impl FnMut(f64, &[f64]) -> bool,
    ) -> RunReport {
        debug_assert!(opts.validate().is_ok());
        debug_assert!(envelope.is_none_or(|e| e.validate().is_ok() && span.grid.start == span.t0));
        let n = sys.dim();
        assert_eq!(y0.len(), n, "initial state has the wrong length");
        self.ensure(n);
        let inner = self.shared.prepare(sys, opts, envelope);
        if let Workspace::Auto(a) = &mut self.ws {
            a.switching = envelope.is_none();
        }
        let sh = &mut self.shared;
        let st = Stepping {
            opts: &inner,
            env: envelope.map(|e| (e, opts)),
        };
        let obs = &mut observe;
        match &mut self.ws {
            Workspace::Radau5(m) => drive(m, sys, span, y0, st, obs, sh),
            Workspace::Rodas4(m) => drive(m, sys, span, y0, st, obs, sh),
            Workspace::Dopri5(m) => drive(m, sys, span, y0, st, obs, sh),
            Workspace::Auto(m) => drive(m, sys, span, y0, st, obs, sh),
            Workspace::Empty => unreachable!("ensure() sized the workspace"),
        }
    }
}

/// The options a driver integrates with: `opts`, and under envelope following the envelope with
/// the run's own, looser options for the stretches it gives up on.
#[derive(Clone, Copy)]
pub(crate) struct Stepping<'a> {
    pub(crate) opts: &'a Options,
    pub(crate) env: Option<(&'a Envelope, &'a Options)>,
}

/// The driver shared by all methods: step control against the span, output by dense output,
/// step limits and status, with the options of `st`.
fn drive<M: Stepper, S: OdeSystem>(
    m: &mut M,
    sys: &S,
    span: Span,
    y0: &mut [f64],
    st: Stepping<'_>,
    observe: &mut impl FnMut(f64, &[f64]) -> bool,
    sh: &mut Shared,
) -> RunReport {
    let mut d = match Drive::begin(m, sys, span, y0, st.opts, observe, sh) {
        Ok(d) => d,
        Err(r) => return r,
    };
    loop {
        if let Some(r) = d.before(m, y0) {
            return r;
        }
        let outcome = m.attempt(sys, &mut d.stats);
        let end = match outcome {
            StepOutcome::Accepted => d.accepted(m, sys, st, observe, sh, y0),
            other => d.unaccepted(m, other, y0),
        };
        if let Some(r) = end {
            return r;
        }
    }
}

/// One integration between attempts: what [`drive`] keeps from one attempt to the next, so
/// that the batch integrator can drive each lane's integration with the same code, one attempt
/// at a time.
pub(crate) struct Drive {
    t1: f64,
    h_max: f64,
    grid: OutputGrid,
    /// Last grid index inside the span: jumps never pass it.
    g_last: u64,
    /// Next output index.
    k: u64,
    attempts: u64,
    max_steps: u64,
    pub(crate) stats: Stats,
}

impl Drive {
    /// Starts an integration of `sys` from `(t0, y0)` to `t1`: the outputs at `t0`, the first
    /// step and the method's start. `Err` with the report where the run ends before a step.
    pub(crate) fn begin<M: Stepper, S: OdeSystem>(
        m: &mut M,
        sys: &S,
        span: Span,
        y0: &[f64],
        opts: &Options,
        observe: &mut impl FnMut(f64, &[f64]) -> bool,
        sh: &mut Shared,
    ) -> Result<Drive, RunReport> {
        let Span { t0, t1, grid } = span;
        let Shared { atol, init, .. } = sh;
        m.set_tolerances(opts.rtol, atol);
        let mut stats = Stats::default();
        let early = |status, stats: &Stats| {
            Err(RunReport {
                status,
                t: t0,
                stats: *stats,
                h_next: 0.0,
            })
        };
        if y0.iter().any(|v| !v.is_finite()) {
            return early(Status::NonFinite, &stats);
        }
        // Output times before t0 are skipped; the one at t0 is the initial state.
        let mut k = 0u64;
        while k < grid.count && grid.time(k) < t0 {
            k += 1;
        }
        while k < grid.count && grid.time(k) == t0 {
            k += 1;
            if !observe(t0, y0) {
                return early(Status::Success, &stats);
            }
        }
        let span = t1 - t0;
        if span <= 0.0 {
            return early(Status::Success, &stats);
        }
        let h_max = opts.h_max.min(span);
        let h = if opts.h0 > 0.0 {
            opts.h0.min(h_max)
        } else {
            let guess = StepGuess {
                order: M::ORDER,
                atol,
                rtol: opts.rtol.max(1e-12),
                h_max,
            };
            initial_step(sys, t0, y0, &guess, init, &mut stats)
        };
        m.start(sys, t0, y0, h, &mut stats);
        let g_last = if grid.count == 0 {
            0
        } else {
            let mut g =
                (((t1 - grid.start) / grid.step).floor().max(0.0) as u64).min(grid.count - 1);
            while g > 0 && grid.time(g) > t1 {
                g -= 1;
            }
            g
        };
        Ok(Drive {
            t1,
            h_max,
            grid,
            g_last,
            k,
            attempts: 0,
            max_steps: opts.max_steps,
            stats,
        })
    }

    /// The report of a run that ends at `t` in state `y` (copied to `y0`).
    fn finish(&self, status: Status, t: f64, y0: &mut [f64], y: &[f64], h_next: f64) -> RunReport {
        y0.copy_from_slice(y);
        RunReport {
            status,
            t,
            stats: self.stats,
            h_next,
        }
    }

    /// Before an attempt: ends the run at the end of the span or at a step limit (`Some`, the
    /// final state in `y0`), else caps the method's next step to land on `t1`.
    #[inline]
    pub(crate) fn before<M: Stepper>(&mut self, m: &mut M, y0: &mut [f64]) -> Option<RunReport> {
        let t1 = self.t1;
        let t = m.t();
        let remaining = t1 - t;
        if remaining <= 1e-14 * t1.abs().max(1.0) {
            return Some(self.finish(Status::Success, t, y0, m.y(), m.h()));
        }
        let mut h = m.h().min(self.h_max);
        // Land on t1 exactly without a sliver step at the end.
        if h >= remaining {
            h = remaining;
        } else if h > 0.5 * remaining {
            h = 0.5 * remaining;
        }
        if 0.1 * h <= t.abs() * f64::EPSILON || h <= 0.0 {
            return Some(self.finish(Status::StepTooSmall, t, y0, m.y(), m.h()));
        }
        m.set_h(h);
        if self.attempts >= self.max_steps {
            return Some(self.finish(Status::MaxSteps, t, y0, m.y(), m.h()));
        }
        // A relaxed load every 256 attempts: microseconds apart, never measurable.
        if self.attempts.is_multiple_of(256) && crate::interrupt::requested() {
            return Some(self.finish(Status::Interrupted, t, y0, m.y(), m.h()));
        }
        self.attempts += 1;
        None
    }

    /// After an attempt that was not accepted: the end of the run where the method failed
    /// (`Some`, the final state in `y0`), else nothing (the method retries).
    pub(crate) fn unaccepted<M: Stepper>(
        &mut self,
        m: &mut M,
        outcome: StepOutcome,
        y0: &mut [f64],
    ) -> Option<RunReport> {
        match outcome {
            StepOutcome::Accepted | StepOutcome::Rejected => None,
            StepOutcome::Failed(status) => {
                let t = m.t();
                Some(self.finish(status, t, y0, m.y(), m.h()))
            }
        }
    }

    /// After an accepted step: the outputs it covers, envelope jumps, and the end of the run
    /// where the state went non-finite or the observer had enough (`Some`, the final state in
    /// `y0`).
    pub(crate) fn accepted<M: Stepper, S: OdeSystem>(
        &mut self,
        m: &mut M,
        sys: &S,
        st: Stepping<'_>,
        observe: &mut impl FnMut(f64, &[f64]) -> bool,
        sh: &mut Shared,
        y0: &mut [f64],
    ) -> Option<RunReport> {
        let Shared {
            atol, out, strobe, ..
        } = sh;
        let (grid, t1) = (self.grid, self.t1);
        let Stepping { opts, env } = st;
        {
            {
                let t_new = m.t();
                if m.y().iter().any(|v| !v.is_finite()) {
                    return Some(self.finish(Status::NonFinite, t_new, y0, m.y(), m.h()));
                }
                // The last step lands on t1 up to round-off; snap output times there.
                let t_hi = if (t_new - t1).abs() <= 1e-14 * t1.abs().max(1.0) {
                    t1
                } else {
                    t_new
                };
                while self.k < grid.count {
                    let tk = grid.time(self.k);
                    if tk > t_hi {
                        break;
                    }
                    m.dense(tk.min(t_new), out);
                    let g = self.k;
                    self.k += 1;
                    if !observe(tk, out) {
                        return Some(self.finish(Status::Success, tk, y0, out, m.h()));
                    }
                    let Some((e, own)) = env else { continue };
                    strobe.record(g, out);
                    if !g.is_multiple_of(e.period_samples) {
                        continue;
                    }
                    let jump = strobe.plan(g, e, (self.g_last - g) / e.period_samples);
                    if jump == 0 {
                        if let Some(loose) = strobe.take_change() {
                            let o = if loose { own } else { opts };
                            for (i, a) in atol.iter_mut().enumerate() {
                                *a = o.atol * sys.scale(i);
                            }
                            m.set_tolerances(o.rtol, atol);
                        }
                        continue;
                    }
                    // Skip `jump` periods: synthesise their samples, land on the envelope and
                    // restart the method there with the step it had.
                    let target = g + jump * e.period_samples;
                    for gj in g + 1..=target {
                        strobe.synth(gj, out);
                        let tj = grid.time(gj);
                        if !observe(tj, out) {
                            return Some(self.finish(Status::Success, tj, y0, out, m.h()));
                        }
                    }
                    strobe.landed(out);
                    self.stats.skipped_periods += jump;
                    let h = m.h();
                    m.start(sys, grid.time(target), out, h, &mut self.stats);
                    self.k = target + 1;
                    break;
                }
                None
            }
        }
    }
}
