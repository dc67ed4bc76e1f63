//! Least-squares fits of the model (base parameters, and optionally one effect) to the features
//! of a set of recordings.
//!
//! The residuals are the standardised feature differences
//! `z = (simulated − measured) / σ`, `σ² = se_measured² + se_simulated² + floor²`
//! ([`super::features::Feature::floor`]), over every feature the recording defines. The gap of a
//! model on a set of recordings is `E = √(mean z²)`: about 1 when the model explains the data to
//! within their noise and the floors.
//!
//! The minimiser is Levenberg–Marquardt with Marquardt's diagonal scaling; each step solves the
//! damped normal equations as the least-squares problem `[J; √λ D] δ = [−z; 0]` with faer's
//! column-pivoted QR. The Jacobian is a forward difference with steps of a few per cent in the
//! fitted coordinates (logarithms of positive quantities): the vibrated runs are sensitive to
//! initial conditions, so finer steps would differentiate noise. After an accepted step the
//! Jacobian is updated by Broyden's rank-one formula instead of differenced again (differenced
//! afresh when the updated one fails to give a descent step). Parameter uncertainties are
//! `s √diag((JᵀJ)⁻¹)` with `s² = Σz² / (m − p)`, from a fresh Jacobian at the optimum.

use super::features::Feature;
use crate::campaign::Recording;
use crate::model::effects::{actuator_gain, form_param, response_gain};
use crate::model::{EffectKind, Effects, Params};
use crate::sweep::spec::logspace;
use faer::Mat;
use faer::linalg::solvers::{Solve, SolveLstsq};
use rayon::prelude::*;

pub use super::model::*;
pub use super::target::*;

/// The fitted effect parameters of `fr` that end on a bound of their range (within 1 % on a
/// log scale, 0.1 % of the range on a linear one) other than the end where the effect vanishes
/// ([`neutral`]): `"effect.param = value at the lower|upper bound lo|hi unit"`, one each.
pub fn at_bounds(bounds: &Plausible, fr: &FitResult) -> Vec<String> {
    let cs = coords(bounds, &fr.effects, &fr.model.effects);
    let (cs, theta): (Vec<Coord>, Vec<f64>) = cs
        .iter()
        .zip(&fr.theta)
        .filter(|(c, _)| c.target.is_ok())
        .map(|(c, &t)| (c.clone(), t))
        .unzip();
    // The end where the effect vanishes is the model it extends, not an implausible value.
    on_bounds(&cs, &theta, |c, end| {
        let Ok((k, i)) = c.target else { return true };
        if circular(k, k.info().params[i].name) {
            return true;
        }
        neutral(k, k.info().params[i].name).is_some_and(|v| {
            let v = if c.log { v.ln() } else { v };
            let tol = if c.log { 0.01 } else { 1e-3 * (c.hi - c.lo) };
            (v - end).abs() <= tol
        })
    })
}

/// The base parameters of `fr` that end on a bound of the calibration's range (within 1 % on a
/// log scale; `h_d = 0`, no drive damping, is a value, not a bound): `"v_s = ... at the lower
/// bound ..."`, one each. A calibration that ends there has not found the rig's values.
pub fn base_at_bounds(fr: &FitResult) -> Vec<String> {
    let cs = coords(&Plausible::default(), &[], &Effects::none());
    on_bounds(&cs, &fr.theta, |c, end| !c.log && end == 0.0)
}

/// Options of a fit.
#[derive(Clone, Copy, Debug)]
pub struct FitOptions {
    /// Levenberg–Marquardt iterations at most. Default 12.
    pub max_iter: usize,
    /// Stop when an iteration lowers the cost by less than this share. Default 1e-3.
    pub rel_tol: f64,
    /// Difference the Jacobian afresh at the optimum for the uncertainties (otherwise they
    /// come from the Broyden-updated one). Default true.
    pub final_jacobian: bool,
    /// Gap (RMS z-score, [`gap`]) the fit has to be able to reach: where, at the start of an
    /// iteration, the least-squares minimum of the residuals linearised on the iteration's
    /// Jacobian (differenced, or Broyden-updated along the last step) lies above it, the fit
    /// stops there, not converged, without trying a step. Positive; default infinity (never).
    /// A screen that only asks whether a candidate can lower the gap to a bar sets it to that
    /// bar: once the gap is below it, the check always passes. The fit also stops, not
    /// converged, where the steps so far do not lead there in the iterations left: where the
    /// cost less the largest fall of the cost one iteration has made so far, once for every
    /// iteration left, stays above the bar's cost (steps through a rough cost that gain a
    /// percent each do not close a gap of ten).
    pub reach: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            max_iter: 12,
            rel_tol: 1e-3,
            final_jacobian: true,
            reach: f64::INFINITY,
        }
    }
}

/// A fitted parameter.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Estimate {
    /// `F_s`, or `effect.param`.
    pub name: String,
    /// Unit.
    pub unit: &'static str,
    /// Value.
    pub value: f64,
    /// Standard uncertainty (NaN when not estimable).
    pub stderr: f64,
}

/// The outcome of a fit.
#[derive(Clone, Debug)]
pub struct FitResult {
    /// The fitted model.
    pub model: Model,
    /// The fitted parameters with uncertainties.
    pub estimates: Vec<Estimate>,
    /// Gap on the fitted recordings.
    pub gap: f64,
    /// Number of residuals.
    pub residuals: usize,
    /// Model evaluations (each a simulation of every recording).
    pub evaluations: usize,
    /// Number of fitted coordinates belonging to the effects.
    pub effect_params: usize,
    /// Levenberg–Marquardt iterations made.
    pub iterations: usize,
    /// Whether the fit converged: its last step on a fresh Jacobian lowered the cost by less
    /// than [`FitOptions::rel_tol`] (or no step lowered it), rather than running out of
    /// iterations.
    pub converged: bool,
    /// Whether the fit ended because no step lowered the cost on a fresh Jacobian at its
    /// optimum (a local minimum at the resolution of the cost's roughness), whatever its
    /// [`FitOptions::rel_tol`]: [`refine`] returns such a fit as it is.
    pub stalled: bool,
    /// The fitted coordinates at the optimum (logarithms where fitted on a log scale).
    pub theta: Vec<f64>,
    /// The residuals at the optimum.
    pub z: Vec<f64>,
    /// Their Jacobian in the fitted coordinates (see [`FitResult::jacobian_fresh`]).
    pub jacobian: Mat<f64>,
    /// Whether [`FitResult::jacobian`] was differenced at the optimum (else Broyden-updated).
    pub jacobian_fresh: bool,
    /// The fitted effects.
    pub effects: Vec<EffectKind>,
}

fn cost_of(target: &Target, model: &Model) -> (f64, Vec<f64>) {
    if model.f_c > model.f_s {
        return (f64::INFINITY, vec![]);
    }
    let z = target.residuals(&target.predict(model));
    (z.iter().map(|v| v * v).sum(), z)
}

/// Fits the base parameters, and the fitted parameters of `effects`, starting from `start`
/// (whose effects give the starting values; missing ones start at their defaults).
pub fn fit(target: &Target, start: &Model, effects: &[EffectKind], opts: FitOptions) -> FitResult {
    fit_from(target, prepare(target, start, effects), opts)
}

/// A fit's start evaluated on the fit's recordings ([`prepare`]), so that a caller choosing
/// between starts by their gap does not evaluate the chosen one twice ([`fit_from`]).
pub struct Start {
    /// The start with `effects` enabled: the template the coordinates are set in.
    pub(crate) model: Model,
    pub(crate) effects: Vec<EffectKind>,
    pub(crate) cs: Vec<Coord>,
    pub(crate) theta: Vec<f64>,
    /// Cost and residuals at `theta` (no residuals: a failed simulation).
    pub(crate) at: (f64, Vec<f64>),
}

impl Start {
    /// The start's gap on the recordings it was evaluated on; infinity where a simulation
    /// failed.
    pub fn gap(&self) -> f64 {
        if self.at.1.is_empty() {
            f64::INFINITY
        } else {
            gap(&self.at.1)
        }
    }
}

