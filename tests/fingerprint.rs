//! The fingerprint checks of `diagnose` (`diagnosis::fingerprint`) on campaigns whose truth is
//! known: a force sensor that rings shows its ringing after slips, a slow sensor that a
//! campaign does not have predicts a ringing the recordings do not show, and an effect that does
//! not act on the spectrum after slips is not judged by it; the held-out feature families
//! carry a true sensor and not a stand-in; and a screw error shows along the travel where the
//! campaign has one and not where it does not.

use stickslip::campaign::synth::{Design, SynthSpec, synth};
use stickslip::campaign::{Campaign, Recording};
use stickslip::diagnosis::diagnose::held_out_families;
use stickslip::diagnosis::fingerprint::{Seen, check};
use stickslip::diagnosis::fit::{self, FitOptions, FitResult, Model, Target};
use stickslip::model::{EffectKind, Effects};

/// A small campaign (16 recordings, 10 kHz, three cycles in each recording's second half) with
/// `effects` and noise 0.02 N.
fn campaign(effects: Effects, seed: u64) -> (tempfile::TempDir, Campaign) {
    let dir = tempfile::tempdir().unwrap();
    let spec = SynthSpec {
        effects,
        design: Design::Small,
        seed,
        ..SynthSpec::default()
    };
    synth(dir.path(), &spec).unwrap();
    let c = Campaign::load(dir.path()).unwrap();
    (dir, c)
}

/// The true base model of `synth` with `effects`.
fn model(effects: &[(EffectKind, &[(&str, f64)])]) -> Model {
    let mut m = Model::default();
    for (k, ps) in effects {
        m.effects.enable(*k);
        for (n, v) in *ps {
            m.effects.set(*k, n, *v).unwrap();
        }
    }
    m
}

fn recs(c: &Campaign) -> Vec<&Recording> {
    c.recordings.iter().collect()
}

/// A 60 Hz sensor with ζ = 0.05 rings after every slip: against the base model its fingerprint
/// is there, at about its predicted size.
#[test]
fn a_ringing_sensor_shows_its_fingerprint() {
    let sensor: &[(&str, f64)] = &[("f_n", 60.0), ("zeta", 0.05)];
    let truth = model(&[(EffectKind::SensorDynamics, sensor)]);
    let (_d, c) = campaign(truth.effects.clone(), 5);
    let checks = check(&recs(&c), &Model::default(), &truth);
    let ring = &checks[0];
    assert_eq!(ring.seen, Seen::Present, "{}", ring.line());
    assert!((ring.share - 1.0).abs() < 0.5, "{}", ring.line());
}

/// On an effect-free campaign a slow sensor (30 Hz, ζ = 0.15, as a fit that stands in for
/// another physics may find) predicts a ringing the recordings do not have: absent. An ageing
/// term, which does not act on the spectrum after slips, is not rejected by it.
#[test]
fn a_sensor_the_campaign_lacks_is_absent_and_ageing_is_not_judged_by_ringing() {
    let (_d, c) = campaign(Effects::none(), 6);
    let slow = model(&[(EffectKind::SensorDynamics, &[("f_n", 30.0), ("zeta", 0.15)])]);
    let checks = check(&recs(&c), &Model::default(), &slow);
    assert_eq!(checks[0].seen, Seen::Absent, "{}", checks[0].line());
    let aging = model(&[(EffectKind::Aging, &[("b", 0.05)])]);
    let checks = check(&recs(&c), &Model::default(), &aging);
    assert_ne!(checks[0].seen, Seen::Absent, "{}", checks[0].line());
}

/// The model `m` with the effects `effects` as a fit at `m` itself (no iteration; its
/// Jacobian differenced there), on every recording of `all`.
fn at(all: &Target, m: &Model, effects: &[EffectKind]) -> FitResult {
    let opts = FitOptions {
        max_iter: 0,
        ..FitOptions::default()
    };
    fit::with_fresh_jacobian(all, fit::fit(all, m, effects, opts))
}

