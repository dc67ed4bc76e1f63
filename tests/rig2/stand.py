"""A second independent simulation of the sliding stand, to check `stickslip diagnose` on
campaigns neither the crate nor the first rig (`tests/rig/rig.py`) made.

Written apart from both: the stand from docs/model.md again, integrated by the three-stage
strong-stability-preserving Runge-Kutta method of Shu and Osher at a fixed step of 2.5 us (the
crate uses adaptive Rosenbrock/Radau and Dormand-Prince methods, the first rig classical RK4), and
every effect in a form that is neither the library's (`src/model/effects/`) nor the first rig's:

- ``sensor``: a second-order force sensor (``f_n`` [Hz], ``zeta``) followed by the acquisition's
  first-order anti-alias low-pass at ``f_lp`` [Hz].
- ``actuator``: the substrate follows its command through a first-order lag (amplifier
  bandwidth ``f_c`` [Hz]); the library's is a second-order resonance.
- ``normal``: the normal load follows the substrate displacement with a fixed time delay,
  ``F_N + k * u(t - delay)`` (so its phase grows with the frequency); the library's has a fixed
  phase.
- ``viscous``: friction quadratic in the slip velocity, ``c2 v_r |v_r|``; the library's is linear.
- ``stribeck``: a Lorentzian Stribeck curve ``F_c + (F_s - F_c) / (1 + (v_r/v_s)^2)``; the
  library's is a stretched exponential.
- ``memory``: the Stribeck level follows the slip over a memory *distance* ``D`` [m],
  ``phi' = |v_r|/D (exp(-(v_r/v_s)^2) - phi)``; the library's first two lag forms delay the
  velocity, not the level, and its ageing is a contact age (its third lag form, ``level``, is
  this memory).

- ``daq``: the data acquisition's anti-alias filter, a fourth-order *Bessel* low-pass at ``f_aa``
  [Hz] (two sections: 1.4192 and 1.5912 ``f_aa``, damping 0.958 and 0.621), and a pure delay
  ``delay`` [s] on the force channel, applied here to the filter's output on the fixed step; the
  library's closest form (``order4_delay``) is two sections at one frequency, their dampings
  tied, and a delay.

and three *mimics*, effects outside the library that resemble one inside it (the right verdict
is `unexplained`, a tie, or the analogue named as partial; never the analogue alone):

- ``runin``: friction that falls as the track runs in, ``1 + a exp(-x/L)`` over the body's
  travel ``x`` (resembles ageing: more friction early on);
- ``drive_noise``: a random drive velocity, ``v_d (1 + n(t))`` with ``n`` an Ornstein-Uhlenbeck
  process (resembles the periodic screw error);
- ``gain``: the substrate moves a fixed fraction of its command at every frequency (resembles an
  actuator resonance).

Designs are random and unbalanced, some campaigns record the force only, some sample below twice
the forcing frequency, and the displacement channels are quantized like a real encoder. Run
``python3 tests/rig2/stand.py DIR --campaign NAME`` to write one (``--effect NAME:k=v,...`` adds one
of the stand's effects to it), ``--list`` for the panel; the
truth goes to ``DIR/../NAME.truth.json``, outside the campaign.
"""

import argparse
import json
import math
import os
import sys

import numpy as np
from numba import njit

# docs/model.md, Table 1.
M = 6.52 / 9.81
K_T = 71.318e6
H_T = 1.377e4
F_C = 8.3
F_S = 11.5
V_S = 0.35e-3
F_N = 36.52

STEP = 2.5e-6

# Parameter slots of the integrator.
(Q_KD, Q_VD, Q_HD, Q_OMEGA, Q_U0, Q_TON, Q_FS, Q_FC,
 Q_SENS, Q_SWN, Q_SZ, Q_SWLP,
 Q_ACT, Q_TAU_ACT,
 Q_NORM, Q_KN, Q_DELAY,
 Q_VISC2,
 Q_LORENTZ,
 Q_MEM, Q_DMEM,
 Q_RUNIN, Q_RA, Q_RL,
 Q_GAIN,
 Q_DAQ, Q_DAW1, Q_DAW2, Q_DDELAY,
 Q_LEN) = range(30)

