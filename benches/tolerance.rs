//! The search fidelity's tolerance, measured: each recording of a campaign simulated under the
//! default model at 1e-5 (the fits' tolerance) and at looser ones, with the time of each and the
//! largest move of a feature against 1e-5 in the measurement's standard errors
//! (`diagnosis::target::SEARCH_TOLERANCE` and docs/campaigns.md, "Two fidelities").
//!
//! `cargo bench --bench tolerance -- DIR` (a campaign directory, e.g. one that
//! `bash benches/diagnose/run.sh aging` writes: `results/diagnose-bench/c-aging`).

use std::time::Instant;
use stickslip::campaign::{Campaign, Solvers, simulate_grid};
use stickslip::diagnosis::features::FEATURES;
use stickslip::diagnosis::model::Model;
use stickslip::diagnosis::target::{difference, measured_features, sigma, trace_features};

fn main() {
    // `cargo bench` passes `--bench` first; the campaign is the first other argument.
    let Some(dir) = std::env::args().skip(1).find(|a| !a.starts_with("--")) else {
        eprintln!("usage: cargo bench --bench tolerance -- CAMPAIGN_DIR");
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
    let tols = [1e-5, 1e-4, 1e-3, 3e-3, 1e-2];
    let mut total = [0.0; 5];
    println!("recording    f [Hz]  then per tolerance: time [ms], largest feature move [sigma]");
    for r in &c.recordings {
        let measured = measured_features(r);
        let p = m.params_for(r);
        let mut line = format!("{:10} {:7}", r.name, r.params.f);
        let mut reference = None;
        for (k, tol) in tols.iter().enumerate() {
            let clock = Instant::now();
            let Ok(tr) = simulate_grid(&p, &m.effects, r.t[0], r.dt(), r.t.len(), *tol, &mut s)
            else {
                line += &format!(" | {tol:.0e}: failed");
                continue;
            };
            let el = clock.elapsed().as_secs_f64();
            total[k] += el;
            let fs = trace_features(
                r,
                &tr.f_d,
                r.x_s.as_ref().map(|_| &tr.x_s[..]),
                r.x_d.as_ref().map(|_| &tr.x_d[..]),
            );
            let Some(f0) = &reference else {
                line += &format!(" | {tol:.0e}: {:.0}", el * 1e3);
                reference = Some(fs);
                continue;
            };
            let mut worst: f64 = 0.0;
            for u in 0..fs.len().min(f0.len()) {
                for f in FEATURES {
                    let i = f as usize;
                    let (a, b, mv) = (fs[u].value[i], f0[u].value[i], measured[u].value[i]);
                    if a.is_finite() && b.is_finite() && mv.is_finite() {
                        let z = difference(f, a, b) / sigma(&measured[u], &f0[u], f);
                        worst = worst.max(z.abs());
                    }
                }
            }
            line += &format!(" | {tol:.0e}: {:.0} {worst:.2}", el * 1e3);
        }
        println!("{line}");
    }
    let t: Vec<String> = tols
        .iter()
        .zip(total)
        .map(|(t, s)| format!("{t:.0e} {s:.2} s"))
        .collect();
    println!("total: {}", t.join(", "));
}
