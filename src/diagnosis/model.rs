//! The models a diagnosis fits (base parameters and effects), their fitted coordinates, and
//! the plausible bounds of every effect parameter derived from a campaign.

use crate::campaign::Recording;
use crate::model::{EffectKind, Effects, Params};

/// The base parameters a calibration fits.
pub const BASE_FITTED: [&str; 4] = ["F_s", "F_c", "v_s", "h_d"];

/// A model to compare with recordings: base parameters (the fitted ones replace the
/// recording's) and effects.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// `F_s` \[N\].
    pub f_s: f64,
    /// `F_c` \[N\].
    pub f_c: f64,
    /// `v_s` [m/s].
    pub v_s: f64,
    /// `h_d` [N s/m].
    pub h_d: f64,
    /// Effects.
    pub effects: Effects,
}

impl Default for Model {
    fn default() -> Self {
        let p = Params::default();
        Model {
            f_s: p.f_s,
            f_c: p.f_c,
            v_s: p.v_s,
            h_d: p.h_d,
            effects: Effects::none(),
        }
    }
}

impl Model {
    /// The parameters of one recording under this model.
    pub fn params_for(&self, rec: &Recording) -> Params {
        let mut p = rec.params;
        p.f_s = self.f_s;
        p.f_c = self.f_c;
        p.v_s = self.v_s;
        p.h_d = self.h_d;
        p
    }
}

/// One fitted coordinate.
#[derive(Clone, Debug)]
pub(crate) struct Coord {
    pub(crate) name: String,
    pub(crate) unit: &'static str,
    /// Effect parameter (kind, index) or base parameter (index into BASE_FITTED).
    pub(crate) target: Result<(EffectKind, usize), usize>,
    pub(crate) log: bool,
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) step: f64,
}

impl Coord {
    pub(crate) fn get(&self, m: &Model) -> f64 {
        let x = match self.target {
            Err(0) => m.f_s,
            Err(1) => m.f_c,
            Err(2) => m.v_s,
            Err(_) => m.h_d,
            Ok((k, i)) => m.effects.get(k, k.info().params[i].name).unwrap_or(0.0),
        };
        if self.log { x.ln() } else { x }
    }

    pub(crate) fn set(&self, m: &mut Model, theta: f64) {
        let th = theta.clamp(self.lo, self.hi);
        let x = if self.log { th.exp() } else { th };
        match self.target {
            Err(0) => m.f_s = x,
            Err(1) => m.f_c = x,
            Err(2) => m.v_s = x,
            Err(_) => m.h_d = x,
            Ok((k, i)) => {
                let info = &k.info().params[i];
                // An angle has no ends: it wraps. exp(ln(max)) may land an ulp outside a bound.
                let x = if circular(k, info.name) {
                    (x + 180.0).rem_euclid(360.0) - 180.0
                } else {
                    x.clamp(info.min, info.max)
                };
                if let Some((_, vals)) = m.effects.list.iter_mut().find(|(kk, _)| *kk == k) {
                    vals[i] = x;
                }
            }
        }
    }
}

/// The fitted coordinates: `F_s`, `F_c`, `v_s` and `h_d`, and the effects' fitted parameters.
/// The base parameters are refitted with every effect: an effect left out of the base model
/// is partly absorbed by them (viscous friction by the drive damping `h_d`, ageing by `F_s`).
/// A parameter the effect's form in `fx` leaves unused ([`Effects::uses`]) is not fitted.
pub(crate) fn coords(bounds: &Plausible, effects: &[EffectKind], fx: &Effects) -> Vec<Coord> {
    let base = |i: usize, name: &str, unit, log, lo: f64, hi: f64, step| Coord {
        name: name.to_string(),
        unit,
        target: Err(i),
        log,
        lo,
        hi,
        step,
    };
    let mut c = vec![
        base(0, "F_s", "N", true, 0.5f64.ln(), 200f64.ln(), 0.01),
        base(1, "F_c", "N", true, 0.5f64.ln(), 200f64.ln(), 0.01),
        base(2, "v_s", "m/s", true, 1e-6f64.ln(), 0.1f64.ln(), 0.05),
        base(3, "h_d", "N s/m", false, 0.0, 200.0, 1.0),
    ];
    debug_assert_eq!(c.len(), BASE_FITTED.len());
    for &k in effects {
        for (i, p) in k.info().params.iter().enumerate() {
            if !p.fitted || !fx.uses(k, p.name) {
                continue;
            }
            let (min, max) = bounds.range(k, p.name);
            let (lo, hi) = if p.log {
                (min.ln(), max.ln())
            } else if circular(k, p.name) {
                // One turn of room on either side: the fit crosses ±180° without meeting an end.
                (min - 360.0, max + 360.0)
            } else {
                (min, max)
            };
            let step = if p.log {
                0.05
            } else if (k, p.name) == (EffectKind::NormalCoupling, "delay") {
                // A delay turns the phase by 360° f t_d: 5 µs is 4.5° at 2.5 kHz, a step the
                // features resolve where 0.05 % of the range would be lost in their roughness.
                5e-6
            } else {
                0.05 * p.default.abs().max(1e-3 * (p.max - p.min))
            };
            c.push(Coord {
                name: format!("{}.{}", k.name(), p.name),
                unit: p.unit,
                target: Ok((k, i)),
                log: p.log,
                lo,
                hi,
                step,
            });
        }
    }
    c
}

