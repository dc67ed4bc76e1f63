//! Sweeps: plan a grid from a sweep file, run it in parallel (rayon over runs, one solver
//! workspace per worker), record every finished run in a journal at once, checkpoint the HDF5
//! file, resume after an interruption.
//!
//! The reference runs without vibration that `r` needs are found by the planner: one per
//! distinct set of non-vibration parameters (`v_d`, `k_d`, load, friction, ...), run once
//! whatever the size of the `u0` and `f` axes. Grid points without vibration reuse their
//! reference run. Every run is independent and deterministic, so the results do not depend on
//! the thread count or on the order in which runs finish.

pub mod boundary;
pub mod check;
pub mod error;
pub mod estimate;
pub mod figures;
pub mod h5;
pub mod journal;
pub mod lock;
pub mod merge;
pub mod plan;
pub mod read;
pub mod refine;
pub mod shard;
pub mod shards;
pub mod spec;
pub mod status;
pub mod traces;

use crate::averaged::TableStore;
use crate::model::Params;
use crate::ode::{Solver, Status};
use crate::progress::Progress;
use crate::sim::{self, RunOptions, RunResult};
use journal::{Journal, Task};
use rayon::prelude::*;
use shard::Shard;
use spec::SweepSpec;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub use self::error::SweepError;
pub use self::h5::{is_complete, shard_complete};
pub use self::plan::{Plan, Results};

use self::plan::{failed_points, tasks_of};
use self::refine::first_points;

/// How to run a sweep. Fields document their defaults.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// Output HDF5 file.
    pub out: PathBuf,
    /// Worker threads; `None` (default): one per core.
    pub threads: Option<usize>,
    /// Continue an interrupted sweep from its journal.
    pub resume: bool,
    /// Discard an unfinished sweep's journal and start afresh.
    pub overwrite: bool,
    /// Show a progress bar (on a terminal only).
    pub progress: bool,
    /// Seconds between HDF5 checkpoints. Default 30.
    pub checkpoint_every: f64,
    /// Run only this part of the sweep, into its own file beside `out` ([`shard`]). Default
    /// `None`: the whole sweep into `out`.
    pub shard: Option<Shard>,
    /// Counts of runs done, planned and failed, shared with a host that shows its own
    /// progress (the Python package). Default `None`.
    pub tally: Option<std::sync::Arc<crate::progress::Tally>>,
    /// Integrate the full model's runs that can run in vector lanes side by side
    /// ([`crate::sim::batch`]; the results are the same bit for bit). Default true; false runs
    /// every run on the scalar path.
    pub batch: bool,
}

impl SweepOptions {
    /// The file this invocation writes: `out`, or the shard's file beside it.
    pub fn target(&self) -> PathBuf {
        match self.shard {
            Some(s) => s.path(&self.out),
            None => self.out.clone(),
        }
    }
}

/// Summary of a finished sweep.
#[derive(Clone, Debug)]
pub struct SweepOutcome {
    /// Grid points.
    pub points: usize,
    /// Runs made in this invocation.
    pub runs_made: usize,
    /// Runs taken from the journal.
    pub runs_resumed: usize,
    /// Journal lines dropped as damaged on resuming (their runs were made again).
    pub journal_dropped: usize,
    /// Tables of the averaged law loaded from the journal on resuming (not built again).
    pub tables_loaded: usize,
    /// Points whose run (or reference) did not succeed.
    pub failed: usize,
    /// Wall time of this invocation \[s\].
    pub wall_time: f64,
    /// The output file.
    pub out: PathBuf,
    /// The full-model checks of the averaged points ([`check`]).
    pub check: check::Summary,
}

/// The parameters and options of one task's run, and the reason the full model serves it
/// where the task decides that (`None`: the run's tier choice decides): a check runs the full
/// model integrating every period (no envelope following). Every point, whether or not another
/// shares its table of the averaged law, takes the tier its run chooses: a table costs 10 to
/// 40 ms, a full run above the contact resonance 60 to 700 ms (`sweeps/fig11-boundary.toml`).
fn task_run(
    plan: &Plan,
    t: Task,
    opts: &RunOptions,
) -> (Params, RunOptions, Option<crate::sim::TierReason>) {
    use crate::sim::{Tier, TierReason};
    let p = plan.params(t);
    if !matches!(t, Task::Check(_)) {
        return (*p, opts.clone(), None);
    }
    // A check is the judge of an averaged point, so it integrates every period: envelope
    // following can tip a slide near its stability limit into stick-slip (2000 Hz, u0 = 79 nm,
    // v_d = 1.1 mm/s: r = 0.073 at 1e-4 where every period integrated gives 0, as does the
    // averaged model).
    let full = RunOptions {
        tier: Tier::Full,
        envelope: None,
        ..opts.clone()
    };
    (*p, full, Some(TierReason::Check))
}

