//! The discrimination criterion of a plan: how far a candidate recording tells two rivals
//! apart, after the rival that is not the truth has refitted its parameters to the existing
//! recordings and the planned ones (Atkinson and Fedorov's T-criterion, linearised at the
//! rivals' fitted parameters), in the evidence's own units.
//!
//! # The criterion
//! For a truth `i` and a rival `j`, each planned recording `y` gives residual rows
//! `r_y(θ_j) = (pred_j(y; θ_j) − pred_i(y)) / σ_y`: `j`'s prediction of the features against
//! `i`'s noiseless one, in the standard errors a recording made under `i` with the campaign's
//! noise would have (the features of such a simulated recording; a row's scale grows by
//! `√(1 + gᵀ Σ_i g)` with `i`'s own parameter covariance `Σ_i` and the row's gradient `g` in
//! `i`'s parameters: where the truth itself is uncertain, its prediction is too). `j` refits:
//! `δ* = argmin |z_j + J_j δ|² + Σ_y |r_y + J_{j,y} δ|²` over the existing recordings' residuals
//! `z_j` and Jacobian `J_j` (the diagnosis's fit, linearised) and the planned rows, inside the
//! plausible bounds. The expected log-likelihood ratio for `i` against `j` is then, as the
//! diagnosis's evidence counts it (one scale per recording:
//! [`evidence`](crate::diagnosis::evidence::evidence)),
//!
//! `D_ij = Σ_y (n_y/2) ln(1 + |r_y(δ*)|²/n_y) + Σ_e (n_e/2) ln(E_e(δ*)/E_e(δ0))`,
//!
//! the planned recordings' share (a truth's own residuals have unit mean square there) and what
//! the refit costs `j` on each existing recording `e` (`δ0`: `j`'s refit on the existing
//! recordings alone). A pair is told apart as far as the worse of its two directions,
//! `min(D_ij, D_ji)`: whichever is true must win.

use super::space::Candidate;
use crate::diagnosis::features::{FEATURES, Feature, FeatureSet};
use crate::diagnosis::fit::zscore;
use crate::diagnosis::linearised::Linearised;
use faer::Mat;
use faer::linalg::solvers::{Solve, SolveLstsq};

/// One candidate recording as the criterion sees it: every rival's features on it, at its
/// fitted parameters and with each coordinate stepped, and what a recording made under each
/// rival would measure.
#[derive(Clone, Debug)]
pub struct Predicted {
    /// The candidate.
    pub candidate: Candidate,
    /// `pred[j][0]`: rival `j`'s features at its fit; `pred[j][1 + k]`: with coordinate `k`
    /// stepped by `steps[j][k]`. One feature set per stage.
    pub pred: Vec<Vec<Vec<FeatureSet>>>,
    /// The steps taken, per rival and coordinate.
    pub steps: Vec<Vec<f64>>,
    /// `meas[i]`: what a recording under rival `i` would measure: its noiseless features with
    /// the standard errors of the same recording with the campaign's noise (no `r`: a planned
    /// recording is compared by its own features).
    pub meas: Vec<Vec<FeatureSet>>,
}

/// Planned rows of one (truth, rival) pair on one recording: residuals at the rival's fit,
/// their Jacobian in its coordinates, and each row's feature.
#[derive(Clone, Debug)]
pub struct Rows {
    /// Residuals `r_y` at the rival's fitted parameters, scaled.
    pub r: Vec<f64>,
    /// `∂r/∂θ_j`, rows × coordinates.
    pub jac: Vec<Vec<f64>>,
    /// Each row's feature.
    pub features: Vec<Feature>,
}

/// The standardised residuals of `pred` against `meas`, every stage's, with each row's feature.
pub(crate) fn rows_raw(meas: &[FeatureSet], pred: &[FeatureSet]) -> (Vec<f64>, Vec<Feature>) {
    let mut r = vec![];
    let mut fs = vec![];
    for (m, p) in meas.iter().zip(pred) {
        for &f in FEATURES.iter() {
            if let Some(z) = zscore(m, p, f) {
                r.push(z);
                fs.push(f);
            }
        }
    }
    (r, fs)
}

