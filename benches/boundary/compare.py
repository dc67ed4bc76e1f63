"""Compares the refined Fig. 11 boundary with a dense map's.

Usage: python3 compare.py DENSE_boundary.csv REFINED_boundary.csv

The refined boundary is interpolated (log u0 against log f) to the dense map's frequencies. For
each frequency it prints how far, in the dense map's u0 steps, the dense boundary lies from the
refined band [lower edge, upper edge] (0 inside it): a dense grid resolves an intermittent band
near v_a = v_d only to its step, so its single crossing may fall anywhere in the band.
"""
import csv
import sys

import numpy as np


def load(path):
    rows = list(csv.DictReader(open(path)))
    col = lambda k: np.array([float(r[k]) for r in rows])
    return col("f"), col("u0_boundary [m]"), col("u0_upper [m]"), col("crossings")


fd, lod, upd, _ = load(sys.argv[1])
fr, lor, upr, crr = load(sys.argv[2])
step = np.log(1000.0) / 63.0  # the dense map: 64 amplitudes from 5 nm to 5 um


def at(y):
    out = np.full(len(fd), np.nan)
    for k, f in enumerate(fd):
        i = np.searchsorted(fr, f)
        i0, i1 = max(i - 1, 0), min(i, len(fr) - 1)
        if np.isfinite(y[i0]) and np.isfinite(y[i1]):
            w = 0.0 if i0 == i1 else (np.log(f) - np.log(fr[i0])) / (np.log(fr[i1]) - np.log(fr[i0]))
            out[k] = np.exp((1 - w) * np.log(y[i0]) + w * np.log(y[i1]))
    return out


lo, up = at(lor), at(upr)
up = np.where(np.isfinite(up), up, lo)
a, b = np.minimum(lo, up), np.maximum(lo, up)
dist = np.where(lod < a, np.log(a / lod), np.where(lod > b, np.log(lod / b), 0.0)) / step
lower = np.abs(np.log(lo / lod)) / step
both = np.isfinite(lod) & np.isfinite(lo)
print(f"frequencies with a boundary: dense {np.isfinite(lod).sum()}, refined {np.isfinite(lo).sum()} of {len(fd)}; "
      f"mismatched {int((np.isfinite(lod) != np.isfinite(lo)).sum())}")
print(f"dense boundary to the refined band: largest {np.nanmax(dist[both]):.2f} steps, "
      f"{int((dist[both] > 1).sum())} beyond one step")
print(f"lower edges: median {np.nanmedian(lower[both]):.2f} steps, largest {np.nanmax(lower[both]):.2f}")
print(f"refined: {int((crr > 1).sum())} of {len(fr)} frequencies with an intermittent band")
sys.exit(1 if (dist[both] > 1).any() or (np.isfinite(lod) != np.isfinite(lo)).any() else 0)
