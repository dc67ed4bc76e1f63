//! What stops a sweep.

use crate::sim;

/// What stopped a sweep.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// Journal or output-file trouble.
    #[error("{0}")]
    State(String),
    /// File output.
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    /// Bad run options.
    #[error(transparent)]
    Sim(#[from] sim::SimError),
    /// Stopped on request ([`crate::interrupt`]): every finished run is in the journal and the
    /// checkpoint; resuming continues.
    #[error("interrupted: {recorded} runs recorded in {journal}; resume to continue")]
    Interrupted {
        /// Runs in the journal (this invocation's and earlier ones').
        recorded: usize,
        /// The journal.
        journal: String,
    },
}
