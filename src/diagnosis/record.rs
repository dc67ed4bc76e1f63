//! The diagnosis as a record: what a diagnosis concludes, typed, in the form of its
//! `diagnosis.json`. [`DiagnosisRecord::of`] builds it from a [`Diagnosis`]; the JSON file is
//! this record serialised, and the planner ([`crate::planning`]) takes the record, from memory
//! within one process or read back from the file ([`DiagnosisRecord::from_json`]).
//!
//! # Reading a file back
//! Every field is required: a file written before a field existed, or edited by hand so that a
//! field no longer parses, is refused with the field's path (`ranking[2].evidence.ln_odds:
//! missing field`), never filled with a default. A number the diagnosis could not compute (NaN)
//! is written as `null` and read back as NaN; a value that may be absent (`best_effect`, a
//! candidate's `screen`) is written as `null`, and must still be present. The file carries
//! [`SCHEMA_VERSION`] beside `code_version`; another schema is refused by its number.

use super::diagnose::{CONDITIONS, Diagnosis, Ranked};
use super::evidence::Evidence;
use super::features::{FEATURES, PHASES};
use super::fingerprint::Seen;
use super::fit::{Estimate, Model};
use super::nullable;
use super::verdict::{Disagreement, Verdict};
use crate::campaign::{Campaign, Recording, check::Implausible};
use crate::model::EffectKind;
use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;

/// The version of the record's layout, written as `schema_version`: raised whenever a field is
/// added, removed or changes meaning, so that a file of another layout is refused by number.
pub const SCHEMA_VERSION: u32 = 2;

/// A value that may be `null` but must be present: `Option`'s own deserialiser, which keeps
/// serde from reading a missing field as `None`.
fn present<'de, D: Deserializer<'de>, T: Deserialize<'de>>(d: D) -> Result<Option<T>, D::Error> {
    Option::<T>::deserialize(d)
}

/// A diagnosis's conclusions, as its `diagnosis.json` holds them (module docs).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagnosisRecord {
    /// [`SCHEMA_VERSION`] of the writer.
    pub schema_version: u32,
    /// The campaign's folder.
    pub campaign: String,
    /// Its number of recordings.
    pub recordings: usize,
    /// [`crate::campaign::digest`] of its recordings.
    pub recordings_digest: String,
    /// The version of stickslip that wrote it.
    pub code_version: String,
    /// The recordings a plan added to the campaign.
    pub planned_recordings: Vec<String>,
    /// The recordings checked on held-out data.
    pub held_out: Vec<String>,
    /// The verdict.
    pub verdict: Verdict,
    /// The named effect, with verdict `effect`.
    #[serde(deserialize_with = "present")]
    pub best_effect: Option<EffectKind>,
    /// The named effects in order.
    pub effects: Vec<EffectKind>,
    /// The named effects explain only part of the gap.
    pub partial: bool,
    /// Held-out gap of the calibrated base model.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_before: f64,
    /// Spread of the folds' held-out gaps of the base model.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_before_spread: f64,
    /// The feature in which the base model's held-out gap concentrates.
    #[serde(deserialize_with = "present")]
    pub concentrated: Option<Concentrated>,
    /// The harmonic feature the base model misses systematically.
    #[serde(deserialize_with = "present")]
    pub systematic: Option<Systematic>,
    /// Held-out gap of the named effects.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_after: f64,
    /// Spread of the folds' held-out gaps of the named effects.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_after_spread: f64,
    /// `(E0 − E1) / E0`.
    #[serde(deserialize_with = "nullable::f64")]
    pub reduction: f64,
    /// The held-out reduction beyond noise, where the decision used it.
    #[serde(deserialize_with = "present")]
    pub reduction_beyond_noise: Option<f64>,
    /// Share of gapped held-out recordings whose gap the top candidate lowers.
    #[serde(deserialize_with = "nullable::f64")]
    pub breadth: f64,
    /// Where the gap left by the named effects lies.
    pub remaining: String,
    /// The held-out folds.
    pub cross_validation: CrossValidation,
    /// The channels some recordings lack, and the features skipped for it.
    pub missing_channels: Vec<String>,
    /// The top candidate's held-out evidence against the base model.
    #[serde(deserialize_with = "present")]
    pub evidence: Option<EvidenceRecord>,
    /// The top candidate's held-out evidence against the runner-up.
    #[serde(deserialize_with = "present")]
    pub evidence_runner_up: Option<RunnerUp>,
    /// The candidates the data cannot tell apart, with verdict `tie`.
    pub tie: Vec<EffectKind>,
    /// The form the data chose for each named effect that has forms.
    pub forms: Vec<FormRecord>,
    /// What the verdict's reader must know.
    pub warnings: Vec<String>,
    /// Where evidence and held-out gap order two models the opposite way.
    pub disagreements: Vec<Disagreement>,
    /// What the campaign could not have seen.
    pub limits: LimitsRecord,
    /// The campaign's plausible ranges of the effects' parameters.
    pub bounds: Vec<BoundRecord>,
    /// The decision's thresholds and its rule in words.
    pub thresholds: Thresholds,
    /// The base calibration on all recordings.
    pub calibration: Calibration,
    /// Second effects tried with the first named one, best first.
    pub second: Vec<CandidateRecord>,
    /// Candidates named by their evidence but rejected by a fingerprint.
    pub rejected: Vec<Rejected>,
    /// Candidates, best first.
    pub ranking: Vec<RankedRecord>,
    /// Where the gap lies.
    #[serde(rename = "where")]
    pub location: WhereRecord,
    /// Wall time \[s\].
    #[serde(deserialize_with = "nullable::f64")]
    pub wall_time: f64,
    /// The simulations behind the diagnosis, with their cost.
    pub work: WorkRecord,
    /// Recordings set aside by the plausibility checks (`diagnose --skip-implausible`).
    pub skipped_implausible: Vec<Skipped>,
    /// The preflight: what the acquisition did to each recording, and what the diagnosis set
    /// aside or corrected for it ([`crate::campaign::acquisition`]).
    pub acquisition: crate::campaign::acquisition::Acquired,
}