/// Runs one task with the given solver ([`task_run`]).
fn run_task(
    plan: &Plan,
    t: Task,
    opts: &RunOptions,
    solver: &mut Solver,
    store: &TableStore,
) -> RunResult {
    let (p, opts, why) = task_run(plan, t, opts);
    let mut r = sim::simulate_in(&p, &plan.effects, &opts, solver, store)
        .expect("parameters and options were validated");
    if let Some(why) = why {
        r.tier_reason = why;
    }
    r
}

/// Runs the tasks `next` hands out, one at a time as the solver's lanes free up, with the given
/// solver: the full model's main integrations that can run in vector lanes side by side
/// ([`sim::batch`]); each result goes to `done` as it ends.
fn run_tasks(
    plan: &Plan,
    mut next: impl FnMut() -> Option<Task>,
    opts: &RunOptions,
    solver: &mut Solver,
    store: &TableStore,
    mut done: impl FnMut(Task, RunResult),
) {
    let mut taken: Vec<(Task, Option<crate::sim::TierReason>)> = Vec::new();
    let taken_ref = std::cell::RefCell::new(&mut taken);
    let asks = std::iter::from_fn(|| {
        let t = next()?;
        let (p, opts, why) = task_run(plan, t, opts);
        let mut tk = taken_ref.borrow_mut();
        tk.push((t, why));
        Some(sim::batch::Ask {
            id: tk.len() - 1,
            p,
            opts,
        })
    });
    sim::batch::simulate_batch(asks, &plan.effects, solver, store, |id, r, _| {
        let (t, why) = taken_ref.borrow()[id];
        let mut r = r.expect("parameters and options were validated");
        if let Some(w) = why {
            r.tier_reason = w;
        }
        done(t, r);
    });
}

/// Runs rounds of tasks in parallel: each finished run goes to the journal at once, and the
/// HDF5 file is checkpointed every `checkpoint_every` seconds.
struct Executor<'a> {
    spec: &'a SweepSpec,
    plan: &'a Plan,
    opts: &'a SweepOptions,
    run_opts: &'a RunOptions,
    pool: &'a rayon::ThreadPool,
    journal: &'a mut Journal,
    target: &'a Path,
    started: &'a str,
    last_checkpoint: Instant,
    /// Runs made so far.
    made: usize,
    /// A run came back interrupted ([`crate::interrupt`]): ask for no more.
    interrupted: bool,
    /// The keys of the averaged law's tables the journal holds.
    tables: std::collections::HashSet<Vec<u64>>,
    /// The averaged law's tables of this sweep, shared by all its runs (every `k_d`, `h_d` of
    /// one `f`, `u0`, `v_d` and contact uses one), loaded from the journal on resuming.
    store: &'a TableStore,
}