# State: x, v, s (contact), sensor y, y', low-pass z, actuator u, memory phi, drive offset e,
# anti-alias sections (y1, y1', y2, y2').
NS = 13

# Fourth-order Bessel low-pass, normalised to -3 dB at 1: the sections' frequencies and damping.
BESSEL = ((1.4192, 0.9580), (1.5912, 0.6207))


@njit(cache=True)
def command(t, q):
    """Commanded substrate displacement and velocity."""
    if q[Q_U0] == 0.0 or t < q[Q_TON]:
        return 0.0, 0.0
    ph = q[Q_OMEGA] * (t - q[Q_TON])
    g = q[Q_GAIN] if q[Q_GAIN] > 0.0 else 1.0
    return g * q[Q_U0] * math.sin(ph), g * q[Q_U0] * q[Q_OMEGA] * math.cos(ph)


@njit(cache=True)
def substrate_velocity(t, y, q):
    if q[Q_ACT] > 0.0:
        uc, _ = command(t, q)
        return (uc - y[6]) / q[Q_TAU_ACT]
    return command(t, q)[1]


@njit(cache=True)
def drive_force(t, y, q):
    # y[8] is the drive's random position offset (zero without drive noise).
    xd = q[Q_VD] * t + y[8]
    return q[Q_KD] * (xd - y[0]) + q[Q_HD] * (q[Q_VD] - y[1])


@njit(cache=True)
def deriv(t, y, q, noise_rate, dy):
    vr = y[1] - substrate_velocity(t, y, q)
    scale = 1.0
    if q[Q_NORM] > 0.0:
        u_late, _ = command(t - q[Q_DELAY], q)
        if t - q[Q_DELAY] < q[Q_TON]:
            u_late = 0.0
        scale = 1.0 + q[Q_KN] * u_late / F_N
    if q[Q_RUNIN] > 0.0:
        scale *= 1.0 + q[Q_RA] * math.exp(-max(y[0], 0.0) / q[Q_RL])
    fs, fc = q[Q_FS] * scale, q[Q_FC] * scale
    if q[Q_MEM] > 0.0:
        level = y[7]
    elif q[Q_LORENTZ] > 0.0:
        level = 1.0 / (1.0 + (vr / V_S) ** 2)
    else:
        level = math.exp(-((vr / V_S) ** 2))
    g = (fc + (fs - fc) * level) / K_T
    ds = vr - abs(vr) * y[2] / g
    ht = H_T * math.exp(-((vr / q[Q_VD]) ** 2))
    ff = K_T * y[2] + ht * ds + q[Q_VISC2] * vr * abs(vr)
    fd = drive_force(t, y, q)
    dy[0] = y[1]
    dy[1] = (fd - ff) / M
    dy[2] = ds
    if q[Q_SENS] > 0.0:
        w = q[Q_SWN]
        dy[3] = y[4]
        dy[4] = w * w * (fd - y[3]) - 2.0 * q[Q_SZ] * w * y[4]
        dy[5] = q[Q_SWLP] * (y[3] - y[5])
    else:
        dy[3] = 0.0
        dy[4] = 0.0
        dy[5] = 0.0
    if q[Q_ACT] > 0.0:
        uc, _ = command(t, q)
        dy[6] = (uc - y[6]) / q[Q_TAU_ACT]
    else:
        dy[6] = 0.0
    if q[Q_MEM] > 0.0:
        dy[7] = abs(vr) / q[Q_DMEM] * (math.exp(-((vr / V_S) ** 2)) - y[7])
    else:
        dy[7] = 0.0
    dy[8] = noise_rate
    if q[Q_DAQ] > 0.0:
        w1, w2 = q[Q_DAW1], q[Q_DAW2]
        dy[9] = y[10]
        dy[10] = w1 * w1 * (fd - y[9]) - 2.0 * 0.9580 * w1 * y[10]
        dy[11] = y[12]
        dy[12] = w2 * w2 * (y[9] - y[11]) - 2.0 * 0.6207 * w2 * y[12]
    else:
        dy[9] = dy[10] = dy[11] = dy[12] = 0.0


