"""Peer benchmark: the rig of docs/model.md solved by the tools a user would pick instead of
stickslip, side by side with stickslip in one run, on the same machine.

Peers: SciPy solve_ivp (Radau, BDF, LSODA; right-hand side and Jacobian compiled with numba),
SUNDIALS CVODE (BDF, through scikit-sundae), numbalsoda (LSODA, DOP853) and the diffsol crate
(BDF, Tsit5; benches/peers/diffsol); stickslip's Radau5, Rodas4, Dopri5, the switching
`auto` and Dopri5 with envelope following (`stickslip-envelope`), and the vibration averaged out
(`stickslip-averaged`, `--tier averaged`, its table built in every timed run; meant above the
contact resonance, `--freq 3000`); a `+early` suffix (`stickslip-envelope+early`) lets
stickslip end once the answer is known (`--early-stop`). Every peer integrates the same equations in the same scaled
variables z = y / w (w = F_s/k_d, v_d + v_a, F_s/k_t, the scales stickslip's atol uses), is
sampled on stickslip's output grid, and is measured with the same definitions (docs/model.md): dF over
the second half of the run, r against a tight run without vibration, the mean drive force.

For each peer and case a ladder of tolerances (rtol = atol) is timed (median of --repeats in one
process, the solve and its samples); the table reports the fastest setting whose r is within 0.01
of the reference and whose mean force is within 0.5 %. stickslip is timed the same way (`run
--repeats N --no-trace`: the integration and its measures, which it computes on the fly). The
reference is stickslip's Dopri5 at rtol = atol = 1e-11, every cycle integrated.

Run through benches/peers/run.sh, which installs what it needs.
"""

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from numba import cfunc, njit, types

ROOT = Path(__file__).resolve().parents[2]
STICKSLIP = ROOT / "target" / "release" / "stickslip"
DIFFSOL = Path(__file__).resolve().parent / "diffsol" / "target" / "release" / "stickslip-peer-diffsol"

# docs/model.md defaults and the Fig. 10 drive.
M = 6.52 / 9.81
K_T, H_T, H_V, F_C, F_S, V_S = 71.318e6, 1.377e4, 0.0, 8.3, 11.5, 0.35e-3
K_D, H_D, V_D, FREQ = 11700.0, 0.0, 0.5e-3, 1500.0
CASES = {"no_vibration": 0.0, "partial": 0.4, "eliminated": 2.0}


def params(ratio):
    """Parameter vector: m k_t h_t h_v F_c F_s v_s k_d h_d v_d u0 omega w0 w1 w2."""
    omega = 2 * math.pi * FREQ
    u0 = ratio * V_D / omega
    w = (F_S / K_D, V_D + ratio * V_D, F_S / K_T)
    return np.array([M, K_T, H_T, H_V, F_C, F_S, V_S, K_D, H_D, V_D, u0, omega, *w])


@njit(cache=True)
def rhs_scaled(t, z, p, out):
    m, k_t, h_t, h_v, f_c, f_s, v_s, k_d, h_d, v_d, u0, om, w0, w1, w2 = p
    x, v, s = z[0] * w0, z[1] * w1, z[2] * w2
    v_r = v - u0 * om * math.cos(om * t)
    g = (f_c + (f_s - f_c) * math.exp(-(v_r / v_s) ** 2)) / k_t
    sd = v_r - abs(v_r) * s / g
    ff = k_t * s + h_t * math.exp(-(v_r / v_d) ** 2) * sd + h_v * v_r
    fd = k_d * (v_d * t - x) + h_d * (v_d - v)
    out[0] = v / w0
    out[1] = (fd - ff) / m / w1
    out[2] = sd / w2


