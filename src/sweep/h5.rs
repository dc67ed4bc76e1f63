//! The sweep's HDF5 file: one N-dimensional dataset per measure at the root, its dimensions the
//! sweep's axes (zipped axes share one), each axis a coordinate dataset attached as an HDF5
//! dimension scale, so h5py's `dims` and xarray (engine h5netcdf) show named coordinates.
//!
//! The measures' datasets are those of [`Measure`] (each with its unit and meaning as
//! attributes), the statistics' those of [`Counter`]:
//!
//! | dataset | unit | meaning |
//! |---|---|---|
//! | `r`, `r_stderr` | 1 | reduction coefficient (5.1) and its standard error (NaN: one cycle of a run with vibration) |
//! | `dF`, `dF_stderr` | N | stick-slip amplitude and its standard error (NaN: one cycle of a run with vibration) |
//! | `dF_reference` | N | dF of the run without vibration used for r |
//! | `mean_force`, `peak_force`, `trough_force` | N | drive-force measures |
//! | `stick_fraction` | 1 | share of the steady window spent sticking |
//! | `period` | s | stick-slip period |
//! | `cycles` | 1 | cycles counted |
//! | `status` | 1 | 0 success, 1 step too small, 2 max steps, 3 Newton failure, 4 non-finite, 5 unsettled (measured, force still creeping at the longest time), −1 not run yet |
//! | `steps`, `rejected`, `rhs_evals`, `jac_evals`, `lu_decomps`, `newton_iters`, `skipped_periods` | 1 | solver statistics of the point's own run, one per [`Counter`] |
//! | `wall_time` | s | wall time of the point's own run |
//! | `t_end` | s | simulated time of the point's own run (shorter than planned where it stopped early) |
//! | `tier` | 1 | model that served the point's own run: 0 full, 1 averaged, 2 hybrid (`crate::sim::Tier`), −1 not run yet |
//! | `tier_reason` | 1 | why: 0 asked, 1 no_vibration, 2 two_stage, 3 effects, 4 separation, 5 no_law, 6 valid, 7 asked_averaged, 8 check (the full run replaced a disagreeing averaged one: `crate::sweep::check`), 9 left_law (the averaged run's window left the valid law; the full model served), 10 below_resonance, 11 unshared (under auto, no other point shares the point's table), 12 small_amplitude (v_a below 0.1 v_d), 13 asked_hybrid, 14 zones (under auto, the averaged run passed the law's zones and hybrid windows served), 15 partial_law (a hybrid run found the law's continuation stopped short; the full model served), 16 near_zone (under auto, `v_d` lies in or within 25 % of a zone of the law; the full model served) (`crate::sim::TierReason`), −1 not run yet |
//!
//! Group `tier_check` (where any point was averaged) holds the full-model checks of averaged points and their summary ([`super::check`]).
//! | `u0_grid`, `v_a_grid` | m, m/s | the vibration amplitude and velocity amplitude of each point |
//!
//! Root attributes: the sweep file's text, the resolved fixed parameters, solver settings, the
//! program version, start and end times, and `sweep_status` (`complete`, `in_progress`, or
//! `partial` for a merge with shards missing); a shard's file also `shard_index` and
//! `shard_count`.
//! Group `traces` holds the traces of the chosen points, one group per point.

use super::plan::{Plan, Results};
use super::shard::Shard;
use super::spec::SweepSpec;
use crate::measures::Measure;
use crate::model::params::PARAMS;
use crate::ode::Counter;
use crate::output::{self, OutputError, ds_attr_str, h5err, ioerr};
use crate::sim::{self, Trace};
use ndarray::{ArrayD, IxDyn};
use rust_hdf5::{H5Dataset, H5File};
use std::path::Path;

struct Grid {
    name: &'static str,
    unit: &'static str,
    doc: &'static str,
    data: ArrayD<f64>,
}

fn status_code(r: Option<&sim::RunResult>) -> f64 {
    r.map(|r| r.status.code() as f64).unwrap_or(-1.0)
}

/// What one grid point gives its columns: its run and its reference (none where not run), its
/// reduction with its standard error, and its parameters.
struct At<'a> {
    own: Option<&'a sim::RunResult>,
    reference: Option<&'a sim::RunResult>,
    r: f64,
    r_stderr: f64,
    point: &'a crate::model::Params,
}

