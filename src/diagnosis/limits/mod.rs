//! What a campaign could not have seen: for every effect kind, the weakest strength at which the
//! campaign, with its own conditions and noise, would have shown it.
//!
//! **The question.** A `no_significant_gap` says the base model matches the recordings within
//! their noise. It does not say that no effect acts: a load cell far above the forcing
//! frequencies, a faint ageing, a small screw error leave traces below the noise of a campaign
//! not designed to see them. The *detection limit* of an effect is the weakest strength at
//! which the same test that decided the verdict would have fired with probability
//! [`POWER`] (95 %): an effect at least that strong would have shown; a weaker one cannot be
//! excluded.
//!
//! **The test repeated.** Against the model in hand `M` (the calibrated base model for a
//! `no_significant_gap`; the named model where an effect is named in full, the test then being
//! the one that decides whether a second effect is tried):
//! 1. the effect is added to `M` at strength `s` and every recording of the campaign is
//!    simulated under its own conditions: the effect's signature is the change of each
//!    measured feature, `Δ = p(M + effect) − p(M)`, in the row's standard errors under the
//!    effect (`Pipeline::signature`). Both traces are also recorded through the campaign's
//!    own pipeline with the same noise (each channel's noise estimated from the recording): a
//!    harmonic the effect attenuates below three of its errors has no measured phase under it
//!    (the row drops out), and its errors scale as that record's do. Rows of failed runs
//!    count 0. A harmonic's phase is the exception: its error is the noise over the amplitude
//!    *measured*, and the campaign's own amplitude is one draw of that (on the first rig's
//!    effect-free campaign a high one, 1.6 against the 1.0 mN predicted, made a fourth-order
//!    sensor's phase shift look twice as sharp as the injected campaign then measured it). So
//!    a phase's error under the effect is the campaign's quadrature noise over the amplitude
//!    the effect predicts, and each draw of step 3 draws the amplitude measured too
//!    (`PhaseRow`): its signature scales with it, and below three errors the phase drops out;
//! 2. each fold's recalibration of `M` to data carrying the effect is the fold's own refit step
//!    ([`fit::refit_delta`], the one-step damped Gauss–Newton refit the cross-validation makes,
//!    on `M`'s Jacobian): it is linear in the residuals, so the held-out residuals under the
//!    effect are `r = e − L δ_s`, with `L δ_s` the part of the signature the refit cannot absorb
//!    and `e` the held-out residuals without the effect. As the cross-validation's refit
//!    ([`fit::refit_rows`]), the step stops at the plausible range of each parameter: on the
//!    first rig's factorial campaign a fourth-order sensor's phase shift was otherwise absorbed
//!    by a damping `h_d` driven below 0, and its limit read at half the frequency a whole
//!    diagnosis detected;
//! 3. `e` is the campaign's own held-out residual vector of each recording with its sign drawn
//!    at random ([`DRAWS`] draws, a fixed seed, the same draws at every strength): each
//!    recording keeps its own noise, floors and misfit, feature by feature, and only its
//!    alignment with the signature is random. All but the part that the recordings at one
//!    vibration frequency share (`shared_misfit`: each group's mean, feature by feature,
//!    shrunk by its significance), which keeps its sign on every draw: a base model that
//!    misses a phase in one direction on every recording at 1500 Hz misses it so under any
//!    noise, and an effect that shifts the phase the same way adds to that miss, one that
//!    shifts it the other way cancels it. (On the first rig's factorial campaign the base
//!    model misses the force's phase at 1500 Hz by +0.89 standard errors on average, over 20
//!    recordings of five noise draws; drawing that sign at random left a fourth-order sensor
//!    an octave weaker than the limit seen on 7 of 10 injected campaigns; with it kept, on 1
//!    of 10.) The draws at
//!    `s = 0` reproduce the campaign's own gap on average, a little less where a group's mean
//!    is shrunk;
//! 4. on each draw the verdict's test is run on `r` ([`Test`]), and the power at `s` is the
//!    share of draws on which it fires.
//!
//! **Searched by statistics, judged in full.** A limit is a number found by a search and judged
//! by the test. The strength runs from the effect's neutral end (`u = 0`) to the strong end of
//! its plausible range (`u = 1`, [`super::model::Plausible`]) on a log scale (linear for the
//! presliding spread). The search (`Scanner::search`):
//! 1. *probe*: the signature at the first rung of a ladder of [`LADDER`] (an octave apart for
//!    a resonance: [`RESONANCE_STEP`]) is simulated in full;
//! 2. *predict*: the signature grows as a power `k` of the effect's strength `x` (the
//!    parameter's distance from where the effect vanishes; for a resonance the distance of
//!    `1/f`): a filter's phase lag goes as `f/f_c` (`k = 1`), a resonance's gain as its square
//!    (`k = 2`), a saturating effect slower. `k` is fitted from the noncentralities of the last
//!    run and the run nearest it (1 until there are two; parametric power estimation, Ueckert,
//!    Karlsson and Hooker 2016). The signature of the last run, scaled, goes through the very
//!    draws of the test (steps 2 to 4, the folds' refit taken once and scaled) to the smallest
//!    scale at which the test fires on [`POWER`] of them: the predicted limit, and its
//!    *noncentrality*, the sum of squares over the held-out rows of the signature the refit
//!    leaves (Gallant 1975). No simulation is run for it;
//! 3. *confirm*: the effect at the predicted strength is simulated in full on every recording
//!    and run through the test. A run that fires bounds the limit from above, one that does
//!    not from below; the next strength is the last run's prediction (a quiet run's a step
//!    further, `Scanner::next_u`) kept inside that bracket, else the bracket's middle. The
//!    search ends when the bracket is one step wide (the ladder's step halved [`BISECTIONS`]
//!    times, the resolution the scan had before it was searched) or when a run that fires
//!    predicts its own strength within a step, and after [`MAX_RUNS`] runs at most (a
//!    resonance's ladder besides): the limit is then the weakest strength confirmed.
//!
//! The limit stated is always a strength at which the full test fired. The power need not grow
//! with the strength: a load cell slower than the forcing shifts the ripple's phase, which
//! shows; slower still it attenuates the ripple into the noise and shows nothing. So the strong
//! end is run too (`Scanner::band`); where it does not fire, every rung of the ladder stronger
//! than the limit is, the rungs that do not fire are *holes*, and the edge of the detected band
//! before the first is bisected. A resonance whose prediction and strong end both stay quiet has
//! its ladder run rung by rung (its band may lie between). A strength at which more than
//! [`MAX_FAILED`] of the runs fail caps the search there. Each effect is scanned in each of its
//! forms, its other parameters fixed at stated values (`form`).
//!
//! **Approximation.** The refit of step 2 is the cross-validation's own, to first order in the
//! signature: where an effect's signature is large enough for the base parameters to move far
//! (a strength well above its limit) the linear refit overstates what they can absorb, which
//! makes the limit conservative there. Near the limit the signature is a few standard errors
//! and the linearisation holds; `tests/limits.rs` checks the limits by injecting effects at
//! twice and half their stated limit and running the whole diagnosis.

