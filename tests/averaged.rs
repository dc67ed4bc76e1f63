//! The averaged friction law of body and contact (`stickslip::averaged`) against what it must
//! reduce to: the rigid Coulomb limit, the small-amplitude creep slope, and the settled sliding
//! force of full runs where vibration eliminates stick-slip.

use stickslip::averaged::{AveragingOptions, SHARED, Shooter, Table, table_span};
use stickslip::model::Params;
use stickslip::ode::Solver;
use stickslip::sim::slow::simulate_slow_with;
use stickslip::sim::{RunOptions, run_case_with};

fn params(f: f64, u0: f64, v_d: f64) -> Params {
    Params {
        f,
        u0,
        v_d,
        ..Params::default()
    }
}

/// Closed form (Littmann et al. 2001): Coulomb friction averaged over the phase of
/// `v_r = V − v_a cos φ` is `(2 F_c/π) asin(V/v_a)` for a body that does not follow the
/// substrate and a contact much stiffer than the amplitude asks (`u0 ≫ F_c/k_t`). Here
/// `F_s = F_c` (no Stribeck drop), `f = 4000 Hz` (the body's velocity ripple `F_c/(m ω)` is
/// 2e-3 of `v_a`) and `u0 = 20 µm`, 170 times `F_c/k_t`: the law must match to 1 %.
#[test]
fn rigid_coulomb_limit() {
    let p = Params {
        f_s: 8.3,
        ..params(4000.0, 20e-6, 0.5e-3)
    };
    let v_a = p.v_a();
    let mut sh = Shooter::new(&p, AveragingOptions::default()).expect("valid");
    let mut guess = [0.0, 0.0, 0.0];
    for frac in [0.0, 0.1, 0.3, 0.5, 0.7] {
        let v = frac * v_a;
        let o = sh.orbit(v, guess).expect("an orbit");
        let closed = 2.0 * p.f_c / std::f64::consts::PI * (v / v_a).asin();
        eprintln!(
            "V = {frac} v_a: F_eff {:.5} N, closed form {closed:.5} N",
            o.force
        );
        assert!(
            (o.force - closed).abs() <= 0.01 * p.f_c,
            "V = {frac} v_a: F_eff = {} N against the closed form {closed} N",
            o.force
        );
        // The slope too: d/dV of the closed form, 2 F_c / (π √(v_a² − V²)).
        let closed_slope = 2.0 * p.f_c / (std::f64::consts::PI * (v_a * v_a - v * v).sqrt());
        assert!(
            (o.slope / closed_slope - 1.0).abs() < 0.03,
            "V = {frac} v_a: slope {} against {closed_slope}",
            o.slope
        );
        // Far above the contact resonance the contact's mode dies within the period, and the
        // other multiplier is the mean velocity's, exp(−F_eff' T / m).
        assert!(o.contracting(), "multipliers {:?}", o.multipliers);
        let drift = (-o.slope / (p.f * p.m)).exp();
        let slow = if o.multipliers[0] == o.fast {
            o.multipliers[1]
        } else {
            o.multipliers[0]
        };
        assert!(
            (slow.0 - drift).abs() < 1e-3 && slow.1 == 0.0,
            "{slow:?} against {drift}"
        );
        guess = [o.start[0], o.start[1], o.force];
    }
}

