//! Detection limits checked by the whole diagnosis: an effect injected into the same conditions
//! at twice the strength a campaign's limits state is found (the diagnosis sees a gap), at half
//! of it usually not. The campaigns come from `synth` (16 recordings, 4 drives × 4 vibrations,
//! 5 kHz), the limits from the diagnosis of the effect-free one, the injected campaigns from
//! `synth` with the same conditions and new noise.

use stickslip::campaign::Campaign;
use stickslip::campaign::synth::{Design, SynthSpec, synth};
use stickslip::diagnosis::diagnose::{DiagnoseOptions, Diagnosis, Verdict, diagnose};
use stickslip::diagnosis::limits::{Confirmation, Limit};
use stickslip::model::{EffectKind, Effects};

fn campaign(effects: Effects, seed: u64) -> (tempfile::TempDir, Campaign) {
    let dir = tempfile::tempdir().unwrap();
    let spec = SynthSpec {
        effects,
        design: Design::Small,
        rate: 5000.0,
        min_cycles: 2,
        seed,
        ..SynthSpec::default()
    };
    synth(dir.path(), &spec).unwrap();
    let c = Campaign::load(dir.path()).unwrap();
    (dir, c)
}

/// The effect of `limit`'s form with its strength parameter at `value`, kept inside the
/// library's bounds.
fn injected(limit: &Limit, value: f64) -> Effects {
    let kind = EffectKind::from_name(limit.effect).unwrap();
    let info = kind.info();
    let mut fx = Effects::none();
    for (k, v) in limit.form_values() {
        fx.set(kind, &k, v).unwrap();
    }
    let p = info.params.iter().find(|p| p.name == limit.param).unwrap();
    fx.set(kind, limit.param, value.clamp(p.min, p.max))
        .unwrap();
    fx
}

fn effect_free_limits(seed: u64) -> Diagnosis {
    let (_dir, c) = campaign(Effects::none(), seed);
    let d = diagnose(&c, &DiagnoseOptions::default()).unwrap();
    assert_eq!(d.verdict, Verdict::NoSignificantGap, "{:?}", d.warnings);
    d
}

/// The diagnosis of a campaign with `fx`, without limits, its candidates `candidates` (all
/// where empty).
fn sees_gap(fx: Effects, seed: u64, candidates: &[EffectKind]) -> Diagnosis {
    let (_dir, c) = campaign(fx, seed);
    let mut opts = DiagnoseOptions {
        limits: false,
        ..DiagnoseOptions::default()
    };
    if !candidates.is_empty() {
        opts.candidates = candidates.to_vec();
    }
    diagnose(&c, &opts).unwrap()
}

/// Every effect of the library has a limit line on an effect-free campaign; the limits of
/// ageing hold: at twice its stated `b` the diagnosis sees a gap and names ageing, at half it
/// sees none.
#[test]
fn ageing_at_twice_its_limit_is_found_and_at_half_is_not() {
    let d = effect_free_limits(21);
    let l = &d.limits;
    assert!(l.not_computed.is_none(), "{:?}", l.not_computed);
    assert_eq!(l.against, "base");
    for k in EffectKind::candidates() {
        assert!(l.effects.iter().any(|e| e.effect == k.name()), "{k}");
    }
    for e in &l.effects {
        eprintln!("{}", e.statement);
        assert!(e.statement.contains(e.param), "{}", e.statement);
        // The search: its probe ran first, and a limit is a strength at which the full test
        // fired on at least 95 % of its draws, never a prediction alone.
        let runs = &e.search.runs;
        assert_eq!(
            runs.first().map(|r| r.value),
            Some(e.search.probe),
            "{}",
            e.statement
        );
        if let Some(v) = e.limit {
            let at = runs
                .iter()
                .find(|r| r.value == v)
                .expect("the limit was run in full");
            assert!(at.detected as f64 >= 0.95 * at.draws as f64, "{at:?}");
            // Every strength run below it did not fire, or the search would have stated it.
            let weaker = |r: &&Confirmation| {
                if e.stronger == "below" {
                    r.value > v
                } else {
                    r.value < v
                }
            };
            for r in runs.iter().filter(weaker) {
                assert!(
                    (r.detected as f64) < 0.95 * r.draws as f64 || r.failed > 0.05,
                    "{r:?} below {v}"
                );
            }
        }
    }
    let aging = l.effects.iter().find(|e| e.effect == "aging").unwrap();
    let b = aging.limit.expect("ageing is detectable in this campaign");
    assert!(b > 1e-3 && b < 0.1, "{b}");
    // Found is the gap seen; the candidates are cut to ageing and two rivals for time.
    let few = [
        EffectKind::Aging,
        EffectKind::Viscous,
        EffectKind::SensorDynamics,
    ];
    let twice = sees_gap(injected(aging, 2.0 * b), 21, &few);
    assert_ne!(twice.verdict, Verdict::NoSignificantGap, "b = {}", 2.0 * b);
    assert_eq!(twice.best_effect, Some(EffectKind::Aging));
    let half = sees_gap(injected(aging, 0.5 * b), 21, &few);
    assert_eq!(half.verdict, Verdict::NoSignificantGap, "b = {}", 0.5 * b);
}

