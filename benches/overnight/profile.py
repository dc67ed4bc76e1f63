"""Where a refined threshold surface's CPU time goes: per (v_d, k_d) plane and per band of
v_a/v_d, from the per-run wall times of a sweep file written by `stickslip sweep`, and the
whole overnight surface's CPU time extrapolated from the sampled planes (bilinear in log v_d,
log k_d, over the 16 x 16 planes of sweeps/overnight-boundary.toml).

    stickslip sweep benches/overnight/boundary-sixteenth.toml -o results/boundary-bench/sixteenth.h5 --no-plot
    python3 benches/overnight/profile.py results/boundary-bench/sixteenth.h5
"""
import sys

import h5py
import numpy as np


def main(path):
    f = h5py.File(path, "r")
    wall = f["wall_time"][:]
    done = f["computed"][:] > 0
    vd, kd, fr, u0 = (f[k][:] for k in ("v_d", "k_d", "f", "u0"))
    print(f"{done.sum()} runs, {np.nansum(wall[done]):.0f} s of CPU")
    print("v_d [m/s]  k_d [N/m]  runs  CPU [s]")
    cost = np.zeros((len(vd), len(kd)))
    for i in range(len(vd)):
        for j in range(len(kd)):
            w = wall[i, j][done[i, j]]
            cost[i, j] = w.sum()
            print(f"{vd[i]:9.2e}  {kd[j]:9.0f}  {len(w):4d}  {w.sum():7.1f}")
    ratio = 2 * np.pi * fr[None, None, :, None] * u0[None, None, None, :] / vd[:, None, None, None]
    print("v_a/v_d band   runs  CPU share")
    total = np.nansum(wall[done])
    for lo, hi in [(0, 0.5), (0.5, 0.8), (0.8, 1.25), (1.25, 2), (2, np.inf)]:
        m = done & (ratio >= lo) & (ratio < hi)
        print(f"[{lo:4g}, {hi:4g})  {m.sum():5d}  {wall[m].sum() / total:6.1%}")
    # Bilinear interpolation of log CPU per plane over the 16 x 16 planes of the surface.
    lv, lk, lc = np.log(vd), np.log(kd), np.log(cost)

    def at(v, k):
        i = int(np.clip(np.searchsorted(lv, v, side="right") - 1, 0, len(lv) - 2))
        j = int(np.clip(np.searchsorted(lk, k, side="right") - 1, 0, len(lk) - 2))
        a = (v - lv[i]) / (lv[i + 1] - lv[i])
        b = (k - lk[j]) / (lk[j + 1] - lk[j])
        return np.exp((1 - a) * (1 - b) * lc[i, j] + a * (1 - b) * lc[i + 1, j]
                      + (1 - a) * b * lc[i, j + 1] + a * b * lc[i + 1, j + 1])

    planes = [(v, k) for v in np.log(np.geomspace(0.1e-3, 2e-3, 16))
              for k in np.log(np.geomspace(1000.0, 20000.0, 16))]
    est = sum(at(v, k) for v, k in planes)
    print(f"whole surface (256 planes): about {est:.0f} s of CPU, {est / 7200:.2f} h on 2 cores")


if __name__ == "__main__":
    main(sys.argv[1])
