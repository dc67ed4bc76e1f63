//! Ageing of static friction: the contact's state `θ` grows with the time it has been stuck
//! (Dieterich's ageing law) or evolves with slip only (Ruina's slip law), and `F_s` grows
//! with it: `F_s → F_s (1 + b ln(1 + θ/θ_0))`.

use super::terms::{FxCoeffs, Shape};
use super::{At, EffectInfo, EffectKind, Grid, Param, Resolved, Scale, Scan, ep, form, range};
use crate::ode::lanes::{Real, ln, ln_1p};

/// `b`.
pub const B: Param = Param(0);
/// `theta_0`.
pub const THETA_0: Param = Param(1);
/// `d_c`.
pub const D_C: Param = Param(2);
/// `form`.
pub const FORM: Param = Param(3);

/// Its forms: the law of the contact's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Law {
    /// `θ' = 1 − |v_r| θ / D_c`.
    AgeingLaw,
    /// `θ' = −x ln x`, `x = |v_r| θ / D_c`.
    SlipLaw,
}

impl Law {
    /// The law of the form parameter's value `v`.
    pub fn of(v: f64) -> Law {
        if v == 1.0 {
            Law::SlipLaw
        } else {
            Law::AgeingLaw
        }
    }
}

/// Ageing, by the ageing law (the family's default form).
const DEFAULT_SCAN: Scan = Scan {
    param: B,
    label: "ageing of static friction",
    fixed: &[(THETA_0, 0.01), (D_C, 1e-6)],
    stronger_below: false,
    weak: Some(5e-4),
    strong: None,
    log: true,
};

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::Aging,
    name: "aging",
    doc: "static friction grows with the time the contact has been stuck (dwell-time ageing)",
    params: &[
        ep(
            "b",
            "-",
            "ageing rate: relative growth of F_s per e-fold of contact age",
            (0.0, 0.5),
            0.03,
            true,
            Scale::Linear,
        ),
        ep(
            "theta_0",
            "s",
            "contact age at which ageing sets in",
            (1e-5, 10.0),
            0.01,
            false,
            Scale::Log,
        ),
        ep(
            "d_c",
            "m",
            "memory slip distance that renews the contact",
            (1e-9, 1e-3),
            1e-6,
            false,
            Scale::Log,
        ),
        ep(
            "form",
            "-",
            "form of the state law: 0 ageing_law, 1 slip_law",
            (0.0, 1.0),
            0.0,
            false,
            Scale::Whole,
        ),
    ],
    candidate: true,
    form: Some(FORM),
    vibration_only: false,
    neutral: &[(B, 0.0)],
    starts: &[(B, Grid::Values(&[0.02, 0.05, 0.1, 0.2]))],
    fit_steps: &[],
    forms: &[
        form(
            "ageing_law",
            "Dieterich's ageing law: the contact ages with stick time, θ' = 1 − |v_r| θ/D_c",
            0.0,
        ),
        form(
            "slip_law",
            "Ruina's slip law: the contact state evolves only with slip, θ' = −(|v_r| θ/D_c) ln(|v_r| θ/D_c)",
            1.0,
        ),
    ],
    fit_ranges: &[],
    realistic: &[range(B, 0.03, 0.06)],
    scans: &[
        DEFAULT_SCAN,
        DEFAULT_SCAN.in_form(
            "ageing of static friction by the slip law",
            B,
            &[(THETA_0, 0.01), (D_C, 1e-6), (FORM, 1.0)],
        ),
    ],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, _: &At) {
    r.aging = Some((v[B], v[THETA_0], v[D_C], r.dim));
    r.slip_law = Law::of(v[FORM]) == Law::SlipLaw;
    r.dim += 1;
}

/// Its piece of the right-hand side ([`crate::model::extended`]): the static friction `f_s`
/// grown by the contact's age `θ = y[i]`, and `θ'` into `dy[i]` (`a` = `|v_r|`).
#[inline(always)]
pub(crate) fn static_friction<T: Real>(
    sh: &Shape,
    x: &FxCoeffs<T>,
    f_s: T,
    a: T,
    i: usize,
    y: &[T],
    dy: &mut [T],
) -> T {
    let (zero, one) = (T::splat(0.0), T::splat(1.0));
    let theta = y[i].max(zero);
    let f_s = f_s * (one + x.b * ln_1p(theta / x.theta0));
    dy[i] = if sh.slip_law {
        // Ruina's slip law: the state moves only with slip; from a fresh contact's age of
        // 1 ns (θ = 0 would stay there).
        let q = a * theta.max(T::splat(1e-9)) / x.dc;
        T::select(q.gt(zero), -q * ln(q), zero)
    } else {
        one - a * y[i] / x.dc
    };
    f_s
}
