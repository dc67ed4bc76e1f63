//! Dormand–Prince 5(4) with the PI step controller (β = 0.04) and the 4th-order continuous
//! extension of Dormand & Prince (Hairer, Nørsett & Wanner, *Solving ODEs I*, Sect. II.5–II.6;
//! the DOPRI5 code). First-same-as-last: 6 right-hand sides per accepted step.

use super::lanes::{self, Real};
use super::{OdeSystem, Stats, StepOutcome, Stepper, error_norm};

const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

const SAFE: f64 = 0.9;
/// `ln 1e-4`: the floor of `facold`, as a logarithm.
const LN_1E_4: f64 = -9.210_340_371_976_182;
const BETA: f64 = 0.04;
/// Step ratio bounds: `FAC1 ≤ h_new/h ≤ FAC2`.
const FAC1: f64 = 0.2;
const FAC2: f64 = 10.0;

/// The step-size controller of one integration: PI control with Lund stabilisation (the DOPRI5
/// code's), its history and whether the last attempt was rejected. Scalar in both paths: the
/// batch integrator keeps one per lane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Control {
    facold: f64,
    /// `facold^β`, computed once per accepted step.
    facold_beta: f64,
    reject: bool,
}

/// What [`Control::judge`] made of an attempt: the step is taken or not, and the next step size.
pub(crate) enum Judged {
    Accepted(f64),
    Rejected(f64),
}

impl Control {
    pub(crate) fn new() -> Self {
        Control {
            facold: 1e-4,
            facold_beta: lanes::exp(BETA * LN_1E_4),
            reject: false,
        }
    }

    /// Judges an attempt of step `h` with error norm `err`: accepted where `err ≤ 1`; a
    /// non-finite error cuts the step tenfold.
    #[inline]
    pub(crate) fn judge(&mut self, err: f64, h: f64) -> Judged {
        self.judge_with(err, h, Powers::of(err))
    }

    /// [`Control::judge`] with the error's powers computed already (for all lanes at once, in
    /// the batch integrator: they are the same numbers).
    #[inline]
    pub(crate) fn judge_with(&mut self, err: f64, h: f64, pw: Powers<f64>) -> Judged {
        if !err.is_finite() {
            self.reject = true;
            return Judged::Rejected(h * 0.1);
        }
        let fac = (pw.fac11 / self.facold_beta / SAFE).clamp(1.0 / FAC2, 1.0 / FAC1);
        if err <= 1.0 {
            self.facold = err.max(1e-4);
            self.facold_beta = pw.facold_beta;
            let mut hnew = h / fac;
            if self.reject {
                hnew = hnew.min(h);
            }
            self.reject = false;
            Judged::Accepted(hnew)
        } else {
            self.reject = true;
            Judged::Rejected(h / (1.0 / FAC1).min(pw.fac11 / SAFE))
        }
    }
}

/// The powers of an attempt's error norm the controller takes: `err^(1/5 − 0.75 β)` and
/// `max(err, 1e-4)^β`, both from one logarithm ([`lanes::ln`], [`lanes::exp`]: written once
/// for one number or for lanes, so that a lane's step sizes are its run's alone).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Powers<T> {
    pub(crate) fac11: T,
    pub(crate) facold_beta: T,
}

impl<T: Real> Powers<T> {
    #[inline(always)]
    pub(crate) fn of(err: T) -> Self {
        let ln_err = lanes::ln(err);
        Powers {
            fac11: lanes::exp(T::splat(0.2 - BETA * 0.75) * ln_err),
            facold_beta: lanes::exp(T::splat(BETA) * ln_err.max(T::splat(LN_1E_4))),
        }
    }
}

