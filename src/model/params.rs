//! The rig's parameters, in SI units, with one descriptor table that drives validation, the
//! command line, case files, sweeps and file attributes alike.

use serde::{Deserialize, Serialize};
use std::fmt;

/// All parameters of the rig model (`docs/model.md`, Table 1 of the paper), in SI units.
///
/// Defaults: Table 1 with `F_s = 11.5 N`; the drive of the Fig. 10 study
/// (`k_d = 11 700 N/m`, `v_d = 0.5 mm/s`) and no vibration (`u0 = 0`, `f = 1500 Hz`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Mass of the shifted body `m` \[kg\]: dead weight 6.52 N / g.
    pub m: f64,
    /// Contact stiffness `k_t` [N/m].
    pub k_t: f64,
    /// Contact damping at zero slip velocity `h_t` [N s/m] (Eq. 4.8 with ζ = 1).
    pub h_t: f64,
    /// Viscous damping of the contact `h_v` [N s/m].
    pub h_v: f64,
    /// Coulomb force `F_c` \[N\].
    #[serde(rename = "F_c")]
    pub f_c: f64,
    /// Static force `F_s` \[N\].
    #[serde(rename = "F_s")]
    pub f_s: f64,
    /// Stribeck velocity `v_s` [m/s].
    pub v_s: f64,
    /// Drive stiffness `k_d` [N/m].
    pub k_d: f64,
    /// Drive damping `h_d` [N s/m].
    pub h_d: f64,
    /// Drive velocity `v_d` [m/s].
    pub v_d: f64,
    /// Vibration frequency `f` \[Hz\].
    pub f: f64,
    /// Vibration amplitude `u0` \[m\].
    pub u0: f64,
    /// Normal load `F_N` \[N\] (`F_g + F_z`); the base model does not use it, load-varying
    /// extensions scale `F_c` and `F_s` with it.
    #[serde(rename = "F_N")]
    pub f_n: f64,
    /// Time the vibration is switched on `t_on` \[s\]: `u(t) = u0 sin(ω (t − t_on))` for
    /// `t ≥ t_on` and `u = 0` before (docs/model.md, the paper's two-stage tests of Figs. 3 to 5).
    /// Default 0: vibrating from the start.
    #[serde(default)]
    pub t_on: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            m: 6.52 / 9.81,
            k_t: 71.318e6,
            h_t: 1.377e4,
            h_v: 0.0,
            f_c: 8.3,
            f_s: 11.5,
            v_s: 0.35e-3,
            k_d: 11_700.0,
            h_d: 0.0,
            v_d: 0.5e-3,
            f: 1500.0,
            u0: 0.0,
            f_n: 36.52,
            t_on: 0.0,
        }
    }
}

/// Lower bound of a parameter's valid range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bound {
    /// Strictly positive.
    Positive,
    /// Zero or positive.
    NonNegative,
}

/// A parameter's name, unit, meaning and valid range.
#[derive(Clone, Copy, Debug)]
pub struct ParamInfo {
    /// Name in files and sweeps (`F_s`, `k_d`, ...).
    pub name: &'static str,
    /// Command-line flag without the dashes (`f-s`, `k-d`, ...).
    pub flag: &'static str,
    /// SI unit.
    pub unit: &'static str,
    /// One line of meaning.
    pub doc: &'static str,
    /// Lower bound (all parameters must also be finite).
    pub bound: Bound,
    /// The physically plausible range for a rig of this kind (a mass on a drive spring over a
    /// vibrating substrate, docs/model.md), wide by orders of magnitude around the paper's values:
    /// a value outside it is a unit mistake, and would only meet a Newton failure or a run
    /// that never ends. Checked after `bound`.
    pub plausible: (f64, f64),
    get: fn(&Params) -> f64,
    set: fn(&mut Params, f64),
}

macro_rules! p {
    ($name:literal, $flag:literal, $field:ident, $unit:literal, $bound:ident, $lo:expr, $hi:expr, $doc:literal) => {
        ParamInfo {
            name: $name,
            flag: $flag,
            unit: $unit,
            doc: $doc,
            bound: Bound::$bound,
            plausible: ($lo, $hi),
            get: |p| p.$field,
            set: |p, v| p.$field = v,
        }
    };
}

