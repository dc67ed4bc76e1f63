//! The append-only journal of finished runs that makes a sweep resumable: one text line per run,
//! written and flushed as the run finishes, so a crash, `kill -9` or Ctrl-C loses only the runs
//! in flight. A torn last line is ignored on reading.
//!
//! Format: a header `stickslip-journal 3 <fingerprint> <columns>` (the fingerprint of the
//! sweep text and program version, so that a journal is never applied to another sweep; the
//! record's columns by name, comma-separated), then one record per line, ended by its checksum
//! `~xxxxxxxx` (FNV-1a of the line before it: a damaged line is dropped and its run made again):
//!
//! ```text
//! <kind> <index> <value of each column> ~<checksum>
//! ```
//!
//! The columns this version writes ([`COLUMNS`]): `status t_end window_start wall_time`, the
//! counters of [`Stats`] but `skipped_periods` ([`Counter`]), the measures of a run
//! ([`Measure::OF_RUN`]), then `skipped_periods continued_from predicted level_error tier
//! tier_reason`: the order of version 2, whose header (`stickslip-journal 2 <fingerprint>`)
//! named no columns, so a journal written by it still resumes (its records hold a prefix of
//! these columns, as they grew).
//!
//! with `kind` `ref`, `pt` or `chk` (a full-model check of an averaged point), `continued_from` NaN where the run was integrated to its end and
//! `predicted` 1 where the measures are the settled level extrapolated from the window, else 0,
//! and `level_error` that level's error bound \[N\] (NaN where not extrapolated), `tier` the
//! model that served the run (0 full, 1 averaged, 2 hybrid: [`Tier::code`]) and `tier_reason` why
//! ([`TierReason::code`]).
//! Floats use Rust's shortest round-trip form, so resumed results are bit-identical. Only lines
//! ended by a newline are read.
//!
//! Lines `tab <key> <fields> ~<checksum>` keep the tables of the averaged law that the sweep's
//! averaged runs used ([`format_table`]), each written once, before the first run that used it:
//! a resumed sweep or shard loads them instead of building them again (building is
//! deterministic, so either way the results are the same bit for bit).

use crate::measures::{Measure, Measures};
use crate::ode::{Counter, Stats, Status};
use crate::sim::RunResult;
use crate::sim::{Tier, TierReason};
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Which run a record belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Task {
    /// Reference run without vibration number `i`.
    Ref(usize),
    /// Grid point `i` (with vibration).
    Point(usize),
    /// The full-model check of grid point `i`, an averaged one ([`super::check`]).
    Check(usize),
}

/// Journal path beside the output file.
pub fn path_for(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".journal");
    PathBuf::from(s)
}

/// A 64-bit FNV-1a fingerprint of the sweep text and the program version. The top-level
/// `max_runs` line is left out: it bounds the work, not the results, so a sweep stopped at its
/// cap continues from its journal once the cap is raised.
pub fn fingerprint(text: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let kept = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("max_runs"))
        .flat_map(|l| l.bytes().chain(std::iter::once(b'\n')));
    for b in kept.chain(crate::output::program().bytes()) {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// The first line of a journal for fingerprint `fp`, naming its columns.
pub fn header(fp: &str) -> String {
    let names: Vec<&str> = COLUMNS.iter().map(|c| c.name()).collect();
    format!("stickslip-journal 3 {fp} {}", names.join(","))
}

/// What a journal's header says: its fingerprint and the columns of its records (`None` for a
/// journal of version 2, whose records hold a prefix of [`COLUMNS`]: [`parse_record`]), or why
/// it cannot be read.
fn read_header(first: &str) -> Result<(&str, Option<Vec<Column>>), String> {
    let f: Vec<&str> = first.split(' ').collect();
    match f.as_slice() {
        ["stickslip-journal", "2", fp] => Ok((fp, None)),
        ["stickslip-journal", "3", fp, names] => {
            let cols = names
                .split(',')
                .map(|n| {
                    Column::from_name(n).ok_or_else(|| {
                        format!("its header names a column `{n}` this program does not know")
                    })
                })
                .collect::<Result<Vec<Column>, String>>()?;
            for need in [
                Column::Status,
                Column::TEnd,
                Column::WindowStart,
                Column::WallTime,
            ] {
                if !cols.contains(&need) {
                    return Err(format!("its header lacks the column `{}`", need.name()));
                }
            }
            Ok((fp, Some(cols)))
        }
        _ => Err("its header is not that of a journal of version 2 or 3".into()),
    }
}

/// Whether the journal whose first line is `first` was written for fingerprint `fp` (by this
/// version or by version 2).
pub fn belongs(first: &str, fp: &str) -> bool {
    read_header(first).is_ok_and(|(f, _)| f == fp)
}

/// A column of a run's record: one of the run's own fields, a counter of its work or one of
/// its measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Column {
    /// [`RunResult::status`], by its code.
    Status,
    /// [`RunResult::t_end`].
    TEnd,
    /// [`RunResult::window_start`].
    WindowStart,
    /// [`RunResult::wall_time`].
    WallTime,
    /// A counter of [`RunResult::stats`].
    Counter(Counter),
    /// A measure of [`RunResult::measures`] (one of [`Measure::OF_RUN`]).
    Measure(Measure),
    /// [`RunResult::continued_from`], NaN for none.
    ContinuedFrom,
    /// [`RunResult::predicted`], 1 or 0.
    Predicted,
    /// [`RunResult::level_error`], NaN for none.
    LevelError,
    /// [`RunResult::tier`], by its code ([`Tier::code`]).
    Tier,
    /// [`RunResult::tier_reason`], by its code ([`TierReason::code`]).
    TierReason,
}

