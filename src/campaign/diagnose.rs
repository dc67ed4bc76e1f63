//! The sim-to-real diagnosis: calibrate the base model on part of a campaign, locate the gap
//! (features, phases, conditions), attribute it to the effect whose fit shrinks the gap most on
//! held-out recordings, decide, and quantify.
//!
//! **Split.** Recordings are grouped by drive (`v_d`, `k_d`, load); with the groups sorted from
//! the longest stick-slip cycle (smallest `k_d v_d`) to the shortest, every third one from the
//! second on is held out (one recording in three when there is a single drive). The
//! calibration keeps the longest and the shortest cycles, so it sees the whole range of stick
//! times, and the held-out drives are conditions no fit has seen. Each group holds runs with and without vibration, so an effect is
//! active in held-out data at drive conditions the fits never saw.
//!
//! **Gap.** `E = √(mean z²)` over the standardised feature differences ([`super::fit`]); 1 means
//! "within noise and floors".
//!
//! **Decision.** With `E0`, `E1` the held-out gaps of the calibrated base model and of the best
//! candidate (ranked by `E1 (1 + 0.05 k)` with `k` the effect's fitted parameters):
//! - `no_significant_gap` when `E0 <` [`SIGNIFICANT_GAP`];
//! - `effect` when the best candidate cuts the gap by at least [`MIN_REDUCTION`], lowers the gap
//!   of at least [`MIN_BREADTH`] of the held-out recordings, and its score is at most
//!   [`CLEAR_MARGIN`] times the runner-up's;
//! - `unexplained` otherwise.

use super::Campaign;
use super::features::{FEATURES, Feature, PHASES};
use super::fit::{self, FitOptions, FitResult, Model, Target};
use crate::model::EffectKind;

/// Held-out gap below which the base model counts as matching the data.
pub const SIGNIFICANT_GAP: f64 = 2.0;
/// Smallest held-out reduction `(E0 − E1)/E0` for naming an effect.
pub const MIN_REDUCTION: f64 = 0.5;
/// The best candidate's score must be at most this share of the runner-up's.
pub const CLEAR_MARGIN: f64 = 0.8;
/// Share of held-out recordings whose own gap the named effect must lower: an effect explains a
/// gap across the conditions, not one recording (such as a run on the edge of elimination,
/// stick-slip on in the data and off in the model, whose gap any flexible candidate can trade).
pub const MIN_BREADTH: f64 = 0.6;
/// Penalty per fitted effect parameter in the ranking score.
pub const PARAM_PENALTY: f64 = 0.05;

/// Options of a diagnosis.
#[derive(Clone, Debug)]
pub struct DiagnoseOptions {
    /// Candidate effects. Default: every candidate of the library.
    pub candidates: Vec<EffectKind>,
    /// Fit options.
    pub fit: FitOptions,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            candidates: EffectKind::candidates(),
            fit: FitOptions::default(),
        }
    }
}

/// One candidate's result.
#[derive(Clone, Debug)]
pub struct Ranked {
    /// The effect.
    pub effect: EffectKind,
    /// Its fit on the calibration split.
    pub fit: FitResult,
    /// Gap on the held-out split.
    pub gap_after: f64,
    /// `(E0 − E1) / E0` on the held-out split.
    pub reduction: f64,
    /// Ranking score `E1 (1 + 0.05 k)`.
    pub score: f64,
}

/// Where the gap lies, from the calibrated base model over all recordings.
#[derive(Clone, Debug)]
pub struct Where {
    /// Per feature: RMS z and share of the summed z².
    pub features: Vec<(Feature, f64, f64)>,
    /// Per phase: RMS z and share of the summed z².
    pub phases: Vec<(&'static str, f64, f64)>,
    /// Per condition: Spearman correlation of the per-recording gap with it.
    pub conditions: Vec<(&'static str, f64)>,
    /// Per recording: name, gap, conditions (v_d, k_d, f, v_a/v_d, stick time, k_t u0/F_c),
    /// held out or not.
    pub recordings: Vec<RecordingGap>,
    /// The gap on recordings with vibration and without.
    pub with_vibration: (f64, f64),
    /// A sentence or two.
    pub summary: String,
}

/// The gap of one recording.
#[derive(Clone, Debug)]
pub struct RecordingGap {
    /// File stem.
    pub name: String,
    /// Gap under the calibrated base model.
    pub gap_base: f64,
    /// Gap under the top-ranked candidate (NaN when none was tried).
    pub gap_best: f64,
    /// Held out from the fits.
    pub held_out: bool,
    /// `[v_d, k_d, f, v_a/v_d, stick time, k_t u0/F_c]`.
    pub conditions: [f64; 6],
    /// z per feature under the base model (NaN where undefined).
    pub z_base: [f64; 11],
}

/// Names of [`RecordingGap::conditions`].
pub const CONDITIONS: [&str; 6] = ["v_d", "k_d", "f", "va_ratio", "stick_time", "kt_u0_over_Fc"];

/// Verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// A candidate explains the gap.
    Effect,
    /// The base model matches within noise.
    NoSignificantGap,
    /// No candidate explains the gap.
    Unexplained,
}

impl Verdict {
    /// Name in the JSON report.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Effect => "effect",
            Verdict::NoSignificantGap => "no_significant_gap",
            Verdict::Unexplained => "unexplained",
        }
    }
}