/// A right-hand side as [`Stages::step`] calls it: one system's, or one per lane. A trait
/// rather than a closure, so that the call is inlined into the code compiled for the vector
/// instruction set.
///
/// `forcing` is the part of the right-hand side that depends on time alone (the rig's
/// substrate velocity); [`Stages::step`] computes it for every stage time before the first
/// stage, so that it runs beside the stages' chain of dependencies instead of inside it, and
/// once for the two stages at `t + h`. `eval` then gives the same numbers as a right-hand side
/// that computes it itself.
pub(crate) trait Eval<T> {
    type Forcing: Copy;
    fn forcing(&self, t: T) -> Self::Forcing;
    fn eval(&self, t: T, forcing: Self::Forcing, y: &[T], dy: &mut [T]);
}

/// One system's right-hand side (no forcing computed apart: [`OdeSystem::rhs`] whole).
pub(crate) struct One<'a, S>(pub &'a S);

impl<S: OdeSystem> Eval<f64> for One<'_, S> {
    type Forcing = ();
    #[inline(always)]
    fn forcing(&self, _t: f64) {}
    #[inline(always)]
    fn eval(&self, t: f64, _forcing: (), y: &[f64], dy: &mut [f64]) {
        self.0.rhs(t, y, dy);
    }
}

/// The buffers of one attempt: the stages `k1` (given: `f(t, y)`) to `k7` (`f(t + h, ynew)`),
/// the fifth-order solution and a scratch state; one point (`T = f64`) or one per lane.
pub(crate) struct Stages<'a, T> {
    pub k1: &'a [T],
    pub k2: &'a mut [T],
    pub k3: &'a mut [T],
    pub k4: &'a mut [T],
    pub k5: &'a mut [T],
    pub k6: &'a mut [T],
    pub k7: &'a mut [T],
    pub ynew: &'a mut [T],
    pub ytmp: &'a mut [T],
}

impl<T: Real> Stages<'_, T> {
    /// One Dormand–Prince attempt from `(t, y)` with step `h`: the stages, `ynew`, and the error
    /// norm of the embedded estimate (`k2` then holds the estimate). The same operations for a
    /// point alone and in a lane.
    #[inline(always)]
    pub(crate) fn step(self, rhs: &impl Eval<T>, t: T, h: T, y: &[T], atol: &[T], rtol: T) -> T {
        let Stages {
            k1,
            k2,
            k3,
            k4,
            k5,
            k6,
            k7,
            ynew,
            ytmp,
        } = self;
        let n = y.len();
        let c = T::splat;
        let (t2, t3, t4, t5, t6) = (
            t + c(C2) * h,
            t + c(C3) * h,
            t + c(C4) * h,
            t + c(C5) * h,
            t + h,
        );
        let (f2, f3, f4, f5, f6) = (
            rhs.forcing(t2),
            rhs.forcing(t3),
            rhs.forcing(t4),
            rhs.forcing(t5),
            rhs.forcing(t6),
        );
        for i in 0..n {
            ytmp[i] = y[i] + h * c(A21) * k1[i];
        }
        rhs.eval(t2, f2, ytmp, k2);
        for i in 0..n {
            ytmp[i] = y[i] + h * (c(A31) * k1[i] + c(A32) * k2[i]);
        }
        rhs.eval(t3, f3, ytmp, k3);
        for i in 0..n {
            ytmp[i] = y[i] + h * (c(A41) * k1[i] + c(A42) * k2[i] + c(A43) * k3[i]);
        }
        rhs.eval(t4, f4, ytmp, k4);
        for i in 0..n {
            ytmp[i] =
                y[i] + h * (c(A51) * k1[i] + c(A52) * k2[i] + c(A53) * k3[i] + c(A54) * k4[i]);
        }
        rhs.eval(t5, f5, ytmp, k5);
        for i in 0..n {
            ytmp[i] = y[i]
                + h * (c(A61) * k1[i]
                    + c(A62) * k2[i]
                    + c(A63) * k3[i]
                    + c(A64) * k4[i]
                    + c(A65) * k5[i]);
        }
        rhs.eval(t6, f6, ytmp, k6);
        for i in 0..n {
            ynew[i] = y[i]
                + h * (c(A71) * k1[i]
                    + c(A73) * k3[i]
                    + c(A74) * k4[i]
                    + c(A75) * k5[i]
                    + c(A76) * k6[i]);
        }
        // The seventh stage is at `t + h` too (`c7 = c6 = 1`).
        rhs.eval(t6, f6, ynew, k7);
        // Local error estimate, reusing k2 as scratch.
        for i in 0..n {
            k2[i] = h
                * (c(E1) * k1[i]
                    + c(E3) * k3[i]
                    + c(E4) * k4[i]
                    + c(E5) * k5[i]
                    + c(E6) * k6[i]
                    + c(E7) * k7[i]);
        }
        error_norm(k2, y, ynew, atol, rtol)
    }
}