/// Small amplitude: the contact stays in its pre-sliding regime and the mean slip grows
/// linearly with the force. The creep slope is `(π/2) F_s / v̂_r`, with `v̂_r` the relative
/// velocity amplitude of body and contact forced at `ω`:
/// `v̂_r = v_a |m ω² / (k_t − m ω² + i ω h_t)|` (the contact's linear response). At 1500 Hz,
/// v_a = 0.2 mm/s the table's slope at `V = 0` must match it to 5 %.
#[test]
fn small_amplitude_creep_slope() {
    let p = params(
        1500.0,
        0.2e-3 / (2.0 * std::f64::consts::PI * 1500.0),
        0.5e-3,
    );
    let mut sh = Shooter::new(&p, AveragingOptions::default()).expect("valid");
    let o = sh.orbit(0.0, [0.0, 0.0, 0.0]).expect("the orbit at V = 0");
    // Zero by symmetry, to the one-period integration's tolerance (rtol 1e-9 of F_c).
    assert!(
        o.force.abs() < 10.0 * 1e-9 * p.f_c,
        "symmetry: F_eff(0) = {}",
        o.force
    );
    let w = p.omega();
    let num = p.m * w * w;
    let den = num_complex::Complex64::new(p.k_t - p.m * w * w, w * p.h_t);
    let v_r = p.v_a() * num / den.norm();
    let creep = std::f64::consts::FRAC_PI_2 * p.f_s / v_r;
    eprintln!(
        "creep slope {} N s/m, (π/2) F_s / v̂_r = {creep} N s/m",
        o.slope
    );
    assert!(
        (o.slope / creep - 1.0).abs() < 0.05,
        "slope {} N s/m against (π/2) F_s / v̂_r = {creep} N s/m (v̂_r = {v_r} m/s)",
        o.slope
    );
}

/// Where vibration eliminates stick-slip the body slides steadily at `v_d` and the drive force
/// settles at `F_eff(v_d)` (without drive damping). Full runs (auto, rtol 1e-8, envelope off,
/// the settled level measured or extrapolated by the run's own rules) at 500, 1500 and 4000 Hz,
/// v_a = 2 v_d, against the table's value at `v_d`: within 0.1 % (the run's own level error is
/// 0.1 %; the published prototype agreed to 0.12 %).
#[test]
fn settled_sliding_force_of_full_runs() {
    for f in [500.0, 1500.0, 4000.0] {
        let v_d = 0.5e-3;
        let p = Params {
            k_d: 11_700.0,
            ..params(f, 2.0 * v_d / (2.0 * std::f64::consts::PI * f), v_d)
        };
        let table = Table::build(
            &p,
            1.5 * v_d,
            AveragingOptions {
                force_tol: 1e-4,
                ..AveragingOptions::default()
            },
        )
        .expect("a table");
        assert!(
            table.stopped_at.is_none(),
            "{f} Hz: stopped at {:?}",
            table.stopped_at
        );
        let averaged = table.force(v_d).expect("inside the table");
        let mut opts = RunOptions {
            tier: stickslip::sim::Tier::Full,
            ..RunOptions::default()
        };
        opts.ode.rtol = 1e-8;
        opts.ode.atol = 1e-8;
        opts.envelope = None;
        let mut solver = Solver::new(opts.method);
        let res = run_case_with(&p, &stickslip::model::Effects::none(), &opts, &mut solver)
            .expect("a run");
        assert!(res.r < 0.05, "{f} Hz: r = {} (not eliminated)", res.r);
        let full = res.run.measures.mean_force;
        let rhs: u64 = table.nodes.iter().map(|n| n.rhs_evals).sum();
        eprintln!(
            "{f} Hz: F_eff(v_d) = {averaged:.6} N, full run {full:.6} N ({:+.3e}), {} nodes, \
             {rhs} right-hand sides of the 12-state system; fast multiplier at v_d {:.3}",
            averaged / full - 1.0,
            table.nodes.len(),
            table
                .nodes
                .iter()
                .min_by(|a, b| (a.v_mean - v_d).abs().total_cmp(&(b.v_mean - v_d).abs()))
                .map_or(f64::NAN, |n| n.fast_modulus())
        );
        assert!(
            (averaged / full - 1.0).abs() < 1e-3,
            "{f} Hz: F_eff(v_d) = {averaged} N against the full run's settled {full} N"
        );
        // The table is odd and passes through its nodes.
        assert_eq!(table.force(-v_d), Some(-averaged));
        for n in &table.nodes {
            assert!((table.force(n.v_mean).expect("node") - n.force).abs() < 1e-12);
        }
    }
}