/// Held-out feature families (`diagnose`'s check of a named effect on each family left out of
/// its fit). The true sensor (60 Hz, ζ = 0.05) against the true base model carries every family
/// it can be tested on: none absent, one present at least. On an effect-free campaign a slow
/// sensor (30 Hz, ζ = 0.15, a stand-in as a fit for another physics may find) predicts
/// departures the held-out families do not carry: none present, one absent at least.
#[test]
fn held_out_families_carry_a_true_sensor_and_not_a_stand_in() {
    let sensor: &[(&str, f64)] = &[("f_n", 60.0), ("zeta", 0.05)];
    let truth = model(&[(EffectKind::SensorDynamics, sensor)]);
    let (_d, c) = campaign(truth.effects.clone(), 5);
    let all = Target::new(recs(&c));
    let base = at(&all, &Model::default(), &[]);
    let cand = at(&all, &truth, &[EffectKind::SensorDynamics]);
    let checks = held_out_families(&all, &base, &cand);
    let lines: Vec<String> = checks.iter().map(|c| c.line()).collect();
    assert_eq!(checks.len(), 3, "{lines:#?}");
    assert!(checks.iter().all(|c| c.seen != Seen::Absent), "{lines:#?}");
    assert!(checks.iter().any(|c| c.seen == Seen::Present), "{lines:#?}");

    let (_d, c) = campaign(Effects::none(), 6);
    let all = Target::new(recs(&c));
    let base = at(&all, &Model::default(), &[]);
    let slow = model(&[(EffectKind::SensorDynamics, &[("f_n", 30.0), ("zeta", 0.15)])]);
    let cand = at(&all, &slow, &[EffectKind::SensorDynamics]);
    let checks = held_out_families(&all, &base, &cand);
    let lines: Vec<String> = checks.iter().map(|c| c.line()).collect();
    assert!(checks.iter().all(|c| c.seen != Seen::Present), "{lines:#?}");
    assert!(checks.iter().any(|c| c.seen == Seen::Absent), "{lines:#?}");
}

/// The families read slip by slip, on the default design (long enough for six slips per
/// stage): a screw error of 1 mm pitch and 20 µm amplitude moves the breakaway force along the
/// travel and with the stick time, and both fingerprints are there against the base model
/// (measured: `position` 1.09 ± 0.14, `stick_time` 1.02 ± 0.09); on an effect-free campaign
/// none of the same screw error's families is present (`position` 0.10 ± 0.08). Before the
/// standard errors took the slips' serial correlation into account, the effect-free campaign
/// showed a false `breakaway_phase` present (1.14 ± 0.36).
#[test]
fn a_screw_error_shows_along_the_travel_and_not_without_one() {
    let ripple: &[(&str, f64)] = &[("a", 2e-5), ("wavelength", 1e-3)];
    let truth = model(&[(EffectKind::DriveRipple, ripple)]);
    let full = |effects: Effects, seed: u64| {
        let dir = tempfile::tempdir().unwrap();
        let spec = SynthSpec {
            effects,
            seed,
            ..SynthSpec::default()
        };
        synth(dir.path(), &spec).unwrap();
        let c = Campaign::load(dir.path()).unwrap();
        (dir, c)
    };
    let family = |checks: &[stickslip::diagnosis::fingerprint::Check], name: &str| {
        checks.iter().find(|c| c.family == name).unwrap().clone()
    };
    let (_d, c) = full(truth.effects.clone(), 8);
    let checks = check(&recs(&c), &Model::default(), &truth);
    for name in ["position", "stick_time"] {
        let f = family(&checks, name);
        assert_eq!(f.seen, Seen::Present, "{}", f.line());
        assert!((f.share - 1.0).abs() < 0.7, "{}", f.line());
    }
    assert!(
        checks
            .iter()
            .all(|c| !c.decisive() || c.seen != Seen::Absent)
    );
    let (_d, c) = full(Effects::none(), 9);
    let checks = check(&recs(&c), &Model::default(), &truth);
    let f = family(&checks, "position");
    assert!(f.share < 0.8, "{}", f.line());
    for c in &checks {
        assert_ne!(c.seen, Seen::Present, "{}", c.line());
    }
}
