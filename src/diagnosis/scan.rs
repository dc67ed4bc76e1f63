//! The starts of a candidate's fit: global scans of an effect's parameters over their plausible
//! ranges on a few recordings at the search fidelity ([`starts`]), the per-frequency scans of the
//! actuator's gain and the load path's phase, the dense line search of a sensor's resonance
//! about a screen's optimum, and the subsets of recordings the scans and screens are scored on.

use super::features::Feature;
use super::fit::{FitOptions, FitResult, Model, Target, cost_of, evaluate};
use super::target::Fidelity;
use crate::campaign::Recording;
use crate::model::effects::{
    Grid, Param, actuator_gain, actuator_response, aging, drive_ripple, normal_coupling,
    response_gain, sensor_dynamics, viscous,
};
use crate::model::{EffectKind, Params};
use crate::sweep::spec::logspace;
use rayon::prelude::*;

/// The values the global scan of [`starts`] tries for one fitted effect parameter, over its
/// plausible range: the effect's [`starts`](crate::model::effects::EffectInfo::starts) (the
/// sensor's resonance at ten frequencies from 20 Hz to 20 kHz, each at a light, a moderate and
/// a critical-like damping; the load modulation's phase with the velocity and against it; the
/// others at three to five points of their range); none where the effect has none for it.
/// The actuator's resonance has a scan of its own ([`actuator_scan`]).
fn scan_values(kind: EffectKind, param: Param) -> Vec<f64> {
    match param.look_up(kind.info().starts) {
        Some(Grid::Values(v)) => v.to_vec(),
        Some(Grid::Log(lo, hi, n)) => logspace(lo, hi, n),
        None => vec![],
    }
}

/// `base` with `kind` switched on at its neutral values ([`neutral`](super::model::neutral)): the base model, or
/// nearly so.
pub fn neutral_start(base: &Model, kind: EffectKind, form: f64) -> Model {
    let mut m0 = base.clone();
    m0.effects.enable(kind);
    let _ = m0.effects.set_form_value(kind, form);
    for &(p, v) in kind.info().neutral {
        let _ = m0.effects.set_at(kind, p, v);
    }
    m0
}

