//! Radau IIA of order 5 (3 stages), after Hairer & Wanner's RADAU5
//! (*Solving ODEs II*, 2nd ed., Sect. IV.8).
//!
//! - The stage system is transformed with the eigenvectors `T` of `A⁻¹`, so that a simplified
//!   Newton iteration needs one real `n×n` and one complex `n×n` LU per step size.
//! - The Jacobian is kept while the Newton contraction `θ` stays below [`THET`]; the LU is kept
//!   too when the new step lies within `[QUOT1, QUOT2]` times the old one.
//! - Error estimate of order 3 through the embedded formula with the `(γ₀h)⁻¹ I − J` filter,
//!   with the extra filtering step after a first or rejected step.
//! - Predictive (Gustafsson) step-size controller.
//! - Dense output: the collocation polynomial (order 3 at any point, 5 at the step's end).
//! - Tolerances are transformed as in RADAU5: `rtol' = 0.1 rtol^(2/3)`,
//!   `atol' = rtol' · atol / rtol`, because the error estimate is of lower order than the method.
// The kernels below step several arrays of one state (stages, weights, tolerances) with one
// index, as the method's equations are written.
#![allow(clippy::needless_range_loop)]
// The transformation matrices below carry the digits RADAU5 publishes, more than an f64 holds.
#![allow(clippy::excessive_precision)]

use super::linalg::DenseLu;
use super::{OdeSystem, Stats, Status, StepOutcome, Stepper, error_norm};
use num_complex::Complex64;
use std::cmp::Ordering;

/// Newton iterations per step before the step is retried with `h/2`.
const NIT: usize = 7;
/// Contraction below which the Jacobian is reused.
const THET: f64 = 0.001;
const SAFE: f64 = 0.9;
/// Step ratio bounds: `1/FACL ≤ h_new/h ≤ 1/FACR`.
const FACL: f64 = 5.0;
const FACR: f64 = 0.125;
/// Keep the LU when `QUOT1 ≤ h_new/h ≤ QUOT2` and the Jacobian is still good.
const QUOT1: f64 = 1.0;
const QUOT2: f64 = 1.2;
/// Consecutive failed attempts (Newton divergence or singular matrix) before giving up.
const MAX_NEWTON_FAILURES: u32 = 40;

// Collocation nodes and the eigen-decomposition of the inverse Radau IIA matrix.
const SQ6: f64 = 2.449_489_742_783_178;
const C1: f64 = (4.0 - SQ6) / 10.0;
const C2: f64 = (4.0 + SQ6) / 10.0;
const C1M1: f64 = C1 - 1.0;
const C2M1: f64 = C2 - 1.0;
const C1MC2: f64 = C1 - C2;
const DD1: f64 = -(13.0 + 7.0 * SQ6) / 3.0;
const DD2: f64 = (-13.0 + 7.0 * SQ6) / 3.0;
const DD3: f64 = -1.0 / 3.0;

pub(crate) const T11: f64 = 9.123_239_487_089_294_279e-2;
pub(crate) const T12: f64 = -0.141_255_295_020_954_208_43;
pub(crate) const T13: f64 = -3.002_919_410_514_742_449_2e-2;
pub(crate) const T21: f64 = 0.241_717_932_707_107_018_96;
pub(crate) const T22: f64 = 0.204_129_352_293_799_931_99;
pub(crate) const T23: f64 = 0.382_942_112_757_261_937_79;
pub(crate) const T31: f64 = 0.966_048_182_615_092_936_19;
pub(crate) const TI11: f64 = 4.325_579_890_063_155_351_0;
pub(crate) const TI12: f64 = 0.339_199_251_815_809_869_54;
pub(crate) const TI13: f64 = 0.541_770_539_935_874_871_19;
pub(crate) const TI21: f64 = -4.178_718_591_551_904_727_3;
pub(crate) const TI22: f64 = -0.327_682_820_761_062_387_08;
pub(crate) const TI23: f64 = 0.476_623_554_500_550_451_96;
pub(crate) const TI31: f64 = -0.502_872_634_945_786_875_95;
pub(crate) const TI32: f64 = 2.571_926_949_855_605_429_2;
pub(crate) const TI33: f64 = -0.596_039_204_828_224_924_97;

