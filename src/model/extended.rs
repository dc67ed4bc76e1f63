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

use super::VISCOUS_REFERENCE;
use super::base::{BaseCoeffs, base_rhs_forced, gauss, substrate_velocity};
use super::state::{BASE_DIM, S, V, X};
use crate::ode::lanes::{Lanes, Real, cos, exp, ln, ln_1p, pow, sin};

/// The Stribeck curve's form (`q = |w|/v_s`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Stribeck {
    /// `e^(−q²)` (docs/model.md, Eq. 4.7).
    #[default]
    Gauss,
    /// `e^(−q^δ)`, `δ ≠ 2`.
    Power,
    /// `1/(1 + q^δ)`.
    Rational,
}

/// What a frictional lag runs over, and what it delays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lag {
    /// The velocity the Stribeck curve is evaluated at lags by a time `τ`.
    #[default]
    Time,
    /// That velocity's memory fades over a slip distance `L`.
    Distance,
    /// The Stribeck level itself lags over a slip distance `L` (its state is the level's
    /// fall from the static one, `ψ = 1 − φ`, zero on a fresh contact).
    Level,
}

/// The terms of an extended rig's right-hand side and the indices of their states: what every
/// lane of a batch must share.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Shape {
    /// Any effect on (else the right-hand side is [`super::base::base_rhs`]).
    pub any: bool,
    /// State dimension.
    pub dim: usize,
    /// Ageing: the index of `θ`, and whether it follows the slip law.
    pub aging: Option<usize>,
    pub slip_law: bool,
    /// Normal coupling, and whether its swing is fixed (else per metre of amplitude).
    pub normal: bool,
    pub normal_fixed: bool,
    /// Force sensor: the index of its first section's output; a second section.
    pub sensor: Option<usize>,
    pub sensor4: bool,
    /// Drive ripple.
    pub ripple: bool,
    /// Viscous friction linear in the slip velocity (exponent exactly 1).
    pub visc_linear: bool,
    /// The Stribeck curve's form.
    pub stribeck: Stribeck,
    /// Presliding elements and the index of the second.
    pub elements: usize,
    pub first_extra: usize,
    /// Frictional lag: the index of its state, and its form.
    pub lag: Option<usize>,
    pub lag_form: Lag,
    /// Friction varying along the track.
    pub track: bool,
}

/// The effects' coefficients of one rig (`T = f64`) or of one rig per lane; a coefficient of an
/// effect that is off is unused.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FxCoeffs<T> {
    /// Ageing: `b` [-], `θ_0` \[s\], `D_c` \[m\].
    pub b: T,
    pub theta0: T,
    pub dc: T,
    /// Normal coupling: the relative load swing (per metre of amplitude, or fixed) and its
    /// phase \[rad\].
    pub c_n: T,
    pub phi: T,
    /// Sensor: `ω_n` \[rad/s\], `ζ` and the second section's `ζ`.
    pub wn: T,
    pub zeta: T,
    pub zeta2: T,
    /// Drive ripple: amplitude \[m\] and wave number `2π/λ` \[1/m\].
    pub rip_a: T,
    pub rip_k: T,
    /// Extra viscous coefficient at `V_1` \[N s/m\] and its exponent.
    pub h_v: T,
    pub visc_n: T,
    /// Stribeck exponent.
    pub delta: T,
    /// Presliding spread.
    pub spread: T,
    /// Frictional lag: `τ` \[s\] or `L` \[m\].
    pub tau: T,
    /// Track: relative amplitude, wave number \[1/m\], offset \[m\].
    pub tr_a: T,
    pub tr_k: T,
    pub tr_x0: T,
}

macro_rules! each_fx {
    ($m:ident) => {
        $m!(
            b, theta0, dc, c_n, phi, wn, zeta, zeta2, rip_a, rip_k, h_v, visc_n, delta, spread,
            tau, tr_a, tr_k, tr_x0
        )
    };
}

