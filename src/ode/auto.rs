//! Automatic switching between Dormand–Prince 5(4) and Radau IIA 5 ([`Method::Auto`]).
//!
//! The run starts explicit. After each accepted Dopri5 step the stiffness test of DOPRI5
//! estimates `h λ̃` (see `Dopri5::h_lambda`); when at least [`STIFF_STEPS`] of the last
//! [`WINDOW`] accepted steps had `h λ̃ >` [`STIFF_H_LAMBDA`], the steps are held by stability,
//! not accuracy, and the run continues with Radau5 from the state reached, with the step Dopri5
//! had. (DOPRI5 itself asks for 15 steps in a row above 3.25; under a large vibration the rig's
//! `h λ̃` sits at 3.2–3.3 through the part of each half-period where the contact slides fast and
//! falls to nothing where `v_r` changes sign, so that rule never fires there.)
//!
//! Radau5 cannot tell cheaply when the stiffness is gone, so after `wait` accepted Radau5 steps
//! the run tries Dopri5 again: if the explicit phase then lasts fewer than [`PROBE_STEPS`]
//! accepted steps before the test fires again, the problem was still stiff and `wait` doubles
//! (from [`MIN_WAIT`] up to [`MAX_WAIT`]); otherwise it starts again from [`MIN_WAIT`].
//!
//! On the rig this follows the phases: the contact's critically damped pole
//! (`h_t / 2m ≈ 1.04·10⁴ /s`) holds Dopri5 while the body sticks without vibration, and the
//! bristles' relaxation `k_t |v_r| / F_c` (Eq. 4.6) while a large vibration drags the contact
//! through every period; slips and moderate vibration, where the forcing sets the step, stay
//! explicit.
//!
//! Under envelope following the run stays explicit: the envelope reads its slopes from the
//! periods it integrates, and a change of method between them shows as curvature (on the
//! 64 × 64 Fig. 11 plane, switching there moved 9 points across the elimination boundary
//! instead of 4 and saved no time).
//!
//! [`Method::Auto`]: super::Method::Auto

use super::dopri5::Dopri5;
use super::radau5::Radau5;
use super::{OdeSystem, Stats, StepOutcome, Stepper};

/// `h λ̃` above which a Dopri5 step counts as limited by stability (the method's stability
/// region reaches −3.3 on the real axis; the controller keeps such steps near 3.2).
const STIFF_H_LAMBDA: f64 = 2.5;
/// Stability-limited steps among the last [`WINDOW`] accepted ones that hand over to Radau5.
const STIFF_STEPS: u32 = 16;
/// Accepted steps the test looks back over.
const WINDOW: u64 = 32;
const WINDOW_MASK: u64 = (1 << WINDOW) - 1;
/// Radau5 steps before the first try of Dopri5 again.
const MIN_WAIT: u64 = 20;
/// Longest wait between tries, in Radau5 steps.
const MAX_WAIT: u64 = 2560;
/// An explicit phase shorter than this many accepted steps was a failed try.
const PROBE_STEPS: u64 = 100;

pub(crate) struct Auto {
    ex: Dopri5,
    im: Radau5,
    /// Radau5 is the active method.
    stiff: bool,
    /// Switch before the next attempt.
    pending: bool,
    /// One bit per accepted Dopri5 step of the phase, the newest lowest: stability-limited.
    window: u64,
    /// Accepted steps of the current phase.
    phase_steps: u64,
    /// Radau5 steps before the next try of Dopri5.
    wait: u64,
    /// Whether the test may hand over at all (not under envelope following).
    pub(crate) switching: bool,
}

impl Auto {
    pub(crate) fn new(n: usize) -> Self {
        let mut ex = Dopri5::new(n);
        ex.detect = true;
        Auto {
            ex,
            im: Radau5::new(n),
            stiff: false,
            pending: false,
            window: 0,
            phase_steps: 0,
            wait: MIN_WAIT,
            switching: true,
        }
    }

    /// Begins a phase of Radau5 (`stiff`) or Dopri5, with a fresh count of its steps.
    fn begin_phase(&mut self, stiff: bool) {
        self.stiff = stiff;
        self.pending = false;
        self.window = 0;
        self.phase_steps = 0;
    }

    /// Starts the other method at the active one's time, state and next step.
    fn switch<S: OdeSystem>(&mut self, sys: &S, st: &mut Stats) {
        if self.stiff {
            let (t, h) = (self.im.t(), self.im.h());
            self.ex.start(sys, t, self.im.y(), h, st);
        } else {
            let (t, h) = (self.ex.t(), self.ex.h());
            self.im.start(sys, t, self.ex.y(), h, st);
        }
        self.begin_phase(!self.stiff);
    }

    /// Bookkeeping after an accepted step of the active method.
    fn accepted(&mut self) {
        if !self.switching {
            return;
        }
        self.phase_steps += 1;
        if self.stiff {
            if self.phase_steps >= self.wait {
                self.pending = true;
            }
            return;
        }
        self.window = (self.window << 1) | u64::from(self.ex.h_lambda > STIFF_H_LAMBDA);
        if self.phase_steps >= WINDOW && (self.window & WINDOW_MASK).count_ones() >= STIFF_STEPS {
            // A short explicit phase means the last try came too soon.
            self.wait = if self.phase_steps < PROBE_STEPS {
                (2 * self.wait).min(MAX_WAIT)
            } else {
                MIN_WAIT
            };
            self.pending = true;
        }
    }
}

impl Stepper for Auto {
    const ORDER: f64 = 4.0;

    /// Also begins a run: it starts explicit, with the shortest wait.
    fn set_tolerances(&mut self, rtol: f64, atol: &[f64]) {
        self.ex.set_tolerances(rtol, atol);
        self.im.set_tolerances(rtol, atol);
        self.begin_phase(false);
        self.wait = MIN_WAIT;
    }

    /// Restarts the active method (after an envelope jump the phase carries on).
    fn start<S: OdeSystem>(&mut self, sys: &S, t0: f64, y0: &[f64], h: f64, st: &mut Stats) {
        if self.pending {
            self.begin_phase(!self.stiff);
        }
        if self.stiff {
            self.im.start(sys, t0, y0, h, st);
        } else {
            self.ex.start(sys, t0, y0, h, st);
        }
    }

    fn t(&self) -> f64 {
        if self.stiff { self.im.t() } else { self.ex.t() }
    }
    fn y(&self) -> &[f64] {
        if self.stiff { self.im.y() } else { self.ex.y() }
    }
    fn h(&self) -> f64 {
        if self.stiff { self.im.h() } else { self.ex.h() }
    }
    fn set_h(&mut self, h: f64) {
        if self.stiff {
            self.im.set_h(h)
        } else {
            self.ex.set_h(h)
        }
    }

    fn attempt<S: OdeSystem>(&mut self, sys: &S, st: &mut Stats) -> StepOutcome {
        if self.pending {
            self.switch(sys, st);
        }
        let out = if self.stiff {
            self.im.attempt(sys, st)
        } else {
            self.ex.attempt(sys, st)
        };
        if let StepOutcome::Accepted = out {
            self.accepted();
        }
        out
    }

    fn dense(&self, t: f64, out: &mut [f64]) {
        // The switch waits for the next attempt, so the active method took the last step.
        if self.stiff {
            self.im.dense(t, out)
        } else {
            self.ex.dense(t, out)
        }
    }
}
