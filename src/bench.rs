//! `stickslip bench`: a work-precision benchmark of stickslip's own methods.
//!
//! For each case and method, a ladder of tolerances (`rtol = atol`); each run is timed (median
//! of `repeats`, one thread, runs side by side in one process) and compared with a reference
//! computed at a tight tolerance: the error of `r` (absolute), of the mean drive force and of dF
//! (relative). `r` uses the dF of a tight run without vibration, so only the vibrated run is
//! timed — the reference is shared by every point of a sweep.
//!
//! With partial reduction the trajectories are sensitive: runs that differ only in tolerance
//! part after a second or two, and `r` spreads by a few thousandths; below that spread an error
//! measures the chaos, not the method.
//!
//! `stickslip bench --batch` measures the batch path against the scalar one instead ([`batch`]).

pub mod batch;

use crate::model::Params;
use crate::ode::{Method, Options, Solver, Stats, Status};
use crate::output::{self, OutputError, h5err};
use crate::plot::{Figure, PlotError, render};
use crate::sim::{self, RunOptions, RunResult};
use plotters::coord::Shift;
use plotters::prelude::*;
use rust_hdf5::H5File;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A benchmark case.
#[derive(Clone, Debug)]
pub struct BenchCase {
    /// Short name.
    pub name: &'static str,
    /// What it exercises.
    pub doc: &'static str,
    /// Parameters.
    pub params: Params,
}

fn with_ratio(mut p: Params, ratio: f64) -> Params {
    p.set_v_a(ratio * p.v_d);
    p
}

/// The cases: no vibration, partial reduction and elimination at 1500 Hz and above the contact
/// resonance (where the averaged tier serves), the slow corner of the paper's ranges, and low
/// frequency with large amplitude.
pub fn cases() -> Vec<BenchCase> {
    let base = Params {
        k_d: 11_700.0,
        v_d: 0.5e-3,
        f: 1500.0,
        ..Params::default()
    };
    vec![
        BenchCase {
            name: "no_vibration",
            doc: "k_d = 11 700 N/m, v_d = 0.5 mm/s, u0 = 0",
            params: base,
        },
        BenchCase {
            name: "partial",
            doc: "v_a/v_d = 0.4 at 1500 Hz (partial reduction)",
            params: with_ratio(base, 0.4),
        },
        BenchCase {
            name: "eliminated",
            doc: "v_a/v_d = 2 at 1500 Hz (eliminated)",
            params: with_ratio(base, 2.0),
        },
        BenchCase {
            name: "partial_3k",
            doc: "v_a/v_d = 0.4 at 3000 Hz (partial reduction above the contact resonance)",
            params: with_ratio(Params { f: 3000.0, ..base }, 0.4),
        },
        BenchCase {
            name: "eliminated_4k",
            doc: "v_a/v_d = 2 at 4000 Hz (eliminated, above the contact resonance)",
            params: with_ratio(Params { f: 4000.0, ..base }, 2.0),
        },
        BenchCase {
            name: "slow_corner",
            doc: "v_d = 0.1 mm/s, k_d = 1000 N/m, v_a/v_d = 2 at 500 Hz",
            params: with_ratio(
                Params {
                    k_d: 1000.0,
                    v_d: 0.1e-3,
                    f: 500.0,
                    ..base
                },
                2.0,
            ),
        },
        BenchCase {
            name: "low_frequency",
            doc: "v_a/v_d = 3 at 100 Hz (large amplitude, not eliminated)",
            params: with_ratio(Params { f: 100.0, ..base }, 3.0),
        },
    ]
}

