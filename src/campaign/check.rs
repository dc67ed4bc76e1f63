//! Recordings are checked before they are believed: `calibrate` and `diagnose` refuse a
//! recording that no working rig could have made under its stated conditions, naming the
//! recording, the check, the value found and what was expected (or, with `--skip-implausible`,
//! set it aside and list it in the report and the JSON).
//!
//! With `T` the recording's duration and the conditions' `k_d`, `v_d`, `F_s`, `F_c`, `u0`, the
//! force scale is `S = max(min(k_d v_d T, F_s), 2 (F_s − F_c))` (the drive spring's load up to
//! the break-away force, or the stick-slip drop), and the travel scale `X = v_d T + 2 u0`.
//!
//! | check | refused when |
//! |---|---|
//! | flat channel | a channel (`F_d`, `x_s`, `x_d`) takes fewer than 3 distinct values (dead, disconnected, or zero-filled) |
//! | force scale | the largest `abs(F_d)` lies beyond `S × 100` or below `min(k_d v_d T, F_s) / 100` (a unit or gain off by orders of magnitude) |
//! | travel scale | the range of `x_s` or `x_d` exceeds `100 X` |
//! | drive slope | the least-squares slope of `x_d` over `t` differs from `v_d` by more than a factor 1.25 (without `x_d`: that of `x_s`, by more than a factor 2) |
//! | spring | `F_d` follows `x_d − x_s` (R² ≥ 0.8) with a stiffness off `k_d` by more than a factor 1.5 (`F_d = k_d (x_d − x_s) + h_d (v_d − v)`: a force gain or `k_d` off) |
//! | vibration timing | `t_on` is given without vibration, or at or after the recording's last sample |
//! | spikes | a force sample stands out from both neighbours, which agree with each other: `abs(F_i − (F_{i−1} + F_{i+1})/2) > max(50 σ, 0.05 S)` with `abs(F_{i+1} − F_{i−1})` under a fifth of that, `σ` the median-absolute-deviation scale of that second difference (a slip drops the force over neighbouring samples, which then disagree) |
//!
//! The thresholds are orders of magnitude away from anything a rig like the paper's records:
//! every campaign of `synth` and of the independent test rig passes.

use super::{Campaign, Recording};
use std::fmt;

/// Factor by which a scale may be off before it is refused.
pub const SCALE_FACTOR: f64 = 100.0;
/// Largest ratio of the recorded drive slope to `v_d` (and of `v_d` to the slope).
pub const SLOPE_FACTOR: f64 = 1.25;
/// Largest ratio of the body's recorded mean velocity to `v_d` (and of `v_d` to it), where no
/// `x_d` is recorded.
pub const BODY_SLOPE_FACTOR: f64 = 2.0;
/// Largest ratio of the stiffness through which `F_d` follows `x_d − x_s` to `k_d` (and of
/// `k_d` to it): a force gain of 1.5 or more is refused.
pub const SPRING_FACTOR: f64 = 1.5;
/// Smallest share of the force's variance that `x_d − x_s` must explain before the spring
/// check judges (drive damping and a slow sensor scatter the relation).
pub const SPRING_R2: f64 = 0.8;
/// A spike stands this many noise scales out.
pub const SPIKE_SIGMAS: f64 = 50.0;

/// One failed check.
#[derive(Clone, Debug, PartialEq)]
pub struct Implausible {
    /// The recording (file stem).
    pub recording: String,
    /// The check (`flat channel`, `force scale`, `travel scale`, `drive slope`, `spring`,
    /// `vibration timing`, `spikes`).
    pub check: &'static str,
    /// What was found.
    pub found: String,
    /// What was expected.
    pub expected: String,
}

impl fmt::Display for Implausible {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "recording {}: {}: found {}; expected {}",
            self.recording, self.check, self.found, self.expected
        )
    }
}

fn distinct(v: &[f64]) -> usize {
    let mut seen: Vec<u64> = vec![];
    for x in v {
        let b = x.to_bits();
        if !seen.contains(&b) {
            seen.push(b);
            if seen.len() >= 3 {
                break;
            }
        }
    }
    seen.len()
}

/// The median of `v` (the upper one of an even count); NaN where `v` is empty.
pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_unstable_by(f64::total_cmp);
    v[v.len() / 2]
}

