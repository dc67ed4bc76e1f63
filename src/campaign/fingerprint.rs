//! Fingerprints: what a candidate effect predicts beyond the features it was fitted to, checked
//! against the recordings themselves.
//!
//! Every model is fitted to the features of [`super::features`]; a candidate can lower their gap
//! by standing in for another physics (a slow force sensor smoothing what is really a friction
//! that varies along the track). Its fingerprints are statistics of the whole trace that no
//! feature holds: the candidate, fitted without them, predicts how they depart from the model it
//! extends, and the recordings show whether they do.
//!
//! **Family `ringing`: the spectrum after slips.** Per slip, the raw force in a window from the
//! re-stick on, and in one of the same length ending an eighth of a window before the breakaway
//! (late in the stick), each detrended by least squares (a line in time and, where the
//! substrate vibrates, the harmonics at `f` and `2f`) and split by the Haar transform into octave
//! bands of the sampling rate (band `j` from `fs/2^(j+1)` to `fs/2^j`). A statistic is one band of
//! one stage: the mean over slips of the band's energy (mean squared detail coefficient) after the
//! slip less its energy before, with the spread over slips / √n as its standard error. Sensor
//! noise and the forcing are stationary and cancel; what a slip excites remains: a sensor's or a
//! frame's ringing, the smoothing of the drop by a slow sensor, the contact's re-stick
//! oscillation. The window is the largest power of two of samples within 0.4 of the median
//! stick (at most 1024); a stage needs three slips with both windows inside their sticks.
//!
//! **The check.** Per statistic `d_obs = S_meas − S_from` and `d_pred = S_cand − S_from`, both in
//! units of `σ`, the three traces' standard errors in quadrature. The share of the predicted
//! fingerprint the data carry is the regression coefficient `β = Σ d_obs d_pred / Σ d_pred²`; its
//! standard error is `s / √(Σ d_pred²)`, with `s` the RMS of `d_obs − β d_pred` (at least 1, the
//! noise): a model that misses these statistics in ways unrelated to the candidate widens it
//! instead of deciding. The prediction's strength is `P = √(Σ d_pred²)`. The family is
//! `not_testable` where `P <` [`MIN_STRENGTH`] (the candidate predicts nothing the recordings
//! could show), `absent` where `β + 2 SE <` [`PRESENT_SHARE`] (less than that share of the
//! predicted departure is there, at two standard errors), `present` where `β − 2 SE >`
//! [`PRESENT_SHARE`], else `inconclusive`. A candidate with an absent fingerprint is not named
//! (`diagnose`). The same rule (`judge`) judges `diagnose`'s held-out feature families
//! (`held_out_families`), whose pairs are feature residuals instead of trace statistics.

use super::features::{smooth, zigzag};
use super::fit::{Model, simulate};
use super::{Recording, Solvers};
use rayon::prelude::*;

/// Strength (in standard errors, summed in quadrature over statistics) below which a family
/// cannot test a candidate.
pub const MIN_STRENGTH: f64 = 3.0;

/// Share of the predicted departure that separates a fingerprint present from one absent.
pub const PRESENT_SHARE: f64 = 0.25;

/// Longest window \[samples\] of the ringing family.
pub const MAX_WINDOW: usize = 1024;

/// Fewest samples in a window of the ringing family (three Haar bands of four coefficients).
pub const MIN_WINDOW: usize = 32;

/// What a family showed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Seen {
    /// The data carry the predicted departure.
    Present,
    /// The data carry less than [`PRESENT_SHARE`] of it, at two standard errors.
    Absent,
    /// Neither.
    Inconclusive,
    /// The candidate predicts no departure the recordings could show.
    NotTestable,
}

impl Seen {
    /// Name in reports, as the JSON spells it.
    pub fn name(self) -> &'static str {
        match self {
            Seen::Present => "present",
            Seen::Absent => "absent",
            Seen::Inconclusive => "inconclusive",
            Seen::NotTestable => "not_testable",
        }
    }
}

