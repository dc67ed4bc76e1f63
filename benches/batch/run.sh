#!/usr/bin/env bash
# The batch path against the scalar path on a 1024-point slice of the overnight grid below the
# contact resonance (benches/batch/slice.toml, --tier full), side by side in one run, and the
# two files compared (identical bit for bit but for wall times). With OLD=/path/to/stickslip, a
# build of another commit runs the slice too, and its r and mean force are compared with this
# build's against the convergence rule (r within 0.005, mean force within 0.5 %).
#   bash benches/batch/run.sh            (about 3 minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --quiet
out=results/bench-batch
mkdir -p "$out"
bin=target/release/stickslip
for path in batch scalar; do
    flag=""; [ "$path" = scalar ] && flag="--scalar"
    $bin sweep benches/batch/slice.toml -o "$out/$path.h5" --no-plot --quiet --overwrite $flag | tail -1
done
python3 tests/python/compare_sweeps.py "$out/batch.h5" "$out/scalar.h5"
if [ -n "${OLD:-}" ]; then
    "$OLD" sweep benches/batch/slice.toml -o "$out/old.h5" --no-plot --quiet --overwrite | tail -1
    python3 benches/batch/compare.py "$out/batch.h5" "$out/old.h5"
fi