/// Above the contact resonance (3 and 4 kHz), where the fast orbit contracts everywhere, the
/// averaged slow model reproduces the full model's stick-slip: r within 0.01 and the mean force
/// within 0.5 % (docs/model.md's convergence rule), from v_a/v_d = 0.4 (partial reduction) to 2
/// (eliminated). The work of both is printed: right-hand sides of the full run against the
/// table's (12-state) and the slow model's.
#[test]
fn slow_model_reproduces_full_runs_above_the_resonance() {
    use stickslip::sim::slow::simulate_slow;
    let v_d = 0.5e-3;
    for f in [3000.0, 4000.0] {
        for ratio in [0.4, 1.0, 2.0] {
            let p = Params {
                k_d: 11_700.0,
                ..params(f, ratio * v_d / (2.0 * std::f64::consts::PI * f), v_d)
            };
            let opts = RunOptions {
                tier: stickslip::sim::Tier::Full,
                ..RunOptions::default()
            };
            let mut solver = Solver::new(opts.method);
            let full = run_case_with(&p, &stickslip::model::Effects::none(), &opts, &mut solver)
                .expect("a run");
            let table = Table::build(&p, 40.0 * v_d, AveragingOptions::default()).expect("a table");
            assert!(
                table.valid(),
                "{f} Hz, {ratio}: the table is not valid everywhere"
            );
            // A long window (some 30 cycles): a window's mean force is biased by up to
            // dF / (8 n) over n cycles by the part-cycles at its ends, and the slow model is cheap.
            let t_end = 20.0 * stickslip::sim::planned_time(&p, 3);
            let slow = simulate_slow(&p, &table, t_end, 1.0 / f, 1e-8).expect("a valid table");
            assert_eq!(slow.status, stickslip::ode::Status::Success);
            let d_ref = full.reference.as_ref().expect("a reference").measures.d_f;
            let r = slow.measures.d_f / d_ref;
            let table_rhs: u64 = table.nodes.iter().map(|n| n.rhs_evals).sum();
            eprintln!(
                "{f} Hz, v_a/v_d = {ratio}: r {r:.4} (full {:.4} ± {:.4}), mean force {:.4} N \
                 (full {:.4} N), rhs: full {} against table {table_rhs} + slow {} ({} nodes)",
                full.r,
                full.r_stderr,
                slow.measures.mean_force,
                full.run.measures.mean_force,
                full.run.stats.rhs_evals,
                slow.stats.rhs_evals,
                table.nodes.len()
            );
            assert!(
                (r - full.r).abs() <= 0.01 + full.r_stderr,
                "{f} Hz, {ratio}: r {r} against {}",
                full.r
            );
            assert!(
                (slow.measures.mean_force / full.run.measures.mean_force - 1.0).abs() < 5e-3,
                "{f} Hz, {ratio}: mean force"
            );
        }
    }
}

/// Below the contact resonance the fast orbit loses stability before the law's peak (it
/// period-doubles: a multiplier through −1); the table marks those nodes, and is then not
/// valid for averaging, and a slow run whose window passes them says so. At 1500 Hz,
/// v_a/v_d = 0.4 such nodes exist; at 3000 Hz none.
#[test]
fn zones_where_averaging_fails_are_marked() {
    let v_d = 0.5e-3;
    for (f, expect_valid) in [(1500.0, false), (3000.0, true)] {
        let p = Params {
            k_d: 11_700.0,
            ..params(f, 0.4 * v_d / (2.0 * std::f64::consts::PI * f), v_d)
        };
        let table = Table::build(&p, 40.0 * v_d, AveragingOptions::default()).expect("a table");
        for n in table.nodes.iter().filter(|n| n.v_mean < 3.0 * v_d) {
            eprintln!(
                "{f} Hz: V {:.3e} F {:.4} slope {:.3e} fast ({:.3}, {:.3}) |{:.3}|",
                n.v_mean,
                n.force,
                n.slope,
                n.fast.0,
                n.fast.1,
                n.fast_modulus()
            );
        }
        eprintln!(
            "{f} Hz: stopped at {:?}, gaps {:?}, valid {}",
            table.stopped_at,
            table.gaps,
            table.valid()
        );
        assert_eq!(table.valid(), expect_valid, "{f} Hz");
        if !expect_valid {
            // The law is not made up across what it could not find.
            for &(lo, hi) in &table.gaps {
                assert_eq!(table.force(0.5 * (lo + hi)), None);
            }
            // A stick-slip run through them says so.
            let t_end = stickslip::sim::planned_time(&p, 3);
            let slow = stickslip::sim::slow::simulate_slow(&p, &table, t_end, 1.0 / f, 1e-8)
                .expect("a table");
            assert!(
                slow.left_law.is_some(),
                "{f} Hz: the run never left the law"
            );
        }
    }
}

