//! Which model served a run, and why: the data of the tier policy ([`crate::sim::choose`]),
//! stored in journals and HDF5 files by code.

/// Which model serves a run with vibration: the option of `run --tier`, `[run] tier` and sweeps.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Tier {
    /// Per run, by the rules of [`choose`](crate::sim::choose::choose): the averaged slow model where they hold, else the
    /// full model. The default.
    #[default]
    Auto,
    /// The averaged slow model wherever its law was found and holds along the run's steady
    /// window ([`SlowRun::left_law`](crate::sim::slow::SlowRun::left_law)), the rules of [`choose`](crate::sim::choose::choose) about the time scales and the
    /// contact resonance left out; the full model where it does not (there is no law to use),
    /// and the result says so.
    Averaged,
    /// The full model, every forcing period integrated.
    Full,
    /// The averaged slow model where its law holds, the full model in windows where the mean
    /// velocity passes zones where it does not ([`hybrid`](crate::sim::hybrid)); the full model where there
    /// is no law.
    Hybrid,
}

impl Tier {
    /// Whether a run served by this tier used the averaged law (alone or between hybrid
    /// windows): its table belongs to the sweep's journal and its result to the sweep's check.
    pub fn uses_law(self) -> bool {
        matches!(self, Tier::Averaged | Tier::Hybrid)
    }

    /// Every tier, in the order help texts list them.
    pub const ALL: [Tier; 4] = [Tier::Auto, Tier::Averaged, Tier::Hybrid, Tier::Full];

    /// The name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Tier::Auto => "auto",
            Tier::Averaged => "averaged",
            Tier::Full => "full",
            Tier::Hybrid => "hybrid",
        }
    }

    /// The code in journals and HDF5 files of the tier that served a run: 0 full, 1 averaged,
    /// 2 hybrid.
    pub fn code(self) -> u8 {
        match self {
            Tier::Averaged => 1,
            Tier::Hybrid => 2,
            _ => 0,
        }
    }

    /// The tier of [`Tier::code`].
    pub fn from_code(c: u8) -> Option<Tier> {
        match c {
            0 => Some(Tier::Full),
            1 => Some(Tier::Averaged),
            2 => Some(Tier::Hybrid),
            _ => None,
        }
    }
}

impl std::fmt::Display for Tier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Tier {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Tier::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("unknown tier '{s}': allowed are auto, averaged, hybrid, full"))
    }
}

/// Why a run was served by its tier ([`choose`](crate::sim::choose::choose)). Stored as its code in journals and HDF5
/// files; [`TierReason::text`] is the sentence of JSON results and summaries.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum TierReason {
    /// `full` was asked for.
    #[default]
    Asked,
    /// No vibration: there is nothing to average.
    NoVibration,
    /// A two-stage run (`t_on > 0`).
    TwoStage,
    /// Model extensions are on.
    Effects,
    /// The forcing is not fast enough against the drive oscillator ([`SEPARATION`](crate::sim::choose::SEPARATION)).
    Separation,
    /// The averaged law was not found from rest on (the continuation stopped at once).
    NoLaw,
    /// Every rule of [`choose`](crate::sim::choose::choose) holds.
    Valid,
    /// `averaged` was asked for and its law exists.
    AskedAveraged,
    /// A full run checking an averaged one in a sweep (`crate::sweep::check`); where it
    /// disagrees it replaces the averaged run.
    Check,
    /// The forcing lies below the contact resonance ([`contact_resonance`](crate::sim::choose::contact_resonance)).
    BelowResonance,
    /// The averaged run's steady window passed a mean velocity where the law may not stand
    /// for the vibration ([`SlowRun::left_law`](crate::sim::slow::SlowRun::left_law)): the full model served.
    LeftLaw,
    /// Code 11 of a sweep's `tier_reason`: a point under `auto` that no other point shared its
    /// table of the averaged law with, run in full. No run takes this reason now (a table costs
    /// a tenth of a full run above the resonance); the code stays so that files holding it read.
    Unshared,
    /// The vibration's velocity amplitude lies below [`MIN_VA_RATIO`](crate::sim::choose::MIN_VA_RATIO) times the drive velocity.
    SmallAmplitude,
    /// `hybrid` was asked for and its law exists.
    AskedHybrid,
    /// Under `auto`, the averaged run's steady window passed zones where the law does not
    /// stand for the vibration ([`TierReason::LeftLaw`]), and hybrid windows integrated the full
    /// model there ([`hybrid`](crate::sim::hybrid)).
    Zones,
    /// A hybrid run was asked for, but the law's continuation stopped short of its span: the
    /// orbits it did not reach may hide the attractor the body escapes from (1000 Hz, `v_a/v_d`
    /// 0.4: a hybrid run on a three-node table gave dF 3.30 N for the full model's 2.20 N). The
    /// full model served.
    PartialLaw,
    /// Under auto, the drive velocity lies in a zone of the law where the fast orbit does not
    /// contract, or within [`ZONE_MARGIN`](crate::sim::choose::ZONE_MARGIN) of one: the full model served.
    NearZone,
}

