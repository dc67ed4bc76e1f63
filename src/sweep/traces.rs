//! The traces of a sweep's chosen points, run once more with tracing on (a finished sweep's and
//! a merge's).

use super::plan::{Plan, Results};
use super::spec::SweepSpec;
use crate::averaged::TableStore;
use crate::ode::Solver;
use crate::sim::{self, RunOptions, Trace};
use rayon::prelude::*;

/// The traces of the sweep's chosen points (`[output] traces`) that have results, run once more
/// with tracing on (the runs are deterministic: the same numbers).
pub fn traces(
    spec: &SweepSpec,
    plan: &Plan,
    results: &Results,
    pool: &rayon::ThreadPool,
    store: &TableStore,
) -> Vec<(usize, Trace)> {
    let method = spec.run.method;
    let points: Vec<usize> = spec
        .trace_points()
        .into_iter()
        .filter(|&i| results.point(plan, i).0.is_some())
        .collect();
    pool.install(|| {
        points
            .into_par_iter()
            .map_init(
                || Solver::new(method),
                |solver, i| {
                    let o = RunOptions {
                        trace: true,
                        ..spec.run.clone()
                    };
                    let r = sim::simulate_in(&plan.points[i], &plan.effects, &o, solver, store)
                        .expect("validated");
                    (i, r.trace.unwrap_or_default())
                },
            )
            .collect()
    })
}
