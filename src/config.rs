//! Case files (TOML) and the shared helpers that turn TOML values into validated parameters with
//! errors that name the file, the line, the key and what is allowed.
//!
//! A case file sets any model parameter by its name in SI units at the top level, optionally
//! `v_a` [m/s] or `va_ratio` (v_a / v_d) instead of `u0`, and two optional tables:
//!
//! ```toml
//! k_d = 10000.0      # N/m
//! v_d = 1.0e-3       # m/s
//! f = 1500.0         # Hz
//! v_a = 1.1e-3       # m/s: u0 = v_a / (2 pi f)
//!
//! [solver]
//! method = "auto"    # default; radau5, rodas4, dopri5 or auto
//! rtol = 1e-6
//! atol = 1e-6        # in units of each state's characteristic size
//!
//! [run]
//! t_end = 12.0       # s; omitted: chosen from the run
//! min_cycles = 3
//! samples_per_period = 16
//! early_stop = true  # end once the answer is known (steady sliding, or dF to 0.5 %);
//!                    # "always": also with t_end given, which is then the longest time
//! periodic = true    # without vibration, continue along the limit cycle once it repeats
//! envelope = 1e-4    # skip vibration periods where the envelope is smooth (default 1e-4;
//!                    # false: integrate every period)
//! tier = "auto"      # auto (default): the vibration averaged out where valid; averaged; hybrid; full
//! ```

use crate::model::effects::{self, EffectKind, Effects};
use crate::model::{Params, params};
use crate::ode::Method;
use crate::sim::{EarlyStop, RunOptions};
use std::cmp::Ordering;
use std::path::{Path, PathBuf};

/// A problem in a configuration file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", self.text())]
pub struct ConfigError {
    /// The file.
    pub file: String,
    /// 1-based line (0 when unknown).
    pub line: usize,
    /// The key (dotted for keys in tables).
    pub key: String,
    /// What is wrong and what is allowed.
    pub msg: String,
}

impl ConfigError {
    /// `file:line: `key`: msg`, without the line where it is unknown (0) and without the key
    /// where there is none.
    fn text(&self) -> String {
        let mut t = self.file.clone();
        if self.line > 0 {
            t += &format!(":{}", self.line);
        }
        if !self.key.is_empty() {
            t += &format!(": `{}`", self.key);
        }
        t + ": " + &self.msg
    }
}

/// A parsed TOML document with its source, for error positions.
pub struct Doc {
    /// Path, for messages.
    pub file: String,
    /// Source text.
    pub text: String,
    /// Parsed top-level table.
    pub table: toml::Table,
}

/// Largest input text file read \[bytes\]: 64 MiB for TOML files (sweep, case and condition
/// files are kilobytes).
pub const MAX_TOML_BYTES: u64 = 64 << 20;

/// Reads an input text file of at most `max` bytes. Refuses what is not a regular file (a
/// device such as `/dev/zero`, a pipe that would block, a folder) before opening it, and a
/// file over `max` before reading it; the message says which (the caller adds the path).
pub fn read_input(path: &Path, max: u64) -> Result<String, String> {
    use std::io::Read;
    let m = std::fs::metadata(path).map_err(|e| format!("cannot read: {e}"))?;
    if !m.is_file() {
        return Err(if m.is_dir() {
            "cannot read: is a directory, not a file".into()
        } else {
            "cannot read: not a regular file (a device, pipe or socket); give a file".into()
        });
    }
    if m.len() > max {
        return Err(format!(
            "cannot read: {} bytes, over the limit of {max} bytes for this kind of file",
            m.len()
        ));
    }
    let f = std::fs::File::open(path).map_err(|e| format!("cannot read: {e}"))?;
    // A file that grows while read is still cut at the limit.
    let mut bytes = Vec::with_capacity(m.len() as usize);
    f.take(max + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read: {e}"))?;
    if bytes.len() as u64 > max {
        return Err(format!("cannot read: over the limit of {max} bytes"));
    }
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "cannot read: not UTF-8 text (byte {} is not valid)",
            e.utf8_error().valid_up_to()
        )
    })
}

