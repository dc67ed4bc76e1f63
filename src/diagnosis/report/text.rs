//! A diagnosis's terminal summary and a calibration's.

use crate::campaign::Campaign;
use crate::diagnosis::diagnose::{Diagnosis, Ranked};
use crate::diagnosis::fit::{Estimate, FitResult};
use std::fmt::Write;

/// Words for an evidence: "10^x times as likely (ln odds a ± s over n recordings)".
fn evidence_words(e: &crate::diagnosis::diagnose::Evidence) -> String {
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
    let pre = c.acquisition.report();
    if !pre.is_empty() {
        let _ = writeln!(s, "preflight (what the acquisition did):");
        for l in pre {
            let _ = writeln!(s, "  {l}");
        }
    }
    for n in &d.not_checked {
        let _ = writeln!(s, "  not checked: {n}");
    }
    for m in crate::diagnosis::record::missing_channels(c) {
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
            crate::diagnosis::diagnose::FEATURE_GAP,
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
    if d.ranking.is_empty() && d.verdict == crate::diagnosis::diagnose::Verdict::NoSignificantGap {
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
            b.param.name(b.effect),
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
        None if d.verdict == crate::diagnosis::diagnose::Verdict::Tie => {
            format!(
                "verdict: tie: {} explain the gap alike, and the held-out data cannot tell them apart (none is named)",
                d.tie
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ) + &strength
        }
        None if d.verdict == crate::diagnosis::diagnose::Verdict::NoSignificantGap => format!(
            "verdict: no significant gap (held-out gap {:.2} < {}, no feature's >= {})",
            d.gap_before,
            crate::diagnosis::diagnose::SIGNIFICANT_GAP,
            crate::diagnosis::diagnose::FEATURE_GAP
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
        let mut moved: Vec<(&str, f64, f64)> = crate::diagnosis::features::FEATURES
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
    let by: Vec<String> = crate::diagnosis::target::Fidelity::ALL
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
fn limits_table(l: &crate::diagnosis::limits::Limits) -> String {
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
