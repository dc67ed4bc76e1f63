//! The measures of docs/model.md, computed on the fly from a uniformly sampled drive force, so that a
//! run of any length needs only a buffer of one vibration period.
//!
//! - **Smoothed drive force**: a moving average of `F_d` over exactly one vibration period
//!   (`K` samples at spacing `1/(K f)`), which cancels the ripple at `f` and its harmonics below
//!   `K f`; no smoothing without vibration.
//! - **Steady window**: the second half of the simulated time.
//! - **Stick-slip cycles**: a peak-and-trough (zig-zag) detector with hysteresis `δ` on the
//!   smoothed force; a *drop* is a peak followed by the next trough. The detector starts in the
//!   falling state, so a drop cut by the window's start is never counted.
//! - **dF**: the mean drop, with its standard error `std/√n`; where no drop remains
//!   (stick-slip eliminated), the max minus min of the smoothed force over the window.
//! - **Mean drive force**: the mean of the raw `F_d` samples over the window (Fig. 10b).
//! - **Stick fraction**: the share of the window in which the period-averaged relative velocity
//!   of body and substrate is below `0.05 v_d` in magnitude.
//! - **Period**: the mean spacing of successive peaks. **Peak / trough force**: the means over the
//!   counted drops (with no drop: max and min of the smoothed force).

use serde::{Deserialize, Serialize};
use std::cmp::Ordering;

/// Hysteresis of the cycle detector as a share of `F_s − F_c` (so 1 % of the nominal
/// amplitude `2 (F_s − F_c)` without vibration): smaller wiggles do not make a cycle.
pub const DROP_THRESHOLD: f64 = 0.02;
/// Stick: period-averaged |v − u'| below this share of `v_d`.
pub const STICK_VELOCITY: f64 = 0.05;

/// The measures of one run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Measures {
    /// Stick-slip amplitude dF \[N\].
    #[serde(rename = "dF")]
    pub d_f: f64,
    /// Standard error of dF over the cycles \[N\]: 0 when no cycle remains (dF is then the
    /// window's max − min, not a mean) and for one cycle of a run without vibration (its cycles
    /// repeat); NaN, unknown, for one cycle of a run with vibration
    /// ([`Measures::varying_cycles`]).
    #[serde(rename = "dF_stderr")]
    pub d_f_stderr: f64,
    /// Mean drive force over the steady window \[N\].
    pub mean_force: f64,
    /// Share of the steady window spent sticking [-].
    pub stick_fraction: f64,
    /// Mean stick-slip period \[s\] (NaN with fewer than two peaks).
    pub period: f64,
    /// Mean peak of the smoothed drive force before a slip \[N\].
    pub peak_force: f64,
    /// Mean trough of the smoothed drive force after a slip \[N\].
    pub trough_force: f64,
    /// Number of drops counted in the steady window.
    pub cycles: u32,
}

impl Measures {
    /// The measures of a run with vibration, whose stick-slip cycles all differ (the slips
    /// start at a different phase of the vibration each time, docs/model.md): a window of one
    /// cycle then says nothing of their spread, and dF's standard error is unknown (NaN), not
    /// the 0 one cycle gives. Without vibration the cycles repeat (a limit cycle), and 0 stands.
    pub fn varying_cycles(mut self) -> Self {
        if self.cycles == 1 {
            self.d_f_stderr = f64::NAN;
        }
        self
    }
}

/// A measure of a run or of a point: its one definition (name, unit, what it means, how it is
/// read), from which the sweep file's choice of measures (`[output] measures`), the journal,
/// the HDF5 files, the JSON of `run` and the refined level are all written. Adding a measure is
/// a variant here (and, where a run measures it, a field of [`Measures`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Measure {
    /// Reduction coefficient `r = dF / dF_reference` (Eq. 5.1): a point's, of two runs.
    R,
    /// Standard error of `r`.
    RStderr,
    /// Stick-slip amplitude ([`Measures::d_f`]).
    DF,
    /// Its standard error ([`Measures::d_f_stderr`]).
    DFStderr,
    /// Mean drive force ([`Measures::mean_force`]).
    MeanForce,
    /// Share of the window spent sticking ([`Measures::stick_fraction`]).
    StickFraction,
    /// Mean stick-slip period ([`Measures::period`]).
    Period,
    /// Mean peak force ([`Measures::peak_force`]).
    PeakForce,
    /// Mean trough force ([`Measures::trough_force`]).
    TroughForce,
    /// Cycles counted ([`Measures::cycles`]).
    Cycles,
}

impl Measure {
    /// Every measure, in the order files write them.
    pub const ALL: [Measure; 10] = [
        Measure::R,
        Measure::RStderr,
        Measure::DF,
        Measure::DFStderr,
        Measure::MeanForce,
        Measure::StickFraction,
        Measure::Period,
        Measure::PeakForce,
        Measure::TroughForce,
        Measure::Cycles,
    ];

    /// The measures of one run (every one but those of a point's two runs, `r` and its error).
    pub const OF_RUN: [Measure; 8] = [
        Measure::DF,
        Measure::DFStderr,
        Measure::MeanForce,
        Measure::StickFraction,
        Measure::Period,
        Measure::PeakForce,
        Measure::TroughForce,
        Measure::Cycles,
    ];

