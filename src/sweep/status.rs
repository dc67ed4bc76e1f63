//! `stickslip status OUT.h5`: how far a sweep has come, on one machine or in shards on many.
//!
//! Read from the files alone (no scheduler is asked): the output's `sweep_status`, the journal
//! beside it, and for each shard in `OUT.h5.shards/` its state, the runs recorded and the runs it
//! needs (for a `[refine]` sweep only the coarse grid's are known in advance, so the count
//! grows), and how long ago its journal last grew (a shard whose journal has not grown for long
//! is interrupted, not running).

use super::error::SweepError;
use super::journal;
use super::merge::{self, ShardState};
use super::plan::{Plan, tasks_of};
use super::refine::first_points;
use super::shard::{self, Shard};
use super::spec::SweepSpec;
use std::fmt;
use std::path::{Path, PathBuf};

/// One part of a sweep: the whole of it on one machine, or a shard.
#[derive(Clone, Debug)]
pub struct PartStatus {
    /// The shard, or `None` for the single-machine sweep.
    pub shard: Option<Shard>,
    /// Its state.
    pub state: ShardState,
    /// Runs recorded (journal or, for a complete shard, its runs file).
    pub runs: usize,
    /// Runs it needs: all of a dense sweep's, the coarse grid's of a `[refine]` sweep (more
    /// follow where the level lies); `None` where the sweep file is not known yet.
    pub planned: Option<usize>,
    /// Seconds since its journal last grew.
    pub idle: Option<f64>,
}

/// A sweep's progress (module docs).
#[derive(Clone, Debug)]
pub struct SweepStatus {
    /// The sweep output.
    pub out: PathBuf,
    /// The output's `sweep_status` (`complete`, `in_progress`, `partial`), `None` if absent.
    pub file_status: Option<String>,
    /// Whether the sweep refines (planned counts are the coarse grid's).
    pub refine: bool,
    /// The single-machine journal, if any.
    pub local: Option<PartStatus>,
    /// Shards, if any.
    pub shards: Vec<PartStatus>,
    /// A shards' folder without shards yet (a job array still in the queue).
    pub waiting: bool,
}

fn idle_of(path: &Path) -> Option<f64> {
    let m = std::fs::metadata(path).ok()?.modified().ok()?;
    Some(m.elapsed().map(|d| d.as_secs_f64()).unwrap_or(0.0))
}

/// The runs a part of the sweep needs (see [`PartStatus::planned`]).
fn planned(spec: &SweepSpec, plan: &Plan, owned: impl Fn(usize) -> bool) -> usize {
    tasks_of(plan, &first_points(spec, owned)).len()
}