use super::evidence::SIGNIFICANT_GAP;
use super::features::Feature;
use super::features::{FEATURES, FeatureSet, N_FEATURES, noise_sd};
use super::fit::{
    self, FitResult, Model, Target, difference, fill_r, sigma, trace_features, zscore,
};
use super::folds::{CrossValidated, concentrated, summarise};
use super::model::{Coord, coords, neutral};
use super::scans::{SCANS, Scan};
use super::target::{Fidelity, simulate_many};
use rand::{RngExt, SeedableRng, rngs::StdRng};
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use std::cmp::Ordering;

mod search;
use search::scan_limit;
pub use search::{Confirmation, Search};

/// The power at which an effect counts as detectable.
pub const POWER: f64 = 0.95;
/// Random-sign draws of the held-out residuals per strength.
pub const DRAWS: usize = 200;
/// Rungs of the ladder of strengths, evenly spaced (in the logarithm where the scan is
/// logarithmic) from the weak end to the strong end; at least, for a resonance, those of
/// [`RESONANCE_STEP`].
pub const LADDER: usize = 4;
/// Largest ratio of two neighbouring rungs of a resonance's ladder (a sensor's or an
/// actuator's frequency). A resonance shows in a band: above it the phase it shifts is within
/// the noise, below it the ripple it attenuates is. On a 16-recording effect-free campaign
/// a fourth-order filter's band (found and named at 1.5 and 2.5 kHz) lay between two rungs of
/// four over 2e4 to 28 Hz (3.9 kHz and 743 Hz), and the limit read 77 Hz. An octave keeps such
/// a band on a rung.
pub const RESONANCE_STEP: f64 = 2.0;
/// Halvings of a rung that set a scan's resolution (its step, a sixteenth of a rung), and of
/// the bracket before the first hole in which the detected band's end is bisected.
pub const BISECTIONS: usize = 4;
/// Largest share of rows whose runs may fail at a strength for its power to count: beyond it,
/// the effect at that strength is outside what the model can simulate, and the scan ends.
pub const MAX_FAILED: f64 = 0.05;
/// Strengths a limit's search runs in full at most (the probe included), a resonance's ladder
/// besides (`Scanner::search`); the detected band's strong side after it is not counted.
pub const MAX_RUNS: usize = 8;
/// Halvings of the logarithm of the scale of a signature in a prediction
/// (`Scanner::predict`): a bracket of at most 21 in the logarithm to 0.08, finer than the
/// scan's step (a sixteenth of a rung, 0.14 in the logarithm over four decades and four rungs);
/// each halving runs the test's draws once.
const PREDICTION_BISECTIONS: usize = 8;
/// Seed of the draws (fixed: a diagnosis is deterministic).
const SEED: u64 = 0x5eed_0f11;

/// The test whose power is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Test {
    /// The base model's gap is significant: held-out gap at least [`SIGNIFICANT_GAP`], or a
    /// concentrated or systematic feature (the test that decides `no_significant_gap`).
    Gap,
    /// The named model leaves a held-out gap of at least [`SIGNIFICANT_GAP`] (the test that
    /// decides whether a second effect is tried).
    Second,
}

impl Test {
    /// Name in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Test::Gap => "significant_gap",
            Test::Second => "gap_left_by_named_effect",
        }
    }

    fn fires(self, cv: &CrossValidated) -> bool {
        let g = cv.gap >= SIGNIFICANT_GAP;
        match self {
            Test::Gap => g || concentrated(cv).is_some(),
            Test::Second => g,
        }
    }
}

/// The detection limit of one effect in one form.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Limit {
    /// The effect.
    pub effect: &'static str,
    /// The parameter that sets its strength.
    pub param: &'static str,
    /// Its unit.
    pub unit: &'static str,
    /// The effect in words, with its form.
    pub label: &'static str,
    /// Its other parameters, fixed: `name = value`, comma separated (empty where none), the
    /// form parameter among them where the form is not the family's default.
    pub form: String,
    /// The form of the effect's family scanned (`slip_law`, `order4`, ...; empty for an
    /// effect of one form).
    pub form_name: &'static str,
    /// `below` where the effect is stronger at lower values of the parameter (a resonance),
    /// else `above`.
    pub stronger: &'static str,
    /// The weakest value detected with [`POWER`] (None: not detected anywhere in the scanned
    /// range).
    pub limit: Option<f64>,
    /// Values stronger than `limit` at which the full test did not fire (the strong end, the
    /// ladder's rungs and the search's runs above the limit): where the effect hides its own
    /// trace. Empty where the strong end fired.
    pub holes: Vec<f64>,
    /// Where such holes exist: the strongest value of the band from `limit` on in which the
    /// test fires (the edge before the first hole, bisected as `limit` is).
    pub band_end: Option<f64>,
    /// The power there (at the strong end where `limit` is None).
    pub power: f64,
    /// The scan's weak end.
    pub weak_end: f64,
    /// The scan's strong end (the plausible range's).
    pub strong_end: f64,
    /// One sentence.
    pub statement: String,
    /// How it was searched: the prediction and the strengths run in full to confirm it.
    pub search: Search,
}

impl Limit {
    /// The parameter's value for the effect `factor` times as strong as at its limit: a
    /// resonance's frequency divided by it, the Stribeck exponent's departure from 2 (in its
    /// logarithm) multiplied by it, any other strength multiplied by it. None without a limit.
    pub fn scaled(&self, factor: f64) -> Option<f64> {
        let l = self.limit?;
        Some(match (self.effect, self.stronger) {
            ("stribeck_shape", _) => 2.0 * (l / 2.0).powf(factor),
            (_, "below") => l / factor,
            _ => l * factor,
        })
    }

