//! Normal coupling: the tangential vibration modulates the normal load, and so `F_c` and
//! `F_s`: `ν(t) = max(0, 1 + ΔF_N sin(ω (t − t_d) + φ) / F_N)`, the swing `ΔF_N` growing with
//! the substrate's displacement, velocity or acceleration, or fixed ([`load_swing`]).

use super::terms::{FxCoeffs, Shape};
use super::{At, EffectInfo, EffectKind, Grid, Param, Resolved, Scale, Scan, ep, form, range};
use crate::model::base::BaseCoeffs;
use crate::ode::lanes::{Real, sin};
use std::f64::consts::TAU;

/// `k_n`.
pub const K_N: Param = Param(0);
/// `phase`.
pub const PHASE: Param = Param(1);
/// `delay`.
pub const DELAY: Param = Param(2);
/// `form`.
pub const FORM: Param = Param(3);

/// Its forms: how the load swing scales.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Swing {
    /// `k_n A u0`.
    Displacement,
    /// `k_n A u0 f/f_ref`.
    Velocity,
    /// `k_n A u0 (f/f_ref)²`.
    Acceleration,
    /// `k_n × 1 µm` while the substrate vibrates.
    Fixed,
}

impl Swing {
    /// The swing of the form parameter's value `v`.
    pub fn of(v: f64) -> Swing {
        match v as usize {
            1 => Swing::Velocity,
            2 => Swing::Acceleration,
            3 => Swing::Fixed,
            _ => Swing::Displacement,
        }
    }
}

/// Displacement amplitude \[m\] at which the `fixed` form of `normal_coupling` swings the
/// normal load by `k_n` times it: its `k_n` reads as for a 1 µm vibration, whatever the
/// amplitude and frequency.
pub const NORMAL_REFERENCE_AMPLITUDE: f64 = 1e-6;

/// Frequency \[Hz\] at which the `velocity` and `acceleration` forms of `normal_coupling`
/// swing the normal load as much as the `displacement` form of the same `k_n`.
pub const NORMAL_REFERENCE_FREQUENCY: f64 = 1000.0;

/// Amplitude of the normal-load swing `ΔF_N` \[N\] of `normal_coupling` with `k_n` \[N/m\] in
/// the form of value `form`, at a substrate displacement amplitude `u` \[m\] and frequency `f`
/// \[Hz\] (0 where `u = 0`): `k_n u`, `k_n u f/f_ref`, `k_n u (f/f_ref)²` or `k_n u_ref`.
pub fn load_swing(k_n: f64, form: f64, f: f64, u: f64) -> f64 {
    if u == 0.0 {
        return 0.0;
    }
    let q = f / NORMAL_REFERENCE_FREQUENCY;
    match Swing::of(form) {
        Swing::Velocity => k_n * u * q,
        Swing::Acceleration => k_n * u * q * q,
        Swing::Fixed => k_n * NORMAL_REFERENCE_AMPLITUDE,
        Swing::Displacement => k_n * u,
    }
}