/// [`DiagnosisRecord::concentrated`].
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Concentrated {
    /// The feature.
    pub feature: String,
    /// Its held-out gap.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap: f64,
    /// Checked recordings on which its `|z|` reaches that level.
    pub recordings: usize,
}

/// [`DiagnosisRecord::systematic`].
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Systematic {
    /// The feature.
    pub feature: String,
    /// Its mean `z`.
    #[serde(deserialize_with = "nullable::f64")]
    pub mean_z: f64,
    /// The `t` of that mean.
    #[serde(deserialize_with = "nullable::f64")]
    pub t: f64,
    /// The units behind it.
    pub units: usize,
}

/// [`DiagnosisRecord::cross_validation`].
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrossValidation {
    /// Number of folds.
    pub folds: usize,
    /// Each recording's fold.
    pub fold_of: BTreeMap<String, usize>,
    /// What the design cannot check on held-out data.
    pub not_checked: Vec<String>,
}

/// One [`Evidence`]: the log-likelihood ratio in nats and as a power of ten, its standard
/// error, the recordings it rests on and whether it is clear.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvidenceRecord {
    /// \[nats\].
    #[serde(deserialize_with = "nullable::f64")]
    pub ln_odds: f64,
    /// `ln_odds / ln 10`.
    #[serde(deserialize_with = "nullable::f64")]
    pub log10_odds: f64,
    /// Jackknife standard error.
    #[serde(deserialize_with = "nullable::f64")]
    pub stderr: f64,
    /// The recordings it rests on.
    pub recordings: usize,
    /// The smallest ln odds with one recording left out.
    #[serde(deserialize_with = "nullable::f64")]
    pub least_left_out: f64,
    /// [`Evidence::clear`].
    pub clear: bool,
}

impl From<&Evidence> for EvidenceRecord {
    fn from(e: &Evidence) -> Self {
        EvidenceRecord {
            ln_odds: e.ln_odds,
            log10_odds: e.log10_odds(),
            stderr: e.stderr,
            recordings: e.recordings,
            least_left_out: e.least_left_out,
            clear: e.clear(),
        }
    }
}

/// [`DiagnosisRecord::evidence_runner_up`]: the evidence and the runner-up.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunnerUp {
    /// The evidence against it.
    #[serde(flatten)]
    pub evidence: EvidenceRecord,
    /// The runner-up.
    pub runner_up: EffectKind,
}

/// One named effect's form ([`super::verdict::FormChoice`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FormRecord {
    /// The effect.
    pub effect: EffectKind,
    /// The form named.
    pub form: String,
    /// Every form tried, the named one first.
    pub tried: Vec<String>,
    /// The forms tried that it does not clearly beat.
    pub not_excluded: Vec<String>,
    /// Whether the form is settled.
    pub settled: bool,
    /// Whether it is the effect's default form.
    pub default: bool,
    /// The form in words.
    #[serde(deserialize_with = "present")]
    pub doc: Option<String>,
}

/// What the campaign could not have seen ([`super::limits::Limits`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsRecord {
    /// The model the effects are added to.
    pub against: String,
    /// The test repeated.
    pub test: String,
    /// The power a limit is stated at.
    #[serde(deserialize_with = "nullable::f64")]
    pub power: f64,
    /// Noise draws per strength.
    pub draws: usize,
    /// One per effect scan.
    pub effects: Vec<LimitRecord>,
    /// Simulations the scans ran.
    pub simulations: usize,
    /// Why no limit was computed, where none was.
    #[serde(deserialize_with = "present")]
    pub not_computed: Option<String>,
}

/// The detection limit of one effect in one form ([`super::limits::Limit`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitRecord {
    /// The effect.
    pub effect: EffectKind,
    /// The parameter that sets its strength.
    pub param: String,
    /// Its unit.
    pub unit: String,
    /// The effect in words, with its form.
    pub label: String,
    /// Its other parameters, fixed.
    pub form: String,
    /// The form scanned (empty for an effect of one form).
    pub form_name: String,
    /// `below` or `above`.
    pub stronger: String,
    /// The weakest value detected.
    #[serde(deserialize_with = "present")]
    pub limit: Option<f64>,
    /// Stronger values at which the test did not fire.
    #[serde(deserialize_with = "nullable::vec")]
    pub holes: Vec<f64>,
    /// The strong end of the detected band, where holes exist.
    #[serde(deserialize_with = "present")]
    pub band_end: Option<f64>,
    /// The power there.
    #[serde(deserialize_with = "nullable::f64")]
    pub power: f64,
    /// The scan's weak end.
    #[serde(deserialize_with = "nullable::f64")]
    pub weak_end: f64,
    /// The scan's strong end.
    #[serde(deserialize_with = "nullable::f64")]
    pub strong_end: f64,
    /// One sentence.
    pub statement: String,
    /// How it was searched.
    pub search: super::limits::Search,
}

