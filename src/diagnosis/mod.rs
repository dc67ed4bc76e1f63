//! The diagnosis of a campaign: where measured recordings ([`crate::campaign`]) depart from the
//! model, which unmodelled effect causes it, and how far the gap shrinks once it is added.
//!
//! Rooms, from the bottom: [`features`] (what is compared: the features of a force signal and
//! their noise floors), [`fit`] (models, plausible bounds, predictions on the campaign's
//! recordings with the shared simulation cache, Levenberg-Marquardt fits; [`linearised`], a fit's
//! residuals and Jacobian at its optimum), [`fingerprint`] (the
//! signatures an effect must leave beyond the features), [`diagnose`] (calibration, screens,
//! held-out folds, evidence and the verdict; [`decide`], the rule that names or ties;
//! [`candidate`], one candidate screened, fitted and ranked, or two together; [`vet`], the
//! fingerprints a candidate to be named must carry), [`report`] (JSON, HDF5, text and figures of a
//! diagnosis; [`record`], the typed record the JSON file is, which the planner reads). Each imports only the rooms above it in this list and [`crate::campaign`]; a
//! planner of recordings belongs beside this room, importing it.

pub mod candidate;
pub mod decide;
pub mod diagnose;
pub mod evidence;
pub mod features;
pub mod fingerprint;
pub mod fit;
pub mod folds;
pub mod forms;
pub mod limits;
pub mod linearised;
pub mod model;
pub use crate::nullable;
pub mod record;
pub mod report;
pub mod scan;
pub mod scans;
pub mod screen;
pub mod target;
pub mod verdict;
pub mod vet;
