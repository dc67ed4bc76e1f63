//! The commands, as library calls: each takes a resolved configuration and does the work.

use crate::campaign::{self, Campaign, CampaignError};
use crate::cli::{
    BenchArgs, BoundaryArgs, CalibrateArgs, CliError, Command, DiagnoseArgs, MergeArgs, PlanArgs,
    PlotArgs, RunArgs, SlurmArgs, StatusArgs, SweepArgs, SynthArgs,
};
use crate::diagnosis;
use crate::measures::Measure;
use crate::ode::Solver;
use crate::output::{self, OutputError};
use crate::plot::{self, PlotError};
use crate::sim::{self, CaseResult, RunOptions, SimError};
use crate::slurm::{SlurmError, SlurmJob};
use crate::sweep::{self, SweepError};
use std::io::Write;

/// Anything that can stop a command.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// Bad command line or configuration file.
    #[error(transparent)]
    Cli(#[from] CliError),
    /// Bad parameters or options.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A file could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A sweep could not go on.
    #[error(transparent)]
    Sweep(#[from] SweepError),
    /// A campaign could not be read or written.
    #[error(transparent)]
    Campaign(#[from] CampaignError),
    /// A Slurm submission failed.
    #[error(transparent)]
    Slurm(#[from] SlurmError),
    /// The simulation ran but did not succeed.
    #[error("the run did not succeed: {0}")]
    Failed(String),
    /// A plan could not be made.
    #[error(transparent)]
    Plan(#[from] crate::planning::PlanError),
    /// A bad design space.
    #[error(transparent)]
    Space(#[from] crate::planning::space::SpaceError),
}

impl AppError {
    /// Process exit code: 2 for bad input, 1 for failures while running.
    pub fn exit_code(&self) -> i32 {
        match self {
            AppError::Cli(_)
            | AppError::Sim(_)
            | AppError::Slurm(SlurmError::Flag { .. } | SlurmError::Unsafe(_)) => 2,
            AppError::Campaign(CampaignError::Malformed { .. } | CampaignError::Config(_)) => 2,
            AppError::Plan(_) | AppError::Space(_) => 2,
            _ => 1,
        }
    }
}

/// Runs a parsed command.
pub fn execute(cmd: Command) -> Result<(), AppError> {
    match cmd {
        Command::Run(a) => run(&a),
        Command::Sweep(a) => sweep_cmd(&a),
        Command::Plot(a) => plot_cmd(&a),
        Command::Boundary(a) => boundary_cmd(&a),
        Command::Bench(a) => bench_cmd(&a),
        Command::Synth(a) => synth_cmd(&a),
        Command::Calibrate(a) => calibrate_cmd(&a),
        Command::Diagnose(a) => diagnose_cmd(&a),
        Command::Plan(a) => plan_cmd(&a),
        Command::Preflight(a) => preflight_cmd(&a),
        Command::Merge(a) => merge_cmd(&a),
        Command::Status(a) => status_cmd(&a),
        Command::Slurm(a) => slurm_cmd(&a),
    }
}

/// `stickslip synth`.
pub fn synth_cmd(a: &SynthArgs) -> Result<(), AppError> {
    let spec = a.resolve()?;
    if a.dir.exists() && !a.dir.is_dir() {
        return Err(CliError::Flag {
            flag: "dir".into(),
            value: a.dir.display().to_string(),
            msg: "is a file; give a directory for the campaign".into(),
        }
        .into());
    }
    // Its parents must be folders (or not exist yet): checked as for an output file inside it.
    crate::cli::check_output("dir", &a.dir.join("campaign.toml"), &[])?;
    if !a.overwrite && a.dir.is_dir() {
        let has = std::fs::read_dir(&a.dir)
            .map(|d| {
                d.flatten()
                    .any(|e| e.path().extension().is_some_and(|x| x == "csv"))
            })
            .unwrap_or(false);
        if has {
            return Err(CliError::Flag {
                flag: "dir".into(),
                value: a.dir.display().to_string(),
                msg: "already holds recordings; pass --overwrite to replace them".into(),
            }
            .into());
        }
    }
    let start = std::time::Instant::now();
    let recs = match &a.conditions {
        Some(plan_dir) => campaign::synth::synth_planned(&a.dir, plan_dir, &spec)?,
        None => campaign::synth::synth(&a.dir, &spec)?,
    };
    if let Some(path) = &a.truth {
        let effects = spec.effects.to_json();
        let truth = serde_json::json!({"effects": effects, "base": spec.base, "seed": spec.seed});
        output::ensure_parent(path)?;
        std::fs::write(
            path,
            serde_json::to_string_pretty(&truth).unwrap_or_default(),
        )
        .map_err(|e| CampaignError::Io {
            path: path.display().to_string(),
            msg: e.to_string(),
        })?;
    }
    crate::say!(
        "wrote {} recordings to {} in {:.1} s (effects: {})",
        recs.len(),
        a.dir.display(),
        start.elapsed().as_secs_f64(),
        spec.effects.describe()
    );
    Ok(())
}

/// `stickslip calibrate`.
pub fn calibrate_cmd(a: &CalibrateArgs) -> Result<(), AppError> {
    let cal = calibrate(a)?;
    crate::console::print(format_args!("{}", cal.summary));
    print_skipped(&cal.skipped);
    if let Some(path) = &a.json {
        output::ensure_parent(path)?;
        let text = serde_json::to_string_pretty(&cal.json).unwrap_or_default();
        std::fs::write(path, text).map_err(|e| CampaignError::Io {
            path: path.display().to_string(),
            msg: e.to_string(),
        })?;
        crate::say!("wrote {}", path.display());
    }
    Ok(())
}

/// A calibration's results: what `stickslip calibrate` prints and writes.
pub struct Calibrated {
    /// The estimates as `--json` writes them.
    pub json: serde_json::Value,
    /// The printed summary.
    pub summary: String,
    /// Recordings set aside as implausible (`--skip-implausible`).
    pub skipped: Vec<campaign::check::Implausible>,
}

/// The calibration of `stickslip calibrate`, without printing or writing anything.
pub fn calibrate(a: &CalibrateArgs) -> Result<Calibrated, AppError> {
    let effect = a.resolve()?;
    let (c, skipped) = checked(Campaign::load(&a.campaign)?, a.skip_implausible)?;
    let target = diagnosis::fit::Target::new(c.recordings.iter().collect());
    let opts = diagnosis::fit::FitOptions {
        max_iter: a.max_iter,
        ..Default::default()
    };
    let base = diagnosis::fit::fit(&target, &diagnosis::fit::Model::default(), &[], opts);
    let f = match effect {
        None => base,
        Some(k) => {
            // Fitted from each of the scan's starts; the lowest gap is kept (the first of equals).
            diagnosis::scan::starts(&target, &base, k, k.default_form())
                .iter()
                .map(|start| diagnosis::fit::fit(&target, &start.model, &[k], opts))
                .reduce(|a, b| if b.gap < a.gap { b } else { a })
                .expect("a start")
        }
    };
    let mut json = diagnosis::report::calibration_json(&c, &f);
    json["skipped_implausible"] = serde_json::to_value(
        skipped
            .iter()
            .map(diagnosis::record::Skipped::from)
            .collect::<Vec<_>>(),
    )
    .expect("plain fields serialise");
    Ok(Calibrated {
        json,
        summary: diagnosis::report::calibration_summary(&c, &f),
        skipped,
    })
}

/// The campaign after its preflight ([`campaign::acquisition::prepare`]), or why nothing is left.
fn prepared(c: Campaign) -> Result<Campaign, AppError> {
    let dir = c.dir.display().to_string();
    campaign::acquisition::prepare(c).map_err(|msg| {
        CampaignError::Malformed {
            file: dir,
            line: 0,
            msg,
        }
        .into()
    })
}

/// Examines every recording's acquisition ([`campaign::acquisition::prepare`]: clipped ones set
/// aside, mains subtracted) and checks the rest before any fit ([`campaign::check`]): refuses
/// the campaign when one is implausible, or with `skip` sets those aside and returns them.
fn checked(
    c: Campaign,
    skip: bool,
) -> Result<(Campaign, Vec<campaign::check::Implausible>), AppError> {
    let c = prepared(c)?;
    let bad = campaign::check::check_campaign(&c);
    if bad.is_empty() {
        return Ok((c, bad));
    }
    if !skip {
        return Err(CampaignError::Malformed {
            file: c.dir.display().to_string(),
            line: 0,
            msg: format!(
                "{} implausible recording(s), refused before any fit:\n  {}\nfix them, or set them aside with --skip-implausible",
                bad.len(),
                bad.iter()
                    .map(|b| b.to_string())
                    .collect::<Vec<_>>()
                    .join("\n  ")
            ),
        }
        .into());
    }
    let mut names: Vec<String> = bad.iter().map(|b| b.recording.clone()).collect();
    names.dedup();
    let rest = c.without(&names);
    if rest.recordings.is_empty() {
        return Err(CampaignError::Malformed {
            file: c.dir.display().to_string(),
            line: 0,
            msg: "every recording is implausible; nothing is left to fit".into(),
        }
        .into());
    }
    Ok((rest, bad))
}

fn print_skipped(skipped: &[campaign::check::Implausible]) {
    if !skipped.is_empty() {
        crate::say!("set aside as implausible (--skip-implausible):");
        for s in skipped {
            crate::say!("  {s}");
        }
    }
}

/// `stickslip diagnose`.
pub fn diagnose_cmd(a: &DiagnoseArgs) -> Result<(), AppError> {
    let d = diagnose(a)?;
    crate::console::print(format_args!("{}", d.summary));
    print_skipped(&d.skipped);
    for w in d.written {
        crate::say!("wrote {}", w.display());
    }
    Ok(())
}

/// A diagnosis's results: what `stickslip diagnose` prints and writes.
pub struct Diagnosed {
    /// The verdict as written to `diagnosis.json`.
    pub json: serde_json::Value,
    /// The printed report.
    pub summary: String,
    /// Recordings set aside as implausible (`--skip-implausible`).
    pub skipped: Vec<campaign::check::Implausible>,
    /// The output folder.
    pub out: std::path::PathBuf,
    /// Files written: the JSON, `diagnosis.h5` and the figures.
    pub written: Vec<std::path::PathBuf>,
}

/// The diagnosis of `stickslip diagnose`: the verdict, its files in the output folder, and the
/// report, returned rather than printed.
pub fn diagnose(a: &DiagnoseArgs) -> Result<Diagnosed, AppError> {
    let opts = a.resolve()?;
    let (c, skipped) = checked(Campaign::load(&a.campaign)?, a.skip_implausible)?;
    let name = a
        .campaign
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "campaign".into());
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| std::path::PathBuf::from("results").join(format!("diagnose-{name}")));
    let d = diagnosis::diagnose::diagnose(&c, &opts)?;
    std::fs::create_dir_all(&out).map_err(|e| CampaignError::Io {
        path: out.display().to_string(),
        msg: e.to_string(),
    })?;
    let json_path = a.json.clone().unwrap_or_else(|| out.join("diagnosis.json"));
    output::ensure_parent(&json_path)?;
    let record = diagnosis::record::DiagnosisRecord::of(&c, &d, &skipped);
    let j = record.to_json();
    let text = serde_json::to_string_pretty(&j).unwrap_or_default();
    std::fs::write(&json_path, text).map_err(|e| CampaignError::Io {
        path: json_path.display().to_string(),
        msg: e.to_string(),
    })?;
    let h5 = out.join("diagnosis.h5");
    let traces = diagnosis::report::traces_figure(&c, &d);
    diagnosis::report::write_h5(&h5, &c, &d, &record, traces.as_ref())?;
    let mut written = vec![json_path, h5];
    if !a.no_plots {
        written.extend(diagnosis::report::plots(&out, &d, traces.as_ref())?);
    }
    Ok(Diagnosed {
        json: j,
        summary: diagnosis::report::summary(&c, &d),
        skipped,
        out,
        written,
    })
}

/// Whether `path` holds a diagnosis of exactly these recordings by this version (its
/// `recordings_digest` and `code_version`), and the diagnosis.
fn matching_diagnosis(
    path: &std::path::Path,
    c: &Campaign,
) -> Result<diagnosis::record::DiagnosisRecord, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    let d = diagnosis::record::DiagnosisRecord::from_json(&text).map_err(|e| e.to_string())?;
    if d.recordings_digest != campaign::digest(&c.recordings) {
        return Err("it is of other recordings".into());
    }
    if d.code_version != env!("CARGO_PKG_VERSION") {
        return Err(format!(
            "it was written by version {}, this is {}",
            d.code_version,
            env!("CARGO_PKG_VERSION")
        ));
    }
    Ok(d)
}

/// A plan's results: what `stickslip plan` prints and writes.
pub struct Planned {
    /// The plan as written to `plan.json`.
    pub json: serde_json::Value,
    /// The printed summary.
    pub summary: String,
    /// Files written.
    pub written: Vec<std::path::PathBuf>,
}

/// `stickslip plan`.
pub fn plan_cmd(a: &PlanArgs) -> Result<(), AppError> {
    let p = plan(a)?;
    crate::console::print(format_args!("{}", p.summary));
    for w in p.written {
        crate::say!("wrote {}", w.display());
    }
    Ok(())
}

/// The plan of `stickslip plan`, returned rather than printed. Files in the output folder are
/// replaced only where a plan wrote them (a conditions file with a `plan` table, `plan.json`,
/// `plan.png`, `plan.svg`, `diagnosis.json`).
pub fn plan(a: &PlanArgs) -> Result<Planned, AppError> {
    let (opts, out, json_path) = a.resolve()?;
    // The preflight as the diagnosis runs it, so a diagnosis written beside the campaign is of
    // the recordings the plan reads.
    let c = prepared(Campaign::load(&a.campaign)?)?;
    let space = match &a.space {
        Some(f) => crate::planning::space::Space::of(&c).with_file(f)?,
        None => crate::planning::space::Space::of(&c),
    };
    let name = a
        .campaign
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "campaign".into());
    // One plan per folder at a time, from its checks to its last file (`OUT.lock` beside it):
    // two plans writing one folder would leave one's conditions beside the other's plan.json.
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| CampaignError::Io {
            path: parent.display().to_string(),
            msg: e.to_string(),
        })?;
    }
    let _lock = crate::sweep::lock::acquire(&out).map_err(|msg| CliError::Flag {
        flag: "out".into(),
        value: out.display().to_string(),
        msg,
    })?;
    // Refuse to write over files a plan did not write.
    if out.is_dir() {
        let mut paths = vec![];
        for e in std::fs::read_dir(&out).map_err(|e| CampaignError::Io {
            path: out.display().to_string(),
            msg: e.to_string(),
        })? {
            paths.push(
                e.map_err(|e| CampaignError::Io {
                    path: out.display().to_string(),
                    msg: e.to_string(),
                })?
                .path(),
            );
        }
        // Recordings are named before other files, whatever order the folder lists them in.
        paths.sort_by_key(|p| (p.extension().is_none_or(|x| x != "csv"), p.clone()));
        for path in paths {
            let is_csv = path.extension().is_some_and(|x| x == "csv");
            if is_csv {
                return Err(CliError::Flag {
                    flag: "out".into(),
                    value: out.display().to_string(),
                    msg: format!(
                        "holds recordings ({}); a plan's folder holds conditions to record, give another --out",
                        path.display()
                    ),
                }
                .into());
            }
            let is_toml = path.extension().is_some_and(|x| x == "toml");
            if is_toml {
                let text = std::fs::read_to_string(&path).unwrap_or_default();
                if !crate::planning::report::written_by_a_plan(&text) {
                    return Err(CliError::Flag {
                        flag: "out".into(),
                        value: out.display().to_string(),
                        msg: format!(
                            "holds {}, which no plan wrote; give another --out",
                            path.display()
                        ),
                    }
                    .into());
                }
            }
        }
    }
    let say = |line: &str| crate::note!("plan: {line}");
    let candidates = [
        a.diagnosis.clone(),
        Some(
            std::path::PathBuf::from("results")
                .join(format!("diagnose-{name}"))
                .join("diagnosis.json"),
        ),
        Some(out.join("diagnosis.json")),
    ];
    let mut diag = None;
    for (k, path) in candidates.iter().enumerate() {
        let Some(path) = path else { continue };
        if !path.is_file() {
            if k == 0 {
                return Err(CliError::Flag {
                    flag: "diagnosis".into(),
                    value: path.display().to_string(),
                    msg: "no such file".into(),
                }
                .into());
            }
            continue;
        }
        match matching_diagnosis(path, &c) {
            Ok(j) => {
                diag = Some((j, path.display().to_string()));
                break;
            }
            Err(why) if k == 0 => {
                return Err(CliError::Flag {
                    flag: "diagnosis".into(),
                    value: path.display().to_string(),
                    msg: format!("cannot plan from it: {why}"),
                }
                .into());
            }
            Err(why) => say(&format!("{} not used: {why}", path.display())),
        }
    }
    let (diag, source) = match diag {
        Some(d) => d,
        None => {
            say("no diagnosis of these recordings found: diagnosing first");
            let d = diagnosis::diagnose::diagnose(&c, &Default::default())?;
            let record = diagnosis::record::DiagnosisRecord::of(&c, &d, &[]);
            std::fs::create_dir_all(&out).map_err(|e| CampaignError::Io {
                path: out.display().to_string(),
                msg: e.to_string(),
            })?;
            let path = out.join("diagnosis.json");
            let text = serde_json::to_string_pretty(&record.to_json()).unwrap_or_default();
            std::fs::write(&path, text).map_err(|e| CampaignError::Io {
                path: path.display().to_string(),
                msg: e.to_string(),
            })?;
            (record, format!("{} (run now)", path.display()))
        }
    };
    say(&format!(
        "from the diagnosis {source}: {}",
        diag.verdict.name()
    ));
    let plan = crate::planning::plan(&c, &diag, &space, &opts, &say)?;
    let plan_name = format!("plan-{name}");
    let written =
        crate::planning::report::write(&out, &c, &plan, &plan_name, &json_path, a.no_plots)?;
    Ok(Planned {
        json: crate::planning::report::json(&c, &plan, &plan_name),
        summary: crate::planning::report::summary(&plan),
        written,
    })
}