impl Executor<'_> {
    /// The rounds of a sweep: the first (the whole grid, or the coarse grid of a refinement),
    /// the refinement's, and the full-model checks of the averaged points, each of the points
    /// `owned`.
    fn rounds(&mut self, owned: &[bool], results: &mut Results) -> Result<(), SweepError> {
        let (spec, plan, opts) = (self.spec, self.plan, self.opts);
        let mine = |i: &usize| owned[*i];
        // The tasks of the first round: the whole grid, or the coarse grid of a refinement (the
        // shard's part of either).
        let first = tasks_of(plan, &first_points(spec, |i| owned[i]));
        let todo: Vec<Task> = first.iter().copied().filter(|t| !results.has(*t)).collect();
        let mut progress = Progress::new(
            first.len() as u64,
            (first.len() - todo.len()) as u64,
            opts.progress,
            opts.tally.clone(),
        );
        self.round(&todo, results, &mut progress)?;
        if spec.refine.is_some() && !self.interrupted {
            self.refine(results, &mut progress, &mine)?;
        }
        // The full-model checks of the averaged points (check): after the grid, as they depend
        // on its results.
        if !self.interrupted && !crate::interrupt::requested() {
            let todo: Vec<Task> = check::points(spec, plan, results, owned)
                .into_iter()
                .map(Task::Check)
                .filter(|t| !results.has(*t))
                .collect();
            progress.grow(todo.len() as u64);
            self.round(&todo, results, &mut progress)?;
        }
        progress.finish();
        Ok(())
    }

    /// Runs `todo` (references before the points that need them: the runs are independent, so
    /// any order gives the same numbers).
    fn round(
        &mut self,
        todo: &[Task],
        results: &mut Results,
        progress: &mut Progress,
    ) -> Result<(), SweepError> {
        let method = self.run_opts.method;
        let mut io_error: Option<String> = None;
        let (plan, run_opts, pool, store) = (self.plan, self.run_opts, self.pool, self.store);
        let batch = self.opts.batch;
        std::thread::scope(|sc| {
            let (tx, rx) = std::sync::mpsc::channel::<(Task, RunResult)>();
            sc.spawn(move || {
                pool.install(|| {
                    // One job per run: the runs' costs differ by a thousand times (an averaged
                    // point against a full one below the resonance), and a worker that has
                    // split off a range of them runs it through alone, while the others wait
                    // (on a 1024-point slice of the overnight grid, one of two workers sat idle
                    // for the last 9 of 25 s).
                    if batch {
                        // One batch per worker, each taking the next run from one shared
                        // queue as its lanes free up: no lane idles while runs remain.
                        let queue = std::sync::atomic::AtomicUsize::new(0);
                        let next = || {
                            let i = queue.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                            todo.get(i).copied()
                        };
                        rayon::scope(|s| {
                            for _ in 0..rayon::current_num_threads() {
                                let (tx, next) = (tx.clone(), &next);
                                s.spawn(move |_| {
                                    let mut solver = Solver::new(method);
                                    run_tasks(plan, next, run_opts, &mut solver, store, |t, r| {
                                        let _ = tx.send((t, r));
                                    });
                                });
                            }
                        })
                    } else {
                        todo.par_iter().with_max_len(1).for_each_init(
                            || (tx.clone(), Solver::new(method)),
                            |(tx, solver), &t| {
                                let r = run_task(plan, t, run_opts, solver, store);
                                // The receiver lives until every sender is gone.
                                let _ = tx.send((t, r));
                            },
                        )
                    }
                });
                drop(tx);
            });
            for (t, r) in rx {
                self.land(t, r, results, progress, &mut io_error);
            }
        });
        match io_error {
            Some(e) => Err(SweepError::State(e)),
            None => Ok(()),
        }
    }

    /// Journals and stores one run's result, and writes a checkpoint when one is due.
    fn land(
        &mut self,
        t: Task,
        r: RunResult,
        results: &mut Results,
        progress: &mut Progress,
        io_error: &mut Option<String>,
    ) {
        // An interrupted run has no result: it is neither journaled nor stored, and is made
        // again on resuming.
        if r.status == Status::Interrupted {
            self.interrupted = true;
            return;
        }
        // The table an averaged run used goes to the journal before the run's record, once: a
        // resumed sweep (or shard) loads it instead of building it again.
        if r.tier.uses_law() {
            let p = self.plan.params(t);
            let key = crate::averaged::TableStore::key(p);
            if !self.tables.contains(&key)
                && let Some(table) = self.store.cached(p)
            {
                match self.journal.record_table(&key, &table) {
                    Ok(()) => {
                        self.tables.insert(key);
                    }
                    Err(e) => {
                        io_error.get_or_insert(format!("{}: {e}", self.journal.path().display()));
                    }
                }
            }
        }
        if let Err(e) = self.journal.record(t, &r) {
            io_error.get_or_insert(format!("{}: {e}", self.journal.path().display()));
        }
        progress.inc(r.status != Status::Success);
        results.store(t, r);
        self.made += 1;
        if self.last_checkpoint.elapsed() > Duration::from_secs_f64(self.opts.checkpoint_every) {
            let _ = self.journal.sync();
            if let Err(e) = h5::write(
                self.target,
                self.spec,
                self.plan,
                results,
                &[],
                h5::Stamp {
                    started: self.started,
                    finished: None,
                    partial: false,
                    shard: self.opts.shard,
                },
            ) {
                io_error.get_or_insert(e.to_string());
            }
            self.last_checkpoint = Instant::now();
        }
    }

    /// The refinement after the coarse grid: each plane goes round after round
    /// ([`refine::next_points`]), its next round asked for as soon as its own runs of the last
    /// one have landed, whatever the other planes are doing, so no plane waits for another's
    /// slowest run. The workers take the runs in the order they are asked for.
    fn refine(
        &mut self,
        results: &mut Results,
        progress: &mut Progress,
        mine: &impl Fn(&usize) -> bool,
    ) -> Result<(), SweepError> {
        let (spec, plan, run_opts, pool, store) =
            (self.spec, self.plan, self.run_opts, self.pool, self.store);
        let method = run_opts.method;
        let batch = self.opts.batch;
        let planes = refine::plane_count(spec);
        let (plane_of, _) = shard::planes(spec);
        let mut io_error: Option<String> = None;
        // Tasks still running per plane, and the plane each was asked for.
        let mut pending = vec![0usize; planes];
        let mut asked_by: HashMap<Task, usize> = HashMap::new();
        let (task_tx, task_rx) = std::sync::mpsc::channel::<Task>();
        let (res_tx, res_rx) = std::sync::mpsc::channel::<(Task, RunResult)>();
        std::thread::scope(|sc| -> Result<(), SweepError> {
            sc.spawn(move || {
                let task_rx = std::sync::Mutex::new(task_rx);
                pool.install(|| {
                    rayon::scope(|s| {
                        for _ in 0..rayon::current_num_threads() {
                            let (res_tx, task_rx) = (res_tx.clone(), &task_rx);
                            s.spawn(move |_| {
                                let mut solver = Solver::new(method);
                                // Until the sender is gone: no plane asks for more. On the
                                // batch path a worker takes what is waiting, up to a chunk.
                                let recv = || task_rx.lock().ok().and_then(|rx| rx.recv().ok());
                                if batch {
                                    // A batch from each run that arrives: its lanes take the
                                    // runs waiting as they free up, and the batch ends when
                                    // none waits (never waiting itself: the planes ask for
                                    // more only once the runs in its lanes have landed).
                                    while let Some(t) = recv() {
                                        let mut first = Some(t);
                                        // Never waiting for the queue's lock either: another
                                        // worker may hold it while it waits for a run.
                                        let next = || {
                                            first.take().or_else(|| {
                                                task_rx
                                                    .try_lock()
                                                    .ok()
                                                    .and_then(|rx| rx.try_recv().ok())
                                            })
                                        };
                                        run_tasks(
                                            plan,
                                            next,
                                            run_opts,
                                            &mut solver,
                                            store,
                                            |t, r| {
                                                let _ = res_tx.send((t, r));
                                            },
                                        );
                                    }
                                } else {
                                    while let Some(t) = recv() {
                                        let r = run_task(plan, t, run_opts, &mut solver, store);
                                        let _ = res_tx.send((t, r));
                                    }
                                }
                            });
                        }
                    })
                });
                drop(res_tx);
            });
            // `max_runs` bounds the refinement too: a round that would pass it is not asked for,
            // and the sweep stops once the rounds under way have landed (its journal kept).
            let over: std::cell::Cell<Option<usize>> = std::cell::Cell::new(None);
            // The next round of plane `p`: its tasks go to the workers (none: the plane is done).
            let ask = |p: usize,
                       results: &Results,
                       pending: &mut [usize],
                       asked_by: &mut HashMap<Task, usize>,
                       progress: &mut Progress| {
                let points: Vec<usize> = refine::next_points(spec, plan, results, p)
                    .into_iter()
                    .filter(|i| mine(i))
                    .collect();
                let tasks: Vec<Task> = tasks_of(plan, &points)
                    .into_iter()
                    .filter(|t| !results.has(*t) && !asked_by.contains_key(t))
                    .collect();
                if crate::interrupt::requested() {
                    return 0;
                }
                let asked = results.count() + asked_by.len() + tasks.len();
                if asked > spec.max_runs || over.get().is_some() {
                    over.set(Some(over.get().unwrap_or(0).max(asked)));
                    return 0;
                }
                progress.grow(tasks.len() as u64);
                let count = tasks.len();
                for t in tasks {
                    pending[p] += 1;
                    asked_by.insert(t, p);
                    let _ = task_tx.send(t);
                }
                count
            };
            // The planes each plane's finished columns guide (`[refine] guide_planes`): a plane
            // waiting for them is asked again whenever one of its guides lands a round.
            let guided_by = guided_by(spec, planes);
            for p in 0..planes {
                ask(p, results, &mut pending, &mut asked_by, progress);
            }
            let mut running: usize = pending.iter().sum();
            while running > 0 {
                let Ok((t, r)) = res_rx.recv() else {
                    return Err(SweepError::State("the sweep's workers stopped".into()));
                };
                let p = asked_by.remove(&t).unwrap_or(match t {
                    Task::Point(i) | Task::Check(i) => plane_of[i],
                    Task::Ref(_) => 0,
                });
                self.land(t, r, results, progress, &mut io_error);
                pending[p] -= 1;
                running -= 1;
                if pending[p] == 0 {
                    running += ask(p, results, &mut pending, &mut asked_by, progress);
                    for &d in &guided_by[p] {
                        if pending[d] == 0 {
                            running += ask(d, results, &mut pending, &mut asked_by, progress);
                        }
                    }
                }
            }
            drop(task_tx);
            if let Some(n) = over.get() {
                return Err(SweepError::State(format!(
                    "the refinement asks for {n} runs in all, over the sweep's cap max_runs = {}; \
                     it stops here with every run so far kept in its journal: raise max_runs in \
                     the sweep file and continue with --resume",
                    spec.max_runs
                )));
            }
            Ok(())
        })?;
        match io_error {
            Some(e) => Err(SweepError::State(e)),
            None => Ok(()),
        }
    }
}

