//! Command-line arguments (clap) and their translation into validated configurations.
//! Nothing here runs a simulation: [`crate::app`] does, from what this module resolves.

// The doc comments here are also clap's help text, where units in brackets ([s], [N]) and
// placeholders (<stem>) read as written; rustdoc would take them for links and HTML.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]

use crate::config::{self, Case};
use crate::model::Params;
use crate::model::params::{PARAMS, ParamInfo};
use crate::ode::Method;
use crate::sim::{EarlyStop, RunOptions};
use clap::{Arg, ArgAction, ArgMatches, Args, FromArgMatches, Parser, Subcommand};
use std::path::{Path, PathBuf};

/// Maps where tangential substrate vibration suppresses stick-slip friction.
#[derive(Parser, Debug)]
#[command(name = "stickslip", version, about, long_about = None, max_term_width = 100)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Simulate one case (and its reference without vibration); print r, dF, the mean force and
    /// solver statistics; write the traces to HDF5 (and CSV, plots on request).
    Run(RunArgs),
    /// Run a grid from a TOML sweep file in parallel; write one HDF5 file of maps (r, dF, mean
    /// force, ..., solver statistics), its plots and, with an amplitude axis, the elimination
    /// boundary. Interrupted sweeps resume with --resume.
    Sweep(SweepArgs),
    /// Draw the figures of a sweep file: Fig. 10a/10b, Fig. 11a/11b and the (u0, f) map of r
    /// with the elimination boundary, as PNG and SVG.
    Plot(PlotArgs),
    /// Compute the elimination boundary of a sweep file (for each f, the smallest u0 with
    /// r < 0.05), store it in the file (group `boundary`) and write it as CSV.
    Boundary(BoundaryArgs),
    /// Work-precision benchmark of the integrators: for each case and method a ladder of
    /// tolerances, error against a tight reference (r, mean force, dF) and time, RHS
    /// evaluations, steps, Jacobians; to HDF5 and work-precision diagrams.
    Bench(BenchArgs),
    /// Write a synthetic campaign: the model plus chosen effects, recorded with sensor noise at
    /// a sampling rate, over a design of drive and vibration conditions.
    Synth(SynthArgs),
    /// Fit the uncertain base parameters (F_s, F_c, v_s, h_d; and an effect's with --effect) to
    /// a campaign's recordings by least squares on their features; report them with
    /// uncertainties.
    Calibrate(CalibrateArgs),
    /// Assemble the shards of a sweep (`sweep --shard I/N`, `slurm`) from OUT.h5.shards/ into
    /// OUT.h5, the file one machine would have written, with its plots and boundary.
    Merge(MergeArgs),
    /// How far a sweep has come, on one machine or in shards: runs recorded of each shard.
    Status(StatusArgs),
    /// Run a sweep on a Slurm cluster as a job array (one task per shard) and a merge job:
    /// write both scripts beside the output and, with --submit, submit them with sbatch.
    Slurm(SlurmArgs),
    /// Diagnose the sim-to-real gap of a campaign: calibrate on a split, locate the gap by
    /// feature, phase and condition, rank the candidate effects by held-out gap reduction,
    /// decide, quantify; terminal summary, JSON, HDF5 and plots.
    Diagnose(DiagnoseArgs),
    /// Plan the next recordings: the ones that best tell apart the explanations a campaign's
    /// diagnosis leaves standing, within the rig's design space, checked by simulation; one
    /// conditions file per recording, plan.json, plan.png.
    Plan(PlanArgs),
    /// Examine a campaign's acquisition before any fit: gaps, clipped channels, mains lines,
    /// the vibration's clock, quantisation, the noise's colour, the force's zero drift and
    /// gain; what `diagnose` would set aside or correct.
    Preflight(PreflightArgs),
}

/// Arguments of `stickslip preflight`.
#[derive(Args, Debug)]
pub struct PreflightArgs {
    /// Campaign directory.
    pub campaign: PathBuf,
    /// Also write every recording's findings as JSON to FILE (`-`: standard output, the
    /// summary then to standard error).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

/// Arguments of `stickslip plan`.
#[derive(Args, Debug)]
pub struct PlanArgs {
    /// Campaign directory.
    pub campaign: PathBuf,
    /// Recordings to plan (1 to 30).
    #[arg(long, default_value_t = 6)]
    pub recordings: usize,
    /// Design space file (TOML: springs, v_d, f, va_ratio, max_u0, max_duration, rate, t_on);
    /// default: the campaign's own ranges.
    #[arg(long, value_name = "FILE")]
    pub space: Option<PathBuf>,
    /// Output directory for the planned conditions files and the figure. Default
    /// results/plan-NAME.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// JSON plan file. Default OUT/plan.json.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// The campaign's diagnosis (diagnosis.json) to plan from. Default: results/diagnose-NAME/
    /// or OUT/ where one of these recordings and this version lies there; else one is run and
    /// written to OUT/diagnosis.json.
    #[arg(long, value_name = "FILE")]
    pub diagnosis: Option<PathBuf>,
    /// Candidates whose rivals' Jacobians are differenced (at least --recordings, at most 200).
    #[arg(long, default_value_t = 24)]
    pub finalists: usize,
    /// Skip the check by simulation (each rival as the truth, every rival refitted).
    #[arg(long)]
    pub no_check: bool,
    /// Seed of the simulated noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Where the diagnosis names an effect only in part and tried nothing beside it, fit each
    /// candidate beside it first and keep those that lower its gap as rivals (minutes more).
    #[arg(long)]
    pub second_effects: bool,
    /// Draw the recordings at random from the design space (seeded by --seed) instead of
    /// choosing them: the baseline a plan must beat.
    #[arg(long)]
    pub random: bool,
    /// Skip the figure.
    #[arg(long)]
    pub no_plots: bool,
}

impl PlanArgs {
    /// The plan's options, checked, and its output folder and JSON file.
    pub fn resolve(&self) -> Result<(crate::planning::PlanOptions, PathBuf, PathBuf), CliError> {
        let o = crate::planning::PlanOptions {
            recordings: self.recordings,
            finalists: self.finalists.max(self.recordings),
            check: !self.no_check,
            seed: self.seed,
            second_effects: self.second_effects,
            random: self.random,
        };
        o.validate().map_err(|e| match e {
            crate::planning::PlanError::Option {
                field,
                value,
                allowed,
            } => CliError::Flag {
                flag: field.into(),
                value,
                msg: allowed,
            },
            other => CliError::Flag {
                flag: "recordings".into(),
                value: self.recordings.to_string(),
                msg: other.to_string(),
            },
        })?;
        let name = self
            .campaign
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "campaign".into());
        let out = self
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("results").join(format!("plan-{name}")));
        if out.exists() && !out.is_dir() {
            return Err(CliError::Flag {
                flag: "out".into(),
                value: out.display().to_string(),
                msg: "is a file; give a folder for the plan".into(),
            });
        }
        let json = self.json.clone().unwrap_or_else(|| out.join("plan.json"));
        let inputs = campaign_files(&self.campaign);
        let mut inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        if let Some(s) = &self.space {
            inputs.push(s);
        }
        if let Some(d) = &self.diagnosis {
            inputs.push(d);
        }
        check_output("json", &json, &inputs)?;
        if same_file(&out, &self.campaign) {
            return Err(CliError::Flag {
                flag: "out".into(),
                value: out.display().to_string(),
                msg: "is the campaign itself; a plan is written beside it, and its recordings are copied in once recorded".into(),
            });
        }
        check_output("out", &out.join("plan.json"), &inputs)?;
        Ok((o, out, json))
    }
}

