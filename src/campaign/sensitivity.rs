//! Forward sensitivities of a simulated recording: the derivative of every sample of the
//! recorded force, body displacement and drive displacement with respect to chosen parameters
//! of the model (base parameters or effects'), integrated with the state.
//!
//! The state `y` of the rig and, for each parameter `p_k`, its sensitivity `s_k = ∂y/∂p_k · p̄_k`
//! (scaled by the parameter's size `p̄_k`, so that `s_k` has the unit of `y`) obey
//!
//! ```text
//! y'   = f(t, y; p)
//! s_k' = ∂f/∂y · s_k + ∂f/∂p_k · p̄_k,        s_k(0) = 0   (the rig starts at rest)
//! ```
//!
//! The right-hand side of `s_k` is the directional derivative of `f` along `(s_k, p̄_k e_k)`,
//! taken as a centred difference quotient of `f` alone at fixed `t`, as CVODES does where no
//! analytic `∂f/∂p` is given (its `CV_CENTERED` simultaneous quotient):
//! `(f(t, y + σ s_k; p + σ p̄_k e_k) − f(t, y − σ s_k; p − σ p̄_k e_k)) / (2σ)` with
//! `σ = ε^(1/3) ≈ 6e-6`, the step that balances the quotient's truncation error (`σ²`) against
//! its rounding (`ε/σ`). A parameter whose step would leave its allowed range (an ageing
//! strength at its neutral 0) takes the one-sided quotient on its inside. The quotient is of the
//! right-hand side at one instant, never of two integrations: the sensitivities are as smooth in
//! the parameters as the solution is, and the step sequence is that of one integration.
//!
//! The augmented system `(y, s_1, ..., s_P)` is integrated by the recording's own methods
//! (Dormand–Prince 5(4) where the substrate vibrates; Radau IIA otherwise and for two-stage
//! recordings, whose iteration matrix is the rig's Jacobian on each block,
//! [`OdeSystem::jacobian_blocks`]), with error control on every component: a sensitivity's
//! tolerance is its state component's (the scaled sensitivity has its unit). A sample's
//! derivative follows from the state's and the sensitivities at the sample by the same centred
//! quotient of the sampler: the recorded force, with a sensor's delay where there is one.

use super::delay::Sampler;
use super::{SimTrace, integrate_recording, simulate_grid};
use crate::model::effects::Param;
use crate::model::params::ParamInfo;
use crate::model::{EffectKind, Effects, MAX_DIM, Params, Rig, RigError};
use crate::ode::{Method, OdeSystem, Solvers, Span};

/// A parameter a derivative is taken along.
#[derive(Clone, Copy, Debug)]
pub enum Knob {
    /// A base parameter of the model (`F_s`, `h_d`, ...).
    Base(&'static ParamInfo),
    /// A parameter of an effect (which must be on).
    Effect(EffectKind, Param),
}

impl Knob {
    /// Its value in `(p, fx)`.
    pub fn value(&self, p: &Params, fx: &Effects) -> f64 {
        match *self {
            Knob::Base(info) => info.get(p),
            Knob::Effect(k, q) => fx.at(k, q).unwrap_or(f64::NAN),
        }
    }