@njit(cache=True)
def run(q, n_samples, per_sample, noise_v):
    """SSP-RK3 (Shu-Osher) at STEP; `noise_v[i]` is the drive's velocity fluctuation [m/s] held
    over sample interval i. Returns recorded force, body and drive positions."""
    y = np.zeros(NS)
    y[7] = 1.0
    a = np.zeros(NS)
    b = np.zeros(NS)
    k = np.zeros(NS)
    F = np.zeros(n_samples)
    X = np.zeros(n_samples)
    XD = np.zeros(n_samples)
    h = STEP
    # The delay of the acquisition in whole steps, and the filter's output over that many.
    nd = int(round(q[Q_DDELAY] / h)) if q[Q_DAQ] > 0.0 else 0
    ring = np.zeros(nd + 1)
    for i in range(n_samples):
        t_i = i * per_sample * h
        if q[Q_DAQ] > 0.0:
            step = i * per_sample
            ring[step % (nd + 1)] = y[11]
            F[i] = ring[(step - nd) % (nd + 1)] if step >= nd else 0.0
        else:
            F[i] = y[5] if q[Q_SENS] > 0.0 else drive_force(t_i, y, q)
        X[i] = y[0]
        XD[i] = q[Q_VD] * t_i + y[8]
        if i == n_samples - 1:
            break
        nv = noise_v[i]
        for j in range(per_sample):
            t = (i * per_sample + j) * h
            if q[Q_DAQ] > 0.0 and j > 0:
                step = i * per_sample + j
                ring[step % (nd + 1)] = y[11]
            deriv(t, y, q, nv, k)
            for m in range(NS):
                a[m] = y[m] + h * k[m]
            deriv(t + h, a, q, nv, k)
            for m in range(NS):
                b[m] = 0.75 * y[m] + 0.25 * (a[m] + h * k[m])
            deriv(t + 0.5 * h, b, q, nv, k)
            for m in range(NS):
                y[m] = y[m] / 3.0 + 2.0 / 3.0 * (b[m] + h * k[m])
    return F, X, XD


def params(cond, effects):
    q = np.zeros(Q_LEN)
    q[Q_KD], q[Q_VD], q[Q_HD] = cond["k_d"], cond["v_d"], cond.get("h_d", 0.0)
    q[Q_FS], q[Q_FC] = F_S, F_C
    f = cond.get("f", 0.0)
    if f > 0:
        q[Q_OMEGA] = 2.0 * math.pi * f
        q[Q_U0] = cond["v_a"] / q[Q_OMEGA]
        q[Q_TON] = cond.get("t_on", 0.0)
    for name, e in effects.items():
        if name == "sensor":
            q[Q_SENS], q[Q_SWN], q[Q_SZ] = 1.0, 2.0 * math.pi * e["f_n"], e["zeta"]
            q[Q_SWLP] = 2.0 * math.pi * e["f_lp"]
        elif name == "actuator":
            q[Q_ACT], q[Q_TAU_ACT] = 1.0, 1.0 / (2.0 * math.pi * e["f_c"])
        elif name == "normal":
            q[Q_NORM], q[Q_KN], q[Q_DELAY] = 1.0, e["k"], e["delay"]
        elif name == "viscous":
            q[Q_VISC2] = e["c2"]
        elif name == "stribeck":
            q[Q_LORENTZ] = 1.0
        elif name == "memory":
            q[Q_MEM], q[Q_DMEM] = 1.0, e["D"]
        elif name == "runin":
            q[Q_RUNIN], q[Q_RA], q[Q_RL] = 1.0, e["a"], e["L"]
        elif name == "gain":
            q[Q_GAIN] = e["g"]
        elif name == "daq":
            q[Q_DAQ] = 1.0
            q[Q_DAW1] = 2.0 * math.pi * BESSEL[0][0] * e["f_aa"]
            q[Q_DAW2] = 2.0 * math.pi * BESSEL[1][0] * e["f_aa"]
            q[Q_DDELAY] = e["delay"]
        elif name == "drive_noise":
            pass
        else:
            raise ValueError(f"unknown effect {name}")
    return q


