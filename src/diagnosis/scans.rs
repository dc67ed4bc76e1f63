//! The scans of the detection limits ([`super::limits`]): for each effect in each of its
//! forms, the parameter that sets its strength, the other parameters fixed, and the ends and
//! scale it is scanned over.

use crate::model::EffectKind;
use crate::model::effects::form_param;

/// One effect's scan: the parameter that sets its strength, in one form.
pub(crate) struct Scan {
    pub(crate) kind: EffectKind,
    pub(crate) param: &'static str,
    /// What the effect is, in a reader's words.
    pub(crate) label: &'static str,
    /// The other parameters and their values.
    pub(crate) fixed: &'static [(&'static str, f64)],
    /// The effect is stronger where the parameter is lower (a resonance).
    pub(crate) stronger_below: bool,
    /// The weak end, where the neutral value cannot serve (0 on a log scale; a scan of one
    /// side of the Stribeck exponent's 2).
    pub(crate) weak: Option<f64>,
    /// The strong end, where it is not the plausible range's.
    pub(crate) strong: Option<f64>,
    pub(crate) log: bool,
}

/// Ageing, by the ageing law (the family's default form; [`Scan::in_form`] for the others).
const AGING: Scan = Scan {
    kind: EffectKind::Aging,
    param: "b",
    label: "ageing of static friction",
    fixed: &[("theta_0", 0.01), ("d_c", 1e-6)],
    stronger_below: false,
    weak: Some(5e-4),
    strong: None,
    log: true,
};

/// The actuator, as a resonance (its default form).
const ACTUATOR: Scan = Scan {
    kind: EffectKind::ActuatorResponse,
    param: "f_r",
    label: "an actuator resonance",
    fixed: &[("zeta", 0.2)],
    stronger_below: true,
    weak: None,
    strong: None,
    log: true,
};

/// The load swing, with the substrate's displacement (its default form).
const NORMAL: Scan = Scan {
    kind: EffectKind::NormalCoupling,
    param: "k_n",
    label: "a normal-load modulation",
    fixed: &[("phase", 90.0), ("delay", 0.0)],
    stronger_below: false,
    weak: None,
    strong: None,
    log: true,
};

/// The force sensor, of second order (its default form).
const SENSOR: Scan = Scan {
    kind: EffectKind::SensorDynamics,
    param: "f_n",
    label: "a load cell",
    fixed: &[("zeta", 0.35)],
    stronger_below: true,
    weak: None,
    strong: None,
    log: true,
};

/// Viscous friction, linear in the slip velocity (its default form).
const VISCOUS: Scan = Scan {
    kind: EffectKind::Viscous,
    param: "h_v",
    label: "viscous friction",
    fixed: &[("exponent", 1.0)],
    stronger_below: false,
    weak: Some(0.3),
    strong: None,
    log: true,
};

/// The frictional lag, over a time (its default form).
const LAG: Scan = Scan {
    kind: EffectKind::FrictionalLag,
    param: "tau",
    label: "a frictional lag",
    fixed: &[],
    stronger_below: false,
    weak: None,
    strong: None,
    log: true,
};

/// Every scan of [`limits`]: each effect in its default form, then the other forms.
pub(crate) const SCANS: [Scan; 19] = [
    AGING,
    ACTUATOR,
    NORMAL,
    SENSOR,
    Scan {
        kind: EffectKind::DriveRipple,
        param: "a",
        label: "a periodic drive error",
        fixed: &[],
        stronger_below: false,
        weak: Some(1e-8),
        strong: None,
        log: true,
    },
    VISCOUS,
    Scan {
        kind: EffectKind::StribeckShape,
        param: "delta",
        label: "a Stribeck exponent below 2",
        fixed: &[],
        stronger_below: true,
        weak: Some(2.0),
        strong: None,
        log: true,
    },
    Scan {
        kind: EffectKind::StribeckShape,
        param: "delta",
        label: "a Stribeck exponent above 2",
        fixed: &[],
        stronger_below: false,
        weak: Some(2.0),
        strong: None,
        log: true,
    },
    Scan {
        kind: EffectKind::Presliding,
        param: "spread",
        label: "presliding in four elements",
        fixed: &[("elements", 4.0)],
        stronger_below: false,
        weak: None,
        strong: None,
        log: false,
    },
    LAG,
    // The other forms of each family with a strength to scan: a limit holds for the form it
    // states (a slip-law ageing, which does not heal at rest, stays unseen at twice the
    // ageing law's limit), so each form states its own. The Stribeck curve's rational form
    // has no neutral strength (at any exponent it is another curve) and is not scanned; the
    // delayed fourth-order sensor is the fourth-order one's scan at no delay (a delay only
    // adds a phase to what the filter shows, so that limit errs on the side of caution).
    AGING.in_form(
        "ageing of static friction by the slip law",
        "b",
        &[("theta_0", 0.01), ("d_c", 1e-6), ("form", 1.0)],
    ),
    ACTUATOR.in_form("a first-order actuator lag", "f_r", &[("form", 1.0)]),
    NORMAL.in_form(
        "a normal-load modulation with the substrate's velocity",
        "k_n",
        &[("phase", 90.0), ("delay", 0.0), ("form", 1.0)],
    ),
    NORMAL.in_form(
        "a normal-load modulation with the substrate's acceleration",
        "k_n",
        &[("phase", 90.0), ("delay", 0.0), ("form", 2.0)],
    ),
    NORMAL.in_form(
        "a normal-load modulation of fixed swing",
        "k_n",
        &[("phase", 90.0), ("delay", 0.0), ("form", 3.0)],
    ),
    SENSOR.in_form(
        "a fourth-order force filter",
        "f_n",
        &[("zeta", 0.383), ("form", 1.0)],
    ),
    VISCOUS.in_form(
        "friction quadratic in the slip velocity",
        "h_v",
        &[("exponent", 2.0)],
    ),
    LAG.in_form(
        "a frictional memory over a slip distance",
        "length",
        &[("form", 1.0)],
    ),
    LAG.in_form(
        "a Stribeck level with a memory over a slip distance",
        "length",
        &[("form", 2.0)],
    ),
];

impl Scan {
    /// This scan in another form of the effect's family: its label, the parameter that sets
    /// its strength there and its other parameters (the form parameter among them); the scale
    /// and the ends as this one's.
    const fn in_form(
        self,
        label: &'static str,
        param: &'static str,
        fixed: &'static [(&'static str, f64)],
    ) -> Scan {
        Scan {
            label,
            param,
            fixed,
            ..self
        }
    }

    /// The name of the form scanned: the form parameter's value among `fixed`, else the
    /// family's default form.
    pub(crate) fn form_name(&self) -> &'static str {
        let q = form_param(self.kind);
        let v = self
            .fixed
            .iter()
            .find(|(n, _)| *n == q)
            .map_or(self.kind.default_form(), |f| f.1);
        self.kind
            .info()
            .forms
            .iter()
            .find(|f| f.value == v)
            .map_or("", |f| f.name)
    }
}