    /// Its name in files, sweep files and the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Measure::R => "r",
            Measure::RStderr => "r_stderr",
            Measure::DF => "dF",
            Measure::DFStderr => "dF_stderr",
            Measure::MeanForce => "mean_force",
            Measure::StickFraction => "stick_fraction",
            Measure::Period => "period",
            Measure::PeakForce => "peak_force",
            Measure::TroughForce => "trough_force",
            Measure::Cycles => "cycles",
        }
    }

    /// Its unit (SI; `1` for a number).
    pub fn unit(self) -> &'static str {
        match self {
            Measure::R | Measure::RStderr | Measure::StickFraction | Measure::Cycles => "1",
            Measure::Period => "s",
            _ => "N",
        }
    }

    /// What it means, as the files describe it.
    pub fn doc(self) -> &'static str {
        match self {
            Measure::R => "reduction coefficient dF/dF_reference (Eq. 5.1)",
            Measure::RStderr => {
                "standard error of r (NaN where a run with vibration holds one cycle)"
            }
            Measure::DF => "stick-slip amplitude: mean drop of the smoothed drive force per cycle",
            Measure::DFStderr => {
                "standard error of dF over the cycles (NaN where a run with vibration holds one)"
            }
            Measure::MeanForce => "mean drive force over the steady window",
            Measure::StickFraction => "share of the steady window spent sticking",
            Measure::Period => "mean stick-slip period",
            Measure::PeakForce => "mean peak of the smoothed drive force",
            Measure::TroughForce => "mean trough of the smoothed drive force",
            Measure::Cycles => "stick-slip cycles counted in the steady window",
        }
    }

    /// The measure named `name`, if any.
    pub fn from_name(name: &str) -> Option<Measure> {
        Measure::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The names of `ms`, joined by commas (for messages that list what is allowed).
    pub fn names(ms: &[Measure]) -> String {
        ms.iter().map(|m| m.name()).collect::<Vec<_>>().join(", ")
    }

    /// Its value on a run's measures `m`; `None` for a point's measures (`r`, `r_stderr`).
    pub fn of_run(self, m: &Measures) -> Option<f64> {
        Some(match self {
            Measure::R | Measure::RStderr => return None,
            Measure::DF => m.d_f,
            Measure::DFStderr => m.d_f_stderr,
            Measure::MeanForce => m.mean_force,
            Measure::StickFraction => m.stick_fraction,
            Measure::Period => m.period,
            Measure::PeakForce => m.peak_force,
            Measure::TroughForce => m.trough_force,
            Measure::Cycles => f64::from(m.cycles),
        })
    }

    /// Its value at a point: of the point's run's measures `m`, or of the point's reduction
    /// `(r, r_stderr)`.
    pub fn of_point(self, m: &Measures, reduction: (f64, f64)) -> f64 {
        match self {
            Measure::R => reduction.0,
            Measure::RStderr => reduction.1,
            _ => self.of_run(m).expect("a run's measure"),
        }
    }

    /// Sets it on a run's measures (a point's measures are not a run's: nothing is set). A
    /// count is set from a whole, non-negative `v`.
    pub fn set(self, m: &mut Measures, v: f64) {
        match self {
            Measure::R | Measure::RStderr => {}
            Measure::DF => m.d_f = v,
            Measure::DFStderr => m.d_f_stderr = v,
            Measure::MeanForce => m.mean_force = v,
            Measure::StickFraction => m.stick_fraction = v,
            Measure::Period => m.period = v,
            Measure::PeakForce => m.peak_force = v,
            Measure::TroughForce => m.trough_force = v,
            Measure::Cycles => m.cycles = v as u32,
        }
    }

    /// The open range a level of it must lie in to be crossed at all, with the rule in words: r,
    /// dF, their errors and the period are never negative, a share lies within 0 to 1; `None`
    /// where any level may be crossed.
    pub fn level_range(self) -> Option<(f64, f64, &'static str)> {
        match self {
            Measure::StickFraction => Some((0.0, 1.0, "0 < level < 1")),
            Measure::R | Measure::RStderr | Measure::DF | Measure::DFStderr | Measure::Period => {
                Some((0.0, f64::INFINITY, "level > 0"))
            }
            _ => None,
        }
    }

    /// Whether a level set of it can be refined: every measure but a count.
    pub fn refinable(self) -> bool {
        self != Measure::Cycles
    }
}

impl Measures {
    /// The measures of a run that measured nothing (it failed): NaN, no cycle.
    pub fn nan() -> Measures {
        let mut m = Measures::default();
        for k in Measure::OF_RUN {
            k.set(&mut m, f64::NAN);
        }
        m
    }
}

/// Statistics of one block of smoothed samples (for windows chosen after the fact).
#[derive(Clone, Copy, Debug)]
struct Block {
    start: f64,
    min: f64,
    max: f64,
    sum_raw: f64,
    n: u32,
    stick: u32,
}

impl Block {
    fn new(start: f64) -> Block {
        Block {
            start,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            sum_raw: 0.0,
            n: 0,
            stick: 0,
        }
    }
}

/// A streaming analyser: feed it samples `(t, F_d, v_r)` at uniform spacing; ask for the
/// [`Measures`] at the end. Allocates its buffers once.
///
/// Besides the fixed steady window it keeps block statistics (min, max and mean of the smoothed
/// force per block of time) from the start, so that [`Analyzer::steady_sliding`] can judge a
/// window `[t/2, t]` for any `t` reached so far.
#[derive(Clone, Debug)]
pub struct Analyzer {
    block_width: f64,
    blocks: Vec<Block>,
    cur: Block,
    window_start: f64,
    stick_speed: f64,
    // Moving averages over one period (ring buffers of K samples).
    ring_f: Vec<f64>,
    ring_v: Vec<f64>,
    pos: usize,
    filled: usize,
    sum_f: f64,
    sum_v: f64,
    // Window statistics.
    n: u64,
    sum_raw: f64,
    stick: u64,
    smin: f64,
    smax: f64,
    // Cycle detectors: over the fixed window, and (with blocks) over the whole run.
    window: ZigZag,
    whole: Option<ZigZag>,
}

impl Analyzer {
    /// An analyser for samples `period_samples` per vibration period (1: no smoothing), a steady
    /// window from `window_start`, drop threshold `threshold` \[N\] and stick speed [m/s].
    pub fn new(period_samples: usize, window_start: f64, threshold: f64, stick_speed: f64) -> Self {
        Self::with_blocks(
            period_samples,
            window_start,
            threshold,
            stick_speed,
            f64::INFINITY,
            0,
        )
    }