/// One family's check of one candidate.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Check {
    /// Family name.
    pub family: &'static str,
    /// What it looks at.
    pub what: &'static str,
    /// Statistics compared (those defined in the recording and both simulations).
    pub statistics: usize,
    /// Strength of the prediction `P` (standard errors).
    pub strength: f64,
    /// Share `β` of the predicted departure the data carry.
    pub share: f64,
    /// Its standard error.
    pub share_se: f64,
    /// The outcome.
    pub seen: Seen,
}

impl Check {
    /// Whether the family looks at the recorded traces themselves (the ringing), rather than
    /// at held-out features (`held_out_*`, see `diagnose`).
    pub fn of_trace(&self) -> bool {
        !self.family.starts_with("held_out")
    }

    /// One line for the summary.
    pub fn line(&self) -> String {
        match self.seen {
            Seen::NotTestable => format!(
                "{} ({}): not testable, the candidate predicts a departure of {:.1} standard errors over {} statistics",
                self.family, self.what, self.strength, self.statistics
            ),
            _ => format!(
                "{} ({}): {}, the data carry {:.2} ± {:.2} of the predicted departure ({:.1} standard errors over {} statistics)",
                self.family,
                self.what,
                self.seen.name(),
                self.share,
                self.share_se,
                self.strength,
                self.statistics
            ),
        }
    }
}

/// One statistic of a trace.
#[derive(Clone, Copy, Debug)]
struct Stat {
    /// (stage, band).
    key: (usize, usize),
    value: f64,
    se: f64,
}

/// The ringing statistics of a force trace sampled like `rec` (see the module docs).
fn ringing(rec: &Recording, f_d: &[f64]) -> Vec<Stat> {
    let dt = rec.dt();
    let mut out = vec![];
    for (si, st) in super::features::stages(&rec.t, &rec.params)
        .into_iter()
        .enumerate()
    {
        let f = &f_d[st.lo..st.hi];
        let n = f.len();
        let i0 = n / 2;
        let w = if st.freq > 0.0 { 1.0 / st.freq } else { 1e-3 };
        let sm = smooth(f, dt, w);
        let (lo, hi) = sm[i0..]
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
        // Slips are the large drops: a ringing sensor's swings after them are not.
        let ext = zigzag(&sm, i0, (0.3 * (hi - lo)).max(0.1));
        // The trailing average delays the smoothed extremes by half its width.
        let lag = ((0.5 * w / dt).round() as usize).min(n);
        let raw = |i: usize| i.saturating_sub(lag);
        // Slips with the trough before (the stick it ends) and the stick after.
        let slips: Vec<(usize, usize, usize, usize)> = (1..ext.len().saturating_sub(1))
            .filter(|&k| ext[k].1)
            .map(|k| {
                let next = ext.get(k + 2).map_or(n, |e| raw(e.0));
                (raw(ext[k - 1].0), raw(ext[k].0), raw(ext[k + 1].0), next)
            })
            .collect();
        if slips.len() < 3 {
            continue;
        }
        let mut sticks: Vec<usize> = slips.iter().map(|s| s.1 - s.0).collect();
        sticks.sort_unstable();
        let want = (0.4 * sticks[sticks.len() / 2] as f64) as usize;
        if want < MIN_WINDOW {
            continue;
        }
        let nw = 1usize << (usize::BITS - 1 - want.min(MAX_WINDOW).leading_zeros());
        let margin = nw / 8;
        let levels = nw.trailing_zeros() as usize - 2;
        let mut diffs: Vec<Vec<f64>> = vec![vec![]; levels];
        let mut post_e = vec![0.0; levels];
        let mut pre_e = vec![0.0; levels];
        for &(t0, pk, tr, next) in &slips {
            let Some(pre_start) = pk.checked_sub(margin + nw) else {
                continue;
            };
            if pre_start < t0 || tr + nw > next {
                continue;
            }
            band_energies(&f[pre_start..pre_start + nw], dt, st.freq, &mut pre_e);
            band_energies(&f[tr..tr + nw], dt, st.freq, &mut post_e);
            for j in 0..levels {
                diffs[j].push(post_e[j] - pre_e[j]);
            }
        }
        for (j, d) in diffs.iter().enumerate() {
            if d.len() < 3 {
                continue;
            }
            let m = d.iter().sum::<f64>() / d.len() as f64;
            let var = d.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (d.len() - 1) as f64;
            out.push(Stat {
                key: (si, j),
                value: m,
                se: (var / d.len() as f64).sqrt(),
            });
        }
    }
    out
}

