//! The screens: a candidate effect's quick fit on at most [`SCREEN_RECORDINGS`] recordings,
//! which decides whether it is fitted on every recording.
//!
//! A screen runs in full. On the search fidelity ([`super::target::Fidelity::Search`]) its
//! fits ended elsewhere: on the bench's ageing campaign the ageing screen's five iterations
//! reached a gap of 1.89 instead of 1.14, and the fit on every recording that starts there
//! then took more full simulations than the screens had saved (the candidates' step 196 s →
//! 230 s, 4087 → 5497 simulations). Its starts' scans, which only compare points, search.

use super::fit::{self, FitOptions, FitResult, Model, Target};
use super::scan;
use crate::model::EffectKind;
use faer::Mat;

/// Most recordings a candidate is first fitted on. Each candidate is screened, by a fit of at
/// most [`SCREEN_ITERATIONS`] iterations, on every recording of a campaign of this many or
/// fewer, else on this many ([`scan::subset`]: half where the model it extends misses most, the
/// rest evenly by name), and fitted further on every recording, from the screen's optimum,
/// only where it lowers the screen's gap by [`SCREEN_BAR`] or more below that of the model it
/// extends (on a subset, that model refitted to it: else the candidate would be credited with
/// what any refit of the base parameters to fewer recordings gains). The others are ranked as
/// that model, as a candidate that moves the gap by less than [`UNCHANGED`](super::evidence::UNCHANGED) is.
pub const SCREEN_RECORDINGS: usize = 16;

/// Share of the subset's gap a candidate must remove in its screening to be fitted on every
/// recording. Why 10 %: a candidate is named only for a held-out reduction of 25 % or more,
/// and a runner-up below 10 % leaves every margin of the verdict rules as it is.
pub const SCREEN_BAR: f64 = 0.1;

/// Relative fall of the cost below which a screening fit's step on a fresh Jacobian ends it
/// (the fits' [`FitOptions::rel_tol`] is 1e-3): a step that lowers the gap by less than 0.5 %
/// does not lead to the [`SCREEN_BAR`] of 10 % in the few iterations left, where small steps
/// through a rough cost would spend them all.
pub const SCREEN_REL_TOL: f64 = 0.01;

/// Relative fall of the cost below which a step on a fresh Jacobian ends a candidate's fit on
/// every recording (where its screen passed): the candidates are ranked on fits converged to
/// 1 % of their cost, and the named effect's fit is then polished to the fits' own
/// [`FitOptions::rel_tol`] ([`fit::refine`]). Why: the cost is rough at the level of a few
/// tenths of a percent (each feature counts stick-slip events, a step in the parameters moves
/// one across a recording's end), so a fit to 1e-3 spends most of its steps on that roughness,
/// on every candidate that passes its screen, the runners-up included.
pub const RANK_REL_TOL: f64 = 0.01;

/// Levenberg–Marquardt iterations of a screening fit: its start comes from the candidate's
/// global scan, so an effect that explains a clear share of the gap shows it within a few.
/// A screen also ends as soon as its linearised residuals cannot reach the bar
/// ([`FitOptions::reach`] at [`SCREEN_BAR`] below the gap of the model it extends), checked
/// first on the extended model's Jacobian columns with the candidate's differenced
/// ([`fit::fit_extending`]): a candidate that explains nothing then costs its start and its
/// own columns, not a Jacobian and five iterations of steps tried and refused.
pub const SCREEN_ITERATIONS: usize = 5;

/// A screen's fit options: at most [`SCREEN_ITERATIONS`] iterations, [`SCREEN_REL_TOL`], no
/// fresh Jacobian at the end, stopped where it cannot reach the gap `reach`.
pub fn screen_fit(reach: f64) -> FitOptions {
    FitOptions {
        max_iter: SCREEN_ITERATIONS,
        rel_tol: SCREEN_REL_TOL,
        final_jacobian: false,
        reach,
    }
}

