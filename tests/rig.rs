//! The diagnosis checked on campaigns this crate did not make: `tests/rig/rig.py` simulates the
//! stand apart (Python and numba, a fixed-step Runge–Kutta method, effects in forms of its own:
//! a fourth-order sensor, a two-mass actuator, load modulation of fixed depth, ageing by the slip
//! law, screw error with its harmonic, friction along the track), with designs like the paper's,
//! two-stage recordings, sampling from 4 to 50 kHz and noise. `diagnose` is not told what was
//! injected.
//!
//! A second rig, `tests/rig2/stand.py`, is written apart from both (an SSP-RK3 method, effects
//! in yet other forms, random and unbalanced designs, force-only campaigns, sampling below twice
//! the forcing frequency, encoder-quantized displacements) and adds *mimics*: effects outside
//! the library that resemble one inside it.
//!
//! A verdict is right when it is `no_significant_gap` for effect-free data, `unexplained` for an
//! effect no library candidate stands for (the track), `effect` naming the library effect that
//! stands for the injected one first, for a single effect, or either of the two, for two (partial
//! explanations count: the forms differ from the library's by design), and for a mimic
//! `unexplained`, a `tie`, or its analogue named as partial. A **confident wrong cause** is an
//! effect named without `partial` where the truth asks for another, for none, or for a mimic's
//! analogue only as partial: no panel may give one.
//!
//! `.ci/run` runs, for its time budget, the cheap ones: the effect-free small unbalanced
//! campaign of the first rig, the actuator scan on its in-band two-mass actuator, and the
//! second rig's effect-free force-only campaign below twice the forcing frequency, and the
//! first rig's two-mass actuator with screw error extended by its plan's six recordings, where
//! the two effects are named together (about 6 min in all). Every other campaign (friction along the track, load modulation, screw error, two
//! effects at once, the mimics, ...) is `--ignored` and runs in the whole panels:
//! `cargo test --release --test rig -- --ignored --nocapture` (docs/campaigns.md).
//!
//! `plan_loop_on_panel_campaigns` closes the plan's loop on panel campaigns (`PLAN_CAMPAIGNS`):
//! a plan of 6 and 6 recordings at random, each made on the stand, the campaign diagnosed again
//! (docs/planning.md).

use stickslip::campaign::Campaign;
use stickslip::diagnosis::diagnose::{DiagnoseOptions, Diagnosis, Verdict, diagnose};

/// The panel's campaigns, in the order of `PANEL` in `rig.py`.
const PANEL: [&str; 13] = [
    "free-paper",
    "free-factorial",
    "free-small",
    "sensor-paper",
    "sensor-factorial",
    "actuator-inband",
    "normal-fixed-depth",
    "aging-slip-law",
    "screw-harmonics",
    "track",
    "sensor+aging",
    "frame-acceleration",
    "actuator+screw",
];

/// The second rig's panel, in the order of `PANEL` in `stand.py`.
const PANEL2: [&str; 13] = [
    "free-random",
    "free-forceonly-lowrate",
    "sensor-lowpass",
    "actuator-lag",
    "normal-delay",
    "viscous-quadratic",
    "stribeck-lorentz",
    "memory-distance",
    "mimic-runin",
    "mimic-drive-noise",
    "mimic-gain",
    "daq-bessel-delay",
    "sensor+viscous",
];

/// An independent rig: its script and the seed its panel is drawn with.
#[derive(Clone, Copy)]
struct Rig {
    script: &'static str,
    seed: &'static str,
    /// The script's option that draws the noise alone, the design kept (`None`: its designs
    /// are fixed, and `--seed` draws the noise alone).
    noise_seed: Option<&'static str>,
}

const RIG: Rig = Rig {
    script: "tests/rig/rig.py",
    seed: "7",
    noise_seed: None,
};
const RIG2: Rig = Rig {
    script: "tests/rig2/stand.py",
    seed: "3",
    noise_seed: Some("--noise-seed"),
};

/// Writes campaign `name` with the first independent rig and reads its expected verdict.
fn make(name: &str, dir: &std::path::Path) -> (Campaign, serde_json::Value) {
    make_with(RIG, name, dir)
}

/// Writes campaign `name` with `rig` and reads its expected verdict.
fn make_with(rig: Rig, name: &str, dir: &std::path::Path) -> (Campaign, serde_json::Value) {
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(rig.script);
    let out = dir.join(name);
    let st = std::process::Command::new("python3")
        .arg(&script)
        .arg(&out)
        .args(["--campaign", name, "--seed", rig.seed])
        .status()
        .expect("python3 runs (install tests/python/requirements.txt: numpy, numba)");
    assert!(st.success(), "{} failed for {name}", rig.script);
    let truth: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join(format!("{name}.truth.json"))).unwrap(),
    )
    .unwrap();
    let c = Campaign::load(&out).unwrap();
    // Every recording of the independent rig passes the plausibility checks.
    let bad = stickslip::campaign::check::check_campaign(&c);
    assert!(bad.is_empty(), "{name}: {bad:?}");
    (c, truth)
}

