//! Figures of a sweep file: Fig. 10a/10b (r and mean force against v_a/v_d, one curve per v_d),
//! Fig. 11a/11b (r against u0 at fixed f, and against f at fixed u0), and the (u0, f) map of r
//! with the elimination boundary (contour r = 0.05) and the rule of thumb v_a = v_d.

use super::boundary::ELIMINATED;
use super::read::SweepData;
use crate::plot::{Figure, PlotError, SIZE, render};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// A line plot of several labelled series.
pub struct Lines {
    /// Title.
    pub title: String,
    /// Axis labels with units.
    pub x_label: String,
    /// Axis labels with units.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Series: label and points.
    pub series: Vec<(String, Vec<(f64, f64)>)>,
    /// Horizontal reference line (value, label).
    pub hline: Option<(f64, String)>,
}

fn range(v: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = v
        .filter(|x| x.is_finite() && (!log || *x > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if !lo.is_finite() {
        return if log { (1e-3, 1.0) } else { (0.0, 1.0) };
    }
    if log {
        (lo / 1.1, hi * 1.1)
    } else {
        let pad = ((hi - lo) * 0.05).max(1e-9 * hi.abs().max(1e-300));
        (lo - pad, hi + pad)
    }
}

impl Figure for Lines {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        let (x0, x1) = range(
            self.series.iter().flat_map(|s| s.1.iter().map(|p| p.0)),
            self.log_x,
        );
        let (y0, y1) = range(
            self.series
                .iter()
                .flat_map(|s| s.1.iter().map(|p| p.1))
                .chain(self.hline.iter().map(|h| h.0)),
            false,
        );
        let mut b = ChartBuilder::on(root);
        b.caption(&self.title, ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(80);
        macro_rules! body {
            ($c:expr) => {{
                let mut c = $c;
                c.configure_mesh()
                    .x_desc(&self.x_label)
                    .y_desc(&self.y_label)
                    .x_labels(8)
                    .x_label_formatter(&|v| {
                        if self.log_x {
                            format!("{v:.1e}")
                        } else {
                            format!("{v:.2}")
                        }
                    })
                    .label_style(("sans-serif", 16))
                    .draw()
                    .map_err(e)?;
                for (k, (label, pts)) in self.series.iter().enumerate() {
                    let col = PALETTE[k % PALETTE.len()];
                    let pts: Vec<(f64, f64)> = pts
                        .iter()
                        .copied()
                        .filter(|p| p.1.is_finite() && (!self.log_x || p.0 > 0.0))
                        .collect();
                    c.draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))
                        .map_err(e)?
                        .label(label.clone())
                        .legend(move |(x, y)| {
                            PathElement::new([(x, y), (x + 20, y)], col.stroke_width(2))
                        });
                    c.draw_series(pts.iter().map(|&p| Circle::new(p, 3, col.filled())))
                        .map_err(e)?;
                }
                if let Some((v, label)) = &self.hline {
                    c.draw_series(LineSeries::new([(x0, *v), (x1, *v)], BLACK.stroke_width(1)))
                        .map_err(e)?
                        .label(label.clone())
                        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
                }
                c.configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 16))
                    .draw()
                    .map_err(e)?;
            }};
        }
        if self.log_x {
            body!(
                b.build_cartesian_2d((x0..x1).log_scale(), y0..y1)
                    .map_err(e)?
            );
        } else {
            body!(b.build_cartesian_2d(x0..x1, y0..y1).map_err(e)?);
        }
        Ok(())
    }
}

/// The (f, u0) map of r on log axes, with the contour r = 0.05 and the line v_a = v_d.
pub struct Map {
    /// Title.
    pub title: String,
    /// Frequencies \[Hz\] (ascending or descending).
    pub f: Vec<f64>,
    /// Amplitudes \[m\].
    pub u0: Vec<f64>,
    /// r at `(f[i], u0[j])` as `r[i][j]`.
    pub r: Vec<Vec<f64>>,
    /// Drive velocity for the rule of thumb [m/s].
    pub v_d: f64,
}