    /// A value at which the limit asserts detection, to check it by: the effect twice as
    /// strong as at its limit ([`Limit::scaled`]), or, where the detected band ends before
    /// that (`band_end`), the band's geometric middle. None without a limit.
    pub fn asserted(&self) -> Option<f64> {
        let twice = self.scaled(2.0)?;
        let Some(end) = self.band_end else {
            return Some(twice);
        };
        let l = self.limit?;
        let beyond = if self.stronger == "below" {
            twice < end
        } else {
            twice > end
        };
        Some(if beyond { (l * end).sqrt() } else { twice })
    }

    /// The effect's other parameters of the form scanned, as `(name, value)`.
    pub fn form_values(&self) -> Vec<(String, f64)> {
        self.form
            .split(", ")
            .filter_map(|kv| {
                let (k, v) = kv.split_once(" = ")?;
                Some((k.to_string(), v.parse().ok()?))
            })
            .collect()
    }
}

/// What a campaign could not have seen (module docs).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Limits {
    /// The model the effects are added to: `base`, or the named effects.
    pub against: String,
    /// The test repeated ([`Test::name`]).
    pub test: &'static str,
    /// [`POWER`].
    pub power: f64,
    /// [`DRAWS`].
    pub draws: usize,
    /// One per effect scan.
    pub effects: Vec<Limit>,
    /// Simulations the scans ran.
    pub simulations: usize,
    /// Why no limit was computed, where none was.
    pub not_computed: Option<String>,
}

impl Limits {
    /// No limits, for the reason given.
    pub fn none(reason: impl Into<String>) -> Limits {
        Limits {
            against: String::new(),
            test: "",
            power: POWER,
            draws: DRAWS,
            effects: vec![],
            simulations: 0,
            not_computed: Some(reason.into()),
        }
    }
}

/// How one row of the signature is found (`Pipeline::signature`).
#[derive(Clone, Copy)]
enum Row {
    /// The measurement shifted by the prediction's change.
    Shifted,
    /// A harmonic the effect attenuates into the noise: not measured under it.
    Unmeasured,
    /// The noise-free change alone (the pipeline does not record it without the effect).
    Fallback,
    /// A run failed: the row says nothing.
    Failed,
}

/// The campaign as the limits measure it: each recording's noise, and the model in hand's
/// traces recorded through the campaign's own pipeline with that noise, so that an effect's
/// signature is what the campaign's measurement of it would show (a harmonic's phase that the
/// effect's attenuation drowns in the noise is not measured; its error grows as its amplitude
/// falls; cycles are found on a noisy force), not what a noise-free simulation shows.
struct Pipeline<'t, 'a> {
    all: &'t Target<'a>,
    /// Per recording: the noise standard deviations of the force, body and drive channels
    /// ([`noise_sd`]; 0 where a channel is absent).
    noise: Vec<[f64; 3]>,
    /// Per unit: the noisy recording of the model in hand through the pipeline (None: its run
    /// failed).
    f0: Vec<Option<FeatureSet>>,
    /// Per unit: the model in hand's predictions, as the diagnosis makes them.
    p0: Vec<FeatureSet>,
    /// Per recording, per unit of it: the model in hand's noisy and noise-free records, for
    /// the recordings an effect leaves alone (`record`'s `alone`).
    per0: Vec<Vec<(Option<FeatureSet>, FeatureSet)>>,
}

impl<'t, 'a> Pipeline<'t, 'a> {
    fn new(all: &'t Target<'a>, model: &Model) -> Self {
        let noise = all
            .recs
            .iter()
            .map(|r| {
                let sd = |x: Option<&[f64]>| x.map_or(0.0, noise_sd).max(0.0);
                [sd(Some(&r.f_d)), sd(r.x_s.as_deref()), sd(r.x_d.as_deref())]
            })
            .map(|v| v.map(|x| if x.is_finite() { x } else { 0.0 }))
            .collect();
        let mut p = Pipeline {
            all,
            noise,
            f0: vec![],
            p0: all.predict(model),
            per0: vec![],
        };
        p.per0 = p.record_each(model, &vec![false; all.recs.len()]);
        p.f0 = p.finish(p.per0.clone()).0;
        p
    }

    /// The noisy recordings of `model` through the pipeline, per unit (None where a run
    /// failed), with the noise-free features beside them. Recordings marked `alone` are
    /// those the model's added effect cannot change (an unvibrated one, for an effect that
    /// acts through the vibration): the model in hand's records stand for them, unsimulated.
    fn record(&self, model: &Model, alone: &[bool]) -> (Vec<Option<FeatureSet>>, Vec<FeatureSet>) {
        self.finish(self.record_each(model, alone))
    }

    /// [`Pipeline::record`] per recording, before the units are joined.
    fn record_each(
        &self,
        model: &Model,
        alone: &[bool],
    ) -> Vec<Vec<(Option<FeatureSet>, FeatureSet)>> {
        let recs = &self.all.recs;
        let run: Vec<usize> = (0..recs.len()).filter(|&i| !alone[i]).collect();
        let asks: Vec<(&Model, &crate::campaign::Recording)> =
            run.iter().map(|&i| (model, recs[i])).collect();
        // Counted and timed in the target's work, as a run through its cache is.
        let sims = simulate_many(&asks, Fidelity::Full);
        for (_, ns) in &sims {
            self.all.count_run(*ns);
        }
        let mut traces: Vec<Option<Option<crate::campaign::SimTrace>>> =
            (0..recs.len()).map(|_| None).collect();
        for (&i, (tr, _)) in run.iter().zip(sims) {
            traces[i] = Some(tr);
        }
        recs.par_iter()
            .zip(traces)
            .enumerate()
            .map(|(i, (rec, tr))| match tr {
                Some(tr) => {
                    let stages = self.all.units.iter().filter(|u| u.0 == i).count();
                    self.record_one(tr, i, rec, stages)
                }
                None => self.per0[i].clone(),
            })
            .collect()
    }

