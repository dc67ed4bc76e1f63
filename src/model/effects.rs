//! Physical effects the base model of docs/model.md leaves out, as switchable model extensions.
//!
//! Each effect has a name (part of the file and command interface: `[effects.aging]` in a case
//! or sweep file), a few parameters with units, defaults and physical bounds, and a precise
//! place in the equations of [`crate::model`]. With no effect switched on the model is exactly
//! docs/model.md's. With effects on, the state grows after `[x, v, s]` and the equations read
//! (`ν` the normal-load factor, `A` the actuator gain; every symbol below is an effect parameter):
//!
//! ```text
//! aging              θ' = 1 − |v_r| θ / D_c                       (Dieterich's ageing law, θ = contact age)
//!                    F_s → F_s (1 + b ln(1 + θ/θ_0))
//! actuator_response  u0 → A u0,  A = 1 / √((1 − (f/f_r)²)² + (2 ζ f/f_r)²)   (piezo + saddle resonance)
//! normal_coupling    ν(t) = max(0, 1 + k_n A u0 sin(ω (t − t_d) + φ) / F_N);  F_c, F_s → ν F_c, ν F_s
//! sensor_dynamics    F_m'' = ω_n² (F_d − F_m) − 2 ζ ω_n F_m'      (recorded force F_m, ω_n = 2π f_n)
//! drive_ripple       x_d = v_d t + a sin(2π v_d t / λ)            (screw or stepper periodic error)
//! viscous            F_F → F_F + h_v v_r (|v_r|/V_1)^(n−1),  V_1 = 1 mm/s   (n = 1: adds to h_v)
//! stribeck_shape     exp(−(v_r/v_s)²) → exp(−|v_r/v_s|^δ)
//! presliding         N Maxwell-slip elements of stiffness k_t/N, breakaway deformations
//!                    α_i g(v_r), α_i = 1 + spread (2i/(N−1) − 1):  s_i' = v_r − |v_r| s_i/(α_i g),
//!                    F_F = Σ_i (k_t s_i + h_t(v_r) s_i')/N + h_v v_r
//! frictional_lag     τ w' = v_r − w;  the Stribeck curve g is evaluated at the lagged velocity w
//! track              F_c, F_s → (1 + a sin(2π (x + x_0)/λ)) F_c, ...   (friction varying along the
//!                    track; a test effect, not a diagnosis candidate)
//! ```
//!
//! Most effects come in a **family of forms** ([`EffectInfo::forms`]), chosen by a whole-numbered
//! parameter (`form`; for `viscous`, its `exponent`), set by name in files and specs:
//!
//! ```text
//! aging              ageing_law (above) | slip_law: θ' = −x ln x, x = |v_r| θ/D_c (θ from 1 ns)
//! actuator_response  resonance (above) | first_order: A = 1/√(1 + (f/f_r)²)  (ζ unused)
//! normal_coupling    swing k_n A u0 × 1 | f/f_ref | (f/f_ref)²  (displacement, velocity,
//!                    acceleration; f_ref = 1 kHz) | fixed: k_n × 1 µm while vibrating
//! sensor_dynamics    order2 (above) | order4: a second section at ω_n, damping (1 + √2) ζ,
//!                    filters the first's output (Butterworth at ζ = 0.383) | order4_delay:
//!                    order4's output recorded `delay` late, F_rec(t) = F_m(t − delay)
//! viscous            linear (n = 1) | quadratic (n = 2)
//! stribeck_shape     exponential (above) | rational: 1/(1 + |v_r/v_s|^δ)
//! frictional_lag     time (above) | distance: L w' = |v_r| (v_r − w)  (τ unused, L = `length`) |
//!                    level: the Stribeck level φ lags over slip distance instead of the
//!                    velocity, L φ' = |v_r| (e(v_r) − φ), g = F_c + (F_s − F_c) φ
//! ```
//!
//! Bounds are physical: a resonance between 100 Hz and 100 kHz, a Stribeck exponent from 0.2 to
//! 10, a presliding spread below 0.95 (no element may break away at zero force), and so on; see
//! [`EFFECTS`].

use super::extended::{FxCoeffs, Lag, Shape, Stribeck};
use std::fmt;