/// `stickslip bench`.
pub fn bench_cmd(a: &BenchArgs) -> Result<(), AppError> {
    if a.batch {
        return bench_batch_cmd(a);
    }
    let o = a.resolve()?;
    let crate::bench::BenchRun {
        cases,
        references: refs,
        rows,
    } = crate::bench::run(&o, |line| crate::note!("{line}"))?;
    crate::bench::write_h5(&a.out, &cases, &refs, &rows, &o)?;
    crate::say!("wrote {}", a.out.display());
    for f in crate::bench::plot(&a.out.with_extension(""), &cases, &rows)? {
        crate::say!("wrote {}", f.display());
    }
    // The fastest tolerance of each setting that meets the accuracy target, per case.
    let mut settings: Vec<String> = vec![];
    for r in &rows {
        if !settings.contains(&r.setting()) {
            settings.push(r.setting());
        }
    }
    for c in &cases {
        for name in &settings {
            {
                let best = rows
                    .iter()
                    .filter(|r| {
                        r.case == c.name
                            && r.setting() == *name
                            && r.err_r <= 0.01
                            && r.err_mean <= 0.005
                            && r.status == crate::ode::Status::Success
                    })
                    .min_by(|x, y| x.time.total_cmp(&y.time));
                match best {
                    Some(r) => crate::say!(
                        "{:13} {:22} fastest within |dr| <= 0.01, |dmean| <= 0.5 %: tol {:.0e}, {:.2} ms",
                        c.name,
                        name,
                        r.tol,
                        r.time * 1e3
                    ),
                    None => crate::say!(
                        "{:13} {:22} no tolerance of the ladder meets the accuracy target",
                        c.name,
                        name
                    ),
                }
            }
        }
    }
    Ok(())
}

