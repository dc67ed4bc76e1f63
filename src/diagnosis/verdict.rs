//! What a diagnosis returns: its options, the ranked candidates, where the gap lies, and the
//! verdict.

use super::evidence::*;
use super::features::{Feature, N_FEATURES};
use super::fingerprint;
use super::fit::{self, FitOptions, FitResult};
use crate::model::EffectKind;
use crate::model::effects::Form;

/// Options of a diagnosis.
#[derive(Clone, Debug)]
pub struct DiagnoseOptions {
    /// Candidate effects. Default: every candidate of the library.
    pub candidates: Vec<EffectKind>,
    /// Fit options.
    pub fit: FitOptions,
    /// Fit and rank the candidates also where the verdict is `no_significant_gap` before any
    /// is fitted (held-out gap below [`SIGNIFICANT_GAP`], no feature's gap concentrated):
    /// nothing is left to explain there, and by default no candidate is fitted (an empty
    /// ranking; most of a diagnosis's time is its candidates). Default false.
    pub rank_always: bool,
    /// Compute the detection limits ([`crate::diagnosis::limits`]) where the model in hand
    /// leaves no significant gap. Default true; about a minute of simulations on 2 cores for
    /// 30 recordings.
    pub limits: bool,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            candidates: EffectKind::candidates(),
            fit: FitOptions::default(),
            rank_always: false,
            limits: true,
        }
    }
}

/// One candidate's result.
#[derive(Clone, Debug)]
pub struct Ranked {
    /// The effect.
    pub effect: EffectKind,
    /// Its form, where the effect has forms ([`crate::model::effects::Form`]).
    pub form: Option<&'static Form>,
    /// Its name in reports: the effect's, with the form in brackets where it is not the
    /// default one (`normal_coupling[velocity]`).
    pub name: String,
    /// Nats charged for the choice of its form where the diagnosis tried the effect's forms
    /// (`ln m` for `m` forms; 0 otherwise), in [`Ranked::evidence`] already.
    pub form_charge: f64,
    /// Its fit on all recordings.
    pub fit: FitResult,
    /// Held-out gap (pooled over the folds).
    pub gap_after: f64,
    /// Standard deviation of the folds' held-out gaps.
    pub gap_spread: f64,
    /// `(E0 − E1) / E0` on the held-out recordings.
    pub reduction: f64,
    /// Ranking score `E1 (1 + 0.05 k)`.
    pub score: f64,
    /// Each held-out recording's own gap under the fold's model (NaN where not checked).
    pub per_recording: Vec<f64>,
    /// The number of held-out residuals behind each of [`Ranked::per_recording`].
    pub per_recording_n: Vec<usize>,
    /// The held-out evidence for it against the model it extends (the base model, or the first
    /// named effect for a second).
    pub evidence: Evidence,
    /// Its fitted parameters that end on a bound of their plausible range ([`fit::at_bounds`]).
    pub at_bound: Vec<String>,
    /// Its held-out gap in each feature (NaN where no held-out unit defines it): against the
    /// base model's ([`Diagnosis::base_per_feature`]), where its fit acts.
    pub per_feature: Vec<f64>,
    /// The feature in which its own held-out gap still concentrates, where one does
    /// ([`FEATURE_GAP`] on two recordings or more).
    pub concentrated: Option<(Feature, f64, usize)>,
    /// Wall time of its scan, fit and cross-validation \[s\].
    pub wall_time: f64,
    /// Its fingerprints checked against the recordings ([`fingerprint::check`]) and its
    /// held-out feature families ([`held_out_families`](crate::diagnosis::diagnose::held_out_families)): for a candidate the decision reached
    /// (named, tied or rejected), empty for the others.
    pub fingerprints: Vec<fingerprint::Check>,
    /// Why it is not named although its evidence would name it: a trace fingerprint absent.
    pub rejected: Option<String>,
    /// Another form of an effect screened but not fitted further, as it could not come near the
    /// leading candidate ([`FORM_REACH`](crate::diagnosis::forms::FORM_REACH)): its
    /// screen's gap and the gap it had to reach, on the screen's recordings. Its other
    /// numbers are the model it extends's, as for a candidate whose screen fails.
    pub short_of_leader: Option<(f64, f64)>,
    /// A candidate whose screen fell short of its bar ([`SCREEN_BAR`](crate::diagnosis::screen::SCREEN_BAR)), ranked as the model it
    /// extends: the lowest gap its screen reached, that model's gap on the screen's
    /// recordings, and the screened model there (on a subset, its base parameters are fitted
    /// to the subset). A plan takes an unexplained gap's best three candidates from these.
    pub screened: Option<(f64, f64, crate::diagnosis::fit::Model)>,
}

