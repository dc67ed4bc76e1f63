//! Each model extension against its defining equation or a closed form, and its behaviour in
//! stick-slip runs.

use stickslip::model::{EffectKind, Effects, Params, Rig, S, V, X};
use stickslip::ode::{Method, OdeSystem, Solver};
use stickslip::sim::{RunOptions, run_case_with, simulate_with};

/// The run options of these tests: the defaults on the full model (the tests are about its
/// integration; the averaged tier has its own in tests/averaged.rs).
fn full_model() -> RunOptions {
    RunOptions {
        tier: stickslip::sim::Tier::Full,
        ..RunOptions::default()
    }
}

fn fx(spec: &str) -> Effects {
    let mut e = Effects::none();
    e.apply_spec(spec).unwrap();
    e
}

/// Friction force from the right-hand side: F_F = F_d − m v'.
fn friction(rig: &Rig, t: f64, y: &[f64]) -> f64 {
    let mut dy = vec![0.0; rig.dim()];
    rig.rhs(t, y, &mut dy);
    rig.drive_force(t, y) - rig.p.m * dy[V]
}

fn state(rig: &Rig, x: f64, v: f64, s: f64) -> Vec<f64> {
    let mut y = rig.initial_state();
    y[X] = x;
    y[V] = v;
    y[S] = s;
    y
}

fn dopri(t_end: Option<f64>) -> RunOptions {
    RunOptions {
        method: Method::Dopri5,
        t_end,
        ..full_model()
    }
}

/// The lag tests' vibrated case: a drive at 1 mm/s through 10 000 N/m, vibrated at 1500 Hz with
/// velocity amplitude `v_a` [m/s].
fn vibrated(v_a: f64) -> Params {
    Params {
        k_d: 10_000.0,
        v_d: 1e-3,
        f: 1500.0,
        u0: v_a / (std::f64::consts::TAU * 1500.0),
        ..Params::default()
    }
}

/// Effects at their neutral values follow exactly the base model's arithmetic.
#[test]
fn neutral_effects_reproduce_the_base_model() {
    let p = Params {
        k_d: 10_000.0,
        v_d: 1e-3,
        f: 1500.0,
        u0: 0.6e-3 / (std::f64::consts::TAU * 1500.0),
        ..Params::default()
    };
    // Same state, same arithmetic: identical numbers.
    let mut same_state = fx("stribeck_shape:delta=2");
    same_state
        .apply_spec("presliding:elements=1,spread=0")
        .unwrap();
    same_state.apply_spec("viscous:h_v=0").unwrap();
    // An extra state (the contact age) changes the error norm, so only the tolerance binds.
    let extra_state = fx("aging:b=0");
    let o = dopri(None);
    let mut s = Solver::new(Method::Dopri5);
    let base = run_case_with(&p, &Effects::none(), &o, &mut s).unwrap();
    for (e, tol) in [(same_state, 1e-6), (extra_state, 1e-4)] {
        let r = run_case_with(&p, &e, &o, &mut s).unwrap();
        let (a, b) = (&r.run.measures, &base.run.measures);
        assert!(
            (a.d_f - b.d_f).abs() < tol * b.d_f,
            "{} {a:?} {b:?}",
            e.describe()
        );
        assert!((a.mean_force - b.mean_force).abs() < tol * b.mean_force);
    }
}

/// Dieterich ageing: the contact age grows one second per second while stuck, and the static
/// force follows F_s (1 + b ln(1 + θ/θ_0)); long sticks raise the peaks more than short ones.
#[test]
fn aging_raises_static_friction_with_stick_time() {
    let p = Params {
        k_d: 17_900.0,
        v_d: 0.5e-3,
        ..Params::default()
    };
    let e = fx("aging:b=0.04,theta_0=0.01,d_c=1e-6");
    let rig = Rig::with_effects(p, &e).unwrap();
    assert_eq!(rig.dim(), 4);
    let mut y = state(&rig, 0.0, 0.0, 0.0);
    y[3] = 0.5; // half a second of contact age
    let mut dy = vec![0.0; 4];
    rig.rhs(0.0, &y, &mut dy);
    assert!((dy[3] - 1.0).abs() < 1e-12, "stuck: θ' = 1");
    // Sliding steadily at v: θ relaxes to D_c / v.
    y[V] = 1e-3;
    y[3] = 1e-6 / 1e-3;
    rig.rhs(0.0, &y, &mut dy);
    assert!(dy[3].abs() < 1e-9);

    let mut s = Solver::new(Method::Rodas4);
    let o = RunOptions {
        method: Method::Rodas4,
        ..full_model()
    };
    let mut excess = vec![];
    for (v_d, k_d) in [(0.5e-3, 17_900.0), (2e-3, 11_700.0)] {
        let q = Params { v_d, k_d, ..p };
        let b = run_case_with(&q, &Effects::none(), &o, &mut s).unwrap();
        let a = run_case_with(&q, &e, &o, &mut s).unwrap();
        let stick = a.run.measures.period;
        let want = q.f_s * 0.04 * (1.0 + stick / 0.01).ln();
        let got = a.run.measures.peak_force - b.run.measures.peak_force;
        // The peak lies a little below F_s(θ) (the drive pulls the contact out before the
        // full static force), so the excess matches the closed form to within a quarter.
        assert!(
            (got / want - 1.0).abs() < 0.25,
            "stick {stick} s: excess {got} N, law {want} N"
        );
        excess.push(got);
    }
    assert!(excess[0] > excess[1] + 0.1, "{excess:?}");
}