/// One switchable effect.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum EffectKind {
    /// Static friction grows with the time the contact has been stuck.
    Aging,
    /// The substrate's real vibration amplitude departs from the nominal one with frequency.
    ActuatorResponse,
    /// The tangential vibration modulates the normal load, and so `F_c` and `F_s`.
    NormalCoupling,
    /// A lightly damped second-order force sensor between the true and the recorded force.
    SensorDynamics,
    /// A periodic error in the drive's motion.
    DriveRipple,
    /// Friction growing with the slip velocity (linearly, or as a power of it).
    Viscous,
    /// A Stribeck exponent other than 2.
    StribeckShape,
    /// Multi-element (Maxwell-slip) presliding in place of the single LuGre bristle.
    Presliding,
    /// The friction force lags behind changes of the slip velocity.
    FrictionalLag,
    /// Friction varying with position along the track (not a diagnosis candidate).
    Track,
}

/// One parameter of an effect.
#[derive(Clone, Copy, Debug)]
pub struct EffectParam {
    /// Name in `[effects.NAME]` tables.
    pub name: &'static str,
    /// SI unit.
    pub unit: &'static str,
    /// Meaning.
    pub doc: &'static str,
    /// Smallest allowed value.
    pub min: f64,
    /// Largest allowed value.
    pub max: f64,
    /// Value when the table leaves it out.
    pub default: f64,
    /// Fitted by `calibrate`/`diagnose` (the others stay at their given value).
    pub fitted: bool,
    /// Fitted on a log scale (positive quantities spanning decades).
    pub log: bool,
}

/// An effect's name, meaning and parameters.
#[derive(Clone, Copy, Debug)]
pub struct EffectInfo {
    /// The effect.
    pub kind: EffectKind,
    /// Name in files and on the command line.
    pub name: &'static str,
    /// One line of physics.
    pub doc: &'static str,
    /// Its parameters.
    pub params: &'static [EffectParam],
    /// Whether `diagnose` tries it as an explanation of a gap.
    pub candidate: bool,
    /// Its forms: how its strength scales with the conditions, or its order where it is a
    /// filter ([`Form`]); empty where the library has one form. The first is the default.
    pub forms: &'static [Form],
}

/// One form of an effect: a value of its form parameter (`form`, or `exponent` for
/// `viscous`), with the parameters that form leaves unused (neither fitted nor reported).
#[derive(Clone, Copy, Debug)]
pub struct Form {
    /// Name in files, on the command line and in reports (`form = "velocity"`).
    pub name: &'static str,
    /// What it means.
    pub doc: &'static str,
    /// The form parameter's value.
    pub value: f64,
    /// Parameters this form does not use.
    pub unused: &'static [&'static str],
}

const fn form(name: &'static str, doc: &'static str, value: f64) -> Form {
    Form {
        name,
        doc,
        value,
        unused: &[],
    }
}

/// The parameter whose value chooses an effect's form.
pub fn form_param(kind: EffectKind) -> &'static str {
    if kind == EffectKind::Viscous {
        "exponent"
    } else {
        "form"
    }
}

/// Displacement amplitude \[m\] at which the `fixed` form of `normal_coupling` swings the
/// normal load by `k_n` times it: its `k_n` reads as for a 1 µm vibration, whatever the
/// amplitude and frequency.
pub const NORMAL_REFERENCE_AMPLITUDE: f64 = 1e-6;

/// Frequency \[Hz\] at which the `velocity` and `acceleration` forms of `normal_coupling`
/// swing the normal load as much as the `displacement` form of the same `k_n`.
pub const NORMAL_REFERENCE_FREQUENCY: f64 = 1000.0;

/// Amplitude of the normal-load swing `ΔF_N` \[N\] of `normal_coupling` with `k_n` \[N/m\] in
/// the form of value `form`, at a substrate displacement amplitude `u` \[m\] and frequency `f`
/// \[Hz\] (0 where `u = 0`): `k_n u`, `k_n u f/f_ref`, `k_n u (f/f_ref)²` or `k_n u_ref`.
pub fn load_swing(k_n: f64, form: f64, f: f64, u: f64) -> f64 {
    if u == 0.0 {
        return 0.0;
    }
    let q = f / NORMAL_REFERENCE_FREQUENCY;
    match form as usize {
        1 => k_n * u * q,
        2 => k_n * u * q * q,
        3 => k_n * NORMAL_REFERENCE_AMPLITUDE,
        _ => k_n * u,
    }
}

/// One entry of [`EFFECTS`]: `range` is `(min, max)`.
const fn ep(
    name: &'static str,
    unit: &'static str,
    doc: &'static str,
    range: (f64, f64),
    default: f64,
    fitted: bool,
    log: bool,
) -> EffectParam {
    EffectParam {
        name,
        unit,
        doc,
        min: range.0,
        max: range.1,
        default,
        fitted,
        log,
    }
}

