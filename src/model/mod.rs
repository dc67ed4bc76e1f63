//! The rig model of MODEL.md: a body dragged over a tangentially vibrating substrate by a
//! spring-damper drive, with LuGre friction in the contact.
//!
//! ```text
//! ω      = 2π f                                   (4.1, with MODEL.md's correction)
//! u'(t)  = u0 ω cos(ω t)                          substrate velocity
//! v_r    = v − u'(t)                              (4.7)
//! g(v_r) = (F_c + (F_s − F_c) exp(−(v_r/v_s)²)) / k_t      (4.7)
//! s'     = v_r − |v_r| s / g(v_r)                 (4.6)
//! h_t(v_r) = h_t exp(−(v_r/v_d)²)                 (4.9)
//! F_F    = k_t s + h_t(v_r) s' + h_v v_r          (4.5)
//! F_d    = k_d (v_d t − x) + h_d (v_d − v)        (4.3, 4.4)
//! m v'   = F_d − F_F                              (4.2)
//! x'     = v
//! ```
//!
//! State `y = [x, v, s]`, all zero at `t = 0`. [`Rig`] implements [`OdeSystem`] with an analytic
//! Jacobian and an analytic `∂f/∂t`; model extensions add state components after these three
//! and terms to the same right-hand side, so the integrators never change.

pub mod params;

pub use params::{ParamError, Params};

use crate::ode::OdeSystem;

/// Index of the body displacement `x` [m] in the state.
pub const X: usize = 0;
/// Index of the body velocity `v` [m/s].
pub const V: usize = 1;
/// Index of the contact deformation `s` [m].
pub const S: usize = 2;
/// Number of state components of the base model.
pub const BASE_DIM: usize = 3;

/// The LuGre contact law evaluated at one relative velocity and deformation, with the partial
/// derivatives the Jacobian needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Deformation rate `s'` [m/s] (Eq. 4.6).
    pub s_dot: f64,
    /// Friction force `F_F` [N] (Eq. 4.5).
    pub force: f64,
    /// `∂s'/∂v_r` [-].
    pub ds_dot_dvr: f64,
    /// `∂s'/∂s` [1/s].
    pub ds_dot_ds: f64,
    /// `∂F_F/∂v_r` [N s/m].
    pub dforce_dvr: f64,
    /// `∂F_F/∂s` [N/m].
    pub dforce_ds: f64,
}

/// Evaluates the LuGre contact (Eqs. 4.5 to 4.9) at relative velocity `v_r` and deformation `s`.
#[inline]
pub fn contact(p: &Params, v_r: f64, s: f64) -> Contact {
    // Stribeck curve g(v_r) (4.7) and its derivative.
    let q = v_r / p.v_s;
    let e_s = (-q * q).exp();
    let g = (p.f_c + (p.f_s - p.f_c) * e_s) / p.k_t;
    let dg = (p.f_s - p.f_c) / p.k_t * e_s * (-2.0 * v_r / (p.v_s * p.v_s));
    let a = v_r.abs();
    let sgn = if v_r > 0.0 {
        1.0
    } else if v_r < 0.0 {
        -1.0
    } else {
        0.0
    };
    // Bristle dynamics (4.6).
    let s_dot = v_r - a * s / g;
    let ds_dot_dvr = 1.0 - sgn * s / g + a * s * dg / (g * g);
    let ds_dot_ds = -a / g;
    // Slip-velocity-dependent contact damping (4.9).
    let qd = v_r / p.v_d;
    let h = p.h_t * (-qd * qd).exp();
    let dh = h * (-2.0 * v_r / (p.v_d * p.v_d));
    let force = p.k_t * s + h * s_dot + p.h_v * v_r;
    Contact {
        s_dot,
        force,
        ds_dot_dvr,
        ds_dot_ds,
        dforce_dvr: dh * s_dot + h * ds_dot_dvr + p.h_v,
        dforce_ds: p.k_t + h * ds_dot_ds,
    }
}

/// The rig as an ODE system. Build it once per run from validated [`Params`].
#[derive(Clone, Debug)]
pub struct Rig {
    /// The parameters (validated by [`Rig::new`]).
    pub p: Params,
    omega: f64,
}