/// `stickslip bench --batch`: prints the table and writes its JSON beside `--out`.
fn bench_batch_cmd(a: &BenchArgs) -> Result<(), AppError> {
    let o = a.resolve_batch()?;
    let b = crate::bench::batch::run(&o, |line| crate::note!("{line}"));
    crate::say!("{b}");
    let stem = a.out.with_extension("");
    let json = stem.with_file_name(format!(
        "{}_batch.json",
        stem.file_name()
            .map_or("bench".into(), |s| s.to_string_lossy())
    ));
    output::write_text(&json, &serde_json::to_string_pretty(&b).unwrap_or_default())?;
    crate::say!("wrote {}", json.display());
    Ok(())
}

/// `stickslip sweep`.
pub fn sweep_cmd(a: &SweepArgs) -> Result<(), AppError> {
    let (spec, opts) = a.resolve()?;
    let plan = sweep::Plan::new(&spec);
    let dims = spec
        .dims
        .iter()
        .map(|d| format!("{} x{}", d.name, d.len))
        .collect::<Vec<_>>()
        .join(", ");
    let threads = opts.threads.unwrap_or_else(rayon::current_num_threads);
    if a.estimate {
        crate::note!(
            "sweep {}: estimating from a sample of about {} {}, {threads} threads",
            spec.name,
            a.sample,
            if spec.refine.is_some() {
                "planes"
            } else {
                "points"
            }
        );
        let e = sweep::estimate::estimate(&spec, a.sample, opts.threads)?;
        crate::say!("{e}");
        return Ok(());
    }
    if let Some(sh) = opts.shard {
        crate::note!(
            "sweep {}: shard {sh} of {} points ({}), {threads} threads -> {}",
            spec.name,
            plan.points.len(),
            if spec.refine.is_some() {
                "dealt by plane"
            } else {
                "dealt point by point"
            },
            opts.target().display()
        );
    } else {
        match &spec.refine {
            None => crate::note!(
                "sweep {}: {} points over {dims} ({} runs: {} without vibration as references), {threads} threads -> {}",
                spec.name,
                plan.points.len(),
                plan.tasks().len(),
                plan.refs.len(),
                opts.out.display()
            ),
            Some(rf) => crate::note!(
                "sweep {}: refining {} = {} along {} on a dense grid of {} points over {dims}: {} coarse points, steps halved {} times where needed, {threads} threads -> {}",
                spec.name,
                rf.measure.name(),
                rf.level,
                spec.axes[rf.along].name,
                plan.points.len(),
                sweep::refine::coarse_points(&spec).len(),
                rf.levels,
                opts.out.display()
            ),
        }
    }
    let outcome = sweep::run(&spec, &opts)?;
    if outcome.journal_dropped > 0 {
        crate::note!(
            "{} damaged line(s) of the journal were dropped on resuming; their runs were made again",
            outcome.journal_dropped
        );
    }
    if outcome.tables_loaded > 0 {
        crate::say!(
            "{} table(s) of the averaged law loaded from the journal",
            outcome.tables_loaded
        );
    }
    crate::say!(
        "wrote {}: {} points, {} runs made, {} resumed, {} failed, {:.1} s",
        outcome.out.display(),
        outcome.points,
        outcome.runs_made,
        outcome.runs_resumed,
        outcome.failed,
        outcome.wall_time
    );
    if outcome.check.averaged > 0 {
        crate::say!("tiers: {}", outcome.check.line());
    }
    if let Some(sh) = opts.shard {
        // A shard's file holds part of the grid: the figures come with the merge.
        crate::say!(
            "shard {sh} complete; when all {} are, `stickslip merge {}` assembles the sweep",
            sh.count,
            opts.out.display()
        );
        return Ok(());
    }
    if !a.no_plot {
        figures_and_boundary(&outcome.out)?;
    }
    Ok(())
}