/// The library of effects, in a fixed order.
pub static EFFECTS: [EffectInfo; 10] = [
    EffectInfo {
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
                false,
            ),
            ep(
                "theta_0",
                "s",
                "contact age at which ageing sets in",
                (1e-5, 10.0),
                0.01,
                false,
                true,
            ),
            ep(
                "d_c",
                "m",
                "memory slip distance that renews the contact",
                (1e-9, 1e-3),
                1e-6,
                false,
                true,
            ),
            ep(
                "form",
                "-",
                "form of the state law: 0 ageing_law, 1 slip_law",
                (0.0, 1.0),
                0.0,
                false,
                false,
            ),
        ],
        candidate: true,
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
    },
    EffectInfo {
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
                true,
            ),
            ep(
                "zeta",
                "-",
                "damping ratio of that resonance",
                (0.01, 2.0),
                0.2,
                true,
                true,
            ),
            ep(
                "form",
                "-",
                "order of the response: 0 resonance (two poles), 1 first_order (one pole)",
                (0.0, 1.0),
                0.0,
                false,
                false,
            ),
        ],
        candidate: true,
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
                unused: &["zeta"],
            },
        ],
    },
    EffectInfo {
        kind: EffectKind::NormalCoupling,
        name: "normal_coupling",
        doc: "the tangential vibration modulates the normal load and so F_c and F_s",
        params: &[
            ep(
                "k_n",
                "N/m",
                "normal load change per metre of tangential substrate displacement",
                (1e3, 1e9),
                2e7,
                true,
                true,
            ),
            ep(
                "phase",
                "deg",
                "phase of the load change ahead of the displacement (90: with the velocity)",
                (-180.0, 180.0),
                90.0,
                true,
                false,
            ),
            ep(
                "delay",
                "s",
                "time by which the load change lags the displacement besides its phase (a load path with a delay: its phase falls by 360° f delay)",
                (0.0, 1e-3),
                0.0,
                true,
                false,
            ),
            ep(
                "form",
                "-",
                "how the load swing scales: 0 displacement, 1 velocity, 2 acceleration, 3 fixed",
                (0.0, 3.0),
                0.0,
                false,
                false,
            ),
        ],
        candidate: true,
        forms: &[
            form(
                "displacement",
                "the load swing grows with the substrate's displacement amplitude: k_n A u0",
                0.0,
            ),
            form(
                "velocity",
                "it grows with the substrate's velocity amplitude: k_n A u0 f/f_ref, f_ref = 1 kHz",
                1.0,
            ),
            form(
                "acceleration",
                "it grows with the substrate's acceleration (a frame mode driven by the shaker's reaction): k_n A u0 (f/f_ref)²",
                2.0,
            ),
            form(
                "fixed",
                "a fixed swing while the substrate vibrates, set by the loading arm: k_n × 1 µm, whatever the amplitude and frequency",
                3.0,
            ),
        ],
    },
    EffectInfo {
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
                true,
            ),
            ep(
                "zeta",
                "-",
                "damping ratio of the sensor",
                (0.005, 2.0),
                0.05,
                true,
                true,
            ),
            ep(
                "form",
                "-",
                "order of the sensor's filter: 0 order2, 1 order4, 2 order4_delay",
                (0.0, 2.0),
                0.0,
                false,
                false,
            ),
            ep(
                "delay",
                "s",
                "delay of the recorded force behind the filter's output (order4_delay)",
                (0.0, 5e-3),
                1e-4,
                true,
                false,
            ),
        ],
        candidate: true,
        forms: &[
            Form {
                name: "order2",
                doc: "one second-order section (a load cell's resonance)",
                value: 0.0,
                unused: &["delay"],
            },
            Form {
                name: "order4",
                doc: "two second-order sections at f_n, of damping ζ and (1 + √2) ζ (a sharp anti-alias filter: Butterworth at ζ = 0.383)",
                value: 1.0,
                unused: &["delay"],
            },
            form(
                "order4_delay",
                "order4, its output recorded a time `delay` late (an acquisition channel: anti-alias filter, then the converter's delay)",
                2.0,
            ),
        ],
    },
    EffectInfo {
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
                false,
            ),
            ep(
                "wavelength",
                "m",
                "drive travel per period of the error",
                (1e-6, 0.1),
                0.3e-3,
                true,
                true,
            ),
        ],
        candidate: true,
        forms: &[],
    },
    EffectInfo {
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
                false,
            ),
            ep(
                "exponent",
                "-",
                "power of the slip velocity: 1 linear (a lubricant film), 2 quadratic (a drag that grows with the square of the speed); not fitted by diagnose",
                (1.0, 3.0),
                1.0,
                false,
                false,
            ),
        ],
        candidate: true,
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
    },
    EffectInfo {
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
                true,
            ),
            ep(
                "form",
                "-",
                "shape of the Stribeck curve: 0 exponential, 1 rational",
                (0.0, 1.0),
                0.0,
                false,
                false,
            ),
        ],
        candidate: true,
        forms: &[
            form("exponential", "exp(−|v_r/v_s|^δ)", 0.0),
            form(
                "rational",
                "1/(1 + |v_r/v_s|^δ) (a Lorentzian curve at δ = 2)",
                1.0,
            ),
        ],
    },
    EffectInfo {
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
                false,
            ),
            ep(
                "elements",
                "-",
                "number of elements (whole number)",
                (1.0, 8.0),
                4.0,
                false,
                false,
            ),
        ],
        candidate: true,
        forms: &[],
    },
    EffectInfo {
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
                true,
            ),
            ep(
                "length",
                "m",
                "memory slip distance of the lag (forms distance and level)",
                (1e-9, 1e-3),
                1e-6,
                true,
                true,
            ),
            ep(
                "form",
                "-",
                "what the lag runs over: 0 time, 1 distance (slip), 2 level (the Stribeck level over slip)",
                (0.0, 2.0),
                0.0,
                false,
                false,
            ),
        ],
        candidate: true,
        forms: &[
            Form {
                name: "time",
                doc: "the lag is a time: τ w' = v_r − w",
                value: 0.0,
                unused: &["length"],
            },
            Form {
                name: "distance",
                doc: "the memory fades over slip distance: L w' = |v_r| (v_r − w)",
                value: 1.0,
                unused: &["tau"],
            },
            Form {
                name: "level",
                doc: "the Stribeck level lags over slip distance: L φ' = |v_r| (e(v_r) − φ), \
                      g = F_c + (F_s − F_c) φ",
                value: 2.0,
                unused: &["tau"],
            },
        ],
    },
    EffectInfo {
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
                false,
            ),
            ep(
                "wavelength",
                "m",
                "period of the variation along the track",
                (1e-6, 1.0),
                0.7e-3,
                false,
                true,
            ),
            ep(
                "offset",
                "m",
                "track position at x = 0",
                (0.0, 1.0),
                0.0,
                false,
                false,
            ),
        ],
        candidate: false,
        forms: &[],
    },
];