    /// As [`Analyzer::new`], also keeping block statistics over blocks of `block_width` seconds
    /// (about `capacity` of them).
    pub fn with_blocks(
        period_samples: usize,
        window_start: f64,
        threshold: f64,
        stick_speed: f64,
        block_width: f64,
        capacity: usize,
    ) -> Self {
        let k = period_samples.max(1);
        Analyzer {
            block_width,
            blocks: Vec::with_capacity(capacity),
            cur: Block::new(0.0),
            window_start,
            stick_speed,
            ring_f: vec![0.0; k],
            ring_v: vec![0.0; k],
            pos: 0,
            filled: 0,
            sum_f: 0.0,
            sum_v: 0.0,
            n: 0,
            sum_raw: 0.0,
            stick: 0,
            smin: f64::INFINITY,
            smax: f64::NEG_INFINITY,
            window: ZigZag::new(threshold),
            whole: block_width.is_finite().then(|| ZigZag::new(threshold)),
        }
    }

    /// Feeds one sample and returns the smoothed force (NaN until one period is filled).
    pub fn push(&mut self, t: f64, force: f64, v_rel: f64) -> f64 {
        let k = self.ring_f.len();
        let (sf, sv) = if k == 1 {
            // Without vibration nothing is smoothed.
            (force, v_rel)
        } else {
            match self.smooth(force, v_rel) {
                Some(s) => s,
                None => return f64::NAN,
            }
        };
        if self.block_width.is_finite() {
            if self.cur.n == 0 {
                self.cur.start = t;
            } else if t >= self.cur.start + self.block_width {
                self.blocks.push(self.cur);
                self.cur = Block::new(t);
            }
            let b = &mut self.cur;
            b.min = b.min.min(sf);
            b.max = b.max.max(sf);
            b.sum_raw += force;
            b.n += 1;
            b.stick += u32::from(sv.abs() < self.stick_speed);
        }
        if let Some(z) = self.whole.as_mut() {
            z.push(t, sf);
        }
        if t >= self.window_start {
            self.n += 1;
            self.sum_raw += force;
            if sv.abs() < self.stick_speed {
                self.stick += 1;
            }
            self.smin = self.smin.min(sf);
            self.smax = self.smax.max(sf);
            self.window.push(t, sf);
        }
        sf
    }

    /// The moving averages of the force and the relative velocity over one period, once the
    /// period is filled.
    fn smooth(&mut self, force: f64, v_rel: f64) -> Option<(f64, f64)> {
        let k = self.ring_f.len();
        // Running sums are refreshed from the buffer once per period, so round-off cannot drift.
        self.sum_f += force - self.ring_f[self.pos];
        self.sum_v += v_rel - self.ring_v[self.pos];
        self.ring_f[self.pos] = force;
        self.ring_v[self.pos] = v_rel;
        self.pos += 1;
        if self.pos == k {
            self.pos = 0;
            self.sum_f = self.ring_f.iter().sum();
            self.sum_v = self.ring_v.iter().sum();
        }
        self.filled = (self.filled + 1).min(k);
        (self.filled == k).then(|| (self.sum_f / k as f64, self.sum_v / k as f64))
    }

    /// The whole blocks of the window `[t/2, t]`.
    fn window_blocks(&self, t: f64) -> &[Block] {
        self.blocks_from(0.5 * t)
    }

    /// The whole blocks that start at or after `start`.
    fn blocks_from(&self, start: f64) -> &[Block] {
        let first = self.blocks.partition_point(|b| b.start < start);
        &self.blocks[first..]
    }

    /// Whether the window `[t/2, t]` (whole blocks) shows steady sliding: the smoothed force
    /// stays within `range` \[N\] (so no stick-slip drop of that size), its range does not grow
    /// from the third quarter to the last, and the window's mean force lies within `drift`
    /// (relative) of the asymptote extrapolated from the means of its thirds (or, when they do
    /// not approach one monotonically, the thirds agree to `drift`). Then returns the measures
    /// of that window, as [`Analyzer::finish`] would give them for a run ending at `t`.
    pub fn steady_sliding(&self, t: f64, range: f64, drift: f64) -> Option<Measures> {
        let w = self.window_blocks(t);
        if w.len() < 8 {
            return None;
        }
        let all = Totals::of(w);
        if (all.hi - all.lo).partial_cmp(&range) != Some(Ordering::Less) || all.n == 0 {
            return None;
        }
        // The mean force settles like an exponential (the drive spring against the friction
        // that vibration makes viscous-like), and the means of an exponential over three equal
        // spans form a geometric sequence: extrapolate it to the asymptote and bound the
        // window's distance from it (Aitken's Δ²).
        let [m0, m1, m2] = thirds(w);
        let mean = all.mean();
        if !near_level(m0, m1, m2, mean, drift) {
            return None;
        }
        let h = w.len() / 2;
        let q = w.len() / 4;
        let third_quarter = Totals::of(&w[h..h + q]);
        let last_quarter = Totals::of(&w[h + q..]);
        if last_quarter.hi - last_quarter.lo > 1.1 * (third_quarter.hi - third_quarter.lo) + 1e-12 {
            return None;
        }
        Some(sliding_measures(all.lo, all.hi, mean, all.stick_fraction()))
    }