/// The recordings candidates extending a model are screened on, with that model's gap there.
pub(crate) struct Screen<'a> {
    /// The subset, with the extended model refitted to it, in a campaign of more than
    /// [`SCREEN_RECORDINGS`]; `None`: every recording, and the model as fitted to them.
    pub subset: Option<(Target<'a>, FitResult)>,
    /// Gap of the extended model on the screen's recordings (refitted to a subset).
    pub gap: f64,
    /// The extended model's Jacobian there, differenced at its optimum, where it is: the
    /// columns of its coordinates in the Jacobian a screen's bar is first checked on
    /// ([`fit::fit_extending`]).
    pub jacobian: Option<Mat<f64>>,
}

/// What the screens of a candidate's starts found.
pub(crate) struct Screened {
    /// The lowest screen that passed its bar (the first of equals).
    pub passed: Option<FitResult>,
    /// The lowest gap a screen reached.
    pub lowest: f64,
    /// The model at that gap (none where no screen ran).
    pub lowest_model: Option<fit::Model>,
    /// Evaluations of the screens that did not go on, and of the neutral start's check.
    pub checks: usize,
}

/// Where a screen's fits may stop short of their bar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Reach {
    /// Where a fit cannot reach the bar ([`SCREEN_BAR`] below the extended model's gap).
    Bar,
    /// Where it cannot come within this many times the extended model's gap, where that is
    /// lower than the bar: another form of a trailing effect ([`super::forms::form_reach`]).
    Leader(f64),
    /// Nowhere: the bar is checked at the end (another form of an effect whose default form
    /// passed).
    Full,
}

impl Reach {
    /// The reach of a candidate with the leader's `reach` where it trails, screened in full
    /// where `full`.
    pub(crate) fn of(reach: Option<f64>, full: bool) -> Reach {
        match (reach, full) {
            (Some(r), _) => Reach::Leader(r),
            (None, true) => Reach::Full,
            (None, false) => Reach::Bar,
        }
    }
}

impl<'a> Screen<'a> {
    /// The gap a candidate's screen must reach to pass: [`SCREEN_BAR`] of the extended
    /// model's gap on the screen's recordings removed.
    pub fn bar(&self) -> f64 {
        (1.0 - SCREEN_BAR) * self.gap
    }

    /// The screen for candidates extending `from`, fitted on every recording of `all`.
    pub fn of(all: &Target<'a>, from: &FitResult, opts: FitOptions) -> Self {
        let fresh = |f: &FitResult| f.jacobian_fresh.then(|| f.jacobian.clone());
        if all.recs.len() <= SCREEN_RECORDINGS {
            return Screen {
                subset: None,
                gap: from.gap,
                jacobian: fresh(from),
            };
        }
        let sub = scan::subset(all, &from.z, SCREEN_RECORDINGS);
        let opts = FitOptions {
            final_jacobian: true,
            ..opts
        };
        let refit = fit::fit(&sub, &from.model, &from.effects, opts);
        Screen {
            gap: refit.gap,
            jacobian: fresh(&refit),
            subset: Some((sub, refit)),
        }
    }