fn range(v: &[f64]) -> f64 {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    hi - lo
}

/// Least-squares slope of `y` over `t`.
fn slope(t: &[f64], y: &[f64]) -> f64 {
    let n = t.len() as f64;
    let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut num, mut den) = (0.0, 0.0);
    for (a, b) in t.iter().zip(y) {
        num += (a - mt) * (b - my);
        den += (a - mt) * (a - mt);
    }
    num / den
}

fn variance(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n
}

/// One recording under check: its scales, its failures so far and its flat channels.
struct Checker<'a> {
    r: &'a Recording,
    /// The drive spring's load up to break-away, `min(k_d v_d T, F_s)` \[N\].
    load: f64,
    /// The force scale `S` \[N\] (module docs).
    scale: f64,
    /// The travel scale `X` \[m\] (module docs).
    travel: f64,
    /// The recorded channels: name, unit, samples.
    channels: Vec<(&'static str, &'static str, &'a [f64])>,
    /// The channels found flat, which later checks leave alone.
    flat: Vec<&'static str>,
    out: Vec<Implausible>,
}

/// The checks of one recording (module docs); empty when it is plausible.
pub fn check(r: &Recording) -> Vec<Implausible> {
    let mut c = Checker::new(r);
    c.flat_channels();
    if !c.flat.contains(&"F_d") {
        c.force_scale();
        c.spikes();
    }
    c.travel_scale();
    c.body_slope();
    c.spring();
    c.vibration_timing();
    c.drive_slope();
    c.out
}

impl<'a> Checker<'a> {
    fn new(r: &'a Recording) -> Self {
        let p = &r.params;
        let dur = r.t[r.t.len() - 1] - r.t[0];
        let load = (p.k_d * p.v_d * dur).min(p.f_s);
        let channels: Vec<(&'static str, &'static str, &'a [f64])> = [
            Some(("F_d", "N", r.f_d.as_slice())),
            r.x_s.as_deref().map(|v| ("x_s", "m", v)),
            r.x_d.as_deref().map(|v| ("x_d", "m", v)),
        ]
        .into_iter()
        .flatten()
        .collect();
        Checker {
            r,
            load,
            scale: load.max(2.0 * (p.f_s - p.f_c)),
            travel: p.v_d * dur + 2.0 * p.u0,
            channels,
            flat: vec![],
            out: vec![],
        }
    }

    fn fail(&mut self, check: &'static str, found: String, expected: String) {
        self.out.push(Implausible {
            recording: self.r.name.clone(),
            check,
            found,
            expected,
        })
    }

    fn flat_channels(&mut self) {
        for (name, unit, v) in self.channels.clone() {
            let k = distinct(v);
            if k < 3 {
                self.flat.push(name);
                self.fail(
                    "flat channel",
                    format!(
                        "{name} takes {} over its {} samples ({} {unit} first)",
                        if k == 1 {
                            "a single value".to_string()
                        } else {
                            format!("only {k} values")
                        },
                        v.len(),
                        v[0]
                    ),
                    "a signal that varies, by its noise at least (a dead or disconnected channel records nothing)".into(),
                );
            }
        }
    }

    fn force_scale(&mut self) {
        let (r, p, load, scale) = (self.r, &self.r.params, self.load, self.scale);
        let peak = r.f_d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if peak > SCALE_FACTOR * scale || peak < load / SCALE_FACTOR {
            self.fail(
                "force scale",
                format!("max |F_d| = {peak:.4e} N"),
                format!(
                    "within a factor {SCALE_FACTOR} of the conditions' force scale: the drive spring's load up to break-away min(k_d v_d T, F_s) = {load:.3e} N, the stick-slip drop 2 (F_s - F_c) = {:.3e} N (a gain or unit off?)",
                    2.0 * (p.f_s - p.f_c)
                ),
            );
        }
    }