@njit(cache=True)
def jac_scaled(t, z, p, jac):
    m, k_t, h_t, h_v, f_c, f_s, v_s, k_d, h_d, v_d, u0, om, w0, w1, w2 = p
    v, s = z[1] * w1, z[2] * w2
    v_r = v - u0 * om * math.cos(om * t)
    e = math.exp(-(v_r / v_s) ** 2)
    g = (f_c + (f_s - f_c) * e) / k_t
    dg = (f_s - f_c) / k_t * e * (-2 * v_r / v_s ** 2)
    a = abs(v_r)
    sg = 1.0 if v_r > 0 else (-1.0 if v_r < 0 else 0.0)
    sd = v_r - a * s / g
    dsd_dv = 1 - sg * s / g + a * s * dg / g ** 2
    dsd_ds = -a / g
    h = h_t * math.exp(-(v_r / v_d) ** 2)
    dh = h * (-2 * v_r / v_d ** 2)
    dff_dv = dh * sd + h * dsd_dv + h_v
    dff_ds = k_t + h * dsd_ds
    w = (w0, w1, w2)
    j = np.zeros((3, 3))
    j[0, 1] = 1.0
    j[1, 0] = -k_d / m
    j[1, 1] = (-h_d - dff_dv) / m
    j[1, 2] = -dff_ds / m
    j[2, 1] = dsd_dv
    j[2, 2] = dsd_ds
    for r in range(3):
        for c in range(3):
            jac[r, c] = j[r, c] * w[c] / w[r]


@njit(cache=True)
def analyse(t, z, p, k, window_start):
    """docs/model.md's measures, as stickslip's Analyzer computes them: dF, mean force."""
    m, k_t, h_t, h_v, f_c, f_s, v_s, k_d, h_d, v_d, u0, om, w0, w1, w2 = p
    thr = 0.02 * (f_s - f_c)
    n = t.shape[0]
    ring = np.zeros(k)
    acc = 0.0
    filled = 0
    pos = 0
    rising = False
    ext = np.inf
    pending = np.nan
    drops = []
    smin, smax = np.inf, -np.inf
    total, cnt = 0.0, 0
    for i in range(n):
        f = k_d * (v_d * t[i] - z[i, 0] * w0) + h_d * (v_d - z[i, 1] * w1)
        acc += f - ring[pos]
        ring[pos] = f
        pos += 1
        if pos == k:
            pos = 0
            acc = ring.sum()
        filled = min(filled + 1, k)
        if filled < k or t[i] < window_start:
            continue
        sf = acc / k
        total += f
        cnt += 1
        smin = min(smin, sf)
        smax = max(smax, sf)
        if rising:
            if sf > ext:
                ext = sf
            elif sf < ext - thr:
                pending = ext
                rising = False
                ext = sf
        else:
            if sf < ext:
                ext = sf
            elif sf > ext + thr:
                if not math.isnan(pending):
                    drops.append(pending - ext)
                    pending = np.nan
                rising = True
                ext = sf
    mean = total / max(cnt, 1)
    if len(drops) == 0:
        return smax - smin, mean
    s = 0.0
    for d in drops:
        s += d
    return s / len(drops), mean


def grid(ratio, t_end):
    """stickslip's sampling (sim::sampling): spacing and samples per vibration period."""
    tc = 2 * (F_S - F_C) / (K_D * V_D)
    slip = math.pi * math.sqrt(M / K_D)
    dt0 = min(tc / 2000, slip / 40)
    if ratio == 0:
        dt, k = dt0, 1
    else:
        k = max(16, math.ceil(1 / (FREQ * dt0)))
        dt = 1 / (k * FREQ)
    n = int(math.floor(t_end / dt)) + 1
    return np.arange(n) * dt, k


