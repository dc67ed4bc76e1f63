//! The preflight: what the acquisition did to each recording, found before any fit and said
//! with its size (the diagnosis's `acquisition`, per recording), and what the diagnosis does
//! about it ([`prepare`]).
//!
//! | finding | how it is found | what the diagnosis does |
//! |---|---|---|
//! | gaps | a step of the time column over 1.5 times the median step (a dropped DAQ buffer, a restart): [`Campaign::load`](super::Campaign::load) | splits the recording there; pieces under 200 samples are dropped and counted |
//! | clipped samples | a channel sits on its extreme value (first or last) in runs of 3 or more, more samples there than in the band of `max(q, σ)` just inside it | sets the recording aside by name: a clipped stick-slip peak cannot be measured |
//! | mains lines | 50, 100, 150, 60, 120, 180 Hz: the line's cosine and sine fitted beside a quartic in windows of three periods, the medians over the windows without a slip; frequency refined from the phase's progression, within [`MAINS_TOLERANCE_HZ`] (and three standard errors) of the grid's; it must stand [`LONE_LINE`] times above any coherent amplitude within ±[`COMB_HZ`] (a stick-slip's harmonic comb) | subtracts each lone line from `F_d`; reports the others as ambiguous |
//! | vibration frequency | the largest amplitude of `F_d` within ±1000 ppm of the conditions' `f` (aliased where it lies beyond the Nyquist frequency) | uses the measured frequency where it departs from `f` by more than [`CLOCK_SIGMAS`] standard errors |
//! | quantisation step | the least step between the force's distinct values, where every step is a multiple of it | reports it (its noise, `q/√12`, is in the noise the fits estimate) |
//! | noise colour | the lag-one correlation `ρ` of the force's noise, from the first differences' (`ρ = 1 + 2 r₁`, white noise `ρ = 0`), slips left out | reports `ρ`, the correlation time and the effective share of samples `(1 − ρ)/(1 + ρ)` |
//! | zero offset and drift | `F_d` regressed on `x_d − x_s`, 1 and `t` (the drive spring's law, docs/model.md) over the quasi-static samples (a stick's ramp, a steady slide) | reports the intercept, the drift over the recording and the stiffness against `k_d` (a calibration's error) |
//! | following | least-squares slopes of `x_d` and `x_s` over `t` against `v_d` | reports them; the plausibility checks refuse a slope off by 1.25 ([`super::check`]) |
//!
//! What was chosen and why: docs/campaigns.md, "The preflight".

use super::{Campaign, Recording, check::median};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Mains frequencies looked for \[Hz\]: both grids' fundamentals and their second and third
/// harmonics.
pub const MAINS: [f64; 6] = [50.0, 100.0, 150.0, 60.0, 120.0, 180.0];
/// A line is found where its amplitude stands this many standard errors out.
pub const LINE_SIGMAS: f64 = 6.0;
/// Least coherence (the windows' mean phasor over their mean magnitude) of a line: mains keeps
/// its phase over a recording, a sensor's ringing after each slip does not.
pub const LINE_COHERENCE: f64 = 0.6;
/// The measured vibration frequency replaces the conditions' where they differ by this many
/// standard errors.
pub const CLOCK_SIGMAS: f64 = 5.0;
/// Half-width of the search for the vibration frequency \[ppm of `f`\].
pub const CLOCK_SEARCH_PPM: f64 = 1000.0;
/// Least run of samples at a channel's extreme that counts as clipped.
pub const CLIP_RUN: usize = 3;

/// A gap in a recording's time column.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gap {
    /// Time of the last sample before it \[s\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub after_s: f64,
    /// Time missing \[s\] (the step less one regular step).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub missing_s: f64,
    /// Samples missing (rounded).
    pub samples: usize,
}

/// A recording file whose time column has gaps, and the pieces the diagnosis reads.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Split {
    /// The file stem.
    pub file: String,
    /// Its gaps, in time order.
    pub gaps: Vec<Gap>,
    /// The pieces kept, each a recording (`FILE~1`, `FILE~2`, ...; the file's own name where one
    /// piece is kept).
    pub pieces: Vec<String>,
    /// Samples in pieces too short to keep (under 200).
    pub dropped_samples: usize,
}

/// A line found in the force channel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Line {
    /// The nominal frequency looked for \[Hz\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub nominal_hz: f64,
    /// The frequency found \[Hz\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub hz: f64,
    /// Amplitude \[N\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub amplitude: f64,
    /// Its standard error \[N\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub stderr: f64,
    /// Phase of `amplitude · cos(2π hz t + phase)` \[rad\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub phase: f64,
    /// The windows' coherence (1: one phase throughout).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub coherence: f64,
    /// Its amplitude over the largest coherent amplitude within ±[`COMB_HZ`] (each less three
    /// standard errors; infinite where none stands out).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub comb_ratio: f64,
    /// Whether it stands alone ([`LONE_LINE`]) and is subtracted.
    pub subtracted: bool,
}

/// The vibration as the force shows it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vibration {
    /// The conditions' frequency \[Hz\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub conditions_hz: f64,
    /// The frequency found \[Hz\] (NaN where the line does not stand out).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub measured_hz: f64,
    /// `(measured − conditions) / conditions` \[ppm\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub offset_ppm: f64,
    /// Standard error of the offset \[ppm\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub stderr_ppm: f64,
    /// Amplitude of the line in `F_d` over the median of its neighbourhood's.
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub snr: f64,
    /// Whether the diagnosis simulates the measured frequency.
    pub used: bool,
}

/// The force's zero and gain against the drive spring's law.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Zero {
    /// Intercept of `F_d` against `x_d − x_s` at the recording's mid-time \[N\] (the force
    /// channel's zero, less `k_d` times the displacement channels' relative zero).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub offset: f64,
    /// Drift of that zero over the recording \[N\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub drift: f64,
    /// Its standard error \[N\] (the residuals' correlation allowed for).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub drift_stderr: f64,
    /// The stiffness found over `k_d`.
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub stiffness_ratio: f64,
    /// Share of the force's variance the law explains.
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub r2: f64,
}

