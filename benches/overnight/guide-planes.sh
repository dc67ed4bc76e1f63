#!/usr/bin/env bash
# Guided planes against planes refined alone, side by side in one run, on an eighth of the
# overnight threshold surface (benches/overnight/boundary-eighth.toml: two drive velocities,
# all 16 drive stiffnesses): wall time, runs, right-hand sides and CPU of each, and how their
# boundaries compare. Writes to results/boundary-bench/. About 25 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --quiet
out=results/boundary-bench
mkdir -p "$out"
bin=target/release/stickslip
guided=benches/overnight/boundary-eighth.toml
alone="$out/boundary-eighth-alone.toml"
grep -v '^guide_planes' "$guided" | sed 's/^name = "overnight-boundary-eighth"/name = "overnight-boundary-eighth-alone"/' > "$alone"
for s in "$guided" "$alone"; do
    name=$(basename "$s" .toml)
    start=$(date +%s.%N)
    "$bin" sweep "$s" -o "$out/$name.h5" --overwrite --quiet --no-plot
    end=$(date +%s.%N)
    echo "$name: $(python3 -c "print(f\"{$end - $start:.1f}\")") s"
    "$bin" boundary "$out/$name.h5" > /dev/null
done
python3 benches/overnight/compare_planes.py "$out/boundary-eighth.h5" "$out/boundary-eighth-alone.h5"