/// Benchmark settings.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Cases to run (by name); empty: all.
    pub cases: Vec<String>,
    /// Methods.
    pub methods: Vec<Method>,
    /// Tolerance ladder (`rtol = atol`).
    pub tolerances: Vec<f64>,
    /// Tolerance of the reference runs (Radau5 without vibration, Dopri5 with).
    pub reference_tolerance: f64,
    /// Envelope-following tolerances to try with each method (`None`: every period
    /// integrated). Default `[None]`.
    pub envelopes: Vec<Option<f64>>,
    /// Timed repetitions per point (median reported).
    pub repeats: usize,
    /// Tiers to run (`crate::sim::Tier`): `Full` runs every method and envelope above;
    /// `Averaged` adds one setting, `averaged`, the averaged slow model at each tolerance, and
    /// `Hybrid` one more, `hybrid`, hybrid windows (the full model's windows with `auto` and
    /// envelope following at [`crate::sim::DEFAULT_ENVELOPE`]); each builds its table afresh for
    /// every repeat, so the time includes it. Default `[Full]`.
    pub tiers: Vec<crate::sim::Tier>,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            cases: vec![],
            methods: Method::ALL.to_vec(),
            tolerances: vec![1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8],
            reference_tolerance: 1e-11,
            envelopes: vec![None],
            repeats: 3,
            tiers: vec![crate::sim::Tier::Full],
        }
    }
}

/// One measured point.
#[derive(Clone, Debug)]
pub struct BenchRow {
    /// Case name.
    pub case: String,
    /// Method.
    pub method: Method,
    /// Envelope-following tolerance (`None`: every period integrated).
    pub envelope: Option<f64>,
    /// Tolerance.
    pub tol: f64,
    /// Median wall time of the run \[s\].
    pub time: f64,
    /// Fastest of the repeats \[s\].
    pub time_min: f64,
    /// Results.
    pub r: f64,
    /// Mean drive force \[N\].
    pub mean_force: f64,
    /// dF \[N\].
    pub d_f: f64,
    /// |r − r_ref|.
    pub err_r: f64,
    /// |mean − mean_ref| / mean_ref.
    pub err_mean: f64,
    /// |dF − dF_ref| / dF_ref.
    pub err_d_f: f64,
    /// Run status.
    pub status: Status,
    /// Work.
    pub stats: Stats,
    /// The tier asked for: full, or averaged (the method is then the slow model's Radau5).
    pub tier: crate::sim::Tier,
    /// Why the tier that served the run did ([`crate::sim::TierReason`]): an averaged
    /// setting whose run left the law was served by the full model.
    pub tier_reason: crate::sim::TierReason,
}

impl BenchRow {
    /// The method with its envelope tolerance, as `dopri5` or `auto+envelope1e-4`; `averaged`
    /// for the averaged tier.
    pub fn setting(&self) -> String {
        match self.tier {
            crate::sim::Tier::Averaged => return "averaged".to_string(),
            crate::sim::Tier::Hybrid => return "hybrid".to_string(),
            _ => {}
        }
        setting_name(self.method, self.envelope)
    }
}

/// A method with its envelope tolerance, as `dopri5` or `auto+envelope1e-4`.
pub fn setting_name(method: Method, envelope: Option<f64>) -> String {
    match envelope {
        None => method.name().to_string(),
        Some(e) => format!("{}+envelope{e:.0e}", method.name()),
    }
}

/// Reference values of a case.
#[derive(Clone, Debug)]
pub struct Reference {
    /// The vibrated run (or the run itself without vibration).
    pub run: RunResult,
    /// dF of the tight run without vibration.
    pub d_f_ss: f64,
}

fn tight(method: Method, tol: f64) -> RunOptions {
    // No step cap: the slow corner at a tight tolerance takes about 10^8 steps.
    RunOptions {
        method,
        envelope: None,
        // The methods compared are integrators of the full model.
        tier: crate::sim::Tier::Full,
        ode: Options {
            rtol: tol,
            atol: tol,
            max_steps: u64::MAX,
            ..Options::default()
        },
        ..RunOptions::default()
    }
}

/// What a benchmark measured: its cases, each case's reference, and a row per setting and
/// tolerance.
pub struct BenchRun {
    /// The cases run.
    pub cases: Vec<BenchCase>,
    /// Each case's reference, in the order of `cases`.
    pub references: Vec<Reference>,
    /// One row per case, setting and tolerance.
    pub rows: Vec<BenchRow>,
}

