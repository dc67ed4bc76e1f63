//! The diffsol peer: the rig of docs/model.md solved with diffsol's BDF (analytic Jacobian-vector
//! product) or Tsit5, sampled on stickslip's output grid and measured with stickslip's own
//! analyser, so that only the integrator differs.
//!
//! Usage: stickslip-peer-diffsol METHOD VA_RATIO T_END RTOL REPEATS [FREQ]
//! (METHOD: bdf or tsit45; FREQ in Hz, default that of `Params::default()`). Prints one JSON object: method, rtol, time (median of the repeats,
//! the solve alone), dF, mean_force, steps-free status.

use diffsol::matrix::MatrixCommon;
use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod};
use stickslip::measures::{Analyzer, DROP_THRESHOLD, STICK_VELOCITY};
use stickslip::model::{Params, Rig};
use stickslip::ode::OdeSystem;
use stickslip::sim::sampling;
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if !(5..=6).contains(&a.len()) {
        eprintln!("usage: stickslip-peer-diffsol bdf|tsit45 VA_RATIO T_END RTOL REPEATS [FREQ]");
        std::process::exit(2);
    }
    let method = a[0].clone();
    let ratio: f64 = a[1].parse().expect("VA_RATIO");
    let t_end: f64 = a[2].parse().expect("T_END");
    let rtol: f64 = a[3].parse().expect("RTOL");
    let repeats: usize = a[4].parse().expect("REPEATS");
    let mut p = Params::default();
    if let Some(f) = a.get(5) {
        p.f = f.parse().expect("FREQ");
    }
    p.set_v_a(ratio * p.v_d);
    let rig = Rig::new(p).expect("valid parameters");
    // The same per-component absolute tolerance as stickslip: atol times the state's scale.
    let atol: Vec<f64> = (0..3).map(|i| rtol * rig.scale(i)).collect();
    let (dt, k) = sampling(&p, 16);
    let count = (t_end / dt).floor() as usize + 1;
    let t_eval: Vec<f64> = (0..count).map(|i| i as f64 * dt).collect();

    let mut times = vec![];
    let mut result = None;
    for _ in 0..repeats.max(1) {
        let r1 = rig.clone();
        let r2 = rig.clone();
        let problem = OdeBuilder::<NalgebraMat<f64>>::new()
            .rtol(rtol)
            .atol(atol.clone())
            .rhs_implicit(
                move |x, _p, t, y| r1.rhs(t, x, y),
                move |x, _p, t, v, y| {
                    let mut j = [0.0; 9];
                    r2.jacobian(t, x, &mut j);
                    for i in 0..3 {
                        y[i] = j[i * 3] * v[0] + j[i * 3 + 1] * v[1] + j[i * 3 + 2] * v[2];
                    }
                },
            )
            .init(|_p, _t, y| y.fill(0.0), 3)
            .build()
            .expect("problem builds");
        let start = Instant::now();
        let sol = match method.as_str() {
            "bdf" => problem.bdf::<NalgebraLU<f64>>().and_then(|mut s| s.solve_dense(&t_eval)),
            "tsit45" => problem.tsit45().and_then(|mut s| s.solve_dense(&t_eval)),
            other => panic!("unknown method {other}"),
        };
        times.push(start.elapsed().as_secs_f64());
        result = Some(sol);
    }
    times.sort_by(f64::total_cmp);
    let time = times[times.len() / 2];
    match result.expect("one repeat") {
        Ok((ys, _)) => {
            let mut an = Analyzer::new(k, 0.5 * t_end, DROP_THRESHOLD * (p.f_s - p.f_c), STICK_VELOCITY * p.v_d);
            let ncols = ys.ncols().min(t_eval.len());
            for c in 0..ncols {
                let y = [ys[(0, c)], ys[(1, c)], ys[(2, c)]];
                let t = t_eval[c];
                an.push(t, rig.drive_force(t, &y), rig.relative_velocity(t, &y));
            }
            let m = an.finish();
            let ok = ncols == t_eval.len();
            println!(
                "{{\"peer\": \"diffsol {method}\", \"rtol\": {rtol:e}, \"time\": {time:e}, \"dF\": {}, \"mean_force\": {}, \"status\": \"{}\"}}",
                m.d_f,
                m.mean_force,
                if ok { "success" } else { "stopped_early" }
            );
        }
        Err(e) => println!("{{\"peer\": \"diffsol {method}\", \"rtol\": {rtol:e}, \"time\": {time:e}, \"dF\": null, \"mean_force\": null, \"status\": \"{}\"}}", e.to_string().replace('"', "'")),
    }
}