/// The actuator's amplitude follows the resonance closed form, and a run with it is the base
/// run at the actuated amplitude.
#[test]
fn actuator_response_scales_the_amplitude_by_the_resonance() {
    let p = Params {
        k_d: 10_000.0,
        v_d: 1e-3,
        f: 1500.0,
        u0: 0.5e-3 / (std::f64::consts::TAU * 1500.0),
        ..Params::default()
    };
    let (f_r, zeta) = (3000.0, 0.1);
    let e = fx(&format!("actuator_response:f_r={f_r},zeta={zeta}"));
    let q = p.f / f_r;
    let gain = 1.0 / ((1.0 - q * q).powi(2) + (2.0 * zeta * q).powi(2)).sqrt();
    let rig = Rig::with_effects(p, &e).unwrap();
    let amp = rig.substrate_velocity(0.0);
    assert!((amp / (gain * p.v_a()) - 1.0).abs() < 1e-12);
    let mut s = Solver::new(Method::Dopri5);
    let with = run_case_with(&p, &e, &dopri(None), &mut s).unwrap();
    let scaled = Params {
        u0: gain * p.u0,
        ..p
    };
    let base = run_case_with(&scaled, &Effects::none(), &dopri(None), &mut s).unwrap();
    assert!((with.r - base.r).abs() < 1e-6, "{} vs {}", with.r, base.r);
    assert!(
        with.r
            < 0.9
                * run_case_with(&p, &Effects::none(), &dopri(None), &mut s)
                    .unwrap()
                    .r
    );
}

/// The base rig with `F_c` and `F_s` scaled by the load factor `nu`.
fn limits_scaled(p: Params, nu: f64) -> Rig {
    Rig::new(Params {
        f_c: nu * p.f_c,
        f_s: nu * p.f_s,
        ..p
    })
    .unwrap()
}

/// Normal coupling scales F_c and F_s by the load factor ν(t) = 1 + k_n u(t + φ/ω)/F_N.
#[test]
fn normal_coupling_modulates_the_friction_limits() {
    let p = Params {
        f: 1000.0,
        u0: 2e-7,
        ..Params::default()
    };
    let k_n = 3e7;
    let e = fx(&format!("normal_coupling:k_n={k_n},phase=90"));
    let rig = Rig::with_effects(p, &e).unwrap();
    // At t = 0 the load change is k_n u0 (phase 90°: in step with the substrate velocity).
    let scaled = limits_scaled(p, 1.0 + k_n * p.u0 / p.f_n);
    for (v, s) in [(1e-3, 1.0e-7), (-2e-4, -0.5e-7), (0.0, 1.2e-7)] {
        let y = state(&rig, 0.0, v, s);
        let (a, b) = (friction(&rig, 0.0, &y), friction(&scaled, 0.0, &y));
        assert!(
            (a - b).abs() < 1e-9 * b.abs().max(1.0),
            "v = {v}: {a} vs {b}"
        );
    }
}

/// A delayed load path: ν(t) = 1 + k_n u(t − t_d + φ/ω)/F_N. At f = 1 kHz a delay of 0.25 ms
/// is a quarter period, so phase 90° with that delay is the load in step with the displacement
/// itself: at t = 0 (u = 0) the friction limits are unchanged, and a quarter period later
/// (u = u0) they are scaled by 1 + k_n u0/F_N.
#[test]
fn normal_coupling_delay_turns_the_phase_with_frequency() {
    let p = Params {
        f: 1000.0,
        u0: 2e-7,
        ..Params::default()
    };
    let k_n = 3e7;
    let rig = Rig::with_effects(
        p,
        &fx(&format!("normal_coupling:k_n={k_n},phase=90,delay=0.25e-3")),
    )
    .unwrap();
    let base = Rig::new(p).unwrap();
    let scaled = limits_scaled(p, 1.0 + k_n * p.u0 / p.f_n);
    let quarter = 0.25e-3;
    for (v, s) in [(1e-3, 1.0e-7), (-2e-4, -0.5e-7), (0.0, 1.2e-7)] {
        let y = state(&rig, 0.0, v, s);
        let (a, b) = (friction(&rig, 0.0, &y), friction(&base, 0.0, &y));
        assert!(
            (a - b).abs() < 1e-9 * b.abs().max(1.0),
            "t = 0, v = {v}: {a} vs {b}"
        );
        // v_r is the same for both at any t: the substrate velocity is a property of p.
        let (a, b) = (friction(&rig, quarter, &y), friction(&scaled, quarter, &y));
        assert!(
            (a - b).abs() < 1e-6 * b.abs().max(1.0),
            "t = T/4, v = {v}: {a} vs {b}"
        );
    }
}