/// Arguments of `stickslip synth`.
#[derive(Args, Debug)]
pub struct SynthArgs {
    /// Campaign directory to write (created if needed).
    pub dir: PathBuf,
    /// Inject an effect with given parameters: `--effect aging:b=0.03`. Repeatable.
    #[arg(long = "effect", value_name = "NAME[:k=v,..]")]
    pub effects: Vec<String>,
    /// Inject an effect with magnitudes drawn from its realistic range (with --seed).
    #[arg(long, value_name = "NAME")]
    pub draw: Option<String>,
    /// The form of the drawn effect (`--draw normal_coupling --form velocity`; its forms:
    /// docs/running.md, "Effects"). Default: the effect's first form.
    #[arg(long, value_name = "FORM", requires = "draw")]
    pub form: Option<String>,
    /// Conditions: full (30 recordings: 5 drives x 6 vibrations) or small (16: 4 x 4).
    #[arg(long, default_value = "full")]
    pub design: String,
    /// Sampling rate [Hz] (1000 to 1e6).
    #[arg(long, default_value_t = 10_000.0)]
    pub rate: f64,
    /// Force sensor noise, standard deviation [N] (0 to 1).
    #[arg(long, default_value_t = 0.02)]
    pub noise: f64,
    /// Displacement sensor noise, standard deviation [m] (0 to 1e-5).
    #[arg(long, default_value_t = 5e-8)]
    pub noise_x: f64,
    /// Stick-slip cycles in the second half of each recording (1 to 100).
    #[arg(long, default_value_t = 3)]
    pub min_cycles: u32,
    /// Random seed (noise, drawn magnitudes, track offsets).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Also write the injected truth (effects, base parameters) as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
    /// Replace recordings already in the directory.
    #[arg(long)]
    pub overwrite: bool,
    /// Record the conditions a plan proposes (`stickslip plan`'s output folder: every NAME.toml
    /// with a [plan] table) instead of a design, each with its duration and rate.
    #[arg(long, value_name = "PLANDIR", conflicts_with = "design")]
    pub conditions: Option<PathBuf>,
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Arguments of `stickslip calibrate`.
#[derive(Args, Debug)]
pub struct CalibrateArgs {
    /// Campaign directory.
    pub campaign: PathBuf,
    /// Also fit this effect's parameters.
    #[arg(long, value_name = "NAME")]
    pub effect: Option<String>,
    /// Levenberg-Marquardt iterations at most (1 to 100).
    #[arg(long, default_value_t = 12)]
    pub max_iter: usize,
    /// Write the estimates as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Set implausible recordings aside (a flat channel, a force or travel off by orders of
    /// magnitude, x_d against v_d, spikes) and fit the rest, listing them; default: refuse.
    #[arg(long)]
    pub skip_implausible: bool,
}

/// Arguments of `stickslip diagnose`.
#[derive(Args, Debug)]
pub struct DiagnoseArgs {
    /// Campaign directory.
    pub campaign: PathBuf,
    /// Output directory for the HDF5 details and the plots. Default results/diagnose-NAME.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// JSON verdict file. Default OUT/diagnosis.json.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Set implausible recordings aside (a flat channel, a force or travel off by orders of
    /// magnitude, x_d against v_d, spikes) and diagnose the rest, listing them in the report
    /// and the JSON; default: refuse.
    #[arg(long)]
    pub skip_implausible: bool,
    /// Candidate effects (comma-separated). Default: all nine.
    #[arg(long, value_delimiter = ',')]
    pub candidates: Vec<String>,
    /// Levenberg-Marquardt iterations at most per fit (1 to 100).
    #[arg(long, default_value_t = 12)]
    pub max_iter: usize,
    /// Fit and rank the candidates even where the held-out gap is within noise (verdict
    /// no_significant_gap); by default none is fitted there and the ranking is empty.
    #[arg(long)]
    pub rank_always: bool,
    /// Skip the detection limits (what the campaign could not have seen: each effect's weakest
    /// strength that would have shown, computed where the model in hand leaves no gap).
    #[arg(long)]
    pub no_limits: bool,
    /// Skip the plots.
    #[arg(long)]
    pub no_plots: bool,
}

/// The effect `name` of a flag that takes an effect's name alone (`calibrate --effect`,
/// `synth --draw`, `diagnose --candidates`): its parameters are fitted or drawn, so `NAME:k=v`
/// is refused, naming the effect it would be.
fn effect_flag(flag: &str, name: &str) -> Result<crate::model::EffectKind, CliError> {
    use crate::model::EffectKind;
    EffectKind::from_name(name).ok_or_else(|| {
        let head = name.split_once(':').map(|(h, _)| h.trim());
        let msg = match head.and_then(EffectKind::from_name) {
            Some(k) => format!(
                "`{}` is an effect, but --{flag} takes its name alone, without parameters (they \
                 are fitted or drawn here): give --{flag} {}",
                k.name(),
                k.name()
            ),
            None => format!(
                "unknown effect; allowed: {}",
                crate::model::effects::names().join(", ")
            ),
        };
        CliError::Flag {
            flag: flag.into(),
            value: name.into(),
            msg,
        }
    })
}

fn iter_flag(n: usize) -> Result<(), CliError> {
    if !(1..=100).contains(&n) {
        return Err(CliError::Flag {
            flag: "max-iter".into(),
            value: n.to_string(),
            msg: "must be from 1 to 100".into(),
        });
    }
    Ok(())
}

impl SynthArgs {
    /// Resolves the flags into a validated synthesis.
    pub fn resolve(&self) -> Result<crate::campaign::synth::SynthSpec, CliError> {
        use crate::campaign::synth::{SynthSpec, draw};
        if let Some(plan) = &self.conditions {
            let bad = |msg: &str| CliError::Flag {
                flag: "conditions".into(),
                value: plan.display().to_string(),
                msg: msg.into(),
            };
            if !plan.exists() {
                return Err(bad(
                    "no such folder; give the folder a plan wrote (stickslip plan --out)",
                ));
            }
            if !plan.is_dir() {
                return Err(bad(
                    "is a file; give the folder a plan wrote (stickslip plan --out)",
                ));
            }
        }
        let mut spec = SynthSpec {
            design: self.design.parse().map_err(|msg| CliError::Flag {
                flag: "design".into(),
                value: self.design.clone(),
                msg,
            })?,
            rate: self.rate,
            noise_force: self.noise,
            noise_x: self.noise_x,
            min_cycles: self.min_cycles,
            seed: self.seed,
            ..SynthSpec::default()
        };
        for (name, v) in &self.params.values {
            spec.base
                .set(name, *v)
                .expect("flag names are parameter names");
        }
        spec.base.validate().map_err(|e| CliError::Flag {
            flag: "params".into(),
            value: String::new(),
            msg: e.to_string(),
        })?;
        if let Some(name) = &self.draw {
            let kind = effect_flag("draw", name)?;
            use rand::SeedableRng;
            let mut rng = rand::rngs::StdRng::seed_from_u64(self.seed ^ 0x5eed);
            // The form first: the load modulation's cap depends on how its swing scales.
            if let Some(form) = &self.form {
                spec.effects
                    .set_form(kind, form)
                    .map_err(|err| CliError::Flag {
                        flag: "form".into(),
                        value: form.clone(),
                        msg: err.to_string(),
                    })?;
            }
            spec.effects = draw(kind, &mut rng, &spec);
        }
        once_each(&self.effects)?;
        for e in &self.effects {
            spec.effects.apply_spec(e).map_err(|err| CliError::Flag {
                flag: "effect".into(),
                value: e.clone(),
                msg: err.to_string(),
            })?;
        }
        spec.validate().map_err(|e| CliError::Flag {
            flag: e.field.replace('_', "-"),
            value: e.value.to_string(),
            msg: e.allowed.to_string(),
        })?;
        Ok(spec)
    }
}

/// The files of a campaign directory (its recordings and metadata): inputs that no output may
/// replace.
fn campaign_files(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default()
}

impl CalibrateArgs {
    /// The effect to fit with the base parameters, checked.
    pub fn resolve(&self) -> Result<Option<crate::model::EffectKind>, CliError> {
        iter_flag(self.max_iter)?;
        if let Some(json) = &self.json {
            let inputs = campaign_files(&self.campaign);
            let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
            check_output("json", json, &inputs)?;
        }
        self.effect
            .as_deref()
            .map(|n| effect_flag("effect", n))
            .transpose()
    }
}

impl DiagnoseArgs {
    /// Candidates and fit options, checked.
    pub fn resolve(&self) -> Result<crate::diagnosis::diagnose::DiagnoseOptions, CliError> {
        iter_flag(self.max_iter)?;
        if let Some(json) = &self.json {
            let inputs = campaign_files(&self.campaign);
            let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
            check_output("json", json, &inputs)?;
        }
        let mut o = crate::diagnosis::diagnose::DiagnoseOptions::default();
        if !self.candidates.is_empty() {
            o.candidates = self
                .candidates
                .iter()
                .map(|n| effect_flag("candidates", n))
                .collect::<Result<_, _>>()?;
            // Each candidate is fitted once: a repeat would be fitted twice, and disagree.
            for (i, k) in o.candidates.iter().enumerate() {
                if o.candidates[..i].contains(k) {
                    return Err(CliError::Flag {
                        flag: "candidates".into(),
                        value: self.candidates.join(","),
                        msg: format!("`{}` is listed twice; list each candidate once", k.name()),
                    });
                }
            }
        }
        o.fit.max_iter = self.max_iter;
        o.rank_always = self.rank_always;
        o.limits = !self.no_limits;
        Ok(o)
    }
}

/// Arguments of `stickslip bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Cases (comma-separated): no_vibration, partial, eliminated, partial_3k, eliminated_4k,
    /// slow_corner, low_frequency. Default: all.
    #[arg(long, value_delimiter = ',')]
    pub cases: Vec<String>,
    /// Methods (comma-separated). Default: radau5,rodas4,dopri5,auto.
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<Method>,
    /// Tolerance ladder, rtol = atol (comma-separated). Default: 1e-3,...,1e-8.
    #[arg(long, value_delimiter = ',')]
    pub tolerances: Vec<f64>,
    /// Tolerance of the reference runs (1e-13 to 1e-6). Default 1e-11.
    #[arg(long, default_value_t = 1e-11)]
    pub reference_tolerance: f64,
    /// Envelope-following tolerances to try with each method (comma-separated, `none` for every
    /// period integrated; 1e-8 to 0.1). Default: none.
    #[arg(long, value_delimiter = ',')]
    pub envelopes: Vec<String>,
    /// Timed repeats per point (median reported), 1 to 100.
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Tiers (comma-separated): full (every method and envelope), averaged (one more setting:
    /// the averaged slow model) and hybrid (one more: hybrid windows, auto with envelope 1e-4
    /// inside them); each builds its table afresh for every repeat. Default: full.
    #[arg(long, value_delimiter = ',', value_name = "TIERS")]
    pub tiers: Vec<crate::sim::Tier>,
    /// Output HDF5 file; diagrams go beside it (<stem>_<case>.png/.svg). With --batch: the
    /// JSON of the batch benchmark goes to <stem>_batch.json.
    #[arg(short, long, default_value = "results/bench.h5")]
    pub out: PathBuf,
    /// Instead of the work-precision ladder: whole sweep runs per second and core on the
    /// scalar path and on the batch path (vector lanes), side by side, their results compared
    /// bit for bit. Takes --methods (one of dopri5, auto; default dopri5), --envelopes (one;
    /// default 1e-4), --repeats and --points.
    #[arg(long)]
    pub batch: bool,
    /// Points of the batch benchmark (1 to 100000), spread over the full model's region below
    /// the contact resonance. Default 64.
    #[arg(long, value_name = "N", requires = "batch")]
    pub points: Option<usize>,
}

impl BenchArgs {
    /// Validates and resolves the options of `--batch`.
    pub fn resolve_batch(&self) -> Result<crate::bench::batch::BatchBenchOptions, CliError> {
        let o = self.resolve()?;
        let mut b = crate::bench::batch::BatchBenchOptions {
            repeats: o.repeats,
            ..Default::default()
        };
        let bad = |flag: &str, value: String, msg: &str| CliError::Flag {
            flag: flag.into(),
            value,
            msg: msg.into(),
        };
        let one = "with --batch give one value";
        if let Some(n) = self.points {
            if !(1..=100_000).contains(&n) {
                return Err(bad("points", n.to_string(), "must be from 1 to 100000"));
            }
            b.points = n;
        }
        match self.methods.as_slice() {
            [] => {}
            [m] if crate::bench::batch::lane_method(*m) => b.method = *m,
            [m] => {
                return Err(bad(
                    "methods",
                    m.to_string(),
                    "the lanes serve dopri5 and auto; give one of them",
                ));
            }
            ms => return Err(bad("methods", format!("{ms:?}"), one)),
        }
        match o.envelopes.as_slice() {
            _ if self.envelopes.is_empty() => {}
            [e] => b.envelope = *e,
            _ => return Err(bad("envelopes", self.envelopes.join(","), one)),
        }
        if !self.cases.is_empty() || !self.tolerances.is_empty() || !self.tiers.is_empty() {
            return Err(bad(
                "batch",
                "true".into(),
                "--batch runs its own points at the sweep's tolerance on the full tier: \
                 --cases, --tolerances and --tiers do not apply",
            ));
        }
        Ok(b)
    }

