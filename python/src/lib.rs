//! `stickslip._native`: the Python binding's compiled core.
//!
//! Every entry point takes what the CLI takes and goes through the CLI's own validation
//! (`stickslip::cli`), so a bad value raises `ValueError` with the CLI's message word for word;
//! the computing itself is the library's. The pure-Python layer (`python/stickslip/`) turns
//! keyword arguments into those options and the results into xarray and pandas objects.
//!
//! Computing runs on a worker thread with the GIL released. The calling thread wakes every
//! 100 ms to let Python handle signals: on Ctrl-C it asks the library to stop
//! ([`stickslip::interrupt`]), waits for the worker (the integrators look at the request every
//! few hundred steps) and raises `KeyboardInterrupt`. A panic in the worker becomes a
//! `RuntimeError`, never a crash of the interpreter.

use clap::Parser;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;
use stickslip::app::{self, AppError};
use stickslip::cli::{Cli, Command};

/// Maps the CLI's error classes to Python's: bad input (exit code 2) is a `ValueError`, a
/// failure while computing a `RuntimeError`.
fn py_err(e: AppError) -> PyErr {
    if e.exit_code() == 2 {
        PyValueError::new_err(e.to_string())
    } else {
        PyRuntimeError::new_err(e.to_string())
    }
}

/// Parses a command line (without the program name) with the CLI's parser.
fn parse(args: Vec<String>) -> PyResult<Command> {
    let argv = std::iter::once("stickslip".to_string()).chain(args);
    match Cli::try_parse_from(argv) {
        Ok(cli) => Ok(cli.command),
        // clap's own message, without its usage lines and help hint.
        Err(e) => {
            let text = e.render().to_string();
            let first = text
                .lines()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("invalid arguments")
                .trim_start_matches("error: ")
                .to_string();
            Err(PyValueError::new_err(first))
        }
    }
}

