//! The terms of an extended rig's right-hand side ([`crate::model::extended`]): which terms it
//! has and where their states sit ([`Shape`], fixed per rig and shared by every lane of a
//! batch), and the effects' numbers ([`FxCoeffs`], one set per lane). Each effect's file reads
//! its share of them.

use crate::ode::lanes::Lanes;

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
    /// Any effect on (else the right-hand side is [`crate::model::base::base_rhs`]).
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