impl Map {
    /// Whether only some points of the grid were run (a `[refine]` sweep): then the cells show
    /// the nearest computed value along u0, and the boundary is drawn from each frequency's
    /// edges instead of a contour through the grid.
    fn refined(&self) -> bool {
        self.r.iter().any(|col| {
            let first = col.iter().position(|v| v.is_finite());
            let last = col.iter().rposition(|v| v.is_finite());
            matches!((first, last), (Some(a), Some(b)) if col[a..b].iter().any(|v| v.is_nan()))
        })
    }

    /// Column `i` with every gap filled by the nearest computed value along u0 (in index).
    fn filled(&self, i: usize) -> Vec<f64> {
        let col = &self.r[i];
        let known: Vec<usize> = (0..col.len()).filter(|&j| col[j].is_finite()).collect();
        (0..col.len())
            .map(|j| {
                let k = known.partition_point(|&x| x < j);
                let near = [k.checked_sub(1), (k < known.len()).then_some(k)]
                    .into_iter()
                    .flatten()
                    .map(|n| known[n])
                    .min_by_key(|&x| x.abs_diff(j));
                near.map(|x| col[x]).unwrap_or(f64::NAN)
            })
            .collect()
    }

    /// The lower and upper edges of elimination per frequency, as two polylines (broken where
    /// a frequency has none).
    fn edge_lines(&self) -> Vec<Vec<(f64, f64)>> {
        let mut lower: Vec<Vec<(f64, f64)>> = vec![vec![]];
        let mut upper: Vec<Vec<(f64, f64)>> = vec![vec![]];
        let mut order: Vec<usize> = (0..self.f.len()).collect();
        order.sort_by(|&a, &b| self.f[a].total_cmp(&self.f[b]));
        for i in order {
            let mut pts: Vec<(f64, f64)> = self
                .u0
                .iter()
                .zip(&self.r[i])
                .filter(|(u, r)| r.is_finite() && **u > 0.0)
                .map(|(u, r)| (*u, *r))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (u, r): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
            let e = super::boundary::edges(&u, &r);
            for (line, v) in [(&mut lower, e.lower), (&mut upper, e.upper)] {
                if v.is_finite() {
                    line.last_mut().expect("never empty").push((self.f[i], v));
                } else if !line.last().expect("never empty").is_empty() {
                    line.push(vec![]);
                }
            }
        }
        lower
            .into_iter()
            .chain(upper)
            .filter(|l| l.len() > 1)
            .collect()
    }
}

/// Colour for r in [0, 1.2]: dark blue (eliminated) through yellow to red (no reduction).
fn colour(r: f64) -> RGBColor {
    if !r.is_finite() {
        return RGBColor(200, 200, 200);
    }
    let t = (r / 1.2).clamp(0.0, 1.0);
    let stops = [
        (0.0, (20, 30, 110)),
        (0.04, (40, 90, 190)),
        (0.25, (60, 170, 200)),
        (0.5, (140, 210, 120)),
        (0.75, (250, 220, 60)),
        (1.0, (200, 40, 30)),
    ];
    for w in stops.windows(2) {
        let (a, ca) = w[0];
        let (b, cb) = w[1];
        if t <= b {
            let s = (t - a) / (b - a);
            let m = |x: u8, y: u8| (x as f64 + s * (y as f64 - x as f64)).round() as u8;
            return RGBColor(m(ca.0, cb.0), m(ca.1, cb.1), m(ca.2, cb.2));
        }
    }
    RGBColor(200, 40, 30)
}

/// Cell edges (geometric midpoints) around log-spaced centres.
fn edges(c: &[f64]) -> Vec<f64> {
    let n = c.len();
    if n == 1 {
        return vec![c[0] / 1.5, c[0] * 1.5];
    }
    let mut e = Vec::with_capacity(n + 1);
    e.push(c[0] * (c[0] / c[1]).sqrt());
    for i in 0..n - 1 {
        e.push((c[i] * c[i + 1]).sqrt());
    }
    e.push(c[n - 1] * (c[n - 1] / c[n - 2]).sqrt());
    e
}

