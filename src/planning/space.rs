//! The design space of a plan: which recordings the rig can make. By default the campaign's
//! own ranges; a `--space` TOML file widens or narrows them. Nothing outside the space is
//! proposed: every candidate recording is built from it ([`Space::candidates`]) and checked
//! against it ([`Space::admits`]).

use crate::campaign::{Campaign, Recording};
use crate::config::{Doc, MAX_TOML_BYTES};
use crate::model::Params;
use std::f64::consts::TAU;
use std::path::Path;

/// Drive velocities of a default grid where the campaign recorded more than this many.
pub const V_D_LEVELS: usize = 4;
/// Vibration frequencies of the grid: log-spaced over the space's range, ends included.
pub const F_LEVELS: usize = 4;
/// Vibration amplitudes of the grid (as `v_a/v_d`): log-spaced over the range, ends included.
pub const RATIO_LEVELS: usize = 3;

/// What recordings the rig can make.
#[derive(Clone, Debug, PartialEq)]
pub struct Space {
    /// The springs available, `k_d` \[N/m\]: a rig changes springs, it does not tune them.
    pub springs: Vec<f64>,
    /// Drive velocities, `(lowest, highest)` \[m/s\].
    pub v_d: (f64, f64),
    /// Where the campaign recorded few drive velocities: those, rather than a grid over
    /// [`Space::v_d`] (empty: a log-spaced grid of [`V_D_LEVELS`]).
    pub v_d_levels: Vec<f64>,
    /// Vibration frequencies, `(lowest, highest)` \[Hz\]; `None`: no vibrated recording.
    pub f: Option<(f64, f64)>,
    /// Vibration velocity amplitudes as a share of the drive velocity, `(lowest, highest)`.
    pub va_ratio: (f64, f64),
    /// The actuator's limit: the largest displacement amplitude `u0` \[m\] at each frequency,
    /// as `(f, u0_max)` points, interpolated log-log between them and held flat beyond.
    pub max_u0: Vec<(f64, f64)>,
    /// The longest recording \[s\].
    pub max_duration: f64,
    /// Sampling rate \[Hz\].
    pub rate: f64,
    /// Where the campaign switches the vibration on within a recording (the paper's two-stage
    /// tests), the time it does \[s\]; `None`: vibrated from the start.
    pub t_on: Option<f64>,
}

/// A bad design space (`--space` file, or a campaign that gives none).
#[derive(Debug)]
pub struct SpaceError {
    /// The file (or the campaign directory).
    pub file: String,
    /// The key.
    pub field: String,
    /// The value given.
    pub value: String,
    /// What is allowed.
    pub allowed: String,
}

impl std::fmt::Display for SpaceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // A file that cannot be read or parsed has no key to name.
        if self.field == "file" {
            match self.allowed.starts_with(&self.file) {
                true => write!(f, "{}", self.allowed),
                false => write!(f, "{}: {}", self.file, self.allowed),
            }
        } else {
            write!(
                f,
                "{}: `{}` = {}: {}",
                self.file, self.field, self.value, self.allowed
            )
        }
    }
}

impl std::error::Error for SpaceError {}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn distinct(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
    v
}

fn rate_of(r: &Recording) -> f64 {
    1.0 / r.dt()
}

fn duration_of(r: &Recording) -> f64 {
    r.t[r.t.len() - 1] - r.t[0]
}

impl Space {
    /// The campaign's own ranges: its springs, its drive velocities (the ones it recorded
    /// where they are at most [`V_D_LEVELS`]), the frequencies and amplitudes of its vibrated
    /// recordings (the largest `u0` it recorded as the actuator's limit at every frequency),
    /// its longest recording, its median sampling rate, and its median `t_on` where it has
    /// two-stage recordings.
    pub fn of(c: &Campaign) -> Space {
        let recs = &c.recordings;
        let springs = distinct(recs.iter().map(|r| r.params.k_d).collect());
        let vds = distinct(recs.iter().map(|r| r.params.v_d).collect());
        let vib: Vec<&Recording> = recs.iter().filter(|r| r.vibrates()).collect();
        let f = (!vib.is_empty()).then(|| {
            let fs: Vec<f64> = vib.iter().map(|r| r.params.f).collect();
            (
                fs.iter().copied().fold(f64::INFINITY, f64::min),
                fs.iter().copied().fold(0.0, f64::max),
            )
        });
        let ratios: Vec<f64> = vib.iter().map(|r| r.params.v_a() / r.params.v_d).collect();
        let va_ratio = if ratios.is_empty() {
            (0.0, 0.0)
        } else {
            (
                ratios.iter().copied().fold(f64::INFINITY, f64::min),
                ratios.iter().copied().fold(0.0, f64::max),
            )
        };
        let u0_max = vib.iter().map(|r| r.params.u0).fold(0.0, f64::max);
        let t_ons: Vec<f64> = vib
            .iter()
            .filter(|r| r.params.two_stage())
            .map(|r| r.params.t_on)
            .collect();
        Space {
            springs,
            v_d: (vds[0], vds[vds.len() - 1]),
            v_d_levels: if vds.len() <= V_D_LEVELS { vds } else { vec![] },
            f,
            va_ratio,
            max_u0: if u0_max > 0.0 {
                vec![(1.0, u0_max)]
            } else {
                vec![]
            },
            max_duration: recs.iter().map(duration_of).fold(0.0, f64::max),
            rate: median(recs.iter().map(rate_of).collect()),
            t_on: (!t_ons.is_empty()).then(|| median(t_ons)),
        }
    }

