//! Forward sensitivities against finite differences of whole integrations, measured side by
//! side in one run: for each recording of a campaign, under the default model at the fits'
//! tolerance, the time of one sensitive simulation along the four fitted base parameters
//! (`F_s`, `F_c`, `v_s`, `h_d`: `campaign::sensitivity`) and of the `1 + 4` integrations a
//! forward-difference Jacobian costs, and how far the two derivatives of the recorded force lie
//! apart (the largest over the samples, in units of the largest derivative).
//!
//! `cargo bench --bench sensitivity -- DIR` (a campaign directory, e.g. one that
//! `stickslip synth DIR --design small` writes). The measurements: `benches/sensitivity.md`.

use std::time::Instant;
use stickslip::campaign::sensitivity::{
    Direction, ErrorControl, Knob, Samples, simulate_grid_sensitive,
};
use stickslip::campaign::{Campaign, FIT_TOLERANCE, Solvers, simulate_grid};
use stickslip::diagnosis::model::Model;
use stickslip::model::params::info;

fn main() {
    let Some(dir) = std::env::args().skip(1).find(|a| !a.starts_with("--")) else {
        eprintln!("usage: cargo bench --bench sensitivity -- CAMPAIGN_DIR [--full]");
        std::process::exit(2);
    };
    let c = match Campaign::load(std::path::Path::new(&dir)) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("{dir}: {e}");
            std::process::exit(1);
        }
    };
    let m = Model::default();
    let mut s = Solvers::default();
    // `--full`: the sensitivities in the error control too.
    let control = if std::env::args().any(|a| a == "--full") {
        ErrorControl::Full
    } else {
        ErrorControl::State
    };
    let (mut t_sens, mut t_fd) = (0.0, 0.0);
    println!("recording    f [Hz]  sensitive [ms]  1+4 runs [ms]  ratio  departure per parameter");
    for r in &c.recordings {
        let p = m.params_for(r);
        let at = Samples {
            t0: r.t[0],
            dt: r.dt(),
            n: r.t.len(),
        };
        let dirs: Vec<Direction> = ["F_s", "F_c", "v_s", "h_d"]
            .iter()
            .map(|n| {
                let i = info(n).expect("a base parameter");
                let bar = i.get(&p);
                Direction {
                    knob: Knob::Base(i),
                    bar: if bar > 0.0 { bar } else { 1.0 },
                }
            })
            .collect();
        let clock = Instant::now();
        let Ok(sens) =
            simulate_grid_sensitive(&p, &m.effects, &dirs, at, (FIT_TOLERANCE, control), &mut s)
        else {
            println!("{:10} failed", r.name);
            continue;
        };
        let a = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let run = |q: &stickslip::model::Params, s: &mut Solvers| {
            simulate_grid(q, &m.effects, at.t0, at.dt, at.n, FIT_TOLERANCE, s).map(|t| t.f_d)
        };
        let Ok(f0) = run(&p, &mut s) else { continue };
        let mut cols = vec![];
        for d in &dirs {
            let Knob::Base(i) = d.knob else { continue };
            let mut q = p;
            let h = 1e-3 * d.bar;
            i.set(&mut q, i.get(&p) + h);
            let Ok(f1) = run(&q, &mut s) else { continue };
            cols.push(
                f1.iter()
                    .zip(&f0)
                    .map(|(a, b)| (a - b) / h)
                    .collect::<Vec<f64>>(),
            );
        }
        let b = clock.elapsed().as_secs_f64();
        (t_sens, t_fd) = (t_sens + a, t_fd + b);
        let dep: Vec<String> = cols
            .iter()
            .zip(&sens.derivatives)
            .map(|(fd, got)| {
                let top = fd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let d = fd
                    .iter()
                    .zip(&got.f_d)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                format!("{:.1e}", d / top)
            })
            .collect();
        println!(
            "{:10} {:7} {:14.0} {:14.0} {:6.2}  {}",
            r.name,
            r.params.f,
            a * 1e3,
            b * 1e3,
            a / b,
            dep.join(" ")
        );
    }
    println!(
        "total: sensitive {:.2} s, 1+4 runs {:.2} s, ratio {:.2}",
        t_sens,
        t_fd,
        t_sens / t_fd
    );
}
