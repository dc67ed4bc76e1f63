//! A request to stop computing, for hosts that catch Ctrl-C themselves (the Python package).
//!
//! The CLI installs no handler: SIGINT ends the process, and a sweep's journal keeps every run
//! that had finished. An embedding host cannot be killed that way, so it calls [`request`] when
//! the user interrupts. The integrators look at the flag every few hundred step attempts and end
//! the run with [`Status::Interrupted`](crate::ode::Status::Interrupted) (well within a second:
//! a step costs microseconds); a sweep records no interrupted run, writes its checkpoint and
//! returns [`SweepError::Interrupted`](crate::sweep::SweepError::Interrupted), so `--resume`
//! (or `resume=True`) continues it. The flag is process-wide, like the signal it stands for.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Asks every run in the process to stop as soon as it can.
pub fn request() {
    REQUESTED.store(true, Ordering::Relaxed);
}

/// Whether a stop was asked for and not yet [`clear`]ed.
#[inline]
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// Withdraws the request, once the interrupted computation has returned.
pub fn clear() {
    REQUESTED.store(false, Ordering::Relaxed);
}
