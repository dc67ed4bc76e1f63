//! Throughput of the batch integrator against the scalar one, side by side in one run: the
//! same points integrated one after another by `Method::Dopri5` and `WIDTH` at a time in
//! vector lanes (`stickslip::ode::batch`), on one thread each, without and with envelope
//! following, and the ratio. The results are bit for bit the same (`tests/batch.rs`); this
//! checks it again on every point it times.
//!
//! `cargo bench --bench batch -- [POINTS] [SIMULATED_TIME_S]` (defaults 1024 and 0.05): a slice
//! of the overnight grid's full-model region below the contact resonance, `f` 500 to 1500 Hz,
//! `v_d` 0.1 to 1.6 mm/s, `k_d` 1000 to 16 000 N/m, `u0` 5 nm to 3 µm, logarithmic, by index.
//! Results and the machine they ran on: `benches/batch.md`.

use std::time::Instant;
use stickslip::model::{Params, Rig};
use stickslip::ode::batch::{Job, Path, WIDTH, solve_batch};
use stickslip::ode::{Method, Options, OutputGrid, Solver, Span};
use stickslip::sim::{envelope_for, sampling};

/// `n` values from `a` to `b`, logarithmic, by index.
fn logspace(a: f64, b: f64, n: usize, i: usize) -> f64 {
    a * (b / a).powf(i as f64 / (n - 1).max(1) as f64)
}

/// The first `count` points of a 4 × 4 × 8 × 8 grid over (v_d, k_d, f, u0), f fastest.
fn points(count: usize) -> Vec<Params> {
    (0..count)
        .map(|n| {
            let (i_f, i_u, i_k, i_v) = (n % 8, (n / 8) % 8, (n / 64) % 4, (n / 256) % 4);
            Params {
                v_d: logspace(1e-4, 1.6e-3, 4, i_v),
                k_d: logspace(1000.0, 16_000.0, 4, i_k),
                f: logspace(500.0, 1500.0, 8, i_f),
                u0: logspace(5e-9, 3e-6, 8, i_u),
                ..Params::default()
            }
        })
        .collect()
}

/// The job of point `p`: `t_end` of simulated time, 16 samples a period, the force summed.
fn job(id: usize, p: &Params, t_end: f64, env: bool) -> Job<Rig, impl FnMut(f64, &[f64]) -> bool> {
    let rig = Rig::new(*p).expect("valid point");
    let (dt, k) = sampling(p, 16);
    let y = rig.initial_state();
    let mut sum = 0.0;
    let force = rig.clone();
    Job {
        id,
        sys: rig,
        t0: 0.0,
        t1: t_end,
        y,
        opts: Options::default(),
        grid: OutputGrid {
            start: 0.0,
            step: dt,
            count: (t_end / dt).floor() as u64 + 1,
        },
        envelope: env.then(|| envelope_for(p, k, 1e-4)),
        observe: move |t: f64, y: &[f64]| {
            sum += force.drive_force(t, y);
            sum.is_finite()
        },
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let count: usize = args
        .first()
        .map_or(1024, |a| a.parse().expect("POINTS: a count"));
    let t_end: f64 = args
        .get(1)
        .map_or(0.05, |a| a.parse().expect("SIMULATED_TIME_S: seconds"));
    let pts = points(count);
    println!(
        "{count} points, {t_end} s simulated each, {WIDTH} lanes, vector set {:?}",
        pulp::Arch::new()
    );
    println!("envelope  scalar [points/s]  batch [points/s]  ratio  rhs/point  steps/point");
    for env in [false, true] {
        // Interleaved repeats, the fastest of each kept: the machine is shared and noisy.
        let (mut scalar, mut batch) = (f64::INFINITY, f64::INFINITY);
        let (mut rhs, mut steps) = (0, 0);
        for _ in 0..REPEATS {
            let (t, want, r, st) = run_scalar(&pts, t_end, env);
            scalar = scalar.min(t);
            (rhs, steps) = (r, st);
            let (t, got) = run_batch(&pts, t_end, env);
            batch = batch.min(t);
            for (i, (w, g)) in want.iter().zip(&got).enumerate() {
                assert!(Some(w) == g.as_ref(), "point {i} differs between the paths");
            }
        }
        println!(
            "{:8}  {:17.1}  {:16.1}  {:5.2}  {:9}  {:11}",
            if env { "1e-4" } else { "none" },
            count as f64 / scalar,
            count as f64 / batch,
            scalar / batch,
            rhs / count as u64,
            steps / count as u64,
        );
    }
}

/// Timed repeats of each path (the fastest counts).
const REPEATS: usize = 3;

type Outcome = (stickslip::ode::RunReport, Vec<f64>);

/// One Dopri5 solver, point after point: time, outcomes, right-hand sides and steps.
fn run_scalar(pts: &[Params], t_end: f64, env: bool) -> (f64, Vec<Outcome>, u64, u64) {
    let clock = Instant::now();
    let mut s = Solver::new(Method::Dopri5);
    let mut want = Vec::with_capacity(pts.len());
    let (mut rhs, mut steps) = (0, 0);
    for (i, p) in pts.iter().enumerate() {
        let mut j = job(i, p, t_end, env);
        let r = s.solve_envelope(
            &j.sys,
            Span::new(j.t0, j.t1, j.grid),
            &mut j.y,
            &j.opts,
            j.envelope.as_ref(),
            &mut j.observe,
        );
        rhs += r.stats.rhs_evals;
        steps += r.stats.steps;
        want.push((r, j.y));
    }
    (clock.elapsed().as_secs_f64(), want, rhs, steps)
}

/// The same jobs in lanes: time and outcomes.
fn run_batch(pts: &[Params], t_end: f64, env: bool) -> (f64, Vec<Option<Outcome>>) {
    let clock = Instant::now();
    let mut got = vec![None; pts.len()];
    let jobs = pts.iter().enumerate().map(|(i, p)| job(i, p, t_end, env));
    solve_batch::<Rig, _, 3>(jobs, |j, r, path| {
        assert_eq!(path, Path::Lanes);
        got[j.id] = Some((r, j.y));
    });
    (clock.elapsed().as_secs_f64(), got)
}