impl Rig {
    /// A rig from validated parameters.
    pub fn new(p: Params) -> Result<Self, ParamError> {
        p.validate()?;
        Ok(Rig {
            p,
            omega: p.omega(),
        })
    }

    /// The initial state of MODEL.md: all zero (spring relaxed, body at rest, contact unloaded).
    pub fn initial_state(&self) -> [f64; BASE_DIM] {
        [0.0; BASE_DIM]
    }

    /// Substrate displacement `u(t) = u0 sin(ω t)` [m] (4.1).
    #[inline]
    pub fn substrate_displacement(&self, t: f64) -> f64 {
        if self.p.u0 == 0.0 {
            0.0
        } else {
            self.p.u0 * (self.omega * t).sin()
        }
    }

    /// Substrate velocity `u'(t) = u0 ω cos(ω t)` [m/s].
    #[inline]
    pub fn substrate_velocity(&self, t: f64) -> f64 {
        // Without vibration there is no cosine to pay for (half the cost of a sample).
        if self.p.u0 == 0.0 {
            0.0
        } else {
            self.p.u0 * self.omega * (self.omega * t).cos()
        }
    }

    /// Drive displacement `x_d = v_d t` [m].
    #[inline]
    pub fn drive_displacement(&self, t: f64) -> f64 {
        self.p.v_d * t
    }

    /// Drive force `F_d = k_d (v_d t − x) + h_d (v_d − v)` [N] (4.3, 4.4).
    #[inline]
    pub fn drive_force(&self, t: f64, y: &[f64]) -> f64 {
        self.p.k_d * (self.p.v_d * t - y[X]) + self.p.h_d * (self.p.v_d - y[V])
    }

    /// Relative velocity `v_r = v − u'(t)` [m/s] (4.7).
    #[inline]
    pub fn relative_velocity(&self, t: f64, y: &[f64]) -> f64 {
        y[V] - self.substrate_velocity(t)
    }
}

impl OdeSystem for Rig {
    fn dim(&self) -> usize {
        BASE_DIM
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let v_r = self.relative_velocity(t, y);
        let c = contact(&self.p, v_r, y[S]);
        dy[X] = y[V];
        dy[V] = (self.drive_force(t, y) - c.force) / self.p.m; // (4.2)
        dy[S] = c.s_dot;
    }

    fn jacobian(&self, t: f64, y: &[f64], j: &mut [f64]) {
        let p = &self.p;
        let v_r = self.relative_velocity(t, y);
        let c = contact(p, v_r, y[S]);
        let n = BASE_DIM;
        j[X * n + X] = 0.0;
        j[X * n + V] = 1.0;
        j[X * n + S] = 0.0;
        // ∂v_r/∂v = 1.
        j[V * n + X] = -p.k_d / p.m;
        j[V * n + V] = (-p.h_d - c.dforce_dvr) / p.m;
        j[V * n + S] = -c.dforce_ds / p.m;
        j[S * n + X] = 0.0;
        j[S * n + V] = c.ds_dot_dvr;
        j[S * n + S] = c.ds_dot_ds;
    }

    fn time_derivative(&self, t: f64, y: &[f64], dfdt: &mut [f64], _scratch: &mut [f64]) {
        let p = &self.p;
        let v_r = self.relative_velocity(t, y);
        let c = contact(p, v_r, y[S]);
        // ∂v_r/∂t = −u''(t) = u0 ω² sin(ω t); ∂F_d/∂t = k_d v_d.
        let dvr_dt = p.u0 * self.omega * self.omega * (self.omega * t).sin();
        dfdt[X] = 0.0;
        dfdt[V] = (p.k_d * p.v_d - c.dforce_dvr * dvr_dt) / p.m;
        dfdt[S] = c.ds_dot_dvr * dvr_dt;
    }

    /// Characteristic sizes: `x` on the spring's stick-slip travel `F_s/k_d`, `v` on
    /// `v_d + v_a`, `s` on the contact's breakaway deformation `F_s/k_t`.
    fn scale(&self, i: usize) -> f64 {
        let p = &self.p;
        match i {
            X => p.f_s / p.k_d,
            V => p.v_d + p.v_a(),
            _ => p.f_s / p.k_t,
        }
    }
}
