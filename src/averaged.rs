//! The vibration averaged out: the effective friction law `F_eff(V)` of body and contact.
//!
//! Where the forcing period `1/f` is short against the stick-slip (the drive oscillator
//! `√(k_d/m)` runs 20 to 600 times slower than `ω = 2π f` in the paper's ranges), the drive force
//! hardly moves over one period. Freeze it at `F` and ask for the periodic orbit of the **body
//! and the contact together** (the contact resonance `√(k_t/m)/2π ≈ 1649 Hz` lies inside the
//! paper's band, so the body's mass belongs to the fast subsystem) whose mean velocity is `V`:
//!
//! ```text
//! m v' = F − F_F(v − u'(t), s),   s' = LuGre (docs/model.md),   u'(t) = v_a cos(ω t),
//! v(T) = v(0),   s(T) = s(0),   (1/T) ∫₀ᵀ v dt = V,                T = 1/f.
//! ```
//!
//! Over one period `m (v(T) − v(0)) = F T − ∫ F_F dt = 0`, so `F` is the period mean of the
//! friction force along the orbit: `F_eff(V) = F`. The unknowns `(v(0), s(0), F)` are found by
//! Newton shooting: one period of the variational equations (the 3 states `v`, `s`,
//! `w = ∫ v dt` and their 9 sensitivities to the unknowns) integrated by the project's Radau IIA
//! with error control on the sensitivities, then a 3 × 3 Newton step. The same Jacobian gives
//! the exact slope `dF_eff/dV` (implicit-function theorem) and the orbit's **fast Floquet
//! multipliers**, the eigenvalues of the monodromy matrix of `(v, s)` at fixed `F`: an orbit
//! whose multipliers approach −1 is about to period-double, where averaging is not valid.
//!
//! [`Table::build`] continues the orbit in `V` from 0 (where symmetry gives `F = 0`) to a
//! chosen `V_max`, with nodes added by bisection until cubic Hermite interpolation on the exact
//! slopes predicts every midpoint to the force tolerance (the midpoints found for that check are
//! nodes too). Each node keeps its orbit's state and multipliers, so a caller can tell where the
//! table may serve (a contracting period-1 orbit) and where it may not.
//!
//! References and checks: the rigid Coulomb limit `(2 F_c/π) asin(V/v_a)` (Littmann, Storck
//! and Wallaschek, Arch. Appl. Mech. 71 (2001) 549) for `u0 ≫ F_c/k_t`; the small-amplitude
//! creep slope `(π/2) F_s / v̂_r`, `v̂_r = v_a |mω² / (k_t − mω² + iωh_t)|`; and the settled
//! sliding force of full runs where vibration eliminates stick-slip (`tests/averaged.rs`).

use crate::model::{Params, contact};
use crate::ode::{Method, OdeSystem, Options, OutputGrid, Solver, Status};

/// The sensitivities' tolerance relative to the states' (the error control covers both): the
/// slope and the multipliers need them to about 1e-3, the states the orbit to `rtol`. At 10 the
/// table at 3000 Hz is unchanged to 1e-5 N at 0.83 of the work.
const SENS_LOOSE: f64 = 10.0;

/// The fast subsystem with its variational equations: state
/// `[v, s, w, S_vv, S_sv, S_wv, S_vs, S_ss, S_ws, S_vF, S_sF, S_wF]`, where `S_ij = ∂y_i/∂p_j`
/// for `y = (v, s, w)` and `p = (v(0), s(0), F)`: the base states, then the sensitivities
/// column by column, so that the Newton iteration matrix is four copies of the base system's
/// 3 × 3 Jacobian ([`OdeSystem::jacobian_blocks`]).
struct Fast<'a> {
    p: &'a Params,
    /// Frozen drive force \[N\] (at `t = 0`, where `ramp` is not zero).
    force: f64,
    /// Rate at which the drive force rises \[N/s\]: 0 for the orbits, the drive's loading
    /// rate `k_d v_d` for [`escape_force`].
    ramp: f64,
    /// Velocity amplitude of the substrate \[m/s\].
    v_a: f64,
    /// Angular frequency \[1/s\].
    omega: f64,
    /// Characteristic sizes of `v`, `s`, `w` and of the unknowns, for the error norm.
    scale_y: [f64; 3],
    scale_p: [f64; 3],
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
struct FastBase<'a>(Fast<'a>);

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
    /// The slow model of a hybrid run ran away: its mean velocity passed [`DIVERGED`] times
    /// the larger of the table's span and [`slip_speed`], or turned non-finite.
    #[error("the slow model diverged (mean velocity {0:.3e} m/s)")]
    Diverged(f64),
}

/// Finds periodic orbits of the fast subsystem of one set of parameters (its `f`, `u0`, `v_d`
/// and contact; `k_d` and `h_d` do not enter).
pub struct Shooter<'a> {
    p: &'a Params,
    opts: AveragingOptions,
    solver: Solver,
    v_a: f64,
    omega: f64,
    period: f64,
    scale_y: [f64; 3],
    scale_p: [f64; 3],
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
            0.0,
            self.period,
            &mut y,
            &opts,
            OutputGrid::NONE,
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
            for k in c..4 {
                a[r][k] -= f * a[c][k];
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

/// `F_eff(V)` tabulated on `0 ≤ V ≤ V_max` (odd in `V`: `F_eff(−V) = −F_eff(V)`), with the orbit
/// at every node.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// The nodes, by increasing `V`.
    pub nodes: Vec<Orbit>,
    /// Where continuation stopped before `V_max` (no converged orbit beyond): the first `V` it
    /// could not reach \[m/s\].
    pub stopped_at: Option<f64>,
    /// Intervals `(V_lo, V_hi)` \[m/s\] between two nodes whose midpoint has no period-1 orbit
    /// (continued from either end): the fast motion there is not periodic with the forcing
    /// (period doubling, chaos, a fold), and the law is undefined.
    pub gaps: Vec<(f64, f64)>,
    /// The nodes' `V` alone, for the lookups of the slow model's every step.
    at: Vec<f64>,
    /// Per interval `k` (nodes `k − 1` and `k`; entry 0 unused): bit 0 set where it is no gap,
    /// bit 1 where, besides, both nodes' orbits contract ([`Table::valid_at`]).
    flags: Vec<u8>,
}

