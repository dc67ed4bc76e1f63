//! Sweep files (TOML): axes, fixed parameters, solver, run policy, output choices.
//!
//! ```toml
//! name = "fig10"              # optional, default: the file's stem
//! description = "..."         # optional
//! max_runs = 20000            # cap on the grid's size (default 100 000)
//!
//! [fixed]                     # parameters held fixed (SI units), as in a case file
//! k_d = 11700.0
//! f = 1500.0
//!
//! [[axis]]                    # one table per axis; exactly one of values, linspace, logspace
//! name = "v_d"
//! values = [0.5e-3, 1.0e-3, 1.5e-3]
//!
//! [[axis]]
//! name = "va_ratio"           # derived: u0 = va_ratio · v_d / (2π f) per point
//! linspace = [0.0, 4.0, 41]   # start, stop, count
//!
//! [[axis]]
//! name = "f"
//! logspace = [50.0, 4000.0, 48]
//! zip = "u0"                  # optional: vary together with axis u0 (same length, one dimension)
//!
//! [solver]                    # as in a case file
//! [run]                       # as in a case file (tier = "auto" averages where valid)
//!
//! [check]                     # full-model checks of averaged points (crate::sweep::check)
//! share = 0.01                # random share re-run with the full model (default 0.01)
//! min_points = 100            # none in a sweep of fewer points with vibration (default 100)
//! band = 0.03                 # and every averaged point with |r - level| <= band (default 0.03)
//!
//! [output]
//! measures = ["r", "dF", "mean_force"]        # default: all
//! traces = [{ v_d = 0.5e-3, va_ratio = 0.5 }] # grid points (nearest) that keep their traces
//! ```
//!
//! Axis names are model parameters (`v_d`, `k_d`, `u0`, `f`, `F_s`, `h_d`, ...) or the derived
//! `v_a` [m/s] and `va_ratio` [-], which set `u0` per point.

use crate::config::{self, ConfigError, Doc};
use crate::measures::Measure;
use crate::model::{Params, params};
use crate::sim::RunOptions;
use std::path::Path;

/// Default cap on the number of grid points.
pub const DEFAULT_MAX_RUNS: usize = 100_000;
/// Largest `max_runs` a sweep file may set: ten million points (the plan holds the parameters
/// of each, about 1.4 GB).
pub const MAX_RUNS_LIMIT: usize = 10_000_000;

/// One axis of the grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Parameter name, `v_a` or `va_ratio`.
    pub name: String,
    /// Unit (SI).
    pub unit: &'static str,
    /// The values, computed by index.
    pub values: Vec<f64>,
    /// Another axis it is zipped with (varies together along one dimension).
    pub zip: Option<String>,
    /// `[start, stop, count]` and whether logarithmic, for a `linspace` or `logspace` axis.
    pub range: Option<(f64, f64, usize, bool)>,
}

/// Adaptive refinement of a level set of one measure (`[refine]`), such as the elimination
/// boundary `r = 0.05` of Fig. 11.
///
/// ```toml
/// [refine]
/// measure = "r"          # default "r"; any kept measure
/// level = 0.05           # default 0.05 (elimination, docs/model.md); > 0 for r, dF, their
///                        # errors and the period, within (0, 1) for the stick fraction
/// along = "u0"           # the axis refined: a linspace or logspace axis, not zipped
/// across = "f"           # the dimension whose values stay as given (the plane's other side)
/// resolution = 0.01      # finest step along `along`: relative on a logspace axis (0.01: 1 %),
///                        # in the axis unit on a linspace axis
/// tolerance = 0.03       # default 0: also refine cells with a value this close to the level
/// guided = true          # default true: columns between others start where their neighbours
///                        # cross the level
/// guide_planes = "k_d"   # optional: planes between others along this dimension start every
///                        # column where the neighbouring planes' same column crosses
/// ```
///
/// The `along` axis of the file is the coarse grid. Its steps are halved `levels` times, the
/// fewest that reach `resolution`, giving a dense axis of `(n − 1) 2^levels + 1` values (each
/// computed by index); only the points the refinement asks for are run. See
/// [`crate::sweep::refine`].
#[derive(Clone, Debug, PartialEq)]
pub struct Refine {
    /// Measure whose level set is refined (any but a count: [`Measure::refinable`]).
    pub measure: Measure,
    /// The level.
    pub level: f64,
    /// Index into [`SweepSpec::axes`] of the refined axis.
    pub along: usize,
    /// Index into [`SweepSpec::dims`] of the dimension across the plane (`None`: the sweep has
    /// no other dimension, and the refinement is along one line).
    pub across: Option<usize>,
    /// Requested finest step (relative on a logarithmic axis).
    pub resolution: f64,
    /// Cells with a corner within this distance of the level are refined too (default 0: only
    /// cells that straddle it).
    pub tolerance: f64,
    /// Columns between others (across) start their search where their neighbours' crossings
    /// interpolate (default true; see [`crate::sweep::refine`]). `false`: every column halves
    /// its steps alone.
    pub guided: bool,
    /// Index into [`SweepSpec::dims`] of a dimension (neither `along` nor `across`, at least
    /// three values) along which neighbouring planes guide each other (`guide_planes`, default
    /// none; see [`crate::sweep::refine`]): the planes at its first and last value refine alone,
    /// every other plane starts each column where the same column of two finished planes on
    /// either side crosses. A sweep with it is sharded by groups of planes along it.
    pub guide_planes: Option<usize>,
    /// Times the coarse steps are halved.
    pub levels: u32,
    /// Values of the coarse axis.
    pub coarse: usize,
}

impl Refine {
    /// Dense indices between two coarse values: `2^levels`.
    pub fn stride(&self) -> usize {
        1 << self.levels
    }
}

/// Most halvings of the coarse steps a refinement may ask for.
pub const MAX_REFINE_LEVELS: u32 = 16;
/// Most points of the dense grid of a refinement (the plan holds the parameters of each).
pub const MAX_DENSE_POINTS: usize = 4_000_000;