    /// One recording's noisy and noise-free features from its simulation `tr` (per unit).
    fn record_one(
        &self,
        tr: Option<crate::campaign::SimTrace>,
        i: usize,
        rec: &crate::campaign::Recording,
        stages: usize,
    ) -> Vec<(Option<FeatureSet>, FeatureSet)> {
        let Some(tr) = tr else {
            return vec![(None, FeatureSet::nan()); stages];
        };
        // The same noise at every strength and under the model in hand: common random
        // numbers, so the difference is the effect's.
        let mut rng = StdRng::seed_from_u64(SEED ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let [sf, ss, sd] = self.noise[i];
        let mut noisy = |x: &[f64], s: f64| -> Vec<f64> {
            let g =
                Normal::new(0.0, s.max(0.0)).unwrap_or(Normal::new(0.0, 0.0).expect("zero spread"));
            x.iter()
                .map(|v| v + if s > 0.0 { g.sample(&mut rng) } else { 0.0 })
                .collect()
        };
        let f_d = noisy(&tr.f_d, sf);
        let x_s = rec.x_s.as_ref().map(|_| noisy(&tr.x_s, ss));
        let x_d = rec.x_d.as_ref().map(|_| noisy(&tr.x_d, sd));
        let with = trace_features(rec, &f_d, x_s.as_deref(), x_d.as_deref());
        let clean = trace_features(
            rec,
            &tr.f_d,
            rec.x_s.as_ref().map(|_| &tr.x_s[..]),
            rec.x_d.as_ref().map(|_| &tr.x_d[..]),
        );
        with.into_iter().map(Some).zip(clean).collect()
    }

    /// The per-recording records joined into units, with `r` filled.
    fn finish(
        &self,
        per: Vec<Vec<(Option<FeatureSet>, FeatureSet)>>,
    ) -> (Vec<Option<FeatureSet>>, Vec<FeatureSet>) {
        let (mut noisy, mut clean): (Vec<Option<FeatureSet>>, Vec<FeatureSet>) =
            per.into_iter().flatten().unzip();
        // `r` of each vibrated unit from its reference, in both.
        let mut filled: Vec<FeatureSet> = noisy
            .iter()
            .map(|f| f.clone().unwrap_or_else(FeatureSet::nan))
            .collect();
        fill_r(&mut filled, &self.all.reference);
        for (n, f) in noisy.iter_mut().zip(filled) {
            if n.is_some() {
                *n = Some(f);
            }
        }
        fill_r(&mut clean, &self.all.reference);
        (noisy, clean)
    }

    /// The signature of `model` (the model in hand with the effect) on every row, in the
    /// campaign's standard errors under the effect: `d = z' − k z`, `z'` the row's residual of
    /// the model in hand against the measurement shifted by the effect (as the pipeline records
    /// it) and `k = σ/σ'` the ratio of the row's scale without and with the effect; with `k`
    /// per row (NaN: the effect makes the row unmeasured, as a phase whose amplitude it
    /// drowns) and the share of rows whose runs failed (their `d` is 0, `k` 1). None where the
    /// rows do not match.
    fn signature(&self, model: &Model, alone: &[bool]) -> Option<Signature> {
        let (fs, clean) = self.record(model, alone);
        let all = self.all;
        let mut d = vec![];
        let mut k = vec![];
        let mut phases = vec![];
        let mut failed = 0usize;
        for (u, m) in all.measured.iter().enumerate() {
            // The measurement shifted by the effect, feature by feature.
            let mut shifted = m.clone();
            let mut state = [Row::Shifted; N_FEATURES];
            for f in FEATURES {
                let i = f as usize;
                if !m.value[i].is_finite() {
                    continue;
                }
                let (Some(a), Some(b)) = (&self.f0[u], &fs[u]) else {
                    state[i] = Row::Failed;
                    continue;
                };
                // The shift is the prediction's, noise-free (a noisy record would add the
                // jitter of its cycle detection to every row); the noisy records say whether
                // a harmonic is still measured under the effect and how its error changes.
                let (p0, ps) = (self.p0[u].value[i], clean[u].value[i]);
                if !(p0.is_finite() && ps.is_finite()) {
                    state[i] = Row::Fallback;
                    continue;
                }
                if f.is_harmonic() && a.value[i].is_finite() && !b.value[i].is_finite() {
                    state[i] = Row::Unmeasured;
                    continue;
                }
                shifted.value[i] = m.value[i] + difference(f, ps, p0);
                let (e0, es) = (a.stderr[i], b.stderr[i]);
                if let Some(amp) = f.amplitude_of() {
                    // A phase's error is the quadrature noise over the amplitude *measured*:
                    // the campaign's own amplitude is one draw of it (a high one makes every
                    // shift look sharp), so the error under the effect is that noise over the
                    // amplitude the effect predicts, and the draws vary that amplitude.
                    let j = amp as usize;
                    let quad = m.stderr[i] * m.value[j];
                    let a_s = clean[u].value[j];
                    if quad.is_finite() && quad > 0.0 && a_s.is_finite() && a_s > 0.0 {
                        shifted.stderr[i] = (quad / a_s).min(std::f64::consts::PI);
                    }
                } else if f.is_harmonic()
                    && e0.is_finite()
                    && es.is_finite()
                    && e0 > 0.0
                    && m.stderr[i].is_finite()
                {
                    shifted.stderr[i] = m.stderr[i] * es / e0;
                }
            }
            for f in FEATURES {
                let i = f as usize;
                let Some(z) = zscore(m, &self.p0[u], f) else {
                    continue;
                };
                match state[i] {
                    Row::Shifted => {
                        let z1 = zscore(&shifted, &self.p0[u], f).unwrap_or(z);
                        let (s0, s1) = (sigma(m, &self.p0[u], f), sigma(&shifted, &self.p0[u], f));
                        let ratio = if s0 > 0.0 && s1 > 0.0 { s0 / s1 } else { 1.0 };
                        let ok = z.abs() < 1e3 && z1.abs() < 1e3 && z1.is_finite();
                        let di = if ok { z1 - ratio * z } else { 0.0 };
                        if let (true, Some(amp)) = (ok, f.amplitude_of()) {
                            let (j, fl) = (amp as usize, f.floor(shifted.value[i]));
                            let (a_s, a_se) = (clean[u].value[j], m.stderr[j]);
                            if a_s > 0.0 && a_se > 0.0 && a_se.is_finite() {
                                let pe = self.p0[u].stderr[i];
                                let pe = if pe.is_finite() { pe } else { 0.0 };
                                phases.push(PhaseRow {
                                    row: d.len(),
                                    d: di,
                                    error: shifted.stderr[i],
                                    rest: fl.hypot(pe),
                                    snr: a_s / a_se,
                                });
                            }
                        }
                        d.push(di);
                        k.push(if ok { ratio } else { 1.0 });
                    }
                    Row::Unmeasured => {
                        d.push(f64::NAN);
                        k.push(f64::NAN);
                    }
                    Row::Fallback => {
                        // The pipeline cannot record it without the effect either: the
                        // noise-free change of the prediction stands in.
                        let zs = zscore(m, &clean[u], f).unwrap_or(z);
                        let ok = z.abs() < 1e3 && zs.abs() < 1e3;
                        d.push(if ok { z - zs } else { 0.0 });
                        k.push(1.0);
                    }
                    Row::Failed => {
                        failed += 1;
                        d.push(0.0);
                        k.push(1.0);
                    }
                }
            }
        }
        (d.len() == all.row_recordings().len()).then(|| {
            let failed = failed as f64 / d.len().max(1) as f64;
            Signature {
                d,
                scale: k,
                phases,
                failed,
            }
        })
    }
}

/// An effect's signature on every row of the campaign (`Pipeline::signature`).
struct Signature {
    /// The change of each row's residual, in its standard errors under the effect (NaN: the
    /// row is not measured under it).
    d: Vec<f64>,
    /// The ratio of each row's scale without and with the effect (NaN where not measured).
    scale: Vec<f64>,
    /// The rows that are a harmonic's phase, whose error depends on the amplitude measured.
    phases: Vec<PhaseRow>,
    /// The share of rows whose runs failed.
    failed: f64,
}

/// A harmonic's phase row of a [`Signature`]. The phase's shift is measured against a scale
/// `√(error² + rest²)` whose `error` is the quadrature noise over the amplitude measured, so
/// on a draw whose amplitude is `ρ` times the one the effect predicts (`ρ = |1 + (n₁ + i n₂) /
/// snr|`, `n` standard normal: the noise in the two quadratures) the row's signature is
/// `d √(error² + rest²) / √((error / ρ)² + rest²)`; below three of its errors the amplitude
/// leaves the phase unmeasured, as the campaign's pipeline does.
#[derive(Clone, Copy, Debug)]
struct PhaseRow {
    /// Row index.
    row: usize,
    /// The signature at the amplitude the effect predicts.
    d: f64,
    /// The phase's standard error at that amplitude \[rad\].
    error: f64,
    /// The prediction's error and the feature's floor in quadrature \[rad\].
    rest: f64,
    /// The amplitude the effect predicts over the measured amplitude's standard error.
    snr: f64,
}

impl PhaseRow {
    /// The row's signature at amplitude ratio `rho` (NaN where the phase is not measured).
    fn at(&self, rho: f64) -> f64 {
        if rho * self.snr < 3.0 {
            return f64::NAN;
        }
        self.d * self.error.hypot(self.rest) / (self.error / rho).hypot(self.rest)
    }
}

/// A scan's value at `u` in [0, 1] from its weak end to its strong end.
fn value_at(weak: f64, strong: f64, log: bool, u: f64) -> f64 {
    // The ends exactly (a logarithm and back would move them by a rounding).
    if u <= 0.0 {
        weak
    } else if u >= 1.0 {
        strong
    } else if log {
        (weak.ln() + u * (strong.ln() - weak.ln())).exp()
    } else {
        weak + u * (strong - weak)
    }
}

/// The detection limits of every effect not already in `against` (fitted on every recording
/// of `all`, with its Jacobian, and cross-validated as `cv` over `fold`, `k_folds`), by the
/// module's procedure, for `test`: the noise draws and the refit of a signature
/// ([`PowerTest`]), then each effect's scan ([`scan_limit`]), in parallel.
pub(crate) fn limits(
    all: &Target,
    against: &FitResult,
    cv: &CrossValidated,
    fold: &[usize],
    k_folds: usize,
    test: Test,
) -> Limits {
    let rows = all.row_recordings();
    let name = if against.effects.is_empty() {
        "base".to_string()
    } else {
        against
            .effects
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(" + ")
    };
    if against.z.len() != rows.len()
        || against.jacobian.nrows() != rows.len()
        || cv.held.len() != rows.len()
    {
        return Limits::none(format!(
            "the residuals or the Jacobian of {name} do not match the campaign's rows"
        ));
    }
    let before = all.work().simulations;
    let pt = PowerTest::new(all, rows, against, cv, (fold, k_folds), test);
    let pipe = Pipeline::new(all, &against.model);
    let effects: Vec<Limit> = SCANS
        .par_iter()
        .filter(|s| !against.effects.contains(&s.kind))
        .map(|s| scan_limit(s, all, against, &pipe, &pt))
        .collect();
    Limits {
        against: name,
        test: test.name(),
        power: POWER,
        draws: DRAWS,
        effects,
        simulations: all.work().simulations - before,
        not_computed: None,
    }
}

/// The test a limit repeats over noise draws: the campaign's held-out residuals with random
/// signs per recording (the part the conditions share kept), a phase row's noise in its two
/// quadratures, each signature refitted by the fold's base parameters as the cross-validation
/// refits them.
struct PowerTest<'a> {
    against: &'a FitResult,
    cv: &'a CrossValidated,
    fold: &'a [usize],
    k_folds: usize,
    test: Test,
    rows: Vec<usize>,
    feats: Vec<Feature>,
    /// Recordings.
    n: usize,
    /// Per fold with held-out rows: the rows its refit keeps.
    keeps: Vec<(usize, Vec<bool>)>,
    /// The fitted coordinates' bounds, in the order of the Jacobian's columns.
    cs: Vec<Coord>,
    /// The part of each held-out residual the campaign's conditions share (step 3), kept with
    /// its sign on every draw.
    shared: Vec<f64>,
    /// The random signs, one per recording per draw, the same at every strength.
    signs: Vec<Vec<f64>>,
    /// The noise of each row's harmonic in its two quadratures, per draw, the same at every
    /// strength (used on the rows that are a phase: `PhaseRow`).
    quadratures: Vec<Vec<(f64, f64)>>,
}