impl From<&super::limits::Limits> for LimitsRecord {
    fn from(l: &super::limits::Limits) -> Self {
        LimitsRecord {
            against: l.against.clone(),
            test: l.test.to_string(),
            power: l.power,
            draws: l.draws,
            effects: l
                .effects
                .iter()
                .map(|x| LimitRecord {
                    effect: EffectKind::from_name(x.effect).expect("a limit's effect is listed"),
                    param: x.param.to_string(),
                    unit: x.unit.to_string(),
                    label: x.label.to_string(),
                    form: x.form.clone(),
                    form_name: x.form_name.to_string(),
                    stronger: x.stronger.to_string(),
                    limit: x.limit,
                    holes: x.holes.clone(),
                    band_end: x.band_end,
                    power: x.power,
                    weak_end: x.weak_end,
                    strong_end: x.strong_end,
                    statement: x.statement.clone(),
                    search: x.search.clone(),
                })
                .collect(),
            simulations: l.simulations,
            not_computed: l.not_computed.clone(),
        }
    }
}

/// One plausible range of an effect's parameter.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundRecord {
    /// The effect.
    pub effect: EffectKind,
    /// The parameter.
    pub param: String,
    /// Lower end.
    #[serde(deserialize_with = "nullable::f64")]
    pub lo: f64,
    /// Upper end.
    #[serde(deserialize_with = "nullable::f64")]
    pub hi: f64,
    /// Why.
    pub reason: String,
}

/// The decision's thresholds ([`super::diagnose`]) and its rule in words.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Thresholds {
    /// The rule in words.
    pub rule: String,
    /// [`super::diagnose::GAP_REL`].
    pub gap_rel: f64,
    /// [`super::diagnose::GAP_SE`].
    pub gap_se: f64,
    /// [`super::diagnose::LN_PRIOR_ODDS`].
    pub ln_prior_odds: f64,
    /// [`super::diagnose::EVIDENCE_SE`].
    pub evidence_se: f64,
    /// [`super::diagnose::PARAM_NATS`].
    pub param_nats: f64,
    /// [`super::diagnose::SIGNIFICANT_GAP`].
    pub significant_gap: f64,
    /// [`super::diagnose::FEATURE_GAP`].
    pub feature_gap: f64,
    /// [`super::diagnose::MIN_PARTIAL`].
    pub min_partial: f64,
    /// [`super::diagnose::MIN_SECOND`].
    pub min_second: f64,
    /// [`super::diagnose::GAPPED`].
    pub gapped: f64,
    /// [`super::diagnose::PARAM_PENALTY`].
    pub param_penalty: f64,
}

const RULE: &str = "a candidate qualifies where the held-out data make it clearly more likely than the model it extends (ln odds >= ln_prior_odds, >= evidence_se standard errors above 0, and >= ln_prior_odds with any one recording left out) and it explains at least min_partial of the gap; the qualifying candidate of best evidence is named where it is clearly more likely than every plausible rival and no rival's held-out gap is lower than its own (by more than gap_rel of it and gap_se jackknife errors); rivals it does not beat, and candidates of better evidence that do not qualify, make a tie; where evidence and held-out gap order two models the opposite way, the pair is listed under disagreements; where no candidate passes its screen alone, the two best screens of different effects are fitted together and named together only where both together qualify against the base model and, as a second effect does (min_second), against each of the two alone";

impl Thresholds {
    /// The thresholds this build decides by.
    pub fn current() -> Thresholds {
        use super::diagnose as d;
        Thresholds {
            rule: RULE.to_string(),
            gap_rel: d::GAP_REL,
            gap_se: d::GAP_SE,
            ln_prior_odds: d::LN_PRIOR_ODDS,
            evidence_se: d::EVIDENCE_SE,
            param_nats: d::PARAM_NATS,
            significant_gap: d::SIGNIFICANT_GAP,
            feature_gap: d::FEATURE_GAP,
            min_partial: d::MIN_PARTIAL,
            min_second: d::MIN_SECOND,
            gapped: d::GAPPED,
            param_penalty: d::PARAM_PENALTY,
        }
    }
}

/// A fitted parameter with its uncertainty.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimateRecord {
    /// Value.
    #[serde(deserialize_with = "nullable::f64")]
    pub value: f64,
    /// Standard uncertainty (NaN when not estimable).
    #[serde(deserialize_with = "nullable::f64")]
    pub stderr: f64,
    /// Unit.
    pub unit: String,
}

/// Estimates by name (`F_s`, `effect.param`).
pub type Estimates = BTreeMap<String, EstimateRecord>;

/// The estimates of a fit, by name.
pub fn estimates(e: &[Estimate]) -> Estimates {
    e.iter()
        .map(|e| {
            (
                e.name.clone(),
                EstimateRecord {
                    value: e.value,
                    stderr: e.stderr,
                    unit: e.unit.to_string(),
                },
            )
        })
        .collect()
}

/// The base calibration.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Its parameters.
    pub params: Estimates,
    /// Its gap on all recordings.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap: f64,
    /// Model evaluations.
    pub evaluations: usize,
    /// Iterations.
    pub iterations: usize,
    /// Whether it converged.
    pub converged: bool,
    /// The fitted model.
    pub model: Model,
}

