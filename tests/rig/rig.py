"""An independent simulation of the test stand of the paper, to check `stickslip diagnose` on
campaigns that stickslip did not make.

It shares no code with the crate: the stand is written again from docs/model.md (numpy, numba), with a
fixed-step classical Runge-Kutta method instead of the crate's adaptive integrators, and every
effect in a form of its own, unlike `src/model/effects/`:

- ``sensor``: a force sensor as a fourth-order Butterworth low-pass (two cascaded second-order
  sections, damping 0.924 and 0.383) at ``f_n`` [Hz]; the crate's is one second-order section.
- ``actuator``: the substrate as the second of two masses, a piezo stack (natural frequency
  ``f_1`` [Hz], damping ``zeta_1``) carrying a saddle (``f_2``, ``zeta_2``, mass ratio ``mu``),
  driven by the commanded motion; the crate's is a gain on the amplitude. The switch-on of a
  two-stage recording rings through it.
- ``normal``: normal load modulated at ``f`` with a fixed relative depth ``eps`` (whatever
  ``u0``) and phase ``phase`` [deg] against the substrate; the crate's depth grows with ``u0``.
- ``aging``: contact age by Ruina's slip law, ``theta' = -(|v_r| theta/D_c) ln(|v_r| theta/D_c)``,
  raising the static level as ``F_s (1 + b ln(1 + theta/theta_0))``; the crate uses the ageing
  law.
- ``screw``: lead-screw error with its second harmonic, ``a sin(k x) + a2 sin(2 k x + phi2)``.
- ``track``: friction varying along the track as a sum of two sinusoids of the body position.
- ``frame``: the normal load follows the substrate's *acceleration* through a frame driven by the
  shaker's reaction, ``F_N - m_f u''(t - t_f)`` (mass ``m_f`` [kg], lag ``t_f`` [s]); the
  library's default load swing follows the displacement.

The design of a campaign, its sampling rate, noise and two-stage protocol are chosen per
campaign (see ``PANEL``). Run ``python3 tests/rig/rig.py DIR --campaign NAME`` to write one,
``--list`` to list the panel; the truth goes to ``DIR/../NAME.truth.json``, outside the
campaign.
"""

import argparse
import json
import math
import os
import sys

import numpy as np
from numba import njit

# docs/model.md, Table 1: mass, contact stiffness and damping, viscous damping, Coulomb and static
# force, Stribeck velocity, normal load.
BASE = dict(m=6.52 / 9.81, k_t=71.318e6, h_t=1.377e4, h_v=0.0, F_c=8.3, F_s=11.5, v_s=0.35e-3,
            h_d=0.0, F_N=36.52)

# The normal load [N], a plain float for the compiled right-hand side.
LOAD = BASE["F_N"]

# Indices into the parameter vector of the integrator.
(P_M, P_KT, P_HT, P_HV, P_FC, P_FS, P_VS, P_KD, P_HD, P_VD, P_W, P_U0, P_TON,
 P_SENS, P_SW, P_ACT, P_W1, P_Z1, P_W2, P_Z2, P_MU, P_NORM, P_EPS, P_PHI,
 P_AGE, P_B, P_TH0, P_DC, P_SCREW, P_A1, P_A2, P_KS, P_PHI2, P_TRACK, P_TA1, P_TK1,
 P_TA2, P_TK2, P_FRAME, P_MF, P_TF, P_LEN) = range(42)

# State: x, v, s, sensor (4), actuator (4), theta.
NSTATE = 12


@njit(cache=True)
def substrate(t, y, p):
    """Substrate displacement and velocity at time t."""
    if p[P_U0] == 0.0 or t < p[P_TON]:
        return 0.0, 0.0
    if p[P_ACT] > 0.0:
        return y[9], y[10]
    ph = p[P_W] * (t - p[P_TON])
    return p[P_U0] * math.sin(ph), p[P_U0] * p[P_W] * math.cos(ph)