/// A channel clipped at its extreme.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Clip {
    /// The channel.
    pub channel: String,
    /// The value it sits on.
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub level: f64,
    /// Samples at it.
    pub samples: usize,
    /// Runs of [`CLIP_RUN`] or more samples at it.
    pub runs: usize,
}

/// What the preflight found in one recording (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Acquisition {
    /// The recording as the diagnosis names it.
    pub recording: String,
    /// Sampling rate \[Hz\].
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub rate_hz: f64,
    /// Samples.
    pub samples: usize,
    /// The gaps of its file, where it is a piece of one.
    pub split: Option<Split>,
    /// Mains lines found in `F_d`.
    pub mains: Vec<Line>,
    /// The vibration's frequency as `F_d` shows it (vibrated recordings).
    pub vibration: Option<Vibration>,
    /// Quantisation step of `F_d` \[N\], where its values lie on a lattice.
    pub quantisation: Option<f64>,
    /// Noise scale of `F_d` \[N\] (from the second differences, slips left out).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub noise: f64,
    /// Lag-one correlation of the noise.
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub lag1: f64,
    /// Its correlation time \[s\] (0 for white or anticorrelated noise).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub correlation_time_s: f64,
    /// Effective share of independent samples, `(1 − ρ)/(1 + ρ)` (1 for white noise).
    #[serde(deserialize_with = "crate::nullable::f64")]
    pub effective_share: f64,
    /// The force's zero and gain against the spring's law (where both displacements are recorded).
    pub zero: Option<Zero>,
    /// Slope of `x_d` over `v_d`.
    pub drive_slope_ratio: Option<f64>,
    /// Slope of `x_s` over `v_d`.
    pub body_slope_ratio: Option<f64>,
    /// Channels clipped.
    pub clipped: Vec<Clip>,
    /// Why it is set aside (a clipped channel), if it is.
    pub set_aside: Option<String>,
    /// What the diagnosis takes out of it or changes, in words.
    pub corrected: Vec<String>,
}

/// What the preflight leaves the diagnosis: per recording of the loaded campaign, and the
/// splits of files at their gaps.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Acquired {
    /// One per recording loaded (set aside or not), in the campaign's order.
    pub recordings: Vec<Acquisition>,
    /// Files split at gaps.
    pub splits: Vec<Split>,
}

impl Acquired {
    /// The recordings set aside, with their reasons.
    pub fn set_aside(&self) -> impl Iterator<Item = (&str, &str)> {
        self.recordings
            .iter()
            .filter_map(|a| a.set_aside.as_deref().map(|w| (a.recording.as_str(), w)))
    }
}

/// Lag-one correlation above which the report names the noise as coloured.
pub const COLOURED: f64 = 0.3;
/// Share of `k_d` by which the force's stiffness against the spring's law may depart before the
/// report names a calibration's error.
pub const GAIN_TOLERANCE: f64 = 0.02;

impl Acquisition {
    /// What a reader must know of this recording's acquisition, a line each (empty where the
    /// channel did nothing of note): what was set aside or corrected, and what stands out.
    pub fn findings(&self) -> Vec<String> {
        let mut out = vec![];
        if let Some(w) = &self.set_aside {
            out.push(format!("set aside: {w}"));
        }
        out.extend(self.corrected.iter().cloned());
        for l in &self.mains {
            if !l.subtracted {
                out.push(format!(
                    "a line at {:.3} Hz, {:.3e} ± {:.1e} N, only {:.1} times the coherent amplitudes beside it: mains or a harmonic of the stick-slip, ambiguous (not subtracted)",
                    l.hz, l.amplitude, l.stderr, l.comb_ratio
                ));
            } else if self.set_aside.is_some() {
                out.push(format!(
                    "mains line at {:.3} Hz, {:.3e} ± {:.1e} N",
                    l.hz, l.amplitude, l.stderr
                ));
            }
        }
        if let Some(q) = self.quantisation
            && q > 0.5 * self.noise
        {
            out.push(format!(
                "F_d quantised in steps of {q:.3e} N (noise {:.3e} N; the step adds {:.3e} N)",
                self.noise,
                q / 12f64.sqrt()
            ));
        }
        if self.lag1 > COLOURED {
            out.push(format!(
                "coloured noise: lag-one correlation {:.2}, correlation time {:.3e} s, effective share of samples {:.2}",
                self.lag1, self.correlation_time_s, self.effective_share
            ));
        }
        if let Some(z) = &self.zero {
            if z.drift.abs() > 4.0 * z.drift_stderr && z.drift.abs() > 3.0 * self.noise {
                out.push(format!(
                    "the force's zero drifts by {:+.3e} ± {:.1e} N over the recording",
                    z.drift, z.drift_stderr
                ));
            }
            if z.r2 >= super::check::SPRING_R2 && (z.stiffness_ratio - 1.0).abs() > GAIN_TOLERANCE {
                out.push(format!(
                    "F_d follows x_d - x_s with {:.4} times k_d: a force calibration (or k_d) off by {:+.1} %",
                    z.stiffness_ratio,
                    100.0 * (z.stiffness_ratio - 1.0)
                ));
            }
        }
        if let Some(s) = &self.split {
            out.push(format!(
                "a piece of {} split at {} gap(s) in its time column (the first after {} s, {} samples missing; {} samples in pieces too short to keep)",
                s.file,
                s.gaps.len(),
                s.gaps[0].after_s,
                s.gaps[0].samples,
                s.dropped_samples
            ));
        }
        out
    }
}

impl Acquired {
    /// The report's lines: each recording with findings, then its findings indented.
    pub fn report(&self) -> Vec<String> {
        let mut out = vec![];
        for a in &self.recordings {
            let f = a.findings();
            if !f.is_empty() {
                out.push(format!("recording {}:", a.recording));
                out.extend(f.into_iter().map(|l| format!("  {l}")));
            }
        }
        out
    }
}

