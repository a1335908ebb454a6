#!/usr/bin/env bash
# Load test on loopback, bounded in time (about 3 minutes): a sustained run and a 4× overload
# run against POST /v1/predict (paper experiment 1, 201 × 201) and POST /v1/optimize (paper
# experiment 1, 501 × 501), with the service at its defaults. Prints one RESULT line per run
# (throughput, p50/p99 latency, responses by status, socket errors) and the server's peak RSS.
# Needs wrk (Debian: apt-get install wrk). Results are recorded in docs/PERFORMANCE.md.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v wrk >/dev/null || { echo "wrk is needed: apt-get install wrk" >&2; exit 1; }

duration=${DURATION:-20s}
port=${PORT:-18788}
cargo build --release --locked --quiet
./target/release/preston serve --listen "127.0.0.1:$port" --drain-delay-ms 0 \
    > target/loadtest-server.log 2>&1 &
server=$!
trap 'kill "$server" 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  curl -sf "http://127.0.0.1:$port/healthz" >/dev/null && break
  sleep 0.1
done

run() { # name, endpoint, fixture, connections[, vary]
  local name=$1 endpoint=$2 fixture=$3 connections=$4 vary=${5:-}
  # Warm up (first requests fill the caches), then measure.
  BODY="fixtures/$fixture" VARY="$vary" wrk -t2 -c2 -d2s -s scripts/loadtest.lua \
      "http://127.0.0.1:$port$endpoint" >/dev/null
  echo "== $name: $connections connections, $duration"
  BODY="fixtures/$fixture" VARY="$vary" wrk -t2 -c"$connections" -d"$duration" --timeout 30s \
      -s scripts/loadtest.lua "http://127.0.0.1:$port$endpoint" | grep '^RESULT'
}

run "predict sustained" /v1/predict predict_paper_exp1_201.json 16
# The same with a new process per request: a new pressure each time (same set-up and η), a new
# workpiece speed (a new η) each time, a new tool radius (a new set-up) each time: what a
# stream of different jobs costs against one repeated job.
run "predict sustained, new pressure per request" /v1/predict predict_paper_exp1_201.json 16 pressure
run "predict sustained, new speed per request" /v1/predict predict_paper_exp1_201.json 16 speed
run "predict sustained, new geometry per request" /v1/predict predict_paper_exp1_201.json 16 geometry
run "predict 4x overload" /v1/predict predict_paper_exp1_201.json 64
run "optimize sustained" /v1/optimize optimize_paper_exp1.json 2
run "optimize 4x overload" /v1/optimize optimize_paper_exp1.json 8

echo "== server peak RSS: $(grep VmHWM /proc/$server/status | tr -s ' ')"
echo "== load shed: $(curl -s "http://127.0.0.1:$port/metrics" | grep '^preston_load_shed_total' || echo none)"
kill "$server"
wait "$server" || true

# The same overload against a server with a short queue (8): the excess is shed with 503 +
# Retry-After at once instead of queueing, and the admitted requests keep their latency.
./target/release/preston serve --listen "127.0.0.1:$port" --drain-delay-ms 0 \
    --max-queued-computations 8 > target/loadtest-server-shed.log 2>&1 &
server=$!
for _ in $(seq 100); do
  curl -sf "http://127.0.0.1:$port/healthz" >/dev/null && break
  sleep 0.1
done
run "predict 4x overload, queue 8" /v1/predict predict_paper_exp1_201.json 64
echo "== server peak RSS: $(grep VmHWM /proc/$server/status | tr -s ' ')"
echo "== load shed: $(curl -s "http://127.0.0.1:$port/metrics" | grep '^preston_load_shed_total' || echo none)"
