//! The rig model of docs/model.md: a body dragged over a tangentially vibrating substrate by a
//! spring-damper drive, with LuGre friction in the contact.
//!
//! ```text
//! ω      = 2π f                                   (4.1, with docs/model.md's correction)
//! u'(t)  = u0 ω cos(ω (t − t_on)) for t ≥ t_on, else 0   substrate velocity (docs/model.md)
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

pub mod base;
pub mod effects;
pub mod extended;
pub mod params;
pub mod state;

pub use base::BaseCoeffs;
pub use effects::{EffectError, EffectKind, Effects};
pub use params::{ParamError, Params};
pub use state::{BASE_DIM, S, V, X};

use effects::Resolved;
use extended::{FxCoeffs, Shape};

use crate::ode::OdeSystem;

/// The LuGre contact law evaluated at one relative velocity and deformation, with the partial
/// derivatives the Jacobian needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Deformation rate `s'` [m/s] (Eq. 4.6).
    pub s_dot: f64,
    /// Friction force `F_F` \[N\] (Eq. 4.5).
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
    let e_s = gauss(q * q);
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
    let h = p.h_t * gauss(qd * qd);
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

/// `exp(−q²)` of the Stribeck curve (4.7) and the contact damping (4.9), given `q²`; 0 beyond
/// `q² = 50`, where it is below 2e-22 and adds less than a rounding error to `F_c` or to the
/// contact force. [`contact`] keeps the platform's exponential: the averaged law's orbits are
/// built on it, and which of their orbits still contracts (a Floquet multiplier at 1) decides
/// the escape force, a threshold a rounding can move (`docs/methods.md`); the right-hand sides
/// integrated use the base model's own ([`base`]).
#[inline]
fn gauss(q2: f64) -> f64 {
    if q2 > 50.0 { 0.0 } else { (-q2).exp() }
}

/// Largest state dimension of the rig with every effect on.
pub const MAX_DIM: usize = 16;

pub use effects::viscous::VISCOUS_REFERENCE;

/// The rig as an ODE system. Build it once per run from validated [`Params`] (and, optionally,
/// [`Effects`]).
#[derive(Clone, Debug)]
pub struct Rig {
    /// The parameters (validated by [`Rig::new`]).
    pub p: Params,
    omega: f64,
    /// Actuated amplitude `A u0` \[m\] (`u0` without the actuator effect).
    u0: f64,
    /// Switch-on time of the vibration \[s\] (docs/model.md; 0: from the start).
    t_on: f64,
    fx: Resolved,
    /// The right-hand side's terms and the effects' coefficients ([`extended`]), resolved once.
    shape: Shape,
    fxc: FxCoeffs<f64>,
}

impl Rig {
    /// A rig from validated parameters: docs/model.md's model.
    pub fn new(p: Params) -> Result<Self, ParamError> {
        p.validate()?;
        let fx = Resolved::new(&Effects::none(), p.f, p.f_n);
        Ok(Rig {
            p,
            omega: p.omega(),
            u0: p.u0,
            t_on: p.t_on,
            shape: fx.shape(),
            fxc: fx.coeffs(),
            fx,
        })
    }

    /// A rig with model extensions (see [`effects`]).
    pub fn with_effects(p: Params, fx: &Effects) -> Result<Self, RigError> {
        p.validate()?;
        fx.validate()?;
        let r = Resolved::new(fx, p.f, p.f_n);
        Ok(Rig {
            p,
            omega: p.omega(),
            u0: p.u0 * r.gain,
            t_on: p.t_on,
            shape: r.shape(),
            fxc: r.coeffs(),
            fx: r,
        })
    }

    /// The same rig without vibration (`u0 = 0`), with the same effects.
    pub fn without_vibration(&self) -> Rig {
        let p = self.p.without_vibration();
        Rig {
            p,
            omega: p.omega(),
            u0: 0.0,
            t_on: 0.0,
            fx: self.fx,
            shape: self.shape,
            fxc: self.fxc,
        }
    }

    /// The terms of its right-hand side, which every lane of a batch shares ([`extended`]).
    pub fn shape(&self) -> Shape {
        self.shape
    }

    /// The effects' coefficients ([`extended`]).
    pub fn effect_coeffs(&self) -> FxCoeffs<f64> {
        self.fxc
    }

    /// The initial state: all zero (spring relaxed, body at rest, contact unloaded; with the
    /// extensions: a fresh contact, a sensor at rest, no lag).
    pub fn initial_state(&self) -> Vec<f64> {
        vec![0.0; self.fx.dim]
    }

    /// Substrate displacement `u(t) = u0 sin(ω (t − t_on))` for `t ≥ t_on`, 0 before \[m\]
    /// (4.1; docs/model.md's two stages).
    #[inline]
    pub fn substrate_displacement(&self, t: f64) -> f64 {
        if self.u0 == 0.0 || t < self.t_on {
            0.0
        } else {
            self.u0 * (self.omega * (t - self.t_on)).sin()
        }
    }

