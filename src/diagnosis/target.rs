//! A set of recordings ready for fitting: their measured features, the predictions of a model
//! on them (through the simulation cache every subset shares), the standardised residuals and
//! the work they cost.

use super::features::{
    FEATURES, Feature, FeatureSet, Stage, quantize, quantum, stage_features, stages, weigh_quantum,
};
use super::model::{Bound, Model, Plausible, SLIP_BOUND_MARGIN, STRIBECK_DELTA, default_range};
use crate::campaign::{GridAsk, Recording, SimTrace, Solvers, simulate_grid, simulate_grids};
use crate::model::effects::{
    Param, actuator_response, drive_ripple, frictional_lag, sensor_dynamics, stribeck_shape,
};
use crate::model::{EffectKind, Params};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// How a target's predictions are simulated: the fidelity of a prediction.
///
/// A diagnosis *searches* (scans for a fit's start, line searches along a resonance) and
/// *judges* (fits, held-out gaps, evidence, fingerprints, limits). Every number it judges on is
/// [`Fidelity::Full`]; a step that only chooses where a full fit starts may run on
/// [`Fidelity::Search`], whose predictions cost about two thirds as much. A search that ends
/// elsewhere on them only starts a full fit elsewhere: the fit, and everything after it, is
/// full.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Fidelity {
    /// Every recording at the fits' tolerance ([`crate::campaign::FIT_TOLERANCE`], 1e-5).
    Full,
    /// Vibrated recordings at [`SEARCH_TOLERANCE`] (1e-4); recordings without vibration, which
    /// cost a few milliseconds, at the fits' tolerance (and shared with the full predictions).
    Search,
}

/// Tolerance (`rtol = atol`) of [`Fidelity::Search`] on a vibrated recording. Why 1e-4: on
/// the 30 recordings of the bench's ageing campaign (`benches/diagnose/README.md`) it takes
/// 29 % less time than 1e-5 and moves no feature by more than 4 of its standard errors, but
/// on recordings at the edge of elimination that 1e-5 itself does not converge (25 to 49,
/// as 1e-6 against 1e-5 there); 1e-3 takes 49 % less but moves features of slow stick-slip by
/// 10 to 40 standard errors, and the stick-slip without vibration by 20 to 115.
pub const SEARCH_TOLERANCE: f64 = 1e-4;

impl Fidelity {
    /// Every fidelity, in the order of [`Work::by_fidelity`].
    pub const ALL: [Fidelity; 2] = [Fidelity::Full, Fidelity::Search];

    /// Its name in the JSON and the summary.
    pub fn name(self) -> &'static str {
        match self {
            Fidelity::Full => "full",
            Fidelity::Search => "search",
        }
    }

    /// The fidelity as it acts on `rec`: a recording without vibration is simulated in full
    /// at any fidelity.
    pub fn on(self, rec: &Recording) -> Fidelity {
        if rec.vibrates() { self } else { Fidelity::Full }
    }

    /// The integration tolerance (`rtol = atol`) of `rec`'s simulation.
    pub fn tolerance(self, rec: &Recording) -> f64 {
        match self.on(rec) {
            Fidelity::Full => crate::campaign::FIT_TOLERANCE,
            Fidelity::Search => SEARCH_TOLERANCE,
        }
    }
}

/// A set of recordings with their measured features, ready for fitting. Each recording gives
/// one unit per stage ([`stages`]: one, or two where the vibration is switched on within it),
/// and every unit its own features.
#[derive(Clone)]
pub struct Target<'a> {
    /// The recordings.
    pub recs: Vec<&'a Recording>,
    /// The units: recording index and stage.
    pub units: Vec<(usize, Stage)>,
    /// Measured features of every unit (with `r` where a reference is in the set).
    pub measured: Vec<FeatureSet>,
    /// For each vibrated unit, the unit it is compared with for `r`: the resting stage of the
    /// same recording, else a recording without vibration of the same drive in the set.
    pub reference: Vec<Option<usize>>,
    /// The plausible ranges of the effects' fitted parameters, derived from the whole
    /// campaign's recordings (a subset keeps the campaign's: [`Plausible::of`]).
    pub bounds: Plausible,
    /// Simulated features already computed, shared with every subset ([`Target::sub`]).
    cache: Arc<SimCache>,
    /// The fidelity of this target's predictions ([`Target::at`]); full where not set.
    pub fidelity: Fidelity,
}

/// Features of simulations already run, by recording and by the model as it acts on that
/// recording ([`SimCache::key`]): a fit's Jacobian column of a parameter that cannot act on a
/// recording, a scan's reference recordings, a model evaluated twice, cost a lookup instead of a
/// simulation. A hit returns exactly what the simulation would (it is deterministic), so results
/// do not depend on what the cache holds or on the order threads fill it.
/// A simulation's key in the cache: the recording, the fidelity and the model's parameters'
/// bits.
type SimKey = (usize, Fidelity, Vec<u64>);