/// Starting values for an effect's fitted parameters, from a global scan over their plausible
/// ranges (every combination: a sensor's resonance at ten frequencies from 20 Hz to 20 kHz, each
/// at three dampings; the others at three to five values; the actuator's resonance from the
/// gain scan of [`actuator_scan`], 100 Hz to 100 kHz in steps of 1 %) on the calibrated
/// parameters of `base`, scored on up to [`SCAN_RECORDINGS`] recordings (half of them those
/// `base` misses most), with
/// the neutral start ([`neutral`](super::model::neutral)) among them; for the drive ripple, the wavelength and
/// amplitude read off the recorded drive position, where recorded. The scan's best start is
/// refined locally by [`fit`](super::fit::fit) (in `diagnose`, first by a screening fit, about whose optimum a
/// sensor's resonance is then scanned densely: [`line_search`]). As the scan holds the
/// neutral start, its best is not worse than the base model on the scored recordings;
/// `diagnose` reports the base model for a candidate whose fit still ends worse on all of
/// them.
///
/// The best start comes first. Where it is a per-frequency scan's ([`actuator_scan`],
/// [`normal_scan`]), the best of the generic grid follows: the scan frees parameters the grid
/// holds (the load path's delay), and a start that scores better on the scan's subset can
/// still lead the fit to a worse optimum than the grid's fewer degrees of freedom do, so
/// `diagnose` screens the candidate from both.
pub fn starts(target: &Target, base: &FitResult, kind: EffectKind, form: f64) -> Vec<ScanStart> {
    let m0 = neutral_start(&base.model, kind, form);
    let mut candidates: Vec<Model> = vec![m0.clone()];
    if kind == EffectKind::DriveRipple
        && let Some((a, lambda)) = ripple_from_drive(&target.recs)
    {
        let mut m = m0.clone();
        let _ = m.effects.set_at(kind, drive_ripple::A, a.clamp(0.0, 1e-3));
        let (lo, hi) = target.bounds.range(kind, drive_ripple::WAVELENGTH);
        let _ = m
            .effects
            .set_at(kind, drive_ripple::WAVELENGTH, lambda.clamp(lo, hi));
        candidates.push(m);
    }
    // The scan only chooses a start: score the starts on a subset of the recordings, at the
    // search fidelity (the screen and the fit that follow are full).
    let mut sub = scan_subset(target, &base.z);
    sub.fidelity = Fidelity::Search;
    let scanned = match kind {
        EffectKind::ActuatorResponse => actuator_scan(&sub, &m0),
        EffectKind::NormalCoupling => normal_scan(&sub, &m0),
        _ => None,
    };
    let from_scan = scanned.is_some().then_some(candidates.len());
    candidates.extend(scanned);
    let mut grid: Vec<Vec<(Param, f64)>> = vec![vec![]];
    let fitted = (0..kind.info().params.len())
        .map(Param)
        .filter(|&p| p.of(kind).fitted);
    for p in fitted.filter(|&p| m0.effects.uses(kind, p)) {
        // The scan's values within the campaign's plausible range, its ends added where the
        // range cuts some off.
        let (lo, hi) = target.bounds.range(kind, p);
        let all_vals = scan_values(kind, p);
        let mut vals: Vec<f64> = all_vals
            .iter()
            .copied()
            .filter(|v| (lo..=hi).contains(v))
            .collect();
        if all_vals.iter().any(|&v| v < lo) {
            vals.insert(0, lo);
        }
        if all_vals.iter().any(|&v| v > hi) {
            vals.push(hi);
        }
        if vals.is_empty() {
            continue;
        }
        grid = grid
            .into_iter()
            .flat_map(|g| {
                vals.iter().map(move |&v| {
                    let mut g = g.clone();
                    g.push((p, v));
                    g
                })
            })
            .collect();
    }
    if grid.iter().any(|g| !g.is_empty()) {
        // Viscous friction is partly absorbed by the base parameters: a base fit to a campaign
        // whose stick-slip dies out as the drive speeds up lowers the breakaway level (F_s, v_s)
        // until stick-slip fades everywhere, a basin the viscous term cannot leave in a few
        // steps. Its grid is scanned from the nominal F_s, v_s and h_d as well, with F_c
        // lowered by the term's force at the campaign's mean drive velocity (the sliding force
        // kept).
        let v_mean =
            target.recs.iter().map(|r| r.params.v_d).sum::<f64>() / target.recs.len() as f64;
        let nominal = Params::default();
        let age = (kind == EffectKind::Aging)
            .then(|| typical_stick_time(target))
            .flatten();
        for g in grid {
            let mut m = m0.clone();
            for &(p, v) in &g {
                let _ = m.effects.set_at(kind, p, v);
            }
            if kind == EffectKind::Viscous {
                let mut mn = m.clone();
                (mn.f_s, mn.v_s, mn.h_d) = (nominal.f_s, nominal.v_s, nominal.h_d);
                let h_v = m.effects.at(kind, viscous::H_V).unwrap_or(0.0);
                mn.f_c = (m.f_c - h_v * v_mean).max(0.5 * m.f_c);
                candidates.push(mn);
            }
            // Ageing is absorbed by the base fit the same way: its F_s takes the aged level at
            // the campaign's typical contact age, and any ageing added on top of it overshoots.
            // Its grid is scanned with F_s lowered to keep that level as well.
            if kind == EffectKind::Aging
                && let (Some(age), Some(b), Some(theta_0)) = (
                    age,
                    m.effects.at(kind, aging::B),
                    m.effects.at(kind, aging::THETA_0),
                )
            {
                let mut ma = m.clone();
                ma.f_s = (m.f_s / (1.0 + b * (age / theta_0).ln_1p())).max(m.f_c);
                candidates.push(ma);
            }
            candidates.push(m);
        }
    }
    if candidates.len() == 1 {
        return vec![ScanStart::stopped(m0)];
    }
    let costs: Vec<f64> = candidates.par_iter().map(|m| evaluate(&sub, m)).collect();
    let lowest = |skip: Option<usize>| {
        (0..costs.len())
            .filter(|&i| Some(i) != skip)
            .min_by(|&a, &b| costs[a].total_cmp(&costs[b]))
    };
    let best = lowest(None).expect("candidates");
    let mut out = vec![ScanStart::stopped(candidates[best].clone())];
    if from_scan == Some(best)
        && let Some(grid_best) = lowest(from_scan)
    {
        out.push(ScanStart::stopped(candidates[grid_best].clone()));
    }
    out.extend(
        strongest_near(kind, &candidates, &costs, best)
            .into_iter()
            .map(|i| ScanStart {
                model: candidates[i].clone(),
                in_full: true,
            }),
    );
    out
}

