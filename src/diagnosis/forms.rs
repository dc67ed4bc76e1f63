//! Effect families in the decision: which other forms of the effects a round tries, the nats
//! charged for choosing a form, and how forms of one effect tied name that effect with its form
//! settled or not (docs/campaigns.md, "Effect families").

use super::decide::between;
use super::fit::{FitResult, Model};
use super::verdict::{FormChoice, Ranked};
use crate::model::EffectKind;

/// The candidates of a round to try in their other forms: every form of each effect with
/// forms whose default form passed its screen (its fit holds the effect), and, with `all`
/// (where the default forms name no effect, or tie), of every effect with forms: an effect out
/// of reach in one form, or rejected by a fingerprint that form predicts, may be within reach,
/// or carry its fingerprint, in another. `(effect, form value, warm start)`, in the order of
/// `ranked`; the warm start, where the default form passed its screen, is its fit in the other
/// form.
pub(crate) fn other_forms(ranked: &[Ranked], all: bool) -> Vec<(EffectKind, f64, Option<Model>)> {
    ranked
        .iter()
        .filter(|r| {
            r.effect.info().forms.len() > 1
                && r.form.is_none_or(|f| f.value == r.effect.default_form())
                && (all || r.fit.effects.contains(&r.effect))
        })
        .flat_map(|r| {
            let k = r.effect;
            let passed = r.fit.effects.contains(&k);
            k.info()
                .forms
                .iter()
                .filter(move |f| f.value != k.default_form())
                .map(move |f| {
                    let warm = passed.then(|| {
                        let mut m = r.fit.model.clone();
                        let _ = m.effects.set_form_value(k, f.value);
                        m
                    });
                    (k, f.value, warm)
                })
        })
        .collect()
}

/// A candidate to try.
#[derive(Clone, Debug)]
pub(crate) struct Try {
    /// The effect.
    pub effect: EffectKind,
    /// Its form's value ([`crate::model::effects::form_param`]).
    pub form: f64,
    /// A warm start: another form starts from the default form's fit.
    pub warm: Option<Model>,
    /// How near the leading candidate its screen must come to be fitted further, as a
    /// multiple of the extended model's gap on the screen's recordings ([`form_reach`]);
    /// `None`, fitted further wherever its screen passes.
    pub reach: Option<f64>,
    /// Whether the reach may also stop the screen's iterations early, on their linearised
    /// residuals (another form of a trailing effect); else the screen runs its iterations in
    /// full and the reach is checked on where it ends (the leader's own forms, and those of the
    /// effects a decision named or tied).
    pub reach_stops_screen: bool,
}

impl Try {
    /// The effect in its default form, from its scan alone, fitted in full.
    pub(crate) fn default_form(effect: EffectKind) -> Try {
        Try {
            effect,
            form: effect.default_form(),
            warm: None,
            reach: None,
            reach_stops_screen: false,
        }
    }
}

/// How far above the leading candidate's gap another form may screen and still be fitted
/// further: its screen's gap at most `FORM_REACH` times the leader's, both as shares of the
/// extended model's gap (the leader's on every recording, the form's on the screen's). Why
/// 1.5: a fit 1.5 times the leader's gap over the few hundred residuals of a campaign is worse
/// by `n/2 · ln 2.25` nats, 40 nats at 100 residuals, far past any tie. A screen's share is
/// not its further fit's (on the bench's five campaigns the further fit's share on every
/// recording was 0.63 to 1.46 times the screen's), so a form cut could end nearer the leader than
/// 1.5 times, but on those campaigns every form cut had ended 1.20 to 3.0 times the named form's
/// held-out gap when fitted in full (docs/campaigns.md, "Effect families").
pub const FORM_REACH: f64 = 1.5;

