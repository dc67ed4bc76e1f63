//! Synthetic campaigns: the model plus chosen effects, recorded with sensor noise at a given
//! sampling rate, over a design of conditions like the paper's tests.

use super::{CampaignError, GridAsk, Recording, simulate_grids, write_recording};
use crate::model::effects::{amplitude_gain, load_swing, normal_coupling, track};
use crate::model::{EffectKind, Effects, Params};
use crate::sim;
use rand::{RngExt, SeedableRng, rngs::StdRng};
use rayon::prelude::*;
use std::path::Path;

/// Conditions of a synthetic campaign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Design {
    /// 30 recordings: 5 drives (v_d, k_d) = (0.5 mm/s, 11 700 N/m), (0.5, 17 900), (1, 11 700),
    /// (1, 20 000), (2, 17 900), whose stick-slip cycles span 0.18 to 1.1 s, × 6 vibrations
    /// (none; f = 1000, 1500, 2000 Hz at v_a/v_d = 0.3, 0.6, 0.9; 1000 Hz at 1.5; 500 Hz at 2).
    Full,
    /// 16 recordings: 4 drives (0.7 mm/s, 11 700 N/m), (1, 11 700), (1, 20 000), (2, 17 900) ×
    /// 4 vibrations (none; 1000 Hz at v_a/v_d = 0.4; 1500 Hz at 0.8; 1000 Hz at 1.5), for tests.
    Small,
}

impl std::str::FromStr for Design {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "full" => Ok(Design::Full),
            "small" => Ok(Design::Small),
            _ => Err(format!("unknown design `{s}`; allowed: full, small")),
        }
    }
}

/// Pairs of a design's conditions: `(v_d [m/s], k_d [N/m])` of a drive or `(f \[Hz\],
/// v_a/v_d)` of a vibration.
type Pairs = Vec<(f64, f64)>;

impl Design {
    /// `(v_d [m/s], k_d [N/m])` of each drive and `(f \[Hz\], v_a/v_d)` of each vibration.
    fn grid(self) -> (Pairs, Pairs) {
        match self {
            Design::Full => (
                vec![
                    (0.5e-3, 11_700.0),
                    (0.5e-3, 17_900.0),
                    (1e-3, 11_700.0),
                    (1e-3, 20_000.0),
                    (2e-3, 17_900.0),
                ],
                vec![
                    (0.0, 0.0),
                    (1000.0, 0.3),
                    (1500.0, 0.6),
                    (2000.0, 0.9),
                    (1000.0, 1.5),
                    (500.0, 2.0),
                ],
            ),
            Design::Small => (
                vec![
                    (0.7e-3, 11_700.0),
                    (1e-3, 11_700.0),
                    (1e-3, 20_000.0),
                    (2e-3, 17_900.0),
                ],
                vec![(0.0, 0.0), (1000.0, 0.4), (1500.0, 0.8), (1000.0, 1.5)],
            ),
        }
    }
}

/// What `synth` makes.
#[derive(Clone, Debug)]
pub struct SynthSpec {
    /// The true base parameters (conditions are set per recording).
    pub base: Params,
    /// The injected effects.
    pub effects: Effects,
    /// Conditions design.
    pub design: Design,
    /// Sampling rate \[Hz\]. Default 10 000. Range 1000 to 1e6.
    pub rate: f64,
    /// Force sensor noise, standard deviation \[N\]. Default 0.02. Range 0 to 1.
    pub noise_force: f64,
    /// Displacement sensor noise, standard deviation \[m\]. Default 5e-8. Range 0 to 1e-5.
    pub noise_x: f64,
    /// Stick-slip cycles in the second half of each recording (as `run --min-cycles`). Default 3.
    pub min_cycles: u32,
    /// Random seed (noise, drawn magnitudes, track offsets).
    pub seed: u64,
}

impl Default for SynthSpec {
    fn default() -> Self {
        SynthSpec {
            base: Params::default(),
            effects: Effects::none(),
            design: Design::Full,
            rate: 10_000.0,
            noise_force: 0.02,
            noise_x: 5e-8,
            min_cycles: 3,
            seed: 1,
        }
    }
}

/// A bad synthesis option.
#[derive(Debug, thiserror::Error)]
#[error("{field} = {value} is not allowed: {allowed}")]
pub struct SynthError {
    /// The option.
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// The range.
    pub allowed: String,
}