/// One family's check of a candidate ([`super::fingerprint::Check`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckRecord {
    /// Family name.
    pub family: String,
    /// What it looks at.
    pub what: String,
    /// Statistics compared.
    pub statistics: usize,
    /// Strength of the prediction (standard errors).
    #[serde(deserialize_with = "nullable::f64")]
    pub strength: f64,
    /// Share of the predicted departure the data carry.
    #[serde(deserialize_with = "nullable::f64")]
    pub share: f64,
    /// Its standard error.
    #[serde(deserialize_with = "nullable::f64")]
    pub share_se: f64,
    /// The outcome.
    pub seen: Seen,
}

impl From<&super::fingerprint::Check> for CheckRecord {
    fn from(c: &super::fingerprint::Check) -> Self {
        CheckRecord {
            family: c.family.to_string(),
            what: c.what.to_string(),
            statistics: c.statistics,
            strength: c.strength,
            share: c.share,
            share_se: c.share_se,
            seen: c.seen,
        }
    }
}

/// A form screened but not fitted further ([`Ranked::short_of_leader`]).
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShortOfLeader {
    /// Its screen's gap.
    #[serde(deserialize_with = "nullable::f64")]
    pub screen_gap: f64,
    /// The gap it needed.
    #[serde(deserialize_with = "nullable::f64")]
    pub needed: f64,
}

/// One candidate's result ([`Ranked`]): a second effect's entry, and the common part of a
/// ranking's.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CandidateRecord {
    /// The effect.
    pub effect: EffectKind,
    /// Its fit's model.
    pub model: Model,
    /// The effects its fit holds beside the base parameters (a candidate whose screen fell
    /// short holds the model it extends: the base model's none, or the named first effect).
    pub fitted_effects: Vec<EffectKind>,
    /// Each held-out recording's own gap (NaN where not checked).
    #[serde(deserialize_with = "nullable::vec")]
    pub per_recording: Vec<f64>,
    /// The held-out residuals behind each.
    pub per_recording_n: Vec<usize>,
    /// Its name in reports.
    pub name: String,
    /// Its form, where the effect has forms.
    #[serde(deserialize_with = "present")]
    pub form: Option<String>,
    /// Nats charged for the choice of its form.
    #[serde(deserialize_with = "nullable::f64")]
    pub form_charge: f64,
    /// Its held-out evidence against the model it extends.
    pub evidence: EvidenceRecord,
    /// Its parameters on a bound of their plausible range.
    pub at_bound: Vec<String>,
    /// Held-out gap.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_after: f64,
    /// Spread of the folds' held-out gaps.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_spread: f64,
    /// `(E0 − E1) / E0` on held-out recordings.
    #[serde(deserialize_with = "nullable::f64")]
    pub reduction: f64,
    /// Ranking score.
    #[serde(deserialize_with = "nullable::f64")]
    pub score: f64,
    /// Its fitted parameters.
    pub params: Estimates,
    /// Its fingerprints checked.
    pub fingerprints: Vec<CheckRecord>,
    /// Why it is not named although its evidence would name it.
    #[serde(deserialize_with = "present")]
    pub rejected: Option<String>,
    /// Another form stopped short of the leader.
    #[serde(deserialize_with = "present")]
    pub short_of_leader: Option<ShortOfLeader>,
}

impl CandidateRecord {
    /// Whether its fit holds its own effect (a candidate whose screen fell short reports the
    /// model it extends, which is no rival of its own).
    pub fn holds_effect(&self) -> bool {
        self.fitted_effects.contains(&self.effect)
    }

    /// Its fitted parameters' count.
    pub fn n_params(&self) -> usize {
        self.params.len()
    }

    fn of(r: &Ranked) -> CandidateRecord {
        CandidateRecord {
            effect: r.effect,
            model: r.fit.model.clone(),
            fitted_effects: r.fit.effects.clone(),
            per_recording: r.per_recording.clone(),
            per_recording_n: r.per_recording_n.clone(),
            name: r.name.clone(),
            form: r.form.map(|f| f.name.to_string()),
            form_charge: r.form_charge,
            evidence: (&r.evidence).into(),
            at_bound: r.at_bound.clone(),
            gap_after: r.gap_after,
            gap_spread: r.gap_spread,
            reduction: r.reduction,
            score: r.score,
            params: estimates(&r.fit.estimates),
            fingerprints: r.fingerprints.iter().map(CheckRecord::from).collect(),
            rejected: r.rejected.clone(),
            short_of_leader: r.short_of_leader.map(|(g, n)| ShortOfLeader {
                screen_gap: g,
                needed: n,
            }),
        }
    }
}

/// A feature's held-out gap under the base model and under a candidate.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeforeAfter {
    /// Under the base model.
    pub before: f64,
    /// Under the candidate.
    pub after: f64,
}

/// A candidate's screen that fell short of its bar ([`Ranked::screened`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Screen {
    /// The lowest gap the screen reached.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap: f64,
    /// The model it extends's gap on the screen's recordings.
    #[serde(deserialize_with = "nullable::f64")]
    pub extended_gap: f64,
    /// The screened model.
    pub model: Model,
}