/// The start of a fit of `effects` from `start` (as [`fit`]), evaluated on `target`: one
/// evaluation, counted in the fit [`fit_from`] makes from it.
pub fn prepare(target: &Target, start: &Model, effects: &[EffectKind]) -> Start {
    let mut model = start.clone();
    for &k in effects {
        model.effects.enable(k);
    }
    let cs = coords(&target.bounds, effects, &model.effects);
    let theta: Vec<f64> = cs.iter().map(|c| c.get(&model)).collect();
    let at = cost_of(target, &build_model(&model, &cs, &theta));
    Start {
        model,
        effects: effects.to_vec(),
        cs,
        theta,
        at,
    }
}

/// [`fit`] from a start [`prepare`]d on the same recordings `target`.
pub fn fit_from(target: &Target, s: Start, opts: FitOptions) -> FitResult {
    levenberg_marquardt(
        target, s.model, &s.effects, s.cs, s.theta, s.at, None, 1, opts,
    )
}

/// [`fit_from`] the start `s` of a model that extends another by effects, with a bar
/// ([`FitOptions::reach`]) checked first on a Jacobian that borrows the columns of the
/// extended model's coordinates (a prefix of the start's) from `known`, that model's Jacobian
/// on the same recordings at its own optimum, and differences only the added effects' columns
/// at the start: `k` evaluations for `k` added coordinates. Where the bar lies out of reach on
/// it, the fit stops there (not converged, that Jacobian in the result, `1 + k` evaluations);
/// else it is [`fit_from`] on a Jacobian differenced afresh at the start (the borrowed columns
/// are of another point: a step on them can lead a narrow valley's fit astray), whose added
/// columns are the ones just differenced: the same fit, `k` evaluations fewer. Where the bar
/// is infinite or `known` does not fit (other rows, more columns than the start has), as
/// [`fit_from`].
pub fn fit_extending(target: &Target, s: Start, known: &Mat<f64>, opts: FitOptions) -> FitResult {
    let (m, p, k0) = (s.at.1.len(), s.cs.len(), known.ncols());
    if !opts.reach.is_finite() || known.nrows() != m || k0 > p || m == 0 || !s.at.0.is_finite() {
        return fit_from(target, s, opts);
    }
    let difference = |cols| fd_jacobian(target, &s.model, &s.cs, &s.theta, &s.at.1, cols);
    let added = difference(k0..p);
    // The first `k0` columns from `left`, the added ones after them.
    let join = |left: &Mat<f64>| {
        Mat::from_fn(m, p, |i, j| {
            if j < k0 {
                left[(i, j)]
            } else {
                added[(i, j - k0)]
            }
        })
    };
    let borrowed = join(known);
    let diag = column_norms(&borrowed);
    let (jac, fresh, evaluations) = if linear_minimum(&borrowed, &s.at.1, &diag) <= opts.reach {
        // Within reach: the added columns are those a fresh Jacobian at the start has;
        // difference the rest.
        (join(&difference(0..k0)), true, 1 + p)
    } else {
        // Out of reach: the iterations stop at their first check, on this Jacobian.
        (borrowed, false, 1 + p - k0)
    };
    levenberg_marquardt(
        target,
        s.model,
        &s.effects,
        s.cs,
        s.theta,
        s.at,
        Some((jac, fresh)),
        evaluations,
        opts,
    )
}

/// Continues the fit `fr` on the same recordings from its optimum: more Levenberg–Marquardt
/// iterations that start on its Jacobian where that is fresh (no evaluation spent on it)
/// instead of differencing it again, as [`fit`] from `fr.model` would. A fit that
/// [`stalled`](FitResult::stalled) is returned as it is (no evaluation, no iteration): its
/// iterations ended on a fresh Jacobian along which no step lowered the cost, which a tighter
/// [`FitOptions::rel_tol`] does not change.
pub fn refine(target: &Target, fr: &FitResult, opts: FitOptions) -> FitResult {
    if fr.stalled && fr.jacobian_fresh {
        return FitResult {
            evaluations: 0,
            iterations: 0,
            ..fr.clone()
        };
    }
    let cs = coords(&target.bounds, &fr.effects, &fr.model.effects);
    let cost = fr.z.iter().map(|v| v * v).sum();
    levenberg_marquardt(
        target,
        fr.model.clone(),
        &fr.effects,
        cs,
        fr.theta.clone(),
        (cost, fr.z.clone()),
        fr.jacobian_fresh.then(|| (fr.jacobian.clone(), true)),
        0,
        opts,
    )
}

/// The iterations of [`fit`] from `theta` (cost and residuals `at`, already evaluated and
/// counted in `evaluations`), on the first Jacobian `jac0` where given (with whether it is a
/// fresh finite-difference Jacobian there), else on a new one.
#[allow(clippy::too_many_arguments)]
fn levenberg_marquardt(
    target: &Target,
    model: Model,
    effects: &[EffectKind],
    cs: Vec<Coord>,
    mut theta: Vec<f64>,
    at: (f64, Vec<f64>),
    jac0: Option<(Mat<f64>, bool)>,
    mut evaluations: usize,
    opts: FitOptions,
) -> FitResult {
    let p = cs.len();
    let (mut cost, mut z) = at;
    let build = |th: &[f64]| build_model(&model, &cs, th);
    let mut lambda = 1e-2;
    let fd_jacobian =
        |theta: &[f64], z: &[f64]| fd_jacobian(target, &model, &cs, theta, z, 0..cs.len());
    let given = jac0.is_some();
    // Whether `jac` is a fresh finite-difference Jacobian (else a Broyden update of one).
    let (mut jac, mut fresh) = jac0.unwrap_or_else(|| (Mat::zeros(z.len(), p), false));
    let mut iter = 0;
    let mut converged = false;
    let mut stalled = false;
    // The largest fall of the cost an iteration has made so far (FitOptions::reach).
    let mut best_gain = 0.0_f64;
    while iter < opts.max_iter && cost.is_finite() && !z.is_empty() {
        iter += 1;
        if iter == 1 && !given {
            jac = fd_jacobian(&theta, &z);
            evaluations += p;
            fresh = true;
        }
        let m = z.len();
        let diag = column_norms(&jac);
        if opts.reach.is_finite() {
            // Out of reach at the pace of the steps so far (after one accepted step), or on
            // the residuals linearised on this Jacobian.
            let bar = opts.reach * opts.reach * m as f64;
            if out_of_pace(cost, best_gain, opts.max_iter - iter + 1, bar) {
                break;
            }
            if linear_minimum(&jac, &z, &diag) > opts.reach {
                break;
            }
        }
        let mut accepted = None;
        for _ in 0..4 {
            let delta = damped_step(&jac, &z, &diag, lambda);
            let trial: Vec<f64> = (0..p)
                .map(|j| (theta[j] + delta[(j, 0)]).clamp(cs[j].lo, cs[j].hi))
                .collect();
            let (c1, z1) = cost_of(target, &build(&trial));
            evaluations += 1;
            if c1 < cost && z1.len() == m {
                accepted = Some((trial, c1, z1));
                lambda = (lambda / 3.0).max(1e-7);
                break;
            }
            lambda *= 4.0;
        }
        match accepted {
            Some((trial, c1, z1)) => {
                let rel = (cost - c1) / cost;
                best_gain = best_gain.max(cost - c1);
                // Broyden's rank-one update: J += (Δz − J δ) δᵀ / δᵀδ, instead of p new runs.
                let d: Vec<f64> = (0..p).map(|j| trial[j] - theta[j]).collect();
                let dd: f64 = d.iter().map(|x| x * x).sum();
                if dd > 0.0 {
                    for i in 0..m {
                        let jd: f64 = (0..p).map(|j| jac[(i, j)] * d[j]).sum();
                        let u = (z1[i] - z[i] - jd) / dd;
                        for j in 0..p {
                            jac[(i, j)] += u * d[j];
                        }
                    }
                }
                let was_fresh = fresh;
                fresh = false;
                theta = trial;
                cost = c1;
                z = z1;
                if rel <= opts.rel_tol {
                    if was_fresh {
                        converged = true;
                        break;
                    }
                    // Small progress on an updated Jacobian: check with a fresh one first.
                    jac = fd_jacobian(&theta, &z);
                    evaluations += p;
                    fresh = true;
                }
            }
            // An updated Jacobian that no longer points downhill: difference afresh once.
            None if !fresh => {
                jac = fd_jacobian(&theta, &z);
                evaluations += p;
                fresh = true;
                lambda = 1e-2;
            }
            None => {
                // No step lowers the cost on a fresh Jacobian: a (local) minimum.
                converged = true;
                stalled = true;
                break;
            }
        }
    }
    if opts.final_jacobian && !fresh && !z.is_empty() && cost.is_finite() {
        jac = fd_jacobian(&theta, &z);
        evaluations += p;
        fresh = true;
    }
    let model = build(&theta);
    FitResult {
        estimates: estimates(&cs, &theta, cost, &jac),
        effect_params: effect_params(effects, &model.effects),
        model,
        gap: gap(&z),
        residuals: z.len(),
        evaluations,
        iterations: iter,
        converged,
        stalled,
        theta,
        z,
        jacobian: jac,
        jacobian_fresh: fresh,
        effects: effects.to_vec(),
    }
}

