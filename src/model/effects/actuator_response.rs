//! The actuator's response: the substrate's real vibration amplitude `A u0` follows a
//! resonance of the piezo and saddle, or a first-order lag, with frequency.

use super::{
    At, EffectInfo, EffectKind, Effects, Form, Param, Resolved, Scale, Scan, ep, form, range,
};

/// `f_r`.
pub const F_R: Param = Param(0);
/// `zeta`.
pub const ZETA: Param = Param(1);
/// `form`.
pub const FORM: Param = Param(2);

/// Its forms: the order of the response.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Response {
    /// Two poles: `A = 1 / √((1 − (f/f_r)²)² + (2 ζ f/f_r)²)`.
    Resonance,
    /// One pole: `A = 1/√(1 + (f/f_r)²)`.
    FirstOrder,
}

impl Response {
    /// The response of the form parameter's value `v`.
    pub fn of(v: f64) -> Response {
        if v == 1.0 {
            Response::FirstOrder
        } else {
            Response::Resonance
        }
    }
}

/// Gain of the `actuator_response` resonance at the forcing frequency `f` \[Hz\] (module
/// docs): `A = 1 / √((1 − (f/f_r)²)² + (2 ζ f/f_r)²)`, 1 at `f = 0`, `1/(2ζ)` at `f = f_r`.
pub fn actuator_gain(f: f64, f_r: f64, zeta: f64) -> f64 {
    let q = f / f_r;
    1.0 / ((1.0 - q * q).powi(2) + (2.0 * zeta * q).powi(2)).sqrt()
}

/// Gain `A` of the substrate's amplitude at `f` \[Hz\] under `fx`'s `actuator_response` in its
/// form (1 without it).
pub fn amplitude_gain(fx: &Effects, f: f64) -> f64 {
    let k = EffectKind::ActuatorResponse;
    match (fx.at(k, F_R), fx.at(k, ZETA), fx.at(k, FORM)) {
        (Some(f_r), Some(zeta), Some(form)) => response_gain(form, f, f_r, zeta),
        _ => 1.0,
    }
}

/// Gain of `actuator_response` in the form of value `form` at `f` \[Hz\]: [`first_order_gain`]
/// for `first_order` (`zeta` unused), else [`actuator_gain`].
pub fn response_gain(form: f64, f: f64, f_r: f64, zeta: f64) -> f64 {
    match Response::of(form) {
        Response::FirstOrder => first_order_gain(f, f_r),
        Response::Resonance => actuator_gain(f, f_r, zeta),
    }
}

/// Gain of the `first_order` form of `actuator_response` at `f` \[Hz\]: one pole at the corner
/// `f_r`, `A = 1/√(1 + (f/f_r)²)`.
pub fn first_order_gain(f: f64, f_r: f64) -> f64 {
    1.0 / (1.0 + (f / f_r).powi(2)).sqrt()
}

/// The actuator, as a resonance (its default form).
const DEFAULT_SCAN: Scan = Scan {
    param: F_R,
    label: "an actuator resonance",
    fixed: &[(ZETA, 0.2)],
    stronger_below: true,
    weak: None,
    strong: None,
    log: true,
};

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::ActuatorResponse,
    name: "actuator_response",
    doc: "the substrate's vibration amplitude follows a resonance of the piezo and saddle",
    params: &[
        ep(
            "f_r",
            "Hz",
            "resonance frequency of actuator and saddle",
            (100.0, 1e5),
            4000.0,
            true,
            Scale::Log,
        ),
        ep(
            "zeta",
            "-",
            "damping ratio of that resonance",
            (0.01, 2.0),
            0.2,
            true,
            Scale::Log,
        ),
        ep(
            "form",
            "-",
            "order of the response: 0 resonance (two poles), 1 first_order (one pole)",
            (0.0, 1.0),
            0.0,
            false,
            Scale::Whole,
        ),
    ],
    candidate: true,
    form: Some(FORM),
    vibration_only: true,
    neutral: &[(F_R, 1e5), (ZETA, 0.7)],
    starts: &[],
    fit_steps: &[],
    forms: &[
        form(
            "resonance",
            "two poles: a resonance at f_r with damping ζ",
            0.0,
        ),
        Form {
            name: "first_order",
            doc: "one pole: a first-order lag of corner f_r, A = 1/√(1 + (f/f_r)²)",
            value: 1.0,
            unused: &[ZETA],
        },
    ],
    fit_ranges: &[],
    realistic: &[range(F_R, 2500.0, 5000.0), range(ZETA, 0.05, 0.2)],
    scans: &[
        DEFAULT_SCAN,
        DEFAULT_SCAN.in_form("a first-order actuator lag", F_R, &[(FORM, 1.0)]),
    ],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, at: &At) {
    r.gain = response_gain(v[FORM], at.f, v[F_R], v[ZETA]);
}