impl EffectKind {
    /// Its entry in [`EFFECTS`].
    pub fn info(self) -> &'static EffectInfo {
        EFFECTS
            .iter()
            .find(|e| e.kind == self)
            .expect("every kind is listed")
    }

    /// Its name in files.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The effect of a name.
    pub fn from_name(name: &str) -> Option<EffectKind> {
        EFFECTS.iter().find(|e| e.name == name).map(|e| e.kind)
    }

    /// Its form of value `value` of its form parameter ([`form_param`]).
    pub fn form_of(self, value: f64) -> Option<&'static Form> {
        self.info().forms.iter().find(|f| f.value == value)
    }

    /// Its form named `name`.
    pub fn form_named(self, name: &str) -> Option<&'static Form> {
        self.info().forms.iter().find(|f| f.name == name)
    }

    /// Whether the effect acts only through the substrate's vibration: with a vibration
    /// amplitude `u0` of 0 the model with it is the model without it, term for term (the
    /// actuator scales `u0`; the load swing is switched on with the vibration).
    pub fn vibration_only(self) -> bool {
        matches!(
            self,
            EffectKind::ActuatorResponse | EffectKind::NormalCoupling
        )
    }

    /// The value of its form parameter in its default form (0 where it has no forms).
    pub fn default_form(self) -> f64 {
        let name = form_param(self);
        self.info()
            .params
            .iter()
            .find(|p| p.name == name)
            .map_or(0.0, |p| p.default)
    }

    /// The effects `diagnose` tries.
    pub fn candidates() -> Vec<EffectKind> {
        EFFECTS
            .iter()
            .filter(|e| e.candidate)
            .map(|e| e.kind)
            .collect()
    }
}

/// An effect in files is its name ([`EffectKind::name`]).
impl serde::Serialize for EffectKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// An effect is read by its name; an unknown name is refused with the names allowed.
impl<'de> serde::Deserialize<'de> for EffectKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        EffectKind::from_name(&name)
            .ok_or_else(|| serde::de::Error::custom(EffectError::UnknownEffect(name)))
    }
}

