//! The `stickslip` binary end to end: output files, JSON, error messages and exit codes; the
//! HDF5 file is read back with h5py (tests/python/requirements.txt).

use std::path::Path;
use std::process::{Command, Output};

fn stickslip(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(args)
        .output()
        .expect("binary runs")
}

fn python(script: &str, args: &[&Path]) {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(script);
    let out = Command::new("python3")
        .arg(here)
        .args(args)
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "{script} failed (install the readers with `python3 -m pip install -r tests/python/requirements.txt`):\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn run_fig4_case_writes_hdf5_csv_plots_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let h5 = dir.path().join("fig4.h5");
    let csv = dir.path().join("fig4.csv");
    let out = stickslip(&[
        "run",
        "--k-d",
        "10000",
        "--v-d",
        "1e-3",
        "--f",
        "1500",
        "--v-a",
        "1.1e-3",
        "--json",
        "--plot",
        "-o",
        h5.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("stdout is one JSON object");
    for k in ["r", "dF", "dF_stderr", "mean_force", "status"] {
        assert!(json.get(k).is_some(), "missing {k}");
    }
    assert_eq!(json["status"], "success");
    // Fig. 4: v_a slightly above v_d removes the stick-slip.
    assert!(json["r"].as_f64().unwrap() < 0.05, "{json}");
    assert!(json["reference"]["dF"].as_f64().unwrap() > 5.0);
    for ext in ["png", "svg"] {
        let f = h5.with_extension(ext);
        assert!(
            std::fs::metadata(&f).unwrap().len() > 10_000,
            "{} too small",
            f.display()
        );
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t [s],F_d [N],F_d_smooth [N],x_s [m],x_d [m],s [m],v_r [m/s],v [m/s],u [m]"
    );
    let row: Vec<f64> = lines
        .nth(10)
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    assert_eq!(row.len(), 9);
    let expected = dir.path().join("expected.json");
    std::fs::write(&expected, &out.stdout).unwrap();
    python("check_run.py", &[&h5, &expected]);
}

/// A vibrated run whose window holds one stick-slip cycle reports r and dF without a standard
/// error (one cycle has no spread), in the JSON (`null`) and on the terminal; its reference
/// without vibration, whose cycles repeat, keeps its 0. Two cycles give a finite error again.
#[test]
fn one_vibrated_cycle_has_an_unknown_standard_error() {
    // Default rig (cycle about 1.1 s), v_a = 0.1 v_d: the window of a 2.75-s run (its second
    // half) holds one drop, that of a 3.5-s run two.
    let dir = tempfile::tempdir().unwrap();
    let h5 = dir.path().join("one.h5");
    let h5 = h5.to_str().unwrap();
    let json = |t_end: &str| -> serde_json::Value {
        let out = stickslip(&[
            "run",
            "--va-ratio",
            "0.1",
            "--t-end",
            t_end,
            "--no-trace",
            "--json",
            "-o",
            h5,
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).expect("one JSON object")
    };
    let one = json("2.75");
    assert_eq!(one["cycles"], 1, "{one}");
    assert!(one["r"].as_f64().is_some_and(|r| r > 0.5), "{one}");
    assert!(
        one["r_stderr"].is_null() && one["dF_stderr"].is_null(),
        "{one}"
    );
    assert_eq!(one["reference"]["cycles"], 1, "{one}");
    assert_eq!(one["reference"]["dF_stderr"].as_f64(), Some(0.0), "{one}");
    let two = json("3.5");
    assert_eq!(two["cycles"], 2, "{two}");
    assert!(two["r_stderr"].as_f64().is_some_and(|s| s > 0.0), "{two}");
    let out = stickslip(&[
        "run",
        "--va-ratio",
        "0.1",
        "--t-end",
        "2.75",
        "--no-trace",
        "-o",
        h5,
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("standard error unknown") && !text.contains("± NaN"),
        "{text}"
    );
}

#[test]
fn case_file_and_flags_combine_and_summary_prints() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("case.toml");
    std::fs::write(
        &case,
        "k_d = 17900\nv_d = 0.5e-3\n[solver]\nmethod = \"dopri5\"\n",
    )
    .unwrap();
    let h5 = dir.path().join("c.h5");
    let out = stickslip(&[
        "run",
        "--case",
        case.to_str().unwrap(),
        "--k-d",
        "5950",
        "-o",
        h5.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(
        s.contains("k_d = 5950 N/m") && s.contains("dopri5") && s.contains("r         1.0000"),
        "{s}"
    );
}

#[test]
fn bad_input_is_named_with_its_range_and_exit_code_2() {
    let cases: &[(&[&str], &str)] = &[
        (&["run", "--k-d", "-5"], "--k-d = -5"),
        (&["run", "--m", "0"], "--m = 0"),
        (&["run", "--u0", "1e-7", "--f", "0"], "f"),
        (&["run", "--rtol", "3"], "--rtol = 3"),
        (&["run", "--va-ratio", "1.2", "--f", "0"], "--va-ratio"),
        (&["run", "--f-s", "5"], "F_c"),
        (&["run", "--solver", "euler"], "euler"),
        (&["run", "--case", "/nonexistent/case.toml"], "cannot read"),
    ];
    for (args, needle) in cases {
        let out = stickslip(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(needle),
            "{args:?}: '{err}' should mention '{needle}'"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn bench_writes_a_work_precision_table_whose_error_falls_with_the_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let h5 = dir.path().join("bench.h5");
    let out = stickslip(&[
        "bench",
        "--cases",
        "no_vibration",
        "--methods",
        "radau5,dopri5",
        "--tolerances",
        "1e-3,1e-7",
        "--repeats",
        "1",
        "--reference-tolerance",
        "1e-10",
        "-o",
        h5.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let f = rust_hdf5::H5File::open(&h5).unwrap();
    let err = f
        .dataset("err_mean_force")
        .unwrap()
        .read_raw::<f64>()
        .unwrap();
    let tol = f.dataset("tolerance").unwrap().read_raw::<f64>().unwrap();
    let time = f.dataset("time").unwrap().read_raw::<f64>().unwrap();
    let methods = f.dataset("method").unwrap().read_strings().unwrap();
    assert_eq!(methods, vec!["radau5", "radau5", "dopri5", "dopri5"]);
    assert_eq!(tol, vec![1e-3, 1e-7, 1e-3, 1e-7]);
    for m in 0..2 {
        // Tighter tolerance: smaller error, more time.
        assert!(err[2 * m + 1] < err[2 * m], "{err:?}");
        assert!(time[2 * m + 1] > 0.0);
    }
    for ext in ["png", "svg"] {
        assert!(
            dir.path()
                .join(format!("bench_no_vibration.{ext}"))
                .exists()
        );
    }
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("fastest within"), "{s}");
    let bad = stickslip(&["bench", "--cases", "nope"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("no_vibration"));
}

/// `bench --batch` times whole runs on both paths, finds them equal bit for bit, writes its JSON
/// beside `--out`, and refuses what the lanes cannot serve by name.
#[test]
fn bench_batch_compares_the_paths_and_refuses_what_lanes_do_not_serve() {
    let dir = tempfile::tempdir().unwrap();
    let h5 = dir.path().join("b.h5");
    let out = stickslip(&[
        "bench",
        "--batch",
        "--points",
        "6",
        "--repeats",
        "1",
        "-o",
        h5.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("agree bit for bit"), "{s}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("b_batch.json")).unwrap())
            .unwrap();
    assert_eq!(j["points"], 6);
    assert_eq!(j["in_lanes"], 6, "{j}");
    assert_eq!(j["differing"].as_array().unwrap().len(), 0, "{j}");
    assert!(j["scalar_seconds"].as_f64().unwrap() > 0.0);
    assert!(!h5.exists(), "--batch writes no work-precision file");
    for (args, named) in [
        (vec!["--methods", "radau5"], "methods"),
        (vec!["--methods", "dopri5,auto"], "methods"),
        (vec!["--points", "0"], "points"),
        (vec!["--cases", "partial"], "batch"),
    ] {
        let mut a = vec!["bench", "--batch"];
        a.extend(args);
        let bad = stickslip(&a);
        assert_eq!(bad.status.code(), Some(2), "{a:?}");
        let e = String::from_utf8_lossy(&bad.stderr);
        assert!(e.contains(named), "{a:?}: {e}");
    }
}
#[test]
fn synth_then_diagnose_writes_the_verdict_json_hdf5_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let camp = dir.path().join("camp");
    let truth = dir.path().join("truth.json");
    let c = camp.to_str().unwrap();
    let out = stickslip(&[
        "synth",
        c,
        "--design",
        "small",
        "--rate",
        "5000",
        "--min-cycles",
        "2",
        "--effect",
        "viscous:h_v=80",
        "--seed",
        "5",
        "--truth",
        truth.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let t: serde_json::Value = serde_json::from_slice(&std::fs::read(&truth).unwrap()).unwrap();
    assert_eq!(t["effects"]["viscous"]["h_v"], 80.0);
    // The truth stays outside the campaign; the conditions files hold conditions only.
    let cond = std::fs::read_to_string(camp.join("d0_v1.toml")).unwrap();
    assert!(
        cond.contains("v_d") && !cond.contains("h_v") && !cond.contains("F_s"),
        "{cond}"
    );
    // Writing over recordings needs --overwrite.
    let again = stickslip(&["synth", c, "--design", "small"]);
    assert_eq!(again.status.code(), Some(2));

    let res = dir.path().join("diag");
    let json = dir.path().join("verdict.json");
    let out = stickslip(&[
        "diagnose",
        c,
        "--out",
        res.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--candidates",
        "viscous,stribeck_shape,sensor_dynamics",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("verdict: viscous (form linear) explains the gap"),
        "{text}"
    );
    assert!(
        text.contains("form: viscous: form linear (its default), the others tried (quadratic) fit worse but are not excluded"),
        "{text}"
    );
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(v["verdict"], "effect");
    assert_eq!(v["best_effect"], "viscous");
    for k in ["gap_before", "gap_after", "reduction"] {
        assert!(v[k].is_number(), "{k}: {v}");
    }
    let rank = v["ranking"].as_array().unwrap();
    // The three candidates, and the other forms of the two whose default form passed its
    // screen (viscous quadratic, the fourth-order sensor with and without its delay).
    let effects: std::collections::BTreeSet<&str> =
        rank.iter().filter_map(|r| r["effect"].as_str()).collect();
    assert_eq!(effects.len(), 3, "{effects:?}");
    assert_eq!(rank.len(), 6);
    assert_eq!(rank[0]["effect"], "viscous");
    let h_v = rank[0]["params"]["viscous.h_v"]["value"].as_f64().unwrap();
    let se = rank[0]["params"]["viscous.h_v"]["stderr"].as_f64().unwrap();
    // Recovered to within 15 % (the drive damping h_d shares the slip damping with it).
    assert!(
        (h_v / 80.0 - 1.0).abs() < 0.15 && se > 0.0,
        "h_v = {h_v} ± {se}"
    );
    for k in ["features", "phases", "conditions"] {
        assert!(!v["where"][k].as_array().unwrap().is_empty(), "{k}");
    }
    for f in [
        "traces.png",
        "traces.svg",
        "gap_conditions.png",
        "diagnosis.h5",
    ] {
        assert!(res.join(f).exists(), "{f}");
    }
    python("check_diagnosis.py", &[&res.join("diagnosis.h5"), &json]);

    // A plan of three recordings from that diagnosis, inside the campaign's ranges, into a
    // folder whose name holds a space and a newline (taken as a name, never as words).
    let plan = dir.path().join("my plan\nnext week");
    let p = plan.to_str().unwrap();
    let j = json.to_str().unwrap();
    let args = |extra: &[&'static str]| {
        let mut a = vec!["plan", c, "--diagnosis", j, "--out", p, "--recordings", "3"];
        a.extend(["--finalists", "8", "--no-plots"]);
        a.extend(extra);
        a
    };
    let out = stickslip(&args(&[]));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let pj: serde_json::Value =
        serde_json::from_slice(&std::fs::read(plan.join("plan.json")).unwrap()).unwrap();
    let recs = pj["recordings"].as_array().unwrap();
    assert_eq!(recs.len(), 3, "{pj}");
    assert_eq!(pj["rivals"][0]["name"], "base");
    assert!(
        pj["rivals"]
            .as_array()
            .unwrap()
            .iter()
            .any(|r| r["name"] == "viscous")
    );
    // The small design's ranges: springs 11 700, 17 900 and 20 000 N/m, v_d 0.7 to 2 mm/s,
    // 1000 to 1500 Hz at v_a/v_d 0.4 to 1.5, or no vibration.
    for r in recs {
        let cnd = &r["conditions"];
        let (k_d, v_d, f, ratio) = (
            cnd["k_d"].as_f64().unwrap(),
            cnd["v_d"].as_f64().unwrap(),
            cnd["f"].as_f64().unwrap(),
            cnd["va_ratio"].as_f64().unwrap(),
        );
        assert!([11_700.0, 17_900.0, 20_000.0].contains(&k_d), "{r}");
        assert!((0.7e-3 - 1e-12..=2e-3 + 1e-12).contains(&v_d), "{r}");
        assert!(
            f == 0.0
                || ((1000.0..=1500.0).contains(&f) && (0.4 - 1e-9..=1.5 + 1e-9).contains(&ratio)),
            "{r}"
        );
        let toml =
            std::fs::read_to_string(plan.join(format!("{}.toml", r["name"].as_str().unwrap())));
        assert!(toml.unwrap().contains("\n[plan]\n"));
    }
    // Viscous friction as the truth: the planned recordings add evidence for it against the
    // base model, by the criterion and by simulation.
    let o = pj["outcomes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["truth"] == "viscous" && o["other"] == "base")
        .unwrap();
    let now = o["ln_odds_now"].as_f64().unwrap();
    assert!(o["ln_odds_expected"].as_f64().unwrap() > now, "{o}");
    assert!(o["ln_odds_simulated"].as_f64().unwrap() > now, "{o}");
    // A plan never writes over what it did not write: the campaign, or a folder of other files.
    let bad = stickslip(&["plan", c, "--diagnosis", j, "--out", c]);
    assert_eq!(bad.status.code(), Some(2));
    std::fs::write(plan.join("notes.toml"), "a = 1\n").unwrap();
    let bad = stickslip(&args(&["--no-check"]));
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("no plan wrote"));
    std::fs::remove_file(plan.join("notes.toml")).unwrap();
    // One plan per folder at a time: a folder whose lock another process holds is refused,
    // naming that process, and left as it was.
    {
        let held = stickslip::sweep::lock::acquire(&plan).unwrap();
        let bad = stickslip(&args(&["--random"]));
        let err = String::from_utf8_lossy(&bad.stderr);
        assert_eq!(bad.status.code(), Some(2), "{err}");
        assert!(
            err.contains("--out") && err.contains(&format!("process {}", std::process::id())),
            "{err}"
        );
        drop(held);
    }
    let again: serde_json::Value =
        serde_json::from_slice(&std::fs::read(plan.join("plan.json")).unwrap()).unwrap();
    assert_eq!(again, pj);
    // The baseline: three recordings drawn at random from the same space, nothing simulated.
    let rand_dir = dir.path().join("random");
    let random = |out: &str, n: &str| {
        stickslip(&[
            "plan",
            c,
            "--diagnosis",
            j,
            "--out",
            out,
            "--recordings",
            n,
            "--random",
            "--no-plots",
        ])
    };
    let out = random(rand_dir.to_str().unwrap(), "3");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rj: serde_json::Value =
        serde_json::from_slice(&std::fs::read(rand_dir.join("plan.json")).unwrap()).unwrap();
    assert_eq!(rj["random"], true);
    assert_eq!(rj["simulations"], 0);
    let names: Vec<&str> = rj["recordings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    assert_eq!(names.len(), 3);
    assert!(
        names
            .iter()
            .all(|n| n.starts_with("rand") && rand_dir.join(format!("{n}.toml")).is_file())
    );
    // Recorded with the truth (synth --conditions) and added to the campaign, the planned
    // recordings load as any other and are counted as a plan's.
    let rec = dir.path().join("rec");
    let out = stickslip(&[
        "synth",
        rec.to_str().unwrap(),
        "--conditions",
        p,
        "--effect",
        "viscous:h_v=80",
        "--seed",
        "6",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // A new plan into the folder of an earlier one replaces it whole: none of the earlier
    // conditions is left to be recorded as if planned now.
    let out = random(p, "2");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut left: Vec<String> = std::fs::read_dir(&plan)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left.len(), 3, "{left:?}");
    assert!(
        left[0] == "plan.json" && left[1..].iter().all(|n| n.starts_with("rand")),
        "{left:?}"
    );
    for r in recs {
        let name = r["name"].as_str().unwrap();
        for ext in ["csv", "toml"] {
            let from = rec.join(format!("{name}.{ext}"));
            std::fs::copy(&from, camp.join(format!("{name}.{ext}"))).unwrap();
        }
    }
    let loaded = stickslip::campaign::Campaign::load(&camp).unwrap();
    assert_eq!(loaded.planned.len(), 3);
    assert_eq!(loaded.recordings.len(), 19);

    let out = stickslip(&["calibrate", c, "--effect", "viscous", "--max-iter", "3"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("viscous.h_v = ") && text.contains("F_s = "),
        "{text}"
    );
}

#[test]
fn malformed_campaigns_and_effects_are_rejected_with_file_line_and_range() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.toml"), "v_d = 1e-3\nk_d = 1e4\nf = 0\nu0 = 0\n").unwrap();
    let mut csv = String::from("t,F_d,x_s,x_d\n");
    for i in 0..300 {
        csv += &format!(
            "{},{},0,0\n",
            i as f64 * 1e-3,
            if i == 99 { "x" } else { "1" }
        );
    }
    std::fs::write(d.join("a.csv"), csv).unwrap();
    let out = stickslip(&["diagnose", d.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("a.csv:101") && err.contains("`x` is not a number"),
        "{err}"
    );

    let out = stickslip(&["run", "--effect", "aging:b=2"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("aging.b = 2") && err.contains("[0, 0.5]"),
        "{err}"
    );

    let case = d.join("case.toml");
    std::fs::write(&case, "k_d = 1e4\n[effects.stribeck_shape]\ndelta = 0.1\n").unwrap();
    let out = stickslip(&["run", "--case", case.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("case.toml:3") && err.contains("delta"),
        "{err}"
    );
}

#[test]
fn run_with_an_effect_from_a_case_file() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("case.toml");
    std::fs::write(
        &case,
        "k_d = 1e4\nv_d = 1e-3\n[effects.viscous]\nh_v = 40\n",
    )
    .unwrap();
    let h5 = dir.path().join("o.h5");
    let with = stickslip(&[
        "run",
        "--case",
        case.to_str().unwrap(),
        "--json",
        "-o",
        h5.to_str().unwrap(),
    ]);
    let base = stickslip(&[
        "run",
        "--k-d",
        "1e4",
        "--v-d",
        "1e-3",
        "--json",
        "-o",
        h5.to_str().unwrap(),
    ]);
    let get = |o: &Output| -> f64 {
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["dF"].as_f64().unwrap()
    };
    // Viscous friction damps the slip: a smaller saw-tooth.
    assert!(
        get(&with) < 0.9 * get(&base),
        "{} vs {}",
        get(&with),
        get(&base)
    );
}

/// Bad inputs that once cost data, aborted or ran on: each is refused before anything runs, with
/// exit code 2 and a message that names the flag or key, the value and the rule, and no file in
/// the working directory changes.
#[test]
fn outputs_never_replace_inputs_and_sizes_are_checked_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |name: &str| d.join(name).to_str().unwrap().to_string();
    let sweep = "[fixed]\nk_d = 20000.0\nv_d = 1.5e-3\n[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 2]\n";
    std::fs::write(d.join("s.toml"), sweep).unwrap();
    std::fs::write(d.join("c.toml"), "k_d = 1e4\nv_d = 1e-3\n").unwrap();
    std::fs::create_dir(d.join("camp")).unwrap();
    std::fs::write(d.join("camp/rec.csv"), "t,F_d,x_s,x_d\n0,0,0,0\n").unwrap();
    std::fs::write(d.join("camp/rec.toml"), "v_d = 1e-3\nk_d = 1e4\n").unwrap();
    std::fs::create_dir(d.join("outdir")).unwrap();
    std::fs::write(d.join("afile"), "not a directory").unwrap();
    let with = |text: &str| {
        let name = format!("bad{}.toml", text.len());
        std::fs::write(d.join(&name), text).unwrap();
        p(&name)
    };
    let huge = with("[[axis]]\nname = \"u0\"\nlinspace = [1e-8, 1e-6, 1000000000000000000]\n");
    let big_cap = with("max_runs = 1000000000000\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n");
    let up = with("name = \"../x\"\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n");
    let empty = with("name = \"\"\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n");
    let far = with("[run]\nt_end = 1e300\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n");
    // (arguments, what the message must contain)
    let cases: Vec<(Vec<String>, Vec<&str>)> = vec![
        (
            vec!["sweep".into(), p("s.toml"), "-o".into(), p("s.toml")],
            vec!["--out", "s.toml", "input"],
        ),
        (
            vec!["sweep".into(), p("s.toml"), "-o".into(), p("outdir")],
            vec!["--out", "is a directory"],
        ),
        (
            vec!["sweep".into(), p("s.toml"), "-o".into(), p("afile/x.h5")],
            vec!["--out", "afile", "is a file"],
        ),
        (
            vec![
                "run".into(),
                "--case".into(),
                p("c.toml"),
                "-o".into(),
                p("c.toml"),
            ],
            vec!["--out", "c.toml", "input"],
        ),
        (
            vec![
                "run".into(),
                "-o".into(),
                p("x.h5"),
                "--csv".into(),
                p("x.h5"),
            ],
            vec!["--csv", "x.h5", "input"],
        ),
        (
            vec!["run".into(), "-o".into(), p("afile/run.h5")],
            vec!["--out", "is a file"],
        ),
        (
            vec![
                "calibrate".into(),
                p("camp"),
                "--json".into(),
                p("camp/rec.csv"),
            ],
            vec!["--json", "rec.csv", "input"],
        ),
        (
            vec![
                "diagnose".into(),
                p("camp"),
                "--json".into(),
                p("camp/rec.toml"),
            ],
            vec!["--json", "rec.toml", "input"],
        ),
        (
            vec![
                "diagnose".into(),
                p("camp"),
                "--candidates".into(),
                "viscous,aging,viscous".into(),
            ],
            vec!["--candidates", "viscous", "listed twice"],
        ),
        (
            vec!["sweep".into(), huge],
            vec!["linspace", "1000000000000000000", "max_runs"],
        ),
        (vec!["sweep".into(), big_cap], vec!["max_runs", "10000000"]),
        (vec!["sweep".into(), up], vec!["name", "../x", "file stem"]),
        (vec!["sweep".into(), empty], vec!["name", "file stem"]),
        (vec!["sweep".into(), far], vec!["t_end", "1e5"]),
        (
            vec![
                "run".into(),
                "--t-end".into(),
                "1e12".into(),
                "-o".into(),
                p("r.h5"),
            ],
            vec!["t-end", "1e5"],
        ),
        (
            vec!["sweep".into(), p("s.toml"), "--shard".into(), "2/2".into()],
            vec!["--shard", "2/2", "I must be from 0 to N - 1 = 1"],
        ),
        (
            vec!["sweep".into(), p("s.toml"), "--shard".into(), "0/3".into()],
            vec!["--shard", "0/3", "2 grid points"],
        ),
        (
            vec![
                "slurm".into(),
                p("s.toml"),
                "--tasks".into(),
                "3".into(),
                "-o".into(),
                p("sl.h5"),
            ],
            vec!["--tasks", "3", "2 grid points"],
        ),
        (
            vec![
                "slurm".into(),
                p("s.toml"),
                "--tasks".into(),
                "2".into(),
                "--time".into(),
                "2h".into(),
                "-o".into(),
                p("sl.h5"),
            ],
            vec!["--time", "2h", "HH:MM:SS"],
        ),
        (
            vec![
                "slurm".into(),
                p("s.toml"),
                "--tasks".into(),
                "2".into(),
                "--cpus-per-task".into(),
                "0".into(),
                "-o".into(),
                p("sl.h5"),
            ],
            vec!["--cpus-per-task", "from 1 to 1024"],
        ),
        (
            vec![
                "slurm".into(),
                p("s.toml"),
                "--tasks".into(),
                "2".into(),
                "--partition".into(),
                "a b".into(),
                "-o".into(),
                p("sl.h5"),
            ],
            vec!["--partition", "a b", "no spaces"],
        ),
        (
            vec![
                "slurm".into(),
                p("s.toml"),
                "--tasks".into(),
                "2".into(),
                "-o".into(),
                p("s.toml"),
            ],
            vec!["--out", "s.toml", "input"],
        ),
        (
            vec![
                "sweep".into(),
                p("s.toml"),
                "--estimate".into(),
                "--sample".into(),
                "0".into(),
            ],
            vec!["--sample", "from 1"],
        ),
    ];
    let snapshot = || {
        let mut files: Vec<(String, Vec<u8>)> = walk(d)
            .into_iter()
            .map(|f| (f.display().to_string(), std::fs::read(&f).unwrap()))
            .collect();
        files.sort();
        files
    };
    for (args, needles) in &cases {
        let before = snapshot();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = stickslip(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        for n in needles {
            assert!(err.contains(n), "{args:?}: `{n}` missing from: {err}");
        }
        assert_eq!(snapshot(), before, "{args:?} changed a file");
    }
    // `status` and `merge` on what is no sweep name it and change nothing.
    let before = snapshot();
    let out = stickslip(&["status", &p("afile")]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("not a stickslip sweep file"),
        "{err}"
    );
    let out = stickslip(&["merge", &p("nothing.h5")]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("no shards of"),
        "{err}"
    );
    assert_eq!(snapshot(), before, "status or merge changed a file");
}

/// Every file below `dir`.
fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = vec![];
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// `--resume` onto a file that is no checkpoint of the sweep (no journal beside it) is refused
/// and the file kept; damaged journal lines are counted and their runs made again; a run that
/// fails (here: a step budget of 50) exits 1 and keeps the earlier result in place.
#[test]
fn resume_and_failed_runs_never_replace_what_is_there() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = d.join("s.toml");
    std::fs::write(
        &sweep,
        "[fixed]\nk_d = 20000.0\nv_d = 1.5e-3\n[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 3]\n[run]\nt_end = 0.5\n",
    )
    .unwrap();
    let out = d.join("s.h5");
    std::fs::write(&out, "a text file, not a sweep").unwrap();
    let r = stickslip(&[
        "sweep",
        sweep.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--resume",
        "--no-plot",
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(
        err.contains("not an interrupted sweep") && err.contains("journal"),
        "{err}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), b"a text file, not a sweep");

    // A journal with one damaged line and a torn last one: both are counted on resuming.
    std::fs::remove_file(&out).unwrap();
    let ok = stickslip(&[
        "sweep",
        sweep.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--no-plot",
    ]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    // The header a journal of this sweep starts with (the file's text and the program version).
    let fp_line = stickslip::sweep::journal::header(&stickslip::sweep::journal::fingerprint(
        &std::fs::read_to_string(&sweep).unwrap(),
    ));
    std::fs::write(
        d.join("s.h5.journal"),
        format!("{fp_line}\npt 1 0 garbage\npt 2 0 0.5 0.2"),
    )
    .unwrap();
    let r = stickslip(&[
        "sweep",
        sweep.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--resume",
        "--no-plot",
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(err.contains("2 damaged line(s)"), "{err}");

    // A failed run keeps the earlier result.
    let h5 = d.join("run.h5");
    let good = stickslip(&["run", "--no-trace", "-o", h5.to_str().unwrap()]);
    assert!(good.status.success());
    let before = std::fs::read(&h5).unwrap();
    let case = d.join("tight.toml");
    std::fs::write(&case, "[solver]\nmax_steps = 50\n").unwrap();
    let bad = stickslip(&[
        "run",
        "--case",
        case.to_str().unwrap(),
        "--no-trace",
        "-o",
        h5.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(1), "{err}");
    assert!(
        err.contains("max_steps") && err.contains("nothing written"),
        "{err}"
    );
    assert_eq!(std::fs::read(&h5).unwrap(), before);
}

/// Corrupted recordings are refused before any fit, each named with its check, the value found
/// and what was expected: a dead force channel, a force 1e6 too large, `v_d` half the recorded
/// drive slope, one 1e300 N sample. `--skip-implausible` fits the rest and lists them in the
/// report and the JSON. Nothing in the campaign changes.
#[test]
fn implausible_recordings_are_refused_by_name_or_set_aside() {
    let dir = tempfile::tempdir().unwrap();
    let camp = dir.path().join("camp");
    let c = camp.to_str().unwrap();
    let out = stickslip(&["synth", c, "--design", "small"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let edit = |name: &str, f: &dyn Fn(usize, &mut Vec<String>)| {
        let p = camp.join(format!("{name}.csv"));
        let text = std::fs::read_to_string(&p).unwrap();
        let mut lines = text.lines();
        let mut out = vec![lines.next().unwrap().to_string()];
        for (i, l) in lines.enumerate() {
            let mut cols: Vec<String> = l.split(',').map(String::from).collect();
            f(i, &mut cols);
            out.push(cols.join(","));
        }
        std::fs::write(&p, out.join("\n") + "\n").unwrap();
    };
    edit("d0_v1", &|_, c| c[1] = "0".into());
    edit("d1_v0", &|_, c| {
        c[1] = format!("{:e}", c[1].parse::<f64>().unwrap() * 1e6)
    });
    edit("d2_v0", &|i, c| {
        if i == 777 {
            c[1] = "1e300".into()
        }
    });
    let toml = camp.join("d1_v1.toml");
    let text = std::fs::read_to_string(&toml).unwrap();
    let v_d: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("v_d = "))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    std::fs::write(
        &toml,
        text.replace(&format!("v_d = {v_d:e}"), &format!("v_d = {:e}", v_d / 2.0)),
    )
    .unwrap();
    let before = walk(&camp)
        .into_iter()
        .map(|f| std::fs::read(f).unwrap())
        .collect::<Vec<_>>();
    for cmd in ["calibrate", "diagnose"] {
        let out = stickslip(&[cmd, c, "--max-iter", "1"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {err}");
        for needle in [
            "recording d0_v1: flat channel",
            "recording d1_v0: force scale: found max |F_d| = 1.",
            "recording d1_v1: drive slope: found x_d rises at",
            "2.000 times v_d",
            "recording d2_v0: spikes",
            "1.0000e300 N",
            "--skip-implausible",
        ] {
            assert!(err.contains(needle), "{cmd}: `{needle}` missing from {err}");
        }
    }
    let json = dir.path().join("cal.json");
    let out = stickslip(&[
        "calibrate",
        c,
        "--max-iter",
        "1",
        "--skip-implausible",
        "--json",
        json.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("set aside as implausible"), "{text}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let skipped: Vec<&str> = j["skipped_implausible"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["recording"].as_str().unwrap())
        .collect();
    // d1_v0 fails the force scale and the spring (a gain of 1e6), d2_v0 the spikes and the scale.
    assert_eq!(
        skipped,
        ["d0_v1", "d1_v0", "d1_v0", "d1_v1", "d2_v0", "d2_v0"]
    );
    let after = walk(&camp)
        .into_iter()
        .map(|f| std::fs::read(f).unwrap())
        .collect::<Vec<_>>();
    assert_eq!(before, after, "the campaign changed");
}

/// Standard output redirected to a full disk (`/dev/full`) or a pipe closed by its reader:
/// the command finishes its work, writes its files, and ends with exit code 1 and a message,
/// never a panic.
#[test]
fn a_full_or_closed_standard_output_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.h5");
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args([
            "run",
            "--k-d",
            "1e4",
            "--v-d",
            "1e-3",
            "--no-trace",
            "--json",
            "-o",
        ])
        .arg(&out)
        .stdout(full)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("standard output") && !err.contains("panicked"),
        "{err}"
    );
    assert!(out.exists(), "the run's file is written all the same");
    // A reader that closes the pipe at once.
    let mut child = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["run", "--k-d", "1e4", "--v-d", "1e-3", "--no-trace", "-o"])
        .arg(dir.path().join("p.h5"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("standard output") && !err.contains("panicked"),
        "{err}"
    );
    assert!(dir.path().join("p.h5").exists());
}

/// The tier of a run: recorded in the JSON and in the run's HDF5 attributes (read by h5py),
/// chosen by `--tier` or `tier` under `[run]`; an unknown tier is refused with the allowed ones
/// named, in a flag and in a case file.
#[test]
fn the_tier_that_served_a_run_is_recorded_and_bad_tiers_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.h5");
    let o = out.to_str().unwrap();
    let base = [
        "run",
        "--f",
        "3000",
        "--va-ratio",
        "0.4",
        "--no-trace",
        "--json",
        "-o",
        o,
    ];
    let auto = stickslip(&base);
    assert!(
        auto.status.success(),
        "{}",
        String::from_utf8_lossy(&auto.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&auto.stdout).unwrap();
    assert_eq!(j["tier"], "averaged");
    assert_eq!(j["tier_reason"], "valid");
    assert_eq!(j["solver"]["tier"], "auto");
    // The reference without vibration is the full model's.
    assert_eq!(j["reference"]["tier"], "full");
    assert_eq!(j["reference"]["tier_reason"], "no_vibration");
    let check = dir.path().join("check.py");
    std::fs::write(
        &check,
        "import sys, h5py\nf = h5py.File(sys.argv[1])\nassert f.attrs['tier'] == 'averaged', f.attrs['tier']\nassert f.attrs['tier_reason'] == 'valid'\n",
    )
    .unwrap();
    let py = Command::new("python3")
        .arg(&check)
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        py.status.success(),
        "{}",
        String::from_utf8_lossy(&py.stderr)
    );
    let mut full_args = base.to_vec();
    full_args.extend(["--tier", "full"]);
    let full = stickslip(&full_args);
    let jf: serde_json::Value = serde_json::from_slice(&full.stdout).unwrap();
    assert_eq!(
        (jf["tier"].as_str(), jf["tier_reason"].as_str()),
        (Some("full"), Some("asked"))
    );
    let (ra, rf) = (j["r"].as_f64().unwrap(), jf["r"].as_f64().unwrap());
    assert!(
        (ra - rf).abs() <= 0.005,
        "r {ra} averaged against {rf} full"
    );
    // Hybrid windows asked for: said so, and the same r where the law holds throughout.
    let mut hybrid_args = base.to_vec();
    hybrid_args.extend(["--tier", "hybrid"]);
    let hybrid = stickslip(&hybrid_args);
    let jh: serde_json::Value = serde_json::from_slice(&hybrid.stdout).unwrap();
    assert_eq!(
        (jh["tier"].as_str(), jh["tier_reason"].as_str()),
        (Some("hybrid"), Some("asked_hybrid"))
    );
    let rh = jh["r"].as_f64().unwrap();
    assert!((rh - rf).abs() <= 0.005, "r {rh} hybrid against {rf} full");
    // Refused: a flag and a case file's key, each naming what is allowed.
    let mut bad = base.to_vec();
    bad.extend(["--tier", "windows"]);
    let e = stickslip(&bad);
    let msg = String::from_utf8_lossy(&e.stderr);
    assert_eq!(e.status.code(), Some(2), "{msg}");
    assert!(
        msg.contains("windows") && msg.contains("auto, averaged, hybrid, full"),
        "{msg}"
    );
    let case = dir.path().join("case.toml");
    std::fs::write(
        &case,
        "f = 3000.0\nu0 = 1e-8\n[run]\ntier = \"sometimes\"\n",
    )
    .unwrap();
    let e = stickslip(&["run", "--case", case.to_str().unwrap(), "-o", o]);
    let msg = String::from_utf8_lossy(&e.stderr);
    assert_eq!(e.status.code(), Some(2), "{msg}");
    assert!(
        msg.contains("tier")
            && msg.contains("sometimes")
            && msg.contains("auto, averaged, hybrid, full"),
        "{msg}"
    );
}

/// `plot --law CASE` tabulates the averaged friction law of the case's point: through zero at
/// V = 0 (vibration turns static friction into creep), its peak where the mean velocity reaches
/// the vibration's velocity amplitude (the averaged Coulomb law `(2 F_c/π) asin(V/v_a)` saturates
/// at `V = v_a`), and the steady friction far beyond; nodes in a CSV, the figure beside it.
#[test]
fn plot_law_draws_the_averaged_friction_curve() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("p.toml");
    std::fs::write(
        &case,
        "k_d = 11700.0\nv_d = 0.5e-3\nf = 3000.0\nv_a = 0.2e-3\n",
    )
    .unwrap();
    let stem = dir.path().join("law");
    let o = stickslip(&[
        "plot",
        "--law",
        case.to_str().unwrap(),
        "-o",
        stem.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for ext in ["png", "svg", "csv"] {
        assert!(stem.with_extension(ext).exists(), "{ext}");
    }
    let text = std::fs::read_to_string(stem.with_extension("csv")).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert!(rows.len() > 10);
    assert!(
        rows[0][0] == 0.0 && rows[0][1].abs() < 1e-3,
        "{:?}",
        rows[0]
    );
    let peak = rows.iter().max_by(|a, b| a[1].total_cmp(&b[1])).unwrap();
    assert!(
        (peak[0] / 0.2e-3 - 1.0).abs() < 0.2,
        "peak at V = {} m/s",
        peak[0]
    );
    let last = rows.last().unwrap();
    assert!(
        (last[1] - 8.3).abs() < 0.05,
        "far from V = 0 the law is F_c: {last:?}"
    );
    // A case without vibration has no law.
    std::fs::write(&case, "f = 3000.0\nu0 = 0.0\n").unwrap();
    let o = stickslip(&[
        "plot",
        "--law",
        case.to_str().unwrap(),
        "-o",
        stem.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no vibration"));
}
