"""Checks a `stickslip diagnose` HDF5 file with h5py against its JSON verdict.

Usage: python3 check_diagnosis.py diagnosis.h5 diagnosis.json
"""
import json
import sys

import h5py
import numpy as np

path, json_path = sys.argv[1], sys.argv[2]
v = json.load(open(json_path))
with h5py.File(path, "r") as f:
    a = f.attrs
    assert a["verdict"] == v["verdict"], (a["verdict"], v["verdict"])
    assert a["best_effect"] == (v["best_effect"] or ""), a["best_effect"]
    assert json.loads(a["json"])["verdict"] == v["verdict"]
    g = f["recordings"]
    n = v["recordings"]
    for k in ("gap_base", "gap_best", "held_out", "v_d", "k_d", "f", "va_ratio", "stick_time"):
        assert g[k].shape == (n,), (k, g[k].shape)
    names = g["gap_base"].attrs["recordings"].split(",")
    assert len(names) == n
    held = [names[i] for i in range(n) if g["held_out"][i] == 1.0]
    assert held == v["held_out"], (held, v["held_out"])
    for rec in v["where"]["recordings"]:
        i = names.index(rec["name"])
        assert abs(g["gap_base"][i] - rec["gap_base"]) < 1e-12
    for feat in ("peak", "trough", "dF", "period", "mean_force", "stick_slope"):
        assert g["z_base"][feat].shape == (n,), feat
    r = f["ranking"]
    keys = sorted(r.keys())
    assert [k.split("_", 1)[1] for k in keys] == [x["name"] for x in v["ranking"]], keys
    if keys:
        top = r[keys[0]]
        assert abs(top["gap_after"][0] - v["ranking"][0]["gap_after"]) < 1e-12
    assert f["calibration"]["F_s"].attrs["units"] == "N"
    # The forcing-frequency features are tabled with the others.
    for feat in ("F_amp_f", "F_phase_f", "F_amp_2f", "x_s_amp_f"):
        assert g["z_base"][feat].shape == (n,), feat
# The verdict's fields: effects in order (best_effect first), partial, the folds.
assert isinstance(v["partial"], bool)
assert v["effects"][:1] == ([v["best_effect"]] if v["best_effect"] else []), v["effects"]
cv = v["cross_validation"]
assert sorted(cv["fold_of"]) == sorted(names), cv["fold_of"]
assert all(0 <= k < cv["folds"] for k in cv["fold_of"].values())
assert v["calibration"]["converged"] in (True, False)
# The decision's evidence: a log-likelihood ratio with its error, clear or not; a tie names two
# candidates or more and no effect; every plausible range says why.
assert isinstance(v["tie"], list) and isinstance(v["warnings"], list)
if v["verdict"] == "tie":
    assert len(v["tie"]) >= 2 and v["best_effect"] is None, v["tie"]
else:
    assert v["tie"] == [], v["tie"]
for r in v["ranking"]:
    e = r["evidence"]
    assert abs(e["log10_odds"] * np.log(10) - e["ln_odds"]) < 1e-9 * max(1, abs(e["ln_odds"])), e
    assert e["clear"] == bool(e["ln_odds"] >= v["thresholds"]["ln_prior_odds"]
                              and e["recordings"] >= 2
                              and e["ln_odds"] - v["thresholds"]["evidence_se"] * e["stderr"] >= 0
                              and e["least_left_out"] >= v["thresholds"]["ln_prior_odds"]), e
    assert isinstance(r["at_bound"], list)
if v["verdict"] == "effect":
    assert v["evidence"]["clear"], v["evidence"]
    assert v["evidence"]["ln_odds"] == v["ranking"][0]["evidence"]["ln_odds"]
# One story from evidence and gap: every disagreement names the two models and the gap's choice
# has the lower gap; a named effect takes part in no disagreement with another candidate of its
# stage (that pair would be a tie).
# Forms of one effect (`effect[form]`) are one explanation: a pair of them may disagree.
cands = {r["name"] for r in v["ranking"]}
def effect_of(name):
    return name.split("[")[0]
for d in v["disagreements"]:
    assert d["by_evidence"] != d["by_gap"], d
    assert d["gap_by_gap"] < d["gap_by_evidence"], d
    assert d["evidence_carried_by"] or d["evidence_recordings"] == 0, d
    pair = (effect_of(d["by_evidence"]), effect_of(d["by_gap"]))
    if v["verdict"] == "effect" and {d["by_evidence"], d["by_gap"]} <= cands and pair[0] != pair[1]:
        assert v["best_effect"] not in pair, (v["best_effect"], d)
# Each named effect with forms says which it takes, among the forms tried.
for f in v["forms"]:
    assert f["effect"] in v["effects"], f
    assert f["form"] == f["tried"][0] and set(f["not_excluded"]) <= set(f["tried"][1:]), f
    assert f["settled"] == (not f["not_excluded"] and len(f["tried"]) > 1 and not f["default"]), f
for r in v["ranking"]:
    assert r["name"] == r["effect"] or r["name"] == f'{r["effect"]}[{r["form"]}]', r
# What the campaign could not have seen: limits with every no_significant_gap, inside the scanned
# range and at the stated power; elsewhere a reason where none were computed.
lim = v["limits"]
if v["verdict"] == "no_significant_gap" and lim["not_computed"] is None:
    assert lim["against"] == "base" and lim["effects"], lim
for e in lim["effects"]:
    lo, hi = sorted((e["weak_end"], e["strong_end"]))
    if e["limit"] is not None:
        assert lo * (1 - 1e-9) <= e["limit"] <= hi * (1 + 1e-9), e
        assert e["power"] >= lim["power"], e
    assert e["param"] in e["statement"], e
if v["verdict"] in ("tie", "unexplained"):
    assert lim["not_computed"] and not lim["effects"], lim
for b in v["bounds"]:
    assert b["lo"] < b["hi"] and b["reason"], b
print("ok")
