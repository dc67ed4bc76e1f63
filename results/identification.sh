#!/usr/bin/env bash
# Identification rate of `stickslip diagnose` over the library: for each of the nine effects
# (magnitudes drawn from their realistic ranges), for effect-free data and for friction varying
# along the track (outside the library), synthesise a campaign with the full design (30
# recordings, 10 kHz, 0.02 N force noise), diagnose it without telling the effect, and tabulate
# verdict, named effect, held-out gap before and after, reduction and wall time.
# Writes results/identification.txt and results/diagnose-demo-*/ (verdict JSON, HDF5, plots).
# Usage: bash results/identification.sh [SEED]   (about 30 minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
seed=${1:-7}
work=$(mktemp -d)
out=results/identification.txt
printf "%-18s %-18s %-18s %7s %7s %9s %8s\n" injected verdict named E0 E1 reduction wall_s > "$out"
for e in none aging actuator_response normal_coupling sensor_dynamics drive_ripple viscous \
         stribeck_shape presliding frictional_lag track; do
  draw=(); [ "$e" != none ] && draw=(--draw "$e")
  ./target/release/stickslip synth "$work/$e" --seed "$seed" "${draw[@]}" > /dev/null
  ./target/release/stickslip diagnose "$work/$e" --out "results/diagnose-demo-$e" --no-plots > /dev/null
  python3 - "$e" "results/diagnose-demo-$e/diagnosis.json" >> "$out" <<'PY'
import json, sys
e, d = sys.argv[1], json.load(open(sys.argv[2]))
print(f"{e:<18s} {d['verdict']:<18s} {str(d['best_effect']):<18s} {d['gap_before']:7.2f} "
      f"{d['gap_after']:7.2f} {100 * d['reduction']:8.1f}% {d['wall_time']:8.1f}")
PY
  rm -rf "$work/$e"
done
cat "$out"