/// One ranked candidate: [`CandidateRecord`] and what the ranking adds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RankedRecord {
    /// The candidate.
    #[serde(flatten)]
    pub candidate: CandidateRecord,
    /// Each feature's held-out gap, where the candidate's fit acts.
    pub per_feature: BTreeMap<String, BeforeAfter>,
    /// Where its standard errors come from.
    pub stderr_from: String,
    /// Its gap on all recordings.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_calibration: f64,
    /// Its screen, where it fell short of the bar.
    #[serde(deserialize_with = "present")]
    pub screen: Option<Screen>,
}

/// A candidate rejected by a fingerprint.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rejected {
    /// The effect.
    pub effect: EffectKind,
    /// Its form.
    #[serde(deserialize_with = "present")]
    pub form: Option<String>,
    /// Why.
    pub reason: String,
}

/// Where the gap lies ([`super::verdict::Where`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WhereRecord {
    /// A sentence or two.
    pub summary: String,
    /// Per feature.
    pub features: Vec<FeatureShare>,
    /// Per phase.
    pub phases: Vec<PhaseShare>,
    /// Per condition.
    pub conditions: Vec<ConditionRho>,
    /// The gap on recordings with vibration.
    #[serde(deserialize_with = "nullable::f64")]
    pub with_vibration: f64,
    /// The gap on recordings without.
    #[serde(deserialize_with = "nullable::f64")]
    pub without_vibration: f64,
    /// Per recording.
    pub recordings: Vec<RecordingRecord>,
}

/// A feature's share of the gap.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeatureShare {
    /// The feature.
    pub feature: String,
    /// Its phase.
    pub phase: String,
    /// RMS z.
    #[serde(deserialize_with = "nullable::f64")]
    pub rms_z: f64,
    /// Share of the summed z².
    #[serde(deserialize_with = "nullable::f64")]
    pub share: f64,
}

/// A phase's share of the gap.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhaseShare {
    /// The phase.
    pub phase: String,
    /// RMS z.
    #[serde(deserialize_with = "nullable::f64")]
    pub rms_z: f64,
    /// Share of the summed z².
    #[serde(deserialize_with = "nullable::f64")]
    pub share: f64,
}

/// A condition's rank correlation with the per-recording gap.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConditionRho {
    /// The condition.
    pub condition: String,
    /// Spearman's rho.
    #[serde(deserialize_with = "nullable::f64")]
    pub spearman_rho: f64,
}

/// One recording's gap.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordingRecord {
    /// File stem.
    pub name: String,
    /// Gap under the calibrated base model.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_base: f64,
    /// Gap under the top-ranked candidate.
    #[serde(deserialize_with = "nullable::f64")]
    pub gap_best: f64,
    /// Checked on held-out data.
    pub held_out: bool,
    /// Its conditions by name ([`CONDITIONS`]).
    pub conditions: BTreeMap<String, Option<f64>>,
}

/// Simulations of one fidelity and their time.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunsRecord {
    /// Simulations run.
    pub simulations: usize,
    /// Their time \[s\].
    #[serde(deserialize_with = "nullable::f64")]
    pub simulation_cpu: f64,
}

/// The simulations of each fidelity, by name (`full`, `search`).
pub type ByFidelity = BTreeMap<String, RunsRecord>;

fn by_fidelity(w: &super::target::Work) -> ByFidelity {
    super::target::Fidelity::ALL
        .iter()
        .zip(w.by_fidelity)
        .map(|(f, r)| {
            (
                f.name().to_string(),
                RunsRecord {
                    simulations: r.simulations,
                    simulation_cpu: r.simulation_cpu,
                },
            )
        })
        .collect()
}

/// The work of the whole diagnosis.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorkRecord {
    /// Simulations run.
    pub simulations: usize,
    /// Predictions served by the cache.
    pub cache_hits: usize,
    /// The simulations' summed time \[s\].
    #[serde(deserialize_with = "nullable::f64")]
    pub simulation_cpu: f64,
    /// By fidelity.
    pub fidelity: ByFidelity,
    /// Step by step.
    pub steps: Vec<StepRecord>,
}

/// The work of one step.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepRecord {
    /// The step.
    pub step: String,
    /// Simulations run.
    pub simulations: usize,
    /// Predictions served by the cache.
    pub cache_hits: usize,
    /// The simulations' summed time \[s\].
    #[serde(deserialize_with = "nullable::f64")]
    pub simulation_cpu: f64,
    /// Its wall time \[s\].
    #[serde(deserialize_with = "nullable::f64")]
    pub wall: f64,
    /// By fidelity.
    pub fidelity: ByFidelity,
}

/// A recording set aside by a plausibility check.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Skipped {
    /// The recording.
    pub recording: String,
    /// The check.
    pub check: String,
    /// What was found.
    pub found: String,
    /// What was expected.
    pub expected: String,
}

impl From<&Implausible> for Skipped {
    fn from(s: &Implausible) -> Self {
        Skipped {
            recording: s.recording.clone(),
            check: s.check.to_string(),
            found: s.found.clone(),
            expected: s.expected.clone(),
        }
    }
}

/// A file that is no diagnosis record of this layout.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// Not JSON at all.
    #[error("not a diagnosis JSON: {0}")]
    Json(String),
    /// Another layout.
    #[error(
        "`schema_version` = {found}: this build reads diagnosis records of schema {SCHEMA_VERSION} (0: written before records had a schema; diagnose again)"
    )]
    Schema {
        /// The version found (0 where the file has none).
        found: u64,
    },
    /// A field missing or of the wrong type.
    #[error("`{field}` in the diagnosis JSON: {msg} (diagnose again)")]
    Field {
        /// The field's path (`ranking[2].evidence.ln_odds`).
        field: String,
        /// What is wrong with it.
        msg: String,
    },
}