#[derive(Default)]
pub(crate) struct SimCache {
    map: Mutex<HashMap<SimKey, Vec<FeatureSet>>>,
    /// The measured features of each recording ([`measured_features`]), by recording.
    measured: Mutex<HashMap<usize, Vec<FeatureSet>>>,
    /// Simulations run (each a recording under a model: a cache miss), by fidelity (in the
    /// order of [`Fidelity::ALL`]).
    pub(crate) simulations: [AtomicUsize; 2],
    /// Predictions served from the map without a simulation.
    pub(crate) hits: AtomicUsize,
    /// Time spent in the simulations and their features \[ns\], summed over the threads that
    /// ran them, by fidelity.
    nanos: [AtomicU64; 2],
}

/// The work behind a diagnosis: how many simulations its fits, scans, folds and fingerprints
/// ran, and what they cost. A recording simulated under one model counts once,
/// however often its features are asked for (the cache; two threads that ask for the same
/// prediction at the same moment may both run it, so two runs' counts can differ by a few).
/// Every other step (features of the recordings, linear algebra, the decision) costs a few
/// percent beside the simulations.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Work {
    /// Simulations run: recordings simulated under a model, each over its whole sample grid.
    pub simulations: usize,
    /// Predictions a fit asked for that an earlier simulation already held (no run).
    pub cache_hits: usize,
    /// Time of the simulations \[s\], each timed on the thread that ran it and summed: their
    /// CPU time on an otherwise idle machine (more where other work takes the cores), and on
    /// `n` cores about `n` times the wall time they take.
    pub simulation_cpu: f64,
    /// The simulations and their time by fidelity, in the order of [`Fidelity::ALL`]: they
    /// add up to [`Work::simulations`] and [`Work::simulation_cpu`].
    pub by_fidelity: [Runs; 2],
}

/// Simulations of one fidelity and their time ([`Work::by_fidelity`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Runs {
    /// Simulations run.
    pub simulations: usize,
    /// Their time \[s\], summed over the threads (as [`Work::simulation_cpu`]).
    pub simulation_cpu: f64,
}

impl Work {
    /// The work done since `earlier` (a snapshot of the same counters).
    pub fn since(self, earlier: Work) -> Work {
        let runs = |a: Runs, b: Runs| Runs {
            simulations: a.simulations.saturating_sub(b.simulations),
            simulation_cpu: (a.simulation_cpu - b.simulation_cpu).max(0.0),
        };
        Work {
            simulations: self.simulations.saturating_sub(earlier.simulations),
            cache_hits: self.cache_hits.saturating_sub(earlier.cache_hits),
            simulation_cpu: (self.simulation_cpu - earlier.simulation_cpu).max(0.0),
            by_fidelity: [0, 1].map(|i| runs(self.by_fidelity[i], earlier.by_fidelity[i])),
        }
    }

    /// `self` and `other` together.
    pub fn add(&mut self, other: Work) {
        self.simulations += other.simulations;
        self.cache_hits += other.cache_hits;
        self.simulation_cpu += other.simulation_cpu;
        for (a, b) in self.by_fidelity.iter_mut().zip(other.by_fidelity) {
            a.simulations += b.simulations;
            a.simulation_cpu += b.simulation_cpu;
        }
    }
}

/// The work of one step of a diagnosis (calibration, candidates, limits, ...): what
/// [`Target::work`] counted while it ran, and its wall time.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StepWork {
    /// The step.
    pub step: &'static str,
    /// Its simulations, cache hits and their CPU time.
    #[serde(flatten)]
    pub work: Work,
    /// Its wall time \[s\].
    pub wall: f64,
}

/// Marks the steps of a diagnosis as they end: each [`StepLog::end`] records the work and wall
/// time since the previous one.
pub struct StepLog {
    last: Work,
    clock: Instant,
    /// The steps ended so far, in order.
    pub steps: Vec<StepWork>,
}

impl StepLog {
    /// A log starting now, from the work `target` has counted so far.
    pub fn new(target: &Target) -> StepLog {
        StepLog {
            last: target.work(),
            clock: Instant::now(),
            steps: vec![],
        }
    }

    /// Ends step `step` (added to the one of that name where one has ended before).
    pub fn end(&mut self, step: &'static str, target: &Target) {
        let now = target.work();
        let work = now.since(self.last);
        let wall = self.clock.elapsed().as_secs_f64();
        self.last = now;
        self.clock = Instant::now();
        match self.steps.iter_mut().find(|s| s.step == step) {
            Some(s) => {
                s.work.add(work);
                s.wall += wall;
            }
            None => self.steps.push(StepWork { step, work, wall }),
        }
    }
}