/// Segments of the contour `r = level` by marching squares on the grid of centres (log space).
pub fn contour(x: &[f64], y: &[f64], z: &[Vec<f64>], level: f64) -> Vec<[(f64, f64); 2]> {
    let mut segs = vec![];
    let lerp = |a: f64, b: f64, za: f64, zb: f64| {
        let w = (level - za) / (zb - za);
        (a.ln() + w * (b.ln() - a.ln())).exp()
    };
    for i in 0..x.len().saturating_sub(1) {
        for j in 0..y.len().saturating_sub(1) {
            let (z00, z10, z01, z11) = (z[i][j], z[i + 1][j], z[i][j + 1], z[i + 1][j + 1]);
            if ![z00, z10, z01, z11].iter().all(|v| v.is_finite()) {
                continue;
            }
            let mut pts = vec![];
            if (z00 < level) != (z10 < level) {
                pts.push((lerp(x[i], x[i + 1], z00, z10), y[j]));
            }
            if (z10 < level) != (z11 < level) {
                pts.push((x[i + 1], lerp(y[j], y[j + 1], z10, z11)));
            }
            if (z01 < level) != (z11 < level) {
                pts.push((lerp(x[i], x[i + 1], z01, z11), y[j + 1]));
            }
            if (z00 < level) != (z01 < level) {
                pts.push((x[i], lerp(y[j], y[j + 1], z00, z01)));
            }
            if pts.len() >= 2 {
                segs.push([pts[0], pts[1]]);
            }
            if pts.len() == 4 {
                segs.push([pts[2], pts[3]]);
            }
        }
    }
    segs
}