@njit(cache=True)
def drive(t, p):
    """Drive position and velocity (with the screw error)."""
    x = p[P_VD] * t
    xd, vd = x, p[P_VD]
    if p[P_SCREW] > 0.0:
        k = p[P_KS]
        xd += p[P_A1] * math.sin(k * x) + p[P_A2] * math.sin(2.0 * k * x + p[P_PHI2])
        vd += p[P_VD] * k * (p[P_A1] * math.cos(k * x)
                             + 2.0 * p[P_A2] * math.cos(2.0 * k * x + p[P_PHI2]))
    return xd, vd


@njit(cache=True)
def drive_force(t, y, p):
    xd, vd = drive(t, p)
    return p[P_KD] * (xd - y[0]) + p[P_HD] * (vd - y[1])


@njit(cache=True)
def rhs(t, y, p, dy):
    u, du = substrate(t, y, p)
    vr = y[1] - du
    # Load factor: the normal load's modulation and the track.
    nu = 1.0
    if p[P_NORM] > 0.0 and p[P_U0] > 0.0 and t >= p[P_TON]:
        nu += p[P_EPS] * math.sin(p[P_W] * (t - p[P_TON]) + p[P_PHI])
    if p[P_FRAME] > 0.0 and p[P_U0] > 0.0 and t - p[P_TF] >= p[P_TON]:
        # u'' = -u0 w^2 sin(w (t - t_on)), felt t_f later.
        acc = -p[P_U0] * p[P_W] ** 2 * math.sin(p[P_W] * (t - p[P_TF] - p[P_TON]))
        nu -= p[P_MF] * acc / LOAD
    if p[P_TRACK] > 0.0:
        nu *= 1.0 + p[P_TA1] * math.sin(p[P_TK1] * y[0]) + p[P_TA2] * math.sin(p[P_TK2] * y[0])
    fs = p[P_FS]
    if p[P_AGE] > 0.0:
        th = max(y[11], 1e-12)
        fs *= 1.0 + p[P_B] * math.log(1.0 + th / p[P_TH0])
        q = abs(vr) * th / p[P_DC]
        dy[11] = -q * math.log(q) if q > 0.0 else 0.0
    else:
        dy[11] = 0.0
    fc = p[P_FC] * nu
    fs *= nu
    # LuGre: g(v_r), s', F_F (docs/model.md, Eqs. 4.5 to 4.9).
    g = (fc + (fs - fc) * math.exp(-(vr / p[P_VS]) ** 2)) / p[P_KT]
    sd = vr - abs(vr) * y[2] / g
    ht = p[P_HT] * math.exp(-(vr / p[P_VD]) ** 2)
    ff = p[P_KT] * y[2] + ht * sd + p[P_HV] * vr
    fd = drive_force(t, y, p)
    dy[0] = y[1]
    dy[1] = (fd - ff) / p[P_M]
    dy[2] = sd
    # Fourth-order Butterworth sensor: two second-order sections in cascade.
    if p[P_SENS] > 0.0:
        w = p[P_SW]
        dy[3] = y[4]
        dy[4] = w * w * (fd - y[3]) - 2.0 * 0.9239 * w * y[4]
        dy[5] = y[6]
        dy[6] = w * w * (y[3] - y[5]) - 2.0 * 0.3827 * w * y[6]
    else:
        dy[3] = dy[4] = dy[5] = dy[6] = 0.0
    # Two-mass actuator: piezo (q1) driven by the command, saddle (q2) on it; q2 is the substrate.
    if p[P_ACT] > 0.0:
        if p[P_U0] > 0.0 and t >= p[P_TON]:
            uc = p[P_U0] * math.sin(p[P_W] * (t - p[P_TON]))
        else:
            uc = 0.0
        w1, w2, mu = p[P_W1], p[P_W2], p[P_MU]
        # Forces per unit mass of the piezo: its own spring to the command, the saddle's
        # reaction (mass ratio mu = m_saddle / m_piezo).
        rel = y[9] - y[7]
        relv = y[10] - y[8]
        dy[7] = y[8]
        dy[8] = (w1 * w1 * (uc - y[7]) - 2.0 * p[P_Z1] * w1 * y[8]
                 + mu * (w2 * w2 * rel + 2.0 * p[P_Z2] * w2 * relv))
        dy[9] = y[10]
        dy[10] = -(w2 * w2 * rel + 2.0 * p[P_Z2] * w2 * relv)
    else:
        dy[7] = dy[8] = dy[9] = dy[10] = 0.0