impl SimCache {
    /// Counts one simulation at `fidelity` that took `nanos`.
    fn count(&self, fidelity: Fidelity, nanos: u64) {
        self.simulations[fidelity as usize].fetch_add(1, Ordering::Relaxed);
        self.nanos[fidelity as usize].fetch_add(nanos, Ordering::Relaxed);
    }

    /// Cache entries at most: beyond, new simulations are not kept (a diagnosis of 30
    /// recordings fills a few thousand).
    const CAPACITY: usize = 200_000;

    /// The model as it acts on `rec`, and its key at `fidelity` (as it acts on `rec`:
    /// [`Fidelity::on`]). Without vibration (`u0 = 0`) the actuator's
    /// gain multiplies a zero amplitude and the load modulation `1 + c u0 sin(..)` is exactly 1,
    /// so their parameters are set to their defaults: the simulation is bit for bit the same.
    pub(crate) fn key(
        model: &Model,
        rec: &Recording,
        fidelity: Fidelity,
    ) -> (Model, (usize, Fidelity, Vec<u64>)) {
        let mut m = model.clone();
        if rec.params.u0 == 0.0 {
            for (k, v) in m.effects.list.iter_mut() {
                if k.vibration_only() {
                    for (x, p) in v.iter_mut().zip(k.info().params) {
                        *x = p.default;
                    }
                }
            }
        }
        let mut bits = vec![
            m.f_s.to_bits(),
            m.f_c.to_bits(),
            m.v_s.to_bits(),
            m.h_d.to_bits(),
        ];
        for (k, v) in &m.effects.list {
            bits.push(*k as u64);
            bits.extend(v.iter().map(|x| x.to_bits()));
        }
        (
            m,
            (rec as *const Recording as usize, fidelity.on(rec), bits),
        )
    }

    /// The measured features of `rec`, computed where not cached.
    fn measured(&self, rec: &Recording) -> Vec<FeatureSet> {
        let key = rec as *const Recording as usize;
        let lock = || self.measured.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(f) = lock().get(&key) {
            return f.clone();
        }
        let f = measured_features(rec);
        lock().insert(key, f.clone());
        f
    }

    /// The features of each recording under its model at `fidelity` (as [`SimCache::features`]
    /// gives one), the simulations not cached run together ([`simulate_grids`]: side by side in
    /// vector lanes where they can, spread over the thread pool), in the order of `asks`.
    pub(crate) fn features_many(
        &self,
        asks: &[(&Model, &Recording)],
        fidelity: Fidelity,
    ) -> Vec<Vec<FeatureSet>> {
        let keyed: Vec<_> = asks
            .iter()
            .map(|(m, r)| Self::key(m, r, fidelity))
            .collect();
        let mut out: Vec<Option<Vec<FeatureSet>>> = vec![None; asks.len()];
        let mut missed = Vec::new();
        {
            let map = self.map.lock().unwrap_or_else(|e| e.into_inner());
            for (i, (_, key)) in keyed.iter().enumerate() {
                match map.get(key) {
                    Some(f) => {
                        self.hits.fetch_add(1, Ordering::Relaxed);
                        out[i] = Some(f.clone());
                    }
                    None => missed.push(i),
                }
            }
        }
        let grid: Vec<GridAsk> = missed
            .iter()
            .map(|&i| grid_ask(&keyed[i].0, asks[i].1, fidelity))
            .collect();
        let sims = simulate_grids(&grid);
        // The features of each trace, in parallel as the simulations were.
        let feats: Vec<(Vec<FeatureSet>, u64)> = missed
            .par_iter()
            .zip(sims)
            .map(|(&i, (sim, nanos))| {
                let rec = asks[i].1;
                let f = match sim {
                    Ok(tr) if tr.status == crate::ode::Status::Success => trace_of(rec, &tr),
                    _ => vec![FeatureSet::nan(); stages(&rec.t, &rec.params).len()],
                };
                (f, nanos)
            })
            .collect();
        let mut map = self.map.lock().unwrap_or_else(|e| e.into_inner());
        for (&i, (f, nanos)) in missed.iter().zip(feats) {
            let key = keyed[i].1.clone();
            self.count(key.1, nanos);
            if map.len() < Self::CAPACITY {
                map.insert(key, f.clone());
            }
            out[i] = Some(f);
        }
        drop(map);
        out.into_iter()
            .map(|f| f.expect("every ask answered"))
            .collect()
    }

    /// The features of `rec` under `model` at `fidelity`, simulated where not cached (one ask of
    /// [`SimCache::features_many`]).
    #[cfg(test)]
    pub(crate) fn features(
        &self,
        model: &Model,
        rec: &Recording,
        fidelity: Fidelity,
    ) -> Vec<FeatureSet> {
        self.features_many(&[(model, rec)], fidelity)
            .pop()
            .expect("one answer")
    }
}