impl DiagnosisRecord {
    /// The record of the diagnosis `d` of the campaign `c`, with the recordings the checks set
    /// aside (`skipped`).
    pub fn of(c: &Campaign, d: &Diagnosis, skipped: &[Implausible]) -> DiagnosisRecord {
        DiagnosisRecord {
            schema_version: SCHEMA_VERSION,
            campaign: c.dir.display().to_string(),
            recordings: c.recordings.len(),
            recordings_digest: crate::campaign::digest(&c.recordings),
            code_version: env!("CARGO_PKG_VERSION").to_string(),
            planned_recordings: c.planned.clone(),
            held_out: d.held_out.clone(),
            verdict: d.verdict,
            best_effect: d.best_effect,
            effects: d.effects.clone(),
            partial: d.partial,
            gap_before: d.gap_before,
            gap_before_spread: d.gap_before_spread,
            concentrated: d.concentrated.map(|(f, g, n)| Concentrated {
                feature: f.name().to_string(),
                gap: g,
                recordings: n,
            }),
            systematic: d.systematic.map(|(f, m, t, n)| Systematic {
                feature: f.name().to_string(),
                mean_z: m,
                t,
                units: n,
            }),
            gap_after: d.gap_after,
            gap_after_spread: d.gap_after_spread,
            reduction: d.reduction,
            reduction_beyond_noise: d.reduction_beyond_noise,
            breadth: d.breadth,
            remaining: d.remaining.clone(),
            cross_validation: CrossValidation {
                folds: d.folds,
                fold_of: c
                    .recordings
                    .iter()
                    .zip(&d.location.recordings)
                    .map(|(r, g)| (r.name.clone(), g.fold))
                    .collect(),
                not_checked: d.not_checked.clone(),
            },
            missing_channels: missing_channels(c),
            evidence: d.evidence.as_ref().map(EvidenceRecord::from),
            evidence_runner_up: d.evidence_runner_up.map(|(k, e)| RunnerUp {
                evidence: (&e).into(),
                runner_up: k,
            }),
            tie: d.tie.clone(),
            forms: d.forms.iter().map(form_record).collect(),
            warnings: d.warnings.clone(),
            disagreements: d.disagreements.clone(),
            limits: (&d.limits).into(),
            bounds: d
                .bounds
                .bounds
                .iter()
                .map(|b| BoundRecord {
                    effect: b.effect,
                    param: b.param.name(b.effect).to_string(),
                    lo: b.lo,
                    hi: b.hi,
                    reason: b.reason.clone(),
                })
                .collect(),
            thresholds: Thresholds::current(),
            calibration: Calibration {
                params: estimates(&d.base.estimates),
                gap: d.base.gap,
                evaluations: d.base.evaluations,
                iterations: d.base.iterations,
                converged: d.base.converged,
                model: d.base.model.clone(),
            },
            second: d.second.iter().map(CandidateRecord::of).collect(),
            rejected: d
                .ranking
                .iter()
                .chain(&d.second)
                .filter_map(|r| {
                    r.rejected.as_ref().map(|why| Rejected {
                        effect: r.effect,
                        form: r.form.map(|f| f.name.to_string()),
                        reason: why.clone(),
                    })
                })
                .collect(),
            ranking: d
                .ranking
                .iter()
                .map(|r| ranked_record(&d.base_per_feature, r))
                .collect(),
            location: where_record(&d.location),
            wall_time: d.wall_time,
            work: WorkRecord {
                simulations: d.work.simulations,
                cache_hits: d.work.cache_hits,
                simulation_cpu: d.work.simulation_cpu,
                fidelity: by_fidelity(&d.work),
                steps: d
                    .steps
                    .iter()
                    .map(|st| StepRecord {
                        step: st.step.to_string(),
                        simulations: st.work.simulations,
                        cache_hits: st.work.cache_hits,
                        simulation_cpu: st.work.simulation_cpu,
                        wall: st.wall,
                        fidelity: by_fidelity(&st.work),
                    })
                    .collect(),
            },
            skipped_implausible: skipped.iter().map(Skipped::from).collect(),
            acquisition: c.acquisition.clone(),
        }
    }

    /// The record as a JSON value (keys sorted), as the file holds it.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("a record of plain fields serialises")
    }

    /// Reads a record back: its schema first, then every field (module docs, "Reading a file
    /// back").
    pub fn from_json(text: &str) -> Result<DiagnosisRecord, RecordError> {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| RecordError::Json(e.to_string()))?;
        let found = v
            .get("schema_version")
            .and_then(|x| x.as_u64())
            .unwrap_or(0);
        if found != u64::from(SCHEMA_VERSION) {
            return Err(RecordError::Schema { found });
        }
        let de = &mut serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(de).map_err(|e| RecordError::Field {
            field: e.path().to_string(),
            msg: e.into_inner().to_string(),
        })
    }

    /// The entry of the named effect in the ranking (its first form), where it has one.
    pub fn ranked(&self, k: EffectKind) -> Option<&RankedRecord> {
        self.ranking.iter().find(|e| e.candidate.effect == k)
    }
}

