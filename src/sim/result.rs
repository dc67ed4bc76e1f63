//! What a run returns: its status, work, measures, the tier that served it, and the errors of
//! bad parameters or options.

use crate::measures::Measures;
use crate::model::{Params, RigError};
use crate::ode::{OptionError, Stats, Status};

use crate::sim::tier::{Tier, TierReason};
use crate::sim::trace::Trace;
use serde::{Deserialize, Serialize};

/// The outcome of one integration of the rig.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// How the integration ended.
    pub status: Status,
    /// Work done.
    pub stats: Stats,
    /// The measures (NaN where the run failed).
    pub measures: Measures,
    /// Simulated time \[s\].
    pub t_end: f64,
    /// Start of the steady window \[s\].
    pub window_start: f64,
    /// Wall-clock time of the integration and analysis \[s\].
    pub wall_time: f64,
    /// Time from which the samples were read off the run's limit cycle instead of integrated
    /// ([`RunOptions::periodic`](crate::sim::RunOptions::periodic)) \[s\]; `None` where every sample was integrated.
    #[serde(default)]
    pub continued_from: Option<f64>,
    /// Error bound of the mean force \[N\] where the measures are those of the settled level,
    /// extrapolated from the force settling along one exponential in the window
    /// `[window_start, t_end]` ([`Analyzer::settling`](crate::measures::Analyzer::settling))
    /// instead of integrated: the larger of the two fits' levels' difference and a share of the
    /// extrapolated distance. `None` where the level was not extrapolated.
    #[serde(default)]
    pub level_error: Option<f64>,
    /// The model that served the run: [`Tier::Full`] (every period integrated) or
    /// [`Tier::Averaged`] (the averaged slow model; its statistics are the slow integration's,
    /// the law's table is counted apart).
    #[serde(default = "full_tier")]
    pub tier: Tier,
    /// Why that tier served ([`choose`](crate::sim::choose::choose)).
    #[serde(default)]
    pub tier_reason: TierReason,
    /// Time traces, when asked for.
    #[serde(skip)]
    pub trace: Option<Trace>,
}

fn full_tier() -> Tier {
    Tier::Full
}

impl RunResult {
    /// Whether the measures are an extrapolated settled level ([`RunResult::level_error`]).
    pub fn predicted(&self) -> bool {
        self.level_error.is_some()
    }
}

/// A run with vibration and its reference without vibration, and the reduction coefficient.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    /// The parameters of the run.
    pub params: Params,
    /// The run itself.
    pub run: RunResult,
    /// The run without vibration at the same `v_d`, `k_d` and load (absent when `u0 = 0`: the
    /// run is its own reference).
    pub reference: Option<RunResult>,
    /// Reduction coefficient `r = dF_sd / dF_ss` (5.1).
    pub r: f64,
    /// Standard error of `r`, propagated from the two dF standard errors.
    pub r_stderr: f64,
}

impl CaseResult {
    /// The worse of the two runs' statuses (success only when both succeeded).
    pub fn status(&self) -> Status {
        match &self.reference {
            Some(r) if r.status != Status::Success => r.status,
            _ => self.run.status,
        }
    }

    /// Work of both runs together.
    pub fn total_stats(&self) -> Stats {
        let mut s = self.run.stats;
        if let Some(r) = &self.reference {
            s += r.stats;
        }
        s
    }
}

/// Bad parameters or options.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A model or effect parameter is out of range.
    #[error(transparent)]
    Model(#[from] RigError),
    /// A solver or run option is out of range.
    #[error(transparent)]
    Option(#[from] OptionError),
    /// A two-stage run that ends before its vibration is switched on.
    #[error(
        "parameter `t_on` = {t_on} s is not allowed: the vibration must be switched on before the run ends (t_end = {t_end} s); give t_on < t_end, or t_on = 0 to vibrate from the start"
    )]
    SwitchOnAfterEnd {
        /// Switch-on time \[s\].
        t_on: f64,
        /// End of the run \[s\].
        t_end: f64,
    },
    /// A run over the work budget ([`T_END_MAX`](crate::sim::T_END_MAX), [`PERIODS_MAX`](crate::sim::PERIODS_MAX)): the message names the
    /// parameters that make it long.
    #[error("{0}")]
    Budget(String),
}