pub(crate) fn same_drive(a: &Params, b: &Params) -> bool {
    a.v_d == b.v_d && a.k_d == b.k_d && a.f_n == b.f_n && a.m == b.m
}

/// Fills `r` of every vibrated unit that has a reference whose `dF` is above its floor
/// ([`Feature::floor`]); `r` stays undefined where it is not.
///
/// Why: `r = dF / dF_0` presupposes stick-slip without vibration. A reference that slides (a
/// candidate that stabilises the sliding at a stiff spring predicts `dF_0` of 1e-7 N) makes the
/// ratio explode (r of 1e5 against a measured 0.5), and with it the cost, by ten orders of
/// magnitude over a step of a parameter: a wall no fit crosses, which hid the basin of viscous
/// friction on the second independent rig's `sensor+viscous` campaign once recordings at stiff
/// springs were added. Below the floor the reference's `dF` is no different from zero; its own
/// residual carries that difference ([`zscore`] counts an undefined prediction 0 where `dF` is
/// defined).
pub(crate) fn fill_r(fs: &mut [FeatureSet], reference: &[Option<usize>]) {
    for i in 0..fs.len() {
        if let Some(j) = reference[i] {
            let (d, d0) = (fs[i].get(Feature::DF), fs[j].get(Feature::DF));
            if d0.partial_cmp(&Feature::DF.floor(d0)) != Some(std::cmp::Ordering::Greater) {
                continue;
            }
            let (s, s0) = (
                fs[i].stderr[Feature::DF as usize],
                fs[j].stderr[Feature::DF as usize],
            );
            let r = d / d0;
            fs[i].value[Feature::R as usize] = r;
            let rel = (s / d).powi(2) + (s0 / d0).powi(2);
            fs[i].stderr[Feature::R as usize] = if rel.is_finite() {
                r * rel.sqrt()
            } else {
                f64::NAN
            };
        }
    }
}

/// Features of every stage of a trace sampled at the recording's times; `x_s` and `x_d` count
/// only where given (where the recording has them), so measured and simulated traces pass
/// through one pipeline.
///
/// A displacement channel the recording holds quantized ([`quantum`]: an encoder's step) is
/// quantized alike in a simulated trace, and its harmonic amplitude weighted by the step
/// ([`weigh_quantum`]).
pub fn trace_features(
    rec: &Recording,
    f_d: &[f64],
    x_s: Option<&[f64]>,
    x_d: Option<&[f64]>,
) -> Vec<FeatureSet> {
    let q_s = rec.x_s.as_deref().and_then(quantum);
    let q_d = rec.x_d.as_deref().and_then(quantum);
    let xs_q = x_s.zip(q_s).map(|(x, q)| quantize(x, q));
    let xd_q = x_d.zip(q_d).map(|(x, q)| quantize(x, q));
    let x_s = xs_q.as_deref().or(x_s);
    let x_d = xd_q.as_deref().or(x_d);
    stages(&rec.t, &rec.params)
        .into_iter()
        .map(|st| {
            let mut fs = stage_features(&rec.t, f_d, x_s, x_d, rec.dt(), st, rec.params.t_on);
            if let Some(q) = q_s {
                weigh_quantum(&mut fs, q);
            }
            fs
        })
        .collect()
}

/// Features of a recording's measured signals, one set per stage.
pub fn measured_features(rec: &Recording) -> Vec<FeatureSet> {
    trace_features(rec, &rec.f_d, rec.x_s.as_deref(), rec.x_d.as_deref())
}

