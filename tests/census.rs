//! A census of bad input across every command: for each malformed input, the exit code (2 for a
//! malformed input, 1 for a file that is not what the command reads), that the message names
//! what a user needs to act (the file and line, key or flag, the value, what is allowed), that
//! nothing panicked, and that no file in the fixture folder changed: neither an input nor the
//! earlier results lying there (`prev.h5`, a finished sweep, a campaign).
//!
//! The count by outcome is printed (`cargo test --release --test census -- --nocapture`).

use std::path::{Path, PathBuf};
use std::process::Command;

/// Every regular file under `dir` (not following links; pipes and devices left out, as reading
/// them would block or never end), and every other entry by name.
fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = vec![];
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let m = std::fs::symlink_metadata(&p).unwrap();
        if m.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// The files under `dir` with their contents (regular files up to 64 MiB; larger ones by
/// length and modification time; links and special files by what they are).
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    walk(dir)
        .into_iter()
        .map(|f| {
            let m = std::fs::symlink_metadata(&f).unwrap();
            let b = if m.is_file() && m.len() <= 64 << 20 {
                std::fs::read(&f).unwrap()
            } else {
                format!("{:?} {} {:?}", m.file_type(), m.len(), m.modified().ok()).into_bytes()
            };
            (f, b)
        })
        .collect()
}