/// Runs the benchmark; `progress` is called with a line per finished point.
pub fn run(o: &BenchOptions, mut progress: impl FnMut(&str)) -> Result<BenchRun, sim::SimError> {
    let all = cases();
    let chosen: Vec<BenchCase> = all
        .into_iter()
        .filter(|c| o.cases.is_empty() || o.cases.iter().any(|n| n == c.name))
        .collect();
    let mut refs = vec![];
    let mut rows = vec![];
    for c in &chosen {
        let t0 = Instant::now();
        // The reference integrates every cycle.
        let ss = sim::simulate(
            &c.params.without_vibration(),
            &RunOptions {
                periodic: false,
                ..tight(Method::Radau5, o.reference_tolerance)
            },
            &mut Solver::new(Method::Radau5),
        )?;
        let run = if c.params.vibrates() {
            sim::simulate(
                &c.params,
                &tight(Method::Dopri5, o.reference_tolerance),
                &mut Solver::new(Method::Dopri5),
            )?
        } else {
            ss.clone()
        };
        progress(&format!(
            "{}: reference r = {:.4}, mean force {:.4} N ({:.1} s)",
            c.name,
            run.measures.d_f / ss.measures.d_f,
            run.measures.mean_force,
            t0.elapsed().as_secs_f64()
        ));
        let reference = Reference {
            d_f_ss: ss.measures.d_f,
            run,
        };
        use crate::sim::Tier;
        let mut settings: Vec<(Method, Option<f64>, Tier)> = vec![];
        if o.tiers.contains(&Tier::Full) {
            for &m in &o.methods {
                for &e in &o.envelopes {
                    settings.push((m, e, Tier::Full));
                }
            }
        }
        if o.tiers.contains(&Tier::Averaged) {
            settings.push((Method::Radau5, None, Tier::Averaged));
        }
        if o.tiers.contains(&Tier::Hybrid) {
            settings.push((Method::Auto, Some(sim::DEFAULT_ENVELOPE), Tier::Hybrid));
        }
        for (m, envelope, tier) in settings {
            let mut solver = Solver::new(m);
            for &tol in &o.tolerances {
                let opts = RunOptions {
                    envelope,
                    tier,
                    ..tight(m, tol)
                };
                let mut times = vec![];
                let mut last = None;
                for _ in 0..o.repeats.max(1) {
                    // Each repeat builds its own table (a run owns its store): the time is a
                    // run's from nothing.
                    let t = Instant::now();
                    let r = sim::simulate(&c.params, &opts, &mut solver)?;
                    times.push(t.elapsed().as_secs_f64());
                    last = Some(r);
                }
                times.sort_by(f64::total_cmp);
                let r = last.expect("at least one repeat");
                let rm = &r.measures;
                let rr = &reference.run.measures;
                let r_val = rm.d_f / reference.d_f_ss;
                let r_ref = rr.d_f / reference.d_f_ss;
                let row = BenchRow {
                    case: c.name.to_string(),
                    method: m,
                    envelope,
                    tol,
                    time: times[times.len() / 2],
                    time_min: times[0],
                    r: r_val,
                    mean_force: rm.mean_force,
                    d_f: rm.d_f,
                    err_r: (r_val - r_ref).abs(),
                    err_mean: ((rm.mean_force - rr.mean_force) / rr.mean_force).abs(),
                    err_d_f: ((rm.d_f - rr.d_f) / rr.d_f).abs(),
                    status: r.status,
                    stats: r.stats,
                    tier,
                    tier_reason: r.tier_reason,
                };
                progress(&format!(
                    "{:13} {:16} tol {:7.0e}: {:9.2} ms  |dr| {:.1e}  |dmean| {:.1e}  {} steps",
                    row.case,
                    row.setting(),
                    tol,
                    row.time * 1e3,
                    row.err_r,
                    row.err_mean,
                    row.stats.steps
                ));
                rows.push(row);
            }
        }
        refs.push(reference);
    }
    Ok(BenchRun {
        cases: chosen,
        references: refs,
        rows,
    })
}