    /// The campaign's space with the keys of a `--space` TOML file in place of its own:
    /// `springs` (list, N/m), `v_d` (`[lo, hi]`, m/s), `f` (`[lo, hi]`, Hz), `va_ratio`
    /// (`[lo, hi]`), `max_u0` (list of `[f, u0]` points, Hz and m), `max_duration` (s), `rate`
    /// (Hz), `t_on` (s; 0 vibrates from the start). Every value is checked, and the message
    /// names the key, the value and what is allowed.
    pub fn with_file(mut self, path: &Path) -> Result<Space, SpaceError> {
        let file = path.display().to_string();
        let bad = |field: &str, value: String, allowed: &str| SpaceError {
            file: file.clone(),
            field: field.to_string(),
            value,
            allowed: allowed.to_string(),
        };
        let text = crate::config::read_input(path, MAX_TOML_BYTES)
            .map_err(|m| bad("file", file.clone(), &m))?;
        let doc =
            Doc::parse(&file, text).map_err(|e| bad("file", String::new(), &e.to_string()))?;
        let num = |k: &str, v: &toml::Value| -> Result<f64, SpaceError> {
            doc.number("", k, v)
                .map_err(|_| bad(k, v.to_string(), "a number in SI units"))
        };
        let list = |k: &str, v: &toml::Value| -> Result<Vec<f64>, SpaceError> {
            let arr = v
                .as_array()
                .ok_or_else(|| bad(k, v.to_string(), "a list of numbers"))?;
            arr.iter().map(|x| num(k, x)).collect()
        };
        let range =
            |k: &str, v: &toml::Value, lo: f64, hi: f64| -> Result<(f64, f64), SpaceError> {
                let r = list(k, v)?;
                let ok = r.len() == 2 && lo <= r[0] && r[0] <= r[1] && r[1] <= hi;
                if !ok {
                    return Err(bad(
                        k,
                        v.to_string(),
                        &format!("[lowest, highest] with {lo:e} <= lowest <= highest <= {hi:e}"),
                    ));
                }
                Ok((r[0], r[1]))
            };
        for (k, v) in &doc.table {
            match k.as_str() {
                "springs" => {
                    let s = list(k, v)?;
                    if s.is_empty() || s.iter().any(|x| !(1.0..=1e9).contains(x)) {
                        return Err(bad(
                            k,
                            v.to_string(),
                            "a non-empty list of k_d from 1 to 1e9 N/m",
                        ));
                    }
                    self.springs = distinct(s);
                }
                "v_d" => {
                    self.v_d = range(k, v, 1e-7, 1.0)?;
                    self.v_d_levels.clear();
                }
                "f" => self.f = Some(range(k, v, 1.0, 1e5)?),
                "va_ratio" => self.va_ratio = range(k, v, 1e-3, 100.0)?,
                "max_u0" => {
                    let arr = v
                        .as_array()
                        .ok_or_else(|| bad(k, v.to_string(), "a list of [f, u0] points"))?;
                    let mut pts = vec![];
                    for p in arr {
                        let xy = list(k, p)?;
                        if xy.len() != 2
                            || !(xy[0] > 0.0 && xy[0] <= 1e5)
                            || !(xy[1] > 0.0 && xy[1] <= 1e-2)
                        {
                            return Err(bad(
                                k,
                                p.to_string(),
                                "[f, u0] with 0 < f <= 1e5 Hz and 0 < u0 <= 1e-2 m",
                            ));
                        }
                        pts.push((xy[0], xy[1]));
                    }
                    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                    self.max_u0 = pts;
                }
                "max_duration" => {
                    let d = num(k, v)?;
                    if !(0.1..=3600.0).contains(&d) {
                        return Err(bad(k, v.to_string(), "from 0.1 to 3600 s"));
                    }
                    self.max_duration = d;
                }
                "rate" => {
                    let r = num(k, v)?;
                    if !(1000.0..=1e6).contains(&r) {
                        return Err(bad(k, v.to_string(), "from 1000 to 1e6 Hz"));
                    }
                    self.rate = r;
                }
                "t_on" => {
                    let t = num(k, v)?;
                    if !(0.0..=3600.0).contains(&t) {
                        return Err(bad(
                            k,
                            v.to_string(),
                            "from 0 (vibrated from the start) to 3600 s",
                        ));
                    }
                    self.t_on = (t > 0.0).then_some(t);
                }
                _ => {
                    return Err(bad(
                        k,
                        v.to_string(),
                        "unknown key; allowed: springs, v_d, f, va_ratio, max_u0, max_duration, rate, t_on",
                    ));
                }
            }
        }
        Ok(self)
    }

