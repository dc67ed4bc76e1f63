//! Features of a recorded or simulated stick-slip trace, computed the same way for both, and
//! the phases of the stick-slip cycle they belong to.
//!
//! The steady window is the second half of the trace (docs/model.md). The force is smoothed by a
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
//! | `r` [-] | whole cycle | dF over dF of the recording without vibration at the same `v_d`, `k_d` (set by the campaign), where that recording shows a stick-slip ([`is_reference`]) |
//! | `F_amp_f`, `F_amp_2f` \[N\] | forcing | amplitude of the raw force at `f` and `2f` (vibrated stages) |
//! | `F_phase_f`, `F_phase_2f` \[rad\] | forcing | their phase against the nominal substrate motion `u0 sin(ω (t − t_on))` |
//! | `x_s_amp_f` \[m\], `x_s_phase_f` \[rad\] | forcing | the same for the body displacement at `f` |
//!
//! The forcing features come from a least-squares fit on the raw samples ([`harmonics`]), in
//! blocks of several periods, each with its own quadratic trend, so they hold at any sampling
//! rate, including rates below `2f`: the fit uses the sample times themselves, and an aliased
//! harmonic is resolved wherever its alias stands clear of zero, of the Nyquist frequency and of
//! the other harmonic's alias (else it is left undefined). A force sensor's or an actuator's
//! dynamics, and a load that varies with the vibration, show here first: the smoothed force that
//! the other features use removes the ripple at `f`.
//!
//! Each feature carries its standard error (spread over cycles / √n; block means for the mean
//! force) and a floor that stands for what a model cannot be asked to match
//! ([`Feature::floor`]).

use std::cmp::Ordering;
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
    /// Force amplitude at `f`.
    ForceAmp1,
    /// Force phase at `f`.
    ForcePhase1,
    /// Force amplitude at `2f`.
    ForceAmp2,
    /// Force phase at `2f`.
    ForcePhase2,
    /// Body displacement amplitude at `f`.
    BodyAmp1,
    /// Body displacement phase at `f`.
    BodyPhase1,
}

/// Number of features.
pub const N_FEATURES: usize = 17;

/// All features, in a fixed order (the columns of the HDF5 tables).
pub const FEATURES: [Feature; N_FEATURES] = [
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
    Feature::ForceAmp1,
    Feature::ForcePhase1,
    Feature::ForceAmp2,
    Feature::ForcePhase2,
    Feature::BodyAmp1,
    Feature::BodyPhase1,
];

