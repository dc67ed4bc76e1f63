//! The fingerprint checks of `diagnose` (`campaign::fingerprint`) on campaigns whose truth is
//! known: a force sensor that rings shows its ringing after slips, a slow sensor that a
//! campaign does not have predicts a ringing the recordings do not show, and an effect that does
//! not act on the spectrum after slips is not judged by it.

use stickslip::campaign::fingerprint::{Seen, check};
use stickslip::campaign::fit::Model;
use stickslip::campaign::synth::{Design, SynthSpec, synth};
use stickslip::campaign::{Campaign, Recording};
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
