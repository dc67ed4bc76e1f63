"""Compares a sweep run with tier = "full" against the same sweep with tier = "auto".

    python3 benches/tiers/compare.py FULL.h5 AUTO.h5

Prints the points each tier served (tier codes: 0 full, 1 averaged, 2 hybrid), |dr| and the mean force's relative difference (share within
0.01 and 0.5 %), boundary side changes at r = 0.05, and the summed wall time of the point runs of
each file, split by the tier that served them in the auto file.
"""
import sys

import h5py
import numpy as np


def main(full_path, auto_path):
    with h5py.File(full_path, "r") as a, h5py.File(auto_path, "r") as b:
        ra, rb = a["r"][()], b["r"][()]
        ma, mb = a["mean_force"][()], b["mean_force"][()]
        wa, wb = a["wall_time"][()], b["wall_time"][()]
        tier, why = b["tier"][()], b["tier_reason"][()]
        print(f"points {ra.size}: averaged {int(np.sum(tier == 1))}, hybrid {int(np.sum(tier == 2))}, reasons (code: count) "
              + ", ".join(f"{int(c)}: {int(n)}" for c, n in zip(*np.unique(why, return_counts=True))))
        d = np.abs(ra - rb)
        ok = ~np.isnan(d)
        print(f"|dr|: max {np.nanmax(d):.4f}, within 0.01 {100 * np.mean(d[ok] <= 0.01):.2f} %")
        e = np.abs(mb / ma - 1)
        ok = ~np.isnan(e)
        print(f"mean force: max {100 * np.nanmax(e):.2f} %, within 0.5 % {100 * np.mean(e[ok] <= 0.005):.2f} %")
        print(f"boundary side changes at r = 0.05: {int(np.sum((ra < 0.05) != (rb < 0.05)))}")
        m, h = tier == 1, tier == 2
        o = ~(m | h)
        print(f"point runs' wall time: averaged points {np.nansum(wa[m]):.1f} s full, {np.nansum(wb[m]):.1f} s auto; "
              f"hybrid points {np.nansum(wa[h]):.1f} s full, {np.nansum(wb[h]):.1f} s auto; "
              f"the others {np.nansum(wa[o]):.1f} s full, {np.nansum(wb[o]):.1f} s auto")
        if h.any():
            dh = np.abs(ra - rb)[h]
            print(f"hybrid points: |dr| max {np.nanmax(dh):.4f}, within 0.01 {100 * np.nanmean(dh <= 0.01):.2f} %")
        if "tier_check" in b:
            print("checks:", b["tier_check"].attrs["summary"])


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
