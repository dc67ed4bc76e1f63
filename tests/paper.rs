//! The paper's results (docs/model.md, "What the paper's results say the model must show") on the
//! Fig. 10 cases: k_d = 11 700 N/m, v_d = 0.5, 1.0, 1.5 mm/s, f = 1500 Hz; and Fig. 11's
//! low-frequency exception at f = 100 Hz, v_d = 0.5 mm/s. Plus the convergence criterion of
//! docs/model.md at the default tolerances.

use rayon::prelude::*;
use stickslip::model::Params;
use stickslip::ode::{Method, Options, Solver, Status};
use stickslip::sim::{CaseResult, EarlyStop, RunOptions, run_case};

/// The defaults on the full model, for the tests of its early stop and settling rules (the
/// averaged tier has its own in tests/averaged.rs).
fn full_model() -> RunOptions {
    RunOptions {
        tier: stickslip::sim::Tier::Full,
        ..RunOptions::default()
    }
}

fn case(v_d: f64, f: f64, ratio: f64, opts: &RunOptions) -> CaseResult {
    let mut p = Params {
        k_d: 11_700.0,
        v_d,
        f,
        ..Params::default()
    };
    p.set_v_a(ratio * v_d);
    let c = run_case(&p, opts, &mut Solver::new(opts.method)).unwrap();
    assert_eq!(
        c.status(),
        Status::Success,
        "v_d {v_d}, f {f}, ratio {ratio}"
    );
    c
}

const V_D: [f64; 3] = [0.5e-3, 1.0e-3, 1.5e-3];

#[test]
fn fig10_without_vibration_saw_tooth_with_peaks_near_f_s() {
    let p = Params::default();
    for v_d in V_D {
        let c = case(v_d, 1500.0, 0.0, &RunOptions::default());
        let m = c.run.measures;
        assert!(
            m.cycles >= 3,
            "v_d {v_d}: only {} cycles in the steady window",
            m.cycles
        );
        assert!(
            (m.peak_force - p.f_s).abs() < 0.05 * p.f_s,
            "v_d {v_d}: peak {}",
            m.peak_force
        );
        assert!(
            m.trough_force < p.f_c - 0.5 * (p.f_s - p.f_c),
            "v_d {v_d}: trough {} not well below F_c",
            m.trough_force
        );
        let nominal = 2.0 * (p.f_s - p.f_c);
        assert!(
            (m.d_f / nominal - 1.0).abs() < 0.2,
            "v_d {v_d}: dF {} vs 2(F_s - F_c) = {nominal}",
            m.d_f
        );
        assert!(
            m.stick_fraction > 0.5,
            "v_d {v_d}: stick fraction {}",
            m.stick_fraction
        );
    }
}

#[test]
fn fig10a_partial_reduction_below_v_d_keeps_the_mean_force() {
    V_D.par_iter().for_each(|&v_d| {
        let base = case(v_d, 1500.0, 0.0, &RunOptions::default())
            .run
            .measures
            .mean_force;
        let rs: Vec<(f64, f64)> = [0.2, 0.5, 0.9]
            .iter()
            .map(|&ratio| {
                let c = case(v_d, 1500.0, ratio, &RunOptions::default());
                let mf = c.run.measures.mean_force;
                assert!(
                    (mf / base - 1.0).abs() < 0.05,
                    "v_d {v_d}, v_a/v_d {ratio}: mean force {mf} vs {base} without vibration"
                );
                (c.r, c.r_stderr)
            })
            .collect();
        for w in rs.windows(2) {
            assert!(
                w[1].0 < w[0].0,
                "v_d {v_d}: r must fall as v_a/v_d rises: {rs:?}"
            );
        }
        assert!(
            rs[0].0 < 1.0 && rs[2].0 > 0.05,
            "v_d {v_d}: partial, not total, reduction: {rs:?}"
        );
    });
}