impl fmt::Display for EffectKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An effect parameter out of range or unknown.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EffectError {
    /// No such effect.
    #[error("unknown effect `{0}`; allowed: {list}", list = names().join(", "))]
    UnknownEffect(String),
    /// No such parameter of the effect.
    #[error("effect `{effect}` has no parameter `{name}`; allowed: {allowed}")]
    UnknownParam {
        /// The effect.
        effect: &'static str,
        /// The key given.
        name: String,
        /// Its parameters.
        allowed: String,
    },
    /// A value that does not parse as a number (`--effect aging:b=abc`).
    #[error("{effect}.{name} = `{text}` is not a number; write NAME:key=value,key=value")]
    NotANumber {
        /// The effect.
        effect: &'static str,
        /// The key given.
        name: String,
        /// The text given.
        text: String,
    },
    /// A form the effect does not have.
    #[error("{effect}.{name} = `{text}` is not a form of the effect; allowed: {allowed}")]
    UnknownForm {
        /// The effect.
        effect: &'static str,
        /// Its form parameter.
        name: &'static str,
        /// The text given.
        text: String,
        /// Its forms, `name (value)`.
        allowed: String,
    },
    /// A value out of its physical range.
    #[error("{effect}.{name} = {value} {unit} is not allowed: must lie in [{min}, {max}]")]
    OutOfRange {
        /// The effect.
        effect: &'static str,
        /// The parameter.
        name: &'static str,
        /// The value given.
        value: f64,
        /// Its unit.
        unit: &'static str,
        /// Lower bound.
        min: f64,
        /// Upper bound.
        max: f64,
    },
}

/// Names of all effects.
pub fn names() -> Vec<&'static str> {
    EFFECTS.iter().map(|e| e.name).collect()
}

/// The switched-on effects and their parameter values (in the order of [`EffectInfo::params`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Effects {
    /// At most one entry per kind, sorted by kind.
    pub list: Vec<(EffectKind, Vec<f64>)>,
}

impl Effects {
    /// The extensions that are on, as `{"name": {"param": value, ...}, ...}` (empty for the
    /// base model), every parameter exact, forms as their codes.
    pub fn to_json(&self) -> serde_json::Value {
        self.list
            .iter()
            .map(|(k, v)| {
                let ps: serde_json::Map<String, serde_json::Value> = k
                    .info()
                    .params
                    .iter()
                    .zip(v)
                    .map(|(p, x)| (p.name.to_string(), serde_json::json!(x)))
                    .collect();
                (k.name().to_string(), serde_json::Value::from(ps))
            })
            .collect::<serde_json::Map<_, _>>()
            .into()
    }

    /// No effects: the base model.
    pub fn none() -> Effects {
        Effects::default()
    }

    /// Whether no effect is on.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Switches an effect on with its default parameters (or keeps it as it is).
    pub fn enable(&mut self, kind: EffectKind) -> &mut Vec<f64> {
        if let Some(i) = self.list.iter().position(|(k, _)| *k == kind) {
            return &mut self.list[i].1;
        }
        let vals = kind.info().params.iter().map(|p| p.default).collect();
        self.list.push((kind, vals));
        self.list.sort_by_key(|(k, _)| *k);
        let i = self.list.iter().position(|(k, _)| *k == kind).unwrap();
        &mut self.list[i].1
    }

