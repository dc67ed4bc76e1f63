//! The fast subsystem's periodic orbit at one mean velocity, found by Newton shooting over one
//! forcing period with its variational equations (the unknowns, the equations and the checks
//! are in [the module above](crate::averaged)).

use crate::model::{Params, contact};
use crate::ode::{Method, OdeSystem, Options, OutputGrid, Solver, Span, Status};

/// The sensitivities' tolerance relative to the states' (the error control covers both): the
/// slope and the multipliers need them to about 1e-3, the states the orbit to `rtol`. At 10 the
/// table at 3000 Hz is unchanged to 1e-5 N at 0.83 of the work.
const SENS_LOOSE: f64 = 10.0;

/// The fast subsystem with its variational equations: state
/// `[v, s, w, S_vv, S_sv, S_wv, S_vs, S_ss, S_ws, S_vF, S_sF, S_wF]`, where `S_ij = ∂y_i/∂p_j`
/// for `y = (v, s, w)` and `p = (v(0), s(0), F)`: the base states, then the sensitivities
/// column by column, so that the Newton iteration matrix is four copies of the base system's
/// 3 × 3 Jacobian ([`OdeSystem::jacobian_blocks`]).
pub(crate) struct Fast<'a> {
    pub(crate) p: &'a Params,
    /// Frozen drive force \[N\] (at `t = 0`, where `ramp` is not zero).
    pub(crate) force: f64,
    /// Rate at which the drive force rises \[N/s\]: 0 for the orbits, the drive's loading
    /// rate `k_d v_d` for [`escape_force`].
    pub(crate) ramp: f64,
    /// Velocity amplitude of the substrate \[m/s\].
    pub(crate) v_a: f64,
    /// Angular frequency \[1/s\].
    pub(crate) omega: f64,
    /// Characteristic sizes of `v`, `s`, `w` and of the unknowns, for the error norm.
    pub(crate) scale_y: [f64; 3],
    pub(crate) scale_p: [f64; 3],
}

impl Fast<'_> {
    /// `∂f/∂y` of the base 3-state system at `(t, v, s)`, row-major 3 × 3, and `f` itself.
    #[inline]
    fn base(&self, t: f64, v: f64, s: f64) -> ([f64; 3], [f64; 9]) {
        let v_r = v - self.v_a * (self.omega * t).cos();
        let c = contact(self.p, v_r, s);
        let m = self.p.m;
        let f = [(self.force + self.ramp * t - c.force) / m, c.s_dot, v];
        let a = [
            -c.dforce_dvr / m,
            -c.dforce_ds / m,
            0.0,
            c.ds_dot_dvr,
            c.ds_dot_ds,
            0.0,
            1.0,
            0.0,
            0.0,
        ];
        (f, a)
    }
}

impl OdeSystem for Fast<'_> {
    fn dim(&self) -> usize {
        12
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let (f, a) = self.base(t, y[0], y[1]);
        dy[..3].copy_from_slice(&f);
        // S' = A S + ∂f/∂p, with ∂f/∂F = (1/m, 0, 0) and the initial values not in f.
        for j in 0..3 {
            let col = &y[3 + 3 * j..6 + 3 * j];
            for i in 0..3 {
                let mut acc = a[i * 3] * col[0] + a[i * 3 + 1] * col[1] + a[i * 3 + 2] * col[2];
                if i == 0 && j == 2 {
                    acc += 1.0 / self.p.m;
                }
                dy[3 + 3 * j + i] = acc;
            }
        }
    }

    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) {
        // A on the diagonal of each of the four blocks; the second derivatives (∂A/∂y · S) are
        // left out: the simplified Newton iteration of Radau IIA needs an iteration matrix, not
        // the exact Jacobian.
        let (_, a) = self.base(t, y[0], y[1]);
        jac.fill(0.0);
        for b in 0..4 {
            for i in 0..3 {
                for k in 0..3 {
                    jac[(3 * b + i) * 12 + 3 * b + k] = a[i * 3 + k];
                }
            }
        }
    }

    fn scale(&self, i: usize) -> f64 {
        if i < 3 {
            self.scale_y[i]
        } else {
            let (c, r) = ((i - 3) / 3, (i - 3) % 3);
            SENS_LOOSE * self.scale_y[r] / self.scale_p[c]
        }
    }

    fn jacobian_blocks(&self) -> usize {
        4
    }
}