    /// `(p, fx)` with it moved to `v`, refused where `v` leaves its allowed range.
    pub fn moved(&self, p: &Params, fx: &Effects, v: f64) -> Result<Rig, RigError> {
        let (mut p, mut fx) = (*p, fx.clone());
        match *self {
            Knob::Base(info) => info.set(&mut p, v),
            Knob::Effect(k, q) => fx.set_at(k, q, v)?,
        }
        Rig::with_effects(p, &fx)
    }
}

/// Step of the centred difference quotients, relative to a parameter's size: `ε^(1/3)`.
pub const QUOTIENT_STEP: f64 = 6.055454452393343e-6;

/// The difference quotient of one direction: the rigs at the two ends and where they lie, in
/// units of the step (`+1`, `0` or `−1`).
struct Quotient {
    hi: Rig,
    lo: Rig,
    /// `(a, b)`: the ends at `p + a σ p̄` and `p + b σ p̄`.
    ends: (f64, f64),
}

impl Quotient {
    /// The centred quotient of `knob` at `(p, fx)` with size `bar`, or a one-sided one where an
    /// end leaves the allowed range.
    fn new(rig: &Rig, p: &Params, fx: &Effects, knob: Knob, bar: f64) -> Result<Self, RigError> {
        let v = knob.value(p, fx);
        let h = QUOTIENT_STEP * bar;
        let hi = knob.moved(p, fx, v + h);
        let lo = knob.moved(p, fx, v - h);
        Ok(match (hi, lo) {
            (Ok(hi), Ok(lo)) => Quotient {
                hi,
                lo,
                ends: (1.0, -1.0),
            },
            (Ok(hi), Err(_)) => Quotient {
                hi,
                lo: rig.clone(),
                ends: (1.0, 0.0),
            },
            (Err(_), Ok(lo)) => Quotient {
                hi: rig.clone(),
                lo,
                ends: (0.0, -1.0),
            },
            (Err(e), Err(_)) => return Err(e),
        })
    }

    /// The states at the two ends, `y + a σ s` and `y + b σ s` (the first `y.len()` of each).
    #[inline]
    fn states(&self, y: &[f64], s: &[f64]) -> ([f64; MAX_DIM], [f64; MAX_DIM]) {
        let (a, b) = self.ends;
        let mut ya = [0.0; MAX_DIM];
        let mut yb = [0.0; MAX_DIM];
        for i in 0..y.len() {
            ya[i] = y[i] + a * QUOTIENT_STEP * s[i];
            yb[i] = y[i] + b * QUOTIENT_STEP * s[i];
        }
        (ya, yb)
    }

    /// `(g(hi, y + a σ s) − g(lo, y + b σ s)) / ((a − b) σ)` for a function `g` of a rig and
    /// a state.
    #[inline]
    fn apply(
        &self,
        y: &[f64],
        s: &[f64],
        mut g: impl FnMut(&Rig, &[f64], &mut [f64; MAX_DIM]),
        out: &mut [f64; MAX_DIM],
    ) {
        let n = y.len();
        let (a, b) = self.ends;
        let (ya, yb) = self.states(y, s);
        let (mut ga, mut gb) = ([0.0; MAX_DIM], [0.0; MAX_DIM]);
        g(&self.hi, &ya[..n], &mut ga);
        g(&self.lo, &yb[..n], &mut gb);
        let inv = 1.0 / ((a - b) * QUOTIENT_STEP);
        for i in 0..y.len() {
            out[i] = (ga[i] - gb[i]) * inv;
        }
    }
}

/// The rig and its sensitivities to `P` parameters as one system of dimension `n (1 + P)`:
/// the state, then each scaled sensitivity.
struct Augmented {
    rig: Rig,
    quotients: Vec<Quotient>,
    n: usize,
    control: ErrorControl,
}

/// Which components a sensitive integration's error control covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorControl {
    /// The state alone: the step sequence is the one the state chooses, and the sensitivities
    /// are integrated on it by the same method. The cheaper (`benches/sensitivity.md`).
    State,
    /// The state and the sensitivities (CVODES' `errconS`): a sensitivity's tolerance is its
    /// state component's.
    Full,
}

impl OdeSystem for Augmented {
    fn dim(&self) -> usize {
        self.n * (1 + self.quotients.len())
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let n = self.n;
        let (y0, s) = y.split_at(n);
        self.rig.rhs(t, y0, &mut dy[..n]);
        for (k, q) in self.quotients.iter().enumerate() {
            let mut out = [0.0; MAX_DIM];
            q.apply(
                y0,
                &s[k * n..(k + 1) * n],
                |rig, y, f: &mut [f64; MAX_DIM]| rig.rhs(t, y, &mut f[..n]),
                &mut out,
            );
            dy[n * (k + 1)..n * (k + 2)].copy_from_slice(&out[..n]);
        }
    }