/// The columns this version writes, in order (module docs).
pub const COLUMNS: [Column; 24] = [
    Column::Status,
    Column::TEnd,
    Column::WindowStart,
    Column::WallTime,
    Column::Counter(Counter::Steps),
    Column::Counter(Counter::Rejected),
    Column::Counter(Counter::RhsEvals),
    Column::Counter(Counter::JacEvals),
    Column::Counter(Counter::LuDecomps),
    Column::Counter(Counter::NewtonIters),
    Column::Measure(Measure::OF_RUN[0]),
    Column::Measure(Measure::OF_RUN[1]),
    Column::Measure(Measure::OF_RUN[2]),
    Column::Measure(Measure::OF_RUN[3]),
    Column::Measure(Measure::OF_RUN[4]),
    Column::Measure(Measure::OF_RUN[5]),
    Column::Measure(Measure::OF_RUN[6]),
    Column::Measure(Measure::OF_RUN[7]),
    Column::Counter(Counter::SkippedPeriods),
    Column::ContinuedFrom,
    Column::Predicted,
    Column::LevelError,
    Column::Tier,
    Column::TierReason,
];

/// The numbers of columns a record of version 2 held, as it grew (20 fields: no skipped
/// periods; then the limit-cycle continuation, predicted windows, their error bound, tiers).
const V2_LENGTHS: [usize; 6] = [18, 19, 20, 21, 22, 24];

impl Column {
    /// Its name in a header (a counter's or a measure's own).
    pub fn name(self) -> &'static str {
        match self {
            Column::Status => "status",
            Column::TEnd => "t_end",
            Column::WindowStart => "window_start",
            Column::WallTime => "wall_time",
            Column::Counter(c) => c.name(),
            Column::Measure(m) => m.name(),
            Column::ContinuedFrom => "continued_from",
            Column::Predicted => "predicted",
            Column::LevelError => "level_error",
            Column::Tier => "tier",
            Column::TierReason => "tier_reason",
        }
    }

    /// The column named `name` among those this version knows.
    pub fn from_name(name: &str) -> Option<Column> {
        COLUMNS.into_iter().find(|c| c.name() == name)
    }

    /// Its value in run `r` (floats in Rust's shortest round-trip form).
    fn format(self, r: &RunResult) -> String {
        match self {
            Column::Status => r.status.code().to_string(),
            Column::TEnd => r.t_end.to_string(),
            Column::WindowStart => r.window_start.to_string(),
            Column::WallTime => r.wall_time.to_string(),
            Column::Counter(c) => c.of(&r.stats).to_string(),
            Column::Measure(Measure::Cycles) => r.measures.cycles.to_string(),
            Column::Measure(m) => m.of_run(&r.measures).unwrap_or(f64::NAN).to_string(),
            Column::ContinuedFrom => r.continued_from.unwrap_or(f64::NAN).to_string(),
            Column::Predicted => u8::from(r.predicted()).to_string(),
            Column::LevelError => r.level_error.unwrap_or(f64::NAN).to_string(),
            Column::Tier => r.tier.code().to_string(),
            Column::TierReason => r.tier_reason.code().to_string(),
        }
    }

    /// Sets its field of `r` from the text `v`; `None` where `v` does not parse.
    fn parse(self, v: &str, r: &mut RunResult) -> Option<()> {
        let x = || v.parse::<f64>().ok();
        match self {
            Column::Status => r.status = Status::from_code(v.parse().ok()?)?,
            Column::TEnd => r.t_end = x()?,
            Column::WindowStart => r.window_start = x()?,
            Column::WallTime => r.wall_time = x()?,
            Column::Counter(c) => *c.slot(&mut r.stats) = v.parse().ok()?,
            Column::Measure(Measure::Cycles) => r.measures.cycles = v.parse().ok()?,
            Column::Measure(m) => m.set(&mut r.measures, x()?),
            Column::ContinuedFrom => r.continued_from = Some(x()?).filter(|t| t.is_finite()),
            // Whether the level was extrapolated; its error bound is the next column.
            Column::Predicted => {
                if !matches!(v, "0" | "1") {
                    return None;
                }
            }
            Column::LevelError => r.level_error = Some(x()?).filter(|e| e.is_finite()),
            Column::Tier => r.tier = Tier::from_code(v.parse().ok()?)?,
            Column::TierReason => r.tier_reason = TierReason::from_code(v.parse().ok()?)?,
        }
        Some(())
    }
}

