//! One candidate fitted and ranked (`try_candidate`): screened from its scan's starts, fitted
//! on every recording where its screen passes, cross-validated and ranked against the model it
//! extends; and two candidates fitted together where none passed alone (`try_pair`). The rule
//! that names them is [`super::vet`]'s and [`super::decide`]'s; the order of the steps is
//! [`super::diagnose`]'s.

use super::decide::{Side, between};
use super::evidence::*;
use super::fit::{self, FitOptions, FitResult, Model, Target};
use super::folds::*;
use super::forms::Try;
use super::scan;
use super::screen::*;
use super::verdict::*;
use super::vet::{Against, vetted};
use crate::model::EffectKind;
use rayon::prelude::*;
use std::cmp::Ordering;

/// The folds a candidate is cross-validated over: each recording's fold, their number, and
/// which recordings are checked on held-out data.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Folds<'a> {
    /// Each recording's fold.
    pub fold: &'a [usize],
    /// Number of folds.
    pub k: usize,
    /// Whether each recording is checked on held-out data.
    pub checked: &'a [bool],
}

/// A round of candidates: what each candidate of one round is screened, fitted, cross-validated
/// and ranked against.
#[derive(Clone, Copy)]
pub(crate) struct Round<'a> {
    /// Every recording.
    pub all: &'a Target<'a>,
    /// The screen of the model the candidates extend.
    pub screen: &'a Screen<'a>,
    /// That model's fit on every recording.
    pub from: &'a FitResult,
    /// Its cross-validation.
    pub from_cv: &'a CrossValidated,
    /// Its effects (empty for the base model).
    pub with: &'a [EffectKind],
    /// The held-out gap a candidate's reduction is taken against.
    pub e0: f64,
    /// The folds.
    pub folds: Folds<'a>,
    /// Fit options.
    pub opts: FitOptions,
}

