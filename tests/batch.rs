//! The batch integrator against the scalar one: a point's integration in a lane, beside other
//! points, is bit for bit its integration alone with `Method::Dopri5` (samples, final state,
//! status and statistics), with and without envelope following; a system with an effect is
//! served by the scalar path and says so.

use std::cell::RefCell;
use stickslip::model::{EffectKind, Effects, Params, Rig};
use stickslip::ode::batch::{Job, Path, WIDTH, solve_batch};
use stickslip::ode::{Method, Options, OutputGrid, RunReport, Solver};
use stickslip::sim::{envelope_for, sampling};

/// Each sample an observer saw: time and state, as bit patterns.
type Samples = Vec<(u64, Vec<u64>)>;

/// What an integration produced, as bit patterns: the report, the final state, every sample.
#[derive(Debug, PartialEq)]
struct Outcome {
    report: RunReport,
    end: Vec<u64>,
    seen: Samples,
}

fn bits(y: &[f64]) -> Vec<u64> {
    y.iter().map(|v| v.to_bits()).collect()
}

/// Most samples an observer takes before it ends its job (so some jobs end on the observer).
const MOST: usize = 500;

/// A spread of points: drive velocity, stiffness, frequency and amplitude below and above the
/// elimination boundary, some without vibration, every third under envelope following.
fn points() -> Vec<(Params, f64, bool)> {
    let mut out = Vec::new();
    let mut n = 0;
    for v_d in [1e-4, 3e-4, 1e-3] {
        for k_d in [1000.0, 5000.0] {
            for f in [500.0, 1200.0, 2500.0] {
                for u0 in [0.0, 2e-8, 1e-7, 5e-7] {
                    n += 1;
                    let p = Params {
                        v_d,
                        k_d,
                        f,
                        u0,
                        ..Params::default()
                    };
                    out.push((p, 0.01 + 0.005 * (n % 3) as f64, n % 3 == 0 && u0 > 0.0));
                }
            }
        }
    }
    out
}

/// The job of point `p` over `t_end`, sampled 16 times a period, observed by `observe`.
fn job<O>(id: usize, p: &Params, t_end: f64, env: bool, fx: &Effects, observe: O) -> Job<Rig, O> {
    let rig = Rig::with_effects(*p, fx).unwrap();
    let (dt, k) = sampling(p, 16);
    let y = rig.initial_state();
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
        envelope: (env && p.u0 > 0.0).then(|| envelope_for(p, k, 1e-4)),
        observe,
    }
}

fn alone(p: &Params, t_end: f64, env: bool, fx: &Effects) -> Outcome {
    let mut seen = Vec::new();
    let mut j = job(0, p, t_end, env, fx, ());
    let report = Solver::new(Method::Dopri5).solve_envelope(
        &j.sys,
        j.t0,
        j.t1,
        &mut j.y,
        &j.opts,
        j.grid,
        j.envelope.as_ref(),
        |t, y| {
            seen.push((t.to_bits(), bits(y)));
            seen.len() < MOST
        },
    );
    Outcome {
        report,
        end: bits(&j.y),
        seen,
    }
}

/// Every point through the batch integrator: each one's outcome and path, by index.
fn batched(pts: &[(Params, f64, bool, Effects)]) -> Vec<(Outcome, Path)> {
    let seen: RefCell<Vec<Samples>> = RefCell::new(vec![Vec::new(); pts.len()]);
    let mut got: Vec<Option<(RunReport, Vec<u64>, Path)>> = vec![None; pts.len()];
    let jobs = pts.iter().enumerate().map(|(i, (p, t_end, env, fx))| {
        let seen = &seen;
        job(i, p, *t_end, *env, fx, move |t: f64, y: &[f64]| {
            let mut s = seen.borrow_mut();
            s[i].push((t.to_bits(), bits(y)));
            s[i].len() < MOST
        })
    });
    solve_batch::<Rig, _, 3>(jobs, |j, r, path| got[j.id] = Some((r, bits(&j.y), path)));
    let seen = seen.into_inner();
    got.into_iter()
        .zip(seen)
        .map(|(g, seen)| {
            let (report, end, path) = g.expect("every job comes back");
            (Outcome { report, end, seen }, path)
        })
        .collect()
}