/// Below the contact resonance (1500 Hz, v_a/v_d = 0.4, k_d = 11 700 N/m, v_d = 0.5 mm/s) the
/// rising branch's period-1 orbits stop contracting before the law's peak, and the body, the
/// drive force frozen, escapes from the attractor that holds it at a lower force than the fold
/// of `F_eff`. The averaging study's pure law gives r = 0.52 for the full model's 0.37; the law
/// cut at the escape force ([`Table::capped`]) must give the full model's r within 0.005 and
/// its standard error, its peak force within 0.5 % (the escape is the slip's start), and its
/// mean force within 0.5 %.
#[test]
fn escape_force_puts_the_slip_where_the_full_model_has_it_below_the_resonance() {
    use stickslip::averaged::{SHARED, escape_force, table_span};
    use stickslip::ode::Method;
    use stickslip::sim::{RunOptions, end_time, run_case};
    use stickslip::sim::{Tier, slow::simulate_slow};
    let mut p = Params {
        f: 1500.0,
        k_d: 11_700.0,
        v_d: 0.5e-3,
        ..Params::default()
    };
    p.set_v_a(0.4 * p.v_d);
    let table = Table::build(&p, table_span(&p), SHARED).expect("the law");
    let f_esc = escape_force(&p, &table).expect("an escape before the peak");
    let peak = table.nodes.iter().map(|o| o.force).fold(0.0, f64::max);
    let full_opts = RunOptions {
        tier: Tier::Full,
        ..RunOptions::default()
    };
    let full = run_case(&p, &full_opts, &mut Solver::new(Method::Auto)).expect("a run");
    let reference = full.reference.as_ref().expect("its reference").measures.d_f;
    let t_end = end_time(&p, &RunOptions::default()).expect("a time");
    let capped = table
        .capped(f_esc)
        .expect("the law rises above the escape force");
    let slow = simulate_slow(&p, &capped, t_end, 1.0 / p.f, 1e-7).expect("a slow run");
    let pure = simulate_slow(&p, &table, t_end, 1.0 / p.f, 1e-7).expect("a slow run");
    let (m, fm) = (slow.measures, full.run.measures);
    let r = m.d_f / reference;
    let r_pure = pure.measures.d_f / reference;
    eprintln!(
        "escape force {f_esc:.4} N (law peak {peak:.4} N); r capped {r:.4}, pure {r_pure:.4}, \
         full {:.4}; peak {:.4} / {:.4} N, mean {:.4} / {:.4} N",
        full.r, m.peak_force, fm.peak_force, m.mean_force, fm.mean_force
    );
    assert!(f_esc < peak - 0.2, "escape {f_esc} against the peak {peak}");
    // The full run's r carries the cycle-to-cycle spread of its window (its standard error,
    // 0.002 to 0.005 here: its step sizes' rounding alone moves it by 0.002), as the other
    // comparisons with a full run in these tests allow.
    assert!(
        (r - full.r).abs() <= 0.005 + full.r_stderr,
        "r {r} against {} ± {}",
        full.r,
        full.r_stderr
    );
    assert!((m.peak_force / fm.peak_force - 1.0).abs() <= 0.005);
    assert!((m.mean_force / fm.mean_force - 1.0).abs() <= 0.005);
    // The pure law misses, as the study found.
    assert!(r_pure - full.r > 0.1, "pure {r_pure} against {}", full.r);
}

