//! Reports of a diagnosis: the terminal summary, the JSON verdict, the HDF5 details and the
//! plots (measured, base and extended traces overlaid; the gap over the conditions).

use super::diagnose::{CONDITIONS, Diagnosis, Ranked};
use super::features::FEATURES;
use super::fit::{Estimate, FitResult, Model};
use crate::campaign::{Campaign, Recording, Solvers, simulate_grid};
use crate::output::{self, OutputError, ds_attr_str, h5err, write_vec};
use crate::plot::{Figure, PlotError, render};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde_json::json;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Words for an evidence: "10^x times as likely (ln odds a ± s over n recordings)".
fn evidence_words(e: &super::diagnose::Evidence) -> String {
    format!(
        "10^{:.1} times as likely (ln odds {:.1} ± {:.1} over {} held-out recordings)",
        e.log10_odds(),
        e.ln_odds,
        e.stderr,
        e.recordings
    )
}

fn est_line(e: &Estimate) -> String {
    if e.stderr.is_finite() {
        format!("{} = {:.4e} ± {:.1e} {}", e.name, e.value, e.stderr, e.unit)
    } else {
        format!("{} = {:.4e} {}", e.name, e.value, e.unit)
    }
}

/// The readable summary.
pub fn summary(c: &Campaign, d: &Diagnosis) -> String {
    let mut s = String::new();
    summary_head(c, d, &mut s);
    summary_candidates(d, &mut s);
    summary_verdict(d, &mut s);
    for w in &d.warnings {
        let _ = writeln!(s, "WARNING: {w}");
    }
    s += &limits_table(&d.limits);
    let _ = writeln!(s, "{}", steps_line(d));
    let _ = writeln!(s, "{}", work_line(d));
    s
}

/// The summary's head: the campaign, its folds and the base calibration.
fn summary_head(c: &Campaign, d: &Diagnosis, s: &mut String) {
    let _ = writeln!(
        s,
        "campaign {}: {} recordings, cross-validated over {} folds of condition groups ({} recordings checked on held-out data)",
        c.dir.display(),
        c.recordings.len(),
        d.folds,
        d.held_out.len(),
    );
    if !c.planned.is_empty() {
        let _ = writeln!(
            s,
            "  {} of the {} recordings were added by a plan (stickslip plan): {}",
            c.planned.len(),
            c.recordings.len(),
            c.planned.join(", ")
        );
    }
    for n in &d.not_checked {
        let _ = writeln!(s, "  not checked: {n}");
    }
    for m in super::record::missing_channels(c) {
        let _ = writeln!(s, "  {m}");
    }
    let _ = writeln!(
        s,
        "base model calibrated on all recordings (gap {:.2}; {} after {} iterations):",
        d.base.gap,
        if d.base.converged {
            "converged"
        } else {
            "NOT converged"
        },
        d.base.iterations
    );
    for e in &d.base.estimates {
        let _ = writeln!(s, "  {}", est_line(e));
    }
}

/// The summary's candidates: where the gap lies, every candidate and second effect tried, the
/// plausible ranges.
fn summary_candidates(d: &Diagnosis, s: &mut String) {
    let _ = writeln!(s, "where: {}", d.location.summary);
    let _ = writeln!(
        s,
        "candidates (held-out gap, base {:.2} ± {:.2} over folds; 1 = within noise):",
        d.gap_before, d.gap_before_spread
    );
    if let Some((f, g, n)) = d.concentrated {
        let _ = writeln!(
            s,
            "  concentrated in {}: held-out gap {:.2} in that feature, |z| >= {} on {} recordings",
            f.name(),
            g,
            super::diagnose::FEATURE_GAP,
            n
        );
    }
    if let Some((f, m, t, n)) = d.systematic {
        let _ = writeln!(
            s,
            "  systematic in {}: held-out mean z {:+.2} ({:.1} standard errors from 0) over {} units",
            f.name(),
            m,
            t.abs(),
            n
        );
    }
    if d.ranking.is_empty() && d.verdict == super::diagnose::Verdict::NoSignificantGap {
        let _ = writeln!(
            s,
            "  none fitted: the gap is within noise, nothing to explain (--rank-always fits them)"
        );
    }
    for r in &d.ranking {
        let ps: Vec<String> = r
            .fit
            .estimates
            .iter()
            .filter(|e| e.name.contains('.'))
            .map(est_line)
            .collect();
        let _ = writeln!(
            s,
            "  {:<18} gap {:>7.2}  reduction {:>6.1} %  ln odds {:>7.1} ± {:<5.1} {}{}",
            r.name,
            r.gap_after,
            100.0 * r.reduction,
            r.evidence.ln_odds,
            r.evidence.stderr,
            ps.join(", "),
            if r.at_bound.is_empty() {
                String::new()
            } else {
                format!("  [on a bound: {}]", r.at_bound.join("; "))
            }
        );
        if let Some(line) = short_line(r) {
            let _ = writeln!(s, "{line}");
        }
    }
    for r in &d.second {
        let _ = writeln!(
            s,
            "  with {:<13} + {:<18} gap {:>7.2}  further reduction {:>6.1} %",
            d.best_effect.map_or("-", |k| k.name()),
            r.name,
            r.gap_after,
            100.0 * r.reduction
        );
        if let Some(line) = short_line(r) {
            let _ = writeln!(s, "{line}");
        }
    }
    for b in &d.bounds.bounds {
        let _ = writeln!(
            s,
            "  plausible: {}.{} in [{:.4e}, {:.4e}]: {}",
            b.effect.name(),
            b.param,
            b.lo,
            b.hi,
            b.reason
        );
    }
}

