//! The thresholds of a diagnosis's decisions and the evidence between two models: the summed
//! log likelihood ratio of their held-out residuals, its jackknife error and the charge for
//! parameters (module docs of [`diagnose`](super::diagnose)).

/// Held-out gap below which the base model counts as matching the data.
pub const SIGNIFICANT_GAP: f64 = 2.0;
/// Held-out gap of a single feature (its `√(mean z²)` over the checked units that define it)
/// from which the base model's gap counts as significant even where the whole gap is under
/// [`SIGNIFICANT_GAP`], when at least two checked recordings reach it in that feature: an
/// effect that leaves its trace in one feature (a load cell's attenuation of the ripple at
/// `f`) is diluted by the sixteen others that it leaves alone. Two recordings: one alone (a
/// run on the edge of elimination, or the phase of a harmonic barely out of the noise, as the
/// `F_phase_2f` of a single recording of the independent rig's effect-free factorial
/// campaign, 9.3) is not a gap of the model.
pub const FEATURE_GAP: f64 = 3.0;
/// The gap of a model that matches the data within noise and floors. Where the whole gap
/// `E0` is under [`SIGNIFICANT_GAP`] and only a concentrated feature ([`FEATURE_GAP`]) makes
/// it significant, the decision's shares are of the gap beyond it, `(E0 − E1)/(E0 − 1)`, and
/// so are the margins between scores.
pub const NOISE_GAP: f64 = 1.0;
/// Penalty per fitted effect parameter in the informative score `E1 (1 + 0.05 k)` of the
/// JSON's ranking (the decision weighs parameters by [`PARAM_NATS`]).
pub const PARAM_PENALTY: f64 = 0.05;
/// Smallest share of the gap an effect must explain to be named at all, fully or in part
/// (`(E0 − E1)/E0`, or of the gap beyond noise where only a concentrated feature makes it
/// significant): an effect size, not a test. Evidence decides whether it is real
/// ([`Evidence::clear`]); this decides whether it is worth naming.
pub const MIN_PARTIAL: f64 = 0.25;
/// Smallest further held-out reduction, of the gap left by the first effect, for naming a
/// second one (an effect size, beside the evidence).
pub const MIN_SECOND: f64 = 0.3;
/// Prior odds against any one explanation, `ln 20`: a model is preferred to another only where
/// the held-out data make it at least 20 times as likely ([`Evidence::clear`]), about "strong"
/// on Jeffreys' and Kass and Raftery's scales.
pub const LN_PRIOR_ODDS: f64 = 2.995_732_273_553_991;
/// How many standard errors of the evidence (its jackknife over held-out recordings) must lie
/// above even odds: the preference must survive the spread over recordings. One, beside the
/// leave-one-out rule of [`Evidence::clear`]: two would ask an effect to act on four recordings'
/// worth or more, and ageing, which acts where the sticks are long, on a few (the first rig's
/// slip-law ageing: 79 % of the gap, `ln odds 73 ± 50`) would go unnamed.
pub const EVIDENCE_SE: f64 = 1.0;
/// Log-likelihood charged per parameter a model adds (Akaike's penalty, in nats): its
/// nonlinear parameters were fitted on every recording, held-out ones included.
pub const PARAM_NATS: f64 = 1.0;
/// A candidate whose fit lowers the calibration gap of the model it extends by less than this
/// share is that model as far as the held-out check can tell: it is ranked with that model's
/// held-out gap instead of being cross-validated again.
pub const UNCHANGED: f64 = 0.02;
/// Folds of the cross-validation (fewer where the campaign has fewer groups of conditions).
pub const FOLDS: usize = 4;

/// The held-out evidence for one model against another (see the module docs, "Evidence").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evidence {
    /// Log-likelihood ratio \[nats\]: `Σ_i n_i ln(E_B,i/E_A,i) − PARAM_NATS (k_A − k_B)` over
    /// the held-out recordings both models define, `n_i` residuals each.
    pub ln_odds: f64,
    /// Its jackknife standard error over those recordings (0 where the two models give the
    /// same gaps; NaN with fewer than two recordings).
    pub stderr: f64,
    /// The recordings it rests on.
    pub recordings: usize,
    /// The smallest log-likelihood ratio with one recording left out (NaN with fewer than two
    /// recordings): the preference without the recording that carries most of it.
    pub least_left_out: f64,
}