    /// Validates and resolves the benchmark options.
    pub fn resolve(&self) -> Result<crate::bench::BenchOptions, CliError> {
        let mut o = crate::bench::BenchOptions::default();
        let known: Vec<&str> = crate::bench::cases().iter().map(|c| c.name).collect();
        for c in &self.cases {
            if !known.contains(&c.as_str()) {
                return Err(CliError::Flag {
                    flag: "cases".into(),
                    value: c.clone(),
                    msg: format!("unknown case; allowed: {}", known.join(", ")),
                });
            }
        }
        o.cases = self.cases.clone();
        if !self.methods.is_empty() {
            o.methods = self.methods.clone();
        }
        if !self.tolerances.is_empty() {
            for &t in &self.tolerances {
                if !(1e-13..=0.1).contains(&t) {
                    return Err(CliError::Flag {
                        flag: "tolerances".into(),
                        value: t.to_string(),
                        msg: "each tolerance must lie in 1e-13 to 0.1".into(),
                    });
                }
            }
            o.tolerances = self.tolerances.clone();
        }
        if !(1e-13..=1e-6).contains(&self.reference_tolerance) {
            return Err(CliError::Flag {
                flag: "reference-tolerance".into(),
                value: self.reference_tolerance.to_string(),
                msg: "must lie in 1e-13 to 1e-6".into(),
            });
        }
        o.reference_tolerance = self.reference_tolerance;
        if !self.envelopes.is_empty() {
            o.envelopes = self
                .envelopes
                .iter()
                .map(|e| match e.trim() {
                    "none" => Ok(None),
                    t => match t.parse::<f64>() {
                        Ok(x) if (1e-8..=0.1).contains(&x) => Ok(Some(x)),
                        _ => Err(CliError::Flag {
                            flag: "envelopes".into(),
                            value: e.clone(),
                            msg: "each must be `none` or a tolerance from 1e-8 to 0.1".into(),
                        }),
                    },
                })
                .collect::<Result<_, _>>()?;
        }
        if self.tiers.contains(&crate::sim::Tier::Auto) {
            return Err(CliError::Flag {
                flag: "tiers".into(),
                value: "auto".into(),
                msg: "a benchmark compares tiers: give full, averaged, hybrid or several".into(),
            });
        }
        if !self.tiers.is_empty() {
            o.tiers = self.tiers.clone();
        }
        if !(1..=100).contains(&self.repeats) {
            return Err(CliError::Flag {
                flag: "repeats".into(),
                value: self.repeats.to_string(),
                msg: "must be from 1 to 100".into(),
            });
        }
        o.repeats = self.repeats;
        Ok(o)
    }
}

/// Arguments of `stickslip sweep`.
#[derive(Args, Debug)]
pub struct SweepArgs {
    /// The sweep file (TOML), e.g. sweeps/fig10.toml.
    pub file: PathBuf,
    /// Output HDF5 file. Default: results/<sweep name>.h5.
    #[arg(short, long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Continue an interrupted sweep: run only what its journal lacks.
    #[arg(long, conflicts_with = "overwrite")]
    pub resume: bool,
    /// Discard an interrupted sweep's journal and start afresh.
    #[arg(long)]
    pub overwrite: bool,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
    /// Do not draw the figures or compute the boundary at the end.
    #[arg(long)]
    pub no_plot: bool,
    /// Integrate every run on the scalar path, one at a time, instead of the full model's runs
    /// side by side in vector lanes (the results are the same bit for bit; for comparisons).
    #[arg(long)]
    pub scalar: bool,
    /// Seconds between HDF5 checkpoints while running (>= 1).
    #[arg(long, value_name = "s", default_value_t = 30.0)]
    pub checkpoint_every: f64,
    /// Run only part I of N of the sweep (I from 0 to N-1), into OUT.shards/I-of-N.h5 with its
    /// own journal; `stickslip merge OUT` assembles the parts. Parts are balanced by expected
    /// cost (interleaved over the grid); a [refine] sweep is split by plane (by group of planes
    /// with guide_planes).
    #[arg(long, value_name = "I/N", value_parser = parse_shard)]
    pub shard: Option<crate::sweep::shard::Shard>,
    /// Run a small sample of the sweep (about --sample points, or planes of a [refine] sweep)
    /// and predict the whole sweep's CPU time, per Slurm task too; writes nothing.
    #[arg(long, conflicts_with_all = ["shard", "resume", "overwrite"])]
    pub estimate: bool,
    /// Grid points (planes of a [refine] sweep) that --estimate samples (1 to 100000).
    #[arg(long, value_name = "N", default_value_t = 32, requires = "estimate")]
    pub sample: usize,
}

/// Refuses an effect parameter given twice with different values across `--effect` flags
/// (`aging:b=0.01 --effect aging:b=0.02`), which would otherwise be resolved silently by order.
fn once_each(specs: &[String]) -> Result<(), CliError> {
    let mut seen: Vec<(String, String, String)> = vec![];
    for spec in specs {
        let (name, rest) = spec.split_once(':').unwrap_or((spec, ""));
        for kv in rest.split(',').filter(|s| !s.trim().is_empty()) {
            let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
            let (name, k, v) = (name.trim(), k.trim(), v.trim());
            if let Some((_, _, v0)) = seen.iter().find(|(n, key, _)| n == name && key == k)
                && v0 != v
            {
                return Err(CliError::Flag {
                    flag: "effect".into(),
                    value: spec.clone(),
                    msg: format!(
                        "{name}.{k} is given twice, as {v0} and as {v}; give each parameter once"
                    ),
                });
            }
            seen.push((name.to_string(), k.to_string(), v.to_string()));
        }
    }
    Ok(())
}

fn parse_shard(s: &str) -> Result<crate::sweep::shard::Shard, String> {
    s.parse()
}

/// Arguments of `stickslip merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The sweep's output HDF5 file; its shards are in OUT.shards/ (e.g. results/quick.h5 and
    /// results/quick.h5.shards/).
    pub out: PathBuf,
    /// The folder holding the shards I-of-N.h5 and I-of-N.runs (default: OUT.shards/ beside
    /// OUT), e.g. where the shards of several hosts were copied.
    #[arg(long, value_name = "DIR")]
    pub shards: Option<PathBuf>,
    /// The sweep file the shards were made from (default: the text stored in the shards); shards
    /// of another sweep file or program version are refused.
    #[arg(long, value_name = "FILE")]
    pub sweep: Option<PathBuf>,
    /// Write what there is when shards are missing or unfinished: their points NaN, status -1,
    /// sweep_status = "partial".
    #[arg(long)]
    pub partial: bool,
    /// Worker threads for the traces (default: one per core).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Do not draw the figures or compute the boundary.
    #[arg(long)]
    pub no_plot: bool,
}

