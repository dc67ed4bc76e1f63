//! The sweep's HDF5 file: one N-dimensional dataset per measure at the root, its dimensions the
//! sweep's axes (zipped axes share one), each axis a coordinate dataset attached as an HDF5
//! dimension scale, so h5py's `dims` and xarray (engine h5netcdf) show named coordinates.
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
//! | `steps`, `rejected`, `rhs_evals`, `jac_evals`, `lu_decomps` | 1 | solver statistics of the point's own run |
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
use crate::model::params::PARAMS;
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
    /// A measure of the run (NaN where not run).
    fn measure(&self, f: fn(&crate::measures::Measures) -> f64) -> f64 {
        self.own.map(|r| f(&r.measures)).unwrap_or(f64::NAN)
    }

    /// A counter of the run's statistics (NaN where not run).
    fn stat(&self, f: fn(&crate::ode::Stats) -> u64) -> f64 {
        self.own.map(|r| f(&r.stats) as f64).unwrap_or(f64::NAN)
    }

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

/// One array of the sweep file: its dataset's name, unit and description, and how a grid
/// point's value is read. A measure a sweep file can leave out ([`super::spec::MEASURES`]) is
/// written where the sweep asks for it; every other column always.
struct Column {
    name: &'static str,
    unit: &'static str,
    doc: &'static str,
    read: fn(&At<'_>) -> f64,
}

/// The sweep file's arrays, in the order they are written.
const COLUMNS: &[Column] = &[
    Column {
        name: "r",
        unit: "1",
        doc: "reduction coefficient dF/dF_reference (Eq. 5.1)",
        read: |a| a.r,
    },
    Column {
        name: "r_stderr",
        unit: "1",
        doc: "standard error of r (NaN where a run with vibration holds one cycle)",
        read: |a| a.r_stderr,
    },
    Column {
        name: "dF",
        unit: "N",
        doc: "stick-slip amplitude: mean drop of the smoothed drive force per cycle",
        read: |a| a.measure(|m| m.d_f),
    },
    Column {
        name: "dF_stderr",
        unit: "N",
        doc: "standard error of dF over the cycles (NaN where a run with vibration holds one)",
        read: |a| a.measure(|m| m.d_f_stderr),
    },
    Column {
        name: "dF_reference",
        unit: "N",
        doc: "dF of the run without vibration",
        read: |a| a.reference.map(|r| r.measures.d_f).unwrap_or(f64::NAN),
    },
    Column {
        name: "mean_force",
        unit: "N",
        doc: "mean drive force over the steady window",
        read: |a| a.measure(|m| m.mean_force),
    },
    Column {
        name: "stick_fraction",
        unit: "1",
        doc: "share of the steady window spent sticking",
        read: |a| a.measure(|m| m.stick_fraction),
    },
    Column {
        name: "period",
        unit: "s",
        doc: "mean stick-slip period",
        read: |a| a.measure(|m| m.period),
    },
    Column {
        name: "peak_force",
        unit: "N",
        doc: "mean peak of the smoothed drive force",
        read: |a| a.measure(|m| m.peak_force),
    },
    Column {
        name: "trough_force",
        unit: "N",
        doc: "mean trough of the smoothed drive force",
        read: |a| a.measure(|m| m.trough_force),
    },
    Column {
        name: "cycles",
        unit: "1",
        doc: "stick-slip cycles counted in the steady window",
        read: |a| a.measure(|m| m.cycles as f64),
    },
    Column {
        name: "status",
        unit: "1",
        doc: "run status",
        read: |a| a.status(),
    },
    Column {
        name: "steps",
        unit: "1",
        doc: "accepted steps",
        read: |a| a.stat(|s| s.steps),
    },
    Column {
        name: "rejected",
        unit: "1",
        doc: "rejected steps",
        read: |a| a.stat(|s| s.rejected),
    },
    Column {
        name: "rhs_evals",
        unit: "1",
        doc: "right-hand-side evaluations",
        read: |a| a.stat(|s| s.rhs_evals),
    },
    Column {
        name: "jac_evals",
        unit: "1",
        doc: "Jacobian evaluations",
        read: |a| a.stat(|s| s.jac_evals),
    },
    Column {
        name: "lu_decomps",
        unit: "1",
        doc: "LU factorisations",
        read: |a| a.stat(|s| s.lu_decomps),
    },
    Column {
        name: "newton_iters",
        unit: "1",
        doc: "Newton iterations of the implicit methods",
        read: |a| a.stat(|s| s.newton_iters),
    },
    Column {
        name: "skipped_periods",
        unit: "1",
        doc: "vibration periods jumped by envelope following",
        read: |a| a.stat(|s| s.skipped_periods),
    },
    Column {
        name: "wall_time",
        unit: "s",
        doc: "wall time of the run",
        read: |a| a.own.map(|r| r.wall_time).unwrap_or(f64::NAN),
    },
    Column {
        name: "t_end",
        unit: "s",
        doc: "simulated time of the run (shorter than planned where it stopped early)",
        read: |a| a.own.map(|r| r.t_end).unwrap_or(f64::NAN),
    },
    Column {
        name: "tier",
        unit: "1",
        doc: "model that served the run: 0 full (every period integrated), 1 averaged (the vibration averaged out), 2 hybrid (averaged, with full windows in the law's zones)",
        read: |a| a.own.map(|r| f64::from(r.tier.code())).unwrap_or(-1.0),
    },
    Column {
        name: "tier_reason",
        unit: "1",
        doc: "why: 0 asked, 1 no_vibration, 2 two_stage, 3 effects, 4 separation, 5 no_law, 6 valid, 7 asked_averaged, 8 check (a full run replaced a disagreeing averaged one), 9 left_law (the averaged run left the valid law: full), 10 below_resonance, 11 unshared (no other point shares its table: full), 12 small_amplitude (v_a < 0.1 v_d: full), 13 asked_hybrid, 14 zones (under auto, the averaged run passed the law's zones: hybrid), 15 partial_law (the law's continuation stopped short: full), 16 near_zone (under auto, v_d in or within 25 % of a zone of the law: full)",
        read: |a| {
            a.own
                .map(|r| f64::from(r.tier_reason.code()))
                .unwrap_or(-1.0)
        },
    },
    Column {
        name: "u0_grid",
        unit: "m",
        doc: "vibration amplitude u0 of the point",
        read: |a| a.point.u0,
    },
    Column {
        name: "v_a_grid",
        unit: "m/s",
        doc: "vibration velocity amplitude v_a = 2 pi f u0 of the point",
        read: |a| a.point.v_a(),
    },
    Column {
        name: "computed",
        unit: "1",
        doc: "1 where the point was run (a [refine] sweep runs only the points near the level; the others hold NaN)",
        read: |a| f64::from(u8::from(a.own.is_some())),
    },
];

/// Builds the result arrays from the results so far (NaN where not run).
fn grids(spec: &SweepSpec, plan: &Plan, res: &Results) -> Vec<Grid> {
    let shape = IxDyn(&spec.shape());
    let n = plan.points.len();
    let keep = |name: &str| {
        !super::spec::MEASURES.contains(&name) || spec.measures.iter().any(|m| m == name)
    };
    let columns: Vec<&Column> = COLUMNS.iter().filter(|c| keep(c.name)).collect();
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
            v.push((c.read)(&at));
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
            file.set_attr_string("refine_measure", &rf.measure)
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