/// Twenty quiet recordings (held-out gap `quiet`) and four informative ones (`loud`): the
/// decision's tests' campaign.
#[cfg(test)]
pub(crate) fn quiet_and_loud(quiet: f64, loud: f64) -> Vec<f64> {
    let mut g = vec![quiet; 20];
    g.extend([loud; 4]);
    g
}

#[cfg(test)]
impl Ranked {
    /// A candidate of `p` parameters with held-out gaps `gaps` (`per` residuals each) and its
    /// evidence against a base model of gaps `base` by the rule: for the decision's tests.
    pub(crate) fn for_test(
        k: EffectKind,
        p: usize,
        gaps: &[f64],
        base: &[f64],
        per: usize,
    ) -> Ranked {
        let n = vec![per; gaps.len()];
        let e = evidence(gaps, &n, base, &n, p as f64);
        let pooled = (gaps.iter().map(|g| g * g).sum::<f64>() / gaps.len() as f64).sqrt();
        Ranked {
            effect: k,
            form: None,
            name: k.name().to_string(),
            form_charge: 0.0,
            fit: FitResult {
                model: crate::diagnosis::model::Model::default(),
                estimates: vec![],
                gap: pooled,
                residuals: per * gaps.len(),
                evaluations: 0,
                effect_params: p,
                iterations: 0,
                converged: true,
                stalled: false,
                theta: vec![],
                z: vec![],
                jacobian: faer::Mat::zeros(0, 0),
                jacobian_fresh: false,
                effects: vec![k],
            },
            gap_after: pooled,
            gap_spread: 0.0,
            reduction: 0.0,
            score: pooled,
            per_recording: gaps.to_vec(),
            per_recording_n: n,
            evidence: e,
            at_bound: vec![],
            per_feature: vec![],
            concentrated: None,
            wall_time: 0.0,
            fingerprints: vec![],
            rejected: None,
            short_of_leader: None,
            screened: None,
        }
    }
}

/// Where the gap lies, from the calibrated base model over all recordings.
#[derive(Clone, Debug)]
pub struct Where {
    /// Per feature: RMS z and share of the summed z².
    pub features: Vec<(Feature, f64, f64)>,
    /// Per phase: RMS z and share of the summed z².
    pub phases: Vec<(&'static str, f64, f64)>,
    /// Per condition: Spearman correlation of the per-recording gap with it.
    pub conditions: Vec<(&'static str, f64)>,
    /// Per recording: name, gap, conditions (v_d, k_d, f, v_a/v_d, stick time, k_t u0/F_c),
    /// checked on held-out data or not.
    pub recordings: Vec<RecordingGap>,
    /// The gap on recordings with vibration and without.
    pub with_vibration: (f64, f64),
    /// A sentence or two.
    pub summary: String,
}

/// The gap of one recording.
#[derive(Clone, Debug)]
pub struct RecordingGap {
    /// File stem.
    pub name: String,
    /// Gap under the calibrated base model.
    pub gap_base: f64,
    /// Gap under the top-ranked candidate (NaN when none was tried).
    pub gap_best: f64,
    /// Checked on held-out data (its kind of condition has two groups or more).
    pub held_out: bool,
    /// Its fold.
    pub fold: usize,
    /// `[v_d, k_d, f, v_a/v_d, stick time, k_t u0/F_c]`.
    pub conditions: [f64; 6],
    /// z per feature under the base model, the largest over the recording's stages (NaN where
    /// undefined).
    pub z_base: [f64; N_FEATURES],
}

/// Names of [`RecordingGap::conditions`].
pub const CONDITIONS: [&str; 6] = ["v_d", "k_d", "f", "va_ratio", "stick_time", "kt_u0_over_Fc"];

/// Verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A candidate explains the gap.
    Effect,
    /// The base model matches within noise.
    NoSignificantGap,
    /// No candidate explains the gap.
    Unexplained,
    /// Two candidates or more explain it and the data cannot tell them apart
    /// ([`Diagnosis::tie`]): none is named.
    Tie,
}

impl Verdict {
    /// Name in the JSON report.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Effect => "effect",
            Verdict::NoSignificantGap => "no_significant_gap",
            Verdict::Unexplained => "unexplained",
            Verdict::Tie => "tie",
        }
    }
}

