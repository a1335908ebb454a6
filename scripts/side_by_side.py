#!/usr/bin/env python3
"""Predict and optimize, cold and cached, side by side against another build.

    scripts/side_by_side.py BASE_BINARY [NEW_BINARY]

Both services run on loopback at once (their own SQLite files under /tmp). Each figure is the
median of ROUNDS interleaved rounds' medians of REQUESTS requests (environment; 4 and 15 by
default): predict 201 x 201 (the paper's
experiment 1, 10 s at each position) and optimize 501 (uniform 100 nm over [0, 40] mm,
`machine: "unlimited"` as the peer benchmark). Cold: a new process per request (the workpiece
speed moved by 1e-9 relative), so nothing is cached; cached: the same request repeated.
"""
import http.client
import json
import os
import statistics
import subprocess
import sys
import time


def start(binary, port):
    process = subprocess.Popen(
        [binary, "serve", "--listen", f"127.0.0.1:{port}", "--drain-delay-ms", "0",
         "--database-url", f"sqlite:///tmp/side-by-side-{port}.db"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(200):
        try:
            c = http.client.HTTPConnection("127.0.0.1", port)
            c.request("GET", "/healthz")
            c.getresponse().read()
            return process
        except OSError:
            time.sleep(0.05)
    raise SystemExit(f"{binary} did not come up")


def body(kind, n, k):
    process = {"workpiece_radius_mm": 50, "tool_radius_mm": 10,
               "workpiece_rpm": -10 * (1 + 1e-9 * k), "tool_rpm": 200}
    positions = [50 * i / (n - 1) for i in range(n)]
    grid = {"start_mm": 0, "stop_mm": 50, "count": n}
    if kind == "predict":
        return {"process": process, "radial_grid": grid,
                "dwell": {"positions_mm": positions, "dwell_s": [10.0] * n}}
    return {"process": process, "radial_grid": grid, "positions_mm": positions,
            "target": {"uniform_depth_nm": 100},
            "clear_aperture": {"inner_mm": 0, "outer_mm": 40}, "machine": "unlimited"}


def median_ms(port, kind, n, cold, requests, k0):
    c = http.client.HTTPConnection("127.0.0.1", port)
    times = []
    for r in range(requests):
        payload = json.dumps(body(kind, n, k0 + r if cold else k0))
        started = time.perf_counter()
        c.request("POST", f"/v1/{kind}", payload, {"content-type": "application/json"})
        response = c.getresponse()
        data = response.read()
        times.append(time.perf_counter() - started)
        assert response.status == 200, data[:300]
    return statistics.median(times) * 1e3


def main():
    base = sys.argv[1]
    new = sys.argv[2] if len(sys.argv) > 2 else "target/release/preston"
    ports = {"before": 18901, "after": 18902}
    services = {"before": start(base, 18901), "after": start(new, 18902)}
    try:
        k = 1
        print("| request | before | after | after / before |\n|---|---|---|---|")
        for kind, n in (("predict", 201), ("optimize", 501)):
            for cold in (True, False):
                rounds = {"before": [], "after": []}
                for r in range(int(os.environ.get("ROUNDS", "4"))):
                    order = ("before", "after") if r % 2 == 0 else ("after", "before")
                    for name in order:
                        k += 1000
                        requests = int(os.environ.get("REQUESTS", "15"))
                        rounds[name].append(median_ms(ports[name], kind, n, cold, requests, k))
                b, a = statistics.median(rounds["before"]), statistics.median(rounds["after"])
                size = f"{n} × {n}" if kind == "predict" else str(n)
                print(f"| {kind} {size}, {'cold' if cold else 'cached'} | {b:.3f} ms "
                      f"| {a:.3f} ms | {a / b:.3f} |")
    finally:
        for service in services.values():
            service.terminate()


if __name__ == "__main__":
    main()