/// The checksum that ends a record: FNV-1a (32 bits) of the record's text before it, in hex
/// after a `~`. A line damaged anywhere (a flipped digit still parses) fails it.
fn checksum(body: &str) -> String {
    let mut h: u32 = 0x811c_9dc5;
    for b in body.bytes() {
        h ^= b as u32;
        h = h.wrapping_mul(0x0100_0193);
    }
    format!("~{h:08x}")
}

/// The body of a line whose checksum (its last field) matches; `None` for a damaged line.
fn checked(line: &str) -> Option<&str> {
    let (body, sum) = line.rsplit_once(' ')?;
    (sum.starts_with('~') && checksum(body) == sum).then_some(body)
}

/// The whole lines of a journal's bytes: a last line without its newline was torn by a kill
/// mid-write, and a torn number may still parse (a float cut short), so it is left out.
fn whole_lines(text: &[u8]) -> std::borrow::Cow<'_, str> {
    let whole = text
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(&text[..0], |p| &text[..p]);
    String::from_utf8_lossy(whole)
}

/// Formats one record (without the newline), its checksum last.
pub fn format_record(task: Task, r: &RunResult) -> String {
    let body = format_body(task, r);
    let sum = checksum(&body);
    body + " " + &sum
}

fn format_body(task: Task, r: &RunResult) -> String {
    let (kind, i) = match task {
        Task::Ref(i) => ("ref", i),
        Task::Point(i) => ("pt", i),
        Task::Check(i) => ("chk", i),
    };
    let mut body = format!("{kind} {i}");
    for c in COLUMNS {
        body.push(' ');
        body.push_str(&c.format(r));
    }
    body
}

/// Parses one record of this version's columns, or of version 2 (a prefix of them, as its
/// records grew: 20 to 26 fields but 25); `None` for a torn or foreign line.
pub fn parse_record(line: &str) -> Option<(Task, RunResult)> {
    let n = checked(line)?.split(' ').count().checked_sub(2)?;
    V2_LENGTHS
        .contains(&n)
        .then(|| parse_with(line, &COLUMNS[..n]))
        .flatten()
}

/// Parses one record whose values are those of `cols`, in order; `None` for a torn, damaged or
/// foreign line. A column `cols` lacks keeps its default (no work, no continuation, no
/// extrapolated level, the full model, as asked).
fn parse_with(line: &str, cols: &[Column]) -> Option<(Task, RunResult)> {
    // Records end with their checksum; one that does not match is damaged.
    let body = checked(line)?;
    let f: Vec<&str> = body.split(' ').collect();
    if f.len() != cols.len() + 2 {
        return None;
    }
    let i: usize = f[1].parse().ok()?;
    let task = match f[0] {
        "ref" => Task::Ref(i),
        "pt" => Task::Point(i),
        "chk" => Task::Check(i),
        _ => return None,
    };
    let mut r = RunResult {
        status: Status::Success,
        stats: Stats::default(),
        measures: Measures::nan(),
        t_end: f64::NAN,
        window_start: f64::NAN,
        wall_time: f64::NAN,
        continued_from: None,
        level_error: None,
        tier: Tier::Full,
        tier_reason: TierReason::Asked,
        trace: None,
    };
    for (c, v) in cols.iter().zip(&f[2..]) {
        c.parse(v, &mut r)?;
    }
    Some((task, r))
}

