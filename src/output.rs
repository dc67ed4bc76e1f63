//! Files: HDF5 (pure Rust, `rust-hdf5`; readable by h5py, xarray/h5netcdf and the HDF5 tools)
//! and CSV. Every file is written under a temporary name and renamed into place, so a reader
//! never sees a half-written file.

use crate::measures::Measure;
use crate::model::params::PARAMS;
use crate::ode::Counter;
use crate::sim::{CaseResult, RunOptions, RunResult, Trace};
use rust_hdf5::{H5Dataset, H5File, VarLenUnicode};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// Operating-system I/O error.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// HDF5 library error.
    #[error("{path}: HDF5: {msg}")]
    Hdf5 {
        /// The file.
        path: String,
        /// The cause.
        msg: String,
    },
}

/// Result of file output.
pub type Result<T> = std::result::Result<T, OutputError>;

pub(crate) fn h5err(path: &Path) -> impl Fn(rust_hdf5::Hdf5Error) -> OutputError + '_ {
    move |e| OutputError::Hdf5 {
        path: path.display().to_string(),
        msg: e.to_string(),
    }
}

pub(crate) fn ioerr(path: &Path) -> impl Fn(std::io::Error) -> OutputError + '_ {
    move |e| OutputError::Io {
        path: path.display().to_string(),
        source: e,
    }
}

/// `path` with `.tmp` appended, in the same directory (so the rename is atomic).
pub fn temp_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".tmp");
    PathBuf::from(s)
}

/// [`temp_path`] of `path`, refused where something other than a regular file is there (a
/// folder left by hand, a device): the error names the temporary path, not `path`, and says
/// what is in the way. A stale regular file there is an interrupted write's and is replaced.
pub fn temp_for(path: &Path) -> Result<PathBuf> {
    let tmp = temp_path(path);
    if special(&tmp) {
        return Err(OutputError::Io {
            path: tmp.display().to_string(),
            source: std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "a folder (or device, pipe, socket) is in the way of the temporary file \
                     written there before it is renamed onto {}; remove or rename it",
                    path.display()
                ),
            ),
        });
    }
    Ok(tmp)
}

/// Whether `path` names something that is there and is not a regular file (following links):
/// a device, pipe, socket or folder, which no command reads as a file or replaces.
pub fn special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file())
}

/// Moves the finished `tmp` onto `path` (atomically, in one directory), unless `path` is there
/// and is not a regular file: a device, pipe, socket or folder is never replaced (`tmp` is
/// removed and an error of kind `InvalidInput` returned).
pub fn replace(tmp: &Path, path: &Path) -> std::io::Result<()> {
    if special(path) {
        let _ = std::fs::remove_file(tmp);
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file (a device, pipe, socket or folder): left as it is; give a file path",
        ));
    }
    std::fs::rename(tmp, path)
}

/// Writes `text` to `path` through its temporary file ([`temp_for`], [`replace`]): a write cut
/// short leaves the file that was there, and a folder or device at `path` is never replaced.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    ensure_parent(path)?;
    let tmp = temp_for(path)?;
    let e = ioerr(path);
    std::fs::write(&tmp, text).map_err(&e)?;
    replace(&tmp, path).map_err(&e)
}

/// Creates the parent directory of `path` if needed.
pub fn ensure_parent(path: &Path) -> Result<()> {
    if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(ioerr(d))?;
    }
    Ok(())
}

/// Sets a string attribute on a dataset.
pub fn ds_attr_str(ds: &H5Dataset, name: &str, value: &str, path: &Path) -> Result<()> {
    let a = ds
        .new_attr::<VarLenUnicode>()
        .shape(())
        .create(name)
        .map_err(h5err(path))?;
    a.write_string(value).map_err(h5err(path))
}

/// Writes a 1-D `f64` dataset with `units` and `long_name` attributes.
pub fn write_vec(
    g: &rust_hdf5::H5Group,
    name: &str,
    data: &[f64],
    units: &str,
    long_name: &str,
    path: &Path,
) -> Result<H5Dataset> {
    let b = g.new_dataset::<f64>().shape([data.len()]);
    // Long traces are chunked and compressed; short ones stay contiguous.
    let b = if data.len() > 32_768 {
        b.chunk(&[16_384]).deflate(4)
    } else {
        b
    };
    let ds = b.create(name).map_err(h5err(path))?;
    ds.write_raw(data).map_err(h5err(path))?;
    ds_attr_str(&ds, "units", units, path)?;
    ds_attr_str(&ds, "long_name", long_name, path)?;
    Ok(ds)
}

/// Program name and version, for file attributes.
pub fn program() -> String {
    format!("stickslip {}", env!("CARGO_PKG_VERSION"))
}

/// The current time as an ISO-8601 UTC string.
pub fn now_iso() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    iso_from_unix(secs)
}