impl<'a> Target<'a> {
    /// Prepares recordings for fitting, with the plausible ranges of the effects' parameters
    /// derived from them ([`Plausible::of`]).
    pub fn new(recs: Vec<&'a Recording>) -> Target<'a> {
        let mut t = Target::with_bounds(recs, Plausible::default(), Arc::default());
        t.bounds = Plausible::of(&t);
        t
    }

    /// A subset of this target's recordings, with this target's plausible ranges: the bounds of
    /// a fit are the campaign's, whichever recordings it is scored on.
    pub fn sub(&self, recs: Vec<&'a Recording>) -> Target<'a> {
        let mut t = Target::with_bounds(recs, self.bounds.clone(), Arc::clone(&self.cache));
        t.fidelity = self.fidelity;
        t
    }

    /// The same recordings, predicted at `fidelity` (sharing the cache and its counts).
    pub fn at(&self, fidelity: Fidelity) -> Target<'a> {
        Target {
            fidelity,
            ..self.clone()
        }
    }

    fn with_bounds(
        recs: Vec<&'a Recording>,
        bounds: Plausible,
        cache: Arc<SimCache>,
    ) -> Target<'a> {
        let per: Vec<Vec<FeatureSet>> = recs.par_iter().map(|r| cache.measured(r)).collect();
        let mut units = vec![];
        let mut measured = vec![];
        for (i, (r, fs)) in recs.iter().zip(per).enumerate() {
            for (st, f) in stages(&r.t, &r.params).into_iter().zip(fs) {
                units.push((i, st));
                measured.push(f);
            }
        }
        let reference: Vec<Option<usize>> = units
            .iter()
            .map(|&(i, st)| {
                if st.freq == 0.0 {
                    return None;
                }
                // The resting stage of the same recording first, then a recording without
                // vibration of the same drive, then any resting stage of that drive.
                let resting = |u: &(usize, Stage)| u.1.freq == 0.0;
                units
                    .iter()
                    .position(|u| u.0 == i && resting(u))
                    .or_else(|| {
                        units.iter().position(|u| {
                            resting(u)
                                && !recs[u.0].vibrates()
                                && same_drive(&recs[u.0].params, &recs[i].params)
                        })
                    })
                    .or_else(|| {
                        units.iter().position(|u| {
                            resting(u) && same_drive(&recs[u.0].params, &recs[i].params)
                        })
                    })
                    // A reference without a stick-slip gives no `r` (a ratio of noise levels).
                    .filter(|&j| {
                        let (k, st) = units[j];
                        super::features::is_reference(&recs[k].f_d[st.lo..st.hi], &measured[j])
                    })
            })
            .collect();
        fill_r(&mut measured, &reference);
        Target {
            recs,
            units,
            measured,
            reference,
            bounds,
            cache,
            fidelity: Fidelity::Full,
        }
    }

    /// The simulations run so far by this target and every subset of it ([`Target::sub`]
    /// shares its cache), with their cost.
    pub fn work(&self) -> Work {
        let by_fidelity = [0, 1].map(|i| Runs {
            simulations: self.cache.simulations[i].load(Ordering::Relaxed),
            simulation_cpu: self.cache.nanos[i].load(Ordering::Relaxed) as f64 * 1e-9,
        });
        Work {
            simulations: by_fidelity.iter().map(|r| r.simulations).sum(),
            cache_hits: self.cache.hits.load(Ordering::Relaxed),
            simulation_cpu: by_fidelity.iter().map(|r| r.simulation_cpu).sum(),
            by_fidelity,
        }
    }

    /// Counts a full simulation run outside the cache (the detection limits' noisy
    /// recordings), with its time \[ns\], in [`Target::work`].
    pub(crate) fn count_run(&self, nanos: u64) {
        self.cache.count(Fidelity::Full, nanos);
    }

    /// The units of recording `i`.
    pub fn units_of(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.units.len()).filter(move |&u| self.units[u].0 == i)
    }

    /// Simulated features of every unit under `model` (NaN features when a run fails).
    pub fn predict(&self, model: &Model) -> Vec<FeatureSet> {
        self.predict_for(model, None)
    }

    /// [`Target::predict`] on the recordings `need` marks alone (every one where `None`); the
    /// others' units are [`FeatureSet::nan`]. The rows of [`Target::residuals`] of a needed
    /// recording are those of `predict` wherever the recordings its units are compared with
    /// for `r` ([`Target::reference`]) are needed too ([`Target::needed_with_references`]).
    pub fn predict_for(&self, model: &Model, need: Option<&[bool]>) -> Vec<FeatureSet> {
        let needed: Vec<usize> = (0..self.recs.len())
            .filter(|&i| need.is_none_or(|n| n[i]))
            .collect();
        let asks: Vec<(&Model, &Recording)> =
            needed.iter().map(|&i| (model, self.recs[i])).collect();
        let mut got = self.cache.features_many(&asks, self.fidelity).into_iter();
        let per: Vec<Vec<FeatureSet>> = (0..self.recs.len())
            .map(|i| {
                if need.is_none_or(|n| n[i]) {
                    got.next().expect("one answer per needed recording")
                } else {
                    vec![FeatureSet::nan(); self.units.iter().filter(|u| u.0 == i).count()]
                }
            })
            .collect();
        let mut out: Vec<FeatureSet> = per.into_iter().flatten().collect();
        debug_assert_eq!(out.len(), self.units.len());
        fill_r(&mut out, &self.reference);
        out
    }

    /// The recordings whose rows `keep` marks (rows as [`Target::row_recordings`]), with the
    /// recordings their units are compared with for `r`: what [`Target::predict_for`] must
    /// simulate for those rows.
    pub fn needed_with_references(&self, keep: &[bool]) -> Vec<bool> {
        let mut need = vec![false; self.recs.len()];
        for (&r, &k) in self.row_recordings().iter().zip(keep) {
            need[r] |= k;
        }
        for (u, reference) in self.reference.iter().enumerate() {
            if let Some(j) = reference
                && need[self.units[u].0]
            {
                need[self.units[*j].0] = true;
            }
        }
        need
    }

    /// One value per row of [`Target::residuals`], `of(u)` for unit `u`: one row per feature
    /// the measurement of each unit defines, unit by unit.
    fn per_row<T: Copy>(&self, of: impl Fn(usize) -> T) -> Vec<T> {
        let mut rows = vec![];
        for (u, m) in self.measured.iter().enumerate() {
            let n = FEATURES
                .iter()
                .filter(|f| m.value[**f as usize].is_finite())
                .count();
            rows.extend(std::iter::repeat_n(of(u), n));
        }
        rows
    }

    /// The recording each row of [`Target::residuals`] belongs to.
    pub fn row_recordings(&self) -> Vec<usize> {
        self.per_row(|u| self.units[u].0)
    }

    /// The vibration frequency of each row's stage of [`Target::residuals`] \[Hz\] (0 at rest).
    pub fn row_frequencies(&self) -> Vec<f64> {
        self.per_row(|u| self.units[u].1.freq)
    }

    /// The feature of each row of [`Target::residuals`] (rows as [`Target::row_recordings`]).
    pub fn row_features(&self) -> Vec<Feature> {
        self.measured
            .iter()
            .flat_map(|m| {
                FEATURES
                    .iter()
                    .copied()
                    .filter(|f| m.value[*f as usize].is_finite())
            })
            .collect()
    }

    /// The standardised differences, one per (unit, feature) that the measurement defines, in
    /// a fixed layout; a feature the model does not produce (no cycles) counts 0, since dF
    /// carries that difference.
    pub fn residuals(&self, pred: &[FeatureSet]) -> Vec<f64> {
        self.measured
            .iter()
            .zip(pred)
            .flat_map(|(m, p)| zscores(m, p))
            .collect()
    }
}

