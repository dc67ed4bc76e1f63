//! The scans of the detection limits ([`super::limits`]): for each effect in each of its
//! forms, the parameter that sets its strength, the other parameters fixed, and the ends and
//! scale it is scanned over.

use crate::model::EffectKind;
use crate::model::effects::{self, EFFECTS, Param};

/// One effect's scan: the parameter that sets its strength, in one form.
#[derive(Clone, Debug)]
pub(crate) struct Scan {
    pub(crate) kind: EffectKind,
    pub(crate) param: Param,
    /// What the effect is, in a reader's words.
    pub(crate) label: &'static str,
    /// The other parameters and their values.
    pub(crate) fixed: &'static [(Param, f64)],
    /// The effect is stronger where the parameter is lower (a resonance).
    pub(crate) stronger_below: bool,
    /// The weak end, where the neutral value cannot serve (0 on a log scale; a scan of one
    /// side of the Stribeck exponent's 2).
    pub(crate) weak: Option<f64>,
    /// The strong end, where it is not the plausible range's.
    pub(crate) strong: Option<f64>,
    pub(crate) log: bool,
}

/// Every scan of [`limits`](super::limits), from the effects' own
/// ([`EffectInfo::scans`](crate::model::effects::EffectInfo::scans)): each effect in its default
/// form, then the other forms. A limit holds for the form it states (a slip-law ageing, which
/// does not heal at rest, stays unseen at twice the ageing law's limit), so each form states its
/// own; the delayed fourth-order sensor is the fourth-order one's scan at no delay (a delay only
/// adds a phase to what the filter shows, so that limit errs on the side of caution).
pub(crate) static SCANS: std::sync::LazyLock<Vec<Scan>> = std::sync::LazyLock::new(|| {
    let all: Vec<Scan> = EFFECTS
        .iter()
        .flat_map(|e| e.scans.iter().map(|s| Scan::of(e.kind, s)))
        .collect();
    let (default, other): (Vec<Scan>, Vec<Scan>) =
        all.into_iter().partition(|s| s.in_default_form());
    default.into_iter().chain(other).collect()
});

impl Scan {
    /// The scan `s` of effect `kind`.
    fn of(kind: EffectKind, s: &effects::Scan) -> Scan {
        Scan {
            kind,
            param: s.param,
            label: s.label,
            fixed: s.fixed,
            stronger_below: s.stronger_below,
            weak: s.weak,
            strong: s.strong,
            log: s.log,
        }
    }

    /// The value of the form parameter it scans: among `fixed`, else the family's default.
    fn form_value(&self) -> f64 {
        let q = self.kind.info().form;
        self.fixed
            .iter()
            .find(|(p, _)| Some(*p) == q)
            .map_or(self.kind.default_form(), |f| f.1)
    }

    /// Whether it scans a resonance (a frequency on a log scale, stronger below), whose trace
    /// can vanish again at stronger strengths.
    pub(crate) fn resonance(&self) -> bool {
        self.stronger_below && self.log
    }

    /// The name of the parameter it scans.
    pub(crate) fn param_name(&self) -> &'static str {
        self.param.name(self.kind)
    }

    /// The other parameters' names and values.
    pub(crate) fn fixed_named(&self) -> impl Iterator<Item = (&'static str, f64)> + '_ {
        self.fixed.iter().map(|&(p, v)| (p.name(self.kind), v))
    }

    /// Whether it scans the effect's default form.
    fn in_default_form(&self) -> bool {
        self.form_value() == self.kind.default_form()
    }

    /// The name of the form scanned: the form parameter's value among `fixed`, else the
    /// family's default form.
    pub(crate) fn form_name(&self) -> &'static str {
        self.kind.form_of(self.form_value()).map_or("", |f| f.name)
    }
}
