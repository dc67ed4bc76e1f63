"""Checks a `stickslip run` HDF5 file with h5py: names, units, dimension scales, values.

Usage: python3 check_run.py FILE.h5 EXPECTED.json
EXPECTED.json is the `--json` output of the same run; exits non-zero on any mismatch.
"""
import json
import sys

import h5py
import numpy as np

path, expected_path = sys.argv[1], sys.argv[2]
expected = json.load(open(expected_path))
with h5py.File(path, "r") as f:
    a = f.attrs
    assert a["program"].startswith("stickslip"), a["program"]
    for key in ("r", "dF", "dF_stderr", "mean_force"):
        want = expected[key]
        got = float(a[key])
        assert want is not None and abs(got - want) <= 1e-12 * max(1.0, abs(want)), (key, got, want)
    assert a["status"] == expected["status"], (a["status"], expected["status"])
    assert float(a["param_k_d"]) == expected["params"]["k_d"]
    assert a["param_k_d_units"] == "N/m"
    g = f["trace"]
    names = ["t", "F_d", "F_d_smooth", "x_s", "x_d", "s", "v_r", "v", "u"]
    assert sorted(g.keys()) == sorted(names), list(g.keys())
    n = g["t"].shape[0]
    assert n > 1000, n
    units = {"t": "s", "F_d": "N", "F_d_smooth": "N", "x_s": "m", "x_d": "m", "s": "m", "v_r": "m/s", "v": "m/s", "u": "m"}
    for k in names:
        assert g[k].shape == (n,), (k, g[k].shape)
        assert g[k].attrs["units"] == units[k], (k, g[k].attrs["units"])
    t = g["t"][:]
    assert np.all(np.diff(t) > 0) and t[0] == 0.0
    assert 0.0 <= float(a["t_end"]) - t[-1] <= 2.0 * (t[1] - t[0]), (t[-1], a["t_end"])
    # t is the dimension scale of every channel.
    fd = g["F_d"]
    assert len(fd.dims[0]) == 1 and fd.dims[0][0].name == "/trace/t", fd.dims[0].keys()
    # x_d = v_d t exactly; the mean of F_d over the steady window is the reported mean force.
    v_d = float(a["param_v_d"])
    assert np.allclose(g["x_d"][:], v_d * t, rtol=1e-12, atol=1e-18)
    if int(a["predicted"]) == 1:
        # The settled level, extrapolated from the force settling over [window_start, t_end]:
        # at most 0.5 % beyond the mean of the window's last sixth, with its error bound stated.
        assert bool(expected.get("predicted")), dict(a)
        err = float(a["level_error"])
        assert np.isfinite(err) and err > 0.0, err
        ws, te = float(a["window_start"]), float(a["t_end"])
        tail = float(np.mean(g["F_d"][:][t >= te - (te - ws) / 6.0]))
        level = expected["mean_force"]
        assert abs(level - tail) <= 5e-3 * abs(level) + 1e-3 * abs(level), (level, tail)
    else:
        w = t >= float(a["window_start"])
        mean = float(np.mean(g["F_d"][:][w]))
        assert abs(mean - expected["mean_force"]) < 2e-3 * abs(expected["mean_force"]), (mean, expected["mean_force"])
    # The force is the spring force: F_d = k_d (x_d - x_s) when h_d = 0.
    if float(a["param_h_d"]) == 0.0:
        k_d = float(a["param_k_d"])
        assert np.allclose(g["F_d"][:], k_d * (g["x_d"][:] - g["x_s"][:]), rtol=1e-9, atol=1e-9)
print("ok", path, n, "samples")