impl Figure for Map {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        let (main, bar) = root.split_horizontally(SIZE.0 - 130);
        let fe = edges(&self.f);
        let ue = edges(&self.u0);
        let (fx0, fx1) = (
            fe.iter().cloned().fold(f64::INFINITY, f64::min),
            fe.iter().cloned().fold(0.0, f64::max),
        );
        let (uy0, uy1) = (
            ue.iter().cloned().fold(f64::INFINITY, f64::min),
            ue.iter().cloned().fold(0.0, f64::max),
        );
        let mut c = ChartBuilder::on(&main)
            .caption(&self.title, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(90)
            .build_cartesian_2d((fx0..fx1).log_scale(), (uy0..uy1).log_scale())
            .map_err(e)?;
        c.configure_mesh()
            .disable_mesh()
            .x_desc("f [Hz]")
            .y_desc("u0 [m]")
            .x_labels(8)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        let refined = self.refined();
        let mut cells = vec![];
        for i in 0..self.f.len() {
            let col = if refined {
                self.filled(i)
            } else {
                self.r[i].clone()
            };
            // Runs of equal values along u0 (the filled gaps of a refinement) are one cell.
            let mut j = 0;
            while j < self.u0.len() {
                let mut k = j + 1;
                while k < self.u0.len() && col[k].to_bits() == col[j].to_bits() {
                    k += 1;
                }
                let (a, b) = (fe[i].min(fe[i + 1]), fe[i].max(fe[i + 1]));
                let (p, q) = (ue[j].min(ue[k]), ue[j].max(ue[k]));
                cells.push(Rectangle::new([(a, p), (b, q)], colour(col[j]).filled()));
                j = k;
            }
        }
        c.draw_series(cells).map_err(e)?;
        let segs: Vec<Vec<(f64, f64)>> = if refined {
            self.edge_lines()
        } else {
            contour(&self.f, &self.u0, &self.r, ELIMINATED)
                .iter()
                .map(|s| s.to_vec())
                .collect()
        };
        let white = WHITE.stroke_width(3);
        c.draw_series(segs.into_iter().map(|s| PathElement::new(s, white)))
            .map_err(e)?
            .label("r = 0.05 (elimination boundary)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], WHITE.stroke_width(3)));
        let rule: Vec<(f64, f64)> = (0..=100)
            .map(|k| {
                let f = (fx0.ln() + (fx1.ln() - fx0.ln()) * k as f64 / 100.0).exp();
                (f, self.v_d / (2.0 * std::f64::consts::PI * f))
            })
            .filter(|p| p.1 >= uy0 && p.1 <= uy1)
            .collect();
        let dash = BLACK.stroke_width(2);
        c.draw_series(DashedLineSeries::new(rule, 10, 6, dash))
            .map_err(e)?
            .label("v_a = v_d (rule of thumb)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        c.configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        // Colour bar.
        let mut cb = ChartBuilder::on(&bar)
            .margin_top(60)
            .margin_bottom(60)
            .margin_right(20)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..1.0, 0.0..1.2)
            .map_err(e)?;
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc("r")
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(e)?;
        cb.draw_series((0..120).map(|k| {
            let v = k as f64 / 100.0;
            Rectangle::new([(0.0, v), (1.0, v + 0.01)], colour(v).filled())
        }))
        .map_err(e)?;
        Ok(())
    }
}

fn curves_over(
    d: &SweepData,
    x_dim: usize,
    group_dim: Option<usize>,
    fixed: &[usize],
    value: &ndarray::ArrayD<f64>,
    max_curves: usize,
) -> Vec<(String, Vec<(f64, f64)>)> {
    let nx = d.dims[x_dim].values.len();
    let groups: Vec<usize> = match group_dim {
        Some(g) => {
            let n = d.dims[g].values.len();
            let take = n.min(max_curves);
            (0..take)
                .map(|k| {
                    if take > 1 {
                        k * (n - 1) / (take - 1)
                    } else {
                        0
                    }
                })
                .collect()
        }
        None => vec![0],
    };
    groups
        .into_iter()
        .map(|gi| {
            let pts = (0..nx)
                .map(|xi| {
                    let mut ix = fixed.to_vec();
                    ix[x_dim] = xi;
                    if let Some(g) = group_dim {
                        ix[g] = gi;
                    }
                    (d.dims[x_dim].values[xi], value[ix.as_slice()])
                })
                .collect();
            let label = match group_dim {
                Some(g) => format_value(&d.dims[g].name, d.dims[g].values[gi]),
                None => d.name.clone(),
            };
            (label, pts)
        })
        .collect()
}

/// A coordinate value in the units people read (mm/s, µm, Hz, N/m).
pub fn format_value(name: &str, v: f64) -> String {
    match name {
        "v_d" | "v_a" => format!("{name} = {:.3} mm/s", v * 1e3),
        "u0" => format!("u0 = {:.3} µm", v * 1e6),
        "f" => format!("f = {v:.0} Hz"),
        "k_d" => format!("k_d = {v:.0} N/m"),
        _ => format!("{name} = {v}"),
    }
}

fn label_of(name: &str, unit: &str) -> String {
    match name {
        "va_ratio" => "v_a / v_d [-]".into(),
        "u0" => "u0 [m]".into(),
        _ => format!("{name} [{unit}]"),
    }
}

/// Draws every figure the file's dimensions allow; returns the files written.
pub fn plot_all(d: &SweepData, out_stem: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let mut files = vec![];
    let nd = d.dims.len();
    let zero = vec![0usize; nd];
    let stem = |s: &str| PathBuf::from(format!("{}_{s}", out_stem.display()));
    let others = |a: &[usize]| (0..nd).filter(|k| !a.contains(k)).collect::<Vec<_>>();
    let other_text = |fixed: &[usize], skip: &[usize]| {
        others(skip)
            .iter()
            .filter(|&&k| d.dims[k].values.len() > 1)
            .map(|&k| format_value(&d.dims[k].name, d.dims[k].values[fixed[k]]))
            .collect::<Vec<_>>()
            .join(", ")
    };
    // Fig. 10: r and mean force against v_a/v_d (or v_a), one curve per v_d (or another dim).
    if let Some(x) = d.dim("va_ratio").or_else(|| d.dim("v_a")) {
        let group = d.dim("v_d").filter(|&g| g != x).or_else(|| {
            others(&[x])
                .into_iter()
                .find(|&k| d.dims[k].values.len() > 1)
        });
        let skip: Vec<usize> = [Some(x), group].into_iter().flatten().collect();
        let note = other_text(&zero, &skip);
        let xl = label_of(&d.dims[x].name, &d.dims[x].unit);
        let suffix = if note.is_empty() {
            String::new()
        } else {
            format!(" ({note})")
        };
        files.extend(render(
            &stem("fig10a"),
            &Lines {
                title: format!("Fig. 10a: stick-slip reduction{suffix}"),
                x_label: xl.clone(),
                y_label: "r = dF_sd / dF_ss [-]".into(),
                log_x: false,
                series: curves_over(d, x, group, &zero, &d.r, 8),
                hline: Some((ELIMINATED, "r = 0.05".into())),
            },
        )?);
        files.extend(render(
            &stem("fig10b"),
            &Lines {
                title: format!("Fig. 10b: mean drive force{suffix}"),
                x_label: xl,
                y_label: "mean F_d [N]".into(),
                log_x: false,
                series: curves_over(d, x, group, &zero, &d.mean_force, 8),
                hline: None,
            },
        )?);
    }
    // Fig. 11: r against u0 at fixed f, r against f at fixed u0, and the (u0, f) map.
    if let (Some(u), Some(f)) = (d.dim("u0"), d.dim("f")) {
        let note = other_text(&zero, &[u, f]);
        let suffix = if note.is_empty() {
            String::new()
        } else {
            format!(" ({note})")
        };
        files.extend(render(
            &stem("fig11a"),
            &Lines {
                title: format!("Fig. 11a: r against amplitude at fixed frequency{suffix}"),
                x_label: "u0 [m]".into(),
                y_label: "r [-]".into(),
                log_x: true,
                series: curves_over(d, u, Some(f), &zero, &d.r, 6),
                hline: Some((ELIMINATED, "r = 0.05".into())),
            },
        )?);
        files.extend(render(
            &stem("fig11b"),
            &Lines {
                title: format!("Fig. 11b: r against frequency at fixed amplitude{suffix}"),
                x_label: "f [Hz]".into(),
                y_label: "r [-]".into(),
                log_x: true,
                series: curves_over(d, f, Some(u), &zero, &d.r, 6),
                hline: Some((ELIMINATED, "r = 0.05".into())),
            },
        )?);
        if d.dims[u].values.len() >= 4 && d.dims[f].values.len() >= 4 {
            // One map per combination of the other dimensions (at most 16).
            let rest = others(&[u, f]);
            let combos: usize = rest.iter().map(|&k| d.dims[k].values.len()).product();
            for c in 0..combos.min(16) {
                let mut ix = zero.clone();
                let mut rem = c;
                for &k in rest.iter().rev() {
                    ix[k] = rem % d.dims[k].values.len();
                    rem /= d.dims[k].values.len();
                }
                let r: Vec<Vec<f64>> = (0..d.dims[f].values.len())
                    .map(|i| {
                        (0..d.dims[u].values.len())
                            .map(|j| {
                                let mut p = ix.clone();
                                p[f] = i;
                                p[u] = j;
                                d.r[p.as_slice()]
                            })
                            .collect()
                    })
                    .collect();
                let note = other_text(&ix, &[u, f]);
                let v_d = d.v_d[ix.as_slice()];
                let name = if combos > 1 {
                    format!("map_{c}")
                } else {
                    "map".into()
                };
                files.extend(render(
                    &stem(&name),
                    &Map {
                        // A swept v_d is named in the note already.
                        title: if note.contains("v_d =") {
                            format!("r over (f, u0), {note}")
                        } else if note.is_empty() {
                            format!("r over (f, u0), v_d = {:.3} mm/s", v_d * 1e3)
                        } else {
                            format!("r over (f, u0), v_d = {:.3} mm/s, {note}", v_d * 1e3)
                        },
                        f: d.dims[f].values.clone(),
                        u0: d.dims[u].values.clone(),
                        r,
                        v_d,
                    },
                )?);
            }
        }
    }
    // Anything else: r against the first dimension, one curve per value of the second.
    if files.is_empty() {
        let group = (nd > 1).then_some(1);
        files.extend(render(
            &stem("r"),
            &Lines {
                title: format!("{}: reduction coefficient", d.name),
                x_label: label_of(&d.dims[0].name, &d.dims[0].unit),
                y_label: "r [-]".into(),
                log_x: false,
                series: curves_over(d, 0, group, &zero, &d.r, 8),
                hline: Some((ELIMINATED, "r = 0.05".into())),
            },
        )?);
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contour_of_a_plane_is_a_straight_line() {
        // r = log10(y) − log10(x) + 1 crosses 0.05 on a line; all segments lie on it.
        let x: Vec<f64> = (0..6).map(|i| 10f64.powi(i)).collect();
        let y = x.clone();
        let z: Vec<Vec<f64>> = x
            .iter()
            .map(|a| y.iter().map(|b| b.log10() - a.log10() + 1.0).collect())
            .collect();
        let segs = contour(&x, &y, &z, 0.05);
        assert!(!segs.is_empty());
        for s in segs {
            for (a, b) in s {
                assert!((b.log10() - a.log10() + 1.0 - 0.05).abs() < 1e-9);
            }
        }
    }
}