/// A second-order sensor on a force ramp lags by 2ζ/ω_n once its transient has died.
#[test]
fn sensor_dynamics_lag_a_ramp_by_two_zeta_over_omega() {
    let p = Params {
        k_d: 10_000.0,
        v_d: 1e-3,
        ..Params::default()
    };
    let (f_n, zeta) = (50.0, 0.5);
    let e = fx(&format!("sensor_dynamics:f_n={f_n},zeta={zeta}"));
    let o = RunOptions {
        method: Method::Rodas4,
        t_end: Some(0.6),
        trace: true,
        ..full_model()
    };
    let r = simulate_with(&p, &e, &o, &mut Solver::new(Method::Rodas4)).unwrap();
    let tr = r.trace.unwrap();
    let lag = 2.0 * zeta / (std::f64::consts::TAU * f_n);
    // The body sticks until F_d reaches about F_s (1.15 s); check between 0.2 and 0.6 s.
    for i in 0..tr.t.len() {
        let t = tr.t[i];
        if t > 0.2 {
            let true_force = p.k_d * (p.v_d * t - tr.x_s[i]);
            let want = true_force - p.k_d * p.v_d * lag;
            assert!(
                (tr.f_d[i] - want).abs() < 2e-3,
                "t = {t}: {} vs {want}",
                tr.f_d[i]
            );
        }
    }
}

/// During the first loading the body sticks, so the drive's position error appears in the
/// force as k_d a sin(2π v_d t / λ).
#[test]
fn drive_ripple_shows_in_the_loading_force() {
    let p = Params {
        k_d: 10_000.0,
        v_d: 1e-3,
        ..Params::default()
    };
    let (a, lambda) = (5e-6, 0.2e-3);
    let e = fx(&format!("drive_ripple:a={a},wavelength={lambda}"));
    let o = RunOptions {
        method: Method::Rodas4,
        t_end: Some(0.8),
        trace: true,
        ..full_model()
    };
    let tr = simulate_with(&p, &e, &o, &mut Solver::new(Method::Rodas4))
        .unwrap()
        .trace
        .unwrap();
    let mut worst: f64 = 0.0;
    for i in 0..tr.t.len() {
        let t = tr.t[i];
        let want = p.k_d * (p.v_d * t + a * (std::f64::consts::TAU * p.v_d * t / lambda).sin());
        assert!(
            (tr.x_d[i] - (p.v_d * t + a * (std::f64::consts::TAU * p.v_d * t / lambda).sin()))
                .abs()
                < 1e-15
        );
        worst = worst.max((tr.f_d[i] - want).abs());
    }
    // The stuck body creeps by F/k_t (below 0.2 µm): 1e4 N/m × 0.2 µm = 2 mN.
    assert!(worst < 3e-3 && p.k_d * a > 0.04, "{worst}");
}

/// Viscous friction adds h_v v_r to the friction force, exactly.
#[test]
fn viscous_adds_h_v_times_slip_velocity() {
    let p = Params::default();
    let h_v = 40.0;
    let rig = Rig::with_effects(p, &fx(&format!("viscous:h_v={h_v}"))).unwrap();
    let base = Rig::new(p).unwrap();
    for (v, s) in [(2e-3, 1.5e-7), (-1e-3, -1e-7), (0.0, 0.3e-7)] {
        let y = state(&rig, 0.0, v, s);
        let d = friction(&rig, 0.0, &y) - friction(&base, 0.0, &y);
        assert!((d - h_v * v).abs() < 1e-9, "v = {v}: {d}");
    }
}