/// The standardised differences of every feature the measurement defines, in [`FEATURES`] order.
pub fn zscores(m: &FeatureSet, p: &FeatureSet) -> Vec<f64> {
    FEATURES.iter().filter_map(|&f| zscore(m, p, f)).collect()
}

/// The standardised difference of one feature (None where the measurement does not define it).
pub fn zscore(m: &FeatureSet, p: &FeatureSet, f: Feature) -> Option<f64> {
    let i = f as usize;
    let mv = m.value[i];
    if !mv.is_finite() {
        return None;
    }
    let pv = p.value[i];
    // The model may leave a harmonic's phase undefined (its amplitude in the noise): the
    // amplitude carries that difference, as dF does for a model without cycles.
    if !pv.is_finite() && f.is_phase() {
        return Some(0.0);
    }
    if !pv.is_finite() {
        return Some(if p.value[Feature::DF as usize].is_finite() {
            0.0
        } else {
            1e3
        });
    }
    let sigma = sigma(m, p, f);
    Some(difference(f, pv, mv) / sigma)
}

/// `a − b` of a feature, wrapped to (−π, π] where the feature is an angle.
pub fn difference(f: Feature, a: f64, b: f64) -> f64 {
    if f.is_phase() {
        let tau = std::f64::consts::TAU;
        let w = (a - b).rem_euclid(tau);
        if w > 0.5 * tau { w - tau } else { w }
    } else {
        a - b
    }
}

/// The scale of a feature's standardised difference ([`zscore`]): the measurement's and the
/// prediction's standard errors and the feature's floor at the measured value, in quadrature.
pub fn sigma(m: &FeatureSet, p: &FeatureSet, f: Feature) -> f64 {
    let i = f as usize;
    let se = |s: f64| if s.is_finite() { s * s } else { 0.0 };
    let fl = f.floor(m.value[i]);
    (se(m.stderr[i]) + se(p.stderr[i]) + fl * fl).sqrt()
}

/// The simulation of recording `rec` under `model` on its sample grid, at the fits' tolerance
/// (`None` where the run fails).
pub fn simulate(model: &Model, rec: &Recording, solvers: &mut Solvers) -> Option<SimTrace> {
    simulate_at(model, rec, Fidelity::Full, solvers)
}

/// The simulations of each recording under its model at `fidelity` ([`simulate_at`] each:
/// `None` where the run fails), run together ([`simulate_grids`]: side by side in vector lanes
/// where they can, spread over the thread pool), each with its CPU time \[ns\].
pub fn simulate_many(
    asks: &[(&Model, &Recording)],
    fidelity: Fidelity,
) -> Vec<(Option<SimTrace>, u64)> {
    let grid: Vec<GridAsk> = asks
        .iter()
        .map(|(m, rec)| grid_ask(m, rec, fidelity))
        .collect();
    simulate_grids(&grid)
        .into_iter()
        .map(|(r, ns)| {
            let ok = r.ok().filter(|tr| tr.status == crate::ode::Status::Success);
            (ok, ns)
        })
        .collect()
}

