//! Sweeps on a real Slurm cluster: a single-node cluster started on this machine by
//! `tests/slurm/cluster.sh` (Debian's slurm-wlm and munge, installed when missing; stopped
//! afterwards by the process ids it started), driven only through `stickslip slurm`, `status`
//! and `merge`, and Slurm's own `squeue` and `scancel`.
//!
//! - `sweeps/quick.toml` as a 4-task array plus the merge job: the merged file equals a
//!   single-machine run bit for bit (h5py, `tests/python/compare_sweeps.py`);
//! - `status` while it runs; a merge with a shard missing fails and names it;
//! - a task cancelled mid-run (`scancel`), then `--resubmit`: only that shard is submitted again,
//!   the result is still identical, and no finished run was made twice.
//!
//! Set `STICKSLIP_SKIP_SLURM=1` to skip on a machine where Slurm cannot be installed (not root).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

struct Cluster {
    dir: tempfile::TempDir,
}

impl Cluster {
    fn script() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/slurm/cluster.sh")
    }

    fn start() -> Cluster {
        let dir = tempfile::tempdir().unwrap();
        let t0 = Instant::now();
        let o = Command::new("bash")
            .arg(Self::script())
            .args(["start", dir.path().to_str().unwrap()])
            .output()
            .unwrap();
        let c = Cluster { dir };
        assert!(
            o.status.success(),
            "the test cluster did not start (set STICKSLIP_SKIP_SLURM=1 to skip where Slurm cannot be installed):\n{}{}\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr),
            ["slurmctld.log", "slurmd.log"]
                .iter()
                .map(|f| std::fs::read_to_string(c.dir.path().join(f)).unwrap_or_default())
                .collect::<Vec<_>>()
                .join("\n")
        );
        eprintln!(
            "cluster up in {:.1} s: {}",
            t0.elapsed().as_secs_f64(),
            String::from_utf8_lossy(&o.stdout).trim()
        );
        c
    }

    fn conf(&self) -> PathBuf {
        self.dir.path().join("slurm.conf")
    }

    /// A command that talks to this cluster.
    fn cmd(&self, prog: &str) -> Command {
        let mut c = Command::new(prog);
        c.env("SLURM_CONF", self.conf());
        c
    }

    fn stickslip(&self, args: &[&str]) -> (bool, String) {
        let o = self
            .cmd(env!("CARGO_BIN_EXE_stickslip"))
            .args(args)
            .output()
            .unwrap();
        (
            o.status.success(),
            format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
        )
    }

    /// squeue's lines for a job (`%i %T %r`), empty once it has left the queue.
    fn queue(&self, job: &str) -> String {
        let o = self
            .cmd("squeue")
            .args(["-h", "-r", "-j", job, "-o", "%i %T %r"])
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout).into_owned()
    }

    /// Waits until `done` holds, polling; panics with the cluster's logs after `limit`.
    fn wait(&self, what: &str, limit: f64, mut done: impl FnMut() -> bool) -> f64 {
        let t0 = Instant::now();
        while !done() {
            if t0.elapsed().as_secs_f64() > limit {
                let q = self.cmd("squeue").output().unwrap();
                panic!(
                    "timed out waiting for {what}; squeue:\n{}\nslurmctld.log tail:\n{}",
                    String::from_utf8_lossy(&q.stdout),
                    std::fs::read_to_string(self.dir.path().join("slurmctld.log"))
                        .unwrap_or_default()
                        .lines()
                        .rev()
                        .take(30)
                        .collect::<Vec<_>>()
                        .join("\n")
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        t0.elapsed().as_secs_f64()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(Self::script())
            .args(["stop", self.dir.path().to_str().unwrap()])
            .status();
    }
}

fn same_sweep(a: &Path, b: &Path) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/compare_sweeps.py");
    let o = Command::new("python3")
        .arg(script)
        .args([a, b])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{} and {} differ:\n{}{}",
        a.display(),
        b.display(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The job ids `stickslip slurm --submit` printed: (array, merge).
fn job_ids(log: &str) -> (String, String) {
    let words: Vec<&str> = log.split_whitespace().collect();
    let after = |w: &str| {
        words
            .windows(3)
            .find(|x| x[0] == w && x[1] == "job")
            .map(|x| x[2].to_string())
            .unwrap_or_else(|| panic!("no `{w} job` in:\n{log}"))
    };
    (after("array"), after("merge"))
}

fn complete(p: &Path) -> bool {
    stickslip::sweep::is_complete(p)
}

/// One test cluster at a time (they share the ports of `cluster.sh`).
static ONE_CLUSTER: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn quick_sweep_as_a_job_array_merges_bit_for_bit_and_survives_a_cancelled_task() {
    if std::env::var_os("STICKSLIP_SKIP_SLURM").is_some_and(|v| v == "1") {
        eprintln!("skipped: STICKSLIP_SKIP_SLURM=1");
        return;
    }
    let _one = ONE_CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    let quick = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/quick.toml");
    let quick = quick.to_str().unwrap();
    let cluster = Cluster::start();
    let work = tempfile::tempdir().unwrap();
    let single = work.path().join("single.h5");
    let (ok, log) = cluster.stickslip(&["sweep", quick, "-o", single.to_str().unwrap(), "-q"]);
    assert!(ok, "{log}");

    // The whole array and its merge job.
    let a = work.path().join("a.h5");
    let am = a.to_str().unwrap();
    let t0 = Instant::now();
    let (ok, log) = cluster.stickslip(&["slurm", quick, "--tasks", "4", "-o", am, "--submit"]);
    assert!(ok, "{log}");
    let (_, merge) = job_ids(&log);
    let mut seen_running = None;
    cluster.wait("the array and its merge", 600.0, || {
        if seen_running.is_none() && a.with_extension("h5.shards").join("0-of-4.h5").exists() {
            let (ok, st) = cluster.stickslip(&["status", am]);
            if ok && st.contains("shards:") && !st.contains("4 of 4 complete") {
                seen_running = Some(st);
            }
        }
        complete(&a) && cluster.queue(&merge).trim().is_empty()
    });
    let array_time = t0.elapsed().as_secs_f64();
    let st = seen_running.expect("status was read while the array ran");
    assert!(st.contains("0/4:") && st.contains("3/4:"), "{st}");
    same_sweep(&single, &a);
    let (ok, st) = cluster.stickslip(&["status", am]);
    assert!(
        ok && st.contains("4 of 4 complete") && st.contains(": complete"),
        "{st}"
    );
    eprintln!("4-task array and merge: {array_time:.1} s to a complete file");

    // A merge with a shard missing fails and names it.
    let shards = a.with_extension("h5.shards");
    let aside = work.path().join("aside");
    std::fs::create_dir(&aside).unwrap();
    for f in ["2-of-4.h5", "2-of-4.runs"] {
        std::fs::rename(shards.join(f), aside.join(f)).unwrap();
    }
    let (ok, log) = cluster.stickslip(&["merge", am, "--no-plot"]);
    assert!(!ok, "{log}");
    assert!(log.contains("shard 2/4 is missing"), "{log}");
    for f in ["2-of-4.h5", "2-of-4.runs"] {
        std::fs::rename(aside.join(f), shards.join(f)).unwrap();
    }

    // A task cancelled mid-run, then --resubmit.
    let b = work.path().join("b.h5");
    let bm = b.to_str().unwrap();
    let (ok, log) = cluster.stickslip(&["slurm", quick, "--tasks", "4", "-o", bm, "--submit"]);
    assert!(ok, "{log}");
    let (array, merge) = job_ids(&log);
    let journal = b.with_extension("h5.shards").join("1-of-4.h5.journal");
    let lines = || {
        std::fs::read_to_string(&journal)
            .map(|t| t.lines().count())
            .unwrap_or(0)
    };
    cluster.wait("task 1 to record runs", 300.0, || lines() > 6);
    let o = cluster
        .cmd("scancel")
        .arg(format!("{array}_1"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    cluster.wait("the other tasks", 300.0, || {
        cluster.queue(&array).trim().is_empty()
    });
    let recorded = lines() - 1;
    assert!(
        recorded < 50,
        "task 1 finished its 50 runs before it was cancelled"
    );
    let (ok, st) = cluster.stickslip(&["status", bm]);
    assert!(ok && st.contains("3 of 4 complete"), "{st}");
    assert!(st.contains("1/4: running or interrupted"), "{st}");
    // The merge job waits for ever on the failed array.
    assert!(
        cluster.queue(&merge).contains("PENDING"),
        "{}",
        cluster.queue(&merge)
    );
    assert!(!complete(&b));
    let (ok, log) = cluster.stickslip(&["slurm", quick, "--tasks", "4", "-o", bm, "--resubmit"]);
    assert!(ok, "{log}");
    assert!(log.contains("(1 task(s): 1)"), "{log}");
    assert!(
        log.contains(&format!("cancelled merge job(s) {merge}")),
        "{log}"
    );
    let (array2, merge2) = job_ids(&log);
    cluster.wait("the resubmitted task and merge", 600.0, || {
        complete(&b) && cluster.queue(&merge2).trim().is_empty()
    });
    same_sweep(&single, &b);
    // No finished run was made twice: the shard's record holds each run once, and the
    // resubmitted task took the cancelled one's records.
    let runs = std::fs::read_to_string(b.with_extension("h5.shards").join("1-of-4.runs")).unwrap();
    let mut tasks: Vec<String> = runs
        .lines()
        .skip(1)
        .map(|l| l.split(' ').take(2).collect::<Vec<_>>().join(" "))
        .collect();
    let n = tasks.len();
    tasks.sort();
    tasks.dedup();
    assert_eq!(tasks.len(), n, "a run recorded twice");
    // The full-model checks of averaged points near the boundary (journal kind `chk`) and the
    // averaged law's tables (kind `tab`) come on top of the shard's runs.
    let checks = tasks
        .iter()
        .filter(|t| t.starts_with("chk ") || t.starts_with("tab "))
        .count();
    assert_eq!(
        n - checks,
        50,
        "shard 1 of quick.toml: 49 points and the reference"
    );
    let task_log = std::fs::read_to_string(
        b.with_extension("h5.shards")
            .join(format!("slurm-{array2}_1.out")),
    )
    .unwrap();
    // "<made> runs made, <resumed> resumed"
    let count = |word: &str, back: usize| -> usize {
        let w: Vec<&str> = task_log.split_whitespace().collect();
        let k = w
            .iter()
            .position(|x| x.trim_end_matches(',') == word)
            .unwrap_or_else(|| panic!("no `{word}` in:\n{task_log}"));
        w[k - back].parse().unwrap()
    };
    let (made, resumed) = (count("made", 2), count("resumed", 1));
    // The cancelled task's last line may have been torn by the kill; it is made again.
    assert_eq!(made + resumed, 50, "{task_log}");
    assert!(
        resumed + 1 >= recorded && resumed >= 5,
        "{recorded}: {task_log}"
    );
}

/// The shards' folder's Slurm logs: (array task logs, merge logs).
fn logs(shards: &Path) -> (Vec<String>, Vec<String>) {
    let mut names: Vec<String> = std::fs::read_dir(shards)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("slurm-") && n.ends_with(".out"))
        .collect();
    names.sort();
    let (merge, tasks): (Vec<String>, Vec<String>) = names
        .into_iter()
        .partition(|n| n.starts_with("slurm-merge-"));
    (tasks, merge)
}

/// Paths with a space, `#`, `%`, `$`, quotes and backticks, and a sweep file whose name would
/// run a command in a shell: the generated scripts, submitted by `stickslip slurm --submit` and
/// by pasting the printed hint into bash, give one log per task in the folder asked for, a
/// complete sweep, and run nothing.
#[test]
fn hostile_paths_give_one_log_per_task_and_run_nothing() {
    if std::env::var_os("STICKSLIP_SKIP_SLURM").is_some_and(|v| v == "1") {
        eprintln!("skipped: STICKSLIP_SKIP_SLURM=1");
        return;
    }
    let _one = ONE_CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    let cluster = Cluster::start();
    let work = tempfile::tempdir().unwrap();
    let dir = work.path().join("a b#c%d$e'f\"g`h");
    std::fs::create_dir(&dir).unwrap();
    let file = dir.join("$(touch pwned) `touch pwned2` x.toml");
    std::fs::write(
        &file,
        "[fixed]\nk_d = 20000.0\nv_d = 1.5e-3\n[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 4]\n[run]\nt_end = 0.5\n",
    )
    .unwrap();
    let pwned = |w: &Path| {
        ["pwned", "pwned2"]
            .iter()
            .any(|n| w.join(n).exists() || dir.join(n).exists() || Path::new(n).exists())
    };
    // `stickslip slurm FILE --tasks 2 -o OUT [extra]`: its output, once it succeeded.
    let slurm = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "slurm",
            file.to_str().unwrap(),
            "--tasks",
            "2",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (ok, log) = cluster.stickslip(&args);
        assert!(ok, "{log}");
        log
    };
    // Submitted by stickslip.
    let a = dir.join("out %j %A #1.h5");
    let log = slurm(&a, &["--submit"]);
    let (array, merge) = job_ids(&log);
    cluster.wait("the array and its merge", 300.0, || {
        complete(&a) && cluster.queue(&merge).trim().is_empty()
    });
    let (tasks, merges) = logs(&shard_dir(&a));
    assert_eq!(
        tasks,
        vec![
            format!("slurm-{array}_0.out"),
            format!("slurm-{array}_1.out")
        ],
        "one log per task, in the shards' folder"
    );
    assert_eq!(merges, vec![format!("slurm-merge-{merge}.out")]);
    assert!(!pwned(work.path()), "a command in a path ran");
    // Written only, then submitted by the printed hint pasted into a shell.
    let b = dir.join("hint $HOME '1'.h5");
    let log = slurm(&b, &[]);
    let hint = log
        .lines()
        .find_map(|l| l.strip_prefix("submit with: "))
        .and_then(|l| l.split("   (or:").next())
        .unwrap_or_else(|| panic!("no hint in:\n{log}"))
        .to_string();
    let o = cluster.cmd("bash").args(["-c", &hint]).output().unwrap();
    assert!(
        o.status.success(),
        "{hint}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    cluster.wait("the hint's array and merge", 300.0, || complete(&b));
    let (tasks, merges) = logs(&shard_dir(&b));
    assert_eq!(tasks.len(), 2, "{tasks:?}");
    assert!(
        tasks
            .iter()
            .all(|t| t.ends_with("_0.out") || t.ends_with("_1.out"))
    );
    assert_eq!(merges.len(), 1, "{merges:?}");
    assert!(!pwned(work.path()), "a command in a path ran");
    // The merged files hold every point.
    let (ok, st) = cluster.stickslip(&["status", a.to_str().unwrap()]);
    assert!(ok && st.contains(": complete"), "{st}");
}

/// `OUT.shards/` of a sweep output.
fn shard_dir(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".shards");
    PathBuf::from(s)
}