impl SynthSpec {
    /// Checks the options against their ranges.
    pub fn validate(&self) -> Result<(), SynthError> {
        let bad = |field, value, allowed: &str| {
            Err(SynthError {
                field,
                value,
                allowed: allowed.to_string(),
            })
        };
        if !(1000.0..=1e6).contains(&self.rate) {
            return bad("rate", self.rate, "1000 <= rate <= 1e6 Hz");
        }
        if !(0.0..=1.0).contains(&self.noise_force) {
            return bad("noise", self.noise_force, "0 <= noise <= 1 N");
        }
        if !(0.0..=1e-5).contains(&self.noise_x) {
            return bad("noise_x", self.noise_x, "0 <= noise_x <= 1e-5 m");
        }
        if !(1..=100).contains(&self.min_cycles) {
            return bad(
                "min_cycles",
                self.min_cycles as f64,
                "1 <= min_cycles <= 100",
            );
        }
        if let Some(k_n) = self
            .effects
            .at(EffectKind::NormalCoupling, normal_coupling::K_N)
            && let Some((name, p, u)) = self.largest_amplitude()
        {
            let per = self.swing_per_k_n(&p, u);
            let cap = MAX_LOAD_SWING * p.f_n / per;
            if k_n > cap {
                return Err(SynthError {
                    field: "effect",
                    value: k_n,
                    allowed: format!(
                        "normal_coupling's k_n at most {cap:.3e} N/m with this design and load: at recording {name} (substrate amplitude {u:.3e} m, F_N = {} N) it swings the normal load by {:.0} % of F_N, more than {:.0} % (the body lifts off at 100 %, which the model does not describe)",
                        p.f_n,
                        100.0 * k_n * per / p.f_n,
                        100.0 * MAX_LOAD_SWING
                    ),
                });
            }
        }
        Ok(())
    }

    /// The vibrated recording whose substrate amplitude is largest against its load, with its
    /// conditions and that amplitude \[m\]: `u0` times the injected actuator's gain at the
    /// recording's frequency, as the rig moves the substrate (1 without the actuator).
    /// (The largest swing of the load against it, for the form of `normal_coupling` injected:
    /// the displacement's, the velocity's or the acceleration's, or a fixed one.)
    fn largest_amplitude(&self) -> Option<(String, Params, f64)> {
        let gain = |f: f64| amplitude_gain(&self.effects, f);
        self.conditions()
            .into_iter()
            .filter(|(_, p)| p.u0 > 0.0)
            .map(|(name, p)| (name, p, p.u0 * gain(p.f)))
            .max_by(|a, b| {
                (self.swing_per_k_n(&a.1, a.2) / a.1.f_n)
                    .total_cmp(&(self.swing_per_k_n(&b.1, b.2) / b.1.f_n))
            })
    }

    /// Normal-load swing \[N\] per N/m of `k_n` at substrate amplitude `u` \[m\] in the
    /// conditions `p`, in the injected form of `normal_coupling` (the displacement's without it).
    fn swing_per_k_n(&self, p: &Params, u: f64) -> f64 {
        let form = self
            .effects
            .at(EffectKind::NormalCoupling, normal_coupling::FORM)
            .unwrap_or(0.0);
        load_swing(1.0, form, p.f, u)
    }

    /// The largest load modulation `k_n` \[N/m\] the design allows ([`MAX_LOAD_SWING`] at its
    /// largest amplitude); `None` without vibrated recordings.
    pub fn k_n_cap(&self) -> Option<f64> {
        self.largest_amplitude()
            .map(|(_, p, u)| MAX_LOAD_SWING * p.f_n / self.swing_per_k_n(&p, u))
    }

    /// The conditions of every recording, with names.
    pub fn conditions(&self) -> Vec<(String, Params)> {
        let (drives, vibs) = self.design.grid();
        let mut out = vec![];
        for (i, &(v_d, k_d)) in drives.iter().enumerate() {
            for (j, &(f, ratio)) in vibs.iter().enumerate() {
                let mut p = self.base;
                p.v_d = v_d;
                p.k_d = k_d;
                p.u0 = 0.0;
                if ratio > 0.0 {
                    p.f = f;
                    p.set_v_a(ratio * v_d);
                }
                out.push((format!("d{i}_v{j}"), p));
            }
        }
        out
    }
}

/// The largest swing of the normal load, `k_n u0 / F_N`, a synthetic recording may carry with
/// `normal_coupling` ([`SynthSpec::validate`]). At 1 the load reaches zero and the body lifts
/// off, which the model does not describe: the contact's relaxation rate `|v_r| k_t / F`
/// grows without bound as the load falls, and the integration fails (with the full design's
/// 500 Hz recording at `v_d` = 2 mm/s, `u0` = 1.27 µm, every `k_n` above 2.9e7 N/m does). Half
/// keeps a margin.
pub const MAX_LOAD_SWING: f64 = 0.5;