/// Phases of the stick-slip cycle, the whole cycle for global features, and the forcing
/// frequency for the harmonic ones.
pub const PHASES: [&str; 6] = [
    "loading",
    "breakaway",
    "slip",
    "re-stick",
    "whole cycle",
    "forcing frequency",
];

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
            Feature::ForceAmp1 => "F_amp_f",
            Feature::ForcePhase1 => "F_phase_f",
            Feature::ForceAmp2 => "F_amp_2f",
            Feature::ForcePhase2 => "F_phase_2f",
            Feature::BodyAmp1 => "x_s_amp_f",
            Feature::BodyPhase1 => "x_s_phase_f",
        }
    }

    /// Whether the feature is an angle (its differences are wrapped to (−π, π]).
    pub fn is_phase(self) -> bool {
        matches!(
            self,
            Feature::ForcePhase1 | Feature::ForcePhase2 | Feature::BodyPhase1
        )
    }

    /// Whether the feature is a harmonic's amplitude or phase at the forcing frequency (or
    /// twice it): measured by a fit whose error is the noise's, its phase only where its
    /// amplitude stands out of that.
    pub fn is_harmonic(self) -> bool {
        self.phase() == 5
    }

    /// The amplitude of the harmonic whose phase this feature is (None: not a phase).
    pub fn amplitude_of(self) -> Option<Feature> {
        match self {
            Feature::ForcePhase1 => Some(Feature::ForceAmp1),
            Feature::ForcePhase2 => Some(Feature::ForceAmp2),
            Feature::BodyPhase1 => Some(Feature::BodyAmp1),
            _ => None,
        }
    }

    /// Unit.
    pub fn unit(self) -> &'static str {
        match self {
            Feature::Period | Feature::SlipTime => "s",
            Feature::StickSlope => "N/s",
            Feature::DriveRipple | Feature::BodyAmp1 => "m",
            Feature::R => "-",
            Feature::ForcePhase1 | Feature::ForcePhase2 | Feature::BodyPhase1 => "rad",
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
            _ => 5,
        }
    }

    /// The part of a difference no model is asked to explain (added in quadrature to the
    /// standard errors): 0.02 N on peak, trough and dF, 0.01 N on the mean force and the
    /// shape forces, 1.5 % on times and slopes, 0.05 µm on the drive ripple, 0.015 on r;
    /// 5 % on the harmonic amplitudes (plus 1e-5 N or 0.1 nm) and 0.05 rad (3°) on their phases.
    /// The amplitudes are relative: the drive spring passes the friction's ripple at `f` scaled
    /// by `k_d / (m ω²)` (2e-4 at 1500 Hz with the defaults), so a force ripple of a few
    /// millinewtons is typical and an absolute floor of 0.01 N would hide it.
    pub fn floor(self, value: f64) -> f64 {
        match self {
            Feature::ForceAmp1 | Feature::ForceAmp2 => 1e-5 + 0.05 * value.abs(),
            Feature::BodyAmp1 => 1e-10 + 0.05 * value.abs(),
            Feature::ForcePhase1 | Feature::ForcePhase2 | Feature::BodyPhase1 => 0.05,
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
    pub value: [f64; N_FEATURES],
    /// Standard errors (NaN where not estimable).
    pub stderr: [f64; N_FEATURES],
    /// Complete cycles found in the window.
    pub cycles: usize,
}

impl FeatureSet {
    /// Every feature undefined.
    pub fn nan() -> FeatureSet {
        FeatureSet {
            value: [f64::NAN; N_FEATURES],
            stderr: [f64::NAN; N_FEATURES],
            cycles: 0,
        }
    }

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

/// The alternating extremes of `sm` from sample `i0` on that differ from their neighbours by
/// more than `h`: `(index, is_peak)`, the first dropped where it is the start itself. In a
/// stick-slip force the peaks are breakaways and the troughs re-sticks.
pub fn zigzag(sm: &[f64], i0: usize, h: f64) -> Vec<(usize, bool)> {
    // Zig-zag: alternating extremes that differ by more than h.
    let mut ext: Vec<(usize, bool)> = vec![]; // (index, is_peak)
    let (mut cand, mut cand_is_peak) = (i0, true);
    let mut dir = 0i8;
    for i in i0..sm.len() {
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
    ext
}

/// Features of a trace sampled every `dt` seconds: force `f` \[N\] and, where recorded, drive
/// displacement `x_d` \[m\], at vibration frequency `freq` \[Hz\] (0 without vibration). `r`
/// and the forcing features are left NaN ([`stage_features`] adds the latter).
pub fn extract(f: &[f64], x_d: Option<&[f64]>, dt: f64, freq: f64) -> FeatureSet {
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
    let ext = zigzag(&sm, i0, h);
    let mut per: [Vec<f64>; N_FEATURES] = Default::default();
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
    let mut value = [f64::NAN; N_FEATURES];
    let mut stderr = [f64::NAN; N_FEATURES];
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
    if let Some(x_d) = x_d {
        let xd = &x_d[i0..];
        let tt: Vec<f64> = (i0..n).map(t).collect();
        let (b, c) = line(&tt, xd);
        let res: Vec<f64> = xd.iter().zip(&tt).map(|(x, tv)| x - b * tv - c).collect();
        let ms = res.iter().map(|r| r * r).sum::<f64>() / res.len() as f64;
        let noise = res.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>()
            / (2.0 * (res.len() - 1) as f64);
        value[Feature::DriveRipple as usize] = (ms - noise).max(0.0).sqrt();
    }
    FeatureSet {
        value,
        stderr,
        cycles,
    }
}

/// Standard deviation of the white noise on a sampled signal, from the median absolute
/// difference of successive samples (`σ = median|Δy| / (0.6745 √2)`): robust to the few fast
/// changes of a slip, which a variance of the differences would count as noise.
pub fn noise_sd(y: &[f64]) -> f64 {
    let mut d: Vec<f64> = y.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    if d.is_empty() {
        return f64::NAN;
    }
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    *m / (0.674_489_75 * std::f64::consts::SQRT_2)
}

/// Least stick-slip amplitude, in standard deviations of the force's noise ([`noise_sd`]), of
/// a resting stage that serves as the reference of `r`: below it the stage shows no stick-slip
/// and `r`, a ratio of two noise levels there, is left undefined.
pub const REFERENCE_MIN_SNR: f64 = 10.0;

/// Whether a resting stage's measured force (samples `f` of the stage, features `fs`) shows a
/// stick-slip that can be the reference of `r`: two cycles or more, of an amplitude of
/// [`REFERENCE_MIN_SNR`] noise standard deviations or more (the noise estimated on the steady
/// window, the second half).
pub fn is_reference(f: &[f64], fs: &FeatureSet) -> bool {
    let sd = noise_sd(&f[f.len() / 2..]);
    fs.cycles >= 2 && fs.get(Feature::DF) >= REFERENCE_MIN_SNR * sd
}

/// The alias of frequency `x` \[Hz\] under sampling at `fs` \[Hz\]: in `[0, fs/2]`.
pub fn alias(x: f64, fs: f64) -> f64 {
    (x - fs * (x / fs).round()).abs()
}

/// Amplitude and phase of one harmonic with standard errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Harmonic {
    /// Amplitude (signal units).
    pub amp: f64,
    /// Its standard error.
    pub amp_se: f64,
    /// Phase \[rad\] in `(−π, π]`: the harmonic is `amp sin(k φ + phase)`, `φ = ω (t − t_on)`.
    pub phase: f64,
    /// Its standard error \[rad\].
    pub phase_se: f64,
}

/// The harmonics at `f` and `2f` (None where unresolved at this sampling) of the steady window
/// (second half) of `y`, sampled at `t0 + i dt`, against the nominal substrate phase
/// `φ = 2π f (t − t_on)`.
///
/// The window is cut into blocks of at least 8 forcing periods and 40 samples (longer where an
/// alias lies close to zero, to the Nyquist frequency or to the other alias: three beat periods
/// of the closest pair). In each block `y ≈ a + b τ + c τ² + Σ_k (C_k cos kφ + S_k sin kφ)` is
/// fitted by least squares (faer's column-pivoted QR) on the samples themselves, so an aliased
/// rate (5 kHz sampling, 3 kHz forcing) fits the right sinusoid. Blocks whose residual RMS
/// exceeds three times the median (a slip inside the block) are dropped; the complex
/// coefficients `S_k + i C_k` are averaged over the rest (coherently: the phase is tied to the
/// substrate), with the spread over blocks / √n as their standard error. A harmonic whose alias
/// cannot be separated within a sixth of the window is left out.
pub fn harmonics(y: &[f64], t0: f64, dt: f64, freq: f64, t_on: f64) -> [Option<Harmonic>; 2] {
    use faer::Mat;
    use faer::linalg::solvers::SolveLstsq;
    let n = y.len();
    let i0 = n / 2;
    let span = (n - i0) as f64 * dt;
    if freq <= 0.0 || n < 80 {
        return [None, None];
    }
    let fs = 1.0 / dt;
    let a = [alias(freq, fs), alias(2.0 * freq, fs)];
    // Separation of each alias from zero and from Nyquist: how long a block must be.
    let sep = |x: f64| x.min(0.5 * fs - x);
    let longest = span / 6.0;
    let need = |d: f64| if d > 0.0 { 3.0 / d } else { f64::INFINITY };
    let mut on = [need(sep(a[0])) <= longest, need(sep(a[1])) <= longest];
    if on[0] && on[1] && need((a[0] - a[1]).abs()) > longest {
        on[1] = false;
    }
    if !on[0] && !on[1] {
        return [None, None];
    }
    let mut block = (8.0 / freq).max(40.0 * dt);
    for k in 0..2 {
        if on[k] {
            block = block.max(need(sep(a[k])));
        }
    }
    if on[0] && on[1] {
        block = block.max(need((a[0] - a[1]).abs()));
    }
    let m = ((block / dt).ceil() as usize).max(8);
    let omega = std::f64::consts::TAU * freq;
    let ks: Vec<usize> = (0..2).filter(|&k| on[k]).collect();
    let cols = 3 + 2 * ks.len();
    // Per block: residual RMS and the complex coefficients (S_k, C_k).
    let mut fits: Vec<(f64, [f64; 4])> = vec![];
    // Each sample's `sin kφ`, `cos kφ` for k = 1, 2: one `sin_cos` a sample, the second
    // harmonic's by the double angle (they fill the blocks' columns).
    let trig: Vec<[f64; 4]> = (i0..n)
        .map(|i| {
            let (s1, c1) = (omega * (t0 + i as f64 * dt - t_on)).sin_cos();
            [s1, c1, 2.0 * s1 * c1, (c1 - s1) * (c1 + s1)]
        })
        .collect();
    let mut start = i0;
    while start + m <= n {
        let tm = t0 + (start as f64 + 0.5 * m as f64) * dt;
        let a_mat = Mat::from_fn(m, cols, |i, j| {
            let t = t0 + (start + i) as f64 * dt;
            let tau = (t - tm) / block;
            match j {
                0 => 1.0,
                1 => tau,
                2 => tau * tau,
                _ => trig[start + i - i0][2 * ks[(j - 3) / 2] + (j - 3) % 2],
            }
        });
        let b = Mat::from_fn(m, 1, |i, _| y[start + i]);
        let x = a_mat.col_piv_qr().solve_lstsq(&b);
        let mut ss = 0.0;
        for i in 0..m {
            let fit: f64 = (0..cols).map(|j| a_mat[(i, j)] * x[(j, 0)]).sum();
            ss += (y[start + i] - fit).powi(2);
        }
        let mut c = [0.0; 4];
        for (q, &k) in ks.iter().enumerate() {
            c[2 * k] = x[(3 + 2 * q, 0)];
            c[2 * k + 1] = x[(4 + 2 * q, 0)];
        }
        if c.iter().all(|v| v.is_finite()) {
            fits.push(((ss / m as f64).sqrt(), c));
        }
        start += m;
    }
    if fits.len() < 4 {
        return [None, None];
    }
    let mut rms: Vec<f64> = fits.iter().map(|f| f.0).collect();
    rms.sort_by(f64::total_cmp);
    let cut = 3.0 * rms[rms.len() / 2];
    let kept: Vec<[f64; 4]> = fits.iter().filter(|f| f.0 <= cut).map(|f| f.1).collect();
    let nk = kept.len() as f64;
    if nk < 4.0 {
        return [None, None];
    }
    let mut out = [None, None];
    for &k in &ks {
        let (si, ci) = (2 * k, 2 * k + 1);
        let ms = kept.iter().map(|c| c[si]).sum::<f64>() / nk;
        let mc = kept.iter().map(|c| c[ci]).sum::<f64>() / nk;
        let vs = kept.iter().map(|c| (c[si] - ms).powi(2)).sum::<f64>() / (nk - 1.0) / nk;
        let vc = kept.iter().map(|c| (c[ci] - mc).powi(2)).sum::<f64>() / (nk - 1.0) / nk;
        let amp = (ms * ms + mc * mc).sqrt();
        // S sin + C cos = A sin(kφ + θ) with A = √(S² + C²), θ = atan2(C, S); the errors by
        // linear propagation (the phase's from the quadrature component).
        let amp_se = if amp > 0.0 {
            ((ms * ms * vs + mc * mc * vc) / (amp * amp)).sqrt()
        } else {
            (0.5 * (vs + vc)).sqrt()
        };
        let phase_se = if amp > 0.0 {
            ((mc * mc * vs + ms * ms * vc).sqrt() / (amp * amp)).min(std::f64::consts::PI)
        } else {
            std::f64::consts::PI
        };
        out[k] = Some(Harmonic {
            amp,
            amp_se,
            phase: mc.atan2(ms),
            phase_se,
        });
    }
    out
}

/// Smallest quantum \[m\] of a displacement channel that [`quantum`] reports: finer steps (a
/// printed file's last digit) act as noise, not as an encoder's resolution.
pub const MIN_QUANTUM: f64 = 1e-10;

/// The step of a quantized channel (an encoder's or an interferometer's resolution), where it
/// has one: the smallest nonzero change between consecutive samples, where at least 90 % of the
/// nonzero changes are whole multiples of it (within 0.1 % of it) and it is at least
/// [`MIN_QUANTUM`]. `None` for a channel that is not quantized (noise makes its changes arbitrary)
/// or never changes.
pub fn quantum(x: &[f64]) -> Option<f64> {
    let diffs = || {
        x.windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .filter(|d| *d > 0.0 && d.is_finite())
    };
    let q = diffs().fold(f64::INFINITY, f64::min);
    if !(q.is_finite() && q >= MIN_QUANTUM) {
        return None;
    }
    let (mut n, mut whole) = (0usize, 0usize);
    for d in diffs() {
        n += 1;
        let k = (d / q).round();
        if (d - k * q).abs() <= 1e-3 * q {
            whole += 1;
        }
    }
    (n > 0 && whole as f64 >= 0.9 * n as f64).then_some(q)
}

/// `x` rounded to the quantum `q`: a simulated channel recorded like the measured one.
pub fn quantize(x: &[f64], q: f64) -> Vec<f64> {
    x.iter().map(|v| (v / q).round() * q).collect()
}

/// A body-displacement channel quantized to `q` \[m\]: its harmonic amplitude at `f` is known to no
/// better than half a quantum (below a few quanta the rounding is a deterministic distortion,
/// not a noise that averages out), so `q/2` joins its standard error in quadrature, and its
/// phase counts only where the amplitude stands out of that too.
pub fn weigh_quantum(fs: &mut FeatureSet, q: f64) {
    let (a, p) = (Feature::BodyAmp1 as usize, Feature::BodyPhase1 as usize);
    if !fs.value[a].is_finite() {
        return;
    }
    let se = fs.stderr[a];
    let se = if se.is_finite() { se } else { 0.0 };
    fs.stderr[a] = se.hypot(0.5 * q);
    if fs.value[a].partial_cmp(&(3.0 * fs.stderr[a])) != Some(Ordering::Greater) {
        fs.value[p] = f64::NAN;
        fs.stderr[p] = f64::NAN;
    }
}

/// One stage of a recording: samples `lo..hi`, vibrating at `freq` (0: resting substrate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stage {
    /// First sample.
    pub lo: usize,
    /// One past the last sample.
    pub hi: usize,
    /// Vibration frequency \[Hz\] (0 without vibration).
    pub freq: f64,
}

/// Fewest samples a stage must hold to give features.
pub const MIN_STAGE_SAMPLES: usize = 200;

/// The stages of a recording sampled at times `t` under conditions `p`: one (the whole
/// recording), or two where the vibration is switched on at `t_on > 0` within it (docs/model.md):
/// the resting substrate before, the vibrated one after. A stage too short to give features
/// ([`MIN_STAGE_SAMPLES`]) is left out.
pub fn stages(t: &[f64], p: &crate::model::Params) -> Vec<Stage> {
    let n = t.len();
    let freq = if p.vibrates() { p.f } else { 0.0 };
    if !p.two_stage() {
        return vec![Stage { lo: 0, hi: n, freq }];
    }
    let on = t.partition_point(|&x| x < p.t_on);
    [
        Stage {
            lo: 0,
            hi: on,
            freq: 0.0,
        },
        Stage {
            lo: on,
            hi: n,
            freq,
        },
    ]
    .into_iter()
    .filter(|s| s.hi - s.lo >= MIN_STAGE_SAMPLES)
    .collect()
}

/// The features of one stage of a trace: [`extract`] on its samples, and on a vibrated stage
/// the forcing features ([`harmonics`]) of the force and, where recorded, of the body
/// displacement, against the substrate phase from `t_on`.
pub fn stage_features(
    t: &[f64],
    f_d: &[f64],
    x_s: Option<&[f64]>,
    x_d: Option<&[f64]>,
    dt: f64,
    stage: Stage,
    t_on: f64,
) -> FeatureSet {
    let r = stage.lo..stage.hi;
    let mut fs = extract(&f_d[r.clone()], x_d.map(|x| &x[r.clone()]), dt, stage.freq);
    if stage.freq > 0.0 {
        let t0 = t[stage.lo];
        let put = |fs: &mut FeatureSet, h: Option<Harmonic>, amp: Feature, phase: Feature| {
            if let Some(h) = h {
                fs.value[amp as usize] = h.amp;
                fs.stderr[amp as usize] = h.amp_se;
                // A phase counts only where its amplitude stands out of the noise.
                if h.amp > 3.0 * h.amp_se {
                    fs.value[phase as usize] = h.phase;
                    fs.stderr[phase as usize] = h.phase_se;
                }
            }
        };
        let [h1, h2] = harmonics(&f_d[r.clone()], t0, dt, stage.freq, t_on);
        put(&mut fs, h1, Feature::ForceAmp1, Feature::ForcePhase1);
        put(&mut fs, h2, Feature::ForceAmp2, Feature::ForcePhase2);
        if let Some(x) = x_s {
            let [h1, _] = harmonics(&x[r], t0, dt, stage.freq, t_on);
            put(&mut fs, h1, Feature::BodyAmp1, Feature::BodyPhase1);
        }
    }
    fs
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The noise estimate sees through a stick-slip: white noise of σ = 0.03 N on a saw-tooth
    /// of 3 N (slips of 20 samples) is estimated within 5 %; that trace is a reference of `r`,
    /// the noise alone on a constant force is not.
    #[test]
    fn noise_is_estimated_beside_slips_and_noise_is_no_reference() {
        let (dt, n, sigma) = (1e-4, 40_000, 0.03);
        // A deterministic uniform generator (splitmix64) summed 12 times: near-Gaussian, σ 1.
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut gauss = || {
            let mut s = 0.0;
            for _ in 0..12 {
                state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
                let mut z = state;
                z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
                s += ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64;
            }
            s - 6.0
        };
        let saw = |i: usize| {
            let k = i % 2000;
            if k < 1980 {
                8.0 + 3.0 * k as f64 / 1980.0
            } else {
                11.0 - 3.0 * (k - 1980) as f64 / 20.0
            }
        };
        let f: Vec<f64> = (0..n).map(|i| saw(i) + sigma * gauss()).collect();
        let est = noise_sd(&f);
        assert!(
            (est / sigma - 1.0).abs() < 0.05,
            "noise {est} against {sigma}"
        );
        assert!(is_reference(&f, &extract(&f, None, dt, 0.0)));
        let flat: Vec<f64> = (0..n).map(|_| 8.3 + 0.05 * gauss()).collect();
        assert!(!is_reference(&flat, &extract(&flat, None, dt, 0.0)));
    }

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
        let fs = extract(&f, Some(&xd), dt, 0.0);
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

    /// An encoder's step is found, whatever the motion; noise or a printed file's last digits
    /// are not a step.
    #[test]
    fn quantized_channels_are_detected_by_their_step() {
        use rand::{RngExt, SeedableRng, rngs::StdRng};
        let mut rng = StdRng::seed_from_u64(3);
        let q = 1e-7;
        let x: Vec<f64> = (0..5000)
            .map(|i| 1e-3 * i as f64 * 1e-4 + 3e-8 * (0.3 * i as f64).sin())
            .collect();
        let xq = quantize(&x, q);
        let got = quantum(&xq).expect("quantized");
        assert!((got / q - 1.0).abs() < 1e-6, "{got}");
        // Coarser steps that the motion crosses two at a time are still one quantum apart.
        let xq5 = quantize(&x, 5e-7);
        assert!((quantum(&xq5).unwrap() / 5e-7 - 1.0).abs() < 1e-6);
        let noisy: Vec<f64> = x
            .iter()
            .map(|v| v + 5e-9 * rng.sample::<f64, _>(rand_distr::StandardNormal))
            .collect();
        assert_eq!(quantum(&noisy), None);
        // Ten significant digits, as a CSV writer prints them: not an encoder.
        let printed: Vec<f64> = noisy
            .iter()
            .map(|v| format!("{v:.9e}").parse::<f64>().unwrap())
            .collect();
        assert_eq!(quantum(&printed), None);
        assert_eq!(quantum(&vec![2e-6; 100]), None);
        // The weight: half a quantum in the amplitude's error, the phase dropped below 3 of it.
        let mut fs = FeatureSet::nan();
        fs.value[Feature::BodyAmp1 as usize] = 1e-7;
        fs.stderr[Feature::BodyAmp1 as usize] = 1e-9;
        fs.value[Feature::BodyPhase1 as usize] = 0.3;
        weigh_quantum(&mut fs, q);
        assert!(
            (fs.stderr[Feature::BodyAmp1 as usize] - (1e-18f64 + 2.5e-15).sqrt()).abs() < 1e-12
        );
        assert!(fs.value[Feature::BodyPhase1 as usize].is_nan());
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
        let fs = extract(&f, Some(&xd), dt, 0.0);
        let want = a / 2f64.sqrt();
        assert!(
            (fs.get(Feature::DriveRipple) / want - 1.0).abs() < 0.03,
            "{fs:?}"
        );
    }

    /// A known sinusoid on a saw-tooth with noise, sampled below twice its frequency (5 kHz
    /// against 3 kHz): amplitude and phase come back within their standard errors.
    #[test]
    fn harmonics_are_fitted_at_an_aliased_rate() {
        use rand::{RngExt, SeedableRng, rngs::StdRng};
        let mut rng = StdRng::seed_from_u64(3);
        let (f, fs, t_on) = (3000.0, 5000.0, 0.37);
        let dt = 1.0 / fs;
        let (a1, p1, a2, p2) = (4e-3, 0.7, 1.5e-3, -2.0);
        let n = 40_000;
        let t0 = 0.5;
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let t = t0 + i as f64 * dt;
                let ph = std::f64::consts::TAU * f * (t - t_on);
                7.0 + 2.0 * ((t * 3.0) % 1.0)
                    + a1 * (ph + p1).sin()
                    + a2 * (2.0 * ph + p2).sin()
                    + 0.02 * rng.sample::<f64, _>(rand_distr::StandardNormal)
            })
            .collect();
        // 3 kHz aliases to 2 kHz and 6 kHz to 1 kHz: both resolved.
        assert!((alias(f, fs) - 2000.0).abs() < 1e-9);
        let [h1, h2] = harmonics(&y, t0, dt, f, t_on);
        let (h1, h2) = (h1.unwrap(), h2.unwrap());
        assert!((h1.amp - a1).abs() < 4.0 * h1.amp_se, "{h1:?}");
        assert!((h1.phase - p1).abs() < 4.0 * h1.phase_se, "{h1:?}");
        assert!((h2.amp - a2).abs() < 4.0 * h2.amp_se, "{h2:?}");
        assert!((h2.phase - p2).abs() < 4.0 * h2.phase_se, "{h2:?}");
        // The errors reflect the noise: 0.02 N over 20 000 samples is about 2e-4 N.
        assert!(h1.amp_se < 5e-4 && h1.amp_se > 5e-5, "{h1:?}");
    }

    /// Forcing at exactly half the sampling rate has no resolvable sine: left undefined.
    #[test]
    fn a_harmonic_at_the_nyquist_frequency_is_left_out() {
        let y: Vec<f64> = (0..20_000).map(|i| (i % 2) as f64).collect();
        let [h1, h2] = harmonics(&y, 0.0, 1e-4, 5000.0, 0.0);
        assert!(h1.is_none(), "{h1:?}");
        // 2f aliases to zero: a trend, not a harmonic.
        assert!(h2.is_none(), "{h2:?}");
    }

    /// Two stages split at t_on; a stage too short is left out.
    #[test]
    fn two_stage_recordings_split_at_the_switch_on() {
        let t: Vec<f64> = (0..10_000).map(|i| i as f64 * 1e-3).collect();
        let mut p = crate::model::Params {
            u0: 1e-7,
            f: 1500.0,
            t_on: 3.0,
            ..Default::default()
        };
        let s = stages(&t, &p);
        assert_eq!(s.len(), 2);
        assert_eq!((s[0].lo, s[0].hi, s[0].freq), (0, 3000, 0.0));
        assert_eq!((s[1].lo, s[1].hi, s[1].freq), (3000, 10_000, 1500.0));
        p.t_on = 0.1;
        let s = stages(&t, &p);
        assert_eq!(s.len(), 1);
        assert_eq!((s[0].lo, s[0].freq), (100, 1500.0));
    }
}
