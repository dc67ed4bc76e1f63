//! Rodas4: the 6-stage, L-stable, stiffly accurate Rosenbrock method of order 4 with an embedded
//! 3rd-order solution (Hairer & Wanner, *Solving ODEs II*, Sect. VI.4; the RODAS code), with the coefficients of
//! that code, written in the form
//!
//! ```text
//! (1/(hγ) I − J) k_i = f(t + α_i h, y + Σ_j a_ij k_j) + Σ_j (c_ij / h) k_j + h γ_i ∂f/∂t
//! y₁ = y + Σ m_i k_i,   err = Σ e_i k_i = k_6
//! ```
//!
//! One Jacobian, one `∂f/∂t` and one LU per attempt, no Newton iteration. Dense output: the cubic
//! Hermite interpolant through `(y₀, f₀)` and `(y₁, f₁)` (order 3), where `f₁` is the first stage
//! of the next step and so costs nothing extra.
// The kernels below step several arrays of one state (stages, weights, tolerances) with one
// index, as the method's equations are written.
#![allow(clippy::needless_range_loop)]

use super::linalg::DenseLu;
use super::{OdeSystem, Stats, Status, StepOutcome, Stepper, error_norm};

const S: usize = 6;
const GAMMA: f64 = 0.25;
const ALPHA: [f64; S] = [0.0, 0.386, 0.21, 0.63, 1.0, 1.0];
const GAMMA_I: [f64; S] = [0.25, -0.1043, 0.1035, -0.036_200_000_000_000_23, 0.0, 0.0];
/// Strictly lower-triangular A, row by row: a21; a31 a32; a41 a42 a43; ...
const A: [f64; 15] = [
    1.544,
    0.946_678_528_081_582_6,
    0.255_701_169_898_328_4,
    3.314_825_187_068_521,
    2.896_124_015_972_201,
    0.998_641_913_997_781_7,
    1.221_224_509_226_641,
    6.019_134_481_288_629,
    12.537_083_329_320_87,
    -0.687_886_036_105_895,
    1.221_224_509_226_641,
    6.019_134_481_288_629,
    12.537_083_329_320_87,
    -0.687_886_036_105_895,
    1.0,
];
const C: [f64; 15] = [
    -5.6688,
    -2.430_093_356_833_875,
    -0.206_359_915_709_191_5,
    -0.107_352_905_815_137_5,
    -9.594_562_251_023_355,
    -20.470_286_148_096_16,
    7.496_443_313_967_647,
    -10.246_804_314_643_52,
    -33.999_903_528_199_05,
    11.708_908_932_061_6,
    8.083_246_795_921_522,
    -7.981_132_988_064_893,
    -31.521_594_328_743_71,
    16.319_305_431_231_36,
    -6.058_818_238_834_054,
];
const M: [f64; S] = [
    1.221_224_509_226_641,
    6.019_134_481_288_629,
    12.537_083_329_320_87,
    -0.687_886_036_105_895,
    1.0,
    1.0,
];

#[inline]
fn idx(i: usize, j: usize) -> usize {
    // 0-based stage i > j.
    i * (i - 1) / 2 + j
}

const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 6.0;
const SAFE: f64 = 0.9;
const MAX_SINGULAR: u32 = 40;

pub(crate) struct Rodas4 {
    n: usize,
    rtol: f64,
    atol: Vec<f64>,
    t: f64,
    h: f64,
    h_prev: f64,
    y: Vec<f64>,
    f0: Vec<f64>,
    // Previous step's start, for dense output.
    y_prev: Vec<f64>,
    f_prev: Vec<f64>,
    k: [Vec<f64>; S],
    ynew: Vec<f64>,
    ytmp: Vec<f64>,
    fnew: Vec<f64>,
    dfdt: Vec<f64>,
    jac: Vec<f64>,
    lu: DenseLu<f64>,
    reject: bool,
    fail_streak: u32,
}

impl Rodas4 {
    pub(crate) fn new(n: usize) -> Self {
        let v = || vec![0.0; n];
        Rodas4 {
            n,
            rtol: 1e-6,
            atol: v(),
            t: 0.0,
            h: 0.0,
            h_prev: 0.0,
            y: v(),
            f0: v(),
            y_prev: v(),
            f_prev: v(),
            k: [v(), v(), v(), v(), v(), v()],
            ynew: v(),
            ytmp: v(),
            fnew: v(),
            dfdt: v(),
            jac: vec![0.0; n * n],
            lu: DenseLu::new(n),
            reject: false,
            fail_streak: 0,
        }
    }