/// Whether the diagnosis gives the verdict the truth asks for.
fn right(d: &Diagnosis, expect: &serde_json::Value) -> bool {
    match expect {
        serde_json::Value::Null => d.verdict == Verdict::NoSignificantGap,
        serde_json::Value::String(s) if s == "unexplained" => d.verdict == Verdict::Unexplained,
        serde_json::Value::Array(names) => {
            let names: Vec<&str> = names.iter().filter_map(|v| v.as_str()).collect();
            d.verdict == Verdict::Effect
                && d.best_effect.is_some_and(|k| {
                    if names.len() == 1 {
                        k.name() == names[0]
                    } else {
                        names.contains(&k.name())
                    }
                })
        }
        serde_json::Value::Object(m) if m.contains_key("mimic") => {
            let analogues = analogues(expect);
            match d.verdict {
                Verdict::Unexplained | Verdict::Tie => true,
                Verdict::Effect => {
                    d.partial && d.best_effect.is_some_and(|k| analogues.contains(&k.name()))
                }
                Verdict::NoSignificantGap => false,
            }
        }
        _ => false,
    }
}

/// A mimic's analogues (empty for other truths).
fn analogues(expect: &serde_json::Value) -> Vec<&str> {
    expect
        .get("mimic")
        .and_then(|v| v.as_array())
        .map_or(vec![], |a| a.iter().filter_map(|v| v.as_str()).collect())
}

/// Whether the diagnosis names a wrong cause with confidence: an effect named without `partial`
/// (nor a tie) that the truth does not ask for, or a mimic's analogue named without `partial`.
fn confident_wrong(d: &Diagnosis, expect: &serde_json::Value) -> bool {
    if d.verdict != Verdict::Effect || d.partial {
        return false;
    }
    match expect {
        serde_json::Value::Array(names) => {
            let names: Vec<&str> = names.iter().filter_map(|v| v.as_str()).collect();
            d.effects.iter().any(|k| !names.contains(&k.name()))
        }
        _ => true,
    }
}

/// A table row: the campaign, its truth (with the form the rig's effect scales like, where it
/// says), the verdict, the effects named (each with its form, `settled` or not, where it has
/// forms), the held-out gap, right or wrong, and the time.
fn row(name: &str, truth: &serde_json::Value, d: &Diagnosis) -> String {
    let expect = &truth["expect"];
    let effects: Vec<String> = d
        .effects
        .iter()
        .map(|k| match d.forms.iter().find(|f| f.effect == *k) {
            Some(f) => format!(
                "{k}[{}{}]",
                f.form,
                if f.settled() { "" } else { ", unsettled" }
            ),
            None => k.name().to_string(),
        })
        .collect();
    let truth_form = truth["form"]
        .as_str()
        .map_or(String::new(), |f| format!(" ({f})"));
    format!(
        "| {name} | {expect}{truth_form} | {}{} | {} | {:.2} → {:.2} ({:.0} %) | {} | {:.0} s |",
        d.verdict.name(),
        if d.partial { " (partial)" } else { "" },
        if !d.tie.is_empty() {
            d.tie
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(" = ")
        } else if effects.is_empty() {
            "-".to_string()
        } else {
            effects.join(" + ")
        },
        d.gap_before,
        d.gap_after,
        100.0 * d.reduction,
        mark(d, expect),
        d.wall_time
    )
}

/// Diagnoses each campaign of `rig`'s `names`: the number right, the number of confident wrong
/// causes, and a table row each.
fn run_with(rig: Rig, names: &[&str]) -> (usize, usize, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let mut ok = 0;
    let mut wrong = 0;
    let mut rows = vec![];
    for name in names {
        let (c, truth) = make_with(rig, name, dir.path());
        let d = diagnose(&c, &DiagnoseOptions::default()).unwrap();
        let expect = &truth["expect"];
        let r = row(name, &truth, &d);
        eprintln!("{r}");
        for k in d.ranking.iter().take(3) {
            eprintln!(
                "      {} held-out gap {:.2} ({:.0} %), ln odds {:.1} ± {:.1}{}",
                k.name,
                k.gap_after,
                100.0 * k.reduction,
                k.evidence.ln_odds,
                k.evidence.stderr,
                if k.at_bound.is_empty() {
                    String::new()
                } else {
                    format!(" [{}]", k.at_bound.join("; "))
                }
            );
            // The fingerprints checked (of named, tied or rejected candidates), and a rejection.
            for c in &k.fingerprints {
                eprintln!("        {}", c.line());
            }
            if let Some(why) = &k.rejected {
                eprintln!("        rejected: {why}");
            }
        }
        if right(&d, expect) {
            ok += 1;
        }
        if confident_wrong(&d, expect) {
            wrong += 1;
        }
        rows.push(r);
    }
    (ok, wrong, rows)
}

/// One campaign of the first rig's panel, its verdict right.
fn right_on(name: &str) {
    right_with(RIG, name);
}

/// One campaign of `rig`'s panel, its verdict right.
fn right_with(rig: Rig, name: &str) {
    let (ok, wrong, rows) = run_with(rig, &[name]);
    assert_eq!((ok, wrong), (1, 0), "\n{}", rows.join("\n"));
}

// `.ci/run`'s five: effect-free (the small unbalanced design), an effect without a library
// counterpart (friction along the track), two with an effect (load modulation of a form
// outside the library's, screw error with its harmonic) and two effects at once (a two-mass
// actuator with screw error); the other two-effect campaign (a sensor with slip-law ageing) is
// left to the whole panel for `.ci/run`'s time budget.

#[test]
fn rig_effect_free_small_unbalanced_campaign() {
    right_on("free-small");
}

#[test]
#[ignore = "in the rig's whole panel; left out of .ci/run for its time budget"]
fn rig_load_modulation_of_fixed_depth() {
    right_on("normal-fixed-depth");
}