/// With an exponent, the viscous term is a power of the slip velocity with its sign:
/// `h_v v_r (|v_r|/1 mm/s)^(n−1)`; a quadratic drag `c₂ v_r |v_r|` is `h_v = c₂ · 1 mm/s`.
#[test]
fn viscous_exponent_makes_a_power_law_drag() {
    let p = Params::default();
    let c2 = 4e4; // N s²/m²
    let rig = Rig::with_effects(p, &fx(&format!("viscous:h_v={},exponent=2", c2 * 1e-3))).unwrap();
    let base = Rig::new(p).unwrap();
    for (v, s) in [
        (5e-3, 1.5e-7),
        (-2e-3, -1e-7),
        (0.0, 0.3e-7),
        (0.4e-3, 1e-7),
    ] {
        let y = state(&rig, 0.0, v, s);
        let d = friction(&rig, 0.0, &y) - friction(&base, 0.0, &y);
        let want = c2 * v * f64::abs(v);
        assert!(
            (d - want).abs() < 1e-9 + 1e-12 * want.abs(),
            "v = {v}: {d} against {want}"
        );
    }
    let rig = Rig::with_effects(p, &fx("viscous:h_v=30,exponent=1.5")).unwrap();
    let y = state(&rig, 0.0, 4e-3, 1e-7);
    let d = friction(&rig, 0.0, &y) - friction(&base, 0.0, &y);
    // 30 N s/m · 4 mm/s · √4 = 0.24 N.
    assert!((d - 0.24).abs() < 1e-9, "{d}");
}

/// In steady sliding the bristle rests at s = g(v) and friction is the Stribeck curve
/// F_c + (F_s − F_c) exp(−|v/v_s|^δ) (+ h_v v).
#[test]
fn stribeck_shape_sets_the_steady_friction_curve() {
    let p = Params::default();
    for delta in [0.7, 1.0, 3.5] {
        let rig = Rig::with_effects(p, &fx(&format!("stribeck_shape:delta={delta}"))).unwrap();
        for v in [0.5 * p.v_s, p.v_s, 3.0 * p.v_s] {
            let ss = p.f_c + (p.f_s - p.f_c) * (-(v / p.v_s).powf(delta)).exp();
            let y = state(&rig, 0.0, v, ss / p.k_t);
            let mut dy = vec![0.0; rig.dim()];
            rig.rhs(0.0, &y, &mut dy);
            assert!(dy[S].abs() < 1e-12 * v.max(1e-9) + 1e-15, "s' = {}", dy[S]);
            assert!(
                (friction(&rig, 0.0, &y) - ss).abs() < 1e-9,
                "δ = {delta}, v = {v}"
            );
        }
    }
}

/// Maxwell-slip presliding keeps the steady friction (the elements' breakaway deformations
/// average to g) but makes the body creep before breakaway.
#[test]
fn presliding_keeps_steady_friction_and_rounds_the_breakaway() {
    let p = Params {
        k_d: 10_000.0,
        v_d: 1e-3,
        ..Params::default()
    };
    let (n, spread) = (4usize, 0.6);
    let rig =
        Rig::with_effects(p, &fx(&format!("presliding:elements={n},spread={spread}"))).unwrap();
    assert_eq!(rig.dim(), 3 + n - 1);
    let v = 2e-3;
    let g = (p.f_c + (p.f_s - p.f_c) * (-(v / p.v_s).powi(2)).exp()) / p.k_t;
    let mut y = rig.initial_state();
    y[V] = v;
    for e in 0..n {
        let alpha = 1.0 + spread * (2.0 * e as f64 / (n - 1) as f64 - 1.0);
        let i = if e == 0 { S } else { 3 + e - 1 };
        y[i] = alpha * g;
    }
    let mut dy = vec![0.0; rig.dim()];
    rig.rhs(0.0, &y, &mut dy);
    assert!(dy[S].abs() < 1e-15 && dy[3..].iter().all(|d| d.abs() < 1e-15));
    assert!((friction(&rig, 0.0, &y) - g * p.k_t).abs() < 1e-9);

    // First loading to 97 % of F_s: the weakest elements yield and the body creeps further.
    let o = RunOptions {
        method: Method::Rodas4,
        t_end: Some(1.3),
        trace: true,
        ..full_model()
    };
    let mut s = Solver::new(Method::Rodas4);
    let creep = |fx: &Effects, s: &mut Solver| {
        let tr = simulate_with(&p, fx, &o, s).unwrap().trace.unwrap();
        let i = tr.f_d.iter().position(|f| *f > 0.97 * p.f_s).unwrap();
        tr.x_s[i]
    };
    let base = creep(&Effects::none(), &mut s);
    let with = creep(
        &fx(&format!("presliding:elements={n},spread={spread}")),
        &mut s,
    );
    assert!(with > 1.2 * base, "creep {with} m vs {base} m");
}