/// Draws every parameter of `kind` with realistic magnitudes
/// ([`EffectInfo::realistic`](crate::model::effects::EffectInfo::realistic)) with `rng`, within what `spec`'s
/// design allows: the load modulation's `k_n` at most [`SynthSpec::k_n_cap`] (its realistic
/// range is then that cap and down to a third of it, where the cap lies below the range).
///
/// The effect takes the form it has in `spec.effects` where it is there (its first form
/// otherwise), and the magnitudes of that form.
pub fn draw(kind: EffectKind, rng: &mut StdRng, spec: &SynthSpec) -> Effects {
    let mut fx = Effects::none();
    fx.enable(kind);
    if let Some(v) = spec.effects.form_value(kind) {
        fx.set_form_value(kind, v)
            .expect("a form the spec holds is valid");
    }
    for r in kind.info().realistic {
        let (k, lo, hi) = (kind, r.lo, r.hi);
        if hi <= lo {
            continue;
        }
        let cap = (k == EffectKind::NormalCoupling && r.param == normal_coupling::K_N)
            .then(|| spec.k_n_cap())
            .flatten();
        let (lo, hi) = match cap {
            Some(cap) if cap < hi => (lo.min(cap / 3.0), cap),
            _ => (lo, hi),
        };
        let log = r.param.of(kind).log();
        let u: f64 = rng.random();
        let v = if log {
            (lo.ln() + u * (hi.ln() - lo.ln())).exp()
        } else {
            lo + u * (hi - lo)
        };
        fx.set_at(kind, r.param, v)
            .expect("realistic ranges lie within the bounds");
    }
    fx
}

/// Simulates and writes a campaign into `dir` (created if needed). Returns the recordings.
pub fn synth(dir: &Path, spec: &SynthSpec) -> Result<Vec<Recording>, CampaignError> {
    spec.validate().map_err(|e| CampaignError::Io {
        path: dir.display().to_string(),
        msg: e.to_string(),
    })?;
    let dt = 1.0 / spec.rate;
    let conds: Vec<(String, Params, usize)> = spec
        .conditions()
        .into_iter()
        .map(|(name, p)| {
            let t_end = sim::planned_time(&p, spec.min_cycles);
            let n = (t_end / dt).floor() as usize + 1;
            (name, p, n)
        })
        .collect();
    let recs = record(&conds, dt, spec)?;
    std::fs::create_dir_all(dir).map_err(|e| super::io(dir, e))?;
    for rec in &recs {
        write_recording(dir, rec)?;
    }
    Ok(recs)
}

/// Simulates recordings of the given conditions (name, conditions, samples at spacing `dt`)
/// with `spec`'s effects and noise, each from its own random stream.
fn record(
    conds: &[(String, Params, usize)],
    dt: f64,
    spec: &SynthSpec,
) -> Result<Vec<Recording>, CampaignError> {
    // Each recording's own random stream (the same campaign whatever the thread count), its
    // effects (a track's offset drawn first from that stream) and its simulation; the
    // simulations run together, side by side in vector lanes where they can.
    let mut rngs = Vec::with_capacity(conds.len());
    let mut asks = Vec::with_capacity(conds.len());
    for (i, (_, p, n)) in conds.iter().enumerate() {
        let mut rng =
            StdRng::seed_from_u64(spec.seed.wrapping_mul(1_000_003).wrapping_add(i as u64));
        let mut fx = spec.effects.clone();
        if let Some(lambda) = fx.at(EffectKind::Track, track::WAVELENGTH) {
            // Each recording starts at another place on the track.
            let off: f64 = rng.random::<f64>() * lambda;
            fx.set_at(EffectKind::Track, track::OFFSET, off)
                .expect("in range");
        }
        rngs.push(rng);
        asks.push(GridAsk {
            p: *p,
            fx,
            t0: 0.0,
            dt,
            n: *n,
            tol: 1e-6,
        });
    }
    let sims = simulate_grids(&asks);
    let recs: Vec<Result<Recording, CampaignError>> = conds
        .par_iter()
        .zip(rngs)
        .zip(sims)
        .map(|(((name, p, _), mut rng), (tr, _))| {
            let tr = tr.map_err(|e| CampaignError::Io {
                path: name.clone(),
                msg: e.to_string(),
            })?;
            if tr.status != crate::ode::Status::Success {
                return Err(CampaignError::Io {
                    path: name.clone(),
                    msg: format!("simulation ended with {}", tr.status.name()),
                });
            }
            let n = tr.f_d.len();
            let mut noise = |s: f64| s * rng.sample::<f64, _>(rand_distr::StandardNormal);
            let rec = Recording {
                name: name.clone(),
                params: *p,
                t: (0..n).map(|k| k as f64 * dt).collect(),
                f_d: tr.f_d.iter().map(|v| v + noise(spec.noise_force)).collect(),
                x_s: Some(tr.x_s.iter().map(|v| v + noise(spec.noise_x)).collect()),
                x_d: Some(tr.x_d.iter().map(|v| v + noise(spec.noise_x)).collect()),
            };
            Ok(rec)
        })
        .collect();
    // Written only once every recording is simulated: a run that fails leaves no campaign
    // that looks complete with a recording missing.
    recs.into_iter().collect()
}