/// Examines every recording of `c` and returns the campaign the diagnosis reads: clipped
/// recordings set aside, mains lines subtracted, a measured vibration frequency used (module
/// docs), with what was found in [`Campaign::acquisition`]. An error where every recording is
/// set aside.
pub fn prepare(c: Campaign) -> Result<Campaign, String> {
    let mut out = c.clone();
    out.recordings.clear();
    out.acquisition.recordings.clear();
    for r in &c.recordings {
        let mut r = r.clone();
        let mut a = examine(&r);
        a.split = c
            .acquisition
            .splits
            .iter()
            .find(|s| s.pieces.contains(&r.name))
            .cloned();
        if a.set_aside.is_none() {
            correct(&mut r, &mut a);
            out.recordings.push(r);
        }
        out.acquisition.recordings.push(a);
    }
    out.planned
        .retain(|n| out.recordings.iter().any(|r| &r.name == n));
    if out.recordings.is_empty() {
        let why: Vec<String> = out
            .acquisition
            .set_aside()
            .map(|(n, w)| format!("{n}: {w}"))
            .collect();
        return Err(format!(
            "every recording is set aside by the preflight; nothing is left to fit:\n  {}",
            why.join("\n  ")
        ));
    }
    Ok(out)
}

/// Subtracts the lines found and uses the measured vibration frequency, saying so in `a`.
fn correct(r: &mut Recording, a: &mut Acquisition) {
    for l in a.mains.iter().filter(|l| l.subtracted) {
        for (f, &t) in r.f_d.iter_mut().zip(&r.t) {
            *f -= l.amplitude * (2.0 * PI * l.hz * t + l.phase).cos();
        }
        a.corrected.push(format!(
            "subtracted the {:.3} Hz mains line ({:.3e} N)",
            l.hz, l.amplitude
        ));
    }
    if let Some(v) = &a.vibration
        && v.used
    {
        r.params.f = v.measured_hz;
        a.corrected.push(format!(
            "simulated at the measured vibration frequency {:.4} Hz ({:+.1} ppm against the conditions' {} Hz)",
            v.measured_hz, v.offset_ppm, v.conditions_hz
        ));
    }
}

/// The preflight of one recording (module docs), without its split.
pub fn examine(r: &Recording) -> Acquisition {
    let dt = r.dt();
    let (noise, lag1) = noise_colour(&r.f_d);
    let q = quantisation(&r.f_d);
    let floor = noise.max(q.unwrap_or(0.0));
    let clipped: Vec<Clip> = [
        Some(("F_d", r.f_d.as_slice())),
        r.x_s.as_deref().map(|v| ("x_s", v)),
        r.x_d.as_deref().map(|v| ("x_d", v)),
    ]
    .into_iter()
    .flatten()
    .flat_map(|(name, v)| {
        let scale = if name == "F_d" {
            floor
        } else {
            noise_colour(v).0
        };
        clips(name, v, scale)
    })
    .collect();
    let set_aside = (!clipped.is_empty()).then(|| {
        let c = &clipped[0];
        format!(
            "{} clipped: {} samples at {:.6e} in {} runs of {CLIP_RUN} or more (a clipped stick-slip peak cannot be measured; set the amplifier's range wider)",
            c.channel, c.samples, c.level, c.runs
        )
    });
    let vib_lines = vibration_aliases(r);
    let mains = MAINS
        .iter()
        .filter(|&&f| f < 0.4 / dt && vib_lines.iter().all(|&v| (v - f).abs() > 2.0 / duration(r)))
        .filter_map(|&f| line(&r.t, &r.f_d, f))
        .collect();
    let rho = lag1.clamp(-0.99, 0.99);
    let slope_ratio = |x: &Option<Vec<f64>>| x.as_ref().map(|x| slope(&r.t, x) / r.params.v_d);
    Acquisition {
        recording: r.name.clone(),
        rate_hz: 1.0 / dt,
        samples: r.t.len(),
        split: None,
        mains,
        vibration: vibration(r),
        quantisation: q,
        noise,
        lag1,
        correlation_time_s: if rho > 0.0 { -dt / rho.ln() } else { 0.0 },
        effective_share: (1.0 - rho.max(0.0)) / (1.0 + rho.max(0.0)),
        zero: zero(r),
        drive_slope_ratio: slope_ratio(&r.x_d),
        body_slope_ratio: slope_ratio(&r.x_s),
        clipped,
        set_aside,
        corrected: vec![],
    }
}

fn duration(r: &Recording) -> f64 {
    r.t[r.t.len() - 1] - r.t[0]
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

/// The median-absolute-deviation scale of `v`.
fn mad(v: &[f64]) -> f64 {
    let m = median(v.to_vec());
    1.4826 * median(v.iter().map(|x| (x - m).abs()).collect())
}

/// Samples per window of the noise's colour: a quadratic in time fitted to each leaves the
/// noise (a stick's ramp, a steady slide and a slow drift are quadratic over 32 samples).
pub const COLOUR_WINDOW: usize = 32;

/// The residual maker `I − X (XᵀX)⁻¹ Xᵀ` of a quadratic over [`COLOUR_WINDOW`] samples.
fn residual_maker() -> Vec<[f64; COLOUR_WINDOW]> {
    const W: usize = COLOUR_WINDOW;
    let u = |i: usize| (i as f64 - 0.5 * (W - 1) as f64) / W as f64;
    let x = |i: usize| [1.0, u(i), u(i) * u(i)];
    let mut xtx = [[0.0; 3]; 3];
    for i in 0..W {
        let g = x(i);
        for a in 0..3 {
            for b in 0..3 {
                xtx[a][b] += g[a] * g[b];
            }
        }
    }
    // Columns of (XᵀX)⁻¹ by solving against the unit vectors.
    let inv: Vec<[f64; 3]> = (0..3)
        .map(|k| {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            solve3(xtx, e).unwrap_or([0.0; 3])
        })
        .collect();
    (0..W)
        .map(|i| {
            let mut row = [0.0; W];
            for (j, r) in row.iter_mut().enumerate() {
                let (gi, gj) = (x(i), x(j));
                let mut h = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        h += gi[a] * inv[b][a] * gj[b];
                    }
                }
                *r = if i == j { 1.0 } else { 0.0 } - h;
            }
            row
        })
        .collect()
}

