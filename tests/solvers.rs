//! Solver tests in three tiers:
//! 1. convergence order at fixed step size;
//! 2. error within tolerance units, with bounds on the work done;
//! 3. agreement with published reference solutions of standard stiff problems
//!    (Robertson, Van der Pol with μ = 1000, HIRES), from the Bari test set for IVP solvers
//!    (Mazzia & Magherini), whose reference values were computed with RADAU5 in quadruple
//!    precision (rtol = atol = 1.1e-18).

use stickslip::ode::{Method, OdeSystem, Options, OutputGrid, Solver, Span, Status};

/// `y' = y²`, `z' = cos(t) z`: exact `y = 1/(1 − t)`, `z = exp(sin t)` (nonlinear and
/// non-autonomous, so Rosenbrock's ∂f/∂t is exercised).
struct Exact;
impl OdeSystem for Exact {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[0] * y[0];
        dy[1] = t.cos() * y[1];
    }
    fn jacobian(&self, t: f64, y: &[f64], j: &mut [f64]) {
        j.copy_from_slice(&[2.0 * y[0], 0.0, 0.0, t.cos()]);
    }
    fn time_derivative(&self, t: f64, y: &[f64], d: &mut [f64], _s: &mut [f64]) {
        d[0] = 0.0;
        d[1] = -t.sin() * y[1];
    }
}
fn exact(t: f64) -> [f64; 2] {
    [1.0 / (1.0 - t), t.sin().exp()]
}

/// The forced oscillator `y₁'' + y₁ = sin 2t`, `y(0) = (1, 0)`: exact
/// `y₁ = cos t + (2/3) sin t − (1/3) sin 2t`. Linear with a constant Jacobian, so the simplified
/// Newton iteration of Radau5 is exact after one iteration and the fixed-step error is the
/// method's truncation error alone.
struct Forced;
impl OdeSystem for Forced {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -y[0] + (2.0 * t).sin();
    }
    fn jacobian(&self, _t: f64, _y: &[f64], j: &mut [f64]) {
        j.copy_from_slice(&[0.0, 1.0, -1.0, 0.0]);
    }
}
fn forced(t: f64) -> [f64; 2] {
    let (s, c) = t.sin_cos();
    [
        c + 2.0 / 3.0 * s - (2.0 * t).sin() / 3.0,
        -s + 2.0 / 3.0 * c - 2.0 / 3.0 * (2.0 * t).cos(),
    ]
}

struct Robertson;
impl OdeSystem for Robertson {
    fn dim(&self) -> usize {
        3
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = -0.04 * y[0] + 1e4 * y[1] * y[2];
        dy[2] = 3e7 * y[1] * y[1];
        dy[1] = -dy[0] - dy[2];
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) {
        j.copy_from_slice(&[
            -0.04,
            1e4 * y[2],
            1e4 * y[1],
            0.04,
            -1e4 * y[2] - 6e7 * y[1],
            -1e4 * y[1],
            0.0,
            6e7 * y[1],
            0.0,
        ]);
    }
    fn scale(&self, i: usize) -> f64 {
        // y2 lives near 1e-5 and below.
        if i == 1 { 1e-4 } else { 1.0 }
    }
}

/// Van der Pol in the Bari test set's scaling, ε = 1e-6 (μ = 1000).
struct VanDerPol(f64);
impl OdeSystem for VanDerPol {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = ((1.0 - y[0] * y[0]) * y[1] - y[0]) / self.0;
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) {
        let e = self.0;
        j.copy_from_slice(&[
            0.0,
            1.0,
            (-2.0 * y[0] * y[1] - 1.0) / e,
            (1.0 - y[0] * y[0]) / e,
        ]);
    }
}

