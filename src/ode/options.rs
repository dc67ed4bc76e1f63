//! The per-call options of the integrators: tolerances and step limits ([`Options`]), and
//! envelope following ([`Envelope`]); each validates its documented ranges.

use std::cmp::Ordering;
/// Per-call options. Every field documents its unit, default and valid range;
/// [`Options::validate`] quotes the violated bound.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Relative tolerance (dimensionless). Default 1e-6. Range: 1e-13 ≤ rtol ≤ 0.1.
    pub rtol: f64,
    /// Absolute tolerance, in units of each component's [`OdeSystem::scale`](super::OdeSystem::scale) (dimensionless).
    /// Default 1e-6. Range: 0 < atol ≤ 1.
    pub atol: f64,
    /// Initial step size (units of t). Default 0: chosen automatically. Range: ≥ 0.
    pub h0: f64,
    /// Largest step size (units of t). Default ∞. Range: > 0.
    pub h_max: f64,
    /// Most steps (accepted and rejected) before the run stops with [`Status::MaxSteps`](super::Status::MaxSteps).
    /// Default 50 000 000. Range: ≥ 1.
    pub max_steps: u64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            rtol: 1e-6,
            atol: 1e-6,
            h0: 0.0,
            h_max: f64::INFINITY,
            max_steps: 50_000_000,
        }
    }
}

/// An option outside its valid range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("option `{field}` = {value} is out of range: {allowed}")]
pub struct OptionError {
    /// Name of the offending field.
    pub field: &'static str,
    /// The value given.
    pub value: f64,
    /// The allowed range, in words.
    pub allowed: &'static str,
}

impl Options {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), OptionError> {
        let bad = |field, value, allowed| {
            Err(OptionError {
                field,
                value,
                allowed,
            })
        };
        if !(self.rtol >= 1e-13 && self.rtol <= 0.1) {
            return bad("rtol", self.rtol, "1e-13 <= rtol <= 0.1");
        }
        if !(self.atol > 0.0 && self.atol <= 1.0) {
            return bad("atol", self.atol, "0 < atol <= 1");
        }
        if !(self.h0 >= 0.0 && self.h0.is_finite()) {
            return bad("h0", self.h0, "finite and >= 0 (0 chooses automatically)");
        }
        if self.h_max.partial_cmp(&0.0) != Some(Ordering::Greater) {
            return bad("h_max", self.h_max, "h_max > 0");
        }
        if self.max_steps == 0 {
            return bad("max_steps", 0.0, "max_steps >= 1");
        }
        Ok(())
    }
}