/// A start of a candidate's fit, from the scan of [`starts`].
#[derive(Clone, Debug)]
pub struct ScanStart {
    /// The model to start from.
    pub model: Model,
    /// Whether a screen from it runs its iterations in full, its bar checked at the end only
    /// (no stop where its linearised residuals or its pace miss the bar:
    /// [`FitOptions::reach`](super::fit::FitOptions::reach)). Set on the strong starts of [`strongest_near`], whose way to
    /// the optimum crosses a jump of the cost that neither predicts.
    pub in_full: bool,
}

impl ScanStart {
    /// A start whose screen stops where it cannot reach its bar.
    pub fn stopped(model: Model) -> Self {
        ScanStart {
            model,
            in_full: false,
        }
    }

    /// The screen's options from this start: `opts`, its reach lifted where the start is
    /// screened in full ([`ScanStart::in_full`]).
    pub fn screen_options(&self, opts: FitOptions) -> FitOptions {
        screen_options(self.in_full, opts)
    }
}

/// A screen's options `opts` for a start screened in full (`in_full`: no reach, the bar
/// checked at the end only) or not (`opts` unchanged).
pub fn screen_options(in_full: bool, opts: FitOptions) -> FitOptions {
    FitOptions {
        reach: if in_full { f64::INFINITY } else { opts.reach },
        ..opts
    }
}

/// Share of the lowest scan cost within which [`strongest_near`] takes stronger starts.
pub const STRONGER_START_MARGIN: f64 = 0.1;

/// For viscous friction, the scan's starts of the strongest term whose cost lies within
/// [`STRONGER_START_MARGIN`] of the lowest, `costs[best]`, and stronger than the best's (each
/// of the scan's starts at that strength: the base fit's parameters and the nominal ones);
/// none where no start is. Why: the base fit absorbs the term (a lower `F_s` and `v_s` where
/// stick-slip fades as the drive speeds up), so the scan's cost rises slowly as the term
/// grows, while the base parameters still carry its work, and then rises steeply where a
/// reference recording stops sticking (its `dF` carries that, and `r`, a ratio over it, did by
/// ten orders of magnitude until it was left undefined there: `target::fill_r`). The lowest
/// start then lies next to the base model, and a screen's few steps from it stay in the
/// absorbed basin, each gaining less than a percent; the strongest start short of the steep
/// rise is the closest to the other basin. On the second independent rig's
/// campaign with quadratic viscous friction and a sensor, a screen from `h_v` 20 ends at a
/// gap of 38.8, one from 100 at 6.0 (the linear form) and from 20 at 2.0 (the quadratic form,
/// whose best start is the neutral one).
pub fn strongest_near(
    kind: EffectKind,
    candidates: &[Model],
    costs: &[f64],
    best: usize,
) -> Vec<usize> {
    if kind != EffectKind::Viscous || !costs[best].is_finite() {
        return vec![];
    }
    let strength = |i: usize| candidates[i].effects.at(kind, viscous::H_V).unwrap_or(0.0);
    let near: Vec<usize> = (0..costs.len())
        .filter(|&i| costs[i] <= (1.0 + STRONGER_START_MARGIN) * costs[best])
        .filter(|&i| strength(i) > strength(best))
        .collect();
    let top = near.iter().map(|&i| strength(i)).fold(f64::NAN, f64::max);
    near.into_iter().filter(|&i| strength(i) == top).collect()
}

/// The median stick time of the units that stick-slip (cycle period less slip time) \[s\]: the
/// contact age at a typical breakaway, to which a base fit's `F_s` absorbs dwell-time ageing.
/// `None` where no unit has both.
fn typical_stick_time(target: &Target) -> Option<f64> {
    let t = crate::campaign::check::median(
        target
            .measured
            .iter()
            .map(|m| m.get(Feature::Period) - m.get(Feature::SlipTime))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect(),
    );
    t.is_finite().then_some(t)
}

/// The forcing frequencies of `sub`'s vibrated units, sorted, each once.
fn forcing_frequencies(sub: &Target) -> Vec<f64> {
    let mut freqs: Vec<f64> = sub
        .units
        .iter()
        .map(|u| u.1.freq)
        .filter(|&f| f > 0.0)
        .collect();
    freqs.sort_by(f64::total_cmp);
    freqs.dedup();
    freqs
}

/// Per forcing frequency of `freqs`: its vibrated recordings of `sub` with the recordings of
/// their references.
fn frequency_groups<'a>(sub: &Target<'a>, freqs: &[f64]) -> Vec<Target<'a>> {
    freqs
        .iter()
        .map(|&f| {
            let mut pick: Vec<usize> = vec![];
            for (u, &(i, st)) in sub.units.iter().enumerate() {
                if st.freq == f {
                    pick.push(i);
                    if let Some(r) = sub.reference[u] {
                        pick.push(sub.units[r].0);
                    }
                }
            }
            pick.sort_unstable();
            pick.dedup();
            sub.sub(pick.into_iter().map(|i| sub.recs[i]).collect())
        })
        .collect()
}