/// A dimension of the result arrays: one axis, or several zipped axes of equal length.
#[derive(Clone, Debug, PartialEq)]
pub struct Dim {
    /// The dimension's name: its first axis's name.
    pub name: String,
    /// Indices into [`SweepSpec::axes`].
    pub axes: Vec<usize>,
    /// Length.
    pub len: usize,
}

/// A grid point chosen to keep its traces, as axis values (matched to the nearest grid value).
#[derive(Clone, Debug, PartialEq)]
pub struct TraceSel(pub Vec<(String, f64)>);

/// A parsed, validated sweep.
#[derive(Clone, Debug)]
pub struct SweepSpec {
    /// Name (file stem by default).
    pub name: String,
    /// Free text.
    pub description: String,
    /// The sweep file's text, stored in the output.
    pub text: String,
    /// Fixed parameters (amplitude not yet resolved when it comes from `fixed_amplitude`).
    pub fixed: Params,
    /// `v_a` or `va_ratio` given in `[fixed]`, resolved per point.
    pub fixed_amplitude: Option<(String, f64)>,
    /// The axes in file order.
    pub axes: Vec<Axis>,
    /// The dimensions (zip groups), in file order of their first axis.
    pub dims: Vec<Dim>,
    /// Solver and run policy.
    pub run: RunOptions,
    /// Measures to keep.
    pub measures: Vec<Measure>,
    /// Points that keep traces.
    pub traces: Vec<TraceSel>,
    /// Cap on the grid size.
    pub max_runs: usize,
    /// Model extensions for every run (`[effects.NAME]` tables).
    pub effects: crate::model::Effects,
    /// Adaptive refinement (`[refine]`); the `along` axis then holds the dense values.
    pub refine: Option<Refine>,
    /// The names set in `[fixed]`, in file order.
    pub fixed_keys: Vec<String>,
    /// Full-model checks of the averaged points (`[check]`).
    pub check: CheckSpec,
}

/// The SI unit of an axis name (a parameter, `v_a` or `va_ratio`).
pub fn unit_of(name: &str) -> Option<&'static str> {
    match name {
        "v_a" => Some("m/s"),
        "va_ratio" => Some("1"),
        n => params::info(n).map(|i| i.unit),
    }
}

/// `count` values from `a` to `b` inclusive, linear, each computed from its index.
pub fn linspace(a: f64, b: f64, count: usize) -> Vec<f64> {
    (0..count)
        .map(|i| {
            if i == 0 {
                a
            } else if i == count - 1 {
                b
            } else {
                a + (b - a) * (i as f64 / (count - 1) as f64)
            }
        })
        .collect()
}

/// `count` values from `a` to `b` inclusive, geometric, each computed from its index.
pub fn logspace(a: f64, b: f64, count: usize) -> Vec<f64> {
    let (la, lb) = (a.ln(), b.ln());
    (0..count)
        .map(|i| {
            if i == 0 {
                a
            } else if i == count - 1 {
                b
            } else {
                (la + (lb - la) * (i as f64 / (count - 1) as f64)).exp()
            }
        })
        .collect()
}

/// The `[check]` table of a sweep file: the full-model checks of its averaged points
/// ([`check`](super::check) performs them). Every field documents its default and range.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckSpec {
    /// Share of the averaged points re-run with the full model, drawn at random (by the point's
    /// index). Default 0.01; range 0 to 1.
    pub share: f64,
    /// No random share in a sweep of fewer grid points with vibration than this (the boundary
    /// band is checked whatever the size). Default 100; set 0 to check small sweeps too.
    pub min_points: usize,
    /// Every averaged point with `|r − level| ≤ band` is checked. Default 0.03; range 0 to 1.
    pub band: f64,
}

impl Default for CheckSpec {
    fn default() -> Self {
        CheckSpec {
            share: 0.01,
            min_points: 100,
            band: 0.03,
        }
    }
}

impl CheckSpec {
    /// Reads a `[check]` table, naming the key, its value and what is allowed on error.
    pub fn parse(doc: &Doc, t: &toml::Table) -> Result<CheckSpec, ConfigError> {
        let sec = "check";
        let mut c = CheckSpec::default();
        for (k, v) in t {
            match k.as_str() {
                "share" => {
                    let x = doc.number(sec, k, v)?;
                    if !(0.0..=1.0).contains(&x) {
                        return Err(doc.err(sec, k, format!("{x}: must lie within 0 to 1")));
                    }
                    c.share = x;
                }
                "band" => {
                    let x = doc.number(sec, k, v)?;
                    if !(0.0..=1.0).contains(&x) {
                        return Err(doc.err(sec, k, format!("{x}: must lie within 0 to 1")));
                    }
                    c.band = x;
                }
                "min_points" => {
                    c.min_points = v
                        .as_integer()
                        .filter(|n| *n >= 0)
                        .ok_or_else(|| doc.err(sec, k, "expected a whole number, 0 or more"))?
                        as usize;
                }
                _ => {
                    return Err(doc.err(sec, k, "unknown key; allowed: share, min_points, band"));
                }
            }
        }
        Ok(c)
    }
}

