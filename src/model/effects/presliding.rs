//! Multi-element (Maxwell-slip) presliding in place of the single LuGre bristle: `N`
//! elements of stiffness `k_t/N` whose breakaway deformations spread about the mean.

use super::terms::{FxCoeffs, Shape};
use super::{At, EffectInfo, EffectKind, Effects, Grid, Param, Resolved, Scale, Scan, ep, range};
use crate::model::state::S;
use crate::ode::lanes::Real;

/// `spread`.
pub const SPREAD: Param = Param(0);
/// `elements`.
pub const ELEMENTS: Param = Param(1);

/// Presliding's elements, sized before any other effect's states (so the contact states stay
/// together): their number, spread and the states they add.
pub(crate) fn elements_first(fx: &Effects, r: &mut Resolved) {
    if let Some(n) = fx.at(EffectKind::Presliding, ELEMENTS) {
        r.elements = n as usize;
        r.spread = fx.at(EffectKind::Presliding, SPREAD).unwrap_or(0.0);
        r.dim += r.elements - 1;
    }
}

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::Presliding,
    name: "presliding",
    doc: "Maxwell-slip presliding: several elements that break away one after another",
    params: &[
        ep(
            "spread",
            "-",
            "spread of the elements' breakaway deformations about the mean",
            (0.0, 0.95),
            0.5,
            true,
            Scale::Linear,
        ),
        ep(
            "elements",
            "-",
            "number of elements (whole number)",
            (1.0, 8.0),
            4.0,
            false,
            Scale::Whole,
        ),
    ],
    candidate: true,
    form: None,
    vibration_only: false,
    neutral: &[(SPREAD, 0.0)],
    starts: &[(SPREAD, Grid::Values(&[0.3, 0.6, 0.9]))],
    fit_steps: &[],
    forms: &[],
    fit_ranges: &[],
    realistic: &[range(SPREAD, 0.5, 0.9)],
    scans: &[Scan {
        param: SPREAD,
        label: "presliding in four elements",
        fixed: &[(ELEMENTS, 4.0)],
        stronger_below: false,
        weak: None,
        strong: None,
        log: false,
    }],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
///
/// Nothing: its elements are sized first ([`elements_first`]), so the contact states stay
/// together.
fn resolve(_: &[f64], _: &mut Resolved, _: &At) {}

/// The bristles of the right-hand side ([`crate::model::extended`], Eq. 4.6): one, or N
/// Maxwell-slip elements of stiffness `k_t/N` with breakaway deformations `α_i g`, their rates
/// into `dy`; returns the sums of their deformations and of their rates.
#[inline(always)]
pub(crate) fn bristles<T: Real>(
    sh: &Shape,
    x: &FxCoeffs<T>,
    g: T,
    v_r: T,
    a: T,
    y: &[T],
    dy: &mut [T],
) -> (T, T) {
    let (zero, one) = (T::splat(0.0), T::splat(1.0));
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
    (sum_s, sum_sd)
}