/// Phases (degrees) [`normal_scan`] tabulates at each forcing frequency: every 30°.
pub const NORMAL_PHASES: usize = 12;

/// Strengths `k_n` [`normal_scan`] tabulates at each forcing frequency: 1e6 to 1e8 N/m in
/// steps of a factor 1.8 (the load modulation's effect on the friction grows about as fast as
/// `k_n`, so the global scan's steps of 3.2 pass its optimum by).
pub const NORMAL_STRENGTHS: usize = 9;

/// The start of `normal_coupling` from a scan of the load modulation's phase at each forcing
/// frequency.
///
/// At a recording's frequency `f` the effect acts through its strength `k_n` and the phase
/// `ψ(f) = φ − 360° f t_d` alone, so the scan's cost is a sum over the forcing frequencies of
/// the subset `sub`, each term a function of `(k_n, ψ)`. Each term is tabulated at
/// [`NORMAL_STRENGTHS`] values of `k_n` and [`NORMAL_PHASES`] phases (the recordings at
/// that frequency with their references), interpolated linearly in the phase (periodic), and
/// the sum minimised over `k_n`, `φ` in steps of 5° and the delay `t_d` from 0 to its
/// plausible end in steps that turn the phase at the highest frequency by 5°. A load path
/// with a delay, whose phase falls with the frequency, is then found as a whole, where a grid
/// of `(φ, t_d)` simulated start by start would need hundreds of runs. `None` where the subset
/// does not vibrate.
pub fn normal_scan(sub: &Target, m0: &Model) -> Option<Model> {
    let kind = EffectKind::NormalCoupling;
    let freqs = forcing_frequencies(sub);
    if freqs.is_empty() {
        return None;
    }
    let groups = frequency_groups(sub, &freqs);
    let strengths = logspace(1e6, 1e8, NORMAL_STRENGTHS);
    let phase = |j: usize| -180.0 + 360.0 * j as f64 / NORMAL_PHASES as f64;
    let jobs: Vec<(usize, usize, usize)> = (0..freqs.len())
        .flat_map(|i| {
            (0..strengths.len()).flat_map(move |k| (0..NORMAL_PHASES).map(move |j| (i, k, j)))
        })
        .collect();
    let costs: Vec<f64> = jobs
        .par_iter()
        .map(|&(i, k, j)| {
            let mut m = m0.clone();
            let _ = m.effects.set_at(kind, normal_coupling::K_N, strengths[k]);
            let _ = m.effects.set_at(kind, normal_coupling::PHASE, phase(j));
            let _ = m.effects.set_at(kind, normal_coupling::DELAY, 0.0);
            let (ssq, _) = cost_of(&groups[i], &m);
            if ssq.is_finite() { ssq } else { f64::INFINITY }
        })
        .collect();
    // costs[(i * strengths + k) * NORMAL_PHASES + j], interpolated periodically in the phase.
    let at = |i: usize, k: usize, psi: f64| -> f64 {
        let x = (psi + 180.0).rem_euclid(360.0) / 360.0 * NORMAL_PHASES as f64;
        let j0 = (x.floor() as usize).min(NORMAL_PHASES - 1);
        let w = x - j0 as f64;
        let j1 = (j0 + 1) % NORMAL_PHASES;
        let base = (i * strengths.len() + k) * NORMAL_PHASES;
        let (a, b) = (costs[base + j0], costs[base + j1]);
        if !(a.is_finite() && b.is_finite()) {
            return f64::INFINITY;
        }
        a + (b - a) * w
    };
    let (_, d_hi) = sub.bounds.range(kind, normal_coupling::DELAY);
    let f_max = freqs[freqs.len() - 1];
    let d_step = 5.0 / (360.0 * f_max);
    let n_d = (d_hi / d_step).floor() as usize;
    let mut best = (f64::INFINITY, strengths[0], 0.0, 0.0);
    for (k, &k_n) in strengths.iter().enumerate() {
        for p in 0..72 {
            let phi = -180.0 + 5.0 * p as f64;
            for d in 0..=n_d {
                // By index: the grid's values are never accumulated.
                let delay = d as f64 * d_step;
                let c: f64 = freqs
                    .iter()
                    .enumerate()
                    .map(|(i, &f)| at(i, k, phi - 360.0 * f * delay))
                    .sum();
                if c < best.0 {
                    best = (c, k_n, phi, delay);
                }
            }
        }
    }
    let mut m = m0.clone();
    let _ = m.effects.set_at(kind, normal_coupling::K_N, best.1);
    let _ = m.effects.set_at(kind, normal_coupling::PHASE, best.2);
    let _ = m.effects.set_at(kind, normal_coupling::DELAY, best.3);
    Some(m)
}