#[test]
fn a_point_in_a_lane_is_the_point_alone_bit_for_bit() {
    let mut pts: Vec<_> = points()
        .into_iter()
        .map(|(p, t, e)| (p, t, e, Effects::none()))
        .collect();
    // One point with an effect: the scalar path serves it, in its turn.
    let mut fx = Effects::none();
    fx.enable(EffectKind::Viscous);
    pts.insert(5, (pts[5].0, 0.01, false, fx));
    assert!(pts.len() > 8 * WIDTH);
    let got = batched(&pts);
    let (mut enveloped, mut cut) = (0, 0);
    for (i, ((p, t_end, env, fx), (b, path))) in pts.iter().zip(&got).enumerate() {
        let want = alone(p, *t_end, *env, fx);
        assert_eq!(want.report, b.report, "point {i}: {p:?}");
        assert_eq!(want.end, b.end, "point {i}");
        assert!(want.seen == b.seen, "point {i}: the samples differ");
        assert_eq!(
            *path,
            if fx.is_empty() {
                Path::Lanes
            } else {
                Path::Scalar
            }
        );
        enveloped += usize::from(b.report.stats.skipped_periods > 0);
        cut += usize::from(b.seen.len() == MOST);
    }
    // The spread exercised envelope jumps and observers that end their job.
    assert!(enveloped >= 3, "{enveloped} points jumped");
    assert!(
        cut >= 3 && cut < pts.len() - 3,
        "{cut} points ended on their observer"
    );
}

/// A run's result with its wall time cleared, as text: `{:?}` prints the shortest decimal that
/// reads back to the same double, and NaN as NaN, so equal texts are equal bits.
fn shown(r: &stickslip::sim::RunResult) -> String {
    let mut r = r.clone();
    r.wall_time = 0.0;
    format!("{r:?}")
}

#[test]
fn runs_in_a_batch_are_the_runs_alone() {
    use stickslip::averaged::store::TableStore;
    use stickslip::sim::batch::{Ask, simulate_batch};
    use stickslip::sim::{RunOptions, Tier, simulate_in};
    let mut asks = Vec::new();
    let mut id = 0;
    for (method, tier) in [
        (Method::Auto, Tier::Auto),
        (Method::Dopri5, Tier::Full),
        (Method::Radau5, Tier::Full),
    ] {
        for v_d in [1e-4, 6e-4] {
            for k_d in [1500.0, 8000.0] {
                for (f, u0) in [(700.0, 0.0), (700.0, 4e-8), (1300.0, 2e-7), (3000.0, 6e-8)] {
                    id += 1;
                    let p = Params {
                        v_d,
                        k_d,
                        f,
                        u0,
                        // One run in two stages: vibration switched on at 10 ms.
                        t_on: if id == 7 { 0.01 } else { 0.0 },
                        ..Params::default()
                    };
                    let opts = RunOptions {
                        method,
                        tier,
                        // Most runs over a fixed time; every eighth over the automatic one,
                        // continued while it settles, some under envelope following.
                        t_end: (id % 8 != 0).then_some(0.03),
                        envelope: (id % 3 != 0).then_some(1e-4),
                        trace: id % 5 == 0,
                        ..RunOptions::default()
                    };
                    asks.push(Ask { id, p, opts });
                }
            }
        }
    }
    let fx = Effects::none();
    let store = TableStore::new();
    let mut solver = Solver::new(Method::Auto);
    let mut got = std::collections::BTreeMap::new();
    let mut lanes = 0;
    simulate_batch(asks.clone(), &fx, &mut solver, &store, |id, r, path| {
        lanes += usize::from(path == Path::Lanes);
        assert!(
            got.insert(id, r.expect("valid runs")).is_none(),
            "run {id} came back twice"
        );
    });
    assert_eq!(got.len(), asks.len(), "every run comes back");
    // The mix sent runs both ways.
    assert!(
        lanes >= 16 && lanes < asks.len() - 8,
        "{lanes} runs in lanes"
    );
    for a in &asks {
        let mut s = Solver::new(a.opts.method);
        let want = simulate_in(&a.p, &fx, &a.opts, &mut s, &TableStore::new()).unwrap();
        assert_eq!(
            shown(&want),
            shown(&got[&a.id]),
            "run {}: {:?} {:?}",
            a.id,
            a.p,
            a.opts
        );
    }
}