struct Hires;
impl OdeSystem for Hires {
    fn dim(&self) -> usize {
        8
    }
    fn rhs(&self, _t: f64, y: &[f64], f: &mut [f64]) {
        f[0] = -1.71 * y[0] + 0.43 * y[1] + 8.32 * y[2] + 0.0007;
        f[1] = 1.71 * y[0] - 8.75 * y[1];
        f[2] = -10.03 * y[2] + 0.43 * y[3] + 0.035 * y[4];
        f[3] = 8.32 * y[1] + 1.71 * y[2] - 1.12 * y[3];
        f[4] = -1.745 * y[4] + 0.43 * y[5] + 0.43 * y[6];
        f[5] = -280.0 * y[5] * y[7] + 0.69 * y[3] + 1.71 * y[4] - 0.43 * y[5] + 0.69 * y[6];
        f[6] = 280.0 * y[5] * y[7] - 1.81 * y[6];
        f[7] = -280.0 * y[5] * y[7] + 1.81 * y[6];
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) {
        j.fill(0.0);
        let mut s = |r: usize, c: usize, v: f64| j[r * 8 + c] = v;
        s(0, 0, -1.71);
        s(0, 1, 0.43);
        s(0, 2, 8.32);
        s(1, 0, 1.71);
        s(1, 1, -8.75);
        s(2, 2, -10.03);
        s(2, 3, 0.43);
        s(2, 4, 0.035);
        s(3, 1, 8.32);
        s(3, 2, 1.71);
        s(3, 3, -1.12);
        s(4, 4, -1.745);
        s(4, 5, 0.43);
        s(4, 6, 0.43);
        s(5, 3, 0.69);
        s(5, 4, 1.71);
        s(5, 5, -0.43 - 280.0 * y[7]);
        s(5, 6, 0.69);
        s(5, 7, -280.0 * y[5]);
        s(6, 5, 280.0 * y[7]);
        s(6, 6, -1.81);
        s(6, 7, 280.0 * y[5]);
        s(7, 5, -280.0 * y[7]);
        s(7, 6, 1.81);
        s(7, 7, -280.0 * y[5]);
    }
}

const ROBER_T: f64 = 1e11;
// The digits as the reference table prints them (the last one is a trailing zero).
#[allow(clippy::excessive_precision)]
const ROBER_REF: [f64; 3] = [
    0.2083340149701255e-7,
    0.8333360770334713e-13,
    0.9999999791665050,
];
const VDP_REF: [f64; 2] = [0.1706167732170483e1, -0.8928097010247975];
const HIRES_T: f64 = 321.8122;
const HIRES_REF: [f64; 8] = [
    0.7371312573325668e-3,
    0.1442485726316185e-3,
    0.5888729740967575e-4,
    0.1175651343283149e-2,
    0.2386356198831331e-2,
    0.6238968252742796e-2,
    0.2849998395185769e-2,
    0.2850001604814231e-2,
];

fn opts(rtol: f64, atol: f64) -> Options {
    Options {
        rtol,
        atol,
        ..Options::default()
    }
}

/// Largest mixed error `|y − ref| / (atol + rtol |ref|)` in units of the requested tolerance.
fn tol_units(y: &[f64], r: &[f64], rtol: f64, atol: f64) -> f64 {
    y.iter()
        .zip(r)
        .map(|(a, b)| (a - b).abs() / (atol + rtol * b.abs()))
        .fold(0.0, f64::max)
}

// ---------------------------------------------------------------- tier 1: convergence order

fn fixed_step_error(method: Method, h: f64) -> f64 {
    let t1 = 2.0;
    let mut y = [1.0, 0.0];
    let o = Options {
        rtol: 0.1,
        atol: 1.0,
        h0: h,
        h_max: h,
        ..Options::default()
    };
    let rep = Solver::new(method).solve(
        &Forced,
        Span::new(0.0, t1, OutputGrid::NONE),
        &mut y,
        &o,
        |_, _| {},
    );
    assert_eq!(rep.status, Status::Success);
    assert_eq!(
        rep.stats.rejected, 0,
        "{method}: a fixed-step run must accept every step"
    );
    assert_eq!(
        rep.stats.steps,
        (t1 / h).round() as u64,
        "{method}: step count"
    );
    let e = forced(t1);
    ((y[0] - e[0]).powi(2) + (y[1] - e[1]).powi(2)).sqrt()
}

#[test]
fn convergence_orders_match_theory() {
    for (method, order, h) in [
        (Method::Radau5, 5.0, 0.25),
        (Method::Rodas4, 4.0, 0.125),
        (Method::Dopri5, 5.0, 0.125),
    ] {
        let e1 = fixed_step_error(method, h);
        let e2 = fixed_step_error(method, h / 2.0);
        let e3 = fixed_step_error(method, h / 4.0);
        let p1 = (e1 / e2).log2();
        let p2 = (e2 / e3).log2();
        assert!(
            (p1 - order).abs() < 0.5 && (p2 - order).abs() < 0.5,
            "{method}: observed orders {p1:.2}, {p2:.2}, expected {order}"
        );
    }
}