    /// Whether the force, sliding without stick-slip, settles so plainly along one exponential
    /// that its settled level follows from the window from `start` to now (docs/model.md: the
    /// measures describe the settled state).
    ///
    /// Sliding under vibration makes the friction viscous-like, so the drive force approaches
    /// its sliding level as `F(s) = A − K e^{−s/τ}`, with `τ` up to tens of seconds at low `v_d`
    /// and `k_d`. The window (whole blocks, no drop of the smoothed force in it) is cut into six
    /// equal parts with means `m_0 … m_5`, which must move one way (no step back by more than
    /// 0.3 `mean_tol` of the mean); an exponential through the means of parts 0, 1, 2 and
    /// another through those of parts 3, 4, 5 (means over equal spans of an exponential are
    /// geometric: Aitken's Δ²) each give the level `A`. When the two agree to `mean_tol`
    /// (relative), the force near the window's end changes by at most `slope` \[N/s\] (the
    /// linear regime, one time constant), and the smoothed force in the last part strays from
    /// the exponential by at most `ripple` \[N\], returns the measures of the settled state:
    /// the second fit's level as the mean force, that ripple (the oscillation about the level)
    /// as dF, and as the error bound of the mean force the larger of the two levels' difference
    /// and [`SETTLING_SHARE`] of the extrapolated distance (the level may lie at most
    /// [`SETTLING_REACH`] beyond the last part's mean).
    pub fn settling(
        &self,
        start: f64,
        slope: f64,
        ripple: f64,
        mean_tol: f64,
    ) -> Option<(Measures, f64)> {
        let z = self.whole.as_ref()?;
        let w = self.blocks_from(start);
        let per = w.len() / 6;
        if per < 4 {
            return None;
        }
        let w = &w[w.len() - 6 * per..];
        if z.drops.last().is_some_and(|d| d.peak_t >= w[0].start) {
            return None;
        }
        let part = |j: usize| Totals::of(&w[j * per..(j + 1) * per]);
        let m: [f64; 6] = std::array::from_fn(|j| part(j).mean());
        // An approach moves one way: no part mean steps back from the one before by more than
        // `BACKSTEP` of the mean tolerance. A force wandering about its level (a small mean
        // friction under strong vibration: 0.04 N at v_a ≈ 140 v_d wanders by about 1 % over
        // seconds) fits two agreeing exponentials by chance, and they extrapolate the wander;
        // a force already at its level with a ripple on top is flat to that bound.
        const BACKSTEP: f64 = 0.3;
        let way = (m[5] - m[0]).signum();
        if m.windows(2)
            .any(|p| (p[1] - p[0]) * way < -BACKSTEP * mean_tol * p[0].abs())
        {
            return None;
        }
        // Parts span equal numbers of blocks of equal width.
        let h = w[per].start - w[0].start;
        // Near its sliding level only: there the relaxation is linear, with one time constant.
        if !matches!(
            ((m[5] - m[4]).abs()).partial_cmp(&(slope * h)),
            Some(Ordering::Less | Ordering::Equal)
        ) {
            return None;
        }
        let s0 = w[0].start;
        // One exponential through the means of parts j, j + 1, j + 2: F(s) = A − K e^{−(s−c)/τ}
        // with c the start of part j + 2; returns A and the change of F over the last part.
        let fit = |j: usize| -> Option<(f64, f64)> {
            let (d1, d2) = (m[j + 1] - m[j], m[j + 2] - m[j + 1]);
            if (d1 * d2).partial_cmp(&0.0) != Some(Ordering::Greater) {
                return None;
            }
            let q = d2 / d1;
            if q.partial_cmp(&0.95) != Some(Ordering::Less) {
                return None;
            }
            let tau = -h / q.ln();
            let a = m[j + 2] + d2 * q / (1.0 - q);
            let c = s0 + (j + 2) as f64 * h;
            // The mean over [c, c + h] is A − K τ/h (1 − e^{−h/τ}).
            let k = (a - m[j + 2]) * (h / tau) / (-(-h / tau).exp_m1());
            let f = |s: f64| a - k * (-(s - c) / tau).exp();
            Some((a, (f(s0 + 6.0 * h) - f(s0 + 5.0 * h)).abs()))
        };
        let (a0, _) = fit(0)?;
        let (a1, last) = fit(3)?;
        let tail = part(5);
        let excess = (tail.hi - tail.lo - last).max(0.0);
        // The fits must agree, and extrapolate only the last stretch of the approach: an
        // approach that looks exponential over the window can still bend further on (the
        // friction under vibration is nonlinear in the velocity even a few per cent from v_d),
        // so the level may lie at most `SETTLING_REACH` beyond the last part.
        let reach = (a1 - m[5]).abs();
        let error = (a1 - a0).abs().max(SETTLING_SHARE * reach);
        if excess > ripple
            || (a1 - a0).abs() > mean_tol * a1.abs()
            || reach > SETTLING_REACH * a1.abs()
        {
            return None;
        }
        let m = Measures {
            d_f: excess,
            d_f_stderr: 0.0,
            mean_force: a1,
            stick_fraction: Totals::of(w).stick_fraction(),
            period: f64::NAN,
            peak_force: a1 + 0.5 * excess,
            trough_force: a1 - 0.5 * excess,
            cycles: 0,
        };
        Some((m, error))
    }

    /// Whether the window from `start` to now (whole blocks) holds stick-slip, a settled force,
    /// or a force still on its way to its level (docs/model.md: such a window does not count).
    ///
    /// A drop of the smoothed force whose peak lies in the window is stick-slip. Otherwise the
    /// window is cut into thirds with mean forces `m_0, m_1, m_2`: the force is settled when the
    /// change across the window, `1.5 |m_2 − m_0|` (the thirds' centres lie two thirds of it
    /// apart), is at most `range_tol` \[N\] and the window's mean lies within `mean_tol`
    /// (relative) of the level: the asymptote of the thirds where they approach one
    /// geometrically (Aitken's Δ²), else the thirds must agree to `mean_tol`.
    pub fn trend(&self, start: f64, range_tol: f64, mean_tol: f64) -> Trend {
        if self
            .whole
            .as_ref()
            .is_some_and(|z| z.drops.last().is_some_and(|d| d.peak_t >= start))
        {
            return Trend::StickSlip;
        }
        let w = self.blocks_from(start);
        if w.len() < 6 {
            return Trend::Settled;
        }
        let [m0, m1, m2] = thirds(w);
        let mean = Totals::of(w).mean();
        if 1.5 * (m2 - m0).abs() > range_tol || !near_level(m0, m1, m2, mean, mean_tol) {
            return Trend::Trending;
        }
        Trend::Settled
    }

