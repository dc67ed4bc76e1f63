//! Held-out folds of a campaign (by kind of recording) and the cross-validated gap of a model,
//! with the tests of whether what is left is concentrated in one feature or systematic.

use super::evidence::*;
use super::features::{FEATURES, Feature, N_FEATURES};
use super::fit::{self, FitResult, Model, Target};
use crate::campaign::Campaign;

/// A recording's kind for the cross-validation (see the module docs): 0 without vibration,
/// else `1 + 2 band + (v_a ≥ v_d)` with the octave band from 250 Hz.
pub(crate) fn kind_of(p: &crate::model::Params) -> usize {
    if !p.vibrates() {
        return 0;
    }
    let band = (p.f / 250.0).log2().floor().clamp(0.0, 10.0) as usize;
    1 + 2 * band + usize::from(p.v_a() >= p.v_d)
}

/// Words for a kind.
pub(crate) fn kind_name(k: usize) -> String {
    if k == 0 {
        return "runs without vibration".into();
    }
    let band = (k - 1) / 2;
    let lo = 250.0 * 2f64.powi(band as i32);
    format!(
        "{} at {:.0} to {:.0} Hz",
        if (k - 1) % 2 == 1 {
            "runs with v_a >= v_d"
        } else {
            "runs with v_a < v_d"
        },
        lo,
        2.0 * lo
    )
}

/// The cross-validation folds (see the module docs): each recording's fold, the number of
/// folds, whether each recording can be checked on held-out data, and a sentence for each kind
/// that cannot.
pub fn folds(c: &Campaign) -> (Vec<usize>, usize, Vec<bool>, Vec<String>) {
    let n = c.recordings.len();
    let key = |p: &crate::model::Params| (p.v_d.to_bits(), p.k_d.to_bits(), p.f_n.to_bits());
    // Groups: (kind, drive), in a fixed order: by kind, then longest stick-slip cycle first.
    let mut groups: Vec<(usize, crate::model::Params)> = vec![];
    for r in &c.recordings {
        let k = kind_of(&r.params);
        if !groups
            .iter()
            .any(|(gk, gp)| *gk == k && key(gp) == key(&r.params))
        {
            groups.push((k, r.params));
        }
    }
    groups.sort_by(|a, b| {
        a.0.cmp(&b.0)
            .then((a.1.k_d * a.1.v_d).total_cmp(&(b.1.k_d * b.1.v_d)))
            .then(a.1.f_n.total_cmp(&b.1.f_n))
    });
    let mut per_kind: std::collections::BTreeMap<usize, usize> = Default::default();
    for g in &groups {
        *per_kind.entry(g.0).or_default() += 1;
    }
    let most = per_kind.values().copied().max().unwrap_or(1);
    let k_folds = FOLDS.min(most).max(2).min(n.max(2));
    // Round-robin over the groups in their order (kind by kind), the count running on across
    // kinds so that the folds stay balanced.
    let group_fold: Vec<usize> = (0..groups.len()).map(|g| g % k_folds).collect();
    let fold: Vec<usize> = c
        .recordings
        .iter()
        .map(|r| {
            let k = kind_of(&r.params);
            let g = groups
                .iter()
                .position(|(gk, gp)| *gk == k && key(gp) == key(&r.params))
                .expect("every recording has its group");
            group_fold[g]
        })
        .collect();
    let checked: Vec<bool> = c
        .recordings
        .iter()
        .map(|r| per_kind[&kind_of(&r.params)] >= 2)
        .collect();
    let not_checked: Vec<String> = per_kind
        .iter()
        .filter(|(_, count)| **count < 2)
        .map(|(&k, _)| {
            let names: Vec<&str> = c
                .recordings
                .iter()
                .filter(|r| kind_of(&r.params) == k)
                .map(|r| r.name.as_str())
                .collect();
            format!(
                "{} come from one drive only ({}): no calibration without them holds their kind, so they are not checked on held-out data",
                kind_name(k),
                names.join(", ")
            )
        })
        .collect();
    (fold, k_folds, checked, not_checked)
}

/// The cross-validation of one fitted model: for every fold, the fit refitted without the
/// fold's recordings, simulated once over all of them.
pub(crate) struct CrossValidated {
    /// Pooled held-out gap.
    pub(crate) gap: f64,
    /// Spread of the folds' gaps.
    pub(crate) spread: f64,
    /// Each recording's held-out gap (NaN where not checked).
    pub(crate) per_recording: Vec<f64>,
    /// The number of held-out residuals behind each recording's gap.
    pub(crate) per_recording_n: Vec<usize>,
    /// Each row's held-out residual (rows as [`Target::row_recordings`]; NaN on rows not
    /// held out, and where only the per-recording gaps were kept).
    pub(crate) held: Vec<f64>,
    /// Each feature's held-out gap, with the number of checked recordings on which its `|z|`
    /// is at least [`FEATURE_GAP`] (NaN, 0 where no checked unit defines it).
    pub(crate) per_feature: Vec<(f64, usize)>,
    /// Each feature's held-out mean `z` and its t statistic (mean over its standard error from
    /// the spread), over the number of held-out units that define it (NaN, NaN, 0 where none).
    pub(crate) per_feature_bias: Vec<(f64, f64, usize)>,
}

