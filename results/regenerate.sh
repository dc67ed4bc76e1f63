#!/usr/bin/env bash
# Regenerates the shipped figures in results/: the sweeps of Figs. 10 and 11 (a, b and the
# (u0, f) map with its elimination boundary) and the refined boundary of Fig. 11. About 6 minutes
# on 2 cores.
# Usage: bash results/regenerate.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
for s in fig10 fig11a fig11b fig11-map fig11-boundary; do
  /usr/bin/time -f "$s: %e s wall" ./target/release/stickslip sweep "sweeps/$s.toml" -o "results/$s.h5" --overwrite --quiet
done