/// Reads a journal written for fingerprint `fp`. Errors when the journal belongs to another
/// sweep. Later records of the same task replace earlier ones.
///
/// Returns the records and the number of lines dropped as damaged (a torn last line, or a line
/// that does not parse as a record); their runs are made again.
pub fn read(path: &Path, fp: &str) -> Result<(Vec<(Task, RunResult)>, usize), String> {
    let text = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let whole = whole_lines(&text);
    let mut lines = whole.lines();
    let first = lines.next().unwrap_or_default();
    let cols = match read_header(first) {
        Ok((f, cols)) if f == fp => cols,
        Ok(_) => {
            return Err(format!(
                "{} was written for another sweep file or program version (header `{first}`, expected `{}`); \
                 start afresh with --overwrite",
                path.display(),
                header(fp)
            ));
        }
        Err(why) => {
            return Err(format!(
                "{} cannot be resumed: {why} (header `{first}`); start afresh with --overwrite",
                path.display()
            ));
        }
    };

    let torn = usize::from(text.last().is_some_and(|&b| b != b'\n'));
    let mut dropped = torn;
    let records = lines
        // Tables of the averaged law are read by read_tables.
        .filter(|l| !l.starts_with("tab "))
        .filter_map(|l| {
            let r = match &cols {
                Some(cols) => parse_with(l, cols),
                None => parse_record(l),
            };
            dropped += usize::from(r.is_none());
            r
        })
        .collect();
    Ok((records, dropped))
}

/// The journal line of the averaged law's table `t` under its key
/// ([`crate::averaged::TableStore::key`]): `tab <key as hex words joined by commas> <fields of
/// Table::to_fields> ~<checksum>`.
pub fn format_table(key: &[u64], t: &crate::averaged::Table) -> String {
    let key: Vec<String> = key.iter().map(|k| format!("{k:x}")).collect();
    let body = format!("tab {} {}", key.join(","), t.to_fields());
    let sum = checksum(&body);
    format!("{body} {sum}")
}

/// The tables of the averaged law a journal keeps (see [`format_table`]); damaged lines are
/// skipped (their tables are built again, identical, where a run needs them).
pub fn read_tables(path: &Path) -> Vec<(Vec<u64>, crate::averaged::Table)> {
    let Ok(text) = std::fs::read(path) else {
        return vec![];
    };
    whole_lines(&text)
        .lines()
        .filter(|l| l.starts_with("tab "))
        .filter_map(|l| {
            let (key, fields) = checked(l)?.strip_prefix("tab ")?.split_once(' ')?;
            let key = key
                .split(',')
                .map(|k| u64::from_str_radix(k, 16).ok())
                .collect::<Option<Vec<u64>>>()?;
            Some((key, crate::averaged::Table::from_fields(fields)?))
        })
        .collect()
}

/// An open journal, appending.
pub struct Journal {
    file: File,
    path: PathBuf,
}

impl Journal {
    /// Creates a fresh journal (replacing any old one).
    pub fn create(path: &Path, fp: &str) -> std::io::Result<Journal> {
        let mut file = File::create(path)?;
        writeln!(file, "{}", header(fp))?;
        file.sync_data()?;
        Ok(Journal {
            file,
            path: path.to_path_buf(),
        })
    }

    /// Opens an existing journal for appending; a torn last line is cut off first.
    pub fn append(path: &Path) -> std::io::Result<Journal> {
        let text = std::fs::read(path)?;
        let keep = text
            .iter()
            .rposition(|&b| b == b'\n')
            .map(|p| p + 1)
            .unwrap_or(0);
        let file = OpenOptions::new().write(true).open(path)?;
        file.set_len(keep as u64)?;
        let mut file = OpenOptions::new().append(true).open(path)?;
        file.flush()?;
        Ok(Journal {
            file,
            path: path.to_path_buf(),
        })
    }

    /// Appends a record and hands it to the operating system at once.
    pub fn record(&mut self, task: Task, r: &RunResult) -> std::io::Result<()> {
        let line = format_record(task, r) + "\n";
        self.file.write_all(line.as_bytes())
    }

    /// Appends the averaged law's table `t` (key `key`), kept so that a resumed sweep does not
    /// build it again.
    pub fn record_table(&mut self, key: &[u64], t: &crate::averaged::Table) -> std::io::Result<()> {
        let line = format_table(key, t) + "\n";
        self.file.write_all(line.as_bytes())
    }

    /// Forces the journal to disk.
    pub fn sync(&mut self) -> std::io::Result<()> {
        self.file.sync_data()
    }

