//! What a plan writes: one conditions file per planned recording (in the campaign's own
//! vocabulary, with a `plan` table the loader ignores), `plan.json`, `plan.png` (and `.svg`):
//! the design space with the existing and the planned recordings), and the terminal summary.

use super::types::{Plan, Planned};
use crate::campaign::Campaign;
use crate::model::Params;
use crate::plot::{Figure, PlotError, render};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};

fn num(x: f64) -> serde_json::Value {
    if x.is_finite() {
        json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// The base parameters a diagnosis fits: not conditions, so not written into a plan's
/// conditions files.
const FITTED: [&str; 4] = ["F_s", "F_c", "v_s", "h_d"];

/// The conditions file of a planned recording: `v_d`, `k_d`, `f`, `u0`, `F_N` (and `t_on` for a
/// two-stage recording), every other condition the campaign sets away from the defaults, and
/// the `plan` table (the plan, the order, the duration and rate to record, and why).
pub fn conditions_toml(p: &Planned, order: usize, plan_name: &str, rate: f64) -> String {
    let q = &p.candidate.params;
    let mut text = format!(
        "# Planned recording {name}: record {dur:.3} s at {rate:.0} Hz, save it as {name}.csv\n\
         # (columns t, F_d and, where the campaign records them, x_s, x_d) beside this file,\n\
         # then copy both into the campaign.\n\
         v_d = {:e}\nk_d = {:e}\nf = {:e}\nu0 = {:e}\nF_N = {:e}\n",
        q.v_d,
        q.k_d,
        if q.vibrates() { q.f } else { 0.0 },
        q.u0,
        q.f_n,
        name = p.name,
        dur = p.candidate.duration,
    );
    if q.two_stage() {
        text += &format!("t_on = {:e}\n", q.t_on);
    }
    let d = Params::default();
    for name in crate::model::params::names() {
        if ["v_d", "k_d", "f", "u0", "F_N", "t_on"].contains(&name) || FITTED.contains(&name) {
            continue;
        }
        let (a, b) = (
            q.get(name).unwrap_or(f64::NAN),
            d.get(name).unwrap_or(f64::NAN),
        );
        if a.is_finite() && a != b {
            text += &format!("{name} = {a:e}\n");
        }
    }
    let why = p.why.replace('\\', "\\\\").replace('"', "\\\"");
    text += &format!(
        "\n[plan]\nname = \"{plan_name}\"\norder = {order}\nduration = {:e}\nrate = {:e}\nwhy = \"{why}\"\n",
        p.candidate.duration, rate
    );
    text
}

/// `plan.json`.
pub fn json(c: &Campaign, plan: &Plan, plan_name: &str) -> serde_json::Value {
    let name = |i: usize| plan.rivals[i].name.clone();
    json!({
        "campaign": c.dir.display().to_string(),
        "plan": plan_name,
        "random": plan.random,
        "criterion": "greedy maximin of the smallest pairwise discrimination min(D_ij, D_ji) over the open pairs; D_ij: expected log-likelihood ratio for rival i against rival j refitted (linearised) to the existing and planned recordings, as the diagnosis's evidence counts it",
        "rivals": plan.rivals.iter().map(|r| json!({
            "name": r.name, "role": r.role.describe(), "ln_odds_vs_base": num(r.ln_odds),
            "clear_vs_base": r.clear, "model": r.model.to_json(),
            "fitted_effects": r.effects.iter().map(|k| k.name()).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "open_pairs": plan.open.iter().map(|&(a, b)| [name(a), name(b)]).collect::<Vec<_>>(),
        "recordings": plan.recordings.iter().enumerate().map(|(k, p)| {
            let q = &p.candidate.params;
            json!({
                "name": p.name,
                "order": k + 1,
                "conditions": {
                    "v_d": q.v_d, "k_d": q.k_d,
                    "f": if q.vibrates() { q.f } else { 0.0 },
                    "u0": q.u0, "va_ratio": p.candidate.va_ratio(),
                    "t_on": q.t_on, "F_N": q.f_n,
                },
                "duration": p.candidate.duration,
                "rate": plan.space.rate,
                // Drawn at random: chosen for no pair.
                "chosen_for": if plan.random {
                    serde_json::Value::Null
                } else {
                    json!([name(p.chosen_for.0), name(p.chosen_for.1)])
                },
                "discrimination": p.gains.iter().map(|g| json!({
                    "pair": [name(g.pair.0), name(g.pair.1)], "nats": num(g.nats),
                })).collect::<Vec<_>>(),
                "features": p.carriers.iter().map(|(f, z)| json!({"feature": f, "z": num(*z)})).collect::<Vec<_>>(),
                "why": p.why,
            })
        }).collect::<Vec<_>>(),
        "outcomes": plan.outcomes.iter().map(|o| json!({
            "truth": name(o.truth), "other": name(o.other),
            "ln_odds_now": num(o.now), "ln_odds_expected": num(o.expected),
            "ln_odds_simulated": o.simulated.map(num),
            "simulated_stderr": o.simulated_stderr.map(num),
            "clear_after": o.clear,
        })).collect::<Vec<_>>(),
        "space": {
            "springs": plan.space.springs,
            "v_d": [plan.space.v_d.0, plan.space.v_d.1],
            "f": plan.space.f.map(|(a, b)| [a, b]),
            "va_ratio": [plan.space.va_ratio.0, plan.space.va_ratio.1],
            "max_u0": plan.space.max_u0.iter().map(|&(f, u)| [f, u]).collect::<Vec<_>>(),
            "max_duration": plan.space.max_duration,
            "rate": plan.space.rate,
            "t_on": plan.space.t_on,
        },
        "candidates": plan.candidates,
        "finalists": plan.finalists,
        "noise": {"force": num(plan.noise.0), "displacement": plan.noise.1.map(num)},
        "simulations": plan.simulations,
        "wall_time": plan.wall_time,
        "steps": plan.steps,
        "warnings": plan.warnings,
    })
}

/// The terminal summary.
pub fn summary(plan: &Plan) -> String {
    let name = |i: usize| plan.rivals[i].name.as_str();
    let mut s = String::new();
    s += &format!(
        "Plan of {} recordings among {} rivals ({} candidate recordings, {} finalists):\n",
        plan.recordings.len(),
        plan.rivals.len(),
        plan.candidates,
        plan.finalists
    );
    for r in &plan.rivals {
        s += &format!(
            "  rival {:<32} {:<40} ln odds vs base {:>8.1}\n",
            r.name,
            r.role.describe(),
            r.ln_odds
        );
    }
    s += "Recordings, in the order chosen:\n";
    for p in &plan.recordings {
        s += &format!(
            "  {} ({:.2} s at {:.0} Hz)\n    {}\n",
            p.name, p.candidate.duration, plan.space.rate, p.why
        );
    }
    s += "Each rival as the truth, ln odds against each other rival (now -> expected -> simulated; \
          the evidence between the rivals as fitted: the diagnosis's screens, which decide what is \
          fitted, are not run):\n";
    for o in &plan.outcomes {
        let sim = match (o.simulated, o.simulated_stderr) {
            (Some(v), Some(e)) => format!("{v:>8.1} ± {e:.1}"),
            _ => "not checked".into(),
        };
        let clear = match o.clear {
            Some(true) => "clear",
            Some(false) => "not clear",
            None => "",
        };
        s += &format!(
            "  {:>24} vs {:<24} {:>8.1} -> {:>8.1} -> {sim} {clear}\n",
            name(o.truth),
            name(o.other),
            o.now,
            o.expected
        );
    }
    for w in &plan.warnings {
        s += &format!("warning: {w}\n");
    }
    if !plan.steps.is_empty() {
        let parts: Vec<String> = plan
            .steps
            .iter()
            .map(|st| format!("{} {:.0} s ({})", st.step, st.wall, st.simulations))
            .collect();
        s += &format!("time by step (wall, simulations): {}\n", parts.join(", "));
    }
    s += &format!(
        "{} simulations, {:.1} s\n",
        plan.simulations, plan.wall_time
    );
    s
}

struct SpaceFigure<'a> {
    c: &'a Campaign,
    plan: &'a Plan,
}

impl Figure for SpaceFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        let root = root
            .titled(
                "Existing recordings (grey crosses), candidates (dots: blue to red, discrimination before refit), planned (numbered)",
                ("sans-serif", 18),
            )
            .map_err(e)?;
        // x: frequency (0 for rest, drawn at the left edge), y: v_a/v_d; one panel per spring.
        let springs = &self.plan.space.springs;
        let areas = root.split_evenly((1, springs.len().max(1)));
        let fmax = self
            .plan
            .screened
            .iter()
            .map(|(c, _)| c.params.f)
            .chain(self.c.recordings.iter().map(|r| r.params.f))
            .fold(1.0f64, f64::max)
            * 1.1e-3;
        let rmax = self
            .plan
            .screened
            .iter()
            .map(|(c, _)| c.va_ratio())
            .chain(
                self.c
                    .recordings
                    .iter()
                    .filter(|r| r.vibrates())
                    .map(|r| r.params.v_a() / r.params.v_d),
            )
            .fold(0.1f64, f64::max)
            * 1.15;
        // Colours spread over the screen's range (log scale: its values span decades).
        let (lo, hi) = self
            .plan
            .screened
            .iter()
            .map(|x| x.1.max(1e-9).ln())
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
        let shade = |s: f64| {
            if s.is_finite() && hi > lo {
                ((s.max(1e-9).ln() - lo) / (hi - lo)).clamp(0.0, 1.0)
            } else {
                0.0
            }
        };
        for (a, &k_d) in areas.iter().zip(springs) {
            let same = |k: f64| (k - k_d).abs() <= 1e-9 * k_d;
            let mut ch = ChartBuilder::on(a)
                .margin(12)
                .caption(format!("k_d = {k_d:.0} N/m"), ("sans-serif", 16))
                .x_label_area_size(36)
                .y_label_area_size(50)
                .build_cartesian_2d(-0.05 * fmax..fmax, 0.0..rmax)
                .map_err(e)?;
            ch.configure_mesh()
                .x_desc("f [kHz] (0: no vibration); several v_d share a point")
                .y_desc("v_a / v_d")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(e)?;
            // Several drive velocities share a point: the most discriminating on top.
            let mut dots: Vec<&(super::space::Candidate, f64)> = self
                .plan
                .screened
                .iter()
                .filter(|(c, _)| same(c.params.k_d))
                .collect();
            dots.sort_by(|a, b| a.1.total_cmp(&b.1));
            ch.draw_series(dots.into_iter().map(|(c, s)| {
                let w = shade(*s);
                let col = RGBColor((40.0 + 215.0 * w) as u8, 60, (255.0 - 215.0 * w) as u8);
                let f = if c.params.vibrates() {
                    c.params.f * 1e-3
                } else {
                    0.0
                };
                Circle::new((f, c.va_ratio()), 4, col.filled())
            }))
            .map_err(e)?;
            ch.draw_series(
                self.c
                    .recordings
                    .iter()
                    .filter(|r| same(r.params.k_d))
                    .map(|r| {
                        let x = if r.vibrates() { r.params.f * 1e-3 } else { 0.0 };
                        let y = if r.vibrates() {
                            r.params.v_a() / r.params.v_d
                        } else {
                            0.0
                        };
                        Cross::new((x, y), 7, RGBColor(120, 120, 120).stroke_width(2))
                    }),
            )
            .map_err(e)?;
            for (k, p) in self.plan.recordings.iter().enumerate() {
                let c = &p.candidate;
                if !same(c.params.k_d) {
                    continue;
                }
                let x = if c.params.vibrates() {
                    c.params.f * 1e-3
                } else {
                    0.0
                };
                let pt = (x, c.va_ratio());
                ch.draw_series([Circle::new(pt, 10, BLACK.stroke_width(2))])
                    .map_err(e)?;
                let label = (pt.0 + 0.02 * fmax, pt.1 + 0.02 * rmax);
                ch.draw_series([Text::new(format!("{}", k + 1), label, ("sans-serif", 18))])
                    .map_err(e)?;
            }
        }
        Ok(())
    }
}

/// Whether the text of a TOML file is a conditions file a plan wrote (it holds a `[plan]`
/// table): `stickslip plan` replaces only such files in its folder.
pub fn written_by_a_plan(text: &str) -> bool {
    text.contains("\n[plan]\n")
}

/// Writes the plan into `out`: one `NAME.toml` per planned recording, `plan.json`,
/// `plan.png` and `plan.svg` (unless `no_plots`). Returns the files written.
///
/// An earlier plan's conditions files in `out` (a TOML with a `[plan]` table) that this plan
/// does not write again are removed first: left there, they would be recorded as if planned
/// now, against a `plan.json` that no longer lists them. Each file is written whole beside
/// its name and then renamed onto it, so an interrupted plan leaves every file either as it
/// was or as this plan wrote it. The caller has checked that `out` holds nothing a plan did
/// not write (`stickslip plan` refuses a folder with recordings or a foreign TOML).
pub fn write(
    out: &Path,
    c: &Campaign,
    plan: &Plan,
    plan_name: &str,
    json_path: &Path,
    no_plots: bool,
) -> Result<Vec<PathBuf>, crate::campaign::CampaignError> {
    let io = |p: &Path, e: &dyn std::fmt::Display| crate::campaign::CampaignError::Io {
        path: p.display().to_string(),
        msg: e.to_string(),
    };
    std::fs::create_dir_all(out).map_err(|e| io(out, &e))?;
    // Whole, then renamed onto its name (a rename within a folder replaces at once).
    let put = |path: &Path, text: &str| {
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".part");
        let tmp = PathBuf::from(tmp);
        std::fs::write(&tmp, text).map_err(|e| io(&tmp, &e))?;
        std::fs::rename(&tmp, path).map_err(|e| io(path, &e))
    };
    let mine: Vec<PathBuf> = plan
        .recordings
        .iter()
        .map(|p| out.join(format!("{}.toml", p.name)))
        .collect();
    for e in std::fs::read_dir(out).map_err(|e| io(out, &e))? {
        let path = e.map_err(|e| io(out, &e))?.path();
        let stale = path.extension().is_some_and(|x| x == "toml")
            && !mine.contains(&path)
            && std::fs::read_to_string(&path).is_ok_and(|t| written_by_a_plan(&t));
        if stale {
            std::fs::remove_file(&path).map_err(|e| io(&path, &e))?;
        }
    }
    let mut written = vec![];
    for (k, (p, path)) in plan.recordings.iter().zip(mine).enumerate() {
        put(
            &path,
            &conditions_toml(p, k + 1, plan_name, plan.space.rate),
        )?;
        written.push(path);
    }
    let text = serde_json::to_string_pretty(&json(c, plan, plan_name)).unwrap_or_default();
    if let Some(d) = json_path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(|e| io(d, &e))?;
    }
    put(json_path, &text)?;
    written.push(json_path.to_path_buf());
    if !no_plots {
        let figs = render(&out.join("plan"), &SpaceFigure { c, plan })
            .map_err(|e: PlotError| io(Path::new(&e.path), &e.msg))?;
        written.extend(figs);
    }
    Ok(written)
}