    /// The largest `u0` \[m\] the actuator reaches at `f` (infinity without a limit).
    pub fn u0_limit(&self, f: f64) -> f64 {
        let p = &self.max_u0;
        match p.len() {
            0 => f64::INFINITY,
            1 => p[0].1,
            _ if f <= p[0].0 => p[0].1,
            _ if f >= p[p.len() - 1].0 => p[p.len() - 1].1,
            _ => {
                let i = p
                    .iter()
                    .position(|q| q.0 >= f)
                    .expect("f inside the points");
                let (a, b) = (p[i - 1], p[i]);
                let s = (f / a.0).ln() / (b.0 / a.0).ln();
                (a.1.ln() + s * (b.1.ln() - a.1.ln())).exp()
            }
        }
    }

    /// The drive velocities of the grid: the campaign's own where it recorded few, else
    /// [`V_D_LEVELS`] log-spaced over the range (by index, ends exact).
    pub fn v_d_grid(&self) -> Vec<f64> {
        if !self.v_d_levels.is_empty() {
            return self.v_d_levels.clone();
        }
        logspace_ends(self.v_d.0, self.v_d.1, V_D_LEVELS)
    }

    /// Whether the conditions `p` of a recording of `duration` s lie in the space.
    pub fn admits(&self, p: &Params, duration: f64) -> bool {
        let tol = |x: f64| 1e-9 * x.abs();
        let within = |x: f64, (lo, hi): (f64, f64)| x >= lo - tol(lo) && x <= hi + tol(hi);
        let spring = self.springs.iter().any(|&k| (k - p.k_d).abs() <= tol(k));
        let vib_ok = if p.vibrates() {
            match self.f {
                Some(fr) => {
                    within(p.f, fr)
                        && within(p.v_a() / p.v_d, self.va_ratio)
                        && p.u0 <= self.u0_limit(p.f) * (1.0 + 1e-9)
                }
                None => false,
            }
        } else {
            true
        };
        spring && within(p.v_d, self.v_d) && vib_ok && duration <= self.max_duration * (1.0 + 1e-9)
    }

    /// Every candidate recording of the grid, on the conditions `template` (a recording's of the
    /// campaign, for its load, mass and contact): each spring × each drive velocity of
    /// [`Space::v_d_grid`] × (no vibration, and [`F_LEVELS`] frequencies × [`RATIO_LEVELS`]
    /// amplitudes within the actuator's limit), each with the duration the measures need
    /// ([`crate::sim::planned_time`], three stick-slip cycles in the steady half) up to the
    /// longest allowed. Only conditions the space admits.
    pub fn candidates(&self, template: &Params) -> Vec<Candidate> {
        let mut out = vec![];
        let fs = self
            .f
            .map(|(lo, hi)| logspace_ends(lo, hi, F_LEVELS))
            .unwrap_or_default();
        let ratios = logspace_ends(
            self.va_ratio.0.max(1e-3),
            self.va_ratio.1.max(1e-3),
            RATIO_LEVELS,
        );
        for &k_d in &self.springs {
            for &v_d in &self.v_d_grid() {
                let mut p = *template;
                p.k_d = k_d;
                p.v_d = v_d;
                p.u0 = 0.0;
                p.t_on = 0.0;
                let mut vibs = vec![p];
                for &f in &fs {
                    for &ratio in &ratios {
                        let mut q = p;
                        q.f = f;
                        q.set_v_a(ratio * v_d);
                        if let Some(t_on) = self.t_on {
                            q.t_on = t_on;
                        }
                        vibs.push(q);
                    }
                }
                for q in vibs {
                    if q.validate().is_err() {
                        continue;
                    }
                    let duration = crate::sim::planned_time(&q, 3).min(self.max_duration);
                    if self.admits(&q, duration) {
                        out.push(Candidate {
                            params: q,
                            duration,
                        });
                    }
                }
            }
        }
        out
    }
}

