//! Friction varying with position along the track, `F_c, F_s → (1 + a sin(2π (x + x_0)/λ)) F_c, …`:
//! a test effect, not a diagnosis candidate.

use super::terms::FxCoeffs;
use super::{At, EffectInfo, EffectKind, Param, Resolved, Scale, ep, range};
use crate::model::state::X;
use crate::ode::lanes::{Real, sin};
use std::f64::consts::TAU;

/// `a`.
pub const A: Param = Param(0);
/// `wavelength`.
pub const WAVELENGTH: Param = Param(1);
/// `offset`.
pub const OFFSET: Param = Param(2);

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::Track,
    name: "track",
    doc: "friction varying with position along the track (for testing; not a diagnosis candidate)",
    params: &[
        ep(
            "a",
            "-",
            "relative amplitude of the friction variation",
            (0.0, 0.5),
            0.1,
            false,
            Scale::Linear,
        ),
        ep(
            "wavelength",
            "m",
            "period of the variation along the track",
            (1e-6, 1.0),
            0.7e-3,
            false,
            Scale::Log,
        ),
        ep(
            "offset",
            "m",
            "track position at x = 0",
            (0.0, 1.0),
            0.0,
            false,
            Scale::Linear,
        ),
    ],
    candidate: false,
    form: None,
    vibration_only: false,
    neutral: &[],
    starts: &[],
    fit_steps: &[],
    forms: &[],
    fit_ranges: &[],
    realistic: &[
        range(A, 0.08, 0.15),
        range(WAVELENGTH, 0.5e-3, 1e-3),
        range(OFFSET, 0.0, 0.0),
    ],
    scans: &[],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, _: &At) {
    r.track = Some((v[A], TAU / v[WAVELENGTH], v[OFFSET]));
}

/// Its factor on `F_c` and `F_s` in the right-hand side ([`crate::model::extended`]):
/// `1 + a sin(2π (x + x_0)/λ)`.
#[inline(always)]
pub(crate) fn load_factor<T: Real>(x: &FxCoeffs<T>, y: &[T]) -> T {
    T::splat(1.0) + x.tr_a * sin(x.tr_k * (y[X] + x.tr_x0))
}
