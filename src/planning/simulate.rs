//! Candidate recordings simulated: a blank recording of a candidate's conditions, the
//! campaign's noise and a noisy copy of a simulated trace, the simulations of many
//! recordings under many models, and the per-recording gaps the evidence takes.

use super::space::Candidate;
use crate::campaign::{Campaign, GridAsk, Recording, simulate_grids};
use crate::diagnosis::features::{FeatureSet, noise_sd};
use crate::diagnosis::fit::{Model, Target};
use crate::diagnosis::target::trace_of;
use rand::{SeedableRng, rngs::StdRng};

/// Per recording of `target`, the root mean square of the residuals `z` (rows as
/// [`Target::row_recordings`]; NaN where a recording has none) and their number: the
/// per-recording gaps the evidence takes.
pub(crate) fn per_recording(target: &Target, z: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let n = target.recs.len();
    let rows = target.row_recordings();
    let mut ss = vec![0.0; n];
    let mut k = vec![0usize; n];
    if z.len() == rows.len() {
        for (&rec, v) in rows.iter().zip(z) {
            ss[rec] += v * v;
            k[rec] += 1;
        }
    }
    let g = ss
        .iter()
        .zip(&k)
        .map(|(s, &n)| {
            if n > 0 {
                (s / n as f64).sqrt()
            } else {
                f64::NAN
            }
        })
        .collect();
    (g, k)
}

/// The campaign's noise: the force's standard deviation \[N\] and the displacements' \[m\]
/// where every recording has them (the median over recordings of [`noise_sd`]).
pub fn noise_of(c: &Campaign) -> (f64, Option<f64>) {
    let med = |mut v: Vec<f64>| {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        if v.is_empty() {
            f64::NAN
        } else {
            v[v.len() / 2]
        }
    };
    let f = med(c.recordings.iter().map(|r| noise_sd(&r.f_d)).collect());
    let has_x = c
        .recordings
        .iter()
        .all(|r| r.x_s.is_some() && r.x_d.is_some());
    let x = has_x.then(|| {
        med(c
            .recordings
            .iter()
            .flat_map(|r| {
                [r.x_s.as_deref(), r.x_d.as_deref()]
                    .into_iter()
                    .flatten()
                    .map(noise_sd)
            })
            .collect())
    });
    (f, x)
}

/// A recording of a candidate's conditions without samples (zeros), its channels those the
/// campaign records: what predictions on it are computed against.
pub fn blank(name: &str, x: &Candidate, rate: f64, has_x: bool) -> Recording {
    let n = (x.duration * rate).floor() as usize + 1;
    let dt = 1.0 / rate;
    Recording {
        name: name.to_string(),
        params: x.params,
        t: (0..n).map(|k| k as f64 * dt).collect(),
        f_d: vec![0.0; n],
        x_s: has_x.then(|| vec![0.0; n]),
        x_d: has_x.then(|| vec![0.0; n]),
    }
}

/// The features of `model` simulated on each recording (`None` where a run fails), in
/// parallel, with the traces kept for noise where asked. `tol`: integration tolerance.
pub(crate) fn simulate_on(
    asks: &[(Model, &Recording)],
    tol: f64,
) -> Vec<Option<crate::campaign::SimTrace>> {
    let grid: Vec<GridAsk> = asks
        .iter()
        .map(|(m, rec)| GridAsk {
            p: m.params_for(rec),
            fx: m.effects.clone(),
            t0: rec.t[0],
            dt: rec.dt(),
            n: rec.t.len(),
            tol,
        })
        .collect();
    simulate_grids(&grid)
        .into_iter()
        .map(|(r, _)| r.ok().filter(|t| t.status == crate::ode::Status::Success))
        .collect()
}

pub(crate) fn features_of(
    rec: &Recording,
    tr: Option<&crate::campaign::SimTrace>,
) -> Vec<FeatureSet> {
    match tr {
        Some(tr) => trace_of(rec, tr),
        None => {
            let n = crate::diagnosis::features::stages(&rec.t, &rec.params).len();
            vec![FeatureSet::nan(); n]
        }
    }
}

/// A trace with the campaign's noise added (seeded per recording and rival).
pub fn noisy(
    tr: &crate::campaign::SimTrace,
    noise: (f64, Option<f64>),
    seed: u64,
) -> crate::campaign::SimTrace {
    use rand::RngExt;
    let mut rng = StdRng::seed_from_u64(seed);
    let mut draw = |s: f64| s * rng.sample::<f64, _>(rand_distr::StandardNormal);
    let (sf, sx) = (noise.0.max(0.0), noise.1.unwrap_or(0.0).max(0.0));
    crate::campaign::SimTrace {
        f_d: tr.f_d.iter().map(|v| v + draw(sf)).collect(),
        x_s: tr.x_s.iter().map(|v| v + draw(sx)).collect(),
        x_d: tr.x_d.iter().map(|v| v + draw(sx)).collect(),
        status: tr.status,
    }
}