/// The real eigenvalue `γ` of `A⁻¹` and the complex pair `α ± iβ`.
pub(crate) fn eigenvalues() -> (f64, f64, f64) {
    let c81 = 81f64.cbrt();
    let c9 = 9f64.cbrt();
    let u1 = (6.0 + c81 - c9) / 30.0;
    let alph = (12.0 - c81 + c9) / 60.0;
    let beta = (c81 + c9) * 3f64.sqrt() / 60.0;
    let cno = alph * alph + beta * beta;
    (1.0 / u1, alph / cno, beta / cno)
}

pub(crate) struct Radau5 {
    n: usize,
    /// Size of the diagonal block the iteration matrices are built from
    /// ([`OdeSystem::jacobian_blocks`]); `n` for a dense Jacobian.
    m: usize,
    u1: f64,
    alph: f64,
    beta: f64,
    rtol: f64,
    atol: Vec<f64>,
    fnewt: f64,
    // State.
    t: f64,
    h: f64,
    y: Vec<f64>,
    f0: Vec<f64>,
    scal: Vec<f64>,
    // Stage and Newton vectors.
    z1: Vec<f64>,
    z2: Vec<f64>,
    z3: Vec<f64>,
    w1: Vec<f64>,
    w2: Vec<f64>,
    w3: Vec<f64>,
    tmp: Vec<f64>,
    ctmp: Vec<Complex64>,
    // Dense output: y at the step's end and the three divided differences.
    cont: [Vec<f64>; 4],
    // Iteration matrices.
    jac: Vec<f64>,
    e1: DenseLu<f64>,
    e2: DenseLu<Complex64>,
    // Controller history.
    first: bool,
    reject: bool,
    jac_current: bool,
    need_jac: bool,
    lu_h: f64,
    hold: f64,
    hacc: f64,
    erracc: f64,
    faccon: f64,
    theta: f64,
    naccpt: u64,
    fail_streak: u32,
}

impl Radau5 {
    pub(crate) fn new(n: usize) -> Self {
        let (u1, alph, beta) = eigenvalues();
        let v = || vec![0.0; n];
        Radau5 {
            n,
            m: n,
            u1,
            alph,
            beta,
            rtol: 1e-6,
            atol: v(),
            fnewt: 0.0,
            t: 0.0,
            h: 0.0,
            y: v(),
            f0: v(),
            scal: v(),
            z1: v(),
            z2: v(),
            z3: v(),
            w1: v(),
            w2: v(),
            w3: v(),
            tmp: v(),
            ctmp: vec![Complex64::default(); n],
            cont: [v(), v(), v(), v()],
            jac: vec![0.0; n * n],
            e1: DenseLu::new(n),
            e2: DenseLu::new(n),
            first: true,
            reject: false,
            jac_current: false,
            need_jac: true,
            lu_h: f64::NAN,
            hold: 0.0,
            hacc: 0.0,
            erracc: 0.0,
            faccon: 1.0,
            theta: 0.0,
            naccpt: 0,
            fail_streak: 0,
        }
    }

    fn update_scal(&mut self) {
        for i in 0..self.n {
            self.scal[i] = self.atol[i] + self.rtol * self.y[i].abs();
        }
    }

    /// Builds and factorises `E1 = γ/h I − J` and `E2 = (α + iβ)/h I − J`.
    fn factorize(&mut self, st: &mut Stats) -> bool {
        // Only the leading m × m block (the whole matrix unless the system declares blocks).
        let n = self.n;
        let fac1 = self.u1 / self.h;
        let alphn = self.alph / self.h;
        let betan = self.beta / self.h;
        let jac = &self.jac;
        let ok1 = self
            .e1
            .factor(|i, j| {
                if i == j {
                    fac1 - jac[i * n + j]
                } else {
                    -jac[i * n + j]
                }
            })
            .is_ok();
        let ok2 = self
            .e2
            .factor(|i, j| {
                if i == j {
                    Complex64::new(alphn - jac[i * n + j], betan)
                } else {
                    Complex64::new(-jac[i * n + j], 0.0)
                }
            })
            .is_ok();
        st.lu_decomps += 2;
        if ok1 && ok2 {
            self.lu_h = self.h;
        } else {
            self.lu_h = f64::NAN;
        }
        ok1 && ok2
    }