    /// The measures over the whole blocks from `start` to now, as [`Analyzer::finish`] gives
    /// them over its fixed window: for a run continued past its planned time, whose window
    /// moved with its end.
    pub fn window_measures(&self, start: f64) -> Measures {
        let w = self.blocks_from(start);
        let all = Totals::of(w);
        let drops = match self.whole.as_ref() {
            Some(z) => &z.drops[z.drops.partition_point(|d| d.peak_t < start)..],
            None => &[][..],
        };
        if drops.is_empty() {
            return sliding_measures(all.lo, all.hi, all.mean(), all.stick_fraction());
        }
        cycle_measures(drops, all.mean(), all.stick_fraction())
    }

    /// The mean force over the whole stick-slip cycles of the window from `start` (first to last
    /// peak of a drop there, whole blocks): the window's mean without the bias of the cycle its
    /// ends cut, up to half a cycle's swing over the number of cycles. `None` without block
    /// statistics or with fewer than two drops in the window.
    pub fn cycle_mean(&self, start: f64) -> Option<f64> {
        let z = self.whole.as_ref()?;
        let drops = &z.drops[z.drops.partition_point(|d| d.peak_t < start)..];
        if drops.len() < 2 {
            return None;
        }
        let w = self.blocks_from(start);
        let a = w.partition_point(|b| b.start < drops[0].peak_t);
        let b = w.partition_point(|b| b.start < drops[drops.len() - 1].peak_t);
        let t = Totals::of(&w[a..b]);
        (t.n > 0).then(|| t.mean())
    }

    /// Whether the window `[t/2, t]` (whole blocks) already gives the stick-slip amplitude and
    /// the mean force to the requested precision: at least `min_drops` drops whose peaks lie in
    /// it, a standard error of their mean of at most `stderr` \[N\], and a mean force that differs
    /// by less than `drift` (relative) from the mean over the whole cycles in the window (first to
    /// last peak), so that the cycle cut by the window's ends does not bias it. Then returns the
    /// measures of that window, as [`Analyzer::finish`] would give them for a run ending at `t`
    /// (the drops are those of a detector run over the whole trace, so a drop whose peak lies in
    /// the window counts even when the window starts on its last rise).
    pub fn steady_cycles(
        &self,
        t: f64,
        min_drops: usize,
        stderr: f64,
        drift: f64,
    ) -> Option<Measures> {
        let z = self.whole.as_ref()?;
        let w = self.window_blocks(t);
        let start = w.first()?.start;
        let drops = &z.drops[z.drops.partition_point(|d| d.peak_t < start)..];
        if drops.len() < min_drops.max(2) {
            return None;
        }
        let all = Totals::of(w);
        let a = w.partition_point(|b| b.start < drops[0].peak_t);
        let b = w.partition_point(|b| b.start < drops[drops.len() - 1].peak_t);
        let cycle_mean = Totals::of(&w[a..b]).mean();
        let m = cycle_measures(drops, all.mean(), all.stick_fraction());
        let unbiased = (m.mean_force - cycle_mean).abs() < drift * cycle_mean.abs();
        (m.d_f_stderr <= stderr && unbiased).then_some(m)
    }

    /// The measures over the window seen so far.
    pub fn finish(&self) -> Measures {
        let mean_force = if self.n > 0 {
            self.sum_raw / self.n as f64
        } else {
            f64::NAN
        };
        let stick_fraction = if self.n > 0 {
            self.stick as f64 / self.n as f64
        } else {
            f64::NAN
        };
        if self.window.drops.is_empty() {
            return sliding_measures(self.smin, self.smax, mean_force, stick_fraction);
        }
        cycle_measures(&self.window.drops, mean_force, stick_fraction)
    }
}

/// One stick-slip drop: the peak of the smoothed force before a slip (time, value) and the
/// trough after it.
#[derive(Clone, Copy, Debug)]
struct Drop {
    peak_t: f64,
    peak: f64,
    trough: f64,
}

/// A peak-and-trough (zig-zag) detector with hysteresis on the smoothed force. It starts in the
/// falling state, so a drop whose peak it has not seen is never counted.
#[derive(Clone, Debug)]
struct ZigZag {
    threshold: f64,
    rising: bool,
    ext: f64,
    ext_t: f64,
    pending_peak: Option<(f64, f64)>,
    drops: Vec<Drop>,
}

impl ZigZag {
    fn new(threshold: f64) -> ZigZag {
        ZigZag {
            threshold,
            rising: false,
            ext: f64::INFINITY,
            ext_t: 0.0,
            pending_peak: None,
            drops: Vec::with_capacity(64),
        }
    }

    fn push(&mut self, t: f64, f: f64) {
        if self.rising {
            if f > self.ext {
                self.ext = f;
                self.ext_t = t;
            } else if f < self.ext - self.threshold {
                // A peak: the slip has begun.
                self.pending_peak = Some((self.ext, self.ext_t));
                self.rising = false;
                self.ext = f;
                self.ext_t = t;
            }
        } else if f < self.ext {
            self.ext = f;
            self.ext_t = t;
        } else if f > self.ext + self.threshold {
            // A trough: the slip has ended; it closes the drop of the pending peak.
            if let Some((peak, peak_t)) = self.pending_peak.take() {
                self.drops.push(Drop {
                    peak_t,
                    peak,
                    trough: self.ext,
                });
            }
            self.rising = true;
            self.ext = f;
            self.ext_t = t;
        }
    }
}

/// The mean forces of the three thirds of a run of blocks.
fn thirds(w: &[Block]) -> [f64; 3] {
    let third = w.len() / 3;
    [
        Totals::of(&w[..third]).mean(),
        Totals::of(&w[third..2 * third]).mean(),
        Totals::of(&w[2 * third..]).mean(),
    ]
}

/// The measures of a window without stick-slip: dF is the max − min `hi − lo` of the smoothed
/// force (docs/model.md), peak and trough its extremes.
fn sliding_measures(lo: f64, hi: f64, mean_force: f64, stick_fraction: f64) -> Measures {
    Measures {
        d_f: hi - lo,
        d_f_stderr: 0.0,
        mean_force,
        stick_fraction,
        period: f64::NAN,
        peak_force: hi,
        trough_force: lo,
        cycles: 0,
    }
}