/// Hybrid windows below the resonance (the averaging study's case, 1500 Hz, `v_a/v_d` 0.4,
/// where the pure law gives r 0.52 for 0.37): the full model integrated only where the law's
/// orbits do not contract reproduces the full run's r, peak and mean force, integrating under
/// half the periods in full; where the law's continuation stopped short (1000 Hz) the hybrid
/// tier hands the run to the full model and says why.
#[test]
fn hybrid_windows_reproduce_the_full_model_below_the_resonance() {
    use stickslip::averaged::TableStore;
    use stickslip::model::Rig;
    use stickslip::ode::{Method, Options};
    use stickslip::sim::{DEFAULT_ENVELOPE, end_time, envelope_for, run_case, sampling};
    use stickslip::sim::{Tier, TierReason};
    let mut p = Params {
        f: 1500.0,
        k_d: 11_700.0,
        v_d: 0.5e-3,
        ..Params::default()
    };
    p.set_v_a(0.4 * p.v_d);
    let with = |tier| RunOptions {
        tier,
        ..RunOptions::default()
    };
    let full = run_case(&p, &with(Tier::Full), &mut Solver::new(Method::Auto)).expect("a run");
    let hybrid = run_case(&p, &with(Tier::Hybrid), &mut Solver::new(Method::Auto)).expect("a run");
    assert_eq!(
        (hybrid.run.tier, hybrid.run.tier_reason),
        (Tier::Hybrid, TierReason::AskedHybrid)
    );
    let (h, f) = (&hybrid.run.measures, &full.run.measures);
    eprintln!(
        "r hybrid {:.4}, full {:.4} ± {:.4}; peak {:.4} / {:.4} N, mean {:.4} / {:.4} N",
        hybrid.r, full.r, full.r_stderr, h.peak_force, f.peak_force, h.mean_force, f.mean_force
    );
    assert!(
        (hybrid.r - full.r).abs() <= 0.005,
        "r {} against {}",
        hybrid.r,
        full.r
    );
    assert!((h.peak_force / f.peak_force - 1.0).abs() <= 0.005);
    assert!((h.mean_force / f.mean_force - 1.0).abs() <= 0.005);
    // The windows: one or more per stick-slip cycle, under half the run's periods.
    let table = TableStore::new().table(&p).expect("the law");
    let rig = Rig::new(p).expect("valid");
    let t_end = end_time(&p, &RunOptions::default()).expect("a time");
    let (_, k) = sampling(&p, 16);
    let env = envelope_for(&p, k, DEFAULT_ENVELOPE);
    let ode = Options::default();
    let ho = stickslip::sim::hybrid::HybridOptions {
        slow_rtol: 1e-7,
        ode: &ode,
        samples_per_period: k,
        envelope: Some(&env),
        trace: None,
    };
    let run = stickslip::sim::hybrid::simulate_hybrid(
        &rig,
        &table,
        t_end,
        &ho,
        &mut Solver::new(Method::Auto),
    )
    .expect("a hybrid run");
    eprintln!(
        "{} windows, {} of {} periods in full, {} cycles",
        run.windows, run.full_periods, run.periods, run.measures.cycles
    );
    assert!(run.windows >= run.measures.cycles);
    assert!(run.full_periods > 0 && 2 * run.full_periods < run.periods);
    // A given simulated time whose last period boundary a grid's rounding puts past the span's
    // end (30 s at 1741 Hz): the run ends, served by its windows.
    let mut q = p;
    q.f = 1741.0;
    q.set_v_a(0.4 * q.v_d);
    let long = RunOptions {
        t_end: Some(30.0),
        ..with(Tier::Hybrid)
    };
    let l = run_case(&q, &long, &mut Solver::new(Method::Auto)).expect("a run");
    assert_eq!(
        (l.run.status, l.run.tier),
        (stickslip::ode::Status::Success, Tier::Hybrid)
    );
    assert!(
        l.run.measures.cycles >= 20,
        "{} cycles",
        l.run.measures.cycles
    );
    // A law whose continuation stopped short: the full model serves.
    p.f = 1000.0;
    p.set_v_a(0.4 * p.v_d);
    let partial = run_case(&p, &with(Tier::Hybrid), &mut Solver::new(Method::Auto)).expect("a run");
    assert_eq!(
        (partial.run.tier, partial.run.tier_reason),
        (Tier::Full, TierReason::PartialLaw)
    );
}