/// Fits one candidate `t` (or a candidate added to `with`) from the scan of its starts on `from`,
/// cross-validates it and ranks it against the held-out gap `e0`. The screening fit starts
/// from the scan's parameters of the candidate on `from` as fitted to the screen's recordings
/// ([`Screen::start`]): from `from` fitted to every recording, the screen's few iterations
/// would go to moving `from`'s own parameters to the subset's optimum, which the screen's
/// refit of `from` has already found. With `reach` (another form of an effect that is not
/// the leading one: [`form_reach`]), a screen that passes is fitted further only where its gap
/// is at most `reach` times the extended model's on the screen's recordings.
pub(crate) fn try_candidate(r: &Round<'_>, t: &Try) -> Ranked {
    let Round {
        all,
        screen,
        from,
        from_cv,
        with,
        e0,
        folds,
        opts,
    } = *r;
    let (k, form, warm, reach) = (t.effect, t.form, t.warm.as_ref(), t.reach);
    let clock = std::time::Instant::now();
    let mut start = scan::starts(all, from, k, form);
    // Another form of an effect also starts from the default form's optimum, its form changed:
    // a family's parameters mean the same in each form, and a coarse scan can miss a narrow
    // valley the default form's fit has found.
    start.extend(warm.cloned().map(scan::ScanStart::stopped));
    let mut effects = with.to_vec();
    effects.push(k);
    let extra = fit::effect_params(&effects, &start[0].model.effects) - from.effect_params;
    let form = k.form_of(form);
    let name = match form {
        Some(f) if f.value != k.default_form() => format!("{k}[{}]", f.name),
        _ => k.name().to_string(),
    };
    // Never worse on the calibration data than the model it extends: at its neutral value the
    // candidate is that model, so a fit that ends worse reports that model's results; and a
    // fit that moves the gap by less than UNCHANGED is that model to within the held-out
    // check's resolution: its results too.
    let as_from = || Ranked {
        effect: k,
        form,
        name: name.clone(),
        form_charge: 0.0,
        score: from_cv.gap * (1.0 + PARAM_PENALTY * extra as f64),
        reduction: (e0 - from_cv.gap) / e0,
        gap_after: from_cv.gap,
        gap_spread: from_cv.spread,
        per_recording: from_cv.per_recording.clone(),
        per_recording_n: from_cv.per_recording_n.clone(),
        evidence: evidence(
            &from_cv.per_recording,
            &from_cv.per_recording_n,
            &from_cv.per_recording,
            &from_cv.per_recording_n,
            extra as f64,
        ),
        at_bound: vec![],
        per_feature: from_cv.per_feature.iter().map(|p| p.0).collect(),
        concentrated: concentrated(from_cv),
        fit: from.clone(),
        wall_time: clock.elapsed().as_secs_f64(),
        fingerprints: vec![],
        rejected: None,
        short_of_leader: None,
        screened: None,
    };
    // The fresh Jacobian at the optimum (p more evaluations) only for a fit that passes the
    // bar: it gives the uncertainties and the folds' refits, which a candidate ranked with the
    // model it extends does not use.
    let opts = FitOptions {
        final_jacobian: false,
        ..opts
    };
    // Screened first against the extended model (refitted to the subset where the subset is
    // not every recording); only a candidate that removes SCREEN_BAR of that gap is fitted
    // further, on every recording, from the screen's optimum. From each of the scan's starts
    // (scan::starts), and from the neutral start where the scanned one misses
    // (Screen::starts). Another form of an effect whose default form passed its screen is
    // screened in full (no stop where its linearised residuals miss the bar at the start): the
    // family is known to reach, and a form's scan start can lie far from its valley (a
    // fourth-order sensor's resonance at twice the data's). That of a trailing effect stops
    // where it cannot come near the leader (`reach`, `reach_stops_screen`): then it can
    // neither be named nor tie; the leader's own forms are judged so where their screens end.
    let from_gap = screen.gap;
    let Screened {
        passed,
        lowest,
        lowest_model,
        checks,
    } = screen.screen(
        all,
        &from.model,
        &start,
        &effects,
        Reach::of(reach.filter(|_| t.reach_stops_screen), warm.is_some()),
        opts,
    );
    let sub = screen.recordings(all);
    let Some(s) = passed else {
        // A trailing effect's form stopped short of the leader's reach says so; and where its
        // screen got to, for a plan's rivals (Ranked::screened).
        return Ranked {
            short_of_leader: reach
                .filter(|_| lowest.is_finite())
                .map(|r| (lowest, r * from_gap)),
            screened: lowest_model.map(|m| (lowest, from_gap, m)),
            ..as_from()
        };
    };
    // Another form whose screen ends short of the leading candidate's reach is not fitted
    // further: it could neither be named nor tie (forms::FORM_REACH).
    if let Some(r) = reach
        && s.gap > r * from_gap
    {
        return Ranked {
            short_of_leader: Some((s.gap, r * from_gap)),
            ..as_from()
        };
    }
    // A resonance's narrow valley next to the screen's optimum (scan::line_search).
    let (line, n) = scan::line_search(sub, &s, k);
    let rank_opts = FitOptions {
        rel_tol: opts.rel_tol.max(RANK_REL_TOL),
        ..opts
    };
    let mut f = match (&screen.subset, line) {
        // Screened on every recording: the screen's iterations go on from its optimum, on its
        // Jacobian where that is fresh, instead of evaluating that point and differencing there
        // again.
        (None, None) => fit::refine(all, &s, rank_opts),
        (_, line) => fit::fit(all, line.as_ref().unwrap_or(&s.model), &effects, rank_opts),
    };
    if screen.subset.is_none() {
        // The same recordings: the screen's (with its starts' checks) and the line's
        // evaluations are the fit's.
        f.evaluations += checks + s.evaluations + n;
    }
    if !matches!(
        f.gap.partial_cmp(&((1.0 - UNCHANGED) * from.gap)),
        Some(Ordering::Less | Ordering::Equal)
    ) {
        return as_from();
    }
    let f = fit::with_fresh_jacobian(all, f);
    let mut r = ranked_fit(all, f, &start[0].model, from_cv, extra, e0, folds);
    (r.effect, r.form, r.name) = (k, form, name);
    r.wall_time = clock.elapsed().as_secs_f64();
    r
}

/// A model fitted on every recording (its Jacobian fresh), cross-validated from `start` and
/// ranked against `against`, the held-out gaps of the model it extends by `extra` parameters
/// (`e0`: the base model's held-out gap, for its reduction). Its effect, form and name are the
/// fit's last effect's default ones, for the caller to set.
fn ranked_fit(
    all: &Target,
    f: FitResult,
    start: &Model,
    against: &CrossValidated,
    extra: usize,
    e0: f64,
    folds: Folds<'_>,
) -> Ranked {
    let cv = cross_validate(all, &f, start, folds.fold, folds.k, folds.checked);
    let k = *f
        .effects
        .last()
        .expect("a candidate's fit holds its effect");
    Ranked {
        effect: k,
        form: None,
        name: k.name().to_string(),
        form_charge: 0.0,
        score: cv.gap * (1.0 + PARAM_PENALTY * extra as f64),
        reduction: (e0 - cv.gap) / e0,
        gap_after: cv.gap,
        gap_spread: cv.spread,
        evidence: evidence(
            &cv.per_recording,
            &cv.per_recording_n,
            &against.per_recording,
            &against.per_recording_n,
            extra as f64,
        ),
        at_bound: fit::at_bounds(&all.bounds, &f),
        per_feature: cv.per_feature.iter().map(|p| p.0).collect(),
        concentrated: concentrated(&cv),
        per_recording: cv.per_recording,
        per_recording_n: cv.per_recording_n,
        fit: f,
        wall_time: 0.0,
        fingerprints: vec![],
        rejected: None,
        short_of_leader: None,
        screened: None,
    }
}