impl<'a> PowerTest<'a> {
    /// The test on the campaign `all` (its rows' recordings `rows`) against `against`.
    fn new(
        all: &Target,
        rows: Vec<usize>,
        against: &'a FitResult,
        cv: &'a CrossValidated,
        (fold, k_folds): (&'a [usize], usize),
        test: Test,
    ) -> Self {
        let feats: Vec<Feature> = all.row_features();
        let n = all.recs.len();
        // The fold's refit of a signature: held-out rows of `d − L d`... as the cross-validation.
        let keeps: Vec<(usize, Vec<bool>)> = (0..k_folds)
            .filter(|&k| (0..rows.len()).any(|r| fold[rows[r]] == k && !cv.held[r].is_nan()))
            .map(|k| (k, rows.iter().map(|&r| fold[r] != k).collect()))
            .collect();
        let cs = coords(&all.bounds, &against.effects, &against.model.effects);
        // The part of each held-out residual the campaign's conditions share (step 3), kept with
        // its sign on every draw.
        let shared = shared_misfit(&feats, &all.row_frequencies(), &cv.held);
        // The random signs, one per recording per draw, the same at every strength.
        let signs: Vec<Vec<f64>> = {
            let mut rng = StdRng::seed_from_u64(SEED);
            (0..DRAWS)
                .map(|_| {
                    (0..n)
                        .map(|_| if rng.random::<bool>() { 1.0 } else { -1.0 })
                        .collect()
                })
                .collect()
        };
        // The noise of each row's harmonic in its two quadratures, per draw, the same at every
        // strength (used on the rows that are a phase: `PhaseRow`).
        let quadratures: Vec<Vec<(f64, f64)>> = {
            let mut rng = StdRng::seed_from_u64(SEED ^ 0x9ad);
            let g = Normal::new(0.0, 1.0).expect("unit normal");
            (0..DRAWS)
                .map(|_| {
                    (0..rows.len())
                        .map(|_| (g.sample(&mut rng), g.sample(&mut rng)))
                        .collect()
                })
                .collect()
        };
        PowerTest {
            against,
            cv,
            fold,
            k_folds,
            test,
            rows,
            feats,
            n,
            keeps,
            cs,
            shared,
            signs,
            quadratures,
        }
    }

    /// A signature `d` on the held-out rows after each fold's refit of the base parameters
    /// (inside their plausible ranges); rows the effect leaves unmeasured stay so.
    fn unabsorbed(&self, d: &[f64]) -> Vec<f64> {
        let (against, cv, fold, rows, cs) =
            (self.against, self.cv, self.fold, &self.rows, &self.cs);
        let keeps = self.keeps.as_slice();
        let mut out = vec![f64::NAN; d.len()];
        // Rows the effect leaves unmeasured take no part in the refit, and stay unmeasured.
        let solve: Vec<f64> = d
            .iter()
            .map(|v| if v.is_nan() { 0.0 } else { *v })
            .collect();
        for (k, keep) in keeps {
            let keep: Vec<bool> = keep.iter().zip(d).map(|(k, v)| *k && !v.is_nan()).collect();
            let Some(delta) = fit::refit_delta(&against.jacobian, &solve, &keep, 0) else {
                continue;
            };
            // Inside the plausible ranges, as the fold's refit: a signature the base parameters
            // could only absorb by leaving their range (a damping below 0) stays unabsorbed.
            let to = fit::step_within(cs, &against.theta, &delta, 1.0);
            let step: Vec<f64> = to.iter().zip(&against.theta).map(|(a, b)| a - b).collect();
            for r in 0..d.len() {
                if fold[rows[r]] == *k && !cv.held[r].is_nan() {
                    let j: f64 = (0..step.len())
                        .map(|c| against.jacobian[(r, c)] * step[c])
                        .sum();
                    out[r] = d[r] + j;
                }
            }
        }
        out
    }

    /// A signature after each fold's refit: once where it has no phase rows, else per draw (a
    /// phase row's signature is the one at the amplitude that draw measures).
    fn unabsorbed_draws(&self, sig: &Signature) -> Unabsorbed {
        if sig.phases.is_empty() {
            return Unabsorbed::Once(self.unabsorbed(&sig.d));
        }
        Unabsorbed::PerDraw(
            self.quadratures
                .par_iter()
                .map(|q| {
                    let mut d = sig.d.clone();
                    for p in &sig.phases {
                        let (n1, n2) = q[p.row];
                        d[p.row] = p.at((1.0 + n1 / p.snr).hypot(n2 / p.snr));
                    }
                    self.unabsorbed(&d)
                })
                .collect(),
        )
    }

    /// The draws on which the test fires with the refitted signature `u` taken `c` times (1: as
    /// simulated), the campaign's own held-out residuals rescaled by the signature's `scale`
    /// (the alternative's noise against the campaign's, row by row; NaN: the row is not
    /// measured under the alternative).
    fn detected(&self, sig: &Signature, u: &Unabsorbed, c: f64) -> usize {
        let (rows, feats, n, cv) = (&self.rows, &self.feats, self.n, self.cv);
        let shared = &self.shared;
        let (fold, k_folds, test) = (self.fold, self.k_folds, self.test);
        self.signs
            .par_iter()
            .enumerate()
            .filter(|(k, s)| {
                let d = u.on(*k);
                let r: Vec<f64> = (0..rows.len())
                    .map(|i| {
                        let e = shared[i] + s[rows[i]] * (cv.held[i] - shared[i]);
                        sig.scale[i] * e + c * d[i]
                    })
                    .collect();
                test.fires(&summarise(rows, feats, n, r, fold, k_folds))
            })
            .count()
    }
}

/// A signature after each fold's refit ([`PowerTest::unabsorbed_draws`]).
enum Unabsorbed {
    /// The same on every draw.
    Once(Vec<f64>),
    /// One per draw.
    PerDraw(Vec<Vec<f64>>),
}

impl Unabsorbed {
    /// On draw `k`.
    fn on(&self, k: usize) -> &[f64] {
        match self {
            Unabsorbed::Once(d) => d,
            Unabsorbed::PerDraw(v) => &v[k],
        }
    }