/// The load swing, with the substrate's displacement (its default form).
const DEFAULT_SCAN: Scan = Scan {
    param: K_N,
    label: "a normal-load modulation",
    fixed: &[(PHASE, 90.0), (DELAY, 0.0)],
    stronger_below: false,
    weak: None,
    strong: None,
    log: true,
};

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::NormalCoupling,
    name: "normal_coupling",
    doc: "the tangential vibration modulates the normal load and so F_c and F_s",
    params: &[
        ep(
            "k_n",
            "N/m",
            "normal load change per metre of tangential substrate displacement",
            (1e3, 1e9),
            2e7,
            true,
            Scale::Log,
        ),
        ep(
            "phase",
            "deg",
            "phase of the load change ahead of the displacement (90: with the velocity)",
            (-180.0, 180.0),
            90.0,
            true,
            Scale::Degrees,
        ),
        ep(
            "delay",
            "s",
            "time by which the load change lags the displacement besides its phase (a load path with a delay: its phase falls by 360° f delay)",
            (0.0, 1e-3),
            0.0,
            true,
            Scale::Linear,
        ),
        ep(
            "form",
            "-",
            "how the load swing scales: 0 displacement, 1 velocity, 2 acceleration, 3 fixed",
            (0.0, 3.0),
            0.0,
            false,
            Scale::Whole,
        ),
    ],
    candidate: true,
    form: Some(FORM),
    vibration_only: true,
    neutral: &[(K_N, 1e3), (DELAY, 0.0)],
    starts: &[
        (K_N, Grid::Log(1e6, 1e8, 5)),
        // With the velocity or against it: the sign of the mean friction change; the fit
        // then turns the phase towards the displacement.
        (PHASE, Grid::Values(&[-90.0, 90.0])),
    ],
    fit_steps: &[
        // A delay turns the phase by 360° f t_d: 5 µs is 4.5° at 2.5 kHz, a step the
        // features resolve where 0.05 % of the range would be lost in their roughness.
        (DELAY, 5e-6),
    ],
    forms: &[
        form(
            "displacement",
            "the load swing grows with the substrate's displacement amplitude: k_n A u0",
            0.0,
        ),
        form(
            "velocity",
            "it grows with the substrate's velocity amplitude: k_n A u0 f/f_ref, f_ref = 1 kHz",
            1.0,
        ),
        form(
            "acceleration",
            "it grows with the substrate's acceleration (a frame mode driven by the shaker's reaction): k_n A u0 (f/f_ref)²",
            2.0,
        ),
        form(
            "fixed",
            "a fixed swing while the substrate vibrates, set by the loading arm: k_n × 1 µm, whatever the amplitude and frequency",
            3.0,
        ),
    ],
    fit_ranges: &[],
    realistic: &[range(K_N, 2e7, 6e7)],
    scans: &[
        DEFAULT_SCAN,
        DEFAULT_SCAN.in_form(
            "a normal-load modulation with the substrate's velocity",
            K_N,
            &[(PHASE, 90.0), (DELAY, 0.0), (FORM, 1.0)],
        ),
        DEFAULT_SCAN.in_form(
            "a normal-load modulation with the substrate's acceleration",
            K_N,
            &[(PHASE, 90.0), (DELAY, 0.0), (FORM, 2.0)],
        ),
        DEFAULT_SCAN.in_form(
            "a normal-load modulation of fixed swing",
            K_N,
            &[(PHASE, 90.0), (DELAY, 0.0), (FORM, 3.0)],
        ),
    ],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, at: &At) {
    let fixed = Swing::of(v[FORM]) == Swing::Fixed;
    // Per metre of displacement amplitude; the fixed form's swing whatever it is.
    let c = load_swing(v[K_N], v[FORM], at.f, 1.0) / at.f_n;
    r.normal = Some((c, v[PHASE].to_radians() - TAU * at.f * v[DELAY], fixed))
}

/// Its load factor `ν` at `t` in the right-hand side ([`crate::model::extended`]): `max(0, 1 +
/// swing sin(ω (t − t_on) + φ))` from the switch-on, with vibration, the swing per metre of
/// amplitude times `u0` or fixed; 1 before.
#[inline(always)]
pub(crate) fn load_factor<T: Real>(sh: &Shape, c: &BaseCoeffs<T>, x: &FxCoeffs<T>, t: T) -> T {
    let (zero, one) = (T::splat(0.0), T::splat(1.0));
    let swing = if sh.normal_fixed { x.c_n } else { x.c_n * c.u0 };
    let phase = c.omega * (t - c.t_on) + x.phi;
    let on = (one + swing * sin(phase)).max(zero);
    // From the switch-on, with vibration.
    T::select(t.lt(c.t_on), one, T::select(c.u0.gt(zero), on, one))
}