/// For each of the `planes` planes of a refinement, the planes its finished columns guide
/// (`[refine] guide_planes`).
fn guided_by(spec: &SweepSpec, planes: usize) -> Vec<Vec<usize>> {
    let mut guided_by: Vec<Vec<usize>> = vec![vec![]; planes];
    for p in 0..planes {
        if let Some((a, b)) = refine::plane_guides(spec, p) {
            guided_by[a].push(p);
            guided_by[b].push(p);
        }
    }
    guided_by
}

/// Runs a whole sweep to `opts.out`, or one shard of it to the shard's file (see the module
/// docs and [`shard`]). The sweep owns the tables of the averaged law its runs share.
pub fn run(spec: &SweepSpec, opts: &SweepOptions) -> Result<SweepOutcome, SweepError> {
    run_with(spec, opts, &TableStore::new())
}

/// [`run`] with the averaged law's tables of `store` (the tables it builds are left there):
/// the estimate's sample runs find the tables it timed apart. The stages: the points this
/// invocation answers for; a shard's earlier record judged; the journal opened (or resumed);
/// the rounds (the grid, the refinement, the averaged points' checks); the complete file.
pub fn run_with(
    spec: &SweepSpec,
    opts: &SweepOptions,
    store: &TableStore,
) -> Result<SweepOutcome, SweepError> {
    let start = Instant::now();
    let started = crate::output::now_iso();
    spec.run.validate().map_err(sim::SimError::from)?;
    let plan = Plan::new(spec);
    let target = opts.target();
    let owned = owned_points(spec, &plan, opts)?;
    let mut results = Results::new(&plan);
    crate::output::ensure_parent(&target)?;
    // One writer per output, from here to the end (module `lock`).
    let _lock = lock::acquire(&target).map_err(SweepError::State)?;
    let files = Files {
        jpath: journal::path_for(&target),
        fp: journal::fingerprint(&spec.text),
        target,
    };
    reopen_shard_record(spec, &plan, opts, &files)?;
    if let Some(done) = finished_shard(opts, &owned, &files, start)? {
        return Ok(done);
    }
    let Opened {
        mut journal,
        resumed,
        journal_dropped,
        kept_tables,
    } = open_journal(spec, opts, &files, store, &plan, &mut results)?;
    let Files { target, jpath, .. } = files;
    if opts.overwrite {
        let _ = std::fs::remove_file(shard::runs_path(&target));
    }
    // An unfinished file of what has run so far: what `stickslip status` reads.
    let checkpoint = |results: &Results| {
        h5::write(
            &target,
            spec,
            &plan,
            results,
            &[],
            h5::Stamp {
                started: &started,
                finished: None,
                partial: false,
                shard: opts.shard,
            },
        )
    };
    // A checkpoint at once.
    checkpoint(&results)?;

    let run_opts = RunOptions {
        trace: false,
        ..spec.run.clone()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.unwrap_or(0))
        .build()
        .map_err(|e| SweepError::State(e.to_string()))?;
    let mut exec = Executor {
        spec,
        plan: &plan,
        opts,
        run_opts: &run_opts,
        pool: &pool,
        journal: &mut journal,
        target: &target,
        started: &started,
        last_checkpoint: Instant::now(),
        made: 0,
        interrupted: false,
        tables: kept_tables,
        store,
    };
    let tables_loaded_n = exec.tables.len();
    exec.rounds(&owned, &mut results)?;
    let runs_made = exec.made;
    let interrupted = exec.interrupted || crate::interrupt::requested();
    let _ = journal.sync();
    if interrupted {
        // Everything finished so far is journaled; the checkpoint shows it to `status`.
        checkpoint(&results)?;
        return Err(SweepError::Interrupted {
            recorded: results.count(),
            journal: jpath.display().to_string(),
        });
    }

    // Points that keep traces are run once more with tracing on (deterministic: same numbers).
    // A shard leaves them to the merge.
    let traced = if opts.shard.is_none() {
        traces::traces(spec, &plan, &results, &pool, store)
    } else {
        vec![]
    };
    let finished = crate::output::now_iso();
    h5::write(
        &target,
        spec,
        &plan,
        &results,
        &traced,
        h5::Stamp {
            started: &started,
            finished: Some(&finished),
            partial: false,
            shard: opts.shard,
        },
    )?;
    // The complete file holds everything the journal did; a shard keeps its runs for the merge.
    match opts.shard {
        None => {
            let _ = std::fs::remove_file(&jpath);
        }
        Some(_) => std::fs::rename(&jpath, shard::runs_path(&target))
            .map_err(|e| SweepError::State(format!("{}: {e}", jpath.display())))?,
    }
    let failed = failed_points(spec, &plan, &results, &owned);
    Ok(SweepOutcome {
        check: check::summary(spec, &plan, &results),
        points: owned.iter().filter(|&&o| o).count(),
        runs_made,
        runs_resumed: resumed,
        journal_dropped,
        tables_loaded: tables_loaded_n,
        failed,
        wall_time: start.elapsed().as_secs_f64(),
        out: target,
    })
}