/// Every parameter, in the order of docs/model.md.
pub const PARAMS: &[ParamInfo] = &[
    p!(
        "m",
        "m",
        m,
        "kg",
        Positive,
        1e-4,
        1e3,
        "mass of the shifted body"
    ),
    p!(
        "k_t",
        "k-t",
        k_t,
        "N/m",
        Positive,
        1e3,
        1e12,
        "contact stiffness"
    ),
    p!(
        "h_t",
        "h-t",
        h_t,
        "N s/m",
        NonNegative,
        0.0,
        1e8,
        "contact damping at zero slip velocity"
    ),
    p!(
        "h_v",
        "h-v",
        h_v,
        "N s/m",
        NonNegative,
        0.0,
        1e6,
        "viscous damping of the contact"
    ),
    p!("F_c", "f-c", f_c, "N", Positive, 1e-6, 1e6, "Coulomb force"),
    p!(
        "F_s",
        "f-s",
        f_s,
        "N",
        Positive,
        1e-6,
        1e6,
        "static force (>= F_c)"
    ),
    p!(
        "v_s",
        "v-s",
        v_s,
        "m/s",
        Positive,
        1e-9,
        10.0,
        "Stribeck velocity"
    ),
    p!(
        "k_d",
        "k-d",
        k_d,
        "N/m",
        Positive,
        1e-2,
        1e9,
        "drive stiffness"
    ),
    p!(
        "h_d",
        "h-d",
        h_d,
        "N s/m",
        NonNegative,
        0.0,
        1e6,
        "drive damping"
    ),
    p!(
        "v_d",
        "v-d",
        v_d,
        "m/s",
        Positive,
        1e-9,
        10.0,
        "drive velocity"
    ),
    p!(
        "f",
        "f",
        f,
        "Hz",
        NonNegative,
        0.0,
        1e6,
        "vibration frequency (> 0 when u0 > 0)"
    ),
    p!(
        "u0",
        "u0",
        u0,
        "m",
        NonNegative,
        0.0,
        1e-2,
        "vibration amplitude"
    ),
    p!("F_N", "f-n", f_n, "N", Positive, 1e-6, 1e6, "normal load"),
    p!(
        "t_on",
        "t-on",
        t_on,
        "s",
        NonNegative,
        0.0,
        1e5,
        "time the vibration is switched on (two-stage run; 0: from the start)"
    ),
];

/// A parameter outside its valid range, or an unknown name.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// The value violates the parameter's bound.
    #[error("parameter `{name}` = {} {unit} is not allowed: {allowed}", number(*value))]
    OutOfRange {
        name: &'static str,
        value: f64,
        unit: &'static str,
        allowed: String,
    },
    /// No parameter of that name.
    #[error("unknown parameter `{0}`; known parameters: {known}", known = names().join(", "))]
    Unknown(String),
}

/// A number as a user reads it: plain for ordinary magnitudes (`0.0005`, `11700`), in
/// exponent form beyond them (`1e300`, `1e-300`).
pub fn number(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e7).contains(&a) {
        v.to_string()
    } else {
        format!("{v:e}")
    }
}

/// Names of all parameters.
pub fn names() -> Vec<&'static str> {
    PARAMS.iter().map(|p| p.name).collect()
}

/// The descriptor of the parameter called `name`.
pub fn info(name: &str) -> Option<&'static ParamInfo> {
    PARAMS.iter().find(|p| p.name == name)
}

impl ParamInfo {
    /// The parameter's value in `p`.
    pub fn get(&self, p: &Params) -> f64 {
        (self.get)(p)
    }
    /// Sets the parameter in `p` (unchecked: call [`Params::validate`] afterwards).
    pub fn set(&self, p: &mut Params, v: f64) {
        (self.set)(p, v)
    }
    /// Checks a value against this parameter's own bound (relations between parameters are
    /// [`Params::validate`]'s).
    pub fn check(&self, v: f64) -> Result<(), ParamError> {
        let (ok, allowed) = match self.bound {
            Bound::Positive => (
                v.is_finite() && v > 0.0,
                format!("must be finite and > 0 {}", self.unit),
            ),
            Bound::NonNegative => (
                v.is_finite() && v >= 0.0,
                format!("must be finite and >= 0 {}", self.unit),
            ),
        };
        let (lo, hi) = self.plausible;
        if !ok {
            return Err(ParamError::OutOfRange {
                name: self.name,
                value: v,
                unit: self.unit,
                allowed,
            });
        }
        if !(lo..=hi).contains(&v) {
            return Err(ParamError::OutOfRange {
                name: self.name,
                value: v,
                unit: self.unit,
                allowed: format!(
                    "must lie within {lo:e} to {hi:e} {}, the plausible range for a rig of this kind (check the unit: SI)",
                    self.unit
                ),
            });
        }
        Ok(())
    }
}

impl Params {
    /// Gets a parameter by name.
    pub fn get(&self, name: &str) -> Result<f64, ParamError> {
        info(name)
            .map(|i| i.get(self))
            .ok_or_else(|| ParamError::Unknown(name.to_string()))
    }

