//! Sweeps on a Slurm cluster: a job array with one task per shard ([`crate::sweep::shard`]) and
//! a merge job that runs once every task has succeeded (`--dependency=afterok`), both submitted
//! with `sbatch` itself; nothing runs between Slurm and `stickslip`.
//!
//! Files, for the sweep output `OUT.h5`:
//!
//! | file | what |
//! |---|---|
//! | `OUT.h5.array.sbatch` | the job array: task `I` runs `stickslip sweep FILE -o OUT.h5 --shard I/N --threads $SLURM_CPUS_PER_TASK --resume` |
//! | `OUT.h5.merge.sbatch` | the merge job: `stickslip merge OUT.h5 --sweep FILE` |
//! | `OUT.h5.shards/` | the shards, their journals, the jobs' logs `slurm-<job>_<task>.out`, and `slurm-jobs` (the ids submitted) |
//!
//! A task runs with `--resume`: a task run again (requeued, resubmitted) continues its journal
//! and a complete shard does nothing, so no finished run is made twice. `--resubmit` submits
//! only the shards that are neither complete nor still queued or running in the arrays recorded
//! in `slurm-jobs`, cancels merge jobs left waiting on an array that failed, and submits a new
//! merge job after the new tasks.

use crate::sweep::journal;
use crate::sweep::shard::{self, Shard};
use crate::sweep::spec::SweepSpec;
use crate::sweep::status;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What the scripts run. Paths are absolute (the jobs run on other hosts, in other folders).
#[derive(Clone, Debug)]
pub struct SlurmJob {
    /// The sweep file.
    pub file: PathBuf,
    /// The sweep output.
    pub out: PathBuf,
    /// Array tasks (shards).
    pub tasks: usize,
    /// `sbatch --partition`.
    pub partition: Option<String>,
    /// `sbatch --time` of each task and of the merge.
    pub time: Option<String>,
    /// `sbatch --cpus-per-task`: the worker threads of each task.
    pub cpus: usize,
    /// The `stickslip` program the jobs run.
    pub exe: PathBuf,
    /// The sweep's name (job names).
    pub name: String,
}

/// Anything that stops `stickslip slurm`.
#[derive(Debug, thiserror::Error)]
pub enum SlurmError {
    /// A flag out of range.
    #[error("--{flag} {value}: {msg}")]
    Flag {
        /// The flag.
        flag: &'static str,
        /// Its value.
        value: String,
        /// What is allowed.
        msg: String,
    },
    /// A path that cannot go into a script as it is (bad input).
    #[error("{0}")]
    Unsafe(String),
    /// `sbatch`, `squeue` or `scancel` failed or is missing.
    #[error("{0}")]
    Slurm(String),
    /// The files.
    #[error("{0}")]
    Io(String),
}

/// Checks a Slurm time limit: minutes, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM`, `D-HH:MM:SS`,
/// or `UNLIMITED`/`INFINITE` (the forms `sbatch --time` accepts).
pub fn check_time(t: &str) -> Result<(), String> {
    let bad = || {
        Err(
            "not a Slurm time limit; use minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS (for example 2:00:00)"
                .to_string(),
        )
    };
    if matches!(t, "UNLIMITED" | "INFINITE" | "unlimited" | "infinite") {
        return Ok(());
    }
    let num = |x: &str| !x.is_empty() && x.len() <= 6 && x.bytes().all(|b| b.is_ascii_digit());
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(d), r),
        None => (None, t),
    };
    if days.is_some_and(|d| !num(d)) {
        return bad();
    }
    let parts: Vec<&str> = rest.split(':').collect();
    if !(parts.iter().all(|p| num(p)) && parts.len() <= 3) {
        return bad();
    }
    if t.bytes().all(|b| b == b'0' || b == b':' || b == b'-') {
        return Err("a time limit of zero; give a positive time".into());
    }
    Ok(())
}

impl SlurmJob {
    /// Checks the flags: tasks within the sweep's units, CPUs 1 to 1024, a Slurm time, a
    /// partition name without spaces.
    pub fn validate(&self, spec: &SweepSpec) -> Result<(), SlurmError> {
        let flag = |flag, value: String, msg: String| Err(SlurmError::Flag { flag, value, msg });
        if self.tasks == 0 || self.tasks > shard::MAX_SHARDS {
            return flag(
                "tasks",
                self.tasks.to_string(),
                format!("must be from 1 to {}", shard::MAX_SHARDS),
            );
        }
        if let Err(msg) = shard::check(spec, self.tasks) {
            return flag("tasks", self.tasks.to_string(), msg);
        }
        if !(1..=1024).contains(&self.cpus) {
            return flag(
                "cpus-per-task",
                self.cpus.to_string(),
                "must be from 1 to 1024".into(),
            );
        }
        if let Some(t) = &self.time
            && let Err(msg) = check_time(t)
        {
            return flag("time", t.clone(), msg);
        }
        for (what, path) in [
            ("sweep file", &self.file),
            ("output (-o)", &self.out),
            ("program", &self.exe),
        ] {
            check_script_path(what, path)?;
        }
        if let Some(p) = &self.partition
            && (p.is_empty() || p.chars().any(|c| c.is_whitespace() || c == '#'))
        {
            return flag(
                "partition",
                p.clone(),
                "a partition name: no spaces or '#'".into(),
            );
        }
        Ok(())
    }