/// The residuals, on every row of `all`, of fit `fr` refitted to the rows `keep` marks, its
/// fitted coordinates before `first_free` held (0: none; `template` gives the model's other
/// values): one damped Gauss–Newton step from its optimum on those rows of its Jacobian
/// ([`fit::refit_rows`]), at full, half or quarter length, the first that does not raise
/// the kept rows' cost; where each raises it, no step: the fit's own residuals (also where its
/// residuals or Jacobian do not match the rows). A fold's refit, and a held-out family's.
pub(crate) fn refit_without(
    all: &Target,
    fr: &FitResult,
    template: &Model,
    keep: &[bool],
    first_free: usize,
) -> Vec<f64> {
    let cost = |z: &[f64]| -> f64 {
        z.iter()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(v, _)| v * v)
            .sum()
    };
    if fr.z.len() == keep.len() && fr.jacobian.nrows() == keep.len() {
        let before = cost(&fr.z);
        // A step is judged on the refit's own rows: the held-out recordings are simulated
        // only for the step taken (the others' runs are cached).
        let need = all.needed_with_references(keep);
        for step in [1.0, 0.5, 0.25] {
            let m = fit::refit_rows(&all.bounds, fr, template, keep, first_free, step);
            let zc = all.residuals(&all.predict_for(&m, Some(&need)));
            if zc.len() == keep.len() && cost(&zc) <= before * (1.0 + 1e-9) {
                return all.residuals(&all.predict(&m));
            }
        }
    }
    fr.z.clone()
}

pub(crate) fn cross_validate(
    all: &Target,
    fr: &FitResult,
    start: &Model,
    fold: &[usize],
    k_folds: usize,
    checked: &[bool],
) -> CrossValidated {
    let row_rec = all.row_recordings();
    let row_feat = all.row_features();
    let mut held = vec![f64::NAN; row_rec.len()];
    for k in 0..k_folds {
        if !(0..all.recs.len()).any(|i| fold[i] == k && checked[i]) {
            continue;
        }
        let keep: Vec<bool> = row_rec.iter().map(|&r| fold[r] != k).collect();
        let z = refit_without(all, fr, start, &keep, 0);
        for (row, &r) in row_rec.iter().enumerate() {
            if fold[r] == k && checked[r] {
                held[row] = z[row];
            }
        }
    }
    summarise(&row_rec, &row_feat, all.recs.len(), held, fold, k_folds)
}

/// The held-out statistics of [`CrossValidated`] from the held-out residual of every row
/// (`held`, NaN on rows not held out; rows as [`Target::row_recordings`], whose recordings
/// `row_rec` and features `row_feat` give), `n` recordings dealt into `k_folds` folds by `fold`.
pub(crate) fn summarise(
    row_rec: &[usize],
    row_feat: &[Feature],
    n: usize,
    held: Vec<f64>,
    fold: &[usize],
    k_folds: usize,
) -> CrossValidated {
    let mut per_recording = vec![f64::NAN; n];
    let mut per_recording_n = vec![0; n];
    let mut feat_sum = [0.0; N_FEATURES];
    let mut feat_n = [0usize; N_FEATURES];
    let mut feat_lin = [0.0; N_FEATURES];
    let mut feat_far = vec![vec![]; N_FEATURES];
    let mut pooled = vec![];
    let mut fold_gaps = vec![];
    for k in 0..k_folds {
        // One pass over the fold's held-out rows: each feature's and each recording's squares.
        let mut fz = vec![];
        let mut rec_z: Vec<Vec<f64>> = vec![vec![]; n];
        for ((&r, &f), &v) in row_rec.iter().zip(row_feat).zip(&held) {
            if fold[r] == k && !v.is_nan() {
                let f = f as usize;
                feat_sum[f] += v * v;
                feat_lin[f] += v;
                feat_n[f] += 1;
                if v.abs() >= FEATURE_GAP && !feat_far[f].contains(&r) {
                    feat_far[f].push(r);
                }
                rec_z[r].push(v);
            }
        }
        for i in 0..n {
            if fold[i] != k || rec_z[i].is_empty() {
                continue;
            }
            per_recording[i] = fit::gap(&rec_z[i]);
            per_recording_n[i] = rec_z[i].len();
            fz.append(&mut rec_z[i]);
        }
        if !fz.is_empty() {
            fold_gaps.push(fit::gap(&fz));
            pooled.extend(fz);
        }
    }
    let mean = fold_gaps.iter().sum::<f64>() / fold_gaps.len().max(1) as f64;
    let spread = if fold_gaps.len() > 1 {
        (fold_gaps.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / (fold_gaps.len() - 1) as f64)
            .sqrt()
    } else {
        f64::NAN
    };
    CrossValidated {
        gap: if pooled.is_empty() {
            f64::NAN
        } else {
            fit::gap(&pooled)
        },
        spread,
        per_recording,
        per_recording_n,
        held,
        per_feature: (0..N_FEATURES)
            .map(|f| {
                if feat_n[f] == 0 {
                    (f64::NAN, 0)
                } else {
                    ((feat_sum[f] / feat_n[f] as f64).sqrt(), feat_far[f].len())
                }
            })
            .collect(),
        per_feature_bias: (0..N_FEATURES)
            .map(|f| {
                let n = feat_n[f];
                if n < 2 {
                    return (f64::NAN, f64::NAN, n);
                }
                let mean = feat_lin[f] / n as f64;
                let var = ((feat_sum[f] - n as f64 * mean * mean) / (n - 1) as f64).max(0.0);
                let t = mean / (var / n as f64).sqrt().max(1e-12);
                (mean, t, n)
            })
            .collect(),
    }
}

