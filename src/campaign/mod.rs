//! Measured campaigns: directories of recordings from a test stand like the paper's, their
//! loading and plausibility checks ([`check`]), the simulation of a recording's conditions, and
//! synthetic campaigns ([`synth`]). What compares them with the model (features, fits, evidence,
//! verdicts, report) is [`crate::diagnosis`], which imports this room and never the reverse.
//!
//! # Format
//! A campaign is a directory. Each recording is two files with the same stem:
//! - `NAME.csv`: a header row, then one row per sample with the columns `t` \[s\] and `F_d`
//!   \[N\] (measured drive force), and where recorded `x_s` \[m\] (body displacement) and `x_d`
//!   \[m\] (drive displacement), in any order; other columns are ignored (a UTF-8 byte-order
//!   mark is skipped, two are refused, a repeated column name is an error; lines end in `\n` or
//!   `\r\n`, a carriage return alone is refused). Uniform sampling at any rate (the
//!   spacing may vary by at most 1 %), at least 200 rows, time increasing. Features that need
//!   a missing column are skipped, and the reports say so.
//! - `NAME.toml`: the conditions in SI units: `v_d`, `k_d`, `f` and `u0` (or `v_a`, or
//!   `va_ratio` = v_a/v_d), and optionally any other model parameter (`F_N`, `h_d`, ...).
//!   `f = 0` with `u0 = 0` is a run without vibration. `t_on` \[s\] (docs/model.md) is the time
//!   the vibration is switched on within the recording (the paper's two-stage tests): the
//!   substrate rests before it; absent or 0, it vibrates from the start.
//!
//! An optional `campaign.toml` gives defaults for every recording (same keys). Other files are
//! ignored. A `.csv` without its `.toml` (or the reverse) is an error, as is any malformed line:
//! the message names the file, the line and the problem. No recording is skipped silently.

pub mod acquisition;
pub mod batch;
pub mod check;
pub mod delay;
pub mod sensitivity;
pub mod synth;
pub use batch::{GridAsk, GridResult, simulate_grids};

use crate::config::{self, ConfigError, Doc};
use crate::model::{Effects, Params, Rig, RigError};
use crate::ode::{Method, Options, Span, Status};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// One recording: its conditions and its sampled signals.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// File stem.
    pub name: String,
    /// Conditions: the model parameters with the campaign's and the recording's values.
    pub params: Params,
    /// Sample times \[s\] (uniform).
    pub t: Vec<f64>,
    /// Measured drive force \[N\].
    pub f_d: Vec<f64>,
    /// Body displacement \[m\], where recorded.
    pub x_s: Option<Vec<f64>>,
    /// Drive displacement \[m\], where recorded.
    pub x_d: Option<Vec<f64>>,
}

impl Recording {
    /// Sampling interval \[s\].
    pub fn dt(&self) -> f64 {
        (self.t[self.t.len() - 1] - self.t[0]) / (self.t.len() - 1) as f64
    }

    /// Whether the substrate vibrates.
    pub fn vibrates(&self) -> bool {
        self.params.vibrates()
    }
}

/// A loaded campaign.
#[derive(Clone, Debug)]
pub struct Campaign {
    /// The directory.
    pub dir: PathBuf,
    /// Recordings sorted by name.
    pub recordings: Vec<Recording>,
    /// The names of the recordings a plan proposed (their conditions file has a `plan` key:
    /// `stickslip plan`), in the order of [`Campaign::recordings`].
    pub planned: Vec<String>,
    /// What the acquisition did: the files split at gaps (by [`Campaign::load`]) and, once
    /// [`acquisition::prepare`] has run, the preflight of every recording.
    pub acquisition: acquisition::Acquired,
}

