//! Reading a sweep's HDF5 file back (for `plot` and `boundary`).

use crate::output::OutputError;
use ndarray::{ArrayD, Dimension, IxDyn};
use rust_hdf5::H5File;
use std::path::{Path, PathBuf};

/// A dimension of the maps.
#[derive(Clone, Debug)]
pub struct DimData {
    /// Name (the axis name).
    pub name: String,
    /// Coordinate values.
    pub values: Vec<f64>,
    /// Unit.
    pub unit: String,
}

/// The maps of a sweep file.
#[derive(Clone, Debug)]
pub struct SweepData {
    /// The file.
    pub path: PathBuf,
    /// Sweep name.
    pub name: String,
    /// Dimensions in order.
    pub dims: Vec<DimData>,
    /// Reduction coefficient.
    pub r: ArrayD<f64>,
    /// Mean drive force \[N\].
    pub mean_force: ArrayD<f64>,
    /// Vibration amplitude per point \[m\].
    pub u0: ArrayD<f64>,
    /// Vibration velocity amplitude per point [m/s].
    pub v_a: ArrayD<f64>,
    /// Drive velocity per point [m/s] (from the axis or the fixed value).
    pub v_d: ArrayD<f64>,
    /// Run status per point (0 success, −1 not run, others failures; docs/model.md).
    pub status: ArrayD<f64>,
}

impl SweepData {
    /// Reads the maps from a sweep file.
    pub fn read(path: &Path) -> Result<SweepData, OutputError> {
        let bad = |msg: String| OutputError::Hdf5 {
            path: path.display().to_string(),
            msg,
        };
        // A device or pipe would be read for ever or block.
        if crate::output::special(path) {
            return Err(bad(
                "not a regular file (a device, pipe, socket or folder)".into()
            ));
        }
        let f = H5File::open(path).map_err(|x| {
            bad(format!(
                "not an HDF5 file, or a damaged one ({x}); plot and boundary read the files `stickslip sweep` and `stickslip merge` write"
            ))
        })?;
        let dims_attr = f.attr_string("dims").map_err(|_| {
            bad("an HDF5 file, but not a stickslip sweep file (no `dims` attribute); plot and boundary read the files `stickslip sweep` and `stickslip merge` write".into())
        })?;
        let read = |name: &str| -> Result<Vec<f64>, OutputError> {
            let ds = f.dataset(name).map_err(|_| {
                bad(format!(
                    "dataset `{name}` is missing: not a complete stickslip sweep file"
                ))
            })?;
            ds.read_raw::<f64>().map_err(|x| {
                bad(format!(
                    "dataset `{name}` is damaged or not of 64-bit floats ({x})"
                ))
            })
        };
        let mut dims = vec![];
        for name in dims_attr.split(',').filter(|s| !s.is_empty()) {
            let values = read(name)?;
            let unit = f
                .dataset(name)
                .ok()
                .and_then(|ds| ds.attr("units").and_then(|a| a.read_string()).ok())
                .unwrap_or_default();
            dims.push(DimData {
                name: name.to_string(),
                values,
                unit,
            });
        }
        let shape: Vec<usize> = dims.iter().map(|d| d.values.len()).collect();
        let grid = |name: &str| -> Result<ArrayD<f64>, OutputError> {
            let v = read(name)?;
            let n = v.len();
            ArrayD::from_shape_vec(IxDyn(&shape), v).map_err(|_| {
                bad(format!(
                    "dataset `{name}` is damaged: {n} values where the dimensions {dims_attr} of shape {shape:?} ask for {}",
                    shape.iter().product::<usize>()
                ))
            })
        };
        let r = grid("r")?;
        let mean_force =
            grid("mean_force").unwrap_or_else(|_| ArrayD::from_elem(IxDyn(&shape), f64::NAN));
        let u0 = grid("u0_grid")?;
        let status = grid("status")?;
        let v_a = grid("v_a_grid")?;
        let v_d = match dims.iter().position(|d| d.name == "v_d") {
            Some(k) => ArrayD::from_shape_fn(IxDyn(&shape), |ix| dims[k].values[ix[k]]),
            None => {
                // The fixed drive velocity is a root attribute; v_a / va_ratio recovers it too.
                let ratio = dims.iter().position(|d| d.name == "va_ratio");
                match ratio {
                    Some(k) => ArrayD::from_shape_fn(IxDyn(&shape), |ix| {
                        let q = dims[k].values[ix.slice()[k]];
                        if q > 0.0 {
                            v_a[ix.slice()] / q
                        } else {
                            f64::NAN
                        }
                    }),
                    None => ArrayD::from_elem(IxDyn(&shape), fixed_v_d(&f).unwrap_or(f64::NAN)),
                }
            }
        };
        let name = f.attr_string("sweep_name").unwrap_or_default();
        Ok(SweepData {
            path: path.to_path_buf(),
            name,
            dims,
            r,
            mean_force,
            u0,
            v_a,
            v_d,
            status,
        })
    }

    /// An error when no point of the sweep has results (every run failed or none ran): its
    /// figures would be empty and its boundary NaN, which reads as "never eliminated".
    pub fn require_results(&self) -> Result<(), String> {
        if self.status.iter().any(|&s| s == 0.0 || s == 5.0) {
            return Ok(());
        }
        let failed = self.status.iter().filter(|&&s| s > 0.0).count();
        Err(format!(
            "{}: no point of the sweep has results ({failed} of {} failed, the others not run): nothing to plot, and no boundary to find; see the `status` dataset",
            self.path.display(),
            self.status.len()
        ))
    }

    /// Index of the dimension called `name`.
    pub fn dim(&self, name: &str) -> Option<usize> {
        self.dims.iter().position(|d| d.name == name)
    }
}

/// The fixed drive velocity: not stored as a readable numeric attribute by every reader, so it is
/// recovered from the sweep file text.
fn fixed_v_d(f: &H5File) -> Option<f64> {
    let text = f.attr_string("sweep_file").ok()?;
    let table: toml::Table = text.parse().ok()?;
    match table.get("fixed").and_then(|t| t.get("v_d")) {
        Some(v) => v.as_float().or_else(|| v.as_integer().map(|i| i as f64)),
        None => Some(crate::model::Params::default().v_d),
    }
}
