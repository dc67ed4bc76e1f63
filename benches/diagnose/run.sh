#!/usr/bin/env bash
# The diagnosis's speed on 30-recording synth campaigns (the paper's design, 5 drives x 6
# vibrations, seed 1): each effect of the library drawn alone, and ageing with a 60 Hz sensor,
# one after the other on this machine. Prints, per campaign, the wall time, the simulations and
# their CPU time (the JSON's `work`) and the verdict. Writes under results/diagnose-bench/.
# Usage: bash benches/diagnose/run.sh [EFFECT ...]   (default: all nine, then the pair)
# One run at a time: each run replaces the campaigns and reports under results/diagnose-bench/.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --quiet
bin=target/release/stickslip
out=results/diagnose-bench
mkdir -p "$out"
effects=("$@")
if [ ${#effects[@]} -eq 0 ]; then
    effects=(aging sensor_dynamics actuator_response normal_coupling drive_ripple viscous
        stribeck_shape presliding frictional_lag aging+sensor_dynamics)
fi
printf '%-24s %8s %8s %9s %8s  %s\n' campaign wall_s sims sim_cpu_s hits verdict
for e in "${effects[@]}"; do
    dir="$out/c-$e"
    rm -rf "$dir"
    case "$e" in
        aging+sensor_dynamics) args=(--draw aging --effect sensor_dynamics:f_n=60,zeta=0.05) ;;
        *) args=(--draw "$e") ;;
    esac
    # A campaign that cannot be made or diagnosed is reported, and the others still run.
    if ! "$bin" synth "$dir" "${args[@]}" --seed 1 > "$out/s-$e.log" 2>&1; then
        printf '%-24s synth failed: %s\n' "$e" "$(tail -1 "$out/s-$e.log")"
        continue
    fi
    if ! "$bin" diagnose "$dir" --out "$out/d-$e" --no-plots > "$out/d-$e.log" 2>&1; then
        printf '%-24s diagnose failed: %s\n' "$e" "$(tail -1 "$out/d-$e.log")"
        continue
    fi
    python3 - "$out/d-$e/diagnosis.json" "$e" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
w = d["work"]
named = " + ".join(d["effects"] or d.get("tie") or [])
partial = " (partial)" if d.get("partial") else ""
print(f"{sys.argv[2]:<24} {d['wall_time']:8.1f} {w['simulations']:8d} {w['simulation_cpu']:9.1f} "
      f"{w['cache_hits']:8d}  {d['verdict']}{partial} {named}")
PY
done
