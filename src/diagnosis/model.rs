//! The models a diagnosis fits (base parameters and effects), their fitted coordinates, and
//! the plausible bounds of every effect parameter derived from a campaign.

use crate::campaign::Recording;
use crate::model::effects::{Param, Scale};
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
    /// Effect parameter or base parameter (index into BASE_FITTED).
    pub(crate) target: Result<(EffectKind, Param), usize>,
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
            Ok((k, p)) => m.effects.at(k, p).unwrap_or(0.0),
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
            Ok((k, p)) => {
                let info = p.of(k);
                // An angle has no ends: it wraps. exp(ln(max)) may land an ulp outside a bound.
                let x = if info.scale == Scale::Degrees {
                    (x + 180.0).rem_euclid(360.0) - 180.0
                } else {
                    x.clamp(info.min, info.max)
                };
                if let Some((_, vals)) = m.effects.list.iter_mut().find(|(kk, _)| *kk == k) {
                    vals[p.0] = x;
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
        let info = k.info();
        for (i, p) in info.params.iter().enumerate() {
            let param = Param(i);
            if !p.fitted || !fx.uses(k, param) {
                continue;
            }
            let (min, max) = bounds.range(k, param);
            let (lo, hi) = match p.scale {
                Scale::Log => (min.ln(), max.ln()),
                // One turn of room on either side: the fit crosses ±180° without meeting an end.
                Scale::Degrees => (min - 360.0, max + 360.0),
                Scale::Linear | Scale::Whole => (min, max),
            };
            let own_step = param.look_up(info.fit_steps);
            let step = if p.log() {
                0.05
            } else if let Some(step) = own_step {
                step
            } else {
                0.05 * p.default.abs().max(1e-3 * (p.max - p.min))
            };
            c.push(Coord {
                name: format!("{}.{}", k.name(), p.name),
                unit: p.unit,
                target: Ok((k, param)),
                log: p.log(),
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
    pub param: Param,
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
    pub fn range(&self, kind: EffectKind, param: Param) -> (f64, f64) {
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
pub(crate) fn default_range(kind: EffectKind, param: Param) -> (f64, f64) {
    let p = param.of(kind);
    fit_range(kind, param).unwrap_or((p.min, p.max))
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
/// bounds and without adding a stiff mode (an explicit method simulates the vibrated runs): the
/// effect's [`neutral`](crate::model::effects::EffectInfo::neutral) values (no ageing, an
/// actuator resonance at 100 kHz, no load coupling, a sensor at 20 kHz with `ζ = 0.7`, flat
/// within 0.1 % up to 4 kHz, no screw error, no viscous friction, the base model's Gaussian
/// Stribeck curve, one breakaway level, 30 µs of lag). Every candidate's scan holds this start,
/// so a candidate is not worse on the calibration data than the base model (where a fit still
/// ends worse, `diagnose` reports the base model for it).
pub fn neutral(kind: EffectKind, param: Param) -> Option<f64> {
    param.look_up(kind.info().neutral)
}

/// Where a fit narrows an effect parameter's allowed range: the effect's
/// [`fit_ranges`](crate::model::effects::EffectInfo::fit_ranges).
pub(crate) fn fit_range(kind: EffectKind, param: Param) -> Option<(f64, f64)> {
    kind.info()
        .fit_ranges
        .iter()
        .find(|r| r.param == param)
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
