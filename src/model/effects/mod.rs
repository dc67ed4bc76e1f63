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

use std::fmt;
use terms::{FxCoeffs, Lag, Shape, Stribeck};

pub mod actuator_response;
pub mod aging;
pub mod drive_ripple;
pub mod frictional_lag;
pub mod normal_coupling;
pub mod presliding;
pub mod sensor_dynamics;
pub mod stribeck_shape;
pub mod terms;
pub mod track;
pub mod viscous;

pub use actuator_response::{actuator_gain, amplitude_gain, first_order_gain, response_gain};
pub use normal_coupling::{NORMAL_REFERENCE_AMPLITUDE, NORMAL_REFERENCE_FREQUENCY, load_swing};

/// A parameter of an effect: its position among the effect's [`EffectInfo::params`] (and in
/// its values, [`Effects::list`]). Each effect's file names its own (`aging::B`, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Param(pub usize);

impl Param {
    /// Its entry among `kind`'s parameters.
    pub fn of(self, kind: EffectKind) -> &'static EffectParam {
        &kind.info().params[self.0]
    }

    /// Its name among `kind`'s parameters.
    pub fn name(self, kind: EffectKind) -> &'static str {
        self.of(kind).name
    }

    /// Its entry in one of an effect's tables by parameter ([`EffectInfo::neutral`],
    /// [`EffectInfo::starts`], [`EffectInfo::fit_steps`]).
    pub fn look_up<T: Copy>(self, table: &[(Param, T)]) -> Option<T> {
        table.iter().find(|e| e.0 == self).map(|e| e.1)
    }
}

impl std::ops::Index<Param> for [f64] {
    type Output = f64;
    fn index(&self, p: Param) -> &f64 {
        &self[p.0]
    }
}

impl std::ops::IndexMut<Param> for [f64] {
    fn index_mut(&mut self, p: Param) -> &mut f64 {
        &mut self[p.0]
    }
}

/// A range of one of an effect's parameters, `lo` to `hi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub param: Param,
    pub lo: f64,
    pub hi: f64,
}

const fn range(param: Param, lo: f64, hi: f64) -> Range {
    Range { param, lo, hi }
}

/// A scan of the detection limits ([`crate::diagnosis::limits`]) over one form of an effect:
/// the parameter that sets its strength, the other parameters fixed, and the ends and scale it
/// is scanned over.
#[derive(Clone, Copy, Debug)]
pub struct Scan {
    /// The parameter that sets the effect's strength.
    pub param: Param,
    /// What the effect is, in a reader's words.
    pub label: &'static str,
    /// The other parameters and their values (the form parameter among them, for a form
    /// other than the default).
    pub fixed: &'static [(Param, f64)],
    /// The effect is stronger where the parameter is lower (a resonance).
    pub stronger_below: bool,
    /// The weak end, where the neutral value cannot serve (0 on a log scale; a scan of one
    /// side of the Stribeck exponent's 2).
    pub weak: Option<f64>,
    /// The strong end, where it is not the plausible range's.
    pub strong: Option<f64>,
    /// Scanned on a log scale.
    pub log: bool,
}

impl Scan {
    /// This scan in another form of the effect's family: its label, the parameter that sets
    /// its strength there and its other parameters (the form parameter among them); the scale
    /// and the ends as this one's.
    const fn in_form(
        self,
        label: &'static str,
        param: Param,
        fixed: &'static [(Param, f64)],
    ) -> Scan {
        Scan {
            label,
            param,
            fixed,
            ..self
        }
    }
}

