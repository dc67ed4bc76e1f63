//! `stickslip sweep FILE --estimate`: the CPU time of a whole sweep predicted from a small
//! sample of its runs, so that a user can choose the number of Slurm tasks and `--time`.
//!
//! The sample is a shard ([`super::shard`]): shard 0 of `M`, with `M` chosen so that it holds
//! about `sample` grid points (dense sweeps) or planes (`[refine]` sweeps), with the reference
//! runs they need, dealt from the scrambled order, so it spreads over the whole grid. It runs to
//! a temporary folder, removed afterwards. Each run's cost is its wall time on one thread (runs
//! are single-threaded), i.e. CPU seconds. The tables of the averaged law the sample needs are
//! built first, timed, and each point is charged its share of its table (the table's time over
//! the number of the sweep's points that share it), as the whole sweep builds each table once.
//! The full-model checks of averaged points (a 1 % share and the band about the level) are not
//! in the estimate.
//!
//! - Dense sweep: `CPU = c_pt N_pt + c_ref N_ref`, the sample means of runs with vibration and of
//!   references times their counts in the whole sweep; the stated uncertainty is one standard
//!   error of the mean, `N_pt s_pt / sqrt(k_pt)` (and the references' alike, where not all were
//!   run).
//! - `[refine]` sweep: the runs of a plane depend on where its level lies, so whole planes are
//!   sampled: `CPU = c_plane N_plane`, with the standard error over the sampled planes (a single
//!   sampled plane gives none). With `[refine] guide_planes` the unit is the group of planes
//!   that guide each other (one value of every dimension but `along`, `across` and the guiding
//!   one), since none of them refines apart from the others.
//!
//! For a Slurm array of `N` tasks, a task of a dense sweep holds `N_pt / N` points and, expecting
//! the points spread evenly over the `N_ref` references, `N_ref (1 − (1 − 1/N_ref)^(N_pt/N))` of
//! them (each task makes the references its points need); a task of a `[refine]` sweep holds
//! `ceil(N_plane / N)` planes.

use super::SweepOptions;
use super::error::SweepError;
use super::journal::{self, Task};
use super::plan::Plan;
use super::shard::{self, Shard};
use super::spec::SweepSpec;
use std::fmt;
use std::time::Instant;

/// A predicted sweep cost (module docs).
#[derive(Clone, Debug)]
pub struct Estimate {
    /// The sweep's name.
    pub name: String,
    /// Whether the sweep refines (units are planes).
    pub refine: bool,
    /// Whether the units are groups of planes (`[refine] guide_planes`).
    pub grouped: bool,
    /// Grid points (dense) or planes (refine) sampled, and in the whole sweep.
    pub sampled: usize,
    /// Units in the whole sweep.
    pub units: usize,
    /// Runs made for the sample.
    pub sample_runs: usize,
    /// Runs of the sample that failed (any status but success): their times say little of a
    /// run that succeeds, and the summary says how many there were.
    pub sample_failed: usize,
    /// Wall time of the sample \[s\].
    pub sample_wall: f64,
    /// Predicted runs of the whole sweep.
    pub runs: f64,
    /// Predicted CPU time of the whole sweep \[s\].
    pub cpu: f64,
    /// One standard error of `cpu` \[s\] (NaN where the sample cannot tell).
    pub cpu_stderr: f64,
    /// The longest run of the sample \[s\]: no task finishes sooner.
    pub longest_run: f64,
    /// Points with vibration and references of the whole sweep (dense sweeps), for per-task
    /// predictions.
    counts: (f64, f64),
    /// Mean cost of a run with vibration, of a reference, of a plane \[s\].
    means: (f64, f64, f64),
    /// Threads of the machine the estimate is for.
    pub threads: usize,
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        f64::NAN
    };
    (m, var.sqrt())
}

/// The sample's runs as the journal kept them, with what its prediction needs.
struct Sample {
    plan: Plan,
    /// Per grid point, the shard that owns it (0: the sample).
    owners: Vec<usize>,
    /// Per sampled point, its share of its averaged table's build \[s\].
    tables: std::collections::HashMap<usize, f64>,
    records: Vec<(Task, crate::sim::RunResult)>,
    /// Wall time of the sample \[s\].
    wall: f64,
}

impl Sample {
    /// A run's cost with its share of its table: the runs found the sample's tables built.
    fn cost(&self, t: &Task, r: &crate::sim::RunResult) -> f64 {
        match *t {
            Task::Point(i) => r.wall_time + self.tables.get(&i).copied().unwrap_or(0.0),
            _ => r.wall_time,
        }
    }

    fn failed(&self) -> usize {
        self.records
            .iter()
            .filter(|(_, r)| r.status != crate::ode::Status::Success)
            .count()
    }
}