impl Predicted {
    /// The rows of rival `j` against truth `i` on this candidate, each scaled by the truth's
    /// own parameter uncertainty (`cov_i`, the covariance of `i`'s coordinates; `None`: none).
    pub fn rows(&self, i: usize, j: usize, cov_i: Option<&Mat<f64>>) -> Rows {
        let (r, features) = rows_raw(&self.meas[i], &self.pred[j][0]);
        // Each coordinate's column of `rival`'s rows, from its residuals at the fit `r0`.
        let grad = |k: usize, rival: usize, r0: &[f64]| -> Vec<f64> {
            let (rk, _) = rows_raw(&self.meas[i], &self.pred[rival][1 + k]);
            let h = self.steps[rival][k];
            rk.iter().zip(r0).map(|(a, b)| (a - b) / h).collect()
        };
        let pj = self.steps[j].len();
        let cols: Vec<Vec<f64>> = (0..pj).map(|k| grad(k, j, &r)).collect();
        let mut jac: Vec<Vec<f64>> = (0..r.len())
            .map(|row| {
                cols.iter()
                    .map(|c| c.get(row).copied().unwrap_or(0.0))
                    .collect()
            })
            .collect();
        let mut r = r;
        if let Some(cov) = cov_i {
            let pi = self.steps[i].len();
            let (ri, _) = rows_raw(&self.meas[i], &self.pred[i][0]);
            let gi: Vec<Vec<f64>> = (0..pi).map(|k| grad(k, i, &ri)).collect();
            for row in 0..r.len() {
                let g: Vec<f64> = gi
                    .iter()
                    .map(|c| c.get(row).copied().unwrap_or(0.0))
                    .collect();
                let mut v = 0.0;
                for a in 0..pi.min(cov.nrows()) {
                    for b in 0..pi.min(cov.ncols()) {
                        v += g[a] * cov[(a, b)] * g[b];
                    }
                }
                let s = (1.0 + v.max(0.0)).sqrt();
                if s.is_finite() {
                    r[row] /= s;
                    for x in &mut jac[row] {
                        *x /= s;
                    }
                }
            }
        }
        Rows { r, jac, features }
    }
}

/// The covariance of a linearised fit's coordinates, `s² (JᵀJ)⁻¹` with `s² = |z|²/(m − p)`
/// (`None` where it is not estimable).
pub fn covariance(lin: &Linearised) -> Option<Mat<f64>> {
    let (m, p) = (lin.jacobian.nrows(), lin.jacobian.ncols());
    if m <= p || lin.z.len() != m {
        return None;
    }
    let jtj = lin.jacobian.transpose() * &lin.jacobian;
    let s2 = lin.z.iter().map(|v| v * v).sum::<f64>() / (m - p) as f64;
    let inv = jtj.partial_piv_lu().solve(Mat::<f64>::identity(p, p));
    let ok = (0..p).all(|a| inv[(a, a)].is_finite() && inv[(a, a)] >= 0.0);
    ok.then(|| Mat::from_fn(p, p, |a, b| inv[(a, b)] * s2))
}

/// A rival's refit, linearised: its existing residuals and Jacobian with the recording of
/// each row.
pub struct Existing<'l> {
    /// The rival linearised on the campaign.
    pub lin: &'l Linearised,
    /// The recording of each of its rows.
    pub row_rec: &'l [usize],
    /// Recordings in the campaign.
    pub n_recs: usize,
}

/// The least-squares step `δ` of `|a + B δ|²` (rows `a`, matrix `b` as rows) inside the box
/// `lo ≤ θ + δ ≤ hi` (coordinates `theta`): the unbounded step, then the coordinates it
/// pushes past a bound held there and the rest solved again. A tiny damping (1e-10 of each
/// column's square norm) guards against rank deficiency.
fn bounded_step(a: &[f64], b: &[Vec<f64>], theta: &[f64], bounds: &[(f64, f64)]) -> Vec<f64> {
    let p = theta.len();
    let m = a.len();
    let solve = |fixed: &[Option<f64>]| -> Vec<f64> {
        let free: Vec<usize> = (0..p).filter(|&k| fixed[k].is_none()).collect();
        let q = free.len();
        if q == 0 {
            return fixed.iter().map(|x| x.unwrap_or(0.0)).collect();
        }
        let diag: Vec<f64> = free
            .iter()
            .map(|&k| (0..m).map(|i| b[i][k] * b[i][k]).sum::<f64>().max(1e-12))
            .collect();
        let mat = Mat::from_fn(m + q, q, |i, c| {
            if i < m {
                b[i][free[c]]
            } else if i - m == c {
                (1e-10 * diag[c]).sqrt()
            } else {
                0.0
            }
        });
        let rhs = Mat::from_fn(m + q, 1, |i, _| {
            if i < m {
                // The fixed coordinates' part moves to the right-hand side.
                -a[i]
                    - (0..p)
                        .filter_map(|k| fixed[k].map(|d| b[i][k] * d))
                        .sum::<f64>()
            } else {
                0.0
            }
        });
        let sol = mat.col_piv_qr().solve_lstsq(&rhs);
        let mut d: Vec<f64> = fixed.iter().map(|x| x.unwrap_or(0.0)).collect();
        for (c, &k) in free.iter().enumerate() {
            d[k] = sol[(c, 0)];
        }
        d
    };
    let mut fixed: Vec<Option<f64>> = vec![None; p];
    let mut d = solve(&fixed);
    for _ in 0..p {
        let mut changed = false;
        for k in 0..p {
            if fixed[k].is_some() {
                continue;
            }
            let (lo, hi) = bounds[k];
            let x = theta[k] + d[k];
            if x < lo || x > hi {
                fixed[k] = Some(x.clamp(lo, hi) - theta[k]);
                changed = true;
            }
        }
        if !changed {
            break;
        }
        d = solve(&fixed);
    }
    d
}

