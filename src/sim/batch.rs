//! Many runs at once: the runs the full model serves with Dormand–Prince step for step (one
//! stage, `dopri5`, or `auto` under envelope following, which keeps it explicit; the base
//! model or extensions without states of their own) integrate their main span side by side in
//! vector lanes
//! ([`crate::ode::batch`]); every other run, and everything a lane's run does after its main
//! span (a limit cycle's replay, a continuation while it settles, the integration again with
//! every period, the measures), is the scalar path's own code. A run's result is therefore bit
//! for bit the one [`simulate_in`](super::simulate_in) gives it alone (tests/batch.rs), except
//! its wall time: a run in a lane counts its time in the batch over the lanes it shared.

use super::choose;
use super::full::{Run, integrate, needs_every_period};
use super::options::RunOptions;
use super::result::RunResult;
use super::tier::Tier;
use super::window::end_time;
use super::{SimError, serve};
use crate::averaged::store::TableStore;
use crate::model::{BASE_DIM, Effects, Params, Rig};
use crate::ode::batch::{Job, Observe, Path, WIDTH, solve_batch};
use crate::ode::{Method, OdeSystem, Solver};
use std::cell::RefCell;

/// One run asked of [`simulate_batch`]: its caller's name for it, parameters and options.
#[derive(Clone, Debug)]
pub struct Ask {
    pub id: usize,
    pub p: Params,
    pub opts: RunOptions,
}

impl Observe for Run {
    #[inline]
    fn observe(&mut self, t: f64, y: &[f64]) -> bool {
        self.rec.observe(t, y)
    }
}

/// Whether the full model's run of `rig` under `opts` is Dormand–Prince's step for step over
/// its main span, so that it can run in a lane.
fn lane_ready(rig: &Rig, opts: &RunOptions) -> bool {
    let p = &rig.p;
    let two_stage = p.two_stage();
    // Extensions with states of their own run on the scalar path here (a sweep's lanes are
    // compiled for the base model's three states; a campaign's for more: `campaign::batch`).
    !two_stage
        && rig.dim() == BASE_DIM
        && match opts.method {
            Method::Dopri5 => true,
            Method::Auto => opts.envelope.is_some() && p.vibrates(),
            _ => false,
        }
}

/// The solver of each method the runs ask for: the caller's for its own method, the others'
/// made when first needed ([`crate::ode::Solvers`]).
struct Solvers<'a> {
    own: &'a mut Solver,
    others: crate::ode::Solvers,
}

impl Solvers<'_> {
    fn of(&mut self, m: Method) -> &mut Solver {
        if self.own.method() == m {
            return self.own;
        }
        self.others.get(m)
    }
}

/// What a lane's run needs once its main integration is done.
struct InLane {
    ask: Ask,
    rig: Rig,
    t_end: f64,
    why: super::TierReason,
    /// The first integration of a run integrated again with every period (`integrate_full`):
    /// its statistics and wall time count too.
    first: Option<(crate::ode::Stats, f64)>,
}