// ---------------------------------------------------------------- tier 2: tolerance and work

#[test]
fn error_within_tolerance_units_and_dense_output_agrees() {
    for method in Method::ALL {
        for rtol in [1e-4, 1e-6, 1e-8] {
            let atol = rtol;
            let mut y = [1.0, 1.0];
            let mut worst = 0.0f64;
            let grid = OutputGrid::linspace(0.0, 0.9, 91);
            let rep = Solver::new(method).solve(
                &Exact,
                Span::new(0.0, 0.9, grid),
                &mut y,
                &opts(rtol, atol),
                |t, yt| {
                    worst = worst.max(tol_units(yt, &exact(t), rtol, atol));
                },
            );
            assert_eq!(rep.status, Status::Success);
            // The final value is within a few tolerance units; the dense output (of lower order)
            // within tens of them.
            let end = tol_units(&y, &exact(0.9), rtol, atol);
            assert!(
                end < 20.0,
                "{method} rtol {rtol}: end error {end:.2} tolerance units"
            );
            assert!(
                worst < 50.0,
                "{method} rtol {rtol}: dense output error {worst:.2} tolerance units"
            );
            // Work grows no faster than tol^(-1/(p)) (with slack): bound the steps.
            let bound = 40.0 * rtol.powf(-1.0 / 4.0);
            assert!(
                (rep.stats.steps as f64) < bound,
                "{method} rtol {rtol}: {} steps > {bound:.0}",
                rep.stats.steps
            );
        }
    }
}

#[test]
fn tighter_tolerance_gives_smaller_error_on_van_der_pol() {
    // μ = 1000 is far too stiff for the explicit method: implicit methods only.
    for method in [Method::Radau5, Method::Rodas4] {
        let mut errs = vec![];
        for rtol in [1e-4, 1e-6, 1e-8] {
            let mut y = [2.0, 0.0];
            let rep = Solver::new(method).solve(
                &VanDerPol(1e-6),
                Span::new(0.0, 2.0, OutputGrid::NONE),
                &mut y,
                &opts(rtol, rtol),
                |_, _| {},
            );
            assert_eq!(rep.status, Status::Success);
            errs.push((y[0] - VDP_REF[0]).abs().max((y[1] - VDP_REF[1]).abs()));
        }
        assert!(
            errs[1] < errs[0] && errs[2] < errs[1],
            "{method}: errors {errs:?} must fall with the tolerance"
        );
    }
}

#[test]
fn explicit_method_stalls_on_stiffness_but_implicit_does_not() {
    // The stiffness ratio decides the work: Dopri5 needs orders of magnitude more steps than
    // Radau5 on Van der Pol with ε = 1e-5, and a step cap stops it with MaxSteps.
    let sys = VanDerPol(1e-5);
    let o = opts(1e-6, 1e-6);
    let mut y = [2.0, 0.0];
    let implicit = Solver::new(Method::Radau5).solve(
        &sys,
        Span::new(0.0, 2.0, OutputGrid::NONE),
        &mut y,
        &o,
        |_, _| {},
    );
    let mut y = [2.0, 0.0];
    let explicit = Solver::new(Method::Dopri5).solve(
        &sys,
        Span::new(0.0, 2.0, OutputGrid::NONE),
        &mut y,
        &o,
        |_, _| {},
    );
    assert_eq!(implicit.status, Status::Success);
    assert_eq!(explicit.status, Status::Success);
    assert!(
        explicit.stats.steps > 10 * implicit.stats.steps,
        "{:?} vs {:?}",
        explicit.stats,
        implicit.stats
    );
    let mut y = [2.0, 0.0];
    let capped = Solver::new(Method::Dopri5).solve(
        &sys,
        Span::new(0.0, 2.0, OutputGrid::NONE),
        &mut y,
        &Options {
            max_steps: 100,
            ..o
        },
        |_, _| {},
    );
    assert_eq!(capped.status, Status::MaxSteps);
    assert!(capped.t < 2.0);
}