    /// Sets one parameter (switching the effect on), checking its range.
    pub fn set(&mut self, kind: EffectKind, name: &str, value: f64) -> Result<(), EffectError> {
        let info = kind.info();
        let Some(i) = info.params.iter().position(|p| p.name == name) else {
            return Err(EffectError::UnknownParam {
                effect: info.name,
                name: name.to_string(),
                allowed: info
                    .params
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        };
        check(info, &info.params[i], value)?;
        self.enable(kind)[i] = value;
        Ok(())
    }

    /// Sets an effect's form by name (switching the effect on): `form = "velocity"`.
    pub fn set_form(&mut self, kind: EffectKind, name: &str) -> Result<(), EffectError> {
        let info = kind.info();
        let f = kind
            .form_named(name)
            .ok_or_else(|| EffectError::UnknownForm {
                effect: info.name,
                name: form_param(kind),
                text: name.to_string(),
                allowed: forms_list(kind),
            })?;
        self.set(kind, form_param(kind), f.value)
    }

    /// The form of an effect that is on, where the effect has forms.
    pub fn form(&self, kind: EffectKind) -> Option<&'static Form> {
        kind.form_of(self.get(kind, form_param(kind))?)
    }

    /// Whether the form of `kind` uses its parameter `param` (every parameter of an effect
    /// without forms, or not on).
    pub fn uses(&self, kind: EffectKind, param: &str) -> bool {
        self.form(kind).is_none_or(|f| !f.unused.contains(&param))
    }

    /// The value of one parameter, if the effect is on.
    pub fn get(&self, kind: EffectKind, name: &str) -> Option<f64> {
        let (_, vals) = self.list.iter().find(|(k, _)| *k == kind)?;
        let i = kind.info().params.iter().position(|p| p.name == name)?;
        Some(vals[i])
    }

    /// Whether an effect is on.
    pub fn has(&self, kind: EffectKind) -> bool {
        self.list.iter().any(|(k, _)| *k == kind)
    }

    /// Checks every value against its bounds.
    pub fn validate(&self) -> Result<(), EffectError> {
        for (k, vals) in &self.list {
            let info = k.info();
            for (p, &v) in info.params.iter().zip(vals) {
                check(info, p, v)?;
            }
        }
        Ok(())
    }

    /// Applies a command-line specification `NAME` or `NAME:key=value,key=value`.
    pub fn apply_spec(&mut self, spec: &str) -> Result<(), EffectError> {
        let (name, rest) = spec.split_once(':').unwrap_or((spec, ""));
        let kind = EffectKind::from_name(name.trim())
            .ok_or_else(|| EffectError::UnknownEffect(name.trim().to_string()))?;
        self.enable(kind);
        for kv in rest.split(',').filter(|s| !s.trim().is_empty()) {
            let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
            if k.trim() == form_param(kind)
                && !kind.info().forms.is_empty()
                && v.trim().parse::<f64>().is_err()
            {
                self.set_form(kind, v.trim())?;
                continue;
            }
            let x: f64 = v.trim().parse().map_err(|_| EffectError::NotANumber {
                effect: kind.name(),
                name: k.trim().to_string(),
                text: v.trim().to_string(),
            })?;
            self.set(kind, k.trim(), x)?;
        }
        Ok(())
    }

    /// `name` or `name(k=v, ...)` for each effect, joined by `+`; `base` when empty.
    pub fn describe(&self) -> String {
        if self.list.is_empty() {
            return "base".into();
        }
        self.list
            .iter()
            .map(|(k, v)| {
                let form = k.form_of(self.get(*k, form_param(*k)).unwrap_or(f64::NAN));
                let ps: Vec<String> = k
                    .info()
                    .params
                    .iter()
                    .zip(v)
                    .filter(|(p, _)| self.uses(*k, p.name))
                    .map(|(p, x)| match form {
                        Some(f) if p.name == form_param(*k) => format!("{}={}", p.name, f.name),
                        _ => format!("{}={x:.4e}", p.name),
                    })
                    .collect();
                format!("{}({})", k.name(), ps.join(", "))
            })
            .collect::<Vec<_>>()
            .join(" + ")
    }
}

/// `name (value)` of each form of `kind`.
fn forms_list(kind: EffectKind) -> String {
    kind.info()
        .forms
        .iter()
        .map(|f| format!("{} ({})", f.name, f.value))
        .collect::<Vec<_>>()
        .join(", ")
}

fn check(info: &EffectInfo, p: &EffectParam, v: f64) -> Result<(), EffectError> {
    let whole = matches!(p.name, "elements" | "form") && v.fract() != 0.0;
    if !(v.is_finite() && v >= p.min && v <= p.max) || whole {
        return Err(EffectError::OutOfRange {
            effect: info.name,
            name: p.name,
            value: v,
            unit: p.unit,
            min: p.min,
            max: p.max,
        });
    }
    Ok(())
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
    match (fx.get(k, "f_r"), fx.get(k, "zeta"), fx.get(k, "form")) {
        (Some(f_r), Some(zeta), Some(form)) => response_gain(form, f, f_r, zeta),
        _ => 1.0,
    }
}

/// Gain of `actuator_response` in the form of value `form` at `f` \[Hz\]: [`first_order_gain`]
/// for `first_order` (`zeta` unused), else [`actuator_gain`].
pub fn response_gain(form: f64, f: f64, f_r: f64, zeta: f64) -> f64 {
    if form == 1.0 {
        first_order_gain(f, f_r)
    } else {
        actuator_gain(f, f_r, zeta)
    }
}

/// Gain of the `first_order` form of `actuator_response` at `f` \[Hz\]: one pole at the corner
/// `f_r`, `A = 1/√(1 + (f/f_r)²)`.
pub fn first_order_gain(f: f64, f_r: f64) -> f64 {
    1.0 / (1.0 + (f / f_r).powi(2)).sqrt()
}

/// The effects resolved into the numbers the right-hand side uses, with the positions of the
/// extra state components.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Resolved {
    /// Any effect on (else the analytic base path is used).
    pub any: bool,
    /// State dimension.
    pub dim: usize,
    /// Actuator gain `A` (1 without the effect).
    pub gain: f64,
    /// Ageing: `(b, θ_0, D_c, index of θ)`.
    pub aging: Option<(f64, f64, f64, usize)>,
    /// Ageing by the slip law (else the ageing law).
    pub slip_law: bool,
    /// Normal coupling: `(c, φ − ω t_d [rad], fixed)`: the relative load swing is `c` times the
    /// substrate's displacement amplitude (`k_n/F_N` scaled by the form's frequency factor), or
    /// `c` itself where `fixed`.
    pub normal: Option<(f64, f64, bool)>,
    /// Sensor: `(ω_n, ζ, index of its first section's output)` (its derivative follows; a
    /// fourth-order sensor's second section follows that: [`Resolved::sensor4`]).
    pub sensor: Option<(f64, f64, usize)>,
    /// The sensor's second section's damping, where it is of fourth order.
    pub sensor4: Option<f64>,
    /// The delay of the recorded force behind the sensor's output \[s\] (`order4_delay`; 0
    /// otherwise). It acts where recordings are sampled ([`crate::campaign`]), not in the
    /// right-hand side.
    pub sensor_delay: f64,
    /// Drive ripple: `(a, 2π/λ)`.
    pub ripple: Option<(f64, f64)>,
    /// Extra viscous coefficient at `V_1` [N s/m].
    pub h_v: f64,
    /// Its power of the slip velocity `n` (1: linear).
    pub visc_n: f64,
    /// Stribeck exponent.
    pub delta: f64,
    /// A rational Stribeck curve `1/(1 + q^δ)` (else `exp(−q^δ)`).
    pub rational: bool,
    /// Presliding: number of elements, spread, index of the second element.
    pub elements: usize,
    pub spread: f64,
    pub first_extra: usize,
    /// Frictional lag: `(τ [s] or L [m], index of its state)` (the lagged velocity `w`, or
    /// the level's fall `ψ` in the `level` form).
    pub lag: Option<(f64, usize)>,
    /// The lag's form.
    pub lag_form: Lag,
    /// Track: `(a, 2π/λ, x_0)`.
    pub track: Option<(f64, f64, f64)>,
}