/// Runs a sample of about `sample` units of the sweep on `threads` threads and predicts the
/// whole (module docs).
pub fn estimate(
    spec: &SweepSpec,
    sample: usize,
    threads: Option<usize>,
) -> Result<Estimate, SweepError> {
    let units = shard::units(spec);
    let s = run_sample(spec, sample, units, threads)?;
    refuse_all_failed(&s)?;
    let base = base_estimate(spec, &s, units, threads);
    Ok(match spec.refine {
        None => dense_prediction(&s, base),
        Some(_) => refine_prediction(spec, &s, base),
    })
}

/// Runs shard 0 of as many as make about `sample` units, in a temporary folder removed
/// afterwards, its averaged tables built first and timed.
fn run_sample(
    spec: &SweepSpec,
    sample: usize,
    units: usize,
    threads: Option<usize>,
) -> Result<Sample, SweepError> {
    // `sample` counts planes; with guide_planes whole groups of them are sampled.
    let per_unit = match spec.refine {
        Some(_) => shard::planes(spec).1 / units,
        None => 1,
    };
    let sample = sample.div_ceil(per_unit).clamp(1, units);
    let count = units.div_ceil(sample);
    let sh = Shard { index: 0, count };
    let dir = std::env::temp_dir().join(format!(
        "stickslip-estimate-{}-{}",
        std::process::id(),
        journal::fingerprint(&spec.text)
    ));
    std::fs::create_dir_all(&dir)
        .map_err(|e| SweepError::State(format!("{}: {e}", dir.display())))?;
    let out = dir.join("sample.h5");
    let plan = Plan::new(spec);
    let owners = shard::owners(spec, count);
    let t0 = Instant::now();
    // The sample's runs find the tables built here (their builds are timed apart).
    let store = crate::averaged::TableStore::new();
    let tables = build_tables(spec, &plan, &owners, &store);
    let opts = SweepOptions {
        out: out.clone(),
        threads,
        resume: false,
        overwrite: true,
        progress: true,
        checkpoint_every: 1e9,
        shard: Some(sh),
        tally: None,
        batch: true,
    };
    let outcome = super::run_with(spec, &opts, &store);
    let wall = t0.elapsed().as_secs_f64();
    let records = outcome.and_then(|o| {
        journal::read(&shard::runs_path(&o.out), &journal::fingerprint(&spec.text))
            .map_err(SweepError::State)
    });
    let _ = std::fs::remove_dir_all(&dir);
    let (records, _) = records?;
    Ok(Sample {
        plan,
        owners,
        tables,
        records,
        wall,
    })
}

/// A sample whose every run failed predicts nothing: its times are those of failures.
fn refuse_all_failed(s: &Sample) -> Result<(), SweepError> {
    if let Some((t, r)) = s.records.first()
        && s.failed() == s.records.len()
    {
        return Err(SweepError::State(format!(
            "every one of the {} sampled runs failed (the first, {}, ended with {}), so their \
             times predict nothing of this sweep; no estimate. Try one of its points with \
             `stickslip run` and mend the sweep file",
            s.records.len(),
            match *t {
                Task::Point(i) | Task::Check(i) => format!("grid point {i}"),
                Task::Ref(k) => format!("reference run {k}"),
            },
            r.status.name()
        )));
    }
    Ok(())
}

/// What the estimate says before its prediction: the sample and the sweep's counts.
fn base_estimate(spec: &SweepSpec, s: &Sample, units: usize, threads: Option<usize>) -> Estimate {
    // Dense sweeps: the sample's points; [refine] sweeps: its planes, counted later.
    let sampled = s.owners.iter().filter(|&&o| o == 0).count();
    let longest_run = s
        .records
        .iter()
        .map(|(_, r)| r.wall_time)
        .fold(0.0, f64::max);
    let n_pt = s.plan.points.iter().filter(|p| p.vibrates()).count() as f64;
    let n_ref = s.plan.refs.len() as f64;
    Estimate {
        name: spec.name.clone(),
        refine: spec.refine.is_some(),
        grouped: spec
            .refine
            .as_ref()
            .is_some_and(|r| r.guide_planes.is_some()),
        sampled,
        units,
        sample_runs: s.records.len(),
        sample_failed: s.failed(),
        sample_wall: s.wall,
        runs: 0.0,
        cpu: 0.0,
        cpu_stderr: f64::NAN,
        longest_run,
        counts: (n_pt, n_ref),
        means: (0.0, 0.0, 0.0),
        threads: threads.unwrap_or_else(rayon::current_num_threads),
    }
}