#[test]
fn auto_is_dopri5_step_for_step_without_stiffness() {
    let t1 = 0.9;
    for rtol in [1e-4, 1e-8] {
        let run = |method| {
            let mut y = [1.0, 1.0];
            let mut samples = vec![];
            let rep = Solver::new(method).solve(
                &Exact,
                Span::new(0.0, t1, OutputGrid::linspace(0.0, t1, 10)),
                &mut y,
                &opts(rtol, rtol),
                |_, yt| samples.push(yt.to_vec()),
            );
            (rep, y, samples)
        };
        let (a, ya, sa) = run(Method::Auto);
        let (d, yd, sd) = run(Method::Dopri5);
        assert_eq!(a.status, Status::Success);
        assert_eq!(a.stats, d.stats, "rtol {rtol}");
        assert_eq!(ya, yd, "rtol {rtol}");
        assert_eq!(sa, sd, "rtol {rtol}");
    }
}

#[test]
fn auto_hands_stiff_stretches_to_the_implicit_method() {
    // Van der Pol with ε = 1e-5: slow stiff branches (λ ≈ −1/ε) and fast jumps. Dopri5 crawls
    // along the stability limit; Auto gives the branches to Radau5 and lands on a tight
    // Radau5 run.
    let sys = VanDerPol(1e-5);
    let o = opts(1e-6, 1e-6);
    let run = |method, o: &Options| {
        let mut y = [2.0, 0.0];
        let rep = Solver::new(method).solve(
            &sys,
            Span::new(0.0, 2.0, OutputGrid::NONE),
            &mut y,
            o,
            |_, _| {},
        );
        assert_eq!(rep.status, Status::Success, "{method}");
        (rep.stats, y)
    };
    let (auto, ya) = run(Method::Auto, &o);
    let (explicit, _) = run(Method::Dopri5, &o);
    let (implicit, _) = run(Method::Radau5, &o);
    let (_, yref) = run(Method::Radau5, &opts(1e-11, 1e-11));
    assert!(auto.jac_evals > 0, "{auto:?}");
    assert!(
        10 * auto.steps < explicit.steps && auto.steps < 3 * implicit.steps,
        "auto {auto:?}, dopri5 {explicit:?}, radau5 {implicit:?}"
    );
    let err = tol_units(&ya, &yref, 1e-6, 1e-6);
    assert!(
        err < 20.0,
        "auto: {ya:?} vs {yref:?}, {err:.2} tolerance units"
    );
}

#[test]
fn non_finite_state_is_reported() {
    // y' = y² blows up at t = 1.
    struct Blowup;
    impl OdeSystem for Blowup {
        fn dim(&self) -> usize {
            1
        }
        fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
            dy[0] = y[0] * y[0];
        }
        fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) {
            j[0] = 2.0 * y[0];
        }
    }
    for method in Method::ALL {
        let mut y = [1.0];
        let rep = Solver::new(method).solve(
            &Blowup,
            Span::new(0.0, 2.0, OutputGrid::NONE),
            &mut y,
            &opts(1e-6, 1e-6),
            |_, _| {},
        );
        assert_ne!(rep.status, Status::Success, "{method}");
        assert!(
            rep.t < 1.0 + 1e-6,
            "{method} passed the singularity: t = {}",
            rep.t
        );
    }
    let mut y = [f64::NAN];
    let rep = Solver::new(Method::Radau5).solve(
        &Blowup,
        Span::new(0.0, 1.0, OutputGrid::NONE),
        &mut y,
        &opts(1e-6, 1e-6),
        |_, _| {},
    );
    assert_eq!(rep.status, Status::NonFinite);
}

// ---------------------------------------------------------------- tier 3: published references

#[test]
fn robertson_matches_reference() {
    for (method, rtol) in [
        (Method::Radau5, 1e-8),
        (Method::Rodas4, 1e-8),
        (Method::Auto, 1e-8),
    ] {
        let mut y = [1.0, 0.0, 0.0];
        let rep = Solver::new(method).solve(
            &Robertson,
            Span::new(0.0, ROBER_T, OutputGrid::NONE),
            &mut y,
            &opts(rtol, 1e-10),
            |_, _| {},
        );
        assert_eq!(rep.status, Status::Success, "{method}");
        let rel: Vec<f64> = y
            .iter()
            .zip(ROBER_REF)
            .map(|(a, b)| ((a - b) / b).abs())
            .collect();
        if method == Method::Auto {
            // Its tries of the explicit method are accurate to the tolerance, not beyond it
            // (y₁ ≈ 2e-8 against atol = 1e-10).
            let err = tol_units(&y, &ROBER_REF, rtol, 1e-10);
            assert!(
                err < 1.0,
                "{method}: error {err:.3} tolerance units, {rel:?}"
            );
        } else {
            assert!(
                rel.iter().all(|&e| e < 1e-4),
                "{method}: relative errors {rel:?}"
            );
        }
        assert!(rep.stats.steps < 3000, "{method}: {:?}", rep.stats);
    }
}

