#!/usr/bin/env bash
# Regenerates the documentation's figures: the sweeps of Figs. 10 and 11 (a, b and the (u0, f)
# map with its elimination boundary) and the refined boundary of Fig. 11 run into results/,
# and their figures and boundaries are copied over the shipped ones in docs/img/. About 6
# minutes on 2 cores.
# Usage: bash results/regenerate.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
for s in fig10 fig11a fig11b fig11-map fig11-boundary; do
  /usr/bin/time -f "$s: %e s wall" ./target/release/stickslip sweep "sweeps/$s.toml" -o "results/$s.h5" --overwrite --quiet
  cp results/"$s"_*.png results/"$s"_*.svg docs/img/
  if [ -f "results/${s}_boundary.csv" ]; then cp "results/${s}_boundary.csv" docs/img/; fi
done