impl<const W: usize> FxCoeffs<Lanes<W>> {
    /// Puts one rig's coefficients in lane `i`.
    pub fn set_lane(&mut self, i: usize, c: &FxCoeffs<f64>) {
        macro_rules! set {
            ($($f:ident),*) => { $( self.$f.set(i, c.$f); )* };
        }
        each_fx!(set);
    }
}

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
    let (zero, one) = (T::splat(0.0), T::splat(1.0));
    let v_r = y[V] - u_dot;
    let a = v_r.abs();
    // Load factor: normal coupling and friction along the track scale F_c and F_s.
    let mut nu = one;
    if sh.normal {
        let swing = if sh.normal_fixed { x.c_n } else { x.c_n * c.u0 };
        let phase = c.omega * (t - c.t_on) + x.phi;
        let on = (one + swing * sin(phase)).max(zero);
        // From the switch-on, with vibration.
        nu = T::select(t.lt(c.t_on), one, T::select(c.u0.gt(zero), on, one));
    }
    if sh.track {
        nu = nu * (one + x.tr_a * sin(x.tr_k * (y[X] + x.tr_x0)));
    }
    let mut f_s = c.f_s;
    if let Some(i) = sh.aging {
        let theta = y[i].max(zero);
        f_s = f_s * (one + x.b * ln_1p(theta / x.theta0));
        dy[i] = if sh.slip_law {
            // Ruina's slip law: the state moves only with slip; from a fresh contact's age of
            // 1 ns (θ = 0 would stay there).
            let q = a * theta.max(T::splat(1e-9)) / x.dc;
            T::select(q.gt(zero), -q * ln(q), zero)
        } else {
            one - a * y[i] / x.dc
        };
    }
    // Stribeck curve (4.7), evaluated at the lagged velocity with a lag of the velocity.
    let w = match sh.lag {
        Some(i) if sh.lag_form != Lag::Level => {
            dy[i] = if sh.lag_form == Lag::Distance {
                // A memory distance L (in `tau`'s place): it fades only as the contact slips.
                a * (v_r - y[i]) / x.tau
            } else {
                (v_r - y[i]) / x.tau
            };
            y[i]
        }
        _ => v_r,
    };
    let q = (w * c.inv_v_s).abs();
    let mut e_s = match sh.stribeck {
        Stribeck::Rational => one / (one + pow(q, x.delta)),
        Stribeck::Gauss => gauss(q * q),
        Stribeck::Power => exp(-pow(q, x.delta)),
    };
    if let Some(i) = sh.lag.filter(|_| sh.lag_form == Lag::Level) {
        // The level φ = 1 − ψ relaxes over slip distance L towards the curve's value at the
        // slip velocity: L φ' = |v_r| (e_s − φ). The state is ψ so a fresh contact starts at 0.
        dy[i] = a * ((one - e_s) - y[i]) / x.tau;
        e_s = one - y[i];
    }
    let g = nu * (c.f_c + (f_s - c.f_c) * e_s) * c.inv_k_t;
    // Contact damping (4.9).
    let qd = v_r * c.inv_v_d;
    let h = c.h_t * gauss(qd * qd);
    // Bristles (4.6): one, or N Maxwell-slip elements of stiffness k_t/N.
    let n = sh.elements;
    let (mut sum_s, mut sum_sd) = (zero, zero);
    for e in 0..n {
        let i = if e == 0 { S } else { sh.first_extra + e - 1 };
        let alpha = if n == 1 {
            one
        } else {
            one + x.spread * T::splat(2.0 * e as f64 / (n - 1) as f64 - 1.0)
        };
        let sd = T::select(g.gt(zero), v_r - a * y[i] / (alpha * g), v_r);
        dy[i] = sd;
        sum_s = sum_s + y[i];
        sum_sd = sum_sd + sd;
    }
    let nf = T::splat(n as f64);
    let h_v = if sh.visc_linear {
        c.h_v + x.h_v
    } else {
        c.h_v + x.h_v * pow(a / T::splat(VISCOUS_REFERENCE), x.visc_n - one)
    };
    let force = c.k_t * sum_s / nf + h * sum_sd / nf + h_v * v_r;
    // Drive force (4.3, 4.4), with the ripple's displacement and velocity where it is on.
    let f_d = if sh.ripple {
        let arg = x.rip_k * c.v_d * t;
        let x_d = c.v_d * t + x.rip_a * sin(arg);
        let v_dr = c.v_d * (one + x.rip_a * x.rip_k * cos(arg));
        c.k_d * (x_d - y[X]) + c.h_d * (v_dr - y[V])
    } else {
        c.k_d * (c.v_d * t - y[X]) + c.h_d * (c.v_d - y[V])
    };
    dy[X] = y[V];
    dy[V] = (f_d - force) * c.inv_m; // (4.2)
    if let Some(i) = sh.sensor {
        let two = T::splat(2.0);
        dy[i] = y[i + 1];
        dy[i + 1] = x.wn * x.wn * (f_d - y[i]) - two * x.zeta * x.wn * y[i + 1];
        if sh.sensor4 {
            // The second section filters the first's output.
            dy[i + 2] = y[i + 3];
            dy[i + 3] = x.wn * x.wn * (y[i] - y[i + 2]) - two * x.zeta2 * x.wn * y[i + 3];
        }
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