def length(cond, cycles=2):
    """Time for `cycles` stick-slip cycles in the second half (of the vibrated stage), and the
    loading before the first slip."""
    tc = 2.0 * (F_S - F_C) / (cond["k_d"] * cond["v_d"])
    load = F_S / (cond["k_d"] * cond["v_d"])
    return cond.get("t_on", 0.0) + 2.0 * max((cycles + 1.5) * tc, load + 2.0 * tc)


def random_design(rng, drives, per_drive, f_range, ratio_range, two_stage=False):
    """`drives` random drives (v_d, k_d), each recorded without vibration and at `per_drive[i]`
    random vibrations (frequency log-uniform in `f_range`, v_a/v_d in `ratio_range`)."""
    out = []
    for i in range(drives):
        v_d = float(np.round(rng.uniform(0.6e-3, 2.0e-3), 5))
        k_d = float(np.round(rng.uniform(9000.0, 20000.0), -2))
        out.append(dict(v_d=v_d, k_d=k_d))
        for _ in range(per_drive[i]):
            f = float(np.round(math.exp(rng.uniform(*np.log(f_range))), -1))
            ratio = float(np.round(rng.uniform(*ratio_range), 2))
            c = dict(v_d=v_d, k_d=k_d, f=f, v_a=ratio * v_d)
            if two_stage:
                tc = 2.0 * (F_S - F_C) / (k_d * v_d)
                c["t_on"] = round(F_S / (k_d * v_d) + 1.5 * tc, 3)
            out.append(c)
    return out