/// `others` (from [`other_forms`]) with the reach of each, where `ranked` has a leading
/// candidate (the best by evidence whose fit holds its effect and that no fingerprint
/// rejected): [`FORM_REACH`] times the leader's gap as a share of `from`'s. The forms of the
/// leader's effect and of `exempt` (the effects a decision named or tied) are screened in full
/// and judged on where their screens end; the others' screens may stop as soon as they cannot
/// come near ([`Try::reach_stops_screen`]). Without a leader, every form is fitted in full.
pub(crate) fn form_reach(
    ranked: &[Ranked],
    from: &FitResult,
    exempt: &[EffectKind],
    others: Vec<(EffectKind, f64, Option<Model>)>,
) -> Vec<Try> {
    // The first of the best evidence, in `ranked`'s order.
    let leader = ranked
        .iter()
        .filter(|r| r.rejected.is_none() && r.fit.effects.contains(&r.effect))
        .reduce(|a, b| {
            if b.evidence.ln_odds > a.evidence.ln_odds {
                b
            } else {
                a
            }
        });
    others
        .into_iter()
        .map(|(k, f, warm)| {
            let reach = leader
                .filter(|_| from.gap > 0.0)
                .map(|l| FORM_REACH * l.fit.gap / from.gap);
            let trailing = leader.is_some_and(|l| l.effect != k && !exempt.contains(&k));
            Try {
                effect: k,
                form: f,
                warm,
                reach,
                reach_stops_screen: trailing,
            }
        })
        .collect()
}

/// The other forms `others` (from [`other_forms`]) tried beside the candidates `ranked`, in
/// two phases: first the forms of the leader's effect and of `exempt` ([`form_reach`]); then,
/// after `between` (the decision again, its fingerprints included, so that the leader is one
/// they let stand; it returns the effects that decision named or tied, exempt too from then
/// on), the trailing effects' forms, whose reach is that of the leader as it then stands: a
/// form of the leader's effect that fits better asks more of them. `round` fits a list of
/// candidates. Returns whether any form was tried.
pub(crate) fn try_forms(
    ranked: &mut Vec<Ranked>,
    from: &FitResult,
    exempt: &[EffectKind],
    others: Vec<(EffectKind, f64, Option<Model>)>,
    round: impl Fn(&[Try]) -> Vec<Ranked>,
    mut between: impl FnMut(&mut Vec<Ranked>) -> Vec<EffectKind>,
) -> bool {
    if others.is_empty() {
        return false;
    }
    let (own, trailing): (Vec<Try>, Vec<Try>) = form_reach(ranked, from, exempt, others)
        .into_iter()
        .partition(|t| !t.reach_stops_screen);
    ranked.extend(round(&own));
    if trailing.is_empty() {
        return true;
    }
    let mut exempt = exempt.to_vec();
    if !own.is_empty() {
        exempt.extend(between(ranked));
    }
    let trailing = trailing
        .into_iter()
        .map(|t| (t.effect, t.form, t.warm))
        .collect();
    let trailing = form_reach(ranked, from, &exempt, trailing);
    ranked.extend(round(&trailing));
    true
}

/// Charges every candidate of an effect tried in several forms `ln m` nats for the choice
/// among its `m` forms ([`Ranked::form_charge`]): a uniform prior over the forms.
pub(crate) fn charge_forms(ranked: &mut [Ranked]) {
    let kinds: Vec<EffectKind> = ranked.iter().map(|r| r.effect).collect();
    for r in ranked.iter_mut() {
        if kinds.iter().filter(|&&k| k == r.effect).count() > 1 {
            let charge = (r.effect.info().forms.len() as f64).ln();
            r.evidence = r.evidence.charged(charge);
            r.form_charge = charge;
        }
    }
}

