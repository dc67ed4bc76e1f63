//! Sweeps end to end: shipped files validate; the planner shares reference runs; 1 and 2
//! threads give identical numbers; a sweep killed with SIGKILL resumes to the same numbers; a
//! failing run is recorded and the sweep goes on; the file reads back in h5py and xarray; the
//! boundary lies where the physics puts it; shards merge into the single-machine file bit for
//! bit, and a merge names what is missing.

use rust_hdf5::H5File;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use stickslip::sweep::{self, Plan, SweepOptions, spec::SweepSpec};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stickslip"))
}

fn python(args: &[&str]) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/check_sweep.py");
    let out = Command::new("python3")
        .arg(script)
        .args(args)
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "check_sweep.py failed (install the readers: python3 -m pip install -r tests/python/requirements.txt):\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A small, fast grid: a stiff, fast drive (short cycles) over a short fixed time.
const SMALL: &str = r#"
name = "small"
[fixed]
k_d = 20000.0
v_d = 1.5e-3
[[axis]]
name = "f"
values = [300.0, 1000.0, 2000.0, 3000.0]
[[axis]]
name = "u0"
logspace = [1e-8, 1e-6, 8]
[solver]
method = "dopri5"
[run]
tier = "full"
t_end = 1.5
"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn read_all(path: &Path) -> Vec<(String, Vec<u64>)> {
    let f = H5File::open(path).unwrap();
    let mut out = vec![];
    for n in [
        "r",
        "r_stderr",
        "dF",
        "dF_stderr",
        "dF_reference",
        "mean_force",
        "stick_fraction",
        "period",
        "peak_force",
        "trough_force",
        "cycles",
        "status",
        "steps",
        "rejected",
        "rhs_evals",
    ] {
        let v = f.dataset(n).unwrap().read_raw::<f64>().unwrap();
        out.push((n.to_string(), v.iter().map(|x| x.to_bits()).collect()));
    }
    out
}

fn opts(out: &Path, threads: usize) -> SweepOptions {
    SweepOptions {
        out: out.to_path_buf(),
        threads: Some(threads),
        resume: false,
        overwrite: false,
        progress: false,
        checkpoint_every: 30.0,
        shard: None,
        tally: None,
        batch: true,
    }
}

/// h5py finds the two sweep files identical, bit for bit, but for wall times and dates.
fn same_sweep(a: &Path, b: &Path) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/compare_sweeps.py");
    let out = Command::new("python3")
        .arg(script)
        .args([a, b])
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "{} and {} differ:\n{}\n{}",
        a.display(),
        b.display(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs the program; returns (success, stdout + stderr).
fn stickslip(args: &[&str]) -> (bool, String) {
    let o = bin().args(args).output().unwrap();
    (
        o.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ),
    )
}

#[test]
fn shipped_sweeps_validate() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().and_then(|x| x.to_str()) == Some("toml") {
            let s = SweepSpec::load(&p).unwrap_or_else(|e| panic!("{e}"));
            assert!(!s.is_empty());
            n += 1;
        }
    }
    assert!(
        n >= 6,
        "expected quick, fig10, fig11a, fig11b, fig11-map and overnight"
    );
    // The shipped figures have the sizes the paper's study needs.
    let map = SweepSpec::load(&dir.join("fig11-map.toml")).unwrap();
    assert!(map.shape().iter().all(|&k| k >= 48));
    let fig10 = SweepSpec::load(&dir.join("fig10.toml")).unwrap();
    assert_eq!(fig10.shape(), vec![3, 41]);
    let overnight = SweepSpec::load(&dir.join("overnight.toml")).unwrap();
    assert_eq!(overnight.dims.len(), 4);
    assert!(overnight.len() >= 65_536);
}

/// The timing samples in `benches/overnight/` are the even and the odd indices of every axis of
/// the overnight grid, with its fixed parameters, effects, solver, run options and measures.
#[test]
fn overnight_samples_are_the_grids_two_parities() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let grid = SweepSpec::load(&root.join("sweeps/overnight.toml")).unwrap();
    for (name, parity) in [("even", 0), ("odd", 1)] {
        let s = SweepSpec::load(&root.join(format!("benches/overnight/{name}.toml"))).unwrap();
        assert_eq!(s.axes.len(), grid.axes.len(), "{name}");
        for (a, g) in s.axes.iter().zip(&grid.axes) {
            assert_eq!(a.name, g.name, "{name}");
            let want: Vec<f64> = g.values.iter().skip(parity).step_by(2).copied().collect();
            assert_eq!(a.values.len(), want.len(), "{name} {}", a.name);
            for (x, w) in a.values.iter().zip(&want) {
                assert!(
                    (x / w - 1.0).abs() < 1e-12,
                    "{name} {}: {x} against {w}",
                    a.name
                );
            }
        }
        assert_eq!(s.fixed, grid.fixed, "{name}");
        assert_eq!(s.effects, grid.effects, "{name}");
        assert_eq!(s.run, grid.run, "{name}");
        assert_eq!(s.measures, grid.measures, "{name}");
        assert_eq!(s.len() * 16, grid.len(), "{name}");
    }
}

#[test]
fn planner_runs_each_reference_once() {
    let spec =
        SweepSpec::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/fig10.toml")).unwrap();
    let plan = Plan::new(&spec);
    // One reference per v_d, whatever the size of the va_ratio axis; the va_ratio = 0 points
    // reuse it.
    assert_eq!(plan.refs.len(), 3);
    assert_eq!(plan.tasks().len(), 3 + 3 * 40);
    let map = SweepSpec::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/fig11-map.toml"))
        .unwrap();
    assert_eq!(Plan::new(&map).refs.len(), 1);
}

#[test]
fn one_and_two_threads_give_identical_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let spec = SweepSpec::parse("small.toml", SMALL).unwrap();
    let a = dir.path().join("a.h5");
    let b = dir.path().join("b.h5");
    sweep::run(&spec, &opts(&a, 1)).unwrap();
    sweep::run(&spec, &opts(&b, 2)).unwrap();
    assert_eq!(read_all(&a), read_all(&b));
}

/// The batch path (runs four at a time in vector lanes) and the scalar path write the same
/// numbers, bit for bit, on a grid and on a refinement (whose workers feed their lanes from the
/// planes' rounds as they come).
#[test]
fn batch_and_scalar_paths_give_identical_numbers() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [("small.toml", SMALL), ("refined.toml", REFINED)] {
        let spec = SweepSpec::parse(name, text).unwrap();
        let a = dir.path().join(format!("batch-{name}.h5"));
        let b = dir.path().join(format!("scalar-{name}.h5"));
        sweep::run(&spec, &opts(&a, 2)).unwrap();
        let scalar = SweepOptions {
            batch: false,
            ..opts(&b, 2)
        };
        sweep::run(&spec, &scalar).unwrap();
        assert_eq!(read_all(&a), read_all(&b), "{name}");
    }
}

