"""The Python package against the CLI it stands beside: the same numbers, the same files, the
same messages, and Ctrl-C honoured.

Runs from the README's test command (after `pip install .` built the package from this checkout
and `cargo test --release` built the CLI): `python3 -m pytest tests/python`.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

import stickslip

ROOT = Path(__file__).resolve().parents[2]
CLI = Path(os.environ.get("STICKSLIP_CLI", ROOT / "target" / "release" / "stickslip"))


@pytest.fixture(scope="session", autouse=True)
def cli_built() -> None:
    if not CLI.is_file():
        pytest.fail(f"{CLI} missing: build the CLI first (cargo build --release)")


def cli(*args: str, ok: bool = True, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    p = subprocess.run([str(CLI), *args], capture_output=True, text=True, cwd=cwd)
    if ok and p.returncode != 0:
        raise AssertionError(f"stickslip {' '.join(args)} failed:\n{p.stderr}")
    return p


def cli_error(*args: str) -> str:
    """The CLI's error message (its stderr's `error: ` line), which must exit 2 or 1."""
    p = cli(*args, ok=False)
    assert p.returncode in (1, 2), p
    line = next(l for l in p.stderr.splitlines() if l.strip())
    return line.removeprefix("error: ")


SMALL_SWEEP = textwrap.dedent(
    """\
    name = "small"
    [fixed]
    k_d = 11700.0
    v_d = 0.5e-3
    [[axis]]
    name = "f"
    logspace = [500.0, 4000.0, 4]
    [[axis]]
    name = "u0"
    logspace = [2e-8, 1e-6, 5]
    """
)


# ---- run -------------------------------------------------------------------------------------


def test_run_gives_the_numbers_of_run_json(tmp_path: Path) -> None:
    """The Fig. 4 case with partial reduction: every measure and statistic as the CLI's JSON."""
    py = stickslip.run(k_d=10_000, v_d=1e-3, f=1500, v_a=0.4e-3)
    j = json.loads(
        cli("run", "--k-d", "10000", "--v-d", "1e-3", "--f", "1500", "--v-a", "0.4e-3",
            "--json", "-o", str(tmp_path / "run.h5")).stdout
    )
    for key in ("r", "r_stderr", "dF", "dF_stderr", "mean_force", "stick_fraction", "period",
                "cycles", "t_end", "status", "params", "solver", "effects"):
        assert py.to_dict()[key] == j[key], key
    # The reference run without vibration too, its wall time aside.
    ref, ref_cli = dict(py.reference), dict(j["reference"])
    ref.pop("wall_time"), ref_cli.pop("wall_time")
    assert ref == ref_cli
    assert py.stats == j["stats"]
    # Partial reduction (docs/model.md: v_a < v_d shrinks stick-slip): r strictly between 0 and 1.
    assert 0.05 < py.r < 1.0
    # The trace is the file's: the CLI's run file opened by the package holds the same samples.
    f = stickslip.open(tmp_path / "run.h5")
    np.testing.assert_array_equal(f["F_d"].values, py.trace["F_d"].values)
    np.testing.assert_array_equal(f["t"].values, py.trace["t"].values)


def test_tiers_say_which_model_served_and_agree() -> None:
    """Above the contact resonance the default tier averages the vibration out and says so; the
    full model asked for gives r within 0.005 (the case of the averaging study's target: 3000 Hz,
    v_a/v_d = 0.4) with some 28 times the right-hand sides; below it auto integrates in full."""
    auto = stickslip.run(k_d=11_700, v_d=0.5e-3, f=3000, va_ratio=0.4, trace=False)
    full = stickslip.run(k_d=11_700, v_d=0.5e-3, f=3000, va_ratio=0.4, trace=False, tier="full")
    assert (auto.tier, auto.tier_reason) == ("averaged", "valid")
    assert (full.tier, full.tier_reason) == ("full", "asked")
    assert abs(auto.r - full.r) <= 0.005
    assert 10 * auto.stats["rhs_evals"] < full.stats["rhs_evals"]
    low = stickslip.run(k_d=11_700, v_d=0.5e-3, f=1500, va_ratio=0.4, trace=False)
    assert (low.tier, low.tier_reason) == ("full", "below_resonance")
    # Below it, hybrid windows asked for: the full model inside the law's zones only.
    hyb = stickslip.run(k_d=11_700, v_d=0.5e-3, f=1500, va_ratio=0.4, trace=False, tier="hybrid")
    assert (hyb.tier, hyb.tier_reason) == ("hybrid", "asked_hybrid")
    assert abs(hyb.r - low.r) <= 0.005
    with pytest.raises(ValueError, match="tier"):
        stickslip.run(f=3000, va_ratio=0.4, tier="windows")