/// The feature whose held-out gap is largest among those that carry a concentrated gap: at
/// least [`FEATURE_GAP`], with `|z|` at least that on two checked recordings or more; else the
/// feature most [`systematic`]ally off, with its held-out gap and the units that define it.
pub(crate) fn concentrated(cv: &CrossValidated) -> Option<(Feature, f64, usize)> {
    FEATURES
        .iter()
        .filter_map(|&f| cv.per_feature.get(f as usize).map(|&(g, n)| (f, g, n)))
        .filter(|&(_, g, n)| g >= FEATURE_GAP && n >= 2)
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .or_else(|| systematic(cv).map(|(f, _, _, n)| (f, cv.per_feature[f as usize].0, n)))
}

/// Smallest held-out mean `|z|` of a feature that counts as systematically off: the model
/// misses it by one and a half standard errors or more on average, in one direction. Why not 1:
/// a harmonic amplitude measured through noise is biased upwards (by up to 1.25 of its error
/// where the harmonic is in the noise), which a noise-free simulation is not; effect-free
/// `synth` campaigns show a mean `z` of about −1 in `x_s_amp_f` for it.
pub const BIAS_Z: f64 = 1.5;
/// Smallest `|t|` of that mean (over its standard error from the spread of the units): with
/// 17 features tested, about a 1 % chance that some effect-free feature reaches it by chance
/// (from 6 units on, [`BIAS_UNITS`]).
pub const BIAS_T: f64 = 5.0;
/// Fewest held-out units that must define a feature for it to count as systematically off.
pub const BIAS_UNITS: usize = 6;

/// The harmonic feature (amplitude or phase at `f` or `2f`) the model misses systematically on
/// held-out data, where one does: mean `z` at least [`BIAS_Z`] in size and [`BIAS_T`] standard
/// errors from 0, over [`BIAS_UNITS`] units or more (the one with the largest `|t|`): its mean,
/// `t` and units. A sensor's attenuation of
/// the ripple at `f` by a third, a few standard errors on each of twenty recordings, is diluted
/// in every recording's gap by the features it leaves alone, and under [`FEATURE_GAP`] in its
/// own, yet nowhere near chance.
pub(crate) fn systematic(cv: &CrossValidated) -> Option<(Feature, f64, f64, usize)> {
    FEATURES
        .iter()
        .filter_map(|&f| {
            cv.per_feature_bias
                .get(f as usize)
                .map(|&(m, t, n)| (f, m, t, n))
        })
        // The harmonics at the forcing frequency only (phase 5): the stick-slip features of
        // a noisy recording carry estimator biases of their own (a peak found on the noise,
        // a rounding of 1.5 standard errors in effect-free `synth` campaigns) that a noise-free
        // simulation does not share.
        .filter(|&(f, m, t, n)| {
            f.phase() == 5 && m.abs() >= BIAS_Z && t.abs() >= BIAS_T && n >= BIAS_UNITS
        })
        .max_by(|a, b| a.2.abs().total_cmp(&b.2.abs()))
}

pub(crate) fn ranks(x: &[f64]) -> Vec<f64> {
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