impl Doc {
    /// Reads and parses a TOML file ([`read_input`], at most [`MAX_TOML_BYTES`]).
    pub fn read(path: &Path) -> Result<Doc, ConfigError> {
        let file = path.display().to_string();
        let text = read_input(path, MAX_TOML_BYTES).map_err(|msg| ConfigError {
            file: file.clone(),
            line: 0,
            key: String::new(),
            msg,
        })?;
        Doc::parse(&file, text)
    }

    /// Parses TOML text attributed to `file`.
    pub fn parse(file: &str, text: String) -> Result<Doc, ConfigError> {
        match text.parse::<toml::Table>() {
            Ok(table) => Ok(Doc {
                file: file.to_string(),
                text,
                table,
            }),
            Err(e) => {
                let line = e
                    .span()
                    .map(|s| text[..s.start.min(text.len())].lines().count().max(1))
                    .unwrap_or(0);
                Err(ConfigError {
                    file: file.to_string(),
                    line,
                    key: String::new(),
                    msg: format!("not valid TOML: {}", e.message()),
                })
            }
        }
    }

    /// The 1-based line where `key` is set inside table `section` ("" for the top level).
    pub fn line_of(&self, section: &str, key: &str) -> usize {
        let mut current = String::new();
        for (i, raw) in self.text.lines().enumerate() {
            let l = raw.trim();
            if l.starts_with('[') {
                current = l
                    .trim_start_matches('[')
                    .trim_end_matches(']')
                    .trim()
                    .to_string();
                if section.is_empty() {
                    continue;
                }
                // A key that is itself a table (`[section.key]` or `[key]`).
                let full = if section.is_empty() {
                    key.to_string()
                } else {
                    format!("{section}.{key}")
                };
                if current == full {
                    return i + 1;
                }
                continue;
            }
            if current == section
                && let Some((k, _)) = l.split_once('=')
                && k.trim().trim_matches('"') == key
            {
                return i + 1;
            }
        }
        0
    }

    /// An error at `section.key`.
    pub fn err(&self, section: &str, key: &str, msg: impl Into<String>) -> ConfigError {
        let full = if section.is_empty() {
            key.to_string()
        } else {
            format!("{section}.{key}")
        };
        ConfigError {
            file: self.file.clone(),
            line: self.line_of(section, key),
            key: full,
            msg: msg.into(),
        }
    }

    /// A number (integers accepted) at `section.key`.
    pub fn number(&self, section: &str, key: &str, v: &toml::Value) -> Result<f64, ConfigError> {
        match v {
            toml::Value::Float(f) => Ok(*f),
            toml::Value::Integer(i) => Ok(*i as f64),
            other => Err(self.err(
                section,
                key,
                format!("expected a number in SI units, found {}", other.type_str()),
            )),
        }
    }
}

/// Applies the parameter-like keys of a table: model parameters by name, and `v_a` or
/// `va_ratio` as alternatives to `u0` (resolved after all parameters are set).
/// Returns the keys it did not recognise.
pub fn apply_params<'a>(
    doc: &Doc,
    section: &str,
    table: &'a toml::Table,
    p: &mut Params,
) -> Result<Vec<&'a str>, ConfigError> {
    let mut rest = Vec::new();
    let mut amplitude: Option<(&str, f64)> = None;
    for k in set_params(doc, section, table, p)? {
        if k == "v_a" || k == "va_ratio" {
            let v = &table[k];
            let x = doc.number(section, k, v)?;
            if let Some((other, _)) = amplitude {
                return Err(doc.err(
                    section,
                    k,
                    format!("give one of u0, v_a and va_ratio, not both `{other}` and `{k}`"),
                ));
            }
            amplitude = Some((k, x));
        } else {
            rest.push(k);
        }
    }
    if let Some((k, x)) = amplitude {
        if table.contains_key("u0") {
            return Err(doc.err(section, k, "give one of u0, v_a and va_ratio, not several"));
        }
        resolve_amplitude(p, k, x).map_err(|m| doc.err(section, k, m))?;
    }
    p.validate().map_err(|e| {
        let key = match &e {
            params::ParamError::OutOfRange { name, .. } => name.to_string(),
            params::ParamError::Unknown(n) => n.clone(),
        };
        doc.err(section, &key, e.to_string())
    })?;
    Ok(rest)
}

