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
# The divan benchmark binary, for Preston's in-process figure (the same work as the library
# call prysm's figure is).
bench=$(cargo bench --bench maps --no-run --message-format=json 2>/dev/null \
    | "$venv/bin/python" -c 'import json,sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "maps" and m.get("executable"):
        print(m["executable"])')
echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
"$venv/bin/python" scripts/peer_bench_maps.py --binary target/release/preston --bench "$bench" "$@"