/// Simulates every run of `asks` with the effects `fx` as [`simulate_in`](super::simulate_in)
/// does one (the averaged law's tables from `store`, scalar work on `solver`, or on a solver
/// of the run's own method where it asks for another), the full model's main integrations that
/// can run in lanes side by side, and hands each result to `done` with the path that served
/// its main integration, in the order the runs end. The asks are taken one at a time as lanes
/// free up (runs the lanes cannot take are served at once, in their turn), so a caller can
/// hand out work from a queue several workers share and no lane idles while asks remain.
pub fn simulate_batch(
    asks: impl IntoIterator<Item = Ask>,
    fx: &Effects,
    solver: &mut Solver,
    store: &TableStore,
    done: impl FnMut(usize, Result<RunResult, SimError>, Path),
) {
    let solvers = RefCell::new(Solvers {
        own: solver,
        others: crate::ode::Solvers::default(),
    });
    let done = RefCell::new(done);
    let lanes: RefCell<Vec<Option<InLane>>> = RefCell::new(Vec::new());
    let mut asks = asks.into_iter();
    // Runs to integrate again with every period, before any new ask.
    let again: RefCell<Vec<InLane>> = RefCell::new(Vec::new());
    // A lane's job for run `meta`.
    let enter = |meta: InLane| {
        let mut run = Run::new(&meta.rig, meta.t_end, &meta.ask.opts);
        run.share = 1.0 / WIDTH as f64;
        let mut l = lanes.borrow_mut();
        // A free slot (one whose run came back), else a new one.
        let id = l.iter().position(Option::is_none).unwrap_or(l.len());
        let job = Job {
            id,
            sys: meta.rig.clone(),
            t0: 0.0,
            t1: meta.t_end,
            y: std::mem::take(&mut run.y),
            opts: run.ode.clone(),
            grid: run.grid,
            envelope: run.envelope,
            observe: run,
        };
        if id == l.len() {
            l.push(Some(meta));
        } else {
            l[id] = Some(meta);
        }
        job
    };
    // The next run for a lane, serving on the way the asks that cannot run in one.
    let jobs = std::iter::from_fn(|| {
        if let Some(meta) = again.borrow_mut().pop() {
            return Some(enter(meta));
        }
        loop {
            let a = asks.next()?;
            let set = a
                .opts
                .validate()
                .map_err(SimError::from)
                .and_then(|()| Ok(Rig::with_effects(a.p, fx)?))
                .and_then(|rig| Ok((end_time(&a.p, &a.opts)?, rig)));
            let (t_end, rig) = match set {
                Ok(s) => s,
                Err(e) => {
                    (done.borrow_mut())(a.id, Err(e), Path::Scalar);
                    continue;
                }
            };
            let (_, why, table) = choose::choose(&rig.p, fx.is_empty(), a.opts.tier, store);
            if table.is_some() || !lane_ready(&rig, &a.opts) {
                let mut s = solvers.borrow_mut();
                let r = serve(
                    &rig,
                    fx.is_empty(),
                    t_end,
                    &a.opts,
                    s.of(a.opts.method),
                    store,
                );
                (done.borrow_mut())(a.id, Ok(r), Path::Scalar);
                continue;
            }
            return Some(enter(InLane {
                ask: a,
                rig,
                t_end,
                why,
                first: None,
            }));
        }
    });
    solve_batch::<_, _, BASE_DIM>(jobs, |job, rep, path| {
        let meta = lanes.borrow_mut()[job.id]
            .take()
            .expect("a lane's run comes back once");
        let mut run = job.observe;
        run.y = job.y;
        let mut s = solvers.borrow_mut();
        let mut r = run.finish(rep, &meta.ask.opts, s.of(meta.ask.opts.method));
        if let Some((stats, wall)) = meta.first {
            r.stats += stats;
            r.wall_time += wall;
        } else if needs_every_period(&r, &meta.rig.p, &meta.ask.opts) {
            // As `integrate_full`: where envelope following ended in slips without a stick,
            // the run is integrated again with every period, in a lane too.
            let mut ask = meta.ask.clone();
            ask.opts.envelope = None;
            if lane_ready(&meta.rig, &ask.opts) {
                again.borrow_mut().push(InLane {
                    ask,
                    first: Some((r.stats, r.wall_time)),
                    ..meta
                });
                return;
            }
            // `auto` without envelope following may go implicit: the scalar path.
            let solver = s.of(ask.opts.method);
            let mut every = integrate(&meta.rig, meta.t_end, &ask.opts, solver);
            every.stats += r.stats;
            every.wall_time += r.wall_time;
            r = every;
        }
        r.tier = Tier::Full;
        r.tier_reason = meta.why;
        (done.borrow_mut())(meta.ask.id, Ok(r), path);
    });
}
