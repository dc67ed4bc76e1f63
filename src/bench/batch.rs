//! `stickslip bench --batch`: whole runs per second and core on the scalar path and on the
//! batch path ([`crate::sim::batch`]), side by side in one process.
//!
//! The points sample the region of the overnight grid where the full model serves every run,
//! below the contact resonance: `f` 500 to 1500 Hz, `v_d` 0.1 to 1.6 mm/s, `k_d` 1000 to
//! 16 000 N/m, `u0` 5 nm to 3 µm, each logarithmic, point `n` at the `n`-th member of a Halton
//! sequence (bases 2, 3, 5, 7), so any count spreads over the whole box. Every run is the
//! sweep's run of that point (automatic simulated time, early stops, the full tier), one thread
//! per path: the scalar path runs them one after another through
//! [`simulate_in`], the batch path hands them all to
//! [`simulate_batch`]. The repeats alternate the paths and keep each one's fastest, as the
//! machine is shared. Every result of the two paths is compared (all fields but the wall time)
//! and the report says whether they agree bit for bit.

use crate::averaged::store::TableStore;
use crate::model::{Effects, Params};
use crate::ode::batch::{Path, WIDTH, vector_set};
use crate::ode::{Method, Solver};
use crate::sim::batch::{Ask, simulate_batch};
use crate::sim::{RunOptions, RunResult, SimError, Tier, simulate_in};
use serde::Serialize;
use std::time::Instant;

/// Settings of the batch benchmark.
#[derive(Clone, Debug)]
pub struct BatchBenchOptions {
    /// Points (1 to 100 000). Default 64.
    pub points: usize,
    /// Timed repeats of each path, alternating (the fastest counts), 1 to 100. Default 3.
    pub repeats: usize,
    /// Integration method: `dopri5` or `auto` (the methods the lanes serve). Default `dopri5`.
    pub method: Method,
    /// Envelope-following tolerance (`None`: every period integrated). Default 1e-4.
    pub envelope: Option<f64>,
}

impl Default for BatchBenchOptions {
    fn default() -> Self {
        BatchBenchOptions {
            points: 64,
            repeats: 3,
            method: Method::Dopri5,
            envelope: Some(crate::sim::DEFAULT_ENVELOPE),
        }
    }
}

/// What the batch benchmark measured.
#[derive(Clone, Debug, Serialize)]
pub struct BatchBench {
    pub points: usize,
    pub repeats: usize,
    pub method: String,
    pub envelope: Option<f64>,
    /// Lanes of the batch path and the vector instructions found at run time.
    pub lanes: usize,
    pub vector_set: String,
    /// Fastest wall time of each path over all points, one thread \[s\].
    pub scalar_seconds: f64,
    pub batch_seconds: f64,
    /// Runs whose main integration the lanes served (the rest ran scalar in the batch path).
    pub in_lanes: usize,
    /// Points whose results differ between the paths (all fields but the wall time).
    pub differing: Vec<usize>,
    /// Right-hand sides and steps of all runs (the same on both paths where they agree).
    pub rhs_evals: u64,
    pub steps: u64,
}

impl BatchBench {
    /// Points per second and core of the scalar path.
    pub fn scalar_rate(&self) -> f64 {
        self.points as f64 / self.scalar_seconds
    }
    /// Points per second and core of the batch path.
    pub fn batch_rate(&self) -> f64 {
        self.points as f64 / self.batch_seconds
    }
    /// Batch over scalar throughput.
    pub fn ratio(&self) -> f64 {
        self.scalar_seconds / self.batch_seconds
    }
}

/// The `i`-th member (from 1) of the van der Corput sequence in `base`, in [0, 1).
fn radical_inverse(mut i: usize, base: usize) -> f64 {
    let (mut x, mut scale) = (0.0, 1.0 / base as f64);
    while i > 0 {
        x += (i % base) as f64 * scale;
        i /= base;
        scale /= base as f64;
    }
    x
}

/// `a (b/a)^s`: the logarithmic scale from `a` to `b` at `s` in [0, 1].
fn log_between(a: f64, b: f64, s: f64) -> f64 {
    a * (b / a).powf(s)
}

/// Point `n` of the benchmark (module docs): Halton member `n + 1`, so the first is not the
/// box's corner.
pub fn point(n: usize) -> Params {
    let h = |base| radical_inverse(n + 1, base);
    Params {
        f: log_between(500.0, 1500.0, h(2)),
        v_d: log_between(1e-4, 1.6e-3, h(3)),
        k_d: log_between(1000.0, 16_000.0, h(5)),
        u0: log_between(5e-9, 3e-6, h(7)),
        ..Params::default()
    }
}

/// Whether `method` can run in the lanes (the benchmark's allowed methods).
pub fn lane_method(method: Method) -> bool {
    matches!(method, Method::Dopri5 | Method::Auto)
}

type Outcome = Result<RunResult, SimError>;

/// A result with its wall time cleared, as text that differs wherever a bit does.
fn fingerprint(r: &Outcome) -> String {
    match r {
        Ok(r) => format!(
            "{:?}",
            RunResult {
                wall_time: 0.0,
                ..r.clone()
            }
        ),
        Err(e) => format!("{e:?}"),
    }
}

