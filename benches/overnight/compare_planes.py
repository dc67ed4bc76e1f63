"""Two refinements of the same threshold surface (guided planes and planes alone, written by
benches/overnight/guide-planes.sh): runs, right-hand sides and CPU of each, and their boundaries
line by line (the lower edge on the same dense step or how many steps apart).

    python3 benches/overnight/compare_planes.py GUIDED.h5 ALONE.h5
"""
import sys

import h5py
import numpy as np


def main(a, b):
    fa, fb = h5py.File(a, "r"), h5py.File(b, "r")
    for name, f in (("guided", fa), ("alone", fb)):
        done = f["computed"][:] > 0
        print(f"{name:7s} {done.sum():6d} runs, {np.nansum(f['rhs_evals'][:][done]):.4g} right-hand sides, "
              f"{np.nansum(f['wall_time'][:][done]):7.1f} s of CPU")
    u0 = fa["u0"][:]
    step = np.log(u0[1] / u0[0])
    ga, gb = fa["boundary"], fb["boundary"]
    la, lb = ga["u0"][:], gb["u0"][:]
    both_nan = np.isnan(la) & np.isnan(lb)
    with np.errstate(invalid="ignore", divide="ignore"):
        steps = np.log(la / lb) / step
    same = both_nan | (np.abs(steps) < 0.5)
    print(f"lower edge on the same dense step: {same.sum()} of {len(la)} lines")
    d = ~same
    if d.any():
        s = steps[d]
        print(f"  differing: guided lower at {(s < 0).sum()}, higher at {(s > 0).sum()}, "
              f"{np.isnan(s).sum()} with an edge in one only; |steps| median {np.nanmedian(np.abs(s)):.0f}, "
              f"max {np.nanmax(np.abs(s)):.0f}")
    cr = (ga["crossings"][:] == gb["crossings"][:]).sum()
    print(f"same number of crossings: {cr} of {len(la)} lines")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