    /// Substrate velocity `u'(t) = u0 ω cos(ω (t − t_on))` for `t ≥ t_on`, 0 before [m/s].
    #[inline]
    pub fn substrate_velocity(&self, t: f64) -> f64 {
        // Without vibration there is no cosine to pay for (half the cost of a sample).
        if self.u0 == 0.0 || t < self.t_on {
            0.0
        } else {
            // The right-hand side's own cosine ([`base`]), so that every path rounds alike.
            base::substrate_velocity(&self.base_coeffs(), t)
        }
    }

    /// The substrate velocity's amplitude `u0 ω` \[m/s\] (0 without vibration) and the
    /// vibration's switch-on time `t_on` \[s\]: [`Rig::substrate_velocity`] is
    /// `u0 ω cos(ω (t − t_on))` from `t_on` on, this product times that cosine.
    pub fn substrate_velocity_terms(&self) -> (f64, f64) {
        (self.u0 * self.omega, self.t_on)
    }

    /// The vibration's phase `ω (t − t_on)` \[rad\] (meaningful from `t_on` on).
    #[inline]
    pub fn vibration_phase(&self, t: f64) -> f64 {
        self.omega * (t - self.t_on)
    }

    /// Drive displacement `x_d = v_d t` \[m\] (plus the ripple when that effect is on).
    #[inline]
    pub fn drive_displacement(&self, t: f64) -> f64 {
        match self.fx.ripple {
            None => self.p.v_d * t,
            Some((a, k)) => self.p.v_d * t + a * (k * self.p.v_d * t).sin(),
        }
    }

    /// Drive velocity `x_d'` [m/s].
    #[inline]
    fn drive_velocity(&self, t: f64) -> f64 {
        match self.fx.ripple {
            None => self.p.v_d,
            Some((a, k)) => self.p.v_d * (1.0 + a * k * (k * self.p.v_d * t).cos()),
        }
    }

    /// Drive force `F_d = k_d (x_d − x) + h_d (x_d' − v)` \[N\] (4.3, 4.4).
    #[inline]
    pub fn drive_force(&self, t: f64, y: &[f64]) -> f64 {
        if self.fx.ripple.is_none() {
            return self.p.k_d * (self.p.v_d * t - y[X]) + self.p.h_d * (self.p.v_d - y[V]);
        }
        self.p.k_d * (self.drive_displacement(t) - y[X])
            + self.p.h_d * (self.drive_velocity(t) - y[V])
    }

    /// The drive force as the force sensor records it: the sensor's output with the
    /// `sensor_dynamics` effect, the drive force itself otherwise \[N\].
    #[inline]
    pub fn measured_force(&self, t: f64, y: &[f64]) -> f64 {
        match self.fx.sensor {
            Some((_, _, i)) if self.fx.sensor4.is_some() => y[i + 2],
            Some((_, _, i)) => y[i],
            None => self.drive_force(t, y),
        }
    }

    /// How late the force is recorded behind the sensor's output \[s\]: `delay` of
    /// `sensor_dynamics` in its `order4_delay` form, 0 otherwise. The state cannot hold a
    /// delay; recordings apply it where they are sampled ([`crate::campaign::delay`]).
    pub fn sensor_delay(&self) -> f64 {
        self.fx.sensor_delay
    }

    /// The fourth-order sensor's output `F_m` and its first three time derivatives, from the
    /// state alone (its second section `F_m'' = ω_n² (F_1 − F_m) − 2 ζ_2 ω_n F_m'` and the
    /// first's output `F_1`, `F_1'`); zeros without a fourth-order sensor.
    pub fn sensor_output_derivatives(&self, y: &[f64]) -> [f64; 4] {
        let (Some((wn, _, i)), Some(z2)) = (self.fx.sensor, self.fx.sensor4) else {
            return [0.0; 4];
        };
        let (f1, d1, f, d) = (y[i], y[i + 1], y[i + 2], y[i + 3]);
        let d2 = wn * wn * (f1 - f) - 2.0 * z2 * wn * d;
        let d3 = wn * wn * (d1 - d) - 2.0 * z2 * wn * d2;
        [f, d, d2, d3]
    }

    /// The mean contact deformation over the presliding elements \[m\] (`s` of the base model).
    pub fn deformation(&self, y: &[f64]) -> f64 {
        let n = self.fx.elements;
        if n == 1 {
            return y[S];
        }
        let extra: f64 = y[self.fx.first_extra..self.fx.first_extra + n - 1]
            .iter()
            .sum();
        (y[S] + extra) / n as f64
    }