/// Whether a fit at `cost` cannot reach the cost `bar` in the `left` iterations it has, at the
/// pace of the largest fall of the cost one of its iterations has made so far (`best_gain`;
/// none yet where it is 0): `cost − left · best_gain > bar` ([`FitOptions::reach`]).
fn out_of_pace(cost: f64, best_gain: f64, left: usize, bar: f64) -> bool {
    best_gain > 0.0 && cost - left as f64 * best_gain > bar
}

/// Each column's square norm (at least 1e-12): the Levenberg–Marquardt scaling.
fn column_norms(jac: &Mat<f64>) -> Vec<f64> {
    (0..jac.ncols())
        .map(|j| {
            (0..jac.nrows())
                .map(|i| jac[(i, j)].powi(2))
                .sum::<f64>()
                .max(1e-12)
        })
        .collect()
}

/// The Levenberg–Marquardt step `δ` (a `p × 1` column) minimising `|z + J δ|² + λ Σ diag_j δ_j²`
/// on `jac`, solved as the least-squares problem of `J` stacked on `√(λ diag)`.
fn damped_step(jac: &Mat<f64>, z: &[f64], diag: &[f64], lambda: f64) -> Mat<f64> {
    let (m, p) = (z.len(), diag.len());
    let a = Mat::from_fn(m + p, p, |i, j| {
        if i < m {
            jac[(i, j)]
        } else if i - m == j {
            (lambda * diag[j]).sqrt()
        } else {
            0.0
        }
    });
    let b = Mat::from_fn(m + p, 1, |i, _| if i < m { -z[i] } else { 0.0 });
    a.col_piv_qr().solve_lstsq(&b)
}

/// The gap at the least-squares minimum of the residuals `z + J δ` linearised on `jac`
/// (`δ` unbounded, the step of [`damped_step`] with a damping of 1e-10 against rank
/// deficiency): the lowest gap a Gauss–Newton step from here predicts.
fn linear_minimum(jac: &Mat<f64>, z: &[f64], diag: &[f64]) -> f64 {
    let (m, p) = (z.len(), diag.len());
    let delta = damped_step(jac, z, diag, 1e-10);
    let r: Vec<f64> = (0..m)
        .map(|i| z[i] + (0..p).map(|j| jac[(i, j)] * delta[(j, 0)]).sum::<f64>())
        .collect();
    gap(&r)
}

/// `fr` with a finite-difference Jacobian at its optimum, and the uncertainties from it, where
/// its Jacobian is a Broyden update (`p` model evaluations, counted in `evaluations`); `fr`
/// itself where it is fresh already. Gives what [`fit`] with [`FitOptions::final_jacobian`]
/// gives, so a fit whose uncertainties may not be needed can defer the cost.
pub fn with_fresh_jacobian(target: &Target, mut fr: FitResult) -> FitResult {
    if fr.jacobian_fresh || fr.z.is_empty() || !fr.gap.is_finite() {
        return fr;
    }
    let cs = coords(&target.bounds, &fr.effects, &fr.model.effects);
    // The fitted model holds every coordinate, and its effects enabled: the template.
    fr.jacobian = fd_jacobian(target, &fr.model, &cs, &fr.theta, &fr.z, 0..cs.len());
    fr.evaluations += cs.len();
    fr.jacobian_fresh = true;
    let cost: f64 = fr.z.iter().map(|v| v * v).sum();
    fr.estimates = estimates(&cs, &fr.theta, cost, &fr.jacobian);
    fr
}

/// Number of fitted coordinates that belong to `effects` (beside the four base parameters).
pub fn effect_params(effects: &[EffectKind], fx: &Effects) -> usize {
    coords(&Plausible::default(), effects, fx)
        .iter()
        .filter(|c| c.target.is_ok())
        .count()
}

/// `template` with the coordinates `cs` set to `theta`.
fn build_model(template: &Model, cs: &[Coord], theta: &[f64]) -> Model {
    let mut m = template.clone();
    for (c, &t) in cs.iter().zip(theta) {
        c.set(&mut m, t);
    }
    m
}

/// Forward-difference Jacobian of the residuals `z` (at `theta`) in the coordinates `cs`, the
/// given columns of it: the perturbed models in one parallel batch, each step taken
/// inward at an upper bound.
pub(crate) fn fd_jacobian(
    target: &Target,
    template: &Model,
    cs: &[Coord],
    theta: &[f64],
    z: &[f64],
    columns: std::ops::Range<usize>,
) -> Mat<f64> {
    let n = columns.len();
    let cols: Vec<Vec<f64>> = columns
        .into_par_iter()
        .map(|j| {
            let mut th = theta.to_vec();
            let c = &cs[j];
            let h = if th[j] + c.step > c.hi {
                -c.step
            } else {
                c.step
            };
            th[j] += h;
            let (_, zj) = cost_of(target, &build_model(template, cs, &th));
            if zj.len() != z.len() {
                return vec![0.0; z.len()];
            }
            zj.iter().zip(z).map(|(a, b)| (a - b) / h).collect()
        })
        .collect();
    Mat::from_fn(z.len(), n, |i, j| cols[j][i])
}

/// The fitted parameters at `theta`, with standard uncertainties from `(JᵀJ)⁻¹ s²`,
/// `s² = cost/(m − p)`, where the `m` residuals outnumber the `p` coordinates.
fn estimates(cs: &[Coord], theta: &[f64], cost: f64, jac: &Mat<f64>) -> Vec<Estimate> {
    let p = cs.len();
    let m = jac.nrows();
    let mut stderr = vec![f64::NAN; p];
    if m > p && jac.ncols() == p {
        let jtj = Mat::from_fn(p, p, |a, b| {
            (0..m).map(|i| jac[(i, a)] * jac[(i, b)]).sum::<f64>()
        });
        let s2 = cost / (m - p) as f64;
        let inv = jtj.partial_piv_lu().solve(Mat::<f64>::identity(p, p));
        for j in 0..p {
            let v = inv[(j, j)] * s2;
            if v.is_finite() && v >= 0.0 {
                stderr[j] = v.sqrt();
            }
        }
    }
    cs.iter()
        .zip(theta)
        .zip(&stderr)
        .map(|((c, &t), &s)| {
            let th = t.clamp(c.lo, c.hi);
            let value = if c.log { th.exp() } else { th };
            Estimate {
                name: c.name.clone(),
                unit: c.unit,
                value,
                stderr: if c.log { value * s } else { s },
            }
        })
        .collect()
}