    fn failure(&mut self, st: &mut Stats) -> StepOutcome {
        st.rejected += 1;
        self.fail_streak += 1;
        if self.fail_streak >= MAX_SINGULAR {
            return StepOutcome::Failed(Status::NewtonFailure);
        }
        self.h *= 0.5;
        self.reject = true;
        StepOutcome::Rejected
    }
}

impl Stepper for Rodas4 {
    const ORDER: f64 = 3.0;

    fn set_tolerances(&mut self, rtol: f64, atol: &[f64]) {
        self.rtol = rtol;
        self.atol.copy_from_slice(atol);
    }

    fn start<Sys: OdeSystem>(&mut self, sys: &Sys, t0: f64, y0: &[f64], h: f64, st: &mut Stats) {
        self.t = t0;
        self.h = h;
        self.h_prev = h;
        self.y.copy_from_slice(y0);
        sys.rhs(t0, y0, &mut self.f0);
        st.rhs_evals += 1;
        self.y_prev.copy_from_slice(y0);
        self.f_prev.copy_from_slice(&self.f0);
        self.reject = false;
        self.fail_streak = 0;
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

    fn attempt<Sys: OdeSystem>(&mut self, sys: &Sys, st: &mut Stats) -> StepOutcome {
        let n = self.n;
        let h = self.h;
        let t = self.t;
        // A Rosenbrock method needs the exact Jacobian at the step's start, every attempt.
        sys.jacobian(t, &self.y, &mut self.jac);
        sys.time_derivative(t, &self.y, &mut self.dfdt, &mut self.ytmp);
        st.jac_evals += 1;
        let ghinv = 1.0 / (GAMMA * h);
        let jac = &self.jac;
        let ok = self
            .lu
            .factor(|i, j| {
                if i == j {
                    ghinv - jac[i * n + j]
                } else {
                    -jac[i * n + j]
                }
            })
            .is_ok();
        st.lu_decomps += 1;
        if !ok {
            return self.failure(st);
        }
        for s in 0..S {
            // Stage argument and right-hand side.
            if s == 0 {
                self.ytmp.copy_from_slice(&self.f0);
            } else {
                for i in 0..n {
                    let mut acc = self.y[i];
                    for j in 0..s {
                        acc += A[idx(s, j)] * self.k[j][i];
                    }
                    self.ynew[i] = acc;
                }
                sys.rhs(t + ALPHA[s] * h, &self.ynew, &mut self.ytmp);
                st.rhs_evals += 1;
            }
            let hg = h * GAMMA_I[s];
            for i in 0..n {
                let mut acc = self.ytmp[i] + hg * self.dfdt[i];
                for j in 0..s {
                    acc += C[idx(s, j)] / h * self.k[j][i];
                }
                self.k[s][i] = acc;
            }
            self.lu.solve(&mut self.k[s]);
        }
        for i in 0..n {
            let mut acc = self.y[i];
            for s in 0..S {
                acc += M[s] * self.k[s][i];
            }
            self.ynew[i] = acc;
        }
        // The embedded solution differs from y₁ by the last stage alone (e = k_6).
        let err = error_norm(&self.k[S - 1], &self.y, &self.ynew, &self.atol, self.rtol);
        if !err.is_finite() || self.ynew.iter().any(|v| !v.is_finite()) {
            return self.failure(st);
        }
        let fac = (SAFE / err.max(1e-10).powf(0.25)).clamp(FAC_MIN, FAC_MAX);
        let mut hnew = h * fac;
        if err <= 1.0 {
            sys.rhs(t + h, &self.ynew, &mut self.fnew);
            st.rhs_evals += 1;
            std::mem::swap(&mut self.y_prev, &mut self.y);
            std::mem::swap(&mut self.f_prev, &mut self.f0);
            self.y.copy_from_slice(&self.ynew);
            self.f0.copy_from_slice(&self.fnew);
            self.h_prev = h;
            self.t = t + h;
            if self.reject {
                hnew = hnew.min(h);
            }
            self.reject = false;
            self.fail_streak = 0;
            self.h = hnew;
            st.steps += 1;
            StepOutcome::Accepted
        } else {
            st.rejected += 1;
            self.reject = true;
            self.h = hnew.min(h);
            StepOutcome::Rejected
        }
    }

    fn dense(&self, t: f64, out: &mut [f64]) {
        // Cubic Hermite on [t − h_prev, t].
        let h = self.h_prev;
        let th = (t - (self.t - h)) / h;
        let th1 = th - 1.0;
        for i in 0..self.n {
            let y0 = self.y_prev[i];
            let y1 = self.y[i];
            let d = y1 - y0;
            out[i] = (1.0 - th) * y0
                + th * y1
                + th * th1
                    * ((1.0 - 2.0 * th) * d + th1 * h * self.f_prev[i] + th * h * self.f0[i]);
        }
    }
}
