//! Bookkeeping of envelope following (see [`Envelope`]): the stroboscopic samples, the slope
//! and its change, the choice of the jump and the samples synthesised inside a jump.
// The kernels below step several arrays of one state (stages, weights, tolerances) with one
// index, as the method's equations are written.
#![allow(clippy::needless_range_loop)]

use super::options::Envelope;

/// The first stretch at the run's own tolerance, in refusal streaks (see [`Strobe::refuse`]).
pub(crate) const LOOSE_FIRST: u64 = 2;
/// The longest stretch at the run's own tolerance \[periods\].
pub(crate) const LOOSE_LONGEST: u64 = 4096;

/// Buffers of one run, sized once per dimension, period and baseline (no allocation while
/// stepping).
#[derive(Default)]
pub(crate) struct Strobe {
    n: usize,
    ps: u64,
    /// Ring length of the stroboscopic samples: `2 L + 1` for a baseline of `L` periods.
    ring: usize,
    /// The last `ps` output samples, by grid index modulo `ps` (row-major, `ps × n`).
    samples: Vec<f64>,
    /// The last `ring` stroboscopic samples, by boundary count modulo `ring` (row-major).
    s: Vec<f64>,
    /// Boundaries recorded in the run (the landing of a jump counts as one).
    boundaries: u64,
    /// Boundaries recorded since the run started or the last jump landed (its target counts 0).
    since: u32,
    /// Last jump [periods].
    last_jump: u64,
    /// Characteristic size of each component.
    scale: Vec<f64>,
    /// The last jump: the period boundary it started from (`None` before the first) and the
    /// slope it used.
    from_period: Option<u64>,
    slope: Vec<f64>,
    /// Refusals (a jump shorter than 2 periods) in a row.
    refused: u32,
    /// Periods still to integrate at the run's own tolerance (0: at the inner tolerance).
    loose_left: u64,
    /// Length of the next stretch at the run's own tolerance \[periods\] (0: the first).
    loose_span: u64,
    /// The periods at the inner tolerance since the last loose stretch are a retry: one more
    /// refusal loosens again at once.
    retrying: bool,
    /// Tolerance switch for the driver to make: `Some(true)` to the run's own, `Some(false)` to
    /// the inner one.
    change: Option<bool>,
    /// The run's own tolerance is looser than the inner one, so refused stretches may be
    /// integrated at it.
    loosen: bool,
}

impl Strobe {
    /// Prepares for a run of an `n`-dimensional system with `ps` samples per period and slopes
    /// measured over `baseline` periods; `loosen` where the run's own tolerance is looser than
    /// the one the periods are integrated with for their slopes.
    pub fn reset(
        &mut self,
        n: usize,
        ps: u64,
        baseline: u32,
        loosen: bool,
        scale: impl Fn(usize) -> f64,
    ) {
        let ring = 2 * baseline as usize + 1;
        if self.n != n || self.ps != ps || self.ring != ring {
            self.n = n;
            self.ps = ps;
            self.ring = ring;
            self.samples = vec![0.0; ps as usize * n];
            self.s = vec![0.0; ring * n];
            self.slope = vec![0.0; n];
            self.scale = vec![0.0; n];
        }
        for (i, w) in self.scale.iter_mut().enumerate() {
            *w = scale(i);
        }
        self.boundaries = 0;
        self.since = 0;
        self.from_period = None;
        self.last_jump = 0;
        self.refused = 0;
        self.loose_left = 0;
        self.loose_span = 0;
        self.retrying = false;
        self.change = None;
        self.loosen = loosen;
    }

    /// The tolerance switch [`Strobe::plan`] asked for, if any: `Some(true)` to integrate at the
    /// run's own tolerance, `Some(false)` back at the inner one.
    #[inline]
    pub fn take_change(&mut self) -> Option<bool> {
        self.change.take()
    }

    /// Stores a stroboscopic sample.
    fn push(&mut self, y: &[f64]) {
        let r = (self.boundaries % self.ring as u64) as usize * self.n;
        self.s[r..r + self.n].copy_from_slice(y);
        self.boundaries += 1;
    }

    /// Component `i` of the stroboscopic sample `back` boundaries before the latest.
    #[inline]
    fn strobe(&self, back: usize, i: usize) -> f64 {
        let b = (self.boundaries - 1 - back as u64) % self.ring as u64;
        self.s[b as usize * self.n + i]
    }

    /// Slope of component `i` over the last `l` periods, `(S_n − S_{n−l}) / l`.
    #[inline]
    fn baseline_slope(&self, i: usize, l: usize) -> f64 {
        (self.strobe(0, i) - self.strobe(l, i)) / l as f64
    }