/// A digest of recordings (names, conditions and every sample), hexadecimal: whether a
/// diagnosis written beside a campaign is of these very recordings. FNV-1a over the bits.
pub fn digest(recs: &[Recording]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for b in bytes {
            h ^= *b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for r in recs {
        eat(r.name.as_bytes());
        for name in crate::model::params::names() {
            eat(&r
                .params
                .get(name)
                .unwrap_or(f64::NAN)
                .to_bits()
                .to_le_bytes());
        }
        for ch in [Some(&r.t), Some(&r.f_d), r.x_s.as_ref(), r.x_d.as_ref()] {
            match ch {
                Some(v) => {
                    eat(&(v.len() as u64).to_le_bytes());
                    for x in v {
                        eat(&x.to_bits().to_le_bytes());
                    }
                }
                None => eat(b"none"),
            }
        }
    }
    format!("{h:016x}")
}

/// A malformed campaign.
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    /// A file could not be read or written.
    #[error("{path}: {msg}")]
    Io {
        /// The file.
        path: String,
        /// What happened.
        msg: String,
    },
    /// A malformed line or value.
    #[error("{file}:{line}: {msg}")]
    Malformed {
        /// The file.
        file: String,
        /// 1-based line (0: the file as a whole).
        line: usize,
        /// The problem.
        msg: String,
    },
    /// A malformed conditions file.
    #[error(transparent)]
    Config(#[from] ConfigError),
}

fn io(path: &Path, e: impl std::fmt::Display) -> CampaignError {
    CampaignError::Io {
        path: path.display().to_string(),
        msg: e.to_string(),
    }
}

/// Keys every recording needs (from its own file or `campaign.toml`).
const REQUIRED: [&str; 3] = ["v_d", "k_d", "f"];

impl Campaign {
    /// Reads every recording of a campaign directory.
    pub fn load(dir: &Path) -> Result<Campaign, CampaignError> {
        if !dir.is_dir() {
            return Err(CampaignError::Malformed {
                file: dir.display().to_string(),
                line: 0,
                msg: if dir.exists() {
                    "is a file; a campaign is a directory of recordings (NAME.csv with NAME.toml)"
                        .into()
                } else {
                    "no such campaign directory".into()
                },
            });
        }
        let entries = std::fs::read_dir(dir).map_err(|e| io(dir, e))?;
        let mut stems: BTreeMap<String, (bool, bool)> = BTreeMap::new();
        for e in entries {
            let path = e.map_err(|e| io(dir, e))?.path();
            let (Some(stem), Some(ext)) = (path.file_stem(), path.extension()) else {
                continue;
            };
            let stem = stem.to_string_lossy().into_owned();
            match ext.to_str() {
                Some("csv") => stems.entry(stem).or_default().0 = true,
                Some("toml") if stem != "campaign" => stems.entry(stem).or_default().1 = true,
                _ => {}
            }
        }
        let defaults = dir.join("campaign.toml");
        let defaults = if defaults.exists() {
            Some(Doc::read(&defaults)?)
        } else {
            None
        };
        let mut recordings = vec![];
        let mut planned = vec![];
        let mut splits = vec![];
        for (stem, (csv, toml)) in stems {
            let csv_path = dir.join(format!("{stem}.csv"));
            let toml_path = dir.join(format!("{stem}.toml"));
            if !csv {
                return Err(CampaignError::Malformed {
                    file: toml_path.display().to_string(),
                    line: 0,
                    msg: format!("conditions without a recording: {stem}.csv is missing"),
                });
            }
            if !toml {
                return Err(CampaignError::Malformed {
                    file: csv_path.display().to_string(),
                    line: 0,
                    msg: format!(
                        "recording without conditions: {stem}.toml (v_d, k_d, f, u0) is missing"
                    ),
                });
            }
            let (params, from_plan) = read_conditions(&toml_path, defaults.as_ref())?;
            let (cols, pieces, gaps) = read_csv(&csv_path)?;
            let kept: Vec<&(usize, usize)> = pieces
                .iter()
                .filter(|(a, b)| b - a >= MIN_SAMPLES)
                .collect();
            if kept.is_empty() {
                return Err(CampaignError::Malformed {
                    file: csv_path.display().to_string(),
                    line: 0,
                    msg: format!(
                        "no stretch between the time column's {} gap(s) holds {MIN_SAMPLES} samples; at least {MIN_SAMPLES} are needed",
                        gaps.len()
                    ),
                });
            }
            let mut split = acquisition::Split {
                file: stem.clone(),
                gaps,
                pieces: vec![],
                dropped_samples: pieces.iter().map(|(a, b)| b - a).sum::<usize>()
                    - kept.iter().map(|(a, b)| b - a).sum::<usize>(),
            };
            for (k, &&(a, b)) in kept.iter().enumerate() {
                let name = if kept.len() == 1 {
                    stem.clone()
                } else {
                    format!("{stem}~{}", k + 1)
                };
                let cut = |v: &Vec<f64>| v[a..b].to_vec();
                if from_plan {
                    planned.push(name.clone());
                }
                split.pieces.push(name.clone());
                recordings.push(Recording {
                    name,
                    params,
                    t: cut(&cols.0),
                    f_d: cut(&cols.1),
                    x_s: cols.2.as_ref().map(cut),
                    x_d: cols.3.as_ref().map(cut),
                });
            }
            if !split.gaps.is_empty() {
                splits.push(split);
            }
        }
        if recordings.is_empty() {
            return Err(CampaignError::Malformed {
                file: dir.display().to_string(),
                line: 0,
                msg: "no recordings (NAME.csv with NAME.toml) in this directory".into(),
            });
        }
        Ok(Campaign {
            dir: dir.to_path_buf(),
            recordings,
            planned,
            acquisition: acquisition::Acquired {
                recordings: vec![],
                splits,
            },
        })
    }
}

/// A recording's conditions, and whether a plan proposed them (a `plan` key, which holds the
/// plan's notes and is otherwise ignored).
fn read_conditions(path: &Path, defaults: Option<&Doc>) -> Result<(Params, bool), CampaignError> {
    let mut doc = Doc::read(path)?;
    let from_plan = doc.table.remove("plan").is_some();
    let mut p = Params::default();
    let mut seen: Vec<String> = doc.table.keys().cloned().collect();
    let unknown = |d: &Doc, k: &str| -> CampaignError {
        d.err(
            "",
            k,
            format!(
                "unknown key; allowed: the model parameters {}, v_a, va_ratio",
                crate::model::params::names().join(", ")
            ),
        )
        .into()
    };
    // Defaults first (each value checked against its own bound), then the recording's own
    // keys, with an amplitude from the defaults used only when the recording gives none.
    let mut table = doc.table.clone();
    if let Some(d) = defaults {
        let rest = config::set_params(d, "", &d.table, &mut p)?;
        for k in rest {
            if k != "v_a" && k != "va_ratio" {
                return Err(unknown(d, k));
            }
            if !["u0", "v_a", "va_ratio"]
                .iter()
                .any(|a| doc.table.contains_key(*a))
            {
                table.insert(k.to_string(), d.table[k].clone());
            }
        }
        seen.extend(d.table.keys().cloned());
    }
    let rest = config::apply_params(&doc, "", &table, &mut p)?;
    if let Some(k) = rest.first() {
        return Err(unknown(&doc, k));
    }
    for k in REQUIRED {
        if !seen.iter().any(|s| s == k) {
            return Err(CampaignError::Malformed {
                file: path.display().to_string(),
                line: 0,
                msg: format!("missing `{k}` (give it here or in campaign.toml)"),
            });
        }
    }
    if !seen
        .iter()
        .any(|s| s == "u0" || s == "v_a" || s == "va_ratio")
    {
        return Err(CampaignError::Malformed {
            file: path.display().to_string(),
            line: 0,
            msg: "missing the vibration amplitude: give `u0` [m] or `v_a` [m/s] (0 without vibration)".into(),
        });
    }
    Ok((p, from_plan))
}

type Columns = (Vec<f64>, Vec<f64>, Option<Vec<f64>>, Option<Vec<f64>>);
/// A file's columns, its stretches between gaps and its gaps.
type Read = (Columns, Vec<(usize, usize)>, Vec<acquisition::Gap>);

/// Largest recording read \[bytes\]: 1 GiB of CSV text, some 20 million samples of four
/// channels.
pub const MAX_CSV_BYTES: u64 = 1 << 30;
/// Most columns a recording's header may name (it uses four; a spreadsheet adds a few).
pub const MAX_COLUMNS: usize = 256;

fn read_csv(path: &Path) -> Result<Read, CampaignError> {
    let text = crate::config::read_input(path, MAX_CSV_BYTES).map_err(|e| io(path, e))?;
    let file = path.display().to_string();
    let bad = |line: usize, msg: String| CampaignError::Malformed {
        file: file.clone(),
        line,
        msg,
    };
    // Lines end in \n or \r\n; a file whose lines end in a carriage return alone (classic Mac
    // OS) would read as one line of as many columns as samples.
    if text.contains('\r') && !text.contains('\n') {
        return Err(bad(
            1,
            "the lines end in a carriage return alone (\\r, classic Mac OS), so the file reads \
             as one line; save it with \\n or \\r\\n line endings"
                .into(),
        ));
    }
    let mut lines = text.lines().enumerate();
    let (_, header) = lines
        .next()
        .ok_or_else(|| bad(1, "empty file; expected a header row t,F_d,x_s,x_d".into()))?;
    // A byte-order mark written by spreadsheet programs is not part of the first name.
    let header = header.strip_prefix('\u{feff}').unwrap_or(header);
    // A second mark is no part of a name either, but no program should write it: say so
    // rather than miss the first column.
    let marks = header.chars().take_while(|&c| c == '\u{feff}').count();
    if marks > 0 {
        return Err(bad(
            1,
            format!(
                "the file starts with {} byte-order marks (U+FEFF); a UTF-8 file has one at \
                 most: remove the extra ones",
                marks + 1
            ),
        ));
    }
    let names: Vec<&str> = header.split(',').map(|s| s.trim()).collect();
    if names.len() > MAX_COLUMNS {
        return Err(bad(
            1,
            format!(
                "the header names {} columns; at most {MAX_COLUMNS} (t, F_d, x_s, x_d and a few more)",
                names.len()
            ),
        ));
    }
    for (j, n) in names.iter().enumerate() {
        if names[..j].contains(n) {
            return Err(bad(
                1,
                format!("column `{n}` appears twice in the header; each column once"),
            ));
        }
    }
    // t and F_d are required; x_s and x_d are read where present.
    let wanted = ["t", "F_d", "x_s", "x_d"];
    let mut idx: Vec<(usize, usize)> = vec![];
    for (j, want) in wanted.iter().enumerate() {
        match names.iter().position(|n| n == want) {
            Some(i) => idx.push((j, i)),
            None if j < 2 => {
                return Err(bad(
                    1,
                    format!(
                        "header has no column `{want}`; found {} (t and F_d are required, x_s and x_d optional)",
                        names.join(",")
                    ),
                ));
            }
            None => {}
        }
    }
    let mut cols: [Vec<f64>; 4] = Default::default();
    for (i, line) in lines {
        let line_no = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() < names.len() {
            return Err(bad(
                line_no,
                format!("{} fields, the header has {}", fields.len(), names.len()),
            ));
        }
        for &(j, col) in &idx {
            let s = fields[col].trim();
            let x: f64 = s.parse().map_err(|_| {
                bad(
                    line_no,
                    format!("column `{}`: `{s}` is not a number", names[col]),
                )
            })?;
            if !x.is_finite() {
                return Err(bad(
                    line_no,
                    format!("column `{}`: {s} is not finite", names[col]),
                ));
            }
            cols[j].push(x);
        }
        let n = cols[0].len();
        if n >= 2 && cols[0][n - 1] <= cols[0][n - 2] {
            return Err(bad(
                line_no,
                format!("time {} does not increase", cols[0][n - 1]),
            ));
        }
    }
    let n = cols[0].len();
    if n < MIN_SAMPLES {
        return Err(bad(
            0,
            format!("{n} samples; at least {MIN_SAMPLES} are needed"),
        ));
    }
    let (pieces, gaps) = pieces(&cols[0], &bad)?;
    let has = |j: usize| idx.iter().any(|&(k, _)| k == j);
    let [t, f, xs, xd] = cols;
    Ok((
        (t, f, has(2).then_some(xs), has(3).then_some(xd)),
        pieces,
        gaps,
    ))
}

/// Fewest samples of a recording (or of a piece of one between gaps).
pub const MIN_SAMPLES: usize = 200;
/// A step of the time column over this many median steps is a gap (a dropped DAQ buffer, a
/// restart); shorter steps must lie within 1 % of their stretch's mean.
pub const GAP_STEPS: f64 = 1.5;

/// The stretches of uniform sampling between the time column's gaps (`[start, end)` sample
/// ranges) and the gaps; an error naming the line where a step is neither regular (within 1 %
/// of its stretch's mean) nor a gap.
fn pieces(
    t: &[f64],
    bad: &impl Fn(usize, String) -> CampaignError,
) -> Result<(Vec<(usize, usize)>, Vec<acquisition::Gap>), CampaignError> {
    let n = t.len();
    let step = check::median(t.windows(2).map(|w| w[1] - w[0]).collect());
    let mut cuts = vec![0];
    let mut gaps = vec![];
    for i in 1..n {
        let d = t[i] - t[i - 1];
        if d > GAP_STEPS * step {
            cuts.push(i);
            gaps.push(acquisition::Gap {
                after_s: t[i - 1],
                missing_s: d - step,
                samples: ((d - step) / step).round() as usize,
            });
        }
    }
    cuts.push(n);
    let pieces: Vec<(usize, usize)> = cuts.windows(2).map(|w| (w[0], w[1])).collect();
    for &(a, b) in &pieces {
        if b - a < 2 {
            continue;
        }
        let dt = (t[b - 1] - t[a]) / (b - a - 1) as f64;
        for i in a + 1..b {
            let d = t[i] - t[i - 1];
            if (d - dt).abs() > 0.01 * dt {
                return Err(bad(
                    i + 2,
                    format!(
                        "sampling is not uniform: step {d:.3e} s against a mean of {dt:.3e} s (1 % allowed; a step over {GAP_STEPS} times the median {step:.3e} s is read as a gap)"
                    ),
                ));
            }
        }
    }
    Ok((pieces, gaps))
}

/// The model's version of a recording: the signals the stand records, sampled at the
/// recording's times.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimTrace {
    /// Recorded drive force \[N\] (the sensor's output with `sensor_dynamics`).
    pub f_d: Vec<f64>,
    /// Body displacement \[m\].
    pub x_s: Vec<f64>,
    /// Drive displacement \[m\].
    pub x_d: Vec<f64>,
    /// How the integration ended.
    pub status: Status,
}