/// Runs the benchmark; `note` gets a line per timed pass.
pub fn run(o: &BatchBenchOptions, mut note: impl FnMut(&str)) -> BatchBench {
    let pts: Vec<Params> = (0..o.points).map(point).collect();
    let opts = RunOptions {
        method: o.method,
        envelope: o.envelope,
        tier: Tier::Full,
        ..RunOptions::default()
    };
    let fx = Effects::none();
    let (mut scalar_s, mut batch_s) = (f64::INFINITY, f64::INFINITY);
    let mut bench = BatchBench {
        points: o.points,
        repeats: o.repeats,
        method: o.method.to_string(),
        envelope: o.envelope,
        lanes: WIDTH,
        vector_set: vector_set().into(),
        scalar_seconds: 0.0,
        batch_seconds: 0.0,
        in_lanes: 0,
        differing: vec![],
        rhs_evals: 0,
        steps: 0,
    };
    for rep in 0..o.repeats {
        let mut solver = Solver::new(o.method);
        let clock = Instant::now();
        let want: Vec<Outcome> = pts
            .iter()
            .map(|p| simulate_in(p, &fx, &opts, &mut solver, &TableStore::new()))
            .collect();
        let t = clock.elapsed().as_secs_f64();
        scalar_s = scalar_s.min(t);
        note(&format!("repeat {}: scalar {t:.2} s", rep + 1));

        let mut solver = Solver::new(o.method);
        let mut got: Vec<Option<Outcome>> = vec![None; pts.len()];
        let mut in_lanes = 0;
        let clock = Instant::now();
        let asks = pts.iter().enumerate().map(|(id, p)| Ask {
            id,
            p: *p,
            opts: opts.clone(),
        });
        simulate_batch(asks, &fx, &mut solver, &TableStore::new(), |id, r, path| {
            in_lanes += usize::from(path == Path::Lanes);
            got[id] = Some(r);
        });
        let t = clock.elapsed().as_secs_f64();
        batch_s = batch_s.min(t);
        note(&format!("repeat {}: batch  {t:.2} s", rep + 1));

        bench.in_lanes = in_lanes;
        bench.differing = (0..pts.len())
            .filter(|&i| {
                got[i]
                    .as_ref()
                    .is_none_or(|g| fingerprint(g) != fingerprint(&want[i]))
            })
            .collect();
        let ok = want.iter().filter_map(|r| r.as_ref().ok());
        (bench.rhs_evals, bench.steps) = ok.fold((0, 0), |(r, s), x| {
            (r + x.stats.rhs_evals, s + x.stats.steps)
        });
    }
    bench.scalar_seconds = scalar_s;
    bench.batch_seconds = batch_s;
    bench
}

impl std::fmt::Display for BatchBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let env = self
            .envelope
            .map_or("none".to_string(), |e| format!("{e:e}"));
        writeln!(
            f,
            "{} points below the contact resonance (f 500-1500 Hz), full tier, {}, envelope {env}; \
             one thread per path, fastest of {} alternating repeats; {} lanes ({})",
            self.points, self.method, self.repeats, self.lanes, self.vector_set
        )?;
        writeln!(f, "path    points/s per core  time [s]")?;
        writeln!(
            f,
            "scalar  {:17.2}  {:8.2}",
            self.scalar_rate(),
            self.scalar_seconds
        )?;
        writeln!(
            f,
            "batch   {:17.2}  {:8.2}",
            self.batch_rate(),
            self.batch_seconds
        )?;
        writeln!(
            f,
            "batch / scalar: {:.2}; {} of {} runs in lanes; {} RHS and {} steps per point",
            self.ratio(),
            self.in_lanes,
            self.points,
            self.rhs_evals / self.points.max(1) as u64,
            self.steps / self.points.max(1) as u64
        )?;
        if self.differing.is_empty() {
            write!(f, "results: the two paths agree bit for bit on every point")
        } else {
            write!(
                f,
                "results: the paths DIFFER at {} of {} points (first: {:?})",
                self.differing.len(),
                self.points,
                &self.differing[..self.differing.len().min(8)]
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Van der Corput in base 2 and 3 by hand: 1/2, 1/4, 3/4 and 1/3, 2/3, 1/9.
    #[test]
    fn halton_members_are_the_radical_inverses() {
        let b2: Vec<f64> = (1..4).map(|i| radical_inverse(i, 2)).collect();
        assert_eq!(b2, vec![0.5, 0.25, 0.75]);
        let b3: Vec<f64> = (1..5).map(|i| radical_inverse(i, 3)).collect();
        let want = [1.0 / 3.0, 2.0 / 3.0, 1.0 / 9.0, 4.0 / 9.0];
        for (g, w) in b3.iter().zip(want) {
            assert!((g - w).abs() < 1e-15, "{g} {w}");
        }
    }

    /// The points stay in the box and spread: every octave of `f`'s range and every quarter of
    /// `u0`'s decades holds some of the first 64.
    #[test]
    fn points_fill_the_slice() {
        let pts: Vec<Params> = (0..64).map(point).collect();
        for p in &pts {
            assert!((500.0..=1500.0).contains(&p.f), "{p:?}");
            assert!((1e-4..=1.6e-3).contains(&p.v_d), "{p:?}");
            assert!((1000.0..=16_000.0).contains(&p.k_d), "{p:?}");
            assert!((5e-9..=3e-6).contains(&p.u0), "{p:?}");
        }
        for q in 0..4 {
            let lo = log_between(5e-9, 3e-6, q as f64 / 4.0);
            let hi = log_between(5e-9, 3e-6, (q + 1) as f64 / 4.0);
            let n = pts.iter().filter(|p| p.u0 >= lo && p.u0 < hi).count();
            assert!(n >= 12, "quarter {q} of u0 holds {n} of 64");
        }
    }
}