# Each campaign: design (drives and vibrations per drive), frequencies, v_a/v_d, sampling rate,
# noise [N], displacement quantum [m] (None: force only), protocol, effects, and the verdict:
# None (no significant gap), "unexplained", a list (the library effect that stands for the
# injected one, partial or not; either of two for two effects), or {"mimic": [analogue]}
# (unexplained, a tie, or the analogue named as partial).
PANEL = {
    "free-random": dict(drives=4, per_drive=[3, 2, 4, 2], f=(500.0, 3000.0),
                        ratio=(0.3, 2.0), rate=6000.0, noise=0.03, quantum=1e-7,
                        effects={}, expect=None),
    "free-forceonly-lowrate": dict(drives=3, per_drive=[3, 3, 3], f=(1200.0, 2500.0),
                                   ratio=(0.3, 1.8), rate=3000.0, noise=0.02, quantum=None,
                                   effects={}, expect=None),
    "sensor-lowpass": dict(drives=4, per_drive=[3, 3, 2, 3], f=(500.0, 2500.0),
                           ratio=(0.3, 1.6), rate=10000.0, noise=0.02, quantum=1e-7,
                           effects={"sensor": dict(f_n=150.0, zeta=0.15, f_lp=400.0)},
                           expect=["sensor_dynamics"]),
    "actuator-lag": dict(drives=4, per_drive=[3, 3, 3, 2], f=(600.0, 3000.0),
                         ratio=(0.4, 2.5), rate=20000.0, noise=0.02, quantum=1e-7,
                         two_stage=True, effects={"actuator": dict(f_c=800.0)},
                         expect=["actuator_response"]),
    "normal-delay": dict(drives=4, per_drive=[3, 3, 3, 3], f=(800.0, 2500.0),
                         ratio=(0.3, 1.2), rate=12000.0, noise=0.02, quantum=1e-7,
                         effects={"normal": dict(k=6e7, delay=0.12e-3)},
                         expect=["normal_coupling"]),
    "viscous-quadratic": dict(drives=4, per_drive=[2, 3, 3, 2], f=(500.0, 2000.0),
                              ratio=(1.0, 3.0), rate=8000.0, noise=0.02, quantum=1e-7,
                              effects={"viscous": dict(c2=4e4)}, expect=["viscous"]),
    "stribeck-lorentz": dict(drives=4, per_drive=[2, 2, 3, 3], f=(500.0, 2500.0),
                             ratio=(0.3, 1.5), rate=8000.0, noise=0.02, quantum=1e-7,
                             effects={"stribeck": {}}, expect=["stribeck_shape"]),
    "memory-distance": dict(drives=4, per_drive=[3, 2, 3, 2], f=(500.0, 2500.0),
                            ratio=(0.3, 1.5), rate=8000.0, noise=0.02, quantum=1e-7,
                            effects={"memory": dict(D=3e-6)},
                            expect=["frictional_lag", "aging"]),
    "mimic-runin": dict(drives=4, per_drive=[3, 3, 2, 3], f=(500.0, 2500.0),
                        ratio=(0.3, 1.5), rate=8000.0, noise=0.03, quantum=1e-7,
                        effects={"runin": dict(a=0.3, L=1.0e-3)},
                        expect={"mimic": ["aging"]}),
    "mimic-drive-noise": dict(drives=4, per_drive=[3, 2, 3, 3], f=(500.0, 2500.0),
                              ratio=(0.3, 1.5), rate=8000.0, noise=0.02, quantum=1e-7,
                              effects={"drive_noise": dict(rel=0.4, tau=4e-3)},
                              expect={"mimic": ["drive_ripple"]}),
    "mimic-gain": dict(drives=4, per_drive=[3, 3, 3, 3], f=(500.0, 3000.0),
                       ratio=(0.4, 2.5), rate=15000.0, noise=0.02, quantum=1e-7,
                       effects={"gain": dict(g=0.55)}, expect={"mimic": ["actuator_response"]}),
    "daq-bessel-delay": dict(drives=4, per_drive=[3, 3, 2, 3], f=(500.0, 2500.0),
                             ratio=(0.3, 1.6), rate=10000.0, noise=0.02, quantum=1e-7,
                             effects={"daq": dict(f_aa=300.0, delay=0.3e-3)},
                             expect=["sensor_dynamics"], form="order4_delay"),
    "sensor+viscous": dict(drives=3, per_drive=[4, 2, 3], f=(500.0, 2000.0),
                           ratio=(0.5, 2.5), rate=10000.0, noise=0.05, quantum=None,
                           effects={"sensor": dict(f_n=120.0, zeta=0.2, f_lp=500.0),
                                    "viscous": dict(c2=4e4)},
                           expect=["sensor_dynamics", "viscous"]),
}


# The parameters of each of the stand's effects (as in ``PANEL``), and the library effect a right
# diagnosis names for it: what ``--effect`` may add to a campaign.
EFFECT_KEYS = {"sensor": ("f_n", "zeta", "f_lp"), "actuator": ("f_c",), "normal": ("k", "delay"),
               "viscous": ("c2",), "stribeck": (), "memory": ("D",), "daq": ("f_aa", "delay")}
LIBRARY = {"sensor": ["sensor_dynamics"], "actuator": ["actuator_response"],
           "normal": ["normal_coupling"], "viscous": ["viscous"], "stribeck": ["stribeck_shape"],
           "memory": ["frictional_lag", "aging"], "daq": ["sensor_dynamics"]}


def with_extra(spec, extra):
    """The campaign `spec` with the effects `extra` ({name: {key: value}}) added; the verdict it
    then expects: the library effects that stand for them. A mimic campaign takes none (its
    verdict rule is its own: ValueError)."""
    spec = dict(spec)
    if extra:
        if isinstance(spec["expect"], dict):
            raise ValueError("a mimic campaign takes no added effect (its verdict rule is its own)")
        spec["effects"] = {**spec["effects"], **extra}
        expect = [] if spec["expect"] is None else list(spec["expect"])
        for k in extra:
            expect += [e for e in LIBRARY[k] if e not in expect]
        spec["expect"] = expect
    return spec