/// The expected variance and lag-one covariance, per sample, of the residuals `M e` of an AR(1)
/// noise `e` of unit variance and lag-one correlation `rho`.
fn expected_residual(m: &[[f64; COLOUR_WINDOW]], rho: f64) -> (f64, f64) {
    const W: usize = COLOUR_WINDOW;
    let sigma = |i: usize, j: usize| rho.powi((i as i64 - j as i64).unsigned_abs() as i32);
    // B = M Σ, then A = B Mᵀ (M is symmetric).
    let mut b = vec![[0.0; W]; W];
    for i in 0..W {
        for j in 0..W {
            b[i][j] = (0..W).map(|k| m[i][k] * sigma(k, j)).sum();
        }
    }
    let a = |i: usize, j: usize| (0..W).map(|k| b[i][k] * m[j][k]).sum::<f64>();
    let v0 = (0..W).map(|i| a(i, i)).sum::<f64>() / W as f64;
    let v1 = (0..W - 1).map(|i| a(i, i + 1)).sum::<f64>() / (W - 1) as f64;
    (v0, v1)
}

/// The noise scale of `x` and its lag-one correlation, as an AR(1) noise's: a quadratic is
/// fitted to each window of [`COLOUR_WINDOW`] samples, windows whose residual exceeds four times
/// the median (a slip, a sensor's ringing) are left out, and the pooled residuals' variance and
/// lag-one correlation are matched to those the same fits leave of an AR(1) noise
/// (`expected_residual`, monotone in `ρ`; `ρ` by bisection).
pub fn noise_colour(x: &[f64]) -> (f64, f64) {
    const W: usize = COLOUR_WINDOW;
    let m = residual_maker();
    let res: Vec<([f64; W], f64)> = x
        .chunks_exact(W)
        .map(|w| {
            let mut e = [0.0; W];
            for (i, ei) in e.iter_mut().enumerate() {
                *ei = (0..W).map(|k| m[i][k] * w[k]).sum();
            }
            let rss = e.iter().map(|v| v * v).sum();
            (e, rss)
        })
        .collect();
    if res.len() < 4 {
        return (f64::NAN, f64::NAN);
    }
    let med = median(res.iter().map(|r| r.1).collect());
    let (mut c0, mut c1, mut n) = (0.0, 0.0, 0usize);
    for (e, rss) in &res {
        if *rss <= 4.0 * med {
            c0 += rss;
            c1 += e.windows(2).map(|p| p[0] * p[1]).sum::<f64>();
            n += 1;
        }
    }
    if n == 0 || c0 <= 0.0 {
        return (0.0, f64::NAN);
    }
    let ratio = (c1 / (n * (W - 1)) as f64) / (c0 / (n * W) as f64);
    let r = |rho: f64| {
        let (v0, v1) = expected_residual(&m, rho);
        v1 / v0
    };
    let (mut lo, mut hi) = (-0.95, 0.995);
    let rho = if ratio <= r(lo) {
        lo
    } else if ratio >= r(hi) {
        hi
    } else {
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if r(mid) < ratio { lo = mid } else { hi = mid }
        }
        0.5 * (lo + hi)
    };
    let (v0, _) = expected_residual(&m, rho);
    ((c0 / (n * W) as f64 / v0).sqrt(), rho)
}

/// The least step between the distinct values of `x`, where every step between neighbouring
/// distinct values is a whole multiple of it (within 2 %) and it exceeds a millionth of the
/// range (the file's written digits are no quantisation).
pub fn quantisation(x: &[f64]) -> Option<f64> {
    let mut v = x.to_vec();
    v.sort_unstable_by(f64::total_cmp);
    v.dedup();
    if v.len() < 3 {
        return None;
    }
    let steps: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).collect();
    let q = steps.iter().copied().fold(f64::INFINITY, f64::min);
    let range = v[v.len() - 1] - v[0];
    if !(q > 1e-6 * range) {
        return None;
    }
    let on = steps
        .iter()
        .filter(|&&s| ((s / q) - (s / q).round()).abs() < 0.02)
        .count();
    (on == steps.len()).then_some(q)
}

/// The channel's clips at either extreme: runs of [`CLIP_RUN`] or more samples exactly at it,
/// with more samples there than in the band of width `scale` just inside it (a peak that is
/// merely reached dwells no longer on its top value than near it).
fn clips(name: &str, v: &[f64], scale: f64) -> Vec<Clip> {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut out = vec![];
    // A channel of fewer than three values is flat, not clipped: the plausibility checks name it.
    let mut few = v.iter().filter(|&&x| x != lo && x != hi);
    if few.next().is_none() {
        return out;
    }
    for (level, inside) in [(hi, -1.0), (lo, 1.0)] {
        let at = v.iter().filter(|&&x| x == level).count();
        let band = v
            .iter()
            .filter(|&&x| x != level && ((x - level) * inside) <= scale.max(0.0))
            .count();
        let mut runs = 0;
        let mut run = 0;
        for &x in v.iter().chain([f64::NAN].iter()) {
            if x == level {
                run += 1;
            } else {
                if run >= CLIP_RUN {
                    runs += 1;
                }
                run = 0;
            }
        }
        if runs > 0 && at >= 2 * CLIP_RUN && at > band {
            out.push(Clip {
                channel: name.into(),
                level,
                samples: at,
                runs,
            });
        }
    }
    out
}