/// The fit of `fr` refitted to a subset of its residuals (`keep`, one flag per row): one
/// Levenberg–Marquardt step from its optimum on those rows of its Jacobian,
/// `[J_k; √λ D] δ = [−z_k; 0]` with `λ = `[`REFIT_DAMPING`] and Marquardt's scaling, then
/// `step` times `δ` (the caller halves it where the subset's cost rises). At the full optimum
/// the gradient of the whole cost vanishes, so the subset's optimum lies where the left-out
/// rows pulled it from, which one Gauss–Newton step finds to first order; the damping keeps
/// directions that only the left-out rows determine where they are. The fitted coordinates
/// before `first_free` are held at the fit's values (their columns left out of the step; 0:
/// none): the base parameters ([`BASE_FITTED`]) come first, then each effect's, in the order of
/// [`FitResult::effects`].
pub fn refit_rows(
    bounds: &Plausible,
    fr: &FitResult,
    start: &Model,
    keep: &[bool],
    first_free: usize,
    step: f64,
) -> Model {
    let cs = coords(bounds, &fr.effects, &fr.model.effects);
    let p = cs.len();
    let mut model = start.clone();
    for &k in &fr.effects {
        model.effects.enable(k);
    }
    let mut theta = fr.theta.clone();
    let delta = (fr.jacobian.ncols() == p)
        .then(|| refit_delta(&fr.jacobian, &fr.z, keep, first_free))
        .flatten();
    if let Some(delta) = delta {
        for j in 0..p {
            let d = delta[j];
            if d.is_finite() {
                theta[j] = (theta[j] + step * d).clamp(cs[j].lo, cs[j].hi);
            }
        }
    }
    for (c, &t) in cs.iter().zip(&theta) {
        c.set(&mut model, t);
    }
    model
}

/// The step of [`refit_rows`] for residuals `z` and their Jacobian `jac` (one row per residual):
/// `[J_k; √λ D] δ = [−z_k; 0]` on the rows `keep` marks, the columns before `first_free` held
/// (`None` where the shapes do not match or no row is kept). Linear in `z`: the held-out
/// residuals of a fold refit to first order are `z + J δ(z)`, which the detection limits
/// ([`super::limits`]) use on an effect's signature.
pub fn refit_delta(
    jac: &Mat<f64>,
    z: &[f64],
    keep: &[bool],
    first_free: usize,
) -> Option<Vec<f64>> {
    let p = jac.ncols();
    let rows: Vec<usize> = (0..keep.len()).filter(|&i| keep[i]).collect();
    if rows.is_empty() || jac.nrows() != keep.len() || z.len() != keep.len() || p == 0 {
        return None;
    }
    let m = rows.len();
    let diag: Vec<f64> = (0..p)
        .map(|j| {
            (0..jac.nrows())
                .map(|i| jac[(i, j)].powi(2))
                .sum::<f64>()
                .max(1e-12)
        })
        .collect();
    let a = Mat::from_fn(m + p, p, |i, j| {
        if i < m {
            if j < first_free {
                0.0
            } else {
                jac[(rows[i], j)]
            }
        } else if i - m == j {
            (REFIT_DAMPING * diag[j]).sqrt()
        } else {
            0.0
        }
    });
    let b = Mat::from_fn(m + p, 1, |i, _| if i < m { -z[rows[i]] } else { 0.0 });
    let delta = a.col_piv_qr().solve_lstsq(&b);
    Some((0..p).map(|j| delta[(j, 0)]).collect())
}

/// Damping of [`refit_rows`], relative to the diagonal of the full `JᵀJ`.
pub const REFIT_DAMPING: f64 = 1e-2;

/// Evaluates a model on a set: its gap.
pub fn evaluate(target: &Target, model: &Model) -> f64 {
    let (_, z) = cost_of(target, model);
    if z.is_empty() { f64::INFINITY } else { gap(&z) }
}

/// The values the global scan of [`starts`] tries for one fitted effect parameter, over its
/// plausible range: the sensor's resonance at ten frequencies from 20 Hz to 20 kHz (a load cell
/// carrying the frame rings at tens of hertz), each at a light, a moderate and a
/// critical-like damping (0.05, 0.3, 0.7); the load modulation's phase with the velocity and
/// against it (±90°); the others at four or five points of their range.
/// The actuator's resonance has a scan of its own ([`actuator_scan`]).
fn scan_values(kind: EffectKind, param: &str) -> Vec<f64> {
    use EffectKind as K;
    match (kind, param) {
        (K::Aging, "b") => vec![0.02, 0.05, 0.1, 0.2],
        (K::SensorDynamics, "f_n") => logspace(20.0, 2e4, 10),
        (K::SensorDynamics, "zeta") => vec![0.05, 0.3, 0.7],
        (K::NormalCoupling, "k_n") => logspace(1e6, 1e8, 5),
        // With the velocity or against it: the sign of the mean friction change; the fit
        // then turns the phase towards the displacement.
        (K::NormalCoupling, "phase") => vec![-90.0, 90.0],
        (K::Viscous, "h_v") => vec![20.0, 50.0, 100.0, 200.0],
        (K::StribeckShape, "delta") => vec![0.5, 1.0, 1.5, 3.0],
        (K::Presliding, "spread") => vec![0.3, 0.6, 0.9],
        (K::FrictionalLag, "tau") => logspace(1e-4, 1e-2, 4),
        // A memory of 0.1 to 10 µm of slip: 0.1 to 10 ms at 1 mm/s.
        (K::FrictionalLag, "length") => logspace(1e-7, 1e-5, 4),
        _ => vec![],
    }
}

/// `base` with `kind` switched on at its neutral values ([`neutral`]): the base model, or
/// nearly so.
pub fn neutral_start(base: &Model, kind: EffectKind, form: f64) -> Model {
    let mut m0 = base.clone();
    m0.effects.enable(kind);
    let _ = m0.effects.set(kind, form_param(kind), form);
    for p in kind.info().params {
        if let Some(v) = neutral(kind, p.name) {
            let _ = m0.effects.set(kind, p.name, v);
        }
    }
    m0
}