/// The averaged slow model continued along its limit cycle (`periodic`) gives the measures of
/// the same model integrated to its end: the cycle, once two sections agree and contract,
/// repeats. Cases: 3000 and 4000 Hz, `v_a/v_d` 0.2 to 0.7, `k_d` 3000 to 40 000 N/m, and one
/// with drive damping; the integration at `rtol` 1e-7, as runs at the default tolerance have it.
/// Agreement: dF and the mean force to 1e-4 of the reference's dF (the cycle's samples are
/// read by cubic interpolation between samples), and the continued run integrates less.
#[test]
fn slow_model_continued_along_its_cycle_keeps_the_measures() {
    let v_d = 0.5e-3;
    let cases = [
        (3000.0, 0.4, 11_700.0, 0.0),
        (3000.0, 0.2, 3000.0, 0.0),
        (4000.0, 0.7, 40_000.0, 0.0),
        (4000.0, 0.4, 11_700.0, 20.0),
    ];
    for (f, ratio, k_d, h_d) in cases {
        let p = Params {
            k_d,
            h_d,
            ..params(f, ratio * v_d / (2.0 * std::f64::consts::PI * f), v_d)
        };
        let table = Table::build(&p, table_span(&p), SHARED).expect("a table");
        let t_end = stickslip::sim::planned_time(&p, 3);
        let dt = 1e-4;
        let run = |periodic| {
            simulate_slow_with(&p, &table, t_end, dt, 1e-7, None, periodic).expect("a slow run")
        };
        let (whole, cont) = (run(false), run(true));
        let nominal = 2.0 * (p.f_s - p.f_c);
        eprintln!(
            "{f} Hz, {ratio}, k_d {k_d}, h_d {h_d}: dF {:.6} / {:.6} N, mean {:.6} / {:.6} N, \
             cycles {} / {}, steps {} / {}, continued from {:?}",
            whole.measures.d_f,
            cont.measures.d_f,
            whole.measures.mean_force,
            cont.measures.mean_force,
            whole.measures.cycles,
            cont.measures.cycles,
            whole.stats.steps,
            cont.stats.steps,
            cont.continued_from
        );
        assert!(whole.continued_from.is_none());
        let from = cont.continued_from.expect("a stick-slip cycle to continue");
        assert!(
            from < 0.6 * t_end,
            "continued only from {from} s of {t_end} s"
        );
        assert!(cont.stats.steps < whole.stats.steps);
        assert_eq!(whole.measures.cycles, cont.measures.cycles);
        assert!((whole.measures.d_f - cont.measures.d_f).abs() <= 1e-4 * nominal);
        assert!((whole.measures.mean_force - cont.measures.mean_force).abs() <= 1e-4 * nominal);
    }
}

/// A run of `p` (and its reference) under `tier` with envelope following at `envelope` (`None`:
/// every period integrated), the other options at their defaults.
fn tiered(
    p: &Params,
    tier: stickslip::sim::Tier,
    envelope: Option<f64>,
) -> stickslip::sim::CaseResult {
    let opts = RunOptions {
        tier,
        envelope,
        ..RunOptions::default()
    };
    let mut solver = Solver::new(opts.method);
    run_case_with(p, &stickslip::model::Effects::none(), &opts, &mut solver).expect("a run")
}