/// The fast subsystem alone (`v`, `s`, `w = ∫ v dt`) at a frozen drive force, for
/// [`escape_force`].
pub(crate) struct FastBase<'a>(pub(crate) Fast<'a>);

impl OdeSystem for FastBase<'_> {
    fn dim(&self) -> usize {
        3
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let (f, _) = self.0.base(t, y[0], y[1]);
        dy.copy_from_slice(&f);
    }
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) {
        let (_, a) = self.0.base(t, y[0], y[1]);
        jac.copy_from_slice(&a);
    }
    fn scale(&self, i: usize) -> f64 {
        self.0.scale_y[i]
    }
}

/// How to find orbits and build a table. Fields document their defaults and ranges.
#[derive(Clone, Debug, PartialEq)]
pub struct AveragingOptions {
    /// Tolerances of the one-period integration (relative and absolute in units of each
    /// component's scale). Default 1e-9; range 1e-12 to 1e-5.
    pub rtol: f64,
    /// Newton iterations per orbit at most. Default 30; range 1 to 200.
    pub max_newton: usize,
    /// Force tolerance of the table's interpolation \[N\]: every interval's midpoint is
    /// predicted by the Hermite cubic to within it. Default 1e-3 N; range 1e-9 to 1.
    pub force_tol: f64,
    /// Most nodes in a table. Default 400; range 3 to 100 000.
    pub max_nodes: usize,
    /// Build only what a run's tier needs: stop where the continuation fails (the table ends
    /// there, `stopped_at`), and refine no interval whose two nodes both have orbits that do not
    /// contract (the law may not serve there whatever its shape). Default false (the whole law
    /// with its zones, for plots).
    pub validity_only: bool,
}

impl Default for AveragingOptions {
    fn default() -> Self {
        AveragingOptions {
            rtol: 1e-9,
            max_newton: 30,
            force_tol: 1e-3,
            max_nodes: 400,
            validity_only: false,
        }
    }
}

impl AveragingOptions {
    /// Checks every field against its documented range, naming the one violated.
    pub fn validate(&self) -> Result<(), String> {
        if !(1e-12..=1e-5).contains(&self.rtol) {
            return Err(format!(
                "rtol = {}: must lie within 1e-12 to 1e-5",
                self.rtol
            ));
        }
        if !(1..=200).contains(&self.max_newton) {
            return Err(format!(
                "max_newton = {}: must be from 1 to 200",
                self.max_newton
            ));
        }
        if !(1e-9..=1.0).contains(&self.force_tol) {
            return Err(format!(
                "force_tol = {} N: must lie within 1e-9 to 1 N",
                self.force_tol
            ));
        }
        if !(3..=100_000).contains(&self.max_nodes) {
            return Err(format!(
                "max_nodes = {}: must be from 3 to 100000",
                self.max_nodes
            ));
        }
        Ok(())
    }
}