/// Where a decision's tie `t` (indices into `ranked`) holds forms of one effect only, that
/// effect is named: its qualifying form of best evidence is moved to the head of `ranked`,
/// and `None` is returned; else the effects tied, each once, best first.
pub(crate) fn forms_of_one(
    ranked: &mut Vec<Ranked>,
    t: &[usize],
    share: impl Fn(f64) -> f64,
    min_share: f64,
) -> Option<Vec<EffectKind>> {
    let mut kinds: Vec<EffectKind> = vec![];
    for &j in t {
        if !kinds.contains(&ranked[j].effect) {
            kinds.push(ranked[j].effect);
        }
    }
    if kinds.len() > 1 {
        return Some(kinds);
    }
    let lead = t
        .iter()
        .copied()
        .find(|&j| ranked[j].evidence.clear() && share(ranked[j].gap_after) >= min_share)
        .unwrap_or(t[0]);
    let r = ranked.remove(lead);
    ranked.insert(0, r);
    None
}

/// The form chosen for the named candidate `ranked[0]` among the forms of its effect in
/// `ranked`, where it has forms.
pub(crate) fn form_choice(ranked: &[Ranked]) -> Option<FormChoice> {
    let named = ranked.first()?;
    let form = named.form?;
    let others: Vec<&Ranked> = ranked[1..]
        .iter()
        .filter(|r| r.effect == named.effect)
        .collect();
    Some(FormChoice {
        effect: named.effect,
        form: form.name,
        tried: std::iter::once(form.name)
            .chain(others.iter().filter_map(|r| r.form.map(|f| f.name)))
            .collect(),
        not_excluded: others
            .iter()
            .filter(|r| r.rejected.is_none() && !between(named, r).clear())
            .filter_map(|r| r.form.map(|f| f.name))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every other form is asked to come within FORM_REACH of the leader. Where its effect
    /// leads (or a decision named or tied it), its screen runs in full and is judged where it
    /// ends; otherwise it may stop as soon as it cannot come near. A rejected candidate, or one
    /// whose screen failed (its fit does not hold its effect), leads nothing.
    #[test]
    fn other_forms_are_asked_to_come_near_the_leader() {
        use crate::model::EffectKind as K;
        let base = [4.0; 24];
        let mut from = Ranked::for_test(K::Viscous, 0, &base, &base, 17).fit;
        from.gap = 4.0;
        let mut rejected = Ranked::for_test(K::SensorDynamics, 2, &[0.5; 24], &base, 17);
        rejected.rejected = Some("ringing absent".into());
        let leader = Ranked::for_test(K::Viscous, 1, &[1.0; 24], &base, 17);
        let mut failed = Ranked::for_test(K::Aging, 1, &[0.9; 24], &base, 17);
        failed.fit.effects.clear();
        let trailing = Ranked::for_test(K::FrictionalLag, 1, &[2.0; 24], &base, 17);
        let ranked = [rejected, failed, leader, trailing];
        let others = vec![
            (K::SensorDynamics, 1.0, None),
            (K::Aging, 1.0, None),
            (K::Viscous, 2.0, None),
            (K::FrictionalLag, 1.0, None),
        ];
        let reach = |ranked: &[Ranked], exempt: &[K]| -> Vec<(Option<f64>, bool)> {
            form_reach(ranked, &from, exempt, others.clone())
                .into_iter()
                .map(|t| (t.reach, t.reach_stops_screen))
                .collect()
        };
        let want = Some(FORM_REACH * 1.0 / 4.0);
        let (stops, judged) = ((want, true), (want, false));
        assert_eq!(reach(&ranked, &[]), [stops, stops, judged, stops]);
        // Named or tied by a decision: screened in full, judged where it ends.
        assert_eq!(reach(&ranked, &[K::Aging]), [stops, judged, judged, stops]);
        // No leader: every form in full.
        let reach = reach(&ranked[..2], &[]);
        assert_eq!(reach, [(None, false); 4]);
    }

    /// The trailing effects' forms are asked to come near the leader as it stands once its own
    /// effect's forms are fitted: a form that fits better than the default asks more of them,
    /// and the fits run in two phases, the leader's first.
    #[test]
    fn trailing_forms_are_judged_after_the_leaders_own() {
        use crate::model::EffectKind as K;
        use std::cell::RefCell;
        let base = [4.0; 24];
        let mut from = Ranked::for_test(K::Viscous, 0, &base, &base, 17).fit;
        from.gap = 4.0;
        let mut ranked = vec![
            Ranked::for_test(K::Viscous, 1, &[2.0; 24], &base, 17),
            Ranked::for_test(K::FrictionalLag, 1, &[3.0; 24], &base, 17),
        ];
        let others = vec![(K::FrictionalLag, 1.0, None), (K::Viscous, 2.0, None)];
        let phases: RefCell<Vec<Vec<(K, Option<f64>, bool)>>> = RefCell::new(vec![]);
        let round = |tries: &[Try]| -> Vec<Ranked> {
            phases.borrow_mut().push(
                tries
                    .iter()
                    .map(|t| (t.effect, t.reach, t.reach_stops_screen))
                    .collect(),
            );
            // The leader's other form fits with half its gap.
            tries
                .iter()
                .map(|t| Ranked::for_test(t.effect, 1, &[1.0; 24], &base, 17))
                .collect()
        };
        let mut between_ran = 0;
        let between = |_: &mut Vec<Ranked>| {
            between_ran += 1;
            vec![]
        };
        let tried = try_forms(&mut ranked, &from, &[], others, round, between);
        assert!(tried);
        assert_eq!(between_ran, 1);
        let phases = phases.into_inner();
        assert_eq!(
            phases,
            [
                vec![(K::Viscous, Some(FORM_REACH * 2.0 / 4.0), false)],
                vec![(K::FrictionalLag, Some(FORM_REACH * 1.0 / 4.0), true)],
            ]
        );
        assert_eq!(ranked.len(), 4);
        // Nothing to try: no round.
        let none = try_forms(
            &mut ranked,
            &from,
            &[],
            vec![],
            |_| unreachable!(),
            |_| vec![],
        );
        assert!(!none);
    }
    use crate::diagnosis::decide::{Side, decide};
    use crate::diagnosis::evidence::MIN_PARTIAL;

    const N: usize = 17;

    use crate::diagnosis::verdict::quiet_and_loud as gaps;

    fn cand(k: EffectKind, p: usize, gaps: &[f64], base: &[f64]) -> Ranked {
        Ranked::for_test(k, p, gaps, base, N)
    }

    /// The decision over `ranked` (sorted by evidence first) against a base model of gaps
    /// `base`: the effects named or tied.
    fn run(ranked: &mut [Ranked], base: &[f64]) -> (Option<Vec<EffectKind>>, usize) {
        ranked.sort_by(|a, b| b.evidence.ln_odds.total_cmp(&a.evidence.ln_odds));
        let n = vec![N; base.len()];
        let from = Side {
            name: "base",
            per_recording: base,
            n: &n,
        };
        let names: Vec<String> = (0..base.len()).map(|i| format!("r{i:02}")).collect();
        let e0 = (base.iter().map(|g| g * g).sum::<f64>() / base.len() as f64).sqrt();
        let (t, d) = decide(ranked, from, &names, |e1| (e0 - e1) / e0, MIN_PARTIAL);
        (
            t.map(|t| t.iter().map(|&j| ranked[j].effect).collect()),
            d.len(),
        )
    }

    /// A candidate in a form of its effect: named `kind[form]` off the default form.
    fn in_form(k: EffectKind, form: &str, p: usize, gaps: &[f64], base: &[f64]) -> Ranked {
        let mut r = cand(k, p, gaps, base);
        let f = k.form_named(form).unwrap();
        r.form = Some(f);
        if f.value != k.default_form() {
            r.name = format!("{k}[{form}]");
        }
        r
    }

    /// Two forms of one effect are one explanation: where the data cannot tell them apart the
    /// effect is named, its form with the other not excluded; where one form is clearly more
    /// likely, the form is settled. Each form is charged `ln m` nats for the choice, `m` the forms of
    /// its family.
    #[test]
    fn forms_of_one_effect_name_the_effect_and_say_whether_the_form_is_settled() {
        let base = gaps(1.0, 6.0);
        // The sensor's two forms, with the informative recordings' gaps `loud2` and `loud4`.
        let sensor_forms = |loud2: f64, loud4: f64| {
            vec![
                in_form(
                    EffectKind::SensorDynamics,
                    "order2",
                    2,
                    &gaps(1.0, loud2),
                    &base,
                ),
                in_form(
                    EffectKind::SensorDynamics,
                    "order4",
                    2,
                    &gaps(1.0, loud4),
                    &base,
                ),
            ]
        };
        let e0 = (base.iter().map(|g| g * g).sum::<f64>() / 24.0).sqrt();
        let share = |e1: f64| (e0 - e1) / e0;
        // Alike: 3.0 and 3.02 on the informative recordings.
        let mut alike = vec![
            in_form(
                EffectKind::SensorDynamics,
                "order2",
                2,
                &gaps(1.0, 3.0),
                &base,
            ),
            in_form(
                EffectKind::SensorDynamics,
                "order4",
                2,
                &gaps(1.0, 3.02),
                &base,
            ),
        ];
        let before = alike[0].evidence.ln_odds;
        charge_forms(&mut alike);
        // The sensor's family has three forms: each is charged ln 3.
        assert!((before - alike[0].evidence.ln_odds - 3f64.ln()).abs() < 1e-12);
        let (t, _) = run(&mut alike, &base);
        assert_eq!(t.as_ref().map(Vec::len), Some(2), "{t:?}");
        let idx: Vec<usize> = vec![0, 1];
        assert_eq!(forms_of_one(&mut alike, &idx, share, MIN_PARTIAL), None);
        let c = form_choice(&alike).unwrap();
        assert_eq!((c.form, c.not_excluded.clone()), ("order2", vec!["order4"]));
        assert!(!c.settled(), "{c:?}");
        // Clearly apart: the fourth-order form halves the informative recordings' gap again.
        let mut apart = sensor_forms(3.0, 1.5);
        charge_forms(&mut apart);
        let (t, _) = run(&mut apart, &base);
        assert_eq!(t.as_ref().map(Vec::len), Some(1), "{t:?}");
        let c = form_choice(&apart).unwrap();
        assert_eq!(c.form, "order4");
        assert!(c.settled(), "{c:?}");
        assert_eq!(apart[0].name, "sensor_dynamics[order4]");
        // The default form clearly ahead is not settled: the others' fits start next to its
        // own, so a worse one of theirs may be an optimum missed.
        let mut ahead = sensor_forms(1.5, 3.0);
        charge_forms(&mut ahead);
        let (t, _) = run(&mut ahead, &base);
        assert_eq!(t.as_ref().map(Vec::len), Some(1), "{t:?}");
        let c = form_choice(&ahead).unwrap();
        assert_eq!(c.form, "order2");
        assert!(
            c.not_excluded.is_empty() && c.is_default() && !c.settled(),
            "{c:?}"
        );
        assert!(c.line().contains("not excluded"), "{}", c.line());
        // Forms of two effects tied stay a tie of the effects.
        let mut two = vec![
            in_form(
                EffectKind::SensorDynamics,
                "order2",
                2,
                &gaps(1.0, 3.0),
                &base,
            ),
            cand(EffectKind::FrictionalLag, 2, &gaps(1.0, 3.01), &base),
        ];
        let idx: Vec<usize> = vec![0, 1];
        assert_eq!(
            forms_of_one(&mut two, &idx, share, MIN_PARTIAL),
            Some(vec![EffectKind::SensorDynamics, EffectKind::FrictionalLag])
        );
    }
}