/// Writes the table to HDF5: one 1-D dataset per column (`case` and `method` as strings).
pub fn write_h5(
    path: &Path,
    cases: &[BenchCase],
    refs: &[Reference],
    rows: &[BenchRow],
    o: &BenchOptions,
) -> Result<(), OutputError> {
    output::ensure_parent(path)?;
    let tmp = output::temp_for(path)?;
    {
        let e = h5err(path);
        let f = H5File::create(&tmp).map_err(&e)?;
        let root = f.root_group();
        let case: Vec<&str> = rows.iter().map(|r| r.case.as_str()).collect();
        let method: Vec<&str> = rows.iter().map(|r| r.method.name()).collect();
        f.write_vlen_strings("case", &case).map_err(&e)?;
        f.write_vlen_strings("method", &method).map_err(&e)?;
        let setting: Vec<String> = rows.iter().map(BenchRow::setting).collect();
        let setting: Vec<&str> = setting.iter().map(String::as_str).collect();
        f.write_vlen_strings("setting", &setting).map_err(&e)?;
        let reason: Vec<&str> = rows.iter().map(|r| r.tier_reason.name()).collect();
        f.write_vlen_strings("tier_reason", &reason).map_err(&e)?;
        let col = |g: fn(&BenchRow) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
        for (name, unit, doc, v) in [
            ("tolerance", "1", "rtol = atol of the run", col(|r| r.tol)),
            (
                "envelope",
                "1",
                "envelope-following tolerance (NaN: every period integrated)",
                col(|r| r.envelope.unwrap_or(f64::NAN)),
            ),
            (
                "time",
                "s",
                "median wall time of the vibrated run",
                col(|r| r.time),
            ),
            ("time_min", "s", "fastest repeat", col(|r| r.time_min)),
            ("r", "1", "reduction coefficient", col(|r| r.r)),
            ("mean_force", "N", "mean drive force", col(|r| r.mean_force)),
            ("dF", "N", "stick-slip amplitude", col(|r| r.d_f)),
            ("err_r", "1", "|r - r_reference|", col(|r| r.err_r)),
            (
                "err_mean_force",
                "1",
                "relative error of the mean drive force",
                col(|r| r.err_mean),
            ),
            ("err_dF", "1", "relative error of dF", col(|r| r.err_d_f)),
            (
                "status",
                "1",
                "run status code",
                col(|r| r.status.code() as f64),
            ),
            (
                "steps",
                "1",
                "accepted steps",
                col(|r| r.stats.steps as f64),
            ),
            (
                "rejected",
                "1",
                "rejected steps",
                col(|r| r.stats.rejected as f64),
            ),
            (
                "rhs_evals",
                "1",
                "right-hand-side evaluations",
                col(|r| r.stats.rhs_evals as f64),
            ),
            (
                "jac_evals",
                "1",
                "Jacobian evaluations",
                col(|r| r.stats.jac_evals as f64),
            ),
            (
                "lu_decomps",
                "1",
                "LU factorisations",
                col(|r| r.stats.lu_decomps as f64),
            ),
        ] {
            output::write_vec(&root, name, &v, unit, doc, path)?;
        }
        let g = f.create_group("reference").map_err(&e)?;
        let names: Vec<&str> = cases.iter().map(|c| c.name).collect();
        g.write_vlen_strings("case", &names).map_err(&e)?;
        output::write_vec(
            &g,
            "r",
            &refs
                .iter()
                .map(|r| r.run.measures.d_f / r.d_f_ss)
                .collect::<Vec<_>>(),
            "1",
            "reference r",
            path,
        )?;
        output::write_vec(
            &g,
            "mean_force",
            &refs
                .iter()
                .map(|r| r.run.measures.mean_force)
                .collect::<Vec<_>>(),
            "N",
            "reference mean force",
            path,
        )?;
        output::write_vec(
            &g,
            "dF",
            &refs.iter().map(|r| r.run.measures.d_f).collect::<Vec<_>>(),
            "N",
            "reference dF",
            path,
        )?;
        f.set_attr_numeric("reference_tolerance", &o.reference_tolerance)
            .map_err(&e)?;
        f.set_attr_numeric("repeats", &(o.repeats as i64))
            .map_err(&e)?;
        f.set_attr_string("program", &output::program())
            .map_err(&e)?;
        f.set_attr_string("created", &output::now_iso())
            .map_err(&e)?;
        f.set_attr_string(
            "cases",
            &cases
                .iter()
                .map(|c| format!("{}: {}", c.name, c.doc))
                .collect::<Vec<_>>()
                .join("; "),
        )
        .map_err(&e)?;
        f.close().map_err(&e)?;
    }
    crate::output::replace(&tmp, path).map_err(output::ioerr(path))
}