impl Resolved {
    /// The terms of the right-hand side and their states' indices ([`super::extended`]).
    pub fn shape(&self) -> Shape {
        Shape {
            any: self.any,
            dim: self.dim,
            aging: self.aging.map(|a| a.3),
            slip_law: self.slip_law,
            normal: self.normal.is_some(),
            normal_fixed: self.normal.is_some_and(|n| n.2),
            sensor: self.sensor.map(|s| s.2),
            sensor4: self.sensor4.is_some(),
            ripple: self.ripple.is_some(),
            visc_linear: self.visc_n == 1.0,
            stribeck: if self.rational {
                Stribeck::Rational
            } else if self.delta == 2.0 {
                Stribeck::Gauss
            } else {
                Stribeck::Power
            },
            elements: self.elements,
            first_extra: self.first_extra,
            lag: self.lag.map(|l| l.1),
            lag_form: self.lag_form,
            track: self.track.is_some(),
        }
    }

    /// The effects' coefficients ([`super::extended`]; 0 for an effect that is off).
    pub fn coeffs(&self) -> FxCoeffs<f64> {
        let (b, theta0, dc) = self.aging.map_or((0.0, 1.0, 1.0), |a| (a.0, a.1, a.2));
        let (c_n, phi) = self.normal.map_or((0.0, 0.0), |n| (n.0, n.1));
        let (wn, zeta) = self.sensor.map_or((0.0, 0.0), |s| (s.0, s.1));
        let (rip_a, rip_k) = self.ripple.unwrap_or((0.0, 0.0));
        let (tr_a, tr_k, tr_x0) = self.track.unwrap_or((0.0, 0.0, 0.0));
        FxCoeffs {
            b,
            theta0,
            dc,
            c_n,
            phi,
            wn,
            zeta,
            zeta2: self.sensor4.unwrap_or(0.0),
            rip_a,
            rip_k,
            h_v: self.h_v,
            visc_n: self.visc_n,
            delta: self.delta,
            spread: self.spread,
            tau: self.lag.map_or(1.0, |l| l.0),
            tr_a,
            tr_k,
            tr_x0,
        }
    }