def test_auto_leaves_a_drive_velocity_near_a_zone_to_the_full_model() -> None:
    """At 2639 Hz, u0 = 12.56 nm, v_d = 0.149 mm/s the averaged law has a zone (no contracting
    fast orbit) up to 13 % below v_d, and the full model slides at 4.79 N on another attractor
    where the law gives 8.60 N: auto serves the point in full and says why (near_zone), and
    averaged asked for reports the law's force."""
    case = dict(k_d=4941.771544836056, v_d=0.00014909760458231002, f=2639.015821545788,
                u0=1.2559432157547897e-08, trace=False)
    auto = stickslip.run(**case)
    assert (auto.tier, auto.tier_reason) == ("full", "near_zone")
    assert abs(auto.mean_force - 4.79) < 0.05
    avg = stickslip.run(**case, tier="averaged")
    assert avg.tier == "averaged"
    assert avg.mean_force > 8.0


def test_trace_is_a_dataset_with_units() -> None:
    r = stickslip.run(k_d=11_700, v_d=0.5e-3, f=1500, va_ratio=2.0, effects={"viscous": {"h_v": 20}})
    tr = r.trace
    assert isinstance(tr, xr.Dataset)
    assert tr["F_d"].attrs["units"] == "N" and tr["x_s"].attrs["units"] == "m"
    assert tr["t"].attrs["units"] == "s"
    assert {"F_d", "F_d_smooth", "x_s", "x_d"} <= set(tr.data_vars)
    # x_d = v_d t exactly (the drive's far end).
    np.testing.assert_allclose(tr["x_d"].values, 0.5e-3 * tr["t"].values, rtol=1e-12, atol=1e-18)
    assert r.effects == {"viscous": {"h_v": 20.0, "exponent": 1.0}}
    # v_a = 2 v_d eliminates stick-slip at 1500 Hz (docs/model.md, result 3).
    assert r.r < 0.05
    assert stickslip.run(k_d=11_700, v_d=0.5e-3, trace=False).trace is None


@pytest.mark.parametrize(
    "kwargs, flags",
    [
        ({"k_d": 1e12}, ["--k-d", "1e12"]),
        ({"u0": 1.0, "f": 100}, ["--u0", "1", "--f", "100"]),
        ({"method": "euler"}, ["--solver", "euler"]),
        ({"rtol": 1.0}, ["--rtol", "1"]),
        ({"t_on": 3.0}, ["--t-on", "3"]),
        ({"effects": "aging:b=9"}, ["--effect", "aging:b=9"]),
        ({"t_end": 1e6, "va_ratio": 1.0, "f": 1000}, ["--t-end", "1e6", "--va-ratio", "1", "--f", "1000"]),
    ],
)
def test_bad_input_is_a_value_error_with_the_cli_message(kwargs: dict, flags: list[str]) -> None:
    with pytest.raises(ValueError) as e:
        stickslip.run(**kwargs)
    expected = cli_error("run", *flags, "--no-trace", "-o", "/tmp/stickslip-test-never/x.h5")
    # The CLI checks outputs after the values: the same first message either way.
    assert str(e.value) == expected


def test_names_and_amplitudes_are_checked_before_the_cli() -> None:
    with pytest.raises(ValueError, match="unknown parameter 'kd'"):
        stickslip.run(kd=1000)
    with pytest.raises(ValueError, match="u0 and v_a given together"):
        stickslip.run(u0=1e-7, v_a=1e-3)
    with pytest.raises(ValueError, match="must be a number"):
        stickslip.run(k_d="1000")


def test_a_run_that_does_not_succeed_is_a_runtime_error() -> None:
    # Too short a t_end for the stick-slip to settle: the CLI's reason, with the time it needs.
    with pytest.raises(RuntimeError) as e:
        stickslip.run(k_d=10_000, v_d=1e-3, t_end=0.5)
    msg = cli_error("run", "--k-d", "10000", "--v-d", "1e-3", "--t-end", "0.5", "-o", "/tmp/never-written.h5")
    # The CLI adds what it left untouched; the reason before it is the same.
    assert msg.startswith(str(e.value)), (msg, str(e.value))
    assert "give t_end >=" in str(e.value)