/// The frequencies at which the vibration and its first three harmonics appear in the sampled
/// record (aliased into `[0, rate/2]`).
fn vibration_aliases(r: &Recording) -> Vec<f64> {
    if !r.vibrates() {
        return vec![];
    }
    let rate = 1.0 / r.dt();
    (1..=3)
        .map(|k| {
            let f = (k as f64 * r.params.f).rem_euclid(rate);
            f.min(rate - f)
        })
        .collect()
}

/// Unknowns of a window's fit: a quartic in time, the line's cosine and sine.
const WINDOW_UNKNOWNS: usize = 7;

/// Cosine and sine amplitudes of `y` at `f` over samples `t`, after a quartic in time is fitted
/// beside them (a stick's ramp and a slow oscillation leave little in the line), and the
/// residual sum of squares.
fn window_fit(t: &[f64], y: &[f64], f: f64) -> Option<([f64; 2], f64)> {
    const K: usize = WINDOW_UNKNOWNS;
    let n = t.len();
    let tm = 0.5 * (t[0] + t[n - 1]);
    let h = 0.5 * (t[n - 1] - t[0]);
    let basis = |ti: f64| {
        let u = (ti - tm) / h;
        let w = 2.0 * PI * f * ti;
        [1.0, u, u * u, u * u * u, u * u * u * u, w.cos(), w.sin()]
    };
    let mut a = [[0.0; K]; K];
    let mut b = [0.0; K];
    for (&ti, &yi) in t.iter().zip(y) {
        let g = basis(ti);
        for i in 0..K {
            b[i] += g[i] * yi;
            for j in 0..K {
                a[i][j] += g[i] * g[j];
            }
        }
    }
    let c = solve_small(a, b)?;
    let rss = t
        .iter()
        .zip(y)
        .map(|(&ti, &yi)| {
            let g = basis(ti);
            let fit: f64 = (0..K).map(|i| g[i] * c[i]).sum();
            (yi - fit).powi(2)
        })
        .sum();
    Some(([c[K - 2], c[K - 1]], rss))
}

/// Gaussian elimination with partial pivoting of a small dense system; `None` where singular.
fn solve_small<const K: usize>(mut a: [[f64; K]; K], mut b: [f64; K]) -> Option<[f64; K]> {
    let scale = (0..K).map(|i| a[i][i].abs()).fold(0.0, f64::max);
    for k in 0..K {
        let p = (k..K).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if !(a[p][k].abs() > 1e-13 * scale) {
            return None;
        }
        a.swap(k, p);
        b.swap(k, p);
        for i in k + 1..K {
            let m = a[i][k] / a[k][k];
            for j in k..K {
                a[i][j] -= m * a[k][j];
            }
            b[i] -= m * b[k];
        }
    }
    let mut x = [0.0; K];
    for k in (0..K).rev() {
        let s: f64 = (k + 1..K).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    Some(x)
}

/// The windows' phasors at `f` (cosine, sine; mid-time), windows of three periods, those whose
/// residual exceeds twice the median (a slip inside: a noise-only window's residual, of some 50
/// degrees of freedom, stays within 1.7 times its mean) left out.
fn phasors(t: &[f64], y: &[f64], f: f64) -> Vec<([f64; 2], f64)> {
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    let len = ((3.0 / (f * dt)).ceil() as usize).max(12);
    let fits: Vec<([f64; 2], f64, f64)> = t
        .chunks_exact(len)
        .zip(y.chunks_exact(len))
        .filter_map(|(tw, yw)| {
            window_fit(tw, yw, f).map(|(c, rss)| (c, rss, 0.5 * (tw[0] + tw[len - 1])))
        })
        .collect();
    let med = median(fits.iter().map(|x| x.1).collect());
    fits.into_iter()
        .filter(|x| x.1 <= 2.0 * med)
        .map(|(c, _, tm)| (c, tm))
        .collect()
}

/// A mains line near `nominal` in `y`, where one stands out (module docs).
fn line(t: &[f64], y: &[f64], nominal: f64) -> Option<Line> {
    let mut f = nominal;
    // Twice: the phase's progression over the windows moves the frequency to the line's.
    for _ in 0..2 {
        let p = phasors(t, y, f);
        if p.len() < 8 {
            return None;
        }
        let (mut num, mut den) = (0.0, 0.0);
        for w in p.windows(2) {
            let ([a0, b0], t0) = w[0];
            let ([a1, b1], t1) = w[1];
            // The phasor z = a − i b turns by 2π δ (t1 − t0) between windows.
            let (re, im) = (a1 * a0 + b1 * b0, -b1 * a0 + a1 * b0);
            let ang = im.atan2(re);
            let wgt = (re * re + im * im).sqrt();
            num += wgt * ang / (2.0 * PI * (t1 - t0));
            den += wgt;
        }
        let delta = if den > 0.0 { num / den } else { 0.0 };
        if delta.abs() > 0.5 {
            break;
        }
        f += delta;
    }
    let (amp, stderr, phase, coherence) = coherent(t, y, f)?;
    if !(amp > LINE_SIGMAS * stderr && coherence >= LINE_COHERENCE) {
        return None;
    }
    // The grid's frequency: off by more than the grid's tolerance and three of the estimate's
    // standard errors (the phase's, √12 (σ_A/A) / (2π T)), it is the rig's own oscillation.
    let dur = t[t.len() - 1] - t[0];
    let f_stderr = 12f64.sqrt() * (stderr / amp) / (2.0 * PI * dur);
    if (f - nominal).abs() > MAINS_TOLERANCE_HZ * nominal / 50.0 + 3.0 * f_stderr {
        return None;
    }
    // The largest coherent amplitude beside it: a periodic stick-slip's harmonics stand in a comb.
    let comb = (0..)
        .map(|j| (2.0 + j as f64) / dur)
        .take_while(|&d| d <= COMB_HZ)
        .flat_map(|d| [f - d, f + d])
        .filter_map(|g| coherent(t, y, g).map(|c| c.0 - 3.0 * c.1))
        .fold(0.0, f64::max);
    Some(Line {
        nominal_hz: nominal,
        hz: f,
        amplitude: amp,
        stderr,
        phase,
        coherence,
        comb_ratio: amp / comb.max(1e-12 * amp),
        subtracted: amp >= LONE_LINE * comb,
    })
}

/// How far the grid's fundamental strays from its nominal 50 or 60 Hz \[Hz\] (ENTSO-E's
/// normal band is ±0.05 Hz, its emergency limit ±0.2 Hz; North America's a few hundredths);
/// harmonics stray in proportion.
pub const MAINS_TOLERANCE_HZ: f64 = 0.1;

/// Half-width of the neighbourhood a line must stand alone in \[Hz\].
pub const COMB_HZ: f64 = 12.0;
/// A line is subtracted where it stands this many times above the largest coherent amplitude
/// within ±[`COMB_HZ`] of it (beyond `2/T`; each less three of its standard errors, so that
/// noise makes no comb); below, it may be a tooth of the stick-slip's own
/// harmonic comb, and is reported as ambiguous, not subtracted.
pub const LONE_LINE: f64 = 3.0;

/// The coherent amplitude of `y` at `f` over the windows without a slip (`phasors`): the
/// medians' amplitude, its standard error, phase and the windows' coherence.
fn coherent(t: &[f64], y: &[f64], f: f64) -> Option<(f64, f64, f64, f64)> {
    let p = phasors(t, y, f);
    if p.len() < 8 {
        return None;
    }
    let ca: Vec<f64> = p.iter().map(|x| x.0[0]).collect();
    let sb: Vec<f64> = p.iter().map(|x| x.0[1]).collect();
    let (a, b) = (median(ca.clone()), median(sb.clone()));
    let se = 1.2533 / (p.len() as f64).sqrt();
    let (sa, sbb) = (se * mad(&ca), se * mad(&sb));
    let amp = a.hypot(b);
    let stderr = ((a * sa).powi(2) + (b * sbb).powi(2)).sqrt() / amp.max(f64::MIN_POSITIVE);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let coherence = mean(&ca).hypot(mean(&sb))
        / mean(&p.iter().map(|x| x.0[0].hypot(x.0[1])).collect::<Vec<_>>());
    // a cos w + b sin w = amp cos(w + phase), phase = atan2(−b, a).
    Some((amp, stderr, (-b).atan2(a), coherence))
}

/// `|Σ y e^{−2πi f t}|·2/n`: the amplitude of `y` at `f`.
fn amplitude_at(t: &[f64], y: &[f64], f: f64) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for (&ti, &yi) in t.iter().zip(y) {
        let w = 2.0 * PI * f * ti;
        re += yi * w.cos();
        im -= yi * w.sin();
    }
    2.0 * re.hypot(im) / t.len() as f64
}

