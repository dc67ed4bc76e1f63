//! Progress display, in one place: an indicatif bar on stderr when stderr is a terminal, silence
//! otherwise (logs and CI stay clean).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// The counts of a [`Progress`], shared with a host that draws its own bar (the Python
/// package's tqdm): runs done (resumed ones included), runs in all so far, runs failed.
#[derive(Debug, Default)]
pub struct Tally {
    /// Runs finished.
    pub done: AtomicU64,
    /// Runs planned so far (a refinement adds its rounds as it asks for them).
    pub total: AtomicU64,
    /// Runs that did not succeed.
    pub failed: AtomicU64,
}

impl Tally {
    /// `(done, total, failed)` at this moment.
    pub fn read(&self) -> (u64, u64, u64) {
        (
            self.done.load(Ordering::Relaxed),
            self.total.load(Ordering::Relaxed),
            self.failed.load(Ordering::Relaxed),
        )
    }
}

/// A progress bar for a batch of runs: done of total, rate, ETA, failures so far.
pub struct Progress {
    bar: ProgressBar,
    failures: u64,
    tally: Option<Arc<Tally>>,
}

impl Progress {
    /// A bar over `total` runs of which `done` are already finished (resume); hidden unless
    /// `enabled` and stderr is a terminal.
    pub fn new(total: u64, done: u64, enabled: bool, tally: Option<Arc<Tally>>) -> Progress {
        let target = if enabled && std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(Some(total), target);
        bar.set_style(
            ProgressStyle::with_template(
                "{bar:40.cyan/blue} {pos}/{len} runs  {per_sec}  ETA {eta}  {msg}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar.set_position(done);
        bar.set_message("0 failed");
        if let Some(t) = &tally {
            t.total.store(total, Ordering::Relaxed);
            t.done.store(done, Ordering::Relaxed);
            t.failed.store(0, Ordering::Relaxed);
        }
        Progress {
            bar,
            failures: 0,
            tally,
        }
    }

    /// One run finished.
    pub fn inc(&mut self, failed: bool) {
        if failed {
            self.failures += 1;
            self.bar.set_message(format!("{} failed", self.failures));
        }
        self.bar.inc(1);
        if let Some(t) = &self.tally {
            t.done.fetch_add(1, Ordering::Relaxed);
            t.failed.fetch_add(u64::from(failed), Ordering::Relaxed);
        }
    }

    /// Adds `n` runs to the total (a refinement's next level).
    pub fn grow(&mut self, n: u64) {
        if let Some(len) = self.bar.length() {
            self.bar.set_length(len + n);
        }
        if let Some(t) = &self.tally {
            t.total.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// Clears the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// A spinner with the elapsed time for one long computation without steps to count (a single
/// `run`): it appears only once the computation has taken `after`, on a terminal, and is
/// cleared when dropped.
pub struct Waiting {
    bar: ProgressBar,
}

impl Waiting {
    /// Starts the clock; `what` says what is being waited for.
    pub fn new(what: &str, after: std::time::Duration, enabled: bool) -> Waiting {
        let target = if enabled && std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(None, target);
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg}: {elapsed} so far")
                .expect("valid template"),
        );
        bar.set_message(what.to_string());
        let shown = bar.clone();
        // Short runs stay silent: the spinner starts ticking only after `after`.
        std::thread::spawn(move || {
            std::thread::sleep(after);
            if !shown.is_finished() {
                shown.enable_steady_tick(std::time::Duration::from_millis(200));
            }
        });
        Waiting { bar }
    }
}

impl Drop for Waiting {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}