    fn spikes(&mut self) {
        let r = self.r;
        let n = r.f_d.len();
        if n < 3 {
            return;
        }
        let r2: Vec<f64> = (1..n - 1)
            .map(|i| r.f_d[i] - 0.5 * (r.f_d[i - 1] + r.f_d[i + 1]))
            .collect();
        let med = median(r2.clone());
        let sigma = 1.4826 * median(r2.iter().map(|x| (x - med).abs()).collect());
        let limit = (SPIKE_SIGMAS * sigma).max(0.05 * self.scale);
        let spikes: Vec<usize> = (1..n - 1)
            .filter(|&i| {
                let d = r2[i - 1].abs();
                d > limit && (r.f_d[i + 1] - r.f_d[i - 1]).abs() < 0.2 * d
            })
            .collect();
        if let Some(&first) = spikes.first() {
            self.fail(
                "spikes",
                format!(
                    "{} sample(s) of F_d standing alone, the first {:.4e} N at t = {} s (row {})",
                    spikes.len(),
                    r.f_d[first],
                    r.t[first],
                    first + 2
                ),
                format!(
                    "no sample more than {limit:.3e} N off both its neighbours ({SPIKE_SIGMAS} times the channel's noise scale {sigma:.3e} N, or 5 % of the force scale)"
                ),
            );
        }
    }

    fn travel_scale(&mut self) {
        let travel = self.travel;
        let channels = self.channels.clone();
        for &(name, _, v) in &channels[1..] {
            if self.flat.contains(&name) {
                continue;
            }
            let span = range(v);
            if span > SCALE_FACTOR * travel {
                self.fail(
                    "travel scale",
                    format!("{name} spans {span:.4e} m"),
                    format!(
                        "at most {SCALE_FACTOR} times the drive's travel v_d T + 2 u0 = {travel:.3e} m (a unit off?)"
                    ),
                );
            }
        }
    }

    /// Without x_d, the body's own mean velocity: over a recording of stick-slip it follows
    /// the drive, though a first loading from rest can hold it back (a wider factor).
    fn body_slope(&mut self) {
        let (r, p) = (self.r, &self.r.params);
        if r.x_d.is_none()
            && let Some(x_s) = &r.x_s
            && !self.flat.contains(&"x_s")
        {
            let s = slope(&r.t, x_s);
            if !(s / p.v_d <= BODY_SLOPE_FACTOR && p.v_d / s <= BODY_SLOPE_FACTOR) {
                self.fail(
                    "drive slope",
                    format!(
                        "x_s rises at {s:.4e} m/s, {:.3} times v_d (no x_d recorded)",
                        s / p.v_d
                    ),
                    format!(
                        "the conditions' v_d = {:e} m/s within a factor {BODY_SLOPE_FACTOR}: the body follows the drive on average (is v_d in the conditions file right?)",
                        p.v_d
                    ),
                );
            }
        }
    }

    /// The drive force is the spring's: F_d = k_d (x_d - x_s) + h_d (v_d - v) (docs/model.md).
    fn spring(&mut self) {
        let (r, p) = (self.r, &self.r.params);
        if let (Some(x_s), Some(x_d)) = (&r.x_s, &r.x_d)
            && !self.flat.iter().any(|c| ["F_d", "x_s", "x_d"].contains(c))
        {
            let ext: Vec<f64> = x_d.iter().zip(x_s).map(|(d, s)| d - s).collect();
            let k = slope(&ext, &r.f_d);
            let r2 = k * k * variance(&ext) / variance(&r.f_d);
            if r2 >= SPRING_R2 && !(k / p.k_d <= SPRING_FACTOR && p.k_d / k <= SPRING_FACTOR) {
                self.fail(
                    "spring",
                    format!(
                        "F_d follows x_d - x_s with a stiffness of {k:.4e} N/m, {:.3} times k_d (it explains {:.0} % of the force's variance)",
                        k / p.k_d,
                        100.0 * r2
                    ),
                    format!(
                        "the conditions' k_d = {:e} N/m within a factor {SPRING_FACTOR}, as F_d = k_d (x_d - x_s) + h_d (v_d - v) (a force gain or k_d off?)",
                        p.k_d
                    ),
                );
            }
        }
    }

    fn vibration_timing(&mut self) {
        let (r, p) = (self.r, &self.r.params);
        if p.t_on <= 0.0 {
            return;
        }
        let end = r.t[r.t.len() - 1];
        if !p.vibrates() {
            self.fail(
                "vibration timing",
                format!("t_on = {} s with no vibration (f = {} Hz, u0 = {} m)", p.t_on, p.f, p.u0),
                "t_on only where the substrate vibrates (f > 0, u0 > 0): the time it is switched on".into(),
            );
        } else if p.t_on >= end {
            self.fail(
                "vibration timing",
                format!("t_on = {} s, at or after the recording's end at t = {end} s", p.t_on),
                "a switch-on within the recording (t_on before its last sample), or t_on = 0 for vibration throughout".into(),
            );
        }
    }

