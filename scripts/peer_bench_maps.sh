#!/usr/bin/env bash
# Preston's map analysis side by side with prysm's on the same file (scripts/peer_bench_maps.py
# says what is measured and how). Makes its own virtualenv under target/ with pinned packages,
# builds the release binary, and prints a Markdown table. numpy 1.26: prysm 0.21.1 calls
# np.trapz, which numpy 2 removed. Usage: scripts/peer_bench_maps.sh [--runs 5]
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/prysm-bench-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet 'prysm==0.21.1' 'numpy==1.26.4' 'scipy==1.13.1'
fi
cargo build --release --quiet
echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
"$venv/bin/python" scripts/peer_bench_maps.py --binary target/release/preston "$@"