    /// A Jacobian where one is needed, and the two LUs where `h` moved away from the step they
    /// were built for; false where a matrix is singular.
    fn prepare_matrices<S: OdeSystem>(&mut self, sys: &S, st: &mut Stats) -> bool {
        if self.need_jac {
            sys.jacobian(self.t, &self.y, &mut self.jac);
            st.jac_evals += 1;
            self.need_jac = false;
            self.jac_current = true;
            self.lu_h = f64::NAN;
        }
        // Refactorise when h moved away from the step the LU was built for.
        self.lu_h == self.h || self.factorize(st)
    }

    /// The stages' starting values.
    fn starting_values(&mut self) {
        let (n, h) = (self.n, self.h);
        // Starting values: zero on the first step, else the previous collocation polynomial.
        if self.first {
            for i in 0..n {
                self.z1[i] = 0.0;
                self.z2[i] = 0.0;
                self.z3[i] = 0.0;
                self.w1[i] = 0.0;
                self.w2[i] = 0.0;
                self.w3[i] = 0.0;
            }
        } else {
            let c3q = h / self.hold;
            let c1q = C1 * c3q;
            let c2q = C2 * c3q;
            for i in 0..n {
                let ak1 = self.cont[1][i];
                let ak2 = self.cont[2][i];
                let ak3 = self.cont[3][i];
                let z1 = c1q * (ak1 + (c1q - C2M1) * (ak2 + (c1q - C1M1) * ak3));
                let z2 = c2q * (ak1 + (c2q - C2M1) * (ak2 + (c2q - C1M1) * ak3));
                let z3 = c3q * (ak1 + (c3q - C2M1) * (ak2 + (c3q - C1M1) * ak3));
                self.z1[i] = z1;
                self.z2[i] = z2;
                self.z3[i] = z3;
                self.w1[i] = TI11 * z1 + TI12 * z2 + TI13 * z3;
                self.w2[i] = TI21 * z1 + TI22 * z2 + TI23 * z3;
                self.w3[i] = TI31 * z1 + TI32 * z2 + TI33 * z3;
            }
        }
    }