impl Table {
    /// Builds the table for `p` from `V = 0` to `v_max`: continuation along the family of
    /// orbits (each node starts from the last one's orbit moved along its tangent), nodes
    /// bisected until every midpoint agrees with the Hermite cubic of its neighbours to
    /// `force_tol` (each midpoint's orbit, found for the check from the cubic of its neighbours'
    /// starts and tangents, stays a node).
    pub fn build(p: &Params, v_max: f64, opts: AveragingOptions) -> Result<Table, AveragingError> {
        if !(v_max > 0.0 && v_max.is_finite()) {
            return Err(AveragingError::Invalid(format!(
                "v_max = {v_max} m/s: must be finite and > 0"
            )));
        }
        let tol = opts.force_tol;
        let max_nodes = opts.max_nodes;
        let quick = opts.validity_only;
        let mut sh = Shooter::new(p, opts)?;
        // V = 0: by symmetry the orbit has F = 0; Newton starts from rest.
        let first = sh.orbit(0.0, [0.0, 0.0, 0.0])?;
        let mut nodes = vec![first];
        let mut stopped_at = None;
        // Coarse continuation, each step halved where Newton fails: 16 even steps up to the
        // knee (four times the larger of v_a and v_d: the law's peak near v_a, the slow
        // model's velocities near v_d, and the zones where the orbit loses stability lie
        // there), doubling beyond it, where the law flattens towards the base friction.
        let knee = (4.0 * p.v_a().max(p.v_d)).min(v_max);
        let mut coarse: Vec<f64> = (1..=16).map(|k| knee * k as f64 / 16.0).collect();
        let mut j = 1;
        while knee * f64::from(1u32 << j.min(30)) < v_max && j < 30 {
            coarse.push(knee * f64::from(1u32 << j));
            j += 1;
        }
        if knee < v_max {
            coarse.push(v_max);
        }
        let mut k = 0;
        while k < coarse.len() {
            let v = coarse[k];
            match reach(&mut sh, nodes.last().expect("one node"), v) {
                Ok(o) => {
                    nodes.push(o);
                    k += 1;
                }
                Err(_) => {
                    stopped_at = Some(v);
                    break;
                }
            }
        }
        if quick && stopped_at.is_some() {
            return Ok(Table::of(nodes, stopped_at, vec![]));
        }
        // Refinement, left to right: an interval whose midpoint the cubic misses is split and its
        // halves looked at in turn; one whose midpoint has no orbit (from either end) is a gap.
        let mut gaps = vec![];
        let mut done = vec![nodes[0]];
        let mut pending: Vec<Orbit> = nodes[1..].iter().rev().copied().collect();
        let mut left = nodes[0];
        while let Some(right) = pending.pop() {
            if done.len() + pending.len() + 1 >= max_nodes {
                done.push(right);
                left = right;
                continue;
            }
            let mid = 0.5 * (left.v_mean + right.v_mean);
            // Inside a zone whose orbits do not contract the law may not serve: no refinement.
            if quick && !left.contracting() && !right.contracting() {
                done.push(right);
                left = right;
                continue;
            }
            // The midpoint's start from the cubic of both ends (values and tangents): Newton
            // then takes 1.4 iterations per orbit for 1.9 from one end's tangent, and its first
            // period, nearer the orbit, fewer steps (at 3000 Hz, `v_a/v_d` 0.4: 0.68 of the
            // right-hand sides). Where it fails, continuation from either end.
            let found = sh
                .orbit(mid, between(&left, &right, mid))
                .or_else(|_| reach(&mut sh, &left, mid))
                .or_else(|_| reach(&mut sh, &right, mid));
            match found {
                Ok(o) if (hermite(&left, &right, mid) - o.force).abs() > tol => {
                    pending.push(right);
                    pending.push(o);
                }
                // The midpoint's orbit, found for the check, is kept: it costs nothing more and
                // the law between the halves is closer still (at 3000 Hz, `v_a/v_d` 0.4, within
                // 1.8e-4 N of a table at `rtol` 1e-9 and `force_tol` 1e-5 N, for 8e-4 N).
                Ok(o) => {
                    done.push(o);
                    done.push(right);
                    left = right;
                }
                Err(_) => {
                    gaps.push((left.v_mean, right.v_mean));
                    done.push(right);
                    left = right;
                }
            }
        }
        Ok(Table::of(done, stopped_at, gaps))
    }

    /// The table of these nodes (by increasing `V`), with its lookup arrays.
    fn of(nodes: Vec<Orbit>, stopped_at: Option<f64>, gaps: Vec<(f64, f64)>) -> Table {
        let at: Vec<f64> = nodes.iter().map(|o| o.v_mean).collect();
        let flags = (0..nodes.len())
            .map(|k| {
                if k == 0 {
                    return 0;
                }
                let (l, r) = (&nodes[k - 1], &nodes[k]);
                let mid = 0.5 * (l.v_mean + r.v_mean);
                let open = !gaps.iter().any(|&(lo, hi)| mid > lo && mid < hi);
                u8::from(open) | (u8::from(open && l.contracting() && r.contracting()) << 1)
            })
            .collect();
        Table {
            nodes,
            stopped_at,
            gaps,
            at,
            flags,
        }
    }

    /// `F_eff(V)` \[N\] by cubic Hermite interpolation on the exact slopes; odd in `V`. `None`
    /// beyond the table or inside a gap.
    pub fn force(&self, v: f64) -> Option<f64> {
        self.law(v).map(|(f, _)| f)
    }

    /// `dF_eff/dV` \[N s/m\] of the interpolant; even in `V`. `None` beyond the table or inside
    /// a gap.
    pub fn slope(&self, v: f64) -> Option<f64> {
        self.law(v).map(|(_, d)| d)
    }

    /// [`Table::force`] and [`Table::slope`] at `v` from one lookup.
    pub fn law(&self, v: f64) -> Option<(f64, f64)> {
        let a = v.abs();
        let k = self.interval(a)?;
        let (l, r) = (&self.nodes[k - 1], &self.nodes[k.min(self.nodes.len() - 1)]);
        let h = r.v_mean - l.v_mean;
        if h <= 0.0 {
            return Some((l.force.copysign(v), l.slope));
        }
        let f = hermite(l, r, a);
        let s = (a - l.v_mean) / h;
        let d00 = 6.0 * s * s - 6.0 * s;
        let d10 = 3.0 * s * s - 4.0 * s + 1.0;
        let d11 = 3.0 * s * s - 2.0 * s;
        let d = d00 * (l.force - r.force) / h + d10 * l.slope + d11 * r.slope;
        Some((if v < 0.0 { -f } else { f }, d))
    }

    /// Index `k ≥ 1` of the interval (nodes `k − 1`, `k`) around `|V| = a` (`k` = 1 with one
    /// node, which then stands twice); `None` beyond the table or inside a gap.
    fn interval(&self, a: f64) -> Option<usize> {
        let last = *self.at.last()?;
        if !(a <= last) {
            return None;
        }
        let k = self.at.partition_point(|&x| x < a).max(1);
        if k < self.nodes.len() && self.flags[k] & 1 == 0 && a > self.at[k - 1] && a < self.at[k] {
            return None;
        }
        Some(k)
    }

    /// Whether every node's orbit is [`Orbit::contracting`] and the table has no gap and
    /// reaches its `V_max`: it may stand for the fast vibration everywhere it reaches.
    pub fn valid(&self) -> bool {
        self.stopped_at.is_none()
            && self.gaps.is_empty()
            && self.nodes.iter().all(Orbit::contracting)
    }

    /// Whether the law may stand for the fast vibration at mean velocity `v`: both nodes
    /// around `|v|` have contracting orbits and no gap lies between them; beyond the last node,
    /// where the table reached its end and that node's orbit contracts.
    pub fn valid_at(&self, v: f64) -> bool {
        let a = v.abs();
        let Some(last) = self.nodes.last() else {
            return false;
        };
        if a > last.v_mean {
            return self.stopped_at.is_none() && last.contracting();
        }
        match self.interval(a) {
            Some(k) if k < self.nodes.len() => self.flags[k] & 2 != 0,
            // A one-node table.
            Some(_) => last.contracting(),
            None => false,
        }
    }
}