/// A load swing that follows the substrate's acceleration (a frame driven by the shaker's
/// reaction): `normal_coupling`, and the form the data choose is the acceleration's.
#[test]
#[ignore = "in the rig's whole panel; left out of .ci/run for its time budget"]
fn rig_load_swing_with_the_acceleration_names_its_form() {
    right_in_form(RIG, "frame-acceleration");
}

/// An acquisition's fourth-order Bessel anti-alias filter with a delay on the force channel:
/// `sensor_dynamics`, in its fourth-order form with a delay (`order4_delay`). Without the
/// delay the fourth-order sensor cut the held-out gap by a third at most, and the verdict was
/// `unexplained`.
#[test]
#[ignore = "about 4 minutes on 2 cores; in the second rig's whole panel"]
fn rig2_antialias_filter_with_delay_names_a_fourth_order_sensor() {
    right_in_form(RIG2, "daq-bessel-delay");
}

/// The two-mass actuator with screw error, extended by the six recordings its plan proposed
/// (`tests/rig/plans/actuator+screw`, written by `stickslip plan` on the campaign): there the
/// actuator's screen lowers the gap by 9.7 % and the screw error's by 6.5 %, so neither passes
/// its screen alone and forward selection has no first step (the verdict was `unexplained`).
/// Screened together they pass, and both are named, each needed beside the other.
#[test]
fn rig_actuator_and_screw_are_named_together_where_neither_passes_alone() {
    let name = "actuator+screw";
    let dir = tempfile::tempdir().unwrap();
    let (_, truth) = make(name, dir.path());
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let rec = dir.path().join("planned");
    let st = std::process::Command::new("python3")
        .arg(root.join(RIG.script))
        .arg(&rec)
        .args(["--campaign", name, "--seed", RIG.seed, "--conditions"])
        .arg(root.join("tests/rig/plans").join(name))
        .status()
        .expect("python3 runs");
    assert!(st.success(), "{} --conditions failed", RIG.script);
    for e in std::fs::read_dir(&rec).unwrap() {
        let e = e.unwrap().path();
        std::fs::copy(&e, dir.path().join(name).join(e.file_name().unwrap())).unwrap();
    }
    let c = Campaign::load(&dir.path().join(name)).unwrap();
    assert_eq!(
        c.recordings.len(),
        16,
        "the campaign's ten and the plan's six"
    );
    let d = diagnose(&c, &DiagnoseOptions::default()).unwrap();
    let r = row(name, &truth, &d);
    eprintln!("{r}");
    for w in &d.warnings {
        eprintln!("  {w}");
    }
    assert!(
        right(&d, &truth["expect"]) && !confident_wrong(&d, &truth["expect"]),
        "{r}"
    );
    let mut named: Vec<&str> = d.effects.iter().map(|k| k.name()).collect();
    named.sort_unstable();
    assert_eq!(named, ["actuator_response", "drive_ripple"], "{r}");
    assert!(
        d.warnings.iter().any(|w| w.contains("named together")),
        "{r}: {:?}",
        d.warnings
    );
}

/// One campaign of `rig`'s panel: its verdict right and the named effect in the form its truth
/// gives.
fn right_in_form(rig: Rig, name: &str) {
    let dir = tempfile::tempdir().unwrap();
    let (c, truth) = make_with(rig, name, dir.path());
    let d = diagnose(&c, &DiagnoseOptions::default()).unwrap();
    let r = row(name, &truth, &d);
    assert!(right(&d, &truth["expect"]), "{r}");
    let want = truth["form"].as_str().expect("the truth gives a form");
    assert_eq!(d.forms.first().map(|f| f.form), Some(want), "{r}");
}

#[test]
#[ignore = "in the rig's whole panel; left out of .ci/run for its time budget"]
fn rig_screw_error_with_its_harmonic() {
    right_on("screw-harmonics");
}

/// Friction varying along the track has no counterpart among the candidates: `unexplained`.
#[test]
#[ignore = "in the rig's whole panel; left out of .ci/run for its time budget"]
fn rig_friction_along_the_track_is_unexplained() {
    right_on("track");
}

/// Two effects at once, both outside the library's forms: the two-mass piezo-and-saddle
/// actuator and screw error with its second harmonic. The verdict rule asks for either first;
/// forward selection names both, the actuator first.
#[test]
#[ignore = "in the rig's whole panel; left out of .ci/run for its time budget"]
fn rig_actuator_and_screw_error_are_both_named() {
    let name = "actuator+screw";
    let dir = tempfile::tempdir().unwrap();
    let (c, truth) = make(name, dir.path());
    let d = diagnose(&c, &DiagnoseOptions::default()).unwrap();
    let r = row(name, &truth, &d);
    eprintln!("{r}");
    assert!(right(&d, &truth["expect"]), "{r}");
    let named: Vec<&str> = d.effects.iter().map(|k| k.name()).collect();
    assert_eq!(named, ["actuator_response", "drive_ripple"], "{r}");
}

/// A fourth-order sensor with slip-law ageing: either named (the rig's truth has both). It
/// was `unexplained` at earlier code (ageing's held-out evidence uneven over the 16
/// recordings, docs/campaigns.md); in the whole panel at this code, slip-law ageing is named.
#[test]
#[ignore = "about 5 minutes on 2 cores; in the rig's whole panel"]
fn rig_sensor_and_slip_law_ageing() {
    right_on("sensor+aging");
}