/// The full diagnosis.
#[derive(Clone, Debug)]
pub struct Diagnosis {
    /// Verdict.
    pub verdict: Verdict,
    /// The named effect (with verdict `effect`).
    pub best_effect: Option<EffectKind>,
    /// Held-out gap of the calibrated base model.
    pub gap_before: f64,
    /// Held-out gap of the best candidate (of the base model when none is named).
    pub gap_after: f64,
    /// `(E0 − E1) / E0`.
    pub reduction: f64,
    /// Share of held-out recordings whose gap the top candidate lowers.
    pub breadth: f64,
    /// The base calibration on the calibration split.
    pub base: FitResult,
    /// Candidates, best first.
    pub ranking: Vec<Ranked>,
    /// Where the gap lies.
    pub location: Where,
    /// Names of the held-out recordings.
    pub held_out: Vec<String>,
    /// Wall time \[s\].
    pub wall_time: f64,
}

/// Which recordings are held out (see the module docs).
pub fn split(c: &Campaign) -> Vec<bool> {
    let key = |p: &crate::model::Params| (p.v_d.to_bits(), p.k_d.to_bits(), p.f_n.to_bits());
    let mut groups: Vec<crate::model::Params> = vec![];
    for r in &c.recordings {
        if !groups.iter().any(|g| key(g) == key(&r.params)) {
            groups.push(r.params);
        }
    }
    // Longest stick-slip cycle first (k_d v_d smallest), so the extremes are held out.
    groups.sort_by(|a, b| {
        (a.k_d * a.v_d)
            .total_cmp(&(b.k_d * b.v_d))
            .then(a.f_n.total_cmp(&b.f_n))
    });
    let n = c.recordings.len();
    if groups.len() < 3 {
        return (0..n).map(|i| i % 3 == 1).collect();
    }
    c.recordings
        .iter()
        .map(|r| {
            let g = groups
                .iter()
                .position(|g| key(g) == key(&r.params))
                .unwrap();
            g % 3 == 1
        })
        .collect()
}

fn ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && x[idx[j + 1]] == x[idx[i]] {
            j += 1;
        }
        for k in i..=j {
            r[idx[k]] = 0.5 * (i + j) as f64;
        }
        i = j + 1;
    }
    r
}