    /// The rig's Jacobian on every diagonal block; the second derivatives (`∂²f/∂y² · s`) are
    /// left out: an implicit method's Newton iteration needs an iteration matrix, not the
    /// exact Jacobian.
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) {
        let n = self.n;
        let dim = self.dim();
        let mut a = [0.0; MAX_DIM * MAX_DIM];
        self.rig.jacobian(t, &y[..n], &mut a[..n * n]);
        jac.fill(0.0);
        for b in 0..=self.quotients.len() {
            for i in 0..n {
                let row = (b * n + i) * dim + b * n;
                jac[row..row + n].copy_from_slice(&a[i * n..(i + 1) * n]);
            }
        }
    }

    fn scale(&self, i: usize) -> f64 {
        if i >= self.n && self.control == ErrorControl::State {
            // Out of the error norm: `atol · scale` outweighs any error.
            return 1e300;
        }
        self.rig.scale(i % self.n)
    }

    fn jacobian_blocks(&self) -> usize {
        1 + self.quotients.len()
    }
}

/// A parameter to differentiate along and its size `p̄` (the scale of its steps: its value,
/// or a typical one where the value is 0).
#[derive(Clone, Copy, Debug)]
pub struct Direction {
    /// The parameter.
    pub knob: Knob,
    /// Its size, in its unit (positive).
    pub bar: f64,
}

/// A simulated recording and its derivatives.
#[derive(Clone, Debug)]
pub struct SensitiveTrace {
    /// The recording as [`simulate_grid`] samples it.
    pub trace: SimTrace,
    /// Per direction, the derivative of each sample per unit of the parameter (`∂F_d/∂p_k`,
    /// `∂x_s/∂p_k`, `∂x_d/∂p_k`), its status the run's.
    pub derivatives: Vec<SimTrace>,
}

/// The method of a sensitive simulation: Dormand–Prince where the substrate vibrates from the
/// start, Radau IIA (whose Newton iteration factorises one block) otherwise.
pub fn sensitive_method_for(p: &Params) -> Method {
    if p.vibrates() && !p.two_stage() {
        Method::Dopri5
    } else {
        Method::Radau5
    }
}

/// The samples of a recording: `n` at `t0 + i dt` \[s\].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Samples {
    /// The first sample's time \[s\].
    pub t0: f64,
    /// The sampling interval \[s\].
    pub dt: f64,
    /// How many.
    pub n: usize,
}

