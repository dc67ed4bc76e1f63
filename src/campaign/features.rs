//! Features of a recorded or simulated stick-slip trace, computed the same way for both, and
//! the phases of the stick-slip cycle they belong to.
//!
//! The steady window is the second half of the trace (MODEL.md). The force is smoothed by a
//! moving average over one vibration period `1/f` (1 ms without vibration, against sensor
//! noise), with fractional-sample ends so that any sampling rate removes the ripple alike.
//! Cycles are found on the smoothed force by a zig-zag detector whose hysteresis is
//! `max(0.1 N, 5 %` of the force range`)`, so noise of a few hundredths of a newton makes no
//! cycles. Per cycle (trough → peak → next trough):
//!
//! | feature | phase | definition |
//! |---|---|---|
//! | `stick_slope` [N/s] | loading | slope of a line fitted to the middle half of the loading |
//! | `period` \[s\] | loading | peak to next peak |
//! | `peak` \[N\] | breakaway | smoothed force at the peak |
//! | `rounding` \[N\] | breakaway | loading line at the peak time minus the peak: how far the force bends before breakaway |
//! | `dF` \[N\] | slip | peak minus next trough (max − min of the smoothed force without cycles) |
//! | `slip_time` \[s\] | slip | peak to next trough |
//! | `trough` \[N\] | re-stick | smoothed force at the trough |
//! | `restick_ripple` \[N\] | re-stick | RMS of the smoothed force about the loading line over the first fifth of the loading |
//! | `mean_force` \[N\] | whole cycle | mean of the force over the window |
//! | `drive_ripple` \[m\] | whole cycle | RMS of `x_d` about a straight line, less the noise estimated from its differences |
//! | `r` [-] | whole cycle | dF over dF of the recording without vibration at the same `v_d`, `k_d` (set by the campaign) |
//!
//! Each feature carries its standard error (spread over cycles / √n; block means for the mean
//! force) and a floor that stands for what a model cannot be asked to match
//! ([`Feature::floor`]).

/// A feature's identity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feature {
    /// Peak force.
    Peak,
    /// Trough force.
    Trough,
    /// Stick-slip amplitude.
    DF,
    /// Cycle period.
    Period,
    /// Mean drive force.
    MeanForce,
    /// Slope of the stick phase.
    StickSlope,
    /// Duration of the slip.
    SlipTime,
    /// Bending of the force before breakaway.
    Rounding,
    /// Ripple after re-stick.
    RestickRipple,
    /// Drive position error.
    DriveRipple,
    /// Reduction coefficient.
    R,
}

/// All features, in a fixed order (the columns of the HDF5 tables).
pub const FEATURES: [Feature; 11] = [
    Feature::Peak,
    Feature::Trough,
    Feature::DF,
    Feature::Period,
    Feature::MeanForce,
    Feature::StickSlope,
    Feature::SlipTime,
    Feature::Rounding,
    Feature::RestickRipple,
    Feature::DriveRipple,
    Feature::R,
];

/// Phases of the stick-slip cycle, and the whole cycle for global features.
pub const PHASES: [&str; 5] = ["loading", "breakaway", "slip", "re-stick", "whole cycle"];

impl Feature {
    /// Name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Feature::Peak => "peak",
            Feature::Trough => "trough",
            Feature::DF => "dF",
            Feature::Period => "period",
            Feature::MeanForce => "mean_force",
            Feature::StickSlope => "stick_slope",
            Feature::SlipTime => "slip_time",
            Feature::Rounding => "rounding",
            Feature::RestickRipple => "restick_ripple",
            Feature::DriveRipple => "drive_ripple",
            Feature::R => "r",
        }
    }

    /// Unit.
    pub fn unit(self) -> &'static str {
        match self {
            Feature::Period | Feature::SlipTime => "s",
            Feature::StickSlope => "N/s",
            Feature::DriveRipple => "m",
            Feature::R => "-",
            _ => "N",
        }
    }

    /// Index into [`PHASES`].
    pub fn phase(self) -> usize {
        match self {
            Feature::StickSlope | Feature::Period => 0,
            Feature::Peak | Feature::Rounding => 1,
            Feature::DF | Feature::SlipTime => 2,
            Feature::Trough | Feature::RestickRipple => 3,
            Feature::MeanForce | Feature::DriveRipple | Feature::R => 4,
        }
    }

    /// The part of a difference no model is asked to explain (added in quadrature to the
    /// standard errors): 0.02 N on peak, trough and dF, 0.01 N on the mean force and the
    /// shape forces, 1.5 % on times and slopes, 0.05 µm on the drive ripple, 0.015 on r.
    pub fn floor(self, value: f64) -> f64 {
        match self {
            Feature::Peak | Feature::Trough | Feature::DF => 0.02,
            Feature::MeanForce | Feature::Rounding | Feature::RestickRipple => 0.01,
            Feature::Period | Feature::SlipTime | Feature::StickSlope => 0.015 * value.abs(),
            Feature::DriveRipple => 5e-8,
            Feature::R => 0.015,
        }
    }
}