/// Starting values for an effect's fitted parameters, from a global scan over their plausible
/// ranges (every combination: a sensor's resonance at ten frequencies from 20 Hz to 20 kHz, each
/// at three dampings; the others at three to five values; the actuator's resonance from the
/// gain scan of [`actuator_scan`], 100 Hz to 100 kHz in steps of 1 %) on the calibrated
/// parameters of `base`, scored on up to [`SCAN_RECORDINGS`] recordings (half of them those
/// `base` misses most), with
/// the neutral start ([`neutral`]) among them; for the drive ripple, the wavelength and
/// amplitude read off the recorded drive position, where recorded. The scan's best start is
/// refined locally by [`fit`] (in `diagnose`, first by a screening fit, about whose optimum a
/// sensor's resonance is then scanned densely: [`line_search`]). As the scan holds the
/// neutral start, its best is not worse than the base model on the scored recordings;
/// `diagnose` reports the base model for a candidate whose fit still ends worse on all of
/// them.
///
/// The best start comes first. Where it is a per-frequency scan's ([`actuator_scan`],
/// [`normal_scan`]), the best of the generic grid follows: the scan frees parameters the grid
/// holds (the load path's delay), and a start that scores better on the scan's subset can
/// still lead the fit to a worse optimum than the grid's fewer degrees of freedom do, so
/// `diagnose` screens the candidate from both.
pub fn starts(target: &Target, base: &FitResult, kind: EffectKind, form: f64) -> Vec<Model> {
    let m0 = neutral_start(&base.model, kind, form);
    let mut candidates: Vec<Model> = vec![m0.clone()];
    if kind == EffectKind::DriveRipple
        && let Some((a, lambda)) = ripple_from_drive(&target.recs)
    {
        let mut m = m0.clone();
        let _ = m.effects.set(kind, "a", a.clamp(0.0, 1e-3));
        let (lo, hi) = target.bounds.range(kind, "wavelength");
        let _ = m.effects.set(kind, "wavelength", lambda.clamp(lo, hi));
        candidates.push(m);
    }
    // The scan only chooses a start: score the starts on a subset of the recordings, at the
    // search fidelity (the screen and the fit that follow are full).
    let mut sub = scan_subset(target, &base.z);
    sub.fidelity = Fidelity::Search;
    let scanned = match kind {
        EffectKind::ActuatorResponse => actuator_scan(&sub, &m0),
        EffectKind::NormalCoupling => normal_scan(&sub, &m0),
        _ => None,
    };
    let from_scan = scanned.is_some().then_some(candidates.len());
    candidates.extend(scanned);
    let mut grid: Vec<Vec<(&str, f64)>> = vec![vec![]];
    for p in kind
        .info()
        .params
        .iter()
        .filter(|p| p.fitted && m0.effects.uses(kind, p.name))
    {
        // The scan's values within the campaign's plausible range, its ends added where the
        // range cuts some off.
        let (lo, hi) = target.bounds.range(kind, p.name);
        let all_vals = scan_values(kind, p.name);
        let mut vals: Vec<f64> = all_vals
            .iter()
            .copied()
            .filter(|v| (lo..=hi).contains(v))
            .collect();
        if all_vals.iter().any(|&v| v < lo) {
            vals.insert(0, lo);
        }
        if all_vals.iter().any(|&v| v > hi) {
            vals.push(hi);
        }
        if vals.is_empty() {
            continue;
        }
        grid = grid
            .into_iter()
            .flat_map(|g| {
                vals.iter().map(move |&v| {
                    let mut g = g.clone();
                    g.push((p.name, v));
                    g
                })
            })
            .collect();
    }
    if grid.iter().any(|g| !g.is_empty()) {
        // Viscous friction is partly absorbed by the base parameters: a base fit to a campaign
        // whose stick-slip dies out as the drive speeds up lowers the breakaway level (F_s, v_s)
        // until stick-slip fades everywhere, a basin the viscous term cannot leave in a few
        // steps. Its grid is scanned from the nominal F_s, v_s and h_d as well, with F_c
        // lowered by the term's force at the campaign's mean drive velocity (the sliding force
        // kept).
        let v_mean =
            target.recs.iter().map(|r| r.params.v_d).sum::<f64>() / target.recs.len() as f64;
        let nominal = Params::default();
        let age = (kind == EffectKind::Aging)
            .then(|| typical_stick_time(target))
            .flatten();
        for g in grid {
            let mut m = m0.clone();
            for &(n, v) in &g {
                let _ = m.effects.set(kind, n, v);
            }
            if kind == EffectKind::Viscous {
                let mut mn = m.clone();
                (mn.f_s, mn.v_s, mn.h_d) = (nominal.f_s, nominal.v_s, nominal.h_d);
                let h_v = m.effects.get(kind, "h_v").unwrap_or(0.0);
                mn.f_c = (m.f_c - h_v * v_mean).max(0.5 * m.f_c);
                candidates.push(mn);
            }
            // Ageing is absorbed by the base fit the same way: its F_s takes the aged level at
            // the campaign's typical contact age, and any ageing added on top of it overshoots.
            // Its grid is scanned with F_s lowered to keep that level as well.
            if kind == EffectKind::Aging
                && let (Some(age), Some(b), Some(theta_0)) = (
                    age,
                    m.effects.get(kind, "b"),
                    m.effects.get(kind, "theta_0"),
                )
            {
                let mut ma = m.clone();
                ma.f_s = (m.f_s / (1.0 + b * (age / theta_0).ln_1p())).max(m.f_c);
                candidates.push(ma);
            }
            candidates.push(m);
        }
    }
    if candidates.len() == 1 {
        return vec![m0];
    }
    let costs: Vec<f64> = candidates.par_iter().map(|m| evaluate(&sub, m)).collect();
    let lowest = |skip: Option<usize>| {
        (0..costs.len())
            .filter(|&i| Some(i) != skip)
            .min_by(|&a, &b| costs[a].total_cmp(&costs[b]))
    };
    let best = lowest(None).expect("candidates");
    let mut out = vec![candidates[best].clone()];
    if from_scan == Some(best)
        && let Some(grid_best) = lowest(from_scan)
    {
        out.push(candidates[grid_best].clone());
    }
    out
}

/// The median stick time of the units that stick-slip (cycle period less slip time) \[s\]: the
/// contact age at a typical breakaway, to which a base fit's `F_s` absorbs dwell-time ageing.
/// `None` where no unit has both.
fn typical_stick_time(target: &Target) -> Option<f64> {
    let t = crate::campaign::check::median(
        target
            .measured
            .iter()
            .map(|m| m.get(Feature::Period) - m.get(Feature::SlipTime))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect(),
    );
    t.is_finite().then_some(t)
}

/// The forcing frequencies of `sub`'s vibrated units, sorted, each once.
fn forcing_frequencies(sub: &Target) -> Vec<f64> {
    let mut freqs: Vec<f64> = sub
        .units
        .iter()
        .map(|u| u.1.freq)
        .filter(|&f| f > 0.0)
        .collect();
    freqs.sort_by(f64::total_cmp);
    freqs.dedup();
    freqs
}

/// Per forcing frequency of `freqs`: its vibrated recordings of `sub` with the recordings of
/// their references.
fn frequency_groups<'a>(sub: &Target<'a>, freqs: &[f64]) -> Vec<Target<'a>> {
    freqs
        .iter()
        .map(|&f| {
            let mut pick: Vec<usize> = vec![];
            for (u, &(i, st)) in sub.units.iter().enumerate() {
                if st.freq == f {
                    pick.push(i);
                    if let Some(r) = sub.reference[u] {
                        pick.push(sub.units[r].0);
                    }
                }
            }
            pick.sort_unstable();
            pick.dedup();
            sub.sub(pick.into_iter().map(|i| sub.recs[i]).collect())
        })
        .collect()
}

/// Phases (degrees) [`normal_scan`] tabulates at each forcing frequency: every 30°.
pub const NORMAL_PHASES: usize = 12;

/// Strengths `k_n` [`normal_scan`] tabulates at each forcing frequency: 1e6 to 1e8 N/m in
/// steps of a factor 1.8 (the load modulation's effect on the friction grows about as fast as
/// `k_n`, so the global scan's steps of 3.2 pass its optimum by).
pub const NORMAL_STRENGTHS: usize = 9;