/// What one (truth, rival) pair's discrimination is made of, on the planned recordings.
#[derive(Clone, Debug)]
pub struct Discrimination {
    /// `D_ij` \[nats\] (module docs).
    pub nats: f64,
    /// Per planned recording: its share \[nats\] and its residuals' squares by feature after
    /// the refit.
    pub per_planned: Vec<(f64, Vec<(Feature, f64)>)>,
}

/// `D_ij` of the planned recordings `planned` (each with its rows for this pair), for the
/// rival `ex` refitting on the existing recordings and the planned ones. `delta0`: the rival's
/// refit on the existing recordings alone ([`refit_alone`]).
pub fn discrimination(ex: &Existing, planned: &[&Rows], delta0: &[f64]) -> Discrimination {
    let lin = ex.lin;
    let p = lin.theta.len();
    let m = lin.z.len();
    let mut a: Vec<f64> = lin.z.clone();
    let mut b: Vec<Vec<f64>> = (0..m)
        .map(|i| (0..p).map(|k| lin.jacobian[(i, k)]).collect())
        .collect();
    for rows in planned {
        a.extend_from_slice(&rows.r);
        b.extend(rows.jac.iter().cloned());
    }
    let d = bounded_step(&a, &b, &lin.theta, &lin.bounds);
    let resid = |i: usize, d: &[f64]| a[i] + (0..p).map(|k| b[i][k] * d[k]).sum::<f64>();
    // The existing recordings' mean squares after each refit.
    let mut e1 = vec![0.0; ex.n_recs];
    let mut e0 = vec![0.0; ex.n_recs];
    let mut n = vec![0usize; ex.n_recs];
    for i in 0..m {
        let rec = ex.row_rec[i];
        e1[rec] += resid(i, &d).powi(2);
        e0[rec] += resid(i, delta0).powi(2);
        n[rec] += 1;
    }
    let mut nats = 0.0;
    for rec in 0..ex.n_recs {
        if n[rec] > 0 && e0[rec] > 0.0 {
            nats += 0.5 * n[rec] as f64 * (e1[rec] / e0[rec]).ln();
        }
    }
    let mut per_planned = vec![];
    let mut row = m;
    for rows in planned {
        let mut by: Vec<(Feature, f64)> = vec![];
        let mut ss = 0.0;
        for f in &rows.features {
            let q = resid(row, &d).powi(2);
            ss += q;
            match by.iter_mut().find(|x| x.0 == *f) {
                Some(x) => x.1 += q,
                None => by.push((*f, q)),
            }
            row += 1;
        }
        let ny = rows.r.len() as f64;
        let share = if ny > 0.0 {
            0.5 * ny * (1.0 + ss / ny).ln()
        } else {
            0.0
        };
        nats += share;
        by.sort_by(|x, y| y.1.total_cmp(&x.1));
        per_planned.push((share, by));
    }
    Discrimination { nats, per_planned }
}

/// The rival's least-squares step on the existing recordings alone, inside its bounds: its
/// fit's own optimum as the linearisation sees it (close to 0).
pub fn refit_alone(ex: &Existing) -> Vec<f64> {
    let lin = ex.lin;
    let p = lin.theta.len();
    let b: Vec<Vec<f64>> = (0..lin.z.len())
        .map(|i| (0..p).map(|k| lin.jacobian[(i, k)]).collect())
        .collect();
    bounded_step(&lin.z, &b, &lin.theta, &lin.bounds)
}