/// The vibration's frequency in `F_d` (module docs): the amplitude's peak over a grid of a
/// tenth of the resolution `1/T` within ±[`CLOCK_SEARCH_PPM`], refined by the phase's
/// progression over the recording (`phase_slope`); its standard error the larger of that
/// regression's and the bound the line's signal-to-noise ratio allows: Rife and Boorstyn's bound for a tone
/// in white noise, `√12 σ / (2π T A √n)`, with `σ/√n` the median amplitude off the line over
/// 1.665 (the median of the Rayleigh law of a noise's amplitude), so `√12 / (2π T · 1.665 ·
/// SNR)`; off the line the stick-slip's own harmonics add to the noise, which only widens it.
fn vibration(r: &Recording) -> Option<Vibration> {
    if !r.vibrates() {
        return None;
    }
    let f0 = r.params.f;
    let dur = duration(r);
    // The force less a quadratic trend, so the stick-slip's ramp does not leak.
    let trend = quadratic(&r.t, &r.f_d);
    let y: Vec<f64> = r.f_d.iter().zip(&trend).map(|(a, b)| a - b).collect();
    let step = 0.1 / dur;
    let half = (CLOCK_SEARCH_PPM * 1e-6 * f0 / step).ceil() as i64;
    let amps: Vec<(f64, f64)> = (-half..=half)
        .map(|k| {
            let f = f0 + k as f64 * step;
            (f, amplitude_at(&r.t, &y, f))
        })
        .collect();
    let &(fpk, apk) = amps.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    let off: Vec<f64> = amps
        .iter()
        .filter(|(f, _)| (f - fpk).abs() > 3.0 / dur)
        .map(|x| x.1)
        .collect();
    let bg = median(off);
    let snr = apk / bg;
    let stands = snr >= 4.0;
    let bound_hz = 12f64.sqrt() / (2.0 * PI * dur * 1.665 * snr);
    let (measured, spread_hz) = phase_slope(&r.t, &y, fpk).unwrap_or((fpk, f64::INFINITY));
    let stderr_hz = bound_hz.max(spread_hz);
    let offset_ppm = (measured - f0) / f0 * 1e6;
    let stderr_ppm = stderr_hz / f0 * 1e6;
    Some(Vibration {
        conditions_hz: f0,
        measured_hz: if stands { measured } else { f64::NAN },
        offset_ppm: if stands { offset_ppm } else { f64::NAN },
        stderr_ppm: if stands { stderr_ppm } else { f64::NAN },
        snr,
        used: stands && offset_ppm.abs() > CLOCK_SIGMAS * stderr_ppm,
    })
}

/// Windows of the vibration's phase regression.
const PHASE_WINDOWS: usize = 10;