@njit(cache=True)
def simulate(p, t_end, rate, sub):
    """Classical RK4 with `sub` steps per sample of a recorder at `rate` [Hz]; returns the
    recorded force (the sensor's output where it has one), body and drive positions."""
    n = int(math.floor(t_end * rate)) + 1
    h = 1.0 / (rate * sub)
    y = np.zeros(NSTATE)
    if p[P_AGE] > 0.0:
        y[11] = p[P_TH0]
    k1 = np.zeros(NSTATE)
    k2 = np.zeros(NSTATE)
    k3 = np.zeros(NSTATE)
    k4 = np.zeros(NSTATE)
    tmp = np.zeros(NSTATE)
    F = np.zeros(n)
    X = np.zeros(n)
    XD = np.zeros(n)
    for i in range(n):
        t = i / rate
        F[i] = y[5] if p[P_SENS] > 0.0 else drive_force(t, y, p)
        X[i] = y[0]
        XD[i] = drive(t, p)[0]
        if i == n - 1:
            break
        for j in range(sub):
            # Times by index, not by accumulation.
            ts = (i * sub + j) * h
            rhs(ts, y, p, k1)
            for q in range(NSTATE):
                tmp[q] = y[q] + 0.5 * h * k1[q]
            rhs(ts + 0.5 * h, tmp, p, k2)
            for q in range(NSTATE):
                tmp[q] = y[q] + 0.5 * h * k2[q]
            rhs(ts + 0.5 * h, tmp, p, k3)
            for q in range(NSTATE):
                tmp[q] = y[q] + h * k3[q]
            rhs(ts + h, tmp, p, k4)
            for q in range(NSTATE):
                y[q] += h * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q]) / 6.0
    return F, X, XD


def param_vector(cond, effects):
    p = np.zeros(P_LEN)
    b = dict(BASE)
    b.update(cond.get("base", {}))
    p[P_M], p[P_KT], p[P_HT], p[P_HV] = b["m"], b["k_t"], b["h_t"], b["h_v"]
    p[P_FC], p[P_FS], p[P_VS], p[P_HD] = b["F_c"], b["F_s"], b["v_s"], b["h_d"]
    p[P_KD], p[P_VD] = cond["k_d"], cond["v_d"]
    f = cond.get("f", 0.0)
    p[P_W] = 2.0 * math.pi * f
    p[P_U0] = cond["va_ratio"] * cond["v_d"] / p[P_W] if f > 0 else 0.0
    p[P_TON] = cond.get("t_on", 0.0)
    for name, e in effects.items():
        if name == "sensor":
            p[P_SENS], p[P_SW] = 1.0, 2.0 * math.pi * e["f_n"]
        elif name == "actuator":
            p[P_ACT] = 1.0
            p[P_W1], p[P_Z1] = 2.0 * math.pi * e["f_1"], e["zeta_1"]
            p[P_W2], p[P_Z2], p[P_MU] = 2.0 * math.pi * e["f_2"], e["zeta_2"], e["mu"]
        elif name == "normal":
            p[P_NORM], p[P_EPS], p[P_PHI] = 1.0, e["eps"], math.radians(e["phase"])
        elif name == "aging":
            p[P_AGE], p[P_B], p[P_TH0], p[P_DC] = 1.0, e["b"], e["theta_0"], e["d_c"]
        elif name == "screw":
            p[P_SCREW], p[P_A1], p[P_A2] = 1.0, e["a"], e["a2"]
            p[P_KS], p[P_PHI2] = 2.0 * math.pi / e["wavelength"], e["phi2"]
        elif name == "frame":
            p[P_FRAME], p[P_MF], p[P_TF] = 1.0, e["m_f"], e["t_f"]
        elif name == "track":
            p[P_TRACK] = 1.0
            p[P_TA1], p[P_TK1] = e["a1"], 2.0 * math.pi / e["l1"]
            p[P_TA2], p[P_TK2] = e["a2"], 2.0 * math.pi / e["l2"]
        else:
            raise ValueError(f"unknown effect {name}")
    return p


