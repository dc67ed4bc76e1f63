#!/usr/bin/env bash
# Peer benchmark: installs the peers (SciPy, numba, scikit-sundae/CVODE, numbalsoda, diffsol),
# builds stickslip and the diffsol peer, and runs everything side by side in one process.
# Not part of the test suite. Usage: bash benches/peers/run.sh [peers.py options]
set -euo pipefail
cd "$(dirname "$0")/../.."
if ! command -v gfortran >/dev/null; then
  if [ "$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq gfortran >/dev/null; else echo "numbalsoda needs gfortran to build" >&2; fi
fi
python3 -m pip install --quiet --disable-pip-version-check -r benches/peers/requirements.txt
cargo build --release --quiet
cargo build --release --quiet --manifest-path benches/peers/diffsol/Cargo.toml
exec python3 benches/peers/peers.py "$@"