/// Whether a window with mean force `mean` and thirds' means `m0, m1, m2` lies within `drift`
/// (relative) of its level: the asymptote of the thirds where they approach one geometrically
/// (means of an exponential over equal spans form a geometric sequence: Aitken's Δ²); where
/// they do not, the thirds must agree to `drift`.
fn near_level(m0: f64, m1: f64, m2: f64, mean: f64, drift: f64) -> bool {
    let (d1, d2) = (m1 - m0, m2 - m1);
    let thirds_agree = d1.abs().max(d2.abs()) < drift * mean.abs();
    if d1 * d2 > 0.0 && d2.abs() < d1.abs() {
        let q = d2 / d1;
        let asymptote = m2 + d2 * q / (1.0 - q);
        // With q ≤ 1/2 what is left of the approach beyond the last third is at most d2, so
        // thirds that agree to the drift bound it as well.
        (mean - asymptote).abs() < drift * asymptote.abs() || (q <= 0.5 && thirds_agree)
    } else {
        thirds_agree
    }
}

/// [`Analyzer::settling`] extrapolates a level at most this relative distance beyond the mean
/// of the window's last sixth (0.5 %, docs/model.md's accuracy of the mean force) ...
pub const SETTLING_REACH: f64 = 0.005;
/// ... and states at least this share of that distance as its error bound. At v_d = 0.5 mm/s,
/// k_d = 11 700 N/m, f = 1500 Hz, v_a/v_d = 1.7 the force approaches 4.838 N along an
/// exponential of about 5 s from 3 to 6 s (fits through that window give 5.26 N), then of
/// about 2.5 s: the reach keeps the extrapolation to where the approach has straightened.
pub const SETTLING_SHARE: f64 = 0.25;

/// What the window of a run holds ([`Analyzer::trend`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Trend {
    /// Stick-slip drops: dF is their mean, and a creep of the level does not enter it.
    StickSlip,
    /// Sliding, with the smoothed force at its level to the tolerances asked for.
    Settled,
    /// Sliding, with the smoothed force still on its way to its level.
    Trending,
}

/// Totals of a run of blocks: extremes of the smoothed force, sum of the raw force, samples and
/// stick samples.
struct Totals {
    lo: f64,
    hi: f64,
    sum: f64,
    n: u64,
    stick: u64,
}

impl Totals {
    fn of(bs: &[Block]) -> Totals {
        bs.iter().fold(
            Totals {
                lo: f64::INFINITY,
                hi: f64::NEG_INFINITY,
                sum: 0.0,
                n: 0,
                stick: 0,
            },
            |t, b| Totals {
                lo: t.lo.min(b.min),
                hi: t.hi.max(b.max),
                sum: t.sum + b.sum_raw,
                n: t.n + b.n as u64,
                stick: t.stick + b.stick as u64,
            },
        )
    }

    /// Mean raw force \[N\] (NaN without samples).
    fn mean(&self) -> f64 {
        self.sum / self.n as f64
    }

    fn stick_fraction(&self) -> f64 {
        self.stick as f64 / self.n as f64
    }
}