fn form_record(f: &super::verdict::FormChoice) -> FormRecord {
    FormRecord {
        effect: f.effect,
        form: f.form.to_string(),
        tried: f.tried.iter().map(|s| s.to_string()).collect(),
        not_excluded: f.not_excluded.iter().map(|s| s.to_string()).collect(),
        settled: f.settled(),
        default: f.is_default(),
        doc: f.effect.form_named(f.form).map(|x| x.doc.to_string()),
    }
}

fn ranked_record(base_per_feature: &[f64], r: &Ranked) -> RankedRecord {
    RankedRecord {
        candidate: CandidateRecord::of(r),
        per_feature: per_feature(base_per_feature, &r.per_feature),
        stderr_from: if r.fit.jacobian_fresh {
            "finite-difference Jacobian at the optimum"
        } else {
            "Broyden-updated Jacobian at the optimum (approximate)"
        }
        .to_string(),
        gap_calibration: r.fit.gap,
        screen: r.screened.as_ref().map(|(g, from, m)| Screen {
            gap: *g,
            extended_gap: *from,
            model: m.clone(),
        }),
    }
}

fn where_record(w: &super::verdict::Where) -> WhereRecord {
    WhereRecord {
        summary: w.summary.clone(),
        features: w
            .features
            .iter()
            .map(|(f, rms, share)| FeatureShare {
                feature: f.name().to_string(),
                phase: PHASES[f.phase()].to_string(),
                rms_z: *rms,
                share: *share,
            })
            .collect(),
        phases: w
            .phases
            .iter()
            .map(|(p, rms, share)| PhaseShare {
                phase: p.to_string(),
                rms_z: *rms,
                share: *share,
            })
            .collect(),
        conditions: w
            .conditions
            .iter()
            .map(|(n, rho)| ConditionRho {
                condition: n.to_string(),
                spearman_rho: *rho,
            })
            .collect(),
        with_vibration: w.with_vibration.0,
        without_vibration: w.with_vibration.1,
        recordings: w
            .recordings
            .iter()
            .map(|r| RecordingRecord {
                name: r.name.clone(),
                gap_base: r.gap_base,
                gap_best: r.gap_best,
                held_out: r.held_out,
                conditions: CONDITIONS
                    .iter()
                    .zip(r.conditions)
                    .map(|(n, v)| (n.to_string(), Some(v).filter(|v| v.is_finite())))
                    .collect(),
            })
            .collect(),
    }
}

/// Each feature's held-out gap under the base model and under a candidate, where held-out
/// units define both: where the candidate's fit acts.
fn per_feature(base: &[f64], cand: &[f64]) -> BTreeMap<String, BeforeAfter> {
    FEATURES
        .iter()
        .filter_map(|&f| {
            let (b, a) = (*base.get(f as usize)?, *cand.get(f as usize)?);
            (b.is_finite() && a.is_finite()).then(|| {
                (
                    f.name().to_string(),
                    BeforeAfter {
                        before: b,
                        after: a,
                    },
                )
            })
        })
        .collect()
}

/// The channels some recordings lack, and the features skipped for it.
pub(crate) fn missing_channels(c: &Campaign) -> Vec<String> {
    let mut out = vec![];
    for (name, skipped, has) in [
        (
            "x_s",
            "x_s_amp_f, x_s_phase_f",
            (|r: &Recording| r.x_s.is_some()) as fn(&Recording) -> bool,
        ),
        ("x_d", "drive_ripple (and the ripple's start)", |r| {
            r.x_d.is_some()
        }),
    ] {
        let without: Vec<&str> = c
            .recordings
            .iter()
            .filter(|r| !has(r))
            .map(|r| r.name.as_str())
            .collect();
        if !without.is_empty() {
            out.push(format!(
                "{} recording(s) have no `{name}` column ({}): {skipped} skipped there",
                without.len(),
                without.join(", ")
            ));
        }
    }
    out
}

#[cfg(test)]
impl DiagnosisRecord {
    /// A record of verdict `verdict` naming `effects`, the base model `base`, no candidate, no
    /// limit, no work: for the planner's tests, which add the candidates they need.
    pub(crate) fn for_test(verdict: Verdict, effects: Vec<EffectKind>, base: Model) -> Self {
        DiagnosisRecord {
            schema_version: SCHEMA_VERSION,
            campaign: String::new(),
            recordings: 0,
            recordings_digest: String::new(),
            code_version: env!("CARGO_PKG_VERSION").to_string(),
            planned_recordings: vec![],
            held_out: vec![],
            verdict,
            best_effect: effects.first().copied(),
            effects,
            partial: false,
            gap_before: f64::NAN,
            gap_before_spread: f64::NAN,
            concentrated: None,
            systematic: None,
            gap_after: f64::NAN,
            gap_after_spread: f64::NAN,
            reduction: f64::NAN,
            reduction_beyond_noise: None,
            breadth: f64::NAN,
            remaining: String::new(),
            cross_validation: CrossValidation {
                folds: 0,
                fold_of: BTreeMap::new(),
                not_checked: vec![],
            },
            missing_channels: vec![],
            evidence: None,
            evidence_runner_up: None,
            tie: vec![],
            forms: vec![],
            warnings: vec![],
            disagreements: vec![],
            limits: (&super::limits::Limits::none("a test")).into(),
            bounds: vec![],
            thresholds: Thresholds::current(),
            calibration: Calibration {
                params: BTreeMap::new(),
                gap: f64::NAN,
                evaluations: 0,
                iterations: 0,
                converged: true,
                model: base,
            },
            second: vec![],
            rejected: vec![],
            ranking: vec![],
            location: WhereRecord {
                summary: String::new(),
                features: vec![],
                phases: vec![],
                conditions: vec![],
                with_vibration: f64::NAN,
                without_vibration: f64::NAN,
                recordings: vec![],
            },
            wall_time: 0.0,
            work: WorkRecord {
                simulations: 0,
                cache_hits: 0,
                simulation_cpu: 0.0,
                fidelity: BTreeMap::new(),
                steps: vec![],
            },
            skipped_implausible: vec![],
            acquisition: Default::default(),
        }
    }
}