    /// `OUT.array.sbatch` and `OUT.merge.sbatch`.
    pub fn script_paths(&self) -> (PathBuf, PathBuf) {
        let with = |ext: &str| {
            let mut s = self.out.as_os_str().to_owned();
            s.push(ext);
            PathBuf::from(s)
        };
        (with(".array.sbatch"), with(".merge.sbatch"))
    }

    /// The job name in the scripts: the sweep's name with anything but letters, digits and
    /// `._+-` replaced by `_` (a job name only labels the queue; Slurm shows it in columns).
    fn job_name(&self) -> String {
        self.name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "._+-".contains(c) {
                    c
                } else {
                    '_'
                }
            })
            .collect()
    }

    fn header(&self, lines: &mut Vec<String>) {
        lines.push(format!("#SBATCH --cpus-per-task={}", self.cpus));
        lines.push("#SBATCH --ntasks=1".into());
        if let Some(p) = &self.partition {
            lines.push(format!("#SBATCH --partition={p}"));
        }
        if let Some(t) = &self.time {
            lines.push(format!("#SBATCH --time={t}"));
        }
    }

    /// The job-array script (module docs).
    pub fn array_script(&self) -> String {
        let logs = shard::dir_for(&self.out);
        let mut l = vec![
            "#!/bin/bash".to_string(),
            format!("#SBATCH --job-name={}", self.job_name()),
            format!("#SBATCH --array=0-{}", self.tasks - 1),
            format!(
                "#SBATCH --output={}",
                output_pattern(&logs, "slurm-%A_%a.out")
            ),
        ];
        self.header(&mut l);
        l.push(format!(
            "# One shard of sweep {} per array task; written by `stickslip slurm`.",
            self.file.display()
        ));
        l.push("# A task run again continues its shard's journal (--resume).".into());
        l.push("set -eu".into());
        l.push(format!(
            "exec {} sweep {} -o {} --shard \"$SLURM_ARRAY_TASK_ID/{}\" --threads \"${{SLURM_CPUS_PER_TASK:-1}}\" --resume --quiet --no-plot",
            quote(&self.exe),
            quote(&self.file),
            quote(&self.out),
            self.tasks
        ));
        l.join("\n") + "\n"
    }

    /// The merge script (module docs); submitted with `--dependency=afterok:<array job>`.
    pub fn merge_script(&self) -> String {
        let logs = shard::dir_for(&self.out);
        let mut l = vec![
            "#!/bin/bash".to_string(),
            format!("#SBATCH --job-name={}-merge", self.job_name()),
            format!(
                "#SBATCH --output={}",
                output_pattern(&logs, "slurm-merge-%j.out")
            ),
        ];
        self.header(&mut l);
        l.push(format!(
            "# Merges the {} shards of sweep {} into {}; written by `stickslip slurm`.",
            self.tasks,
            self.file.display(),
            self.out.display()
        ));
        l.push("set -eu".into());
        l.push(format!(
            "exec {} merge {} --sweep {} --threads \"${{SLURM_CPUS_PER_TASK:-1}}\"",
            quote(&self.exe),
            quote(&self.out),
            quote(&self.file)
        ));
        l.join("\n") + "\n"
    }

    /// Writes both scripts (and the shards' folder, where the jobs' logs go).
    pub fn write_scripts(&self) -> Result<(PathBuf, PathBuf), SlurmError> {
        let dir = shard::dir_for(&self.out);
        std::fs::create_dir_all(&dir)
            .map_err(|e| SlurmError::Io(format!("{}: {e}", dir.display())))?;
        let (a, m) = self.script_paths();
        for (p, text) in [(&a, self.array_script()), (&m, self.merge_script())] {
            std::fs::write(p, text).map_err(|e| SlurmError::Io(format!("{}: {e}", p.display())))?;
        }
        Ok((a, m))
    }

    /// Refuses shards of another sweep file or program version in `OUT.shards/`.
    pub fn check_shards(&self, spec: &SweepSpec) -> Result<(), SlurmError> {
        let fp = journal::fingerprint(&spec.text);
        for index in 0..self.tasks {
            let h5 = Shard {
                index,
                count: self.tasks,
            }
            .path(&self.out);
            for f in [shard::runs_path(&h5), journal::path_for(&h5)] {
                if let Ok(text) = std::fs::read_to_string(&f)
                    && !journal::belongs(text.lines().next().unwrap_or_default(), &fp)
                {
                    return Err(SlurmError::Io(format!(
                        "{} was made from another sweep file or program version; \
                         remove {} to start the sweep afresh",
                        f.display(),
                        shard::dir_for(&self.out).display()
                    )));
                }
            }
        }
        Ok(())
    }

    fn jobs_path(&self) -> PathBuf {
        shard::dir_for(&self.out).join("slurm-jobs")
    }

    /// The job ids recorded by earlier submissions: (kind, id), kind `array` or `merge`.
    pub fn recorded_jobs(&self) -> Vec<(String, String)> {
        std::fs::read_to_string(self.jobs_path())
            .unwrap_or_default()
            .lines()
            .filter_map(|l| {
                let (k, v) = l.split_once(' ')?;
                Some((k.to_string(), v.trim().to_string()))
            })
            .collect()
    }

    fn record_job(&self, kind: &str, id: &str) -> Result<(), SlurmError> {
        use std::io::Write;
        let p = self.jobs_path();
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&p)
            .map_err(|e| SlurmError::Io(format!("{}: {e}", p.display())))?;
        writeln!(f, "{kind} {id}").map_err(|e| SlurmError::Io(format!("{}: {e}", p.display())))
    }

    /// Submits the array (all tasks, or `only` these) and the merge job after it; returns their
    /// ids. `only` empty: the merge job alone.
    pub fn submit(&self, only: Option<&[usize]>) -> Result<(Option<String>, String), SlurmError> {
        let (a, m) = self.write_scripts()?;
        let array = match only {
            Some([]) => None,
            Some(list) => Some(sbatch(
                &[format!(
                    "--array={}",
                    list.iter()
                        .map(|i| i.to_string())
                        .collect::<Vec<_>>()
                        .join(",")
                )],
                &a,
            )?),
            None => Some(sbatch(&[], &a)?),
        };
        if let Some(id) = &array {
            self.record_job("array", id)?;
        }
        let dep: Vec<String> = array
            .iter()
            .map(|id| format!("--dependency=afterok:{id}"))
            .collect();
        let merge = sbatch(&dep, &m)?;
        self.record_job("merge", &merge)?;
        Ok((array, merge))
    }

    /// The array tasks of recorded arrays that are still pending or running.
    pub fn queued_tasks(&self) -> Result<Vec<usize>, SlurmError> {
        let mut out = vec![];
        for (kind, id) in self.recorded_jobs() {
            if kind != "array" {
                continue;
            }
            let o = squeue(&id, "%K %T")?;
            for line in o.lines() {
                let mut w = line.split_whitespace();
                if let (Some(k), Some(state)) = (w.next(), w.next())
                    && let Ok(k) = k.parse::<usize>()
                    && !matches!(state, "COMPLETED" | "CANCELLED" | "FAILED" | "TIMEOUT")
                {
                    out.push(k);
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        Ok(out)
    }

    /// Cancels recorded merge jobs that have not started (left waiting on a failed array).
    pub fn cancel_waiting_merges(&self) -> Result<Vec<String>, SlurmError> {
        let mut cancelled = vec![];
        for (kind, id) in self.recorded_jobs() {
            if kind != "merge" {
                continue;
            }
            let o = squeue(&id, "%T")?;
            if o.lines().any(|s| s.trim() == "PENDING") {
                run_slurm("scancel", &[&id])?;
                cancelled.push(id);
            }
        }
        Ok(cancelled)
    }

    /// The shards to submit again: not complete, and not queued or running.
    pub fn to_resubmit(&self) -> Result<Vec<usize>, SlurmError> {
        // Nothing on disk yet (never submitted, or its folder removed): every shard is left.
        let st = match status::status(&self.out) {
            Ok(st) => st,
            Err(_) if !shard::dir_for(&self.out).exists() => {
                return Ok((0..self.tasks).collect());
            }
            Err(e) => return Err(SlurmError::Io(e.to_string())),
        };
        let queued = self.queued_tasks()?;
        let mut left: Vec<usize> = if st.shards.is_empty() {
            (0..self.tasks).collect()
        } else {
            if st.shards.len() != self.tasks {
                return Err(SlurmError::Flag {
                    flag: "tasks",
                    value: self.tasks.to_string(),
                    msg: format!(
                        "the shards in {} are of {} tasks; resubmit with --tasks {}",
                        shard::dir_for(&self.out).display(),
                        st.shards.len(),
                        st.shards.len()
                    ),
                });
            }
            st.incomplete().iter().map(|s| s.index).collect()
        };
        left.retain(|i| !queued.contains(i));
        Ok(left)
    }
}

/// Refuses a path that cannot be written into a script as it is: not valid UTF-8 (it would be
/// written altered), a control character (a newline would end the `#SBATCH` directive or the
/// comment it stands in and start a command of its own), or a backslash (sbatch then takes
/// the whole `--output` pattern literally, and every task would log into one file).
fn check_script_path(what: &str, p: &Path) -> Result<(), SlurmError> {
    let bad = |msg: &str| {
        Err(SlurmError::Unsafe(format!(
            "the {what} path {:?} cannot go into a Slurm script: {msg}; rename or move it",
            p.as_os_str()
        )))
    };
    let Some(s) = p.to_str() else {
        return bad("it is not valid UTF-8");
    };
    if s.chars().any(char::is_control) {
        return bad("it holds a control character (a newline, tab, ...)");
    }
    if s.contains('\\') {
        return bad("it holds a backslash, which turns off sbatch's %A/%a file-name patterns");
    }
    Ok(())
}

/// An `#SBATCH --output` value: `dir/file`, where `file` holds sbatch's own `%` patterns, and
/// the folder's `%` are doubled (sbatch's `%%`, a literal `%`), in double quotes with `"`
/// escaped by a backslash (sbatch's directive parser: outside quotes a space ends the value
/// and a `#` starts a comment). The folder holds no backslash or control character
/// ([`check_script_path`]).
fn output_pattern(dir: &Path, file: &str) -> String {
    let d = dir.display().to_string().replace('%', "%%");
    format!("\"{}/{file}\"", d.replace('"', "\\\""))
}

/// Quotes a path for the shell.
pub fn quote(p: &Path) -> String {
    let s = p.display().to_string();
    if s.bytes()
        .all(|b| b.is_ascii_alphanumeric() || b"/._-+=:,".contains(&b))
    {
        s
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// squeue's lines for job `id` in `format`: empty once the job has left the queue (squeue then
/// calls the id invalid).
fn squeue(id: &str, format: &str) -> Result<String, SlurmError> {
    match run_slurm("squeue", &["-h", "-r", "-j", id, "-o", format]) {
        Err(SlurmError::Slurm(e)) if e.contains("Invalid job id") => Ok(String::new()),
        r => r,
    }
}

fn run_slurm(prog: &str, args: &[&str]) -> Result<String, SlurmError> {
    let o = Command::new(prog).args(args).output().map_err(|e| {
        SlurmError::Slurm(format!(
            "{prog} could not be started ({e}): is this a Slurm login node with {prog} on the PATH?"
        ))
    })?;
    if !o.status.success() {
        return Err(SlurmError::Slurm(format!(
            "{prog} {} failed ({}): {}",
            args.join(" "),
            o.status,
            String::from_utf8_lossy(&o.stderr).trim()
        )));
    }
    Ok(String::from_utf8_lossy(&o.stdout).into_owned())
}

/// `sbatch --parsable ARGS SCRIPT`: the job id.
fn sbatch(args: &[String], script: &Path) -> Result<String, SlurmError> {
    let mut all: Vec<&str> = vec!["--parsable"];
    all.extend(args.iter().map(String::as_str));
    let s = script.display().to_string();
    all.push(&s);
    let o = run_slurm("sbatch", &all)?;
    // --parsable prints "id" or "id;cluster".
    let id = o.trim().split(';').next().unwrap_or_default().to_string();
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        return Err(SlurmError::Slurm(format!(
            "sbatch {s} printed `{}`, not a job id",
            o.trim()
        )));
    }
    Ok(id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_limits_are_slurms() {
        for ok in [
            "30",
            "30:00",
            "2:00:00",
            "1-0",
            "1-02:00",
            "1-02:00:00",
            "UNLIMITED",
        ] {
            assert!(check_time(ok).is_ok(), "{ok}");
        }
        for bad in [
            "", "2h", "1:2:3:4", "-1", "1-", "0", "00:00:00", "1.5", "a-1",
        ] {
            assert!(check_time(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn output_patterns_keep_the_folder_literal() {
        assert_eq!(
            output_pattern(Path::new("/a b/c%d\"e#"), "slurm-%A_%a.out"),
            "\"/a b/c%%d\\\"e#/slurm-%A_%a.out\""
        );
    }

    #[test]
    fn control_characters_and_backslashes_are_refused() {
        for bad in ["/a\nb", "/a\rb", "/a\\b", "/a\tb"] {
            let e = check_script_path("output (-o)", Path::new(bad)).unwrap_err();
            assert!(e.to_string().contains("output (-o)"), "{e}");
        }
        assert!(check_script_path("output (-o)", Path::new("/a b/#%$'\"`x")).is_ok());
    }

    #[test]
    fn paths_with_spaces_are_quoted() {
        assert_eq!(quote(Path::new("/a/b.h5")), "/a/b.h5");
        assert_eq!(quote(Path::new("/a b/it's")), "'/a b/it'\\''s'");
    }
}