    /// The simplified Newton iteration on the transformed stage values: its iterations where it
    /// converged, else the attempt's outcome (a smaller step).
    fn newton<S: OdeSystem>(&mut self, sys: &S, st: &mut Stats) -> Result<usize, StepOutcome> {
        // Simplified Newton iteration on the transformed stage values W = T⁻¹ Z.
        let (n, h, t) = (self.n, self.h, self.t);
        let fac1 = self.u1 / h;
        let alphn = self.alph / h;
        let betan = self.beta / h;
        let mut newt = 0usize;
        self.faccon = self.faccon.max(f64::EPSILON).powf(0.8);
        self.theta = THET.abs();
        let mut dynold = 0.0f64;
        let mut thqold = 0.0f64;
        loop {
            if newt >= NIT {
                return Err(self.newton_failure(st));
            }
            for i in 0..n {
                self.tmp[i] = self.y[i] + self.z1[i];
            }
            sys.rhs(t + C1 * h, &self.tmp, &mut self.z1);
            for i in 0..n {
                self.tmp[i] = self.y[i] + self.z2[i];
            }
            sys.rhs(t + C2 * h, &self.tmp, &mut self.z2);
            for i in 0..n {
                self.tmp[i] = self.y[i] + self.z3[i];
            }
            sys.rhs(t + h, &self.tmp, &mut self.z3);
            st.rhs_evals += 3;
            st.newton_iters += 1;
            // Right-hand sides of the transformed linear systems.
            for i in 0..n {
                let (a1, a2, a3) = (self.z1[i], self.z2[i], self.z3[i]);
                let r1 = TI11 * a1 + TI12 * a2 + TI13 * a3;
                let r2 = TI21 * a1 + TI22 * a2 + TI23 * a3;
                let r3 = TI31 * a1 + TI32 * a2 + TI33 * a3;
                let s2 = -self.w2[i];
                let s3 = -self.w3[i];
                self.z1[i] = r1 - self.w1[i] * fac1;
                self.ctmp[i] =
                    Complex64::new(r2 + s2 * alphn - s3 * betan, r3 + s3 * alphn + s2 * betan);
            }
            for c in self.z1.chunks_mut(self.m) {
                self.e1.solve(c);
            }
            for c in self.ctmp.chunks_mut(self.m) {
                self.e2.solve(c);
            }
            for i in 0..n {
                self.z2[i] = self.ctmp[i].re;
                self.z3[i] = self.ctmp[i].im;
            }
            newt += 1;
            let mut dyno = 0.0;
            for i in 0..n {
                let d = self.scal[i];
                dyno +=
                    (self.z1[i] / d).powi(2) + (self.z2[i] / d).powi(2) + (self.z3[i] / d).powi(2);
            }
            let dyno = (dyno / (3 * n) as f64).sqrt();
            if !dyno.is_finite() {
                return Err(self.newton_failure(st));
            }
            // Convergence monitor: the contraction rate θ predicts whether NIT iterations suffice.
            if newt > 1 && newt < NIT {
                let thq = dyno / dynold;
                self.theta = if newt == 2 {
                    thq
                } else {
                    (thq * thqold).sqrt()
                };
                thqold = thq;
                if self.theta < 0.99 {
                    self.faccon = self.theta / (1.0 - self.theta);
                    let dyth =
                        self.faccon * dyno * self.theta.powi((NIT - 1 - newt) as i32) / self.fnewt;
                    if dyth >= 1.0 {
                        // Too slow: retry with a smaller step, keeping the Jacobian.
                        let qnewt = dyth.clamp(1e-4, 20.0);
                        let hhfac = 0.8 * qnewt.powf(-1.0 / (4.0 + NIT as f64 - 1.0 - newt as f64));
                        self.h *= hhfac;
                        self.reject = true;
                        st.rejected += 1;
                        if !self.jac_current {
                            self.need_jac = true;
                        }
                        return Err(StepOutcome::Rejected);
                    }
                } else {
                    return Err(self.newton_failure(st));
                }
            }
            dynold = dyno.max(f64::EPSILON);
            for i in 0..n {
                let f1 = self.w1[i] + self.z1[i];
                let f2 = self.w2[i] + self.z2[i];
                let f3 = self.w3[i] + self.z3[i];
                self.w1[i] = f1;
                self.w2[i] = f2;
                self.w3[i] = f3;
                self.z1[i] = T11 * f1 + T12 * f2 + T13 * f3;
                self.z2[i] = T21 * f1 + T22 * f2 + T23 * f3;
                self.z3[i] = T31 * f1 + f2;
            }
            if self.faccon * dyno <= self.fnewt {
                break;
            }
        }
        Ok(newt)
    }

    /// The embedded error estimate of the converged stages, in tolerance units.
    fn error_estimate<S: OdeSystem>(&mut self, sys: &S, st: &mut Stats) -> f64 {
        let (n, h, t) = (self.n, self.h, self.t);
        // Error estimate (Hairer & Wanner IV.8, (8.19)-(8.20)), filtered through E1.
        let hee1 = DD1 / h;
        let hee2 = DD2 / h;
        let hee3 = DD3 / h;
        for i in 0..n {
            let f2 = hee1 * self.z1[i] + hee2 * self.z2[i] + hee3 * self.z3[i];
            self.w2[i] = f2;
            self.tmp[i] = f2 + self.f0[i];
        }
        for c in self.tmp.chunks_mut(self.m) {
            self.e1.solve(c);
        }
        let mut err = error_norm(&self.tmp, &self.y, &self.y, &self.atol, self.rtol);
        if err.partial_cmp(&1.0) != Some(Ordering::Less) && (self.first || self.reject) {
            for i in 0..n {
                self.w3[i] = self.y[i] + self.tmp[i];
            }
            sys.rhs(t, &self.w3, &mut self.w1);
            st.rhs_evals += 1;
            for i in 0..n {
                self.tmp[i] = self.w1[i] + self.w2[i];
            }
            for c in self.tmp.chunks_mut(self.m) {
                self.e1.solve(c);
            }
            err = error_norm(&self.tmp, &self.y, &self.y, &self.atol, self.rtol);
        }
        err
    }

