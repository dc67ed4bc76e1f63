//! Frictional lag: the friction force lags behind changes of the slip velocity, over a time
//! (`τ w' = v_r − w`) or a slip distance, or the Stribeck level itself lags over slip.

use super::terms::{FxCoeffs, Lag, Shape};
use super::{At, EffectInfo, EffectKind, Form, Grid, Param, Resolved, Scale, Scan, ep, range};
use crate::ode::lanes::Real;

/// `tau`.
pub const TAU: Param = Param(0);
/// `length`.
pub const LENGTH: Param = Param(1);
/// `form`.
pub const FORM: Param = Param(2);

/// Its forms are [`Lag`]'s: what the lag runs over.
pub fn lag_of(v: f64) -> Lag {
    match v {
        1.0 => Lag::Distance,
        2.0 => Lag::Level,
        _ => Lag::Time,
    }
}

/// The frictional lag, over a time (its default form).
const DEFAULT_SCAN: Scan = Scan {
    param: TAU,
    label: "a frictional lag",
    fixed: &[],
    stronger_below: false,
    weak: None,
    strong: None,
    log: true,
};

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::FrictionalLag,
    name: "frictional_lag",
    doc: "the friction force lags behind changes of the slip velocity",
    params: &[
        ep(
            "tau",
            "s",
            "time constant of the lag (form time)",
            (1e-6, 1.0),
            1e-3,
            true,
            Scale::Log,
        ),
        ep(
            "length",
            "m",
            "memory slip distance of the lag (forms distance and level)",
            (1e-9, 1e-3),
            1e-6,
            true,
            Scale::Log,
        ),
        ep(
            "form",
            "-",
            "what the lag runs over: 0 time, 1 distance (slip), 2 level (the Stribeck level over slip)",
            (0.0, 2.0),
            0.0,
            false,
            Scale::Whole,
        ),
    ],
    candidate: true,
    form: Some(FORM),
    vibration_only: false,
    neutral: &[(TAU, 3e-5), (LENGTH, 1e-7)],
    starts: &[
        (TAU, Grid::Log(1e-4, 1e-2, 4)),
        // A memory of 0.1 to 10 µm of slip: 0.1 to 10 ms at 1 mm/s.
        (LENGTH, Grid::Log(1e-7, 1e-5, 4)),
    ],
    fit_steps: &[],
    forms: &[
        Form {
            name: "time",
            doc: "the lag is a time: τ w' = v_r − w",
            value: 0.0,
            unused: &[LENGTH],
        },
        Form {
            name: "distance",
            doc: "the memory fades over slip distance: L w' = |v_r| (v_r − w)",
            value: 1.0,
            unused: &[TAU],
        },
        Form {
            name: "level",
            doc: "the Stribeck level lags over slip distance: L φ' = |v_r| (e(v_r) − φ), \
                  g = F_c + (F_s − F_c) φ",
            value: 2.0,
            unused: &[TAU],
        },
    ],
    fit_ranges: &[
        range(TAU, 3e-5, 1.0),
        // 0.1 µm of slip: 25 µs at the 4 mm/s of the fastest vibrated slips.
        range(LENGTH, 1e-7, 1e-3),
    ],
    realistic: &[range(TAU, 0.5e-3, 2e-3), range(LENGTH, 0.5e-6, 2e-6)],
    scans: &[
        DEFAULT_SCAN,
        DEFAULT_SCAN.in_form(
            "a frictional memory over a slip distance",
            LENGTH,
            &[(FORM, 1.0)],
        ),
        DEFAULT_SCAN.in_form(
            "a Stribeck level with a memory over a slip distance",
            LENGTH,
            &[(FORM, 2.0)],
        ),
    ],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, _: &At) {
    r.lag_form = lag_of(v[FORM]);
    let l = if r.lag_form == Lag::Time {
        v[TAU]
    } else {
        v[LENGTH]
    };
    r.lag = Some((l, r.dim));
    r.dim += 1;
}

/// Its piece of the right-hand side ([`crate::model::extended`]) in the forms `time` and
/// `distance`: the lagged velocity `w = y[i]` the Stribeck curve is evaluated at, and `w'`
/// into `dy[i]` (`a` = `|v_r|`).
#[inline(always)]
pub(crate) fn lagged_velocity<T: Real>(
    sh: &Shape,
    x: &FxCoeffs<T>,
    v_r: T,
    a: T,
    i: usize,
    y: &[T],
    dy: &mut [T],
) -> T {
    dy[i] = if sh.lag_form == Lag::Distance {
        // A memory distance L (in `tau`'s place): it fades only as the contact slips.
        a * (v_r - y[i]) / x.tau
    } else {
        (v_r - y[i]) / x.tau
    };
    y[i]
}

/// Its piece of the right-hand side in the form `level`: the level φ = 1 − ψ relaxes over
/// slip distance L towards the curve's value `e_s` at the slip velocity, L φ' = |v_r| (e_s −
/// φ); the state is ψ = `y[i]` so a fresh contact starts at 0. Returns the lagged level.
#[inline(always)]
pub(crate) fn lagged_level<T: Real>(
    x: &FxCoeffs<T>,
    a: T,
    e_s: T,
    i: usize,
    y: &[T],
    dy: &mut [T],
) -> T {
    let one = T::splat(1.0);
    dy[i] = a * ((one - e_s) - y[i]) / x.tau;
    one - y[i]
}