/// A dense sweep: the sample means of runs with vibration and of references times their counts.
fn dense_prediction(s: &Sample, base: Estimate) -> Estimate {
    let (n_pt, n_ref) = base.counts;
    let pts: Vec<f64> = s
        .records
        .iter()
        .filter(|(t, _)| matches!(t, Task::Point(_)))
        .map(|(t, r)| s.cost(t, r))
        .collect();
    let refs: Vec<f64> = s
        .records
        .iter()
        .filter(|(t, _)| matches!(t, Task::Ref(_)))
        .map(|(_, r)| r.wall_time)
        .collect();
    let (cp, sp) = if pts.is_empty() {
        (0.0, 0.0)
    } else {
        mean_sd(&pts)
    };
    let (cr, sr) = mean_sd(&refs);
    let se_p = if pts.len() as f64 >= n_pt {
        0.0
    } else {
        n_pt * sp / (pts.len() as f64).sqrt()
    };
    let se_r = if refs.len() as f64 >= n_ref {
        0.0
    } else {
        n_ref * sr / (refs.len() as f64).sqrt()
    };
    Estimate {
        runs: n_pt + n_ref,
        cpu: cp * n_pt + cr * n_ref,
        cpu_stderr: se_p.hypot(se_r),
        means: (cp, cr, 0.0),
        ..base
    }
}

/// A `[refine]` sweep: the mean cost of a unit (a plane, or a group of planes that guide each
/// other) times the units.
fn refine_prediction(spec: &SweepSpec, s: &Sample, base: Estimate) -> Estimate {
    let units = base.units;
    let (plane, _) = shard::groups(spec);
    let mut per_plane = std::collections::BTreeMap::<usize, f64>::new();
    for (i, &o) in s.owners.iter().enumerate() {
        if o == 0 {
            per_plane.entry(plane[i]).or_default();
        }
    }
    for (t, r) in &s.records {
        let p = match *t {
            Task::Point(i) | Task::Check(i) => plane[i],
            Task::Ref(k) => {
                plane[(0..s.plan.points.len())
                    .find(|&i| s.owners[i] == 0 && s.plan.point_ref[i] == k)
                    .expect("a reference the shard made serves one of its points")]
            }
        };
        *per_plane.entry(p).or_default() += s.cost(t, r);
    }
    let per: Vec<f64> = per_plane.values().copied().collect();
    let (c, sd) = mean_sd(&per);
    let k = per.len() as f64;
    Estimate {
        sampled: per.len(),
        runs: s.records.len() as f64 / k * units as f64,
        cpu: c * units as f64,
        cpu_stderr: if per.len() >= units {
            0.0
        } else {
            units as f64 * sd / k.sqrt()
        },
        means: (0.0, 0.0, c),
        ..base
    }
}

/// Builds, timed, the tables of the averaged law that the sample's points (those `owners` gives
/// to shard 0) will look up, before their runs, and returns per such point its share of its
/// table's time \[s\]: the time over the number of the whole sweep's points that share the
/// table ([`Plan::table_share`]). In the sample a table serves a point or two; in the sweep it
/// serves every `k_d`, `h_d` of its `(f, u0, v_d)`, so a run's own wall time would charge
/// each point with a whole table.
fn build_tables(
    spec: &SweepSpec,
    plan: &Plan,
    owners: &[usize],
    store: &crate::averaged::TableStore,
) -> std::collections::HashMap<usize, f64> {
    use crate::averaged::TableStore;
    use crate::sim::choose::needs_table;
    let tier = spec.run.tier;
    let none = plan.effects.is_empty();
    let mut took = std::collections::HashMap::<Vec<u64>, f64>::new();
    let mut share = std::collections::HashMap::new();
    for (i, p) in plan.points.iter().enumerate() {
        if owners[i] != 0 || !needs_table(p, none, tier) {
            continue;
        }
        let key = TableStore::key(p);
        let secs = *took.entry(key).or_insert_with(|| {
            let t = Instant::now();
            let _ = store.table(p);
            t.elapsed().as_secs_f64()
        });
        share.insert(i, secs / plan.table_share[i].max(1) as f64);
    }
    share
}

impl Estimate {
    /// Predicted CPU time of one task of a Slurm array of `tasks` tasks \[s\] (module docs).
    pub fn per_task(&self, tasks: usize) -> f64 {
        let n = tasks as f64;
        if self.refine {
            return self.means.2 * self.units.div_ceil(tasks) as f64;
        }
        let (n_pt, n_ref) = self.counts;
        let (cp, cr, _) = self.means;
        let refs = if n_ref > 0.0 {
            n_ref * (1.0 - (1.0 - 1.0 / n_ref).powf((n_pt / n).max(1.0)))
        } else {
            0.0
        };
        cp * n_pt / n + cr * refs
    }
}