/// Arguments of `stickslip status`.
#[derive(Args, Debug)]
pub struct StatusArgs {
    /// The sweep's output HDF5 file (on one machine or sharded).
    pub out: PathBuf,
}

/// Arguments of `stickslip slurm`.
#[derive(Args, Debug)]
pub struct SlurmArgs {
    /// The sweep file (TOML).
    pub file: PathBuf,
    /// Array tasks, one shard each (1 to 100000; at most the sweep's points, or planes of a
    /// [refine] sweep, or its groups of planes with guide_planes).
    #[arg(long, value_name = "N")]
    pub tasks: usize,
    /// Output HDF5 file. Default: results/<sweep name>.h5. The scripts are written beside it
    /// (OUT.array.sbatch, OUT.merge.sbatch), the shards and job logs in OUT.shards/.
    #[arg(short, long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Slurm partition (sbatch --partition); default: the cluster's default partition.
    #[arg(long, value_name = "P")]
    pub partition: Option<String>,
    /// Time limit of each array task (sbatch --time: MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM or
    /// D-HH:MM:SS); default: the partition's. `sweep FILE --estimate` suggests one.
    #[arg(long, value_name = "T")]
    pub time: Option<String>,
    /// CPUs of each array task, its worker threads (1 to 1024).
    #[arg(long, value_name = "C", default_value_t = 1)]
    pub cpus_per_task: usize,
    /// Submit the array and the merge job (afterok on the array) with sbatch; print the job ids.
    #[arg(long)]
    pub submit: bool,
    /// Submit only the shards that are not complete (after a preempted task or a failed node),
    /// and a new merge job after them.
    #[arg(long, conflicts_with = "submit")]
    pub resubmit: bool,
}