/// The summary's verdict: the named effects with their forms and parameters, and each
/// candidate's fingerprints.
fn summary_verdict(d: &Diagnosis, s: &mut String) {
    // The named effects, each with its form where it has forms.
    let names: Vec<String> = d
        .effects
        .iter()
        .map(|k| match d.forms.iter().find(|f| f.effect == *k) {
            Some(f) => format!("{k} (form {})", f.form),
            None => k.name().to_string(),
        })
        .collect();
    let strength = match (d.evidence, d.evidence_runner_up) {
        (Some(e), Some((k, r))) => format!(
            "\nevidence: against the base model {}; against the runner-up {} {}",
            evidence_words(&e),
            k.name(),
            evidence_words(&r)
        ),
        (Some(e), None) => format!("\nevidence: against the base model {}", evidence_words(&e)),
        _ => String::new(),
    };
    let verdict = match d.best_effect {
        Some(_) => {
            format!(
                "verdict: {} {} the gap: held-out gap {:.2} -> {:.2} ({:.0} % smaller{}){}",
                names.join(" + "),
                if d.partial {
                    "explains part of"
                } else if names.len() > 1 {
                    "explain"
                } else {
                    "explains"
                },
                d.gap_before,
                d.gap_after,
                100.0 * d.reduction,
                d.reduction_beyond_noise.map_or(String::new(), |x| format!(
                    "; {:.0} % of the gap beyond noise (1)",
                    100.0 * x
                )),
                if d.remaining.is_empty() {
                    String::new()
                } else {
                    format!("\nwhat remains: {}", d.remaining)
                }
            ) + &strength
        }
        None if d.verdict == super::diagnose::Verdict::Tie => {
            format!(
                "verdict: tie: {} explain the gap alike, and the held-out data cannot tell them apart (none is named)",
                d.tie
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ) + &strength
        }
        None if d.verdict == super::diagnose::Verdict::NoSignificantGap => format!(
            "verdict: no significant gap (held-out gap {:.2} < {}, no feature's >= {})",
            d.gap_before,
            super::diagnose::SIGNIFICANT_GAP,
            super::diagnose::FEATURE_GAP
        ),
        None => {
            let rejected: Vec<String> = d
                .ranking
                .iter()
                .filter(|r| r.rejected.is_some())
                .map(|r| format!("{} (cuts it by {:.0} %)", r.name, 100.0 * r.reduction))
                .collect();
            let live = d.ranking.iter().find(|r| r.rejected.is_none());
            format!(
                "verdict: unexplained: no candidate explains the gap (best {} cuts it by {:.0} %){}",
                live.map_or("-", |r| r.name.as_str()),
                100.0 * live.map_or(0.0, |r| r.reduction),
                if rejected.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; rejected, as fingerprints they predict are absent: {}",
                        rejected.join(", ")
                    )
                }
            ) + &strength
        }
    };
    let _ = writeln!(s, "{verdict}");
    for f in &d.forms {
        let _ = writeln!(s, "form: {}", f.line());
    }
    // The named model: the first effect's fit, or the fit of both where two are named.
    let named = if d.effects.len() > 1 {
        d.second.first()
    } else {
        d.ranking.first()
    };
    if let Some(top) = named.filter(|_| d.best_effect.is_some()) {
        // Where the named effect acts: the features whose held-out gap it lowers most.
        let mut moved: Vec<(&str, f64, f64)> = super::features::FEATURES
            .iter()
            .filter_map(|&f| {
                let (b, a) = (
                    *d.base_per_feature.get(f as usize)?,
                    *top.per_feature.get(f as usize)?,
                );
                (b.is_finite() && a.is_finite()).then_some((f.name(), b, a))
            })
            .collect();
        moved.sort_by(|x, y| (y.1 - y.2).total_cmp(&(x.1 - x.2)));
        let words: Vec<String> = moved
            .iter()
            .take(3)
            .map(|(n, b, a)| format!("{n} {b:.2} -> {a:.2}"))
            .collect();
        let _ = writeln!(
            s,
            "where {} acts (held-out gap per feature): {}",
            match (d.effects.len() > 1, d.ranking.first()) {
                (true, Some(first)) => format!("{} + {}", first.name, top.name),
                _ => top.name.clone(),
            },
            words.join(", ")
        );
    }
    for r in d.ranking.iter().chain(&d.second) {
        if r.fingerprints.is_empty() {
            continue;
        }
        let _ = writeln!(
            s,
            "fingerprints of {} (beyond the fitted features):",
            r.name
        );
        for c in &r.fingerprints {
            let _ = writeln!(s, "  {}", c.line());
        }
        if r.rejected.is_some() {
            let _ = writeln!(
                s,
                "  rejected: not named, as a fingerprint it predicts is absent"
            );
        }
    }
}