/// ISO-8601 UTC from Unix seconds (civil-from-days, proleptic Gregorian).
pub fn iso_from_unix(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

fn set_measures(file: &H5File, prefix: &str, r: &RunResult, path: &Path) -> Result<()> {
    let m = &r.measures;
    let e = h5err(path);
    for k in Measure::OF_RUN {
        let name = format!("{prefix}{}", k.name());
        match k {
            Measure::Cycles => file.set_attr_numeric(&name, &i64::from(m.cycles)),
            k => file.set_attr_numeric(&name, &k.of_run(m).unwrap_or(f64::NAN)),
        }
        .map_err(&e)?;
    }
    for (k, v) in [
        ("t_end", r.t_end),
        ("window_start", r.window_start),
        ("wall_time", r.wall_time),
    ] {
        file.set_attr_numeric(&format!("{prefix}{k}"), &v)
            .map_err(&e)?;
    }
    // 1 where the measures are the settled level, extrapolated from a settling force, with the
    // level's error bound (NaN where not extrapolated).
    file.set_attr_numeric(&format!("{prefix}predicted"), &i64::from(r.predicted()))
        .map_err(&e)?;
    file.set_attr_numeric(
        &format!("{prefix}level_error"),
        &r.level_error.unwrap_or(f64::NAN),
    )
    .map_err(&e)?;
    file.set_attr_string(&format!("{prefix}status"), r.status.name())
        .map_err(&e)?;
    // The model that served the run and why (crate::sim::TierReason names).
    file.set_attr_string(&format!("{prefix}tier"), r.tier.name())
        .map_err(&e)?;
    file.set_attr_string(&format!("{prefix}tier_reason"), r.tier_reason.name())
        .map_err(&e)?;
    for c in Counter::ALL {
        file.set_attr_numeric(&format!("{prefix}{}", c.name()), &(c.of(&r.stats) as i64))
            .map_err(&e)?;
    }
    Ok(())
}

/// Writes one case (`stickslip run`) to HDF5: the measures, `r`, statistics, parameters (with
/// units) and solver settings as root attributes, and the traces in group `trace`, each
/// channel a 1-D dataset with `units`, with `t` attached as its dimension scale.
pub fn write_case_h5(
    path: &Path,
    case: &CaseResult,
    opts: &RunOptions,
    effects: &crate::model::Effects,
) -> Result<()> {
    ensure_parent(path)?;
    let tmp = temp_for(path)?;
    {
        let e = h5err(path);
        let file = H5File::create(&tmp).map_err(&e)?;
        file.set_attr_string("program", &program()).map_err(&e)?;
        file.set_attr_string("created", &now_iso()).map_err(&e)?;
        file.set_attr_string("solver", opts.method.name())
            .map_err(&e)?;
        file.set_attr_numeric("rtol", &opts.ode.rtol).map_err(&e)?;
        file.set_attr_numeric("atol", &opts.ode.atol).map_err(&e)?;
        // The model extensions that were on: `base` or `name(k=v, ...)+...`, and each
        // parameter as `effect_<name>_<param>`.
        file.set_attr_string("effects", &effects.describe())
            .map_err(&e)?;
        for (k, v) in &effects.list {
            for (p, x) in k.info().params.iter().zip(v) {
                file.set_attr_numeric(&format!("effect_{}_{}", k.name(), p.name), x)
                    .map_err(&e)?;
            }
        }
        file.set_attr_numeric("r", &case.r).map_err(&e)?;
        file.set_attr_numeric("r_stderr", &case.r_stderr)
            .map_err(&e)?;
        file.set_attr_numeric("v_a", &case.params.v_a())
            .map_err(&e)?;
        file.set_attr_numeric("va_ratio", &(case.params.v_a() / case.params.v_d))
            .map_err(&e)?;
        for p in PARAMS {
            file.set_attr_numeric(&format!("param_{}", p.name), &p.get(&case.params))
                .map_err(&e)?;
            file.set_attr_string(&format!("param_{}_units", p.name), p.unit)
                .map_err(&e)?;
        }
        set_measures(&file, "", &case.run, path)?;
        if let Some(r) = &case.reference {
            set_measures(&file, "reference_", r, path)?;
        }
        if let Some(tr) = &case.run.trace {
            write_trace_group(&file.root_group(), "trace", tr, path)?;
        }
        file.close().map_err(&e)?;
    }
    crate::output::replace(&tmp, path).map_err(ioerr(path))
}

/// Writes a trace as group `name`: one dataset per channel, `t` a dimension scale.
pub fn write_trace_group(
    parent: &rust_hdf5::H5Group,
    name: &str,
    tr: &Trace,
    path: &Path,
) -> Result<rust_hdf5::H5Group> {
    let g = parent.create_group(name).map_err(h5err(path))?;
    let cols = tr.columns();
    let mut t_ds = None;
    for ((ch, unit, doc), data) in Trace::CHANNELS.iter().zip(cols) {
        let ds = write_vec(&g, ch, data, unit, doc, path)?;
        if *ch == "t" {
            ds.set_scale(Some("t")).map_err(h5err(path))?;
            t_ds = Some(ds);
        } else if let Some(t) = &t_ds {
            ds.attach_scale(0, t).map_err(h5err(path))?;
        }
    }
    Ok(g)
}

/// Writes a trace as CSV with a header of names and units (`t \[s\],F_d \[N\],...`).
pub fn write_trace_csv(path: &Path, tr: &Trace) -> Result<()> {
    ensure_parent(path)?;
    let tmp = temp_for(path)?;
    let e = ioerr(path);
    {
        let f = std::fs::File::create(&tmp).map_err(&e)?;
        let mut w = std::io::BufWriter::new(f);
        let header: Vec<String> = Trace::CHANNELS
            .iter()
            .map(|(n, u, _)| format!("{n} [{u}]"))
            .collect();
        writeln!(w, "{}", header.join(",")).map_err(&e)?;
        let cols = tr.columns();
        for i in 0..tr.len() {
            for (j, c) in cols.iter().enumerate() {
                if j > 0 {
                    w.write_all(b",").map_err(&e)?;
                }
                write!(w, "{:e}", c[i]).map_err(&e)?;
            }
            w.write_all(b"\n").map_err(&e)?;
        }
        w.flush().map_err(&e)?;
    }
    crate::output::replace(&tmp, path).map_err(e)
}

#[cfg(test)]
mod tests {
    #[test]
    fn iso_dates() {
        assert_eq!(super::iso_from_unix(0), "1970-01-01T00:00:00Z");
        assert_eq!(super::iso_from_unix(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(super::iso_from_unix(1_795_000_000), "2026-11-18T11:06:40Z");
    }
}