/// Gains the actuator scan ([`actuator_scan`]) tabulates at each forcing frequency, evenly in
/// `ln A` from [`ACTUATOR_GAIN_MIN`] to [`ACTUATOR_GAIN_MAX`] (steps of 20 %), with the neutral
/// gain 1 besides.
pub const ACTUATOR_GAINS: usize = 34;
/// Smallest gain of the actuator scan: the substrate moving at a twentieth of its nominal
/// amplitude, as good as no vibration for the features.
pub const ACTUATOR_GAIN_MIN: f64 = 0.05;
/// Largest gain of the actuator scan: twenty times the nominal amplitude turns every tested
/// `v_a/v_d` of 0.05 or more into elimination.
pub const ACTUATOR_GAIN_MAX: f64 = 20.0;

/// The start of `actuator_response` from a scan of the gain at each forcing frequency.
///
/// The effect changes a recording only through its gain `A(f)` at the recording's own
/// frequency ([`actuator_gain`]), so the scan's cost is a sum over the forcing frequencies of
/// the subset `sub`, each term a function of one gain. Each term is tabulated at
/// [`ACTUATOR_GAINS`] gains from 0.05 to 20 (each realised by a resonance next to that
/// frequency; the recordings at that frequency with their references), interpolated linearly
/// in `ln A`, and the sum minimised over a fine grid of `(f_r, ζ)`: `f_r` from 100 Hz to
/// 100 kHz in steps of 1 %, `ζ` at 15 values from 0.01 to 2. A resonance as sharp as a
/// saddle's (`ζ` of a few hundredths, within 5 % of a tested frequency) is then found wherever
/// it lies, where a grid of the resonance itself would need hundreds of simulated starts.
/// `None` where the subset does not vibrate.
pub fn actuator_scan(sub: &Target, m0: &Model) -> Option<Model> {
    let kind = EffectKind::ActuatorResponse;
    let freqs = forcing_frequencies(sub);
    if freqs.is_empty() {
        return None;
    }
    let groups = frequency_groups(sub, &freqs);
    let (f_lo, f_hi) = sub.bounds.range(kind, actuator_response::F_R);
    // A resonance that gives gain `g` at `f`: below `f` for g < 1 (`(f/f_r)² = 1 + 1/g`), above
    // it for g > 1 (`(f/f_r)² = 1 − 1/g`), lightly damped; the neutral start `m0` for 1. The
    // gain tabulated is the one realised (the bounds of `f_r` may cut it).
    // The table is of gains, whatever the form; it is realised by the resonance.
    let first_order = m0.effects.at(kind, actuator_response::FORM) == Some(1.0);
    let realise = |f: f64, g: f64| -> Model {
        let mut m = m0.clone();
        let _ = m.effects.set_at(kind, actuator_response::FORM, 0.0);
        if g != 1.0 {
            let q2 = if g < 1.0 {
                1.0 + 1.0 / g
            } else {
                1.0 - 1.0 / g
            };
            let _ = m.effects.set_at(
                kind,
                actuator_response::F_R,
                (f / q2.sqrt()).clamp(f_lo, f_hi),
            );
            let _ = m.effects.set_at(kind, actuator_response::ZETA, 0.01);
        }
        m
    };
    let mut gains = logspace(ACTUATOR_GAIN_MIN, ACTUATOR_GAIN_MAX, ACTUATOR_GAINS);
    gains.push(1.0);
    let jobs: Vec<(usize, f64)> = (0..freqs.len())
        .flat_map(|i| gains.iter().map(move |&g| (i, g)))
        .collect();
    let costs: Vec<(usize, f64, f64)> = jobs
        .par_iter()
        .map(|&(i, g)| {
            let m = realise(freqs[i], g);
            let (f_r, zeta) = (
                m.effects.at(kind, actuator_response::F_R),
                m.effects.at(kind, actuator_response::ZETA),
            );
            let gain = actuator_gain(freqs[i], f_r.unwrap_or(f_hi), zeta.unwrap_or(1.0));
            let (ssq, _) = cost_of(&groups[i], &m);
            let ssq = if ssq.is_finite() { ssq } else { f64::INFINITY };
            (i, gain.ln(), ssq)
        })
        .collect();
    // Per frequency, the table (ln A, cost) sorted by ln A, one entry per realised gain.
    let tables: Vec<Vec<(f64, f64)>> = (0..freqs.len())
        .map(|i| {
            let mut t: Vec<(f64, f64)> = costs
                .iter()
                .filter(|c| c.0 == i)
                .map(|c| (c.1, c.2))
                .collect();
            t.sort_by(|a, b| a.0.total_cmp(&b.0));
            t.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-9);
            t
        })
        .collect();
    let at = |t: &[(f64, f64)], x: f64| -> f64 {
        let k = t.partition_point(|p| p.0 < x);
        if k == 0 {
            return t[0].1;
        }
        if k == t.len() {
            return t[t.len() - 1].1;
        }
        let (a, b) = (t[k - 1], t[k]);
        if !(a.1.is_finite() && b.1.is_finite()) {
            return f64::INFINITY;
        }
        a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
    };
    const ZETAS: [f64; 15] = [
        0.01, 0.015, 0.02, 0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0,
    ];
    // `f_r` in steps of at most 1 %.
    let n_f = ((f_hi / f_lo).ln() / 1.01f64.ln()).ceil() as usize;
    let mut best = (f64::INFINITY, f_hi, 1.0);
    // One pole: the corner alone.
    let zetas: &[f64] = if first_order { &[1.0] } else { &ZETAS };
    for f_r in logspace(f_lo, f_hi, n_f + 1) {
        for &zeta in zetas {
            let form = if first_order { 1.0 } else { 0.0 };
            let gain = |f: f64| response_gain(form, f, f_r, zeta);
            let c: f64 = freqs
                .iter()
                .zip(&tables)
                .map(|(&f, t)| at(t, gain(f).ln()))
                .sum();
            if c < best.0 {
                best = (c, f_r, zeta);
            }
        }
    }
    let mut m = m0.clone();
    let _ = m.effects.set_at(kind, actuator_response::F_R, best.1);
    if !first_order {
        let _ = m.effects.set_at(kind, actuator_response::ZETA, best.2);
    }
    Some(m)
}