/// The dense output coefficients of an accepted step of size `h` from `y` to `ynew`, given the
/// stages `[k1, k3, k4, k5, k6, k7]`.
#[inline(always)]
pub(crate) fn dense_coefficients<T: Real>(
    h: T,
    y: &[T],
    ynew: &[T],
    k: [&[T]; 6],
    rc: [&mut [T]; 5],
) {
    let [k1, k3, k4, k5, k6, k7] = k;
    let [rc0, rc1, rc2, rc3, rc4] = rc;
    let c = T::splat;
    for i in 0..y.len() {
        let ydiff = ynew[i] - y[i];
        let bspl = h * k1[i] - ydiff;
        rc0[i] = y[i];
        rc1[i] = ydiff;
        rc2[i] = bspl;
        rc3[i] = ydiff - h * k7[i] - bspl;
        rc4[i] = h
            * (c(D1) * k1[i]
                + c(D3) * k3[i]
                + c(D4) * k4[i]
                + c(D5) * k5[i]
                + c(D6) * k6[i]
                + c(D7) * k7[i]);
    }
}

/// The continuous extension at `t` of the step that ended at `t_end` after `h_prev`, from one
/// component's coefficients.
#[inline(always)]
pub(crate) fn dense_value(t: f64, t_end: f64, h_prev: f64, rc: [f64; 5]) -> f64 {
    let s = (t - (t_end - h_prev)) / h_prev;
    let s1 = 1.0 - s;
    rc[0] + s * (rc[1] + s1 * (rc[2] + s * (rc[3] + s1 * rc[4])))
}

pub(crate) struct Dopri5 {
    n: usize,
    rtol: f64,
    atol: Vec<f64>,
    t: f64,
    h: f64,
    h_prev: f64,
    y: Vec<f64>,
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    k5: Vec<f64>,
    k6: Vec<f64>,
    k7: Vec<f64>,
    ynew: Vec<f64>,
    ytmp: Vec<f64>,
    /// Dense output coefficients of the last accepted step.
    rc: [Vec<f64>; 5],
    control: Control,
    /// Whether to run the stiffness test on accepted steps (for [`super::Method::Auto`]).
    pub(crate) detect: bool,
    /// `h λ̃` of the last accepted step (0 unless `detect`): the stiffness test of DOPRI5,
    /// `λ̃ = ‖f(t+h, y₁) − f(t+h, ŷ₆)‖₂ / ‖y₁ − ŷ₆‖₂` from the two evaluations at `t + h`
    /// (the last stage's state `ŷ₆` and the new state `y₁`) — the local Lipschitz constant
    /// along the step's last correction; `h λ̃` above 3.25 means the step sits at the edge of
    /// the method's stability region (Hairer, Nørsett & Wanner, *Solving ODEs I*, Sect. IV.2).
    pub(crate) h_lambda: f64,
}

impl Dopri5 {
    pub(crate) fn new(n: usize) -> Self {
        let v = || vec![0.0; n];
        Dopri5 {
            n,
            rtol: 1e-6,
            atol: v(),
            t: 0.0,
            h: 0.0,
            h_prev: 0.0,
            y: v(),
            k1: v(),
            k2: v(),
            k3: v(),
            k4: v(),
            k5: v(),
            k6: v(),
            k7: v(),
            ynew: v(),
            ytmp: v(),
            rc: [v(), v(), v(), v(), v()],
            control: Control::new(),
            detect: false,
            h_lambda: 0.0,
        }
    }
}

