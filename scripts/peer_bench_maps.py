"""Preston's map analysis against prysm's, side by side on the same file.

The file is the real Fizeau map in fixtures/maps (prysm's own MetroPro sample, 425 x 432
pixels). Each side does the same analysis, medians over the runs:

- prysm 0.21.1, in-process: read the .dat (Interferogram.from_zygo_dat), remove piston and
  tip/tilt, fit the 37 Fringe Zernike terms (unit RMS, on the valid pixels' radius) by its
  lstsq, fill the missing pixels and take the PSD with its band-limited RMS for three bands.
- Preston, end to end over HTTP on loopback (the file sent as the body, the JSON answer read):
  read, boundary fit, piston and tilt, the same 37 terms, the PSD and its three bands, and
  besides the ISO 10110 figures, the radial profile and the non-axisymmetric part.

A cold Preston figure is the first request of a fresh process; the others are the medians of
the following requests (nothing is cached between them: a map analysis keeps no state).

With --bench (the divan binary of benches/maps.rs), Preston in-process as well: the file's
bytes read and analysed by the library, as prysm's figure is a library call. Each run takes
the median of 15 analyses in a fresh benchmark process, runs interleaved with prysm's.

Usage: python scripts/peer_bench_maps.py --binary target/release/preston [--bench BIN] [--runs 5]
(scripts/peer_bench_maps.sh makes the virtualenv, builds Preston and runs this.)
"""

import argparse
import http.client
import re
import socket
import statistics
import subprocess
import time
from pathlib import Path

import numpy as np
from prysm.coordinates import cart_to_polar, make_xy_grid
from prysm.interferogram import Interferogram
from prysm.polynomials import fringe_to_nm, lstsq, zernike_nm_sequence

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "fixtures/maps/valid_zygo_dat_file.dat"


def prysm_analysis():
    i = Interferogram.from_zygo_dat(str(SAMPLE))
    i.remove_piston()
    i.remove_tiptilt()
    nms = [fringe_to_nm(j) for j in range(1, 37)] + [(12, 0)]
    x, y = make_xy_grid(i.data.shape, dx=i.dx)
    r, t = cart_to_polar(x, y)
    valid = np.isfinite(i.data)
    radius = r[valid].max()
    modes = list(zernike_nm_sequence(nms, r / radius, t, norm=True))
    coefficients = lstsq(modes, i.data)
    i.fill()
    bands = [i.bandlimited_rms(flow=lo, fhigh=hi) for lo, hi in ((0, 0.2), (0.2, 0.85), (0.85, 4.3))]
    return coefficients, bands


def in_process(bench):
    """Median (s) of 15 analyses of the sample in one run of the divan benchmark binary."""
    out = subprocess.run([bench, "--bench", "sample_file_read_and_analysed", "--sample-count", "15"],
                         capture_output=True, text=True, check=True).stdout
    line = next(l for l in out.splitlines() if "sample_file_read_and_analysed" in l)
    value, unit = re.findall(r"([0-9.]+) (ns|µs|ms|s)\b", line)[2]  # fastest, slowest, median
    return float(value) * {"ns": 1e-9, "µs": 1e-6, "ms": 1e-3, "s": 1.0}[unit]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def preston_request(port, body):
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    connection.request("POST", "/v1/maps/analysis", body, {"Content-Type": "application/octet-stream"})
    response = connection.getresponse()
    answer = response.read()
    assert response.status == 200, answer[:300]
    connection.close()
    return answer


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", required=True)
    parser.add_argument("--bench")
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    body = SAMPLE.read_bytes()
    prysm_times, library_times = [], []
    for run in range(args.runs + 1):
        start = time.perf_counter()
        prysm_analysis()
        prysm_times.append(time.perf_counter() - start)
        if args.bench and run > 0:
            library_times.append(in_process(args.bench))
    prysm_times = prysm_times[1:]  # the first imports and warms numpy's caches
    port = free_port()
    service = subprocess.Popen([args.binary, "--listen", f"127.0.0.1:{port}"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(100):
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.1).close()
                break
            except OSError:
                time.sleep(0.05)
        start = time.perf_counter()
        preston_request(port, body)
        cold = time.perf_counter() - start
        times = []
        for _ in range(args.runs):
            start = time.perf_counter()
            preston_request(port, body)
            times.append(time.perf_counter() - start)
    finally:
        service.terminate()
        service.wait()
    p, q = statistics.median(prysm_times), statistics.median(times)
    print("| analysis of the 425 x 432 MetroPro sample | median (ms) |")
    print("|---|---|")
    print(f"| prysm 0.21.1 (read, piston/tilt, 37 Fringe terms, PSD, 3 bands) | {1e3 * p:.1f} |")
    if library_times:
        lib = statistics.median(library_times)
        print(f"| Preston in-process (the same, plus ISO 10110, radial profile, non-axisymmetric) | {1e3 * lib:.1f} |")
    print(f"| Preston over HTTP, cold (first request of the process) | {1e3 * cold:.1f} |")
    print(f"| Preston over HTTP (same, plus ISO 10110, radial profile, non-axisymmetric) | {1e3 * q:.1f} |")
    if library_times:
        print(f"\nIn-process (library against library), Preston is {p / lib:.1f}x prysm's speed.")
    print(f"Over HTTP, Preston is {p / q:.1f}x prysm's speed ({args.runs} runs each, medians).")


if __name__ == "__main__":
    main()