/// Feature values and standard errors (NaN where undefined: no cycles, no reference).
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureSet {
    /// Values, in the order of [`FEATURES`].
    pub value: [f64; 11],
    /// Standard errors (NaN where not estimable).
    pub stderr: [f64; 11],
    /// Complete cycles found in the window.
    pub cycles: usize,
}

impl FeatureSet {
    /// The value of one feature.
    pub fn get(&self, f: Feature) -> f64 {
        self.value[f as usize]
    }
}

fn mean_se(x: &[f64]) -> (f64, f64) {
    let n = x.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let m = x.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (m, f64::NAN);
    }
    let var = x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1) as f64;
    (m, (var / n as f64).sqrt())
}

/// Least-squares line through `(t, y)`: `(slope, intercept)`.
fn line(t: &[f64], y: &[f64]) -> (f64, f64) {
    let n = t.len() as f64;
    let mt = t.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (a, b) in t.iter().zip(y) {
        sxy += (a - mt) * (b - my);
        sxx += (a - mt) * (a - mt);
    }
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (b, my - b * mt)
}

/// Moving average over a window of `w` seconds ending at each sample, with fractional ends
/// (trapezoidal running integral, interpolated). Samples closer than `w` to the start keep
/// their raw value.
pub fn smooth(y: &[f64], dt: f64, w: f64) -> Vec<f64> {
    let n = y.len();
    let m = w / dt;
    if m <= 1.0 {
        return y.to_vec();
    }
    let mut c = vec![0.0; n];
    for i in 1..n {
        c[i] = c[i - 1] + 0.5 * (y[i] + y[i - 1]) * dt;
    }
    (0..n)
        .map(|i| {
            let s = i as f64 - m;
            if s < 0.0 {
                return y[i];
            }
            let j = s.floor() as usize;
            let fr = s - j as f64;
            let cs = c[j] + fr * (c[(j + 1).min(n - 1)] - c[j]);
            (c[i] - cs) / w
        })
        .collect()
}

