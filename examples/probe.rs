use stickslip::model::Params;
use stickslip::ode::{Method, Options, Solver};
use stickslip::sim::{RunOptions, run_case};
fn main() {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let (k_d, v_d, f, ratio, rtol) = (args[0], args[1], args[2], args[3], args[4]);
    let method: Method = std::env::var("M")
        .unwrap_or("radau5".into())
        .parse()
        .unwrap();
    let mut p = Params {
        k_d,
        v_d,
        f,
        ..Params::default()
    };
    if let Ok(v) = std::env::var("VS") {
        p.v_s = v.parse().unwrap();
    }
    if let Ok(v) = std::env::var("HT") {
        p.h_t = v.parse().unwrap();
    }
    p.set_v_a(ratio * v_d);
    let o = RunOptions {
        method,
        ode: Options {
            rtol,
            atol: rtol,
            ..Options::default()
        },
        ..RunOptions::default()
    };
    let mut s = Solver::new(method);
    let c = run_case(&p, &o, &mut s).unwrap();
    println!(
        "r={:.4}±{:.4} dF={:.4}±{:.4} mean={:.4} cyc={} per={:.4} peak={:.3} trough={:.3} stick={:.3} T={:.2} wall={:.3}s stats={:?}",
        c.r,
        c.r_stderr,
        c.run.measures.d_f,
        c.run.measures.d_f_stderr,
        c.run.measures.mean_force,
        c.run.measures.cycles,
        c.run.measures.period,
        c.run.measures.peak_force,
        c.run.measures.trough_force,
        c.run.measures.stick_fraction,
        c.run.t_end,
        c.run.wall_time,
        c.run.stats
    );
    if let Some(r) = &c.reference {
        println!(
            "  ref: dF={:.4}±{:.4} mean={:.4} cyc={} per={:.4} peak={:.3} trough={:.3} wall={:.3}s {:?}",
            r.measures.d_f,
            r.measures.d_f_stderr,
            r.measures.mean_force,
            r.measures.cycles,
            r.measures.period,
            r.measures.peak_force,
            r.measures.trough_force,
            r.wall_time,
            r.stats
        );
    }
}
