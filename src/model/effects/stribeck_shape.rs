//! The Stribeck curve's shape: an exponent other than 2, `exp(−(v_r/v_s)²) → exp(−|v_r/v_s|^δ)`,
//! or a rational curve `1/(1 + |v_r/v_s|^δ)`.

use super::terms::{FxCoeffs, Shape, Stribeck};
use super::{At, EffectInfo, EffectKind, Grid, Param, Resolved, Scale, Scan, ep, form, range};
use crate::model::base::gauss;
use crate::ode::lanes::{Real, exp, pow};

/// `delta`.
pub const DELTA: Param = Param(0);
/// `form`.
pub const FORM: Param = Param(1);

/// Its forms: the curve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Curve {
    /// `exp(−|v_r/v_s|^δ)`.
    Exponential,
    /// `1/(1 + |v_r/v_s|^δ)`.
    Rational,
}

impl Curve {
    /// The curve of the form parameter's value `v`.
    pub fn of(v: f64) -> Curve {
        if v == 1.0 {
            Curve::Rational
        } else {
            Curve::Exponential
        }
    }
}

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::StribeckShape,
    name: "stribeck_shape",
    doc: "a Stribeck exponent other than 2",
    params: &[
        ep(
            "delta",
            "-",
            "Stribeck exponent",
            (0.2, 10.0),
            1.0,
            true,
            Scale::Log,
        ),
        ep(
            "form",
            "-",
            "shape of the Stribeck curve: 0 exponential, 1 rational",
            (0.0, 1.0),
            0.0,
            false,
            Scale::Whole,
        ),
    ],
    candidate: true,
    form: Some(FORM),
    vibration_only: false,
    neutral: &[(DELTA, 2.0)],
    starts: &[(DELTA, Grid::Values(&[0.5, 1.0, 1.5, 3.0]))],
    fit_steps: &[],
    forms: &[
        form("exponential", "exp(−|v_r/v_s|^δ)", 0.0),
        form(
            "rational",
            "1/(1 + |v_r/v_s|^δ) (a Lorentzian curve at δ = 2)",
            1.0,
        ),
    ],
    fit_ranges: &[],
    realistic: &[range(DELTA, 0.5, 1.0)],
    scans: &[
        // The rational form has no neutral strength (at any exponent it is another curve)
        // and is not scanned.
        Scan {
            param: DELTA,
            label: "a Stribeck exponent below 2",
            fixed: &[],
            stronger_below: true,
            weak: Some(2.0),
            strong: None,
            log: true,
        },
        Scan {
            param: DELTA,
            label: "a Stribeck exponent above 2",
            fixed: &[],
            stronger_below: false,
            weak: Some(2.0),
            strong: None,
            log: true,
        },
    ],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, _: &At) {
    r.delta = v[DELTA];
    r.rational = Curve::of(v[FORM]) == Curve::Rational;
}

/// The Stribeck curve at `q = |w|/v_s` in the right-hand side ([`crate::model::extended`]):
/// `e^(−q²)` (docs/model.md, Eq. 4.7) without the effect, else its exponent and curve.
#[inline(always)]
pub(crate) fn curve<T: Real>(sh: &Shape, x: &FxCoeffs<T>, q: T) -> T {
    let one = T::splat(1.0);
    match sh.stribeck {
        Stribeck::Rational => one / (one + pow(q, x.delta)),
        Stribeck::Gauss => gauss(q * q),
        Stribeck::Power => exp(-pow(q, x.delta)),
    }
}