impl At<'_> {
    /// The point's status: its run's, or its reference's where that failed (a point fails when
    /// its run or its reference fails); −1 where not run.
    fn status(&self) -> f64 {
        match (self.own, self.reference) {
            (Some(a), Some(b)) if b.status != crate::ode::Status::Success => {
                b.status.code().max(a.status.code()) as f64
            }
            _ => status_code(self.own),
        }
    }
}

/// Where a column's values come from: a measure ([`Measure`], left out where the sweep does
/// not keep it), a counter of the run's work ([`Counter`]), or the point's run or parameters.
#[derive(Clone, Copy)]
enum Source {
    Measure(Measure),
    Counter(Counter),
    Other(fn(&At<'_>) -> f64),
}

/// One array of the sweep file: its dataset's name, unit and description, and where a grid
/// point's value comes from.
struct Column {
    name: &'static str,
    unit: &'static str,
    doc: &'static str,
    source: Source,
}

impl Column {
    fn read(&self, a: &At<'_>) -> f64 {
        match self.source {
            Source::Measure(m) => match m {
                Measure::R => a.r,
                Measure::RStderr => a.r_stderr,
                m => a
                    .own
                    .and_then(|r| m.of_run(&r.measures))
                    .unwrap_or(f64::NAN),
            },
            Source::Counter(c) => a.own.map(|r| c.of(&r.stats) as f64).unwrap_or(f64::NAN),
            Source::Other(f) => f(a),
        }
    }
}

/// The sweep file's arrays, in the order they are written: every measure, the reference's dF
/// and the status, every counter of the run's work, then the run's times and tier and the
/// point's vibration.
fn columns() -> Vec<Column> {
    let measures = Measure::ALL.into_iter().map(|m| Column {
        name: m.name(),
        unit: m.unit(),
        doc: m.doc(),
        source: Source::Measure(m),
    });
    let counters = Counter::ALL.into_iter().map(|c| Column {
        name: c.name(),
        unit: "1",
        doc: c.doc(),
        source: Source::Counter(c),
    });
    let first = [
        Column {
            name: "dF_reference",
            unit: "N",
            doc: "dF of the run without vibration",
            source: Source::Other(|a| a.reference.map(|r| r.measures.d_f).unwrap_or(f64::NAN)),
        },
        Column {
            name: "status",
            unit: "1",
            doc: "run status",
            source: Source::Other(|a| a.status()),
        },
    ];
    let rest = [
        Column {
            name: "wall_time",
            unit: "s",
            doc: "wall time of the run",
            source: Source::Other(|a| a.own.map(|r| r.wall_time).unwrap_or(f64::NAN)),
        },
        Column {
            name: "t_end",
            unit: "s",
            doc: "simulated time of the run (shorter than planned where it stopped early)",
            source: Source::Other(|a| a.own.map(|r| r.t_end).unwrap_or(f64::NAN)),
        },
        Column {
            name: "tier",
            unit: "1",
            doc: "model that served the run: 0 full (every period integrated), 1 averaged (the vibration averaged out), 2 hybrid (averaged, with full windows in the law's zones)",
            source: Source::Other(|a| a.own.map(|r| f64::from(r.tier.code())).unwrap_or(-1.0)),
        },
        Column {
            name: "tier_reason",
            unit: "1",
            doc: "why: 0 asked, 1 no_vibration, 2 two_stage, 3 effects, 4 separation, 5 no_law, 6 valid, 7 asked_averaged, 8 check (a full run replaced a disagreeing averaged one), 9 left_law (the averaged run left the valid law: full), 10 below_resonance, 11 unshared (no other point shares its table: full), 12 small_amplitude (v_a < 0.1 v_d: full), 13 asked_hybrid, 14 zones (under auto, the averaged run passed the law's zones: hybrid), 15 partial_law (the law's continuation stopped short: full), 16 near_zone (under auto, v_d in or within 25 % of a zone of the law: full)",
            source: Source::Other(|a| {
                a.own
                    .map(|r| f64::from(r.tier_reason.code()))
                    .unwrap_or(-1.0)
            }),
        },
        Column {
            name: "u0_grid",
            unit: "m",
            doc: "vibration amplitude u0 of the point",
            source: Source::Other(|a| a.point.u0),
        },
        Column {
            name: "v_a_grid",
            unit: "m/s",
            doc: "vibration velocity amplitude v_a = 2 pi f u0 of the point",
            source: Source::Other(|a| a.point.v_a()),
        },
        Column {
            name: "computed",
            unit: "1",
            doc: "1 where the point was run (a [refine] sweep runs only the points near the level; the others hold NaN)",
            source: Source::Other(|a| f64::from(u8::from(a.own.is_some()))),
        },
    ];
    measures.chain(first).chain(counters).chain(rest).collect()
}

/// Builds the result arrays from the results so far (NaN where not run).
fn grids(spec: &SweepSpec, plan: &Plan, res: &Results) -> Vec<Grid> {
    let shape = IxDyn(&spec.shape());
    let n = plan.points.len();
    let keep = |c: &Column| match c.source {
        Source::Measure(m) => spec.measures.contains(&m),
        _ => true,
    };
    let columns: Vec<Column> = columns().into_iter().filter(keep).collect();
    let mut data: Vec<Vec<f64>> = vec![Vec::with_capacity(n); columns.len()];
    for i in 0..n {
        let (own, reference) = res.point(plan, i);
        let (r, r_stderr) = res.reduction(plan, i);
        let at = At {
            own,
            reference,
            r,
            r_stderr,
            point: &plan.points[i],
        };
        for (c, v) in columns.iter().zip(data.iter_mut()) {
            v.push(c.read(&at));
        }
    }
    columns
        .into_iter()
        .zip(data)
        .map(|(c, v)| Grid {
            name: c.name,
            unit: c.unit,
            doc: c.doc,
            data: ArrayD::from_shape_vec(shape.clone(), v).expect("shape matches the grid"),
        })
        .collect()
}

/// When and how a sweep file was made: its start, its end (none while in progress), whether
/// points are missing on purpose (a merge with `--partial`) and which shard it holds.
#[derive(Clone, Copy, Debug)]
pub struct Stamp<'a> {
    /// Start time (ISO 8601).
    pub started: &'a str,
    /// End time; `None` while the sweep is in progress (a checkpoint).
    pub finished: Option<&'a str>,
    /// A merge of the shards there were, some missing (`sweep_status = "partial"`).
    pub partial: bool,
    /// The shard the file holds (attributes `shard_index`, `shard_count`).
    pub shard: Option<Shard>,
}

impl Stamp<'_> {
    /// The `sweep_status` attribute: `in_progress`, `complete` or `partial`.
    pub fn status(&self) -> &'static str {
        match (self.finished, self.partial) {
            (None, _) => "in_progress",
            (Some(_), false) => "complete",
            (Some(_), true) => "partial",
        }
    }
}

