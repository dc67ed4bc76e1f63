//! The explanations a diagnosis leaves standing ([`rivals()`] of a [`DiagnosisRecord`]), why
//! each stands ([`Role`]), and the pairs of them the choice aims at (`open_pairs`).

use crate::diagnosis::evidence::evidence;
use crate::diagnosis::fit::Model;
use crate::diagnosis::record::{CandidateRecord, DiagnosisRecord};
use crate::diagnosis::verdict::Verdict;
use crate::model::EffectKind;

/// Most rivals a plan tells apart: the base model and the four best-supported others (every
/// rival adds its simulations on every candidate recording).
pub const MAX_RIVALS: usize = 5;

/// Why a rival stands: its place in the diagnosis, or how the plan fitted it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// The calibrated base model.
    Base,
    /// The two effects the diagnosis named, together.
    NamedEffects,
    /// The effect the diagnosis named.
    Named,
    /// A member of the diagnosis's tie.
    Tied,
    /// The leading candidate of an unexplained gap.
    BestOfUnexplained,
    /// A fitted candidate whose evidence against the leader is not clear.
    NotClearlyWorse,
    /// One of the best three candidates of an unexplained gap.
    BestThree,
    /// A second effect the diagnosis tried beside the first and did not name.
    SecondTried,
    /// One of an unexplained gap's best three, fitted by the plan ([`super::second`]).
    BestThreeFittedByPlan,
    /// A second effect beside the named one, fitted by the plan ([`super::second`]).
    SecondFittedByPlan,
}

impl Role {
    /// The role in words, as `plan.json` and the summary give it.
    pub fn describe(self) -> &'static str {
        match self {
            Role::Base => "the base model",
            Role::NamedEffects => "the named effects",
            Role::Named => "named",
            Role::Tied => "tied",
            Role::BestOfUnexplained => "the best of an unexplained gap",
            Role::NotClearlyWorse => "not clearly worse than the leader",
            Role::BestThree => "one of the best three of an unexplained gap",
            Role::SecondTried => "a second effect tried and not named",
            Role::BestThreeFittedByPlan => {
                "one of the best three of an unexplained gap, fitted by the plan (in-sample \
                 evidence: the diagnosis's screen fell short)"
            }
            Role::SecondFittedByPlan => {
                "a second effect beside the named one, fitted by the plan (in-sample \
                 evidence: the diagnosis tried none)"
            }
        }
    }
}

/// One explanation a diagnosis leaves standing.
#[derive(Clone, Debug)]
pub struct Rival {
    /// Its name in reports (`base`, `sensor_dynamics[order4]`, `aging+viscous`).
    pub name: String,
    /// Why it is a rival.
    pub role: Role,
    /// The fitted model.
    pub model: Model,
    /// Its effects fitted beside the base parameters.
    pub effects: Vec<EffectKind>,
    /// Its held-out ln odds against the base model \[nats\] (0 for the base model).
    pub ln_odds: f64,
    /// Whether that evidence is clear ([`crate::diagnosis::evidence::Evidence::clear`]).
    pub clear: bool,
}

fn entry_rival(e: &CandidateRecord, role: Role) -> Rival {
    Rival {
        name: e.name.clone(),
        role,
        model: e.model.clone(),
        effects: e.fitted_effects.clone(),
        ln_odds: e.evidence.ln_odds,
        clear: e.evidence.clear,
    }
}