/// Arguments of `stickslip plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// A sweep's HDF5 file.
    #[arg(required_unless_present = "law")]
    pub file: Option<PathBuf>,
    /// Stem of the figure files (default: the HDF5 file without extension, or
    /// results/<case stem>_law with --law); figures are named <stem>_fig10a.png,
    /// <stem>_map.svg, ...
    #[arg(short, long, value_name = "STEM")]
    pub out: Option<PathBuf>,
    /// Instead of a sweep's figures: the averaged friction law F_eff(V) of the point of this
    /// case file (its f, u0, v_d and contact), with the zones where the fast orbit does not
    /// contract, as <stem>.png/.svg and its nodes as <stem>.csv.
    #[arg(long, value_name = "CASE", conflicts_with = "file")]
    pub law: Option<PathBuf>,
}

/// Arguments of `stickslip boundary`.
#[derive(Args, Debug)]
pub struct BoundaryArgs {
    /// A sweep's HDF5 file with an amplitude axis (u0, v_a or va_ratio).
    pub file: PathBuf,
}

/// Every model parameter as a flag named after it (`--k-d`, `--f-s`, ...), SI units.
#[derive(Debug, Clone, Default)]
pub struct ParamArgs {
    /// Values given on the command line, by parameter name.
    pub values: Vec<(&'static str, f64)>,
}

fn param_help(p: &ParamInfo) -> String {
    format!(
        "{} [{}] (default {})",
        p.doc,
        p.unit,
        p.get(&Params::default())
    )
}

impl Args for ParamArgs {
    fn augment_args(mut cmd: clap::Command) -> clap::Command {
        for p in PARAMS {
            cmd = cmd.arg(
                Arg::new(p.name)
                    .long(p.flag)
                    .value_name(p.unit)
                    .help(param_help(p))
                    .allow_negative_numbers(true)
                    .value_parser(clap::value_parser!(f64))
                    .action(ArgAction::Set)
                    .help_heading("Model parameters (SI units)"),
            );
        }
        cmd
    }
    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

impl FromArgMatches for ParamArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let values = PARAMS
            .iter()
            .filter_map(|p| m.get_one::<f64>(p.name).map(|v| (p.name, *v)))
            .collect();
        Ok(ParamArgs { values })
    }
    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

/// Arguments of `stickslip run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Case file (TOML): parameters by name in SI units, optional [solver] and [run] tables;
    /// flags override it.
    #[arg(long, value_name = "FILE")]
    pub case: Option<PathBuf>,