#[test]
fn van_der_pol_mu_1000_matches_reference() {
    for (method, rtol, max_steps) in [
        (Method::Radau5, 1e-8, 3000),
        (Method::Rodas4, 1e-8, 20000),
        (Method::Auto, 1e-8, 3000),
    ] {
        let mut y = [2.0, 0.0];
        let rep = Solver::new(method).solve(
            &VanDerPol(1e-6),
            Span::new(0.0, 2.0, OutputGrid::NONE),
            &mut y,
            &opts(rtol, rtol),
            |_, _| {},
        );
        assert_eq!(rep.status, Status::Success, "{method}");
        let err = tol_units(&y, &VDP_REF, 1e-6, 1e-6);
        assert!(
            err < 1.0,
            "{method}: y = {y:?}, error {err:.3} units of 1e-6"
        );
        assert!(rep.stats.steps < max_steps, "{method}: {:?}", rep.stats);
        if method == Method::Radau5 {
            // The Jacobian is reused across steps.
            assert!(rep.stats.jac_evals < rep.stats.steps, "{:?}", rep.stats);
        }
    }
}

#[test]
fn hires_matches_reference() {
    for method in [Method::Radau5, Method::Rodas4, Method::Auto] {
        let mut y = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0057];
        let rep = Solver::new(method).solve(
            &Hires,
            Span::new(0.0, HIRES_T, OutputGrid::NONE),
            &mut y,
            &opts(1e-9, 1e-11),
            |_, _| {},
        );
        assert_eq!(rep.status, Status::Success, "{method}");
        let rel = y
            .iter()
            .zip(HIRES_REF)
            .map(|(a, b)| ((a - b) / b).abs())
            .fold(0.0, f64::max);
        assert!(rel < 1e-6, "{method}: max relative error {rel:.2e}");
        assert!(rep.stats.steps < 5000, "{method}: {:?}", rep.stats);
    }
}

#[test]
fn a_solver_is_reusable_and_gives_identical_runs() {
    let mut s = Solver::new(Method::Radau5);
    let run = |s: &mut Solver| {
        let mut y = [2.0, 0.0];
        let rep = s.solve(
            &VanDerPol(1e-3),
            Span::new(0.0, 1.0, OutputGrid::NONE),
            &mut y,
            &opts(1e-6, 1e-6),
            |_, _| {},
        );
        (y, rep.stats)
    };
    let a = run(&mut s);
    // A different dimension in between resizes the workspace.
    let mut y3 = [1.0, 0.0, 0.0];
    s.solve(
        &Robertson,
        Span::new(0.0, 1.0, OutputGrid::NONE),
        &mut y3,
        &opts(1e-6, 1e-6),
        |_, _| {},
    );
    let b = run(&mut s);
    assert_eq!(a.0, b.0);
    assert_eq!(a.1, b.1);
}

/// A damped oscillator driven by a slow quadratic ramp and a fast sine,
/// `x'' + 2ζω₀ x' + ω₀² x = ω₀² (b t² + A sin Ωt)`, started on its steady solution
/// `x = b t² + c₁ t + c₀ + X sin(Ωt − φ)` (closed form: `c₁ = −4ζb/ω₀`,
/// `c₀ = −(2b + 2ζω₀c₁)/ω₀²`, `X = ω₀²A/√((ω₀² − Ω²)² + (2ζω₀Ω)²)`). Its state sampled once per
/// forcing period follows a parabola: the case envelope following is built for.
struct Ramped;
const RAMP: (f64, f64, f64, f64, f64) = (
    std::f64::consts::TAU * 3000.0, // ω₀: the free motion decays within a forcing period
    0.5,                            // ζ
    1.0,                            // b
    1.0,                            // A
    std::f64::consts::TAU * 1000.0, // Ω
);
impl OdeSystem for Ramped {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let (w0, z, b, a, w) = RAMP;
        dy[0] = y[1];
        dy[1] = w0 * w0 * (b * t * t + a * (w * t).sin() - y[0]) - 2.0 * z * w0 * y[1];
    }
    fn jacobian(&self, _t: f64, _y: &[f64], j: &mut [f64]) {
        let (w0, z, ..) = RAMP;
        j.copy_from_slice(&[0.0, 1.0, -w0 * w0, -2.0 * z * w0]);
    }
}
fn ramped(t: f64) -> [f64; 2] {
    let (w0, z, b, a, w) = RAMP;
    let c1 = -4.0 * z * b / w0;
    let c0 = -(2.0 * b + 2.0 * z * w0 * c1) / (w0 * w0);
    let (re, im) = (w0 * w0 - w * w, 2.0 * z * w0 * w);
    let x = w0 * w0 * a / (re * re + im * im).sqrt();
    let phi = im.atan2(re);
    [
        b * t * t + c1 * t + c0 + x * (w * t - phi).sin(),
        2.0 * b * t + c1 + x * w * (w * t - phi).cos(),
    ]
}

