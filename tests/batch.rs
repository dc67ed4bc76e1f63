//! The batch integrator against the scalar one: a point's integration in a lane, beside other
//! points, is bit for bit its integration alone with `Method::Dopri5` (samples, final state,
//! status and statistics), with and without envelope following, with and without model
//! extensions; a system whose terms differ from those of the systems in busy lanes is served by
//! the scalar path and says so.

use std::cell::RefCell;
use stickslip::model::{EffectKind, Effects, Params, Rig};
use stickslip::ode::batch::{Job, Path, WIDTH, solve_batch_dim};
use stickslip::ode::{Method, Options, OutputGrid, RunReport, Solver, Span};
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
        Span::new(j.t0, j.t1, j.grid),
        &mut j.y,
        &j.opts,
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

/// Every point through the batch integrator (for systems of `dim` states): each one's outcome
/// and path, by index.
fn batched(pts: &[(Params, f64, bool, Effects)], dim: usize) -> Vec<(Outcome, Path)> {
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
    solve_batch_dim(dim, jobs, |j, r, path| {
        got[j.id] = Some((r, bits(&j.y), path))
    });
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
    // One point with an effect among base-model points: the scalar path serves it, in its turn.
    let mut fx = Effects::none();
    fx.enable(EffectKind::Viscous);
    pts.insert(5, (pts[5].0, 0.01, false, fx));
    assert!(pts.len() > 8 * WIDTH);
    let got = batched(&pts, 3);
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
    use stickslip::sim::batch::Ask;
    use stickslip::sim::{RunOptions, Tier};
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
    // The base model, and two extensions without states of their own (in lanes too; the
    // full model alone).
    let mut loaded = Effects::none();
    loaded.enable(EffectKind::NormalCoupling);
    loaded.enable(EffectKind::DriveRipple);
    batch_against_alone(&asks, &Effects::none());
    // With the extensions, the runs over a fixed time (an automatic one grows long with them).
    let fixed: Vec<_> = asks
        .iter()
        .filter(|a| a.opts.t_end.is_some())
        .cloned()
        .collect();
    batch_against_alone(&fixed, &loaded);
}