/// Injecting effects where their limits assert detection (twice as strong as at the limit, or
/// inside a narrower band: [`Limit::asserted`]) and at half the limit's strength, over new
/// noise draws: the table of the closing note. `LIMITS_DRAWS` (default 10) draws per level;
/// `LIMITS_EFFECTS` (default `aging,normal_coupling,viscous,sensor_dynamics`) the effects,
/// each in its default form or in the form named in brackets (`aging[slip_law]`,
/// `sensor_dynamics[order4]`).
#[test]
#[ignore = "about 3 minutes per draw and effect on 2 cores; run with --ignored --nocapture"]
fn limits_hold_over_noise_draws() {
    let draws: u64 = std::env::var("LIMITS_DRAWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10);
    let effects = std::env::var("LIMITS_EFFECTS")
        .unwrap_or_else(|_| "aging,normal_coupling,viscous,sensor_dynamics".into());
    let d = effect_free_limits(21);
    let mut wrong = vec![];
    println!("| effect | limit | found where asserted (named) | found at ½× (named) |");
    println!("|---|---|---|---|");
    for spec in effects.split(',') {
        // `effect` (its default form, the first scanned) or `effect[form]`.
        let (name, form) = match spec.split_once('[') {
            Some((n, f)) => (n, Some(f.trim_end_matches(']'))),
            None => (spec, None),
        };
        let Some(l) = d
            .limits
            .effects
            .iter()
            .find(|e| e.effect == name && form.is_none_or(|f| e.form_name == f))
        else {
            println!("| {spec} | not scanned | - | - |");
            continue;
        };
        let Some(limit) = l.limit else {
            println!("| {spec} | none | - | - |");
            continue;
        };
        let mut counts = [(0, 0); 2];
        // Inside what the limit asserts (twice as strong, or a narrow band's middle), and
        // half as strong as at the limit.
        let at = [l.asserted().unwrap(), l.scaled(0.5).unwrap()];
        for (j, value) in at.into_iter().enumerate() {
            for k in 0..draws {
                let r = sees_gap(injected(l, value), 1000 + k, &[]);
                let found = r.verdict != Verdict::NoSignificantGap;
                counts[j].0 += usize::from(found);
                counts[j].1 += usize::from(r.effects.first().map(|e| e.name()) == Some(name));
                if found && r.best_effect.is_some_and(|e| e.name() != name) && !r.partial {
                    wrong.push(format!(
                        "{name} at {value:.3e} draw {k}: named {:?}",
                        r.effects
                    ));
                }
            }
        }
        println!(
            "| {spec} ({} {} {}) | {limit:.3e} {} (band to {}) | {:.3e}: {}/{draws} ({}) | {:.3e}: {}/{draws} ({}) |",
            l.param,
            l.stronger,
            l.form,
            l.unit,
            l.band_end.map_or("-".into(), |e| format!("{e:.3e}")),
            at[0],
            counts[0].0,
            counts[0].1,
            at[1],
            counts[1].0,
            counts[1].1
        );
        assert!(
            counts[0].0 as u64 * 10 >= 9 * draws,
            "{spec}: found at {:.3e}, where its limit asserts detection, on {} of {draws}",
            at[0],
            counts[0].0
        );
    }
    assert!(wrong.is_empty(), "{wrong:?}");
}
