//! Drive ripple: a periodic error in the drive's motion (screw or stepper motor),
//! `x_d = v_d t + a sin(2π v_d t / λ)`.

use super::terms::FxCoeffs;
use super::{At, EffectInfo, EffectKind, Param, Resolved, Scale, Scan, ep, range};
use crate::model::base::BaseCoeffs;
use crate::model::state::{V, X};
use crate::ode::lanes::{Real, cos, sin};
use std::f64::consts::TAU;

/// `a`.
pub const A: Param = Param(0);
/// `wavelength`.
pub const WAVELENGTH: Param = Param(1);

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::DriveRipple,
    name: "drive_ripple",
    doc: "a periodic error in the drive's motion (screw or stepper motor)",
    params: &[
        ep(
            "a",
            "m",
            "amplitude of the drive position error",
            (0.0, 1e-3),
            5e-6,
            true,
            Scale::Linear,
        ),
        ep(
            "wavelength",
            "m",
            "drive travel per period of the error",
            (1e-6, 0.1),
            0.3e-3,
            true,
            Scale::Log,
        ),
    ],
    candidate: true,
    form: None,
    vibration_only: false,
    neutral: &[(A, 0.0)],
    starts: &[],
    fit_steps: &[],
    forms: &[],
    fit_ranges: &[],
    realistic: &[range(A, 4e-6, 10e-6), range(WAVELENGTH, 0.2e-3, 0.5e-3)],
    scans: &[Scan {
        param: A,
        label: "a periodic drive error",
        fixed: &[],
        stronger_below: false,
        weak: Some(1e-8),
        strong: None,
        log: true,
    }],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, _: &At) {
    r.ripple = Some((v[A], TAU / v[WAVELENGTH]));
}

/// The drive force of the right-hand side ([`crate::model::extended`], Eqs. 4.3, 4.4) with the
/// ripple's displacement and velocity.
#[inline(always)]
pub(crate) fn drive_force<T: Real>(c: &BaseCoeffs<T>, x: &FxCoeffs<T>, t: T, y: &[T]) -> T {
    let one = T::splat(1.0);
    let arg = x.rip_k * c.v_d * t;
    let x_d = c.v_d * t + x.rip_a * sin(arg);
    let v_dr = c.v_d * (one + x.rip_a * x.rip_k * cos(arg));
    c.k_d * (x_d - y[X]) + c.h_d * (v_dr - y[V])
}