    /// The screening fit's starts for the candidate `effects` (the extended model's and the
    /// candidate `k`, last) from its scan's best start `scanned`: `k`'s parameters from the
    /// scan on the extended model as fitted to the screen's recordings (refitted to a subset);
    /// where that misses them by more than the extended model does (the scan scores half as
    /// many recordings, on the model fitted to all, and holds the extended model's parameters
    /// where the candidate would move them), `k` at its neutral values there
    /// ([`scan::neutral_start`]) besides: a screen is run from each, and the lowest that passes
    /// its bar goes on. Why both: an effect the extended model's parameters have
    /// compensated (a friction growing with the slip velocity, absorbed by a lower `F_s`)
    /// misses at its scanned values until those parameters move back, which the screen's
    /// steps do; the neutral start keeps every candidate at least the model it extends.
    /// Evaluated on the screen's recordings, with the number of evaluations beside the ones the
    /// screening fits count (0, or 1 for the neutral start).
    fn starts(
        &self,
        all: &Target,
        from: &Model,
        scanned: &Model,
        effects: &[EffectKind],
    ) -> (Vec<fit::Start>, usize) {
        let k = *effects.last().expect("a candidate");
        let m = match &self.subset {
            Some((_, refit)) => {
                let mut m = refit.model.clone();
                if let Some((_, v)) = scanned.effects.list.iter().find(|(e, _)| *e == k) {
                    *m.effects.enable(k) = v.clone();
                }
                // Where the scan moved the base parameters with the candidate (the ones the
                // extended model has absorbed it into: scan::starts), the refit's move the same
                // way, by the same factor (by the same amount for h_d, which may be 0).
                let scale = |refit: f64, scanned: f64, from: f64| {
                    if scanned == from || from == 0.0 {
                        refit
                    } else {
                        refit * scanned / from
                    }
                };
                m.f_s = scale(m.f_s, scanned.f_s, from.f_s);
                m.f_c = scale(m.f_c, scanned.f_c, from.f_c);
                m.v_s = scale(m.v_s, scanned.v_s, from.v_s);
                m.h_d += scanned.h_d - from.h_d;
                m.f_s = m.f_s.max(m.f_c);
                m
            }
            None => scanned.clone(),
        };
        let sub = self.recordings(all);
        let first = fit::prepare(sub, &m, effects);
        if first.gap() <= self.gap {
            (vec![first], 0)
        } else {
            // The model it extends, as fitted to these recordings (not the scan's base
            // parameters, which may have moved with the candidate).
            let base = match &self.subset {
                Some((_, refit)) => &refit.model,
                None => from,
            };
            let form = scanned.effects.form_value(k).unwrap_or(k.default_form());
            let neutral = fit::prepare(sub, &scan::neutral_start(base, k, form), effects);
            (vec![first, neutral], 1)
        }
    }

    /// The screen's recordings: the subset, or `all`.
    pub fn recordings<'s>(&'s self, all: &'s Target<'a>) -> &'s Target<'a> {
        self.subset.as_ref().map_or(all, |(sub, _)| sub)
    }

    /// Screens the candidate `effects` (the extended model's and the candidate, last) from
    /// each of its scan's starts `scanned` ([`Screen::starts`]): fits of at most
    /// [`SCREEN_ITERATIONS`] iterations with the options `opts` (their reach set here), each
    /// stopped where it cannot reach its bar, [`SCREEN_BAR`] below the extended model's gap,
    /// or as `reach` says.
    pub fn screen(
        &self,
        all: &Target,
        from: &Model,
        scanned: &[scan::ScanStart],
        effects: &[EffectKind],
        reach: Reach,
        opts: FitOptions,
    ) -> Screened {
        let sub = self.recordings(all);
        let mut firsts = vec![];
        let mut checks = 0;
        for m in scanned {
            let (f, n) = self.starts(all, from, &m.model, effects);
            firsts.extend(f.into_iter().map(|f| (f, m.in_full)));
            checks += n;
        }
        let bar = self.bar();
        let screen = screen_fit(match reach {
            // Short of the leader's reach, it is not fitted further whatever its start.
            Reach::Leader(r) => (r * self.gap).min(bar),
            Reach::Full => f64::INFINITY,
            Reach::Bar => bar,
        });
        let opts = FitOptions {
            max_iter: opts.max_iter.min(screen.max_iter),
            final_jacobian: opts.final_jacobian,
            ..screen
        };
        let mut passed: Option<FitResult> = None;
        let mut lowest = f64::INFINITY;
        let mut lowest_model = None;
        for (first, in_full) in firsts {
            // A start beyond a jump of the cost is screened in full (scan::ScanStart).
            let opts = scan::screen_options(in_full, opts);
            // The bar checked first on the extended model's Jacobian columns from its own fit
            // on these recordings and the candidate's differenced: a
            // candidate out of reach costs those.
            let s = match &self.jacobian {
                Some(known) => fit::fit_extending(sub, first, known, opts),
                None => fit::fit_from(sub, first, opts),
            };
            // The lowest screen that passes goes on (the first of equals); the others'
            // evaluations count with the fit's where its recordings are the fit's.
            if s.gap < lowest {
                lowest = s.gap;
                lowest_model = Some(s.model.clone());
            }
            let better = s.gap <= bar && passed.as_ref().is_none_or(|p| s.gap < p.gap);
            if better {
                if let Some(p) = passed.replace(s) {
                    checks += p.evaluations;
                }
            } else {
                checks += s.evaluations;
            }
        }
        Screened {
            passed,
            lowest,
            lowest_model,
            checks,
        }
    }
}