/// One planned recording's conditions file (`stickslip plan`): its stem, its conditions on
/// `base` (every key of the file but the `plan` table), its duration \[s\] and rate \[Hz\]
/// (from the `plan` table), and the file's text.
pub fn read_planned(
    path: &Path,
    base: &Params,
) -> Result<(String, Params, f64, f64, String), CampaignError> {
    let mut doc = crate::config::Doc::read(path)?;
    let plan = doc.table.remove("plan");
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let bad = |msg: String| CampaignError::Malformed {
        file: path.display().to_string(),
        line: 0,
        msg,
    };
    let plan = plan
        .and_then(|v| v.as_table().cloned())
        .ok_or_else(|| bad("no `[plan]` table: not a conditions file a plan wrote".into()))?;
    let get = |k: &str, lo: f64, hi: f64| -> Result<f64, CampaignError> {
        let v = plan
            .get(k)
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            .ok_or_else(|| bad(format!("`plan.{k}` missing or not a number")))?;
        if !(lo..=hi).contains(&v) {
            return Err(bad(format!("`plan.{k}` = {v}: allowed {lo} to {hi}")));
        }
        Ok(v)
    };
    let duration = get("duration", 0.01, 3600.0)?;
    let rate = get("rate", 1000.0, 1e6)?;
    let mut p = *base;
    let table = doc.table.clone();
    let rest = crate::config::apply_params(&doc, "", &table, &mut p)?;
    if let Some(k) = rest.first() {
        return Err(doc
            .err("", k, "unknown key in a planned recording's conditions")
            .into());
    }
    let text = std::fs::read_to_string(path).map_err(|e| super::io(path, e))?;
    Ok((stem, p, duration, rate, text))
}