/// Tolerance (`rtol = atol`) of the simulations inside fits: 1e-5 moves the features by about
/// 1e-4 N against the run default 1e-6 (peak, trough, mean force of the Fig. 4 drive at
/// v_a/v_d = 0.8), a fiftieth of the smallest feature floor, for a third fewer steps.
pub const FIT_TOLERANCE: f64 = 1e-5;

/// Method for simulations of recordings: Dopri5 with vibration (the forcing caps the step
/// and the explicit method is cheapest), Rodas4 without (long sticks on a stiff contact), and
/// `auto` for two-stage recordings (sticks on the resting substrate, then the forcing).
pub fn method_for(p: &Params) -> Method {
    if p.two_stage() {
        Method::Auto
    } else if p.vibrates() {
        Method::Dopri5
    } else {
        Method::Rodas4
    }
}

/// Simulates the model with effects `fx` from rest at `t = 0` and samples it at `n` times
/// `t0 + i dt`, as the stand's recorder would, at tolerance `tol` (`rtol = atol`).
pub fn simulate_grid(
    p: &Params,
    fx: &Effects,
    t0: f64,
    dt: f64,
    n: usize,
    tol: f64,
    solvers: &mut Solvers,
) -> Result<SimTrace, RigError> {
    let rig = Rig::with_effects(*p, fx)?;
    let mut y = rig.initial_state();
    let (mut sampler, grid) = delay::Sampler::new(rig.clone(), t0, dt, n);
    let t1 = t0 + dt * (n - 1) as f64;
    let solver = solvers.get(method_for(p));
    let span = Span::new(0.0, t1, grid);
    let rep = integrate_recording(solver, &rig, p, span, &mut y, tol, |t, y| {
        sampler.take(t, y);
        true
    });
    Ok(sampler.finish(rep.status))
}