    /// The noncentrality it stands for: the sum of its squares over the held-out rows (the
    /// mean over the draws where it is drawn).
    fn noncentrality(&self) -> f64 {
        let ss = |d: &[f64]| {
            d.iter()
                .filter(|x| x.is_finite())
                .map(|x| x * x)
                .sum::<f64>()
        };
        match self {
            Unabsorbed::Once(d) => ss(d),
            Unabsorbed::PerDraw(v) => v.iter().map(|d| ss(d)).sum::<f64>() / v.len().max(1) as f64,
        }
    }
}

/// What a scan found, for its statement.
struct Found<'a> {
    weak: f64,
    /// The strong end the runs reached.
    strong: f64,
    limit: Option<f64>,
    band_end: Option<f64>,
    /// Detected down to the weak end.
    everywhere: bool,
    holes: &'a [f64],
    power: f64,
    /// The share of the scan the runs reached.
    reached: f64,
}

/// A limit's sentence, and which side of its parameter is stronger (`below`, `above`).
fn statement(s: &Scan, unit: &str, f: &Found<'_>) -> (&'static str, String) {
    let Found {
        weak,
        strong,
        limit,
        band_end,
        everywhere,
        holes,
        power,
        reached,
    } = *f;
    let p_unit = unit;
    let (stronger, weaker) = if s.stronger_below {
        ("below", "and above")
    } else {
        ("above", "and below")
    };
    // The form's other parameters in the statement (its name is in the label).
    let shown: Vec<String> = s
        .fixed
        .iter()
        .filter(|(q, _)| Some(*q) != s.kind.info().form)
        .map(|&(q, v)| format!("{} = {v}", q.name(s.kind)))
        .collect();
    let with = if shown.is_empty() {
        String::new()
    } else {
        format!(" ({})", shown.join(", "))
    };
    let hidden = || {
        format!(
            "(not detected at {} {}: the effect attenuates its own trace into the noise)",
            holes.iter().map(|h| fmt(*h)).collect::<Vec<_>>().join(", "),
            p_unit
        )
    };
    let statement = match (limit, band_end) {
        (Some(_), Some(e)) if everywhere => format!(
            "{}{with} would have shown from the weakest strength scanned, {} = {}, to {} {}; a weaker one, and one {stronger} {} {}, cannot be excluded",
            s.label,
            s.param_name(),
            fmt(weak),
            fmt(e),
            p_unit,
            fmt(e),
            hidden(),
        ),
        _ if everywhere => format!(
            "{}{with} would have shown at every strength scanned, down to {} = {} {}: only a weaker one cannot be excluded",
            s.label,
            s.param_name(),
            fmt(weak),
            p_unit,
        ),
        (Some(l), Some(e)) => format!(
            "{}{with} with {} from {} to {} {} would have shown; {} {weaker}, and {stronger} {} {}, cannot be excluded",
            s.label,
            s.param_name(),
            fmt(l),
            fmt(e),
            p_unit,
            fmt(l),
            fmt(e),
            hidden(),
        ),
        (Some(l), None) => format!(
            "{}{with} with {} {stronger} {} {} would have shown; {} {weaker} cannot be excluded",
            s.label,
            s.param_name(),
            fmt(l),
            p_unit,
            fmt(l),
        ),
        (None, _) => format!(
            "{}{with} would not have shown anywhere in {} ({} from {} to {} {}, power {:.0} % at the strong end): it cannot be excluded",
            s.label,
            if reached < 1.0 {
                "the range in which its runs succeed"
            } else {
                "its plausible range"
            },
            s.param_name(),
            fmt(weak),
            fmt(strong),
            p_unit,
            100.0 * power
        ),
    };
    (stronger, statement)
}