/// Output grid of 2000 forcing periods of 1 ms, 16 samples each: the grid, the samples per
/// period and the last output time.
fn thousand_hertz_grid() -> (OutputGrid, u64, f64) {
    let (period, samples) = (1e-3, 16u64);
    let grid = OutputGrid {
        start: 0.0,
        step: period / samples as f64,
        count: 2000 * samples + 1,
    };
    (grid, samples, grid.time(grid.count - 1))
}

#[test]
fn envelope_following_skips_periods_and_stays_on_the_closed_form() {
    use stickslip::ode::Envelope;
    let (grid, samples, t1) = thousand_hertz_grid();
    for (method, baseline) in [
        (Method::Dopri5, 1),
        (Method::Dopri5, 4),
        (Method::Rodas4, 1),
        (Method::Rodas4, 4),
    ] {
        let env = Envelope {
            tol: 1e-3,
            baseline,
            ..Envelope::new(samples)
        };
        assert!(env.validate().is_ok());
        let o = opts(1e-8, 1e-8);
        let mut y = ramped(0.0).to_vec();
        let (mut worst, mut seen, mut last_t) = (0.0f64, 0u64, -1.0);
        let rep = Solver::new(method).solve_envelope(
            &Ramped,
            Span::new(0.0, t1, grid),
            &mut y,
            &o,
            Some(&env),
            |t, y| {
                assert!(t > last_t, "output times must increase");
                last_t = t;
                seen += 1;
                // Position error relative to the oscillation amplitude plus the ramp.
                worst = worst.max((y[0] - ramped(t)[0]).abs() / (1.0 + t * t));
                true
            },
        );
        assert_eq!(rep.status, Status::Success, "{method}");
        assert_eq!(
            seen, grid.count,
            "{method}: every output time observed once"
        );
        let skipped = rep.stats.skipped_periods;
        assert!(
            skipped > 1500,
            "{method}, baseline {baseline}: only {skipped} of 2000 periods skipped"
        );
        // Each jump's extrapolation error is held below tol; the damping keeps them from adding up.
        assert!(
            worst < 2.0 * env.tol,
            "{method}, baseline {baseline}: worst error {worst:.2e}"
        );
        // Without envelope following: same problem, every period integrated, no skips.
        let mut y = ramped(0.0).to_vec();
        let direct =
            Solver::new(method).solve(&Ramped, Span::new(0.0, t1, grid), &mut y, &o, |_, _| {});
        assert_eq!(direct.stats.skipped_periods, 0);
        assert!(
            direct.stats.rhs_evals > 4 * rep.stats.rhs_evals,
            "{method}: envelope {} vs direct {} right-hand sides",
            rep.stats.rhs_evals,
            direct.stats.rhs_evals
        );
    }
}

/// An undamped oscillator forced off its own frequency: `y'' + w0² y = a sin(w t)`, with
/// `w0 / w` the golden ratio's fraction, so its free oscillation, started by `y(0) = 1`, never
/// locks to the forcing and the samples taken once per forcing period turn by 222.5° each
/// (a quasi-periodic response, which envelope following cannot extrapolate).
const DETUNED: (f64, f64, f64) = (
    0.618_033_988_749_894_9,
    1.0,
    2.0 * std::f64::consts::PI * 1e3,
);
struct Detuned;
impl OdeSystem for Detuned {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let (q, a, w) = DETUNED;
        let w0 = q * w;
        dy[0] = y[1];
        dy[1] = a * (w * t).sin() - w0 * w0 * y[0];
    }
    fn jacobian(&self, _t: f64, _y: &[f64], j: &mut [f64]) {
        let w0 = DETUNED.0 * DETUNED.2;
        j.copy_from_slice(&[0.0, 1.0, -w0 * w0, 0.0]);
    }
}
/// Closed form of [`Detuned`] from `y(0) = 1`, `y'(0) = 0`.
fn detuned(t: f64) -> f64 {
    let (q, a, w) = DETUNED;
    let w0 = q * w;
    let c = a / (w0 * w0 - w * w);
    (w0 * t).cos() + c * ((w * t).sin() - w / w0 * (w0 * t).sin())
}