/// A whole panel: all right but one at most, and no confident wrong cause.
fn panel(rig: Rig, names: &[&str]) {
    let (ok, wrong, rows) = run_with(rig, names);
    eprintln!(
        "{}: {ok} of {} right, {wrong} confident wrong\n| campaign | truth | verdict | effects | held-out gap | right | time |\n|---|---|---|---|---|---|---|\n{}",
        rig.script,
        names.len(),
        rows.join("\n")
    );
    assert!(
        ok + 1 >= names.len() && wrong == 0,
        "{ok} of {} right, {wrong} confident wrong\n{}",
        names.len(),
        rows.join("\n")
    );
}

/// Some campaigns of either panel, named in `RIG_CAMPAIGNS` (`rig:NAME` or `rig2:NAME`,
/// comma-separated): their table, and the same assertion as a whole panel's on them.
#[test]
#[ignore = "as long as the campaigns named; for checks of part of a panel"]
fn some_panel_campaigns() {
    let names = std::env::var("RIG_CAMPAIGNS").unwrap_or_default();
    for rig in [RIG, RIG2] {
        let tag = if rig.script == RIG.script {
            "rig"
        } else {
            "rig2"
        };
        let picked: Vec<&str> = names
            .split(',')
            .filter_map(|n| n.trim().strip_prefix(tag)?.strip_prefix(':'))
            .collect();
        if !picked.is_empty() {
            panel(rig, &picked);
        }
    }
}

/// The first rig's whole panel.
#[test]
#[ignore = "the whole panel takes about 15 minutes on 2 cores (18 with the build); .ci/run runs two of its campaigns"]
fn independent_rig_panel() {
    panel(RIG, &PANEL);
}

/// The second rig's whole panel.
#[test]
#[ignore = "the whole panel takes about 15 minutes on 2 cores; .ci/run runs one of its campaigns"]
fn second_rig_panel() {
    panel(RIG2, &PANEL2);
}

/// Writes campaign `name` of `rig`, its design the panel's and its noise drawn with `seed`,
/// with the rig's own effects `effects` (`NAME:k=v,...` each) added.
fn make_extra(
    rig: Rig,
    name: &str,
    dir: &std::path::Path,
    seed: u64,
    effects: &[String],
) -> Campaign {
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(rig.script);
    let out = dir.join(format!("{name}-{seed}"));
    let mut cmd = std::process::Command::new("python3");
    cmd.arg(&script).arg(&out).args(["--campaign", name]);
    match rig.noise_seed {
        Some(flag) => cmd.args(["--seed", rig.seed, flag, &seed.to_string()]),
        None => cmd.args(["--seed", &seed.to_string()]),
    };
    for e in effects {
        cmd.args(["--effect", e]);
    }
    let st = cmd.status().expect("python3 runs");
    assert!(st.success(), "{} failed for {name} {effects:?}", rig.script);
    Campaign::load(&out).unwrap()
}

/// Noise draws per strength of the rig's limit checks: `RIG_LIMIT_DRAWS`, 3 by default.
fn limit_draws() -> u64 {
    std::env::var("RIG_LIMIT_DRAWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3)
}

/// Which candidates the diagnoses of a limit check fit.
#[derive(Clone, Copy)]
enum Judged {
    /// Every candidate of the library: the whole diagnosis, and never a confident wrong cause.
    All,
    /// The injected kind alone. Whether a gap is seen is decided before any candidate is
    /// fitted (the test the limit states), so this counts the same detections at a fraction
    /// of the time; "named" then says only whether the kind explains the gap.
    Alone,
    /// No candidate: the detection alone (the limit's claim), a calibration and its
    /// cross-validation per draw; nothing is named.
    Gap,
}

/// A limit check: the detection limits of the effect-free campaign `campaign` of `rig` (its
/// panel's design and seed), checked on one of the rig's own effects: the limit of `effect` in
/// form `form` (`effect` in the library's words), then, for each `(row, value, asserted)` that
/// `at` makes of it, the rig's effect at that strength (`inject(value)`, a `--effect` of the
/// rig's script) over [`limit_draws`] draws of the noise, diagnosed without limits. Prints the
/// limits and the counts of gaps seen and of the effect named; asserts a gap seen on at least
/// 9 in 10 draws where `asserted`, and, where every candidate is judged, never a confident
/// wrong cause.
struct LimitCheck<'a> {
    rig: Rig,
    campaign: &'a str,
    effect: &'a str,
    form: &'a str,
    judged: Judged,
}