impl Evidence {
    /// Whether the data clearly prefer the first model: its likelihood at least
    /// `exp(`[`LN_PRIOR_ODDS`]`)` = 20 times the other's, still above the other's
    /// [`EVIDENCE_SE`] standard errors lower, and still 20 times with any one recording left
    /// out (one recording is not an effect).
    pub fn clear(&self) -> bool {
        self.ln_odds >= LN_PRIOR_ODDS
            && self.recordings >= 2
            && self.ln_odds - EVIDENCE_SE * self.stderr >= 0.0
            && self.least_left_out >= LN_PRIOR_ODDS
    }

    /// `log10` of the likelihood ratio: "10^x times as likely".
    pub fn log10_odds(&self) -> f64 {
        self.ln_odds / std::f64::consts::LN_10
    }
}

/// The recordings two models' per-recording gaps both define (finite, over residuals).
fn paired(a: &[f64], a_n: &[usize], b: &[f64], b_n: &[usize]) -> Vec<usize> {
    (0..a.len().min(b.len()))
        .filter(|&i| {
            a[i].is_finite()
                && b[i].is_finite()
                && a_n.get(i).is_some_and(|&k| k > 0)
                && b_n.get(i).is_some_and(|&k| k > 0)
        })
        .collect()
}

/// The jackknife over the recordings `idx` of a statistic `stat(skip)` (`skip`: the recording
/// left out): its standard error and the smallest value with one recording left out (both NaN
/// with fewer than two recordings).
fn jackknife(idx: &[usize], stat: impl Fn(Option<usize>) -> f64) -> (f64, f64) {
    let n = idx.len();
    if n < 2 {
        return (f64::NAN, f64::NAN);
    }
    let jack: Vec<f64> = idx.iter().map(|&i| stat(Some(i))).collect();
    let mean = jack.iter().sum::<f64>() / n as f64;
    let var = (n - 1) as f64 / n as f64 * jack.iter().map(|j| (j - mean).powi(2)).sum::<f64>();
    (
        var.sqrt(),
        jack.iter().copied().fold(f64::INFINITY, f64::min),
    )
}

impl Evidence {
    /// The evidence with `nats` more charged against the first model (a choice it made that
    /// the other did not: its form among `m`, `ln m` nats).
    pub fn charged(self, nats: f64) -> Evidence {
        Evidence {
            ln_odds: self.ln_odds - nats,
            least_left_out: self.least_left_out - nats,
            ..self
        }
    }
}

/// The held-out evidence for model A (per-recording held-out gaps `a`, each over `a_n`
/// residuals) against model B (`b`, `b_n`), A having `extra` more parameters than B. The
/// held-out residuals of a model in recording `i` are taken as Gaussian with the model's own
/// mean square there as variance (the profile likelihood, one scale per recording: recordings
/// differ in noise and in how far a model misses them), so the log-likelihood ratio is
/// `Σ_i n_i ln(E_B,i/E_A,i)` over the recordings both models define, less [`PARAM_NATS`] per
/// extra parameter. One recording's residuals share its one stick-slip history and are not
/// independent: the standard error is therefore the jackknife over recordings (leave one
/// recording out), and a preference that one recording carries has a large one.
pub fn evidence(a: &[f64], a_n: &[usize], b: &[f64], b_n: &[usize], extra: f64) -> Evidence {
    let idx = paired(a, a_n, b, b_n);
    let n = idx.len();
    let penalty = PARAM_NATS * extra;
    // Each recording's term: its residuals' log-likelihood ratio, `n_i ln(E_B,i/E_A,i)`.
    let term = |i: usize| {
        let n_i = 0.5 * (a_n[i] + b_n[i]) as f64;
        n_i * (b[i].max(1e-150) / a[i].max(1e-150)).ln()
    };
    let ln_odds = |skip: Option<usize>| {
        idx.iter()
            .filter(|&&i| Some(i) != skip)
            .map(|&i| term(i))
            .sum::<f64>()
            - penalty
    };
    let full = ln_odds(None);
    let (stderr, least_left_out) = jackknife(&idx, ln_odds);
    Evidence {
        ln_odds: full,
        stderr,
        recordings: n,
        least_left_out,
    }
}