/// The frequency of the tone near `f` in `y` from its phase's progression over
/// [`PHASE_WINDOWS`] windows (weighted by the windows' squared amplitudes), and the slope's
/// standard error from the phases' scatter about the line \[Hz\]: a stick-slip that modulates
/// the tone's phase widens it, as it should.
fn phase_slope(t: &[f64], y: &[f64], f: f64) -> Option<(f64, f64)> {
    let len = t.len() / PHASE_WINDOWS;
    if len < 16 {
        return None;
    }
    let mut pts: Vec<(f64, f64, f64)> = vec![];
    let mut last: Option<f64> = None;
    for (tw, yw) in t.chunks_exact(len).zip(y.chunks_exact(len)) {
        let (mut re, mut im) = (0.0, 0.0);
        for (&ti, &yi) in tw.iter().zip(yw) {
            let w = 2.0 * PI * f * ti;
            re += yi * w.cos();
            im -= yi * w.sin();
        }
        let mut ph = im.atan2(re);
        if let Some(p) = last {
            ph += (2.0 * PI) * ((p - ph) / (2.0 * PI)).round();
        }
        last = Some(ph);
        pts.push((0.5 * (tw[0] + tw[len - 1]), ph, re * re + im * im));
    }
    let sw: f64 = pts.iter().map(|p| p.2).sum();
    let tm = pts.iter().map(|p| p.2 * p.0).sum::<f64>() / sw;
    let pm = pts.iter().map(|p| p.2 * p.1).sum::<f64>() / sw;
    let sxx: f64 = pts.iter().map(|p| p.2 * (p.0 - tm).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| p.2 * (p.0 - tm) * (p.1 - pm)).sum();
    let slope = sxy / sxx;
    let rss: f64 = pts
        .iter()
        .map(|p| p.2 * (p.1 - pm - slope * (p.0 - tm)).powi(2))
        .sum();
    // Weights relative to their mean, so that the residual variance is per window.
    let s2 = rss / (pts.len() as f64 - 2.0) / (sw / pts.len() as f64);
    let se = (s2 / (sxx / (sw / pts.len() as f64))).sqrt();
    Some((f + slope / (2.0 * PI), se / (2.0 * PI)))
}

/// The least-squares quadratic in time through `y`, at each sample.
fn quadratic(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = t.len();
    let tm = 0.5 * (t[0] + t[n - 1]);
    let h = 0.5 * (t[n - 1] - t[0]);
    let mut a = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    for (&ti, &yi) in t.iter().zip(y) {
        let u = (ti - tm) / h;
        let g = [1.0, u, u * u];
        for i in 0..3 {
            b[i] += g[i] * yi;
            for j in 0..3 {
                a[i][j] += g[i] * g[j];
            }
        }
    }
    let c = solve3(a, b).unwrap_or([0.0; 3]);
    t.iter()
        .map(|&ti| {
            let u = (ti - tm) / h;
            c[0] + c[1] * u + c[2] * u * u
        })
        .collect()
}

/// Cramer's rule for a 3 × 3 system.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d.abs() < 1e-300 {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        *xk = det(m) / d;
    }
    Some(x)
}

/// Half-width of the moving mean through which [`quasi_static`] judges the force's rate \[s\].
const SMOOTH_S: f64 = 2.5e-3;

/// The samples at which the force changes no faster than three times the drive spring's loading
/// rate `k_d v_d` (over a moving mean of ±[`SMOOTH_S`]): a stick's ramp and a steady slide, where
/// the spring's law holds whatever a slow sensor or the slips' dynamics do.
fn quasi_static(r: &Recording) -> Vec<bool> {
    let n = r.t.len();
    let h = ((SMOOTH_S / r.dt()).round() as usize).max(1);
    let mut cum = vec![0.0; n + 1];
    for i in 0..n {
        cum[i + 1] = cum[i] + r.f_d[i];
    }
    let mean = |i: usize| {
        let (a, b) = (i.saturating_sub(h), (i + h + 1).min(n));
        (cum[b] - cum[a]) / (b - a) as f64
    };
    let limit = 3.0 * r.params.k_d * r.params.v_d;
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(h), (i + h).min(n - 1));
            b > a && ((mean(b) - mean(a)) / (r.t[b] - r.t[a])).abs() <= limit
        })
        .collect()
}