impl LimitCheck<'_> {
    fn holds(
        &self,
        at: impl Fn(&stickslip::diagnosis::limits::Limit) -> Vec<(String, f64, bool)>,
        inject: impl Fn(f64) -> String,
    ) {
        let (effect, form) = (self.effect, self.form);
        let draws = limit_draws();
        let dir = tempfile::tempdir().unwrap();
        let (c, _) = make_with(self.rig, self.campaign, dir.path());
        let d = diagnose(&c, &DiagnoseOptions::default()).unwrap();
        assert_eq!(d.verdict, Verdict::NoSignificantGap);
        for e in &d.limits.effects {
            eprintln!("  {}", e.statement);
        }
        let l = d
            .limits
            .effects
            .iter()
            .find(|e| e.effect == effect && e.form_name == form)
            .unwrap();
        let kind = stickslip::model::EffectKind::from_name(effect).unwrap();
        let opts = DiagnoseOptions {
            limits: false,
            candidates: match self.judged {
                Judged::All => DiagnoseOptions::default().candidates,
                Judged::Alone => vec![kind],
                Judged::Gap => vec![],
            },
            ..DiagnoseOptions::default()
        };
        let mut rows = vec![];
        let mut short = vec![];
        for (row, value, asserted) in at(l) {
            let (mut found, mut named) = (0, 0);
            for k in 0..draws {
                let c = make_extra(
                    self.rig,
                    self.campaign,
                    dir.path(),
                    100 + k,
                    &[inject(value)],
                );
                let r = diagnose(&c, &opts).unwrap();
                found += usize::from(r.verdict != Verdict::NoSignificantGap);
                named += usize::from(r.best_effect == Some(kind));
                // Never a confident wrong cause.
                assert!(
                    r.best_effect.is_none_or(|e| e == kind) || r.partial,
                    "{row}: named {:?}",
                    r.effects
                );
            }
            if asserted && (found as u64) * 10 < 9 * draws {
                short.push(format!("{row}: found on {found} of {draws}"));
            }
            let named = match self.judged {
                Judged::Gap => "-".to_string(),
                _ => format!("{named}/{draws}"),
            };
            let line = format!("| {row} | {value:.3e} | {found}/{draws} | {named} |");
            // Each row as it ends: a check runs for many minutes.
            eprintln!("{line}");
            rows.push(line);
        }
        let among = match self.judged {
            Judged::All => "",
            Judged::Alone => " (alone)",
            Judged::Gap => " (not judged)",
        };
        eprintln!(
            "{} {effect} [{form}]: {}\n| injected | value | gap seen | named {effect}{among} |\n|---|---|---|---|\n{}",
            self.campaign,
            l.statement,
            rows.join("\n")
        );
        assert!(short.is_empty(), "{short:?}");
    }
}

/// The first rig's effect-free small campaign, its limit of `effect` in `form` checked with
/// every candidate judged.
fn rig_limit_holds(
    effect: &str,
    form: &str,
    at: impl Fn(&stickslip::diagnosis::limits::Limit) -> Vec<(String, f64, bool)>,
    inject: impl Fn(f64) -> String,
) {
    LimitCheck {
        rig: RIG,
        campaign: "free-small",
        effect,
        form,
        judged: Judged::All,
    }
    .holds(at, inject)
}

/// The rig's ageing (Ruina's slip law) at twice the `b` the diagnosis states for the library's
/// slip-law form: a gap seen; at half, usually not. The ageing law's limit is another (7.43e-3
/// against 0.0176 at the last run): a slip-law ageing at twice the ageing law's limit stayed
/// unseen on 0 of 3 draws, which is why each form states its own.
#[test]
#[ignore = "about 6 minutes on 2 cores; left out of .ci/run for its time budget"]
fn rig_limits_hold_for_its_own_ageing() {
    rig_limit_holds("aging", "slip_law", ageing_rows, rig_ageing);
}

/// The rows of an ageing limit's check: twice its `b` (asserted) and half of it (not).
fn ageing_rows(l: &stickslip::diagnosis::limits::Limit) -> Vec<(String, f64, bool)> {
    let b = l.limit.expect("ageing is detectable in the campaign");
    vec![
        (format!("2x (b = {:.3e})", 2.0 * b), 2.0 * b, true),
        (format!("0.5x (b = {:.3e})", 0.5 * b), 0.5 * b, false),
    ]
}

/// The first rig's slip-law ageing of strength `b`, as a `--effect` of its script.
fn rig_ageing(b: f64) -> String {
    format!("aging:b={b},theta_0=0.01,d_c=1e-6")
}

/// The first rig's slip-law ageing on its effect-free campaign in the paper's design, against
/// the library's slip-law limit there (0.0196 at the last run; 0.0176 before the limits kept
/// a misfit shared at one frequency); the detection alone judged. At twice it a gap was seen on
/// 10 of 10 draws, at half on 0 of 10 (`RIG_LIMIT_DRAWS=10`, 20 minutes on 2 cores beside the
/// test suite).
#[test]
#[ignore = "about 15 minutes on 2 cores with RIG_LIMIT_DRAWS=10; left out of .ci/run"]
fn rig_ageing_limit_holds_on_the_paper_design() {
    LimitCheck {
        rig: RIG,
        campaign: "free-paper",
        effect: "aging",
        form: "slip_law",
        judged: Judged::Gap,
    }
    .holds(ageing_rows, rig_ageing);
}

/// The second rig's amplifier lag (first order, as the library's `first_order` form) on its
/// effect-free random design, against that form's limit (below 6588 Hz at the last run); the
/// detection alone judged. At 3294 Hz a gap was seen on 10 of 10 draws, at 13.2 kHz on 1 of 10
/// (`RIG_LIMIT_DRAWS=10`, 8 minutes on 2 cores beside other checks).
#[test]
#[ignore = "about 6 minutes on 2 cores with RIG_LIMIT_DRAWS=10; left out of .ci/run"]
fn rig2_actuator_limit_holds_on_the_random_design() {
    LimitCheck {
        rig: RIG2,
        campaign: "free-random",
        effect: "actuator_response",
        form: "first_order",
        judged: Judged::Gap,
    }
    .holds(resonance_rows, |f_c| format!("actuator:f_c={f_c}"));
}