#[test]
fn envelope_integrates_a_response_it_cannot_follow_at_the_runs_own_tolerance() {
    use stickslip::ode::Envelope;
    let (grid, samples, t1) = thousand_hertz_grid();
    // Slopes are measured on periods integrated at inner · tol = 1e-7.
    let env = Envelope {
        tol: 1e-3,
        baseline: 4,
        settle: 4,
        inner: 1e-4,
        ..Envelope::new(samples)
    };
    let run = |rtol: f64, env: Option<&Envelope>| {
        let mut y = vec![1.0, 0.0];
        let mut worst = 0.0f64;
        let rep = Solver::new(Method::Dopri5).solve_envelope(
            &Detuned,
            Span::new(0.0, t1, grid),
            &mut y,
            &opts(rtol, rtol),
            env,
            |t, y| {
                worst = worst.max((y[0] - detuned(t)).abs());
                true
            },
        );
        assert_eq!(rep.status, Status::Success);
        (rep.stats, worst)
    };
    // Asked for 1e-7, every period is integrated at 1e-7, exactly as without the envelope.
    let (tight, tight_err) = run(1e-7, Some(&env));
    let (direct_tight, direct_tight_err) = run(1e-7, None);
    assert_eq!(
        tight.skipped_periods, 0,
        "no jump in a quasi-periodic response"
    );
    assert_eq!(tight.rhs_evals, direct_tight.rhs_evals);
    assert_eq!(tight_err, direct_tight_err);
    // Asked for 1e-4, the envelope gives up after its first refusals and integrates at 1e-4,
    // trying 1e-7 again between ever longer stretches: the work and the error of a run at 1e-4
    // (Dopri5's steps grow as the tolerance's fifth root, 1000^(1/5) ≈ 4), a little more of both.
    let (own, own_err) = run(1e-4, Some(&env));
    let (direct_own, direct_own_err) = run(1e-4, None);
    assert_eq!(
        own.skipped_periods, 0,
        "no jump in a quasi-periodic response"
    );
    assert!(
        (own.rhs_evals as f64) < 0.5 * tight.rhs_evals as f64
            && own.rhs_evals > direct_own.rhs_evals
            && (own.rhs_evals as f64) < 1.5 * direct_own.rhs_evals as f64,
        "right-hand sides: {} at the run's tolerance, {} at the inner one, {} without the envelope at 1e-4",
        own.rhs_evals,
        tight.rhs_evals,
        direct_own.rhs_evals
    );
    // The undamped free oscillation's phase error grows over its 1236 cycles: the worst error
    // is that of a run at the tolerance the periods were integrated with.
    assert!(
        own_err > 10.0 * tight_err && own_err < 1.5 * direct_own_err,
        "worst errors: {own_err:.2e} at the run's tolerance, {tight_err:.2e} at the inner one, \
         {direct_own_err:.2e} without the envelope at 1e-4"
    );
}

#[test]
fn envelope_options_are_validated_with_the_bound_quoted() {
    use stickslip::ode::Envelope;
    let e = Envelope {
        tol: 0.5,
        ..Envelope::new(16)
    };
    let err = e.validate().unwrap_err();
    assert_eq!(err.field, "envelope.tol");
    assert!(err.allowed.contains("0.1"), "{}", err.allowed);
    assert_eq!(
        Envelope::new(1).validate().unwrap_err().field,
        "envelope.period_samples"
    );
    let e = Envelope {
        baseline: 0,
        ..Envelope::new(16)
    };
    let err = e.validate().unwrap_err();
    assert_eq!((err.field, err.value), ("envelope.baseline", 0.0));
    assert!(err.allowed.contains("50"), "{}", err.allowed);
    let e = Envelope {
        inner: 1e-6,
        ..Envelope::new(16)
    };
    let err = e.validate().unwrap_err();
    assert_eq!((err.field, err.value), ("envelope.inner", 1e-6));
    assert!(err.allowed.contains("1e-5"), "{}", err.allowed);
    // The integration tolerance is lowered to `inner · tol`, never raised.
    let e = Envelope {
        tol: 1e-4,
        inner: 1e-4,
        ..Envelope::new(16)
    };
    assert_eq!(e.inner_tolerance(1e-6), 1e-8);
    assert_eq!(e.inner_tolerance(1e-9), 1e-9);
}