/// `F_d` regressed on `x_d − x_s`, 1 and `t − t̄` over the quasi-static samples (module docs);
/// `None` where under a fifth of the samples are.
fn zero(r: &Recording) -> Option<Zero> {
    let (x_s, x_d) = (r.x_s.as_ref()?, r.x_d.as_ref()?);
    let keep = quasi_static(r);
    let idx: Vec<usize> = (0..r.t.len()).filter(|&i| keep[i]).collect();
    if idx.len() * 5 < r.t.len() || idx.len() < 16 {
        return None;
    }
    let n = idx.len();
    let tm = idx.iter().map(|&i| r.t[i]).sum::<f64>() / n as f64;
    let mut a = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    let row = |i: usize| [x_d[i] - x_s[i], 1.0, r.t[i] - tm];
    for &i in &idx {
        let g = row(i);
        for j in 0..3 {
            b[j] += g[j] * r.f_d[i];
            for k in 0..3 {
                a[j][k] += g[j] * g[k];
            }
        }
    }
    let c = solve3(a, b)?;
    let res: Vec<f64> = idx
        .iter()
        .map(|&i| {
            let g = row(i);
            r.f_d[i] - (c[0] * g[0] + c[1] * g[1] + c[2] * g[2])
        })
        .collect();
    let rss: f64 = res.iter().map(|e| e * e).sum();
    let mf = idx.iter().map(|&i| r.f_d[i]).sum::<f64>() / n as f64;
    let tss: f64 = idx.iter().map(|&i| (r.f_d[i] - mf).powi(2)).sum();
    // The residuals' own lag-one correlation widens the drift's error.
    let c1: f64 = res.windows(2).map(|w| w[0] * w[1]).sum();
    let rho = (c1 / rss).clamp(0.0, 0.99);
    let inflate = ((1.0 + rho) / (1.0 - rho)).sqrt();
    // The drift's variance: σ² (AᵀA)⁻¹₂₂ by the cofactor.
    let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    let inv22 = (a[0][0] * a[1][1] - a[0][1] * a[1][0]) / det;
    let sigma2 = rss / (n as f64 - 3.0);
    let dur = duration(r);
    Some(Zero {
        offset: c[1],
        drift: c[2] * dur,
        drift_stderr: (sigma2 * inv22).sqrt() * dur * inflate,
        stiffness_ratio: c[0] / r.params.k_d,
        r2: 1.0 - rss / tss,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Params;
    use rand::{RngExt, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// A stick-slip-like saw-tooth (period 0.5 s, 3 N) on 8 N with white noise of 0.02 N,
    /// sampled at `rate` for 4 s, the drive at v_d and the spring's law holding.
    fn rec(rate: f64, seed: u64) -> Recording {
        let p = Params {
            v_d: 1e-3,
            k_d: 1e4,
            ..Params::default()
        };
        let n = (4.0 * rate) as usize;
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let g = Normal::new(0.0, 0.02).unwrap();
        let t: Vec<f64> = (0..n).map(|i| i as f64 / rate).collect();
        let f_d: Vec<f64> = t
            .iter()
            .map(|&x| 8.0 + 3.0 * (x * 2.0).fract() + g.sample(&mut rng))
            .collect();
        let x_d: Vec<f64> = t.iter().map(|&x| p.v_d * x).collect();
        let x_s = x_d
            .iter()
            .zip(&f_d)
            .map(|(d, f)| d - f / p.k_d + 1e-9 * rng.random::<f64>())
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

    #[test]
    fn a_clean_recording_shows_nothing() {
        for seed in 0..5 {
            let a = examine(&rec(5000.0, seed));
            assert!(a.mains.is_empty(), "{:?}", a.mains);
            assert!(a.clipped.is_empty() && a.set_aside.is_none(), "{a:?}");
            assert_eq!(a.quantisation, None);
            assert!((a.noise - 0.02).abs() < 0.002, "{}", a.noise);
            assert!(a.lag1.abs() < 0.05, "{}", a.lag1);
            let z = a.zero.unwrap();
            assert!((z.stiffness_ratio - 1.0).abs() < 1e-3, "{z:?}");
            assert!(z.drift.abs() < 4.0 * z.drift_stderr + 1e-9, "{z:?}");
        }
    }

    #[test]
    fn mains_is_found_with_its_size_and_subtracted() {
        let mut r = rec(5000.0, 1);
        let (amp, hz, ph) = (0.05, 50.03, 0.7);
        for (f, &t) in r.f_d.iter_mut().zip(&r.t) {
            *f += amp * (2.0 * PI * hz * t + ph).cos();
        }
        let a = examine(&r);
        assert_eq!(a.mains.len(), 1, "{:?}", a.mains);
        let l = &a.mains[0];
        assert_eq!(l.nominal_hz, 50.0);
        assert!((l.amplitude - amp).abs() < 3.0 * l.stderr, "{l:?}");
        assert!((l.hz - hz).abs() < 0.01, "{l:?}");
        let c = prepare(Campaign {
            dir: "mem".into(),
            recordings: vec![r],
            planned: vec![],
            acquisition: Acquired::default(),
        })
        .unwrap();
        // What is left is the estimate's error: a tenth of the line at most.
        let left = examine(&c.recordings[0]).mains;
        assert!(left.iter().all(|l| l.amplitude < 0.1 * amp), "{left:?}");
        assert_eq!(c.acquisition.recordings[0].corrected.len(), 1);
    }

    #[test]
    fn ringing_after_each_slip_is_no_mains_line() {
        // A 60 Hz sensor's ringing, set off by each slip with its own phase.
        let mut r = rec(5000.0, 2);
        for (f, &t) in r.f_d.iter_mut().zip(&r.t) {
            let since = (t * 2.0).fract() / 2.0;
            *f += 0.5 * (-since * 20.0).exp() * (2.0 * PI * 60.0 * since).sin();
        }
        let a = examine(&r);
        assert!(a.mains.is_empty(), "{:?}", a.mains);
    }

    #[test]
    fn quantisation_colour_and_clipping_are_named() {
        let mut r = rec(5000.0, 3);
        let q = 200.0 / 4096.0;
        let mut quant = r.clone();
        quant.f_d.iter_mut().for_each(|f| *f = (*f / q).round() * q);
        let a = examine(&quant);
        assert!(
            (a.quantisation.unwrap() - q).abs() < 1e-9 * q,
            "{:?}",
            a.quantisation
        );
        assert!(a.set_aside.is_none(), "{a:?}");
        // AR(1) noise of correlation 0.8 in place of the white.
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let g = Normal::new(0.0, 0.02 * (1.0f64 - 0.64).sqrt()).unwrap();
        let mut e = 0.0;
        let mut red = r.clone();
        for (f, &t) in red.f_d.iter_mut().zip(&r.t) {
            e = 0.8 * e + g.sample(&mut rng);
            *f = 8.0 + 3.0 * (t * 2.0).fract() + e;
        }
        let a = examine(&red);
        assert!((a.lag1 - 0.8).abs() < 0.05, "{}", a.lag1);
        assert!((a.noise - 0.02).abs() < 0.003, "{}", a.noise);
        let tau = -1.0 / (5000.0 * 0.8f64.ln());
        assert!((a.correlation_time_s / tau - 1.0).abs() < 0.25, "{a:?}");
        // Peaks cut flat at 10.5 N.
        r.f_d.iter_mut().for_each(|f| *f = f.min(10.5));
        let a = examine(&r);
        assert_eq!(a.clipped.len(), 1, "{a:?}");
        assert!(a.set_aside.as_deref().unwrap().contains("F_d clipped"));
    }

    #[test]
    fn a_clock_offset_is_measured() {
        let mut r = rec(5000.0, 4);
        r.params.f = 1000.0;
        r.params.set_v_a(0.5 * r.params.v_d);
        let true_hz = 1000.0 * (1.0 + 60e-6);
        for (f, &t) in r.f_d.iter_mut().zip(&r.t) {
            *f += 0.05 * (2.0 * PI * true_hz * t).sin();
        }
        let v = examine(&r).vibration.unwrap();
        assert!(v.snr > 10.0, "{v:?}");
        assert!((v.offset_ppm - 60.0).abs() < 3.0 * v.stderr_ppm, "{v:?}");
        assert!(v.used, "{v:?}");
    }
}