/// Work-precision diagram of one case: error of r and of the mean force against time, log-log.
struct WorkPrecision<'a> {
    case: &'a BenchCase,
    rows: Vec<&'a BenchRow>,
}

impl Figure for WorkPrecision<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        let root = root
            .titled(
                &format!("work-precision: {} ({})", self.case.name, self.case.doc),
                ("sans-serif", 22),
            )
            .map_err(e)?;
        let (left, right) = root.split_horizontally(crate::plot::SIZE.0 / 2);
        // (area, label, the error read off a row, its target)
        type Panel<'p, DB> = (
            &'p DrawingArea<DB, Shift>,
            &'p str,
            fn(&BenchRow) -> f64,
            f64,
        );
        let panels: [Panel<'_, DB>; 2] = [
            (&left, "|r - r_ref|", |r| r.err_r, 0.01),
            (&right, "|mean F_d - ref| / ref", |r| r.err_mean, 0.005),
        ];
        let floor = 1e-7;
        for (area, label, err, target) in panels {
            let pts: Vec<(f64, f64)> = self
                .rows
                .iter()
                .map(|r| (r.time.max(1e-6), err(r).max(floor)))
                .collect();
            let (t0, t1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
                (a.min(p.0), b.max(p.0))
            });
            let (e0, e1) = pts
                .iter()
                .fold((target, target), |(a, b), p| (a.min(p.1), b.max(p.1)));
            let mut c = ChartBuilder::on(area)
                .margin(14)
                .x_label_area_size(45)
                .y_label_area_size(75)
                .build_cartesian_2d(
                    (t0 / 1.5..t1 * 1.5).log_scale(),
                    (e0 / 2.0..e1 * 2.0).log_scale(),
                )
                .map_err(e)?;
            c.configure_mesh()
                .x_desc("time per run [s]")
                .y_desc(label)
                .x_labels(5)
                .y_labels(6)
                .x_label_formatter(&|v| format!("{v:.0e}"))
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(e)?;
            let mut settings: Vec<String> = vec![];
            for r in &self.rows {
                if !settings.contains(&r.setting()) {
                    settings.push(r.setting());
                }
            }
            for (k, name) in settings.iter().enumerate() {
                let colours = [
                    BLUE,
                    RED,
                    RGBColor(30, 140, 30),
                    RGBColor(200, 120, 0),
                    RGBColor(120, 40, 160),
                    RGBColor(0, 150, 160),
                    RGBColor(120, 120, 120),
                    BLACK,
                ];
                let col = colours[k % colours.len()];
                let line: Vec<(f64, f64)> = self
                    .rows
                    .iter()
                    .filter(|r| r.setting() == *name)
                    .map(|r| (r.time.max(1e-6), err(r).max(floor)))
                    .collect();
                c.draw_series(LineSeries::new(line.clone(), col.stroke_width(2)))
                    .map_err(e)?
                    .label(name.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 20, y)], col.stroke_width(2))
                    });
                c.draw_series(line.iter().map(|&p| Circle::new(p, 4, col.filled())))
                    .map_err(e)?;
            }
            c.draw_series(LineSeries::new(
                [(t0 / 1.5, target), (t1 * 1.5, target)],
                BLACK.stroke_width(1),
            ))
            .map_err(e)?
            .label("accuracy target")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
            c.configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(e)?;
        }
        Ok(())
    }
}

/// Draws one work-precision diagram per case as `<stem>_<case>.png/.svg`.
pub fn plot(
    stem: &Path,
    cases: &[BenchCase],
    rows: &[BenchRow],
) -> Result<Vec<PathBuf>, PlotError> {
    let mut files = vec![];
    for c in cases {
        let fig = WorkPrecision {
            case: c,
            rows: rows.iter().filter(|r| r.case == c.name).collect(),
        };
        files.extend(render(
            &PathBuf::from(format!("{}_{}", stem.display(), c.name)),
            &fig,
        )?);
    }
    Ok(files)
}