/// Draws a complete sweep file's figures and, with amplitude and frequency axes, its boundary.
pub fn figures_and_boundary(out: &std::path::Path) -> Result<(), AppError> {
    let d = sweep::read::SweepData::read(out).map_err(SweepError::from)?;
    if let Err(e) = d.require_results() {
        // The sweep itself is complete: its statuses say what failed.
        crate::note!("no figures or boundary: {e}");
        return Ok(());
    }
    for f in sweep::figures::plot_all(&d, &out.with_extension(""))? {
        crate::say!("wrote {}", f.display());
    }
    let has_amplitude = ["u0", "v_a", "va_ratio"].iter().any(|n| d.dim(n).is_some());
    if has_amplitude && d.dim("f").is_some() {
        let (csv, _) = sweep::boundary::run(out)?;
        crate::say!("wrote {} (elimination boundary)", csv.display());
    }
    Ok(())
}

/// Writes a complete sweep file's elimination boundary (group `boundary` and the CSV beside
/// it) where it has amplitude and frequency axes and results; draws no figure.
pub fn boundary_into(out: &std::path::Path) -> Result<(), AppError> {
    let d = sweep::read::SweepData::read(out).map_err(SweepError::from)?;
    let has_amplitude = ["u0", "v_a", "va_ratio"].iter().any(|n| d.dim(n).is_some());
    if d.require_results().is_ok() && has_amplitude && d.dim("f").is_some() {
        sweep::boundary::run(out)?;
    }
    Ok(())
}