/// The plausible range of one effect parameter in a campaign, where the recordings themselves
/// narrow the library's table (`src/model/effects/`), with the reason in words.
#[derive(Clone, Debug, PartialEq)]
pub struct Bound {
    /// The effect.
    pub effect: EffectKind,
    /// The parameter.
    pub param: &'static str,
    /// Lower end, in the parameter's unit.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// Why, with the campaign's numbers.
    pub reason: String,
}

/// The plausible ranges of the effects' fitted parameters in one campaign ([`Plausible::of`]).
/// A parameter without a campaign bound keeps the fit's narrower range (where it has one) or the library's.
/// A fit never leaves these ranges; one that ends on a campaign bound is reported as such
/// (`diagnose` names it only as partial, with a warning).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plausible {
    /// The campaign's own bounds.
    pub bounds: Vec<Bound>,
}

/// The longest time from the onset of a force drop to its trough that a second-order sensor of
/// natural frequency `f_n` shows for an instantaneous drop is half its damped period,
/// `1/(2 f_n √(1 − ζ²)) ≥ 1/(2 f_n)`: a recorded slip (peak to trough of the smoothed force)
/// can be no shorter than that. The bound takes this margin below `1/(2 t_slip)`, for the
/// smoothing and the zig-zag detection of the trough.
pub const SLIP_BOUND_MARGIN: f64 = 0.75;

/// The plausible range of the Stribeck exponent `δ` (the library allows 0.2 to 10): generous
/// about the 0.5 to 2 of measured friction curves.
pub const STRIBECK_DELTA: (f64, f64) = (0.25, 4.0);

impl Plausible {
    /// The range of a fitted parameter: the campaign's bound, else the fit's narrower range,
    /// else the library's table.
    pub fn range(&self, kind: EffectKind, param: &str) -> (f64, f64) {
        if let Some(b) = self
            .bounds
            .iter()
            .find(|b| b.effect == kind && b.param == param)
        {
            return (b.lo, b.hi);
        }
        default_range(kind, param)
    }
}

/// The range of a fitted effect parameter without the campaign's bounds: the fit's narrower
/// range ([`fit_range`]), else the library's table.
pub(crate) fn default_range(kind: EffectKind, param: &str) -> (f64, f64) {
    let p = kind.info().params.iter().find(|p| p.name == param);
    let table = p.map_or((f64::NEG_INFINITY, f64::INFINITY), |p| (p.min, p.max));
    fit_range(kind, param).unwrap_or(table)
}

/// The coordinates `cs` at `theta` that lie on an end of their range (within 1 % on a log scale,
/// 0.1 % of the range on a linear one), other than the ends `natural` accepts as values:
/// `"name = value at the lower|upper bound end unit"`, one each.
pub(crate) fn on_bounds(
    cs: &[Coord],
    theta: &[f64],
    natural: impl Fn(&Coord, f64) -> bool,
) -> Vec<String> {
    let mut out = vec![];
    for (c, &th) in cs.iter().zip(theta) {
        let tol = if c.log { 0.01 } else { 1e-3 * (c.hi - c.lo) };
        let v = |x: f64| if c.log { x.exp() } else { x };
        for (end, word) in [(c.lo, "lower"), (c.hi, "upper")] {
            if (th - end).abs() <= tol && !natural(c, end) {
                out.push(format!(
                    "{} = {:.4e} at the {word} bound {:.4e} {}",
                    c.name,
                    v(th),
                    v(end),
                    c.unit
                ));
            }
        }
    }
    out
}