/// Frictional lag: the lagged velocity relaxes at 1/τ towards v_r; the Stribeck curve follows
/// it, so a sudden slip meets static friction for about τ.
#[test]
fn frictional_lag_delays_the_stribeck_curve() {
    let p = Params::default();
    let tau = 2e-3;
    let rig = Rig::with_effects(p, &fx(&format!("frictional_lag:tau={tau}"))).unwrap();
    let base = Rig::new(p).unwrap();
    let v = 2e-3;
    let mut y = state(&rig, 0.0, v, 1e-7);
    let mut dy = vec![0.0; rig.dim()];
    // Lagged velocity still at rest.
    y[3] = 0.0;
    rig.rhs(0.0, &y, &mut dy);
    assert!((dy[3] - v / tau).abs() < 1e-12);
    // Friction with w = 0 uses g(0) = F_s/k_t; with w = v it is the base model's.
    // The widest plausible v_s makes g(v) = F_s/k_t to (v/v_s)² = 4e-8 of the Stribeck drop
    // (1e-7 N); the base model at v gives F_c instead, 3 N away.
    let b = Rig::new(Params { v_s: 10.0, ..p }).unwrap();
    let yb = state(&b, 0.0, v, 1e-7);
    assert!((friction(&rig, 0.0, &y) - friction(&b, 0.0, &yb)).abs() < 1e-6);
    y[3] = v;
    let yb = state(&base, 0.0, v, 1e-7);
    assert!((friction(&rig, 0.0, &y) - friction(&base, 0.0, &yb)).abs() < 1e-9);

    // With vibration the lag filters the oscillating slip velocity out of the Stribeck curve
    // and changes how much the vibration reduces stick-slip.
    let q = vibrated(0.8e-3);
    let mut s = Solver::new(Method::Dopri5);
    let a = run_case_with(&q, &fx("frictional_lag:tau=2e-3"), &dopri(None), &mut s).unwrap();
    let b = run_case_with(&q, &Effects::none(), &dopri(None), &mut s).unwrap();
    assert!((a.r - b.r).abs() > 0.05, "r {} vs {}", a.r, b.r);
}

/// Friction along the track: F_c and F_s scale by 1 + a sin(2π (x + x_0)/λ).
#[test]
fn track_friction_varies_with_position() {
    let p = Params::default();
    let (a, lambda, x0) = (0.1, 0.7e-3, 0.1e-3);
    let rig = Rig::with_effects(
        p,
        &fx(&format!("track:a={a},wavelength={lambda},offset={x0}")),
    )
    .unwrap();
    for x in [0.0, 0.3e-3, 1.1e-3] {
        let k = 1.0 + a * (std::f64::consts::TAU * (x + x0) / lambda).sin();
        let scaled = Rig::new(Params {
            f_c: k * p.f_c,
            f_s: k * p.f_s,
            ..p
        })
        .unwrap();
        let y = state(&rig, x, 1e-3, 1e-7);
        let ys = state(&scaled, x, 1e-3, 1e-7);
        assert!((friction(&rig, 0.0, &y) - friction(&scaled, 0.0, &ys)).abs() < 1e-9);
    }
    assert!(!EffectKind::candidates().contains(&EffectKind::Track));
}

/// The finite-difference Jacobian of the extended model drives the implicit solvers to the
/// explicit method's answer.
#[test]
fn implicit_and_explicit_agree_with_all_effects_on() {
    let p = Params {
        k_d: 11_700.0,
        v_d: 1e-3,
        ..Params::default()
    };
    let mut e = Effects::none();
    for s in [
        "aging:b=0.03",
        "sensor_dynamics:f_n=300,zeta=0.05",
        "presliding:spread=0.5",
        "frictional_lag:tau=5e-4",
        "viscous:h_v=20",
        "stribeck_shape:delta=1.2",
        "drive_ripple:a=3e-6,wavelength=3e-4",
    ] {
        e.apply_spec(s).unwrap();
    }
    let mut out = vec![];
    for m in [Method::Radau5, Method::Rodas4, Method::Dopri5] {
        let o = RunOptions {
            method: m,
            ..full_model()
        };
        let r = run_case_with(&p, &e, &o, &mut Solver::new(m)).unwrap();
        out.push(r.run.measures);
    }
    for m in &out[1..] {
        assert!(
            (m.d_f / out[0].d_f - 1.0).abs() < 0.01,
            "{m:?} vs {:?}",
            out[0]
        );
        assert!((m.mean_force / out[0].mean_force - 1.0).abs() < 0.005);
    }
}

/// Bad effect parameters are rejected with the effect, parameter, value and range.
#[test]
fn effect_parameters_are_bounded() {
    let mut e = Effects::none();
    let err = e
        .apply_spec("sensor_dynamics:zeta=5")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("sensor_dynamics.zeta = 5") && err.contains("[0.005, 2]"),
        "{err}"
    );
    let err = e.apply_spec("aging:b=abc").unwrap_err().to_string();
    assert!(err.contains("aging.b = `abc` is not a number"), "{err}");
    let err = e.apply_spec("wear").unwrap_err().to_string();
    assert!(
        err.contains("unknown effect `wear`") && err.contains("frictional_lag"),
        "{err}"
    );
}

