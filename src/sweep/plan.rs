//! The expanded grid of a sweep (its points, reference runs and tables shared), the results
//! collected so far, and which runs a set of points needs. Data and bookkeeping: every room of
//! the sweep that reads or writes results imports it; it runs nothing.

use super::journal::Task;
use super::spec::SweepSpec;
use crate::measures::Measure;
use crate::model::{Params, params::PARAMS};
use crate::ode::Status;
use crate::sim;
use crate::sim::RunResult;
use std::collections::HashMap;

/// The expanded grid and its reference runs.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Parameters of every grid point, flat in C order.
    pub points: Vec<Params>,
    /// Parameters of every distinct reference run (no vibration).
    pub refs: Vec<Params>,
    /// For each point, the index of its reference.
    pub point_ref: Vec<usize>,
    /// Model extensions of every run.
    pub effects: crate::model::Effects,
    /// The boundary level of `r` about which averaged points are checked ([`check_level`]).
    pub check_level: f64,
    /// For each point, how many points with vibration share its table of the averaged law
    /// ([`crate::averaged::TableStore::key`]): [`super::estimate`] charges each point its share
    /// of its table.
    pub table_share: Vec<usize>,
    /// For each point, the forcing periods its full-model run plans to integrate (planned
    /// simulated time times `f`), 0 where the averaged law may serve it (a table is built
    /// for it): a sweep hands its runs out longest first.
    pub periods: Vec<u64>,
}

/// The bits of every parameter that a run without vibration depends on (all but u0, f, t_on).
fn reference_key(p: &Params) -> Vec<u64> {
    PARAMS
        .iter()
        .filter(|i| !matches!(i.name, "u0" | "f" | "t_on"))
        .map(|i| i.get(p).to_bits())
        .collect()
}

impl Plan {
    /// Expands a validated sweep.
    pub fn new(spec: &SweepSpec) -> Plan {
        let n = spec.len();
        let mut points = Vec::with_capacity(n);
        let mut refs = vec![];
        let mut point_ref = Vec::with_capacity(n);
        let mut index: HashMap<Vec<u64>, usize> = HashMap::new();
        for i in 0..n {
            let p = spec
                .point_params(i)
                .expect("points were validated when the sweep was read");
            let key = reference_key(&p);
            let r = *index.entry(key).or_insert_with(|| {
                refs.push(p.without_vibration());
                refs.len() - 1
            });
            point_ref.push(r);
            points.push(p);
        }
        let table_share = {
            let keys: Vec<Vec<u64>> = points
                .iter()
                .map(crate::averaged::TableStore::key)
                .collect();
            let mut count: HashMap<&Vec<u64>, usize> = HashMap::new();
            for (k, p) in keys.iter().zip(&points) {
                if p.vibrates() {
                    *count.entry(k).or_default() += 1;
                }
            }
            keys.iter()
                .map(|k| count.get(k).copied().unwrap_or(0))
                .collect()
        };
        let none = spec.effects.is_empty();
        let periods = points
            .iter()
            .map(|p| {
                if crate::sim::choose::needs_table(p, none, spec.run.tier) {
                    0
                } else {
                    (crate::sim::planned_time(p, spec.run.min_cycles) * p.f) as u64
                }
            })
            .collect();
        Plan {
            periods,
            points,
            refs,
            point_ref,
            effects: spec.effects.clone(),
            check_level: check_level(spec),
            table_share,
        }
    }

    /// All runs the sweep needs: every reference, and every point with vibration.
    pub fn tasks(&self) -> Vec<Task> {
        let mut t: Vec<Task> = (0..self.refs.len()).map(Task::Ref).collect();
        t.extend(
            (0..self.points.len())
                .filter(|&i| self.points[i].vibrates())
                .map(Task::Point),
        );
        t
    }

    /// Parameters of a task's run.
    pub fn params(&self, t: Task) -> &Params {
        match t {
            Task::Ref(i) => &self.refs[i],
            Task::Point(i) | Task::Check(i) => &self.points[i],
        }
    }
}

/// A run with measures (succeeded, or unsettled and flagged), if any.
pub(crate) fn measured(r: Option<&RunResult>) -> Option<&RunResult> {
    r.filter(|r| r.status.has_measures())
}