/// Simulates the model with effects `fx` as [`simulate_grid`] does (on the samples `at`, at
/// tolerance `tol`, `rtol = atol`) together with its forward sensitivities along `dirs`, the
/// error controlled as `control` says; with no direction, [`simulate_grid`] itself.
pub fn simulate_grid_sensitive(
    p: &Params,
    fx: &Effects,
    dirs: &[Direction],
    at: Samples,
    (tol, control): (f64, ErrorControl),
    solvers: &mut Solvers,
) -> Result<SensitiveTrace, RigError> {
    let Samples { t0, dt, n } = at;
    if dirs.is_empty() {
        let trace = simulate_grid(p, fx, t0, dt, n, tol, solvers)?;
        return Ok(SensitiveTrace {
            trace,
            derivatives: vec![],
        });
    }
    let rig = Rig::with_effects(*p, fx)?;
    let quotients = dirs
        .iter()
        .map(|d| Quotient::new(&rig, p, fx, d.knob, d.bar))
        .collect::<Result<Vec<_>, _>>()?;
    let dim = rig.initial_state().len();
    let sys = Augmented {
        rig: rig.clone(),
        quotients,
        n: dim,
        control,
    };
    let mut y = vec![0.0; sys.dim()];
    let tau = sys
        .quotients
        .iter()
        .map(|q| q.hi.sensor_delay().max(q.lo.sensor_delay()))
        .fold(0.0, f64::max);
    let (mut sampler, grid) = Sampler::covering(rig.clone(), t0, dt, n, tau);
    // Each direction's samplers at the quotient's two ends, on the primal's grid.
    let mut ends: Vec<(Sampler, Sampler)> = sys
        .quotients
        .iter()
        .map(|q| (sampler.alike(q.hi.clone()), sampler.alike(q.lo.clone())))
        .collect();
    let t1 = t0 + dt * (n - 1) as f64;
    let solver = solvers.get(sensitive_method_for(p));
    let observe = |t: f64, y: &[f64]| {
        let (y0, s) = y.split_at(dim);
        sampler.take(t, y0);
        for (k, (q, (hi, lo))) in sys.quotients.iter().zip(ends.iter_mut()).enumerate() {
            let (ya, yb) = q.states(y0, &s[k * dim..(k + 1) * dim]);
            hi.take(t, &ya[..dim]);
            lo.take(t, &yb[..dim]);
        }
        true
    };
    let span = Span::new(0.0, t1, grid);
    let rep = integrate_recording(solver, &sys, p, span, &mut y, tol, observe);
    let trace = sampler.finish(rep.status);
    let derivatives = ends
        .into_iter()
        .zip(&sys.quotients)
        .zip(dirs)
        .map(|(((hi, lo), q), d)| {
            let (hi, lo) = (hi.finish(rep.status), lo.finish(rep.status));
            let inv = 1.0 / ((q.ends.0 - q.ends.1) * QUOTIENT_STEP * d.bar);
            let quotient = |a: &[f64], b: &[f64]| -> Vec<f64> {
                a.iter().zip(b).map(|(x, y)| (x - y) * inv).collect()
            };
            SimTrace {
                f_d: quotient(&hi.f_d, &lo.f_d),
                x_s: quotient(&hi.x_s, &lo.x_s),
                x_d: quotient(&hi.x_d, &lo.x_d),
                status: rep.status,
            }
        })
        .collect();
    Ok(SensitiveTrace { trace, derivatives })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::effects::{aging, normal_coupling, sensor_dynamics};
    use crate::model::params::info;

    /// The reference: the difference quotient of whole integrations at a tight tolerance
    /// (centred, or forward where the parameter sits on its lower end), at relative steps `h`
    /// and `h/2`; their difference is the reference's own error.
    fn reference(
        p: &Params,
        fx: &Effects,
        d: &Direction,
        at: Samples,
        h: f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let mut solvers = Solvers::default();
        let v = d.knob.value(p, fx);
        let at_value = |x: f64, solvers: &mut Solvers| {
            let (mut q, mut g) = (*p, fx.clone());
            match d.knob {
                Knob::Base(i) => i.set(&mut q, x),
                Knob::Effect(k, e) => g.set_at(k, e, x).unwrap(),
            }
            simulate_grid(&q, &g, at.t0, at.dt, at.n, 1e-12, solvers)
                .unwrap()
                .f_d
        };
        let one_sided = d.knob.moved(p, fx, v - h * d.bar).is_err();
        let cd = |h: f64, solvers: &mut Solvers| -> Vec<f64> {
            let a = at_value(v + h * d.bar, solvers);
            let (b, w) = if one_sided {
                (at_value(v, solvers), h * d.bar)
            } else {
                (at_value(v - h * d.bar, solvers), 2.0 * h * d.bar)
            };
            a.iter().zip(&b).map(|(a, b)| (a - b) / w).collect()
        };
        (cd(h, &mut solvers), cd(h / 2.0, &mut solvers))
    }

    /// Each column of the sensitive run's force derivative against the centred difference of
    /// integrations at 1e-11: its largest departure over the samples, in units of the largest
    /// derivative, is printed and returned with the reference's own error (in the same units).
    fn compare(
        p: &Params,
        fx: &Effects,
        dirs: &[Direction],
        at: Samples,
        control: ErrorControl,
    ) -> Vec<(f64, f64)> {
        let mut solvers = Solvers::default();
        let s = simulate_grid_sensitive(p, fx, dirs, at, (1e-9, control), &mut solvers).unwrap();
        assert_eq!(s.trace.status, crate::ode::Status::Success);
        dirs.iter()
            .zip(&s.derivatives)
            .map(|(d, got)| {
                let (r1, r2) = reference(p, fx, d, at, 1e-3);
                let top = r2.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let dev = |a: &[f64], b: &[f64]| {
                    a.iter()
                        .zip(b)
                        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
                        / top
                };
                let (err, ref_err) = (dev(&got.f_d, &r2), dev(&r1, &r2));
                let name = match d.knob {
                    Knob::Base(i) => i.name,
                    Knob::Effect(k, q) => q.name(k),
                };
                eprintln!(
                    "{name}: top {top:.3e}, departure {err:.2e}, reference error {ref_err:.2e}"
                );
                (err, ref_err)
            })
            .collect()
    }

    /// What a run at 1e-9 may depart beyond the reference's error, in units of the largest
    /// derivative: with the sensitivities under error control, the tolerance's reach; without,
    /// their error is the method's on the state's steps (docs/campaigns.md, "Derivatives from
    /// the integrator", gives the largest measured here).
    fn floor(control: ErrorControl) -> f64 {
        match control {
            ErrorControl::Full => 1e-4,
            ErrorControl::State => 2e-3,
        }
    }

    fn base(name: &str, p: &Params) -> Direction {
        let i = info(name).unwrap();
        Direction {
            knob: Knob::Base(i),
            bar: i.get(p),
        }
    }

    /// Over two stick-slip cycles, 1 to 2.5 s, slips included.
    #[test]
    fn base_parameters_without_vibration() {
        let p = Params {
            v_d: 7e-4,
            ..Params::default()
        };
        let at = Samples {
            t0: 1.0,
            dt: 1e-3,
            n: 1500,
        };
        let mut dirs: Vec<Direction> = ["F_s", "F_c", "v_s"].iter().map(|n| base(n, &p)).collect();
        // No drive damping by default: a size of 1 N s/m.
        dirs.push(Direction {
            knob: Knob::Base(info("h_d").unwrap()),
            bar: 1.0,
        });
        for control in [ErrorControl::Full, ErrorControl::State] {
            for (err, ref_err) in compare(&p, &Effects::none(), &dirs, at, control) {
                assert!(
                    err <= 3.0 * ref_err + floor(control),
                    "{control:?}: {err:.2e} against {ref_err:.2e}"
                );
            }
        }
    }

    #[test]
    fn effects_under_vibration() {
        let mut p = Params {
            v_d: 7e-4,
            ..Params::default()
        };
        p.u0 = 0.3e-3 / (std::f64::consts::TAU * p.f);
        let mut fx = Effects::none();
        fx.set_at(EffectKind::SensorDynamics, sensor_dynamics::F_N, 400.0)
            .unwrap();
        fx.set_at(EffectKind::SensorDynamics, sensor_dynamics::ZETA, 0.2)
            .unwrap();
        fx.set_at(EffectKind::NormalCoupling, normal_coupling::K_N, 2e7)
            .unwrap();
        fx.set_at(EffectKind::Aging, aging::B, 0.0).unwrap();
        // The first stick, 0.05 to 0.9 s (the vibration ends it before the 1.4 s of F_s/(k_d v_d)). Across a slip
        // under vibration neither the reference nor the sensitivities converge (docs/campaigns.md,
        // "Derivatives from the integrator").
        let at = Samples {
            t0: 0.05,
            dt: 1e-3,
            n: 850,
        };
        let eff = |k, q, bar| Direction {
            knob: Knob::Effect(k, q),
            bar,
        };
        let dirs = [
            base("F_s", &p),
            eff(EffectKind::SensorDynamics, sensor_dynamics::F_N, 400.0),
            eff(EffectKind::SensorDynamics, sensor_dynamics::ZETA, 0.2),
            eff(EffectKind::NormalCoupling, normal_coupling::K_N, 2e7),
            eff(EffectKind::NormalCoupling, normal_coupling::PHASE, 90.0),
            // At its neutral end: the one-sided quotient.
            eff(EffectKind::Aging, aging::B, 0.05),
        ];
        for control in [ErrorControl::Full, ErrorControl::State] {
            for (err, ref_err) in compare(&p, &fx, &dirs, at, control) {
                assert!(
                    err <= 3.0 * ref_err + floor(control),
                    "{control:?}: {err:.2e} against {ref_err:.2e}"
                );
            }
        }
    }
}