/// Points of [`line_search`]: a resonance frequency from half to twice its fitted value in
/// steps of 4 %.
pub const LINE_POINTS: usize = 36;

/// The resonance frequencies [`line_search`] scans: the sensor's `f_n`. A lightly damped
/// sensor's cost along `f_n` is a narrow valley (about ±6 % wide) between a cliff below and a
/// slope above, so a local fit started outside it slides down the slope, away from it.
fn line_param(kind: EffectKind) -> Option<Param> {
    (kind == EffectKind::SensorDynamics).then_some(sensor_dynamics::F_N)
}

/// A dense scan of the resonance frequency of effect `kind` in the fit `fr` (the sensor's `f_n`;
/// nothing for the other effects, the actuator's resonance has [`actuator_scan`]) about its
/// optimum, the other parameters held at the fit's values: [`LINE_POINTS`] values from half to
/// twice it (within the range a fit allows, 10 Hz to 20 kHz), scored on `target`, the fit's own
/// recordings, at the search fidelity ([`Fidelity::Search`]: the point found only starts a full
/// fit). Returns the best point where it lies below the fit's own gap at that fidelity (a
/// start for a new fit), else `None`, and the number of models evaluated (each a simulation of
/// every recording of `target`, the fit's own point among them). Where the global scan of [`starts`] (steps of a factor 2.15) put the start on
/// the slope next to a narrow valley, the local fit stays on the slope; this finds the valley
/// within a factor 2 of the fit.
pub fn line_search(target: &Target, fr: &FitResult, kind: EffectKind) -> (Option<Model>, usize) {
    let Some(name) = line_param(kind) else {
        return (None, 0);
    };
    let Some(v0) = fr.model.effects.at(kind, name) else {
        return (None, 0);
    };
    let target = &target.at(Fidelity::Search);
    let (lo, hi) = target.bounds.range(kind, name);
    let values: Vec<f64> = logspace(0.5 * v0, 2.0 * v0, LINE_POINTS)
        .into_iter()
        .filter(|v| (lo..=hi).contains(v))
        .collect();
    let gaps: Vec<(f64, Model)> = values
        .par_iter()
        .map(|&v| {
            let mut m = fr.model.clone();
            let _ = m.effects.set_at(kind, name, v);
            (evaluate(target, &m), m)
        })
        .collect();
    // The fit's own point at the same fidelity, which the line's points must beat.
    let own = evaluate(target, &fr.model);
    let evaluations = gaps.len() + 1;
    // The lowest below the fit's gap; the first of equals (values in increasing order).
    let best = gaps
        .into_iter()
        .filter(|(g, _)| *g < own)
        .reduce(|a, b| if b.0 < a.0 { b } else { a });
    (best.map(|b| b.1), evaluations)
}