def duration(cond, cycles):
    """Long enough for `cycles` stick-slip cycles in the second half (of the second stage)."""
    b = dict(BASE)
    b.update(cond.get("base", {}))
    tc = 2.0 * (b["F_s"] - b["F_c"]) / (cond["k_d"] * cond["v_d"])
    load = b["F_s"] / (cond["k_d"] * cond["v_d"])
    return cond.get("t_on", 0.0) + 2.0 * max((cycles + 1.5) * tc, load + 2.0 * tc)


def design(kind, two_stage):
    """Conditions of a design: `paper` (no vibration at three stiffnesses and two drive
    velocities; vibration at one stiffness, two velocities, three frequencies, four v_a/v_d:
    30 recordings), `factorial` (four drives, each without vibration and at three vibrations:
    16) or `small` (an unbalanced campaign of 10)."""
    out = []
    if kind == "paper":
        for k_d in (11700.0, 17900.0, 20000.0):
            for v_d in (1e-3, 2e-3):
                out.append(dict(k_d=k_d, v_d=v_d))
        for v_d in (1e-3, 2e-3):
            for f in (500.0, 1500.0, 3000.0):
                for ratio in (0.4, 0.8, 1.3, 2.0):
                    out.append(dict(k_d=11700.0, v_d=v_d, f=f, va_ratio=ratio))
    elif kind == "factorial":
        for k_d, v_d in ((11700.0, 0.7e-3), (11700.0, 1e-3), (20000.0, 1e-3), (17900.0, 2e-3)):
            out.append(dict(k_d=k_d, v_d=v_d))
            for f, ratio in ((1000.0, 0.5), (2000.0, 0.8), (1500.0, 1.5)):
                out.append(dict(k_d=k_d, v_d=v_d, f=f, va_ratio=ratio))
    elif kind == "small":
        out = [dict(k_d=11700.0, v_d=1e-3), dict(k_d=17900.0, v_d=2e-3),
               dict(k_d=20000.0, v_d=1e-3),
               dict(k_d=11700.0, v_d=1e-3, f=1500.0, va_ratio=0.5),
               dict(k_d=11700.0, v_d=1e-3, f=1500.0, va_ratio=1.4),
               dict(k_d=11700.0, v_d=1e-3, f=800.0, va_ratio=0.7),
               dict(k_d=17900.0, v_d=2e-3, f=2500.0, va_ratio=0.4),
               dict(k_d=17900.0, v_d=2e-3, f=2500.0, va_ratio=1.8),
               dict(k_d=20000.0, v_d=1e-3, f=1000.0, va_ratio=0.9),
               dict(k_d=20000.0, v_d=1e-3, f=3000.0, va_ratio=1.2)]
    else:
        raise ValueError(f"unknown design {kind}")
    for c in out:
        c.setdefault("f", 0.0)
        c.setdefault("va_ratio", 0.0)
        if two_stage and c["f"] > 0:
            # Rest for two stick-slip cycles' worth of loading, then vibrate.
            tc = 2.0 * (BASE["F_s"] - BASE["F_c"]) / (c["k_d"] * c["v_d"])
            c["t_on"] = round(BASE["F_s"] / (c["k_d"] * c["v_d"]) + 2.0 * tc, 3)
    return out