/// The value of an effect parameter at which the effect vanishes, or nearly so, within its
/// bounds and without adding a stiff mode (an explicit method simulates the vibrated runs): no
/// ageing, an actuator resonance at 100 kHz, no load coupling, a sensor at 20 kHz with
/// `ζ = 0.7` (flat within 0.1 % up to 4 kHz), no screw error, no viscous friction, the base
/// model's Gaussian Stribeck curve (`δ = 2`), one breakaway level, 30 µs of lag. Every
/// candidate's scan holds this start, so a candidate is not worse on the calibration data than
/// the base model (where a fit still ends worse, `diagnose` reports the base model for it).
pub fn neutral(kind: EffectKind, param: &str) -> Option<f64> {
    use EffectKind as K;
    Some(match (kind, param) {
        (K::Aging, "b") => 0.0,
        (K::ActuatorResponse, "f_r") => 1e5,
        (K::ActuatorResponse, "zeta") => 0.7,
        (K::NormalCoupling, "k_n") => 1e3,
        (K::NormalCoupling, "delay") => 0.0,
        (K::SensorDynamics, "f_n") => 2e4,
        (K::SensorDynamics, "zeta") => 0.7,
        (K::DriveRipple, "a") => 0.0,
        (K::Viscous, "h_v") => 0.0,
        (K::StribeckShape, "delta") => 2.0,
        (K::Presliding, "spread") => 0.0,
        (K::FrictionalLag, "tau") => 3e-5,
        (K::FrictionalLag, "length") => 1e-7,
        _ => return None,
    })
}

/// Whether an effect parameter is an angle (degrees, wrapped into [-180°, 180°)): the phase of
/// the normal-load modulation, whose sign and timing against the vibration a rig's geometry sets
/// (a load that follows the displacement after a delay lags it by `360° f delay`).
pub(crate) fn circular(kind: EffectKind, param: &str) -> bool {
    matches!((kind, param), (EffectKind::NormalCoupling, "phase"))
}

/// Where a fit narrows an effect parameter's allowed range: the effect's
/// [`fit_ranges`](crate::model::effects::EffectInfo::fit_ranges).
pub(crate) fn fit_range(kind: EffectKind, param: &str) -> Option<(f64, f64)> {
    kind.info()
        .fit_ranges
        .iter()
        .find(|r| r.param.name(kind) == param)
        .map(|r| (r.lo, r.hi))
}

/// A model in files is [`Model::to_json`]'s form.
impl serde::Serialize for Model {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.to_json().serialize(s)
    }
}

/// A model is read by [`Model::from_json`], whose message names what is missing or wrong.
impl<'de> serde::Deserialize<'de> for Model {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = serde_json::Value::deserialize(d)?;
        Model::from_json(&v).map_err(serde::de::Error::custom)
    }
}

impl Model {
    /// The model as JSON, every parameter exact (`{"F_s", "F_c", "v_s", "h_d", "effects":
    /// {name: {param: value, ...}}}`), the effects' unfitted parameters and forms included:
    /// what [`Model::from_json`] reads back bit for bit.
    pub fn to_json(&self) -> serde_json::Value {
        let effects = self.effects.to_json();
        serde_json::json!({
            "F_s": self.f_s, "F_c": self.f_c, "v_s": self.v_s, "h_d": self.h_d,
            "effects": effects,
        })
    }

    /// Reads [`Model::to_json`]'s form; the message names what is missing or wrong.
    pub fn from_json(v: &serde_json::Value) -> Result<Model, String> {
        let num = |o: &serde_json::Value, k: &str| {
            o.get(k)
                .and_then(|x| x.as_f64())
                .ok_or_else(|| format!("model: `{k}` missing or not a number"))
        };
        let mut m = Model {
            f_s: num(v, "F_s")?,
            f_c: num(v, "F_c")?,
            v_s: num(v, "v_s")?,
            h_d: num(v, "h_d")?,
            effects: Effects::none(),
        };
        if let Some(fx) = v.get("effects").and_then(|e| e.as_object()) {
            for (name, ps) in fx {
                let k = EffectKind::from_name(name)
                    .ok_or_else(|| format!("model: unknown effect `{name}`"))?;
                let vals = k
                    .info()
                    .params
                    .iter()
                    .map(|p| num(ps, p.name))
                    .collect::<Result<Vec<f64>, String>>()?;
                *m.effects.enable(k) = vals;
            }
        }
        Ok(m)
    }
}