/// `n` log-spaced values from `lo` to `hi`, computed by index (both ends exact; one value
/// where they are equal).
pub fn logspace_ends(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n <= 1 || lo >= hi {
        return vec![lo];
    }
    (0..n)
        .map(|i| {
            if i == 0 {
                lo
            } else if i == n - 1 {
                hi
            } else {
                (lo.ln() + (hi.ln() - lo.ln()) * i as f64 / (n - 1) as f64).exp()
            }
        })
        .collect()
}

/// One recording the rig could make.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Its conditions.
    pub params: Params,
    /// Its duration \[s\].
    pub duration: f64,
}

impl Candidate {
    /// Its vibration velocity amplitude as a share of the drive velocity (0 without vibration).
    pub fn va_ratio(&self) -> f64 {
        if self.params.vibrates() {
            self.params.u0 * TAU * self.params.f / self.params.v_d
        } else {
            0.0
        }
    }

    /// A short name of its conditions: `k11700_v1.0_f1500_a0.60` (spring in N/m, drive in
    /// mm/s, frequency in Hz, `v_a/v_d`), `..._rest` without vibration.
    pub fn label(&self) -> String {
        let p = &self.params;
        let base = format!("k{:.0}_v{:.3}", p.k_d, p.v_d * 1e3);
        if p.vibrates() {
            format!("{base}_f{:.0}_a{:.2}", p.f, self.va_ratio())
        } else {
            format!("{base}_rest")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn space() -> Space {
        Space {
            springs: vec![11_700.0, 20_000.0],
            v_d: (0.5e-3, 2e-3),
            v_d_levels: vec![],
            f: Some((500.0, 2000.0)),
            va_ratio: (0.3, 2.0),
            max_u0: vec![(500.0, 1e-6), (2000.0, 2e-7)],
            max_duration: 10.0,
            rate: 10_000.0,
            t_on: None,
        }
    }

    /// Every candidate lies in the space, the actuator's limit included (interpolated
    /// log-log: at the geometric mean of two points, the geometric mean of their limits), and
    /// an amplitude beyond it is refused.
    #[test]
    fn candidates_stay_inside_the_space() {
        let s = space();
        let lim = s.u0_limit(1000.0);
        assert!((lim - (1e-6f64 * 2e-7).sqrt()).abs() < 1e-12 * lim, "{lim}");
        assert_eq!(s.u0_limit(100.0), 1e-6);
        assert_eq!(s.u0_limit(5000.0), 2e-7);
        let c = s.candidates(&Params::default());
        assert!(!c.is_empty());
        for x in &c {
            assert!(s.admits(&x.params, x.duration), "{}", x.label());
            assert!(x.params.u0 <= s.u0_limit(x.params.f) * (1.0 + 1e-9));
        }
        // Both springs and both ends of the drive range are there; at 2 kHz the actuator's
        // 0.2 µm admits v_a/v_d = 0.3 at 2 mm/s (0.048 µm) but not 2.0 at 2 mm/s (0.32 µm).
        for k in [11_700.0, 20_000.0] {
            assert!(c.iter().any(|x| x.params.k_d == k));
        }
        let at = |f: f64, ratio: f64, v: f64| {
            c.iter().any(|x| {
                x.params.f == f && (x.va_ratio() - ratio).abs() < 1e-9 && x.params.v_d == v
            })
        };
        assert!(at(2000.0, 0.3, 2e-3));
        assert!(!at(2000.0, 2.0, 2e-3));
        let mut p = c.iter().find(|x| x.params.vibrates()).unwrap().params;
        p.u0 = 2.0 * s.u0_limit(p.f);
        assert!(!s.admits(&p, 1.0));
        p.u0 = 0.0;
        assert!(!s.admits(&p, 11.0), "longer than the longest recording");
        p.k_d = 15_000.0;
        assert!(!s.admits(&p, 1.0), "a spring the rig does not have");
    }

    /// A `--space` file's bad values are refused with the key, the value and what is allowed.
    #[test]
    fn a_bad_space_file_names_the_key() {
        let dir = std::env::temp_dir().join(format!("stickslip-space-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("space.toml");
        for (text, key) in [
            ("f = [2000, 500]", "f"),
            ("springs = []", "springs"),
            ("max_u0 = [[1000, -1]]", "max_u0"),
            ("rate = 10", "rate"),
            ("colour = 3", "colour"),
        ] {
            std::fs::write(&f, text).unwrap();
            let e = space().with_file(&f).unwrap_err();
            assert_eq!(e.field, key, "{text}: {e}");
            assert!(!e.allowed.is_empty());
        }
        std::fs::write(&f, "f = [500, 3000]\nsprings = [20000]\nmax_duration = 4").unwrap();
        let s = space().with_file(&f).unwrap();
        assert_eq!(s.f, Some((500.0, 3000.0)));
        assert_eq!(s.springs, vec![20_000.0]);
        assert!(
            s.candidates(&Params::default())
                .iter()
                .all(|x| x.duration <= 4.0)
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
