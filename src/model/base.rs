//! The base model's right-hand side, written once for one rig or for `W` rigs in lanes
//! ([`crate::ode::lanes`]): the scalar integrators call it with `T = f64` through
//! [`Rig`](super::Rig)'s [`OdeSystem`](crate::ode::OdeSystem) implementation, the batch
//! integrator with `T = Lanes<W>`, so both perform the same operations for a point.

use super::state::{S, V, X};
use crate::ode::lanes::{Lanes, Real, cos, exp};

/// The coefficients of the base model's right-hand side (docs/model.md, Eqs. 4.1 to 4.9), for
/// one rig (`T = f64`) or one rig per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BaseCoeffs<T> {
    /// Actuated vibration amplitude `u0` \[m\] (0: no vibration).
    pub u0: T,
    /// Angular frequency `ω = 2π f` \[rad/s\].
    pub omega: T,
    /// Switch-on time of the vibration \[s\].
    pub t_on: T,
    /// Stribeck velocity \[m/s\].
    pub v_s: T,
    /// Coulomb and static friction \[N\].
    pub f_c: T,
    pub f_s: T,
    /// Contact stiffness \[N/m\].
    pub k_t: T,
    /// Drive velocity \[m/s\].
    pub v_d: T,
    /// Contact damping \[N s/m\] and viscous friction \[N s/m\].
    pub h_t: T,
    pub h_v: T,
    /// Drive stiffness \[N/m\] and damping \[N s/m\].
    pub k_d: T,
    pub h_d: T,
    /// Body mass \[kg\].
    pub m: T,
    /// `1/v_s`, `1/v_d`, `1/k_t` and `1/m`: the right-hand side multiplies where it would
    /// divide (a division costs several multiplications, in lanes too).
    pub inv_v_s: T,
    pub inv_v_d: T,
    pub inv_k_t: T,
    pub inv_m: T,
}

macro_rules! each_coeff {
    ($m:ident) => {
        $m!(
            u0, omega, t_on, v_s, f_c, f_s, k_t, v_d, h_t, h_v, k_d, h_d, m, inv_v_s, inv_v_d,
            inv_k_t, inv_m
        )
    };
}

impl<const W: usize> BaseCoeffs<Lanes<W>> {
    /// Puts one rig's coefficients in lane `i`.
    pub fn set_lane(&mut self, i: usize, c: &BaseCoeffs<f64>) {
        macro_rules! set {
            ($($f:ident),*) => { $( self.$f.set(i, c.$f); )* };
        }
        each_coeff!(set);
    }
}

/// `exp(−q²)` given `q²`, 0 beyond `q² = 50` (below 2e-22: less than a rounding error beside
/// `F_c` or the contact force).
#[inline(always)]
pub(crate) fn gauss<T: Real>(q2: T) -> T {
    T::select(q2.gt(T::splat(50.0)), T::splat(0.0), exp(-q2))
}

/// Substrate velocity `u'(t) = u0 ω cos(ω (t − t_on))` from `t_on` on, 0 before or without
/// vibration [m/s].
#[inline(always)]
pub fn substrate_velocity<T: Real>(c: &BaseCoeffs<T>, t: T) -> T {
    let off = T::or(c.u0.eq(T::splat(0.0)), t.lt(c.t_on));
    let on = c.u0 * c.omega * cos(c.omega * (t - c.t_on));
    T::select(off, T::splat(0.0), on)
}

/// The base model's right-hand side `dy = f(t, y)`, `y = [x, v, s]` (docs/model.md):
///
/// ```text
/// v_r = v − u'(t),  g = (F_c + (F_s − F_c) e^(−(v_r/v_s)²)) / k_t,  s' = v_r − |v_r| s / g,
/// F_F = k_t s + h_t e^(−(v_r/v_d)²) s' + h_v v_r,  m v' = k_d (v_d t − x) + h_d (v_d − v) − F_F.
/// ```
#[inline(always)]
pub fn base_rhs<T: Real>(c: &BaseCoeffs<T>, t: T, y: &[T], dy: &mut [T]) {
    base_rhs_forced(c, t, substrate_velocity(c, t), y, dy);
}

/// [`base_rhs`] given the substrate velocity `u_dot` = [`substrate_velocity`]`(c, t)`: the
/// part of the right-hand side that depends on time alone, which the batch integrator
/// computes for all stages of an attempt before the first (the same numbers, out of the
/// stages' chain of dependencies).
#[inline(always)]
pub fn base_rhs_forced<T: Real>(c: &BaseCoeffs<T>, t: T, u_dot: T, y: &[T], dy: &mut [T]) {
    let (x, v, s) = (y[X], y[V], y[S]);
    let v_r = v - u_dot;
    let q = v_r * c.inv_v_s;
    let g = (c.f_c + (c.f_s - c.f_c) * gauss(q * q)) * c.inv_k_t;
    let s_dot = v_r - v_r.abs() * s / g;
    let qd = v_r * c.inv_v_d;
    let h = c.h_t * gauss(qd * qd);
    let force = c.k_t * s + h * s_dot + c.h_v * v_r;
    let f_d = c.k_d * (c.v_d * t - x) + c.h_d * (c.v_d - v);
    dy[X] = v;
    dy[V] = (f_d - force) * c.inv_m;
    dy[S] = s_dot;
}