/// Energy per Haar band of `y` (a power-of-two length) after removing its least-squares trend
/// (a line in time; the harmonics at `freq` and `2 freq` where `freq > 0`): band `j`
/// (finest first) holds the mean squared detail coefficient of level `j + 1`.
fn band_energies(y: &[f64], dt: f64, freq: f64, out: &mut [f64]) {
    use faer::Mat;
    use faer::linalg::solvers::SolveLstsq;
    let n = y.len();
    let cols = if freq > 0.0 { 6 } else { 2 };
    let omega = std::f64::consts::TAU * freq;
    let half = 0.5 * n as f64;
    let a = Mat::from_fn(n, cols, |i, j| {
        let tau = (i as f64 - half) / half;
        let ph = omega * i as f64 * dt;
        match j {
            0 => 1.0,
            1 => tau,
            2 => ph.sin(),
            3 => ph.cos(),
            4 => (2.0 * ph).sin(),
            _ => (2.0 * ph).cos(),
        }
    });
    let b = Mat::from_fn(n, 1, |i, _| y[i]);
    let x = a.col_piv_qr().solve_lstsq(&b);
    let mut r: Vec<f64> = (0..n)
        .map(|i| y[i] - (0..cols).map(|j| a[(i, j)] * x[(j, 0)]).sum::<f64>())
        .collect();
    let mut len = n;
    for e in out.iter_mut() {
        let h = len / 2;
        let mut s = 0.0;
        for i in 0..h {
            let (p, q) = (r[2 * i], r[2 * i + 1]);
            s += 0.5 * (p - q) * (p - q);
            r[i] = std::f64::consts::FRAC_1_SQRT_2 * (p + q);
        }
        *e = s / h as f64;
        len = h;
    }
}

/// The outcome of one family from the standardised departures `(d_obs, d_pred)`.
pub(super) fn judge(family: &'static str, what: &'static str, pairs: &[(f64, f64)]) -> Check {
    let spp: f64 = pairs.iter().map(|p| p.1 * p.1).sum();
    let strength = spp.sqrt();
    let mut c = Check {
        family,
        what,
        statistics: pairs.len(),
        strength,
        share: f64::NAN,
        share_se: f64::NAN,
        seen: Seen::NotTestable,
    };
    if !(strength >= MIN_STRENGTH) {
        return c;
    }
    let beta = pairs.iter().map(|p| p.0 * p.1).sum::<f64>() / spp;
    let dof = pairs.len().saturating_sub(1).max(1) as f64;
    let s = (pairs
        .iter()
        .map(|p| (p.0 - beta * p.1).powi(2))
        .sum::<f64>()
        / dof)
        .sqrt()
        .max(1.0);
    let se = s / strength;
    c.share = beta;
    c.share_se = se;
    c.seen = if beta + 2.0 * se < PRESENT_SHARE {
        Seen::Absent
    } else if beta - 2.0 * se > PRESENT_SHARE {
        Seen::Present
    } else {
        Seen::Inconclusive
    };
    c
}

/// What every candidate extending one model is checked against: per recording, the measured
/// statistics and those of the model `from` the candidates extend (`None` where its run fails),
/// made once for all the candidates checked against it.
pub struct Reference {
    per: Vec<Option<(Vec<Stat>, Vec<Stat>)>>,
}

impl Reference {
    /// The statistics of the recordings `recs` and of `from` simulated for each (in parallel
    /// over recordings; deterministic).
    pub fn of(recs: &[&Recording], from: &Model) -> Reference {
        let per = recs
            .par_iter()
            .map_init(Solvers::default, |s, rec| {
                let fb = simulate(from, rec, s)?;
                Some((ringing(rec, &rec.f_d), ringing(rec, &fb.f_d)))
            })
            .collect();
        Reference { per }
    }