def parse_effect(text):
    """``NAME:k=v,...`` as (name, {k: v}), or a ValueError saying what is wrong."""
    name, _, kv = text.partition(":")
    if name not in EFFECT_KEYS:
        raise ValueError(f"unknown effect {name!r}; allowed: {', '.join(sorted(EFFECT_KEYS))}")
    vals = {}
    for item in filter(None, kv.split(",")):
        k, _, v = item.partition("=")
        k = k.strip()
        if k not in EFFECT_KEYS[name]:
            raise ValueError(f"{name} has no parameter {k!r}; it takes "
                             f"{', '.join(EFFECT_KEYS[name]) or 'none'}")
        try:
            vals[k] = float(v)
        except ValueError:
            raise ValueError(f"{k} = {v!r} is not a number") from None
    missing = [k for k in EFFECT_KEYS[name] if k not in vals]
    if missing:
        raise ValueError(f"{name} needs {', '.join(missing)}")
    return name, vals


def record(out, stem, i, cond, n, rate, per_sample, spec, rng):
    """One recording of `n` samples at `rate` under the conditions `cond`, with the campaign
    `spec`'s effects, noise and encoder: STEM.csv and STEM.toml in `out`."""
    q = params(cond, spec["effects"])
    noise_v = np.zeros(n)
    if "drive_noise" in spec["effects"]:
        e = spec["effects"]["drive_noise"]
        # Ornstein-Uhlenbeck velocity fluctuation, exact update per sample interval.
        dt = 1.0 / rate
        rho = math.exp(-dt / e["tau"])
        sd = e["rel"] * cond["v_d"]
        w = rng.standard_normal(n)
        for j in range(1, n):
            noise_v[j] = rho * noise_v[j - 1] + sd * math.sqrt(1.0 - rho * rho) * w[j]
    F, X, XD = run(q, n, per_sample, noise_v)
    F = F + spec["noise"] * rng.standard_normal(n)
    t = np.arange(n) / rate
    cols, names = [t, F], ["t", "F_d"]
    if spec["quantum"] is not None:
        qn = spec["quantum"]
        # An encoder: positions rounded to its quantum (with a little jitter before it).
        cols += [np.round((X + 2e-9 * rng.standard_normal(n)) / qn) * qn,
                 np.round((XD + 2e-9 * rng.standard_normal(n)) / qn) * qn]
        names += ["x_s", "x_d"]
    # Columns in another order than the first rig's: drive force first.
    order = [1, 0] + list(range(2, len(cols)))
    np.savetxt(os.path.join(out, stem + ".csv"), np.column_stack([cols[k] for k in order]),
               delimiter=",", header=",".join(names[k] for k in order), comments="",
               fmt="%.10g")
    with open(os.path.join(out, stem + ".toml"), "w") as fh:
        fh.write(f"# drive and vibration of {stem}\nv_d = {cond['v_d']!r}\n"
                 f"k_d = {cond['k_d']!r}\n")
        if cond.get("f", 0.0) > 0:
            # u0 on odd recordings, v_a on even ones: both spellings are the user's.
            if i % 2:
                fh.write(f"f = {cond['f']!r}\nu0 = {cond['v_a'] / (2 * math.pi * cond['f'])!r}\n")
            else:
                fh.write(f"f = {cond['f']!r}\nv_a = {cond['v_a']!r}\n")
            if cond.get("t_on", 0.0) > 0:
                fh.write(f"t_on = {cond['t_on']!r}\n")
        else:
            fh.write("f = 0.0\nu0 = 0.0\n")