def timed(fn, repeats):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    times.sort()
    return times[len(times) // 2], out


def scipy_peer(method):
    from scipy.integrate import solve_ivp

    def run(p, t_eval, tol, repeats):
        out = np.zeros(3)
        jac = np.zeros((3, 3))

        def f(t, z):
            rhs_scaled(t, z, p, out)
            return out.copy()

        def jf(t, z):
            jac_scaled(t, z, p, jac)
            return jac.copy()

        kw = {} if method == "LSODA" else {"jac": jf}

        def go():
            return solve_ivp(f, (0, t_eval[-1]), np.zeros(3), method=method, t_eval=t_eval, rtol=tol, atol=tol, **kw)

        tm, sol = timed(go, repeats)
        if not sol.success:
            return tm, None, sol.message
        return tm, sol.y.T, "success"

    return run


def cvode_peer(p, t_eval, tol, repeats):
    from sksundae.cvode import CVODE

    def f(t, z, zp):
        rhs_scaled(t, z, p, zp)

    def jf(t, z, zp, jj):
        jac_scaled(t, z, p, jj)

    def go():
        s = CVODE(f, method="BDF", rtol=tol, atol=tol, jacfn=jf, linsolver="dense", max_num_steps=10_000_000)
        return s.solve(t_eval, np.zeros(3))

    tm, sol = timed(go, repeats)
    if not sol.success:
        return tm, None, str(sol.message)
    return tm, np.asarray(sol.y), "success"


def numbalsoda_peer(kind):
    def run(p, t_eval, tol, repeats):
        import numbalsoda

        sig = types.void(types.double, types.CPointer(types.double), types.CPointer(types.double), types.CPointer(types.double))

        @cfunc(sig)
        def rhs_c(t, u, du, pp):
            z = np.empty(3)
            pa = np.empty(15)
            for i in range(3):
                z[i] = u[i]
            for i in range(15):
                pa[i] = pp[i]
            o = np.empty(3)
            rhs_scaled(t, z, pa, o)
            for i in range(3):
                du[i] = o[i]

        solver = numbalsoda.lsoda if kind == "LSODA" else numbalsoda.dop853

        def go():
            return solver(rhs_c.address, np.zeros(3), t_eval, data=p, rtol=tol, atol=tol, mxstep=100_000_000)

        tm, (usol, ok) = timed(go, repeats)
        return tm, (usol if ok else None), ("success" if ok else "failed")

    return run


def diffsol_peer(method):
    def run(ratio, t_end, tol, repeats):
        out = subprocess.run([str(DIFFSOL), method, str(ratio), str(t_end), repr(tol), str(repeats), repr(FREQ)], capture_output=True, text=True, check=True)
        return json.loads(out.stdout)

    return run


def stickslip_run(ratio, t_end, method, tol, repeats=1, flags=()):
    """One stickslip run; method `envelope` (or `envelope-<method>`) is Dopri5 (or that method)
    with envelope following, its extrapolation tolerance a hundred times the integration
    tolerance (the periods it integrates at `tol`); a `+early` suffix adds `--early-stop`."""
    extra = list(flags)
    # `<method>+early`: end once the answer is known (`--early-stop`; --t-end is then the longest
    # simulated time, and a settling force predicts the measures of the 3 to 6 s window).
    if method.endswith("+early"):
        method, extra = method[: -len("+early")], extra + ["--early-stop"]
    if method.startswith("envelope"):
        inner = method.split("-", 1)[1] if "-" in method else "dopri5"
        method, extra = inner, extra + ["--envelope", repr(min(0.1, 100 * tol))]
    # Timed in one process, median of the repeats, and measures without traces: as the peers
    # are timed (their solve and its output samples, in their own timing loop).
    # `averaged`: the vibration averaged out (`--tier averaged`), each repeat building its table
    # afresh as a single run does; every other method integrates the full model (`--tier full`).
    if method == "averaged":
        method, extra = "auto", extra + ["--tier", "averaged", "--fresh-tables"]
    else:
        extra = extra + ["--tier", "full"]
    args = [str(STICKSLIP), "run", "--t-end", str(t_end), "--f", repr(FREQ), "--va-ratio", str(ratio), "--solver", method, "--rtol", repr(tol), "--atol", repr(tol), "--json", "--no-trace", "--repeats", str(repeats), "-o", "/tmp/stickslip-peers.h5"] + extra
    last = json.loads(subprocess.run(args, capture_output=True, text=True, check=True).stdout)
    return last.get("wall_time_median", last["wall_time"]), last


def main():
    global FREQ
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--t-end", type=float, default=6.0, help="simulated time [s] (default 6)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tolerances", default="1e-3,1e-4,1e-5,1e-6,1e-7,1e-8")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--peers", default="scipy-Radau,scipy-BDF,scipy-LSODA,cvode-BDF,numbalsoda-LSODA,numbalsoda-DOP853,diffsol-bdf,diffsol-tsit45,stickslip-radau5,stickslip-rodas4,stickslip-dopri5,stickslip-auto,stickslip-envelope")
    ap.add_argument("--max-seconds", type=float, default=20.0, help="skip tighter tolerances of a peer once one run takes longer")
    ap.add_argument("--out", default=str(ROOT / "results" / "peers.json"))
    ap.add_argument("--freq", type=float, default=1500.0, help="vibration frequency [Hz] (default 1500, Fig. 10)")
    a = ap.parse_args()
    FREQ = a.freq
    tols = [float(x) for x in a.tolerances.split(",")]
    peers = a.peers.split(",")
    rows = []
    summary = {}
    for case in a.cases.split(","):
        ratio = CASES[case]
        p = params(ratio)
        t_eval, k = grid(ratio, a.t_end)
        _, ref = stickslip_run(ratio, a.t_end, "dopri5", 1e-11, flags=["--no-periodic"])
        ref_ss = ref["reference"] if ref["reference"] else ref
        d_f_ss = ref_ss["dF"]
        r_ref, mean_ref = ref["dF"] / d_f_ss, ref["mean_force"]
        print(f"{case}: reference r = {r_ref:.4f}, mean force = {mean_ref:.4f} N", flush=True)
        for peer in peers:
            family, method = peer.split("-", 1)
            best = None
            for tol in tols:
                try:
                    if family == "stickslip":
                        tm, res = stickslip_run(ratio, a.t_end, method, tol, a.repeats)
                        d_f, mean, status = res["dF"], res["mean_force"], res["status"]
                    elif family == "diffsol":
                        res = diffsol_peer(method)(ratio, a.t_end, tol, a.repeats)
                        tm, d_f, mean, status = res["time"], res["dF"], res["mean_force"], res["status"]
                    else:
                        runner = {"scipy": lambda: scipy_peer(method), "cvode": lambda: cvode_peer, "numbalsoda": lambda: numbalsoda_peer(method)}[family]()
                        tm, z, status = runner(p, t_eval, tol, a.repeats)
                        d_f, mean = analyse(t_eval, z, p, k, 0.5 * a.t_end) if z is not None and len(z) == len(t_eval) else (None, None)
                except Exception as e:  # a peer that fails is recorded, not fatal
                    tm, d_f, mean, status = float("nan"), None, None, f"error: {e}"
                ok = d_f is not None and mean is not None and status == "success"
                err_r = abs(d_f / d_f_ss - r_ref) if ok else None
                err_m = abs(mean - mean_ref) / mean_ref if ok else None
                row = dict(case=case, peer=peer, tol=tol, time=tm, r=(d_f / d_f_ss if ok else None), mean_force=mean, err_r=err_r, err_mean=err_m, status=status)
                rows.append(row)
                print(f"  {peer:20} tol {tol:7.0e}: {tm * 1e3:10.2f} ms  " + (f"|dr| {err_r:.1e} |dmean| {err_m:.1e}" if ok else status), flush=True)
                if ok and err_r <= 0.01 and err_m <= 0.005 and (best is None or tm < best["time"]):
                    best = row
                if tm > a.max_seconds:
                    break
            summary[(case, peer)] = best
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(rows, indent=1))
    print("\nFastest setting within |r - r_ref| <= 0.01 and |mean - ref| <= 0.5 % (median of", a.repeats, "runs):\n")
    print("| case | peer | tol | time per run | r error | mean force error |")
    print("|---|---|---|---|---|---|")
    for (case, peer), b in summary.items():
        if b is None:
            print(f"| {case} | {peer} | none met the target | | | |")
        else:
            print(f"| {case} | {peer} | {b['tol']:.0e} | {b['time'] * 1e3:.1f} ms | {b['err_r']:.1e} | {b['err_mean']:.1e} |")
    for case in a.cases.split(","):
        own = [summary[(case, p)] for p in peers if p.startswith("stickslip") and summary.get((case, p))]
        other = [summary[(case, p)] for p in peers if not p.startswith("stickslip") and summary.get((case, p))]
        if own and other:
            b_own = min(own, key=lambda r: r["time"])
            b_other = min(other, key=lambda r: r["time"])
            print(f"\n{case}: fastest peer {b_other['peer']} {b_other['time'] * 1e3:.1f} ms, stickslip {b_own['peer']} {b_own['time'] * 1e3:.1f} ms: ratio {b_other['time'] / b_own['time']:.2f}")
    print(f"\nwrote {a.out}")


if __name__ == "__main__":
    sys.exit(main())