    /// The step accepted (its state, dense output and next step) or rejected by the error `err`
    /// after `newt` Newton iterations.
    fn accept_or_reject<S: OdeSystem>(
        &mut self,
        sys: &S,
        st: &mut Stats,
        err: f64,
        newt: usize,
    ) -> StepOutcome {
        let (n, h, t) = (self.n, self.h, self.t);
        let cfac = SAFE * (1.0 + 2.0 * NIT as f64);
        let fac = SAFE.min(cfac / (newt as f64 + 2.0 * NIT as f64));
        let mut quot = FACR.max(FACL.min(err.powf(0.25) / fac));
        let mut hnew = h / quot;
        if err < 1.0 {
            self.fail_streak = 0;
            self.first = false;
            self.naccpt += 1;
            // Predictive controller of Gustafsson.
            if self.naccpt > 1 {
                let facgus = (self.hacc / h) * (err * err / self.erracc).powf(0.25) / SAFE;
                let facgus = FACR.max(FACL.min(facgus));
                quot = quot.max(facgus);
                hnew = h / quot;
            }
            self.hacc = h;
            self.erracc = err.max(1e-2);
            self.hold = h;
            self.t = t + h;
            for i in 0..n {
                self.y[i] += self.z3[i];
                let z1 = self.z1[i];
                let z2 = self.z2[i];
                let z3 = self.z3[i];
                self.cont[1][i] = (z2 - z3) / C2M1;
                let ak = (z1 - z2) / C1MC2;
                let acont3 = (ak - z1 / C1) / C2;
                self.cont[2][i] = (ak - self.cont[1][i]) / C1M1;
                self.cont[3][i] = self.cont[2][i] - acont3;
            }
            self.cont[0].copy_from_slice(&self.y);
            self.update_scal();
            sys.rhs(self.t, &self.y, &mut self.f0);
            st.rhs_evals += 1;
            st.steps += 1;
            if self.reject {
                hnew = hnew.min(h);
            }
            self.reject = false;
            self.jac_current = false;
            let qt = hnew / h;
            if self.theta <= THET && (QUOT1..=QUOT2).contains(&qt) {
                // Keep h, the Jacobian and the LU.
                self.h = h;
            } else {
                self.h = hnew;
                // Keep the Jacobian (new LU only) while Newton converged fast.
                self.need_jac = self.theta > THET;
            }
            StepOutcome::Accepted
        } else {
            self.reject = true;
            st.rejected += 1;
            self.h = if self.first { h * 0.1 } else { hnew };
            if !self.jac_current {
                self.need_jac = true;
            }
            StepOutcome::Rejected
        }
    }

    /// A failed attempt (Newton divergence, singular matrix, non-finite values): halve the step.
    fn newton_failure(&mut self, st: &mut Stats) -> StepOutcome {
        st.rejected += 1;
        self.fail_streak += 1;
        if self.fail_streak >= MAX_NEWTON_FAILURES {
            return StepOutcome::Failed(Status::NewtonFailure);
        }
        self.h *= 0.5;
        self.reject = true;
        if !self.jac_current {
            self.need_jac = true;
        }
        StepOutcome::Rejected
    }
}

impl Stepper for Radau5 {
    const ORDER: f64 = 3.0;

    fn set_tolerances(&mut self, rtol: f64, atol: &[f64]) {
        // RADAU5's transformation (its error estimate is of order 3, the method of order 5).
        let r = 0.1 * rtol.powf(2.0 / 3.0);
        for i in 0..self.n {
            self.atol[i] = r * atol[i] / rtol;
        }
        self.rtol = r;
        let uround = f64::EPSILON;
        self.fnewt = (10.0 * uround / r).max(0.03f64.min(r.sqrt()));
    }