impl TierReason {
    /// Every reason, by code.
    pub const ALL: [TierReason; 17] = [
        TierReason::Asked,
        TierReason::NoVibration,
        TierReason::TwoStage,
        TierReason::Effects,
        TierReason::Separation,
        TierReason::NoLaw,
        TierReason::Valid,
        TierReason::AskedAveraged,
        TierReason::Check,
        TierReason::LeftLaw,
        TierReason::BelowResonance,
        TierReason::Unshared,
        TierReason::SmallAmplitude,
        TierReason::AskedHybrid,
        TierReason::Zones,
        TierReason::PartialLaw,
        TierReason::NearZone,
    ];

    /// The name in files.
    pub fn name(self) -> &'static str {
        match self {
            TierReason::Asked => "asked",
            TierReason::NoVibration => "no_vibration",
            TierReason::TwoStage => "two_stage",
            TierReason::Effects => "effects",
            TierReason::Separation => "separation",
            TierReason::NoLaw => "no_law",
            TierReason::Valid => "valid",
            TierReason::AskedAveraged => "asked_averaged",
            TierReason::Check => "check",
            TierReason::LeftLaw => "left_law",
            TierReason::BelowResonance => "below_resonance",
            TierReason::Unshared => "unshared",
            TierReason::SmallAmplitude => "small_amplitude",
            TierReason::AskedHybrid => "asked_hybrid",
            TierReason::Zones => "zones",
            TierReason::PartialLaw => "partial_law",
            TierReason::NearZone => "near_zone",
        }
    }

    /// The code in journals and HDF5 files (the index in [`TierReason::ALL`]).
    pub fn code(self) -> u8 {
        TierReason::ALL
            .iter()
            .position(|&r| r == self)
            .expect("listed") as u8
    }

    /// The reason of [`TierReason::code`].
    pub fn from_code(c: u8) -> Option<TierReason> {
        TierReason::ALL.get(c as usize).copied()
    }

    /// One sentence for results and summaries.
    pub fn text(self) -> &'static str {
        match self {
            TierReason::Asked => "the full model was asked for",
            TierReason::NoVibration => "no vibration: nothing to average",
            TierReason::TwoStage => {
                "a two-stage run: its switch-on transient is integrated in full"
            }
            TierReason::Effects => {
                "model extensions are on: the averaged law holds the base contact only"
            }
            TierReason::Separation => {
                "the forcing is less than 20 times the drive oscillator's frequency: the drive \
                 force moves within a period"
            }
            TierReason::NoLaw => "no averaged law: the fast orbit was not found from rest on",
            TierReason::Valid => {
                "the averaged law: the forcing lies above the contact resonance and is 20 or more \
                 times faster than the drive oscillator, and the fast orbit contracts at every \
                 mean velocity of the steady window"
            }
            TierReason::AskedAveraged => "averaged was asked for and its law exists",
            TierReason::Check => {
                "the full model's check of an averaged point, which disagreed with it and \
                 replaces it"
            }
            TierReason::BelowResonance => {
                "the forcing lies below the contact resonance, where the fast orbit of body and \
                 contact can period-double and other attractors coexist with it"
            }
            TierReason::Unshared => {
                "no other point of the sweep shares this point's averaged law: its table would \
                 cost about what the full run does"
            }
            TierReason::SmallAmplitude => {
                "the vibration's velocity amplitude is below a tenth of the drive velocity: at \
                 breakaway the body crosses the averaged law's rise within a fraction of a period"
            }
            TierReason::AskedHybrid => {
                "hybrid was asked for and its law exists: the averaged law where it holds, the \
                 full model in windows where it does not"
            }
            TierReason::Zones => {
                "the averaged run's steady window passed mean velocities where the fast orbit \
                 does not contract: hybrid windows integrated the full model there"
            }
            TierReason::PartialLaw => {
                "the averaged law's continuation stopped short of its span, and the orbits it did \
                 not reach may hide the attractor the body escapes from: the full model served"
            }
            TierReason::LeftLaw => {
                "the averaged run's steady window reached mean velocities where the fast orbit \
                 does not contract (or was not found): the full model served"
            }
            TierReason::NearZone => {
                "the drive velocity lies in or within 25 % of a zone of the averaged law where \
                 the fast orbit does not contract: a body that accelerates through the zone can \
                 stay on another attractor beyond it, so the full model served"
            }
        }
    }
}
