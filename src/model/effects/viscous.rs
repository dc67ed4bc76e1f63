//! Viscous friction growing with the slip velocity, linearly or as a power of it:
//! `F_F → F_F + h_v v_r (|v_r|/V_1)^(n−1)`, `V_1` = 1 mm/s.

use super::terms::{FxCoeffs, Shape};
use super::{At, EffectInfo, EffectKind, Grid, Param, Resolved, Scale, Scan, ep, form, range};
use crate::ode::lanes::{Real, pow};

/// `h_v`.
pub const H_V: Param = Param(0);
/// `exponent`.
pub const EXPONENT: Param = Param(1);

/// Its forms: the power of the slip velocity (the form parameter is the exponent itself).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Power {
    /// `n = 1`: adds to the model's `h_v`.
    Linear,
    /// `n = 2`.
    Quadratic,
}

impl Power {
    /// The form of the exponent `v`, where it is one of the forms.
    pub fn of(v: f64) -> Option<Power> {
        match v {
            1.0 => Some(Power::Linear),
            2.0 => Some(Power::Quadratic),
            _ => None,
        }
    }
}

/// Viscous friction, linear in the slip velocity (its default form).
const DEFAULT_SCAN: Scan = Scan {
    param: H_V,
    label: "viscous friction",
    fixed: &[(EXPONENT, 1.0)],
    stronger_below: false,
    weak: Some(0.3),
    strong: None,
    log: true,
};

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::Viscous,
    name: "viscous",
    doc: "friction growing with the slip velocity: proportional to it, or to a power of it",
    params: &[
        ep(
            "h_v",
            "N s/m",
            "viscous friction coefficient at a slip velocity of 1 mm/s (added to the model's h_v where the exponent is 1)",
            (0.0, 1e4),
            50.0,
            true,
            Scale::Linear,
        ),
        ep(
            "exponent",
            "-",
            "power of the slip velocity: 1 linear (a lubricant film), 2 quadratic (a drag that grows with the square of the speed); not fitted by diagnose",
            (1.0, 3.0),
            1.0,
            false,
            Scale::Linear,
        ),
    ],
    candidate: true,
    form: Some(EXPONENT),
    vibration_only: false,
    neutral: &[(H_V, 0.0)],
    starts: &[(H_V, Grid::Values(&[20.0, 50.0, 100.0, 200.0]))],
    fit_steps: &[],
    forms: &[
        form(
            "linear",
            "friction proportional to the slip velocity (a lubricant film)",
            1.0,
        ),
        form(
            "quadratic",
            "friction growing with the square of the slip velocity (a drag)",
            2.0,
        ),
    ],
    fit_ranges: &[],
    realistic: &[range(H_V, 40.0, 100.0)],
    scans: &[
        DEFAULT_SCAN,
        DEFAULT_SCAN.in_form(
            "friction quadratic in the slip velocity",
            H_V,
            &[(EXPONENT, 2.0)],
        ),
    ],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, _: &At) {
    r.h_v = v[H_V];
    r.visc_n = v[EXPONENT];
}

/// The slip velocity `V_1` [m/s] at which the `viscous` effect's coefficient `h_v` is given
/// when its exponent is not 1: `F = h_v v_r (|v_r|/V_1)^(n−1)`, so that `h_v` keeps its unit
/// and its size (a quadratic drag `c₂ v_r |v_r|` has `h_v = c₂ V_1`).
pub const VISCOUS_REFERENCE: f64 = 1e-3;

/// The viscous coefficient of the right-hand side ([`crate::model::extended`]) at `a` =
/// `|v_r|`: the model's `h_v` with the effect's, linear or as its power of the slip velocity.
#[inline(always)]
pub(crate) fn coefficient<T: Real>(sh: &Shape, x: &FxCoeffs<T>, h_v: T, a: T) -> T {
    if sh.visc_linear {
        h_v + x.h_v
    } else {
        h_v + x.h_v * pow(a / T::splat(VISCOUS_REFERENCE), x.visc_n - T::splat(1.0))
    }
}
