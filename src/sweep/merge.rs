//! `stickslip merge`: the shards of a sweep ([`super::shard`]) assembled into the file a single
//! machine would have written.
//!
//! The runs come from the shards' records (`I-of-N.runs`, the journal format: every number in
//! its shortest round-trip form), so the merged datasets equal a single-machine run's bit for
//! bit on every measure and statistic; only wall times and the `started`/`finished` attributes
//! differ (`started` is the earliest shard's start). A reference run made by several shards is
//! the same run; the lowest shard's record is kept. The traces of `[output] traces` are run by
//! the merge itself (a handful of runs, deterministic).
//!
//! Every shard must carry the fingerprint of the sweep file and program version the merge is
//! made for (`--sweep FILE`, or else the sweep text stored in the shards' HDF5 files), and every
//! shard `0..N` must be complete, judged from its record ([`judge`]): every run the shard must
//! make there, each line whole by its checksum. Otherwise the merge names what is missing,
//! unfinished, lacking or foreign. With `partial`, it writes what there is: missing points NaN, status −1,
//! `sweep_status = "partial"`.

use super::journal;
use super::shard::{self, Shard};
use super::spec::SweepSpec;
use super::{Plan, Results, SweepError, h5};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How to merge. Fields document their defaults.
#[derive(Clone, Debug)]
pub struct MergeOptions {
    /// The merged sweep file.
    pub out: PathBuf,
    /// The folder of the shards. Default `None`: `OUT.shards/` beside `out`.
    pub shards: Option<PathBuf>,
    /// The sweep file the shards were made from. Default `None`: the sweep text stored in the
    /// shards' HDF5 files (the lowest shard that has one).
    pub sweep: Option<SweepSpec>,
    /// Write what there is when shards are missing or unfinished (`sweep_status = "partial"`).
    /// Default false: refuse, naming them.
    pub partial: bool,
    /// Worker threads for the traces; `None`: one per core.
    pub threads: Option<usize>,
}

/// What one shard holds on disk.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShardState {
    /// Complete: `I-of-N.runs` beside a complete `I-of-N.h5`.
    Complete,
    /// Started (a journal with this many records) but not complete: running, or interrupted.
    Unfinished {
        /// Runs recorded so far.
        runs: usize,
    },
    /// A record `I-of-N.runs` that lacks runs the shard must make: cut short, damaged lines
    /// (their checksums fail), only its header, or another shard's copy.
    Broken {
        /// Whole records of this sweep in it.
        runs: usize,
        /// Runs of the shard it lacks (for a refinement, at least these: the rounds after
        /// them are not known yet).
        missing: usize,
        /// Lines dropped as damaged.
        damaged: usize,
    },
    /// Nothing on disk.
    Missing,
}

/// Runs of shard `sh` that `records` lack: every task of its points (or of its coarse points
/// and, replayed from the records, every round of its refinement) must be there.
pub fn missing_runs(
    spec: &SweepSpec,
    plan: &Plan,
    sh: Shard,
    records: Vec<(journal::Task, crate::sim::RunResult)>,
) -> usize {
    let owners = shard::owners(spec, sh.count);
    let mine = |i: usize| owners[i] == sh.index;
    let mut results = Results::new(plan);
    results.absorb(plan, records);
    let first = super::tasks_of(plan, &super::first_points(spec, mine));
    let mut missing = first.iter().filter(|t| !results.has(**t)).count();
    if spec.refine.is_some() && missing == 0 {
        for p in 0..super::refine::plane_count(spec) {
            let pts: Vec<usize> = super::refine::next_points(spec, plan, &results, p)
                .into_iter()
                .filter(|&i| mine(i))
                .collect();
            missing += super::tasks_of(plan, &pts)
                .iter()
                .filter(|t| !results.has(**t))
                .count();
        }
    }
    missing
}

/// The state of shard `sh` (file `h5`) judged from its record: complete only where
/// `I-of-N.runs` holds every run the shard must make ([`missing_runs`]), each record whole
/// (its checksum) and of this sweep and program (fingerprint `fp`). A whole record stands even
/// where the shard's HDF5 file is damaged: the merge reads the runs from the record, and
/// `--resume` rebuilds the file from it. Errors for a record of another sweep.
pub fn judge(
    spec: &SweepSpec,
    plan: &Plan,
    sh: Shard,
    h5: &Path,
    fp: &str,
) -> Result<ShardState, String> {
    let runs = shard::runs_path(h5);
    if !runs.exists() {
        return Ok(match state(h5) {
            ShardState::Complete => ShardState::Unfinished { runs: 0 },
            st => st,
        });
    }
    let (records, damaged) = journal::read(&runs, fp)?;
    let n = records.len();
    let missing = missing_runs(spec, plan, sh, records);
    Ok(if missing == 0 {
        ShardState::Complete
    } else {
        ShardState::Broken {
            runs: n,
            missing,
            damaged,
        }
    })
}