#[test]
fn killed_sweep_resumes_to_the_same_numbers_and_reads_in_h5py_and_xarray() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "small.toml", SMALL);
    let killed = dir.path().join("killed.h5");
    let clean = dir.path().join("clean.h5");
    let journal = dir.path().join("killed.h5.journal");
    // A one-thread sweep, checkpointing every second; kill it once a third of its runs are in.
    let mut child = bin()
        .args([
            "sweep",
            file.to_str().unwrap(),
            "-o",
            killed.to_str().unwrap(),
            "--threads",
            "1",
            "--checkpoint-every",
            "1",
            "--no-plot",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    loop {
        let lines = std::fs::read_to_string(&journal)
            .map(|s| s.lines().count())
            .unwrap_or(0);
        if lines > 9 {
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "the sweep made no progress"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the sweep finished before it could be killed"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert!(journal.exists());
    // Without --resume the unfinished sweep is protected.
    let out = bin()
        .args([
            "sweep",
            file.to_str().unwrap(),
            "-o",
            killed.to_str().unwrap(),
            "--quiet",
        ])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("--resume"));
    // Resume, and compare with an uninterrupted two-thread run.
    let out = bin()
        .args([
            "sweep",
            file.to_str().unwrap(),
            "-o",
            killed.to_str().unwrap(),
            "--resume",
            "--quiet",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let resumed: usize = text
        .split(" resumed")
        .next()
        .unwrap()
        .rsplit(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(resumed >= 9, "{text}");
    assert!(!journal.exists(), "a complete sweep leaves no journal");
    let out = bin()
        .args([
            "sweep",
            file.to_str().unwrap(),
            "-o",
            clean.to_str().unwrap(),
            "--threads",
            "2",
            "--quiet",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(read_all(&killed), read_all(&clean));
    assert!(sweep::is_complete(&clean));
    python(&[clean.to_str().unwrap(), "f,u0", "4,8"]);
    // The sweep also drew its figures and its boundary.
    for s in [
        "clean_fig11a.png",
        "clean_fig11b.svg",
        "clean_map.png",
        "clean_boundary.csv",
    ] {
        assert!(dir.path().join(s).exists(), "{s} missing");
    }
}

#[test]
fn a_failing_run_is_recorded_and_the_sweep_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    // Too few steps for the vibrated runs at 3000 Hz, enough for the others.
    let text = SMALL.replace("[run]", "[run]\n").replace(
        "method = \"dopri5\"",
        "method = \"dopri5\"\nmax_steps = 60000",
    );
    let spec = SweepSpec::parse("fail.toml", &text).unwrap();
    let out = dir.path().join("fail.h5");
    let o = sweep::run(&spec, &opts(&out, 2)).unwrap();
    assert!(o.failed > 0 && o.failed < o.points, "{o:?}");
    let f = H5File::open(&out).unwrap();
    let status = f.dataset("status").unwrap().read_raw::<f64>().unwrap();
    let r = f.dataset("r").unwrap().read_raw::<f64>().unwrap();
    let steps = f.dataset("steps").unwrap().read_raw::<f64>().unwrap();
    for i in 0..status.len() {
        if status[i] == 2.0 {
            assert!(r[i].is_nan() && steps[i] > 0.0, "point {i}");
        } else {
            assert_eq!(status[i], 0.0);
            assert!(r[i].is_finite());
        }
    }
    assert_eq!(status.iter().filter(|&&s| s != 0.0).count(), o.failed);
}

#[test]
fn boundary_follows_the_rule_of_thumb_at_high_frequency() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"
[fixed]
k_d = 11700.0
v_d = 0.5e-3
[[axis]]
name = "f"
values = [1500.0, 3000.0]
[[axis]]
name = "u0"
logspace = [1e-8, 1e-6, 9]
[solver]
method = "dopri5"
"#;
    let spec = SweepSpec::parse("b.toml", text).unwrap();
    let out = dir.path().join("b.h5");
    sweep::run(&spec, &opts(&out, 2)).unwrap();
    let (csv, pts) = sweep::boundary::run(&out).unwrap();
    assert_eq!(pts.len(), 2);
    for p in &pts {
        // Fig. 11 at 1500 Hz and above: the boundary lies near v_a = v_d.
        assert!(p.u0.is_finite() && !p.below_range, "{p:?}");
        assert!(p.va_ratio > 0.7 && p.va_ratio < 1.6, "{p:?}");
    }
    assert!(
        pts[1].u0 < pts[0].u0,
        "higher frequency, smaller amplitude: {pts:?}"
    );
    let text = std::fs::read_to_string(csv).unwrap();
    assert!(text.starts_with("f,u0_boundary [m]"), "{text}");
    // The group is in the HDF5 file too.
    let f = H5File::open(&out).unwrap();
    let u = f.dataset("boundary/u0").unwrap().read_raw::<f64>().unwrap();
    assert_eq!(u, pts.iter().map(|p| p.u0).collect::<Vec<_>>());
}

#[test]
fn bad_sweep_files_are_rejected_with_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bad.toml",
        "[[axis]]\nname = \"v_d\"\nlinspace = [1e-3, 2e-3]\n",
    );
    let out = bin().args(["sweep", p.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.toml:3")
            && err.contains("axis[0].linspace")
            && err.contains("[start, stop, count]"),
        "{err}"
    );
}

/// The small grid refined along u0: a coarse grid of 5 amplitudes whose steps are halved three
/// times (dense axis of 33) where r straddles 0.05 or comes within 0.04 of it.
const REFINED: &str = r#"
name = "refined"
[fixed]
k_d = 20000.0
v_d = 1.5e-3
[[axis]]
name = "f"
values = [300.0, 1000.0, 2000.0, 3000.0]
[[axis]]
name = "u0"
logspace = [1e-8, 1e-6, 5]
[refine]
along = "u0"
across = "f"
resolution = 0.16
tolerance = 0.04
[solver]
method = "dopri5"
[run]
tier = "full"
t_end = 1.5
"#;

/// The same grid, dense: u0 on the refined sweep's 33 values, every point run.
const DENSE: &str = r#"
name = "dense"
[fixed]
k_d = 20000.0
v_d = 1.5e-3
[[axis]]
name = "f"
values = [300.0, 1000.0, 2000.0, 3000.0]
[[axis]]
name = "u0"
logspace = [1e-8, 1e-6, 33]
[solver]
method = "dopri5"
[run]
tier = "full"
t_end = 1.5
"#;

/// A refinement runs part of the dense grid: the coarse grid and the steps near r = 0.05. Its
/// points are the dense sweep's to the bit (every run is independent and deterministic), the
/// other points are NaN with `computed` 0, and its boundary (both edges, the crossings and the
/// resolution reached) is the dense grid's. One and two threads give the same points and
/// numbers; the file reads in h5py and xarray.
#[test]
fn refinement_runs_the_points_near_the_level_and_finds_the_dense_boundary() {
    let dir = tempfile::tempdir().unwrap();
    let spec = SweepSpec::parse("refined.toml", REFINED).unwrap();
    let rf = spec.refine.as_ref().unwrap();
    assert_eq!((rf.levels, rf.coarse), (3, 5));
    assert_eq!(spec.shape(), vec![4, 33]);
    let dense = SweepSpec::parse("dense.toml", DENSE).unwrap();
    // The dense axis is the dense sweep's, value for value (both computed by index).
    assert_eq!(spec.axes[1].values, dense.axes[1].values);
    let a = dir.path().join("a.h5");
    let b = dir.path().join("b.h5");
    let d = dir.path().join("d.h5");
    let ra = sweep::run(&spec, &opts(&a, 1)).unwrap();
    let rb = sweep::run(&spec, &opts(&b, 2)).unwrap();
    let rd = sweep::run(&dense, &opts(&d, 2)).unwrap();
    assert_eq!(read_all(&a), read_all(&b));
    assert!(
        ra.runs_made < rd.runs_made,
        "{} vs {}",
        ra.runs_made,
        rd.runs_made
    );
    assert_eq!(ra.runs_made, rb.runs_made);
    let fa = H5File::open(&a).unwrap();
    let fd = H5File::open(&d).unwrap();
    let computed = fa.dataset("computed").unwrap().read_raw::<f64>().unwrap();
    let done = computed.iter().filter(|&&c| c == 1.0).count();
    assert_eq!(done + 1, ra.runs_made, "points plus the one reference");
    for n in ["r", "dF", "mean_force", "steps"] {
        let x = fa.dataset(n).unwrap().read_raw::<f64>().unwrap();
        let y = fd.dataset(n).unwrap().read_raw::<f64>().unwrap();
        for k in 0..x.len() {
            if computed[k] == 1.0 {
                assert_eq!(x[k].to_bits(), y[k].to_bits(), "{n} at {k}");
            } else {
                assert!(x[k].is_nan(), "{n} at {k} not run but {}", x[k]);
            }
        }
    }
    drop((fa, fd));
    let ba = sweep::boundary::run(&a).unwrap().1;
    let bd = sweep::boundary::run(&d).unwrap().1;
    let mut crossed = 0;
    for (p, q) in ba.iter().zip(&bd) {
        let same = |x: f64, y: f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
        // The refinement runs a subset of the dense points with the same numbers: it may miss
        // a dip narrower than the steps it does not refine, never invent one. At 3000 Hz the
        // dense line dips below 0.05 at one amplitude between two of 0.08; it is found because
        // the coarse value 0.082 lies within the tolerance of the level.
        assert!(same(p.u0_upper, q.u0_upper), "{p:?} vs {q:?}");
        assert!(p.crossings <= q.crossings, "{p:?} vs {q:?}");
        assert!(p.u0 >= q.u0 || p.u0.is_nan(), "{p:?} vs {q:?}");
        assert!(same(p.u0, q.u0), "{p:?} vs {q:?}");
        assert_eq!(p.crossings, q.crossings, "{p:?} vs {q:?}");
        if p.u0.is_finite() && !p.below_range {
            crossed += 1;
            // The finest step of the dense axis: (1e-6/1e-8)^(1/32) - 1 = 15.5 %.
            assert!(p.resolution < 0.16, "{p:?}");
        }
    }
    assert!(crossed >= 2, "{ba:?}");
    python(&[a.to_str().unwrap(), "f,u0", "4,33"]);
}

/// Two refinements of the same 3 % sweep give the same boundary line by line: both edges to the
/// bit and the same crossings; every line crossing within the range is resolved below 3 % (to
/// the same resolution in both where `same_resolution`). Returns how many lines cross.
fn same_edges(
    ba: &[sweep::boundary::BoundaryPoint],
    bb: &[sweep::boundary::BoundaryPoint],
    same_resolution: bool,
) -> usize {
    assert_eq!(ba.len(), bb.len());
    let same = |x: f64, y: f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
    let mut crossed = 0;
    for (p, q) in ba.iter().zip(bb) {
        assert!(
            same(p.u0, q.u0) && same(p.u0_upper, q.u0_upper),
            "{p:?} vs {q:?}"
        );
        assert_eq!(p.crossings, q.crossings, "{p:?} vs {q:?}");
        if p.u0.is_finite() && !p.below_range {
            crossed += 1;
            assert!(p.resolution < 0.03, "{p:?}");
            assert!(
                !same_resolution || same(p.resolution, q.resolution),
                "{p:?} vs {q:?}"
            );
        }
    }
    crossed
}

/// Nine frequencies refined along u0 to 3 % (coarse steps of a factor of 10 halved seven
/// times), guided or with every column halving alone.
fn nine_columns(guided: bool) -> String {
    format!(
        r#"
name = "nine"
[fixed]
k_d = 20000.0
v_d = 1.5e-3
[[axis]]
name = "f"
logspace = [500.0, 4000.0, 9]
[[axis]]
name = "u0"
logspace = [1e-8, 1e-5, 4]
[refine]
along = "u0"
across = "f"
resolution = 0.03
guided = {guided}
[solver]
method = "dopri5"
[run]
t_end = 1.5
"#
    )
}

/// Guided columns start where their neighbours cross the level: the same boundary as columns
/// that halve their steps alone, every crossing resolved to the same dense step, from fewer runs
/// (each halving alone takes seven per column; a guided column whose prediction holds, two). The
/// points both make carry the same numbers, and `guided = 1` is refused by name.
#[test]
fn guided_columns_find_the_halved_boundary_with_fewer_runs() {
    let dir = tempfile::tempdir().unwrap();
    let g = SweepSpec::parse("g.toml", &nine_columns(true)).unwrap();
    let h = SweepSpec::parse("h.toml", &nine_columns(false)).unwrap();
    assert_eq!(h.refine.as_ref().unwrap().levels, 7);
    let (a, b) = (dir.path().join("g.h5"), dir.path().join("h.h5"));
    let ra = sweep::run(&g, &opts(&a, 2)).unwrap();
    let rb = sweep::run(&h, &opts(&b, 2)).unwrap();
    let ba = sweep::boundary::run(&a).unwrap().1;
    let bb = sweep::boundary::run(&b).unwrap().1;
    assert_eq!(ba.len(), 9);
    let crossed = same_edges(&ba, &bb, true);
    assert!(crossed >= 6, "{ba:?}");
    // Halving alone: the coarse points and seven runs per crossing column at least.
    assert!(rb.runs_made >= 1 + 9 * 4 + 7 * crossed, "{}", rb.runs_made);
    // 79 against 104 runs.
    assert!(
        5 * ra.runs_made <= 4 * rb.runs_made,
        "guided {} vs halved {}",
        ra.runs_made,
        rb.runs_made
    );
    let fa = H5File::open(&a).unwrap();
    let fb = H5File::open(&b).unwrap();
    let ca = fa.dataset("computed").unwrap().read_raw::<f64>().unwrap();
    let cb = fb.dataset("computed").unwrap().read_raw::<f64>().unwrap();
    let ya = fa.dataset("r").unwrap().read_raw::<f64>().unwrap();
    let yb = fb.dataset("r").unwrap().read_raw::<f64>().unwrap();
    let both = (0..ca.len())
        .filter(|&k| ca[k] == 1.0 && cb[k] == 1.0)
        .count();
    assert!(both >= 9 * 4, "{both}");
    for k in (0..ca.len()).filter(|&k| ca[k] == 1.0 && cb[k] == 1.0) {
        assert_eq!(ya[k].to_bits(), yb[k].to_bits(), "r at {k}");
    }
    let err = SweepSpec::parse(
        "bad.toml",
        &nine_columns(true).replace("guided = true", "guided = 1"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("guided") && err.contains("true or false"),
        "{err}"
    );
}

/// Five drive stiffnesses and three frequencies at two drive velocities, refined along u0 to
/// 3 %: ten `(f, u0)` planes, with or without `guide_planes = "k_d"`.
fn stiffness_planes(guide: bool) -> String {
    let g = if guide { "guide_planes = \"k_d\"" } else { "" };
    format!(
        r#"
name = "stiffness-planes"
[[axis]]
name = "v_d"
values = [1.0e-3, 1.5e-3]
[[axis]]
name = "k_d"
logspace = [5000.0, 20000.0, 5]
[[axis]]
name = "f"
logspace = [500.0, 4000.0, 3]
[[axis]]
name = "u0"
logspace = [1e-8, 1e-5, 4]
[refine]
along = "u0"
across = "f"
resolution = 0.03
{g}
[solver]
method = "dopri5"
[run]
t_end = 1.5
"#
    )
}

/// Planes along `guide_planes` start every column where the same column of the planes on
/// either side crosses: the same boundary as planes refined alone, from fewer runs; the two
/// groups of planes (one per drive velocity) run as two shards and merge into the single
/// machine's file bit for bit; three shards, and `guide_planes` naming a side of the plane,
/// no dimension, or with `guided = false`, are refused by name.
#[test]
fn planes_guided_along_the_stiffness_find_the_same_boundary_with_fewer_runs() {
    let dir = tempfile::tempdir().unwrap();
    let g = SweepSpec::parse("g.toml", &stiffness_planes(true)).unwrap();
    let h = SweepSpec::parse("h.toml", &stiffness_planes(false)).unwrap();
    assert_eq!(sweep::refine::plane_count(&g), 10);
    // The planes at the ends of k_d refine alone; the middle one (2) is guided by them, the
    // quarters (1, 3) by an end and the middle.
    let guides: Vec<_> = (0..5).map(|p| sweep::refine::plane_guides(&g, p)).collect();
    assert_eq!(
        guides,
        [None, Some((0, 2)), Some((0, 4)), Some((2, 4)), None]
    );
    assert_eq!(sweep::refine::plane_guides(&g, 7), Some((5, 9)));
    assert!((0..10).all(|p| sweep::refine::plane_guides(&h, p).is_none()));
    let (a, b) = (dir.path().join("g.h5"), dir.path().join("h.h5"));
    let ra = sweep::run(&g, &opts(&a, 2)).unwrap();
    let rb = sweep::run(&h, &opts(&b, 2)).unwrap();
    let ba = sweep::boundary::run(&a).unwrap().1;
    let bb = sweep::boundary::run(&b).unwrap().1;
    assert_eq!(ba.len(), 30);
    let crossed = same_edges(&ba, &bb, false);
    assert!(crossed >= 20, "{ba:?}");
    assert!(
        ra.runs_made < rb.runs_made,
        "{} vs {}",
        ra.runs_made,
        rb.runs_made
    );
    // Per plane (v_d, k_d), in C order: the planes at the ends of k_d refine alone, exactly as
    // without guide_planes; the six between make fewer refinement runs (12 coarse points each).
    let computed = |path: &Path| {
        let f = H5File::open(path).unwrap();
        f.dataset("computed").unwrap().read_raw::<f64>().unwrap()
    };
    let (ca, cb) = (computed(&a), computed(&b));
    let per = ca.len() / 10;
    let runs = |c: &[f64], p: usize| {
        c[p * per..(p + 1) * per]
            .iter()
            .filter(|&&x| x == 1.0)
            .count()
    };
    for p in [0, 4, 5, 9] {
        assert_eq!(
            ca[p * per..(p + 1) * per],
            cb[p * per..(p + 1) * per],
            "plane {p}"
        );
    }
    let refined = |c: &[f64]| {
        [1, 2, 3, 6, 7, 8]
            .iter()
            .map(|&p| runs(c, p) - 12)
            .sum::<usize>()
    };
    let (ga, gb) = (refined(&ca), refined(&cb));
    // 129 against 152: here the boundary moves by up to 90 dense steps from k_d = 5000 to
    // 20 000 N/m, so the interpolation misses by a few steps (the overnight surface's moves by
    // a few).
    assert!(10 * ga <= 9 * gb, "guided planes {ga} vs alone {gb}");
    // Two shards, one group of five planes each, merged: the single machine's file.
    let file = write(dir.path(), "g.toml", &stiffness_planes(true));
    let merged = dir.path().join("merged.h5");
    let m = merged.to_str().unwrap();
    for i in 0..2 {
        let (ok, log) = stickslip(&[
            "sweep",
            file.to_str().unwrap(),
            "-o",
            m,
            "--shard",
            &format!("{i}/2"),
            "-q",
        ]);
        assert!(ok, "{log}");
    }
    let (ok, log) = stickslip(&["merge", m]);
    assert!(ok, "{log}");
    same_sweep(&a, &merged);
    let owners = sweep::shard::owners(&g, 2);
    let (plane, _) = sweep::shard::planes(&g);
    for i in 0..owners.len() {
        // Plane p lies at v_d index p / 5: a shard owns whole drive velocities.
        assert_eq!(
            owners[i],
            owners[if plane[i] < 5 { 0 } else { owners.len() - 1 }]
        );
    }
    let (ok, log) = stickslip(&["sweep", file.to_str().unwrap(), "-o", m, "--shard", "0/3"]);
    assert!(
        !ok && log.contains("3 shards") && log.contains("groups of planes"),
        "{log}"
    );
    let text = stiffness_planes(true);
    for (bad, words) in [
        (
            "guide_planes = \"f\"",
            &["guide_planes", "`f`", "side of the refined plane"][..],
        ),
        (
            "guide_planes = \"h_d\"",
            &["guide_planes", "`h_d`", "not a dimension"],
        ),
        (
            "guide_planes = \"k_d\"\nguided = false",
            &["guide_planes", "guided = true"],
        ),
    ] {
        let err = SweepSpec::parse("bad.toml", &text.replace("guide_planes = \"k_d\"", bad))
            .unwrap_err()
            .to_string();
        assert!(words.iter().all(|w| err.contains(w)), "{err}");
    }
}

/// A refinement killed with SIGKILL resumes from its journal to the same points and numbers.
#[test]
fn killed_refinement_resumes_to_the_same_points_and_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "refined.toml", REFINED);
    let killed = dir.path().join("killed.h5");
    let clean = dir.path().join("clean.h5");
    let journal = dir.path().join("killed.h5.journal");
    let sweep_args = |out: &Path, extra: &[&str]| {
        let mut c = bin();
        c.args([
            "sweep",
            file.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--no-plot",
        ])
        .args(extra);
        c
    };
    let mut child = sweep_args(&killed, &["--threads", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    // Past the coarse grid (20 points and the reference), into the refinement.
    loop {
        let lines = std::fs::read_to_string(&journal)
            .map(|s| s.lines().count())
            .unwrap_or(0);
        if lines > 24 {
            break;
        }
        assert!(t0.elapsed() < Duration::from_secs(120), "no progress");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the sweep finished before it could be killed"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    // `status` reads the interrupted sweep from its checkpoint and journal: the coarse grid's 21
    // runs are planned, more recorded than that.
    let st = bin()
        .args(["status", killed.to_str().unwrap()])
        .output()
        .unwrap();
    let st = String::from_utf8_lossy(&st.stdout);
    assert!(st.contains("in progress or interrupted"), "{st}");
    assert!(
        st.contains("on one machine: running or interrupted"),
        "{st}"
    );
    assert!(st.contains(" of 21 runs recorded"), "{st}");
    let out = sweep_args(&killed, &["--resume", "--quiet"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = sweep_args(&clean, &["--threads", "2", "--quiet"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(read_all(&killed), read_all(&clean));
    let c = |p: &Path| {
        H5File::open(p)
            .unwrap()
            .dataset("computed")
            .unwrap()
            .read_raw::<f64>()
            .unwrap()
    };
    assert_eq!(c(&killed), c(&clean));
}

/// SMALL with a trace point and a second drive velocity: two references, two planes.
const SHARDED: &str = r#"
name = "sharded"
[fixed]
k_d = 20000.0
[[axis]]
name = "v_d"
values = [1.5e-3, 2.0e-3]
[[axis]]
name = "f"
values = [300.0, 1000.0, 2000.0, 3000.0]
[[axis]]
name = "u0"
logspace = [1e-8, 1e-6, 5]
[solver]
method = "dopri5"
[run]
tier = "full"
t_end = 1.5
[output]
traces = [{ v_d = 2.0e-3, f = 1000.0, u0 = 1e-6 }]
"#;

/// Shards run apart (3 processes) and merged equal the single-machine run bit for bit, as h5py
/// reads them: datasets, traces, boundary, attributes (wall times and dates aside); `status`
/// follows them; each shard holds about a third of the points, from every part of the grid.
#[test]
fn shards_merge_into_the_single_machine_file_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "sharded.toml", SHARDED);
    let f = file.to_str().unwrap();
    let single = dir.path().join("single.h5");
    let merged = dir.path().join("merged.h5");
    let (ok, log) = stickslip(&["sweep", f, "-o", single.to_str().unwrap(), "-q"]);
    assert!(ok, "{log}");
    let m = merged.to_str().unwrap();
    let children: Vec<_> = (0..3)
        .map(|i| {
            bin()
                .args([
                    "sweep",
                    f,
                    "-o",
                    m,
                    "--shard",
                    &format!("{i}/3"),
                    "--threads",
                    "1",
                    "-q",
                ])
                .output()
                .unwrap()
        })
        .collect();
    for c in &children {
        assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
    }
    let (ok, st) = stickslip(&["status", m]);
    assert!(ok, "{st}");
    assert!(st.contains("shards: 3 of 3 complete"), "{st}");
    assert!(st.contains("stickslip merge"), "{st}");
    // Every shard owns a third of the 40 points, spread over both drive velocities.
    let spec = SweepSpec::parse("sharded.toml", SHARDED).unwrap();
    let owners = sweep::shard::owners(&spec, 3);
    for k in 0..3 {
        let mine: Vec<usize> = (0..40).filter(|&i| owners[i] == k).collect();
        assert!((13..=14).contains(&mine.len()), "{mine:?}");
        assert!(
            mine.iter().any(|&i| i < 20) && mine.iter().any(|&i| i >= 20),
            "{mine:?}"
        );
    }
    let (ok, log) = stickslip(&["merge", m]);
    assert!(ok, "{log}");
    assert!(log.contains("3 shards merged"), "{log}");
    same_sweep(&single, &merged);
    assert!(sweep::is_complete(&merged));
    // The shards copied into a folder of their own (as from several hosts) merge alike.
    let copied = dir.path().join("copied");
    std::fs::create_dir(&copied).unwrap();
    for e in std::fs::read_dir(dir.path().join("merged.h5.shards")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), copied.join(e.file_name())).unwrap();
    }
    let elsewhere = dir.path().join("elsewhere.h5");
    let (ok, log) = stickslip(&[
        "merge",
        elsewhere.to_str().unwrap(),
        "--shards",
        copied.to_str().unwrap(),
    ]);
    assert!(ok, "{log}");
    same_sweep(&single, &elsewhere);
    let (ok, st) = stickslip(&["status", m]);
    assert!(ok && st.contains(": complete"), "{st}");
    // A shard run again is complete and makes nothing.
    let (ok, log) = stickslip(&["sweep", f, "-o", m, "--shard", "1/3", "--resume"]);
    assert!(ok && log.contains("0 runs made"), "{log}");
}

/// A merge refuses missing, unfinished, foreign and mixed shards, naming them; `--partial`
/// writes what there is, the missing shard's points NaN, `sweep_status = "partial"`.
#[test]
fn merge_names_missing_unfinished_and_foreign_shards() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "sharded.toml", SHARDED);
    let f = file.to_str().unwrap();
    let out = dir.path().join("m.h5");
    let m = out.to_str().unwrap();
    let (ok, log) = stickslip(&["merge", m]);
    assert!(!ok && log.contains("no shards of"), "{log}");
    for i in [0, 2] {
        let (ok, log) = stickslip(&["sweep", f, "-o", m, "--shard", &format!("{i}/3"), "-q"]);
        assert!(ok, "{log}");
    }
    let (ok, log) = stickslip(&["merge", m, "--no-plot"]);
    assert!(!ok, "{log}");
    assert!(log.contains("shard 1/3 is missing"), "{log}");
    assert!(log.contains("--partial"), "{log}");
    assert!(!out.exists());
    let (ok, st) = stickslip(&["status", m]);
    assert!(ok && st.contains("1/3: not started"), "{st}");
    // An unfinished shard: its journal, as a kill leaves it.
    let shard1 = sweep::shard::Shard { index: 1, count: 3 }.path(&out);
    let jpath = sweep::journal::path_for(&shard1);
    let fp = sweep::journal::fingerprint(&SweepSpec::parse("s", SHARDED).unwrap().text);
    std::fs::write(&jpath, sweep::journal::header(&fp) + "\n").unwrap();
    let (ok, log) = stickslip(&["merge", m, "--no-plot"]);
    assert!(
        !ok && log.contains("shard 1/3 is unfinished (0 runs recorded"),
        "{log}"
    );
    let (ok, log) = stickslip(&["merge", m, "--no-plot", "--partial"]);
    assert!(ok, "{log}");
    assert!(log.contains("1 missing or unfinished: 1/3"), "{log}");
    let h = H5File::open(&out).unwrap();
    assert_eq!(h.attr_string("sweep_status").unwrap(), "partial");
    let computed = h.dataset("computed").unwrap().read_raw::<f64>().unwrap();
    let r = h.dataset("r").unwrap().read_raw::<f64>().unwrap();
    let spec = SweepSpec::parse("sharded.toml", SHARDED).unwrap();
    let owners = sweep::shard::owners(&spec, 3);
    for i in 0..40 {
        assert_eq!(computed[i] == 1.0, owners[i] != 1, "point {i}");
        assert_eq!(r[i].is_nan(), owners[i] == 1, "point {i}: r = {}", r[i]);
    }
    drop(h);
    // A shard of another sweep file (another t_end) is refused by name.
    std::fs::remove_file(&jpath).unwrap();
    let other = write(
        dir.path(),
        "other.toml",
        &SHARDED.replace("t_end = 1.5", "t_end = 1.4"),
    );
    let (ok, log) = stickslip(&[
        "sweep",
        other.to_str().unwrap(),
        "-o",
        m,
        "--shard",
        "1/3",
        "-q",
    ]);
    assert!(ok, "{log}");
    let (ok, log) = stickslip(&["merge", m, "--no-plot", "--sweep", f]);
    assert!(
        !ok && log.contains("shard 1/3 was not made from this sweep file"),
        "{log}"
    );
    // Shards of two splits side by side.
    let (ok, log) = stickslip(&["sweep", f, "-o", m, "--shard", "0/2", "-q"]);
    assert!(ok, "{log}");
    let (ok, log) = stickslip(&["merge", m]);
    assert!(!ok && log.contains("N = 2, 3"), "{log}");
    // Bad shard flags name the rule.
    for (bad, want) in [
        ("3/3", "I must be from 0 to N - 1 = 2"),
        ("0/41", "has 40 grid points"),
    ] {
        let (ok, log) = stickslip(&["sweep", f, "-o", m, "--shard", bad]);
        assert!(!ok && log.contains(want), "{bad}: {log}");
    }
}

/// A [refine] sweep is sharded by plane (here one per drive velocity): the merged file equals
/// the single-machine refinement, computed points included; more shards than planes are
/// refused.
#[test]
fn refinement_shards_by_plane() {
    let dir = tempfile::tempdir().unwrap();
    let text = SHARDED
        .replace("name = \"sharded\"", "name = \"planes\"")
        .replace(
            "[solver]",
            "[refine]\nalong = \"u0\"\nacross = \"f\"\nresolution = 0.3\ntolerance = 0.04\n[solver]",
        )
        .replace("logspace = [1e-8, 1e-6, 5]", "logspace = [1e-8, 1e-6, 3]");
    let file = write(dir.path(), "planes.toml", &text);
    let f = file.to_str().unwrap();
    let single = dir.path().join("single.h5");
    let merged = dir.path().join("merged.h5");
    let m = merged.to_str().unwrap();
    let (ok, log) = stickslip(&[
        "sweep",
        f,
        "-o",
        single.to_str().unwrap(),
        "-q",
        "--no-plot",
    ]);
    assert!(ok, "{log}");
    for i in 0..2 {
        let (ok, log) = stickslip(&["sweep", f, "-o", m, "--shard", &format!("{i}/2"), "-q"]);
        assert!(ok, "{log}");
    }
    let (ok, log) = stickslip(&["merge", m, "--no-plot"]);
    assert!(ok, "{log}");
    same_sweep(&single, &merged);
    let (ok, log) = stickslip(&["sweep", f, "-o", m, "--shard", "0/3"]);
    assert!(!ok && log.contains("sharded by plane"), "{log}");
}

/// `--estimate` on a sample as large as the sweep predicts exactly the sweep's runs and their
/// summed cost (no extrapolation, no error); a small sample predicts the run count exactly.
#[test]
fn estimate_from_the_whole_sweep_is_exact() {
    let spec = SweepSpec::parse("sharded.toml", SHARDED).unwrap();
    let plan = Plan::new(&spec);
    let e = sweep::estimate::estimate(&spec, 1000, Some(2)).unwrap();
    assert_eq!(e.sampled, 40);
    assert_eq!(e.sample_runs, plan.tasks().len());
    assert_eq!(e.runs, plan.tasks().len() as f64);
    assert_eq!(e.cpu_stderr, 0.0);
    assert!(e.cpu > 0.0 && e.cpu < 2.0 * e.sample_wall + 1.0, "{e}");
    let small = sweep::estimate::estimate(&spec, 8, Some(2)).unwrap();
    assert!(small.sampled >= 8 && small.sampled <= 10, "{small}");
    assert_eq!(small.runs, plan.tasks().len() as f64);
    assert!(
        small.cpu_stderr.is_finite() && small.cpu_stderr > 0.0,
        "{small}"
    );
    assert!(format!("{small}").contains("--time"), "{small}");
}

/// A `[refine]` sweep is estimated by whole planes: sampling both planes of a two-plane sweep
/// gives its exact runs and cost; sampling one predicts twice that plane's runs.
#[test]
fn estimate_of_a_refinement_samples_whole_planes() {
    let text = SHARDED
        .replace("name = \"sharded\"", "name = \"planes\"")
        .replace(
            "[solver]",
            "[refine]\nalong = \"u0\"\nacross = \"f\"\nresolution = 0.3\ntolerance = 0.04\n[solver]",
        )
        .replace("logspace = [1e-8, 1e-6, 5]", "logspace = [1e-8, 1e-6, 3]");
    let spec = SweepSpec::parse("planes.toml", &text).unwrap();
    let all = sweep::estimate::estimate(&spec, 2, Some(2)).unwrap();
    assert_eq!((all.sampled, all.units), (2, 2), "{all}");
    assert_eq!(all.cpu_stderr, 0.0);
    assert_eq!(all.runs, all.sample_runs as f64);
    let one = sweep::estimate::estimate(&spec, 1, Some(2)).unwrap();
    assert_eq!(one.sampled, 1, "{one}");
    assert_eq!(one.runs, 2.0 * one.sample_runs as f64);
    assert!(one.cpu_stderr.is_nan(), "{one}");
    assert!(format!("{one}").contains("no spread known"), "{one}");
}

/// Two drives on a slide near its stability limit: at 2000 Hz, `u0` = 79 nm, `v_d` = 1.1 mm/s the
/// averaged law peaks within 0.1 % of `v_d` (`stickslip plot --law`: slope 14 N s/m there), so
/// the slow model slides steadily, `r` = 0. Every period integrated (Dopri5, Radau5 at 1e-8 alike)
/// slides too, at 8.5337 N, while envelope following at 1e-4 tips it into stick-slip of
/// `r` = 0.073.
const MARGINAL: &str = r#"
name = "marginal"
[fixed]
v_d = 0.0010985605433061181
f = 2000.0
u0 = 7.924465962305561e-08
[[axis]]
name = "k_d"
values = [4941.771544836056, 7368.062997280768]
[solver]
method = "dopri5"
[run]
envelope = 1e-4
[check]
share = 1.0
min_points = 0
"#;

/// The full run that checks an averaged point integrates every period, not with the envelope
/// the sweep's own full runs use: on a slide near its stability limit ([`MARGINAL`]) the check
/// confirms the averaged `r` = 0 and the mean force, and nothing is replaced; with the envelope
/// the check read `r` = 0.073, a side change, and replaced the right answer by a wrong one.
#[test]
fn a_check_integrates_every_period_and_confirms_a_marginal_slide() {
    let dir = tempfile::tempdir().unwrap();
    let spec = SweepSpec::parse("marginal.toml", MARGINAL).unwrap();
    let a = dir.path().join("a.h5");
    let o = sweep::run(&spec, &opts(&a, 2)).unwrap();
    let c = o.check;
    eprintln!("{}", c.line());
    assert_eq!((c.averaged, c.checked), (2, 2), "{c:?}");
    assert_eq!(c.replaced, 0, "{c:?}");
    let f = H5File::open(&a).unwrap();
    let read = |n: &str| f.dataset(n).unwrap().read_raw::<f64>().unwrap();
    let (rf, ff, fa) = (
        read("tier_check/r_full"),
        read("tier_check/mean_force_full"),
        read("tier_check/mean_force_averaged"),
    );
    for k in 0..2 {
        assert!(rf[k] < 0.01, "check {k}: r_full {}", rf[k]);
        assert!((ff[k] / fa[k] - 1.0).abs() < 1e-3, "{ff:?} {fa:?}");
    }
    assert_eq!(read("tier"), vec![1.0, 1.0]);
    assert!(read("r").iter().all(|&r| r < 0.01));
}

/// A sweep the averaged tier serves: three drives at 3000 Hz, above the contact resonance, one
/// table of the averaged law for all of them per amplitude.
const TIERED: &str = r#"
name = "tiered"
[fixed]
v_d = 0.5e-3
f = 3000.0
[[axis]]
name = "k_d"
values = [8000.0, 11700.0, 16000.0]
[[axis]]
name = "va_ratio"
values = [0.0, 0.4, 1.0, 2.0]
[check]
share = 0.5
min_points = 0
"#;

/// Under `tier = "auto"` the vibrated points are served by the averaged model and say so
/// (`tier` 1, reason `valid`), the points without vibration by the full one (reason
/// `no_vibration`); the checks re-run the drawn share and the points near r = 0.05 with the
/// full model, their comparison lands in group `tier_check`, and a point whose check
/// disagrees carries its full run (`tier` 0, reason `check`, `r` the full run's); with one `k_d`
/// no point shares its table and each is averaged all the same (a table costs less than a full
/// run). The file is
/// the same bit for bit from one and two threads, from shards merged, and from a sweep resumed
/// from half of its runs (a shard's runs file as its journal), as h5py reads them.
#[test]
fn averaged_points_are_checked_and_resume_and_merge_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let spec = SweepSpec::parse("tiered.toml", TIERED).unwrap();
    let a = dir.path().join("a.h5");
    let b = dir.path().join("b.h5");
    let oa = sweep::run(&spec, &opts(&a, 1)).unwrap();
    let ob = sweep::run(&spec, &opts(&b, 2)).unwrap();
    assert_eq!(read_all(&a), read_all(&b));
    assert_eq!(oa.check, ob.check);
    let c = oa.check;
    eprintln!("{}", c.line());
    assert_eq!(c.averaged, 9, "every vibrated point averaged: {c:?}");
    assert!(c.checked >= 1 && c.checked <= c.averaged, "{c:?}");
    let f = H5File::open(&a).unwrap();
    let read = |n: &str| f.dataset(n).unwrap().read_raw::<f64>().unwrap();
    let (tier, why, r) = (read("tier"), read("tier_reason"), read("r"));
    let g = f.root_group().group("tier_check").unwrap();
    assert_eq!(g.attr_string("summary").unwrap(), c.line());
    let col = |n: &str| read(&format!("tier_check/{n}"));
    let point = col("point");
    assert_eq!(point.len(), c.checked);
    let (ra, rf, rep, within) = (
        col("r_averaged"),
        col("r_full"),
        col("replaced"),
        col("within_r"),
    );
    for k in 0..point.len() {
        let i = point[k] as usize;
        assert_eq!(within[k] == 1.0, (ra[k] - rf[k]).abs() <= 0.01, "point {i}");
        if rep[k] == 1.0 {
            // The full run stands for the point.
            assert_eq!((tier[i], why[i]), (0.0, 8.0), "point {i}");
            assert_eq!(r[i].to_bits(), rf[k].to_bits(), "point {i}");
        } else {
            assert_eq!(r[i].to_bits(), ra[k].to_bits(), "point {i}");
        }
    }
    for i in 0..tier.len() {
        let vibrated = i % 4 != 0;
        if !vibrated {
            assert_eq!((tier[i], why[i]), (0.0, 1.0), "point {i}");
        } else if !point
            .iter()
            .zip(&rep)
            .any(|(&p, &x)| p as usize == i && x == 1.0)
        {
            assert_eq!((tier[i], why[i]), (1.0, 6.0), "point {i}");
        }
    }
    // One k_d: no point shares its table; auto averages each all the same (reason 6, valid).
    let alone = SweepSpec::parse(
        "alone.toml",
        &TIERED.replace("values = [8000.0, 11700.0, 16000.0]", "values = [11700.0]"),
    )
    .unwrap();
    let c = dir.path().join("alone.h5");
    let oc = sweep::run(&alone, &opts(&c, 2)).unwrap();
    assert_eq!(oc.check.averaged, 3);
    let fc = H5File::open(&c).unwrap();
    let why = fc
        .dataset("tier_reason")
        .unwrap()
        .read_raw::<f64>()
        .unwrap();
    assert_eq!(why, vec![1.0, 6.0, 6.0, 6.0]);
    // Shards merged, and a resume from a shard's runs as the journal: the same file.
    let file = write(dir.path(), "tiered.toml", TIERED);
    let fs = file.to_str().unwrap();
    let m = dir.path().join("m.h5");
    for i in 0..2 {
        let (ok, log) = stickslip(&[
            "sweep",
            fs,
            "-o",
            m.to_str().unwrap(),
            "--shard",
            &format!("{i}/2"),
            "-q",
        ]);
        assert!(ok, "{log}");
    }
    let (ok, log) = stickslip(&["merge", m.to_str().unwrap(), "--no-plot"]);
    assert!(ok, "{log}");
    same_sweep(&a, &m);
    let resumed = dir.path().join("resumed.h5");
    let shard_runs = sweep::shard::runs_path(&sweep::shard::Shard { index: 0, count: 2 }.path(&m));
    std::fs::copy(&shard_runs, sweep::journal::path_for(&resumed)).unwrap();
    // The shard journaled the tables its averaged points used (one per va_ratio): the resumed
    // sweep loads them
    // instead of building them (a new process), and the file is the same bit for bit.
    let kept = std::fs::read_to_string(&shard_runs).unwrap();
    assert!(
        kept.lines().any(|l| l.starts_with("tab ")),
        "no table in the journal"
    );
    let (ok, log) = stickslip(&[
        "sweep",
        fs,
        "-o",
        resumed.to_str().unwrap(),
        "--resume",
        "--no-plot",
    ]);
    assert!(ok && !log.contains(" 0 resumed"), "{log}");
    assert!(
        log.contains("3 table(s) of the averaged law loaded from the journal"),
        "{log}"
    );
    same_sweep(&a, &resumed);
}

const HYBRID: &str = r#"
name = "hybrid"
[fixed]
v_d = 0.5e-3
f = 1500.0
[[axis]]
name = "k_d"
values = [8000.0, 11700.0]
[[axis]]
name = "va_ratio"
values = [0.0, 0.4]
[run]
tier = "hybrid"
[check]
share = 1.0
min_points = 0
"#;

/// Under `tier = "hybrid"` below the contact resonance the vibrated points say so (`tier` 2,
/// reason `asked_hybrid`), every one is checked with the full model (share 1), the file is the
/// same bit for bit from one and two threads, and a sweep resumed from a shard's runs loads
/// the shared table from the journal and writes the same file, as h5py reads them.
#[test]
fn hybrid_points_are_checked_and_resume_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let spec = SweepSpec::parse("hybrid.toml", HYBRID).unwrap();
    let a = dir.path().join("a.h5");
    let b = dir.path().join("b.h5");
    let oa = sweep::run(&spec, &opts(&a, 1)).unwrap();
    let ob = sweep::run(&spec, &opts(&b, 2)).unwrap();
    assert_eq!(read_all(&a), read_all(&b));
    let c = oa.check;
    assert_eq!(c, ob.check);
    eprintln!("{}", c.line());
    assert_eq!((c.averaged, c.checked), (2, 2), "{c:?}");
    let f = H5File::open(&a).unwrap();
    let read = |n: &str| f.dataset(n).unwrap().read_raw::<f64>().unwrap();
    let (tier, why) = (read("tier"), read("tier_reason"));
    for i in 0..tier.len() {
        // A vibrated point whose check disagreed carries its full run (reason 8, check).
        let want = if i % 2 == 0 {
            (0.0, 1.0)
        } else if tier[i] == 0.0 {
            (0.0, 8.0)
        } else {
            (2.0, 13.0)
        };
        assert_eq!((tier[i], why[i]), want, "point {i}");
    }
    let full_vibrated = (0..tier.len())
        .filter(|&i| i % 2 == 1 && tier[i] == 0.0)
        .count();
    assert_eq!(full_vibrated, c.replaced);
    let file = write(dir.path(), "hybrid.toml", HYBRID);
    let fs = file.to_str().unwrap();
    let m = dir.path().join("m.h5");
    // The shard that ran a hybrid point journaled its table.
    let mut shard_runs = None;
    for index in 0..2 {
        let shard = format!("{index}/2");
        let (ok, log) = stickslip(&[
            "sweep",
            fs,
            "-o",
            m.to_str().unwrap(),
            "--shard",
            &shard,
            "-q",
        ]);
        assert!(ok, "{log}");
        let runs = sweep::shard::runs_path(&sweep::shard::Shard { index, count: 2 }.path(&m));
        if std::fs::read_to_string(&runs)
            .unwrap()
            .lines()
            .any(|l| l.starts_with("tab "))
        {
            shard_runs = Some(runs);
        }
    }
    let shard_runs = shard_runs.expect("a shard journaled the table");
    let resumed = dir.path().join("resumed.h5");
    std::fs::copy(&shard_runs, sweep::journal::path_for(&resumed)).unwrap();
    let (ok, log) = stickslip(&[
        "sweep",
        fs,
        "-o",
        resumed.to_str().unwrap(),
        "--resume",
        "--no-plot",
    ]);
    assert!(ok && !log.contains(" 0 resumed"), "{log}");
    assert!(
        log.contains("1 table(s) of the averaged law loaded from the journal"),
        "{log}"
    );
    same_sweep(&a, &resumed);
}