/// Records the recordings a plan proposes (every conditions file with a `[plan]` table in
/// `plan_dir`) into `dir`, with `spec`'s effects, base parameters and noise: each `NAME.csv`
/// beside a copy of its `NAME.toml`, so that the campaign they join counts them as planned.
/// A plan's rate is the same for all of its recordings (its design space's).
pub fn synth_planned(
    dir: &Path,
    plan_dir: &Path,
    spec: &SynthSpec,
) -> Result<Vec<Recording>, CampaignError> {
    spec.validate().map_err(|e| CampaignError::Io {
        path: dir.display().to_string(),
        msg: e.to_string(),
    })?;
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(plan_dir)
        .map_err(|e| super::io(plan_dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    let mut planned = vec![];
    for f in &files {
        planned.push(read_planned(f, &spec.base)?);
    }
    if planned.is_empty() {
        return Err(CampaignError::Malformed {
            file: plan_dir.display().to_string(),
            line: 0,
            msg: "no planned conditions (NAME.toml with a [plan] table) in this directory".into(),
        });
    }
    let rate = planned[0].3;
    if let Some(other) = planned.iter().find(|x| x.3 != rate) {
        return Err(CampaignError::Malformed {
            file: other.0.clone(),
            line: 0,
            msg: format!(
                "rate {} differs from the plan's {rate}; record one plan at one rate",
                other.3
            ),
        });
    }
    let dt = 1.0 / rate;
    let conds: Vec<(String, Params, usize)> = planned
        .iter()
        .map(|(name, p, dur, _, _)| (name.clone(), *p, (dur / dt).floor() as usize + 1))
        .collect();
    let recs = record(&conds, dt, spec)?;
    std::fs::create_dir_all(dir).map_err(|e| super::io(dir, e))?;
    for (rec, (_, _, _, _, text)) in recs.iter().zip(&planned) {
        write_recording(dir, rec)?;
        let path = dir.join(format!("{}.toml", rec.name));
        std::fs::write(&path, text).map_err(|e| super::io(&path, e))?;
    }
    Ok(recs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::{Solvers, simulate_grid};

    /// The full design's strongest drawn load modulation used to lift the body off at its
    /// 500 Hz, 2 mm/s recording, where the integration failed (`synth --draw normal_coupling
    /// --seed 1`). Draws now stay under the cap, a value above it is refused with the recording
    /// named, and the worst recording at the cap integrates.
    #[test]
    fn the_load_modulation_stays_below_lift_off() {
        let full = SynthSpec::default();
        let small = SynthSpec {
            design: Design::Small,
            ..SynthSpec::default()
        };
        // In the acceleration's form the swing grows with f²: the worst recording is another,
        // the cap follows it, and a drawn k_n stays under it in that form.
        let mut accel = SynthSpec::default();
        accel
            .effects
            .set_form(EffectKind::NormalCoupling, "acceleration")
            .unwrap();
        let (worst_a, p_a, u_a) = accel.largest_amplitude().unwrap();
        let cap_a = accel.k_n_cap().unwrap();
        let swing = crate::model::effects::load_swing(cap_a, 2.0, p_a.f, u_a);
        assert!((swing - MAX_LOAD_SWING * p_a.f_n).abs() < 1e-9, "{worst_a}");
        for seed in 0..10 {
            let mut rng = StdRng::seed_from_u64(seed);
            let fx = draw(EffectKind::NormalCoupling, &mut rng, &accel);
            assert_eq!(
                fx.form(EffectKind::NormalCoupling).unwrap().name,
                "acceleration"
            );
            let k_n = fx.get(EffectKind::NormalCoupling, "k_n").unwrap();
            assert!(k_n <= cap_a, "seed {seed}: {k_n} for cap {cap_a}");
        }
        let cap = full.k_n_cap().unwrap();
        // The largest amplitude: 2 mm/s at 500 Hz and v_a/v_d = 2, u0 = 1.27 µm.
        let (name, worst, _) = full.largest_amplitude().unwrap();
        assert_eq!(name, "d4_v5");
        assert!((cap - MAX_LOAD_SWING * worst.f_n / worst.u0).abs() < 1e-6 * cap);
        for seed in 0..40 {
            let mut rng = StdRng::seed_from_u64(seed);
            let k_n = draw(EffectKind::NormalCoupling, &mut rng, &full)
                .get(EffectKind::NormalCoupling, "k_n")
                .unwrap();
            assert!(
                (cap / 3.0..=cap).contains(&k_n),
                "seed {seed}: {k_n} for cap {cap}"
            );
            // Other effects draw the same whatever the design.
            let a = |spec: &SynthSpec| {
                draw(EffectKind::Aging, &mut StdRng::seed_from_u64(seed), spec)
                    .get(EffectKind::Aging, "b")
            };
            assert_eq!(a(&full), a(&small));
        }
        let mut strong = full.clone();
        strong.effects.enable(EffectKind::NormalCoupling);
        strong
            .effects
            .set(EffectKind::NormalCoupling, "k_n", 1.01 * cap)
            .unwrap();
        let e = strong.validate().unwrap_err();
        assert_eq!(e.field, "effect");
        assert!(e.allowed.contains("d4_v5"), "{}", e.allowed);
        strong
            .effects
            .set(EffectKind::NormalCoupling, "k_n", cap)
            .unwrap();
        strong.validate().unwrap();
        // An actuator resonating at 1000 Hz moves the substrate five times as far there: the
        // same k_n then lifts the 1000 Hz recordings off and is refused, naming one of them.
        let mut actuated = strong.clone();
        actuated.effects.enable(EffectKind::ActuatorResponse);
        actuated
            .effects
            .set(EffectKind::ActuatorResponse, "f_r", 1000.0)
            .unwrap();
        actuated
            .effects
            .set(EffectKind::ActuatorResponse, "zeta", 0.1)
            .unwrap();
        let e = actuated.validate().unwrap_err();
        assert!(e.allowed.contains("d4_v4"), "{}", e.allowed);
        assert!(actuated.k_n_cap().unwrap() < 0.6 * cap);
        // The worst recording at the cap integrates, as synth does it (a second of it).
        let dt = 1e-4;
        let tr = simulate_grid(
            &worst,
            &strong.effects,
            0.0,
            dt,
            10_001,
            1e-6,
            &mut Solvers::default(),
        )
        .unwrap();
        assert_eq!(tr.status, crate::ode::Status::Success);
    }
}