/// The measures of a run of drops (at least one): dF as their mean drop with its standard error
/// `std/√n`, the period as the mean spacing of their peaks, the mean peak and trough.
fn cycle_measures(drops: &[Drop], mean_force: f64, stick_fraction: f64) -> Measures {
    let nd = drops.len();
    let n = nd as f64;
    let d_f = drops.iter().map(|d| d.peak - d.trough).sum::<f64>() / n;
    let d_f_stderr = if nd > 1 {
        let var = drops
            .iter()
            .map(|d| (d.peak - d.trough - d_f).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        (var / n).sqrt()
    } else {
        0.0
    };
    let period = if nd > 1 {
        (drops[nd - 1].peak_t - drops[0].peak_t) / (n - 1.0)
    } else {
        f64::NAN
    };
    Measures {
        d_f,
        d_f_stderr,
        mean_force,
        stick_fraction,
        period,
        peak_force: drops.iter().map(|d| d.peak).sum::<f64>() / n,
        trough_force: drops.iter().map(|d| d.trough).sum::<f64>() / n,
        cycles: nd as u32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run's measures are every measure a run's values give (`of_run`), in the order of all.
    #[test]
    fn the_measures_of_a_run_are_those_a_run_gives() {
        let m = Measures::default();
        let of_run: Vec<Measure> = Measure::ALL
            .into_iter()
            .filter(|k| k.of_run(&m).is_some())
            .collect();
        assert_eq!(of_run, Measure::OF_RUN);
        for k in Measure::ALL {
            assert_eq!(Measure::from_name(k.name()), Some(k));
        }
    }

    /// A saw-tooth: linear rise from 5 to 11 N over 0.9 s, then a fall back over 0.1 s.
    fn saw(t: f64) -> f64 {
        let ph = t.rem_euclid(1.0);
        if ph < 0.9 {
            5.0 + 6.0 * ph / 0.9
        } else {
            11.0 - 6.0 * (ph - 0.9) / 0.1
        }
    }

    #[test]
    fn cycle_mean_removes_the_bias_of_a_cut_cycle() {
        // The saw-tooth's mean over whole cycles is 8 N (the average of 5 and 11 along both
        // straight flanks). A window from 4.1 s to 9.6 s holds half a rise more than whole
        // cycles, so its plain mean lies off 8; the mean from the first to the last peak does not.
        let dt = 1e-3;
        let mut a = Analyzer::with_blocks(1, 4.1, 0.1, 1e-4, 1e-2, 1000);
        for k in 0..9_600 {
            let t = k as f64 * dt;
            a.push(t, saw(t), 1.0);
        }
        let plain = a.finish().mean_force;
        let whole = a.cycle_mean(4.1).expect("drops in the window");
        assert!(
            (plain - 8.0).abs() > 0.04,
            "the cut window's mean {plain} should be biased"
        );
        assert!((whole - 8.0).abs() < 0.01, "mean over whole cycles {whole}");
        // Without block statistics there is nothing to cut at.
        let b = Analyzer::new(1, 4.3, 0.1, 1e-4);
        assert!(b.cycle_mean(4.3).is_none());
    }

    #[test]
    fn saw_tooth_gives_its_drop_period_and_mean() {
        let dt = 1e-3;
        // Window starts in the middle of a fall: that partial drop must not count; the last
        // peak's trough (at t = 10) lies past the data, so that drop is not closed either.
        let mut a = Analyzer::new(1, 4.95, 0.1, 1e-4);
        for k in 0..10_000 {
            let t = k as f64 * dt;
            a.push(t, saw(t), 1.0);
        }
        let m = a.finish();
        assert_eq!(m.cycles, 4, "{m:?}");
        assert!((m.d_f - 6.0).abs() < 0.07, "{m:?}");
        assert!(m.d_f_stderr < 1e-9);
        assert!((m.period - 1.0).abs() < 2e-3, "{m:?}");
        assert!((m.mean_force - 8.0).abs() < 0.02, "{m:?}");
        assert!(
            (m.peak_force - 11.0).abs() < 0.07 && (m.trough_force - 5.0).abs() < 0.07,
            "{m:?}"
        );
        assert_eq!(m.stick_fraction, 0.0);
    }

    /// One drop in the window: 0 spread for a run whose cycles repeat, an unknown one for a run
    /// with vibration (r's error then too: `tests/cli.rs`); two drops of different size give
    /// their spread over √2.
    #[test]
    fn a_single_cycle_of_a_vibrated_run_has_no_standard_error() {
        let dt = 1e-3;
        // The saw-tooth drops at t = 1, 2, ...: a window from 7.95 s to 9.5 s closes one drop
        // (at 9; the one at 8 began before the window).
        let mut a = Analyzer::new(1, 7.95, 0.1, 1e-4);
        for k in 0..9_500 {
            a.push(k as f64 * dt, saw(k as f64 * dt), 1.0);
        }
        let m = a.finish();
        assert_eq!(m.cycles, 1, "{m:?}");
        assert!((m.d_f - 6.0).abs() < 0.07, "{m:?}");
        assert_eq!(m.d_f_stderr, 0.0);
        let v = m.varying_cycles();
        assert!(v.d_f_stderr.is_nan(), "{v:?}");
        // Two drops of 6 and 4 N: mean 5 N, standard error |6 − 4| / 2 = 1 N, kept.
        let drops = [
            Drop {
                peak_t: 1.0,
                peak: 11.0,
                trough: 5.0,
            },
            Drop {
                peak_t: 2.0,
                peak: 10.0,
                trough: 6.0,
            },
        ];
        let two = cycle_measures(&drops, 8.0, 0.0).varying_cycles();
        assert_eq!((two.cycles, two.d_f), (2, 5.0));
        assert!((two.d_f_stderr - 1.0).abs() < 1e-12, "{two:?}");
    }

    /// A force settling exponentially on 3 N: steady sliding is declared only once the window's
    /// mean lies within the drift of the asymptote, and it is declared eventually, for a fast and
    /// a slow approach.
    #[test]
    fn steady_sliding_bounds_the_distance_to_the_asymptote() {
        for tau in [0.3, 2.0] {
            let dt = 1e-3;
            let drift = 1e-3;
            let mut a = Analyzer::with_blocks(1, f64::INFINITY, 0.1, 1e-4, 0.01, 4000);
            let mut first = None;
            for i in 0..40_000 {
                let t = i as f64 * dt;
                a.push(t, 3.0 - 2.0 * (-t / tau).exp(), 1.0);
                if i % 100 == 0
                    && i > 0
                    && let Some(m) = a.steady_sliding(t, 10.0, drift)
                {
                    let err = (m.mean_force - 3.0).abs() / 3.0;
                    assert!(err < drift, "tau {tau}, t {t}: mean {}", m.mean_force);
                    first.get_or_insert(t);
                }
            }
            let t = first.expect("never settled");
            // The window [t/2, t] mean is within 0.1 % once 2 e^{-t/2τ} τ/(t/2) < 3e-3.
            assert!(t < 30.0 * tau, "tau {tau}: settled only at {t}");
        }
    }

    /// A force settling on 3 N, smoothed over a 100 Hz ripple: the level is extrapolated once
    /// the slope bound allows and the approach has come within the reach (0.5 % of the level),
    /// and it is the force's own to within the stated error bound (at most 0.1 %). With two
    /// time constants (2 and 8 s) only once the faster has died out; with a tight slope bound
    /// only once the force is that flat.
    #[test]
    fn settling_extrapolates_the_level_of_an_exponential_approach() {
        let (k, t_max, tau) = (20, 60.0, 2.0);
        let dt = 1.0 / (100.0 * k as f64);
        let one = |s: f64| 3.0 - 2.0 * (-s / tau).exp();
        let two = |s: f64| 3.0 - (-s / tau).exp() - (-s / (4.0 * tau)).exp();
        // (force, slope bound, earliest allowed extrapolation: the reach is met from 9.8 s with
        // one exponential, from 33.6 s with two; the slope 1e-4 N/s from 18.4 s)
        for (force, slope, earliest) in [
            (&one as &dyn Fn(f64) -> f64, 0.05, 9.8),
            (&one, 1e-4, 18.4),
            (&two, 0.05, 33.6),
        ] {
            let mut a = Analyzer::with_blocks(k, f64::INFINITY, 0.5, 1e-4, t_max / 8000.0, 8000);
            let mut found = None;
            for i in 0..(t_max / dt) as usize {
                let t = i as f64 * dt;
                let w = 2.0 * std::f64::consts::PI * 100.0 * t;
                a.push(t, force(t) + 0.2 * w.sin(), 1.0);
                if i % 1000 == 0
                    && i > 0
                    && let Some(m) = a.settling(0.5 * t, slope, 1e-3, 1e-3)
                {
                    found = Some((t, m));
                    break;
                }
            }
            let (t, (m, err)) = found.expect("a plain exponential approach is extrapolated");
            assert!(
                t >= earliest,
                "extrapolated at {t}, before {earliest}: {m:?}"
            );
            assert!(t < earliest + 6.0, "extrapolated only at {t}");
            // At most the fits' tolerance or a quarter of the reach, 0.25 × 0.5 % of 3 N.
            assert!(err <= 3.75e-3, "error bound {err}");
            assert!((m.mean_force - 3.0).abs() <= err, "{m:?} ± {err}");
            assert!(m.d_f < 1e-3, "{m:?}");
            assert_eq!(m.cycles, 0);
        }
    }

    /// A window still on its way is `Trending` until the change across it and the distance to
    /// its level fall within the tolerances; a saw-tooth is stick-slip whatever its trend.
    #[test]
    fn trend_tells_a_creeping_window_from_a_settled_one() {
        let (k, t_max) = (20, 60.0);
        let dt = 1.0 / (100.0 * k as f64);
        let creep = |s: f64| 3.0 - 2.0 * (-s / 4.0).exp();
        let mut a = Analyzer::with_blocks(k, f64::INFINITY, 0.5, 1e-4, t_max / 4000.0, 4000);
        let mut first_settled = None;
        for i in 0..(t_max / dt) as usize {
            let t = i as f64 * dt;
            a.push(t, creep(t), 1.0);
            if i % 2000 == 0 && t > 2.0 {
                let trend = a.trend(0.5 * t, 0.01, 1e-3);
                assert_ne!(trend, Trend::StickSlip);
                if trend == Trend::Settled {
                    first_settled.get_or_insert(t);
                } else {
                    assert!(first_settled.is_none(), "trending again at {t}");
                }
            }
        }
        // By quadrature of the creep over [t/2, t] (1.5 × the thirds' spread below 0.01 N and the
        // mean within 0.1 % of the thirds' asymptote): first at t = 40 s with checks each second.
        let t = first_settled.expect("settles within 60 s");
        assert!((39.0..=41.0).contains(&t), "settled at {t}");
        let mut z = Analyzer::with_blocks(1, f64::INFINITY, 0.5, 1e-4, 0.01, 4000);
        for i in 0..20_000 {
            let t = i as f64 * 1e-3;
            z.push(t, saw(t) + 0.05 * t, 1.0);
        }
        assert_eq!(z.trend(10.0, 0.01, 1e-3), Trend::StickSlip);
    }

    /// A small mean force that wanders about its level (as where vibration far above the drive
    /// velocity leaves a few hundredths of a newton) is no settling approach: two exponentials
    /// through the wander can agree on a level they only extrapolate. A prediction, if any, must
    /// hold the planned window's mean and max − min to the tolerances asked for.
    #[test]
    fn settling_keeps_its_tolerances_on_a_force_wandering_about_its_level() {
        let (k, t_plan, level, tol) = (20, 40.0, 0.02, 1e-3);
        let dt = 1.0 / (100.0 * k as f64);
        for amp in [1e-5, 3e-5, 1e-4, 3e-4] {
            // Eight incommensurate slow swings, over a 100 Hz ripple.
            let wander = |t: f64| {
                (0..8)
                    .map(|j| {
                        let f = 0.31 * 1.37f64.powi(j);
                        amp * (2.0 * std::f64::consts::PI * f * t + j as f64).sin()
                    })
                    .sum::<f64>()
            };
            // The planned window's mean and max − min (the ripple averages out over a period).
            let n = 200_000;
            let s = |j: usize| 0.5 * t_plan * (1.0 + j as f64 / n as f64);
            let mean = level + (0..n).map(|j| wander(s(j))).sum::<f64>() / n as f64;
            let (lo, hi) = (0..=n)
                .map(|j| wander(s(j)))
                .fold((f64::MAX, f64::MIN), |(l, h), w| (l.min(w), h.max(w)));
            let mut a = Analyzer::with_blocks(k, f64::INFINITY, 0.5, 1e-4, t_plan / 4000.0, 4000);
            let mut checks = 0;
            for i in 0..(t_plan / dt) as usize {
                let t = i as f64 * dt;
                let w = 2.0 * std::f64::consts::PI * 100.0 * t;
                a.push(t, level + wander(t) + 1e-3 * w.sin(), 1.0);
                if i % 50 == 0 && t > 1.0 {
                    checks += 1;
                    if let Some((m, err)) = a.settling(0.5 * t, 0.05, tol, tol) {
                        // Never extrapolated far: within the wander's reach of the level, and
                        // the stated bound covers the distance to the window's mean.
                        let ok = (m.mean_force - level).abs() <= 8.0 * amp + tol * level
                            && (m.mean_force - mean).abs() <= err + (hi - lo)
                            && m.d_f <= tol;
                        assert!(ok, "amp {amp}, at {t}: {m:?} ± {err} against {mean}");
                    }
                }
            }
            assert!(checks > 1000);
        }
    }

    #[test]
    fn smoothing_over_one_period_removes_the_ripple() {
        // A constant force plus a 100 Hz ripple of 1 N and its third harmonic.
        let k = 20;
        let dt = 1.0 / (100.0 * k as f64);
        let mut a = Analyzer::new(k, 0.5, 0.05, 1e-3);
        for i in 0..(k * 100) {
            let t = i as f64 * dt;
            let w = 2.0 * std::f64::consts::PI * 100.0 * t;
            a.push(t, 8.0 + w.sin() + 0.3 * (3.0 * w).cos(), 0.0);
        }
        let m = a.finish();
        assert_eq!(m.cycles, 0);
        assert!(m.d_f < 1e-9, "{m:?}");
        assert!((m.mean_force - 8.0).abs() < 1e-9);
        assert_eq!(m.stick_fraction, 1.0);
    }
}