#[test]
fn fig10_eliminated_at_1_2_and_mean_force_falls_beyond() {
    V_D.par_iter().for_each(|&v_d| {
        let c = case(v_d, 1500.0, 1.2, &RunOptions::default());
        assert!(c.r < 0.05, "v_d {v_d}: r = {} at v_a/v_d = 1.2", c.r);
        let means: Vec<f64> = [1.5, 2.0, 3.0, 4.0]
            .iter()
            .map(|&ratio| {
                case(v_d, 1500.0, ratio, &RunOptions::default())
                    .run
                    .measures
                    .mean_force
            })
            .collect();
        for w in means.windows(2) {
            assert!(
                w[1] < w[0],
                "v_d {v_d}: mean force must fall with v_a/v_d from 1.5 to 4: {means:?}"
            );
        }
    });
}

#[test]
fn fig11_low_frequency_large_amplitude_does_not_eliminate() {
    // At f = 100 Hz the body follows the substrate: some v_a/v_d > 1.5 leaves r > 0.5.
    let found = [1.6, 2.0, 3.0]
        .par_iter()
        .map(|&ratio| case(0.5e-3, 100.0, ratio, &RunOptions::default()).r)
        .collect::<Vec<_>>();
    assert!(
        found.iter().any(|&r| r > 0.5),
        "r at f = 100 Hz, v_a/v_d = 1.6, 2, 3: {found:?}"
    );
    // While at 1500 Hz the same ratios eliminate it.
    let high = case(0.5e-3, 1500.0, 1.6, &RunOptions::default()).r;
    assert!(high < 0.05, "r = {high} at 1500 Hz");
}

/// docs/model.md, Numerics: tightening the tolerance tenfold moves r by less than the standard errors
/// plus 0.005, and the mean force by less than its standard error plus 0.5 %.
#[test]
fn default_tolerances_are_converged() {
    let cases = [(0.5e-3, 0.0), (0.5e-3, 0.5), (1.0e-3, 0.9), (0.5e-3, 2.0)];
    cases.par_iter().for_each(|&(v_d, ratio)| {
        for method in [Method::Radau5, Method::Dopri5] {
            let base = RunOptions {
                method,
                ..RunOptions::default()
            };
            let tight = RunOptions {
                method,
                ode: Options {
                    rtol: base.ode.rtol / 10.0,
                    atol: base.ode.atol / 10.0,
                    ..base.ode.clone()
                },
                ..base.clone()
            };
            let a = case(v_d, 1500.0, ratio, &base);
            let b = case(v_d, 1500.0, ratio, &tight);
            let dr = (a.r - b.r).abs();
            assert!(
                dr < a.r_stderr + b.r_stderr + 0.005,
                "{method} v_d {v_d} ratio {ratio}: r {} vs {} (±{}, ±{})",
                a.r,
                b.r,
                a.r_stderr,
                b.r_stderr
            );
            let (ma, mb) = (a.run.measures.mean_force, b.run.measures.mean_force);
            assert!(
                ((ma - mb) / mb).abs() < 0.005,
                "{method} v_d {v_d} ratio {ratio}: mean force {ma} vs {mb}"
            );
        }
    });
}