    #[command(flatten)]
    pub params: ParamArgs,

    /// Switch on a model extension, with optional parameters: `--effect aging` or
    /// `--effect aging:b=0.05,theta_0=0.01`. Repeatable. Effects: aging, actuator_response,
    /// normal_coupling, sensor_dynamics, drive_ripple, viscous, stribeck_shape, presliding,
    /// frictional_lag, track.
    #[arg(long = "effect", value_name = "NAME[:k=v,..]")]
    pub effects: Vec<String>,

    /// Vibration velocity amplitude v_a = 2 pi f u0 [m/s], instead of --u0.
    #[arg(long, value_name = "m/s", conflicts_with_all = ["u0", "va_ratio"], allow_negative_numbers = true)]
    pub v_a: Option<f64>,

    /// Vibration velocity amplitude as a ratio v_a / v_d [-], instead of --u0.
    #[arg(
        long,
        value_name = "RATIO",
        conflicts_with = "u0",
        allow_negative_numbers = true
    )]
    pub va_ratio: Option<f64>,

    /// Integration method: radau5 (implicit Radau IIA, order 5), rodas4 (Rosenbrock, order 4),
    /// dopri5 (explicit Dormand-Prince 5(4)) or auto (dopri5, switching to radau5 where
    /// stability rather than accuracy limits its step). Default auto, with envelope following
    /// at 1e-4: the fastest setting that meets docs/model.md's accuracy in `stickslip bench`.
    #[arg(long, value_name = "METHOD")]
    pub solver: Option<Method>,

    /// Relative tolerance (1e-13 to 0.1). Default 1e-6.
    #[arg(long, allow_negative_numbers = true)]
    pub rtol: Option<f64>,

    /// Absolute tolerance, in units of each state's characteristic size (0 to 1). Default 1e-6.
    #[arg(long, allow_negative_numbers = true)]
    pub atol: Option<f64>,

    /// Simulated time [s]. Default: chosen so that the steady window (the second half) holds
    /// --min-cycles stick-slip cycles of the run without vibration.
    #[arg(long, value_name = "s", allow_negative_numbers = true)]
    pub t_end: Option<f64>,

    /// Stick-slip cycles the steady window must hold (1 to 1000). Default 3.
    #[arg(long)]
    pub min_cycles: Option<u32>,

    /// Run the whole automatic simulated time even once the answer is known (steady sliding, or
    /// the stick-slip cycles of the window give dF to 0.5 %).
    #[arg(long, conflicts_with = "early_stop")]
    pub no_early_stop: bool,

    /// End early once the answer is known also with --t-end, which is then the longest
    /// simulated time (without it a given --t-end is run in full)
    #[arg(long)]
    pub early_stop: bool,

    /// Integrate every cycle instead of continuing along the limit cycle once two successive
    /// slips pass the same state (runs without vibration and the averaged slow model).
    #[arg(long)]
    pub no_periodic: bool,

    /// Envelope following with vibration: skip whole vibration periods where the state sampled
    /// once per period drifts smoothly, with this extrapolation tolerance per jump (1e-8 to 0.1,
    /// in units of each state's characteristic size). Default 1e-4.
    #[arg(
        long,
        value_name = "TOL",
        allow_negative_numbers = true,
        conflicts_with = "no_envelope"
    )]
    pub envelope: Option<f64>,

    /// Integrate every vibration period (no envelope following).
    #[arg(long)]
    pub no_envelope: bool,

    /// Which model serves a run with vibration: auto (averages the vibration out where the
    /// averaged law of body and contact is valid and the forcing is 20 or more times faster than
    /// the drive oscillator, hybrid windows where the run passes zones of the law that are not,
    /// else full), averaged (wherever the law exists), hybrid (the averaged law with the full
    /// model in windows where it is not valid) or full (every period integrated). Default auto.
    /// The result says which served and why.
    #[arg(long, value_name = "TIER")]
    pub tier: Option<crate::sim::Tier>,

    /// Print the results as one JSON object on stdout (no other output there).
    #[arg(long)]
    pub json: bool,

    /// Keep no time traces: the HDF5 file gets the results only (no CSV or plot either).
    #[arg(long, conflicts_with_all = ["csv", "plot"])]
    pub no_trace: bool,

    /// Run the case this many times in one process (1 to 1000) and report the median wall time
    /// (and the fastest): the first run pays for cold caches and fresh pages, as a timing loop
    /// inside any other tool does. Results and traces are those of the last run.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub repeats: u32,

    /// With --repeats: every repeat builds the averaged law's table afresh, as one run in a
    /// fresh process does (without it the repeats share the table, as the runs of a sweep's
    /// `k_d` line do).
    #[arg(long)]
    pub fresh_tables: bool,

    /// HDF5 file for the traces and results.
    #[arg(short, long, value_name = "FILE", default_value = "results/run.h5")]
    pub out: PathBuf,

    /// Also write the traces as CSV to this file.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,

    /// Draw F_d, x_s and x_d against time (the paper's Figs. 3 to 5) to PNG and SVG; the
    /// files take the HDF5 file's name with .png and .svg.
    #[arg(long)]
    pub plot: bool,
}