/// The part of each held-out residual that recordings at the same vibration frequency share,
/// feature by feature (step 3 of the module doc), as the empirical-Bayes mean of its group.
///
/// Rows (`feats`, the stage's frequency `freq`, 0 at rest, and the held-out residual `held`,
/// NaN where not held out) fall into groups of one feature at one frequency. With `ē_g` a
/// group's mean over its `n_g ≥ 2` rows and `s²` the feature's pooled variance within its
/// groups, the group's shared part is `ē_g (1 − 1/t²)₊`, `t = ē_g √n_g / s`: the posterior
/// mean of a normal mean whose prior variance is estimated by the method of moments,
/// `max(0, ē_g² − s²/n_g)`. A mean within its error is shrunk to 0, a clear one kept nearly
/// whole; a row alone at its frequency, or a feature without two rows in any group, shares
/// nothing.
fn shared_misfit(feats: &[Feature], freq: &[f64], held: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; held.len()];
    let mut groups: Vec<((Feature, u64), Vec<usize>)> = vec![];
    for i in 0..held.len() {
        if !held[i].is_finite() {
            continue;
        }
        let key = (feats[i], freq[i].to_bits());
        match groups.iter_mut().find(|g| g.0 == key) {
            Some(g) => g.1.push(i),
            None => groups.push((key, vec![i])),
        }
    }
    let mean = |ix: &[usize]| ix.iter().map(|&i| held[i]).sum::<f64>() / ix.len() as f64;
    for f in FEATURES {
        let mine: Vec<&Vec<usize>> = groups
            .iter()
            .filter(|g| g.0.0 == f && g.1.len() >= 2)
            .map(|g| &g.1)
            .collect();
        let (ss, dof) = mine.iter().fold((0.0, 0usize), |(ss, dof), ix| {
            let m = mean(ix);
            let within: f64 = ix.iter().map(|&i| (held[i] - m).powi(2)).sum();
            (ss + within, dof + ix.len() - 1)
        });
        if dof < 2 || ss.partial_cmp(&0.0) != Some(Ordering::Greater) {
            continue;
        }
        let var = ss / dof as f64;
        for ix in mine {
            let m = mean(ix);
            let t2 = m * m * ix.len() as f64 / var;
            let keep = (1.0 - 1.0 / t2).max(0.0);
            for &i in ix {
                out[i] = keep * m;
            }
        }
    }
    out
}