#[cfg(test)]
impl CandidateRecord {
    /// A candidate of effect `effect` named `name`, its fit `model` holding `fitted`, over three
    /// held-out recordings of gap 1 (10 residuals each), its evidence `ln_odds` not clear: for
    /// the planner's tests.
    pub(crate) fn for_test(
        effect: EffectKind,
        name: &str,
        model: Model,
        fitted: Vec<EffectKind>,
        ln_odds: f64,
    ) -> Self {
        CandidateRecord {
            effect,
            model,
            fitted_effects: fitted,
            per_recording: vec![1.0; 3],
            per_recording_n: vec![10; 3],
            name: name.to_string(),
            form: None,
            form_charge: 0.0,
            evidence: EvidenceRecord {
                ln_odds,
                log10_odds: ln_odds / std::f64::consts::LN_10,
                stderr: f64::NAN,
                recordings: 3,
                least_left_out: f64::NAN,
                clear: false,
            },
            at_bound: vec![],
            gap_after: 1.0,
            gap_spread: 0.0,
            reduction: 0.0,
            score: 1.0,
            params: BTreeMap::new(),
            fingerprints: vec![],
            rejected: None,
            short_of_leader: None,
        }
    }

    /// Itself as a ranking's entry, with the screen `screen`.
    pub(crate) fn ranked(self, screen: Option<Screen>) -> RankedRecord {
        RankedRecord {
            candidate: self,
            per_feature: BTreeMap::new(),
            stderr_from: String::new(),
            gap_calibration: f64::NAN,
            screen,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record survives its file: written, read back and written again, value for value, NaN
    /// as null; a field removed is refused by its path, a schema of another number by it.
    #[test]
    fn a_record_reads_back_as_written_and_refuses_what_is_missing() {
        let mut m = Model::default();
        m.effects.enable(EffectKind::Viscous);
        let mut d =
            DiagnosisRecord::for_test(Verdict::Effect, vec![EffectKind::Viscous], m.clone());
        let mut c = CandidateRecord::for_test(
            EffectKind::Viscous,
            "viscous",
            m.clone(),
            vec![EffectKind::Viscous],
            7.5,
        );
        c.per_recording[1] = f64::NAN;
        d.ranking.push(c.clone().ranked(Some(Screen {
            gap: 1.2,
            extended_gap: f64::NAN,
            model: m,
        })));
        d.second.push(c);
        let v = d.to_json();
        assert!(v["ranking"][0]["per_recording"][1].is_null());
        assert!(v["second"][0].get("screen").is_none());
        let text = serde_json::to_string_pretty(&v).unwrap();
        let back = DiagnosisRecord::from_json(&text).unwrap();
        assert_eq!(back.to_json(), v);
        assert!(back.ranking[0].candidate.per_recording[1].is_nan());
        assert_eq!(
            back.ranking[0].candidate.model.effects,
            d.ranking[0].candidate.model.effects
        );
        // A field removed: refused, naming its path (to the entry, inside a flattened one).
        let mut w = v.clone();
        w["ranking"][0]["evidence"]
            .as_object_mut()
            .unwrap()
            .remove("ln_odds");
        let e = DiagnosisRecord::from_json(&w.to_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("ranking[0]") && e.contains("ln_odds"), "{e}");
        // An optional value must still be present.
        let mut w = v.clone();
        w["ranking"][0].as_object_mut().unwrap().remove("screen");
        let e = DiagnosisRecord::from_json(&w.to_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("screen"), "{e}");
        // An unknown effect, a verdict of another spelling: refused by name.
        let mut w = v.clone();
        w["effects"][0] = "viscosity".into();
        let e = DiagnosisRecord::from_json(&w.to_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("effects[0]") && e.contains("viscosity"), "{e}");
        let mut w = v.clone();
        w["verdict"] = "Effect".into();
        let e = DiagnosisRecord::from_json(&w.to_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("verdict"), "{e}");
        // A file without a schema (written before records had one), or of another.
        let mut w = v.clone();
        w.as_object_mut().unwrap().remove("schema_version");
        let e = DiagnosisRecord::from_json(&w.to_string()).unwrap_err();
        assert!(matches!(e, RecordError::Schema { found: 0 }), "{e}");
        w["schema_version"] = (SCHEMA_VERSION + 1).into();
        let e = DiagnosisRecord::from_json(&w.to_string()).unwrap_err();
        assert!(
            matches!(e, RecordError::Schema { found } if found == u64::from(SCHEMA_VERSION) + 1),
            "{e}"
        );
    }
}