    /// The coefficients of the base model's right-hand side (with the actuated amplitude).
    #[inline(always)]
    pub fn base_coeffs(&self) -> BaseCoeffs<f64> {
        let p = &self.p;
        BaseCoeffs {
            u0: self.u0,
            omega: self.omega,
            t_on: self.t_on,
            v_s: p.v_s,
            f_c: p.f_c,
            f_s: p.f_s,
            k_t: p.k_t,
            v_d: p.v_d,
            h_t: p.h_t,
            h_v: p.h_v,
            k_d: p.k_d,
            h_d: p.h_d,
            m: p.m,
            inv_v_s: 1.0 / p.v_s,
            inv_v_d: 1.0 / p.v_d,
            inv_k_t: 1.0 / p.k_t,
            inv_m: 1.0 / p.m,
        }
    }

    /// Whether any effect is on.
    pub fn has_effects(&self) -> bool {
        self.fx.any
    }

    /// The right-hand side with the effects (see [`effects`] for the equations).
    fn rhs_effects(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let c = self.base_coeffs();
        let u_dot = base::substrate_velocity(&c, t);
        extended::extended_rhs(&self.shape, &c, &self.fxc, t, u_dot, y, dy);
    }

    /// Relative velocity `v_r = v − u'(t)` [m/s] (4.7).
    #[inline]
    pub fn relative_velocity(&self, t: f64, y: &[f64]) -> f64 {
        y[V] - self.substrate_velocity(t)
    }
}

/// Bad parameters of the model or of an effect.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RigError {
    /// A model parameter.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// An effect parameter.
    #[error(transparent)]
    Effect(#[from] EffectError),
}

impl OdeSystem for Rig {
    fn dim(&self) -> usize {
        self.fx.dim
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        if self.fx.any {
            return self.rhs_effects(t, y, dy);
        }
        base::base_rhs(&self.base_coeffs(), t, y, dy);
    }

    fn jacobian(&self, t: f64, y: &[f64], j: &mut [f64]) {
        if self.fx.any {
            // Extensions: forward differences, column by column, on stack buffers.
            let n = self.fx.dim;
            let mut f0 = [0.0; MAX_DIM];
            let mut f1 = [0.0; MAX_DIM];
            let mut yp = [0.0; MAX_DIM];
            yp[..n].copy_from_slice(y);
            self.rhs(t, y, &mut f0[..n]);
            for c in 0..n {
                let h = f64::EPSILON.sqrt() * y[c].abs().max(1e-3 * self.scale(c));
                yp[c] = y[c] + h;
                self.rhs(t, &yp[..n], &mut f1[..n]);
                yp[c] = y[c];
                for r in 0..n {
                    j[r * n + c] = (f1[r] - f0[r]) / h;
                }
            }
            return;
        }
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

    fn time_derivative(&self, t: f64, y: &[f64], dfdt: &mut [f64], scratch: &mut [f64]) {
        if self.fx.any {
            return crate::ode::fd_time_derivative(self, t, y, dfdt, scratch);
        }
        let p = &self.p;
        let v_r = self.relative_velocity(t, y);
        let c = contact(p, v_r, y[S]);
        // ∂v_r/∂t = −u''(t) = u0 ω² sin(ω t); ∂F_d/∂t = k_d v_d.
        let dvr_dt = if t < self.t_on {
            0.0
        } else {
            p.u0 * self.omega * self.omega * self.vibration_phase(t).sin()
        };
        dfdt[X] = 0.0;
        dfdt[V] = (p.k_d * p.v_d - c.dforce_dvr * dvr_dt) / p.m;
        dfdt[S] = c.ds_dot_dvr * dvr_dt;
    }

    /// Characteristic sizes: `x` on the spring's stick-slip travel `F_s/k_d`, `v` on
    /// `v_d + v_a`, `s` on the contact's breakaway deformation `F_s/k_t`.
    fn scale(&self, i: usize) -> f64 {
        let p = &self.p;
        let fx = &self.fx;
        match i {
            X => p.f_s / p.k_d,
            V => p.v_d + self.u0 * self.omega,
            _ if fx.aging.is_some_and(|a| a.3 == i) => fx.aging.unwrap().1,
            _ if fx.sensor.is_some_and(|s| s.2 == i || s.2 + 2 == i) => p.f_s,
            _ if fx.sensor.is_some_and(|s| s.2 + 1 == i || s.2 + 3 == i) => {
                p.f_s * fx.sensor.unwrap().0
            }
            // The lagged velocity, or the Stribeck level's fall (a fraction).
            _ if fx.lag.is_some_and(|l| l.1 == i) => match fx.lag_form {
                extended::Lag::Level => 1.0,
                _ => p.v_d + self.u0 * self.omega,
            },
            _ => p.f_s / p.k_t,
        }
    }
}