/// Features of a trace sampled every `dt` seconds: force `f` \[N\] and drive displacement `x_d`
/// \[m\], at vibration frequency `freq` \[Hz\] (0 without vibration). `r` is left NaN.
pub fn extract(f: &[f64], x_d: &[f64], dt: f64, freq: f64) -> FeatureSet {
    let n = f.len();
    let i0 = n / 2;
    let w = if freq > 0.0 { 1.0 / freq } else { 1e-3 };
    let sm = smooth(f, dt, w);
    let win = &sm[i0..];
    let (lo, hi) = win
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let h = (0.05 * (hi - lo)).max(0.1);
    // Zig-zag: alternating extremes that differ by more than h.
    let mut ext: Vec<(usize, bool)> = vec![]; // (index, is_peak)
    let (mut cand, mut cand_is_peak) = (i0, true);
    let mut dir = 0i8;
    for i in i0..n {
        let x = sm[i];
        match dir {
            0 => {
                if x - sm[cand] > h {
                    dir = 1;
                    ext.push((cand, false));
                    cand = i;
                    cand_is_peak = true;
                } else if sm[cand] - x > h {
                    dir = -1;
                    ext.push((cand, true));
                    cand = i;
                    cand_is_peak = false;
                } else if (x > sm[cand]) == cand_is_peak {
                    cand = i;
                }
            }
            1 => {
                if x > sm[cand] {
                    cand = i;
                } else if sm[cand] - x > h {
                    ext.push((cand, true));
                    cand = i;
                    dir = -1;
                }
            }
            _ => {
                if x < sm[cand] {
                    cand = i;
                } else if x - sm[cand] > h {
                    ext.push((cand, false));
                    cand = i;
                    dir = 1;
                }
            }
        }
    }
    // The first extreme found from the window's start may be the start itself: drop it.
    if ext.first().is_some_and(|e| e.0 == i0) {
        ext.remove(0);
    }
    let mut per: [Vec<f64>; 11] = Default::default();
    let t = |i: usize| i as f64 * dt;
    let mut peaks = vec![];
    for k in 0..ext.len() {
        let (ip, is_peak) = ext[k];
        if !is_peak || k == 0 || k + 1 >= ext.len() {
            continue;
        }
        let (it0, _) = ext[k - 1];
        let (it1, _) = ext[k + 1];
        peaks.push(ip);
        let p = sm[ip];
        per[Feature::Peak as usize].push(p);
        per[Feature::Trough as usize].push(sm[it1]);
        per[Feature::DF as usize].push(p - sm[it1]);
        per[Feature::SlipTime as usize].push(t(it1) - t(ip));
        let len = ip - it0;
        if len >= 8 {
            let (a, b) = (it0 + len / 4, ip - len / 4);
            let tt: Vec<f64> = (a..=b).map(t).collect();
            let (slope, c) = line(&tt, &sm[a..=b]);
            per[Feature::StickSlope as usize].push(slope);
            per[Feature::Rounding as usize].push(slope * t(ip) + c - p);
            let e = it0 + (len / 5).max(2);
            let rms = ((it0..e)
                .map(|i| (sm[i] - slope * t(i) - c).powi(2))
                .sum::<f64>()
                / (e - it0) as f64)
                .sqrt();
            per[Feature::RestickRipple as usize].push(rms);
        }
    }
    for w in peaks.windows(2) {
        per[Feature::Period as usize].push(t(w[1]) - t(w[0]));
    }
    let mut value = [f64::NAN; 11];
    let mut stderr = [f64::NAN; 11];
    for (i, v) in per.iter().enumerate() {
        let (m, s) = mean_se(v);
        value[i] = m;
        stderr[i] = s;
    }
    let cycles = per[Feature::DF as usize].len();
    if cycles == 0 {
        value[Feature::DF as usize] = hi - lo;
    }
    // Mean force: raw samples; standard error from 8 block means.
    let raw = &f[i0..];
    value[Feature::MeanForce as usize] = raw.iter().sum::<f64>() / raw.len() as f64;
    let blocks: Vec<f64> = raw
        .chunks(raw.len().div_ceil(8))
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .collect();
    stderr[Feature::MeanForce as usize] = mean_se(&blocks).1;
    // Drive ripple: x_d about its line, less white noise (difference variance = 2 σ²).
    let xd = &x_d[i0..];
    let tt: Vec<f64> = (i0..n).map(t).collect();
    let (b, c) = line(&tt, xd);
    let res: Vec<f64> = xd.iter().zip(&tt).map(|(x, tv)| x - b * tv - c).collect();
    let ms = res.iter().map(|r| r * r).sum::<f64>() / res.len() as f64;
    let noise =
        res.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (res.len() - 1) as f64);
    value[Feature::DriveRipple as usize] = (ms - noise).max(0.0).sqrt();
    FeatureSet {
        value,
        stderr,
        cycles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A saw-tooth of known peaks, troughs, period and slope.
    #[test]
    fn sawtooth_features_are_exact() {
        let dt = 1e-4;
        let (period, slip, lo, hi) = (0.2, 0.02, 5.0, 11.0);
        let n = 40_000;
        let f: Vec<f64> = (0..n)
            .map(|i| {
                let ph = (i as f64 * dt) % period;
                if ph < period - slip {
                    lo + (hi - lo) * ph / (period - slip)
                } else {
                    hi - (hi - lo) * (ph - (period - slip)) / slip
                }
            })
            .collect();
        let xd: Vec<f64> = (0..n).map(|i| 1e-3 * i as f64 * dt).collect();
        let fs = extract(&f, &xd, dt, 0.0);
        // The 1 ms smoothing shaves the corners by about half its width times the slopes.
        assert!(
            (fs.get(Feature::Period) - period).abs() < 2.0 * dt,
            "{fs:?}"
        );
        assert!((fs.get(Feature::DF) - (hi - lo)).abs() < 0.2, "{fs:?}");
        let slope = (hi - lo) / (period - slip);
        assert!(
            (fs.get(Feature::StickSlope) / slope - 1.0).abs() < 1e-3,
            "{fs:?}"
        );
        assert!(fs.get(Feature::Rounding).abs() < 0.2, "{fs:?}");
        assert!((fs.get(Feature::MeanForce) - 0.5 * (lo + hi)).abs() < 0.05);
        assert!(fs.get(Feature::DriveRipple) < 1e-9);
        assert!(fs.cycles >= 8);
    }

    /// Smoothing over exactly one period removes a sinusoid at any sampling rate.
    #[test]
    fn smoothing_removes_the_vibration_ripple() {
        let (f, dt) = (1500.0, 1.0 / 7100.0);
        let y: Vec<f64> = (0..5000)
            .map(|i| 3.0 + (std::f64::consts::TAU * f * i as f64 * dt).sin())
            .collect();
        let s = smooth(&y, dt, 1.0 / f);
        let worst = s[100..].iter().map(|v| (v - 3.0).abs()).fold(0.0, f64::max);
        assert!(worst < 0.08, "{worst}");
    }

    /// A sinusoidal drive error is measured through white noise.
    #[test]
    fn drive_ripple_is_measured_through_noise() {
        use rand::{RngExt, SeedableRng, rngs::StdRng};
        let mut rng = StdRng::seed_from_u64(1);
        let dt = 1e-4;
        let n = 20_000;
        let a = 5e-6;
        let xd: Vec<f64> = (0..n)
            .map(|i| {
                let x = 1e-3 * i as f64 * dt;
                x + a * (std::f64::consts::TAU * x / 0.2e-3).sin()
                    + 2e-7 * rng.sample::<f64, _>(rand_distr::StandardNormal)
            })
            .collect();
        let f = vec![8.0; n];
        let fs = extract(&f, &xd, dt, 0.0);
        let want = a / 2f64.sqrt();
        assert!(
            (fs.get(Feature::DriveRipple) / want - 1.0).abs() < 0.03,
            "{fs:?}"
        );
    }
}