/// Early stop changes r by less than docs/model.md's convergence allowance (0.005 plus the standard
/// errors of both runs) and does less work. Steady sliding (v_a > v_d): the mean force within
/// 0.1 %. Stick-slip (v_a < v_d, the run ends once its window holds the cycles and gives dF to
/// the standard error asked for): the mean force within the bias of a window that cuts a
/// saw-tooth of amplitude dF with n cycles, dF / (8 n), for each of the two windows.
#[test]
fn early_stop_agrees_with_the_full_run() {
    // (v_d, v_a / v_d, sliding): at v_a = 60 v_d the force settles in about ten milliseconds and
    // the checks start before the twentieth of the planned time.
    [
        (0.5e-3, 2.0, true),
        (1.0e-3, 4.0, true),
        (0.5e-3, 60.0, true),
        (0.5e-3, 0.5, false),
    ]
    .par_iter()
    .for_each(|&(v_d, ratio, sliding)| {
        let early = case(
            v_d,
            1500.0,
            ratio,
            &RunOptions {
                method: Method::Dopri5,
                ..full_model()
            },
        );
        let full = case(
            v_d,
            1500.0,
            ratio,
            &RunOptions {
                method: Method::Dopri5,
                early_stop: EarlyStop::Off,
                ..full_model()
            },
        );
        assert!(
            early.run.t_end < full.run.t_end,
            "v_d {v_d} ratio {ratio}: {} vs {}",
            early.run.t_end,
            full.run.t_end
        );
        assert!(early.run.stats.rhs_evals < full.run.stats.rhs_evals);
        if ratio > 10.0 {
            let first = stickslip::sim::EARLY_STOP_FIRST * full.run.t_end;
            assert!(early.run.t_end < first, "{} vs {first}", early.run.t_end);
        }
        assert!(
            (early.r - full.r).abs() < 0.005 + early.r_stderr + full.r_stderr,
            "r {} ± {} vs {} ± {}",
            early.r,
            early.r_stderr,
            full.r,
            full.r_stderr
        );
        let (a, b) = (early.run.measures.mean_force, full.run.measures.mean_force);
        if sliding {
            assert_eq!(early.run.measures.cycles, 0);
            assert!(((a - b) / b).abs() < 1e-3, "mean force {a} vs {b}");
        } else {
            let (e, f) = (&early.run.measures, &full.run.measures);
            assert!(e.cycles >= 3, "{e:?}");
            // The standard error early stop asks for: 0.5 % of the nominal amplitude.
            let p = Params::default();
            assert!(e.d_f_stderr <= 0.005 * 2.0 * (p.f_s - p.f_c), "{e:?}");
            let bias = e.d_f / (8.0 * e.cycles as f64) + f.d_f / (8.0 * f.cycles as f64);
            assert!(
                (a - b).abs() < bias,
                "mean force {a} vs {b}, allowed {bias}"
            );
        }
    });
}

/// Eliminated stick-slip whose force still creeps towards its sliding level at the end of the
/// planned time (v_a a little above v_d). docs/model.md: the measures describe the settled state. The
/// early stop extrapolates the level once the approach is plainly exponential and near its
/// end; a run without early stop goes on until its window has settled. The two must agree to
/// r within 0.003 and the mean force within 0.1 % plus the stated error bound, the
/// extrapolation at less work.
#[test]
fn settled_level_extrapolated_agrees_with_the_run_continued_until_it_settles() {
    [(4000.0, 1.196), (3015.0, 1.76), (1500.0, 2.0)]
        .par_iter()
        .for_each(|&(f, ratio)| {
            let opts = |early_stop| RunOptions {
                method: Method::Dopri5,
                early_stop,
                ..full_model()
            };
            let early = case(0.5e-3, f, ratio, &opts(EarlyStop::Automatic));
            let full = case(0.5e-3, f, ratio, &opts(EarlyStop::Off));
            assert!(early.run.predicted(), "f {f}: {:?}", early.run);
            let err = early
                .run
                .level_error
                .expect("an extrapolated level states its error");
            assert!(!full.run.predicted() && full.run.level_error.is_none());
            assert!(full.r < 0.05, "f {f}: not eliminated, r {}", full.r);
            assert!(early.run.stats.rhs_evals < full.run.stats.rhs_evals);
            assert!(
                (early.r - full.r).abs() < 3e-3,
                "f {f}: r {} vs {}",
                early.r,
                full.r
            );
            let (a, b) = (early.run.measures.mean_force, full.run.measures.mean_force);
            assert!(
                (a - b).abs() < 1e-3 * b + err,
                "f {f}: mean force {a} ± {err} vs {b}"
            );
        });
}

