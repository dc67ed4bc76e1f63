//! Figures, drawn with plotters to PNG and SVG. The font (DejaVu Sans) is compiled in, so no
//! system font library is needed.

use crate::sim::Trace;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// A figure could not be drawn.
#[derive(Debug, thiserror::Error)]
#[error("{path}: cannot draw: {msg}")]
pub struct PlotError {
    /// The file.
    pub path: String,
    /// The cause.
    pub msg: String,
}

static FONT: Once = Once::new();

fn register_font() {
    FONT.call_once(|| {
        // The embedded font is valid; a failure here would be a build defect.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
        let _ = plotters::style::register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold());
    });
}

/// Pixel size of every figure.
pub const SIZE: (u32, u32) = (1200, 800);

/// Something drawable on any plotters backend.
pub trait Figure {
    /// Draws the figure on `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Draws `fig` into `stem.png` and `stem.svg`; returns both paths.
pub fn render(stem: &Path, fig: &impl Figure) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    if let Some(d) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(|e| PlotError {
            path: d.display().to_string(),
            msg: e.to_string(),
        })?;
    }
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    let perr = |p: &Path| {
        let p = p.display().to_string();
        move |msg: String| PlotError {
            path: p.clone(),
            msg,
        }
    };
    {
        let root = BitMapBackend::new(&png, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| perr(&png)(e.to_string()))?;
        fig.draw(&root).map_err(perr(&png))?;
        root.present().map_err(|e| perr(&png)(e.to_string()))?;
    }
    {
        let root = SVGBackend::new(&svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| perr(&svg)(e.to_string()))?;
        fig.draw(&root).map_err(perr(&svg))?;
        root.present().map_err(|e| perr(&svg)(e.to_string()))?;
    }
    Ok(vec![png, svg])
}

/// The range of the finite values, padded by 5 % ((0, 1) when there are none).
pub(crate) fn bounds(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-12 * hi.abs().max(1.0));
    (lo - pad, hi + pad)
}

/// Reduces a series to at most `n` points per pixel column, keeping each column's min and max
/// (so saw-tooth peaks and the vibration envelope survive).
fn envelope(t: &[f64], y: &[f64], columns: usize) -> Vec<(f64, f64)> {
    if t.len() <= 2 * columns {
        return t
            .iter()
            .zip(y)
            .map(|(a, b)| (*a, *b))
            .filter(|p| p.1.is_finite())
            .collect();
    }
    let per = t.len().div_ceil(columns);
    let mut out = Vec::with_capacity(2 * columns);
    for c in t.chunks(per).zip(y.chunks(per)) {
        let (tc, yc) = c;
        let (mut imin, mut imax) = (0, 0);
        for i in 0..yc.len() {
            if yc[i] < yc[imin] {
                imin = i;
            }
            if yc[i] > yc[imax] {
                imax = i;
            }
        }
        let (a, b) = if imin < imax {
            (imin, imax)
        } else {
            (imax, imin)
        };
        out.push((tc[a], yc[a]));
        out.push((tc[b], yc[b]));
    }
    out.into_iter().filter(|p| p.1.is_finite()).collect()
}

/// The paper's Figs. 3 to 5: the drive force `F_d` (raw and smoothed) and the displacements of
/// the body `x_s` and of the drive `x_d` against time.
pub fn trace_figure(stem: &Path, tr: &Trace, title: &str) -> Result<Vec<PathBuf>, PlotError> {
    render(stem, &TraceFigure { tr, title })
}

struct TraceFigure<'a> {
    tr: &'a Trace,
    title: &'a str,
}