impl Table {
    /// The fast state `(v(0), s(0))` at phase 0 of the orbit at mean velocity `v`, for a hand-over
    /// to the full model: linear between the nodes around `v`, the end node's beyond the table,
    /// across a gap the nearer node's; at `v < 0` (a body sliding back, which the law's symmetry
    /// maps to phase `π`, not 0) the orbit at rest's. The full model settles onto its own orbit
    /// from there within a few periods.
    pub fn start_at(&self, v: f64) -> [f64; 2] {
        let a = v.max(0.0);
        let n = self.nodes.len();
        let k = self.at.partition_point(|&x| x < a).clamp(1, n.max(2) - 1);
        let (lo, hi) = (&self.nodes[(k - 1).min(n - 1)], &self.nodes[k.min(n - 1)]);
        let h = hi.v_mean - lo.v_mean;
        let w = if h > 0.0 {
            ((a - lo.v_mean) / h).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let gap = k < n && self.flags[k] & 1 == 0;
        let w = if gap { w.round() } else { w };
        [
            lo.start[0] + w * (hi.start[0] - lo.start[0]),
            lo.start[1] + w * (hi.start[1] - lo.start[1]),
        ]
    }
}

impl Table {
    /// The `V` of least modulus in `[lo, hi]` where the law may not stand for the vibration
    /// ([`Table::valid_at`] false), `None` where it may everywhere in the range.
    pub fn first_invalid(&self, lo: f64, hi: f64) -> Option<f64> {
        // The moduli visited: a range through zero covers [0, max |V|].
        let (a, b) = if lo <= 0.0 && hi >= 0.0 {
            (0.0, (-lo).max(hi))
        } else {
            (lo.abs().min(hi.abs()), lo.abs().max(hi.abs()))
        };
        let sign = if hi < 0.0 { -1.0 } else { 1.0 };
        let n = self.nodes.len();
        let Some(&last) = self.at.last() else {
            return Some(sign * a);
        };
        if n >= 2 {
            let first = self.at.partition_point(|&x| x < a).max(1);
            for k in first..n {
                if self.at[k - 1] > b {
                    break;
                }
                if self.flags[k] & 2 == 0 {
                    return Some(sign * a.max(self.at[k - 1]));
                }
            }
        }
        if b > last && !self.valid_at(b) {
            return Some(sign * a.max(last));
        }
        (n == 1 && !self.valid_at(a)).then_some(sign * a)
    }
}

impl Table {
    /// The table as space-separated fields, every float in its shortest round-trip form (so a
    /// table read back is the one written, bit for bit): `V_stop` (NaN where the continuation
    /// reached its end), the gap count and each gap's ends, the node count and per node
    /// `V, F, F', tangent (2), start (2), multipliers (4), fast (2), iterations, rhs_evals`.
    pub fn to_fields(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = write!(
            s,
            "{:e} {}",
            self.stopped_at.unwrap_or(f64::NAN),
            self.gaps.len()
        );
        for (lo, hi) in &self.gaps {
            let _ = write!(s, " {lo:e} {hi:e}");
        }
        let _ = write!(s, " {}", self.nodes.len());
        for o in &self.nodes {
            let m = o.multipliers;
            for x in [
                o.v_mean,
                o.force,
                o.slope,
                o.tangent[0],
                o.tangent[1],
                o.start[0],
                o.start[1],
                m[0].0,
                m[0].1,
                m[1].0,
                m[1].1,
                o.fast.0,
                o.fast.1,
            ] {
                let _ = write!(s, " {x:e}");
            }
            let _ = write!(s, " {} {}", o.iterations, o.rhs_evals);
        }
        s
    }

    /// The table of [`Table::to_fields`]; `None` where a field is missing, malformed or left
    /// over.
    pub fn from_fields(s: &str) -> Option<Table> {
        let mut it = s.split_ascii_whitespace();
        let mut x = || it.next()?.parse::<f64>().ok();
        let stop = x()?;
        let n_gaps = x()?;
        if !(n_gaps >= 0.0 && n_gaps.fract() == 0.0 && n_gaps < 1e6) {
            return None;
        }
        let mut gaps = Vec::with_capacity(n_gaps as usize);
        for _ in 0..n_gaps as usize {
            gaps.push((x()?, x()?));
        }
        let n = x()?;
        if !(n >= 1.0 && n.fract() == 0.0 && n <= 100_000.0) {
            return None;
        }
        let mut nodes = Vec::with_capacity(n as usize);
        for _ in 0..n as usize {
            let mut v = [0.0; 13];
            for e in v.iter_mut() {
                *e = x()?;
            }
            let (iters, rhs) = (x()?, x()?);
            if !(iters >= 0.0 && rhs >= 0.0 && iters.fract() == 0.0 && rhs.fract() == 0.0) {
                return None;
            }
            nodes.push(Orbit {
                v_mean: v[0],
                force: v[1],
                slope: v[2],
                tangent: [v[3], v[4]],
                start: [v[5], v[6]],
                multipliers: [(v[7], v[8]), (v[9], v[10])],
                fast: (v[11], v[12]),
                iterations: iters as usize,
                rhs_evals: rhs as u64,
            });
        }
        if x().is_some() || !nodes.windows(2).all(|w| w[0].v_mean < w[1].v_mean) {
            return None;
        }
        Some(Table::of(nodes, stop.is_finite().then_some(stop), gaps))
    }
}

impl Table {
    /// The law with its rising branch cut at `f_esc` \[N\]: where the fast motion escapes from
    /// its low-velocity attractor at a frozen drive force below the law's peak (below the
    /// contact resonance the period-1 orbit there does not contract, and the attractor that
    /// holds the body is chaotic), the slow model must slip at `f_esc`, not at the fold. The
    /// nodes above `f_esc` between the rising and the falling branch are replaced by a flat
    /// stretch at `f_esc`, taken as valid; the rest is the law. `None` where the law never
    /// rises above `f_esc` or never falls back below it.
    pub fn capped(&self, f_esc: f64) -> Option<Table> {
        let n = &self.nodes;
        let i = n.iter().position(|o| o.force > f_esc)?;
        let j = i + n[i..].iter().position(|o| o.force < f_esc)?;
        if i == 0 {
            return None;
        }
        // Where each branch crosses f_esc, linearly between its nodes.
        let cross = |a: &Orbit, b: &Orbit| {
            a.v_mean + (f_esc - a.force) / (b.force - a.force) * (b.v_mean - a.v_mean)
        };
        let flat = |v: f64, like: &Orbit| Orbit {
            v_mean: v,
            force: f_esc,
            slope: 0.0,
            multipliers: [(0.0, 0.0); 2],
            fast: (0.0, 0.0),
            ..*like
        };
        let mut nodes: Vec<Orbit> = n[..i].to_vec();
        nodes.push(flat(cross(&n[i - 1], &n[i]), &n[i - 1]));
        nodes.push(flat(cross(&n[j - 1], &n[j]), &n[j]));
        nodes.extend_from_slice(&n[j..]);
        nodes.dedup_by(|b, a| b.v_mean <= a.v_mean);
        Some(Table::of(nodes, self.stopped_at, vec![]))
    }
}

/// The drive force \[N\] at which the body escapes from the low-velocity attractor of the fast
/// motion while the drive loads it, where that comes before the law's peak; `None` where every
/// orbit of the law's rising branch contracts (the slow model then slips at the law's own fold),
/// or the body holds up to the peak.
///
/// Below the contact resonance the period-1 orbit of the rising branch stops contracting before
/// the law's peak, and the attractor that holds the body there is not periodic: it lets the body
/// go at a lower force than the fold of `F_eff`. How much lower depends on how long the force
/// dwells near it (at 1500 Hz, v_a/v_d 0.4, a frozen force held 200 periods per level gave
/// 9.415 to 9.45 N by the levels' spacing), so the force here rises as the drive raises it
/// while the body sticks, at `k_d v_d`, from the last contracting orbit of the rising branch;
/// the escape is the first period whose mean velocity exceeds twice the peak's `V`.
/// [`Table::capped`] then gives the law the slow model slips by.
pub fn escape_force(p: &Params, table: &Table) -> Option<f64> {
    let n = &table.nodes;
    let peak = (0..n.len()).max_by(|&a, &b| n[a].force.total_cmp(&n[b].force))?;
    let first_bad = n[..=peak].iter().position(|o| !o.contracting())?;
    let lo = first_bad.checked_sub(1)?;
    let (f_lo, f_hi, v_peak) = (n[lo].force, n[peak].force, n[peak].v_mean);
    let rate = p.k_d * p.v_d;
    let period = 1.0 / p.f;
    let sh = Shooter::new(p, SHARED).ok()?;
    let sys = FastBase(Fast {
        p,
        force: f_lo,
        ramp: rate,
        v_a: sh.v_a,
        omega: sh.omega,
        scale_y: sh.scale_y,
        scale_p: sh.scale_p,
    });
    let opts = Options {
        rtol: 1e-7,
        atol: 1e-7,
        h_max: period / 8.0,
        ..Options::default()
    };
    // The ramp to the peak, whole periods (the orbit's phase 0 at each).
    let periods = ((f_hi - f_lo) / rate / period).ceil() as u64 + 1;
    let grid = OutputGrid {
        start: 0.0,
        step: period,
        count: periods + 1,
    };
    let mut y = [n[lo].start[0], n[lo].start[1], 0.0];
    let mut last_w = 0.0;
    let mut escaped = None;
    let rep = Solver::new(Method::Radau5).solve_until(
        &sys,
        0.0,
        periods as f64 * period,
        &mut y,
        &opts,
        grid,
        |t, y| {
            let v = (y[2] - last_w) / period;
            last_w = y[2];
            if t > 0.0 && v > 2.0 * v_peak {
                escaped = Some(f_lo + rate * t);
                return false;
            }
            true
        },
    );
    (rep.status == Status::Success).then_some(escaped).flatten()
}

/// The slow model of the averaged rig: the spring's stretch `z = v_d t − x` and the body's
/// mean velocity `V`, with the vibration replaced by `F_eff`:
/// `z' = v_d − V`, `m V' = k_d z + h_d (v_d − V) − F_eff(V)`.
pub(crate) struct Slow<'a> {
    pub(crate) p: &'a Params,
    pub(crate) table: &'a Table,
}