/// The creep of docs/model.md. At v_d = 0.5 mm/s, k_d = 11 700 N/m, f = 1500 Hz, v_a/v_d = 1.7
/// (Fig. 10a) and at f = 1487 Hz, v_a/v_d = 1.69 (a creep island of the 32 × 32 Fig. 11 map) the
/// smoothed force creeps for some 20 s towards its sliding level; the planned time is 9.8 s.
/// Settled references: runs of 60 s (window 30 to 60 s) with Radau5 at rtol = atol = 1e-8,
/// `stickslip run --va-ratio 1.7 --t-end 60 --rtol 1e-8 --atol 1e-8 --solver radau5` (and
/// `--va-ratio 1.69 --f 1487`): mean force 4.838004 N and 5.002330 N, r 2.4e-6 and 3.8e-7
/// (the same at rtol 1e-6 with `--solver auto`: 4.837872 N and 5.002388 N). Radau5 integrating
/// every period, the defaults (auto with envelope following) and Dopri5 without early stop must
/// give r below 0.005 (elimination, not the 0.10 and 0.13 of the creep)
/// and the mean force within 0.1 % (0.5 % is docs/model.md's accuracy).
#[test]
fn creep_towards_the_sliding_level_is_not_stick_slip() {
    let settings: Vec<(f64, f64, f64, RunOptions)> =
        [(1500.0, 1.7, 4.838004), (1487.0, 1.69, 5.002330)]
            .into_iter()
            .flat_map(|(f, ratio, level)| {
                [
                    RunOptions {
                        method: Method::Radau5,
                        envelope: None,
                        ..full_model()
                    },
                    full_model(),
                    RunOptions {
                        method: Method::Dopri5,
                        early_stop: EarlyStop::Off,
                        ..full_model()
                    },
                ]
                .into_iter()
                .map(move |o| (f, ratio, level, o))
            })
            .collect();
    settings.par_iter().for_each(|(f, ratio, level, o)| {
        let c = case(0.5e-3, *f, *ratio, o);
        let m = &c.run.measures;
        let tag = format!("f {f}, v_a/v_d {ratio}, {:?} {:?}", o.method, o.early_stop);
        assert!(c.r < 0.005, "{tag}: r {} ({:?})", c.r, c.run);
        assert!(
            ((m.mean_force - level) / level).abs() < 1e-3,
            "{tag}: mean force {} vs {level}",
            m.mean_force
        );
        // The window that caught the creep, the planned one, is not the one reported.
        let planned = stickslip::sim::planned_time(&c.params, o.min_cycles);
        assert!(c.run.t_end > planned, "{tag}: {} s", c.run.t_end);
    });
}

/// A given simulated time is run in full unless early stop is asked for always; then it is the
/// longest time. A given time is not continued: where its window still creeps the run says so.
#[test]
fn a_given_t_end_ends_early_only_when_asked_always() {
    let opts = |early_stop| RunOptions {
        method: Method::Dopri5,
        t_end: Some(6.0),
        early_stop,
        ..full_model()
    };
    let given = case(0.5e-3, 1500.0, 2.0, &opts(EarlyStop::Automatic));
    let always = case(0.5e-3, 1500.0, 2.0, &opts(EarlyStop::Always));
    assert_eq!(given.run.t_end, 6.0);
    assert!(!given.run.predicted());
    assert!(always.run.t_end < 6.0, "{:?}", always.run);
    assert!(
        (always.r - given.r).abs() < 3e-3,
        "r {} vs {}",
        always.r,
        given.r
    );
    let (a, b) = (
        always.run.measures.mean_force,
        given.run.measures.mean_force,
    );
    assert!(((a - b) / b).abs() < 2.5e-3, "mean force {a} vs {b}");
    let mut p = Params {
        k_d: 11_700.0,
        v_d: 0.5e-3,
        f: 1500.0,
        ..Params::default()
    };
    p.set_v_a(1.7 * p.v_d);
    let short = RunOptions {
        t_end: Some(8.0),
        ..opts(EarlyStop::Automatic)
    };
    let c = run_case(&p, &short, &mut Solver::new(short.method)).unwrap();
    assert_eq!(c.run.status, Status::Unsettled, "{:?}", c.run);
    assert_eq!(c.run.t_end, 8.0);
}