/// Results collected so far (`None`: not run yet).
#[derive(Clone, Debug)]
pub struct Results {
    /// Reference runs.
    pub refs: Vec<Option<RunResult>>,
    /// Grid-point runs (only points with vibration are run; the others use their reference).
    pub points: Vec<Option<RunResult>>,
    /// Full-model checks of averaged points ([`check`](super::check)).
    pub checks: Vec<Option<RunResult>>,
}

impl Results {
    pub(crate) fn new(plan: &Plan) -> Results {
        Results {
            refs: vec![None; plan.refs.len()],
            points: vec![None; plan.points.len()],
            checks: vec![None; plan.points.len()],
        }
    }

    pub(crate) fn store(&mut self, t: Task, r: RunResult) {
        match t {
            Task::Ref(i) => self.refs[i] = Some(r),
            Task::Point(i) => self.points[i] = Some(r),
            Task::Check(i) => self.checks[i] = Some(r),
        }
    }

    /// Stores journal records that belong to this plan and are not stored yet (later records
    /// of a task do not replace the first); returns how many were stored.
    pub(crate) fn absorb(&mut self, plan: &Plan, records: Vec<(Task, RunResult)>) -> usize {
        let mut stored = 0;
        for (t, r) in records {
            let valid = match t {
                Task::Ref(i) => i < plan.refs.len(),
                Task::Point(i) | Task::Check(i) => i < plan.points.len(),
            };
            if valid && !self.has(t) {
                self.store(t, r);
                stored += 1;
            }
        }
        stored
    }

    /// Runs stored (references and points).
    pub(crate) fn count(&self) -> usize {
        self.refs
            .iter()
            .chain(&self.points)
            .chain(&self.checks)
            .filter(|r| r.is_some())
            .count()
    }

    pub(crate) fn has(&self, t: Task) -> bool {
        match t {
            Task::Ref(i) => self.refs[i].is_some(),
            Task::Point(i) => self.points[i].is_some(),
            Task::Check(i) => self.checks[i].is_some(),
        }
    }

    /// The reduction coefficient of grid point `i` and its standard error (5.1): 1 without
    /// vibration, NaN where the point or its reference has no measures.
    pub fn reduction(&self, plan: &Plan, i: usize) -> (f64, f64) {
        let (own, rf) = self.point(plan, i);
        match (measured(own), measured(rf)) {
            (Some(a), Some(b)) if plan.points[i].vibrates() => {
                sim::reduction(&a.measures, &b.measures)
            }
            (Some(_), Some(_)) => (1.0, 0.0),
            _ => (f64::NAN, f64::NAN),
        }
    }

    /// The value of measure `m` at grid point `i`: NaN where the point, or for `r` its
    /// reference, has no measures.
    pub fn measure(&self, plan: &Plan, i: usize, m: Measure) -> f64 {
        let Some(own) = measured(self.point(plan, i).0) else {
            return f64::NAN;
        };
        m.of_point(&own.measures, self.reduction(plan, i))
    }

    /// The run that stands for grid point `i` (its own, its full-model check where that
    /// disagrees with its averaged run ([`replaced`]), or its reference when it has no
    /// vibration) and its reference.
    pub fn point(&self, plan: &Plan, i: usize) -> (Option<&RunResult>, Option<&RunResult>) {
        let rf = self.refs[plan.point_ref[i]].as_ref();
        let own = if !plan.points[i].vibrates() {
            rf
        } else if replaced(plan, self, i) {
            self.checks[i].as_ref()
        } else {
            self.points[i].as_ref()
        };
        (own, rf)
    }
}

/// The boundary level of `r` the band is about.
pub fn check_level(spec: &SweepSpec) -> f64 {
    spec.refine
        .as_ref()
        .filter(|r| r.measure == Measure::R)
        .map_or(super::boundary::ELIMINATED, |r| r.level)
}