/// The registry: each effect's variant of [`EffectKind`] and its entry in [`EFFECTS`], from one
/// line (and its doc) per effect, in a fixed order (the order of `[x, v, s]`'s extensions, of
/// files and of reports). An effect is defined in its file, whose `INFO` this line names.
macro_rules! registry {
    ($($(#[$doc:meta])* $kind:ident => $file:ident,)*) => {
        /// One switchable effect.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum EffectKind {
            $($(#[$doc])* $kind,)*
        }

        /// The library of effects, in the registry's order, each defined in its file.
        pub static EFFECTS: &[EffectInfo] = &[$($file::INFO,)*];
    };
}

registry! {
    /// Static friction grows with the time the contact has been stuck.
    Aging => aging,
    /// The substrate's real vibration amplitude departs from the nominal one with frequency.
    ActuatorResponse => actuator_response,
    /// The tangential vibration modulates the normal load, and so `F_c` and `F_s`.
    NormalCoupling => normal_coupling,
    /// A lightly damped second-order force sensor between the true and the recorded force.
    SensorDynamics => sensor_dynamics,
    /// A periodic error in the drive's motion.
    DriveRipple => drive_ripple,
    /// Friction growing with the slip velocity (linearly, or as a power of it).
    Viscous => viscous,
    /// A Stribeck exponent other than 2.
    StribeckShape => stribeck_shape,
    /// Multi-element (Maxwell-slip) presliding in place of the single LuGre bristle.
    Presliding => presliding,
    /// The friction force lags behind changes of the slip velocity.
    FrictionalLag => frictional_lag,
    /// Friction varying with position along the track (not a diagnosis candidate).
    Track => track,
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
    /// How its values are spaced: what a fit steps on and how `synth` draws it.
    pub scale: Scale,
}

impl EffectParam {
    /// Fitted (and drawn) on a log scale.
    pub fn log(&self) -> bool {
        self.scale == Scale::Log
    }
}

/// How an effect parameter's values are spaced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// A linear quantity.
    Linear,
    /// A positive quantity spanning decades: fitted and drawn on a log scale.
    Log,
    /// An angle in degrees, wrapped into [-180°, 180°): a fit crosses ±180° without meeting
    /// an end.
    Degrees,
    /// A whole number (a count of elements, a form's code): a fraction is refused.
    Whole,
}

/// The values a global scan tries for one parameter ([`EffectInfo::starts`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Grid {
    /// These values.
    Values(&'static [f64]),
    /// `n` values evenly spaced on a log scale from `lo` to `hi`, both ends included.
    Log(f64, f64, usize),
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
    /// Where a fit narrows a parameter's allowed range: ends that add a stiff mode to the
    /// simulations (a lag under 30 µs, a sensor above 20 kHz) would make every evaluation of
    /// a fit that drifts there several times slower, as an effect-free campaign drives these
    /// candidates towards their most neutral end. These ends lie far outside rigs' values.
    pub fit_ranges: &'static [Range],
    /// Realistic magnitudes, from which `synth --draw` picks values uniformly (log-uniformly
    /// for parameters fitted on a log scale), in the order they are drawn: what test stands
    /// show.
    pub realistic: &'static [Range],
    /// The detection limits' scans of it, one per form with a strength to scan (none for an
    /// effect that is no candidate).
    pub scans: &'static [Scan],
    /// The parameter whose value chooses its form (`form`, or `exponent` for `viscous`), where
    /// it has forms.
    pub form: Option<Param>,
    /// Whether it acts only through the substrate's vibration: with a vibration amplitude `u0`
    /// of 0 the model with it is the model without it, term for term.
    pub vibration_only: bool,
    /// The values at which it vanishes, or nearly so, within its bounds and without adding a
    /// stiff mode: where a diagnosis starts its fit (`diagnosis::model::neutral`).
    pub neutral: &'static [(Param, f64)],
    /// The values the global scan of a diagnosis tries for its fitted parameters, over their
    /// plausible ranges (`diagnosis::scan::starts`); a fitted parameter left out is not scanned.
    pub starts: &'static [(Param, Grid)],
    /// A fit's step where 5 % of the default (or 0.1 % of the range) does not serve.
    pub fit_steps: &'static [(Param, f64)],
    /// Its share of the right-hand side's numbers, from its values, at the forcing frequency
    /// and normal load.
    pub(crate) resolve: fn(&[f64], &mut Resolved, &At),
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
    pub unused: &'static [Param],
}

const fn form(name: &'static str, doc: &'static str, value: f64) -> Form {
    Form {
        name,
        doc,
        value,
        unused: &[],
    }
}

/// The name of the parameter whose value chooses an effect's form ([`EffectInfo::form`];
/// `form` where it has none).
pub fn form_param(kind: EffectKind) -> &'static str {
    kind.info().form.map_or("form", |p| p.name(kind))
}

/// One entry of [`EFFECTS`]: `range` is `(min, max)`.
const fn ep(
    name: &'static str,
    unit: &'static str,
    doc: &'static str,
    range: (f64, f64),
    default: f64,
    fitted: bool,
    scale: Scale,
) -> EffectParam {
    EffectParam {
        name,
        unit,
        doc,
        min: range.0,
        max: range.1,
        default,
        fitted,
        scale,
    }
}

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
        self.info().vibration_only
    }

    /// The value of its form parameter in its default form (0 where it has no forms).
    pub fn default_form(self) -> f64 {
        self.info()
            .form
            .map_or(0.0, |p| self.info().params[p.0].default)
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
        self.set_at(kind, Param(i), value)
    }

    /// Sets parameter `p` of `kind` ([`Param`]), switching the effect on, checking its range.
    pub fn set_at(&mut self, kind: EffectKind, p: Param, value: f64) -> Result<(), EffectError> {
        let info = kind.info();
        check(info, p.of(kind), value)?;
        self.enable(kind)[p.0] = value;
        Ok(())
    }

    /// Sets an effect's form by name (switching the effect on): `form = "velocity"`.
    pub fn set_form(&mut self, kind: EffectKind, name: &str) -> Result<(), EffectError> {
        let info = kind.info();
        let unknown = || EffectError::UnknownForm {
            effect: info.name,
            name: form_param(kind),
            text: name.to_string(),
            allowed: forms_list(kind),
        };
        let f = kind.form_named(name).ok_or_else(unknown)?;
        self.set_form_value(kind, f.value)
    }

    /// Sets an effect's form by its form parameter's value ([`EffectInfo::form`]), switching
    /// the effect on; an effect without forms is only switched on.
    pub fn set_form_value(&mut self, kind: EffectKind, value: f64) -> Result<(), EffectError> {
        match kind.info().form {
            Some(p) => self.set_at(kind, p, value),
            None => {
                self.enable(kind);
                Ok(())
            }
        }
    }

    /// The value of the form parameter of an effect that is on, where the effect has forms.
    pub fn form_value(&self, kind: EffectKind) -> Option<f64> {
        self.at(kind, kind.info().form?)
    }

    /// The form of an effect that is on, where the effect has forms.
    pub fn form(&self, kind: EffectKind) -> Option<&'static Form> {
        kind.form_of(self.form_value(kind)?)
    }

    /// Whether the form of `kind` uses its parameter `param` (every parameter of an effect
    /// without forms, or not on).
    pub fn uses(&self, kind: EffectKind, param: Param) -> bool {
        self.form(kind).is_none_or(|f| !f.unused.contains(&param))
    }

    /// The value of parameter `p` of `kind` ([`Param`]), if the effect is on.
    pub fn at(&self, kind: EffectKind, p: Param) -> Option<f64> {
        let (_, vals) = self.list.iter().find(|(k, _)| *k == kind)?;
        vals.get(p.0).copied()
    }

    /// The value of one parameter, if the effect is on.
    pub fn get(&self, kind: EffectKind, name: &str) -> Option<f64> {
        let i = kind.info().params.iter().position(|p| p.name == name)?;
        self.at(kind, Param(i))
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
                let form = self.form(*k);
                let ps: Vec<String> = k
                    .info()
                    .params
                    .iter()
                    .zip(v)
                    .enumerate()
                    .filter(|&(i, _)| self.uses(*k, Param(i)))
                    .map(|(i, (p, x))| match form {
                        Some(f) if k.info().form == Some(Param(i)) => {
                            format!("{}={}", p.name, f.name)
                        }
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
    let whole = p.scale == Scale::Whole && v.fract() != 0.0;
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

/// The conditions an effect's numbers are resolved at: the forcing frequency `f` \[Hz\] and
/// the normal load `f_n` \[N\].
pub(crate) struct At {
    pub f: f64,
    pub f_n: f64,
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
        // Presliding elements come first so the contact states stay together.
        presliding::elements_first(fx, &mut r);
        for (k, v) in &fx.list {
            (k.info().resolve)(v, &mut r, &At { f, f_n });
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_consistent() {
        for e in EFFECTS {
            assert_eq!(EffectKind::from_name(e.name), Some(e.kind));
            for p in e.params {
                assert!(
                    p.min <= p.default && p.default <= p.max,
                    "{}.{}",
                    e.name,
                    p.name
                );
                assert!(!p.log() || p.min > 0.0, "{}.{}", e.name, p.name);
            }
        }
        assert_eq!(EffectKind::candidates().len(), 9);
    }

    /// What an effect's file says of its parameters for the diagnosis holds against its table:
    /// its form parameter is the one its forms set (and a whole number), its neutral values and
    /// scan grids lie within the bounds, a grid and a step are for a fitted parameter, and only
    /// the two effects that act through the vibration say so.
    #[test]
    fn an_effects_diagnosis_data_agree_with_its_table() {
        for e in EFFECTS {
            let name = |p: Param| format!("{}.{}", e.name, p.name(e.kind));
            match e.form {
                Some(p) => {
                    assert!(!e.forms.is_empty(), "{}", name(p));
                    let info = p.of(e.kind);
                    assert!(matches!(info.name, "form" | "exponent"), "{}", name(p));
                    assert_eq!(info.default, e.forms[0].value, "{}", name(p));
                    for f in e.forms {
                        assert!(check(e, info, f.value).is_ok(), "{}", f.name);
                    }
                }
                None => assert!(e.forms.is_empty(), "{}", e.name),
            }
            for &(p, v) in e.neutral {
                let info = p.of(e.kind);
                assert!(
                    info.fitted && (info.min..=info.max).contains(&v),
                    "{}",
                    name(p)
                );
            }
            for &(p, g) in e.starts {
                let (lo, hi, ok) = match g {
                    Grid::Values(v) => (v[0], v[v.len() - 1], v.windows(2).all(|w| w[0] < w[1])),
                    Grid::Log(lo, hi, n) => (lo, hi, lo > 0.0 && lo < hi && n >= 2),
                };
                let info = p.of(e.kind);
                assert!(ok && info.fitted, "{}", name(p));
                assert!(lo >= info.min && hi <= info.max, "{}", name(p));
            }
            for &(p, step) in e.fit_steps {
                assert!(p.of(e.kind).fitted && step > 0.0, "{}", name(p));
            }
        }
        let vibrated: Vec<_> = EFFECTS
            .iter()
            .filter(|e| e.vibration_only)
            .map(|e| e.kind)
            .collect();
        assert_eq!(
            vibrated,
            [EffectKind::ActuatorResponse, EffectKind::NormalCoupling]
        );
    }

    /// Each effect file's typed indices name the parameter at their place in its table, and its
    /// forms' enum tells every form of the table apart: the two definitions of an effect's
    /// parameters cannot drift apart.
    #[test]
    fn typed_indices_and_form_enums_match_the_table() {
        use EffectKind as K;
        let named: &[(K, Param, &str)] = &[
            (K::Aging, aging::B, "b"),
            (K::Aging, aging::THETA_0, "theta_0"),
            (K::Aging, aging::D_C, "d_c"),
            (K::Aging, aging::FORM, "form"),
            (K::ActuatorResponse, actuator_response::F_R, "f_r"),
            (K::ActuatorResponse, actuator_response::ZETA, "zeta"),
            (K::ActuatorResponse, actuator_response::FORM, "form"),
            (K::NormalCoupling, normal_coupling::K_N, "k_n"),
            (K::NormalCoupling, normal_coupling::PHASE, "phase"),
            (K::NormalCoupling, normal_coupling::DELAY, "delay"),
            (K::NormalCoupling, normal_coupling::FORM, "form"),
            (K::SensorDynamics, sensor_dynamics::F_N, "f_n"),
            (K::SensorDynamics, sensor_dynamics::ZETA, "zeta"),
            (K::SensorDynamics, sensor_dynamics::FORM, "form"),
            (K::SensorDynamics, sensor_dynamics::DELAY, "delay"),
            (K::DriveRipple, drive_ripple::A, "a"),
            (K::DriveRipple, drive_ripple::WAVELENGTH, "wavelength"),
            (K::Viscous, viscous::H_V, "h_v"),
            (K::Viscous, viscous::EXPONENT, "exponent"),
            (K::StribeckShape, stribeck_shape::DELTA, "delta"),
            (K::StribeckShape, stribeck_shape::FORM, "form"),
            (K::Presliding, presliding::SPREAD, "spread"),
            (K::Presliding, presliding::ELEMENTS, "elements"),
            (K::FrictionalLag, frictional_lag::TAU, "tau"),
            (K::FrictionalLag, frictional_lag::LENGTH, "length"),
            (K::FrictionalLag, frictional_lag::FORM, "form"),
            (K::Track, track::A, "a"),
            (K::Track, track::WAVELENGTH, "wavelength"),
            (K::Track, track::OFFSET, "offset"),
        ];
        for &(k, p, name) in named {
            assert_eq!(p.name(k), name, "{k}");
        }
        for e in EFFECTS {
            assert_eq!(
                named.iter().filter(|n| n.0 == e.kind).count(),
                e.params.len(),
                "{}",
                e.name
            );
        }
        // Each enum tells the table's forms apart (and the default is the first).
        let values = |k: K| -> Vec<f64> { k.info().forms.iter().map(|f| f.value).collect() };
        fn distinct<T: PartialEq>(v: &[T]) -> bool {
            v.iter()
                .enumerate()
                .all(|(i, a)| v[..i].iter().all(|b| a != b))
        }
        let aging: Vec<_> = values(K::Aging).into_iter().map(aging::Law::of).collect();
        assert!(distinct(&aging) && aging[0] == aging::Law::AgeingLaw);
        let act: Vec<_> = values(K::ActuatorResponse)
            .into_iter()
            .map(actuator_response::Response::of)
            .collect();
        assert!(distinct(&act) && act[0] == actuator_response::Response::Resonance);
        let swing: Vec<_> = values(K::NormalCoupling)
            .into_iter()
            .map(normal_coupling::Swing::of)
            .collect();
        assert!(distinct(&swing) && swing[0] == normal_coupling::Swing::Displacement);
        let order: Vec<_> = values(K::SensorDynamics)
            .into_iter()
            .map(sensor_dynamics::Order::of)
            .collect();
        assert!(distinct(&order) && order[0] == sensor_dynamics::Order::Order2);
        let curve: Vec<_> = values(K::StribeckShape)
            .into_iter()
            .map(stribeck_shape::Curve::of)
            .collect();
        assert!(distinct(&curve) && curve[0] == stribeck_shape::Curve::Exponential);
        let power: Vec<_> = values(K::Viscous)
            .into_iter()
            .map(viscous::Power::of)
            .collect();
        assert!(distinct(&power) && power.iter().all(Option::is_some));
        let lag: Vec<_> = values(K::FrictionalLag)
            .into_iter()
            .map(frictional_lag::lag_of)
            .collect();
        assert!(distinct(&lag) && lag[0] == Lag::Time);
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