/// Most recordings [`starts`] scores its starts on.
pub const SCAN_RECORDINGS: usize = 8;

/// The recordings a start scan is scored on: all of them up to [`SCAN_RECORDINGS`]; else half
/// of that many where the model the candidate extends misses most (largest gap over the
/// recording's residuals `z`, rows as [`Target::row_recordings`]), the rest taken evenly over
/// the others in their order (the campaign's sorted names); each vibrated one with its
/// reference where the set has one. Why the worst ones: an effect that acts on a few
/// conditions (a sensor at the lowest forcing frequencies) is invisible on recordings chosen
/// by name, and the scan would start its fit where it cannot find them.
fn scan_subset<'a>(target: &Target<'a>, z: &[f64]) -> Target<'a> {
    subset(target, z, SCAN_RECORDINGS)
}

/// At most `most` recordings of `target` (with their references) chosen as for
/// [`SCAN_RECORDINGS`]: half where the model whose residuals are `z` misses most, the rest
/// evenly by name.
pub fn subset<'a>(target: &Target<'a>, z: &[f64], most: usize) -> Target<'a> {
    let n = target.recs.len();
    if n <= most {
        return target.sub(target.recs.clone());
    }
    let rows = target.row_recordings();
    let gaps: Option<Vec<f64>> = (rows.len() == z.len()).then(|| {
        let mut sum = vec![(0.0, 0usize); n];
        for (&r, v) in rows.iter().zip(z) {
            sum[r].0 += v * v;
            sum[r].1 += 1;
        }
        sum.iter()
            .map(|&(s, c)| if c == 0 { 0.0 } else { s / c as f64 })
            .collect()
    });
    let mut pick = choose(n, gaps.as_deref(), most);
    for k in 0..most {
        let i = pick[k];
        for u in target.units_of(i) {
            if let Some(r) = target.reference[u] {
                let j = target.units[r].0;
                if !pick.contains(&j) {
                    pick.push(j);
                }
            }
        }
    }
    pick.sort_unstable();
    target.sub(pick.into_iter().map(|i| target.recs[i]).collect())
}

/// `most` of `n` recordings (`most < n`): the `most/2` with the largest mean squared residual
/// `gaps` (ties to the lower index; none where `gaps` is unknown), then the rest spread evenly
/// by index over the others, by index arithmetic.
fn choose(n: usize, gaps: Option<&[f64]>, most: usize) -> Vec<usize> {
    let mut pick: Vec<usize> = vec![];
    if let Some(gaps) = gaps {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| gaps[b].total_cmp(&gaps[a]).then(a.cmp(&b)));
        pick.extend(order.into_iter().take(most / 2));
    }
    let rest: Vec<usize> = (0..n).filter(|i| !pick.contains(i)).collect();
    let k_rest = most - pick.len();
    pick.extend((0..k_rest).map(|k| rest[k * rest.len() / k_rest]));
    pick
}