/// A sweep's files: its output, the journal beside it, and the sweep file's fingerprint that
/// the journal carries.
struct Files {
    target: PathBuf,
    jpath: PathBuf,
    fp: String,
}

/// The journal a sweep appends to, and what resuming it brought back.
struct Opened {
    journal: Journal,
    /// Runs taken from the journal.
    resumed: usize,
    /// Journal lines dropped (a torn last line).
    journal_dropped: usize,
    /// The averaged law's tables the journal kept.
    kept_tables: std::collections::HashSet<Vec<u64>>,
}

/// The grid points this invocation answers for (all, or the shard's).
fn owned_points(
    spec: &SweepSpec,
    plan: &Plan,
    opts: &SweepOptions,
) -> Result<Vec<bool>, SweepError> {
    Ok(match opts.shard {
        None => vec![true; plan.points.len()],
        Some(sh) => {
            shard::check(spec, sh.count).map_err(SweepError::State)?;
            shard::owners(spec, sh.count)
                .into_iter()
                .map(|o| o == sh.index)
                .collect()
        }
    })
}

/// A shard's record decides whether it is done: a whole record over a damaged file, or a
/// record that lacks runs, goes back to being the shard's journal, and `--resume` rebuilds the
/// file and makes only the runs it lacks.
fn reopen_shard_record(
    spec: &SweepSpec,
    plan: &Plan,
    opts: &SweepOptions,
    files: &Files,
) -> Result<(), SweepError> {
    let (target, jpath, fp) = (&files.target, &files.jpath, &files.fp);
    let runs_file = shard::runs_path(target);
    if let Some(sh) = opts.shard
        && !opts.overwrite
        && runs_file.exists()
        && !jpath.exists()
    {
        let judged = shards::judge(spec, plan, sh, target, fp)
            .map_err(|e| SweepError::State(format!("shard {sh}: {e}")))?;
        let whole = judged == shards::ShardState::Complete;
        if !(whole && is_complete(target)) {
            if !opts.resume {
                return Err(SweepError::State(format!(
                    "shard {sh} has a record {} that {}; continue it with --resume (only what is \
                     lacking is made) or start afresh with --overwrite",
                    runs_file.display(),
                    match judged {
                        shards::ShardState::Broken { missing, .. } => {
                            format!("lacks {missing} runs")
                        }
                        _ => "is whole beside a damaged or unfinished file".to_string(),
                    }
                )));
            }
            std::fs::rename(&runs_file, jpath)
                .map_err(|e| SweepError::State(format!("{}: {e}", runs_file.display())))?;
        }
    }
    Ok(())
}