/// The start of `normal_coupling` from a scan of the load modulation's phase at each forcing
/// frequency.
///
/// At a recording's frequency `f` the effect acts through its strength `k_n` and the phase
/// `ψ(f) = φ − 360° f t_d` alone, so the scan's cost is a sum over the forcing frequencies of
/// the subset `sub`, each term a function of `(k_n, ψ)`. Each term is tabulated at
/// [`NORMAL_STRENGTHS`] values of `k_n` and [`NORMAL_PHASES`] phases (the recordings at
/// that frequency with their references), interpolated linearly in the phase (periodic), and
/// the sum minimised over `k_n`, `φ` in steps of 5° and the delay `t_d` from 0 to its
/// plausible end in steps that turn the phase at the highest frequency by 5°. A load path
/// with a delay, whose phase falls with the frequency, is then found as a whole, where a grid
/// of `(φ, t_d)` simulated start by start would need hundreds of runs. `None` where the subset
/// does not vibrate.
pub fn normal_scan(sub: &Target, m0: &Model) -> Option<Model> {
    let kind = EffectKind::NormalCoupling;
    let freqs = forcing_frequencies(sub);
    if freqs.is_empty() {
        return None;
    }
    let groups = frequency_groups(sub, &freqs);
    let strengths = logspace(1e6, 1e8, NORMAL_STRENGTHS);
    let phase = |j: usize| -180.0 + 360.0 * j as f64 / NORMAL_PHASES as f64;
    let jobs: Vec<(usize, usize, usize)> = (0..freqs.len())
        .flat_map(|i| {
            (0..strengths.len()).flat_map(move |k| (0..NORMAL_PHASES).map(move |j| (i, k, j)))
        })
        .collect();
    let costs: Vec<f64> = jobs
        .par_iter()
        .map(|&(i, k, j)| {
            let mut m = m0.clone();
            let _ = m.effects.set(kind, "k_n", strengths[k]);
            let _ = m.effects.set(kind, "phase", phase(j));
            let _ = m.effects.set(kind, "delay", 0.0);
            let (ssq, _) = cost_of(&groups[i], &m);
            if ssq.is_finite() { ssq } else { f64::INFINITY }
        })
        .collect();
    // costs[(i * strengths + k) * NORMAL_PHASES + j], interpolated periodically in the phase.
    let at = |i: usize, k: usize, psi: f64| -> f64 {
        let x = (psi + 180.0).rem_euclid(360.0) / 360.0 * NORMAL_PHASES as f64;
        let j0 = (x.floor() as usize).min(NORMAL_PHASES - 1);
        let w = x - j0 as f64;
        let j1 = (j0 + 1) % NORMAL_PHASES;
        let base = (i * strengths.len() + k) * NORMAL_PHASES;
        let (a, b) = (costs[base + j0], costs[base + j1]);
        if !(a.is_finite() && b.is_finite()) {
            return f64::INFINITY;
        }
        a + (b - a) * w
    };
    let (_, d_hi) = sub.bounds.range(kind, "delay");
    let f_max = freqs[freqs.len() - 1];
    let d_step = 5.0 / (360.0 * f_max);
    let n_d = (d_hi / d_step).floor() as usize;
    let mut best = (f64::INFINITY, strengths[0], 0.0, 0.0);
    for (k, &k_n) in strengths.iter().enumerate() {
        for p in 0..72 {
            let phi = -180.0 + 5.0 * p as f64;
            for d in 0..=n_d {
                // By index: the grid's values are never accumulated.
                let delay = d as f64 * d_step;
                let c: f64 = freqs
                    .iter()
                    .enumerate()
                    .map(|(i, &f)| at(i, k, phi - 360.0 * f * delay))
                    .sum();
                if c < best.0 {
                    best = (c, k_n, phi, delay);
                }
            }
        }
    }
    let mut m = m0.clone();
    let _ = m.effects.set(kind, "k_n", best.1);
    let _ = m.effects.set(kind, "phase", best.2);
    let _ = m.effects.set(kind, "delay", best.3);
    Some(m)
}

/// Gains the actuator scan ([`actuator_scan`]) tabulates at each forcing frequency, evenly in
/// `ln A` from [`ACTUATOR_GAIN_MIN`] to [`ACTUATOR_GAIN_MAX`] (steps of 20 %), with the neutral
/// gain 1 besides.
pub const ACTUATOR_GAINS: usize = 34;
/// Smallest gain of the actuator scan: the substrate moving at a twentieth of its nominal
/// amplitude, as good as no vibration for the features.
pub const ACTUATOR_GAIN_MIN: f64 = 0.05;
/// Largest gain of the actuator scan: twenty times the nominal amplitude turns every tested
/// `v_a/v_d` of 0.05 or more into elimination.
pub const ACTUATOR_GAIN_MAX: f64 = 20.0;

/// The start of `actuator_response` from a scan of the gain at each forcing frequency.
///
/// The effect changes a recording only through its gain `A(f)` at the recording's own
/// frequency ([`actuator_gain`]), so the scan's cost is a sum over the forcing frequencies of
/// the subset `sub`, each term a function of one gain. Each term is tabulated at
/// [`ACTUATOR_GAINS`] gains from 0.05 to 20 (each realised by a resonance next to that
/// frequency; the recordings at that frequency with their references), interpolated linearly
/// in `ln A`, and the sum minimised over a fine grid of `(f_r, ζ)`: `f_r` from 100 Hz to
/// 100 kHz in steps of 1 %, `ζ` at 15 values from 0.01 to 2. A resonance as sharp as a
/// saddle's (`ζ` of a few hundredths, within 5 % of a tested frequency) is then found wherever
/// it lies, where a grid of the resonance itself would need hundreds of simulated starts.
/// `None` where the subset does not vibrate.
pub fn actuator_scan(sub: &Target, m0: &Model) -> Option<Model> {
    let kind = EffectKind::ActuatorResponse;
    let freqs = forcing_frequencies(sub);
    if freqs.is_empty() {
        return None;
    }
    let groups = frequency_groups(sub, &freqs);
    let (f_lo, f_hi) = sub.bounds.range(kind, "f_r");
    // A resonance that gives gain `g` at `f`: below `f` for g < 1 (`(f/f_r)² = 1 + 1/g`), above
    // it for g > 1 (`(f/f_r)² = 1 − 1/g`), lightly damped; the neutral start `m0` for 1. The
    // gain tabulated is the one realised (the bounds of `f_r` may cut it).
    // The table is of gains, whatever the form; it is realised by the resonance.
    let first_order = m0.effects.get(kind, "form") == Some(1.0);
    let realise = |f: f64, g: f64| -> Model {
        let mut m = m0.clone();
        let _ = m.effects.set(kind, "form", 0.0);
        if g != 1.0 {
            let q2 = if g < 1.0 {
                1.0 + 1.0 / g
            } else {
                1.0 - 1.0 / g
            };
            let _ = m
                .effects
                .set(kind, "f_r", (f / q2.sqrt()).clamp(f_lo, f_hi));
            let _ = m.effects.set(kind, "zeta", 0.01);
        }
        m
    };
    let mut gains = logspace(ACTUATOR_GAIN_MIN, ACTUATOR_GAIN_MAX, ACTUATOR_GAINS);
    gains.push(1.0);
    let jobs: Vec<(usize, f64)> = (0..freqs.len())
        .flat_map(|i| gains.iter().map(move |&g| (i, g)))
        .collect();
    let costs: Vec<(usize, f64, f64)> = jobs
        .par_iter()
        .map(|&(i, g)| {
            let m = realise(freqs[i], g);
            let (f_r, zeta) = (m.effects.get(kind, "f_r"), m.effects.get(kind, "zeta"));
            let gain = actuator_gain(freqs[i], f_r.unwrap_or(f_hi), zeta.unwrap_or(1.0));
            let (ssq, _) = cost_of(&groups[i], &m);
            let ssq = if ssq.is_finite() { ssq } else { f64::INFINITY };
            (i, gain.ln(), ssq)
        })
        .collect();
    // Per frequency, the table (ln A, cost) sorted by ln A, one entry per realised gain.
    let tables: Vec<Vec<(f64, f64)>> = (0..freqs.len())
        .map(|i| {
            let mut t: Vec<(f64, f64)> = costs
                .iter()
                .filter(|c| c.0 == i)
                .map(|c| (c.1, c.2))
                .collect();
            t.sort_by(|a, b| a.0.total_cmp(&b.0));
            t.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-9);
            t
        })
        .collect();
    let at = |t: &[(f64, f64)], x: f64| -> f64 {
        let k = t.partition_point(|p| p.0 < x);
        if k == 0 {
            return t[0].1;
        }
        if k == t.len() {
            return t[t.len() - 1].1;
        }
        let (a, b) = (t[k - 1], t[k]);
        if !(a.1.is_finite() && b.1.is_finite()) {
            return f64::INFINITY;
        }
        a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
    };
    const ZETAS: [f64; 15] = [
        0.01, 0.015, 0.02, 0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0,
    ];
    // `f_r` in steps of at most 1 %.
    let n_f = ((f_hi / f_lo).ln() / 1.01f64.ln()).ceil() as usize;
    let mut best = (f64::INFINITY, f_hi, 1.0);
    // One pole: the corner alone.
    let zetas: &[f64] = if first_order { &[1.0] } else { &ZETAS };
    for f_r in logspace(f_lo, f_hi, n_f + 1) {
        for &zeta in zetas {
            let form = if first_order { 1.0 } else { 0.0 };
            let gain = |f: f64| response_gain(form, f, f_r, zeta);
            let c: f64 = freqs
                .iter()
                .zip(&tables)
                .map(|(&f, t)| at(t, gain(f).ln()))
                .sum();
            if c < best.0 {
                best = (c, f_r, zeta);
            }
        }
    }
    let mut m = m0.clone();
    let _ = m.effects.set(kind, "f_r", best.1);
    if !first_order {
        let _ = m.effects.set(kind, "zeta", best.2);
    }
    Some(m)
}