# ---- sweep, open, boundary --------------------------------------------------------------------


def test_sweep_equals_the_cli_file(tmp_path: Path) -> None:
    spec = tmp_path / "small.toml"
    spec.write_text(SMALL_SWEEP)
    cli("sweep", str(spec), "-o", str(tmp_path / "cli.h5"), "--no-plot")
    with xr.open_dataset(tmp_path / "cli.h5", engine="h5netcdf") as f:
        by_cli = f.load()
    ds = stickslip.sweep(spec, threads=2, progress=False)
    # Every measure and statistic, bit for bit; wall times and dates aside.
    assert ds.drop_vars("wall_time").equals(by_cli.drop_vars("wall_time"))
    assert set(ds.attrs) == set(by_cli.attrs)
    for k in ds.attrs:
        if k not in ("started", "finished", "t_end"):
            assert ds.attrs[k] == by_cli.attrs[k], k
    assert ds["r"].dims == ("f", "u0") and ds["r"].attrs["units"] == "1"
    # The same content as a dict gives the same numbers.
    as_dict = {
        "name": "small",
        "fixed": {"k_d": 11700.0, "v_d": 0.5e-3},
        "axis": [
            {"name": "f", "logspace": [500.0, 4000.0, 4]},
            {"name": "u0", "logspace": [2e-8, 1e-6, 5]},
        ],
    }
    from_dict = stickslip.sweep(as_dict, threads=1, progress=False)
    for name in ("r", "dF", "mean_force", "status", "steps", "rhs_evals"):
        np.testing.assert_array_equal(from_dict[name].values, by_cli[name].values)
    # The boundary: the CLI's CSV, read back, column for column.
    cli("boundary", str(tmp_path / "cli.h5"))
    csv = pd.read_csv(tmp_path / "cli_boundary.csv")
    for b in (stickslip.boundary(ds), stickslip.boundary(tmp_path / "cli.h5"), stickslip.boundary(from_dict)):
        assert list(b.columns) == list(csv.columns)
        for col in csv.columns:
            np.testing.assert_allclose(b[col].astype(float), csv[col].astype(float), rtol=1e-15, equal_nan=True)


def test_sweep_to_a_file_and_bad_sweeps(tmp_path: Path) -> None:
    out = tmp_path / "s.h5"
    ds = stickslip.sweep({"fixed": {"k_d": 11700.0, "f": 1500.0}, "axis": [{"name": "va_ratio", "values": [0.0, 0.5, 2.0]}]},
                         out=out, progress=False)
    assert out.is_file()
    assert "stickslip" in cli("status", str(out)).stdout or cli("status", str(out)).returncode == 0
    reopened = stickslip.open(out)
    assert reopened.drop_vars("wall_time").equals(ds.drop_vars("wall_time"))
    # r falls with the amplitude; 2 v_d eliminates (docs/model.md results 2 and 3).
    r = ds["r"].values
    assert r[0] == pytest.approx(1.0) and r[1] < r[0] and r[2] < 0.05
    with pytest.raises(ValueError, match="max_runs"):
        stickslip.sweep({"max_runs": 0, "axis": [{"name": "f", "values": [1.0]}]}, progress=False)
    with pytest.raises(ValueError, match="needs out"):
        stickslip.sweep({"axis": [{"name": "f", "values": [1.0]}]}, resume=True)
    (tmp_path / "small.toml").write_text(SMALL_SWEEP)
    with pytest.raises(ValueError) as e:
        stickslip.sweep(tmp_path / "small.toml", threads=0)
    assert str(e.value) == cli_error("sweep", str(tmp_path / "small.toml"), "--threads", "0")
    # A sweep file that is not there: the CLI's message.
    with pytest.raises(ValueError) as e:
        stickslip.sweep(tmp_path / "none.toml", progress=False)
    assert str(e.value) == cli_error("sweep", str(tmp_path / "none.toml"))