/// A shard already complete: its outcome, made again from its record (a job array may run a
/// finished task again: a shard is idempotent).
fn finished_shard(
    opts: &SweepOptions,
    owned: &[bool],
    files: &Files,
    start: Instant,
) -> Result<Option<SweepOutcome>, SweepError> {
    let (target, fp) = (&files.target, &files.fp);
    if let Some(sh) = opts.shard
        && shard_complete(target)
        && !opts.overwrite
    {
        // A shard is idempotent: a job array may run a finished task again.
        let points = owned.iter().filter(|&&o| o).count();
        return Ok(Some(SweepOutcome {
            points,
            runs_made: 0,
            runs_resumed: journal::read(&shard::runs_path(target), fp)
                .map_err(|e| SweepError::State(format!("shard {sh}: {e}")))?
                .0
                .len(),
            journal_dropped: 0,
            tables_loaded: 0,
            failed: 0,
            wall_time: start.elapsed().as_secs_f64(),
            out: target.clone(),
            check: check::Summary::default(),
        }));
    }
    Ok(None)
}

/// The journal: resumed (its runs into `results`, its tables into `store`) where an
/// interrupted sweep left one and `--resume` asks for it, else created; refused where it would
/// lose or misreport a result.
fn open_journal(
    spec: &SweepSpec,
    opts: &SweepOptions,
    files: &Files,
    store: &TableStore,
    plan: &Plan,
    results: &mut Results,
) -> Result<Opened, SweepError> {
    let (target, jpath, fp) = (&files.target, &files.jpath, &files.fp);
    let mut resumed = 0;
    let mut journal_dropped = 0;
    let mut kept_tables = std::collections::HashSet::new();
    let journal = if jpath.exists() && !opts.overwrite {
        if !opts.resume {
            return Err(SweepError::State(format!(
                "{} holds an unfinished sweep; continue it with --resume or discard it with --overwrite",
                jpath.display()
            )));
        }
        let (records, dropped) = journal::read(jpath, fp).map_err(SweepError::State)?;
        journal_dropped = dropped;
        // The averaged law's tables kept by the interrupted sweep: loaded, not built again.
        for (key, table) in journal::read_tables(jpath) {
            kept_tables.insert(key.clone());
            store.preload(key, table);
        }
        resumed = results.absorb(plan, records);
        Journal::append(jpath)
            .map_err(|e| SweepError::State(format!("{}: {e}", jpath.display())))?
    } else {
        if opts.resume && is_complete(target) && opts.shard.is_none() {
            // Complete, but of which sweep: a user who resumes into another sweep's result must
            // not read that their own sweep is done.
            let held = rust_hdf5::H5File::open(target).ok().map(|f| {
                (
                    f.attr_string("sweep_name").unwrap_or_default(),
                    f.attr_string("sweep_file").unwrap_or_default(),
                )
            });
            return Err(SweepError::State(match held {
                Some((name, text)) if text != spec.text => format!(
                    "{} holds the complete result of another sweep ('{name}', from another \
                     sweep file), not of '{}': there is nothing of this sweep to resume. \
                     Write this sweep to another file with -o",
                    target.display(),
                    spec.name
                ),
                _ => format!(
                    "{} is already complete; nothing to resume",
                    target.display()
                ),
            }));
        }
        // A file without its journal is no checkpoint of this sweep: --resume must not replace
        // it (with nothing there, there is nothing to lose, and the sweep starts).
        if opts.resume && !opts.overwrite && target.exists() {
            return Err(SweepError::State(format!(
                "{} is not an interrupted sweep's checkpoint (no journal {} beside it); nothing to resume. \
                 Run without --resume to start afresh, which replaces it",
                target.display(),
                jpath.display()
            )));
        }
        Journal::create(jpath, fp)
            .map_err(|e| SweepError::State(format!("{}: {e}", jpath.display())))?
    };
    Ok(Opened {
        journal,
        resumed,
        journal_dropped,
        kept_tables,
    })
}