/// Each effect's forms against their defining equations: the load swing of each form of
/// `normal_coupling`, the one-pole actuator's gain, the rational Stribeck curve, the lag over
/// slip distance, Ruina's slip law and the fourth-order sensor's lag on a ramp.
#[test]
fn effect_forms_follow_their_equations() {
    use stickslip::model::effects::{NORMAL_REFERENCE_AMPLITUDE, NORMAL_REFERENCE_FREQUENCY};
    let p = Params {
        f: 2000.0,
        u0: 2e-7,
        ..Params::default()
    };
    let k_n = 3e7;
    let q = p.f / NORMAL_REFERENCE_FREQUENCY;
    for (form, swing) in [
        ("displacement", k_n * p.u0),
        ("velocity", k_n * p.u0 * q),
        ("acceleration", k_n * p.u0 * q * q),
        ("fixed", k_n * NORMAL_REFERENCE_AMPLITUDE),
    ] {
        let rig = Rig::with_effects(
            p,
            &fx(&format!("normal_coupling:k_n={k_n},phase=90,form={form}")),
        )
        .unwrap();
        let scaled = limits_scaled(p, 1.0 + swing / p.f_n);
        for (v, s) in [(1e-3, 1.0e-7), (0.0, 1.2e-7)] {
            let y = state(&rig, 0.0, v, s);
            let (a, b) = (friction(&rig, 0.0, &y), friction(&scaled, 0.0, &y));
            assert!(
                (a - b).abs() < 1e-9 * b.abs().max(1.0),
                "{form}: {a} vs {b}"
            );
        }
    }
    // A fixed swing needs the vibration on.
    let still = Params { u0: 0.0, ..p };
    let rig = Rig::with_effects(still, &fx("normal_coupling:k_n=3e7,form=fixed")).unwrap();
    let y = state(&rig, 0.0, 1e-3, 1e-7);
    let base = Rig::new(still).unwrap();
    assert!((friction(&rig, 0.0, &y) - friction(&base, 0.0, &y)).abs() < 1e-12);

    // One pole: A = 1/√(1 + (f/f_r)²).
    let f_r = 1500.0;
    let rig = Rig::with_effects(
        p,
        &fx(&format!("actuator_response:f_r={f_r},form=first_order")),
    )
    .unwrap();
    let gain = 1.0 / (1.0 + (p.f / f_r).powi(2)).sqrt();
    assert!((rig.substrate_velocity(0.0) / (gain * p.v_a()) - 1.0).abs() < 1e-12);

    // Rational Stribeck curve in steady sliding: F_c + (F_s − F_c)/(1 + |v/v_s|^δ).
    let p0 = Params::default();
    let delta = 2.0;
    let rig = Rig::with_effects(p0, &fx("stribeck_shape:delta=2,form=rational")).unwrap();
    for v in [0.5 * p0.v_s, p0.v_s, 3.0 * p0.v_s] {
        let ss = p0.f_c + (p0.f_s - p0.f_c) / (1.0 + (v / p0.v_s).powf(delta));
        let y = state(&rig, 0.0, v, ss / p0.k_t);
        assert!((friction(&rig, 0.0, &y) - ss).abs() < 1e-9, "v = {v}");
    }

    // Lag over slip distance L: w' = |v_r| (v_r − w)/L, frozen where the contact sticks.
    let l = 2e-6;
    let rig =
        Rig::with_effects(p0, &fx(&format!("frictional_lag:length={l},form=distance"))).unwrap();
    let mut dy = vec![0.0; rig.dim()];
    let v = 2e-3;
    let mut y = state(&rig, 0.0, v, 1e-7);
    y[3] = 0.5e-3;
    rig.rhs(0.0, &y, &mut dy);
    assert!((dy[3] - v * (v - 0.5e-3) / l).abs() < 1e-9 * dy[3].abs());
    let y = state(&rig, 0.0, 0.0, 1e-7);
    let mut y = y;
    y[3] = 0.5e-3;
    rig.rhs(0.0, &y, &mut dy);
    assert_eq!(dy[3], 0.0);

    // Ruina's slip law: θ' = −x ln x, x = |v_r| θ/D_c; no change at rest.
    let (theta, d_c) = (0.02, 1e-6);
    let rig = Rig::with_effects(p0, &fx(&format!("aging:b=0.05,d_c={d_c},form=slip_law"))).unwrap();
    for v in [1e-5, 1e-4, 1e-3] {
        let mut y = state(&rig, 0.0, v, 1e-7);
        y[3] = theta;
        rig.rhs(0.0, &y, &mut dy);
        let x = v * theta / d_c;
        assert!(
            (dy[3] + x * x.ln()).abs() < 1e-9 * (x * x.ln()).abs(),
            "v = {v}"
        );
    }
    let mut y = state(&rig, 0.0, 0.0, 1e-7);
    y[3] = theta;
    rig.rhs(0.0, &y, &mut dy);
    assert_eq!(dy[3], 0.0);
}

