//! A calibration's JSON (a diagnosis's is its record serialised:
//! [`DiagnosisRecord`](crate::diagnosis::record::DiagnosisRecord)).

use crate::campaign::Campaign;
use crate::diagnosis::fit::FitResult;
use serde_json::json;

/// The JSON of a calibration.
pub fn calibration_json(c: &Campaign, f: &FitResult) -> serde_json::Value {
    json!({
        "campaign": c.dir.display().to_string(),
        "recordings": c.recordings.len(),
        "params": crate::diagnosis::record::estimates(&f.estimates),
        "gap": f.gap,
        "residuals": f.residuals,
        "evaluations": f.evaluations,
    })
}