/// The simulation of `rec` under `model` at `fidelity`, as [`simulate_grids`] takes it.
fn grid_ask(model: &Model, rec: &Recording, fidelity: Fidelity) -> GridAsk {
    GridAsk {
        p: model.params_for(rec),
        fx: model.effects.clone(),
        t0: rec.t[0],
        dt: rec.dt(),
        n: rec.t.len(),
        tol: fidelity.tolerance(rec),
    }
}

/// [`simulate`] at `fidelity`.
pub fn simulate_at(
    model: &Model,
    rec: &Recording,
    fidelity: Fidelity,
    solvers: &mut Solvers,
) -> Option<SimTrace> {
    let p = model.params_for(rec);
    simulate_grid(
        &p,
        &model.effects,
        rec.t[0],
        rec.dt(),
        rec.t.len(),
        fidelity.tolerance(rec),
        solvers,
    )
    .ok()
    .filter(|tr| tr.status == crate::ode::Status::Success)
}

/// The features of `rec` simulated under `model` in full (NaN where the run fails).
#[cfg(test)]
pub(crate) fn predict_one(
    model: &Model,
    rec: &Recording,
    solvers: &mut Solvers,
) -> Vec<FeatureSet> {
    predict_at(model, rec, Fidelity::Full, solvers)
}

/// [`predict_one`] at `fidelity`.
#[cfg(test)]
fn predict_at(
    model: &Model,
    rec: &Recording,
    fidelity: Fidelity,
    solvers: &mut Solvers,
) -> Vec<FeatureSet> {
    match simulate_at(model, rec, fidelity, solvers) {
        Some(tr) => trace_of(rec, &tr),
        None => vec![FeatureSet::nan(); stages(&rec.t, &rec.params).len()],
    }
}

/// The features of every stage of `rec` from its simulated trace `tr`.
pub(crate) fn trace_of(rec: &Recording, tr: &SimTrace) -> Vec<FeatureSet> {
    trace_features(
        rec,
        &tr.f_d,
        rec.x_s.as_ref().map(|_| &tr.x_s[..]),
        rec.x_d.as_ref().map(|_| &tr.x_d[..]),
    )
}