/// Sets the model parameters named in `table`, each checked against its own bound (relations
/// between parameters are left to [`Params::validate`]); returns the keys that are not
/// parameters.
pub fn set_params<'a>(
    doc: &Doc,
    section: &str,
    table: &'a toml::Table,
    p: &mut Params,
) -> Result<Vec<&'a str>, ConfigError> {
    let mut rest = Vec::new();
    for (k, v) in table {
        match params::info(k) {
            Some(info) => {
                let x = doc.number(section, k, v)?;
                info.check(x)
                    .map_err(|e| doc.err(section, k, e.to_string()))?;
                info.set(p, x);
            }
            None => rest.push(k.as_str()),
        }
    }
    Ok(rest)
}

/// Sets `u0` from `v_a` [m/s] or `va_ratio` (v_a / v_d), checking the value and that `f > 0`.
pub fn resolve_amplitude(p: &mut Params, key: &str, x: f64) -> Result<(), String> {
    if !(x.is_finite() && x >= 0.0) {
        return Err(format!(
            "{key} = {x} is not allowed: must be finite and >= 0"
        ));
    }
    if x > 0.0 && p.f.partial_cmp(&0.0) != Some(Ordering::Greater) {
        return Err(format!(
            "{key} = {x} needs a vibration frequency f > 0 Hz (f = {})",
            p.f
        ));
    }
    let v_a = if key == "va_ratio" { x * p.v_d } else { x };
    p.set_v_a(v_a);
    Ok(())
}

/// Applies a `[solver]` table.
pub fn apply_solver(doc: &Doc, table: &toml::Table, o: &mut RunOptions) -> Result<(), ConfigError> {
    let sec = "solver";
    for (k, v) in table {
        match k.as_str() {
            "method" => {
                let s = v.as_str().ok_or_else(|| {
                    doc.err(sec, k, "expected a string: radau5, rodas4, dopri5 or auto")
                })?;
                o.method = s.parse::<Method>().map_err(|e| doc.err(sec, k, e))?;
            }
            "rtol" => o.ode.rtol = doc.number(sec, k, v)?,
            "atol" => o.ode.atol = doc.number(sec, k, v)?,
            "h_max" => o.ode.h_max = doc.number(sec, k, v)?,
            "max_steps" => {
                let n = v
                    .as_integer()
                    .filter(|n| *n > 0)
                    .ok_or_else(|| doc.err(sec, k, "expected a whole number >= 1"))?;
                o.ode.max_steps = n as u64;
            }
            _ => {
                return Err(doc.err(
                    sec,
                    k,
                    "unknown key; allowed: method, rtol, atol, h_max, max_steps",
                ));
            }
        }
    }
    o.ode
        .validate()
        .map_err(|e| doc.err(sec, e.field, e.to_string()))
}

/// Applies a `[run]` table.
pub fn apply_run(doc: &Doc, table: &toml::Table, o: &mut RunOptions) -> Result<(), ConfigError> {
    let sec = "run";
    for (k, v) in table {
        match k.as_str() {
            "t_end" => o.t_end = Some(doc.number(sec, k, v)?),
            "min_cycles" => {
                let n = v
                    .as_integer()
                    .filter(|n| *n > 0 && *n <= 1000)
                    .ok_or_else(|| doc.err(sec, k, "expected a whole number from 1 to 1000"))?;
                o.min_cycles = n as u32;
            }
            "samples_per_period" => {
                let n = v
                    .as_integer()
                    .filter(|n| (4..=4096).contains(n))
                    .ok_or_else(|| doc.err(sec, k, "expected a whole number from 4 to 4096"))?;
                o.samples_per_period = n as usize;
            }
            "early_stop" => {
                o.early_stop = match (v.as_bool(), v.as_str()) {
                    (Some(true), _) => EarlyStop::Automatic,
                    (Some(false), _) => EarlyStop::Off,
                    (_, Some("always")) => EarlyStop::Always,
                    _ => {
                        return Err(doc.err(
                            sec,
                            k,
                            "expected true (automatic simulated time only), false or \"always\" \
                             (a given t_end is the longest time)",
                        ));
                    }
                };
            }
            "periodic" => {
                o.periodic = v
                    .as_bool()
                    .ok_or_else(|| doc.err(sec, k, "expected true or false"))?;
            }
            "tier" => {
                o.tier = v
                    .as_str()
                    .ok_or_else(|| {
                        doc.err(
                            sec,
                            k,
                            "expected \"auto\", \"averaged\", \"hybrid\" or \"full\"",
                        )
                    })?
                    .parse()
                    .map_err(|e: String| doc.err(sec, k, e))?;
            }
            "envelope" => {
                o.envelope = match v {
                    toml::Value::Boolean(false) => None,
                    toml::Value::Boolean(true) => Some(crate::sim::DEFAULT_ENVELOPE),
                    _ => Some(doc.number(sec, k, v)?),
                }
            }
            _ => {
                return Err(doc.err(
                    sec,
                    k,
                    "unknown key; allowed: t_end, min_cycles, samples_per_period, early_stop, \
                     periodic, envelope, tier",
                ));
            }
        }
    }
    o.validate()
        .map_err(|e| doc.err(sec, e.field, e.to_string()))
}