    /// Checks the fingerprints of `cand` (a fit of a candidate effect extending the reference's
    /// model) on the same recordings `recs`.
    pub fn check(&self, recs: &[&Recording], cand: &Model) -> Vec<Check> {
        let per: Vec<Vec<(f64, f64)>> = recs
            .par_iter()
            .zip(&self.per)
            .map_init(Solvers::default, |s, (rec, reference)| {
                let (Some((m, b)), Some(fc)) = (reference, simulate(cand, rec, s)) else {
                    return vec![];
                };
                let c = ringing(rec, &fc.f_d);
                let find = |v: &[Stat], k| v.iter().find(|s| s.key == k).copied();
                m.iter()
                    .filter_map(|sm| {
                        let (sb, sc) = (find(b, sm.key)?, find(&c, sm.key)?);
                        let sigma = (sm.se.powi(2) + sb.se.powi(2) + sc.se.powi(2)).sqrt();
                        (sigma > 0.0 && sigma.is_finite())
                            .then(|| ((sm.value - sb.value) / sigma, (sc.value - sb.value) / sigma))
                    })
                    .collect()
            })
            .collect();
        let pairs: Vec<(f64, f64)> = per.into_iter().flatten().collect();
        vec![judge(
            "ringing",
            "the force's spectrum after slips against before them",
            &pairs,
        )]
    }
}

/// Checks the fingerprints of `cand` (a fit of a candidate effect) against the model `from` it
/// extends, on the recordings `recs` ([`Reference::of`], then [`Reference::check`]).
pub fn check(recs: &[&Recording], from: &Model, cand: &Model) -> Vec<Check> {
    Reference::of(recs, from).check(recs, cand)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Haar bands of white noise hold its variance in every band; a line holds none.
    #[test]
    fn haar_bands_of_noise_and_trend() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let nd = Normal::new(0.0, 0.5).unwrap();
        let n = 1024;
        let mut e = vec![0.0; 6];
        let mut acc = [0.0; 6];
        for _ in 0..50 {
            let y: Vec<f64> = (0..n)
                .map(|i| 3.0 + 0.01 * i as f64 + nd.sample(&mut rng))
                .collect();
            band_energies(&y, 1e-4, 0.0, &mut e);
            for j in 0..6 {
                acc[j] += e[j] / 50.0;
            }
        }
        for (j, a) in acc.iter().enumerate() {
            assert!((a / 0.25 - 1.0).abs() < 0.1, "band {j}: {a}");
        }
        let y: Vec<f64> = (0..n).map(|i| 1.0 + 2e-3 * i as f64).collect();
        band_energies(&y, 1e-4, 0.0, &mut e);
        assert!(e.iter().all(|v| *v < 1e-18), "{e:?}");
        // A sinusoid at f is the trend's, at any phase.
        let y: Vec<f64> = (0..n)
            .map(|i| (std::f64::consts::TAU * 700.0 * i as f64 * 1e-4 + 0.3).sin())
            .collect();
        band_energies(&y, 1e-4, 700.0, &mut e);
        assert!(e.iter().all(|v| *v < 1e-18), "{e:?}");
    }

    /// The rule: a prediction the data carry is present, one they do not is absent, one too
    /// weak to see is not testable.
    #[test]
    fn judge_reads_the_share() {
        let pred: Vec<f64> = (0..20).map(|i| 3.0 * ((i as f64) * 0.7).sin()).collect();
        let carried: Vec<(f64, f64)> = pred
            .iter()
            .enumerate()
            .map(|(i, p)| (0.9 * p + 0.5 * ((i * 7 % 5) as f64 - 2.0) / 2.0, *p))
            .collect();
        assert_eq!(judge("x", "x", &carried).seen, Seen::Present);
        let missing: Vec<(f64, f64)> = pred
            .iter()
            .enumerate()
            .map(|(i, p)| (0.5 * ((i * 7 % 5) as f64 - 2.0) / 2.0, *p))
            .collect();
        assert_eq!(judge("x", "x", &missing).seen, Seen::Absent);
        let weak: Vec<(f64, f64)> = pred.iter().map(|p| (0.0, 0.1 * p)).collect();
        assert_eq!(judge("x", "x", &weak).seen, Seen::NotTestable);
    }
}