/// `√(mean z²)`.
pub fn gap(z: &[f64]) -> f64 {
    if z.is_empty() {
        return 0.0;
    }
    (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt()
}

impl Plausible {
    /// The bounds a campaign's recordings imply (the units' measured features, their conditions
    /// and sampling):
    /// - a force sensor's `f_n` and an actuator's `f_r` no lower than the fastest drive
    ///   oscillator of the campaign, `√(k_d/m)/2π` (a resonance below it would turn each
    ///   stick-slip cycle into a ringing of its own); a sensor's also no lower than
    ///   [`SLIP_BOUND_MARGIN`]` / (2 t_slip)` with `t_slip` the shortest recorded slip (the mean
    ///   peak-to-trough time of a unit's smoothed force): a sensor slower than that cannot
    ///   record a drop that fast;
    /// - a screw error's `wavelength` no longer than half the longest drive travel recorded
    ///   (`v_d` times the record's length: a longer one is a drift, not a periodic error) and
    ///   no shorter than the shortest one any recording resolves (`2 v_d / f_sample`);
    /// - a friction lag `tau` no longer than the longest stick-slip period recorded (a longer
    ///   memory acts as a changed friction level, not as a lag);
    /// - a Stribeck exponent within [`STRIBECK_DELTA`] (not from the campaign: from measured
    ///   friction curves).
    pub fn of(t: &Target) -> Plausible {
        let mut bounds = vec![];
        let mut push = |effect: EffectKind, param: Param, lo: f64, hi: f64, reason: String| {
            let (a, b) = default_range(effect, param);
            let (lo, hi) = (lo.max(a), hi.min(b));
            if lo < hi && (lo > a || hi < b) {
                bounds.push(Bound {
                    effect,
                    param,
                    lo,
                    hi,
                    reason,
                });
            }
        };
        if t.recs.is_empty() {
            return Plausible { bounds };
        }
        // The fastest drive oscillator.
        let f_osc = t
            .recs
            .iter()
            .map(|r| (r.params.k_d / r.params.m).sqrt() / std::f64::consts::TAU)
            .fold(0.0, f64::max);
        // The shortest recorded slip and the longest stick-slip period, over the units.
        let feature_over = |f: Feature, pick: fn(f64, f64) -> f64, init: f64| {
            t.measured
                .iter()
                .map(|m| m.get(f))
                .filter(|v| v.is_finite() && *v > 0.0)
                .fold(init, pick)
        };
        let t_slip = feature_over(Feature::SlipTime, f64::min, f64::INFINITY);
        let period = feature_over(Feature::Period, f64::max, 0.0);
        let slip_lo = if t_slip.is_finite() {
            SLIP_BOUND_MARGIN / (2.0 * t_slip)
        } else {
            0.0
        };
        let (sensor_lo, why) = if slip_lo > f_osc {
            (
                slip_lo,
                format!(
                    "the shortest recorded slip lasts {:.1} ms: a slower sensor cannot record it ({SLIP_BOUND_MARGIN} / (2 t_slip)); the fastest drive oscillator is {f_osc:.1} Hz",
                    1e3 * t_slip
                ),
            )
        } else {
            (
                f_osc,
                format!(
                    "no lower than the fastest drive oscillator, sqrt(k_d/m)/2pi = {f_osc:.1} Hz{}",
                    if t_slip.is_finite() {
                        format!(
                            " (the shortest recorded slip, {:.1} ms, allows {slip_lo:.1} Hz)",
                            1e3 * t_slip
                        )
                    } else {
                        String::new()
                    }
                ),
            )
        };
        push(
            EffectKind::SensorDynamics,
            sensor_dynamics::F_N,
            sensor_lo,
            f64::INFINITY,
            why,
        );
        push(
            EffectKind::ActuatorResponse,
            actuator_response::F_R,
            f_osc,
            f64::INFINITY,
            format!("no lower than the fastest drive oscillator, sqrt(k_d/m)/2pi = {f_osc:.1} Hz"),
        );
        let travel = t
            .recs
            .iter()
            .map(|r| r.params.v_d * (r.t[r.t.len() - 1] - r.t[0]))
            .fold(0.0, f64::max);
        let resolved = t
            .recs
            .iter()
            .map(|r| 2.0 * r.params.v_d * r.dt())
            .fold(f64::INFINITY, f64::min);
        push(
            EffectKind::DriveRipple,
            drive_ripple::WAVELENGTH,
            resolved,
            0.5 * travel,
            format!(
                "at most half the longest drive travel recorded ({:.3} mm) and at least the shortest wavelength a recording resolves (2 v_d / sampling rate = {:.2} um)",
                1e3 * travel,
                1e6 * resolved
            ),
        );
        if period > 0.0 {
            push(
                EffectKind::FrictionalLag,
                frictional_lag::TAU,
                0.0,
                period,
                format!(
                    "no longer than the longest stick-slip period recorded ({:.0} ms)",
                    1e3 * period
                ),
            );
        }
        push(
            EffectKind::StribeckShape,
            stribeck_shape::DELTA,
            STRIBECK_DELTA.0,
            STRIBECK_DELTA.1,
            format!(
                "Stribeck exponents of measured friction curves lie about 0.5 to 2 (1: Tustin's exponential, 2: Gaussian); outside {} to {} the curve is a step or a straight line",
                STRIBECK_DELTA.0, STRIBECK_DELTA.1
            ),
        );
        Plausible { bounds }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit with `dF = d` (its standard error 1 % of it) and nothing else defined.
    fn unit(d: f64) -> FeatureSet {
        let mut f = FeatureSet::nan();
        f.value[Feature::DF as usize] = d;
        f.stderr[Feature::DF as usize] = 0.01 * d;
        f
    }

    /// `r` is the ratio where the reference stick-slips, undefined where its `dF` lies under
    /// the floor; the residual of such a prediction's `r` is then 0 against a measured one and
    /// its reference's `dF` carries the difference, where the ratio of 1e-7 N made a residual
    /// of millions.
    #[test]
    fn r_is_undefined_where_the_reference_slides() {
        let reference = [None, Some(0)];
        let mut measured = vec![unit(2.0), unit(1.0)];
        fill_r(&mut measured, &reference);
        assert_eq!(measured[1].get(Feature::R), 0.5);

        let mut sticks = vec![unit(1.0), unit(0.5)];
        fill_r(&mut sticks, &reference);
        assert_eq!(sticks[1].get(Feature::R), 0.5);
        assert_eq!(zscore(&measured[1], &sticks[1], Feature::R), Some(0.0));

        let floor = Feature::DF.floor(0.0);
        for d0 in [1e-7, 0.5 * floor, floor] {
            let mut slides = vec![unit(d0), unit(0.05)];
            fill_r(&mut slides, &reference);
            assert!(slides[1].get(Feature::R).is_nan(), "r at dF_0 = {d0}");
            assert_eq!(zscore(&measured[1], &slides[1], Feature::R), Some(0.0));
            let z0 = zscore(&measured[0], &slides[0], Feature::DF).expect("dF defined");
            assert!(
                z0 < -50.0,
                "the reference's dF carries the difference: z {z0}"
            );
        }
        // Just above the floor the ratio stands, large as it is.
        let mut near = vec![unit(1.01 * floor), unit(0.05)];
        fill_r(&mut near, &reference);
        assert!(near[1].get(Feature::R) > 2.0);
    }
}