/// Reads the status of sweep output `out` (module docs).
pub fn status(out: &Path) -> Result<SweepStatus, SweepError> {
    // A device or pipe would block the HDF5 reader or be read for ever.
    if crate::output::special(out) {
        return Err(SweepError::State(format!(
            "{} is not a regular file (a device, pipe, socket or folder); give a sweep output",
            out.display()
        )));
    }
    let file_status = rust_hdf5::H5File::open(out)
        .ok()
        .and_then(|f| f.attr_string("sweep_status").ok());
    if out.exists() && file_status.is_none() {
        return Err(SweepError::State(format!(
            "{} is not a stickslip sweep file (no sweep_status attribute)",
            out.display()
        )));
    }
    let dir = shard::dir_for(out);
    // A shards' folder without shard files yet: a job array waiting in the queue.
    let found = if dir.is_dir() {
        match merge::find(out) {
            Ok(f) => Some(f),
            Err(e) if merge::has_shards(out) => return Err(e),
            Err(_) => None,
        }
    } else {
        None
    };
    let waiting = dir.is_dir() && found.is_none();
    // The sweep, from the output or any shard (each writes a checkpoint as it starts).
    let spec = merge::stored_spec(out).or_else(|| {
        let f = found.as_ref()?;
        (0..f.count).find_map(|index| {
            merge::stored_spec(
                &Shard {
                    index,
                    count: f.count,
                }
                .path(out),
            )
        })
    });
    let plan = spec.as_ref().map(Plan::new);
    let jpath = journal::path_for(out);
    let local = jpath.exists().then(|| {
        // One read of the journal, which can hold tens of thousands of records.
        let runs = merge::records_in(&jpath);
        PartStatus {
            shard: None,
            state: ShardState::Unfinished { runs },
            runs,
            planned: spec
                .as_ref()
                .zip(plan.as_ref())
                .map(|(s, p)| planned(s, p, |_| true)),
            idle: idle_of(&jpath),
        }
    });
    let mut shards = vec![];
    if let Some(f) = &found {
        let owners = spec
            .as_ref()
            .filter(|s| shard::check(s, f.count).is_ok())
            .map(|s| shard::owners(s, f.count));
        let fp = spec.as_ref().map(|s| journal::fingerprint(&s.text));
        for (index, state) in f.states.iter().enumerate() {
            let sh = Shard {
                index,
                count: f.count,
            };
            let h5 = sh.path(out);
            // Completeness from the records themselves, where the sweep is known.
            let judged = match (&spec, &plan, &owners, &fp) {
                (Some(s), Some(p), Some(_), Some(fp)) => merge::judge(s, p, sh, &h5, fp)
                    .map_err(|e| SweepError::State(format!("shard {sh}: {e}")))?,
                _ => state.clone(),
            };
            let state = &judged;
            let (runs, idle) = match state {
                ShardState::Complete => (merge::records_in(&shard::runs_path(&h5)), None),
                ShardState::Broken { runs, .. } => (*runs, None),
                ShardState::Unfinished { runs } => (*runs, idle_of(&journal::path_for(&h5))),
                ShardState::Missing => (0, None),
            };
            let planned = match (&spec, &plan, &owners) {
                (Some(s), Some(p), Some(o)) => Some(planned(s, p, |i| o[i] == index)),
                _ => None,
            };
            shards.push(PartStatus {
                shard: Some(sh),
                state: state.clone(),
                runs,
                planned,
                idle,
            });
        }
    }
    if file_status.is_none() && local.is_none() && shards.is_empty() && !waiting {
        return Err(SweepError::State(format!(
            "no sweep at {}: neither the file, nor its journal, nor shards in {}",
            out.display(),
            dir.display()
        )));
    }
    Ok(SweepStatus {
        out: out.to_path_buf(),
        file_status,
        refine: spec.is_some_and(|s| s.refine.is_some()),
        local,
        shards,
        waiting,
    })
}

impl SweepStatus {
    /// The shards that are not complete.
    pub fn incomplete(&self) -> Vec<Shard> {
        self.shards
            .iter()
            .filter(|p| p.state != ShardState::Complete)
            .filter_map(|p| p.shard)
            .collect()
    }
}

impl fmt::Display for PartStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let of = match self.planned {
            Some(p) => format!("{} of {p}", self.runs),
            None => self.runs.to_string(),
        };
        match &self.state {
            ShardState::Complete => write!(f, "complete, {} runs", self.runs),
            ShardState::Missing => write!(f, "not started"),
            ShardState::Broken {
                missing, damaged, ..
            } => write!(
                f,
                "finished but its record lacks {missing} runs ({of} whole records, {damaged} \
                 damaged lines): run it again with --resume to make only those"
            ),
            ShardState::Unfinished { .. } => {
                write!(f, "running or interrupted, {of} runs recorded")?;
                if let Some(s) = self.idle {
                    write!(f, ", last {s:.0} s ago")?;
                }
                Ok(())
            }
        }
    }
}

impl fmt::Display for SweepStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.file_status.as_deref() {
            Some("complete") => "complete",
            Some("partial") => "merged from some shards only (partial)",
            Some(_) => "in progress or interrupted",
            None => "not written yet",
        };
        writeln!(f, "{}: {what}", self.out.display())?;
        if let Some(l) = &self.local {
            writeln!(f, "  on one machine: {l}")?;
        }
        if self.waiting {
            writeln!(f, "  shards: none started yet")?;
        }
        if !self.shards.is_empty() {
            let done = self
                .shards
                .iter()
                .filter(|p| p.state == ShardState::Complete)
                .count();
            writeln!(
                f,
                "  shards: {done} of {} complete{}",
                self.shards.len(),
                if self.refine {
                    " (a [refine] sweep: planned counts are the coarse grid's; refinement adds runs)"
                } else {
                    ""
                }
            )?;
            for p in &self.shards {
                let s = p.shard.expect("a shard");
                writeln!(f, "    {s}: {p}")?;
            }
            let left = self.incomplete();
            if left.is_empty() && self.file_status.as_deref() != Some("complete") {
                writeln!(
                    f,
                    "  every shard is complete: `stickslip merge {}` writes the sweep file",
                    self.out.display()
                )?;
            } else if !left.is_empty() {
                writeln!(
                    f,
                    "  not complete: {}",
                    left.iter()
                        .map(|s| s.index.to_string())
                        .collect::<Vec<_>>()
                        .join(",")
                )?;
            }
        }
        Ok(())
    }
}
