//! The elimination boundary of Fig. 11: for each frequency (and each value of the other
//! dimensions), the smallest vibration amplitude `u0` at which `r < 0.05`, interpolated between
//! computed points (linear in `r` against `log u0`), and the amplitude above which every one
//! eliminates (the two edges of a band where elimination comes and goes, near `v_a = v_d`).
//! Points without a value (not run by a refinement) are skipped.

use super::read::SweepData;
use crate::output::{self, OutputError, h5err, ioerr};
use rust_hdf5::H5File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// `r` below this counts as eliminated (docs/model.md).
pub const ELIMINATED: f64 = 0.05;

/// One boundary point.
#[derive(Clone, Debug, PartialEq)]
pub struct BoundaryPoint {
    /// Coordinates of the other dimensions (name, value), the amplitude dimension excluded.
    pub coords: Vec<(String, f64)>,
    /// Boundary amplitude \[m\] (NaN: not eliminated in the grid's range).
    pub u0: f64,
    /// `v_a = 2π f u0` at the boundary [m/s].
    pub v_a: f64,
    /// `v_a / v_d` at the boundary.
    pub va_ratio: f64,
    /// Rule of thumb `u0 = v_d / (2π f)` \[m\].
    pub u0_rule: f64,
    /// Whether even the smallest amplitude of the grid eliminates (the boundary lies below it).
    pub below_range: bool,
    /// The amplitude above which every computed amplitude eliminates \[m\]: the upper edge of
    /// a band where elimination comes and goes (equal to `u0` where r crosses 0.05 once; NaN
    /// where the largest amplitude does not eliminate).
    pub u0_upper: f64,
    /// How often r crosses 0.05 along the line (more than one: intermittent elimination).
    pub crossings: usize,
    /// Relative spacing of the two computed amplitudes around `u0` (the resolution reached).
    pub resolution: f64,
}

/// The edges of elimination along one line of computed points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edges {
    /// Smallest amplitude with `r < 0.05`, interpolated (NaN: none).
    pub lower: f64,
    /// Amplitude above which every computed one has `r < 0.05` (NaN: the largest does not).
    pub upper: f64,
    /// Whether the smallest amplitude already eliminates.
    pub below: bool,
    /// Crossings of `r = 0.05`.
    pub crossings: usize,
    /// Relative spacing of the computed amplitudes around `lower`.
    pub resolution: f64,
}