    fn start<S: OdeSystem>(&mut self, sys: &S, t0: f64, y0: &[f64], h: f64, st: &mut Stats) {
        let k = sys.jacobian_blocks();
        let m = if k > 1 && self.n.is_multiple_of(k) {
            self.n / k
        } else {
            self.n
        };
        if m != self.m {
            // Sized once per system, not per step.
            self.m = m;
            self.e1 = DenseLu::new(m);
            self.e2 = DenseLu::new(m);
        }
        self.t = t0;
        self.h = h;
        self.y.copy_from_slice(y0);
        sys.rhs(t0, y0, &mut self.f0);
        st.rhs_evals += 1;
        self.update_scal();
        self.first = true;
        self.reject = false;
        self.jac_current = false;
        self.need_jac = true;
        self.lu_h = f64::NAN;
        self.hold = h;
        self.faccon = 1.0;
        self.theta = 0.0;
        self.naccpt = 0;
        self.fail_streak = 0;
        for c in self.cont.iter_mut() {
            c.fill(0.0);
        }
        self.cont[0].copy_from_slice(y0);
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
        if !self.prepare_matrices(sys, st) {
            return self.newton_failure(st);
        }
        self.starting_values();
        let newt = match self.newton(sys, st) {
            Ok(newt) => newt,
            Err(outcome) => return outcome,
        };
        let err = self.error_estimate(sys, st);
        if !err.is_finite() {
            return self.newton_failure(st);
        }
        self.accept_or_reject(sys, st, err.max(1e-10), newt)
    }

    fn dense(&self, t: f64, out: &mut [f64]) {
        let s = (t - self.t) / self.hold;
        let c = &self.cont;
        for i in 0..self.n {
            out[i] = c[0][i] + s * (c[1][i] + (s - C2M1) * (c[2][i] + (s - C1M1) * c[3][i]));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Radau IIA coefficient matrix (Hairer & Wanner, Table IV.5.6).
    fn a() -> [[f64; 3]; 3] {
        let s = 6f64.sqrt();
        [
            [
                (88.0 - 7.0 * s) / 360.0,
                (296.0 - 169.0 * s) / 1800.0,
                (-2.0 + 3.0 * s) / 225.0,
            ],
            [
                (296.0 + 169.0 * s) / 1800.0,
                (88.0 + 7.0 * s) / 360.0,
                (-2.0 - 3.0 * s) / 225.0,
            ],
            [(16.0 - s) / 36.0, (16.0 + s) / 36.0, 1.0 / 9.0],
        ]
    }

    fn mul(x: &[[f64; 3]; 3], y: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    r[i][j] += x[i][k] * y[k][j];
                }
            }
        }
        r
    }

    #[test]
    fn transformation_block_diagonalises_the_inverse_coefficient_matrix() {
        let t = [[T11, T12, T13], [T21, T22, T23], [T31, 1.0, 0.0]];
        let ti = [[TI11, TI12, TI13], [TI21, TI22, TI23], [TI31, TI32, TI33]];
        let id = mul(&t, &ti);
        for i in 0..3 {
            for j in 0..3 {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (id[i][j] - e).abs() < 1e-14,
                    "T·T⁻¹ [{i}][{j}] = {}",
                    id[i][j]
                );
            }
        }
        // T⁻¹ A T = diag(1/γ, [[α', β'], [−β', α']]) with γ, α ± iβ the eigenvalues of A⁻¹.
        let d = mul(&mul(&ti, &a()), &t);
        let (g, al, be) = eigenvalues();
        let n = al * al + be * be;
        let want = [
            [1.0 / g, 0.0, 0.0],
            [0.0, al / n, be / n],
            [0.0, -be / n, al / n],
        ];
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    (d[i][j] - want[i][j]).abs() < 1e-13,
                    "T⁻¹AT [{i}][{j}] = {} vs {}",
                    d[i][j],
                    want[i][j]
                );
            }
        }
        // Published values: γ ≈ 3.6378, α ± iβ ≈ 2.6811 ± 3.0504 i.
        assert!(
            (g - 3.637_834_252_744_5).abs() < 1e-9
                && (al - 2.681_082_873_627_75).abs() < 1e-9
                && (be - 3.050_430_199_247_41).abs() < 1e-9
        );
    }
}
