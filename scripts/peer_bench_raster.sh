#!/usr/bin/env bash
# Preston's X-Y plan side by side with scipy's lsq_linear and RIFTA on the public fluid-jet
# case (scripts/peer_bench_raster.py says what is measured and how). Makes its own virtualenv
# under target/ with pinned packages, builds the release binary and the problem's export, and
# prints a Markdown table. Usage: scripts/peer_bench_raster.sh [--runs 5]
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/raster-bench-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet 'numpy==1.26.4' 'scipy==1.13.1'
fi
cargo build --release --quiet --bin preston --example raster_problem
problem=target/raster-problem
target/release/examples/raster_problem fixtures/maps/fluid_jet_request.json "$problem" > /dev/null
echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
"$venv/bin/python" scripts/peer_bench_raster.py --binary target/release/preston --problem "$problem" "$@"