/// Points of [`line_search`]: a resonance frequency from half to twice its fitted value in
/// steps of 4 %.
pub const LINE_POINTS: usize = 36;

/// The resonance frequencies [`line_search`] scans: the sensor's `f_n`. A lightly damped
/// sensor's cost along `f_n` is a narrow valley (about ±6 % wide) between a cliff below and a
/// slope above, so a local fit started outside it slides down the slope, away from it.
fn line_param(kind: EffectKind) -> Option<&'static str> {
    (kind == EffectKind::SensorDynamics).then_some("f_n")
}

/// A dense scan of the resonance frequency of effect `kind` in the fit `fr` (the sensor's `f_n`;
/// nothing for the other effects, the actuator's resonance has [`actuator_scan`]) about its
/// optimum, the other parameters held at the fit's values: [`LINE_POINTS`] values from half to
/// twice it (within the range a fit allows, 10 Hz to 20 kHz), scored on `target`, the fit's own
/// recordings, at the search fidelity ([`Fidelity::Search`]: the point found only starts a full
/// fit). Returns the best point where it lies below the fit's own gap at that fidelity (a
/// start for a new fit), else `None`, and the number of models evaluated (each a simulation of
/// every recording of `target`, the fit's own point among them). Where the global scan of [`starts`] (steps of a factor 2.15) put the start on
/// the slope next to a narrow valley, the local fit stays on the slope; this finds the valley
/// within a factor 2 of the fit.
pub fn line_search(target: &Target, fr: &FitResult, kind: EffectKind) -> (Option<Model>, usize) {
    let Some(name) = line_param(kind) else {
        return (None, 0);
    };
    let Some(v0) = fr.model.effects.get(kind, name) else {
        return (None, 0);
    };
    let target = &target.at(Fidelity::Search);
    let (lo, hi) = target.bounds.range(kind, name);
    let values: Vec<f64> = logspace(0.5 * v0, 2.0 * v0, LINE_POINTS)
        .into_iter()
        .filter(|v| (lo..=hi).contains(v))
        .collect();
    let gaps: Vec<(f64, Model)> = values
        .par_iter()
        .map(|&v| {
            let mut m = fr.model.clone();
            let _ = m.effects.set(kind, name, v);
            (evaluate(target, &m), m)
        })
        .collect();
    // The fit's own point at the same fidelity, which the line's points must beat.
    let own = evaluate(target, &fr.model);
    let evaluations = gaps.len() + 1;
    // The lowest below the fit's gap; the first of equals (values in increasing order).
    let best = gaps
        .into_iter()
        .filter(|(g, _)| *g < own)
        .reduce(|a, b| if b.0 < a.0 { b } else { a });
    (best.map(|b| b.1), evaluations)
}

/// Most recordings [`starts`] scores its starts on.
pub const SCAN_RECORDINGS: usize = 8;

/// The recordings a start scan is scored on: all of them up to [`SCAN_RECORDINGS`]; else half
/// of that many where the model the candidate extends misses most (largest gap over the
/// recording's residuals `z`, rows as [`Target::row_recordings`]), the rest taken evenly over
/// the others in their order (the campaign's sorted names); each vibrated one with its
/// reference where the set has one. Why the worst ones: an effect that acts on a few
/// conditions (a sensor at the lowest forcing frequencies) is invisible on recordings chosen
/// by name, and the scan would start its fit where it cannot find them.
fn scan_subset<'a>(target: &Target<'a>, z: &[f64]) -> Target<'a> {
    subset(target, z, SCAN_RECORDINGS)
}

/// At most `most` recordings of `target` (with their references) chosen as for
/// [`SCAN_RECORDINGS`]: half where the model whose residuals are `z` misses most, the rest
/// evenly by name.
pub fn subset<'a>(target: &Target<'a>, z: &[f64], most: usize) -> Target<'a> {
    let n = target.recs.len();
    if n <= most {
        return target.sub(target.recs.clone());
    }
    let rows = target.row_recordings();
    let gaps: Option<Vec<f64>> = (rows.len() == z.len()).then(|| {
        let mut sum = vec![(0.0, 0usize); n];
        for (&r, v) in rows.iter().zip(z) {
            sum[r].0 += v * v;
            sum[r].1 += 1;
        }
        sum.iter()
            .map(|&(s, c)| if c == 0 { 0.0 } else { s / c as f64 })
            .collect()
    });
    let mut pick = choose(n, gaps.as_deref(), most);
    for k in 0..most {
        let i = pick[k];
        for u in target.units_of(i) {
            if let Some(r) = target.reference[u] {
                let j = target.units[r].0;
                if !pick.contains(&j) {
                    pick.push(j);
                }
            }
        }
    }
    pick.sort_unstable();
    target.sub(pick.into_iter().map(|i| target.recs[i]).collect())
}

/// `most` of `n` recordings (`most < n`): the `most/2` with the largest mean squared residual
/// `gaps` (ties to the lower index; none where `gaps` is unknown), then the rest spread evenly
/// by index over the others, by index arithmetic.
fn choose(n: usize, gaps: Option<&[f64]>, most: usize) -> Vec<usize> {
    let mut pick: Vec<usize> = vec![];
    if let Some(gaps) = gaps {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| gaps[b].total_cmp(&gaps[a]).then(a.cmp(&b)));
        pick.extend(order.into_iter().take(most / 2));
    }
    let rest: Vec<usize> = (0..n).filter(|i| !pick.contains(i)).collect();
    let k_rest = most - pick.len();
    pick.extend((0..k_rest).map(|k| rest[k * rest.len() / k_rest]));
    pick
}