/// The edges along a line of computed amplitudes `u` (ascending, > 0) with values `r`
/// (finite): crossings are interpolated linearly in `r` against `log u`.
pub fn edges(u: &[f64], r: &[f64]) -> Edges {
    let cross = |n: usize| {
        let (r0, r1) = (r[n - 1], r[n]);
        let (l0, l1) = (u[n - 1].ln(), u[n].ln());
        let w = if r0 != r1 {
            ((r0 - ELIMINATED) / (r0 - r1)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        (l0 + w * (l1 - l0)).exp()
    };
    let len = u.len();
    let eliminated = |n: usize| r[n] < ELIMINATED;
    let first = (0..len).find(|&n| eliminated(n));
    let last_not = (0..len).rev().find(|&n| !eliminated(n));
    let (lower, below, resolution) = match first {
        None => (f64::NAN, false, f64::NAN),
        Some(0) => (u[0], true, f64::NAN),
        Some(n) => (cross(n), false, u[n] / u[n - 1] - 1.0),
    };
    let upper = match (first, last_not) {
        (None, _) => f64::NAN,
        (Some(_), None) => lower,
        (Some(_), Some(m)) if m + 1 == len => f64::NAN,
        (Some(_), Some(m)) => cross(m + 1),
    };
    Edges {
        lower,
        upper,
        below,
        crossings: (1..len)
            .filter(|&n| eliminated(n) != eliminated(n - 1))
            .count(),
        resolution,
    }
}

/// Computes the boundary along the amplitude dimension (`u0`, `v_a` or `va_ratio`).
pub fn compute(d: &SweepData) -> Result<Vec<BoundaryPoint>, String> {
    let amp = ["u0", "v_a", "va_ratio"]
        .iter()
        .find_map(|n| d.dim(n))
        .ok_or_else(|| {
            format!(
                "{}: no amplitude axis (u0, v_a or va_ratio) to find a boundary along",
                d.path.display()
            )
        })?;
    let shape: Vec<usize> = d.dims.iter().map(|x| x.values.len()).collect();
    let others: Vec<usize> = (0..shape.len()).filter(|&k| k != amp).collect();
    let count: usize = others.iter().map(|&k| shape[k]).product();
    let mut out = vec![];
    for flat in 0..count {
        // Multi-index over the other dimensions (C order).
        let mut idx = vec![0usize; shape.len()];
        let mut rem = flat;
        for &k in others.iter().rev() {
            idx[k] = rem % shape[k];
            rem /= shape[k];
        }
        let at = |j: usize| {
            let mut ix = idx.clone();
            ix[amp] = j;
            ix
        };
        // Amplitudes ascending along the axis (the sweep's order may be descending); points
        // without a value (not run by a refinement, or failed) are left out.
        let mut order: Vec<usize> = (0..shape[amp])
            .filter(|&j| d.r[at(j).as_slice()].is_finite())
            .collect();
        order.sort_by(|&a, &b| d.u0[at(a).as_slice()].total_cmp(&d.u0[at(b).as_slice()]));
        let us: Vec<f64> = order.iter().map(|&j| d.u0[at(j).as_slice()]).collect();
        let rs: Vec<f64> = order.iter().map(|&j| d.r[at(j).as_slice()]).collect();
        let e = edges(&us, &rs);
        let (u0_b, below, resolution, u0_upper, crossings) =
            (e.lower, e.below, e.resolution, e.upper, e.crossings);
        if order.is_empty() {
            order.push(0);
        }
        let ix0 = at(order[0]);
        let u0_0 = d.u0[ix0.as_slice()];
        let v_a0 = d.v_a[ix0.as_slice()];
        // 2π f from any point with u0 > 0 on this line.
        let omega = order
            .iter()
            .map(|&j| (d.v_a[at(j).as_slice()], d.u0[at(j).as_slice()]))
            .find(|(_, u)| *u > 0.0)
            .map(|(v, u)| v / u)
            .unwrap_or(if u0_0 > 0.0 { v_a0 / u0_0 } else { f64::NAN });
        let v_d = d.v_d[ix0.as_slice()];
        out.push(BoundaryPoint {
            coords: others
                .iter()
                .map(|&k| (d.dims[k].name.clone(), d.dims[k].values[idx[k]]))
                .collect(),
            u0: u0_b,
            v_a: omega * u0_b,
            va_ratio: omega * u0_b / v_d,
            u0_rule: v_d / omega,
            below_range: below,
            u0_upper,
            crossings,
            resolution,
        });
    }
    Ok(out)
}

/// The boundary CSV's columns after those of the other axes, in order (the values of
/// [`BoundaryPoint::csv_row`]).
pub const CSV_COLUMNS: [&str; 8] = [
    "u0_boundary [m]",
    "v_a_boundary [m/s]",
    "va_ratio_boundary",
    "u0_rule_of_thumb [m]",
    "below_grid",
    "u0_upper [m]",
    "crossings",
    "resolution",
];

impl BoundaryPoint {
    /// The values of [`CSV_COLUMNS`] for this point (`below_grid` as 0 or 1).
    pub fn csv_row(&self) -> [f64; 8] {
        [
            self.u0,
            self.v_a,
            self.va_ratio,
            self.u0_rule,
            f64::from(u8::from(self.below_range)),
            self.u0_upper,
            self.crossings as f64,
            self.resolution,
        ]
    }
}

/// Writes the boundary as CSV beside the file (`<stem>_boundary.csv`) and into the HDF5 file as
/// group `boundary`; returns the CSV path.
pub fn write(d: &SweepData, pts: &[BoundaryPoint]) -> Result<PathBuf, OutputError> {
    let path = &d.path;
    let stem = path.with_extension("");
    let csv = PathBuf::from(format!("{}_boundary.csv", stem.display()));
    {
        let tmp = output::temp_for(&csv)?;
        let e = ioerr(&csv);
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp).map_err(&e)?);
        let names: Vec<String> = pts
            .first()
            .map(|p| p.coords.iter().map(|c| c.0.clone()).collect())
            .unwrap_or_default();
        let mut header: Vec<String> = names.clone();
        header.extend(CSV_COLUMNS.map(String::from));
        writeln!(w, "{}", header.join(",")).map_err(&e)?;
        for p in pts {
            let mut row: Vec<String> = p.coords.iter().map(|c| format!("{:e}", c.1)).collect();
            row.extend([
                format!("{:e}", p.u0),
                format!("{:e}", p.v_a),
                format!("{}", p.va_ratio),
                format!("{:e}", p.u0_rule),
                (p.below_range as u8).to_string(),
                format!("{:e}", p.u0_upper),
                p.crossings.to_string(),
                format!("{:e}", p.resolution),
            ]);
            writeln!(w, "{}", row.join(",")).map_err(&e)?;
        }
        w.flush().map_err(&e)?;
        drop(w);
        crate::output::replace(&tmp, &csv).map_err(&e)?;
    }
    {
        let e = h5err(path);
        let f = H5File::open_rw(path).map_err(&e)?;
        if f.root_group()
            .group_names()
            .map_err(&e)?
            .iter()
            .any(|g| g == "boundary")
        {
            f.delete_group("boundary").map_err(&e)?;
        }
        let g = f.create_group("boundary").map_err(&e)?;
        if let Some(first) = pts.first() {
            for (k, (name, _)) in first.coords.iter().enumerate() {
                let v: Vec<f64> = pts.iter().map(|p| p.coords[k].1).collect();
                let unit = super::spec::unit_of(name).unwrap_or("");
                output::write_vec(&g, name, &v, unit, "coordinate of the boundary point", path)?;
            }
        }
        let col = |f: fn(&BoundaryPoint) -> f64| pts.iter().map(f).collect::<Vec<f64>>();
        output::write_vec(
            &g,
            "u0",
            &col(|p| p.u0),
            "m",
            "smallest u0 with r < 0.05 (NaN: none in the grid)",
            path,
        )?;
        output::write_vec(
            &g,
            "v_a",
            &col(|p| p.v_a),
            "m/s",
            "v_a = 2 pi f u0 at the boundary",
            path,
        )?;
        output::write_vec(
            &g,
            "va_ratio",
            &col(|p| p.va_ratio),
            "1",
            "v_a / v_d at the boundary",
            path,
        )?;
        output::write_vec(
            &g,
            "u0_rule",
            &col(|p| p.u0_rule),
            "m",
            "rule of thumb v_a = v_d: u0 = v_d / (2 pi f)",
            path,
        )?;
        output::write_vec(
            &g,
            "below_grid",
            &col(|p| p.below_range as u8 as f64),
            "1",
            "1 where the smallest amplitude of the grid already eliminates",
            path,
        )?;
        output::write_vec(
            &g,
            "u0_upper",
            &col(|p| p.u0_upper),
            "m",
            "u0 above which every computed u0 has r < 0.05 (upper edge of an intermittent band)",
            path,
        )?;
        output::write_vec(
            &g,
            "crossings",
            &col(|p| p.crossings as f64),
            "1",
            "number of crossings of r = 0.05 along the amplitude axis",
            path,
        )?;
        output::write_vec(
            &g,
            "resolution",
            &col(|p| p.resolution),
            "1",
            "relative spacing of the computed amplitudes around the boundary",
            path,
        )?;
        g.set_attr_numeric("threshold", &ELIMINATED).map_err(&e)?;
        f.close().map_err(&e)?;
    }
    Ok(csv)
}

/// `stickslip boundary FILE`: computes and writes the boundary.
pub fn run(path: &Path) -> Result<(PathBuf, Vec<BoundaryPoint>), super::error::SweepError> {
    let d = SweepData::read(path)?;
    let pts = compute(&d).map_err(super::error::SweepError::State)?;
    let csv = write(&d, &pts)?;
    Ok((csv, pts))
}