/// Two effects named together where no candidate passed its screen alone ([`try_pair`]).
pub(crate) struct Pair {
    /// The first of the two, fitted alone on every recording, against the base model.
    pub first: Ranked,
    /// The second, fitted alone, against the base model.
    pub alone: Ranked,
    /// Both together, against the first alone (the second effect's entry).
    pub both: Ranked,
    /// Both together against the base model.
    pub vs_base: Evidence,
    /// Both together against the second alone.
    pub vs_alone: Evidence,
}

/// Why a pair fitted on every recording is not named: `tried` (the two screened together),
/// and the pair's evidence `r` `of` what it is against.
fn not_named(tried: &str, r: &Ranked, of: &str) -> String {
    format!(
        "{tried} pass it and were fitted on every recording; together, {of}: ln odds {:.1} ± {:.1}, held-out gap {:.2} ({:.0} % below the base model's){}; not named",
        r.evidence.ln_odds,
        r.evidence.stderr,
        r.gap_after,
        100.0 * r.reduction,
        r.rejected
            .as_ref()
            .map(|w| format!(", {w}"))
            .unwrap_or_default()
    )
}

/// One member's screened model `m` with the other's effect `k` added, at the other's
/// screened values (of `other`) or at its neutral ones (where the screened values together
/// overshoot). Not `scan::neutral_start`: the other's parameters without a neutral value (a
/// ripple's wavelength, a load path's phase) keep where its screen put them.
fn with_other(m: &Model, other: &Model, k: EffectKind, at_neutral: bool) -> Model {
    let mut m = m.clone();
    if let Some((_, v)) = other.effects.list.iter().find(|(e, _)| *e == k) {
        let v: Vec<f64> = v
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                at_neutral
                    .then(|| super::model::neutral(k, crate::model::effects::Param(i)))
                    .flatten()
                    .unwrap_or(x)
            })
            .collect();
        *m.effects.enable(k) = v;
    }
    m
}

/// Two screened candidates `(model, effect)` screened together on the screen's recordings
/// `sub`, from four starts (each member's model with the other's effect, at its screened or
/// its neutral values), stopping at the bar `bar`: the best of the four.
fn joint_screen(
    sub: &Target<'_>,
    bar: f64,
    (ma, ka): (&Model, EffectKind),
    (mb, kb): (&Model, EffectKind),
) -> FitResult {
    let both_effects = [ka, kb];
    let screen_opts = screen_fit(bar);
    [
        with_other(ma, mb, kb, false),
        with_other(mb, ma, ka, false),
        with_other(ma, mb, kb, true),
        with_other(mb, ma, ka, true),
    ]
    .par_iter()
    .map(|m| fit::fit(sub, m, &both_effects, screen_opts))
    .min_by(|x, y| x.gap.total_cmp(&y.gap))
    .expect("four starts")
}

