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

use super::error::SweepError;
use super::h5;
use super::journal;
use super::plan::{Plan, Results};
use super::shard::{self, Shard};
use super::spec::SweepSpec;
use std::path::PathBuf;
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

pub use super::shards::*;

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
    let traced = super::traces::traces(&spec, &plan, &results, &pool, &store);
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
        failed: super::plan::failed_points(&spec, &plan, &results, &all),
        wall_time: t0.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::shards::parse_name;

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