impl SweepSpec {
    /// Reads and validates a sweep file.
    pub fn load(path: &Path) -> Result<SweepSpec, ConfigError> {
        let doc = Doc::read(path)?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "sweep".into());
        Self::from_doc(&doc, &stem)
    }

    /// Parses a sweep from TOML text (for tests); `file` is used in messages.
    pub fn parse(file: &str, text: &str) -> Result<SweepSpec, ConfigError> {
        let doc = Doc::parse(file, text.to_string())?;
        let stem = Path::new(file)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "sweep".into());
        Self::from_doc(&doc, &stem)
    }

    fn from_doc(doc: &Doc, stem: &str) -> Result<SweepSpec, ConfigError> {
        let mut spec = SweepSpec {
            name: stem.to_string(),
            description: String::new(),
            text: doc.text.clone(),
            fixed: Params::default(),
            fixed_amplitude: None,
            axes: vec![],
            dims: vec![],
            run: RunOptions::default(),
            measures: Measure::ALL.to_vec(),
            traces: vec![],
            max_runs: DEFAULT_MAX_RUNS,
            effects: crate::model::Effects::none(),
            refine: None,
            fixed_keys: vec![],
            check: CheckSpec::default(),
        };
        let mut refine: Option<&toml::Table> = None;
        let mut axis_tables: Vec<&toml::Table> = vec![];
        let mut output: Option<&toml::Table> = None;
        for (k, v) in &doc.table {
            match (k.as_str(), v) {
                ("name", toml::Value::String(s)) => {
                    // The name becomes the output's file stem under results/.
                    let stem_like = !s.is_empty()
                        && s != "."
                        && s != ".."
                        && !s.contains(['/', '\\'])
                        && !s.chars().any(char::is_control);
                    if !stem_like {
                        return Err(doc.err(
                            "",
                            k,
                            format!("name = {s:?} is not allowed: it names the output file results/<name>.h5, so it must be a non-empty file stem without / or \\"),
                        ));
                    }
                    spec.name = s.clone();
                }
                ("description", toml::Value::String(s)) => spec.description = s.clone(),
                ("max_runs", toml::Value::Integer(n))
                    if *n > 0 && (*n as u64) <= MAX_RUNS_LIMIT as u64 =>
                {
                    spec.max_runs = *n as usize
                }
                ("max_runs", _) => {
                    return Err(doc.err(
                        "",
                        k,
                        format!("expected a whole number from 1 to {MAX_RUNS_LIMIT}"),
                    ));
                }
                ("name" | "description", _) => return Err(doc.err("", k, "expected a string")),
                ("fixed", toml::Value::Table(t)) => spec.parse_fixed(doc, t)?,
                ("axis", toml::Value::Array(arr)) => {
                    for a in arr {
                        match a {
                            toml::Value::Table(t) => axis_tables.push(t),
                            _ => {
                                return Err(doc.err(
                                    "",
                                    "axis",
                                    "each axis must be a table: [[axis]]",
                                ));
                            }
                        }
                    }
                }
                ("solver", toml::Value::Table(t)) => config::apply_solver(doc, t, &mut spec.run)?,
                ("effects", toml::Value::Table(t)) => {
                    config::apply_effects(doc, t, &mut spec.effects)?
                }
                ("run", toml::Value::Table(t)) => config::apply_run(doc, t, &mut spec.run)?,
                ("output", toml::Value::Table(t)) => output = Some(t),
                ("refine", toml::Value::Table(t)) => refine = Some(t),
                ("check", toml::Value::Table(t)) => spec.check = CheckSpec::parse(doc, t)?,
                _ => {
                    return Err(doc.err(
                        "",
                        k,
                        "unknown key; allowed: name, description, max_runs, [fixed], [[axis]], [solver], [run], [output], [refine], [check], [effects.NAME]",
                    ));
                }
            }
        }
        for (i, t) in axis_tables.iter().enumerate() {
            spec.axes.push(parse_axis(doc, i, t, spec.max_runs)?);
        }
        if spec.axes.is_empty() {
            return Err(doc.err("", "axis", "a sweep needs at least one [[axis]]"));
        }
        spec.check_axes(doc)?;
        spec.build_dims(doc)?;
        if let Some(t) = output {
            spec.parse_output(doc, t)?;
        }
        let total: usize = spec.dims.iter().map(|d| d.len).product();
        if total > spec.max_runs {
            return Err(doc.err("", "max_runs", format!("the grid has {total} points, over the cap max_runs = {}; raise max_runs or shrink the axes", spec.max_runs)));
        }
        if let Some(t) = refine {
            spec.parse_refine(doc, t)?;
        }
        let total: usize = spec.dims.iter().map(|d| d.len).product();
        // Every point must be a valid case: check them all before anything runs.
        for i in 0..total {
            if let Err(msg) = spec.point_params(i) {
                let coords = spec.coords_text(i);
                return Err(doc.err(
                    "",
                    "axis",
                    format!("grid point {i} ({coords}) is not a valid case: {msg}"),
                ));
            }
        }
        Ok(spec)
    }

    /// Reads `[fixed]`: the parameters now; `v_a` / `va_ratio` are resolved per point, after
    /// the axes.
    fn parse_fixed(&mut self, doc: &Doc, t: &toml::Table) -> Result<(), ConfigError> {
        // Parameters now; v_a / va_ratio are resolved per point, after the axes.
        let mut plain = toml::Table::new();
        self.fixed_keys = t.keys().cloned().collect();
        for (fk, fv) in t {
            if fk == "v_a" || fk == "va_ratio" {
                let x = doc.number("fixed", fk, fv)?;
                if !(x.is_finite() && x >= 0.0) {
                    return Err(doc.err(
                        "fixed",
                        fk,
                        format!("{fk} = {x} is not allowed: must be finite and >= 0"),
                    ));
                }
                if self.fixed_amplitude.is_some() || t.contains_key("u0") {
                    return Err(doc.err("fixed", fk, "give one of u0, v_a and va_ratio"));
                }
                self.fixed_amplitude = Some((fk.clone(), x));
            } else {
                plain.insert(fk.clone(), fv.clone());
            }
        }
        // Relations (F_s >= F_c, f > 0 with u0 > 0) are checked per point, after the axes.
        let rest = config::set_params(doc, "fixed", &plain, &mut self.fixed)?;
        if let Some(bad) = rest.first() {
            return Err(doc.err(
                "fixed",
                bad,
                format!(
                    "unknown parameter; allowed: {}, v_a, va_ratio",
                    params::names().join(", ")
                ),
            ));
        }
        Ok(())
    }

    /// The dimension a key names, or an error naming the key and the dimensions there are.
    fn dim_named(&self, doc: &Doc, sec: &str, key: &str, name: &str) -> Result<usize, ConfigError> {
        self.dims
            .iter()
            .position(|d| d.name == name)
            .ok_or_else(|| {
                let names: Vec<&str> = self.dims.iter().map(|d| d.name.as_str()).collect();
                doc.err(
                    sec,
                    key,
                    format!(
                        "`{name}` is not a dimension of this sweep; dimensions: {}",
                        names.join(", ")
                    ),
                )
            })
    }

    /// The dimension `guide_planes = name` names, checked against the refined plane's sides
    /// `(along, across)` and `guided`.
    fn guide_plane(
        &self,
        doc: &Doc,
        name: &str,
        (d_along, across): (usize, Option<usize>),
        guided: bool,
    ) -> Result<usize, ConfigError> {
        let sec = "refine";
        let d = self.dim_named(doc, sec, "guide_planes", name)?;
        if d == d_along || Some(d) == across {
            return Err(doc.err(sec, "guide_planes", format!("guide_planes = `{name}` is a side of the refined plane (along or across); give another dimension")));
        }
        if !guided {
            return Err(doc.err(
                sec,
                "guide_planes",
                format!("guide_planes = `{name}` needs guided = true"),
            ));
        }
        let len = self.dims[d].len;
        if len < 3 {
            return Err(doc.err(sec, "guide_planes", format!("guide_planes = `{name}` has {len} values; planes are guided between its first and last, so it needs at least 3")));
        }
        Ok(d)
    }

    /// Reads `[refine]` and makes its axis dense (see [`Refine`]).
    fn parse_refine(&mut self, doc: &Doc, t: &toml::Table) -> Result<(), ConfigError> {
        let sec = "refine";
        let RefineKeys {
            measure,
            level,
            along,
            across,
            resolution,
            tolerance,
            guided,
            guide_planes,
        } = refine_keys(doc, t)?;
        let along = along.ok_or_else(|| {
            doc.err(
                sec,
                "along",
                "[refine] needs along = \"<axis>\", the axis to refine",
            )
        })?;
        let resolution = resolution.ok_or_else(|| {
            doc.err(
                sec,
                "resolution",
                "[refine] needs resolution = <finest step> (relative on a logspace axis)",
            )
        })?;
        let names = || {
            self.dims
                .iter()
                .map(|d| d.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let a = self
            .axes
            .iter()
            .position(|x| x.name == along)
            .ok_or_else(|| {
                doc.err(
                    sec,
                    "along",
                    format!("`{along}` is not an axis of this sweep; axes: {}", names()),
                )
            })?;
        let d_along = self
            .dims
            .iter()
            .position(|d| d.axes.contains(&a))
            .expect("every axis has a dimension");
        if self.dims[d_along].axes.len() > 1 {
            return Err(doc.err(
                sec,
                "along",
                format!("axis `{along}` is zipped with another; a refined axis must vary alone"),
            ));
        }
        let Some((start, stop, n, log)) = self.axes[a].range else {
            return Err(doc.err(sec, "along", format!("axis `{along}` is given by values; a refined axis must be a linspace or logspace")));
        };
        if n < 2 {
            return Err(doc.err(
                sec,
                "along",
                format!("axis `{along}` has {n} value; refinement needs at least 2"),
            ));
        }
        let dim_named = |key: &str, name: &str| self.dim_named(doc, sec, key, name);
        let across = match across {
            Some(name) => {
                let d = dim_named("across", &name)?;
                if d == d_along {
                    return Err(doc.err(
                        sec,
                        "across",
                        format!("across = `{name}` is the refined axis; give another dimension"),
                    ));
                }
                Some(d)
            }
            None if self.dims.len() == 1 => None,
            None => {
                return Err(doc.err(sec, "across", format!("[refine] needs across = \"<dimension>\", the plane's other side; dimensions: {}", names())));
            }
        };
        let guide_planes = match guide_planes {
            None => None,
            Some(name) => Some(self.guide_plane(doc, &name, (d_along, across), guided)?),
        };
        let levels = refine_levels(doc, (start, stop, n, log), resolution)?;
        let dense = (n - 1) * (1 << levels) + 1;
        let others: usize = self
            .dims
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != d_along)
            .map(|(_, d)| d.len)
            .product();
        let total = others.saturating_mul(dense);
        if total > MAX_DENSE_POINTS {
            return Err(doc.err(sec, "resolution", format!("the dense grid would have {total} points ({others} lines of {dense}), over the cap of {MAX_DENSE_POINTS}; coarsen the resolution or shrink the other axes")));
        }
        self.axes[a].values = if log {
            logspace(start, stop, dense)
        } else {
            linspace(start, stop, dense)
        };
        self.dims[d_along].len = dense;
        self.refine = Some(Refine {
            measure,
            level,
            along: a,
            across,
            resolution,
            tolerance,
            guided,
            guide_planes,
            levels,
            coarse: n,
        });
        Ok(())
    }

    /// Index of the dimension of the refined axis.
    pub fn along_dim(&self) -> Option<usize> {
        let rf = self.refine.as_ref()?;
        self.dims.iter().position(|d| d.axes.contains(&rf.along))
    }

    fn check_axes(&self, doc: &Doc) -> Result<(), ConfigError> {
        let amp: Vec<&Axis> = self
            .axes
            .iter()
            .filter(|a| matches!(a.name.as_str(), "u0" | "v_a" | "va_ratio"))
            .collect();
        if amp.len() > 1 {
            return Err(doc.err(
                "",
                "axis",
                format!(
                    "axes `{}` and `{}` both set the amplitude u0; keep one",
                    amp[0].name, amp[1].name
                ),
            ));
        }
        if let (Some(axis), Some(fixed)) = (amp.first(), self.fixed_amplitude.as_ref()) {
            return Err(doc.err(
                "fixed",
                &fixed.0,
                format!(
                    "the axis `{}` sets the amplitude; remove it from [fixed]",
                    axis.name
                ),
            ));
        }
        // Nothing is set twice: a fixed value next to an axis would be silently overruled.
        let amplitude = |n: &str| matches!(n, "u0" | "v_a" | "va_ratio");
        for a in &self.axes {
            if let Some(k) = self
                .fixed_keys
                .iter()
                .find(|k| **k == a.name || (amplitude(k) && amplitude(&a.name)))
            {
                return Err(doc.err(
                    "fixed",
                    k,
                    format!(
                        "`{k}` in [fixed] and the axis `{}` both set {}; remove one",
                        a.name,
                        if amplitude(k) {
                            "the amplitude u0"
                        } else {
                            "it"
                        }
                    ),
                ));
            }
        }
        for (i, a) in self.axes.iter().enumerate() {
            if self.axes[..i].iter().any(|b| b.name == a.name) {
                return Err(doc.err("", "axis", format!("axis `{}` appears twice", a.name)));
            }
        }
        Ok(())
    }

    fn build_dims(&mut self, doc: &Doc) -> Result<(), ConfigError> {
        // Union of zip links, in file order.
        let n = self.axes.len();
        let mut group: Vec<usize> = (0..n).collect();
        for i in 0..n {
            if let Some(z) = &self.axes[i].zip {
                let j = self.axes.iter().position(|a| &a.name == z).ok_or_else(|| {
                    doc.err(
                        "",
                        "axis",
                        format!(
                            "axis `{}` zips with `{z}`, which is not an axis",
                            self.axes[i].name
                        ),
                    )
                })?;
                if self.axes[i].values.len() != self.axes[j].values.len() {
                    return Err(doc.err("", "axis", format!("zipped axes `{}` ({} values) and `{z}` ({} values) must have the same length", self.axes[i].name, self.axes[i].values.len(), self.axes[j].values.len())));
                }
                let (gi, gj) = (group[i], group[j]);
                let g = gi.min(gj);
                for x in group.iter_mut() {
                    if *x == gi || *x == gj {
                        *x = g;
                    }
                }
            }
        }
        for i in 0..n {
            if group[i] == i {
                let axes: Vec<usize> = (0..n).filter(|&k| group[k] == i).collect();
                self.dims.push(Dim {
                    name: self.axes[i].name.clone(),
                    len: self.axes[i].values.len(),
                    axes,
                });
            }
        }
        Ok(())
    }

    fn parse_output(&mut self, doc: &Doc, t: &toml::Table) -> Result<(), ConfigError> {
        for (k, v) in t {
            match k.as_str() {
                "measures" => {
                    let arr = v
                        .as_array()
                        .ok_or_else(|| doc.err("output", k, "expected a list of measure names"))?;
                    let mut list = vec![];
                    for m in arr {
                        let s = m.as_str().and_then(Measure::from_name).ok_or_else(|| {
                            doc.err(
                                "output",
                                k,
                                format!(
                                    "unknown measure {m}; allowed: {}",
                                    Measure::names(&Measure::ALL)
                                ),
                            )
                        })?;
                        list.push(s);
                    }
                    self.measures = list;
                }
                "traces" => {
                    let arr = v.as_array().ok_or_else(|| {
                        doc.err(
                            "output",
                            k,
                            "expected a list of points, e.g. [{ v_d = 0.5e-3, va_ratio = 0.5 }]",
                        )
                    })?;
                    for pt in arr {
                        let tbl = pt.as_table().ok_or_else(|| {
                            doc.err("output", k, "each point is an inline table of axis values")
                        })?;
                        let mut sel = vec![];
                        for (ak, av) in tbl {
                            if !self.axes.iter().any(|a| &a.name == ak) {
                                return Err(doc.err(
                                    "output",
                                    k,
                                    format!("`{ak}` is not an axis of this sweep"),
                                ));
                            }
                            let x = doc.number("output", k, av)?;
                            // A trace point is a grid point: off the axis's range it is refused,
                            // not moved to the nearest end.
                            let vals = &self
                                .axes
                                .iter()
                                .find(|a| &a.name == ak)
                                .expect("checked above")
                                .values;
                            let (lo, hi) = vals
                                .iter()
                                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                                    (l.min(*v), h.max(*v))
                                });
                            let slack = 1e-9 * lo.abs().max(hi.abs());
                            if !(x >= lo - slack && x <= hi + slack) {
                                return Err(doc.err(
                                    "output",
                                    k,
                                    format!("trace point {ak} = {x} lies outside the axis ({lo} to {hi}); give a point of the grid"),
                                ));
                            }
                            sel.push((ak.clone(), x));
                        }
                        self.traces.push(TraceSel(sel));
                    }
                }
                _ => return Err(doc.err("output", k, "unknown key; allowed: measures, traces")),
            }
        }
        Ok(())
    }

    /// Shape of the result arrays.
    pub fn shape(&self) -> Vec<usize> {
        self.dims.iter().map(|d| d.len).collect()
    }

    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.shape().iter().product()
    }

    /// Whether the grid is empty (never, for a validated spec).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The multi-index of flat point `i` (C order: the last dimension varies fastest).
    pub fn unravel(&self, mut i: usize) -> Vec<usize> {
        let shape = self.shape();
        let mut idx = vec![0; shape.len()];
        for d in (0..shape.len()).rev() {
            idx[d] = i % shape[d];
            i /= shape[d];
        }
        idx
    }

    /// The axis values of point `i`, in axis order.
    pub fn point_values(&self, i: usize) -> Vec<(String, f64)> {
        let idx = self.unravel(i);
        let mut out = vec![];
        for (d, dim) in self.dims.iter().enumerate() {
            for &a in &dim.axes {
                out.push((self.axes[a].name.clone(), self.axes[a].values[idx[d]]));
            }
        }
        out
    }

    fn coords_text(&self, i: usize) -> String {
        self.point_values(i)
            .iter()
            .map(|(n, v)| format!("{n} = {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The validated parameters of point `i`.
    pub fn point_params(&self, i: usize) -> Result<Params, String> {
        let mut p = self.fixed;
        let mut amp = self.fixed_amplitude.clone();
        for (name, v) in self.point_values(i) {
            match name.as_str() {
                "v_a" | "va_ratio" => amp = Some((name, v)),
                _ => p.set(&name, v).map_err(|e| e.to_string())?,
            }
        }
        if let Some((k, x)) = amp {
            config::resolve_amplitude(&mut p, &k, x)?;
        }
        p.validate().map_err(|e| e.to_string())?;
        // The relations of the point with the run's options (t_on before the end, the work
        // budget), as `run` checks them.
        crate::sim::end_time(&p, &self.run).map_err(|e| e.to_string())?;
        Ok(p)
    }

    /// Flat indices of the points that keep traces (nearest grid value on each named axis; the
    /// first value on unnamed ones).
    pub fn trace_points(&self) -> Vec<usize> {
        let mut out = vec![];
        for sel in &self.traces {
            let mut idx = vec![0usize; self.dims.len()];
            for (name, v) in &sel.0 {
                for (d, dim) in self.dims.iter().enumerate() {
                    if let Some(&a) = dim.axes.iter().find(|&&a| &self.axes[a].name == name) {
                        let vals = &self.axes[a].values;
                        let best = (0..vals.len())
                            .min_by(|&x, &y| (vals[x] - v).abs().total_cmp(&(vals[y] - v).abs()))
                            .unwrap_or(0);
                        idx[d] = best;
                    }
                }
            }
            let flat = idx
                .iter()
                .zip(self.shape())
                .fold(0, |acc, (i, n)| acc * n + i);
            if !out.contains(&flat) {
                out.push(flat);
            }
        }
        out
    }
}

/// The line of `key` in the `i`-th `[[axis]]` table of `doc` (that table's header where the
/// key is not written; 0 where there is no such table).
fn axis_key_line(doc: &Doc, i: usize, key: &str) -> usize {
    let mut seen = 0;
    let mut line = 0;
    let mut inside = false;
    for (n, l) in doc.text.lines().enumerate() {
        let l = l.trim();
        if l.starts_with("[[axis]]") {
            inside = seen == i;
            seen += 1;
            if inside {
                line = n + 1;
            }
            continue;
        }
        if l.starts_with('[') {
            inside = false;
        }
        if inside
            && l.split_once('=')
                .map(|(k, _)| k.trim() == key)
                .unwrap_or(false)
        {
            line = n + 1;
            break;
        }
    }
    line
}

fn parse_axis(doc: &Doc, i: usize, t: &toml::Table, max_runs: usize) -> Result<Axis, ConfigError> {
    let sec = format!("axis[{i}]");
    let here = |key: &str, msg: String| ConfigError {
        file: doc.file.clone(),
        line: axis_key_line(doc, i, key),
        key: format!("{sec}.{key}"),
        msg,
    };
    let name = t
        .get("name")
        .and_then(|v| v.as_str())
        .ok_or_else(|| here("name", "each axis needs name = \"<parameter>\"".into()))?;
    let unit = unit_of(name).ok_or_else(|| {
        here(
            "name",
            format!(
                "unknown axis `{name}`; allowed: the parameters {}, v_a, va_ratio",
                params::names().join(", ")
            ),
        )
    })?;
    let mut values: Option<Vec<f64>> = None;
    let mut range = None;
    let mut zip = None;
    let nums = |key: &str, v: &toml::Value| -> Result<Vec<f64>, ConfigError> {
        let arr = v
            .as_array()
            .ok_or_else(|| here(key, "expected a list of numbers".into()))?;
        arr.iter()
            .map(|x| match x {
                toml::Value::Float(f) => Ok(*f),
                toml::Value::Integer(n) => Ok(*n as f64),
                other => Err(here(
                    key,
                    format!("expected numbers, found {}", other.type_str()),
                )),
            })
            .collect()
    };
    for (k, v) in t {
        let kind = k.as_str();
        match kind {
            "name" => {}
            "zip" => {
                zip = Some(
                    v.as_str()
                        .ok_or_else(|| here(kind, "expected the name of another axis".into()))?
                        .to_string(),
                )
            }
            "values" | "linspace" | "logspace" => {
                if values.is_some() {
                    return Err(here(
                        kind,
                        "give exactly one of values, linspace, logspace".into(),
                    ));
                }
                let x = nums(kind, v)?;
                let vals = if kind == "values" {
                    if x.is_empty() {
                        return Err(here(
                            kind,
                            "the list is empty; an axis needs at least one value".into(),
                        ));
                    }
                    x
                } else {
                    let (a, b, n) = match x.as_slice() {
                        [a, b, n] if *n >= 1.0 && n.fract() == 0.0 => (*a, *b, *n as usize),
                        _ => {
                            return Err(here(
                                kind,
                                format!(
                                    "expected [start, stop, count] with a whole count >= 1, found {x:?}"
                                ),
                            ));
                        }
                    };
                    if !(a.is_finite() && b.is_finite()) {
                        return Err(here(kind, "start and stop must be finite".into()));
                    }
                    // Before any allocation: one axis alone over the cap is refused.
                    if n > max_runs {
                        return Err(here(
                            kind,
                            format!(
                                "count {n} is over the cap max_runs = {max_runs} (the grid cannot be smaller than one axis); raise max_runs or lower the count"
                            ),
                        ));
                    }
                    range = Some((a, b, n, kind == "logspace"));
                    if kind == "logspace" {
                        if !(a > 0.0 && b > 0.0) {
                            return Err(here(
                                kind,
                                format!(
                                    "a logarithmic range needs start and stop > 0, found [{a}, {b}]"
                                ),
                            ));
                        }
                        logspace(a, b, n)
                    } else {
                        linspace(a, b, n)
                    }
                };
                for &val in &vals {
                    // Each parameter's own bound (the amplitude ratios may be 0).
                    let zero_ok = matches!(name, "va_ratio" | "v_a")
                        || crate::model::params::info(name)
                            .is_some_and(|i| i.bound == crate::model::params::Bound::NonNegative);
                    let ok = val.is_finite() && (val > 0.0 || (zero_ok && val == 0.0));
                    if !ok {
                        return Err(here(
                            kind,
                            format!("value {val} {unit} is out of range for `{name}`"),
                        ));
                    }
                }
                values = Some(vals);
            }
            _ => {
                return Err(here(
                    kind,
                    "unknown key; allowed: name, values, linspace, logspace, zip".into(),
                ));
            }
        }
    }
    let values = values.ok_or_else(|| {
        here(
            "name",
            format!("axis `{name}` needs one of values, linspace, logspace"),
        )
    })?;
    Ok(Axis {
        name: name.to_string(),
        unit,
        values,
        zip,
        range,
    })
}

/// The halvings of a refined axis's coarse step (`start` to `stop` over `n` values, `log` or
/// linear) that reach `resolution` (relative on a log axis), at most [`MAX_REFINE_LEVELS`].
fn refine_levels(
    doc: &Doc,
    (start, stop, n, log): (f64, f64, usize, bool),
    resolution: f64,
) -> Result<u32, ConfigError> {
    let sec = "refine";
    // The coarse step against the resolution, in the axis's own spacing.
    let (step, fine) = if log {
        (
            (stop / start).ln().abs() / (n - 1) as f64,
            resolution.ln_1p(),
        )
    } else {
        ((stop - start).abs() / (n - 1) as f64, resolution)
    };
    let levels = (step / fine).log2().ceil().max(0.0);
    if levels > MAX_REFINE_LEVELS as f64 {
        return Err(doc.err(sec, "resolution", format!("resolution = {resolution} needs {levels} halvings of the coarse step; at most {MAX_REFINE_LEVELS} are allowed: coarsen the resolution or add values to the axis")));
    }
    Ok(levels as u32)
}

/// The keys of a `[refine]` table, each checked alone (their relations to the axes are
/// [`SweepSpec::parse_refine`]'s).
struct RefineKeys {
    measure: Measure,
    level: f64,
    along: Option<String>,
    across: Option<String>,
    resolution: Option<f64>,
    tolerance: f64,
    guided: bool,
    guide_planes: Option<String>,
}

/// Reads the keys of `[refine]`; unset: `measure` r, `level` 0.05, `tolerance` 0, `guided`.
fn refine_keys(doc: &Doc, t: &toml::Table) -> Result<RefineKeys, ConfigError> {
    let sec = "refine";
    let mut measure = Measure::R;
    let mut level = 0.05;
    let mut along: Option<String> = None;
    let mut across: Option<String> = None;
    let mut resolution: Option<f64> = None;
    let mut tolerance = 0.0;
    let mut guided = true;
    let mut guide_planes: Option<String> = None;
    for (k, v) in t {
        match k.as_str() {
            "measure" => {
                let m = v
                    .as_str()
                    .ok_or_else(|| doc.err(sec, k, "expected the name of a measure"))?;
                let refinable: Vec<Measure> =
                    Measure::ALL.into_iter().filter(|m| m.refinable()).collect();
                measure = Measure::from_name(m)
                    .filter(|m| m.refinable())
                    .ok_or_else(|| {
                        doc.err(
                            sec,
                            k,
                            format!(
                                "unknown measure `{m}`; allowed: {}",
                                Measure::names(&refinable)
                            ),
                        )
                    })?;
            }
            "level" => {
                level = doc.number(sec, k, v)?;
                if !level.is_finite() {
                    return Err(doc.err(sec, k, format!("level = {level}: must be finite")));
                }
            }
            "along" | "across" => {
                let name = v
                    .as_str()
                    .ok_or_else(|| doc.err(sec, k, "expected the name of an axis"))?;
                if k == "along" {
                    along = Some(name.to_string());
                } else {
                    across = Some(name.to_string());
                }
            }
            "resolution" => {
                let r = doc.number(sec, k, v)?;
                if !(r.is_finite() && r > 0.0) {
                    return Err(doc.err(
                        sec,
                        k,
                        format!("resolution = {r} is not allowed: must be finite and > 0"),
                    ));
                }
                resolution = Some(r);
            }
            "tolerance" => {
                tolerance = doc.number(sec, k, v)?;
                if !(tolerance.is_finite() && tolerance >= 0.0) {
                    return Err(doc.err(
                        sec,
                        k,
                        format!("tolerance = {tolerance} is not allowed: must be finite and >= 0"),
                    ));
                }
            }
            "guided" => {
                guided = v.as_bool().ok_or_else(|| {
                    doc.err(
                        sec,
                        k,
                        format!("guided = {v} is not allowed: must be true or false"),
                    )
                })?;
            }
            "guide_planes" => {
                let name = v
                    .as_str()
                    .ok_or_else(|| doc.err(sec, k, "expected the name of a dimension"))?;
                guide_planes = Some(name.to_string());
            }
            _ => {
                return Err(doc.err(
                    sec,
                    k,
                    "unknown key; allowed: measure, level, along, across, resolution, tolerance, guided, guide_planes",
                ));
            }
        }
    }
    // A level the measure never crosses refines nothing: r, dF, their errors and the period
    // are never negative and a stick fraction lies within 0 to 1; the boundary of such a
    // measure lies strictly inside its range.
    let range = measure.level_range();
    if let Some((lo, hi, rule)) = range
        && !(level > lo && level < hi)
    {
        return Err(doc.err(
            sec,
            "level",
            format!(
                "level = {level}: {} never crosses it, so nothing would be refined; \
                 allowed: {rule}",
                measure.name()
            ),
        ));
    }
    Ok(RefineKeys {
        measure,
        level,
        along,
        across,
        resolution,
        tolerance,
        guided,
        guide_planes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effects_tables_apply_to_every_point() {
        let text = "[fixed]\nv_d = 1e-3\n[[axis]]\nname = \"k_d\"\nvalues = [5000, 10000]\n[effects.aging]\nb = 0.02\n[effects.viscous]\n";
        let s = SweepSpec::parse("fx.toml", text).unwrap();
        assert_eq!(
            s.effects.get(crate::model::EffectKind::Aging, "b"),
            Some(0.02)
        );
        assert_eq!(
            s.effects.get(crate::model::EffectKind::Viscous, "h_v"),
            Some(50.0)
        );
        let e = SweepSpec::parse("fx.toml", "[effects.aging]\nb = 3\n").unwrap_err();
        assert_eq!((e.line, e.key.as_str()), (2, "effects.aging.b"), "{e}");
        let e = SweepSpec::parse("fx.toml", "[effects.wear]\n").unwrap_err();
        assert!(e.msg.contains("unknown effect"), "{e}");
    }

    /// Nothing contradictory is silently resolved: a fixed value next to an axis that sets it,
    /// and a trace point off the grid, are refused with the key and its line.
    #[test]
    fn contradictions_are_refused() {
        let e = SweepSpec::parse(
            "s.toml",
            "[fixed]\nk_d = 5000.0\n[[axis]]\nname = \"k_d\"\nvalues = [1e4, 2e4]\n",
        )
        .unwrap_err();
        assert!(
            e.key == "fixed.k_d" && e.line == 2 && e.msg.contains("remove one"),
            "{e}"
        );
        let e = SweepSpec::parse(
            "s.toml",
            "[fixed]\nu0 = 1e-7\n[[axis]]\nname = \"v_a\"\nvalues = [1e-4, 2e-4]\n",
        )
        .unwrap_err();
        assert!(e.key == "fixed.u0" && e.msg.contains("amplitude"), "{e}");
        let e = SweepSpec::parse(
            "s.toml",
            "[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 3]\n[output]\ntraces = [{ u0 = 5.0 }]\n",
        )
        .unwrap_err();
        assert!(
            e.key == "output.traces" && e.msg.contains("outside the axis"),
            "{e}"
        );
        // On the grid (to round-off) it is taken.
        let s = SweepSpec::parse(
            "s.toml",
            "[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 3]\n[output]\ntraces = [{ u0 = 1e-6 }]\n",
        )
        .unwrap();
        assert_eq!(s.trace_points(), vec![2]);
    }

    #[test]
    fn grids_are_computed_by_index_with_exact_ends() {
        let v = linspace(0.0, 4.0, 41);
        assert_eq!(v.len(), 41);
        assert_eq!(v[0], 0.0);
        assert_eq!(v[40], 4.0);
        assert_eq!(v[10], 1.0);
        let l = logspace(50.0, 4000.0, 48);
        assert_eq!((l[0], l[47]), (50.0, 4000.0));
        for w in l.windows(2) {
            assert!((w[1] / w[0] - (80f64).powf(1.0 / 47.0)).abs() < 1e-12);
        }
    }

    #[test]
    fn a_sweep_with_derived_and_zipped_axes_expands() {
        let s = SweepSpec::parse(
            "t.toml",
            "[fixed]\nk_d = 11700\nf = 1500\n[[axis]]\nname = \"v_d\"\nvalues = [0.5e-3, 1e-3]\n[[axis]]\nname = \"va_ratio\"\nlinspace = [0, 2, 3]\n[[axis]]\nname = \"F_s\"\nvalues = [11, 12]\n[[axis]]\nname = \"h_d\"\nvalues = [0, 5]\nzip = \"F_s\"\n",
        )
        .unwrap();
        assert_eq!(s.shape(), vec![2, 3, 2]);
        assert_eq!(s.dims[2].name, "F_s");
        assert_eq!(s.dims[2].axes.len(), 2);
        // Point (v_d = 1e-3, va_ratio = 2, F_s = 12 & h_d = 5): the last one.
        let p = s.point_params(11).unwrap();
        assert_eq!((p.v_d, p.f_s, p.h_d), (1e-3, 12.0, 5.0));
        assert!((p.v_a() - 2e-3).abs() < 1e-15);
        assert_eq!(s.point_params(0).unwrap().u0, 0.0);
    }

    #[test]
    fn errors_name_file_line_key_and_allowed() {
        let e = SweepSpec::parse(
            "s.toml",
            "[[axis]]\nname = \"v_d\"\nlinspace = [1e-3, 2e-3, 0]\n",
        )
        .unwrap_err();
        assert_eq!((e.line, e.key.as_str()), (3, "axis[0].linspace"));
        let e =
            SweepSpec::parse("s.toml", "[[axis]]\nname = \"speed\"\nvalues = [1]\n").unwrap_err();
        assert!(e.msg.contains("unknown axis") && e.line == 2, "{e}");
        let e = SweepSpec::parse("s.toml", "[[axis]]\nname = \"v_d\"\nvalues = []\n").unwrap_err();
        assert!(e.msg.contains("empty"), "{e}");
        let e = SweepSpec::parse("s.toml", "[[axis]]\nname = \"f\"\nlogspace = [0, 100, 5]\n")
            .unwrap_err();
        assert!(e.msg.contains("> 0"), "{e}");
        let e = SweepSpec::parse(
            "s.toml",
            "max_runs = 10\n[[axis]]\nname = \"v_d\"\nlinspace = [1e-4, 2e-3, 4]\n[[axis]]\nname = \"k_d\"\nlinspace = [1e3, 2e4, 4]\n",
        )
        .unwrap_err();
        assert!(
            e.msg.contains("16 points") && e.key == "max_runs" && e.line == 1,
            "{e}"
        );
        // One axis over the cap is refused before its values are made.
        let e = SweepSpec::parse(
            "s.toml",
            "max_runs = 10\n[[axis]]\nname = \"v_d\"\nlinspace = [1e-4, 2e-3, 11]\n",
        )
        .unwrap_err();
        assert!(
            e.msg.contains("count 11") && e.key == "axis[0].linspace" && e.line == 4,
            "{e}"
        );
        let e = SweepSpec::parse(
            "s.toml",
            "[fixed]\nk_d = -1\n[[axis]]\nname = \"v_d\"\nvalues = [1e-3]\n",
        )
        .unwrap_err();
        assert!(e.key == "fixed.k_d" && e.line == 2, "{e}");
        let e = SweepSpec::parse(
            "s.toml",
            "[[axis]]\nname = \"va_ratio\"\nvalues = [1]\n[fixed]\nf = 0\n",
        )
        .unwrap_err();
        assert!(e.msg.contains("grid point 0"), "{e}");
        let e = SweepSpec::parse(
            "s.toml",
            "speed = 3\n[[axis]]\nname = \"v_d\"\nvalues = [1e-3]\n",
        )
        .unwrap_err();
        assert!(e.key == "speed" && e.line == 1, "{e}");
        let e = SweepSpec::parse(
            "s.toml",
            "[[axis]]\nname = \"v_d\"\nvalues = [1e-3]\n[output]\nmeasures = [\"r\", \"q\"]\n",
        )
        .unwrap_err();
        assert!(e.key == "output.measures" && e.line == 5, "{e}");
    }
}