# The panel: each campaign's design, protocol, sampling, noise, effects, and the verdict a right
# diagnosis gives (the library effect that stands for the injected one; None: no significant
# gap; "unexplained": none in the library).
PANEL = {
    "free-paper": dict(design="paper", two_stage=True, rate=5000.0, noise=0.02, effects={},
                       expect=None),
    "free-factorial": dict(design="factorial", two_stage=False, rate=20000.0, noise=0.02,
                           effects={}, expect=None),
    "free-small": dict(design="small", two_stage=False, rate=8000.0, noise=0.01, effects={},
                       expect=None),
    "sensor-paper": dict(design="paper", two_stage=True, rate=5000.0, noise=0.02,
                         effects={"sensor": dict(f_n=250.0)}, expect=["sensor_dynamics"]),
    "sensor-factorial": dict(design="factorial", two_stage=False, rate=10000.0, noise=0.02,
                             effects={"sensor": dict(f_n=90.0)}, expect=["sensor_dynamics"]),
    "actuator-inband": dict(design="factorial", two_stage=True, rate=25000.0, noise=0.02,
                            effects={"actuator": dict(f_1=9000.0, zeta_1=0.2, f_2=1100.0,
                                                      zeta_2=0.08, mu=0.3)},
                            expect=["actuator_response"]),
    "normal-fixed-depth": dict(design="factorial", two_stage=False, rate=10000.0, noise=0.02,
                               effects={"normal": dict(eps=0.15, phase=60.0)},
                               expect=["normal_coupling"]),
    "aging-slip-law": dict(design="factorial", two_stage=False, rate=4000.0, noise=0.02,
                           effects={"aging": dict(b=0.08, theta_0=0.01, d_c=1e-6)},
                           expect=["aging"]),
    "screw-harmonics": dict(design="factorial", two_stage=False, rate=10000.0, noise=0.02,
                            effects={"screw": dict(a=6e-6, a2=2e-6, wavelength=0.4e-3,
                                                   phi2=0.7)},
                            expect=["drive_ripple"]),
    "track": dict(design="factorial", two_stage=False, rate=10000.0, noise=0.02,
                  effects={"track": dict(a1=0.08, l1=0.9e-3, a2=0.05, l2=0.37e-3)},
                  expect="unexplained"),
    "sensor+aging": dict(design="factorial", two_stage=False, rate=10000.0, noise=0.02,
                         effects={"sensor": dict(f_n=120.0),
                                  "aging": dict(b=0.08, theta_0=0.01, d_c=1e-6)},
                         expect=["sensor_dynamics", "aging"]),
    "frame-acceleration": dict(design="factorial", two_stage=False, rate=10000.0, noise=0.02,
                               effects={"frame": dict(m_f=0.15, t_f=40e-6)},
                               expect=["normal_coupling"], form="acceleration"),
    "actuator+screw": dict(design="small", two_stage=False, rate=50000.0, noise=0.02,
                           effects={"actuator": dict(f_1=12000.0, zeta_1=0.2, f_2=2500.0,
                                                     zeta_2=0.1, mu=0.3),
                                    "screw": dict(a=6e-6, a2=2e-6, wavelength=0.4e-3, phi2=0.7)},
                           expect=["actuator_response", "drive_ripple"]),
}


# What each added effect of this rig stands for in the library (the verdict a right diagnosis
# gives for it).
LIBRARY = {"sensor": "sensor_dynamics", "actuator": "actuator_response",
           "normal": "normal_coupling", "frame": "normal_coupling", "aging": "aging", "screw": "drive_ripple",
           "track": "unexplained"}


def write_campaign(out, name, seed, cycles=2, extra=None):
    spec = dict(PANEL[name])
    if extra:
        spec["effects"] = {**spec["effects"], **extra}
        names = [LIBRARY[k] for k in extra]
        spec["expect"] = "unexplained" if "unexplained" in names else names
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(seed)
    rate = spec["rate"]
    # Steps of at most 5 microseconds between samples (the contact and the forcing need it).
    sub = max(1, math.ceil(1.0 / (rate * 5e-6)))
    for i, cond in enumerate(design(spec["design"], spec["two_stage"])):
        p = param_vector(cond, spec["effects"])
        F, X, XD = simulate(p, duration(cond, cycles), rate, sub)
        F = F + spec["noise"] * rng.standard_normal(F.size)
        X = X + 5e-9 * rng.standard_normal(X.size)
        XD = XD + 5e-9 * rng.standard_normal(XD.size)
        stem = f"r{i:02d}"
        t = np.arange(F.size) / rate
        np.savetxt(os.path.join(out, stem + ".csv"), np.column_stack([t, F, X, XD]),
                   delimiter=",", header="t,F_d,x_s,x_d", comments="", fmt="%.9e")
        with open(os.path.join(out, stem + ".toml"), "w") as fh:
            fh.write(f"v_d = {cond['v_d']!r}\nk_d = {cond['k_d']!r}\nf = {cond['f']!r}\n")
            fh.write(f"va_ratio = {cond['va_ratio']!r}\n")
            if cond.get("t_on", 0.0) > 0:
                fh.write(f"t_on = {cond['t_on']!r}\n")
    truth = dict(name=name, effects=spec["effects"], expect=spec["expect"], form=spec.get("form"),
                 design=spec["design"], two_stage=spec["two_stage"], rate=rate,
                 noise=spec["noise"], seed=seed)
    with open(os.path.join(os.path.dirname(os.path.abspath(out)), name + ".truth.json"),
              "w") as fh:
        json.dump(truth, fh, indent=1)