impl Slow<'_> {
    fn law(&self, v: f64) -> (f64, f64) {
        // Beyond the table the vibration's share of the friction has faded and the Stribeck
        // term decayed (table_span): the law goes on with the viscous slope.
        let last = self.table.nodes.last().expect("a table has nodes");
        match self.table.law(v) {
            Some(fd) => fd,
            None => (
                (last.force + self.p.h_v * (v.abs() - last.v_mean).max(0.0)).copysign(v),
                self.p.h_v,
            ),
        }
    }
}

impl OdeSystem for Slow<'_> {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let p = self.p;
        let (f, _) = self.law(y[1]);
        dy[0] = p.v_d - y[1];
        dy[1] = (p.k_d * y[0] + p.h_d * (p.v_d - y[1]) - f) / p.m;
    }
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut [f64]) {
        let p = self.p;
        let (_, d) = self.law(y[1]);
        jac.copy_from_slice(&[0.0, -1.0, p.k_d / p.m, (-p.h_d - d) / p.m]);
    }
    fn time_derivative(&self, _t: f64, _y: &[f64], dfdt: &mut [f64], _scratch: &mut [f64]) {
        dfdt.fill(0.0);
    }
    fn scale(&self, i: usize) -> f64 {
        if i == 0 {
            (self.p.f_s / self.p.k_d).max(1e-12)
        } else {
            self.p.v_d
        }
    }
}

/// A run of the averaged slow model: the measures of docs/model.md from its drive force, and
/// its work.
#[derive(Clone, Debug)]
pub struct SlowRun {
    /// The measures over the steady window (the drive force needs no smoothing: it carries no
    /// ripple at `f`), the mean force over the window's whole stick-slip cycles where it holds
    /// two drops or more ([`crate::measures::Analyzer::cycle_mean`]). Where the slide at `v_d` is stable and the run ends on it, or settles
    /// onto it (no slip in the window, the force's swing shrinking from the window's first half
    /// to its second), the mean force is the averaged law's `F_eff(v_d)` itself, and dF, where
    /// no slip fell in the window, 0: the settled slide has no oscillation left.
    pub measures: crate::measures::Measures,
    /// How the integration ended.
    pub status: Status,
    /// The slow integration's work.
    pub stats: crate::ode::Stats,
    /// The slow states sampled (where asked for): `t`, `F_d = k_d z + h_d (v_d − V)`, the same
    /// as `F_d_smooth`, `x_s = v_d t − z`, `x_d`, `v = V`; the fast channels `s`, `v_r` and `u`
    /// are NaN, as the slow model does not hold them.
    pub trace: Option<crate::sim::Trace>,
    /// The first mean velocity \[m/s\] of the steady window (as sampled) where the
    /// law may not stand for the vibration ([`Table::valid_at`]: an orbit that does not
    /// contract, a gap, past a failed continuation); `None` where it may all along. The run's
    /// measures are then not the averaged model's to give: the full model must serve. The
    /// transient before the window is not checked: the stick-slip forgets it, and a start from
    /// rest passes the law at zero force, where the orbit of a small vibration need not
    /// contract. Infinite where the slow model diverged: its window ran past
    /// [`divergence_bound`], or through non-finite values (the full model must serve; hybrid
    /// windows would hand back to the same slow model).
    pub left_law: Option<f64>,
    /// Time \[s\] from which the samples were read off the slow model's limit cycle instead of
    /// integrated ([`simulate_slow_with`]'s `periodic`); `None` where every one was integrated.
    pub continued_from: Option<f64>,
}

/// Integrates the averaged slow model of `p` from rest to `t_end` with Radau IIA at `rtol`,
/// sampling the drive force every `dt` seconds for the measures (window: the second half, as a
/// full run's), and says where the window left the valid law ([`SlowRun::left_law`]). A table
/// of fewer than two nodes is refused.
pub fn simulate_slow(
    p: &Params,
    table: &Table,
    t_end: f64,
    dt: f64,
    rtol: f64,
) -> Result<SlowRun, AveragingError> {
    simulate_slow_with(p, table, t_end, dt, rtol, None, true)
}

/// How far past the larger of the table's upper end ([`table_span`]) and the fastest slip
/// ([`slip_speed`]) the slow model's mean velocity may run in the steady window before the run
/// counts as diverged and leaves the law ([`SlowRun::left_law`]): a window beyond four times
/// both is a runaway of the integration, not friction. On the overnight grid's even sixteenth
/// (2000 Hz, `u0` = 12.6 nm, `v_d` = 0.15 mm/s) the slow model ran off to `V` ≈ 1e17 m/s and,
/// without this bound, reported `r` ≈ 5e21 as a success. (Four times the table alone was too
/// tight: a soft drive's slips outrun it, at 2000 Hz, `u0` = 5 nm, `v_d` = 0.27 mm/s,
/// `k_d` = 5000 N/m by ten times, and 33 points of a 1024-point slice of the overnight grid went to
/// the full model for nothing.)
pub const DIVERGED: f64 = 4.0;

/// The mean velocity \[m/s\] past which a slow model has diverged: [`DIVERGED`] times the
/// larger of the table's upper end and [`slip_speed`].
pub fn divergence_bound(p: &Params, table: &Table) -> f64 {
    DIVERGED * table.at.last().copied().unwrap_or(0.0).max(slip_speed(p))
}