/// Formats seconds as Slurm's `--time` does: `D-HH:MM:SS` or `HH:MM:SS`.
pub fn slurm_time(secs: f64) -> String {
    let s = secs.max(0.0).ceil() as u64;
    let (d, h, m, s) = (s / 86_400, s / 3600 % 24, s / 60 % 60, s % 60);
    if d > 0 {
        format!("{d}-{h:02}:{m:02}:{s:02}")
    } else {
        format!("{h:02}:{m:02}:{s:02}")
    }
}

fn human(secs: f64) -> String {
    if secs < 120.0 {
        format!("{secs:.1} s")
    } else if secs < 7200.0 {
        format!("{:.1} min", secs / 60.0)
    } else {
        format!("{:.2} h", secs / 3600.0)
    }
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let unit = match (self.refine, self.grouped) {
            (true, true) => "groups of planes",
            (true, false) => "planes",
            _ => "grid points",
        };
        writeln!(
            f,
            "estimate for sweep {}: sampled {} of {} {unit} ({} runs) in {}",
            self.name,
            self.sampled,
            self.units,
            self.sample_runs,
            human(self.sample_wall)
        )?;
        if self.sample_failed > 0 {
            writeln!(
                f,
                "  {} of the {} sampled runs failed: their times are counted as they ran, which \
                 says little of the runs that succeed",
                self.sample_failed, self.sample_runs
            )?;
        }
        let se = if self.cpu_stderr.is_finite() {
            format!(" ± {} (one standard error)", human(self.cpu_stderr))
        } else {
            " (a single plane or point sampled: no spread known)".into()
        };
        writeln!(
            f,
            "  predicted: {:.0} runs, {} CPU{se}",
            self.runs,
            human(self.cpu),
        )?;
        writeln!(
            f,
            "  on this machine ({} threads): about {}",
            self.threads,
            human((self.cpu / self.threads as f64).max(self.longest_run))
        )?;
        writeln!(
            f,
            "  as a Slurm array (stickslip slurm FILE --tasks N --cpus-per-task C): per task about"
        )?;
        for n in [4, 16, 64, 256, 1024] {
            if n > self.units {
                break;
            }
            let t = self.per_task(n).max(self.longest_run);
            writeln!(
                f,
                "    N = {n:>4}: {} CPU, so with C = 1 suggest --time {} (twice that, at least 10 min)",
                human(t),
                slurm_time((2.0 * t).max(600.0))
            )?;
        }
        write!(
            f,
            "  the longest sampled run took {}; no task can take less",
            human(self.longest_run)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slurm_times_read_as_slurm_writes_them() {
        assert_eq!(slurm_time(59.2), "00:01:00");
        assert_eq!(slurm_time(3600.0 * 25.0 + 61.0), "1-01:01:01");
    }

    /// Under auto, the sample's points that average (above the resonance, sharing their table
    /// with another point) are charged their share of their table, built once; points below the
    /// resonance or without vibration build none.
    #[test]
    fn tables_are_charged_by_their_share_of_the_sweep() {
        let spec = SweepSpec::parse(
            "t.toml",
            r#"
name = "t"
[fixed]
v_d = 0.5e-3
[[axis]]
name = "k_d"
values = [8000.0, 11700.0]
[[axis]]
name = "f"
values = [1000.0, 3000.0, 4000.0]
[[axis]]
name = "va_ratio"
values = [0.0, 0.4]
"#,
        )
        .unwrap();
        let plan = Plan::new(&spec);
        let n = plan.points.len();
        // The 4000 Hz points' k_d = 11 700 N/m left out of the sample: the one at 8000 N/m still
        // shares its table with it in the sweep.
        let owners: Vec<usize> = (0..n)
            .map(|i| usize::from(plan.points[i].f == 4000.0 && plan.points[i].k_d == 11_700.0))
            .collect();
        let share = build_tables(&spec, &plan, &owners, &crate::averaged::TableStore::new());
        let mut got: Vec<usize> = share.keys().copied().collect();
        got.sort();
        let want: Vec<usize> = (0..n)
            .filter(|&i| plan.points[i].vibrates() && plan.points[i].f > 2000.0 && owners[i] == 0)
            .collect();
        assert_eq!(got, want);
        let at = |f: f64| {
            let v: Vec<f64> = want
                .iter()
                .filter(|&&i| plan.points[i].f == f)
                .map(|i| share[i])
                .collect();
            v
        };
        // At 3000 Hz both k_d share one build; each is charged the same half of it.
        let (s3, s4) = (at(3000.0), at(4000.0));
        assert_eq!(s3.len(), 2);
        assert!(s3[0] > 0.0 && s3[0] == s3[1], "{s3:?}");
        assert_eq!(s4.len(), 1);
        assert!(s4[0] > 0.0);
    }
}