/// The rig's force sensor (a fourth-order Butterworth low-pass, the library's fourth-order form
/// at its damping 0.383) where the diagnosis's limit for that form asserts detection
/// ([`Limit::asserted`](stickslip::diagnosis::limits::Limit::asserted): twice as strong, or the
/// middle of a narrower band): a gap seen; an octave above the limit (weaker), usually not. At
/// the last run the limit read "below 103 Hz"; the rig's sensor at 52 Hz was seen and named
/// on 10 of 10 draws, at 206 Hz on 0 of 10 (`RIG_LIMIT_DRAWS=10`). (When a phase's error was
/// scaled from the campaign's own, high, amplitude, the limit claimed a band of 2554 to 2890 Hz
/// that neither the rig's sensor nor the library's showed.)
#[test]
#[ignore = "about 6 minutes on 2 cores; left out of .ci/run for its time budget"]
fn rig_limits_hold_for_its_own_sensor() {
    rig_limit_holds("sensor_dynamics", "order4", resonance_rows, |f_n| {
        format!("sensor:f_n={f_n}")
    });
}

/// The rows of a resonance's limit check: where the limit asserts detection (asserted), and an
/// octave above the limit, weaker (not asserted).
fn resonance_rows(l: &stickslip::diagnosis::limits::Limit) -> Vec<(String, f64, bool)> {
    let top = l.limit.expect("the resonance is detectable there");
    let inside = l.asserted().expect("a limit");
    let p = &l.param;
    vec![
        (
            format!("where the limit asserts it ({p} = {inside:.0} Hz)"),
            inside,
            true,
        ),
        (
            format!("an octave above it ({p} = {:.0} Hz)", 2.0 * top),
            2.0 * top,
            false,
        ),
    ]
}

/// The first rig's fourth-order Butterworth sensor (the library's fourth-order form at its
/// damping 0.383) on its effect-free campaign `campaign`, checked against the library's
/// fourth-order limit there, the candidates `judged`.
fn rig_sensor_limit_holds(campaign: &str, judged: Judged) {
    LimitCheck {
        rig: RIG,
        campaign,
        effect: "sensor_dynamics",
        form: "order4",
        judged,
    }
    .holds(resonance_rows, |f_n| format!("sensor:f_n={f_n}"));
}

/// The first rig's effect-free campaign in the paper's design (two-stage recordings sampled at
/// 5 kHz). At the last run its fourth-order limit read "below 5358 Hz"; at 2679 Hz a gap was
/// seen on 10 of 10 draws, at 10.7 kHz on 1 of 10 (`RIG_LIMIT_DRAWS=10`, 25 minutes on 2 cores
/// beside another check). (Before the limits' refit kept each parameter in its range, the
/// limit read as a band, "from 5358 to 4545 Hz", and its middle, 4935 Hz, was seen on 9 of 10.)
#[test]
#[ignore = "about 15 minutes on 2 cores with RIG_LIMIT_DRAWS=10; left out of .ci/run"]
fn rig_sensor_limit_holds_on_the_paper_design() {
    rig_sensor_limit_holds("free-paper", Judged::Gap);
}

/// The first rig's effect-free factorial campaign (sampled at 20 kHz). At the last run its
/// fourth-order limit read "from 4362 to 1436 Hz"; at 2181 Hz a gap was seen on 10 of 10
/// draws, and an octave weaker, at 8723 Hz, on 1 of 10 (`RIG_LIMIT_DRAWS=10`, 6 minutes on 2
/// cores). Before the limits kept the misfit shared by the recordings at one frequency
/// (the base model misses the force's phase at 1500 Hz the way a slow sensor shifts it:
/// docs/campaigns.md) it read "from 3855 to 1436 Hz", and 7710 Hz was seen on 7 of 10.
#[test]
#[ignore = "about 6 minutes on 2 cores with RIG_LIMIT_DRAWS=10; left out of .ci/run"]
fn rig_sensor_limit_holds_on_the_factorial_design() {
    rig_sensor_limit_holds("free-factorial", Judged::Gap);
}

/// The second rig's load cell (second order, its damping the library's 0.35, its acquisition
/// low-pass at 20 kHz, far above) on its effect-free campaign `campaign`, checked against the
/// library's second-order limit there, the candidates `judged` (the gap seen is the limit's
/// claim; the whole panels check the causes named).
fn rig2_sensor_limit_holds(campaign: &str, judged: Judged) {
    LimitCheck {
        rig: RIG2,
        campaign,
        effect: "sensor_dynamics",
        form: "order2",
        judged,
    }
    .holds(resonance_rows, |f_n| {
        format!("sensor:f_n={f_n},zeta=0.35,f_lp=20000")
    });
}

/// The second rig's effect-free random design (forcing 500 to 3000 Hz, sampled at 6 kHz): its
/// second-order sensor limit. At the last run the limit read "below 1488 Hz"; the stand's
/// load cell at 744 Hz was seen and named on 10 of 10 draws, at 2977 Hz on 0 of 10
/// (`RIG_LIMIT_DRAWS=10`, 39 minutes on 2 cores, mostly beside another check).
#[test]
#[ignore = "about 30 minutes on 2 cores with RIG_LIMIT_DRAWS=10; left out of .ci/run"]
fn rig2_sensor_limit_holds_on_the_random_design() {
    rig2_sensor_limit_holds("free-random", Judged::Alone);
}

/// The second rig's effect-free force-only campaign sampled at 3 kHz below twice its forcing
/// frequency (1.2 to 2.5 kHz): the ripple is aliased, so only a sensor slow enough to shape
/// the slips shows. At the last run the limit read "below 121 Hz"; the stand's load cell at
/// 61 Hz was seen on 10 of 10 draws, at 243 Hz on 0 of 10 (`RIG_LIMIT_DRAWS=10`, 9 minutes on
/// 2 cores beside another check).
#[test]
#[ignore = "about 10 minutes on 2 cores with RIG_LIMIT_DRAWS=10; left out of .ci/run"]
fn rig2_sensor_limit_holds_on_the_force_only_low_rate_campaign() {
    rig2_sensor_limit_holds("free-forceonly-lowrate", Judged::Gap);
}