/// Amplitude and wavelength of a sinusoidal drive error, from the recorded drive position:
/// a periodogram over 400 wavelengths from 20 µm to 5 mm, pooled over the recordings
/// (None when the recordings hold less than two wavelengths of travel).
fn ripple_from_drive(recs: &[&Recording]) -> Option<(f64, f64)> {
    let recs: Vec<(&Recording, &Vec<f64>)> = recs
        .iter()
        .filter_map(|r| r.x_d.as_ref().map(|x| (*r, x)))
        .collect();
    let travel = recs
        .iter()
        .map(|(r, _)| r.params.v_d * (r.t[r.t.len() - 1] - r.t[0]))
        .fold(0.0, f64::max);
    let n_l = 400;
    let (lmin, lmax) = (20e-6f64, (travel / 2.0).min(5e-3));
    if lmax <= lmin {
        return None;
    }
    let lambdas: Vec<f64> = (0..n_l)
        .map(|i| (lmin.ln() + (lmax.ln() - lmin.ln()) * i as f64 / (n_l - 1) as f64).exp())
        .collect();
    // Residuals of x_d about v_d t, decimated to at most 4000 points a recording.
    let series: Vec<(Vec<f64>, Vec<f64>)> = recs
        .iter()
        .map(|(r, x_d)| {
            let stride = (r.t.len() / 4000).max(1);
            let xs: Vec<f64> = (0..r.t.len())
                .step_by(stride)
                .map(|i| r.params.v_d * r.t[i])
                .collect();
            let res: Vec<f64> = (0..r.t.len())
                .step_by(stride)
                .map(|i| x_d[i] - r.params.v_d * r.t[i])
                .collect();
            let mean = res.iter().sum::<f64>() / res.len() as f64;
            (xs, res.into_iter().map(|v| v - mean).collect())
        })
        .collect();
    let power: Vec<(f64, f64)> = lambdas
        .par_iter()
        .map(|&l| {
            let k = std::f64::consts::TAU / l;
            let (mut pw, mut amp, mut n) = (0.0, 0.0, 0.0);
            for (xs, res) in &series {
                let (mut c, mut s) = (0.0, 0.0);
                for (x, r) in xs.iter().zip(res) {
                    c += r * (k * x).cos();
                    s += r * (k * x).sin();
                }
                let len = xs.len() as f64;
                pw += (c * c + s * s) / len;
                amp += 2.0 * (c * c + s * s).sqrt();
                n += len;
            }
            (pw, amp / n)
        })
        .collect();
    let best = (0..n_l).max_by(|&a, &b| power[a].0.total_cmp(&power[b].0))?;
    Some((power[best].1, lambdas[best]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The strong starts of a viscous scan: the strongest term within the margin of the
    /// lowest cost, each of its starts (base and nominal parameters), none past the jump.
    /// Costs of the second independent rig's `sensor+viscous` scan (linear form, 8 recordings).
    #[test]
    fn a_viscous_scan_keeps_its_strongest_start_short_of_the_jump() {
        let base = Model::default();
        let k = EffectKind::Viscous;
        let at = |h_v: f64, f_s: f64| {
            let mut m = neutral_start(&base, k, k.default_form());
            let _ = m.effects.set_at(k, viscous::H_V, h_v);
            m.f_s = f_s;
            m
        };
        let scan = [
            (at(0.0, 9.85), 47.65),
            (at(20.0, 11.5), 56.72),
            (at(20.0, 9.85), 47.55),
            (at(50.0, 11.5), 51.75),
            (at(50.0, 9.85), 48.04),
            (at(100.0, 11.5), 49.23),
            (at(100.0, 9.85), 49.50),
            (at(200.0, 11.5), 1.0e7),
            (at(200.0, 9.85), 2.8e6),
        ];
        let (models, costs): (Vec<Model>, Vec<f64>) = scan.iter().cloned().unzip();
        assert_eq!(strongest_near(k, &models, &costs, 2), vec![5, 6]);
        // A stronger term past the margin is not taken.
        let mut steep = costs.clone();
        (steep[5], steep[6]) = (53.0, 52.5);
        assert_eq!(strongest_near(k, &models, &steep, 2), vec![3, 4]);
        // Nothing stronger within it: none; nor for an effect the base fit does not absorb.
        assert!(strongest_near(k, &models, &costs, 6).is_empty());
        assert!(strongest_near(EffectKind::StribeckShape, &models, &costs, 2).is_empty());
    }

    /// The worst half is taken by gap, the rest evenly over the others, without repeats.
    #[test]
    fn subsets_hold_the_worst_recordings_and_spread_the_rest() {
        let mut gaps = vec![1.0; 30];
        for (i, g) in [(17, 9.0), (3, 7.0), (29, 5.0), (12, 4.0), (20, 3.0)] {
            gaps[i] = g;
        }
        let pick = choose(30, Some(&gaps), 16);
        assert_eq!(&pick[..8], &[17, 3, 29, 12, 20, 0, 1, 2]);
        let mut sorted = pick.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), 16, "{pick:?}");
        // The eight others: every third or so of the 22 left, from the first on.
        let rest: Vec<usize> = (0..30).filter(|i| !pick[..8].contains(i)).collect();
        assert_eq!(rest.len(), 22);
        let expect: Vec<usize> = (0..8).map(|k| rest[k * 22 / 8]).collect();
        assert_eq!(&pick[8..], &expect[..]);
        assert_eq!(&pick[8..], &[4, 6, 9, 13, 16, 19, 23, 26]);
        // Without residuals: evenly over all.
        assert_eq!(choose(30, None, 4), vec![0, 7, 15, 22]);
    }
}