def record_plan(out, name, plan_dir, seed, extra=None):
    """The recordings a plan proposes (`stickslip plan`: every TOML with a [plan] table in
    `plan_dir`), made on this stand with the campaign `name`'s effects, noise and encoder, each
    for the plan's duration at the stand's nearest rate; each STEM.toml is the plan's own, so
    the campaign they join counts them as planned."""
    import shutil
    import tomllib

    spec = with_extra(PANEL[name], extra)
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(seed + 7919)
    files = sorted(f for f in os.listdir(plan_dir) if f.endswith(".toml"))
    made = 0
    for k, f in enumerate(files):
        with open(os.path.join(plan_dir, f), "rb") as fh:
            t = tomllib.load(fh)
        if "plan" not in t:
            continue
        per_sample = max(1, round(1.0 / (t["plan"]["rate"] * STEP)))
        rate = 1.0 / (per_sample * STEP)
        cond = dict(v_d=t["v_d"], k_d=t["k_d"])
        if t.get("f", 0.0) > 0 and t.get("u0", 0.0) > 0:
            cond.update(f=t["f"], v_a=2 * math.pi * t["f"] * t["u0"], t_on=t.get("t_on", 0.0))
        n = int(math.floor(t["plan"]["duration"] * rate)) + 1
        stem = f[:-5]
        record(out, stem, k, cond, n, rate, per_sample, spec, rng)
        shutil.copy(os.path.join(plan_dir, f), os.path.join(out, stem + ".toml"))
        made += 1
    if made == 0:
        sys.exit(f"{plan_dir}: no planned conditions (NAME.toml with a [plan] table)")


def write_campaign(out, name, seed, cycles=2, extra=None, noise_seed=None):
    """Campaign `name` (with the effects `extra` added) in `out`: its design drawn with `seed`,
    its noise too, or with `noise_seed` where one is given (the same design, another draw of
    the noise)."""
    spec = with_extra(PANEL[name], extra)
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(seed)
    conds = random_design(rng, spec["drives"], spec["per_drive"], spec["f"], spec["ratio"],
                          spec.get("two_stage", False))
    if noise_seed is not None:
        rng = np.random.default_rng(noise_seed)
    rate = spec["rate"]
    per_sample = max(1, round(1.0 / (rate * STEP)))
    # The recorder's clock: samples every per_sample steps (the rate is rounded to it).
    rate = 1.0 / (per_sample * STEP)
    for i, cond in enumerate(conds):
        n = int(math.floor(length(cond, cycles) * rate)) + 1
        record(out, f"run_{i + 1:02d}", i, cond, n, rate, per_sample, spec, rng)
    truth = dict(name=name, effects=spec["effects"], expect=spec["expect"], form=spec.get("form"),
                 rate=rate,
                 noise=spec["noise"], quantum=spec["quantum"], seed=seed, noise_seed=noise_seed,
                 recordings=len(conds))
    with open(os.path.join(os.path.dirname(os.path.abspath(out)), name + ".truth.json"),
              "w") as fh:
        json.dump(truth, fh, indent=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", nargs="?")
    ap.add_argument("--campaign", choices=sorted(PANEL))
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--noise-seed", type=int, default=None,
                    help="draw the noise with this seed, the design still with --seed")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--effect", action="append", default=[], metavar="NAME:k=v,...",
                    help="add an effect in this stand's own form to the campaign (repeatable; "
                         "every parameter given), e.g. sensor:f_n=300,zeta=0.15,f_lp=2000; the "
                         "truth then expects it")
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
    for text in a.effect:
        try:
            name, vals = parse_effect(text)
        except ValueError as e:
            ap.error(f"--effect {text}: {e}")
        extra[name] = vals
    try:
        with_extra(PANEL[a.campaign], extra)
    except ValueError as e:
        ap.error(f"--effect on {a.campaign}: {e}")
    if a.conditions:
        record_plan(a.dir, a.campaign, a.conditions, a.seed, extra=extra)
    else:
        write_campaign(a.dir, a.campaign, a.seed, extra=extra, noise_seed=a.noise_seed)


if __name__ == "__main__":
    sys.exit(main())