/// Runs `work` on a worker thread with the GIL released, calling `tick` (with the GIL) every
/// 100 ms, and honours Ctrl-C within that period plus the worker's stop.
fn compute<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce() -> T + Send + 'static,
    mut tick: impl FnMut(Python<'_>) -> PyResult<()>,
) -> PyResult<T> {
    let (tx, rx) = channel();
    let worker = std::thread::Builder::new()
        .name("stickslip".into())
        .spawn(move || {
            let _ = tx.send(work());
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start a worker thread: {e}")))?;
    // Waiting without the GIL needs a receiver that may cross threads.
    let rx = std::sync::Mutex::new(rx);
    let wait = |timeout: Option<Duration>| -> Result<T, RecvTimeoutError> {
        let rx = rx.lock().unwrap_or_else(|p| p.into_inner());
        match timeout {
            Some(d) => rx.recv_timeout(d),
            None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
        }
    };
    loop {
        match py.detach(|| wait(Some(Duration::from_millis(100)))) {
            Ok(v) => {
                let _ = worker.join();
                return Ok(v);
            }
            Err(RecvTimeoutError::Timeout) => {
                let stop = py.check_signals().and_then(|()| tick(py));
                if let Err(e) = stop {
                    stickslip::interrupt::request();
                    let _ = py.detach(|| wait(None));
                    let _ = worker.join();
                    stickslip::interrupt::clear();
                    return Err(e);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                let why = match worker.join() {
                    Err(p) => p
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_else(|| "unknown".into()),
                    Ok(()) => "no result".into(),
                };
                return Err(PyRuntimeError::new_err(format!(
                    "stickslip stopped with an internal error ({why}); please report it"
                )));
            }
        }
    }
}

/// A vector as a numpy array.
fn array<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, numpy::PyArray1<f64>> {
    numpy::PyArray1::from_slice(py, v)
}

/// One case, as `stickslip run ARGS --json` computes it: returns the JSON text the CLI prints
/// and the trace's channels as numpy arrays (`None` with `--no-trace`). Writes nothing.
#[pyfunction]
fn run<'py>(py: Python<'py>, args: Vec<String>) -> PyResult<(String, Option<Bound<'py, PyDict>>)> {
    let Command::Run(a) = parse(std::iter::once("run".into()).chain(args).collect())? else {
        unreachable!("the command is run")
    };
    let case = a.resolve().map_err(|e| py_err(e.into()))?;
    let job = case.clone();
    let res = compute(
        py,
        move || {
            let mut solver = stickslip::ode::Solver::new(job.run.method);
            stickslip::sim::run_case_with(&job.params, &job.effects, &job.run, &mut solver)
        },
        |_| Ok(()),
    )?
    .map_err(|e| py_err(e.into()))?;
    let status = res.status();
    if status == stickslip::ode::Status::Interrupted {
        return Err(PyKeyboardInterrupt::new_err("interrupted"));
    }
    // As `stickslip run`: a run that did not succeed is an error, with the CLI's reason.
    if status != stickslip::ode::Status::Success {
        return Err(py_err(AppError::Failed(app::failure_reason(&res, &case))));
    }
    let json = app::run_report_json(&res, &case).to_string();
    let trace = match &res.run.trace {
        Some(tr) => {
            let d = PyDict::new(py);
            d.set_item("t", array(py, &tr.t))?;
            d.set_item("F_d", array(py, &tr.f_d))?;
            d.set_item("F_d_smooth", array(py, &tr.f_d_smooth))?;
            d.set_item("x_s", array(py, &tr.x_s))?;
            d.set_item("x_d", array(py, &tr.x_d))?;
            d.set_item("s", array(py, &tr.s))?;
            d.set_item("v_r", array(py, &tr.v_r))?;
            d.set_item("v", array(py, &tr.v))?;
            d.set_item("u", array(py, &tr.u))?;
            Some(d)
        }
        None => None,
    };
    Ok((json, trace))
}

/// The trace channels' names, units and meanings, in file order.
#[pyfunction]
fn trace_channels() -> Vec<(&'static str, &'static str, &'static str)> {
    stickslip::sim::Trace::CHANNELS.to_vec()
}

/// A sweep, as `stickslip sweep` makes it: `text` is the sweep file's TOML (read from `file`
/// when `text` is `None`); writes `out` with its boundary (and figures with `figures`), calls
/// `progress(done, total, failed)` every 100 ms, and returns the run counts.
#[pyfunction]
#[allow(clippy::too_many_arguments)] // a Python signature with keywords
#[pyo3(signature = (file, text, out, threads=None, resume=false, overwrite=false, figures=false, progress=None))]
fn sweep<'py>(
    py: Python<'py>,
    file: String,
    text: Option<String>,
    out: String,
    threads: Option<usize>,
    resume: bool,
    overwrite: bool,
    figures: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PathBuf::from(out);
    // A file goes through the CLI's own resolution; a dict's TOML through the same checks.
    // The CLI's own options and checks; a file is loaded as the CLI loads it, a dict's TOML
    // parsed under the label `file`.
    let mut args = vec![
        "sweep".to_string(),
        file.clone(),
        "-o".into(),
        out.display().to_string(),
        "--quiet".into(),
    ];
    if let Some(t) = threads {
        args.extend(["--threads".into(), t.to_string()]);
    }
    if resume {
        args.push("--resume".into());
    }
    if overwrite {
        args.push("--overwrite".into());
    }
    let Command::Sweep(a) = parse(args)? else {
        unreachable!("the command is sweep")
    };
    let (spec, mut opts) = match text {
        None => a.resolve().map_err(|e| py_err(e.into()))?,
        Some(text) => {
            let spec = stickslip::sweep::spec::SweepSpec::parse(&file, &text)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            let opts = a.options(&spec).map_err(|e| py_err(e.into()))?;
            (spec, opts)
        }
    };
    let tally = Arc::new(stickslip::progress::Tally::default());
    opts.tally = Some(tally.clone());
    let result = compute(
        py,
        move || {
            let o = stickslip::sweep::run(&spec, &opts).map_err(AppError::from)?;
            // The file the CLI leaves: the boundary in it (and the figures beside it).
            if figures {
                app::figures_and_boundary(&o.out)?;
            } else {
                app::boundary_into(&o.out)?;
            }
            Ok::<_, AppError>(o)
        },
        |py| {
            if let Some(cb) = &progress {
                let (done, total, failed) = tally.read();
                cb.call1(py, (done, total, failed))?;
            }
            Ok(())
        },
    )?;
    let o = result.map_err(py_err)?;
    if let Some(cb) = &progress {
        let (done, total, failed) = tally.read();
        cb.call1(py, (done, total, failed))?;
    }
    let d = PyDict::new(py);
    d.set_item("out", o.out.display().to_string())?;
    d.set_item("points", o.points)?;
    d.set_item("runs_made", o.runs_made)?;
    d.set_item("runs_resumed", o.runs_resumed)?;
    d.set_item("journal_dropped", o.journal_dropped)?;
    d.set_item("failed", o.failed)?;
    d.set_item("wall_time", o.wall_time)?;
    Ok(d)
}

/// Converts a sweep given as JSON (a dict in Python) into the TOML text of a sweep file.
#[pyfunction]
fn sweep_toml(json: &str) -> PyResult<String> {
    let v: serde_json::Value =
        serde_json::from_str(json).map_err(|e| PyValueError::new_err(e.to_string()))?;
    stickslip::config::toml_of_json(&v).map_err(PyValueError::new_err)
}

/// The elimination boundary of a sweep file, as rows of the CSV `stickslip boundary` writes
/// (column name, value); reads the file, writes nothing.
#[pyfunction]
fn boundary(path: String) -> PyResult<(Vec<String>, Vec<Vec<f64>>)> {
    let d = stickslip::sweep::read::SweepData::read(std::path::Path::new(&path))
        .map_err(|e| py_err(stickslip::sweep::SweepError::from(e).into()))?;
    d.require_results()
        .map_err(|e| PyValueError::new_err(format!("{path}: {e}")))?;
    let pts = stickslip::sweep::boundary::compute(&d).map_err(PyValueError::new_err)?;
    let mut names: Vec<String> = pts
        .first()
        .map(|p| p.coords.iter().map(|c| c.0.clone()).collect())
        .unwrap_or_default();
    names.extend(stickslip::sweep::boundary::CSV_COLUMNS.map(String::from));
    let rows = pts
        .iter()
        .map(|p| {
            let mut r: Vec<f64> = p.coords.iter().map(|c| c.1).collect();
            r.extend(p.csv_row());
            r
        })
        .collect();
    Ok((names, rows))
}

/// `stickslip calibrate DIR ARGS`: the estimates' JSON text and the printed summary.
#[pyfunction]
fn calibrate(py: Python<'_>, args: Vec<String>) -> PyResult<(String, String)> {
    let Command::Calibrate(a) = parse(std::iter::once("calibrate".into()).chain(args).collect())?
    else {
        unreachable!("the command is calibrate")
    };
    let c = compute(py, move || app::calibrate(&a), |_| Ok(()))?.map_err(py_err)?;
    Ok((c.json.to_string(), c.summary))
}

/// `stickslip diagnose DIR ARGS`: the verdict's JSON text, the report, the output folder and the
/// files written there.
#[pyfunction]
fn diagnose(py: Python<'_>, args: Vec<String>) -> PyResult<(String, String, String, Vec<String>)> {
    let Command::Diagnose(a) = parse(std::iter::once("diagnose".into()).chain(args).collect())?
    else {
        unreachable!("the command is diagnose")
    };
    let d = compute(py, move || app::diagnose(&a), |_| Ok(()))?.map_err(py_err)?;
    Ok((
        d.json.to_string(),
        d.summary,
        d.out.display().to_string(),
        d.written.iter().map(|p| p.display().to_string()).collect(),
    ))
}

/// `stickslip plan DIR ARGS`: the plan's JSON text, its summary and the files written.
#[pyfunction]
fn plan(py: Python<'_>, args: Vec<String>) -> PyResult<(String, String, Vec<String>)> {
    let Command::Plan(a) = parse(std::iter::once("plan".into()).chain(args).collect())? else {
        unreachable!("the command is plan")
    };
    let p = compute(py, move || app::plan(&a), |_| Ok(()))?.map_err(py_err)?;
    Ok((
        p.json.to_string(),
        p.summary,
        p.written.iter().map(|p| p.display().to_string()).collect(),
    ))
}

/// Checks a campaign folder as `calibrate` and `diagnose` would read it: loads it and returns
/// the number of recordings, or raises the CLI's error.
#[pyfunction]
fn check_campaign(dir: String) -> PyResult<usize> {
    let c = stickslip::campaign::Campaign::load(std::path::Path::new(&dir))
        .map_err(|e| py_err(e.into()))?;
    Ok(c.recordings.len())
}

/// The model parameters: (name, CLI flag, unit, default, meaning), in the CLI's order.
#[pyfunction]
fn parameters() -> Vec<(&'static str, &'static str, &'static str, f64, &'static str)> {
    let d = stickslip::model::Params::default();
    stickslip::model::params::PARAMS
        .iter()
        .map(|p| (p.name, p.flag, p.unit, p.get(&d), p.doc))
        .collect()
}

/// The program version that stamps every file.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

/// The compiled core of the `stickslip` package.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(trace_channels, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_toml, m)?)?;
    m.add_function(wrap_pyfunction!(boundary, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(plan, m)?)?;
    m.add_function(wrap_pyfunction!(check_campaign, m)?)?;
    m.add_function(wrap_pyfunction!(parameters, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    Ok(())
}