/// `stickslip merge`.
pub fn merge_cmd(a: &MergeArgs) -> Result<(), AppError> {
    let sweep = match &a.sweep {
        Some(f) => Some(sweep::spec::SweepSpec::load(f).map_err(CliError::from)?),
        None => None,
    };
    if let Some(t) = a.threads
        && (t == 0 || t > 1024)
    {
        return Err(CliError::Flag {
            flag: "threads".into(),
            value: t.to_string(),
            msg: "must be from 1 to 1024".into(),
        }
        .into());
    }
    let inputs: Vec<&std::path::Path> = a.sweep.iter().map(|p| p.as_path()).collect();
    crate::cli::check_output("out", &a.out, &inputs)?;
    // The shards' folder holds the inputs (records, shard files, journals): the output may not
    // be written among them.
    let shards = a
        .shards
        .clone()
        .unwrap_or_else(|| sweep::shard::dir_for(&a.out));
    let canon = |p: &std::path::Path| {
        std::path::absolute(p).ok().map(|p| {
            p.parent()
                .and_then(|d| d.canonicalize().ok())
                .map(|d| d.join(p.file_name().unwrap_or_default()))
                .unwrap_or(p)
        })
    };
    if let (Some(o), Ok(d)) = (canon(&a.out), shards.canonicalize())
        && o.starts_with(&d)
    {
        return Err(CliError::Flag {
            flag: "out".into(),
            value: a.out.display().to_string(),
            msg: format!(
                "lies in the shards' folder {}, among this merge's inputs; give an output outside it",
                shards.display()
            ),
        }
        .into());
    }
    let o = sweep::merge::merge(&sweep::merge::MergeOptions {
        out: a.out.clone(),
        shards: a.shards.clone(),
        sweep,
        partial: a.partial,
        threads: a.threads,
    })?;
    crate::say!(
        "wrote {}: {} shards merged{}, {} points, {} computed, {} failed, {:.1} s",
        o.out.display(),
        o.shards - o.incomplete.len(),
        if o.incomplete.is_empty() {
            String::new()
        } else {
            format!(
                " ({} missing or unfinished: {}; sweep_status = partial)",
                o.incomplete.len(),
                o.incomplete
                    .iter()
                    .map(|s| s.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        o.points,
        o.computed,
        o.failed,
        o.wall_time
    );
    if !a.no_plot {
        figures_and_boundary(&o.out)?;
    }
    Ok(())
}

/// `stickslip preflight`: the acquisition of every recording, as `diagnose` examines it.
pub fn preflight_cmd(a: &crate::cli::PreflightArgs) -> Result<(), AppError> {
    let c = Campaign::load(&a.campaign)?;
    let n = c.recordings.len();
    let dir = c.dir.display().to_string();
    let pre = match campaign::acquisition::prepare(c.clone()) {
        Ok(p) => p.acquisition,
        Err(_) => {
            // Every recording set aside: the findings still say why.
            let mut acq = c.acquisition.clone();
            acq.recordings = c
                .recordings
                .iter()
                .map(campaign::acquisition::examine)
                .collect();
            acq
        }
    };
    let mut text = format!("campaign {dir}: {n} recordings examined\n");
    let lines = pre.report();
    if lines.is_empty() {
        text += "nothing of note: no gap, clip, mains line, clock offset, coarse quantisation, coloured noise, drift or gain error found\n";
    }
    for l in lines {
        text += &l;
        text += "\n";
    }
    let json = serde_json::to_string_pretty(&pre).unwrap_or_default();
    match &a.json {
        Some(p) if p.as_os_str() == "-" => {
            eprint!("{text}");
            println!("{json}");
        }
        Some(p) => {
            output::ensure_parent(p)?;
            std::fs::write(p, json).map_err(|e| CampaignError::Io {
                path: p.display().to_string(),
                msg: e.to_string(),
            })?;
            crate::console::print(format_args!("{text}"));
            crate::say!("wrote {}", p.display());
        }
        None => crate::console::print(format_args!("{text}")),
    }
    Ok(())
}

/// `stickslip status`.
pub fn status_cmd(a: &StatusArgs) -> Result<(), AppError> {
    let s = sweep::status::status(&a.out)?;
    crate::console::print(format_args!("{s}"));
    Ok(())
}

/// `stickslip slurm`.
pub fn slurm_cmd(a: &SlurmArgs) -> Result<(), AppError> {
    let spec = sweep::spec::SweepSpec::load(&a.file).map_err(CliError::from)?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| std::path::PathBuf::from("results").join(format!("{}.h5", spec.name)));
    crate::cli::check_output("out", &out, &[&a.file])?;
    let abs = |p: &std::path::Path| -> Result<std::path::PathBuf, AppError> {
        std::path::absolute(p).map_err(|e| SlurmError::Io(format!("{}: {e}", p.display())).into())
    };
    let exe = std::env::current_exe()
        .map_err(|e| SlurmError::Io(format!("the stickslip program's path: {e}")))?;
    let job = SlurmJob {
        file: abs(&a.file)?,
        out: abs(&out)?,
        tasks: a.tasks,
        partition: a.partition.clone(),
        time: a.time.clone(),
        cpus: a.cpus_per_task,
        exe,
        name: format!("stickslip-{}", spec.name),
    };
    job.validate(&spec)?;
    job.check_shards(&spec)?;
    if a.resubmit {
        if sweep::is_complete(&job.out) {
            crate::say!("{} is complete; nothing to resubmit", out.display());
            return Ok(());
        }
        let cancelled = job.cancel_waiting_merges()?;
        if !cancelled.is_empty() {
            crate::say!(
                "cancelled merge job(s) {} left waiting on earlier tasks",
                cancelled.join(", ")
            );
        }
        let left = job.to_resubmit()?;
        let (array, merge) = job.submit(Some(&left))?;
        match array {
            Some(id) => crate::say!(
                "submitted array job {id} ({} task(s): {})",
                left.len(),
                left.iter()
                    .map(|i| i.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            ),
            None => crate::say!("every shard is complete or still queued; no tasks submitted"),
        }
        crate::say!("submitted merge job {merge} -> {}", out.display());
        return Ok(());
    }
    let (script, merge_script) = job.write_scripts()?;
    crate::say!("wrote {} ({} array tasks)", script.display(), a.tasks);
    crate::say!("wrote {}", merge_script.display());
    if a.submit {
        let (array, merge) = job.submit(None)?;
        crate::say!(
            "submitted array job {} and merge job {merge} (afterok); {} is complete once the merge job has finished",
            array.expect("the whole array"),
            out.display()
        );
        crate::say!("follow it with: stickslip status {}", out.display());
    } else {
        crate::say!(
            "submit with: jid=$(sbatch --parsable {}) && sbatch --dependency=afterok:$jid {}   (or: stickslip slurm {} --tasks {} --submit)",
            crate::slurm::quote(&script),
            crate::slurm::quote(&merge_script),
            crate::slurm::quote(&a.file),
            a.tasks
        );
    }
    Ok(())
}

/// `stickslip plot`.
pub fn plot_cmd(a: &PlotArgs) -> Result<(), AppError> {
    if let Some(case) = &a.law {
        return law_cmd(case, a.out.as_deref());
    }
    let file = a.file.as_ref().expect("clap asks for a file without --law");
    let stem = a.out.clone().unwrap_or_else(|| file.with_extension(""));
    // The figures are STEM_map.png, ...: their folder must be one.
    crate::cli::check_output(
        "out",
        &std::path::PathBuf::from(format!("{}_map.png", stem.display())),
        &[file],
    )?;
    let d = sweep::read::SweepData::read(file).map_err(SweepError::from)?;
    d.require_results().map_err(SweepError::State)?;
    for f in sweep::figures::plot_all(&d, &stem)? {
        crate::say!("wrote {}", f.display());
    }
    Ok(())
}

/// `stickslip plot --law CASE`: the averaged law of the case's point, its zones and nodes.
fn law_cmd(case: &std::path::Path, out: Option<&std::path::Path>) -> Result<(), AppError> {
    use crate::averaged::{AveragingOptions, Table, table_span};
    let c = crate::config::load_case(case).map_err(CliError::from)?;
    let p = c.params;
    if !p.vibrates() {
        return Err(CliError::Flag {
            flag: "law".into(),
            value: case.display().to_string(),
            msg: "the case has no vibration (f and u0 must be > 0): there is no law to average"
                .into(),
        }
        .into());
    }
    let stem = out.map(std::path::Path::to_path_buf).unwrap_or_else(|| {
        let name = case
            .file_stem()
            .map_or("case".into(), |s| s.to_string_lossy());
        std::path::PathBuf::from(format!("results/{name}_law"))
    });
    let csv = stem.with_extension("csv");
    crate::cli::check_output("out", &csv, &[case])?;
    let waiting = crate::progress::Waiting::new(
        "building the averaged law",
        std::time::Duration::from_secs(2),
        true,
    );
    let t = Table::build(&p, table_span(&p), AveragingOptions::default()).map_err(|e| {
        CliError::Flag {
            flag: "law".into(),
            value: case.display().to_string(),
            msg: e.to_string(),
        }
    })?;
    drop(waiting);
    let mut text =
        String::from("V_m_per_s,F_eff_N,slope_N_s_per_m,fast_multiplier_modulus,contracting\n");
    for n in &t.nodes {
        text += &format!(
            "{},{},{},{},{}\n",
            n.v_mean,
            n.force,
            n.slope,
            n.fast_modulus(),
            u8::from(n.contracting())
        );
    }
    crate::output::ensure_parent(&csv)?;
    std::fs::write(&csv, text).map_err(crate::output::ioerr(&csv))?;
    let title = format!(
        "averaged friction law: f = {} Hz, v_a = {:.3} mm/s, v_d = {} mm/s",
        p.f,
        p.v_a() * 1e3,
        p.v_d * 1e3
    );
    let mut written = vec![csv];
    written.extend(crate::plot::law_figure(&stem, &t, &p, &title)?);
    for f in written {
        crate::say!("wrote {}", f.display());
    }
    crate::say!(
        "{} nodes; {} with a fast orbit that does not contract; {} gap(s); {}",
        t.nodes.len(),
        t.nodes.iter().filter(|n| !n.contracting()).count(),
        t.gaps.len(),
        match t.stopped_at {
            Some(v) => format!("no orbit found beyond V = {v:.3e} m/s"),
            None => format!("up to V = {:.3e} m/s", table_span(&p)),
        }
    );
    Ok(())
}

/// `stickslip boundary`.
pub fn boundary_cmd(a: &BoundaryArgs) -> Result<(), AppError> {
    sweep::read::SweepData::read(&a.file)
        .map_err(SweepError::from)?
        .require_results()
        .map_err(SweepError::State)?;
    let (csv, pts) = sweep::boundary::run(&a.file)?;
    let mut out = crate::console::stdout();
    for p in &pts {
        let coords = p
            .coords
            .iter()
            .map(|(n, v)| sweep::figures::format_value(n, *v))
            .collect::<Vec<_>>()
            .join(", ");
        if p.u0.is_finite() {
            let _ = writeln!(
                out,
                "{coords}: u0 = {:.4e} m (v_a/v_d = {:.3}; rule of thumb u0 = {:.4e} m){}",
                p.u0,
                p.va_ratio,
                p.u0_rule,
                if p.below_range {
                    ", at or below the grid's smallest amplitude"
                } else {
                    ""
                }
            );
        } else {
            let _ = writeln!(
                out,
                "{coords}: not eliminated within the grid (rule of thumb u0 = {:.4e} m)",
                p.u0_rule
            );
        }
    }
    let _ = writeln!(
        out,
        "wrote {} and group /boundary in {}",
        csv.display(),
        a.file.display()
    );
    Ok(())
}

/// `stickslip run`.
pub fn run(a: &RunArgs) -> Result<(), AppError> {
    let case = a.resolve()?;
    let mut solver = Solver::new(case.run.method);
    let waiting = crate::progress::Waiting::new(
        &format!(
            "simulating{} (and the run without vibration)",
            case.run
                .t_end
                .map(|t| format!(" {t} s"))
                .unwrap_or_default()
        ),
        std::time::Duration::from_secs(2),
        true,
    );
    // The repeats share the first run's table of the averaged law unless asked to build their own.
    let mut store = crate::averaged::TableStore::new();
    let mut res = sim::run_case_in(&case.params, &case.effects, &case.run, &mut solver, &store)?;
    drop(waiting);
    // Timing: the run's own wall time (as `wall_time`; the reference without vibration is timed
    // apart), its median over the repeats, as hyperfine and the peers' timing loops report.
    let mut times = vec![res.run.wall_time];
    for _ in 1..a.repeats {
        if a.fresh_tables {
            store = crate::averaged::TableStore::new();
        }
        res = sim::run_case_in(&case.params, &case.effects, &case.run, &mut solver, &store)?;
        times.push(res.run.wall_time);
    }
    times.sort_by(f64::total_cmp);
    let timing = (a.repeats > 1).then(|| (times[times.len() / 2], times[0]));
    // Only a successful run is written: a failed or unsettled one never replaces an earlier
    // result (its measures, where it has them, are printed and flagged).
    let status = res.status();
    let failed = |why: String| {
        let mut kept = vec![a.out.display().to_string()];
        kept.extend(a.csv.iter().map(|p| p.display().to_string()));
        AppError::Failed(format!(
            "{why} (nothing written; {} left untouched)",
            kept.join(", ")
        ))
    };
    if !status.has_measures() {
        return Err(failed(status.name().to_string()));
    }
    let mut written = vec![];
    if status == crate::ode::Status::Success {
        output::write_case_h5(&a.out, &res, &case.run, &case.effects)?;
        written.push(a.out.clone());
    }
    if status == crate::ode::Status::Success
        && let (Some(path), Some(tr)) = (&a.csv, &res.run.trace)
    {
        output::write_trace_csv(path, tr)?;
        written.push(path.clone());
    }
    if a.plot
        && status == crate::ode::Status::Success
        && let Some(tr) = &res.run.trace
    {
        let p = &case.params;
        let title = format!(
            "k_d = {} N/m, v_d = {} mm/s, f = {} Hz, v_a = {:.3} mm/s{}: r = {:.3}",
            p.k_d,
            p.v_d * 1e3,
            p.f,
            p.v_a() * 1e3,
            if p.two_stage() {
                format!(" from t = {} s", p.t_on)
            } else {
                String::new()
            },
            res.r
        );
        written.extend(plot::trace_figure(&a.out.with_extension(""), tr, &title)?);
    }
    let mut out = crate::console::stdout();
    if a.json {
        let mut v = run_report_json(&res, &case);
        if let Some((median, min)) = timing {
            let obj = v.as_object_mut().expect("object");
            obj.insert("repeats".into(), serde_json::json!(a.repeats));
            obj.insert("wall_time_median".into(), serde_json::json!(median));
            obj.insert("wall_time_min".into(), serde_json::json!(min));
        }
        let _ = writeln!(out, "{v}");
    } else {
        let _ = write!(out, "{}", case_summary(&res, &case.run));
        if !case.effects.is_empty() {
            let _ = writeln!(out, "effects   {}", case.effects.describe());
        }
        if let Some((median, min)) = timing {
            let _ = writeln!(
                out,
                "wall time over {} repeats: median {:.3} ms, fastest {:.3} ms",
                a.repeats,
                median * 1e3,
                min * 1e3
            );
        }
        for w in &written {
            let _ = writeln!(out, "wrote {}", w.display());
        }
    }
    if status != crate::ode::Status::Success {
        let why = failure_reason(&res, &case);
        return Err(failed(why));
    }
    Ok(())
}

/// Why a run that did not succeed failed, as `stickslip run` says it: the status, and for an
/// unsettled run the simulated time it would need.
pub fn failure_reason(res: &CaseResult, case: &crate::config::Case) -> String {
    match (res.status(), case.run.t_end) {
        (crate::ode::Status::Unsettled, Some(t)) => {
            let auto = sim::planned_time(&case.params, case.run.min_cycles);
            format!(
                "unsettled: t_end = {t} s is too short for the stick-slip to settle and be \
                 measured over {} cycles of about {:.3} s each; give t_end >= {auto:.3} s, \
                 or leave t_end out to have it chosen",
                case.run.min_cycles,
                case.params.cycle_estimate()
            )
        }
        (crate::ode::Status::Unsettled, None) => "unsettled: the stick-slip did not settle \
             within the automatic time; give a longer t_end"
            .to_string(),
        (s, _) => s.name().to_string(),
    }
}

/// What `stickslip run --json` prints for a case: [`case_json`] with the effects that were on.
pub fn run_report_json(res: &CaseResult, case: &crate::config::Case) -> serde_json::Value {
    let mut v = case_json(res, &case.run);
    let obj = v.as_object_mut().expect("object");
    obj.insert("effects".into(), case.effects.to_json());
    obj.insert(
        "effects_described".into(),
        serde_json::json!(case.effects.describe()),
    );
    v
}

fn finite(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

fn run_json(r: &sim::RunResult) -> serde_json::Value {
    let m = &r.measures;
    let mut obj = serde_json::json!({
        "status": r.status.name(),
        "t_end": r.t_end,
        "window_start": r.window_start,
        "wall_time": r.wall_time,
        "continued_from": r.continued_from,
        "predicted": r.predicted(),
        "level_error": r.level_error,
        "tier": r.tier.name(),
        "tier_reason": r.tier_reason.name(),
        "tier_reason_text": r.tier_reason.text(),
        "stats": r.stats,
    });
    let fields = obj.as_object_mut().expect("object");
    for k in Measure::OF_RUN {
        let v = match k {
            Measure::Cycles => serde_json::json!(m.cycles),
            k => finite(k.of_run(m).unwrap_or(f64::NAN)),
        };
        fields.insert(k.name().into(), v);
    }
    obj
}

/// The results of a case as one JSON object (non-finite numbers become null).
pub fn case_json(c: &CaseResult, o: &RunOptions) -> serde_json::Value {
    let mut v = run_json(&c.run);
    let obj = v.as_object_mut().expect("object");
    obj.insert("status".into(), serde_json::json!(c.status().name()));
    obj.insert("r".into(), finite(c.r));
    obj.insert("r_stderr".into(), finite(c.r_stderr));
    obj.insert("v_a".into(), finite(c.params.v_a()));
    obj.insert("va_ratio".into(), finite(c.params.v_a() / c.params.v_d));
    obj.insert(
        "params".into(),
        serde_json::to_value(c.params).expect("params serialise"),
    );
    obj.insert(
        "solver".into(),
        serde_json::json!({
            "method": o.method.name(),
            "rtol": o.ode.rtol,
            "atol": o.ode.atol,
            "tier": o.tier.name(),
        }),
    );
    obj.insert(
        "reference".into(),
        c.reference
            .as_ref()
            .map(run_json)
            .unwrap_or(serde_json::Value::Null),
    );
    v
}

/// The lines of [`case_summary`] for `r` and `dF`, with what their standard errors can say.
fn measures_lines(c: &CaseResult, s: &mut String) {
    use std::fmt::Write as _;
    let m = &c.run.measures;
    let ref_slides = c.reference.as_ref().is_some_and(|r| r.measures.cycles == 0);
    // One cycle of a run with vibration: dF's spread, and so r's error, unknown
    // (`Measures::varying_cycles`); a failed run's NaN measures are not that.
    let one_cycle = m.cycles == 1 && m.d_f_stderr.is_nan();
    if ref_slides {
        let _ = writeln!(
            s,
            "r         undefined: the run without vibration has no stick-slip cycle either (nothing to reduce)"
        );
    } else if one_cycle {
        let _ = writeln!(
            s,
            "r         {:.4}, standard error unknown: a window with a single stick-slip cycle (dF with / without vibration, Eq. 5.1)",
            c.r
        );
    } else {
        let _ = writeln!(
            s,
            "r         {:.4} ± {:.4}   (dF with / without vibration, Eq. 5.1)",
            c.r, c.r_stderr
        );
    }
    if m.cycles == 0 {
        let _ = writeln!(
            s,
            "dF        0 N: no stick-slip cycle in the steady window ({})",
            if m.stick_fraction > 0.5 {
                "the body sticks throughout"
            } else {
                "the body slides"
            }
        );
    } else if one_cycle {
        let _ = writeln!(
            s,
            "dF        {:.4} N over 1 cycle (standard error unknown: a spread needs two)",
            m.d_f
        );
    } else {
        let _ = writeln!(
            s,
            "dF        {:.4} ± {:.4} N over {} cycles",
            m.d_f, m.d_f_stderr, m.cycles
        );
    }
}

/// A readable summary of a case.
pub fn case_summary(c: &CaseResult, o: &RunOptions) -> String {
    use std::fmt::Write as _;
    let p = &c.params;
    let m = &c.run.measures;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "case      k_d = {} N/m, v_d = {} mm/s, f = {} Hz, u0 = {:.4e} m (v_a = {:.4} mm/s, v_a/v_d = {:.3})",
        p.k_d,
        p.v_d * 1e3,
        p.f,
        p.u0,
        p.v_a() * 1e3,
        p.v_a() / p.v_d
    );
    if p.two_stage() {
        let _ = writeln!(
            s,
            "          two stages: resting substrate until t_on = {} s, vibrating after",
            p.t_on
        );
    }
    let _ = writeln!(
        s,
        "          F_s = {} N, F_c = {} N, v_s = {} m/s, k_t = {:e} N/m, h_t = {} N s/m, h_d = {} N s/m, m = {:.4} kg",
        p.f_s, p.f_c, p.v_s, p.k_t, p.h_t, p.h_d, p.m
    );
    let _ = writeln!(s, "status    {}", c.status().name());
    measures_lines(c, &mut s);
    let _ = writeln!(s, "mean F_d  {:.4} N", m.mean_force);
    let _ = writeln!(
        s,
        "peak      {:.4} N   trough {:.4} N   period {:.4} s   stick fraction {:.3}",
        m.peak_force, m.trough_force, m.period, m.stick_fraction
    );
    if let Some(r) = &c.reference {
        let rm = &r.measures;
        let _ = writeln!(
            s,
            "reference dF {:.4} ± {:.4} N, mean F_d {:.4} N, period {:.4} s (no vibration)",
            rm.d_f, rm.d_f_stderr, rm.mean_force, rm.period
        );
    }
    // An extrapolated run reports the level its window's approach leads to.
    let how = if let Some(e) = c.run.level_error {
        format!("the settled level extrapolated from it, mean force ± {e:.2e} N")
    } else if c.run.status == crate::ode::Status::Unsettled {
        "still settling at the longest simulated time: unsettled".to_string()
    } else if p.two_stage() {
        "second half of the second stage".to_string()
    } else {
        "second half of the run".to_string()
    };
    let end = c.run.t_end;
    let _ = writeln!(
        s,
        "window    {:.3} s to {:.3} s ({how})",
        c.run.window_start, end
    );
    let _ = writeln!(
        s,
        "tier      {} (asked {}): {}",
        c.run.tier,
        o.tier,
        c.run.tier_reason.text()
    );
    if c.run.tier.uses_law() {
        let _ = writeln!(
            s,
            "          {}; its statistics below leave out the law's table \
             (shared by every run of the same f, u0, v_d and contact)",
            if c.run.tier == crate::sim::Tier::Hybrid {
                "the averaged slow model with full windows in the law's zones"
            } else {
                "the averaged slow model"
            }
        );
    }
    let st = c.total_stats();
    let wall = c.run.wall_time + c.reference.as_ref().map(|r| r.wall_time).unwrap_or(0.0);
    let _ = writeln!(
        s,
        "solver    {} rtol {:e} atol {:e}: {} steps, {} rejected, {} RHS, {} Jacobians, {} LU, {:.3} s",
        o.method,
        o.ode.rtol,
        o.ode.atol,
        st.steps,
        st.rejected,
        st.rhs_evals,
        st.jac_evals,
        st.lu_decomps,
        wall
    );
    // Where a limit cycle took over: the run's own (without vibration, or the averaged slow
    // model's), else its reference's.
    let continued = c.run.continued_from.map(|t| (t, "")).or_else(|| {
        c.reference
            .as_ref()
            .and_then(|r| r.continued_from)
            .map(|t| (t, " of the reference"))
    });
    if let Some((t, whose)) = continued {
        let _ = writeln!(
            s,
            "          samples after {t:.3} s read off the repeating stick-slip cycle{}",
            whose
        );
    }
    s
}