fn run(dir: &Path, args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// A plausible synthetic recording (a noisy saw-tooth, the drive at `v_d`).
fn recording(rows: usize, v_d: f64) -> String {
    let mut s = String::from("t,F_d,x_s,x_d\n");
    for i in 0..rows {
        let t = i as f64 * 1e-3;
        let noise = 0.02 * ((i * 7919 % 1000) as f64 / 500.0 - 1.0);
        s += &format!(
            "{t},{},{},{}\n",
            8.0 + 3.0 * (t * 2.0).fract() + noise,
            v_d * t - 8e-4 + 1e-7 * noise,
            v_d * t
        );
    }
    s
}

const SWEEP: &str = "name = \"s\"\n[fixed]\nk_d = 20000.0\nv_d = 1.5e-3\n[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 2]\n[run]\nt_end = 0.5\n";

#[test]
fn census_of_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let w = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, text).unwrap();
    };
    // Fixtures: good inputs, earlier results, and the bad files the cases name.
    w("s.toml", SWEEP);
    w("c.toml", "k_d = 1e4\nv_d = 1e-3\n");
    w("afile", "a text file");
    w("prev.h5", "an earlier result that must survive");
    std::fs::create_dir(d.join("outdir")).unwrap();
    // Design spaces of a plan, and a folder holding a conditions file no plan wrote.
    w("sp_key.toml", "colour = 1\n");
    w("sp_neg.toml", "max_duration = -1\n");
    w("sp_spring.toml", "springs = [0]\n");
    w("ptoml/x.toml", "v_d = 1e-3\nk_d = 1e4\n");
    // A plan's conditions file cut short mid-line.
    w(
        "pcut/p1.toml",
        "v_d = 1e-3\nk_d = 1e4\nf = 0\nu0 = 0\n\n[plan]\nduration = 2.0\nra",
    );
    // A finished sweep and a run's HDF5 file (not a sweep).
    let ok = run(
        d,
        &[
            "sweep".into(),
            "s.toml".into(),
            "-o".into(),
            "done.h5".into(),
            "-q".into(),
        ],
    );
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let ok = run(
        d,
        &[
            "run",
            "--no-trace",
            "-o",
            "run.h5",
            "--k-d",
            "20000",
            "--v-d",
            "1.5e-3",
        ]
        .map(String::from),
    );
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    // A campaign of two plausible recordings, and broken copies.
    let good = recording(400, 1e-3);
    let camp = |dir: &str, csv: &str, toml: &str| {
        w(&format!("{dir}/a.csv"), csv);
        w(&format!("{dir}/a.toml"), toml);
        w(&format!("{dir}/b.csv"), &good);
        w(
            &format!("{dir}/b.toml"),
            "v_d = 1e-3\nk_d = 1e4\nf = 0\nu0 = 0\n",
        );
    };
    let cond = "v_d = 1e-3\nk_d = 1e4\nf = 0\nu0 = 0\n";
    camp("camp", &good, cond);
    camp("c_notnum", &good.replacen("\n0.05,", "\nx,", 1), cond);
    camp("c_cr", &good.replace('\n', "\r"), cond);
    camp("c_bom2", &format!("\u{feff}\u{feff}{good}"), cond);
    camp("c_nohead", &good.replacen("t,F_d", "time,F_d", 1), cond);
    camp(
        "c_dupcol",
        &good.replacen("t,F_d,x_s,x_d", "t,F_d,x_s,F_d", 1),
        cond,
    );
    camp("c_short", &recording(50, 1e-3), cond);
    camp("c_unknown", &good, &format!("{cond}colour = 3\n"));
    camp("c_nov_d", &good, "k_d = 1e4\nf = 0\nu0 = 0\n");
    camp("c_noamp", &good, "v_d = 1e-3\nk_d = 1e4\nf = 0\n");
    camp("c_u0", &good, "v_d = 1e-3\nk_d = 1e4\nf = 1500\nu0 = 1\n");
    camp("c_kd", &good, "v_d = 1e-3\nk_d = -1\nf = 0\nu0 = 0\n");
    camp(
        "c_dead",
        &good
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i == 0 {
                    l.to_string()
                } else {
                    let c: Vec<&str> = l.split(',').collect();
                    format!("{},0,{},{}", c[0], c[2], c[3])
                }
            })
            .collect::<Vec<_>>()
            .join("\n"),
        cond,
    );
    camp(
        "c_gain",
        &good
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i == 0 {
                    l.to_string()
                } else {
                    let c: Vec<&str> = l.split(',').collect();
                    format!(
                        "{},{},{},{}",
                        c[0],
                        c[1].parse::<f64>().unwrap() * 1e6,
                        c[2],
                        c[3]
                    )
                }
            })
            .collect::<Vec<_>>()
            .join("\n"),
        cond,
    );
    camp("c_slope", &good, "v_d = 5e-4\nk_d = 1e4\nf = 0\nu0 = 0\n");
    w("c_orphan/a.csv", &good);
    w("c_empty/readme.txt", "no recordings here");
    w("c_nocsv/a.toml", cond);
    // Sweep files, each with one fault.
    let sw = |name: &str, text: &str| w(&format!("{name}.toml"), text);
    sw("unknown_key", &format!("{SWEEP}colour = 1\n"));
    sw("check_share", &format!("{SWEEP}[check]\nshare = 2.0\n"));
    sw("check_key", &format!("{SWEEP}[check]\nevery = 3\n"));
    sw("bad_tier", &format!("{SWEEP}tier = \"windows\"\n"));
    sw("bad_axis", "[[axis]]\nname = \"speed\"\nvalues = [1.0]\n");
    sw(
        "count0",
        "[[axis]]\nname = \"u0\"\nlinspace = [1e-8, 1e-6, 0]\n",
    );
    sw(
        "log0",
        "[[axis]]\nname = \"u0\"\nlogspace = [0.0, 1e-6, 4]\n",
    );
    sw("strnum", "[[axis]]\nname = \"u0\"\nvalues = [\"small\"]\n");
    sw(
        "dupaxis",
        "[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n[[axis]]\nname = \"u0\"\nvalues = [1e-7]\n",
    );
    sw("emptyvals", "[[axis]]\nname = \"u0\"\nvalues = []\n");
    sw(
        "t_end_neg",
        "[run]\nt_end = -1.0\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    sw(
        "rtol0",
        "[solver]\nrtol = 0.0\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    sw(
        "method",
        "[solver]\nmethod = \"euler\"\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    sw(
        "maxruns0",
        "max_runs = 0\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    sw(
        "refine_measure",
        "[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 3]\n[refine]\nmeasure = \"colour\"\nalong = \"u0\"\nresolution = 0.1\n",
    );
    sw(
        "refine_along",
        "[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 3]\n[refine]\nalong = \"f\"\nresolution = 0.1\n",
    );
    sw(
        "refine_res",
        "[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 3]\n[refine]\nalong = \"u0\"\nresolution = 0.0\n",
    );
    sw(
        "refine_level",
        "[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 3]\n[refine]\nalong = \"u0\"\nresolution = 0.1\nlevel = -1\n",
    );
    // Another sweep than the one done.h5 holds, and a sweep whose every run fails.
    sw("s2", &SWEEP.replace("name = \"s\"", "name = \"s2\""));
    sw("allfail", &format!("{SWEEP}[solver]\nmax_steps = 10\n"));
    sw(
        "trace_off",
        "[[axis]]\nname = \"u0\"\nvalues = [1e-8, 1e-7]\n[output]\ntraces = [{ u0 = 5.0 }]\n",
    );
    sw(
        "fixed_u0_va",
        "[fixed]\nu0 = 1e-7\n[[axis]]\nname = \"v_a\"\nvalues = [1e-4]\n",
    );
    sw(
        "fixed_and_axis",
        "[fixed]\nf = 100.0\n[[axis]]\nname = \"f\"\nvalues = [200.0]\n",
    );
    sw(
        "kd_huge",
        "[fixed]\nk_d = 1e12\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    sw("u0_1m", "[[axis]]\nname = \"u0\"\nvalues = [1.0]\n");
    sw("f_neg", "[[axis]]\nname = \"f\"\nvalues = [-5.0]\n");
    sw(
        "zip_len",
        "[[axis]]\nname = \"u0\"\nvalues = [1e-8, 1e-7]\n[[axis]]\nname = \"f\"\nvalues = [100.0]\nzip = \"u0\"\n",
    );
    sw("notoml", "[[axis\nname = \"u0\"\n");
    sw(
        "huge",
        "[[axis]]\nname = \"u0\"\nlinspace = [1e-8, 1e-6, 1000000000000000000]\n",
    );
    sw(
        "cap",
        "max_runs = 1000000000000\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    sw(
        "name_up",
        "name = \"../x\"\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    sw(
        "name_empty",
        "name = \"\"\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    sw(
        "t_end_far",
        "[run]\nt_end = 1e300\n[[axis]]\nname = \"u0\"\nvalues = [1e-8]\n",
    );
    // Case files.
    w("case_unknown.toml", "k_d = 1e4\ncolour = 2\n");
    w("case_kt.toml", "k_t = 1e300\n");
    w("case_m.toml", "m = 1e-300\n");
    w("case_u0.toml", "u0 = 1.0\nf = 100.0\n");
    w("case_both.toml", "u0 = 1e-7\nv_a = 1e-3\n");
    w("case_str.toml", "k_d = \"stiff\"\n");
    w("case_effect.toml", "[effects.aging]\nb = 2.0\n");
    w("case_noeffect.toml", "[effects.wear]\nk = 1.0\n");

    // (arguments, exit code, what the message must contain)
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<String>>();
    let cases: Vec<(Vec<String>, i32, Vec<&str>)> = vec![
        // run: flags
        (s(&["run", "--k-d", "-5"]), 2, vec!["--k-d", "-5", "> 0"]),
        (s(&["run", "--m", "0"]), 2, vec!["--m", "0"]),
        (
            s(&["run", "--m", "1e-300"]),
            2,
            vec!["--m", "1e-300", "plausible"],
        ),
        (
            s(&["run", "--k-t", "1e300"]),
            2,
            vec!["--k-t", "1e300", "1e12"],
        ),
        (
            s(&["run", "--k-d", "1e12"]),
            2,
            vec!["--k-d", "1e12", "1e9"],
        ),
        (s(&["run", "--u0", "1"]), 2, vec!["--u0", "1", "1e-2 m"]),
        (s(&["run", "--u0", "1e-7", "--f", "0"]), 2, vec!["f", "u0"]),
        (s(&["run", "--rtol", "3"]), 2, vec!["--rtol", "3"]),
        (s(&["run", "--rtol", "nan"]), 2, vec!["--rtol"]),
        (
            s(&["run", "--va-ratio", "1.2", "--f", "0"]),
            2,
            vec!["--va-ratio"],
        ),
        (s(&["run", "--va-ratio", "-1"]), 2, vec!["--va-ratio", "-1"]),
        (s(&["run", "--f-s", "5"]), 2, vec!["--f-s", "5", "F_c"]),
        (s(&["run", "--solver", "euler"]), 2, vec!["euler", "radau5"]),
        (
            s(&["run", "--t-end", "1e12", "-o", "r.h5"]),
            2,
            vec!["t-end", "1e5"],
        ),
        (
            s(&["run", "--t-end", "-1", "-o", "r.h5"]),
            2,
            vec!["t-end", "-1"],
        ),
        (s(&["run", "--t-on", "-1"]), 2, vec!["t-on", "-1"]),
        (
            s(&["run", "--effect", "wear"]),
            2,
            vec!["--effect", "wear", "aging"],
        ),
        (
            s(&["run", "--effect", "aging:b=abc"]),
            2,
            vec!["aging.b", "abc", "not a number"],
        ),
        (
            s(&["run", "--effect", "aging:b=2"]),
            2,
            vec!["aging.b = 2", "[0, 0.5]"],
        ),
        (
            s(&["run", "--effect", "aging:zz=1"]),
            2,
            vec!["aging", "zz", "allowed"],
        ),
        (
            s(&[
                "run",
                "--effect",
                "aging:b=0.01",
                "--effect",
                "aging:b=0.02",
            ]),
            2,
            vec!["aging.b", "twice", "0.01", "0.02"],
        ),
        (s(&["run", "--repeats", "0"]), 2, vec!["repeats", "0"]),
        (
            s(&["run", "--case", "/nonexistent/case.toml"]),
            2,
            vec!["/nonexistent/case.toml", "cannot read"],
        ),
        // run: outputs
        (
            s(&["run", "--case", "c.toml", "-o", "c.toml"]),
            2,
            vec!["--out", "c.toml", "input"],
        ),
        (
            s(&["run", "-o", "x.h5", "--csv", "x.h5"]),
            2,
            vec!["--csv", "x.h5", "input"],
        ),
        (
            s(&["run", "-o", "afile/run.h5"]),
            2,
            vec!["--out", "afile", "is a file"],
        ),
        (
            s(&["run", "-o", "outdir"]),
            2,
            vec!["--out", "outdir", "is a directory"],
        ),
        (
            s(&["run", "--csv", "afile/x.csv"]),
            2,
            vec!["--csv", "afile", "is a file"],
        ),
        // run: case files
        (
            s(&["run", "--case", "case_unknown.toml"]),
            2,
            vec!["case_unknown.toml:2", "colour"],
        ),
        (
            s(&["run", "--case", "case_kt.toml"]),
            2,
            vec!["case_kt.toml:1", "k_t", "1e12"],
        ),
        (
            s(&["run", "--case", "case_m.toml"]),
            2,
            vec!["case_m.toml:1", "m", "1e-4"],
        ),
        (
            s(&["run", "--case", "case_u0.toml"]),
            2,
            vec!["case_u0.toml", "u0", "1e-2"],
        ),
        (
            s(&["run", "--case", "case_both.toml"]),
            2,
            vec!["case_both.toml", "u0", "v_a"],
        ),
        (
            s(&["run", "--case", "case_str.toml"]),
            2,
            vec!["case_str.toml:1", "k_d"],
        ),
        (
            s(&["run", "--case", "case_effect.toml"]),
            2,
            vec!["case_effect.toml", "b", "[0, 0.5]"],
        ),
        (
            s(&["run", "--case", "case_noeffect.toml"]),
            2,
            vec!["case_noeffect.toml", "wear"],
        ),
        // sweep: flags
        (
            s(&["sweep", "s.toml", "--threads", "0"]),
            2,
            vec!["--threads", "0", "1 to 1024"],
        ),
        (
            s(&["sweep", "s.toml", "--checkpoint-every", "0"]),
            2,
            vec!["--checkpoint-every", "0", ">= 1"],
        ),
        (
            s(&["sweep", "s.toml", "--shard", "2/2"]),
            2,
            vec!["--shard", "2/2", "N - 1 = 1"],
        ),
        (
            s(&["sweep", "s.toml", "--shard", "x"]),
            2,
            vec!["--shard", "I/N"],
        ),
        (
            s(&["sweep", "s.toml", "--shard", "0/3"]),
            2,
            vec!["--shard", "0/3", "2 grid points"],
        ),
        (
            s(&["sweep", "s.toml", "--estimate", "--sample", "0"]),
            2,
            vec!["--sample", "from 1"],
        ),
        (
            s(&["sweep", "s.toml", "--resume", "--overwrite"]),
            2,
            vec!["--resume", "--overwrite"],
        ),
        (s(&["sweep", "missing.toml"]), 2, vec!["missing.toml"]),
        // sweep: outputs and what lies there
        (
            s(&["sweep", "s.toml", "-o", "s.toml"]),
            2,
            vec!["--out", "s.toml", "input"],
        ),
        (
            s(&["sweep", "s.toml", "-o", "outdir"]),
            2,
            vec!["--out", "is a directory"],
        ),
        (
            s(&["sweep", "s.toml", "-o", "afile/x.h5"]),
            2,
            vec!["--out", "afile", "is a file"],
        ),
        (
            s(&["sweep", "s.toml", "-o", "prev.h5", "--resume"]),
            1,
            vec!["prev.h5", "not an interrupted sweep", "no journal"],
        ),
        (
            s(&["sweep", "s.toml", "-o", "done.h5", "--resume"]),
            1,
            vec!["done.h5", "already complete"],
        ),
        // sweep files
        (
            s(&["sweep", "unknown_key.toml"]),
            2,
            vec!["unknown_key.toml", "colour"],
        ),
        (
            s(&["sweep", "check_share.toml"]),
            2,
            vec!["check_share.toml", "share", "2", "0 to 1"],
        ),
        (
            s(&["sweep", "check_key.toml"]),
            2,
            vec!["check_key.toml", "every", "share, min_points, band"],
        ),
        (
            s(&["sweep", "bad_tier.toml"]),
            2,
            vec![
                "bad_tier.toml",
                "tier",
                "windows",
                "auto, averaged, hybrid, full",
            ],
        ),
        (
            s(&["run", "--tier", "sometimes"]),
            2,
            vec!["sometimes", "auto, averaged, hybrid, full"],
        ),
        (
            s(&["bench", "--tiers", "auto", "-o", "b.h5"]),
            2,
            vec!["tiers", "auto", "full, averaged"],
        ),
        (
            s(&["plot", "--law", "missing.toml"]),
            2,
            vec!["missing.toml"],
        ),
        (
            s(&["sweep", "bad_axis.toml"]),
            2,
            vec!["bad_axis.toml:2", "speed"],
        ),
        (
            s(&["sweep", "count0.toml"]),
            2,
            vec!["count0.toml", "linspace"],
        ),
        (s(&["sweep", "log0.toml"]), 2, vec!["log0.toml", "logspace"]),
        (
            s(&["sweep", "strnum.toml"]),
            2,
            vec!["strnum.toml:3", "values"],
        ),
        (
            s(&["sweep", "dupaxis.toml"]),
            2,
            vec!["dupaxis.toml", "u0", "keep one"],
        ),
        (
            s(&["sweep", "emptyvals.toml"]),
            2,
            vec!["emptyvals.toml", "values"],
        ),
        (
            s(&["sweep", "t_end_neg.toml"]),
            2,
            vec!["t_end_neg.toml", "t_end"],
        ),
        (s(&["sweep", "rtol0.toml"]), 2, vec!["rtol0.toml", "rtol"]),
        (
            s(&["sweep", "method.toml"]),
            2,
            vec!["method.toml", "euler"],
        ),
        (
            s(&["sweep", "maxruns0.toml"]),
            2,
            vec!["maxruns0.toml", "max_runs"],
        ),
        (
            s(&["sweep", "refine_measure.toml"]),
            2,
            vec!["refine_measure.toml", "colour"],
        ),
        (
            s(&["sweep", "refine_along.toml"]),
            2,
            vec!["refine_along.toml", "along", "f"],
        ),
        (
            s(&["sweep", "refine_res.toml"]),
            2,
            vec!["refine_res.toml", "resolution"],
        ),
        (
            s(&["sweep", "refine_level.toml"]),
            2,
            vec![
                "refine_level.toml",
                "level = -1",
                "never crosses",
                "level > 0",
            ],
        ),
        (
            s(&["sweep", "s2.toml", "-o", "done.h5", "--resume", "-q"]),
            1,
            vec!["done.h5", "another sweep ('s'", "not of 's2'", "-o"],
        ),
        (
            s(&["sweep", "allfail.toml", "--estimate"]),
            1,
            vec![
                "every one of the",
                "sampled runs failed",
                "max_steps",
                "no estimate",
            ],
        ),
        (
            s(&["sweep", "trace_off.toml"]),
            2,
            vec!["trace_off.toml", "u0", "5"],
        ),
        (
            s(&["sweep", "fixed_u0_va.toml"]),
            2,
            vec!["fixed_u0_va.toml", "u0", "v_a"],
        ),
        (
            s(&["sweep", "fixed_and_axis.toml"]),
            2,
            vec!["fixed_and_axis.toml", "f"],
        ),
        (
            s(&["sweep", "kd_huge.toml"]),
            2,
            vec!["kd_huge.toml:2", "k_d", "1e9"],
        ),
        (
            s(&["sweep", "u0_1m.toml"]),
            2,
            vec!["u0_1m.toml", "u0", "1e-2"],
        ),
        (
            s(&["sweep", "f_neg.toml"]),
            2,
            vec!["f_neg.toml", "f", "-5"],
        ),
        (
            s(&["sweep", "zip_len.toml"]),
            2,
            vec!["zip_len.toml", "zip"],
        ),
        (s(&["sweep", "notoml.toml"]), 2, vec!["notoml.toml"]),
        (
            s(&["sweep", "huge.toml"]),
            2,
            vec!["linspace", "1000000000000000000", "max_runs"],
        ),
        (s(&["sweep", "cap.toml"]), 2, vec!["max_runs", "10000000"]),
        (
            s(&["sweep", "name_up.toml"]),
            2,
            vec!["name", "../x", "file stem"],
        ),
        (
            s(&["sweep", "name_empty.toml"]),
            2,
            vec!["name", "file stem"],
        ),
        (s(&["sweep", "t_end_far.toml"]), 2, vec!["t_end", "1e5"]),
        // plot, boundary, status, merge on files that are no sweep output
        (s(&["plot", "afile"]), 1, vec!["afile", "not an HDF5 file"]),
        (
            s(&["plot", "run.h5"]),
            1,
            vec!["run.h5", "not a stickslip sweep file"],
        ),
        (s(&["plot", "missing.h5"]), 1, vec!["missing.h5"]),
        (
            s(&["plot", "done.h5", "-o", "afile/fig"]),
            2,
            vec!["--out", "afile", "is a file"],
        ),
        (
            s(&["boundary", "run.h5"]),
            1,
            vec!["run.h5", "not a stickslip sweep file"],
        ),
        (
            s(&["status", "afile"]),
            1,
            vec!["afile", "not a stickslip sweep file"],
        ),
        (
            s(&["merge", "nothing.h5"]),
            1,
            vec!["no shards of", "nothing.h5"],
        ),
        (
            s(&["merge", "x.h5", "--threads", "0"]),
            2,
            vec!["--threads", "0"],
        ),
        // slurm
        (
            s(&["slurm", "s.toml", "--tasks", "3", "-o", "sl.h5"]),
            2,
            vec!["--tasks", "3", "2 grid points"],
        ),
        (
            s(&["slurm", "s.toml", "--tasks", "0", "-o", "sl.h5"]),
            2,
            vec!["--tasks", "0", "from 1"],
        ),
        (
            s(&[
                "slurm", "s.toml", "--tasks", "2", "--time", "2h", "-o", "sl.h5",
            ]),
            2,
            vec!["--time", "2h", "HH:MM:SS"],
        ),
        (
            s(&[
                "slurm",
                "s.toml",
                "--tasks",
                "2",
                "--cpus-per-task",
                "0",
                "-o",
                "sl.h5",
            ]),
            2,
            vec!["--cpus-per-task", "from 1 to 1024"],
        ),
        (
            s(&[
                "slurm",
                "s.toml",
                "--tasks",
                "2",
                "--partition",
                "a b",
                "-o",
                "sl.h5",
            ]),
            2,
            vec!["--partition", "a b", "no spaces"],
        ),
        (
            s(&["slurm", "s.toml", "--tasks", "2", "-o", "s.toml"]),
            2,
            vec!["--out", "s.toml", "input"],
        ),
        // synth
        (s(&["synth", "afile"]), 2, vec!["dir", "afile", "is a file"]),
        (
            s(&["synth", "afile/camp"]),
            2,
            vec!["dir", "afile", "is a file"],
        ),
        (
            s(&["synth", "camp"]),
            2,
            vec!["camp", "already holds recordings", "--overwrite"],
        ),
        (s(&["synth", "new", "--rate", "0"]), 2, vec!["rate", "0"]),
        (s(&["synth", "new", "--noise=-1"]), 2, vec!["noise", "-1"]),
        (
            s(&["synth", "new", "--design", "huge"]),
            2,
            vec!["design", "huge"],
        ),
        (
            s(&["synth", "new", "--effect", "wear"]),
            2,
            vec!["--effect", "wear"],
        ),
        // A load modulation that would lift the body off at the design's largest amplitude.
        (
            s(&["synth", "new", "--effect", "normal_coupling:k_n=6e7"]),
            2,
            vec!["--effect", "normal_coupling", "d4_v5", "lifts off"],
        ),
        // calibrate and diagnose: campaigns
        (
            s(&["calibrate", "c_notnum"]),
            2,
            vec!["a.csv:52", "`x` is not a number"],
        ),
        (s(&["calibrate", "c_nohead"]), 2, vec!["a.csv:1", "`t`"]),
        (
            s(&["calibrate", "c_cr"]),
            2,
            vec!["a.csv:1", "carriage return alone", "\\r\\n"],
        ),
        (
            s(&["calibrate", "c_bom2"]),
            2,
            vec!["a.csv:1", "2 byte-order marks", "one at most"],
        ),
        (
            s(&["calibrate", "camp", "--effect", "viscous:h_v=1"]),
            2,
            vec![
                "--effect",
                "`viscous` is an effect",
                "name alone",
                "--effect viscous",
            ],
        ),
        (
            s(&["calibrate", "c_dupcol"]),
            2,
            vec!["a.csv:1", "F_d", "twice"],
        ),
        (s(&["calibrate", "c_short"]), 2, vec!["a.csv", "200"]),
        (
            s(&["calibrate", "c_unknown"]),
            2,
            vec!["a.toml:5", "colour"],
        ),
        (s(&["calibrate", "c_nov_d"]), 2, vec!["a.toml", "v_d"]),
        (s(&["calibrate", "c_noamp"]), 2, vec!["a.toml", "u0", "v_a"]),
        (s(&["calibrate", "c_u0"]), 2, vec!["a.toml:4", "u0", "1e-2"]),
        (s(&["calibrate", "c_kd"]), 2, vec!["a.toml:2", "k_d", "-1"]),
        (
            s(&["calibrate", "c_orphan"]),
            2,
            vec!["a.csv", "without conditions", "a.toml"],
        ),
        (
            s(&["calibrate", "c_nocsv"]),
            2,
            vec!["a.toml", "a.csv is missing"],
        ),
        (
            s(&["calibrate", "c_empty"]),
            2,
            vec!["c_empty", "no recordings"],
        ),
        (
            s(&["calibrate", "c_dead"]),
            2,
            vec!["recording a: flat channel", "F_d", "single value"],
        ),
        (
            s(&["calibrate", "c_gain"]),
            2,
            vec!["recording a: force scale", "max |F_d|"],
        ),
        (
            s(&["calibrate", "c_slope"]),
            2,
            vec!["recording a: drive slope", "2.000 times v_d"],
        ),
        (
            s(&["diagnose", "c_dead"]),
            2,
            vec!["recording a: flat channel", "--skip-implausible"],
        ),
        (
            s(&["calibrate", "camp", "--max-iter", "0"]),
            2,
            vec!["max-iter", "0"],
        ),
        (
            s(&["calibrate", "camp", "--effect", "wear"]),
            2,
            vec!["effect", "wear"],
        ),
        (
            s(&["calibrate", "camp", "--json", "camp/a.csv"]),
            2,
            vec!["--json", "a.csv", "input"],
        ),
        (
            s(&["calibrate", "camp", "--json", "afile/x.json"]),
            2,
            vec!["--json", "afile", "is a file"],
        ),
        (
            s(&["diagnose", "camp", "--json", "camp/a.toml"]),
            2,
            vec!["--json", "a.toml", "input"],
        ),
        (
            s(&["diagnose", "camp", "--candidates", "viscous,wear"]),
            2,
            vec!["--candidates", "wear"],
        ),
        (
            s(&["diagnose", "camp", "--candidates", "viscous,aging,viscous"]),
            2,
            vec!["--candidates", "viscous", "listed twice"],
        ),
        (
            s(&["diagnose", "missing_dir"]),
            2,
            vec!["missing_dir", "no such campaign directory"],
        ),
        (
            s(&["calibrate", "afile"]),
            2,
            vec!["afile", "is a file", "directory"],
        ),
        // plan: every one refused before any diagnosis runs
        (
            s(&["plan", "camp", "--recordings", "0"]),
            2,
            vec!["--recordings", "0", "from 1 to 30"],
        ),
        (
            s(&["plan", "camp", "--recordings", "30", "--finalists", "201"]),
            2,
            vec!["--finalists", "201", "to 200"],
        ),
        (
            s(&["plan", "camp", "--space", "missing.toml"]),
            2,
            vec!["missing.toml", "cannot read"],
        ),
        (
            s(&["plan", "camp", "--space", "afile"]),
            2,
            vec!["afile:1", "not valid TOML"],
        ),
        (
            s(&["plan", "camp", "--space", "sp_key.toml"]),
            2,
            vec!["sp_key.toml", "colour", "unknown key", "max_u0"],
        ),
        (
            s(&["plan", "camp", "--space", "sp_neg.toml"]),
            2,
            vec!["sp_neg.toml", "max_duration", "-1", "3600 s"],
        ),
        (
            s(&["plan", "camp", "--space", "sp_spring.toml"]),
            2,
            vec!["sp_spring.toml", "springs", "[0]", "1e9 N/m"],
        ),
        (
            s(&["plan", "camp", "--out", "camp"]),
            2,
            vec!["--out", "camp", "the campaign itself"],
        ),
        (
            s(&["plan", "camp", "--out", "c_notnum"]),
            2,
            vec!["--out", "holds recordings", "a.csv"],
        ),
        (
            s(&["plan", "camp", "--out", "ptoml"]),
            2,
            vec!["--out", "x.toml", "which no plan wrote"],
        ),
        (
            s(&["plan", "camp", "--out", "afile"]),
            2,
            vec!["--out", "afile", "is a file"],
        ),
        (
            s(&["plan", "camp", "--json", "camp/a.toml"]),
            2,
            vec!["--json", "a.toml", "input"],
        ),
        (
            s(&["plan", "camp", "--diagnosis", "missing.json"]),
            2,
            vec!["--diagnosis", "missing.json", "no such file"],
        ),
        (
            s(&["plan", "camp", "--diagnosis", "afile"]),
            2,
            vec!["--diagnosis", "afile", "not a diagnosis JSON"],
        ),
        (
            s(&["plan", "$(touch pwned)"]),
            2,
            vec!["$(touch pwned)", "no such campaign directory"],
        ),
        // A plan's folder another process is writing (this test holds its lock): refused at
        // once, naming the holder. Folders whose names would run a command or hold a space and
        // a newline are names: each plan takes and frees their lock, then stops at the missing
        // diagnosis, leaving nothing behind.
        (
            s(&[
                "plan",
                "camp",
                "--out",
                "plocked",
                "--diagnosis",
                "missing.json",
            ]),
            2,
            vec!["--out", "plocked", "is being written by process"],
        ),
        (
            s(&[
                "plan",
                "camp",
                "--out",
                "$(touch pwned)",
                "--diagnosis",
                "missing.json",
            ]),
            2,
            vec!["--diagnosis", "missing.json", "no such file"],
        ),
        (
            s(&[
                "plan",
                "camp",
                "--out",
                "my plan\nnext",
                "--diagnosis",
                "missing.json",
            ]),
            2,
            vec!["--diagnosis", "missing.json", "no such file"],
        ),
        (
            s(&["synth", "new", "--conditions", "missing"]),
            2,
            vec!["--conditions", "missing", "no such folder"],
        ),
        (
            s(&["synth", "new", "--conditions", "afile"]),
            2,
            vec!["--conditions", "afile", "is a file"],
        ),
        (
            s(&["synth", "new", "--conditions", "pcut"]),
            2,
            vec!["p1.toml:8", "not valid TOML"],
        ),
        (
            s(&["synth", "new", "--conditions", "outdir"]),
            2,
            vec!["outdir", "no planned conditions", "[plan]"],
        ),
        // bench
        (
            s(&["bench", "--tolerances", "0", "-o", "b.h5"]),
            2,
            vec!["tolerances", "0"],
        ),
        (
            s(&["bench", "--cases", "wobbly", "-o", "b.h5"]),
            2,
            vec!["cases", "wobbly"],
        ),
        (
            s(&["bench", "--methods", "euler", "-o", "b.h5"]),
            2,
            vec!["euler"],
        ),
        (
            s(&["bench", "--repeats", "0", "-o", "b.h5"]),
            2,
            vec!["repeats", "0"],
        ),
    ];
    // Held for every case: `plocked`'s plans meet a writer that is still at work.
    let _held = stickslip::sweep::lock::acquire(&d.join("plocked")).unwrap();
    let mut failures = vec![];
    let mut by_code = std::collections::BTreeMap::<i32, usize>::new();
    for (args, code, needles) in &cases {
        let before = snapshot(d);
        let out = run(d, args);
        let err = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stderr),
            String::from_utf8_lossy(&out.stdout)
        );
        let got = out.status.code().unwrap_or(-1);
        *by_code.entry(got).or_default() += 1;
        let mut why = vec![];
        if got != *code {
            why.push(format!("exit code {got}, expected {code}"));
        }
        for n in needles {
            if !err.contains(n) {
                why.push(format!("`{n}` missing"));
            }
        }
        if err.contains("panicked") {
            why.push("panicked".into());
        }
        if snapshot(d) != before {
            why.push("changed a file".into());
        }
        if !why.is_empty() {
            failures.push(format!("{args:?}: {}\n    {}", why.join("; "), err.trim()));
        }
    }
    eprintln!(
        "census: {} malformed inputs; exit codes {:?}; {} as expected",
        cases.len(),
        by_code,
        cases.len() - failures.len()
    );
    assert!(cases.len() >= 80);
    assert!(
        failures.is_empty(),
        "{} of {} cases:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// Copies folder `from` to `to` (files only, one level).
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
        }
    }
}