def test_open_a_diagnosis_and_refuse_what_is_not_a_file(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no such file"):
        stickslip.open(tmp_path / "missing.h5")


# ---- Ctrl-C ----------------------------------------------------------------------------------


def _interrupt(script: str, after: float, ready: Callable[[], bool] | None = None) -> tuple[str, float]:
    """Run `script`, send SIGINT once it is under way, and give its output and how long it took
    to stop. Under way means: it printed "go" (just before the computation), `after` seconds
    passed, and `ready()` holds if given (polled every 5 ms, for at most a minute)."""
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout is not None
    assert p.stdout.readline().strip() == "go"
    time.sleep(after)
    deadline = time.monotonic() + 60.0
    while ready is not None and not ready():
        assert p.poll() is None, "the script ended before it was ready to be interrupted"
        assert time.monotonic() < deadline, "the script never became ready to be interrupted"
        time.sleep(0.005)
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    return out + err, time.monotonic() - t0


def test_ctrl_c_stops_a_run_within_a_second() -> None:
    # The slow corner with every period integrated: about a minute of computing.
    script = textwrap.dedent(
        """
        import stickslip
        print("go", flush=True)
        try:
            stickslip.run(k_d=1000, v_d=1e-4, f=1500, va_ratio=1.0, envelope=False, method="radau5")
            print("finished")
        except KeyboardInterrupt:
            print("interrupted")
        """
    )
    out, waited = _interrupt(script, 1.0)
    assert "interrupted" in out, out
    assert waited < 1.0, waited


def test_ctrl_c_keeps_a_sweep_that_resumes_to_the_cli_numbers(tmp_path: Path) -> None:
    out = tmp_path / "ov.h5"
    spec = tmp_path / "ov.toml"
    spec.write_text(SMALL_SWEEP.replace('logspace = [2e-8, 1e-6, 5]', 'logspace = [2e-8, 1e-6, 40]')
                    .replace('logspace = [500.0, 4000.0, 4]', 'logspace = [500.0, 4000.0, 12]'))
    script = textwrap.dedent(
        f"""
        import stickslip
        print("go", flush=True)
        try:
            stickslip.sweep({str(spec)!r}, out={str(out)!r}, threads=2, progress=False)
            print("finished")
        except KeyboardInterrupt:
            print("interrupted")
        """
    )
    journal = Path(str(out) + ".journal")

    def some_runs_journaled() -> bool:
        # Interrupt once a first run is recorded (the journal's first line is its header), so the
        # sweep is under way however fast the machine is, and far from finished.
        return journal.is_file() and sum(1 for l in journal.read_text().splitlines()[1:] if l.strip()) > 0

    text, waited = _interrupt(script, 0.0, some_runs_journaled)
    assert "interrupted" in text, text
    assert waited < 1.0, waited
    assert journal.is_file()
    recorded = sum(1 for l in journal.read_text().splitlines()[1:] if l.strip())
    assert recorded > 0
    assert "interrupted" in cli("status", str(out)).stdout
    # Nothing lost: resuming makes only what is missing and gives the CLI's numbers.
    ds = stickslip.sweep(spec, out=out, resume=True, progress=False)
    cli("sweep", str(spec), "-o", str(tmp_path / "cli.h5"), "--no-plot")
    with xr.open_dataset(tmp_path / "cli.h5", engine="h5netcdf") as f:
        by_cli = f.load()
    for name in ("r", "dF", "mean_force", "status", "steps", "rhs_evals"):
        np.testing.assert_array_equal(ds[name].values, by_cli[name].values)
    assert not journal.exists()


# ---- campaigns -------------------------------------------------------------------------------


@pytest.fixture(scope="session")
def small_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("camp") / "small"
    cli("synth", str(d), "--design", "small", "--seed", "3")
    return d


def test_campaign_from_frames_round_trips_and_calibrates_as_the_cli(small_campaign: Path, tmp_path: Path) -> None:
    frames = {}
    for toml in sorted(small_campaign.glob("*.toml")):
        if toml.name == "campaign.toml":
            continue
        import tomllib

        frames[toml.stem] = (pd.read_csv(toml.with_suffix(".csv")), tomllib.loads(toml.read_text()))
    camp = stickslip.Campaign.from_frames(frames)
    assert len(camp) == len(frames)
    folder = camp.to_dir(tmp_path / "copy")
    # Never over files: a second write into the same folder is refused.
    with pytest.raises(ValueError, match="already there"):
        camp.to_dir(folder)
    cal = stickslip.calibrate(camp)
    cli("calibrate", str(small_campaign), "--json", str(tmp_path / "cal.json"))
    by_cli = json.loads((tmp_path / "cal.json").read_text())
    # The frames, written at full precision, are the CLI's recordings: the same estimates.
    got, want = cal.to_dict(), by_cli
    assert got.keys() == want.keys()
    for key in ("params", "gap", "residuals", "evaluations", "recordings"):
        assert got[key] == want[key], key
    assert "F_s" in cal.summary


def test_bad_campaigns_raise_the_cli_message(tmp_path: Path) -> None:
    bad = pd.DataFrame({"t": [0.0, 1.0], "F_d": [0.0, 1.0]})
    with pytest.raises(ValueError, match="column 'F_d' missing"):
        stickslip.Campaign.from_frames({"a": (pd.DataFrame({"t": [0.0]}), {})})
    camp = stickslip.Campaign.from_frames({"a": (bad, {"v_d": 1e-3, "k_d": 1e4})})
    with pytest.raises(ValueError) as e:
        camp.to_dir(tmp_path / "bad")
    assert str(e.value) == cli_error("calibrate", str(tmp_path / "bad"))


def test_diagnose_from_frames_gives_the_cli_verdict(small_campaign: Path, tmp_path: Path) -> None:
    camp = stickslip.Campaign.from_dir(small_campaign)
    # Without the detection limits (a minute each; tests/limits.rs checks them): the JSON says so.
    d = stickslip.diagnose(camp, out=tmp_path / "py", limits=False)
    cli("diagnose", str(small_campaign), "--out", str(tmp_path / "cli"), "--no-limits")
    by_cli = json.loads((tmp_path / "cli" / "diagnosis.json").read_text())
    assert d.verdict == by_cli["verdict"]
    assert d.to_dict()["gap_before"] == by_cli["gap_before"]
    assert d.to_dict()["ranking"] == by_cli["ranking"]
    assert d.limits == by_cli["limits"] and d.limits["not_computed"] == "not asked for"
    assert d.limits["effects"] == [] and d.disagreements == by_cli["disagreements"]
    assert (tmp_path / "py" / "diagnosis.json").is_file()
    # Its work: every recording simulated at least once for the calibration, and more for its
    # iterations (threads that ask for one prediction at once may each run it, so the counts of
    # two runs can differ by a few).
    assert d.work["simulations"] > len(camp) and by_cli["work"]["simulations"] > len(camp)
    assert d.work["simulation_cpu"] > 0 and d.work["cache_hits"] >= 0
    # By fidelity (the full simulations and the search's cheaper ones): they add up.
    by = d.work["fidelity"]
    assert set(by) == {"full", "search"}
    assert sum(f["simulations"] for f in by.values()) == d.work["simulations"]
    assert by["full"]["simulations"] > len(camp)
    figs = d.figures()
    import matplotlib.figure

    assert set(figs) == {"traces", "gap_conditions"}
    assert all(isinstance(f, matplotlib.figure.Figure) for f in figs.values())
    # The traces figure carries the measured and the base model's force.
    assert len(figs["traces"].axes[0].lines) >= 2
    h5 = stickslip.open(tmp_path / "py" / "diagnosis.h5")
    assert h5.attrs["verdict"] == by_cli["verdict"]
    # Its datasets by path, those of one group over shared dimensions.
    gaps = h5["recordings/gap_base"]
    assert gaps.dims == h5["recordings/gap_best"].dims and gaps.size == len(camp)
    # A named effect was checked for its fingerprints; h5py reads each family the JSON reports.
    if by_cli["verdict"] == "effect":
        assert by_cli["ranking"][0]["fingerprints"], by_cli["ranking"][0]
    import h5py

    with h5py.File(tmp_path / "py" / "diagnosis.h5", "r") as f:
        for i, r in enumerate(by_cli["ranking"]):
            for c in r["fingerprints"]:
                g = f[f"ranking/{i:02d}_{r['effect']}/fingerprint_{c['family']}"]
                assert g.attrs["seen"] == c["seen"]
                assert g["strength"][0] == pytest.approx(c["strength"], rel=1e-12)


def test_plan_returns_the_cli_plan_as_xarray(small_campaign: Path, tmp_path: Path) -> None:
    """A plan from a diagnosis of the effect-free small campaign: with no candidate standing it
    says there is nothing to tell apart; with a rival added to that diagnosis (viscous friction
    at h_v = 60 N s/m, as a diagnosis would list a candidate it could not tell from the base
    model) it plans, inside the campaign's ranges, the same recordings as the CLI."""
    cli("diagnose", str(small_campaign), "--out", str(tmp_path / "d"), "--no-limits", "--no-plots")
    djson = tmp_path / "d" / "diagnosis.json"
    d = json.loads(djson.read_text())
    if not d["ranking"]:
        with pytest.raises(ValueError, match="nothing to tell apart"):
            stickslip.plan(small_campaign, n=2, diagnosis=djson, out=tmp_path / "p0")
    model = json.loads(json.dumps(d["calibration"]["model"]))
    model["effects"] = {"viscous": {"h_v": 60.0, "exponent": 1.0}}
    n = d["recordings"]
    # A whole ranking entry: a diagnosis record refuses an entry missing any field.
    estimate = {"value": 0.0, "stderr": None, "unit": ""}
    d["ranking"] = [{
        "effect": "viscous", "name": "viscous", "model": model, "fitted_effects": ["viscous"],
        "evidence": {"ln_odds": 1.0, "log10_odds": 1.0 / np.log(10), "stderr": None,
                     "recordings": n, "least_left_out": None, "clear": False},
        "per_recording": [1.0] * n, "per_recording_n": [10] * n,
        "params": {k: estimate for k in ("F_s", "F_c", "v_s", "h_d", "viscous.h_v")},
        "form": None, "form_charge": 0.0, "at_bound": [], "gap_after": 1.0, "gap_spread": 0.0,
        "reduction": 0.0, "score": 1.0, "fingerprints": [], "rejected": None,
        "short_of_leader": None, "per_feature": {}, "stderr_from": "", "gap_calibration": 1.0,
        "screen": None,
    }]
    d["verdict"], d["tie"], d["effects"] = "tie", ["viscous"], []
    rivals = tmp_path / "rivals.json"
    rivals.write_text(json.dumps(d))
    p = stickslip.plan(small_campaign, n=2, diagnosis=rivals, out=tmp_path / "py", plots=False)
    cli("plan", str(small_campaign), "--recordings", "2", "--diagnosis", str(rivals),
        "--out", str(tmp_path / "cli"), "--no-plots")
    by_cli = json.loads((tmp_path / "cli" / "plan.json").read_text())
    assert [r["name"] for r in p.rivals] == ["base", "viscous"]
    assert [r["name"] for r in p.recordings] == [r["name"] for r in by_cli["recordings"]]
    t = p.recordings_table()
    assert t.sizes["recording"] == 2 and t["k_d"].attrs["units"] == "N/m"
    springs = {r["conditions"]["k_d"] for r in by_cli["recordings"]}
    assert springs <= set(by_cli["space"]["springs"])
    assert (t["duration"] <= by_cli["space"]["max_duration"] + 1e-9).all()
    o = p.outcomes_table()
    # Viscous as the truth: the planned recordings add evidence for it, by the criterion and
    # by simulation.
    assert o["expected"].sel(truth="viscous", other="base") > o["now"].sel(truth="viscous", other="base")
    assert np.isfinite(o["simulated"].sel(truth="viscous", other="base"))
    for r in by_cli["recordings"]:
        text = (tmp_path / "cli" / f"{r['name']}.toml").read_text()
        assert "[plan]" in text and "v_d" in text


def test_hostile_paths_are_only_paths(tmp_path: Path) -> None:
    """Folders with a space, a quote, `$(...)` and backticks: written where asked, nothing run."""
    odd = tmp_path / "a b$(touch pwned) `touch pwned2` 'q'"
    odd.mkdir()
    ds = stickslip.sweep({"fixed": {"k_d": 11700.0, "f": 1500.0}, "axis": [{"name": "va_ratio", "values": [0.5, 2.0]}]},
                         out=odd / "s w.h5", progress=False)
    assert (odd / "s w.h5").is_file() and ds["r"].size == 2
    frames = {"rec one": (pd.DataFrame({"t": [0.0, 1e-3], "F_d": [0.0, 1e-3]}), {"v_d": 1e-3, "k_d": 1e4, "f": 0.0, "u0": 0.0})}
    with pytest.raises(ValueError):
        stickslip.Campaign.from_frames(frames).to_dir(odd / "camp")  # too short to be a recording
    assert (odd / "camp" / "rec one.csv").is_file()
    assert not any(p.name.startswith("pwned") for p in tmp_path.rglob("*")) and not Path("pwned").exists()
