//! A diagnosis's figures: measured, base and extended traces overlaid; the gap over the
//! conditions.

use crate::campaign::{Campaign, Recording, Solvers, simulate_grid};
use crate::diagnosis::diagnose::Diagnosis;
use crate::diagnosis::fit::Model;
use crate::plot::{Figure, PlotError, render};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Simulated force of a recording under a model.
fn simulated_force(rec: &Recording, m: &Model) -> Vec<f64> {
    let mut s = Solvers::default();
    simulate_grid(
        &m.params_for(rec),
        &m.effects,
        rec.t[0],
        rec.dt(),
        rec.t.len(),
        crate::campaign::FIT_TOLERANCE,
        &mut s,
    )
    .map(|t| t.f_d)
    .unwrap_or_default()
}

/// The traces figure: the measured, base-model and best-candidate drive force of the held-out
/// recording the base model misses most (any recording where none is held out). Its two
/// simulations are made once, for both [`plots`] and [`write_h5`](super::write_h5).
pub fn traces_figure<'a>(c: &'a Campaign, d: &Diagnosis) -> Option<TracesFigure<'a>> {
    let w = &d.location.recordings;
    let i = (0..w.len())
        .filter(|&i| w[i].held_out)
        .max_by(|&a, &b| w[a].gap_base.total_cmp(&w[b].gap_base))
        .or_else(|| (0..w.len()).max_by(|&a, &b| w[a].gap_base.total_cmp(&w[b].gap_base)))?;
    let rec = &c.recordings[i];
    let mut series = vec![
        (
            "measured".to_string(),
            rec.f_d.clone(),
            RGBColor(160, 160, 160),
        ),
        (
            format!("base model (gap {:.2})", w[i].gap_base),
            simulated_force(rec, &d.base.model),
            BLUE,
        ),
    ];
    if let Some(b) = d.ranking.first() {
        series.push((
            format!("with {} (gap {:.2})", b.effect.name(), w[i].gap_best),
            simulated_force(rec, &b.fit.model),
            RED,
        ));
    }
    Some(TracesFigure {
        title: format!(
            "{} (held out): v_d = {} mm/s, k_d = {} N/m, f = {} Hz, v_a/v_d = {:.2}",
            rec.name,
            rec.params.v_d * 1e3,
            rec.params.k_d,
            if rec.vibrates() { rec.params.f } else { 0.0 },
            rec.params.v_a() / rec.params.v_d
        ),
        t: &rec.t,
        series,
    })
}

/// The data of the traces figure ([`traces_figure`]).
pub struct TracesFigure<'a> {
    /// The figure's title: the recording and the candidate.
    pub(super) title: String,
    /// The recording's times \[s\].
    pub(super) t: &'a [f64],
    /// Measured, base-model and best-candidate force: label, values \[N\], colour.
    pub(super) series: Vec<(String, Vec<f64>, RGBColor)>,
}

impl Figure for TracesFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        let n = self.t.len();
        // The last fifth of the recording: a few cycles, readable.
        let i0 = n - n / 5;
        let t = &self.t[i0..];
        let (lo, hi) =
            crate::plot::bounds(self.series.iter().flat_map(|s| s.1[i0..].iter().copied()));
        let mut ch = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 24))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(t[0]..t[t.len() - 1], lo..hi)
            .map_err(e)?;
        ch.configure_mesh()
            .x_desc("t [s]")
            .y_desc("F_d [N]")
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        for (name, y, col) in &self.series {
            let col = *col;
            ch.draw_series(LineSeries::new(
                t.iter()
                    .zip(&y[i0..])
                    .map(|(a, b)| (*a, *b))
                    .filter(|p| p.1.is_finite()),
                col.stroke_width(2),
            ))
            .map_err(e)?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], col));
        }
        ch.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(e)?;
        Ok(())
    }
}

struct GapMap<'a> {
    d: &'a Diagnosis,
}

impl Figure for GapMap<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        let root = root
            .titled(
                "Gap per recording (circles: calibrated base model, crosses: top candidate; red: held out)",
                ("sans-serif", 20),
            )
            .map_err(e)?;
        let areas = root.split_evenly((2, 3));
        let recs = &self.d.location.recordings;
        let ymax = recs
            .iter()
            .flat_map(|r| [r.gap_base, r.gap_best])
            .filter(|v| v.is_finite())
            .fold(1.0f64, f64::max)
            * 1.1;
        let labels = [
            "v_d [mm/s]",
            "k_d [kN/m]",
            "f [kHz] (0: no vibration)",
            "v_a / v_d",
            "stick time [s]",
            "k_t u0 / F_c",
        ];
        let unit = [1e3, 1e-3, 1e-3, 1.0, 1.0, 1.0];
        for (k, a) in areas.iter().enumerate() {
            let label = labels[k];
            let x = |r: &crate::diagnosis::diagnose::RecordingGap| r.conditions[k] * unit[k];
            let xmax = recs.iter().map(x).fold(0.0f64, f64::max).max(1e-3) * 1.1;
            let mut ch = ChartBuilder::on(a)
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(50)
                .build_cartesian_2d(0.0..xmax, 0.0..ymax)
                .map_err(e)?;
            ch.configure_mesh()
                .x_desc(label)
                .y_desc("gap E")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(e)?;
            ch.draw_series(recs.iter().map(|r| {
                let col = if r.held_out { RED } else { BLUE };
                Circle::new((x(r), r.gap_base), 5, col.stroke_width(2))
            }))
            .map_err(e)?;
            ch.draw_series(recs.iter().filter(|r| r.gap_best.is_finite()).map(|r| {
                let col = if r.held_out { RED } else { BLUE };
                Cross::new((x(r), r.gap_best), 5, col.stroke_width(2))
            }))
            .map_err(e)?;
        }
        Ok(())
    }
}

/// Draws the gap map and the traces figure ([`traces_figure`]).
pub fn plots(
    dir: &Path,
    d: &Diagnosis,
    traces: Option<&TracesFigure<'_>>,
) -> Result<Vec<PathBuf>, PlotError> {
    let mut written = render(&dir.join("gap_conditions"), &GapMap { d })?;
    if let Some(o) = traces {
        written.extend(render(&dir.join("traces"), o)?);
    }
    Ok(written)
}
