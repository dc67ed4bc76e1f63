//! Reports of a diagnosis, one format per file: the terminal summary ([`text`]), the JSON of a
//! calibration ([`json`]; a diagnosis's is its record), the HDF5 details ([`h5`]) and the
//! figures ([`figures`]).

pub mod figures;
pub mod h5;
pub mod json;
pub mod text;

pub use figures::{TracesFigure, plots, traces_figure};
pub use h5::write_h5;
pub use json::calibration_json;
pub use text::{calibration_summary, summary};