    /// The journal's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_round_trip_bit_for_bit_and_damaged_ones_are_skipped() {
        use crate::averaged::{SHARED, Table};
        let mut p = crate::model::Params {
            f: 3000.0,
            ..Default::default()
        };
        p.set_v_a(0.4 * p.v_d);
        let t = Table::build(&p, 4.0 * p.v_d, SHARED).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j");
        let key = crate::averaged::TableStore::key(&p);
        let mut j = Journal::create(&path, "abc").unwrap();
        j.record_table(&key, &t).unwrap();
        let mut bad = format_table(&[7], &t);
        // One digit changed: the checksum no longer matches.
        let k = bad.find(' ').unwrap() + 3;
        bad.replace_range(k..k + 1, if &bad[k..k + 1] == "1" { "2" } else { "1" });
        writeln!(j.file, "{bad}").unwrap();
        drop(j);
        let back = read_tables(&path);
        assert_eq!(back.len(), 1);
        assert_eq!(back[0].0, key);
        assert_eq!(back[0].1.to_fields(), t.to_fields());
        assert_eq!(back[0].1, t);
        // Table lines are not runs, nor damaged runs.
        let (records, dropped) = read(&path, "abc").unwrap();
        assert!(records.is_empty());
        assert_eq!(dropped, 0);
        // Trailing or missing fields are refused.
        assert!(Table::from_fields(&(t.to_fields() + " 1")).is_none());
        let f = t.to_fields();
        assert!(Table::from_fields(f.rsplit_once(' ').unwrap().0).is_none());
    }

    #[test]
    fn records_round_trip_bit_for_bit_including_nan() {
        let r = RunResult {
            status: Status::MaxSteps,
            stats: Stats {
                steps: 12,
                rejected: 3,
                rhs_evals: 99,
                jac_evals: 4,
                lu_decomps: 8,
                newton_iters: 20,
                skipped_periods: 7,
            },
            measures: Measures {
                d_f: 0.1 + 0.2,
                d_f_stderr: 1e-300,
                mean_force: f64::NAN,
                stick_fraction: 1.0 / 3.0,
                period: f64::INFINITY,
                peak_force: -0.0,
                trough_force: 7.25,
                cycles: 5,
            },
            t_end: 9.85,
            window_start: 4.925,
            wall_time: 0.123456789,
            continued_from: Some(1.0 / 7.0),
            level_error: Some(0.1 + 0.7),
            tier: Tier::Averaged,
            tier_reason: TierReason::Valid,
            trace: None,
        };
        let line = format_record(Task::Point(42), &r);
        let (t, back) = parse_record(&line).unwrap();
        assert_eq!(t, Task::Point(42));
        assert_eq!(back.measures.d_f.to_bits(), r.measures.d_f.to_bits());
        assert!(back.measures.mean_force.is_nan());
        assert_eq!(
            back.measures.stick_fraction.to_bits(),
            r.measures.stick_fraction.to_bits()
        );
        assert_eq!(back.stats, r.stats);
        assert_eq!(back.status, r.status);
        assert_eq!(back.continued_from, r.continued_from);
        assert_eq!((back.tier, back.tier_reason), (r.tier, r.tier_reason));
        assert!(back.predicted());
        assert_eq!(
            back.level_error.map(f64::to_bits),
            r.level_error.map(f64::to_bits)
        );
        let integrated = RunResult {
            continued_from: None,
            level_error: None,
            ..r.clone()
        };
        let (_, back) = parse_record(&format_record(Task::Ref(1), &integrated)).unwrap();
        assert_eq!(back.continued_from, None);
        assert!(!back.predicted());
        assert_eq!(back.level_error, None);
        // A line cut short of its fields is rejected (a torn number is caught by `read`).
        assert!(parse_record("pt 1 0 1.0").is_none());
    }

    /// A journal of version 2 (no columns in its header, records of 20 to 26 fields) still
    /// resumes under this version; a header of version 3 is read by its columns, in any order,
    /// and one naming a column this version does not know, or lacking the run's status, is
    /// refused by the column's name.
    #[test]
    fn journals_resume_by_their_header_columns_and_version_2_still_reads() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("j");
        let line = |body: &str| format!("{body} {}\n", checksum(body));
        // Version 2, as it wrote them: a record before envelope following (20 fields) and one
        // with tiers (26 fields).
        let old = "ref 0 0 1 0.5 0.1 1 0 6 1 2 3 6.4 0.01 8.4 0.9 1.1 11.4 5.1 4";
        let new = "pt 3 0 2 1 0.2 10 1 60 2 4 6 1.5 0.02 8.1 0.1 0.01 9 6.5 7 12 NaN 0 NaN 1 6";
        std::fs::write(
            &p,
            "stickslip-journal 2 abc\n".to_string() + &line(old) + &line(new),
        )
        .unwrap();
        let (recs, dropped) = read(&p, "abc").unwrap();
        assert_eq!((recs.len(), dropped), (2, 0));
        assert_eq!(recs[0].1.measures.cycles, 4);
        assert_eq!(recs[0].1.stats.skipped_periods, 0);
        assert_eq!(recs[1].1.stats.skipped_periods, 12);
        assert_eq!(recs[1].1.tier, Tier::Averaged);
        assert_eq!(recs[1].1.measures.trough_force, 6.5);
        // Version 3 written by a program whose columns came in another order.
        std::fs::write(
            &p,
            "stickslip-journal 3 abc wall_time,window_start,t_end,status,dF,cycles\n".to_string()
                + &line("chk 5 0.25 0.5 1 0 6.25 3"),
        )
        .unwrap();
        let (recs, _) = read(&p, "abc").unwrap();
        let r = &recs[0].1;
        assert_eq!(recs[0].0, Task::Check(5));
        assert_eq!((r.wall_time, r.window_start, r.t_end), (0.25, 0.5, 1.0));
        assert_eq!((r.measures.d_f, r.measures.cycles), (6.25, 3));
        assert!(r.measures.mean_force.is_nan() && r.stats == Stats::default());
        std::fs::write(
            &p,
            "stickslip-journal 3 abc status,t_end,window_start,wall_time,q\n",
        )
        .unwrap();
        let e = read(&p, "abc").unwrap_err();
        assert!(e.contains("column `q`"), "{e}");
        std::fs::write(&p, "stickslip-journal 3 abc t_end,window_start,wall_time\n").unwrap();
        let e = read(&p, "abc").unwrap_err();
        assert!(e.contains("lacks the column `status`"), "{e}");
        // This version's header names every column it writes.
        let h = header("abc");
        assert!(
            h.ends_with("skipped_periods,continued_from,predicted,level_error,tier,tier_reason")
        );
        assert!(belongs(&h, "abc") && !belongs(&h, "abd"));
        assert!(belongs("stickslip-journal 2 abc", "abc"));
    }

    #[test]
    fn a_journal_of_another_sweep_is_refused_and_torn_tails_are_cut() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("j");
        let body = "ref 0 0 1 0.5 0.1 1 0 6 1 2 3 6.4 0.01 8.4 0.9 1.1 11.4 5.1 4";
        let r = parse_record(&format!("{body} {}", checksum(body)))
            .unwrap()
            .1;
        // A record damaged anywhere fails its checksum, though every field still parses.
        let flipped = format_record(Task::Ref(0), &r).replacen(" 8.4 ", " 8.5 ", 1);
        assert!(flipped.contains(" 8.5 ") && parse_record(&flipped).is_none());
        assert!(
            parse_record(body).is_none(),
            "a record without its checksum"
        );
        {
            let mut j = Journal::create(&p, "abc").unwrap();
            j.record(Task::Ref(0), &r).unwrap();
            j.record(Task::Point(3), &r).unwrap();
        }
        // Simulate a kill in the middle of a write: a torn record is not read (its checksum
        // cut short fails; a torn line is dropped unread besides).
        let mut f = OpenOptions::new().append(true).open(&p).unwrap();
        let continued = RunResult {
            continued_from: Some(0.123456),
            level_error: Some(0.123456),
            ..r.clone()
        };
        let full = format_record(Task::Point(4), &continued);
        f.write_all(&full.as_bytes()[..full.len() - 2]).unwrap();
        assert!(parse_record(&full[..full.len() - 2]).is_none());
        let (recs, dropped) = read(&p, "abc").unwrap();
        assert_eq!((recs.len(), dropped), (2, 1));
        assert!(read(&p, "xyz").unwrap_err().contains("another sweep"));
        let mut j = Journal::append(&p).unwrap();
        j.record(Task::Point(5), &r).unwrap();
        let (recs, dropped) = read(&p, "abc").unwrap();
        assert_eq!(dropped, 0, "appending cut the torn line off");
        assert_eq!(
            recs.iter().map(|x| x.0).collect::<Vec<_>>(),
            vec![Task::Ref(0), Task::Point(3), Task::Point(5)]
        );
    }
}