/// The second rig, effect-free, force only, sampled at 3 kHz with forcing up to 2.5 kHz (below
/// twice the forcing frequency): no significant gap.
#[test]
fn rig2_effect_free_force_only_below_twice_the_forcing_frequency() {
    right_with(RIG2, "free-forceonly-lowrate");
}

/// The second rig's mimic of a screw error: a random drive velocity (an Ornstein–Uhlenbeck
/// fluctuation of 40 % with a 4 ms memory), which no periodic error is. `unexplained`, a tie, or
/// the screw error as partial; never the screw error alone.
#[test]
#[ignore = "in the rig's whole panel; left out of .ci/run for its time budget"]
fn rig2_random_drive_velocity_is_no_confident_screw_error() {
    right_with(RIG2, "mimic-drive-noise");
}

/// The second rig's mimic of an actuator resonance: the substrate moves 0.55 times its command at
/// every frequency, which no resonance gives. Right: `unexplained`, a tie, or the actuator as
/// partial. The best candidate by evidence is a slow force sensor (about 33 Hz), which predicts a
/// ringing after every slip that the recordings lack: its fingerprint must reject it (at the
/// last run the actuator was then named as partial, its damping on the bound of 2). Left out of
/// `.ci/run` for its time (about 250 s); `second_rig_panel` checks it among the twelve.
#[test]
#[ignore = "about 250 s on 2 cores; left out of .ci/run for its time budget, in second_rig_panel"]
fn rig2_constant_actuator_gain_is_no_slow_sensor() {
    right_with(RIG2, "mimic-gain");
}

/// The actuator's scan finds a saddle resonance inside the tested band. The rig's two-mass
/// actuator of `actuator-inband` (9 kHz piezo, 1.1 kHz saddle, mass ratio 0.3) moves the
/// substrate at 4.58, 1.17 and 0.47 times the commanded amplitude at the campaign's 1000, 1500
/// and 2000 Hz (its closed-form transfer function); the library's one resonance matches these
/// gains only for `f_r` just above 1 kHz (1.05 to 1.2 kHz), a band narrower than one step of a
/// ten-point grid from 200 Hz to 20 kHz. The start must lie there and already lower the gap.
#[test]
fn rig_in_band_actuator_resonance_is_found_by_its_scan() {
    use stickslip::diagnosis::fit::{self, FitOptions, Model, Target};
    use stickslip::diagnosis::scan;
    use stickslip::model::EffectKind;
    let dir = tempfile::tempdir().unwrap();
    let (c, _) = make("actuator-inband", dir.path());
    let all = Target::new(c.recordings.iter().collect());
    let opts = FitOptions {
        final_jacobian: false,
        ..FitOptions::default()
    };
    let base = fit::fit(&all, &Model::default(), &[], opts);
    let k = EffectKind::ActuatorResponse;
    let start = scan::starts(&all, &base, k, k.default_form())
        .swap_remove(0)
        .model;
    let f_r = start.effects.get(k, "f_r").unwrap();
    let zeta = start.effects.get(k, "zeta").unwrap();
    let gap = fit::evaluate(&all, &start);
    eprintln!(
        "base gap {:.2}; start f_r {f_r:.0} Hz, zeta {zeta:.3}: gap {gap:.2}",
        base.gap
    );
    assert!((1050.0..1200.0).contains(&f_r), "f_r {f_r} Hz");
    assert!(
        gap < 0.8 * base.gap,
        "start gap {gap} against base {}",
        base.gap
    );
}

/// Whether a verdict is `right`, `WRONG` or `CONFIDENT WRONG` for the truth `expect`.
fn mark(d: &Diagnosis, expect: &serde_json::Value) -> &'static str {
    if confident_wrong(d, expect) {
        "CONFIDENT WRONG"
    } else if right(d, expect) {
        "right"
    } else {
        "WRONG"
    }
}

/// A verdict in a few words, and whether it is right (`right`, `WRONG`, `CONFIDENT WRONG`).
fn judged(d: &Diagnosis, expect: &serde_json::Value) -> String {
    let named: Vec<&str> = if d.tie.is_empty() {
        d.effects.iter().map(|k| k.name()).collect()
    } else {
        d.tie.iter().map(|k| k.name()).collect()
    };
    format!(
        "{}{} {} ({:.2} → {:.2}), {}",
        d.verdict.name(),
        if d.partial { " (partial)" } else { "" },
        if named.is_empty() {
            "-".to_string()
        } else {
            named.join(if d.tie.is_empty() { " + " } else { " = " })
        },
        d.gap_before,
        d.gap_after,
        mark(d, expect)
    )
}

/// Whether a campaign's verdict asks for a plan: wrong, or a `tie`, `partial` or `unexplained`
/// where the truth is among the library's effects.
fn wants_a_plan(d: &Diagnosis, expect: &serde_json::Value) -> bool {
    let in_library = expect.is_array();
    !right(d, expect)
        || (in_library && (d.partial || matches!(d.verdict, Verdict::Tie | Verdict::Unexplained)))
}