/// The summary's last line: the wall time, the simulations by fidelity with their CPU time,
/// and the cache's hits.
fn work_line(d: &Diagnosis) -> String {
    let by: Vec<String> = super::target::Fidelity::ALL
        .iter()
        .zip(d.work.by_fidelity)
        .map(|(f, r)| format!("{} {} ({:.0} s)", r.simulations, f.name(), r.simulation_cpu))
        .collect();
    format!(
        "wall time {:.1} s ({} simulations, {:.0} s of CPU in them: {}; {} predictions from the cache)",
        d.wall_time,
        d.work.simulations,
        d.work.simulation_cpu,
        by.join(", "),
        d.work.cache_hits
    )
}

/// For a form not fitted further as it could not come near the leader: what its screen
/// reached, against what it had to.
fn short_line(r: &Ranked) -> Option<String> {
    let (got, needed) = r.short_of_leader?;
    Some(format!(
        "    {}: screened to gap {got:.2} on the screen's recordings, short of the {needed:.2} it needed to come near the leading candidate; not fitted further (its numbers are the model it extends's)",
        r.name
    ))
}

/// Where the time went: each step's wall time and simulations, the largest first.
fn steps_line(d: &Diagnosis) -> String {
    let mut st: Vec<_> = d.steps.iter().filter(|s| s.wall >= 0.05).collect();
    st.sort_by(|a, b| b.wall.total_cmp(&a.wall));
    let parts: Vec<String> = st
        .iter()
        .map(|s| format!("{} {:.0} s ({})", s.step, s.wall, s.work.simulations))
        .collect();
    format!("time by step (wall, simulations): {}", parts.join(", "))
}

/// The detection limits as a table for the summary (a sentence where none were computed).
fn limits_table(l: &super::limits::Limits) -> String {
    let mut s = String::new();
    if let Some(why) = &l.not_computed {
        let _ = writeln!(s, "detection limits: not computed ({why})");
        return s;
    }
    let _ = writeln!(
        s,
        "what this campaign could not have seen (each effect added to {}; the weakest strength at which the test `{}` fires on {:.0} % of {} draws of the campaign's own held-out noise):",
        l.against,
        l.test,
        100.0 * l.power,
        l.draws
    );
    let _ = writeln!(
        s,
        "  {:<34} {:<8} {:>12} {:<6}  reading",
        "effect [form]", "param", "limit", "unit"
    );
    for e in &l.effects {
        let name = if e.form_name.is_empty() {
            e.effect.to_string()
        } else {
            format!("{} [{}]", e.effect, e.form_name)
        };
        let limit = match e.limit {
            Some(v) => format!("{} {v:.3e}", if e.stronger == "below" { "<" } else { ">" }),
            None => "none".to_string(),
        };
        let _ = writeln!(
            s,
            "  {:<34} {:<8} {:>12} {:<6}  {}",
            name, e.param, limit, e.unit, e.statement
        );
    }
    s
}

/// The JSON of a calibration.
pub fn calibration_json(c: &Campaign, f: &FitResult) -> serde_json::Value {
    json!({
        "campaign": c.dir.display().to_string(),
        "recordings": c.recordings.len(),
        "params": super::record::estimates(&f.estimates),
        "gap": f.gap,
        "residuals": f.residuals,
        "evaluations": f.evaluations,
    })
}

/// A readable calibration report.
pub fn calibration_summary(c: &Campaign, f: &FitResult) -> String {
    let mut s = format!(
        "campaign {}: {} recordings, {} feature residuals, {} model evaluations\n",
        c.dir.display(),
        c.recordings.len(),
        f.residuals,
        f.evaluations
    );
    for e in &f.estimates {
        let _ = writeln!(s, "  {}", est_line(e));
    }
    let _ = writeln!(s, "gap after the fit: {:.2} (1 = within noise)", f.gap);
    s
}

/// Writes the details to HDF5: per-recording conditions, gaps and z per feature; the ranking
/// with fitted parameters; the calibration; the verdict as attributes.
pub fn write_h5(
    path: &Path,
    c: &Campaign,
    d: &Diagnosis,
    record: &super::record::DiagnosisRecord,
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
    checks: &[super::fingerprint::Check],
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
/// simulations are made once, for both [`plots`] and [`write_h5`].
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
    title: String,
    t: &'a [f64],
    series: Vec<(String, Vec<f64>, RGBColor)>,
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
            let x = |r: &super::diagnose::RecordingGap| r.conditions[k] * unit[k];
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
