//! Many recordings' simulations at once: those Dormand–Prince serves ([`super::method_for`]: one
//! stage, with vibration) integrated side by side in vector lanes ([`crate::ode::batch`]), with
//! or without model extensions; the others on the scalar path. Each simulation is bit for bit
//! [`simulate_grid`]'s of the same ask (tests/batch.rs, `grids_in_lanes_are_the_grids_alone`),
//! whatever the asks beside it or the thread that ran it.

use super::delay::Sampler;
use super::{SimTrace, Solvers, method_for, simulate_grid};
use crate::model::{Effects, Params, Rig, RigError};
use crate::ode::batch::{Job, MAX_LANE_DIM, Observe, WIDTH, solve_batch_dim};
use crate::ode::{Method, OdeSystem, Options};
use rayon::prelude::*;
use std::collections::VecDeque;
use std::sync::Mutex;
use std::time::Instant;

/// One simulation asked of [`simulate_grids`]: the arguments of [`simulate_grid`].
#[derive(Clone, Debug)]
pub struct GridAsk {
    pub p: Params,
    pub fx: Effects,
    /// First sample time \[s\], sample spacing \[s\] and number of samples.
    pub t0: f64,
    pub dt: f64,
    pub n: usize,
    /// Tolerance (`rtol = atol`).
    pub tol: f64,
}

impl GridAsk {
    /// The last sample's time \[s\]: the simulation's end.
    fn t_end(&self) -> f64 {
        self.t0 + self.dt * (self.n - 1) as f64
    }
}

/// A simulation's trace and the CPU time it took \[ns\] (a lane's share of its batch: the
/// batch's time while it ran over [`WIDTH`]).
pub type GridResult = (Result<SimTrace, RigError>, u64);

/// The sampling of one ask in a lane, and when it entered its lane.
struct GridRecorder {
    sampler: Sampler,
    start: Instant,
}

impl Observe for GridRecorder {
    #[inline]
    fn observe(&mut self, t: f64, y: &[f64]) -> bool {
        self.sampler.take(t, y);
        true
    }
}

/// Simulates every ask (as [`simulate_grid`] does one), spread over the thread pool: those a
/// lane can take in batches, streamed longest first (simulated time times frequency) from a
/// queue every batch shares, so no lane idles while asks remain; the rest one per task.
/// Results in the order of `asks`.
pub fn simulate_grids(asks: &[GridAsk]) -> Vec<GridResult> {
    let mut out: Vec<Option<GridResult>> = (0..asks.len()).map(|_| None).collect();
    let mut lanes: Vec<(usize, Rig)> = Vec::new();
    let mut scalar: Vec<usize> = Vec::new();
    for (i, a) in asks.iter().enumerate() {
        match Rig::with_effects(a.p, &a.fx) {
            Err(e) => out[i] = Some((Err(e), 0)),
            Ok(rig) if method_for(&a.p) == Method::Dopri5 && rig.dim() <= MAX_LANE_DIM => {
                lanes.push((i, rig));
            }
            Ok(_) => scalar.push(i),
        }
    }
    let span = |a: &GridAsk| a.t_end() * a.p.f;
    lanes.sort_by(|x, y| span(&asks[y.0]).total_cmp(&span(&asks[x.0])));
    let done: Mutex<Vec<(usize, GridResult)>> = Mutex::new(Vec::new());
    rayon::join(
        || {
            let got: Vec<(usize, GridResult)> = scalar
                .par_iter()
                .map_init(Solvers::default, |s, &i| {
                    let a = &asks[i];
                    let clock = Instant::now();
                    let r = simulate_grid(&a.p, &a.fx, a.t0, a.dt, a.n, a.tol, s);
                    (i, (r, nanos(clock)))
                })
                .collect();
            lock(&done).extend(got);
        },
        || in_lanes(asks, lanes, &done),
    );
    for (i, r) in done.into_inner().unwrap_or_else(|e| e.into_inner()) {
        out[i] = Some(r);
    }
    out.into_iter()
        .map(|r| r.expect("every ask is simulated"))
        .collect()
}

/// The asks of `lanes` (index and rig, longest first), in batches on every thread of the pool,
/// one batch per dimension at a time; results into `done`.
fn in_lanes(asks: &[GridAsk], lanes: Vec<(usize, Rig)>, done: &Mutex<Vec<(usize, GridResult)>>) {
    let mut dims: Vec<usize> = lanes.iter().map(|(_, r)| r.dim()).collect();
    dims.sort_unstable();
    dims.dedup();
    let mut lanes = lanes;
    for dim in dims {
        let (this, rest): (Vec<_>, Vec<_>) = lanes.into_iter().partition(|(_, r)| r.dim() == dim);
        lanes = rest;
        let batches = rayon::current_num_threads()
            .min(this.len().div_ceil(WIDTH))
            .max(1);
        let queue = Mutex::new(VecDeque::from(this));
        (0..batches).into_par_iter().for_each(|_| {
            let jobs = std::iter::from_fn(|| {
                let (i, rig) = lock(&queue).pop_front()?;
                let a = &asks[i];
                let (sampler, grid) = Sampler::new(rig.clone(), a.t0, a.dt, a.n);
                Some(Job {
                    id: i,
                    sys: rig.clone(),
                    t0: 0.0,
                    t1: a.t_end(),
                    y: rig.initial_state(),
                    opts: Options {
                        rtol: a.tol,
                        atol: a.tol,
                        ..Options::default()
                    },
                    grid,
                    envelope: None,
                    observe: GridRecorder {
                        sampler,
                        start: Instant::now(),
                    },
                })
            });
            let mut got = Vec::new();
            solve_batch_dim(dim, jobs, |job, rep, _| {
                let rec = job.observe;
                // Its share of the batch it ran in.
                let share = rec.start.elapsed().as_nanos() / WIDTH as u128;
                got.push((
                    job.id,
                    (
                        Ok(rec.sampler.finish(rep.status)),
                        u64::try_from(share).unwrap_or(u64::MAX),
                    ),
                ));
            });
            lock(done).extend(got);
        });
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

fn nanos(clock: Instant) -> u64 {
    u64::try_from(clock.elapsed().as_nanos()).unwrap_or(u64::MAX)
}