/// Every ask through [`simulate_batch`] against [`simulate_in`] alone.
fn batch_against_alone(asks: &[stickslip::sim::batch::Ask], fx: &Effects) {
    use stickslip::averaged::store::TableStore;
    use stickslip::sim::batch::simulate_batch;
    use stickslip::sim::simulate_in;
    let store = TableStore::new();
    let mut solver = Solver::new(Method::Auto);
    let mut got = std::collections::BTreeMap::new();
    let mut lanes = 0;
    simulate_batch(asks.to_vec(), fx, &mut solver, &store, |id, r, path| {
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
    for a in asks {
        let mut s = Solver::new(a.opts.method);
        let want = simulate_in(&a.p, fx, &a.opts, &mut s, &TableStore::new()).unwrap();
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

/// Every effect of the library in each of its forms, switched on at its defaults.
fn each_form() -> Vec<(&'static stickslip::model::effects::EffectInfo, Effects)> {
    use stickslip::model::effects::{EFFECTS, form_param};
    let mut sets = Vec::new();
    for info in EFFECTS {
        let forms: Vec<Option<f64>> = if info.forms.is_empty() {
            vec![None]
        } else {
            info.forms.iter().map(|f| Some(f.value)).collect()
        };
        for form in forms {
            let mut fx = Effects::none();
            fx.enable(info.kind);
            if let Some(v) = form {
                fx.set(info.kind, form_param(info.kind), v).unwrap();
            }
            sets.push((info, fx));
        }
    }
    sets
}

/// Every effect of the library in each of its forms (and a few together), on points that differ
/// in their drive, vibration and effect parameters, integrated in lanes beside each other: each
/// bit for bit its integration alone, and served by the lanes.
#[test]
fn effects_in_lanes_are_the_effects_alone_bit_for_bit() {
    use stickslip::model::effects::form_param;
    use stickslip::ode::batch::MAX_LANE_DIM;
    let mut sets: Vec<Effects> = each_form().into_iter().map(|(_, fx)| fx).collect();
    let mut both = Effects::none();
    both.enable(EffectKind::Aging);
    both.enable(EffectKind::SensorDynamics);
    both.enable(EffectKind::NormalCoupling);
    sets.push(both);
    let mut three = Effects::none();
    three.set(EffectKind::Presliding, "elements", 3.0).unwrap();
    three.enable(EffectKind::FrictionalLag);
    sets.push(three);
    // The largest rig the lanes serve: a fourth-order sensor beside ageing, eight states.
    let mut eight = Effects::none();
    eight.enable(EffectKind::Aging);
    eight.enable(EffectKind::SensorDynamics);
    eight
        .set_form(EffectKind::SensorDynamics, "order4")
        .unwrap();
    sets.push(eight);
    let mut served = 0;
    for fx in &sets {
        // Points of one shape: the effect's own parameters moved within their ranges.
        let mut pts = Vec::new();
        for (n, (p, t_end, env)) in points().into_iter().enumerate().step_by(5) {
            let mut fx = fx.clone();
            let shape = |fx: &Effects| Rig::with_effects(p, fx).unwrap().shape();
            for (kind, vals) in fx.list.clone() {
                for (j, q) in kind.info().params.iter().enumerate() {
                    if q.name == "elements" || q.name == form_param(kind) {
                        continue;
                    }
                    let before = fx.clone();
                    let v = (vals[j] * (0.8 + 0.1 * (n % 5) as f64)).clamp(q.min, q.max);
                    fx.set(kind, q.name, v).unwrap();
                    // Where the value changes the terms (a Stribeck exponent off 2), keep the old.
                    if shape(&fx) != shape(&before) {
                        fx = before;
                    }
                }
            }
            pts.push((p, t_end, env, fx));
        }
        // A rig with more states than the lanes serve runs on the scalar path.
        let dim = Rig::with_effects(pts[0].0, &pts[0].3)
            .unwrap()
            .initial_state()
            .len();
        let path = if dim <= MAX_LANE_DIM {
            Path::Lanes
        } else {
            Path::Scalar
        };
        for (i, ((p, t_end, env, fx), (b, got_path))) in
            pts.iter().zip(batched(&pts, dim)).enumerate()
        {
            let want = alone(p, *t_end, *env, fx);
            assert_eq!(want.report, b.report, "{fx:?}, point {i}");
            assert_eq!(want.end, b.end, "{fx:?}, point {i}");
            assert!(want.seen == b.seen, "{fx:?}, point {i}: the samples differ");
            assert_eq!(got_path, path, "{fx:?}, point {i}");
            served += usize::from(path == Path::Lanes);
        }
    }
    // Every set fits the lanes: eight states at most.
    assert!(served >= 8 * sets.len(), "{served} runs in lanes");
}

/// Recordings' simulations through [`simulate_grids`] (lanes where they can, spread over the
/// pool) against [`simulate_grid`] one at a time: every sample bit for bit, whatever the mix of
/// models, effects, stages and sampling beside it.
#[test]
fn grids_in_lanes_are_the_grids_alone() {
    use stickslip::campaign::{GridAsk, Solvers, simulate_grid, simulate_grids};
    let mut sets = vec![Effects::none()];
    let mut aging = Effects::none();
    aging.enable(EffectKind::Aging);
    sets.push(aging);
    let mut sensor = Effects::none();
    sensor.enable(EffectKind::SensorDynamics);
    sets.push(sensor.clone());
    // A fourth-order sensor: seven states, the lanes' second largest.
    sensor
        .set_form(EffectKind::SensorDynamics, "order4")
        .unwrap();
    sets.push(sensor.clone());
    // Its output recorded late: sampled from a grid started before the recording's.
    sensor
        .set_form(EffectKind::SensorDynamics, "order4_delay")
        .unwrap();
    sensor
        .set(EffectKind::SensorDynamics, "delay", 2.7e-4)
        .unwrap();
    sets.push(sensor);
    let mut normal = Effects::none();
    normal.enable(EffectKind::NormalCoupling);
    sets.push(normal);
    let mut asks = Vec::new();
    for (n, (p, _, _)) in points().into_iter().enumerate().step_by(3) {
        let fx = sets[n % sets.len()].clone();
        let mut p = p;
        // Some in two stages: the vibration switched on within the recording.
        if n % 7 == 0 && p.u0 > 0.0 {
            p.t_on = 0.004;
        }
        let dt = [1e-4, 5e-5][n % 2];
        asks.push(GridAsk {
            p,
            fx,
            t0: 0.001 * (n % 3) as f64,
            dt,
            n: 200 + 37 * (n % 5),
            tol: [1e-5, 1e-4][n % 2],
        });
    }
    let got = simulate_grids(&asks);
    assert_eq!(got.len(), asks.len());
    let mut s = Solvers::default();
    for (i, (a, (g, _))) in asks.iter().zip(&got).enumerate() {
        let want = simulate_grid(&a.p, &a.fx, a.t0, a.dt, a.n, a.tol, &mut s).unwrap();
        let g = g.as_ref().expect("valid asks");
        assert_eq!(want.status, g.status, "ask {i}");
        for (w, v) in [
            (&want.f_d, &g.f_d),
            (&want.x_s, &g.x_s),
            (&want.x_d, &g.x_d),
        ] {
            assert_eq!(bits(w), bits(v), "ask {i}: {:?}", a.p);
        }
    }
}

/// An effect that acts only through the vibration (`EffectKind::vibration_only`: the
/// actuator and the load swing, in every form, at strengths off their defaults) leaves a run
/// without vibration bit for bit as the base model has it; the detection limits rely on it to
/// skip those recordings. The other candidates do change such a run.
#[test]
fn vibration_only_effects_leave_a_run_without_vibration_alone() {
    use stickslip::averaged::store::TableStore;
    use stickslip::model::effects::form_param;
    use stickslip::sim::{RunOptions, Tier, simulate_in};
    let p = Params {
        u0: 0.0,
        ..Params::default()
    };
    // The explicit method: the stiff one's Jacobian takes another path with effects on (its
    // LU factorisations differ, the trace by rounding).
    let opts = RunOptions {
        method: Method::Dopri5,
        tier: Tier::Full,
        t_end: Some(0.05),
        trace: true,
        ..RunOptions::default()
    };
    let run = |fx: &Effects| {
        let mut s = Solver::new(opts.method);
        shown(&simulate_in(&p, fx, &opts, &mut s, &TableStore::new()).unwrap())
    };
    let base = run(&Effects::none());
    for (info, mut fx) in each_form().into_iter().filter(|(i, _)| i.candidate) {
        // Each parameter moved off its default, within its bounds (not the form's).
        for q in info.params {
            if q.name == "elements" || q.name == form_param(info.kind) {
                continue;
            }
            let v = (q.default * 1.5 + 0.1 * (q.max - q.min).min(1.0)).clamp(q.min, q.max);
            fx.set(info.kind, q.name, v).unwrap();
        }
        let same = run(&fx) == base;
        assert_eq!(
            same,
            info.kind.vibration_only(),
            "{:?}: the run without vibration is {}",
            fx.list,
            if same { "unchanged" } else { "changed" }
        );
    }
}