    /// Sets a parameter by name (unchecked: call [`Params::validate`] afterwards).
    pub fn set(&mut self, name: &str, v: f64) -> Result<(), ParamError> {
        let i = info(name).ok_or_else(|| ParamError::Unknown(name.to_string()))?;
        i.set(self, v);
        Ok(())
    }

    /// Checks every parameter against its bound and the relations between them:
    /// `F_s >= F_c`, and `f > 0` whenever `u0 > 0`.
    pub fn validate(&self) -> Result<(), ParamError> {
        for i in PARAMS {
            i.check(i.get(self))?;
        }
        if self.f_s < self.f_c {
            return Err(ParamError::OutOfRange {
                name: "F_s",
                value: self.f_s,
                unit: "N",
                allowed: format!(
                    "must be >= F_c = {} N (static friction at least the Coulomb level)",
                    self.f_c
                ),
            });
        }
        if self.u0 > 0.0 && self.f <= 0.0 {
            return Err(ParamError::OutOfRange {
                name: "f",
                value: self.f,
                unit: "Hz",
                allowed: format!(
                    "must be > 0 Hz when u0 = {} m > 0 (a vibration needs a frequency)",
                    self.u0
                ),
            });
        }
        Ok(())
    }

    /// Angular frequency `ω = 2π f` [rad/s] (docs/model.md: the paper's Eq. 4.1 misprints `π f`).
    pub fn omega(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.f
    }

    /// Vibration velocity amplitude `v_a = 2π f u0` [m/s] (Eq. 5.2).
    pub fn v_a(&self) -> f64 {
        self.omega() * self.u0
    }

    /// Whether the substrate vibrates.
    pub fn vibrates(&self) -> bool {
        self.u0 > 0.0 && self.f > 0.0
    }

    /// The same rig without vibration (the reference run of `r`, Eq. 5.1).
    pub fn without_vibration(&self) -> Params {
        Params {
            u0: 0.0,
            t_on: 0.0,
            ..*self
        }
    }

    /// Whether the run has two stages: sliding on the resting substrate until `t_on > 0`,
    /// then with the vibration on.
    pub fn two_stage(&self) -> bool {
        self.vibrates() && self.t_on > 0.0
    }

    /// Sets `u0` from a vibration velocity amplitude: `u0 = v_a / (2π f)`.
    pub fn set_v_a(&mut self, v_a: f64) {
        self.u0 = if v_a == 0.0 { 0.0 } else { v_a / self.omega() };
    }

    /// docs/model.md's estimate of one stick-slip cycle without vibration, `2 (F_s − F_c) / (k_d v_d)` \[s\].
    pub fn cycle_estimate(&self) -> f64 {
        2.0 * (self.f_s - self.f_c) / (self.k_d * self.v_d)
    }

    /// Half period of the body on the drive spring, `π √(m / k_d)` \[s\]: the duration of a slip.
    pub fn slip_duration(&self) -> f64 {
        std::f64::consts::PI * (self.m / self.k_d).sqrt()
    }
}

impl fmt::Display for Params {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, i) in PARAMS.iter().enumerate() {
            if k > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{} = {} {}", i.name, i.get(self), i.unit)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_match_model_md() {
        let p = Params::default();
        p.validate().unwrap();
        // h_t = 2 sqrt(m k_t) for ζ = 1 (Eq. 4.8) to within the table's rounding.
        assert!((2.0 * (p.m * p.k_t).sqrt() / p.h_t - 1.0).abs() < 0.01);
    }

    #[test]
    fn every_bound_is_enforced_with_the_field_named() {
        for i in PARAMS {
            for bad in [f64::NAN, f64::INFINITY, -1.0] {
                let mut p = Params::default();
                i.set(&mut p, bad);
                let e = p.validate().unwrap_err().to_string();
                assert!(e.contains(&format!("`{}`", i.name)), "{e}");
            }
            if i.bound == Bound::Positive {
                let mut p = Params::default();
                i.set(&mut p, 0.0);
                assert!(p.validate().is_err(), "{} = 0 must be rejected", i.name);
            }
        }
    }

    #[test]
    fn relations_are_enforced() {
        let p = Params {
            u0: 1e-7,
            f: 0.0,
            ..Params::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("`f`"));
        let p = Params {
            f_s: 5.0,
            ..Params::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("F_c"));
        assert!(
            Params::default()
                .set("nope", 1.0)
                .unwrap_err()
                .to_string()
                .contains("k_d")
        );
    }

    #[test]
    fn v_a_round_trips() {
        let mut p = Params {
            f: 1500.0,
            ..Params::default()
        };
        p.set_v_a(1.1e-3);
        assert!((p.v_a() - 1.1e-3).abs() < 1e-18);
    }
}
