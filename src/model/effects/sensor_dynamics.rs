//! Sensor dynamics: a lightly damped force sensor between the true and the recorded force,
//! `F_m'' = ω_n² (F_d − F_m) − 2 ζ ω_n F_m'`, of second or fourth order, its output recorded
//! late in `order4_delay`.

use super::terms::{FxCoeffs, Shape};
use super::{
    At, EffectInfo, EffectKind, Form, Grid, Param, Resolved, Scale, Scan, ep, form, range,
};
use crate::ode::lanes::Real;
use std::f64::consts::TAU;

/// `f_n`.
pub const F_N: Param = Param(0);
/// `zeta`.
pub const ZETA: Param = Param(1);
/// `form`.
pub const FORM: Param = Param(2);
/// `delay`.
pub const DELAY: Param = Param(3);

/// Its forms: the order of the sensor's filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// One second-order section.
    Order2,
    /// Two sections at `f_n`, of damping `ζ` and `(1 + √2) ζ`.
    Order4,
    /// `Order4`, its output recorded `delay` late.
    Order4Delay,
}

impl Order {
    /// The order of the form parameter's value `v`.
    pub fn of(v: f64) -> Order {
        if v == 2.0 {
            Order::Order4Delay
        } else if v >= 1.0 {
            Order::Order4
        } else {
            Order::Order2
        }
    }
}

/// The force sensor, of second order (its default form).
const DEFAULT_SCAN: Scan = Scan {
    param: F_N,
    label: "a load cell",
    fixed: &[(ZETA, 0.35)],
    stronger_below: true,
    weak: None,
    strong: None,
    log: true,
};

/// Its entry in the library ([`super::EFFECTS`]).
pub(super) const INFO: EffectInfo = EffectInfo {
    kind: EffectKind::SensorDynamics,
    name: "sensor_dynamics",
    doc: "a lightly damped second-order force sensor lies between the true and recorded force",
    params: &[
        ep(
            "f_n",
            "Hz",
            "natural frequency of the sensor",
            (10.0, 1e5),
            250.0,
            true,
            Scale::Log,
        ),
        ep(
            "zeta",
            "-",
            "damping ratio of the sensor",
            (0.005, 2.0),
            0.05,
            true,
            Scale::Log,
        ),
        ep(
            "form",
            "-",
            "order of the sensor's filter: 0 order2, 1 order4, 2 order4_delay",
            (0.0, 2.0),
            0.0,
            false,
            Scale::Whole,
        ),
        ep(
            "delay",
            "s",
            "delay of the recorded force behind the filter's output (order4_delay)",
            (0.0, 5e-3),
            1e-4,
            true,
            Scale::Linear,
        ),
    ],
    candidate: true,
    form: Some(FORM),
    vibration_only: false,
    neutral: &[(F_N, 2e4), (ZETA, 0.7)],
    starts: &[
        // A load cell carrying the frame rings at tens of hertz.
        (F_N, Grid::Log(20.0, 2e4, 10)),
        (ZETA, Grid::Values(&[0.05, 0.3, 0.7])),
    ],
    fit_steps: &[],
    forms: &[
        Form {
            name: "order2",
            doc: "one second-order section (a load cell's resonance)",
            value: 0.0,
            unused: &[DELAY],
        },
        Form {
            name: "order4",
            doc: "two second-order sections at f_n, of damping ζ and (1 + √2) ζ (a sharp anti-alias filter: Butterworth at ζ = 0.383)",
            value: 1.0,
            unused: &[DELAY],
        },
        form(
            "order4_delay",
            "order4, its output recorded a time `delay` late (an acquisition channel: anti-alias filter, then the converter's delay)",
            2.0,
        ),
    ],
    fit_ranges: &[range(F_N, 10.0, 2e4)],
    realistic: &[range(F_N, 40.0, 80.0), range(ZETA, 0.02, 0.08)],
    scans: &[
        DEFAULT_SCAN,
        DEFAULT_SCAN.in_form(
            "a fourth-order force filter",
            F_N,
            &[(ZETA, 0.383), (FORM, 1.0)],
        ),
    ],
    resolve,
};

/// Its share of the right-hand side's numbers ([`Resolved`]), from its values `v`, under the
/// conditions `at`.
fn resolve(v: &[f64], r: &mut Resolved, _: &At) {
    r.sensor = Some((TAU * v[F_N], v[ZETA], r.dim));
    r.dim += 2;
    let order = Order::of(v[FORM]);
    if order != Order::Order2 {
        r.sensor4 = Some((v[ZETA] * (1.0 + std::f64::consts::SQRT_2)).min(2.0));
        r.dim += 2;
    }
    if order == Order::Order4Delay {
        r.sensor_delay = v[DELAY];
    }
}

/// Its piece of the right-hand side ([`crate::model::extended`]): the sensor's sections driven
/// by the drive force `f_d`, their states from `y[i]` on.
#[inline(always)]
pub(crate) fn rhs<T: Real>(sh: &Shape, x: &FxCoeffs<T>, f_d: T, i: usize, y: &[T], dy: &mut [T]) {
    let two = T::splat(2.0);
    dy[i] = y[i + 1];
    dy[i + 1] = x.wn * x.wn * (f_d - y[i]) - two * x.zeta * x.wn * y[i + 1];
    if sh.sensor4 {
        // The second section filters the first's output.
        dy[i + 2] = y[i + 3];
        dy[i + 3] = x.wn * x.wn * (y[i] - y[i + 2]) - two * x.zeta2 * x.wn * y[i + 3];
    }
}