    pub fn new(fx: &Effects, f: f64, f_n: f64) -> Resolved {
        let mut r = Resolved {
            any: !fx.is_empty(),
            dim: crate::model::state::BASE_DIM,
            gain: 1.0,
            aging: None,
            slip_law: false,
            normal: None,
            sensor: None,
            sensor4: None,
            sensor_delay: 0.0,
            ripple: None,
            h_v: 0.0,
            visc_n: 1.0,
            delta: 2.0,
            rational: false,
            elements: 1,
            spread: 0.0,
            first_extra: crate::model::state::BASE_DIM,
            lag: None,
            lag_form: Lag::Time,
            track: None,
        };
        let tau = std::f64::consts::TAU;
        // Presliding elements come first so the contact states stay together.
        if let Some(n) = fx.get(EffectKind::Presliding, "elements") {
            r.elements = n as usize;
            r.spread = fx.get(EffectKind::Presliding, "spread").unwrap_or(0.0);
            r.dim += r.elements - 1;
        }
        for (k, v) in &fx.list {
            match k {
                EffectKind::Aging => {
                    r.aging = Some((v[0], v[1], v[2], r.dim));
                    r.slip_law = v[3] == 1.0;
                    r.dim += 1;
                }
                EffectKind::ActuatorResponse => r.gain = response_gain(v[2], f, v[0], v[1]),
                EffectKind::NormalCoupling => {
                    let fixed = v[3] == 3.0;
                    // Per metre of displacement amplitude; the fixed form's swing whatever it is.
                    let c = load_swing(v[0], v[3], f, 1.0) / f_n;
                    r.normal = Some((c, v[1].to_radians() - tau * f * v[2], fixed))
                }
                EffectKind::SensorDynamics => {
                    r.sensor = Some((tau * v[0], v[1], r.dim));
                    r.dim += 2;
                    if v[2] >= 1.0 {
                        r.sensor4 = Some((v[1] * (1.0 + std::f64::consts::SQRT_2)).min(2.0));
                        r.dim += 2;
                    }
                    if v[2] == 2.0 {
                        r.sensor_delay = v[3];
                    }
                }
                EffectKind::DriveRipple => r.ripple = Some((v[0], tau / v[1])),
                EffectKind::Viscous => {
                    r.h_v = v[0];
                    r.visc_n = v[1];
                }
                EffectKind::StribeckShape => {
                    r.delta = v[0];
                    r.rational = v[1] == 1.0;
                }
                EffectKind::Presliding => {}
                EffectKind::FrictionalLag => {
                    r.lag_form = match v[2] {
                        1.0 => Lag::Distance,
                        2.0 => Lag::Level,
                        _ => Lag::Time,
                    };
                    let l = if r.lag_form == Lag::Time { v[0] } else { v[1] };
                    r.lag = Some((l, r.dim));
                    r.dim += 1;
                }
                EffectKind::Track => r.track = Some((v[0], tau / v[1], v[2])),
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_consistent() {
        for e in &EFFECTS {
            assert_eq!(EffectKind::from_name(e.name), Some(e.kind));
            for p in e.params {
                assert!(
                    p.min <= p.default && p.default <= p.max,
                    "{}.{}",
                    e.name,
                    p.name
                );
                assert!(!p.log || p.min > 0.0, "{}.{}", e.name, p.name);
            }
        }
        assert_eq!(EffectKind::candidates().len(), 9);
    }

    #[test]
    fn bad_values_are_named() {
        let mut fx = Effects::none();
        let e = fx
            .set(EffectKind::StribeckShape, "delta", 20.0)
            .unwrap_err();
        assert!(
            e.to_string().contains("stribeck_shape.delta = 20") && e.to_string().contains("10]"),
            "{e}"
        );
        let e = fx.set(EffectKind::Aging, "rate", 0.1).unwrap_err();
        assert!(e.to_string().contains("b, theta_0, d_c"), "{e}");
        let e = fx.set(EffectKind::Presliding, "elements", 2.5).unwrap_err();
        assert!(e.to_string().contains("elements"), "{e}");
        assert!(fx.is_empty());
    }
}