/// Writes the sweep file (under a temporary name, renamed into place).
pub fn write(
    path: &Path,
    spec: &SweepSpec,
    plan: &Plan,
    res: &Results,
    traces: &[(usize, Trace)],
    stamp: Stamp,
) -> Result<(), OutputError> {
    let (started, finished) = (stamp.started, stamp.finished);
    output::ensure_parent(path)?;
    let tmp = output::temp_for(path)?;
    {
        let e = h5err(path);
        let file = H5File::create(&tmp).map_err(&e)?;
        // Coordinates: one dataset per axis, a dimension scale named after it.
        let mut scales: Vec<Vec<H5Dataset>> = vec![];
        for dim in &spec.dims {
            let mut v = vec![];
            for &a in &dim.axes {
                let ax = &spec.axes[a];
                let ds = output::write_vec(
                    &file.root_group(),
                    &ax.name,
                    &ax.values,
                    ax.unit,
                    &axis_doc(&ax.name),
                    path,
                )?;
                ds.set_scale(Some(&ax.name)).map_err(&e)?;
                v.push(ds);
            }
            scales.push(v);
        }
        let shape = spec.shape();
        for g in grids(spec, plan, res) {
            let ds = file
                .new_dataset::<f64>()
                .shape(&shape)
                .create(g.name)
                .map_err(&e)?;
            ds.write_raw(g.data.as_slice().expect("standard layout"))
                .map_err(&e)?;
            ds_attr_str(&ds, "units", g.unit, path)?;
            ds_attr_str(&ds, "long_name", g.doc, path)?;
            if g.name == "status" {
                ds_attr_str(
                    &ds,
                    "flag_meanings",
                    "not_run(-1) success(0) step_too_small(1) max_steps(2) newton_failure(3) non_finite(4) unsettled(5)",
                    path,
                )?;
            }
            for (d, sc) in scales.iter().enumerate() {
                for s in sc {
                    ds.attach_scale(d, s).map_err(&e)?;
                }
            }
        }
        file.set_attr_string("program", &output::program())
            .map_err(&e)?;
        file.set_attr_string("sweep_name", &spec.name).map_err(&e)?;
        file.set_attr_string("sweep_description", &spec.description)
            .map_err(&e)?;
        file.set_attr_string("sweep_file", &spec.text).map_err(&e)?;
        file.set_attr_string("started", started).map_err(&e)?;
        file.set_attr_string("finished", finished.unwrap_or(""))
            .map_err(&e)?;
        file.set_attr_string("sweep_status", stamp.status())
            .map_err(&e)?;
        file.set_attr_numeric("complete", &i64::from(stamp.status() == "complete"))
            .map_err(&e)?;
        if let Some(sh) = stamp.shard {
            file.set_attr_numeric("shard_index", &(sh.index as i64))
                .map_err(&e)?;
            file.set_attr_numeric("shard_count", &(sh.count as i64))
                .map_err(&e)?;
        }
        file.set_attr_string(
            "dims",
            &spec
                .dims
                .iter()
                .map(|d| d.name.clone())
                .collect::<Vec<_>>()
                .join(","),
        )
        .map_err(&e)?;
        file.set_attr_string("solver", spec.run.method.name())
            .map_err(&e)?;
        file.set_attr_numeric("rtol", &spec.run.ode.rtol)
            .map_err(&e)?;
        file.set_attr_numeric("atol", &spec.run.ode.atol)
            .map_err(&e)?;
        file.set_attr_numeric("min_cycles", &(spec.run.min_cycles as i64))
            .map_err(&e)?;
        file.set_attr_numeric("t_end", &spec.run.t_end.unwrap_or(f64::NAN))
            .map_err(&e)?;
        file.set_attr_numeric("reference_runs", &(plan.refs.len() as i64))
            .map_err(&e)?;
        if let Some(rf) = &spec.refine {
            file.set_attr_string("refine_measure", rf.measure.name())
                .map_err(&e)?;
            file.set_attr_string("refine_along", &spec.axes[rf.along].name)
                .map_err(&e)?;
            file.set_attr_numeric("refine_level", &rf.level)
                .map_err(&e)?;
            file.set_attr_numeric("refine_resolution", &rf.resolution)
                .map_err(&e)?;
            file.set_attr_numeric("refine_tolerance", &rf.tolerance)
                .map_err(&e)?;
            file.set_attr_numeric("refine_levels", &(rf.levels as i64))
                .map_err(&e)?;
            file.set_attr_numeric("refine_coarse", &(rf.coarse as i64))
                .map_err(&e)?;
        }
        for p in PARAMS {
            file.set_attr_numeric(&format!("fixed_{}", p.name), &p.get(&spec.fixed))
                .map_err(&e)?;
        }
        if let Some((k, v)) = &spec.fixed_amplitude {
            file.set_attr_numeric(&format!("fixed_{k}"), v)
                .map_err(&e)?;
        }
        super::check::write_h5(&file, spec, plan, res, path)?;
        if !traces.is_empty() {
            let g = file.create_group("traces").map_err(&e)?;
            for (i, tr) in traces {
                let pg = output::write_trace_group(&g, &format!("point_{i}"), tr, path)?;
                pg.set_attr_string("point", &describe_point(spec, *i))
                    .map_err(&e)?;
                pg.set_attr_numeric("index", &(*i as i64)).map_err(&e)?;
            }
        }
        file.close().map_err(&e)?;
    }
    crate::output::replace(&tmp, path).map_err(ioerr(path))
}

fn axis_doc(name: &str) -> String {
    match name {
        "v_a" => "vibration velocity amplitude v_a = 2 pi f u0".into(),
        "va_ratio" => "vibration velocity amplitude over drive velocity, v_a / v_d".into(),
        n => crate::model::params::info(n)
            .map(|i| i.doc.to_string())
            .unwrap_or_default(),
    }
}

/// Writes the traces' point coordinates into a CSV-friendly string (for messages).
pub fn describe_point(spec: &SweepSpec, i: usize) -> String {
    spec.point_values(i)
        .iter()
        .map(|(n, v)| format!("{n}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Whether a shard's file is complete: its HDF5 file says so and its runs are kept beside it.
pub fn shard_complete(path: &Path) -> bool {
    is_complete(path) && super::shard::runs_path(path).exists()
}

/// Whether an HDF5 sweep file exists and is marked complete.
pub fn is_complete(path: &Path) -> bool {
    rust_hdf5::H5File::open(path)
        .ok()
        .and_then(|f| f.attr_string("sweep_status").ok())
        .as_deref()
        == Some("complete")
}