impl Figure for TraceFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let (tr, title) = (self.tr, self.title);
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        let root = root.titled(title, ("sans-serif", 26)).map_err(e)?;
        let (top, bottom) = root.split_vertically(SIZE.1 as f64 * 0.5);
        let t0 = tr.t.first().copied().unwrap_or(0.0);
        let t1 = tr.t.last().copied().unwrap_or(1.0).max(t0 + 1e-9);
        let cols = 1600;
        let (f_lo, f_hi) = bounds(tr.f_d.iter().copied());
        let mut c = ChartBuilder::on(&top)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(t0..t1, f_lo..f_hi)
            .map_err(e)?;
        c.configure_mesh()
            .x_desc("t [s]")
            .y_desc("F_d [N]")
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        c.draw_series(LineSeries::new(
            envelope(&tr.t, &tr.f_d, cols),
            RGBColor(150, 170, 220).stroke_width(1),
        ))
        .map_err(e)?
        .label("F_d")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RGBColor(150, 170, 220)));
        c.draw_series(LineSeries::new(
            envelope(&tr.t, &tr.f_d_smooth, cols),
            BLUE.stroke_width(2),
        ))
        .map_err(e)?
        .label("F_d, mean over one vibration period")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
        c.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(e)?;

        let mm = |v: &[f64]| v.iter().map(|x| x * 1e3).collect::<Vec<_>>();
        let (xs, xd) = (mm(&tr.x_s), mm(&tr.x_d));
        let (lo, hi) = bounds(xs.iter().chain(xd.iter()).copied());
        let mut c = ChartBuilder::on(&bottom)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(t0..t1, lo..hi)
            .map_err(e)?;
        c.configure_mesh()
            .x_desc("t [s]")
            .y_desc("displacement [mm]")
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        c.draw_series(LineSeries::new(
            envelope(&tr.t, &xd, cols),
            RED.stroke_width(2),
        ))
        .map_err(e)?
        .label("x_d (drive)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED));
        c.draw_series(LineSeries::new(
            envelope(&tr.t, &xs, cols),
            BLACK.stroke_width(2),
        ))
        .map_err(e)?
        .label("x_s (body)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
        c.configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        Ok(())
    }
}

/// The averaged friction law `F_eff(V)` of a table up to four times the largest of `v_a`,
/// `v_d` and `v_s`: the Hermite interpolant through its nodes, the nodes whose orbit does not contract (red: the law
/// may not serve there), gaps without a period-1 orbit (grey bands), and the steady friction of
/// the contact without vibration for comparison (dashed).
pub fn law_figure(
    stem: &Path,
    table: &crate::averaged::Table,
    p: &crate::model::Params,
    title: &str,
) -> Result<Vec<PathBuf>, PlotError> {
    render(stem, &LawFigure { table, p, title })
}

struct LawFigure<'a> {
    table: &'a crate::averaged::Table,
    p: &'a crate::model::Params,
    title: &'a str,
}

impl Figure for LawFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        let t = self.table;
        let p = self.p;
        // Up to four times the largest of v_a, v_d and v_s: the law's shape lies there, and
        // beyond it flattens onto the steady friction.
        let v_hi = t
            .nodes
            .last()
            .map_or(1e-3, |n| n.v_mean)
            .min(4.0 * p.v_a().max(p.v_d).max(p.v_s))
            .max(1e-12);
        let n = 800;
        let vs: Vec<f64> = (0..=n).map(|i| v_hi * i as f64 / n as f64).collect();
        let law: Vec<(f64, f64)> = vs
            .iter()
            .filter_map(|&v| t.force(v).map(|f| (v * 1e3, f)))
            .collect();
        let steady: Vec<(f64, f64)> = vs
            .iter()
            .map(|&v| {
                let g = p.f_c + (p.f_s - p.f_c) * (-(v / p.v_s).powi(2)).exp();
                (v * 1e3, g + p.h_v * v)
            })
            .collect();
        let (lo, hi) = bounds(
            law.iter()
                .chain(steady.iter())
                .map(|q| q.1)
                .chain(std::iter::once(0.0)),
        );
        let root = root.titled(self.title, ("sans-serif", 26)).map_err(e)?;
        let mut c = ChartBuilder::on(&root)
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..v_hi * 1e3, lo..hi)
            .map_err(e)?;
        c.configure_mesh()
            .x_desc("mean sliding velocity V [mm/s]")
            .y_desc("friction force [N]")
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        for &(a, b) in &t.gaps {
            c.draw_series(std::iter::once(Rectangle::new(
                [(a * 1e3, lo), (b * 1e3, hi)],
                RGBColor(200, 200, 200).mix(0.5).filled(),
            )))
            .map_err(e)?;
        }
        c.draw_series(LineSeries::new(steady, BLACK.stroke_width(1)))
            .map_err(e)?
            .label("steady friction without vibration")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
        c.draw_series(LineSeries::new(law, BLUE.stroke_width(2)))
            .map_err(e)?
            .label("F_eff(V), averaged over the vibration")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
        c.draw_series(
            t.nodes
                .iter()
                .filter(|o| !o.contracting())
                .map(|o| Circle::new((o.v_mean * 1e3, o.force), 4, RED.filled())),
        )
        .map_err(e)?
        .label("fast orbit does not contract: the law may not serve")
        .legend(|(x, y)| Circle::new((x + 10, y), 4, RED.filled()));
        c.configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        Ok(())
    }
}