/// Amplitude and wavelength of a sinusoidal drive error, from the recorded drive position:
/// a periodogram over 400 wavelengths from 20 µm to 5 mm, pooled over the recordings
/// (None when the recordings hold less than two wavelengths of travel).
fn ripple_from_drive(recs: &[&Recording]) -> Option<(f64, f64)> {
    let recs: Vec<(&Recording, &Vec<f64>)> = recs
        .iter()
        .filter_map(|r| r.x_d.as_ref().map(|x| (*r, x)))
        .collect();
    let travel = recs
        .iter()
        .map(|(r, _)| r.params.v_d * (r.t[r.t.len() - 1] - r.t[0]))
        .fold(0.0, f64::max);
    let n_l = 400;
    let (lmin, lmax) = (20e-6f64, (travel / 2.0).min(5e-3));
    if lmax <= lmin {
        return None;
    }
    let lambdas: Vec<f64> = (0..n_l)
        .map(|i| (lmin.ln() + (lmax.ln() - lmin.ln()) * i as f64 / (n_l - 1) as f64).exp())
        .collect();
    // Residuals of x_d about v_d t, decimated to at most 4000 points a recording.
    let series: Vec<(Vec<f64>, Vec<f64>)> = recs
        .iter()
        .map(|(r, x_d)| {
            let stride = (r.t.len() / 4000).max(1);
            let xs: Vec<f64> = (0..r.t.len())
                .step_by(stride)
                .map(|i| r.params.v_d * r.t[i])
                .collect();
            let res: Vec<f64> = (0..r.t.len())
                .step_by(stride)
                .map(|i| x_d[i] - r.params.v_d * r.t[i])
                .collect();
            let mean = res.iter().sum::<f64>() / res.len() as f64;
            (xs, res.into_iter().map(|v| v - mean).collect())
        })
        .collect();
    let power: Vec<(f64, f64)> = lambdas
        .par_iter()
        .map(|&l| {
            let k = std::f64::consts::TAU / l;
            let (mut pw, mut amp, mut n) = (0.0, 0.0, 0.0);
            for (xs, res) in &series {
                let (mut c, mut s) = (0.0, 0.0);
                for (x, r) in xs.iter().zip(res) {
                    c += r * (k * x).cos();
                    s += r * (k * x).sin();
                }
                let len = xs.len() as f64;
                pw += (c * c + s * s) / len;
                amp += 2.0 * (c * c + s * s).sqrt();
                n += len;
            }
            (pw, amp / n)
        })
        .collect();
    let best = (0..n_l).max_by(|&a, &b| power[a].0.total_cmp(&power[b].0))?;
    Some((power[best].1, lambdas[best]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::Solvers;
    use crate::diagnosis::target::{Fidelity, SimCache};
    use std::sync::atomic::Ordering;

    /// What the simulation cache relies on: without vibration the actuator's and the load
    /// modulation's parameters do not act, so a model with them at any value simulates a
    /// resting recording bit for bit as with them at their defaults (the cache's key), and a
    /// cached prediction equals a fresh one. With vibration they act, and the key keeps them.
    #[test]
    fn parameters_inert_without_vibration_give_the_same_simulation() {
        let rest = Params::default().without_vibration();
        let n = 3000;
        let rec = |p: Params| Recording {
            name: "r".into(),
            params: p,
            t: (0..n).map(|i| i as f64 * 2e-4).collect(),
            f_d: vec![0.0; n],
            x_s: None,
            x_d: None,
        };
        let mut m = Model::default();
        for (k, name, v) in [
            (EffectKind::ActuatorResponse, "f_r", 900.0),
            (EffectKind::ActuatorResponse, "zeta", 0.05),
            (EffectKind::NormalCoupling, "k_n", 3e7),
            (EffectKind::NormalCoupling, "phase", 60.0),
        ] {
            m.effects.set(k, name, v).unwrap();
        }
        let mut s = Solvers::default();
        let resting = rec(rest);
        let (canonical, _) = SimCache::key(&m, &resting, Fidelity::Full);
        assert_ne!(
            canonical.effects, m.effects,
            "the defaults differ from the values set"
        );
        let a = simulate(&m, &resting, &mut s).expect("runs");
        let b = simulate(&canonical, &resting, &mut s).expect("runs");
        assert_eq!(a.f_d, b.f_d);
        assert_eq!(a.x_s, b.x_s);
        let vibrated = rec(Params {
            f: 2000.0,
            u0: 5e-8,
            ..Params::default()
        });
        assert!(vibrated.vibrates());
        let (kept, _) = SimCache::key(&m, &vibrated, Fidelity::Full);
        assert_eq!(kept.effects, m.effects);
        let a = simulate(&m, &vibrated, &mut s).expect("runs");
        let b = simulate(
            &SimCache::key(&m, &resting, Fidelity::Full).0,
            &vibrated,
            &mut s,
        )
        .expect("runs");
        assert_ne!(a.f_d, b.f_d, "with vibration the parameters act");
        let cache = SimCache::default();
        let first = cache.features(&m, &vibrated, Fidelity::Full);
        let again = cache.features(&m, &vibrated, Fidelity::Full);
        let fresh = predict_one(&m, &vibrated, &mut s);
        assert_eq!(format!("{first:?}"), format!("{fresh:?}"));
        assert_eq!(format!("{again:?}"), format!("{fresh:?}"));
        // The search fidelity is an entry of its own on a vibrated recording (another
        // tolerance, other numbers), and the full one's on a resting recording (the same run).
        let search = cache.features(&m, &vibrated, Fidelity::Search);
        assert_ne!(format!("{search:?}"), format!("{fresh:?}"));
        let rest_full = cache.features(&m, &resting, Fidelity::Full);
        let rest_search = cache.features(&m, &resting, Fidelity::Search);
        assert_eq!(format!("{rest_full:?}"), format!("{rest_search:?}"));
        let runs = |f: Fidelity| cache.simulations[f as usize].load(Ordering::Relaxed);
        assert_eq!((runs(Fidelity::Full), runs(Fidelity::Search)), (2, 1));
        assert_eq!(cache.hits.load(Ordering::Relaxed), 2);
    }

    /// The linearised minimum is the part of `z` outside the span of the Jacobian's columns:
    /// `z = (1, 2, 3)` against the first two unit vectors leaves `(0, 0, 3)`, gap `√3`; a
    /// repeated column (a coordinate the residuals do not tell apart from another) changes
    /// nothing, and a column along `z` leaves nothing.
    #[test]
    fn linear_minimum_is_the_residual_outside_the_columns() {
        let z = [1.0, 2.0, 3.0];
        let unit = |n: usize| Mat::from_fn(3, n, |i, j| if i == j.min(1) { 1.0 } else { 0.0 });
        let diag = |j: &Mat<f64>| -> Vec<f64> {
            (0..j.ncols())
                .map(|c| (0..3).map(|r| j[(r, c)].powi(2)).sum())
                .collect()
        };
        for n in [2, 3] {
            let j = unit(n);
            let g = linear_minimum(&j, &z, &diag(&j));
            assert!((g - 3f64.sqrt()).abs() < 1e-6, "{n} columns: {g}");
        }
        let along = Mat::from_fn(3, 1, |i, _| z[i]);
        let g = linear_minimum(&along, &z, &diag(&along));
        assert!(g < 1e-6, "{g}");
    }

    /// The pace rule of a screen ([`FitOptions::reach`]) on two screening fits of `diagnose`
    /// (16 recordings, 191 residuals: a cost of 191 gap²): `sensor_dynamics` as a second effect
    /// on the independent rig's `sensor+aging` campaign, at 682.17 after one step that lowered
    /// the cost by 11.41, four iterations left, bar 590.50: out of pace (its five iterations
    /// ended at 666.58). A fit below the bar, as `sensor-factorial`'s sensor screen at 236.65
    /// against 274.5 (its steps fell by 5.2, 1.2 and then 46.5), is never out of pace, whatever
    /// its steps; nor a fit that has made no step yet.
    #[test]
    fn a_screen_out_of_pace_stops() {
        assert!(out_of_pace(682.17, 11.41, 4, 590.50));
        // Eight iterations left at that fall stay above the bar; nine reach below it.
        assert!(out_of_pace(682.17, 11.41, 8, 590.50));
        assert!(!out_of_pace(682.17, 11.41, 9, 590.50));
        assert!(!out_of_pace(682.17, 0.0, 4, 590.50));
        for gain in [1e-9, 1.2, 5.2, 46.5] {
            for left in 1..=5 {
                assert!(!out_of_pace(236.65, gain, left, 274.5));
            }
        }
        // The bound is the iterations left counted with the current one.
        assert!(out_of_pace(600.0, 5.0, 1, 590.0) && !out_of_pace(600.0, 5.0, 2, 590.0));
    }

    /// The worst half is taken by gap, the rest evenly over the others, without repeats.
    #[test]
    fn subsets_hold_the_worst_recordings_and_spread_the_rest() {
        let mut gaps = vec![1.0; 30];
        for (i, g) in [(17, 9.0), (3, 7.0), (29, 5.0), (12, 4.0), (20, 3.0)] {
            gaps[i] = g;
        }
        let pick = choose(30, Some(&gaps), 16);
        assert_eq!(&pick[..8], &[17, 3, 29, 12, 20, 0, 1, 2]);
        let mut sorted = pick.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), 16, "{pick:?}");
        // The eight others: every third or so of the 22 left, from the first on.
        let rest: Vec<usize> = (0..30).filter(|i| !pick[..8].contains(i)).collect();
        assert_eq!(rest.len(), 22);
        let expect: Vec<usize> = (0..8).map(|k| rest[k * 22 / 8]).collect();
        assert_eq!(&pick[8..], &expect[..]);
        assert_eq!(&pick[8..], &[4, 6, 9, 13, 16, 19, 23, 26]);
        // Without residuals: evenly over all.
        assert_eq!(choose(30, None, 4), vec![0, 7, 15, 22]);
    }
}
