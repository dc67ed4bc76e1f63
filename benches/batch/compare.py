"""Two sweep files of the same grid against docs/model.md's convergence rule: how many points
move by more than 0.005 in r or 0.5 % in the mean force, and how many change side of the
elimination boundary r = 0.05, split by the model that served each point in the first file.

    python3 benches/batch/compare.py NEW.h5 OLD.h5
"""
import sys

import h5py
import numpy as np

TIERS = {0: "full", 1: "averaged", 2: "hybrid"}


def main(new_path, old_path):
    a, b = h5py.File(new_path, "r"), h5py.File(old_path, "r")
    ra, rb = a["r"][()], b["r"][()]
    both = np.isfinite(ra) & np.isfinite(rb)
    if "computed" in a and "computed" in b:
        both &= (a["computed"][()] > 0) & (b["computed"][()] > 0)
    dr = np.where(both, np.abs(ra - rb), 0.0)
    fa, fb = a["mean_force"][()], b["mean_force"][()]
    dm = np.where(both, np.abs(fa / fb - 1.0), 0.0)
    side = both & ((ra < 0.05) != (rb < 0.05))
    tier = a["tier"][()] if "tier" in a else np.zeros_like(ra)
    print(f"{new_path} against {old_path}: {both.sum()} points in both")
    print("tier (first file)  points  r moves > 0.005  mean force > 0.5 %  side changes  largest |dr|")
    for t in sorted(set(tier[both].astype(int))):
        m = both & (tier == t)
        print(
            f"{TIERS.get(t, t):17}  {m.sum():6}  {np.sum(m & (dr > 0.005)):15}  "
            f"{np.sum(m & (dm > 0.005)):18}  {np.sum(m & side):12}  {dr[m].max():12.3f}"
        )
    print(
        f"{'all':17}  {both.sum():6}  {np.sum(dr > 0.005):15}  {np.sum(dm > 0.005):18}  "
        f"{side.sum():12}  {dr.max():12.3f}"
    )


if __name__ == "__main__":
    main(*sys.argv[1:3])