/// Envelope following for a system forced with a known period `T`: stroboscopic projective
/// integration (after Petzold's envelope following and the projective integrators of Gear and
/// Kevrekidis).
///
/// The state sampled once per period, `S_n = y(t0 + n T)`, changes slowly while the forced
/// response settles to a slowly drifting periodic one (here: sticking or steady sliding under
/// vibration). The driver integrates the full system period by period; once the slope over a
/// baseline of `L` settled periods, `Δ_n = (S_n − S_{n−L}) / L`, is known, it jumps `M` whole
/// periods at once,
///
/// ```text
/// S_{n+M} = S_n + M Δ_n,
/// ```
///
/// choosing the largest `M` whose extrapolation error `M (M+L)/2 · ‖c‖` stays below [`tol`]
/// (`c`, the change of the slope per period, is measured between the last two baselines,
/// `(S_n − 2 S_{n−L} + S_{n−2L}) / L²`, and across the previous jump; the slope, a mean over the
/// baseline, lags the one at `S_n` by `L/2` periods of `c`; `‖·‖` is the max norm over all
/// components, in units of [`OdeSystem::scale`](super::OdeSystem::scale)). A baseline of several periods averages out
/// what changes from period to period without drifting (the integrator's noise, a decaying
/// alternating mode), which one-period differences would read as curvature. The slopes are
/// differences of integrated states, so the integrator's own error must lie well below `tol`:
/// [`Envelope::inner_tolerance`] gives the tolerance the periods are integrated with ([`inner`]
/// times `tol` at most). Output times inside a jump get the last integrated period's samples at
/// the same phase, shifted by the envelope (`y(t + mT) ≈ y(t) + m Δ_n`), so a moving average over
/// one period sees the drift only. Fast transients that a jump excites in stiff components decay
/// during the [`settle`] periods integrated after it, before the slope is measured again. Where the envelope bends
/// (a slip starting), `M` falls below 2 and the driver integrates every period.
///
/// Where `M` stays below 2 for `settle + 2L` checks in a row (a slip, or a response that does
/// not repeat with the forcing at all: subharmonic or quasi-periodic, as the rig's near its
/// contact's pole), the inner tolerance buys nothing, and where the tolerance asked for is
/// looser the driver integrates at that one: for `2 (settle + 2L)` periods first, then it tries
/// the inner tolerance again (`settle + 2L` periods, the slope measured on them alone) and, if
/// still refused, goes on for twice as long, up to 4096 periods. At v_d = 0.1 mm/s,
/// k_d = 1000 N/m, 1741 Hz, u0 = 9.854 nm (`stickslip run`, envelope 1e-4, rtol 1e-6): 17.4 s
/// → 10.1 s, the mean force 10.5973 N against 10.5979 N integrating every period at 1e-6
/// (10.5509 N before, the inner tolerance throughout).
///
/// The output grid must start at `t0`, a period boundary, and hold [`period_samples`] samples
/// per period: the period is `period_samples · grid.step`.
///
/// [`tol`]: Envelope::tol
/// [`settle`]: Envelope::settle
/// [`inner`]: Envelope::inner
/// [`period_samples`]: Envelope::period_samples
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Envelope {
    /// Output samples per forcing period. Range ≥ 2.
    pub period_samples: u64,
    /// Largest extrapolation error of one jump, in units of each component's scale (max norm).
    /// Default 2e-3. Range 1e-8 ≤ tol ≤ 0.1.
    pub tol: f64,
    /// Periods integrated after a jump before the slope is measured again. Default 1.
    /// Range 1 to 100.
    pub settle: u32,
    /// Periods each slope is measured over (`L`): the slope is `(S_n − S_{n−L})/L` and its
    /// change comes from two such baselines. Default 1. Range 1 to 50.
    pub baseline: u32,
    /// Longest jump \[periods\]. Default 200. Range ≥ 2.
    pub max_jump: u64,
    /// Tolerance of the integrated periods as a fraction of [`Envelope::tol`] (the integration
    /// tolerance asked for is lowered to `inner · tol` where it is larger). The period-to-period
    /// noise of the sampled states, which the slopes and their change carry, is about a hundred
    /// times the integration tolerance on the rig, so jumps of `M` periods need `inner` well below
    /// `1 / M`. Default 0.01. Range 1e-5 ≤ inner ≤ 0.1 (so that `inner · tol` stays a valid
    /// [`Options::rtol`]).
    pub inner: f64,
}

impl Envelope {
    /// Defaults for `period_samples` samples per period.
    pub fn new(period_samples: u64) -> Self {
        Envelope {
            period_samples,
            tol: 2e-3,
            settle: 1,
            baseline: 1,
            max_jump: 200,
            inner: 0.01,
        }
    }

    /// The tolerance to integrate the periods with, given the one asked for: at most
    /// [`Envelope::inner`] times [`Envelope::tol`], so that the integrator's error in a slope
    /// stays well below the extrapolation error allowed.
    pub fn inner_tolerance(&self, tol: f64) -> f64 {
        tol.min(self.inner * self.tol)
    }

    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), OptionError> {
        let bad = |field, value: f64, allowed| {
            Err(OptionError {
                field,
                value,
                allowed,
            })
        };
        if self.period_samples < 2 {
            return bad(
                "envelope.period_samples",
                self.period_samples as f64,
                "period_samples >= 2",
            );
        }
        if !(self.tol >= 1e-8 && self.tol <= 0.1) {
            return bad("envelope.tol", self.tol, "1e-8 <= tol <= 0.1");
        }
        if !(1..=100).contains(&self.settle) {
            return bad("envelope.settle", self.settle as f64, "1 <= settle <= 100");
        }
        if !(1..=50).contains(&self.baseline) {
            return bad(
                "envelope.baseline",
                self.baseline as f64,
                "1 <= baseline <= 50",
            );
        }
        if self.max_jump < 2 {
            return bad("envelope.max_jump", self.max_jump as f64, "max_jump >= 2");
        }
        if !(self.inner >= 1e-5 && self.inner <= 0.1) {
            return bad("envelope.inner", self.inner, "1e-5 <= inner <= 0.1");
        }
        Ok(())
    }
}
