#!/usr/bin/env bash
# Preston side by side with numpy + scipy (predict) and cvxpy + Clarabel (optimize), each
# request cold (a process the service has not seen) and cached (scripts/peer_bench.py says what
# is measured and how). Makes its own virtualenv under target/ with pinned packages, builds the
# release binary, and prints Markdown tables. Usage: scripts/peer_bench.sh [--sizes 501 2001]
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/peer-bench-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet 'numpy==2.1.3' 'scipy==1.14.1' 'cvxpy==1.6.0' 'clarabel==0.9.0'
fi
cargo build --release --quiet
echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
"$venv/bin/python" scripts/peer_bench.py --binary target/release/preston "$@"
