//! A diagnosis's HDF5 details.

use super::figures::TracesFigure;
use crate::campaign::Campaign;
use crate::diagnosis::diagnose::{CONDITIONS, Diagnosis};
use crate::diagnosis::features::FEATURES;
use crate::diagnosis::fit::Estimate;
use crate::output::{self, OutputError, ds_attr_str, h5err, write_vec};
use std::path::Path;

/// Writes the details to HDF5: per-recording conditions, gaps and z per feature; the ranking
/// with fitted parameters; the calibration; the verdict as attributes.
pub fn write_h5(
    path: &Path,
    c: &Campaign,
    d: &Diagnosis,
    record: &crate::diagnosis::record::DiagnosisRecord,
    traces: Option<&TracesFigure<'_>>,
) -> Result<(), OutputError> {
    use rust_hdf5::H5File;
    output::ensure_parent(path)?;
    let tmp = output::temp_for(path)?;
    {
        let f = H5File::create(&tmp).map_err(h5err(&tmp))?;
        let root = f.root_group();
        let attr = |name: &str, v: &str| -> Result<(), OutputError> {
            f.set_attr_string(name, v).map_err(h5err(&tmp))
        };
        attr("verdict", d.verdict.name())?;
        attr("best_effect", d.best_effect.map_or("", |k| k.name()))?;
        attr("where", &d.location.summary)?;
        attr("campaign", &c.dir.display().to_string())?;
        attr("program", &output::program())?;
        attr("created", &output::now_iso())?;
        attr("json", &record.to_json().to_string())?;
        let g = root.create_group("recordings").map_err(h5err(&tmp))?;
        let w = &d.location;
        let names: Vec<String> = w.recordings.iter().map(|r| r.name.clone()).collect();
        ds_attr_str(
            &write_vec(
                &g,
                "gap_base",
                &w.recordings.iter().map(|r| r.gap_base).collect::<Vec<_>>(),
                "1",
                "gap under the calibrated base model",
                &tmp,
            )?,
            "recordings",
            &names.join(","),
            &tmp,
        )?;
        write_vec(
            &g,
            "gap_best",
            &w.recordings.iter().map(|r| r.gap_best).collect::<Vec<_>>(),
            "1",
            "gap under the best candidate",
            &tmp,
        )?;
        write_vec(
            &g,
            "held_out",
            &w.recordings
                .iter()
                .map(|r| if r.held_out { 1.0 } else { 0.0 })
                .collect::<Vec<_>>(),
            "1",
            "1 when held out from the fits",
            &tmp,
        )?;
        for (k, name) in CONDITIONS.iter().enumerate() {
            write_vec(
                &g,
                name,
                &w.recordings
                    .iter()
                    .map(|r| r.conditions[k])
                    .collect::<Vec<_>>(),
                "SI",
                name,
                &tmp,
            )?;
        }
        let zg = g.create_group("z_base").map_err(h5err(&tmp))?;
        for f in FEATURES {
            write_vec(
                &zg,
                f.name(),
                &w.recordings
                    .iter()
                    .map(|r| r.z_base[f as usize])
                    .collect::<Vec<_>>(),
                "1",
                "standardised difference, base model minus measured",
                &tmp,
            )?;
        }
        let rg = root.create_group("ranking").map_err(h5err(&tmp))?;
        for (i, r) in d.ranking.iter().enumerate() {
            let eg = rg
                .create_group(&format!("{i:02}_{}", r.name))
                .map_err(h5err(&tmp))?;
            write_vec(&eg, "gap_after", &[r.gap_after], "1", "held-out gap", &tmp)?;
            write_vec(
                &eg,
                "reduction",
                &[r.reduction],
                "1",
                "held-out reduction",
                &tmp,
            )?;
            write_estimates(&eg, &r.fit.estimates, &tmp)?;
            write_fingerprints(&eg, &r.fingerprints, &tmp)?;
            if let Some(why) = &r.rejected {
                eg.set_attr_string("rejected", why).map_err(h5err(&tmp))?;
            }
        }
        let cg = root.create_group("calibration").map_err(h5err(&tmp))?;
        write_estimates(&cg, &d.base.estimates, &tmp)?;
        // The traces figure's data, for hosts that draw their own (the Python package).
        if let Some(o) = traces {
            let fg = root.create_group("figure_traces").map_err(h5err(&tmp))?;
            fg.set_attr_string("title", &o.title).map_err(h5err(&tmp))?;
            write_vec(&fg, "t", o.t, "s", "time", &tmp)?;
            for ((label, y, _), key) in o.series.iter().zip(["measured", "base", "best"]) {
                write_vec(&fg, key, y, "N", label, &tmp)?;
            }
        }
        f.close().map_err(h5err(&tmp))?;
    }
    crate::output::replace(&tmp, path).map_err(output::ioerr(path))
}

/// Each fingerprint family checked, a group under `eg`: share carried, its error, the
/// prediction's strength; what it showed as attributes.
fn write_fingerprints(
    eg: &rust_hdf5::H5Group,
    checks: &[crate::diagnosis::fingerprint::Check],
    tmp: &Path,
) -> Result<(), OutputError> {
    for c in checks {
        let fg = eg
            .create_group(&format!("fingerprint_{}", c.family))
            .map_err(h5err(tmp))?;
        fg.set_attr_string("seen", c.seen.name())
            .map_err(h5err(tmp))?;
        fg.set_attr_string("what", c.what).map_err(h5err(tmp))?;
        write_vec(
            &fg,
            "share",
            &[c.share],
            "1",
            "share of the predicted departure the data carry",
            tmp,
        )?;
        write_vec(
            &fg,
            "share_se",
            &[c.share_se],
            "1",
            "its standard error",
            tmp,
        )?;
        write_vec(
            &fg,
            "strength",
            &[c.strength],
            "1",
            "predicted departure, standard errors in quadrature",
            tmp,
        )?;
    }
    Ok(())
}

/// One dataset `[value, standard uncertainty]` per fitted parameter, with its unit.
fn write_estimates(
    g: &rust_hdf5::H5Group,
    es: &[Estimate],
    path: &Path,
) -> Result<(), OutputError> {
    for e in es {
        write_vec(
            g,
            &e.name,
            &[e.value, e.stderr],
            e.unit,
            "value, standard uncertainty",
            path,
        )?;
    }
    Ok(())
}