/// Three significant digits, without an exponent where a reader would not write one.
fn fmt(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && !(1e-2..1e5).contains(&a) {
        format!("{x:.2e}")
    } else {
        let digits = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{x:.digits$}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::EffectKind;

    #[test]
    fn scans_name_real_parameters_in_range() {
        for s in SCANS.iter() {
            let info = s.kind.info();
            assert!(
                info.params.iter().any(|p| p.name == s.param_name()),
                "{}",
                s.label
            );
            let mut fx = crate::model::Effects::none();
            for (q, v) in s.fixed_named() {
                fx.set(s.kind, q, v).unwrap();
            }
            assert!(info.candidate, "{}", s.label);
        }
        // Every candidate of the library has a scan, in every form but the Stribeck curve's
        // rational one (no neutral strength) and the delayed sensor (the fourth-order
        // sensor's scan, at no delay), each scan's form named.
        for k in EffectKind::candidates() {
            assert!(SCANS.iter().any(|s| s.kind == k), "{k}");
            for f in k.info().forms {
                if [
                    (EffectKind::StribeckShape, "rational"),
                    (EffectKind::SensorDynamics, "order4_delay"),
                ]
                .contains(&(k, f.name))
                {
                    continue;
                }
                assert!(
                    SCANS.iter().any(|s| s.kind == k && s.form_name() == f.name),
                    "{k} {}",
                    f.name
                );
            }
        }
        let slip = SCANS.iter().find(|s| s.label.contains("slip law")).unwrap();
        assert_eq!(slip.form_name(), "slip_law");
        assert_eq!(SCANS[0].form_name(), "ageing_law");
    }

    /// The shared part of a group is its mean shrunk by its significance (closed form:
    /// `ē (1 − s²/(n ē²))₊`); a row alone at its frequency, a mean within its error, and rows
    /// not held out share nothing.
    #[test]
    fn recordings_at_one_frequency_share_a_clear_misfit_only() {
        use Feature::{ForceAmp1 as FAmpF, ForcePhase1 as FPhaseF};
        // F_phase_f: four rows at 1500 Hz about +2 (within spread 0.5), one alone at 1000 Hz;
        // F_amp_f: two groups whose means lie within their errors; one row not held out.
        let feats = [
            FPhaseF, FPhaseF, FPhaseF, FPhaseF, FPhaseF, FAmpF, FAmpF, FAmpF, FAmpF, FAmpF,
        ];
        let freq = [
            1500.0, 1500.0, 1500.0, 1500.0, 1000.0, 1500.0, 1500.0, 2000.0, 2000.0, 2000.0,
        ];
        let held = [2.5, 1.5, 2.0, 2.0, 3.0, 1.0, -0.8, 0.9, -1.1, f64::NAN];
        let m = shared_misfit(&feats, &freq, &held);
        // Pooled within variance of F_phase_f: its one group, (0.25 + 0.25) / 3.
        let var: f64 = 0.5 / 3.0;
        let want = 2.0 * (1.0 - var / (4.0 * 4.0));
        for (i, mi) in m.iter().enumerate().take(4) {
            assert!((mi - want).abs() < 1e-12, "{i}: {mi} against {want}");
        }
        assert_eq!(m[4], 0.0, "alone at its frequency");
        // F_amp_f: means 0.1 and -0.1, pooled variance (1.62 + 2.0) / 2 = 1.81: t² < 1.
        assert!(m[5..].iter().all(|&v| v == 0.0), "{m:?}");
        // A clear mean in a noisy feature is still kept in part, never beyond the mean.
        let held = [3.0, 1.0, 2.6, 1.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let m = shared_misfit(&feats, &freq, &held);
        assert!(m[0] > 1.5 && m[0] < 2.0, "{}", m[0]);
    }

    #[test]
    fn values_run_from_the_weak_to_the_strong_end() {
        assert_eq!(value_at(2e4, 50.0, true, 0.0), 2e4);
        assert!((value_at(2e4, 50.0, true, 1.0) - 50.0).abs() < 1e-9);
        assert!((value_at(100.0, 1.0, true, 0.5) - 10.0).abs() < 1e-9);
        assert_eq!(value_at(0.0, 0.9, false, 0.5), 0.45);
        assert_eq!(fmt(612.345), "612");
        assert_eq!(fmt(0.0312), "0.0312");
        assert_eq!(fmt(3.2e-6), "3.20e-6");
    }

    /// A phase's signature scales with the amplitude drawn, as its error falls with it: at the
    /// predicted amplitude it is `d`; at half, with the floor small, about half; twice as large
    /// at most as the floor allows; below three errors of the amplitude, not measured.
    #[test]
    fn a_phase_signature_follows_the_amplitude_measured() {
        let p = PhaseRow {
            row: 0,
            d: 10.0,
            error: 0.24,
            rest: 0.05,
            snr: 10.0,
        };
        assert!((p.at(1.0) - 10.0).abs() < 1e-12);
        // Closed form: 10 √(0.24² + 0.05²) / √(0.48² + 0.05²).
        let half = 10.0 * 0.24f64.hypot(0.05) / 0.48f64.hypot(0.05);
        assert!((p.at(0.5) - half).abs() < 1e-12 && half < 5.2 && half > 5.0);
        assert!(p.at(1e6) <= 10.0 * 0.24f64.hypot(0.05) / 0.05 + 1e-9);
        assert!(
            p.at(0.29).is_nan(),
            "2.9 amplitude errors: the phase is not measured"
        );
        assert!(p.at(0.31).is_finite());
    }

    fn limit(
        limit: f64,
        band_end: Option<f64>,
        effect: &'static str,
        stronger: &'static str,
    ) -> Limit {
        Limit {
            effect,
            param: "",
            unit: "",
            label: "",
            form: String::new(),
            form_name: "",
            stronger,
            limit: Some(limit),
            holes: vec![],
            band_end,
            power: 1.0,
            weak_end: 0.0,
            strong_end: 0.0,
            statement: String::new(),
            search: Search {
                probe: 0.0,
                predicted: None,
                noncentrality: None,
                runs: vec![],
                at_budget: false,
            },
        }
    }

    /// Where a limit asserts detection: twice as strong, unless the band ends first.
    #[test]
    fn a_limit_is_checked_inside_what_it_asserts() {
        // A resonance (stronger below): twice as strong is half the frequency.
        assert_eq!(
            limit(1000.0, None, "sensor_dynamics", "below").asserted(),
            Some(500.0)
        );
        assert_eq!(
            limit(1000.0, Some(400.0), "sensor_dynamics", "below").asserted(),
            Some(500.0)
        );
        let mid = limit(1121.0, Some(743.0), "sensor_dynamics", "below")
            .asserted()
            .unwrap();
        assert!((mid - (1121.0f64 * 743.0).sqrt()).abs() < 1e-9);
        // A strength (stronger above).
        assert_eq!(limit(0.01, None, "aging", "above").asserted(), Some(0.02));
        let mid = limit(0.01, Some(0.015), "aging", "above")
            .asserted()
            .unwrap();
        assert!((mid - 0.015f64.sqrt() * 0.1).abs() < 1e-12);
        // The Stribeck exponent's departure from 2, in its logarithm.
        let s = limit(1.5, None, "stribeck_shape", "below")
            .asserted()
            .unwrap();
        assert!((s - 2.0 * 0.75f64.powi(2)).abs() < 1e-12);
    }
}
