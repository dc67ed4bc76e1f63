#!/usr/bin/env bash
# Hybrid windows against the full model, side by side, one machine: r, mean force and wall time
# of `run --tier full` and `run --tier hybrid` at points below (and one above) the contact
# resonance, k_d = 11 700 N/m, v_d = 0.5 mm/s. "cold": a fresh process, the table built in it;
# "shared": the median of 7 repeats, the table built once (as in a sweep's k_d line).
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --quiet
bin=target/release/stickslip
field() { python3 -c "import json,sys; d=json.load(sys.stdin); print(' '.join(str(d[k]) for k in sys.argv[1:]))" "$@"; }
printf '%-6s %-5s | %-8s %-8s %-7s %-7s | %-8s %-8s | %-9s %-9s %-9s | %s\n' \
    f ratio r_full r_hyb mean_f mean_h dr dmean% full_ms hyb_cold hyb_shared tier_reason
for pt in "1500 0.2" "1500 0.4" "1500 1.0" "1200 0.4" "1000 1.0" "1741 0.4" "1000 0.4"; do
    set -- $pt
    read -r rf mf wf < <("$bin" run --f "$1" --va-ratio "$2" --no-trace --tier full --json | field r mean_force wall_time)
    read -r rh mh wh why < <("$bin" run --f "$1" --va-ratio "$2" --no-trace --tier hybrid --json | field r mean_force wall_time tier_reason)
    read -r ws < <("$bin" run --f "$1" --va-ratio "$2" --no-trace --tier hybrid --repeats 7 --json | field wall_time)
    python3 - "$1" "$2" "$rf" "$rh" "$mf" "$mh" "$wf" "$wh" "$ws" "$why" <<'PY'
import sys
f, q, rf, rh, mf, mh, wf, wh, ws, why = sys.argv[1:]
rf, rh, mf, mh, wf, wh, ws = map(float, (rf, rh, mf, mh, wf, wh, ws))
print(f"{f:<6} {q:<5} | {rf:<8.4f} {rh:<8.4f} {mf:<7.4f} {mh:<7.4f} | {rh - rf:<+8.4f} {100 * (mh / mf - 1):<+8.3f} | "
      f"{1e3 * wf:<9.1f} {1e3 * wh:<9.1f} {1e3 * ws:<9.1f} | {why}")
PY
done