/// The tasks of grid points `points` (flat indices): their references first, then the points
/// with vibration, without repeats.
pub(crate) fn tasks_of(plan: &Plan, points: &[usize]) -> Vec<Task> {
    let mut refs: Vec<usize> = points.iter().map(|&i| plan.point_ref[i]).collect();
    refs.sort_unstable();
    refs.dedup();
    let mut t: Vec<Task> = refs.into_iter().map(Task::Ref).collect();
    // The full model's runs first, the most forcing periods first: a long run started when
    // the other workers are nearly done ends the sweep alone (on the 1024-point slice of
    // `benches/batch/slice.toml` a run of 2e8 right-hand sides did). Then the points that
    // share a table of the averaged law (every k_d, h_d of one f, u0, v_d and contact) next to
    // each other: a worker takes runs in order, so it builds the table once for the runs that
    // follow instead of two workers waiting on one build. The order changes no number: every
    // run is independent.
    let mut pts: Vec<usize> = points
        .iter()
        .copied()
        .filter(|&i| plan.points[i].vibrates())
        .collect();
    pts.sort_by_cached_key(|&i| {
        (
            std::cmp::Reverse(plan.periods[i]),
            crate::averaged::TableStore::key(&plan.points[i]),
        )
    });
    t.extend(pts.into_iter().map(Task::Point));
    t
}

/// The grid points among `owned` whose run or reference did not succeed (a refinement leaves
/// the points far from the level out on purpose: those do not count).
pub(crate) fn failed_points(
    spec: &SweepSpec,
    plan: &Plan,
    results: &Results,
    owned: &[bool],
) -> usize {
    (0..plan.points.len())
        .filter(|&i| owned[i])
        .filter(|&i| {
            let (own, rf) = results.point(plan, i);
            match own {
                None => spec.refine.is_none(),
                Some(a) => {
                    a.status != Status::Success
                        || rf.map(|r| r.status != Status::Success).unwrap_or(true)
                }
            }
        })
        .count()
}

/// Largest `|Δr|` of a check that agrees (docs/model.md's accuracy of `r`).
pub const R_TOL: f64 = 0.01;
/// Largest relative difference of the mean force of a check that agrees (docs/model.md's 0.5 %).
pub const FORCE_TOL: f64 = 0.005;

/// The averaged run of point `i` (its own run, where the averaged model served it).
pub(crate) fn averaged_run(res: &Results, i: usize) -> Option<&crate::sim::RunResult> {
    measured(res.points[i].as_ref()).filter(|r| r.tier.uses_law())
}

/// One averaged point against its full run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Flat index of the grid point.
    pub point: usize,
    /// Drawn in the random share (else: in the band about the level).
    pub random: bool,
    /// `r` of the averaged and of the full run.
    pub r: (f64, f64),
    /// Mean drive force of the averaged and of the full run \[N\].
    pub mean_force: (f64, f64),
    /// `|Δr| ≤` [`R_TOL`].
    pub within_r: bool,
    /// Relative difference of the mean force `≤` [`FORCE_TOL`].
    pub within_force: bool,
    /// The two `r` on opposite sides of the level.
    pub side_change: bool,
}

impl Comparison {
    /// Whether the full run replaces the averaged one.
    pub fn replaced(&self) -> bool {
        !self.within_r || !self.within_force || self.side_change
    }
}

/// The comparison of point `i`, where it was checked (its full run has measures, as has its
/// averaged run and their reference); `random` says whether it was drawn in the random share.
pub(crate) fn compare(plan: &Plan, res: &Results, i: usize, random: bool) -> Option<Comparison> {
    let avg = averaged_run(res, i)?;
    let full = measured(res.checks[i].as_ref())?;
    let rf = measured(res.refs[plan.point_ref[i]].as_ref())?;
    let ra = crate::sim::reduction(&avg.measures, &rf.measures).0;
    let rb = crate::sim::reduction(&full.measures, &rf.measures).0;
    let (fa, fb) = (avg.measures.mean_force, full.measures.mean_force);
    let lv = plan.check_level;
    Some(Comparison {
        point: i,
        random,
        r: (ra, rb),
        mean_force: (fa, fb),
        // NaN on either side (a reference without stick-slip) agrees only with NaN.
        within_r: (ra - rb).abs() <= R_TOL || (ra.is_nan() && rb.is_nan()),
        within_force: (fa / fb - 1.0).abs() <= FORCE_TOL,
        side_change: (ra < lv) != (rb < lv),
    })
}

/// Whether the full run of point `i` replaces its averaged one ([`Comparison::replaced`]);
/// false where it was not checked.
pub fn replaced(plan: &Plan, res: &Results, i: usize) -> bool {
    compare(plan, res, i, false).is_some_and(|c| c.replaced())
}