/// Applies an `[effects]` table: one sub-table per effect (`[effects.aging]` with `b = 0.03`),
/// an empty sub-table switching the effect on with its defaults.
pub fn apply_effects(doc: &Doc, table: &toml::Table, fx: &mut Effects) -> Result<(), ConfigError> {
    for (name, v) in table {
        let kind = EffectKind::from_name(name).ok_or_else(|| {
            doc.err(
                "effects",
                name,
                format!("unknown effect; allowed: {}", effects::names().join(", ")),
            )
        })?;
        let toml::Value::Table(t) = v else {
            return Err(doc.err(
                "effects",
                name,
                "expected a table of the effect's parameters, e.g. [effects.aging] b = 0.03",
            ));
        };
        fx.enable(kind);
        let sec = format!("effects.{name}");
        for (k, v) in t {
            // A form by name: `form = "velocity"`.
            if let toml::Value::String(name) = v
                && k == effects::form_param(kind)
            {
                fx.set_form(kind, name)
                    .map_err(|e| doc.err(&sec, k, e.to_string()))?;
                continue;
            }
            let x = doc.number(&sec, k, v)?;
            fx.set(kind, k, x)
                .map_err(|e| doc.err(&sec, k, e.to_string()))?;
        }
    }
    Ok(())
}

/// A case: parameters and run options.
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    /// Validated parameters.
    pub params: Params,
    /// Validated run options.
    pub run: RunOptions,
    /// Model extensions (`[effects.NAME]` tables).
    pub effects: Effects,
    /// The file it came from.
    pub path: Option<PathBuf>,
}

/// Reads a case file on top of the defaults.
pub fn load_case(path: &Path) -> Result<Case, ConfigError> {
    let doc = Doc::read(path)?;
    let mut p = Params::default();
    let mut o = RunOptions::default();
    let mut top = toml::Table::new();
    let mut fx = Effects::none();
    for (k, v) in &doc.table {
        match (k.as_str(), v) {
            ("effects", toml::Value::Table(t)) => apply_effects(&doc, t, &mut fx)?,
            ("solver", toml::Value::Table(t)) => apply_solver(&doc, t, &mut o)?,
            ("run", toml::Value::Table(t)) => apply_run(&doc, t, &mut o)?,
            _ => {
                top.insert(k.clone(), v.clone());
            }
        }
    }
    let rest = apply_params(&doc, "", &top, &mut p)?;
    if let Some(k) = rest.first() {
        return Err(doc.err(
            "",
            k,
            format!("unknown key; allowed: the parameters {}, v_a, va_ratio, and the tables [solver], [run] and [effects.NAME]", params::names().join(", ")),
        ));
    }
    Ok(Case {
        params: p,
        run: o,
        effects: fx,
        path: Some(path.to_path_buf()),
    })
}

