#!/usr/bin/env bash
# The refined Fig. 11 boundary against a dense 64 x 64 map, side by side in one run:
# times of both sweeps and the comparison of their boundaries. Writes to results/boundary-bench/.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --quiet
out=results/boundary-bench
mkdir -p "$out"
bin=target/release/stickslip
for s in sweeps/fig11-boundary.toml benches/boundary/dense64.toml; do
    name=$(basename "$s" .toml)
    start=$(date +%s.%N)
    "$bin" sweep "$s" -o "$out/$name.h5" --overwrite --quiet --no-plot
    end=$(date +%s.%N)
    echo "$name: $(python3 -c "print(f\"{$end - $start:.1f}\")") s"
done
"$bin" boundary "$out/dense64.h5" > /dev/null
"$bin" boundary "$out/fig11-boundary.h5" > /dev/null
python3 benches/boundary/compare.py "$out/dense64_boundary.csv" "$out/fig11-boundary_boundary.csv"
