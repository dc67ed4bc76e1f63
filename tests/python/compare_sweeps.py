"""Two stickslip sweep files hold the same sweep, bit for bit, as h5py reads them.

    python3 compare_sweeps.py A.h5 B.h5

Every dataset (root, traces, boundary) must have the same shape, dtype and bytes, NaNs in the same
places, and every attribute the same value, except what records when and how fast the sweep ran:
the datasets `wall_time` and the attributes `started` and `finished`. Prints what differs and
exits 1 on a difference.
"""
import sys

import h5py
import numpy as np

SKIP_DATASETS = {"wall_time"}
SKIP_ATTRS = {"started", "finished"}


def walk(f):
    out = {}

    def visit(name, obj):
        out[name] = obj

    f.visititems(visit)
    return out


def attrs(obj):
    return {k: obj.attrs[k] for k in obj.attrs if k not in SKIP_ATTRS and k not in ("DIMENSION_LIST", "REFERENCE_LIST")}


def same_value(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind == "f":
        return a.tobytes() == b.tobytes()
    return bool(np.all(a == b))


def main(pa, pb):
    problems = []
    with h5py.File(pa, "r") as fa, h5py.File(pb, "r") as fb:
        ia, ib = walk(fa), walk(fb)
        for name in sorted(set(ia) | set(ib)):
            if name not in ia or name not in ib:
                problems.append(f"{name}: only in {'A' if name in ia else 'B'}")
                continue
            a, b = ia[name], ib[name]
            if isinstance(a, h5py.Dataset) and name.split("/")[-1] not in SKIP_DATASETS:
                if not same_value(a[()], b[()]):
                    problems.append(f"dataset {name} differs")
            for k in sorted(set(attrs(a)) | set(attrs(b))):
                if k not in attrs(a) or k not in attrs(b) or not same_value(attrs(a)[k], attrs(b)[k]):
                    problems.append(f"attribute {name}@{k} differs")
        for k in sorted(set(attrs(fa)) | set(attrs(fb))):
            if k not in attrs(fa) or k not in attrs(fb) or not same_value(attrs(fa)[k], attrs(fb)[k]):
                problems.append(f"root attribute {k} differs: {attrs(fa).get(k)!r} vs {attrs(fb).get(k)!r}")
        n = len([o for o in ia.values() if isinstance(o, h5py.Dataset)])
    if problems:
        print("\n".join(problems))
        sys.exit(1)
    print(f"{pa} and {pb}: {n} datasets and their attributes identical (wall times and dates aside)")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