/// A bound on the body's speed in a slip \[m/s\]: `v_d + 2 F_s / √(k_d m)`. The spring's energy
/// at breakaway, `F²/(2 k_d)` with `F` below `2 F_s`, is all a slip can turn into the body's
/// kinetic energy `m V²/2` relative to the drive.
pub fn slip_speed(p: &Params) -> f64 {
    p.v_d + 2.0 * p.f_s / (p.k_d * p.m).sqrt()
}

/// Share of the nominal stick-slip amplitude `2 (F_s − F_c)` (and of `v_d`) within which the
/// slow model's end state must lie of the steady slide at `v_d` for its mean force to be
/// reported as `F_eff(v_d)`.
pub const SLIDE_TOL: f64 = 1e-4;

/// The analyser of a run sampled once every `dt` seconds without ripple (the slow model's, a
/// hybrid run's): no smoothing, the window of a full run of `t_end`, blocks as a full run keeps
/// them (for the mean over whole cycles).
pub(crate) fn slow_analyzer(p: &Params, t_end: f64, dt: f64) -> crate::measures::Analyzer {
    use crate::measures::{Analyzer, DROP_THRESHOLD, STICK_VELOCITY};
    let block = (t_end / 4000.0).max(dt);
    Analyzer::with_blocks(
        1,
        crate::sim::window_start(p, t_end),
        DROP_THRESHOLD * (p.f_s - p.f_c),
        STICK_VELOCITY * p.v_d,
        block,
        (t_end / block) as usize + 2,
    )
}

/// [`simulate_slow`], keeping at most `trace` samples of the slow states (evenly decimated)
/// where given. Where `periodic`, once the stick-slip repeats (two successive downward crossings
/// of the level `F_eff(v_d)` in the same state, the orbit contracting:
/// [`LimitCycle::slow`](crate::cycle::LimitCycle::slow)) the rest of the samples are read off
/// the last cycle instead of integrated, as a run without vibration does
/// ([`RunOptions::periodic`](crate::sim::RunOptions::periodic)). The slow model is planar and
/// autonomous, so its periodic orbit, once reached, repeats exactly.
pub fn simulate_slow_with(
    p: &Params,
    table: &Table,
    t_end: f64,
    dt: f64,
    rtol: f64,
    trace: Option<usize>,
    periodic: bool,
) -> Result<SlowRun, AveragingError> {
    if table.nodes.len() < 2 {
        return Err(AveragingError::Invalid(format!(
            "the averaged law has {} node(s) (continuation stopped at {:?} m/s): use the full model",
            table.nodes.len(),
            table.stopped_at
        )));
    }
    let sys = Slow { p, table };
    let window = crate::sim::window_start(p, t_end);
    let mid = 0.5 * (window + t_end);
    // The range of V the window visits (V is continuous: every value between is visited too).
    let mut seen = (f64::INFINITY, f64::NEG_INFINITY);
    // The drive force's range over each half of the window: a decaying approach to the slide.
    let mut halves = [(f64::INFINITY, f64::NEG_INFINITY); 2];
    let mut an = slow_analyzer(p, t_end, dt);
    let mut y = [0.0, 0.0];
    let opts = Options {
        rtol,
        atol: rtol,
        ..Options::default()
    };
    let count = (t_end / dt).floor() as u64 + 1;
    let grid = OutputGrid {
        start: 0.0,
        step: dt,
        count,
    };
    let stride = trace.map(|n| count.div_ceil(n.max(1) as u64).max(1));
    let mut tr = stride.map(|_| crate::sim::Trace::default());
    let mut i = 0u64;
    // Sample `i` at `t` with drive force `f`, stretch `z` and mean velocity `v`.
    let mut finite = true;
    let mut record = |i: u64, t: f64, f: f64, z: f64, v: f64| {
        an.push(t, f, v);
        finite &= f.is_finite() && v.is_finite();
        if t >= window {
            seen = (seen.0.min(v), seen.1.max(v));
            let h = &mut halves[usize::from(t >= mid)];
            *h = (h.0.min(f), h.1.max(f));
        }
        if let (Some(tr), Some(k)) = (tr.as_mut(), stride)
            && i.is_multiple_of(k)
        {
            tr.push_slow(t, f, p.v_d * t - z, p.v_d * t, v);
        }
    };
    let mut cycle = table.force(p.v_d).filter(|_| periodic).map(|level| {
        crate::cycle::LimitCycle::slow(p, level, dt, rtol, [sys.scale(0), sys.scale(1)])
    });
    let mut solver = Solver::new(Method::Radau5);
    let rep = solver.solve_until(&sys, 0.0, t_end, &mut y, &opts, grid, |t, y| {
        let f = p.k_d * y[0] + p.h_d * (p.v_d - y[1]);
        record(i, t, f, y[0], y[1]);
        i += 1;
        // Once periodic the integration ends here; the samples after it are the cycle's.
        !cycle
            .as_mut()
            .is_some_and(|c| c.push(t, f, &[p.v_d * t - y[0], y[1], 0.0]))
    });
    let continued_from = cycle.as_ref().and_then(|c| c.continued_from());
    if let Some(c) = cycle.as_ref()
        && rep.status == Status::Success
    {
        c.replay(&grid, i, t_end, |i, t, f, x| {
            record(i, t, f, p.v_d * t - x[0], x[1]);
        });
    }
    // A window that runs far past both the table and the fastest slip, or through non-finite
    // values, has diverged: no law holds it there.
    let reach = divergence_bound(p, table);
    let left_law = if !finite || !(seen.0.abs().max(seen.1.abs()) <= reach) {
        Some(f64::INFINITY)
    } else {
        (seen.0 <= seen.1)
            .then(|| table.first_invalid(seen.0, seen.1))
            .flatten()
    };
    let mut measures = an.finish();
    // The window's mean over its whole cycles: a full run ends where the window's mean agrees
    // with it (its early stop), while the slow run's window ends where its planned time does,
    // and a cut cycle biases the plain mean by up to 0.7 % (3000 Hz, v_a/v_d 0.4).
    if let Some(m) = an.cycle_mean(window) {
        measures.mean_force = m;
    }
    // The steady slide: stable where F_eff' + h_d > 0 (the linearised slow model's damping);
    // reached where the end state lies on it, or settling onto it where no slip falls in the
    // window and the force's swing shrinks from the window's first half to its second (a
    // decaying approach: its settled level has no oscillation, as docs/model.md measures it).
    if let (Some(level), Some(slope)) = (table.force(p.v_d), table.slope(p.v_d)) {
        let nominal = 2.0 * (p.f_s - p.f_c);
        // A repeating cycle is no slide, wherever the run stopped on it.
        let on_slide = continued_from.is_none()
            && (y[1] - p.v_d).abs() <= SLIDE_TOL * p.v_d
            && (p.k_d * y[0] - level).abs() <= SLIDE_TOL * nominal;
        let swing = |h: (f64, f64)| h.1 - h.0;
        let settling = measures.cycles == 0
            && (swing(halves[1]) <= 0.9 * swing(halves[0])
                || swing(halves[1]) <= SLIDE_TOL * nominal);
        if rep.status == Status::Success && slope + p.h_d > 0.0 && (on_slide || settling) {
            measures.mean_force = level;
            // No slip in the window and the slide reached: the settled level carries no
            // oscillation (docs/model.md: dF about the settled level, never the approach to it).
            if measures.cycles == 0 {
                measures.d_f = 0.0;
                measures.d_f_stderr = 0.0;
            }
        }
    }
    Ok(SlowRun {
        measures,
        status: rep.status,
        stats: rep.stats,
        trace: tr,
        left_law,
        continued_from,
    })
}