/// A slow model that runs away is no result: at 2000 Hz, `u0` = 12.56 nm, `v_d` = 0.149 mm/s,
/// `k_d` = 2223 N/m (a point of the overnight grid's even sixteenth, `v_a/v_d` = 1.06) the
/// averaged slow model's mean velocity grows past 1e11 m/s within 13 s, and once reported
/// `r` ≈ 5e21 and a mean force of −1.2e22 N as a success. Its window is now marked as having
/// left the law (an infinite velocity), and `averaged` and `hybrid` hand the point to the full
/// model (`left_law`; `auto` does not try the law, as `v_d` lies in one of its zones), which
/// gives the numbers of a run asked for with the full model: stick-slip eliminated, `r` below
/// 0.01.
#[test]
fn a_diverging_slow_model_hands_the_point_to_the_full_model() {
    use stickslip::averaged::TableStore;
    use stickslip::sim::{Tier, TierReason};
    let p = Params {
        k_d: 2223.0095692182826,
        ..params(
            1999.9999999999998,
            1.2559432157547897e-8,
            0.00014909760458231002,
        )
    };
    let table = TableStore::new().table(&p).expect("a table");
    let t_end = stickslip::sim::planned_time(&p, 3);
    let slow = simulate_slow_with(&p, &table, t_end, 1.0 / p.f, 1e-7, None, true)
        .expect("a table of two nodes or more");
    assert_eq!(slow.left_law, Some(f64::INFINITY), "{:?}", slow.measures);
    let run = |tier| tiered(&p, tier, RunOptions::default().envelope);
    let full = run(Tier::Full);
    assert!(full.r < 0.01, "full model: r {}", full.r);
    // Auto does not try the law here: `v_d` lies in one of its zones (near_zone).
    // A hybrid run's slow stretches ran away the same way (r ≈ 5e21 reported as a success).
    for (tier, why) in [
        (Tier::Averaged, TierReason::LeftLaw),
        (Tier::Hybrid, TierReason::LeftLaw),
        (Tier::Auto, TierReason::NearZone),
    ] {
        let r = run(tier);
        assert_eq!(r.run.tier, Tier::Full, "{tier:?}");
        assert_eq!(r.run.tier_reason, why, "{tier:?}");
        assert_eq!(r.r, full.r, "{tier:?}");
        assert_eq!(
            r.run.measures.mean_force, full.run.measures.mean_force,
            "{tier:?}"
        );
    }
}

/// Near a zone of the law the full model can slide on another attractor: at 2639 Hz,
/// `u0` = 12.56 nm, `v_d` = 0.149 mm/s the fast orbit does not contract from rest up to 13 %
/// below `v_d` (`stickslip plot --law`), and the full model, every period integrated, slides at
/// 4.79 N where the law's period-1 orbit (contracting at `v_d`, multiplier 0.87) gives 8.60 N.
/// `averaged` reports the law's force; `auto` sees the zone within 25 % of `v_d` and serves the
/// point with the full model (`near_zone`), within 0.5 % of every period integrated.
#[test]
fn auto_leaves_a_drive_velocity_near_a_zone_to_the_full_model() {
    use stickslip::sim::{Tier, TierReason};
    let p = Params {
        k_d: 4941.771544836056,
        ..params(
            2639.015821545788,
            1.2559432157547897e-8,
            0.00014909760458231002,
        )
    };
    let run = |tier, envelope| tiered(&p, tier, envelope);
    let every = run(Tier::Full, None);
    let force = every.run.measures.mean_force;
    assert!(
        every.r < 0.01 && (force - 4.79).abs() < 0.05,
        "full: r {} force {force}",
        every.r
    );
    let averaged = run(Tier::Averaged, RunOptions::default().envelope);
    assert_eq!(averaged.run.tier, Tier::Averaged);
    assert!(
        averaged.run.measures.mean_force > 8.0,
        "{:?}",
        averaged.run.measures
    );
    let auto = run(Tier::Auto, RunOptions::default().envelope);
    assert_eq!(
        (auto.run.tier, auto.run.tier_reason),
        (Tier::Full, TierReason::NearZone)
    );
    let rel = (auto.run.measures.mean_force / force - 1.0).abs();
    assert!(
        rel < 0.005,
        "auto {} against {force}",
        auto.run.measures.mean_force
    );
}