/// Van der Pol `x' = y, y' = μ (1 − x²) y − x` with its sensitivity `s = ∂(x, y)/∂μ`
/// (`s' = A s + ∂f/∂μ`), stored after the state. With `blocks` 2 the Newton iteration matrix is
/// `diag(A, A)` ([`OdeSystem::jacobian_blocks`]); with 1, the exact 4 × 4 Jacobian.
struct VdpSensitivity {
    mu: f64,
    blocks: usize,
}
impl OdeSystem for VdpSensitivity {
    fn dim(&self) -> usize {
        4
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let (x, v, sx, sv) = (y[0], y[1], y[2], y[3]);
        let mu = self.mu;
        dy[0] = v;
        dy[1] = mu * (1.0 - x * x) * v - x;
        dy[2] = sv;
        dy[3] = (-2.0 * mu * x * v - 1.0) * sx + mu * (1.0 - x * x) * sv + (1.0 - x * x) * v;
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) {
        let (x, v, sx, sv) = (y[0], y[1], y[2], y[3]);
        let mu = self.mu;
        let a10 = -2.0 * mu * x * v - 1.0;
        let a11 = mu * (1.0 - x * x);
        j.fill(0.0);
        j[1] = 1.0;
        j[4] = a10;
        j[5] = a11;
        j[2 * 4 + 3] = 1.0;
        j[3 * 4 + 2] = a10;
        j[3 * 4 + 3] = a11;
        if self.blocks == 1 {
            // The sensitivity rows' derivatives in x and v (dropped by the block form).
            j[3 * 4] = -2.0 * mu * v * sx - 2.0 * mu * x * sv - 2.0 * x * v;
            j[3 * 4 + 1] = -2.0 * mu * x * sx + 1.0 - x * x;
        }
    }
    fn jacobian_blocks(&self) -> usize {
        self.blocks
    }
}

#[test]
fn block_diagonal_iteration_matrix_gives_the_sensitivities_to_tolerance() {
    // Reference: central differences in μ of the state alone at rtol 1e-12 (another route to
    // ∂(x, y)/∂μ than the variational equations), step 1e-4 (truncation ~1e-8 relative).
    let (mu, t1) = (5.0, 3.0);
    let mut solver = Solver::new(Method::Radau5);
    let state = |m: f64, solver: &mut Solver| {
        let mut y = [2.0, 0.0, 0.0, 0.0];
        let rep = solver.solve(
            &VdpSensitivity { mu: m, blocks: 1 },
            Span::new(0.0, t1, OutputGrid::NONE),
            &mut y,
            &opts(1e-12, 1e-12),
            |_, _| {},
        );
        assert_eq!(rep.status, Status::Success);
        y
    };
    let d = 1e-4;
    let (hi, lo) = (state(mu + d, &mut solver), state(mu - d, &mut solver));
    let reference = [(hi[0] - lo[0]) / (2.0 * d), (hi[1] - lo[1]) / (2.0 * d)];
    let mut work = vec![];
    for blocks in [1, 2] {
        let mut y = [2.0, 0.0, 0.0, 0.0];
        let rep = solver.solve(
            &VdpSensitivity { mu, blocks },
            Span::new(0.0, t1, OutputGrid::NONE),
            &mut y,
            &opts(1e-7, 1e-7),
            |_, _| {},
        );
        assert_eq!(rep.status, Status::Success, "blocks {blocks}");
        for k in 0..2 {
            let err = (y[2 + k] - reference[k]).abs() / (1e-7 + 1e-7 * reference[k].abs());
            assert!(
                err < 200.0,
                "blocks {blocks}: ∂y{k}/∂μ {} vs {}: {err:.1} tolerance units",
                y[2 + k],
                reference[k]
            );
        }
        work.push(rep.stats);
    }
    // The block form takes about the steps of the dense one (its Newton iteration converges a
    // little slower where the dropped terms matter) and factorises no more often.
    let (dense, block) = (&work[0], &work[1]);
    assert!(block.steps <= 2 * dense.steps, "{dense:?} vs {block:?}");
}