/// A bad command line that clap cannot see (ranges, relations).
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A case-file problem.
    #[error(transparent)]
    Config(#[from] config::ConfigError),
    /// A flag's value is out of range.
    #[error("--{flag} = {value}: {msg}")]
    Flag {
        /// Flag name.
        flag: String,
        /// Value given.
        value: String,
        /// What is allowed.
        msg: String,
    },
}

/// Whether two paths name the same file or folder (the same one by another spelling
/// included; where either does not exist, whether they are spelled alike).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// Checks an output location before anything is computed: `path` (given by `--flag`) must not
/// be a directory, its nearest existing ancestor must be a directory, and it must not be one of
/// the command's `inputs` (the same file by another spelling included). Refused with a message
/// that names the flag, the path and the problem.
pub fn check_output(flag: &str, path: &Path, inputs: &[&Path]) -> Result<(), CliError> {
    let bad = |msg: String| {
        Err(CliError::Flag {
            flag: flag.into(),
            value: path.display().to_string(),
            msg,
        })
    };
    if path.as_os_str().is_empty() {
        return bad("an empty path; give a file name".into());
    }
    if path.is_dir() {
        return bad("is a directory; give a file name".into());
    }
    if crate::output::special(path) {
        return bad("is not a regular file (a device, pipe or socket); give a file name".into());
    }
    let mut up = path.parent();
    while let Some(d) = up.filter(|d| !d.as_os_str().is_empty()) {
        if d.exists() {
            if !d.is_dir() {
                return bad(format!(
                    "its parent {} is a file, not a directory",
                    d.display()
                ));
            }
            break;
        }
        up = d.parent();
    }

    for input in inputs {
        if same_file(path, input) {
            return bad(format!(
                "is an input of this command ({}); it would be overwritten: give another output",
                input.display()
            ));
        }
    }
    Ok(())
}

impl SweepArgs {
    /// Loads and validates the sweep file and resolves the options.
    pub fn resolve(
        &self,
    ) -> Result<(crate::sweep::spec::SweepSpec, crate::sweep::SweepOptions), CliError> {
        let spec = crate::sweep::spec::SweepSpec::load(&self.file)?;
        let opts = self.options(&spec)?;
        Ok((spec, opts))
    }