/// The rivals of a diagnosis: the base model; the named effects (with a second named effect,
/// the model of both); every member of a tie; every other fitted candidate, another form of
/// the named effect included, whose held-out evidence against the leader is not clear (the
/// [`evidence`] of their per-recording held-out gaps); a second effect tried and not named; for
/// `unexplained`, the three best candidates. At most [`MAX_RIVALS`], the best supported first.
/// Candidates whose screen stopped short of the leader, or of the bar (their fit holds no
/// effect of its own, [`CandidateRecord::holds_effect`]), are not rivals; where an unexplained gap
/// leaves fewer than three, [`super::plan`] fits the others itself.
pub fn rivals(diag: &DiagnosisRecord) -> Vec<Rival> {
    let verdict = diag.verdict;
    let mut out = vec![Rival {
        name: "base".into(),
        role: Role::Base,
        model: diag.calibration.model.clone(),
        effects: vec![],
        ln_odds: 0.0,
        clear: false,
    }];
    let standing = |e: &&CandidateRecord| e.short_of_leader.is_none() && e.holds_effect();
    let ranking: Vec<&CandidateRecord> = diag
        .ranking
        .iter()
        .map(|e| &e.candidate)
        .filter(standing)
        .collect();
    let second: Vec<&CandidateRecord> = diag.second.iter().filter(standing).collect();
    let named = &diag.effects;
    let tie = &diag.tie;
    let first_of = |k: EffectKind| ranking.iter().find(|e| e.effect == k).copied();
    let push = |r: Rival, out: &mut Vec<Rival>| {
        if !out.iter().any(|x| x.name == r.name) {
            out.push(r);
        }
    };
    let mut leader: Option<&CandidateRecord> = None;
    if named.len() >= 2
        && let Some(s) = second.iter().find(|e| e.effect == named[1])
    {
        let mut r = entry_rival(s, Role::NamedEffects);
        r.name = format!("{}+{}", named[0], s.name);
        // Its evidence is against the first effect: add the first's against the base.
        if let Some(f) = first_of(named[0]) {
            r.ln_odds += f.evidence.ln_odds;
            leader = Some(f);
        }
        push(r, &mut out);
    }
    if let Some(&first) = named.first()
        && let Some(e) = first_of(first)
    {
        push(entry_rival(e, Role::Named), &mut out);
        leader = leader.or(Some(e));
    }
    for &t in tie {
        if let Some(e) = first_of(t) {
            push(entry_rival(e, Role::Tied), &mut out);
            leader = leader.or(Some(e));
        }
    }
    let leader = leader.or(ranking.first().copied());
    let unexplained = verdict == Verdict::Unexplained;
    // Neither named nor tied (an unexplained gap): the leading candidate is the first of its
    // best three.
    if let Some(l) = leader
        && unexplained
        && named.is_empty()
        && tie.is_empty()
    {
        push(entry_rival(l, Role::BestOfUnexplained), &mut out);
    }
    // Every fitted candidate, each form of an effect its own (a form the data did not settle
    // is a rival like another effect).
    let mut others = vec![];
    let mut best_three = 0;
    for e in &ranking {
        let Some(l) = leader else { break };
        if std::ptr::eq(*e, l) {
            continue;
        }
        let ev = evidence(
            &l.per_recording,
            &l.per_recording_n,
            &e.per_recording,
            &e.per_recording_n,
            l.n_params() as f64 - e.n_params() as f64,
        );
        if !ev.clear() {
            others.push((*e, Role::NotClearlyWorse));
        } else if unexplained && best_three < 2 {
            others.push((*e, Role::BestThree));
        }
        best_three += 1;
    }
    for (e, role) in others {
        push(entry_rival(e, role), &mut out);
    }
    if named.len() < 2
        && let Some(s) = second.first()
    {
        let mut r = entry_rival(s, Role::SecondTried);
        if let Some(&first) = named.first().or(tie.first()) {
            r.name = format!("{first}+{}", r.name);
            if let Some(f) = first_of(first) {
                r.ln_odds += f.evidence.ln_odds;
            }
        }
        push(r, &mut out);
    }
    // The base model first, then the best supported.
    let mut rest = out.split_off(1);
    rest.sort_by(|a, b| b.ln_odds.total_cmp(&a.ln_odds));
    rest.truncate(MAX_RIVALS - 1);
    out.extend(rest);
    out
}

