//! Progress display, in one place: an indicatif bar on stderr when stderr is a terminal, silence
//! otherwise (logs and CI stay clean).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// A progress bar for a batch of runs: done of total, rate, ETA, failures so far.
pub struct Progress {
    bar: ProgressBar,
    failures: u64,
}

impl Progress {
    /// A bar over `total` runs of which `done` are already finished (resume); hidden unless
    /// `enabled` and stderr is a terminal.
    pub fn new(total: u64, done: u64, enabled: bool) -> Progress {
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
        Progress { bar, failures: 0 }
    }

    /// One run finished.
    pub fn inc(&mut self, failed: bool) {
        if failed {
            self.failures += 1;
            self.bar.set_message(format!("{} failed", self.failures));
        }
        self.bar.inc(1);
    }

    /// Ends the bar.
    /// Adds `n` runs to the total (a refinement's next level).
    pub fn grow(&mut self, n: u64) {
        if let Some(len) = self.bar.length() {
            self.bar.set_length(len + n);
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