/// The shards found beside a sweep output: their count and each one's state.
#[derive(Clone, Debug)]
pub struct Found {
    /// N.
    pub count: usize,
    /// State of shards 0 to N − 1.
    pub states: Vec<ShardState>,
}

/// Parses a shard file name `I-of-N.h5`, `I-of-N.runs` or `I-of-N.h5.journal`.
fn parse_name(name: &str) -> Option<Shard> {
    let stem = name
        .strip_suffix(".h5")
        .or_else(|| name.strip_suffix(".runs"))
        .or_else(|| name.strip_suffix(".h5.journal"))?;
    let (i, n) = stem.split_once("-of-")?;
    let s = format!("{i}/{n}");
    s.parse().ok()
}

/// Whether the shards' folder of `out` holds any shard file.
pub fn has_shards(out: &Path) -> bool {
    std::fs::read_dir(shard::dir_for(out)).is_ok_and(|d| {
        d.flatten()
            .any(|e| parse_name(&e.file_name().to_string_lossy()).is_some())
    })
}

/// Finds the shards of sweep output `out` in `OUT.shards/` (see [`find_in`]).
pub fn find(out: &Path) -> Result<Found, SweepError> {
    find_in(&shard::dir_for(out), out)
}

/// Finds the shards of sweep output `out` in folder `dir` (see [`Found`]). Errors when there
/// are none, or when shards of different counts lie side by side.
pub fn find_in(dir: &Path, out: &Path) -> Result<Found, SweepError> {
    let entries = std::fs::read_dir(dir).map_err(|e| {
        SweepError::State(format!(
            "no shards of {} found: {}: {e} (shards are made by `stickslip sweep FILE -o {} --shard I/N`)",
            out.display(),
            dir.display(),
            out.display()
        ))
    })?;
    let mut counts: BTreeMap<usize, usize> = BTreeMap::new();
    for e in entries.flatten() {
        if let Some(s) = parse_name(&e.file_name().to_string_lossy()) {
            *counts.entry(s.count).or_default() += 1;
        }
    }
    let count = match counts.len() {
        0 => {
            return Err(SweepError::State(format!(
                "no shards of {} found in {} (files I-of-N.h5, I-of-N.runs)",
                out.display(),
                dir.display()
            )));
        }
        1 => *counts.keys().next().expect("one"),
        _ => {
            return Err(SweepError::State(format!(
                "{} holds shards of {} splits (N = {}); keep the files of one split and remove the others",
                dir.display(),
                counts.len(),
                counts
                    .keys()
                    .map(|n| n.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    };
    let states = (0..count)
        .map(|index| state(&Shard { index, count }.path_in(dir)))
        .collect();
    Ok(Found { count, states })
}

/// The state of the shard whose file is `h5`.
pub fn state(h5: &Path) -> ShardState {
    if super::shard_complete(h5) {
        return ShardState::Complete;
    }
    let jpath = journal::path_for(h5);
    if jpath.exists() || h5.exists() {
        ShardState::Unfinished {
            runs: records_in(&jpath),
        }
    } else {
        ShardState::Missing
    }
}

/// The number of records in a journal or runs file (its lines after the header; 0 if absent).
pub fn records_in(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .map(|t| t.lines().skip(1).count())
        .unwrap_or(0)
}

/// The sweep text stored in a sweep or shard HDF5 file.
pub fn stored_spec(h5: &Path) -> Option<SweepSpec> {
    let f = rust_hdf5::H5File::open(h5).ok()?;
    let text = f.attr_string("sweep_file").ok()?;
    SweepSpec::parse(&h5.display().to_string(), &text).ok()
}

/// Summary of a merge.
#[derive(Clone, Debug)]
pub struct MergeOutcome {
    /// The merged file.
    pub out: PathBuf,
    /// Number of shards.
    pub shards: usize,
    /// Shards missing or unfinished (merged anyway with `partial`).
    pub incomplete: Vec<Shard>,
    /// Grid points.
    pub points: usize,
    /// Grid points with results.
    pub computed: usize,
    /// Points whose run or reference did not succeed.
    pub failed: usize,
    /// Wall time \[s\].
    pub wall_time: f64,
}

/// Merges the shards of `opts.out` into it (module docs).
pub fn merge(opts: &MergeOptions) -> Result<MergeOutcome, SweepError> {
    let t0 = Instant::now();
    let dir = opts
        .shards
        .clone()
        .unwrap_or_else(|| shard::dir_for(&opts.out));
    let found = find_in(&dir, &opts.out)?;
    crate::output::ensure_parent(&opts.out)?;
    let _lock = super::lock::acquire(&opts.out).map_err(SweepError::State)?;
    let n = found.count;
    let shards: Vec<Shard> = (0..n).map(|index| Shard { index, count: n }).collect();
    let path = |s: &Shard| s.path_in(&dir);
    let spec = match &opts.sweep {
        Some(s) => s.clone(),
        None => shards
            .iter()
            .find_map(|s| stored_spec(&path(s)))
            .ok_or_else(|| {
                SweepError::State(format!(
                    "none of the {n} shards in {} holds the sweep file's text; give it with --sweep FILE",
                    dir.display()
                ))
            })?,
    };
    shard::check(&spec, n).map_err(SweepError::State)?;
    let fp = journal::fingerprint(&spec.text);
    let plan = Plan::new(&spec);
    // Completeness from the records themselves, not from the files' flags.
    let states: Vec<ShardState> = shards
        .iter()
        .map(|s| {
            judge(&spec, &plan, *s, &path(s), &fp).map_err(|e| {
                SweepError::State(format!(
                    "shard {s} was not made from this sweep file and program version: {e}"
                ))
            })
        })
        .collect::<Result<_, _>>()?;
    let found = Found { count: n, states };
    let incomplete: Vec<(Shard, &ShardState)> = shards
        .iter()
        .zip(&found.states)
        .filter(|(_, st)| **st != ShardState::Complete)
        .map(|(s, st)| (*s, st))
        .collect();
    if !incomplete.is_empty() && !opts.partial {
        let list = incomplete
            .iter()
            .map(|(s, st)| match st {
                ShardState::Missing => {
                    format!("shard {s} is missing (no {})", path(s).display())
                }
                ShardState::Unfinished { runs } => format!(
                    "shard {s} is unfinished ({runs} runs recorded in {})",
                    journal::path_for(&path(s)).display()
                ),
                ShardState::Broken {
                    runs,
                    missing,
                    damaged,
                } => format!(
                    "shard {s}'s record {} lacks {missing} of its runs ({runs} whole records, \
                     {damaged} damaged lines)",
                    shard::runs_path(&path(s)).display()
                ),
                ShardState::Complete => unreachable!(),
            })
            .collect::<Vec<_>>()
            .join("; ");
        return Err(SweepError::State(format!(
            "{} of {n} shards of {} are not complete: {list}. Run them (`stickslip sweep FILE -o {} --shard I/{n} --resume`, \
             or `stickslip slurm FILE --tasks {n} --resubmit`), or merge what there is with --partial",
            incomplete.len(),
            opts.out.display(),
            opts.out.display()
        )));
    }
    let mut results = Results::new(&plan);
    let mut started: Option<String> = None;
    for (s, st) in shards.iter().zip(&found.states) {
        let file = match st {
            ShardState::Complete | ShardState::Broken { .. } => shard::runs_path(&path(s)),
            ShardState::Unfinished { .. } => journal::path_for(&path(s)),
            ShardState::Missing => continue,
        };
        if !file.exists() {
            continue;
        }
        let (records, _) = journal::read(&file, &fp).map_err(|e| {
            SweepError::State(format!(
                "shard {s} was not made from this sweep file and program version: {e}"
            ))
        })?;
        results.absorb(&plan, records);
        if let Some(st) = rust_hdf5::H5File::open(path(s))
            .ok()
            .and_then(|f| f.attr_string("started").ok())
            .filter(|t| !t.is_empty())
            && started.as_ref().is_none_or(|s0| st < *s0)
        {
            started = Some(st);
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.unwrap_or(0))
        .build()
        .map_err(|e| SweepError::State(e.to_string()))?;
    // The merge owns the tables of the averaged law its traced runs build.
    let store = crate::averaged::TableStore::new();
    let traced = super::traces(&spec, &plan, &results, &pool, &store);
    let started = started.unwrap_or_else(crate::output::now_iso);
    let finished = crate::output::now_iso();
    crate::output::ensure_parent(&opts.out)?;
    h5::write(
        &opts.out,
        &spec,
        &plan,
        &results,
        &traced,
        h5::Stamp {
            started: &started,
            finished: Some(&finished),
            partial: !incomplete.is_empty(),
            shard: None,
        },
    )?;
    let all = vec![true; plan.points.len()];
    let computed = (0..plan.points.len())
        .filter(|&i| results.point(&plan, i).0.is_some())
        .count();
    Ok(MergeOutcome {
        out: opts.out.clone(),
        shards: n,
        incomplete: incomplete.iter().map(|(s, _)| *s).collect(),
        points: plan.points.len(),
        computed,
        failed: super::failed_points(&spec, &plan, &results, &all),
        wall_time: t0.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_file_names_parse() {
        assert_eq!(
            parse_name("3-of-8.runs"),
            Some(Shard { index: 3, count: 8 })
        );
        assert_eq!(
            parse_name("0-of-1.h5.journal"),
            Some(Shard { index: 0, count: 1 })
        );
        for other in [
            "3-of-8.csv",
            "8-of-8.h5",
            "x-of-2.h5",
            "array.sbatch",
            "3of8.h5",
        ] {
            assert_eq!(parse_name(other), None, "{other}");
        }
    }
}