/// A periodic orbit of the fast subsystem at mean velocity `V`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// Mean body velocity \[m/s\].
    pub v_mean: f64,
    /// The averaged friction force `F_eff(V)` \[N\] (the frozen drive force of the orbit).
    pub force: f64,
    /// Its slope `dF_eff/dV` \[N s/m\], exact through the shooting Jacobian.
    pub slope: f64,
    /// The family's tangent `d(v(0), s(0))/dV` at this orbit (the slope is the force's
    /// component): the continuation's first-order predictor of the next node's start.
    pub tangent: [f64; 2],
    /// Body velocity \[m/s\] and contact deformation \[m\] at the period's start (phase 0 of
    /// `u'(t) = v_a cos ωt`): the orbit's fast state, for a hand-over to the full model.
    pub start: [f64; 2],
    /// The Floquet multipliers (eigenvalues of the monodromy of `(v, s)` at fixed `F`), as
    /// (real, imaginary) pairs, largest modulus first. One of them belongs to the mean velocity,
    /// which the averaged law itself governs (`≈ exp(−F_eff' T / m)`, near 1 for short periods);
    /// the other is the fast one, [`Orbit::fast`].
    pub multipliers: [(f64, f64); 2],
    /// The fast multiplier: the contact's mode along the orbit (the one of [`Orbit::multipliers`]
    /// farther from the mean velocity's `exp(−F_eff' T / m)`; a complex pair, where the two
    /// modes mix, counts as fast).
    pub fast: (f64, f64),
    /// Newton iterations taken.
    pub iterations: usize,
    /// Right-hand sides of the variational system evaluated.
    pub rhs_evals: u64,
}

impl Orbit {
    /// Modulus of the fast multiplier.
    pub fn fast_modulus(&self) -> f64 {
        self.fast.0.hypot(self.fast.1)
    }

    /// Whether averaging may use this orbit: its fast multiplier lies inside the circle of
    /// radius 0.95, so the contact settles onto the orbit within a few periods after any
    /// disturbance, and is far from −1 (a period doubling ahead) and from +1 (a fold).
    pub fn contracting(&self) -> bool {
        self.fast_modulus() < 0.95
    }
}

/// Why no orbit was found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AveragingError {
    /// Bad options or parameters.
    #[error("{0}")]
    Invalid(String),
    /// The one-period integration failed.
    #[error("the one-period integration ended with {0}")]
    Integration(&'static str),
    /// Newton did not converge.
    #[error(
        "no periodic orbit at V = {v_mean} m/s: Newton did not converge in {iterations} iterations (residual {residual:.3e})"
    )]
    NoOrbit {
        /// Mean velocity asked for \[m/s\].
        v_mean: f64,
        /// Iterations taken.
        iterations: usize,
        /// Scaled residual at the end.
        residual: f64,
    },
    /// The slow model of a hybrid run ran away: its mean velocity passed [`DIVERGED`](crate::sim::slow::DIVERGED) times
    /// the larger of the table's span and [`slip_speed`](crate::sim::slow::slip_speed), or turned non-finite.
    #[error("the slow model diverged (mean velocity {0:.3e} m/s)")]
    Diverged(f64),
}

/// Finds periodic orbits of the fast subsystem of one set of parameters (its `f`, `u0`, `v_d`
/// and contact; `k_d` and `h_d` do not enter).
pub struct Shooter<'a> {
    p: &'a Params,
    opts: AveragingOptions,
    solver: Solver,
    pub(crate) v_a: f64,
    pub(crate) omega: f64,
    pub(crate) period: f64,
    pub(crate) scale_y: [f64; 3],
    pub(crate) scale_p: [f64; 3],
    /// First step of the next one-period integration: the step the last one proposed at its
    /// end (the orbit is periodic, so its end is the next one's start); 0 at first (chosen
    /// automatically).
    h0: f64,
}