/// The plan's loop on the panel campaigns named in `PLAN_CAMPAIGNS` (`rig:NAME` or
/// `rig2:NAME`, comma-separated): each campaign is diagnosed; where its verdict asks for a plan
/// ([`wants_a_plan`]), 6 recordings are planned (`stickslip plan`, checked) and 6 drawn at
/// random from the same space (seed 1); each set is recorded on the rig (`--conditions`: the
/// campaign's hidden effects and noise), added to the campaign, and the campaign diagnosed
/// again. Prints a table (before, after the planned, after the random) and asserts what
/// docs/planning.md states: no confident wrong cause before or after; planned right on at
/// least two thirds of the campaigns planned for, and on at least two more than random.
/// `PLAN_LOOP_DIR` keeps the campaigns, plans and diagnoses (a temporary folder otherwise).
#[test]
#[ignore = "a diagnosis, a plan and two diagnoses per campaign: about 15 minutes each on 2 cores"]
fn plan_loop_on_panel_campaigns() {
    use stickslip::planning::{PlanOptions, plan, report, space::Space};
    let names = std::env::var("PLAN_CAMPAIGNS").unwrap_or_default();
    let tmp = tempfile::tempdir().unwrap();
    let root = std::env::var("PLAN_LOOP_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|_| tmp.path().to_path_buf());
    let mut rows = vec![];
    let (mut asked, mut planned_right, mut random_right, mut wrong) = (0, 0, 0, 0);
    for item in names.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (rig, name) = match item.split_once(':') {
            Some(("rig", n)) => (RIG, n),
            Some(("rig2", n)) => (RIG2, n),
            _ => panic!("PLAN_CAMPAIGNS: {item}: give rig:NAME or rig2:NAME"),
        };
        let dir = root.join(format!(
            "{}-{name}",
            if rig.script == RIG.script {
                "rig"
            } else {
                "rig2"
            }
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let (c, truth) = make_with(rig, name, &dir);
        let expect = &truth["expect"];
        let d0 = diagnose(&c, &DiagnoseOptions::default()).unwrap();
        wrong += usize::from(confident_wrong(&d0, expect));
        let before = judged(&d0, expect);
        eprintln!("{item}: before: {before} ({:.0} s)", d0.wall_time);
        if !wants_a_plan(&d0, expect) {
            rows.push(format!(
                "| {item} | {expect} | {before} | no plan asked | | |"
            ));
            continue;
        }
        asked += 1;
        let j0 = stickslip::diagnosis::record::DiagnosisRecord::of(&c, &d0, &[]);
        let keep = |file: &str, j: &serde_json::Value| {
            std::fs::write(dir.join(file), serde_json::to_string_pretty(j).unwrap()).unwrap()
        };
        keep("diagnosis-before.json", &j0.to_json());
        let mut after = vec![];
        let mut took = String::new();
        for random in [false, true] {
            let kind = if random { "random" } else { "plan" };
            let opts = PlanOptions {
                random,
                check: !random,
                ..PlanOptions::default()
            };
            let say = |line: &str| eprintln!("{item}: {kind}: {line}");
            let p = plan(&c, &j0, &Space::of(&c), &opts, &say).unwrap();
            if !random {
                took = format!("{} rivals, {:.0} s", p.rivals.len(), p.wall_time);
            }
            let pdir = dir.join(format!("{kind}-{name}"));
            report::write(
                &pdir,
                &c,
                &p,
                &format!("plan-{name}"),
                &pdir.join("plan.json"),
                true,
            )
            .unwrap();
            let rec = dir.join(format!("rec-{kind}-{name}"));
            let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(rig.script);
            let st = std::process::Command::new("python3")
                .arg(&script)
                .arg(&rec)
                .args(["--campaign", name, "--seed", rig.seed, "--conditions"])
                .arg(&pdir)
                .status()
                .expect("python3 runs");
            assert!(
                st.success(),
                "{} --conditions failed for {name}",
                rig.script
            );
            let ext = dir.join(format!("ext-{kind}-{name}"));
            std::fs::create_dir_all(&ext).unwrap();
            for from in [dir.join(name), rec] {
                for e in std::fs::read_dir(&from).unwrap() {
                    let e = e.unwrap().path();
                    std::fs::copy(&e, ext.join(e.file_name().unwrap())).unwrap();
                }
            }
            let c2 = Campaign::load(&ext).unwrap();
            assert_eq!(
                c2.recordings.len(),
                c.recordings.len() + 6,
                "{item}: {kind}"
            );
            let d = diagnose(&c2, &DiagnoseOptions::default()).unwrap();
            keep(
                &format!("diagnosis-after-{kind}.json"),
                &stickslip::diagnosis::record::DiagnosisRecord::of(&c2, &d, &[]).to_json(),
            );
            wrong += usize::from(confident_wrong(&d, expect));
            if right(&d, expect) {
                if random {
                    random_right += 1;
                } else {
                    planned_right += 1;
                }
            }
            let a = judged(&d, expect);
            eprintln!("{item}: after 6 {kind}: {a} ({:.0} s)", d.wall_time);
            after.push(a);
        }
        rows.push(format!(
            "| {item} | {expect} | {before} | {took} | {} | {} |",
            after[0], after[1]
        ));
    }
    eprintln!(
        "planned for {asked}: right after 6 planned {planned_right}, after 6 random {random_right}; {wrong} confident wrong\n| campaign | truth | before | plan | after 6 planned | after 6 random |\n|---|---|---|---|---|---|\n{}",
        rows.join("\n")
    );
    assert_eq!(wrong, 0, "a confident wrong cause");
    assert!(
        3 * planned_right >= 2 * asked && planned_right >= random_right + 2,
        "planned right on {planned_right} of {asked}, random on {random_right}"
    );
}