/// Makes a FIFO at `p` (a pipe that blocks whoever opens it to read).
fn fifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().unwrap();
    assert!(st.success());
}

/// The second census: the paths between files and processes (shards, merges, status, Slurm
/// scripts, refinements, `t_on`, budgets, campaigns, streams and devices). Each case asserts
/// its exit code, the words of its message, no panic, no hang (a limit of 60 s), and that no
/// file in the fixture folder changed (cases marked `writes` may leave a checkpoint, never
/// replace an input or a result). Counted by outcome in the test's output.
#[test]
fn census_of_paths_between_files_and_processes() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let w = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, text).unwrap();
    };
    let ok = |args: &[&str]| {
        let o = run(d, &args.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    w("s.toml", SWEEP);
    w("prev.h5", "an earlier result that must survive");
    w("prev.csv", "an earlier trace that must survive");
    // A complete set of two shards, and damaged copies of it.
    ok(&[
        "sweep",
        "s.toml",
        "-o",
        "sh.h5",
        "--shard",
        "0/2",
        "-q",
        "--no-plot",
    ]);
    ok(&[
        "sweep",
        "s.toml",
        "-o",
        "sh.h5",
        "--shard",
        "1/2",
        "-q",
        "--no-plot",
    ]);
    let shards = d.join("sh.h5.shards");
    let runs1 = std::fs::read_to_string(shards.join("1-of-2.runs")).unwrap();
    let lines: Vec<&str> = runs1.lines().collect();
    assert!(lines.len() >= 3, "{runs1}");
    let variant = |name: &str, runs: &str| {
        let to = d.join(format!("{name}.h5.shards"));
        copy_dir(&shards, &to);
        std::fs::write(to.join("1-of-2.runs"), runs).unwrap();
    };
    variant("cut", &format!("{}\n{}\n", lines[0], lines[1]));
    variant("hdr", &format!("{}\n", lines[0]));
    variant(
        "dup",
        &std::fs::read_to_string(shards.join("0-of-2.runs")).unwrap(),
    );
    let flipped: String = {
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        // One digit of the second record changed: every field still parses.
        let k = l[2].find(" 0.5 ").expect("t_end 0.5 in the record");
        l[2].replace_range(k..k + 5, " 0.6 ");
        l.join("\n") + "\n"
    };
    variant("dmg", &flipped);
    variant("torn", &runs1[..runs1.len() - 3]);
    variant(
        "foreign",
        &runs1.replacen(
            lines[0],
            &format!("{} {}", "stickslip-journal 2", "0123456789abcdef"),
            1,
        ),
    );
    // A sweep file whose name holds a newline, and one whose stem would run a command.
    w("n\nl.toml", SWEEP);
    w("$(touch pwned).toml", SWEEP);
    // t_on and budgets.
    w(
        "ton_after.toml",
        &SWEEP.replace("[[axis]]", "t_on = 2.0\n[[axis]]"),
    );
    w(
        "ton_axis.toml",
        "[fixed]\nk_d = 20000.0\nv_d = 1.5e-3\nu0 = 1e-7\n[[axis]]\nname = \"t_on\"\nvalues = [0.1, 0.5]\n[run]\nt_end = 0.5\n",
    );
    w(
        "slowgrid.toml",
        "[fixed]\nk_d = 1e4\n[[axis]]\nname = \"v_d\"\nvalues = [1e-3, 1e-9]\n",
    );
    w(
        "periods.toml",
        "[fixed]\nk_d = 1e4\nv_d = 1e-3\nf = 4000\n[[axis]]\nname = \"u0\"\nvalues = [1e-7]\n[run]\nt_end = 1e5\n",
    );
    w(
        "refine_cap.toml",
        "max_runs = 12\n[fixed]\nk_d = 11700.0\nv_d = 0.5e-3\n[[axis]]\nname = \"f\"\nvalues = [1000.0, 2000.0]\n[[axis]]\nname = \"u0\"\nlogspace = [5e-9, 2e-6, 4]\n[refine]\nalong = \"u0\"\nacross = \"f\"\nresolution = 0.02\n",
    );
    w("case_ton.toml", "k_d = 1e4\nv_d = 1e-3\nt_on = 1.0\n");
    w(
        "case_ton_end.toml",
        "k_d = 1e4\nv_d = 1e-3\nu0 = 1e-7\nt_on = 1.0\n",
    );
    // Campaigns: one plausible recording beside each broken one.
    let good = recording(400, 1e-3);
    let cond = "v_d = 1e-3\nk_d = 1e4\nf = 0\nu0 = 0\n";
    let camp = |dir: &str, csv: Option<&str>, toml: &str| {
        if let Some(csv) = csv {
            w(&format!("{dir}/a.csv"), csv);
        }
        w(&format!("{dir}/a.toml"), toml);
        w(&format!("{dir}/b.csv"), &good);
        w(&format!("{dir}/b.toml"), cond);
    };
    camp(
        "c_ton_after",
        Some(&good),
        "v_d = 1e-3\nk_d = 1e4\nf = 1500\nu0 = 1e-7\nt_on = 1000\n",
    );
    camp("c_ton_novib", Some(&good), &format!("{cond}t_on = 0.1\n"));
    // The force twice what the spring gives (a gain of 2 on the load cell).
    let spring = |gain: f64| {
        let mut s = String::from("t,F_d,x_s,x_d\n");
        for i in 0..400 {
            let t = i as f64 * 1e-3;
            let ext = 8e-4 + 3e-4 * (t * 2.0).fract();
            let x_d = 1e-3 * t;
            s += &format!("{t},{},{},{x_d}\n", gain * 1e4 * ext, x_d - ext);
        }
        s
    };
    camp("c_gain2", Some(&spring(2.0)), cond);
    let xs_only: String = good
        .lines()
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            format!("{},{},{}", c[0], c[1], c[2])
        })
        .collect::<Vec<_>>()
        .join("\n");
    camp(
        "c_noxd_slope",
        Some(&xs_only),
        "v_d = 5e-3\nk_d = 1e4\nf = 0\nu0 = 0\n",
    );
    camp("c_fifo", None, cond);
    fifo(&d.join("c_fifo/a.csv"));
    camp("c_zero", None, cond);
    std::os::unix::fs::symlink("/dev/zero", d.join("c_zero/a.csv")).unwrap();
    let wide = format!(
        "{}\n",
        (0..300_000)
            .map(|i| format!("c{i}"))
            .collect::<Vec<_>>()
            .join(",")
    );
    camp("c_wide", Some(&wide), cond);
    camp("c_big", Some(&good), cond);
    std::fs::File::options()
        .write(true)
        .open(d.join("c_big/a.csv"))
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    // Streams and devices as inputs.
    fifo(&d.join("fifo.toml"));
    fifo(&d.join("fifo.h5"));
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.toml")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.h5")).unwrap();
    w("big.toml", "");
    std::fs::File::options()
        .write(true)
        .open(d.join("big.toml"))
        .unwrap()
        .set_len(100 << 20)
        .unwrap();
    w("camp/a.csv", &good);
    w("camp/a.toml", cond);
    w("camp/b.csv", &good);
    w("camp/b.toml", cond);

    let s = |a: &[&str]| a.iter().map(|x| x.to_string()).collect::<Vec<String>>();
    // (args, exit code, words of the message, may leave a checkpoint)
    let mut cases: Vec<(Vec<String>, i32, Vec<&str>, bool)> = vec![];
    // shard, merge, status: records that lack runs.
    for (v, word) in [
        ("cut", "lacks"),
        ("hdr", "lacks"),
        ("dup", "lacks"),
        ("dmg", "1 damaged"),
        ("torn", "1 damaged"),
    ] {
        let out = format!("{v}.h5");
        cases.push((
            s(&["merge", &out, "--no-plot"]),
            1,
            vec!["1/2", word],
            false,
        ));
        cases.push((
            s(&["merge", &out, "--sweep", "s.toml", "--no-plot"]),
            1,
            vec!["1/2", word, "--partial"],
            false,
        ));
        cases.push((
            s(&["status", &out]),
            0,
            vec!["1/2: finished but", word],
            false,
        ));
        cases.push((
            s(&[
                "sweep",
                "s.toml",
                "-o",
                &out,
                "--shard",
                "1/2",
                "-q",
                "--no-plot",
            ]),
            1,
            vec!["shard 1/2", "--resume"],
            false,
        ));
    }
    cases.push((
        s(&["merge", "foreign.h5", "--no-plot"]),
        1,
        vec!["1/2", "another sweep"],
        false,
    ));
    cases.push((
        s(&["status", "foreign.h5"]),
        1,
        vec!["1/2", "another sweep"],
        false,
    ));
    cases.push((
        s(&[
            "sweep",
            "s.toml",
            "-o",
            "foreign.h5",
            "--shard",
            "1/2",
            "--resume",
            "-q",
        ]),
        1,
        vec!["another sweep"],
        false,
    ));
    // A folder left where the merge writes its temporary file: the message names that path.
    copy_dir(&d.join("sh.h5.shards"), &d.join("stale.h5.shards"));
    std::fs::create_dir(d.join("stale.h5.tmp")).unwrap();
    cases.push((
        s(&["merge", "stale.h5", "--no-plot"]),
        1,
        vec![
            "stale.h5.tmp",
            "folder",
            "in the way",
            "remove or rename it",
        ],
        false,
    ));
    // merge: its inputs are never its output.
    cases.push((
        s(&["merge", "s.toml", "--sweep", "s.toml"]),
        2,
        vec!["s.toml", "input"],
        false,
    ));
    for f in ["0-of-2.runs", "0-of-2.h5", "1-of-2.h5.journal", "new.h5"] {
        let p = format!("sh.h5.shards/{f}");
        cases.push((
            s(&["merge", &p, "--shards", "sh.h5.shards", "--no-plot"]),
            2,
            vec!["shards' folder", "outside"],
            false,
        ));
    }
    cases.push((
        s(&[
            "merge",
            "sh.h5.shards/x/deeper.h5",
            "--shards",
            "sh.h5.shards",
        ]),
        2,
        vec!["shards' folder"],
        false,
    ));
    cases.push((
        s(&["merge", "/dev/full"]),
        2,
        vec!["/dev/full", "regular file"],
        false,
    ));
    cases.push((
        s(&["merge", "m.h5", "--sweep", "fifo.toml"]),
        2,
        vec!["fifo.toml", "not a regular file"],
        false,
    ));
    // slurm: nothing a user types runs as a command or breaks a directive.
    for (out, word) in [
        ("a\nb.h5", "control character"),
        ("a\rb.h5", "control character"),
        ("a\tb.h5", "control character"),
        ("a\u{1b}b.h5", "control character"),
        ("a\\b.h5", "backslash"),
        ("x\\/y.h5", "backslash"),
    ] {
        cases.push((
            s(&["slurm", "s.toml", "--tasks", "2", "-o", out]),
            2,
            vec!["output (-o)", word],
            false,
        ));
    }
    cases.push((
        s(&["slurm", "n\nl.toml", "--tasks", "2", "-o", "nl.h5"]),
        2,
        vec!["sweep file", "control character"],
        false,
    ));
    cases.push((
        s(&["slurm", "s.toml", "--tasks", "2", "-o", "/dev/full"]),
        2,
        vec!["/dev/full", "regular file"],
        false,
    ));
    cases.push((
        s(&["slurm", "s.toml", "--tasks", "2", "--partition", "a b"]),
        2,
        vec!["partition", "no spaces"],
        false,
    ));
    cases.push((
        s(&["slurm", "s.toml", "--tasks", "2", "--partition", "a#b"]),
        2,
        vec!["partition"],
        false,
    ));
    cases.push((
        s(&["slurm", "s.toml", "--tasks", "2", "--time", "2h"]),
        2,
        vec!["time", "2h"],
        false,
    ));
    cases.push((
        s(&["slurm", "s.toml", "--tasks", "0"]),
        2,
        vec!["tasks", "0"],
        false,
    ));
    cases.push((
        s(&["slurm", "s.toml", "--tasks", "2", "--cpus-per-task", "0"]),
        2,
        vec!["cpus-per-task", "0"],
        false,
    ));
    cases.push((
        s(&["slurm", "fifo.toml", "--tasks", "2"]),
        2,
        vec!["fifo.toml", "not a regular file"],
        false,
    ));
    // refine: max_runs bounds the refinement too.
    cases.push((
        s(&["sweep", "refine_cap.toml", "-o", "rc.h5", "-q", "--no-plot"]),
        1,
        vec!["max_runs = 12", "--resume", "journal"],
        true,
    ));
    // t_on and the work budget, checked before anything runs, by every route.
    cases.push((
        s(&["sweep", "ton_after.toml", "-o", "t.h5", "-q"]),
        2,
        vec!["t_on", "t_end = 0.5"],
        false,
    ));
    cases.push((
        s(&["sweep", "ton_axis.toml", "-o", "t.h5", "-q"]),
        2,
        vec!["grid point 1", "t_on"],
        false,
    ));
    cases.push((
        s(&["slurm", "ton_after.toml", "--tasks", "2"]),
        2,
        vec!["t_on"],
        false,
    ));
    cases.push((
        s(&["sweep", "ton_after.toml", "-o", "t.h5", "--estimate"]),
        2,
        vec!["t_on"],
        false,
    ));
    cases.push((
        s(&[
            "run", "--u0", "1e-7", "--t-on", "2", "--t-end", "1", "-o", "prev.h5",
        ]),
        2,
        vec!["t_on", "t_end = 1"],
        false,
    ));
    cases.push((
        s(&["run", "--t-on", "1", "-o", "prev.h5"]),
        2,
        vec!["--t-on", "needs vibration"],
        false,
    ));
    cases.push((
        s(&["run", "--case", "case_ton.toml", "-o", "prev.h5"]),
        2,
        vec!["t-on", "needs vibration"],
        false,
    ));
    cases.push((
        s(&[
            "run",
            "--case",
            "case_ton_end.toml",
            "--t-end",
            "0.5",
            "-o",
            "prev.h5",
        ]),
        2,
        vec!["t_on", "t_end = 0.5"],
        false,
    ));
    cases.push((
        s(&["run", "--k-d", "1e-2", "--v-d", "1e-9", "-o", "prev.h5"]),
        2,
        vec!["budget", "k_d = 0.01", "v_d"],
        false,
    ));
    cases.push((
        s(&[
            "run",
            "--k-d",
            "100",
            "--v-d",
            "1e-6",
            "--va-ratio",
            "0.5",
            "-o",
            "prev.h5",
        ]),
        2,
        vec!["budget", "k_d = 100"],
        false,
    ));
    cases.push((
        s(&[
            "run", "--u0", "1e-7", "--f", "1000", "--t-end", "1e5", "-o", "prev.h5",
        ]),
        2,
        vec!["forcing periods", "f = 1000"],
        false,
    ));
    cases.push((
        s(&["sweep", "slowgrid.toml", "-o", "t.h5", "-q"]),
        2,
        vec!["grid point 1", "budget"],
        false,
    ));
    cases.push((
        s(&["sweep", "periods.toml", "-o", "t.h5", "-q"]),
        2,
        vec!["forcing periods"],
        false,
    ));
    // A run that is not a success writes nothing.
    cases.push((
        s(&[
            "run", "--k-d", "1e4", "--v-d", "1e-3", "--t-end", "0.5", "-o", "prev.h5",
        ]),
        1,
        vec!["unsettled", "t_end >=", "prev.h5 left untouched"],
        false,
    ));
    cases.push((
        s(&[
            "run", "--k-d", "1e4", "--v-d", "1e-3", "--t-end", "0.5", "-o", "prev.h5", "--csv",
            "prev.csv",
        ]),
        1,
        vec!["unsettled", "prev.csv"],
        false,
    ));
    // Campaigns.
    for c in ["c_ton_after", "c_ton_novib", "c_gain2", "c_noxd_slope"] {
        let word = match c {
            "c_ton_after" => "after the recording's end",
            "c_ton_novib" => "no vibration",
            "c_gain2" => "spring",
            _ => "x_s rises",
        };
        cases.push((s(&["calibrate", c]), 2, vec!["recording a", word], false));
        cases.push((
            s(&["diagnose", c, "--no-plots"]),
            2,
            vec!["recording a", word],
            false,
        ));
    }
    for (c, word) in [
        ("c_fifo", "not a regular file"),
        ("c_zero", "not a regular file"),
        ("c_big", "over the limit"),
    ] {
        cases.push((s(&["calibrate", c]), 1, vec!["a.csv", word], false));
        cases.push((
            s(&["diagnose", c, "--no-plots"]),
            1,
            vec!["a.csv", word],
            false,
        ));
    }
    cases.push((
        s(&["calibrate", "c_wide"]),
        2,
        vec!["a.csv:1", "at most 256"],
        false,
    ));
    // Streams and devices.
    for f in ["fifo.toml", "zero.toml"] {
        cases.push((
            s(&["sweep", f, "-o", "t.h5"]),
            2,
            vec![f, "not a regular file"],
            false,
        ));
        cases.push((
            s(&["run", "--case", f, "-o", "t.h5"]),
            2,
            vec![f, "not a regular file"],
            false,
        ));
    }
    cases.push((
        s(&["sweep", "big.toml", "-o", "t.h5"]),
        2,
        vec!["big.toml", "over the limit"],
        false,
    ));
    for f in ["fifo.h5", "zero.h5"] {
        cases.push((s(&["plot", f]), 1, vec![f, "not a regular file"], false));
        cases.push((s(&["boundary", f]), 1, vec![f, "not a regular file"], false));
        cases.push((s(&["status", f]), 1, vec![f, "not a regular file"], false));
    }
    for (args, flag) in [
        (vec!["run", "--no-trace", "-o", "/dev/full"], "--out"),
        (vec!["run", "-o", "t.h5", "--csv", "/dev/full"], "--csv"),
        (vec!["sweep", "s.toml", "-o", "/dev/full"], "--out"),
        (vec!["calibrate", "camp", "--json", "/dev/full"], "--json"),
        (vec!["diagnose", "camp", "--json", "/dev/full"], "--json"),
    ] {
        cases.push((s(&args), 2, vec![flag, "/dev/full", "regular file"], false));
    }

    let mut failures = vec![];
    let mut by_code = std::collections::BTreeMap::<i32, usize>::new();
    for (args, code, needles, writes) in &cases {
        let before = snapshot(d);
        let mut child = Command::new(env!("CARGO_BIN_EXE_stickslip"))
            .args(args)
            .current_dir(d)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // No case may hang: a blocked read of a pipe is killed and counted.
        let t0 = std::time::Instant::now();
        while child.try_wait().unwrap().is_none() && t0.elapsed().as_secs() < 60 {
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let hung = child.try_wait().unwrap().is_none();
        if hung {
            let _ = child.kill();
        }
        let out = child.wait_with_output().unwrap();
        let err = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stderr),
            String::from_utf8_lossy(&out.stdout)
        );
        let got = out.status.code().unwrap_or(-1);
        *by_code.entry(got).or_default() += 1;
        let mut why = vec![];
        if hung {
            why.push("hung".to_string());
        }
        if got != *code {
            why.push(format!("exit code {got}, expected {code}"));
        }
        for n in needles {
            if !err.contains(n) {
                why.push(format!("`{n}` missing"));
            }
        }
        if err.contains("panicked") {
            why.push("panicked".into());
        }
        if err.contains("every shard is complete") || err.contains("sweep_status = complete") {
            why.push("reported complete".into());
        }
        let after = snapshot(d);
        if *writes {
            // Nothing there before may change; a checkpoint may be added.
            let changed = before
                .iter()
                .filter(|(p, b)| {
                    after
                        .iter()
                        .find(|(q, _)| q == p)
                        .is_none_or(|(_, a)| a != b)
                })
                .count();
            if changed > 0 {
                why.push(format!("changed {changed} file(s)"));
            }
        } else if after != before {
            why.push("changed a file".into());
        }
        if d.join("pwned").exists() {
            why.push("ran a command".into());
        }
        if !why.is_empty() {
            failures.push(format!("{args:?}: {}\n    {}", why.join("; "), err.trim()));
        }
    }
    eprintln!(
        "census of files and processes: {} cases; exit codes {:?}; {} as expected",
        cases.len(),
        by_code,
        cases.len() - failures.len()
    );
    assert!(cases.len() >= 80, "{} cases", cases.len());
    assert!(
        failures.is_empty(),
        "{} of {} cases:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// Writers that meet, as real processes: while a sweep runs, the same sweep again, with
/// `--overwrite`, with `--resume`, and the same shard twice are refused at once with the
/// holder's process id, and the running sweep's journal is left whole; after `kill -9` of the
/// holder no lock is left, and `--resume` completes the sweep with every recorded run kept.
#[test]
fn concurrent_writers_are_refused_and_kill_9_leaves_no_lock() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(
        d.join("slow.toml"),
        "[fixed]\nk_d = 11700.0\nv_d = 0.5e-3\n[[axis]]\nname = \"u0\"\nlogspace = [1e-8, 1e-6, 60]\n[[axis]]\nname = \"f\"\nvalues = [800.0, 1500.0, 3000.0]\n",
    )
    .unwrap();
    let bin = env!("CARGO_BIN_EXE_stickslip");
    let start = |args: &[&str]| {
        Command::new(bin)
            .args(args)
            .current_dir(d)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let journal = d.join("slow.h5.journal");
    let records = || {
        std::fs::read_to_string(&journal)
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0)
    };
    let wait_for = |what: &str, done: &dyn Fn() -> bool| {
        let t0 = std::time::Instant::now();
        while !done() {
            assert!(t0.elapsed().as_secs() < 120, "timed out waiting for {what}");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    };
    let mut a = start(&[
        "sweep",
        "slow.toml",
        "-o",
        "slow.h5",
        "--threads",
        "1",
        "-q",
    ]);
    wait_for("the first records", &|| records() >= 3);
    let holder = a.id().to_string();
    for extra in [&[][..], &["--overwrite"][..], &["--resume"][..]] {
        let mut args = vec!["sweep", "slow.toml", "-o", "slow.h5", "-q"];
        args.extend_from_slice(extra);
        let o = run(d, &args.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains(&format!("process {holder}")) && err.contains("slow.h5.lock"),
            "{args:?}: {err}"
        );
    }
    let before = records();
    wait_for("the holder to go on", &|| records() > before);
    // kill -9: the kernel drops the lock with the process.
    a.kill().unwrap();
    a.wait().unwrap();
    let kept = records();
    let o = run(
        d,
        &[
            "sweep",
            "slow.toml",
            "-o",
            "slow.h5",
            "--resume",
            "-q",
            "--no-plot",
        ]
        .map(String::from),
    );
    let log = String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{log}");
    assert!(
        log.contains(&format!("{kept} resumed"))
            || log.contains(&format!("{} resumed", kept.saturating_sub(1))),
        "{kept}: {log}"
    );
    assert!(
        !d.join("slow.h5.lock").exists(),
        "a clean exit removes its lock file"
    );
    // The same shard twice at once.
    let mut s1 = start(&[
        "sweep",
        "slow.toml",
        "-o",
        "sh.h5",
        "--shard",
        "0/2",
        "--threads",
        "1",
        "-q",
    ]);
    let j = d.join("sh.h5.shards/0-of-2.h5.journal");
    wait_for("the shard's first record", &|| {
        std::fs::read_to_string(&j).is_ok_and(|t| t.lines().count() > 1)
    });
    let o = run(
        d,
        &[
            "sweep",
            "slow.toml",
            "-o",
            "sh.h5",
            "--shard",
            "0/2",
            "--resume",
            "-q",
        ]
        .map(String::from),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("process {}", s1.id())), "{err}");
    // A merge onto the output while the shard runs refuses the unfinished shard; one onto a
    // shard's file is refused as an input.
    let o = run(d, &["merge", "sh.h5", "--no-plot"].map(String::from));
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not complete"));
    s1.kill().unwrap();
    s1.wait().unwrap();
}