impl<'a> Shooter<'a> {
    /// A shooter for `p` (validated; it must vibrate).
    pub fn new(p: &'a Params, opts: AveragingOptions) -> Result<Shooter<'a>, AveragingError> {
        opts.validate().map_err(AveragingError::Invalid)?;
        p.validate()
            .map_err(|e| AveragingError::Invalid(e.to_string()))?;
        if !p.vibrates() {
            return Err(AveragingError::Invalid(
                "the averaged law needs vibration: give f > 0 and u0 > 0".into(),
            ));
        }
        let v_a = p.v_a();
        let omega = p.omega();
        let period = 1.0 / p.f;
        let vs = v_a.max(p.v_s);
        let ss = p.f_c / p.k_t;
        Ok(Shooter {
            p,
            opts,
            solver: Solver::new(Method::Radau5),
            v_a,
            omega,
            period,
            scale_y: [vs, ss, vs * period],
            scale_p: [vs, ss, p.f_c],
            h0: 0.0,
        })
    }

    /// One period from `(v0, s0)` at force `force`: the end state `(v, s, w)` and the 3 × 3
    /// sensitivities (row-major: rows `v, s, w`, columns `v0, s0, F`).
    fn period_map(
        &mut self,
        v0: f64,
        s0: f64,
        force: f64,
        rhs: &mut u64,
    ) -> Result<([f64; 3], [f64; 9]), AveragingError> {
        let sys = Fast {
            p: self.p,
            force,
            ramp: 0.0,
            v_a: self.v_a,
            omega: self.omega,
            scale_y: self.scale_y,
            scale_p: self.scale_p,
        };
        let mut y = [0.0; 12];
        y[0] = v0;
        y[1] = s0;
        y[3] = 1.0; // ∂v/∂v0
        y[3 + 4] = 1.0; // ∂s/∂s0
        let opts = Options {
            rtol: self.opts.rtol,
            atol: self.opts.rtol,
            // A few steps per period at least: the forcing must be resolved.
            h_max: self.period / 8.0,
            h0: self.h0,
            ..Options::default()
        };
        let rep = self.solver.solve(
            &sys,
            Span::new(0.0, self.period, OutputGrid::NONE),
            &mut y,
            &opts,
            |_, _| {},
        );
        *rhs += rep.stats.rhs_evals;
        if rep.status != Status::Success {
            self.h0 = 0.0;
            return Err(AveragingError::Integration(rep.status.name()));
        }
        self.h0 = rep.h_next.min(self.period / 8.0);
        // Row-major (rows v, s, w; columns v0, s0, F) from the column-by-column state.
        let mut s = [0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                s[i * 3 + j] = y[3 + 3 * j + i];
            }
        }
        Ok(([y[0], y[1], y[2]], s))
    }

    /// The periodic orbit with mean velocity `v_mean`, by Newton from `guess = (v0, s0, F)`.
    pub fn orbit(&mut self, v_mean: f64, guess: [f64; 3]) -> Result<Orbit, AveragingError> {
        let mut x = guess;
        let mut rhs = 0u64;
        let t = self.period;
        let sc = self.scale_p;
        let mut last = f64::INFINITY;
        for it in 1..=self.opts.max_newton {
            let (end, s) = self.period_map(x[0], x[1], x[2], &mut rhs)?;
            let r = [end[0] - x[0], end[1] - x[1], end[2] / t - v_mean];
            let rs = [r[0] / sc[0], r[1] / sc[1], r[2] / sc[0]];
            let norm = rs.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let j = shooting_jacobian(&s, t);
            let dx = solve3(&j, &[-r[0], -r[1], -r[2]]).ok_or(AveragingError::NoOrbit {
                v_mean,
                iterations: it,
                residual: norm,
            })?;
            let step = [dx[0] / sc[0], dx[1] / sc[1], dx[2] / sc[2]]
                .iter()
                .fold(0.0f64, |a, b| a.max(b.abs()));
            for k in 0..3 {
                x[k] += dx[k];
            }
            // Converged: the step and the residual both at the integration's own accuracy. The
            // slope and the multipliers come from this iteration's sensitivities, at the orbit
            // less the last step (a relative change of the step's size, 1e2 rtol at most, far
            // below what the Hermite interpolation and the contraction test need).
            if step < 1e2 * self.opts.rtol && norm < 1e2 * self.opts.rtol.max(1e-12) {
                // dx/dV solves J dx = (0, 0, 1): the tangent of the family of orbits.
                let d = solve3(&j, &[0.0, 0.0, 1.0]).unwrap_or([f64::NAN; 3]);
                let slope = d[2];
                let multipliers = eig2([s[0], s[1], s[3], s[4]]);
                let drift = (-slope * t / self.p.m).exp();
                let fast = if multipliers[0].1 != 0.0 {
                    multipliers[0]
                } else if (multipliers[0].0 - drift).abs() < (multipliers[1].0 - drift).abs() {
                    multipliers[1]
                } else {
                    multipliers[0]
                };
                return Ok(Orbit {
                    v_mean,
                    force: x[2],
                    slope,
                    tangent: [d[0], d[1]],
                    start: [x[0], x[1]],
                    multipliers,
                    fast,
                    iterations: it,
                    rhs_evals: rhs,
                });
            }
            if !(norm.is_finite()) || (it > 8 && norm > last) {
                return Err(AveragingError::NoOrbit {
                    v_mean,
                    iterations: it,
                    residual: norm,
                });
            }
            last = norm;
        }
        Err(AveragingError::NoOrbit {
            v_mean,
            iterations: self.opts.max_newton,
            residual: last,
        })
    }
}