    fn drive_slope(&mut self) {
        let (r, p) = (self.r, &self.r.params);
        if let Some(x_d) = &r.x_d
            && !self.flat.contains(&"x_d")
        {
            let s = slope(&r.t, x_d);
            if !(s / p.v_d <= SLOPE_FACTOR && p.v_d / s <= SLOPE_FACTOR) {
                self.fail(
                    "drive slope",
                    format!("x_d rises at {s:.4e} m/s, {:.3} times v_d", s / p.v_d),
                    format!(
                        "the conditions' v_d = {:e} m/s within a factor {SLOPE_FACTOR} (is v_d in the conditions file right?)",
                        p.v_d
                    ),
                );
            }
        }
    }
}

/// The checks of every recording of a campaign.
pub fn check_campaign(c: &Campaign) -> Vec<Implausible> {
    c.recordings.iter().flat_map(check).collect()
}

impl Campaign {
    /// The campaign without the named recordings.
    pub fn without(&self, names: &[String]) -> Campaign {
        Campaign {
            dir: self.dir.clone(),
            recordings: self
                .recordings
                .iter()
                .filter(|r| !names.contains(&r.name))
                .cloned()
                .collect(),
            planned: self
                .planned
                .iter()
                .filter(|n| !names.contains(n))
                .cloned()
                .collect(),
            acquisition: self.acquisition.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Params;

    /// A plausible recording: stick-slip-like saw-tooth with noise, drive at v_d.
    fn rec() -> Recording {
        let p = Params {
            v_d: 1e-3,
            k_d: 1e4,
            ..Params::default()
        };
        let n = 4000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let noise = |i: usize| 0.02 * ((i * 7919 % 1000) as f64 / 500.0 - 1.0);
        let f_d = t
            .iter()
            .enumerate()
            .map(|(i, &x)| 8.0 + 3.0 * ((x * 2.0).fract()) + noise(i))
            .collect();
        let x_d = t.iter().map(|&x| p.v_d * x).collect();
        let x_s = t
            .iter()
            .enumerate()
            .map(|(i, &x)| p.v_d * x - 8e-4 + 1e-7 * noise(i))
            .collect();
        Recording {
            name: "a".into(),
            params: p,
            t,
            f_d,
            x_s: Some(x_s),
            x_d: Some(x_d),
        }
    }

    fn checks(r: &Recording) -> Vec<&'static str> {
        check(r).iter().map(|i| i.check).collect()
    }

    #[test]
    fn a_plausible_recording_passes_and_each_corruption_is_named() {
        let r = rec();
        assert!(check(&r).is_empty(), "{:?}", check(&r));
        let mut dead = r.clone();
        dead.f_d.iter_mut().for_each(|x| *x = 0.0);
        assert_eq!(checks(&dead), ["flat channel"]);
        let mut gain = r.clone();
        gain.f_d.iter_mut().for_each(|x| *x *= 1e6);
        assert_eq!(checks(&gain), ["force scale"]);
        let mut spike = r.clone();
        spike.f_d[1234] = 1e300;
        let s = check(&spike);
        assert!(
            s.iter()
                .any(|i| i.check == "spikes" && i.found.contains("row 1236")),
            "{s:?}"
        );
        let mut small = r.clone();
        small.f_d[1234] += 3.0;
        assert_eq!(checks(&small), ["spikes"]);
        let mut half = r.clone();
        half.params.v_d /= 2.0;
        assert!(checks(&half).contains(&"drive slope"), "{:?}", check(&half));
        let mut mm = r.clone();
        mm.x_s.as_mut().unwrap().iter_mut().for_each(|x| *x *= 1e3);
        assert_eq!(checks(&mm), ["travel scale"]);
        // A slip drops the force over neighbouring samples: not a spike.
        let mut drop = r.clone();
        for i in 2000..4000 {
            drop.f_d[i] -= 3.0;
        }
        assert!(check(&drop).is_empty(), "{:?}", check(&drop));
    }
}