/// The TOML text of a case or sweep given as JSON (a Python dict): tables and arrays of tables
/// as in a file; `null` is refused, since TOML has no such value.
pub fn toml_of_json(v: &serde_json::Value) -> Result<String, String> {
    fn convert(v: &serde_json::Value, at: &str) -> Result<toml::Value, String> {
        Ok(match v {
            serde_json::Value::Null => {
                return Err(format!("{at}: None has no TOML form; leave the key out"));
            }
            serde_json::Value::Bool(b) => toml::Value::Boolean(*b),
            serde_json::Value::Number(n) => match n.as_i64() {
                Some(i) => toml::Value::Integer(i),
                None => toml::Value::Float(n.as_f64().unwrap_or(f64::NAN)),
            },
            serde_json::Value::String(s) => toml::Value::String(s.clone()),
            serde_json::Value::Array(a) => toml::Value::Array(
                a.iter()
                    .enumerate()
                    .map(|(i, x)| convert(x, &format!("{at}[{i}]")))
                    .collect::<Result<_, _>>()?,
            ),
            serde_json::Value::Object(o) => toml::Value::Table(
                o.iter()
                    .map(|(k, x)| {
                        let here = if at.is_empty() {
                            k.clone()
                        } else {
                            format!("{at}.{k}")
                        };
                        convert(x, &here).map(|t| (k.clone(), t))
                    })
                    .collect::<Result<_, _>>()?,
            ),
        })
    }
    match convert(v, "")? {
        toml::Value::Table(t) => toml::to_string(&t).map_err(|e| e.to_string()),
        _ => Err("a sweep or case is a table (a dict) of keys and values".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Case, ConfigError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("case.toml");
        std::fs::write(&p, text).unwrap();
        load_case(&p)
    }

    #[test]
    fn a_full_case_file_is_read() {
        let c = parse("k_d = 10000\nv_d = 1e-3\nf = 1500.0\nv_a = 1.1e-3\n[solver]\nmethod = \"dopri5\"\nrtol = 1e-7\n[run]\nt_end = 3.0\n").unwrap();
        assert_eq!(c.params.k_d, 10000.0);
        assert!((c.params.v_a() - 1.1e-3).abs() < 1e-15);
        assert_eq!(c.run.method, Method::Dopri5);
        assert_eq!(c.run.ode.rtol, 1e-7);
        assert_eq!(c.run.t_end, Some(3.0));
    }

    #[test]
    fn errors_name_file_line_key_and_range() {
        let e = parse("v_d = 1e-3\n\nk_d = -5\n").unwrap_err();
        assert_eq!((e.line, e.key.as_str()), (3, "k_d"));
        assert!(
            e.to_string().contains("case.toml:3") && e.msg.contains("> 0"),
            "{e}"
        );
        let e = parse("k_d = 1e4\nfoo = 1\n").unwrap_err();
        assert_eq!((e.line, e.key.as_str()), (2, "foo"));
        let e = parse("[solver]\nrtol = 5.0\n").unwrap_err();
        assert_eq!((e.line, e.key.as_str()), (2, "solver.rtol"));
        assert!(e.msg.contains("0.1"), "{e}");
        let e = parse("u0 = 1e-7\nf = 0\n").unwrap_err();
        assert_eq!(e.key, "f");
        let e = parse("u0 = 1e-7\nv_a = 1e-3\n").unwrap_err();
        assert!(e.msg.contains("not several"), "{e}");
        let e = parse("k_d = \"stiff\"\n").unwrap_err();
        assert!(e.msg.contains("expected a number"), "{e}");
        let e = parse("k_d = = 3\n").unwrap_err();
        assert!(e.msg.contains("TOML") && e.line == 1, "{e}");
        let e = parse("[run]\nearly_stop = \"sometimes\"\n").unwrap_err();
        assert_eq!((e.line, e.key.as_str()), (2, "run.early_stop"));
        assert!(e.msg.contains("\"always\""), "{e}");
    }

    #[test]
    fn early_stop_is_on_off_or_always() {
        for (text, want) in [
            ("true", EarlyStop::Automatic),
            ("false", EarlyStop::Off),
            ("\"always\"", EarlyStop::Always),
        ] {
            let c = parse(&format!("[run]\nt_end = 3.0\nearly_stop = {text}\n")).unwrap();
            assert_eq!(c.run.early_stop, want, "{text}");
        }
        assert_eq!(parse("").unwrap().run.early_stop, EarlyStop::Automatic);
    }
}
