//! A fitted model linearised on a set of recordings: its coordinates, residuals and
//! finite-difference Jacobian at the fit, what a planner of recordings refits rivals on.

use super::fit::{fd_jacobian, prepare};
use super::model::{Model, Plausible, coords};
use super::target::Target;
use crate::model::EffectKind;
use faer::Mat;

/// A model linearised on a set of recordings: its fitted coordinates at the model, the
/// residuals there and their forward-difference Jacobian, as a fit's last iteration would hold
/// them (`1 + p` evaluations for `p` coordinates). What a planner of recordings refits rivals
/// on without running their fits again.
#[derive(Clone, Debug)]
pub struct Linearised {
    /// The model with its effects enabled: the template the coordinates are set in.
    pub model: Model,
    /// The effects whose parameters are fitted beside the base ones.
    pub effects: Vec<EffectKind>,
    /// The fitted coordinates' names, in the Jacobian's column order.
    pub names: Vec<String>,
    /// The coordinates at the model (logarithms where fitted on a log scale).
    pub theta: Vec<f64>,
    /// Their plausible bounds `(lo, hi)`, in the same scale.
    pub bounds: Vec<(f64, f64)>,
    /// Each coordinate's difference step, in the same scale (taken inward at an upper bound).
    pub steps: Vec<f64>,
    /// Residuals on the recordings (empty where a simulation failed).
    pub z: Vec<f64>,
    /// Their Jacobian in the coordinates.
    pub jacobian: Mat<f64>,
}

impl Linearised {
    /// The model with its coordinates set to `theta` (each clamped into its bounds).
    pub fn at(&self, theta: &[f64]) -> Model {
        let cs = coords(&Plausible::default(), &self.effects, &self.model.effects);
        // The names fix which coordinates these are; the bounds are this campaign's.
        let mut m = self.model.clone();
        for ((c, &t), &(lo, hi)) in cs.iter().zip(theta).zip(&self.bounds) {
            c.set(&mut m, t.clamp(lo, hi));
        }
        m
    }

    /// The difference step of coordinate `j` at `theta`: its step, negated where it would
    /// cross the upper bound.
    pub fn step_at(&self, j: usize, theta: &[f64]) -> f64 {
        if theta[j] + self.steps[j] > self.bounds[j].1 {
            -self.steps[j]
        } else {
            self.steps[j]
        }
    }
}

/// `model` (with `effects` fitted beside the base parameters) linearised on `target`.
pub fn linearise(target: &Target, model: &Model, effects: &[EffectKind]) -> Linearised {
    let s = prepare(target, model, effects);
    let p = s.cs.len();
    let jacobian = if s.at.1.is_empty() {
        Mat::zeros(0, p)
    } else {
        fd_jacobian(target, &s.model, &s.cs, &s.theta, &s.at.1, 0..p)
    };
    Linearised {
        names: s.cs.iter().map(|c| c.name.clone()).collect(),
        bounds: s.cs.iter().map(|c| (c.lo, c.hi)).collect(),
        steps: s.cs.iter().map(|c| c.step).collect(),
        theta: s.theta,
        z: s.at.1,
        jacobian,
        model: s.model,
        effects: s.effects,
    }
}
