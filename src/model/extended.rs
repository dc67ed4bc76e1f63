//! The right-hand side of the rig with model extensions ([`super::effects`]), written once for
//! one rig (`T = f64`) or for `W` rigs in vector lanes, as the base model's is ([`super::base`]).
//!
//! Which terms the right-hand side has and where their states sit is its [`Shape`], fixed per
//! rig and shared by every lane of a batch; the effects' numbers are [`FxCoeffs`], one set per
//! lane. The transcendental functions the extensions use (`sin`, `cos`, `exp`, `ln`, `ln_1p`,
//! `pow`) are [`crate::ode::lanes`]'s, written in the same generic arithmetic, so a rig rounds
//! in a lane exactly as it does alone, and they run in the vector units.
//!
//! [`RigPack`] holds `W` rigs for the batch integrator ([`crate::ode::batch::Lanewise`]): the base
//! model's right-hand side inlined into the integrator's attempts, the extended one called.

use super::base::{BaseCoeffs, base_rhs_forced, gauss, substrate_velocity};
use super::effects::{
    aging, drive_ripple, frictional_lag, normal_coupling, presliding, sensor_dynamics,
    stribeck_shape, track, viscous,
};
use super::state::{BASE_DIM, V, X};
use crate::ode::lanes::{Lanes, Real};

pub use super::effects::terms::{FxCoeffs, Lag, Shape, Stribeck};

/// The right-hand side of a rig with effects, `dy = f(t, y)` ([`super::effects`] gives each
/// term; with no term on it equals [`super::base::base_rhs`] up to rounding), given the
/// substrate velocity `u_dot` = [`substrate_velocity`]`(c, t)` (see
/// [`super::base::base_rhs_forced`]).
#[inline(always)]
pub fn extended_rhs<T: Real>(
    sh: &Shape,
    c: &BaseCoeffs<T>,
    x: &FxCoeffs<T>,
    t: T,
    u_dot: T,
    y: &[T],
    dy: &mut [T],
) {
    let one = T::splat(1.0);
    let v_r = y[V] - u_dot;
    let a = v_r.abs();
    // Load factor: normal coupling and friction along the track scale F_c and F_s.
    let mut nu = one;
    if sh.normal {
        nu = normal_coupling::load_factor(sh, c, x, t);
    }
    if sh.track {
        nu = nu * track::load_factor(x, y);
    }
    let mut f_s = c.f_s;
    if let Some(i) = sh.aging {
        f_s = aging::static_friction(sh, x, f_s, a, i, y, dy);
    }
    // Stribeck curve (4.7), evaluated at the lagged velocity with a lag of the velocity.
    let w = match sh.lag {
        Some(i) if sh.lag_form != Lag::Level => {
            frictional_lag::lagged_velocity(sh, x, v_r, a, i, y, dy)
        }
        _ => v_r,
    };
    let q = (w * c.inv_v_s).abs();
    let mut e_s = stribeck_shape::curve(sh, x, q);
    if let Some(i) = sh.lag.filter(|_| sh.lag_form == Lag::Level) {
        e_s = frictional_lag::lagged_level(x, a, e_s, i, y, dy);
    }
    let g = nu * (c.f_c + (f_s - c.f_c) * e_s) * c.inv_k_t;
    // Contact damping (4.9).
    let qd = v_r * c.inv_v_d;
    let h = c.h_t * gauss(qd * qd);
    // Bristles (4.6): one, or N Maxwell-slip elements of stiffness k_t/N.
    let (sum_s, sum_sd) = presliding::bristles(sh, x, g, v_r, a, y, dy);
    let nf = T::splat(sh.elements as f64);
    let h_v = viscous::coefficient(sh, x, c.h_v, a);
    let force = c.k_t * sum_s / nf + h * sum_sd / nf + h_v * v_r;
    // Drive force (4.3, 4.4), with the ripple's displacement and velocity where it is on.
    let f_d = if sh.ripple {
        drive_ripple::drive_force(c, x, t, y)
    } else {
        c.k_d * (c.v_d * t - y[X]) + c.h_d * (c.v_d - y[V])
    };
    dy[X] = y[V];
    dy[V] = (f_d - force) * c.inv_m; // (4.2)
    if let Some(i) = sh.sensor {
        sensor_dynamics::rhs(sh, x, f_d, i, y, dy);
    }
}

/// The coefficients of `W` rigs, one per lane, and the terms their right-hand side shares.
#[derive(Clone, Copy, Debug, Default)]
pub struct RigPack<const W: usize> {
    /// The terms (every lane's rig has them: [`crate::ode::batch::Lanewise::shape`]).
    pub shape: Shape,
    pub base: BaseCoeffs<Lanes<W>>,
    pub fx: FxCoeffs<Lanes<W>>,
}

impl crate::ode::batch::Lanewise for super::Rig {
    type Pack<const W: usize> = RigPack<W>;
    type Shape = Shape;

    fn shape(&self) -> Shape {
        super::Rig::shape(self)
    }

    fn pack<const W: usize>(&self, pack: &mut Self::Pack<W>, lane: usize) {
        pack.shape = super::Rig::shape(self);
        pack.base.set_lane(lane, &self.base_coeffs());
        pack.fx.set_lane(lane, &self.effect_coeffs());
    }

    #[inline(always)]
    fn forcing_lanes<const W: usize>(pack: &Self::Pack<W>, t: Lanes<W>) -> Lanes<W> {
        substrate_velocity(&pack.base, t)
    }

    #[inline(always)]
    fn rhs_lanes<const W: usize>(
        pack: &Self::Pack<W>,
        t: Lanes<W>,
        u_dot: Lanes<W>,
        y: &[Lanes<W>],
        dy: &mut [Lanes<W>],
    ) {
        // A rig of more than the base model's states has extensions: the test on the length
        // (a constant once inlined into an attempt of a given dimension) drops the base
        // model's inlined code from those attempts.
        if y.len() == BASE_DIM && !pack.shape.any {
            base_rhs_forced(&pack.base, t, u_dot, y, dy);
        } else {
            extended_lanes(pack, t, u_dot, y, dy);
        }
    }
}

/// [`extended_rhs`] in lanes, compiled once for each vector instruction set and called, not
/// inlined, from the integrator's attempts: inlined into each attempt's six stages and each
/// state dimension it would multiply the build's size, while its terms cost far more than a
/// call.
#[inline(never)]
fn extended_lanes<const W: usize>(
    pack: &RigPack<W>,
    t: Lanes<W>,
    u_dot: Lanes<W>,
    y: &[Lanes<W>],
    dy: &mut [Lanes<W>],
) {
    struct Rhs<'a, const W: usize> {
        pack: &'a RigPack<W>,
        t: Lanes<W>,
        u_dot: Lanes<W>,
        y: &'a [Lanes<W>],
        dy: &'a mut [Lanes<W>],
    }
    impl<const W: usize> pulp::WithSimd for Rhs<'_, W> {
        type Output = ();
        #[inline(always)]
        fn with_simd<Sd: pulp::Simd>(self, _simd: Sd) {
            let p = self.pack;
            extended_rhs(
                &p.shape, &p.base, &p.fx, self.t, self.u_dot, self.y, self.dy,
            );
        }
    }
    pulp::Arch::new().dispatch(Rhs {
        pack,
        t,
        u_dot,
        y,
        dy,
    });
}