/// Spearman's rank correlation (0 when either side is constant).
pub fn spearman(x: &[f64], y: &[f64]) -> f64 {
    let (rx, ry) = (ranks(x), ranks(y));
    let n = x.len() as f64;
    let (mx, my) = (rx.iter().sum::<f64>() / n, ry.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in rx.iter().zip(&ry) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    if sxx == 0.0 || syy == 0.0 {
        0.0
    } else {
        sxy / (sxx * syy).sqrt()
    }
}

/// Diagnoses a campaign.
pub fn diagnose(c: &Campaign, opts: &DiagnoseOptions) -> Diagnosis {
    let start = std::time::Instant::now();
    let held = split(c);
    let cal_recs: Vec<_> = c
        .recordings
        .iter()
        .zip(&held)
        .filter(|(_, h)| !**h)
        .map(|(r, _)| r)
        .collect();
    let held_recs: Vec<_> = c
        .recordings
        .iter()
        .zip(&held)
        .filter(|(_, h)| **h)
        .map(|(r, _)| r)
        .collect();
    let cal = Target::new(cal_recs);
    let test = Target::new(held_recs);
    let base = fit::fit(&cal, &Model::default(), None, opts.fit);
    let gap_before = fit::evaluate(&test, &base.model);
    // Candidates one after another; each fit runs its simulations in parallel.
    let mut ranking: Vec<Ranked> = opts
        .candidates
        .iter()
        .map(|&k| {
            let start_model = fit::starts(&cal, &base.model, k);
            // Uncertainties only for the winner (below): its fresh Jacobian is p more runs.
            let quick = FitOptions {
                final_jacobian: false,
                ..opts.fit
            };
            let f = fit::fit(&cal, &start_model, Some(k), quick);
            let e1 = fit::evaluate(&test, &f.model);
            Ranked {
                effect: k,
                score: e1 * (1.0 + PARAM_PENALTY * f.effect_params as f64),
                reduction: (gap_before - e1) / gap_before,
                gap_after: e1,
                fit: f,
            }
        })
        .collect();
    ranking.sort_by(|a, b| a.score.total_cmp(&b.score));
    if let Some(top) = ranking.first_mut() {
        // Uncertainties of the winner from a fresh Jacobian at its optimum (no further steps).
        let at = FitOptions {
            max_iter: 0,
            final_jacobian: true,
            ..opts.fit
        };
        let f = fit::fit(&cal, &top.fit.model, Some(top.effect), at);
        top.fit.estimates = f.estimates;
        top.fit.evaluations += f.evaluations;
    }
    // Per-recording gaps of the base and the top-ranked candidate (named or not), over all
    // recordings; the held-out ones give the breadth: the share whose gap the top one lowers.
    let top_model = ranking.first().map(|b| b.fit.model.clone());
    let location = locate(c, &held, &base.model, top_model.as_ref());
    let held_gaps: Vec<&RecordingGap> = location.recordings.iter().filter(|r| r.held_out).collect();
    let better = held_gaps.iter().filter(|r| r.gap_best < r.gap_base).count();
    let breadth = better as f64 / held_gaps.len().max(1) as f64;
    let (verdict, best) = if gap_before < SIGNIFICANT_GAP {
        (Verdict::NoSignificantGap, None)
    } else {
        match ranking.as_slice() {
            [b, rest @ ..]
                if b.reduction >= MIN_REDUCTION
                    && breadth >= MIN_BREADTH
                    && rest
                        .first()
                        .is_none_or(|r| b.score <= CLEAR_MARGIN * r.score) =>
            {
                (Verdict::Effect, Some(b))
            }
            _ => (Verdict::Unexplained, None),
        }
    };
    let gap_after = best.map(|b| b.gap_after).unwrap_or(gap_before);
    Diagnosis {
        verdict,
        best_effect: best.map(|b| b.effect),
        gap_before,
        gap_after,
        reduction: (gap_before - gap_after) / gap_before,
        breadth,
        base,
        ranking,
        location,
        held_out: c
            .recordings
            .iter()
            .zip(&held)
            .filter(|(_, h)| **h)
            .map(|(r, _)| r.name.clone())
            .collect(),
        wall_time: start.elapsed().as_secs_f64(),
    }
}

/// Where the gap of `base` lies, over all recordings.
fn locate(c: &Campaign, held: &[bool], base: &Model, best: Option<&Model>) -> Where {
    let all = Target::new(c.recordings.iter().collect());
    let pred = all.predict(base);
    let pred_best = best.map(|m| all.predict(m));
    let mut recordings = vec![];
    let mut feat_sum = [0.0; 11];
    let mut feat_n = [0usize; 11];
    for (i, rec) in c.recordings.iter().enumerate() {
        let m = &all.measured[i];
        let mut z_base = [f64::NAN; 11];
        let mut zs = vec![];
        for f in FEATURES {
            if let Some(z) = fit::zscore(m, &pred[i], f) {
                z_base[f as usize] = z;
                feat_sum[f as usize] += z * z;
                feat_n[f as usize] += 1;
                zs.push(z);
            }
        }
        let gap_best = pred_best
            .as_ref()
            .map_or(f64::NAN, |pb| fit::gap(&fit::zscores(m, &pb[i])));
        let p = &rec.params;
        let period = m.get(Feature::Period);
        let slip = m.get(Feature::SlipTime);
        let stick = if period.is_finite() && slip.is_finite() {
            period - slip
        } else {
            0.0
        };
        recordings.push(RecordingGap {
            name: rec.name.clone(),
            gap_base: fit::gap(&zs),
            gap_best,
            held_out: held[i],
            conditions: [
                p.v_d,
                p.k_d,
                if p.vibrates() { p.f } else { 0.0 },
                p.v_a() / p.v_d,
                stick,
                p.k_t * p.u0 / base.f_c,
            ],
            z_base,
        });
    }
    let total: f64 = feat_sum.iter().sum::<f64>().max(1e-300);
    let features: Vec<(Feature, f64, f64)> = FEATURES
        .iter()
        .map(|&f| {
            let i = f as usize;
            let rms = if feat_n[i] > 0 {
                (feat_sum[i] / feat_n[i] as f64).sqrt()
            } else {
                0.0
            };
            (f, rms, feat_sum[i] / total)
        })
        .collect();
    let phases: Vec<(&'static str, f64, f64)> = PHASES
        .iter()
        .enumerate()
        .map(|(k, &name)| {
            let (s, n) = FEATURES
                .iter()
                .filter(|f| f.phase() == k)
                .fold((0.0, 0usize), |(s, n), f| {
                    (s + feat_sum[*f as usize], n + feat_n[*f as usize])
                });
            (
                name,
                if n > 0 { (s / n as f64).sqrt() } else { 0.0 },
                s / total,
            )
        })
        .collect();
    let gaps: Vec<f64> = recordings.iter().map(|r| r.gap_base).collect();
    let conditions: Vec<(&'static str, f64)> = CONDITIONS
        .iter()
        .enumerate()
        .map(|(k, &name)| {
            let x: Vec<f64> = recordings.iter().map(|r| r.conditions[k]).collect();
            (name, spearman(&x, &gaps))
        })
        .collect();
    let mean_gap = |vib: bool| {
        let z: Vec<f64> = recordings
            .iter()
            .filter(|r| (r.conditions[2] > 0.0) == vib)
            .map(|r| r.gap_base * r.gap_base)
            .collect();
        if z.is_empty() {
            f64::NAN
        } else {
            (z.iter().sum::<f64>() / z.len() as f64).sqrt()
        }
    };
    let with_vibration = (mean_gap(true), mean_gap(false));
    let mut summary = describe(&features, &phases, &conditions, with_vibration);
    let sq: Vec<f64> = recordings.iter().map(|r| r.gap_base * r.gap_base).collect();
    let total_sq: f64 = sq.iter().sum();
    if let Some(i) = (0..sq.len()).max_by(|&a, &b| sq[a].total_cmp(&sq[b]))
        && total_sq > 0.0
        && sq[i] / total_sq > 0.3
    {
        summary += &format!(
            " Recording {} alone carries {:.0} % of it (gap {:.2}).",
            recordings[i].name,
            100.0 * sq[i] / total_sq,
            recordings[i].gap_base
        );
    }
    Where {
        features,
        phases,
        conditions,
        recordings,
        with_vibration,
        summary,
    }
}

fn describe(
    features: &[(Feature, f64, f64)],
    phases: &[(&str, f64, f64)],
    conditions: &[(&str, f64)],
    vib: (f64, f64),
) -> String {
    let mut f: Vec<_> = features.to_vec();
    f.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut ph: Vec<_> = phases.to_vec();
    ph.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut cs: Vec<_> = conditions.to_vec();
    cs.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    let mut s = format!(
        "The gap concentrates in {} ({:.0} % of the squared gap) and {} ({:.0} %), i.e. in the {} phase ({:.0} %)",
        f[0].0.name(),
        100.0 * f[0].2,
        f[1].0.name(),
        100.0 * f[1].2,
        ph[0].0,
        100.0 * ph[0].2
    );
    if ph[1].2 > 0.2 {
        s += &format!(" and the {} phase ({:.0} %)", ph[1].0, 100.0 * ph[1].2);
    }
    s += ". ";
    if vib.0.is_finite() && vib.1.is_finite() {
        let (a, b) = vib;
        if a > 1.5 * b {
            s += &format!("It is larger with vibration (gap {a:.2}) than without ({b:.2}). ");
        } else if b > 1.5 * a {
            s += &format!("It is larger without vibration (gap {b:.2}) than with ({a:.2}). ");
        } else {
            s += &format!("It is alike with vibration (gap {a:.2}) and without ({b:.2}). ");
        }
    }
    if let Some((name, rho)) = cs.first() {
        if rho.abs() >= 0.4 {
            s += &format!(
                "Over the conditions it {} with {name} (Spearman ρ = {rho:.2}).",
                if *rho > 0.0 { "grows" } else { "shrinks" }
            );
        } else {
            s += "It follows no single condition (|ρ| < 0.4 for all).";
        }
    }
    s
}
