//! Hot paths: the rig's right-hand side and Jacobian, and short runs of each method with and
//! without vibration (ratios between methods are what to read; the machine is shared).
//! `cargo bench --bench integrators`; `-- --quick` for a short profile.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use stickslip::model::{Params, Rig};
use stickslip::ode::{Method, OdeSystem, Options, OutputGrid, Solver, Span};

fn rig(ratio: f64) -> Rig {
    let mut p = Params::default();
    p.set_v_a(ratio * p.v_d);
    Rig::new(p).unwrap()
}

fn model(c: &mut Criterion) {
    let r = rig(0.5);
    let y = [1e-4, 2e-4, 1e-7];
    let mut dy = [0.0; 3];
    let mut j = [0.0; 9];
    c.bench_function("rig/rhs", |b| {
        b.iter(|| r.rhs(black_box(0.123), black_box(&y), &mut dy))
    });
    c.bench_function("rig/jacobian", |b| {
        b.iter(|| r.jacobian(black_box(0.123), black_box(&y), &mut j))
    });
}

fn runs(c: &mut Criterion) {
    let mut g = c.benchmark_group("run");
    g.sample_size(10);
    for (name, ratio, t_end) in [
        ("no_vibration_10s", 0.0, 10.0),
        ("partial_0.5_0.2s", 0.5, 0.2),
        ("eliminated_2_0.2s", 2.0, 0.2),
    ] {
        let r = rig(ratio);
        for m in Method::ALL {
            let mut s = Solver::new(m);
            g.bench_function(format!("{name}/{m}"), |b| {
                b.iter(|| {
                    let mut y = r.initial_state();
                    s.solve(
                        &r,
                        Span::new(0.0, t_end, OutputGrid::NONE),
                        &mut y,
                        &Options::default(),
                        |_, _| {},
                    )
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, model, runs);
criterion_main!(benches);