/// Two models the held-out data order one way by their evidence and the other way by their
/// held-out gap ([`crate::diagnosis::decide`], module docs), with the recordings that carry each
/// side.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Disagreement {
    /// The model the evidence prefers.
    pub by_evidence: String,
    /// The model the held-out gap prefers.
    pub by_gap: String,
    /// The evidence \[nats\] for `by_evidence` against `by_gap`.
    #[serde(deserialize_with = "crate::diagnosis::nullable::f64")]
    pub ln_odds: f64,
    /// Pooled held-out gap of `by_evidence` over the recordings both define.
    #[serde(deserialize_with = "crate::diagnosis::nullable::f64")]
    pub gap_by_evidence: f64,
    /// Pooled held-out gap of `by_gap` there (the lower).
    #[serde(deserialize_with = "crate::diagnosis::nullable::f64")]
    pub gap_by_gap: f64,
    /// Jackknife standard error of the gaps' difference.
    #[serde(deserialize_with = "crate::diagnosis::nullable::f64")]
    pub gap_stderr: f64,
    /// How many recordings' log ratios favour `by_evidence`.
    pub evidence_recordings: usize,
    /// Those carrying most of it, largest first (at most four).
    pub evidence_carried_by: Vec<String>,
    /// How many recordings' squared residuals favour `by_gap`.
    pub gap_recordings: usize,
    /// Those carrying most of it, largest first (at most four).
    pub gap_carried_by: Vec<String>,
    /// The share of the net squared-gap difference the listed recordings carry.
    #[serde(deserialize_with = "crate::diagnosis::nullable::f64")]
    pub gap_share: f64,
}

impl Disagreement {
    /// One sentence for the warnings and the report.
    pub fn line(&self) -> String {
        format!(
            "the evidence and the held-out gap disagree about {e} and {g}: the evidence prefers {e} (ln odds {lo:.1}), from {ne} recording(s) with {ec}; the held-out gap prefers {g} ({gg:.3} against {ge:.3}, ± {se:.3}), carried by {gc} ({share}of the squared-residual difference, {ng} recording(s) in its favour); the two cannot be ordered, and are at most a tie",
            e = self.by_evidence,
            g = self.by_gap,
            lo = self.ln_odds,
            ne = self.evidence_recordings,
            ec = if self.evidence_carried_by.is_empty() {
                "none".to_string()
            } else {
                format!("most of it in {}", self.evidence_carried_by.join(", "))
            },
            gg = self.gap_by_gap,
            ge = self.gap_by_evidence,
            se = self.gap_stderr,
            gc = self.gap_carried_by.join(", "),
            share = if self.gap_share.is_finite() {
                format!("{:.0} % ", 100.0 * self.gap_share.min(9.99))
            } else {
                String::new()
            },
            ng = self.gap_recordings,
        )
    }
}