/// How many standard errors (the jackknife over held-out recordings) a difference of two
/// held-out gaps must exceed to order the two models by their gap ([`GapOrder::order`]).
pub const GAP_SE: f64 = 1.0;
/// Relative difference of two held-out gaps below which they do not order the models, as
/// [`UNCHANGED`] for a fit against the model it extends.
pub const GAP_REL: f64 = UNCHANGED;

/// The held-out gaps of two models compared over the recordings both define: the second story
/// beside the [`Evidence`], told by the squared residuals pooled over recordings instead of
/// their per-recording log ratios.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapOrder {
    /// Pooled held-out gap of model A, `√(Σ n_i E_A,i² / Σ n_i)`.
    pub gap_a: f64,
    /// Pooled held-out gap of model B.
    pub gap_b: f64,
    /// Jackknife standard error of `gap_b − gap_a` over the recordings (NaN with fewer than
    /// two).
    pub stderr: f64,
    /// The recordings it rests on.
    pub recordings: usize,
}

impl GapOrder {
    /// `Some(true)` where A's gap is lower than B's by more than [`GAP_REL`] of B's and
    /// [`GAP_SE`] standard errors, `Some(false)` where B's is lower by as much, `None` where
    /// the gaps do not order the two models.
    pub fn order(&self) -> Option<bool> {
        let d = self.gap_b - self.gap_a;
        let se = if self.stderr.is_finite() {
            self.stderr
        } else {
            0.0
        };
        if !(d.is_finite() && self.recordings >= 2) {
            return None;
        }
        if d > GAP_REL * self.gap_b && d > GAP_SE * se {
            Some(true)
        } else if -d > GAP_REL * self.gap_a && -d > GAP_SE * se {
            Some(false)
        } else {
            None
        }
    }
}

/// The held-out gaps of model A (per-recording gaps `a` over `a_n` residuals) and model B,
/// pooled over the recordings both define, with the jackknife error of their difference.
pub fn gap_order(a: &[f64], a_n: &[usize], b: &[f64], b_n: &[usize]) -> GapOrder {
    let idx = paired(a, a_n, b, b_n);
    let pooled = |x: &[f64], n: &[usize], skip: Option<usize>| {
        let (s, m) = idx
            .iter()
            .filter(|&&i| Some(i) != skip)
            .fold((0.0, 0usize), |(s, m), &i| {
                (s + n[i] as f64 * x[i] * x[i], m + n[i])
            });
        if m == 0 {
            f64::NAN
        } else {
            (s / m as f64).sqrt()
        }
    };
    let diff = |skip| pooled(b, b_n, skip) - pooled(a, a_n, skip);
    GapOrder {
        gap_a: pooled(a, a_n, None),
        gap_b: pooled(b, b_n, None),
        stderr: jackknife(&idx, diff).0,
        recordings: idx.len(),
    }
}

/// Held-out gap of a recording from which it counts as carrying a gap for the breadth rule.
pub const GAPPED: f64 = 1.5;

/// Share of the checked recordings that carry a gap (held-out gap `before` at least
/// [`GAPPED`]) whose gap `after` lowers; 0 when fewer than two of them are lowered. Recordings
/// already within noise do not vote: whether a candidate moves them up or down is a coin flip,
/// and where a second effect or the vibrated runs leave them within noise they would outvote
/// the ones the effect explains. Two lowered at least: one recording (on the edge of
/// elimination, say) is not an effect.
pub(crate) fn breadth_of(before: &[f64], after: &[f64]) -> f64 {
    let pairs: Vec<(f64, f64)> = before
        .iter()
        .zip(after)
        .filter(|(a, b)| a.is_finite() && b.is_finite() && **a >= GAPPED)
        .map(|(a, b)| (*a, *b))
        .collect();
    let lowered = pairs.iter().filter(|(a, b)| b < a).count();
    if lowered < 2 {
        return 0.0;
    }
    lowered as f64 / pairs.len() as f64
}