    /// Validates the options for a sweep already loaded (from the file, or from text a host
    /// gave, as the Python package's dicts).
    pub fn options(
        &self,
        spec: &crate::sweep::spec::SweepSpec,
    ) -> Result<crate::sweep::SweepOptions, CliError> {
        if let Some(t) = self.threads
            && (t == 0 || t > 1024)
        {
            return Err(CliError::Flag {
                flag: "threads".into(),
                value: t.to_string(),
                msg: "must be from 1 to 1024".into(),
            });
        }
        if !(self.checkpoint_every >= 1.0 && self.checkpoint_every.is_finite()) {
            return Err(CliError::Flag {
                flag: "checkpoint-every".into(),
                value: self.checkpoint_every.to_string(),
                msg: "must be a finite number of seconds >= 1".into(),
            });
        }
        let out = self
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("results").join(format!("{}.h5", spec.name)));
        check_output("out", &out, &[&self.file])?;
        if let Some(sh) = self.shard {
            crate::sweep::shard::check(spec, sh.count).map_err(|msg| CliError::Flag {
                flag: "shard".into(),
                value: sh.to_string(),
                msg,
            })?;
        }
        if !(1..=100_000).contains(&self.sample) {
            return Err(CliError::Flag {
                flag: "sample".into(),
                value: self.sample.to_string(),
                msg: "must be from 1 to 100000".into(),
            });
        }
        Ok(crate::sweep::SweepOptions {
            out,
            threads: self.threads,
            resume: self.resume,
            overwrite: self.overwrite,
            progress: !self.quiet,
            checkpoint_every: self.checkpoint_every,
            shard: self.shard,
            tally: None,
            batch: !self.scalar,
        })
    }
}

impl RunArgs {
    /// Resolves defaults, case file and flags (in that order) into a validated case.
    pub fn resolve(&self) -> Result<Case, CliError> {
        let mut case = match &self.case {
            Some(path) => config::load_case(path)?,
            None => Case {
                params: Params::default(),
                run: RunOptions::default(),
                effects: crate::model::Effects::none(),
                path: None,
            },
        };
        once_each(&self.effects)?;
        for spec in &self.effects {
            case.effects.apply_spec(spec).map_err(|e| CliError::Flag {
                flag: "effect".into(),
                value: spec.clone(),
                msg: e.to_string(),
            })?;
        }
        let p = &mut case.params;
        for (name, v) in &self.params.values {
            p.set(name, *v).expect("flag names are parameter names");
        }
        // An amplitude flag replaces the case file's u0; a case file's v_a or va_ratio was turned
        // into u0 at the file's own f and v_d.
        if let Some(x) = self.v_a {
            config::resolve_amplitude(p, "v_a", x).map_err(|msg| CliError::Flag {
                flag: "v-a".into(),
                value: x.to_string(),
                msg,
            })?;
        } else if let Some(x) = self.va_ratio {
            config::resolve_amplitude(p, "va_ratio", x).map_err(|msg| CliError::Flag {
                flag: "va-ratio".into(),
                value: x.to_string(),
                msg,
            })?;
        }
        p.validate().map_err(|e| match e {
            crate::model::ParamError::OutOfRange {
                name,
                value,
                allowed,
                ..
            } => CliError::Flag {
                flag: crate::model::params::info(name)
                    .map(|i| i.flag)
                    .unwrap_or(name)
                    .to_string(),
                value: crate::model::params::number(value),
                msg: allowed,
            },
            other => CliError::Flag {
                flag: "?".into(),
                value: String::new(),
                msg: other.to_string(),
            },
        })?;
        let o = &mut case.run;
        if let Some(m) = self.solver {
            o.method = m;
        }
        if let Some(v) = self.rtol {
            o.ode.rtol = v;
        }
        if let Some(v) = self.atol {
            o.ode.atol = v;
        }
        if let Some(v) = self.t_end {
            o.t_end = Some(v);
        }
        if let Some(v) = self.min_cycles {
            o.min_cycles = v;
        }
        if self.no_early_stop {
            o.early_stop = EarlyStop::Off;
        }
        if self.early_stop {
            o.early_stop = EarlyStop::Always;
        }
        if self.no_periodic {
            o.periodic = false;
        }
        if self.no_envelope {
            o.envelope = None;
        }
        if let Some(v) = self.envelope {
            o.envelope = Some(v);
        }
        if let Some(t) = self.tier {
            o.tier = t;
        }
        o.trace = !self.no_trace;
        // Outputs: never an input, never each other, and writable places.
        let case_file: Vec<&Path> = self.case.iter().map(PathBuf::as_path).collect();
        check_output("out", &self.out, &case_file)?;
        if let Some(csv) = &self.csv {
            let mut inputs = case_file.clone();
            inputs.push(&self.out);
            check_output("csv", csv, &inputs)?;
        }
        if !(1..=1000).contains(&self.repeats) {
            return Err(CliError::Flag {
                flag: "repeats".into(),
                value: self.repeats.to_string(),
                msg: "must be from 1 to 1000".into(),
            });
        }
        o.validate().map_err(|e| CliError::Flag {
            flag: e.field.replace('_', "-"),
            value: e.value.to_string(),
            msg: e.allowed.to_string(),
        })?;
        // A switch-on time without vibration would be stored and mean nothing.
        let p = &case.params;
        if p.t_on > 0.0 && !p.vibrates() {
            return Err(CliError::Flag {
                flag: "t-on".into(),
                value: p.t_on.to_string(),
                msg: format!(
                    "a switch-on time needs vibration to switch on (f = {} Hz, u0 = {} m); give u0, v_a or va_ratio, or leave t_on out",
                    p.f, p.u0
                ),
            });
        }
        // The run's length and budget, before anything runs.
        crate::sim::end_time(p, o).map_err(|e| CliError::Flag {
            flag: "t-end".into(),
            value: o.t_end.map_or("automatic".into(), |t| t.to_string()),
            msg: e.to_string(),
        })?;
        Ok(case)
    }
}