/// Feature names of the largest shares, for reports.
pub fn carriers(by: &[(Feature, f64)], most: usize) -> Vec<(&'static str, f64)> {
    let total: f64 = by.iter().map(|x| x.1).sum();
    by.iter()
        .take(most)
        .filter(|x| total > 0.0 && x.1 > 0.05 * total)
        .map(|x| (x.0.name(), x.1.sqrt()))
        .collect()
}

/// The feature sets of a recording with `r` removed (a planned recording is compared by its
/// own features: its reference would be another planned recording).
pub fn without_r(mut fs: Vec<FeatureSet>) -> Vec<FeatureSet> {
    for f in &mut fs {
        f.value[Feature::R as usize] = f64::NAN;
        f.stderr[Feature::R as usize] = f64::NAN;
    }
    fs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lin(z: Vec<f64>, jac: Vec<f64>, lo: f64) -> Linearised {
        let m = z.len();
        Linearised {
            model: crate::diagnosis::fit::Model::default(),
            effects: vec![],
            names: vec!["c".into()],
            theta: vec![0.0],
            bounds: vec![(lo, 10.0)],
            steps: vec![0.01],
            z,
            jacobian: Mat::from_fn(m, 1, |i, _| jac[i]),
        }
    }

    fn rows(r: f64, j: f64) -> Rows {
        Rows {
            r: vec![r],
            jac: vec![vec![j]],
            features: vec![Feature::MeanForce],
        }
    }

    /// D_ij in closed form, one coordinate: existing residuals (1, −1) of one recording with
    /// gradient (1, 1) (the fit's optimum: δ0 = 0), one planned row of residual 3.
    /// - The coordinate does not act on the planned row: no refit helps,
    ///   `D = ½ ln(1 + 9)`.
    /// - It does (gradient 1): the refit is δ* = −1 (least squares of (1+δ, −1+δ, 3+δ)), the
    ///   planned residual 2, the existing ones (0, −2): `D = ½·2 ln(2/1) + ½ ln(1 + 4)`.
    /// - Its bound at −0.5 holds it there: residuals 2.5 and (0.5, −1.5):
    ///   `D = ½·2 ln(1.25) + ½ ln(1 + 6.25)`.
    #[test]
    fn discrimination_in_closed_form() {
        let row_rec = [0usize, 0];
        for (j_x, lo, want) in [
            (0.0, -10.0, 0.5 * 10f64.ln()),
            (1.0, -10.0, 2f64.ln() + 0.5 * 5f64.ln()),
            (1.0, -0.5, 1.25f64.ln() + 0.5 * 7.25f64.ln()),
        ] {
            let l = lin(vec![1.0, -1.0], vec![1.0, 1.0], lo);
            let ex = Existing {
                lin: &l,
                row_rec: &row_rec,
                n_recs: 1,
            };
            let d0 = refit_alone(&ex);
            assert!(d0[0].abs() < 1e-9, "{d0:?}");
            let x = rows(3.0, j_x);
            let d = discrimination(&ex, &[&x], &d0);
            assert!(
                (d.nats - want).abs() < 1e-9,
                "{j_x} {lo}: {} vs {want}",
                d.nats
            );
            assert_eq!(d.per_planned.len(), 1);
            assert_eq!(d.per_planned[0].1[0].0, Feature::MeanForce);
        }
    }

    /// The bounded step of a problem whose unbounded minimum lies outside the box holds that
    /// coordinate on its bound and solves the other again: `|(x − 2, y − x)|²` with `x ≤ 1`
    /// is least at x = 1, y = 1 (closed form), not at the clamped unbounded (1, 2).
    #[test]
    fn a_step_past_a_bound_is_solved_again_on_it() {
        // Residuals a + B δ at θ = 0: (δx − 2, δy − δx).
        let a = vec![-2.0, 0.0];
        let b = vec![vec![1.0, 0.0], vec![-1.0, 1.0]];
        let d = bounded_step(&a, &b, &[0.0, 0.0], &[(-10.0, 1.0), (-10.0, 10.0)]);
        assert!(
            (d[0] - 1.0).abs() < 1e-9 && (d[1] - 1.0).abs() < 1e-9,
            "{d:?}"
        );
        let free = bounded_step(&a, &b, &[0.0, 0.0], &[(-10.0, 10.0), (-10.0, 10.0)]);
        assert!(
            (free[0] - 2.0).abs() < 1e-9 && (free[1] - 2.0).abs() < 1e-9,
            "{free:?}"
        );
    }
}