/// The lag's `level` form: the Stribeck level `φ` (its state is `ψ = 1 − φ`) relaxes over slip
/// distance, `L ψ' = |v_r| ((1 − e(v_r)) − ψ)`, and the curve is `F_c + (F_s − F_c) φ`. A fresh
/// contact (ψ = 0) slides at the static level; a level at its steady value is the base model;
/// at rest the memory is frozen; with a vanishing memory distance a whole run is the base
/// model's, and with a long one it is not.
#[test]
fn a_stribeck_level_with_memory_relaxes_over_slip_distance() {
    let p = Params::default();
    let l = 2e-6;
    let rig = Rig::with_effects(p, &fx(&format!("frictional_lag:length={l},form=level"))).unwrap();
    let base = Rig::new(p).unwrap();
    let mut dy = vec![0.0; rig.dim()];
    let e = |v: f64| (-(v / p.v_s) * (v / p.v_s)).exp();
    for v in [-1e-3, 2e-4, 2e-3] {
        let mut y = state(&rig, 0.0, v, 1e-7);
        y[3] = 0.1;
        rig.rhs(0.0, &y, &mut dy);
        let want = v.abs() * ((1.0 - e(v)) - 0.1) / l;
        assert!(
            (dy[3] - want).abs() < 1e-12 * want.abs().max(1.0),
            "v = {v}"
        );
        // The level at its steady value: the base model's friction to rounding.
        y[3] = 1.0 - e(v);
        let yb = state(&base, 0.0, v, 1e-7);
        assert!((friction(&rig, 0.0, &y) - friction(&base, 0.0, &yb)).abs() < 1e-9);
    }
    // A fresh contact slides at the static level: the base model with the widest v_s, whose
    // curve at 2 mm/s is F_s to 4e-8 of the Stribeck drop (see the time lag's test above).
    let v = 2e-3;
    let wide = Rig::new(Params { v_s: 10.0, ..p }).unwrap();
    let y = state(&rig, 0.0, v, 1e-7);
    let yb = state(&wide, 0.0, v, 1e-7);
    assert!((friction(&rig, 0.0, &y) - friction(&wide, 0.0, &yb)).abs() < 1e-6);
    // Frozen while the contact rests.
    let mut y = state(&rig, 0.0, 0.0, 1e-7);
    y[3] = 0.4;
    rig.rhs(0.0, &y, &mut dy);
    assert_eq!(dy[3], 0.0);

    // Whole runs with vibration: a memory of 1 nm (the slips travel micrometres) leaves r and
    // the mean force as the base model has them (docs/model.md's convergence rule: r within
    // 0.005, the mean force within 0.5 %); 20 µm changes r.
    let q = vibrated(0.4e-3);
    let mut s = Solver::new(Method::Dopri5);
    let b = run_case_with(&q, &Effects::none(), &dopri(None), &mut s).unwrap();
    let short = fx("frictional_lag:length=1e-9,form=level");
    let a = run_case_with(&q, &short, &dopri(None), &mut s).unwrap();
    assert!((a.r - b.r).abs() < 0.005, "r {} vs {}", a.r, b.r);
    let (ma, mb) = (a.run.measures.mean_force, b.run.measures.mean_force);
    assert!((ma - mb).abs() < 5e-3 * mb, "mean force {ma} vs {mb}");
    let long = fx("frictional_lag:length=2e-5,form=level");
    let c = run_case_with(&q, &long, &dopri(None), &mut s).unwrap();
    assert!((c.r - b.r).abs() > 0.05, "r {} vs {}", c.r, b.r);
}

/// Two second-order sections in cascade lag a ramp by the sum of their lags, `2 ζ/ω_n` and
/// `2 (1 + √2) ζ/ω_n`, once the transient has died.
#[test]
fn fourth_order_sensor_lags_a_ramp_by_both_sections() {
    let p = Params {
        k_d: 10_000.0,
        v_d: 1e-3,
        ..Params::default()
    };
    let (f_n, zeta) = (60.0, 0.383);
    let e = fx(&format!(
        "sensor_dynamics:f_n={f_n},zeta={zeta},form=order4"
    ));
    let o = RunOptions {
        method: Method::Rodas4,
        t_end: Some(0.6),
        trace: true,
        ..full_model()
    };
    let r = simulate_with(&p, &e, &o, &mut Solver::new(Method::Rodas4)).unwrap();
    let tr = r.trace.unwrap();
    let w = std::f64::consts::TAU * f_n;
    let lag = 2.0 * zeta / w + 2.0 * (1.0 + std::f64::consts::SQRT_2) * zeta / w;
    for i in 0..tr.t.len() {
        let t = tr.t[i];
        if t > 0.25 {
            let true_force = p.k_d * (p.v_d * t - tr.x_s[i]);
            let want = true_force - p.k_d * p.v_d * lag;
            assert!(
                (tr.f_d[i] - want).abs() < 2e-3,
                "t = {t}: {} vs {want}",
                tr.f_d[i]
            );
        }
    }
}

