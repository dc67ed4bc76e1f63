#!/usr/bin/env bash
# Side by side, one machine: each sweep of benches/tiers with tier = "full" and with "auto",
# their wall times and their comparison (compare.py). Writes under results/tiers/.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --quiet
bin=target/release/stickslip
out=results/tiers
mkdir -p "$out"
for sweep in kd-4000 overnight-slice; do
    for tier in full auto; do
        sed "s/^tier = \"auto\"/tier = \"$tier\"/" "benches/tiers/$sweep.toml" > "$out/$sweep-$tier.toml"
        start=$(date +%s%N)
        "$bin" sweep "$out/$sweep-$tier.toml" -o "$out/$sweep-$tier.h5" --overwrite --no-plot -q | tail -1
        end=$(date +%s%N)
        echo "$sweep $tier: $(( (end - start) / 1000000 )) ms"
    done
    python3 benches/tiers/compare.py "$out/$sweep-full.h5" "$out/$sweep-auto.h5"
done