/// Integrates a recording's system `sys` (the rig, or the rig with its sensitivities) from
/// rest over `span` at tolerance `tol` (`rtol = atol`), in two stages where the recording's
/// vibration switches on inside it (the substrate velocity jumps at `t_on`; the grid is shared
/// by index), handing each output to `observe`.
pub(crate) fn integrate_recording<S: crate::ode::OdeSystem>(
    solver: &mut crate::ode::Solver,
    sys: &S,
    p: &Params,
    span: Span,
    y: &mut [f64],
    tol: f64,
    observe: impl FnMut(f64, &[f64]) -> bool,
) -> crate::ode::RunReport {
    let opts = Options {
        rtol: tol,
        atol: tol,
        ..Options::default()
    };
    if p.two_stage() && p.t_on < span.t1 {
        crate::sim::integrate_stages(solver, sys, p.t_on, span, y, &opts, observe)
    } else {
        solver.solve_until(sys, span, y, &opts, observe)
    }
}

/// One solver per method, kept across runs by a worker.
pub use crate::ode::Solvers;

/// Writes one recording (`NAME.csv` and `NAME.toml` with the conditions `v_d`, `k_d`, `f`,
/// `u0`, `F_N`) into `dir`.
pub fn write_recording(dir: &Path, rec: &Recording) -> Result<(), CampaignError> {
    let p = &rec.params;
    let toml_path = dir.join(format!("{}.toml", rec.name));
    let mut text = format!(
        "# conditions of recording {name}\nv_d = {:e}\nk_d = {:e}\nf = {:e}\nu0 = {:e}\nF_N = {:e}\n",
        p.v_d,
        p.k_d,
        if p.vibrates() { p.f } else { 0.0 },
        p.u0,
        p.f_n,
        name = rec.name
    );
    if p.two_stage() {
        text += &format!("t_on = {:e}\n", p.t_on);
    }
    std::fs::write(&toml_path, text).map_err(|e| io(&toml_path, e))?;
    let csv_path = dir.join(format!("{}.csv", rec.name));
    let f = std::fs::File::create(&csv_path).map_err(|e| io(&csv_path, e))?;
    let mut w = std::io::BufWriter::new(f);
    let mut go = || -> std::io::Result<()> {
        let mut header = String::from("t,F_d");
        for (name, col) in [("x_s", &rec.x_s), ("x_d", &rec.x_d)] {
            if col.is_some() {
                header += ",";
                header += name;
            }
        }
        writeln!(w, "{header}")?;
        for i in 0..rec.t.len() {
            write!(w, "{:.9e},{:.7e}", rec.t[i], rec.f_d[i])?;
            for col in [&rec.x_s, &rec.x_d].into_iter().flatten() {
                write!(w, ",{:.9e}", col[i])?;
            }
            writeln!(w)?;
        }
        w.flush()
    };
    go().map_err(|e| io(&csv_path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) {
        std::fs::write(dir.join(name), text).unwrap();
    }

    fn csv(n: usize) -> String {
        let mut s = String::from("t,F_d,x_s,x_d,extra\n");
        for i in 0..n {
            s += &format!(
                "{},{},{},{},7\n",
                i as f64 * 1e-3,
                1.0,
                0.0,
                i as f64 * 1e-6
            );
        }
        s
    }

    #[test]
    fn reads_a_campaign_with_defaults() {
        let d = tempfile::tempdir().unwrap();
        write(d.path(), "campaign.toml", "k_d = 10000\nF_N = 40\n");
        write(d.path(), "a.toml", "v_d = 1e-3\nf = 0\nu0 = 0\n");
        write(d.path(), "a.csv", &csv(300));
        write(
            d.path(),
            "b.toml",
            "v_d = 1e-3\nf = 1500\nv_a = 1e-3\nk_d = 5000\n",
        );
        write(d.path(), "b.csv", &csv(300));
        write(d.path(), "notes.txt", "ignored");
        let c = Campaign::load(d.path()).unwrap();
        assert_eq!(c.recordings.len(), 2);
        assert_eq!(c.recordings[0].params.k_d, 10000.0);
        assert_eq!(c.recordings[0].params.f_n, 40.0);
        assert_eq!(c.recordings[1].params.k_d, 5000.0);
        assert!((c.recordings[1].params.v_a() - 1e-3).abs() < 1e-12);
        assert!((c.recordings[0].dt() - 1e-3).abs() < 1e-12);
    }

    /// The force channel alone is a recording; a byte-order mark before the header is skipped.
    #[test]
    fn reads_the_force_channel_alone_and_skips_a_byte_order_mark() {
        let d = tempfile::tempdir().unwrap();
        write(
            d.path(),
            "a.toml",
            "v_d = 1e-3\nk_d = 1e4\nf = 1500\nu0 = 1e-7\nt_on = 0.1\n",
        );
        let mut text = String::from("\u{feff}t,F_d\n");
        for i in 0..300 {
            text += &format!("{},{}\n", i as f64 * 1e-3, 2.0);
        }
        write(d.path(), "a.csv", &text);
        let c = Campaign::load(d.path()).unwrap();
        let r = &c.recordings[0];
        assert!(r.x_s.is_none() && r.x_d.is_none());
        assert_eq!(r.f_d.len(), 300);
        assert_eq!(r.params.t_on, 0.1);
        // Written back without the missing columns, and read again alike.
        let e = tempfile::tempdir().unwrap();
        write_recording(e.path(), r).unwrap();
        let again = Campaign::load(e.path()).unwrap();
        assert_eq!(again.recordings[0].x_s, None);
        assert_eq!(again.recordings[0].params.t_on, 0.1);
    }

    #[test]
    fn malformed_files_name_file_line_and_problem() {
        let d = tempfile::tempdir().unwrap();
        write(d.path(), "a.toml", "v_d = 1e-3\nk_d = 1e4\nf = 0\nu0 = 0\n");
        let mut text = csv(300);
        text = text.replacen("0.005,1,", "0.005,abc,", 1);
        write(d.path(), "a.csv", &text);
        let e = Campaign::load(d.path()).unwrap_err().to_string();
        assert!(
            e.contains("a.csv:7") && e.contains("`abc` is not a number"),
            "{e}"
        );

        write(d.path(), "a.csv", &csv(300));
        write(d.path(), "b.csv", &csv(300));
        let e = Campaign::load(d.path()).unwrap_err().to_string();
        assert!(e.contains("b.csv") && e.contains("b.toml"), "{e}");

        write(d.path(), "b.toml", "v_d = 1e-3\nk_d = -3\nf = 0\nu0 = 0\n");
        let e = Campaign::load(d.path()).unwrap_err().to_string();
        assert!(e.contains("b.toml:2") && e.contains("k_d"), "{e}");

        write(d.path(), "b.toml", "v_d = 1e-3\nf = 0\nu0 = 0\n");
        let e = Campaign::load(d.path()).unwrap_err().to_string();
        assert!(e.contains("missing `k_d`"), "{e}");

        write(d.path(), "b.toml", "v_d = 1e-3\nk_d = 1e4\nf = 0\nu0 = 0\n");
        write(d.path(), "b.csv", "t,x_s\n0,1,2\n");
        let e = Campaign::load(d.path()).unwrap_err().to_string();
        assert!(e.contains("b.csv:1") && e.contains("F_d"), "{e}");

        write(d.path(), "b.csv", "t,F_d,x_s,F_d\n0,1,2,3\n");
        let e = Campaign::load(d.path()).unwrap_err().to_string();
        assert!(
            e.contains("b.csv:1") && e.contains("`F_d` appears twice"),
            "{e}"
        );

        write(
            d.path(),
            "b.csv",
            &csv(300).replacen("0.003,", "0.0031,", 1),
        );
        let e = Campaign::load(d.path()).unwrap_err().to_string();
        assert!(e.contains("not uniform"), "{e}");
    }

    #[test]
    fn a_gap_in_the_time_column_splits_the_recording() {
        let d = tempfile::tempdir().unwrap();
        write(
            d.path(),
            "a.toml",
            "v_d = 1e-3
k_d = 1e4
f = 0
u0 = 0
",
        );
        // 600 rows, rows 300 to 339 lost (a dropped buffer of 40 samples).
        let text: String = csv(600)
            .lines()
            .enumerate()
            .filter(|(i, _)| !(301..341).contains(i))
            .map(|(_, l)| format!("{l}\n"))
            .collect();
        write(d.path(), "a.csv", &text);
        let c = Campaign::load(d.path()).unwrap();
        let names: Vec<&str> = c.recordings.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["a~1", "a~2"]);
        assert_eq!(c.recordings[0].t.len(), 300);
        assert_eq!(c.recordings[1].t.len(), 260);
        let s = &c.acquisition.splits[0];
        assert_eq!(s.gaps.len(), 1);
        assert_eq!(s.gaps[0].samples, 40);
        assert!((s.gaps[0].after_s - 0.299).abs() < 1e-12, "{s:?}");
        // A short piece is dropped and counted; the long one keeps the file's name.
        let text: String = csv(600)
            .lines()
            .enumerate()
            .filter(|(i, _)| !(101..141).contains(i))
            .map(|(_, l)| format!("{l}\n"))
            .collect();
        write(d.path(), "a.csv", &text);
        let c = Campaign::load(d.path()).unwrap();
        assert_eq!(c.recordings[0].name, "a");
        assert_eq!(c.recordings[0].t.len(), 460);
        assert_eq!(c.acquisition.splits[0].dropped_samples, 100);
    }
}