/// The names of the rivals a plan fitted itself, for its warning (`none` where it kept none).
pub(crate) fn kept_names(extra: &[Rival], none: &str) -> String {
    if extra.is_empty() {
        return none.to_string();
    }
    extra
        .iter()
        .map(|x| x.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The pairs of rivals the maximin aims at ([`Plan::open`]), with a warning where the rule
/// had to fall back:
/// - a pair of the base model and a rival whose held-out evidence against it is clear is
///   closed by the existing recordings;
/// - a pair of two forms of the same effects (`sensor_dynamics` and `sensor_dynamics[order4]`)
///   is left out wherever a pair of different causes is open: a verdict names the cause, and
///   its form beside it; two forms predict nearly alike, so the smallest discrimination is
///   theirs, and a maximin that kept them would spend every recording on the form while the
///   causes stay untold;
/// - where no pair is open, every pair is (said in the warning).
pub(crate) fn open_pairs(rivals: &[Rival]) -> (Vec<(usize, usize)>, Option<String>) {
    let r = rivals.len();
    let cause = |x: &Rival| {
        let mut e: Vec<&str> = x.effects.iter().map(|k| k.name()).collect();
        e.sort_unstable();
        e
    };
    let mut open = vec![];
    let mut forms = vec![];
    for a in 0..r {
        for b in a + 1..r {
            let closed = (a == 0 && rivals[b].clear) || (b == 0 && rivals[a].clear);
            if closed {
                continue;
            }
            if cause(&rivals[a]) == cause(&rivals[b]) {
                forms.push((a, b));
            } else {
                open.push((a, b));
            }
        }
    }
    if !open.is_empty() {
        return (open, None);
    }
    if !forms.is_empty() {
        return (forms, None);
    }
    let all = (0..r)
        .flat_map(|a| (a + 1..r).map(move |b| (a, b)))
        .collect::<Vec<_>>();
    let why = (r >= 2).then(|| {
        "every pair of rivals is closed by the existing evidence: the plan tells all pairs \
         apart instead"
            .to_string()
    });
    (all, why)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnosis::fit::Model;
    use crate::diagnosis::record::CandidateRecord;

    /// A diagnosis: the base calibration and ranking entries `(name, fitted effects, ln
    /// odds)`, each over the same three recordings.
    fn diagnosis(
        verdict: Verdict,
        named: &[&str],
        entries: &[(&str, &[&str], f64)],
    ) -> DiagnosisRecord {
        let kind = |f: &str| EffectKind::from_name(f).unwrap();
        let base = Model::default();
        let mut d = DiagnosisRecord::for_test(
            verdict,
            named.iter().map(|n| kind(n)).collect(),
            base.clone(),
        );
        d.ranking = entries
            .iter()
            .map(|(name, fitted, ln_odds)| {
                let mut m = base.clone();
                for f in *fitted {
                    m.effects.enable(kind(f));
                }
                let fitted = fitted.iter().map(|f| kind(f)).collect();
                CandidateRecord::for_test(kind(name), name, m, fitted, *ln_odds).ranked(None)
            })
            .collect();
        d
    }

    /// A second effect whose screen fell short beside the named one reports the named model
    /// (`fitted_effects` without its own effect): no rival; one whose fit holds both is.
    #[test]
    fn a_second_effect_without_its_effect_is_not_a_rival() {
        let mut d = diagnosis(
            Verdict::Effect,
            &["actuator_response"],
            &[("actuator_response", &["actuator_response"], 40.0)],
        );
        let second = |fitted: &[&str]| {
            let mut m = Model::default();
            let mut effects = vec![];
            for f in fitted {
                let k = EffectKind::from_name(f).unwrap();
                m.effects.enable(k);
                effects.push(k);
            }
            CandidateRecord::for_test(EffectKind::Presliding, "presliding", m, effects, 2.0)
        };
        d.second = vec![second(&["actuator_response"])];
        let names: Vec<String> = rivals(&d).into_iter().map(|r| r.name).collect();
        assert_eq!(names, ["base", "actuator_response"]);
        d.second = vec![second(&["actuator_response", "presliding"])];
        let names: Vec<String> = rivals(&d).into_iter().map(|r| r.name).collect();
        // Best supported first: the pair's evidence adds the named effect's.
        assert_eq!(
            names,
            ["base", "actuator_response+presliding", "actuator_response"]
        );
    }

    /// A candidate whose screen fell short reports the base model (`fitted_effects` empty): it
    /// is not a rival, however its evidence reads; one whose fit holds its effect is.
    #[test]
    fn a_fit_without_its_effect_is_not_a_rival() {
        let d = diagnosis(
            Verdict::Unexplained,
            &[],
            &[("aging", &[], -1.7), ("viscous", &["viscous"], 3.0)],
        );
        let names: Vec<String> = rivals(&d).into_iter().map(|r| r.name).collect();
        assert_eq!(names, ["base", "viscous"]);
        // None fitted: the base model alone (the plan then fits the best three itself).
        let d = diagnosis(
            Verdict::Unexplained,
            &[],
            &[("aging", &[], -1.7), ("viscous", &[], -1.7)],
        );
        assert_eq!(rivals(&d).len(), 1);
        // Four fitted, their evidence against each other clear: the best three of the ranking
        // (the leader among them), the fourth left out.
        let mut d = diagnosis(
            Verdict::Unexplained,
            &[],
            &[
                ("viscous", &["viscous"], 3.0),
                ("aging", &["aging"], 2.0),
                ("presliding", &["presliding"], 1.0),
                ("drive_ripple", &["drive_ripple"], 0.5),
            ],
        );
        for (k, e) in d.ranking.iter_mut().enumerate() {
            e.candidate.per_recording = vec![1.0 + k as f64; 3];
        }
        let names: Vec<String> = rivals(&d).into_iter().map(|r| r.name).collect();
        assert_eq!(names, ["base", "viscous", "aging", "presliding"]);
    }

    /// A rival of `effects`, its evidence against the base model clear or not.
    fn rival(name: &str, effects: &[EffectKind], clear: bool) -> Rival {
        Rival {
            name: name.into(),
            role: Role::Base,
            model: Model::default(),
            effects: effects.to_vec(),
            ln_odds: 0.0,
            clear,
        }
    }

    #[test]
    fn the_maximin_aims_at_causes_before_forms() {
        use EffectKind::*;
        let base = rival("base", &[], false);
        let s2 = rival("sensor_dynamics", &[SensorDynamics], true);
        let s4 = rival("sensor_dynamics[order4]", &[SensorDynamics], false);
        let lag = rival("frictional_lag", &[FrictionalLag], false);
        let two = rival(
            "frictional_lag+stribeck_shape",
            &[StribeckShape, FrictionalLag],
            false,
        );
        let two_again = rival(
            "stribeck_shape+frictional_lag",
            &[FrictionalLag, StribeckShape],
            false,
        );
        // The sensor's two forms are one cause; base and the clear sensor are closed.
        let (open, why) = open_pairs(&[base.clone(), s2.clone(), s4.clone(), lag.clone()]);
        assert_eq!(open, [(0, 2), (0, 3), (1, 3), (2, 3)]);
        assert!(why.is_none());
        // The same effects in another order are the same cause.
        let (open, _) = open_pairs(&[base.clone(), two.clone(), two_again, lag]);
        assert_eq!(open, [(0, 1), (0, 2), (0, 3), (1, 3), (2, 3)]);
        // Only forms left to tell apart: the forms.
        let (open, why) = open_pairs(&[base.clone(), s2.clone(), s4]);
        assert_eq!(open, [(0, 2)]);
        assert!(why.is_none());
        let s4_clear = rival("sensor_dynamics[order4]", &[SensorDynamics], true);
        let (open, _) = open_pairs(&[base.clone(), s2.clone(), s4_clear]);
        assert_eq!(open, [(1, 2)]);
        // Nothing open: every pair, with a warning.
        let (open, why) = open_pairs(&[base, s2]);
        assert_eq!(open, [(0, 1)]);
        assert!(why.is_some());
    }
}