/// Which model serves a run with vibration: the option of `run --tier`, `[run] tier` and sweeps.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Tier {
    /// Per run, by the rules of [`choose`]: the averaged slow model where they hold, else the
    /// full model. The default.
    #[default]
    Auto,
    /// The averaged slow model wherever its law was found and holds along the run's steady
    /// window ([`SlowRun::left_law`]), the rules of [`choose`] about the time scales and the
    /// contact resonance left out; the full model where it does not (there is no law to use),
    /// and the result says so.
    Averaged,
    /// The full model, every forcing period integrated.
    Full,
    /// The averaged slow model where its law holds, the full model in windows where the mean
    /// velocity passes zones where it does not ([`crate::hybrid`]); the full model where there
    /// is no law.
    Hybrid,
}

impl Tier {
    /// Whether a run served by this tier used the averaged law (alone or between hybrid
    /// windows): its table belongs to the sweep's journal and its result to the sweep's check.
    pub fn uses_law(self) -> bool {
        matches!(self, Tier::Averaged | Tier::Hybrid)
    }

    /// Every tier, in the order help texts list them.
    pub const ALL: [Tier; 4] = [Tier::Auto, Tier::Averaged, Tier::Hybrid, Tier::Full];

    /// The name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Tier::Auto => "auto",
            Tier::Averaged => "averaged",
            Tier::Full => "full",
            Tier::Hybrid => "hybrid",
        }
    }

    /// The code in journals and HDF5 files of the tier that served a run: 0 full, 1 averaged,
    /// 2 hybrid.
    pub fn code(self) -> u8 {
        match self {
            Tier::Averaged => 1,
            Tier::Hybrid => 2,
            _ => 0,
        }
    }

    /// The tier of [`Tier::code`].
    pub fn from_code(c: u8) -> Option<Tier> {
        match c {
            0 => Some(Tier::Full),
            1 => Some(Tier::Averaged),
            2 => Some(Tier::Hybrid),
            _ => None,
        }
    }
}

impl std::fmt::Display for Tier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Tier {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Tier::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("unknown tier '{s}': allowed are auto, averaged, hybrid, full"))
    }
}

/// Why a run was served by its tier ([`choose`]). Stored as its code in journals and HDF5
/// files; [`TierReason::text`] is the sentence of JSON results and summaries.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum TierReason {
    /// `full` was asked for.
    #[default]
    Asked,
    /// No vibration: there is nothing to average.
    NoVibration,
    /// A two-stage run (`t_on > 0`).
    TwoStage,
    /// Model extensions are on.
    Effects,
    /// The forcing is not fast enough against the drive oscillator ([`SEPARATION`]).
    Separation,
    /// The averaged law was not found from rest on (the continuation stopped at once).
    NoLaw,
    /// Every rule of [`choose`] holds.
    Valid,
    /// `averaged` was asked for and its law exists.
    AskedAveraged,
    /// A full run checking an averaged one in a sweep (`crate::sweep::check`); where it
    /// disagrees it replaces the averaged run.
    Check,
    /// The forcing lies below the contact resonance ([`contact_resonance`]).
    BelowResonance,
    /// The averaged run's steady window passed a mean velocity where the law may not stand
    /// for the vibration ([`SlowRun::left_law`]): the full model served.
    LeftLaw,
    /// In a sweep under `auto`, no other point shares the point's table of the averaged law:
    /// building it would cost about what the full run does.
    Unshared,
    /// The vibration's velocity amplitude lies below [`MIN_VA_RATIO`] times the drive velocity.
    SmallAmplitude,
    /// `hybrid` was asked for and its law exists.
    AskedHybrid,
    /// Under `auto`, the averaged run's steady window passed zones where the law does not
    /// stand for the vibration ([`TierReason::LeftLaw`]), and hybrid windows integrated the full
    /// model there ([`crate::hybrid`]).
    Zones,
    /// A hybrid run was asked for, but the law's continuation stopped short of its span: the
    /// orbits it did not reach may hide the attractor the body escapes from (1000 Hz, `v_a/v_d`
    /// 0.4: a hybrid run on a three-node table gave dF 3.30 N for the full model's 2.20 N). The
    /// full model served.
    PartialLaw,
    /// Under auto, the drive velocity lies in a zone of the law where the fast orbit does not
    /// contract, or within [`ZONE_MARGIN`] of one: the full model served.
    NearZone,
}

impl TierReason {
    /// Every reason, by code.
    pub const ALL: [TierReason; 17] = [
        TierReason::Asked,
        TierReason::NoVibration,
        TierReason::TwoStage,
        TierReason::Effects,
        TierReason::Separation,
        TierReason::NoLaw,
        TierReason::Valid,
        TierReason::AskedAveraged,
        TierReason::Check,
        TierReason::LeftLaw,
        TierReason::BelowResonance,
        TierReason::Unshared,
        TierReason::SmallAmplitude,
        TierReason::AskedHybrid,
        TierReason::Zones,
        TierReason::PartialLaw,
        TierReason::NearZone,
    ];

    /// The name in files.
    pub fn name(self) -> &'static str {
        match self {
            TierReason::Asked => "asked",
            TierReason::NoVibration => "no_vibration",
            TierReason::TwoStage => "two_stage",
            TierReason::Effects => "effects",
            TierReason::Separation => "separation",
            TierReason::NoLaw => "no_law",
            TierReason::Valid => "valid",
            TierReason::AskedAveraged => "asked_averaged",
            TierReason::Check => "check",
            TierReason::LeftLaw => "left_law",
            TierReason::BelowResonance => "below_resonance",
            TierReason::Unshared => "unshared",
            TierReason::SmallAmplitude => "small_amplitude",
            TierReason::AskedHybrid => "asked_hybrid",
            TierReason::Zones => "zones",
            TierReason::PartialLaw => "partial_law",
            TierReason::NearZone => "near_zone",
        }
    }

    /// The code in journals and HDF5 files (the index in [`TierReason::ALL`]).
    pub fn code(self) -> u8 {
        TierReason::ALL
            .iter()
            .position(|&r| r == self)
            .expect("listed") as u8
    }

    /// The reason of [`TierReason::code`].
    pub fn from_code(c: u8) -> Option<TierReason> {
        TierReason::ALL.get(c as usize).copied()
    }

    /// One sentence for results and summaries.
    pub fn text(self) -> &'static str {
        match self {
            TierReason::Asked => "the full model was asked for",
            TierReason::NoVibration => "no vibration: nothing to average",
            TierReason::TwoStage => {
                "a two-stage run: its switch-on transient is integrated in full"
            }
            TierReason::Effects => {
                "model extensions are on: the averaged law holds the base contact only"
            }
            TierReason::Separation => {
                "the forcing is less than 20 times the drive oscillator's frequency: the drive \
                 force moves within a period"
            }
            TierReason::NoLaw => "no averaged law: the fast orbit was not found from rest on",
            TierReason::Valid => {
                "the averaged law: the forcing lies above the contact resonance and is 20 or more \
                 times faster than the drive oscillator, and the fast orbit contracts at every \
                 mean velocity of the steady window"
            }
            TierReason::AskedAveraged => "averaged was asked for and its law exists",
            TierReason::Check => {
                "the full model's check of an averaged point, which disagreed with it and \
                 replaces it"
            }
            TierReason::BelowResonance => {
                "the forcing lies below the contact resonance, where the fast orbit of body and \
                 contact can period-double and other attractors coexist with it"
            }
            TierReason::Unshared => {
                "no other point of the sweep shares this point's averaged law: its table would \
                 cost about what the full run does"
            }
            TierReason::SmallAmplitude => {
                "the vibration's velocity amplitude is below a tenth of the drive velocity: at \
                 breakaway the body crosses the averaged law's rise within a fraction of a period"
            }
            TierReason::AskedHybrid => {
                "hybrid was asked for and its law exists: the averaged law where it holds, the \
                 full model in windows where it does not"
            }
            TierReason::Zones => {
                "the averaged run's steady window passed mean velocities where the fast orbit \
                 does not contract: hybrid windows integrated the full model there"
            }
            TierReason::PartialLaw => {
                "the averaged law's continuation stopped short of its span, and the orbits it did \
                 not reach may hide the attractor the body escapes from: the full model served"
            }
            TierReason::LeftLaw => {
                "the averaged run's steady window reached mean velocities where the fast orbit \
                 does not contract (or was not found): the full model served"
            }
            TierReason::NearZone => {
                "the drive velocity lies in or within 25 % of a zone of the averaged law where \
                 the fast orbit does not contract: a body that accelerates through the zone can \
                 stay on another attractor beyond it, so the full model served"
            }
        }
    }
}

