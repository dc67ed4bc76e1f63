//! What a plan is: its options and errors, the recordings it proposes with what each gains,
//! the outcomes it expects for every pair of rivals, and its steps.

use super::rivals::Rival;
use super::space::{Candidate, Space};

/// Options of a plan.
#[derive(Clone, Debug)]
pub struct PlanOptions {
    /// Recordings to plan. Default 6; 1 to 30.
    pub recordings: usize,
    /// Candidates of the grid whose rivals' Jacobians are differenced (the best by their
    /// discrimination before any refit); at least [`PlanOptions::recordings`]. Default 24;
    /// up to 200.
    pub finalists: usize,
    /// Check the plan by simulation ([`super::verify`]): each rival as the truth, every rival refitted
    /// to the existing and the planned recordings. Default true.
    pub check: bool,
    /// Seed of the simulated noise. Default 1.
    pub seed: u64,
    /// Where the diagnosis names an effect only in part and tried nothing beside it, fit each
    /// candidate beside it and keep those that lower its gap as rivals ([`super::second`]): minutes
    /// more on a 30-recording campaign. Default false.
    pub second_effects: bool,
    /// Draw the recordings at random from the design space's candidates (seeded by
    /// [`PlanOptions::seed`]) instead of by the criterion: the baseline a plan must beat. No
    /// simulation runs. Default false.
    pub random: bool,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            recordings: 6,
            finalists: 24,
            check: true,
            seed: 1,
            second_effects: false,
            random: false,
        }
    }
}

/// A plan that cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A bad option.
    #[error("`{field}` = {value}: {allowed}")]
    Option {
        /// The option.
        field: &'static str,
        /// Its value.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// The diagnosis does not give what a plan needs.
    #[error("the diagnosis: {0}")]
    Diagnosis(String),
    /// Nothing to plan for.
    #[error("{0}")]
    Nothing(String),
}

impl PlanOptions {
    /// Checks every option, naming the bound violated.
    pub fn validate(&self) -> Result<(), PlanError> {
        if !(1..=30).contains(&self.recordings) {
            return Err(PlanError::Option {
                field: "recordings",
                value: self.recordings.to_string(),
                allowed: "from 1 to 30".into(),
            });
        }
        if !(self.recordings..=200).contains(&self.finalists) {
            return Err(PlanError::Option {
                field: "finalists",
                value: self.finalists.to_string(),
                allowed: format!("from the recordings planned ({}) to 200", self.recordings),
            });
        }
        Ok(())
    }
}

/// What a planned recording is expected to add to one pair of rivals.
#[derive(Clone, Debug)]
pub struct PairGain {
    /// The two rivals (indices into [`Plan::rivals`]).
    pub pair: (usize, usize),
    /// The discrimination it adds \[nats\], `min(D_ab, D_ba)` after it less before it.
    pub nats: f64,
}

/// One planned recording.
#[derive(Clone, Debug)]
pub struct Planned {
    /// Its name (the stem of its conditions file).
    pub name: String,
    /// Its conditions and duration.
    pub candidate: Candidate,
    /// What it adds to each open pair.
    pub gains: Vec<PairGain>,
    /// The pair worst told apart before it (the one it was chosen for), and the features that
    /// carry its discrimination of that pair, with their RMS standardised difference.
    pub chosen_for: (usize, usize),
    /// Features carrying it, with their root summed squares of standardised differences.
    pub carriers: Vec<(&'static str, f64)>,
    /// One sentence why.
    pub why: String,
}

/// One ordered pair of rivals after the plan: `truth` true, evidence for it against `other`.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The rival taken as the truth.
    pub truth: usize,
    /// The rival it is compared with.
    pub other: usize,
    /// Held-out ln odds for `truth` against `other` now \[nats\] (from the diagnosis).
    pub now: f64,
    /// Expected after the planned recordings, by the criterion: `now + D_truth,other`.
    pub expected: f64,
    /// Simulated ([`super::verify`]): `now` plus the ln odds of the planned recordings after every
    /// rival is refitted to recordings simulated from `truth` (None: not checked).
    pub simulated: Option<f64>,
    /// Its jackknife standard error over the planned recordings.
    pub simulated_stderr: Option<f64>,
    /// Whether the simulated evidence would then be clear (ln odds at least ln 20 with any one
    /// planned recording left out).
    pub clear: Option<bool>,
}

/// A plan of recordings.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The rivals, the base model first.
    pub rivals: Vec<Rival>,
    /// The open pairs (the maximin's); the others are closed by the existing evidence.
    pub open: Vec<(usize, usize)>,
    /// The planned recordings, in the order chosen.
    pub recordings: Vec<Planned>,
    /// Every ordered pair after the plan.
    pub outcomes: Vec<Outcome>,
    /// The design space.
    pub space: Space,
    /// Candidates of the grid, and how many were finalists.
    pub candidates: usize,
    /// Finalists whose Jacobians were differenced.
    pub finalists: usize,
    /// Every candidate's smallest open-pair discrimination before any refit (for the figure):
    /// `(candidate, nats)`.
    pub screened: Vec<(Candidate, f64)>,
    /// The campaign's noise used: force \[N\], displacement \[m\].
    pub noise: (f64, Option<f64>),
    /// Simulations run: every step's ([`Plan::steps`]), the rivals' fits included.
    pub simulations: usize,
    /// Wall time \[s\].
    pub wall_time: f64,
    /// The plan's steps in the order they ran, each with its wall time and simulations.
    pub steps: Vec<PlanStep>,
    /// What the reader must know.
    pub warnings: Vec<String>,
    /// Whether the recordings were drawn at random ([`PlanOptions::random`]).
    pub random: bool,
}

/// One step of a plan and what it cost ([`Plan::steps`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PlanStep {
    /// The step: `rivals` (the fits a plan makes itself), `linearisation` (each rival's
    /// Jacobian on the campaign's recordings), `candidates` (every rival simulated on every
    /// candidate recording), `finalists` (their predictions differenced), `choice` (the
    /// greedy maximin) and `check` (the planned recordings simulated from each rival, every
    /// rival refitted).
    pub step: &'static str,
    /// Wall time \[s\].
    pub wall: f64,
    /// Simulations run (each a recording under a model).
    pub simulations: usize,
}
