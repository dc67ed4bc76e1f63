//! Bookkeeping of envelope following (see [`Envelope`]): the stroboscopic samples, the slope
//! and its change, the choice of the jump and the samples synthesised inside a jump.

use super::Envelope;

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
}

impl Strobe {
    /// Prepares for a run of an `n`-dimensional system with `ps` samples per period and slopes
    /// measured over `baseline` periods.
    pub fn reset(&mut self, n: usize, ps: u64, baseline: u32, scale: impl Fn(usize) -> f64) {
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
            return 0;
        }
        for i in 0..n {
            self.slope[i] = self.baseline_slope(i, lu);
        }
        self.from_period = Some(k);
        self.last_jump = m;
        m
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