/// Least ratio of the forcing frequency `f` to the drive oscillator's `√(k_d/m)/2π` for
/// [`Tier::Auto`] to average: the averaged law freezes the drive force over a period, which
/// then moves by at most `2π · 1/20` of its oscillation's phase. The study of the averaged
/// law (`../shared/research/AVERAGING.md`) covers ratios of 20 to 600.
pub const SEPARATION: f64 = 20.0;

/// Least `v_a/v_d` for [`Tier::Auto`] to average. Below it the vibration hardly shrinks the
/// stick-slip, and at breakaway the body accelerates through the law's rise (`0 ≤ V ≲ v_a`)
/// within a fraction of a forcing period, where the period-mean law does not hold: on a
/// 1024-point slice of `sweeps/overnight.toml` the averaged points at `v_a/v_d` 0.03 (2000 Hz,
/// `u0` = 5 nm, `v_d` = 2 mm/s) gave `r` 0.023 above the full model's, while those from 0.05 on
/// stayed within 0.0033. The study of the averaged law covered 0.1 to 4.
pub const MIN_VA_RATIO: f64 = 0.1;

/// Upper end of the table [`shared_table`] builds for `p` \[m/s\]: 40 `v_d`, 10 `v_a` and 20
/// `v_s`, the largest. Beyond it the law is continued with the viscous slope `h_v` (the
/// vibration's share of the friction falls as `v_a/V`, and LuGre's Stribeck term has decayed
/// there). It does not depend on `k_d` or `h_d`, so one table serves every drive.
pub fn table_span(p: &Params) -> f64 {
    (40.0 * p.v_d).max(10.0 * p.v_a()).max(20.0 * p.v_s)
}

/// The options of [`shared_table`]: the defaults but the one-period integration at `rtol`
/// 1e-5. At 3000 Hz, `v_a/v_d` = 0.4 (`k_d` = 11 700 N/m, `v_d` = 0.5 mm/s) the law agrees with
/// a table at `rtol` 1e-9 and `force_tol` 1e-5 N to 7e-4 N everywhere on `[0, table_span]` (33
/// nodes, as at 1e-6, for 0.7 of its work; 1.8e-4 N with the refinement's midpoints kept as
/// nodes, 65 of them); at `u0` = 5 nm, 2000 Hz it has the nodes of 1e-6 (30 and 44, before
/// the midpoints were kept). Newton stops at steps of `1e2 rtol` (scaled): at `1e3 rtol` noise
/// entered the slopes at 1e-5, the table grew to 83 to 98 nodes there, and its interpolant
/// stalled the slow model's integration.
pub const SHARED: AveragingOptions = AveragingOptions {
    rtol: 1e-5,
    max_newton: 30,
    force_tol: 1e-3,
    max_nodes: 400,
    validity_only: true,
};

/// The tables [`shared_table`] keeps for the process.
fn tables() -> &'static std::sync::Mutex<std::collections::HashMap<Vec<u64>, Shared>> {
    static TABLES: std::sync::OnceLock<
        std::sync::Mutex<std::collections::HashMap<Vec<u64>, Shared>>,
    > = std::sync::OnceLock::new();
    TABLES.get_or_init(Default::default)
}

/// Drops every table [`shared_table`] keeps (a benchmark's repeat times a run from nothing).
pub fn forget_tables() {
    tables().lock().unwrap_or_else(|e| e.into_inner()).clear();
}

type Shared = std::sync::Arc<std::sync::OnceLock<Result<std::sync::Arc<Table>, AveragingError>>>;

/// The averaged law of `p` (its `f`, `u0`, `v_d`, mass and contact; `k_d`, `h_d` and `t_on`
/// do not enter) over `[0, table_span(p)]` with the options [`SHARED`], built once per
/// process and shared by every run that asks for it: the runs of a sweep over `k_d` use one
/// table. Building is deterministic, so a shared table is the one each run would build.
pub fn shared_table(p: &Params) -> Result<std::sync::Arc<Table>, AveragingError> {
    use std::sync::Arc;
    let key = table_key(p);
    let cell = {
        let mut map = tables().lock().unwrap_or_else(|e| e.into_inner());
        map.entry(key).or_default().clone()
    };
    // Built outside the map's lock: runs of other tables go on meanwhile; runs of this one
    // wait for it.
    cell.get_or_init(|| Table::build(p, table_span(p), SHARED).map(Arc::new))
        .clone()
}

/// The table of `p` where this process has built or loaded it already; `None` otherwise (it is
/// not built here).
pub fn cached_table(p: &Params) -> Option<std::sync::Arc<Table>> {
    let cell = tables()
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .get(&table_key(p))?
        .clone();
    cell.get()?.as_ref().ok().cloned()
}

/// Hands [`shared_table`] a table kept from an earlier process (a sweep's journal) under its
/// [`table_key`], so that it is not built again. A table already there stays.
pub fn preload(key: Vec<u64>, table: Table) {
    let cell = {
        let mut map = tables().lock().unwrap_or_else(|e| e.into_inner());
        map.entry(key).or_default().clone()
    };
    let _ = cell.set(Ok(std::sync::Arc::new(table)));
}

/// What identifies the table of `p` in [`shared_table`]: the bits of every parameter but
/// `k_d`, `h_d` and `t_on`.
pub fn table_key(p: &Params) -> Vec<u64> {
    let mut key_p = *p;
    key_p.k_d = 0.0;
    key_p.h_d = 0.0;
    key_p.t_on = 0.0;
    crate::model::params::PARAMS
        .iter()
        .map(|i| i.get(&key_p).to_bits())
        .collect()
}

/// Whether [`choose`] looks up the table of `p` for a run asked for with `tier` (with model
/// extensions on where `!none`): the rules that need no table hold.
pub fn needs_table(p: &Params, none: bool, tier: Tier) -> bool {
    prechecks(p, none, tier).is_none()
}

/// The tier and reason where a rule that needs no table decides; `None` where the table must.
fn prechecks(p: &Params, none: bool, tier: Tier) -> Option<TierReason> {
    if tier == Tier::Full {
        return Some(TierReason::Asked);
    }
    if !p.vibrates() {
        return Some(TierReason::NoVibration);
    }
    if p.two_stage() {
        return Some(TierReason::TwoStage);
    }
    if !none {
        return Some(TierReason::Effects);
    }
    let f_drive = (p.k_d / p.m).sqrt() / (2.0 * std::f64::consts::PI);
    if tier == Tier::Auto && p.f < SEPARATION * f_drive {
        return Some(TierReason::Separation);
    }
    if tier == Tier::Auto && p.f < contact_resonance(p) {
        return Some(TierReason::BelowResonance);
    }
    if tier == Tier::Auto && p.v_a() < MIN_VA_RATIO * p.v_d {
        return Some(TierReason::SmallAmplitude);
    }
    None
}