def record_plan(out, name, plan_dir, seed, extra=None):
    """The recordings a plan proposes (`stickslip plan`: every TOML with a [plan] table in
    `plan_dir`), made on this rig with the campaign `name`'s effects (and `extra`) and noise, for
    the plan's duration at the plan's rate; each STEM.toml is the plan's own, so the campaign
    they join counts them as planned."""
    import shutil
    import tomllib

    spec = dict(PANEL[name])
    if extra:
        spec["effects"] = {**spec["effects"], **extra}
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(seed + 7919)
    made = 0
    for f in sorted(x for x in os.listdir(plan_dir) if x.endswith(".toml")):
        with open(os.path.join(plan_dir, f), "rb") as fh:
            t = tomllib.load(fh)
        if "plan" not in t:
            continue
        rate = t["plan"]["rate"]
        sub = max(1, math.ceil(1.0 / (rate * 5e-6)))
        vib = t.get("f", 0.0) > 0 and t.get("u0", 0.0) > 0
        cond = dict(v_d=t["v_d"], k_d=t["k_d"], f=t["f"] if vib else 0.0,
                    va_ratio=2 * math.pi * t["f"] * t["u0"] / t["v_d"] if vib else 0.0,
                    t_on=t.get("t_on", 0.0))
        p = param_vector(cond, spec["effects"])
        F, X, XD = simulate(p, t["plan"]["duration"], rate, sub)
        F = F + spec["noise"] * rng.standard_normal(F.size)
        X = X + 5e-9 * rng.standard_normal(X.size)
        XD = XD + 5e-9 * rng.standard_normal(XD.size)
        stem = f[:-5]
        tt = np.arange(F.size) / rate
        np.savetxt(os.path.join(out, stem + ".csv"), np.column_stack([tt, F, X, XD]),
                   delimiter=",", header="t,F_d,x_s,x_d", comments="", fmt="%.9e")
        shutil.copy(os.path.join(plan_dir, f), os.path.join(out, stem + ".toml"))
        made += 1
    if made == 0:
        sys.exit(f"{plan_dir}: no planned conditions (NAME.toml with a [plan] table)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", nargs="?")
    ap.add_argument("--campaign", choices=sorted(PANEL))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--effect", action="append", default=[], metavar="NAME:k=v,...",
                    help="add an effect in this rig's own form to the campaign (repeatable), "
                         "e.g. aging:b=0.02,theta_0=0.01,d_c=1e-6; the truth then expects it")
    ap.add_argument("--conditions", metavar="PLANDIR",
                    help="record the conditions a plan proposes (stickslip plan's folder)")
    a = ap.parse_args()
    if a.list:
        for k, v in PANEL.items():
            print(k, json.dumps(v["expect"]))
        return
    if not a.dir or not a.campaign:
        ap.error("give DIR and --campaign (or --list)")
    extra = {}
    for spec in a.effect:
        name, _, kv = spec.partition(":")
        if name not in ("sensor", "actuator", "normal", "aging", "screw", "track"):
            ap.error(f"--effect {spec}: unknown effect {name!r}")
        vals = {}
        for item in filter(None, kv.split(",")):
            k, _, v = item.partition("=")
            try:
                vals[k.strip()] = float(v)
            except ValueError:
                ap.error(f"--effect {spec}: {k.strip()} = {v!r} is not a number")
        extra[name] = vals
    if a.conditions:
        record_plan(a.dir, a.campaign, a.conditions, a.seed, extra=extra)
    else:
        write_campaign(a.dir, a.campaign, a.seed, extra=extra)


if __name__ == "__main__":
    sys.exit(main())
