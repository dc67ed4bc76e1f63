#!/usr/bin/env bash
# The plan's loop on the diagnosis bench's campaigns (benches/diagnose/run.sh makes them): for
# each, the campaign's diagnosis (reused where results/diagnose-bench-plan/NAME holds one of
# these recordings), a plan of 6 and 6 recordings drawn at random (--random), each recorded with
# the campaign's hidden truth (synth --conditions, another noise seed), added, and the campaign
# diagnosed again. Prints the plan's time and the verdicts before and after.
# Usage: bash benches/plan/run.sh [EFFECT ...]   (default: aging+sensor_dynamics sensor_dynamics)
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --quiet
bin=target/release/stickslip
bench=results/diagnose-bench
out=results/plan-bench
mkdir -p "$out"
effects=("$@")
[ ${#effects[@]} -eq 0 ] && effects=(aging+sensor_dynamics sensor_dynamics)
verdict() {
    python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
named = " + ".join(d["effects"] or d.get("tie") or [])
print(f"{d['verdict']}{' (partial)' if d.get('partial') else ''} {named}")
PY
}
for e in "${effects[@]}"; do
    camp="$bench/c-$e"
    if [ ! -d "$camp" ]; then
        echo "$e: no campaign $camp (bash benches/diagnose/run.sh $e makes it)"; continue
    fi
    # The hidden truth: the campaign's synth arguments again, into a scratch folder, with --truth.
    case "$e" in
        aging+sensor_dynamics) args=(--draw aging --effect sensor_dynamics:f_n=60,zeta=0.05) ;;
        *) args=(--draw "$e") ;;
    esac
    rm -rf "$out/truth-$e"
    "$bin" synth "$out/truth-$e" "${args[@]}" --seed 1 --design small --truth "$out/truth-$e.json" > /dev/null
    fx=$(python3 - "$out/truth-$e.json" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))["effects"]
print(" ".join(f"--effect {k}:" + ",".join(f"{p}={v!r}" for p, v in ps.items()) for k, ps in t.items()))
PY
)
    d0="$out/d0-$e"
    [ -f "$d0/diagnosis.json" ] || "$bin" diagnose "$camp" --out "$d0" --no-plots > "$out/d0-$e.log" 2>&1
    echo "$e: before: $(verdict "$d0/diagnosis.json")"
    for kind in plan random; do
        extra=(); [ $kind = random ] && extra=(--random --no-check)
        rm -rf "$out/$kind-$e" "$out/rec-$kind-$e" "$out/ext-$kind-$e"
        start=$(date +%s.%N)
        "$bin" plan "$camp" --diagnosis "$d0/diagnosis.json" --out "$out/$kind-$e" "${extra[@]}" > "$out/$kind-$e.log" 2>&1
        took=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$(date +%s.%N)")
        # shellcheck disable=SC2086
        "$bin" synth "$out/rec-$kind-$e" --conditions "$out/$kind-$e" $fx --seed 11 > /dev/null
        mkdir -p "$out/ext-$kind-$e" && cp "$camp"/* "$out/rec-$kind-$e"/* "$out/ext-$kind-$e/"
        "$bin" diagnose "$out/ext-$kind-$e" --out "$out/d-$kind-$e" --no-plots > "$out/d-$kind-$e.log" 2>&1
        echo "$e: $kind ($took s): after: $(verdict "$out/d-$kind-$e/diagnosis.json")"
    done
done