impl Stepper for Dopri5 {
    const ORDER: f64 = 4.0;

    fn set_tolerances(&mut self, rtol: f64, atol: &[f64]) {
        self.rtol = rtol;
        self.atol.copy_from_slice(atol);
    }

    fn start<S: OdeSystem>(&mut self, sys: &S, t0: f64, y0: &[f64], h: f64, st: &mut Stats) {
        self.t = t0;
        self.h = h;
        self.h_prev = h;
        self.y.copy_from_slice(y0);
        sys.rhs(t0, y0, &mut self.k1);
        st.rhs_evals += 1;
        self.control = Control::new();
        self.h_lambda = 0.0;
        self.rc[0].copy_from_slice(y0);
        for c in self.rc[1..].iter_mut() {
            c.fill(0.0);
        }
    }

    fn t(&self) -> f64 {
        self.t
    }
    fn y(&self) -> &[f64] {
        &self.y
    }
    fn h(&self) -> f64 {
        self.h
    }
    fn set_h(&mut self, h: f64) {
        self.h = h;
    }

    fn attempt<S: OdeSystem>(&mut self, sys: &S, st: &mut Stats) -> StepOutcome {
        let n = self.n;
        let (t, h) = (self.t, self.h);
        // Every buffer as a slice of length n: the loops then carry no bounds checks, which for
        // the rig's three states cost as much as their arithmetic.
        let Dopri5 {
            y,
            k1,
            k2,
            k3,
            k4,
            k5,
            k6,
            k7,
            ynew,
            ytmp,
            ..
        } = self;
        let ks = Stages {
            k1: &k1[..n],
            k2: &mut k2[..n],
            k3: &mut k3[..n],
            k4: &mut k4[..n],
            k5: &mut k5[..n],
            k6: &mut k6[..n],
            k7: &mut k7[..n],
            ynew: &mut ynew[..n],
            ytmp: &mut ytmp[..n],
        };
        let err = ks.step(&One(sys), t, h, &y[..n], &self.atol, self.rtol);
        st.rhs_evals += 6;
        let accepted = match self.control.judge(err, h) {
            Judged::Accepted(h_next) => h_next,
            Judged::Rejected(h_next) => {
                st.rejected += 1;
                self.h = h_next;
                return StepOutcome::Rejected;
            }
        };
        let n = self.n;
        if self.detect {
            // Stiffness test, before k7 and ytmp are reused.
            let (mut num, mut den) = (0.0, 0.0);
            for i in 0..n {
                num += (self.k7[i] - self.k6[i]).powi(2);
                den += (self.ynew[i] - self.ytmp[i]).powi(2);
            }
            self.h_lambda = if den > 0.0 {
                h * (num / den).sqrt()
            } else {
                0.0
            };
        }
        let [rc0, rc1, rc2, rc3, rc4] = &mut self.rc;
        dense_coefficients(
            h,
            &self.y[..n],
            &self.ynew[..n],
            [
                &self.k1[..n],
                &self.k3[..n],
                &self.k4[..n],
                &self.k5[..n],
                &self.k6[..n],
                &self.k7[..n],
            ],
            [
                &mut rc0[..n],
                &mut rc1[..n],
                &mut rc2[..n],
                &mut rc3[..n],
                &mut rc4[..n],
            ],
        );
        std::mem::swap(&mut self.k1, &mut self.k7);
        std::mem::swap(&mut self.y, &mut self.ynew);
        self.h_prev = h;
        self.t = t + h;
        self.h = accepted;
        st.steps += 1;
        StepOutcome::Accepted
    }

    fn dense(&self, t: f64, out: &mut [f64]) {
        let n = self.n;
        let [rc0, rc1, rc2, rc3, rc4] = &self.rc;
        for i in 0..n {
            out[i] = dense_value(
                t,
                self.t,
                self.h_prev,
                [rc0[i], rc1[i], rc2[i], rc3[i], rc4[i]],
            );
        }
    }
}
