//! The shards on disk beside a sweep output: finding them, and each one's state judged from its
//! record (complete, unfinished, broken or missing). A sweep run and a merge both ask.

use super::error::SweepError;
use super::journal;
use super::plan::{Plan, Results, tasks_of};
use super::refine::first_points;
use super::shard::{self, Shard};
use super::spec::SweepSpec;
use std::collections::BTreeMap;
use std::path::Path;

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
    let first = tasks_of(plan, &first_points(spec, mine));
    let mut missing = first.iter().filter(|t| !results.has(**t)).count();
    if spec.refine.is_some() && missing == 0 {
        for p in 0..super::refine::plane_count(spec) {
            let pts: Vec<usize> = super::refine::next_points(spec, plan, &results, p)
                .into_iter()
                .filter(|&i| mine(i))
                .collect();
            missing += tasks_of(plan, &pts)
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
pub(crate) fn parse_name(name: &str) -> Option<Shard> {
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
    if super::h5::shard_complete(h5) {
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