    /// Records the output sample of grid index `g`.
    #[inline]
    pub fn record(&mut self, g: u64, y: &[f64]) {
        let r = (g % self.ps) as usize * self.n;
        self.samples[r..r + self.n].copy_from_slice(y);
        if g.is_multiple_of(self.ps) {
            self.push(y);
            self.since += 1;
        }
    }

    /// Called at the period boundary of grid index `g` (just recorded): the jump to take
    /// [periods], or 0 to integrate the next period. `room` is the most periods left in the span.
    pub fn plan(&mut self, g: u64, env: &Envelope, room: u64) -> u64 {
        let k = g / self.ps;
        let settle = env.settle;
        let l = env.baseline;
        let lf = l as f64;
        let (lu, n) = (l as usize, self.n);
        if self.loose_left > 0 {
            self.loose_left -= 1;
            if self.loose_left == 0 {
                // Back at the inner tolerance: the next slope and its change come from periods
                // integrated at it only, after `settle` periods for what the loose ones left.
                self.change = Some(false);
                self.since = 0;
                self.from_period = None;
                self.retrying = true;
            }
            return 0;
        }
        // A slope needs a baseline of settled periods after the last jump target.
        if self.since < settle + l {
            return 0;
        }
        // Change of the slope per period: between the last two baselines when both are
        // settled, and across the previous jump right after one (its baseline spans the jump).
        // Slopes over L periods average out what repeats from period to period without drift
        // (the integrator's noise, a decaying alternating mode).
        let mut curv = 0.0f64;
        let mut known = false;
        if self.since >= settle + 2 * l {
            for i in 0..n {
                let d2 = self.strobe(0, i) - 2.0 * self.strobe(lu, i) + self.strobe(2 * lu, i);
                curv = curv.max((d2 / (lf * lf) / self.scale[i]).abs());
            }
            known = true;
        }
        if let Some(at) = self.from_period
            && self.since <= settle + 2 * l
        {
            let span = (k - at) as f64;
            for i in 0..n {
                let d = (self.baseline_slope(i, lu) - self.slope[i]) / span / self.scale[i];
                curv = curv.max(d.abs());
            }
            known = true;
        }
        if !known {
            return 0;
        }
        // Largest M with M (M+L)/2 · ‖c‖ ≤ tol: the slope, a mean over the baseline, lags the
        // one at its end by L/2 periods of curvature.
        let m_tol = if curv > 0.0 {
            ((-lf + (lf * lf + 8.0 * env.tol / curv).sqrt()) / 2.0).floor()
        } else {
            f64::INFINITY
        };
        let cap = env.max_jump.min(3 * self.last_jump + 4).min(room);
        let m = if m_tol >= cap as f64 {
            cap
        } else {
            m_tol as u64
        };
        if m < 2 {
            self.refuse(settle + 2 * l);
            return 0;
        }
        self.refused = 0;
        self.retrying = false;
        self.loose_span = 0;
        for i in 0..n {
            self.slope[i] = self.baseline_slope(i, lu);
        }
        self.from_period = Some(k);
        self.last_jump = m;
        m
    }

    /// Counts a refusal. After `streak` of them in a row (or one, right after a loose stretch)
    /// the strobe no longer behaves like a drifting fixed point (a slip, or a response that is
    /// not periodic with the forcing: subharmonic or quasi-periodic near the contact's pole), so
    /// the periods are integrated at the run's own tolerance for a stretch of
    /// [`LOOSE_FIRST`] times `streak` periods, doubled after every retry that is refused again
    /// up to [`LOOSE_LONGEST`], then tried at the inner tolerance again.
    fn refuse(&mut self, streak: u32) {
        self.refused += 1;
        if !self.loosen || !self.retrying && self.refused < streak {
            return;
        }
        self.loose_span = if self.loose_span == 0 {
            LOOSE_FIRST * streak as u64
        } else {
            (2 * self.loose_span).min(LOOSE_LONGEST)
        };
        self.loose_left = self.loose_span;
        self.refused = 0;
        self.retrying = false;
        self.change = Some(true);
    }

    /// The sample synthesised for grid index `g` inside the current jump: the last integrated
    /// period's sample at the same phase, shifted by the envelope.
    #[inline]
    pub fn synth(&self, g: u64, out: &mut [f64]) {
        let r = g % self.ps;
        // The source: the same phase in the period ending at the jump's origin.
        let from = self.from_period.unwrap_or(0) * self.ps;
        let src = if r == 0 { from } else { from - self.ps + r };
        let m = ((g - src) / self.ps) as f64;
        let row = r as usize * self.n;
        for i in 0..self.n {
            out[i] = self.samples[row + i] + m * self.slope[i];
        }
    }

    /// Marks the landing of a jump: the target boundary is the new `S_0`.
    pub fn landed(&mut self, y: &[f64]) {
        self.push(y);
        self.since = 0;
    }
}