/// The full diagnosis.
#[derive(Clone, Debug)]
pub struct Diagnosis {
    /// Verdict.
    pub verdict: Verdict,
    /// The named effect (with verdict `effect`).
    pub best_effect: Option<EffectKind>,
    /// The named effects in order (the first is `best_effect`; a second when forward selection
    /// names one).
    pub effects: Vec<EffectKind>,
    /// The named effects explain only part of the gap: they leave a significant one, or a fitted
    /// parameter ends on a bound of its plausible range (see the module docs).
    pub partial: bool,
    /// The feature in which the base model's held-out gap concentrates, where one does
    /// ([`FEATURE_GAP`]): the feature, its held-out gap and the number of checked recordings
    /// on which its `|z|` reaches that level.
    pub concentrated: Option<(Feature, f64, usize)>,
    /// The harmonic feature the base model misses systematically on held-out data ([`BIAS_Z`](crate::diagnosis::folds::BIAS_Z),
    /// [`BIAS_T`](crate::diagnosis::folds::BIAS_T), [`BIAS_UNITS`](crate::diagnosis::folds::BIAS_UNITS)),
    /// where one does: the feature, its mean `z`, the `t` of that mean and the units.
    pub systematic: Option<(Feature, f64, f64, usize)>,
    /// Where only [`Diagnosis::concentrated`] makes the gap significant: the held-out
    /// reduction of the gap beyond noise, `(E0 − E1)/(E0 − 1)`, which the decision used.
    pub reduction_beyond_noise: Option<f64>,
    /// Held-out gap of the calibrated base model.
    pub gap_before: f64,
    /// Spread of the folds' held-out gaps of the base model.
    pub gap_before_spread: f64,
    /// Held-out gap of the named effects (of the base model when none is named).
    pub gap_after: f64,
    /// Spread of the folds' held-out gaps of the named effects.
    pub gap_after_spread: f64,
    /// `(E0 − E1) / E0`.
    pub reduction: f64,
    /// Share of held-out recordings with a gap (at least [`GAPPED`]) whose gap the top
    /// candidate lowers (informative: the decision weighs the evidence).
    pub breadth: f64,
    /// The top candidate's held-out evidence against the base model (two effects named
    /// together where neither passed its screen alone: the pair's).
    pub evidence: Option<Evidence>,
    /// The top candidate's held-out evidence against the runner-up (the best candidate of
    /// another effect), with the runner-up (a pair named together: the pair's against its
    /// second effect alone).
    pub evidence_runner_up: Option<(EffectKind, Evidence)>,
    /// The candidates the data cannot tell apart, best first, with verdict [`Verdict::Tie`]
    /// (empty otherwise).
    pub tie: Vec<EffectKind>,
    /// The form the data chose for each named effect that has forms, in the order of
    /// [`Diagnosis::effects`].
    pub forms: Vec<FormChoice>,
    /// What the verdict's reader must know: a named effect's parameter on a bound of its
    /// plausible range, a first effect not converged, ...
    pub warnings: Vec<String>,
    /// Where the evidence and the held-out gap order two models (candidates, or a candidate
    /// and the model it extends) the opposite way ([`crate::diagnosis::decide`]): such a pair
    /// is at most a tie, and each is also a warning.
    pub disagreements: Vec<Disagreement>,
    /// What the campaign could not have seen: each effect's detection limit, where the model
    /// in hand leaves no significant gap ([`crate::diagnosis::limits`]).
    pub limits: crate::diagnosis::limits::Limits,
    /// The campaign's plausible ranges of the effects' parameters.
    pub bounds: fit::Plausible,
    /// The base model's held-out gap in each feature (NaN where no held-out unit defines it).
    pub base_per_feature: Vec<f64>,
    /// The base calibration on all recordings.
    pub base: FitResult,
    /// Candidates, best first; empty where the verdict is `no_significant_gap` (unless
    /// [`DiagnoseOptions::rank_always`]).
    pub ranking: Vec<Ranked>,
    /// Second effects tried with the first named one, best first.
    pub second: Vec<Ranked>,
    /// Where the gap lies.
    pub location: Where,
    /// Where the gap left by the named effects lies (empty when none is named).
    pub remaining: String,
    /// Number of folds.
    pub folds: usize,
    /// Names of the recordings checked on held-out data.
    pub held_out: Vec<String>,
    /// What the design cannot check on held-out data, one sentence each.
    pub not_checked: Vec<String>,
    /// Wall time \[s\].
    pub wall_time: f64,
    /// The simulations behind the diagnosis, with their cost.
    pub work: fit::Work,
    /// The same, step by step (calibration, cross-validation, candidates, fingerprints, forms,
    /// second effect, location, limits; a step that did not run is absent).
    pub steps: Vec<fit::StepWork>,
}

/// The form a named effect takes, as the data chose it among the forms tried.
#[derive(Clone, Debug, PartialEq)]
pub struct FormChoice {
    /// The effect.
    pub effect: EffectKind,
    /// The form named (the best evidence among those not rejected).
    pub form: &'static str,
    /// Every form tried, the named one first.
    pub tried: Vec<&'static str>,
    /// The forms tried that it does not clearly beat (by evidence): where any is, the data
    /// cannot tell the form, and the effect is named without it being settled.
    pub not_excluded: Vec<&'static str>,
}

impl FormChoice {
    /// Whether the named form is the effect's default (first) one.
    pub fn is_default(&self) -> bool {
        self.effect.info().forms.first().map(|f| f.name) == Some(self.form)
    }

    /// Whether the form is settled: another than the default, clearly more likely than every
    /// other form tried. The default form is never settled against the others: they are
    /// fitted from starts next to its own fit (and their scans), with less search than it
    /// gets, so a worse fit of theirs may be an optimum missed rather than a worse form.
    pub fn settled(&self) -> bool {
        self.not_excluded.is_empty() && self.tried.len() > 1 && !self.is_default()
    }

    /// One line: `sensor_dynamics: form order4 (against order2: settled)`.
    pub fn line(&self) -> String {
        let others: Vec<&str> = self.tried[1..].to_vec();
        if others.is_empty() {
            return format!("{}: form {} (the only one tried)", self.effect, self.form);
        }
        if self.is_default() && self.not_excluded.is_empty() {
            format!(
                "{}: form {} (its default), the others tried ({}) fit worse but are not excluded: their fits start next to this one's",
                self.effect,
                self.form,
                others.join(", ")
            )
        } else if self.settled() {
            format!(
                "{}: form {}, clearly more likely than {}",
                self.effect,
                self.form,
                others.join(", ")
            )
        } else {
            format!(
                "{}: form {} by evidence, but the data cannot exclude {}",
                self.effect,
                self.form,
                self.not_excluded.join(", ")
            )
        }
    }
}