/// The Jacobian of the shooting residual `(v(T) − v0, s(T) − s0, w(T)/T − V)` with respect to
/// `(v0, s0, F)`, from the period's sensitivities `s` (row-major, rows `v, s, w`).
fn shooting_jacobian(s: &[f64; 9], t: f64) -> [f64; 9] {
    [
        s[0] - 1.0,
        s[1],
        s[2],
        s[3],
        s[4] - 1.0,
        s[5],
        s[6] / t,
        s[7] / t,
        s[8] / t,
    ]
}

/// `J x = b` for a 3 × 3 `J` (row-major) by Gaussian elimination with partial pivoting; `None`
/// when singular.
fn solve3(j: &[f64; 9], b: &[f64; 3]) -> Option<[f64; 3]> {
    let mut a = [
        [j[0], j[1], j[2], b[0]],
        [j[3], j[4], j[5], b[1]],
        [j[6], j[7], j[8], b[2]],
    ];
    for c in 0..3 {
        let piv = (c..3).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[piv][c] == 0.0 || !a[piv][c].is_finite() {
            return None;
        }
        a.swap(c, piv);
        for r in c + 1..3 {
            let f = a[r][c] / a[c][c];
            let pivot_row = a[c];
            for (x, p) in a[r].iter_mut().zip(pivot_row).skip(c) {
                *x -= f * p;
            }
        }
    }
    let mut x = [0.0; 3];
    for r in (0..3).rev() {
        let mut acc = a[r][3];
        for k in r + 1..3 {
            acc -= a[r][k] * x[k];
        }
        x[r] = acc / a[r][r];
    }
    Some(x)
}

/// Eigenvalues of a 2 × 2 matrix `[a, b; c, d]`, largest modulus first.
fn eig2(m: [f64; 4]) -> [(f64, f64); 2] {
    let (a, b, c, d) = (m[0], m[1], m[2], m[3]);
    let tr = a + d;
    let det = a * d - b * c;
    let disc = tr * tr / 4.0 - det;
    let mut e = if disc >= 0.0 {
        let r = disc.sqrt();
        [(tr / 2.0 + r, 0.0), (tr / 2.0 - r, 0.0)]
    } else {
        let i = (-disc).sqrt();
        [(tr / 2.0, i), (tr / 2.0, -i)]
    };
    if e[1].0.hypot(e[1].1) > e[0].0.hypot(e[0].1) {
        e.swap(0, 1);
    }
    e
}

#[cfg(test)]
mod tests {
    use crate::averaged::orbit::{eig2, solve3};

    #[test]
    fn small_linear_algebra() {
        let j = [2.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 4.0];
        let x = solve3(&j, &[3.0, 5.0, 5.0]).expect("regular");
        for (a, b) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((a - b).abs() < 1e-14);
        }
        let e = eig2([0.0, -1.0, 1.0, 0.0]);
        assert!((e[0].1.abs() - 1.0).abs() < 1e-15 && e[0].0 == 0.0);
        let e = eig2([0.5, 0.0, 0.0, -0.9]);
        assert!((e[0].0 + 0.9).abs() < 1e-15 && e[0].1 == 0.0, "{e:?}");
        assert!((e[1].0 - 0.5).abs() < 1e-15, "{e:?}");
    }
}