/// A soft drive's slips outrun the table of the law, and that is friction, not a runaway: at
/// 2000 Hz, `u0` = 5 nm, `v_d` = 0.271 mm/s, `k_d` = 5000 N/m the table spans 10.8 mm/s, and a
/// slip of about 6 N (`r` ≈ 0.93) reaches ten times that (`ΔF/√(k_d m)`). The divergence bound
/// is four times the larger of the table's span and the fastest slip the spring's energy allows
/// (`slip_speed`), so `auto` averages the point (with four times the span alone it counted as
/// diverged and went to the full model), within 0.005 of the full model's `r` and 0.5 % of its
/// mean force.
#[test]
fn a_soft_drives_fast_slips_are_no_divergence() {
    use stickslip::averaged::TableStore;
    use stickslip::sim::{Tier, TierReason, slow::slip_speed};
    let p = Params {
        k_d: 5000.0,
        ..params(2000.0, 5e-9, 0.000271)
    };
    let table = TableStore::new().table(&p).expect("a table");
    let span = table.nodes.last().unwrap().v_mean;
    assert!(
        slip_speed(&p) > 4.0 * span,
        "{} against {span}",
        slip_speed(&p)
    );
    let run = |tier| tiered(&p, tier, RunOptions::default().envelope);
    let (auto, full) = (run(Tier::Auto), run(Tier::Full));
    assert_eq!(
        (auto.run.tier, auto.run.tier_reason),
        (Tier::Averaged, TierReason::Valid)
    );
    assert!(full.r > 0.8, "full r {}", full.r);
    assert!(
        (auto.r - full.r).abs() < 0.005,
        "{} against {}",
        auto.r,
        full.r
    );
    let rel = auto.run.measures.mean_force / full.run.measures.mean_force - 1.0;
    assert!(rel.abs() < 0.005, "mean force {rel}");
}

/// A store's tables are shared, never a source of difference: averaged runs of two drives
/// handed one store (the second finds the table the first built) give, bit for bit, what each
/// gives with a store of its own, and the store holds one table for both.
#[test]
fn runs_sharing_a_table_store_give_what_each_gives_alone() {
    use stickslip::averaged::TableStore;
    use stickslip::model::Effects;
    use stickslip::ode::Solver;
    use stickslip::sim::{RunOptions, Tier, run_case_in};
    let base = params(3000.0, 2e-8, 5e-4);
    let opts = RunOptions {
        tier: Tier::Averaged,
        ..RunOptions::default()
    };
    let mut solver = Solver::new(opts.method);
    let shared = TableStore::new();
    for k_d in [8000.0, 11_700.0] {
        let p = Params { k_d, ..base };
        let with_shared =
            run_case_in(&p, &Effects::none(), &opts, &mut solver, &shared).expect("valid");
        let alone = run_case_in(&p, &Effects::none(), &opts, &mut solver, &TableStore::new())
            .expect("valid");
        assert_eq!(with_shared.run.tier, Tier::Averaged, "k_d = {k_d}");
        assert_eq!(with_shared.run.measures, alone.run.measures, "k_d = {k_d}");
        assert_eq!(with_shared.run.stats, alone.run.stats, "k_d = {k_d}");
        assert_eq!(with_shared.r.to_bits(), alone.r.to_bits(), "k_d = {k_d}");
    }
    // One table serves both drives: the second drive's run found the first one's.
    let other_drive = Params {
        k_d: 20_000.0,
        ..base
    };
    assert!(shared.cached(&other_drive).is_some());
}