/// Forms are named in specs and files; a name the effect lacks, or a form value that is not
/// one of its forms, is refused with the allowed ones.
#[test]
fn forms_are_set_by_name_and_checked() {
    let e = fx("sensor_dynamics:form=order4,f_n=420");
    assert_eq!(e.form(EffectKind::SensorDynamics).unwrap().name, "order4");
    assert!(e.describe().contains("form=order4"), "{}", e.describe());
    let mut e = Effects::none();
    let err = e
        .apply_spec("normal_coupling:form=jerk")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("jerk") && err.contains("acceleration (2)"),
        "{err}"
    );
    let err = e.apply_spec("aging:form=0.5").unwrap_err().to_string();
    assert!(err.contains("aging.form = 0.5"), "{err}");
    // A form's unused parameter is not described.
    let e = fx("frictional_lag:form=distance,length=1e-6");
    assert!(!e.describe().contains("tau"), "{}", e.describe());
}

/// `sensor_dynamics` in its `order4_delay` form records the fourth-order sensor's output a
/// time `delay` late. Against the same run sampled by dense output at the shifted times (the
/// integrator's own interpolant, not the delay's): a delay of whole samples gives the earlier
/// samples themselves, a fractional one the samples of a grid started that much earlier, and
/// before `t = 0` the sensor at rest. The other channels are not delayed.
#[test]
fn a_delayed_sensor_records_the_fourth_order_output_late() {
    use stickslip::campaign::{Solvers, simulate_grid};
    let p = Params {
        f: 800.0,
        u0: 2e-7,
        ..Params::default()
    };
    let mut order4 = fx("sensor_dynamics:f_n=400,zeta=0.5");
    order4
        .set_form(EffectKind::SensorDynamics, "order4")
        .unwrap();
    let delayed = |tau: f64| {
        let mut e = order4.clone();
        e.set_form(EffectKind::SensorDynamics, "order4_delay")
            .unwrap();
        e.set(EffectKind::SensorDynamics, "delay", tau).unwrap();
        e
    };
    let (t0, dt, n, tol) = (0.01, 1e-4, 600, 1e-9);
    let mut s = Solvers::default();
    let mut sim = |fx: &Effects, t0: f64| simulate_grid(&p, fx, t0, dt, n, tol, &mut s).unwrap();
    let plain = sim(&order4, t0);
    let range = plain.f_d.iter().fold(0.0_f64, |m, f| m.max(f.abs()));
    assert!(range > 0.1, "the force swings: {range}");
    let x_range = plain.x_s.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    // Three whole samples.
    let whole = sim(&delayed(3.0 * dt), t0);
    for i in 3..n {
        assert!(
            (whole.f_d[i] - plain.f_d[i - 3]).abs() < 1e-9 * range,
            "sample {i}: {} against {}",
            whole.f_d[i],
            plain.f_d[i - 3]
        );
        assert!(
            (whole.x_s[i] - plain.x_s[i]).abs() <= 1e-9 * x_range,
            "sample {i}: x_s {} against {}",
            whole.x_s[i],
            plain.x_s[i]
        );
        // The same times, up to the rounding of a grid started earlier.
        assert!((whole.x_d[i] - plain.x_d[i]).abs() <= 1e-12 * plain.x_d[i].abs());
    }
    // A fraction of a sample, and more than one.
    for tau in [0.37 * dt, 2.61 * dt] {
        let late = sim(&delayed(tau), t0);
        let early = sim(&order4, t0 - tau);
        let worst = (0..n).fold(0.0_f64, |m, i| m.max((late.f_d[i] - early.f_d[i]).abs()));
        assert!(worst < 1e-6 * range, "delay {tau}: off by {worst}");
        // The delay moves the record by far more than the agreement above.
        let moved = (0..n).fold(0.0_f64, |m, i| m.max((late.f_d[i] - plain.f_d[i]).abs()));
        assert!(
            moved > 100.0 * worst.max(1e-9 * range),
            "delay {tau}: moved by {moved}, off by {worst}"
        );
    }
    // From t = 0: the first samples read the sensor at rest.
    let from0 = sim(&delayed(2.5 * dt), 0.0);
    let rest = Rig::with_effects(p, &order4).unwrap();
    let at_rest = rest.measured_force(0.0, &rest.initial_state());
    assert_eq!(&from0.f_d[..3], &[at_rest; 3]);
}