/// Share of `v_d` about it within which no zone of the law may lie (no mean velocity whose
/// fast orbit does not contract, [`Table::valid_at`]) for [`Tier::Auto`] to average or to use
/// hybrid windows ([`TierReason::NearZone`]). A body that accelerates from rest through a zone
/// can stay on the attractor it found there (a period-doubled or chaotic fast motion) past the
/// zone's edge, where the period-1 orbit the law holds contracts again: on the overnight grid's
/// even sixteenth at 2639 Hz, `u0` = 12.6 nm, `v_d` = 0.149 mm/s (a zone up to 13 % below
/// `v_d`, the orbit at `v_d` contracting with multiplier 0.87) the full model, every period
/// integrated, slides at 4.79 N and the averaged law gives 8.60 N; at 2000 Hz, `u0` = 12.6 nm,
/// `v_d` = 0.149 mm/s, `k_d` = 10 986 N/m (`v_d` inside a zone) hybrid windows gave `r` = 0.50
/// for 0. 25 % is about twice the farthest such reach seen there.
pub const ZONE_MARGIN: f64 = 0.25;

/// The contact resonance `√(k_t/m)/2π` \[Hz\] (1649 Hz on the defaults). Below it the fast
/// orbit of body and contact period-doubles and turns chaotic in zones of the mean velocity
/// that a table's nodes can straddle unseen, and attractors other than the period-1 orbit
/// coexist with it: on a 1024-point slice of `sweeps/overnight.toml` the full model settled at
/// 500 Hz, `u0` = 0.5 µm, `v_d` = 0.1 mm/s to a mean force of 4.17 N where the averaged law
/// (its orbits contracting at every node) gave 5.27 N, while every averaged point at 2000 and
/// 4000 Hz kept `r` within 0.0073 and the mean force within 1.3 %. [`Tier::Auto`] therefore
/// averages above it only; [`Tier::Averaged`] averages below it too.
pub fn contact_resonance(p: &Params) -> f64 {
    (p.k_t / p.m).sqrt() / (2.0 * std::f64::consts::PI)
}

/// The tier that serves a run of `p` (with `effects` on, `none` where there are none) asked
/// for with `tier`, why, and the law where it is the averaged one. [`Tier::Auto`] averages where
/// the run vibrates from the start without model extensions, `f ≥` [`SEPARATION`] times the
/// drive oscillator's frequency and above the contact resonance ([`contact_resonance`]), and
/// the law was found from rest on; [`Tier::Averaged`] drops
/// the separation rule. Under auto the law must also hold within [`ZONE_MARGIN`] of `v_d`
/// ([`TierReason::NearZone`]). The run itself then checks that its steady window stays where the law
/// may serve ([`SlowRun::left_law`]), and hands over to the full model where it does not
/// ([`TierReason::LeftLaw`]).
pub fn choose(
    p: &Params,
    none: bool,
    tier: Tier,
) -> (Tier, TierReason, Option<std::sync::Arc<Table>>) {
    let full = |r| (Tier::Full, r, None);
    if let Some(why) = prechecks(p, none, tier) {
        return full(why);
    }
    match shared_table(p) {
        Ok(t) if t.nodes.len() >= 2 => {
            let m = ZONE_MARGIN * p.v_d;
            if tier == Tier::Auto && t.first_invalid(p.v_d - m, p.v_d + m).is_some() {
                return full(TierReason::NearZone);
            }
            let (tier, why) = match tier {
                Tier::Auto => (Tier::Averaged, TierReason::Valid),
                Tier::Hybrid => (Tier::Hybrid, TierReason::AskedHybrid),
                _ => (Tier::Averaged, TierReason::AskedAveraged),
            };
            (tier, why, Some(t))
        }
        _ => full(TierReason::NoLaw),
    }
}

/// The orbit at `v`, continued from `from` along its tangent; halves the stride on failure.
fn reach(sh: &mut Shooter<'_>, from: &Orbit, v: f64) -> Result<Orbit, AveragingError> {
    // The start of the orbit at `to` from `o`, along the family's tangent.
    let guess = |o: &Orbit, to: f64| {
        let dv = to - o.v_mean;
        let t = finite_tangent(o);
        [
            o.start[0] + t[0] * dv,
            o.start[1] + t[1] * dv,
            o.force + o.slope * dv,
        ]
    };
    let mut base = *from;
    let mut err = None;
    for _ in 0..6 {
        match sh.orbit(v, guess(&base, v)) {
            Ok(o) => return Ok(o),
            Err(e) => {
                err = Some(e);
                // Half the stride, then on from there.
                let half = 0.5 * (base.v_mean + v);
                base = sh.orbit(half, guess(&base, half))?;
            }
        }
    }
    Err(err.expect("tried"))
}

/// The start `(v(0), s(0), F)` of the orbit at `v` between orbits `a` and `b`: the cubic
/// Hermite interpolant of their starts and forces on the family's tangents and slopes.
fn between(a: &Orbit, b: &Orbit, v: f64) -> [f64; 3] {
    let h = b.v_mean - a.v_mean;
    let s = (v - a.v_mean) / h;
    let (ta, tb) = (finite_tangent(a), finite_tangent(b));
    [
        cubic(h, s, [a.start[0], ta[0], b.start[0], tb[0]]),
        cubic(h, s, [a.start[1], ta[1], b.start[1], tb[1]]),
        hermite(a, b, v),
    ]
}

/// The orbit's tangent where finite, `(1, 0)` (the body's velocity follows `V`) where not.
fn finite_tangent(o: &Orbit) -> [f64; 2] {
    if o.tangent.iter().all(|x| x.is_finite()) {
        o.tangent
    } else {
        [1.0, 0.0]
    }
}

/// Cubic Hermite interpolation of the force between two orbits at `v`.
fn hermite(a: &Orbit, b: &Orbit, v: f64) -> f64 {
    let h = b.v_mean - a.v_mean;
    if h <= 0.0 {
        return a.force;
    }
    cubic(h, (v - a.v_mean) / h, [a.force, a.slope, b.force, b.slope])
}

/// The cubic Hermite interpolant at `s = (v − v_a)/h` of an interval `h` wide with values and
/// slopes `[x_a, x_a', x_b, x_b']` at its ends.
fn cubic(h: f64, s: f64, [x0, d0, x1, d1]: [f64; 4]) -> f64 {
    let (h00, h10, h01, h11) = (
        (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s),
        s * (1.0 - s) * (1.0 - s),
        s * s * (3.0 - 2.0 * s),
        s * s * (s - 1.0),
    );
    h00 * x0 + h10 * h * d0 + h01 * x1 + h11 * h * d1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_leaves_small_amplitudes_to_the_full_model() {
        let mut p = Params {
            f: 3000.0,
            v_d: 5e-4,
            ..Params::default()
        };
        for (ratio, want) in [(0.05, Some(TierReason::SmallAmplitude)), (0.2, None)] {
            p.set_v_a(ratio * p.v_d);
            assert_eq!(prechecks(&p, true, Tier::Auto), want, "v_a/v_d = {ratio}");
            // Asked for, the averaged tier is tried whatever the amplitude.
            assert_eq!(prechecks(&p, true, Tier::Averaged), None);
        }
    }

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
