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

use crate::model::{EffectKind, Effects};
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
        let Ok((k, p)) = c.target else { return true };
        if p.of(k).scale == crate::model::effects::Scale::Degrees {
            return true;
        }
        neutral(k, p).is_some_and(|v| {
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

pub(crate) fn cost_of(target: &Target, model: &Model) -> (f64, Vec<f64>) {
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
    levenberg_marquardt(target, s, None, 1, opts)
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
    levenberg_marquardt(target, s, Some((jac, fresh)), evaluations, opts)
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
    let start = Start {
        model: fr.model.clone(),
        effects: fr.effects.clone(),
        cs,
        theta: fr.theta.clone(),
        at: (cost, fr.z.clone()),
    };
    let jac0 = fr.jacobian_fresh.then(|| (fr.jacobian.clone(), true));
    levenberg_marquardt(target, start, jac0, 0, opts)
}

/// The iterations of [`fit`] from the start `s` (its cost and residuals already evaluated and
/// counted in `evaluations`), on the first Jacobian `jac0` where given (with whether it is a
/// fresh finite-difference Jacobian there), else on a new one.
fn levenberg_marquardt(
    target: &Target,
    s: Start,
    jac0: Option<(Mat<f64>, bool)>,
    mut evaluations: usize,
    opts: FitOptions,
) -> FitResult {
    let Start {
        model,
        effects,
        cs,
        mut theta,
        at,
    } = s;
    let effects = effects.as_slice();
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
    let delta = (fr.jacobian.ncols() == p)
        .then(|| refit_delta(&fr.jacobian, &fr.z, keep, first_free))
        .flatten();
    let theta = match delta {
        Some(delta) => step_within(&cs, &fr.theta, &delta, step),
        None => fr.theta.clone(),
    };
    for (c, &t) in cs.iter().zip(&theta) {
        c.set(&mut model, t);
    }
    model
}

/// The coordinates `theta` moved by `step` times `delta`, each kept inside its plausible range
/// (`cs`, in the same order); a non-finite entry of `delta` leaves its coordinate where it is.
/// The one bound of a fold's refit ([`refit_rows`]) and of its image in the detection limits
/// ([`super::limits`]).
pub(crate) fn step_within(cs: &[Coord], theta: &[f64], delta: &[f64], step: f64) -> Vec<f64> {
    cs.iter()
        .zip(theta)
        .zip(delta)
        .map(|((c, &t), &d)| {
            if d.is_finite() {
                (t + step * d).clamp(c.lo, c.hi)
            } else {
                t
            }
        })
        .collect()
}

/// The step of [`refit_rows`] for residuals `z` and their Jacobian `jac` (one row per residual):
/// `[J_k; √λ D] δ = [−z_k; 0]` on the rows `keep` marks, the columns before `first_free` held
/// (`None` where the shapes do not match or no row is kept), before `step_within` keeps it
/// inside the bounds. Linear in `z`: the held-out residuals
/// of a fold refit to first order are `z + J δ(z)`, which the detection limits
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::{Recording, Solvers};
    use crate::diagnosis::target::{Fidelity, SimCache};
    use crate::model::Params;
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
}