/// Two effects whose screens each fell short of [`SCREEN_BAR`] can still explain the gap
/// together: where each alone accounts for part of a misfit that needs both (a rig's actuator
/// and its screw error, each moving the harmonics the other leaves), forward selection stops
/// before its first step. Where no candidate passed its screen (the verdict would be
/// `unexplained`), the two best screens of different effects that lowered the screen's gap by
/// [`UNCHANGED`] or more are screened together (from each one's screened model with the other's
/// parameters added, at their screened values and at their neutral ones) and, where the pair passes the bar, each is fitted alone and both together
/// on every recording. Both are named only where the pair passes every rule a named effect and
/// a second effect pass: against the base model, clearly more likely, [`MIN_PARTIAL`] of the
/// gap and no fingerprint absent; and against each one alone, clearly more likely, a further
/// [`MIN_SECOND`] of the gap it leaves, and a fingerprint present where one can test it (a
/// pair of weak screens can share out a misfit neither causes, so each must show its own
/// physics). One extra screen where no pair passes; three fits and their cross-validations where
/// one does. `None`: no pair to try; `Err`: why the pair tried is not named.
pub(crate) fn try_pair(
    r: &Round<'_>,
    ranking: &[Ranked],
    share: impl Fn(f64) -> f64,
    disagreements: &mut Vec<Disagreement>,
) -> Option<Result<Pair, String>> {
    let Round {
        all,
        screen,
        from: base,
        from_cv: base_cv,
        folds: cv_args,
        opts: fo,
        ..
    } = *r;
    // Only where nothing was fitted in full: a candidate that passed its screen has had its
    // own chance, and a second effect beside it is forward selection's.
    if ranking.iter().any(|r| r.fit.effects.contains(&r.effect)) {
        return None;
    }
    let mut screened: Vec<(&Ranked, f64, &Model)> = ranking
        .iter()
        .filter_map(|r| {
            let (g, from, m) = r.screened.as_ref()?;
            (*g <= (1.0 - UNCHANGED) * from).then_some((r, *g, m))
        })
        .collect();
    screened.sort_by(|x, y| x.1.total_cmp(&y.1));
    let (a, ga, ma) = *screened.first()?;
    let (b, gb, mb) = *screened.iter().find(|x| x.0.effect != a.effect)?;
    let sub = screen.recordings(all);
    let bar = screen.bar();
    let both_effects = [a.effect, b.effect];
    let joint = joint_screen(sub, bar, (ma, a.effect), (mb, b.effect));
    let pct = |g: f64| 100.0 * (screen.gap - g) / screen.gap;
    let tried = format!(
        "no candidate passed its screen alone; the two best, {} ({:.2} %) and {} ({:.2} %), screened together",
        a.name,
        pct(ga),
        b.name,
        pct(gb)
    );
    if !matches!(
        joint.gap.partial_cmp(&bar),
        Some(Ordering::Less | Ordering::Equal)
    ) {
        return Some(Err(format!(
            "{tried} lower the screen's gap by {:.2} %, short of the {:.0} % bar: not fitted further",
            pct(joint.gap),
            100.0 * SCREEN_BAR
        )));
    }
    let rank_opts = FitOptions {
        rel_tol: fo.rel_tol.max(RANK_REL_TOL),
        final_jacobian: false,
        ..fo
    };
    let jobs: [(&Model, &[EffectKind]); 3] = [
        (ma, &both_effects[..1]),
        (mb, &both_effects[1..]),
        (&joint.model, &both_effects),
    ];
    let mut fits: Vec<FitResult> = jobs
        .par_iter()
        .map(|(m, fx)| fit::with_fresh_jacobian(all, fit::fit(all, m, fx, rank_opts)))
        .collect();
    let (fab, fb, fa) = (fits.remove(2), fits.remove(1), fits.remove(0));
    let e0 = base_cv.gap;
    let ranked = |f: FitResult, start: &Model, of: &Ranked| {
        let extra = f.effect_params.saturating_sub(base.effect_params);
        let mut r = ranked_fit(all, f, start, base_cv, extra, e0, cv_args);
        (r.effect, r.form, r.name) = (of.effect, of.form, of.name.clone());
        r
    };
    let first = ranked(fa, ma, a);
    let alone = ranked(fb, mb, b);
    let mut both = ranked(fab, &joint.model, b);
    both.name = format!("{} + {}", a.name, b.name);
    // The pair against one of its members: the evidence and the share of the gap it leaves.
    let against = |one: &Ranked, name: &str| {
        let mut r = both.clone();
        r.name = name.to_string();
        r.evidence = between(&both, one);
        r
    };
    let mut vs_base = [both.clone()];
    let base_side = Side {
        name: "base",
        per_recording: &base_cv.per_recording,
        n: &base_cv.per_recording_n,
    };
    let said = |r: &Ranked, of: &str| not_named(&tried, r, of);
    let mut found = vec![];
    let vs = Against {
        from: base,
        side: base_side,
        share: &share,
        min_share: MIN_PARTIAL,
        need_present: false,
    };
    if vetted(&mut vs_base, all, vs, &mut found).is_none() {
        return Some(Err(said(&vs_base[0], "against the base model")));
    }
    // The pair against the first alone (the second effect's entry, with its fingerprints
    // there), then against the second alone.
    let mut vs_each = Vec::with_capacity(2);
    for (one, other) in [(&first, &b.name), (&alone, &a.name)] {
        let mut vs = [against(one, other)];
        let left = one.gap_after;
        let mut f2 = vec![];
        let second = Against {
            from: &one.fit,
            side: Side::of(one),
            share: |e| (left - e) / left,
            min_share: MIN_SECOND,
            need_present: true,
        };
        if vetted(&mut vs, all, second, &mut f2).is_none() {
            return Some(Err(said(&vs[0], &format!("against {} alone", one.name))));
        }
        found.extend(f2);
        let [vs] = vs;
        vs_each.push(vs);
    }
    let vs_alone = vs_each.pop().expect("checked against the second").evidence;
    let both = vs_each.pop().expect("checked against the first");
    disagreements.extend(found);
    Some(Ok(Pair {
        first,
        alone,
        both,
        vs_base: vs_base[0].evidence,
        vs_alone,
    }))
}
