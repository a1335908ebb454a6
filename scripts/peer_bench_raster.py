"""Preston's X-Y dwell plan against scipy's lsq_linear and RIFTA, side by side on the public
fluid-jet case (fixtures/maps: a measured 26 x 372 surface of 0.32 mm pixels and a measured
fluid-jet influence function, MIT, from TWANG006/surface-extension).

One problem for every solver: the removal matrix M of Preston's raster (1,501 dwell points on
the 1.28 mm default pitch, each column the exact removal per second of dwell of that point's
executed cell, on the map's pixels with data), exported once by `examples/raster_problem.rs`
from the same request the service gets. The objective is Preston's with the time weight set
to 0 (a linear term lsq_linear cannot hold):

    minimise  1/(2 m s_d^2) * ||M t + c - d||^2  +  lambda/(2 E tau^2) * sum_edges (t_a - t_b)^2
    over      t >= floors (the axes' velocity and acceleration limits as least dwell), c free

(m the pixels, s_d and tau Preston's depth and dwell scales, lambda = 1e-4 the smoothing over
the E neighbour pairs, c the piston). Each side is judged on the same matrix: the residual
RMS over the aperture with piston and tilt removed by least squares, the total dwell and the
objective.

- **Preston**: `POST /v1/maps/optimize` over HTTP on loopback (the request as JSON, the answer
  read), `objective.time_weight` 0. Cold = the first request of a fresh process; then the
  median of the following requests (nothing is cached between them).
- **scipy** `lsq_linear` (scipy 1.13.1), bounded, on the sparse matrix (CSR, `trf` with
  `lsmr`), the smoothing as extra rows and the piston as a free column; its default
  tolerance. Timed from the matrix in memory: building it is not counted.
- **RIFTA** (Wang et al., Sci. Rep. 10, 8135, 2020), written here from the paper: the dwell
  by FFT inverse filtering of the target with the influence function (thresholded at gamma
  times the spectrum's peak), the threshold searched for the least residual, the target's
  piston raised so the dwell is non-negative, and the dwell sampled at the dwell points. It
  plans point dwells on the map's grid and knows no motion, so its plan is judged here twice:
  as it planned it (its own point-dwell model), and as the machine executes it (its dwell at
  Preston's points through the matrix M, floors applied).

Usage: python scripts/peer_bench_raster.py --binary target/release/preston --problem DIR [--runs 5]
(scripts/peer_bench_raster.sh makes the virtualenv, builds Preston and the export and runs this.)
"""

import argparse
import http.client
import json
import socket
import statistics
import subprocess
import time
from pathlib import Path

import numpy as np
from scipy import sparse
from scipy.optimize import lsq_linear

ROOT = Path(__file__).resolve().parents[1]
REQUEST = ROOT / "fixtures/maps/fluid_jet_request.json"


def load(problem: Path):
    meta = json.loads((problem / "meta.json").read_text())
    rows = np.fromfile(problem / "rows.u32", dtype="<u4")
    cols = np.fromfile(problem / "cols.u32", dtype="<u4")
    vals = np.fromfile(problem / "vals.f64", dtype="<f8")
    m, n = meta["rows"], meta["points"]
    matrix = sparse.csr_matrix((vals, (rows, cols)), shape=(m, n))
    vectors = {
        name: np.fromfile(problem / f"{name}.f64", dtype="<f8")
        for name in ["target", "x", "y", "lower"]
    }
    edges = np.fromfile(problem / "edges.u32", dtype="<u4").reshape(-1, 2)
    points = np.fromfile(problem / "points.f64", dtype="<f8").reshape(-1, 2)
    return meta, matrix, vectors, edges, points


def figures(matrix, v, t):
    """Residual RMS (piston and tilt removed), PV, and the total dwell of plan t on M."""
    r = matrix @ t - v["target"]
    basis = np.column_stack([np.ones_like(r), v["x"], v["y"]])
    coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
    r = r - basis @ coef
    return float(np.sqrt(np.mean(r**2))), float(r.max() - r.min()), float(t.sum())


def objective(meta, matrix, v, edges, t):
    m, sd, tau, lam = meta["rows"], meta["depth_scale"], meta["dwell_scale"], meta["smoothing"]
    r = matrix @ t - v["target"]
    r = r - r.mean()  # the free piston's optimum
    smooth = np.sum((t[edges[:, 0]] - t[edges[:, 1]]) ** 2)
    return 0.5 * r @ r / (m * sd**2) + 0.5 * lam * smooth / (len(edges) * tau**2)


def scipy_plan(meta, matrix, v, edges):
    m, n = matrix.shape
    sd, tau, lam = meta["depth_scale"], meta["dwell_scale"], meta["smoothing"]
    fit = sparse.hstack([matrix, np.ones((m, 1))]) / (np.sqrt(m) * sd)
    e = len(edges)
    diff = sparse.csr_matrix(
        (
            np.concatenate([np.ones(e), -np.ones(e)]),
            (np.concatenate([np.arange(e)] * 2), np.concatenate([edges[:, 0], edges[:, 1]])),
        ),
        shape=(e, n + 1),
    ) * np.sqrt(lam / (e * tau**2))
    a = sparse.vstack([fit, diff]).tocsr()
    b = np.concatenate([v["target"] / (np.sqrt(m) * sd), np.zeros(e)])
    lower = np.concatenate([v["lower"], [-np.inf]])
    upper = np.full(n + 1, np.inf)
    start = time.perf_counter()
    result = lsq_linear(a, b, bounds=(lower, upper), method="trf", lsq_solver="lsmr")
    seconds = time.perf_counter() - start
    return result.x[:n], seconds, result


def rifta(surface, spot, spot_px, map_px, points_px, lower):
    """RIFTA's dwell at the points: inverse filtering with a searched threshold (module docs)."""
    # The influence function resampled onto the map's pixels, centred.
    h, w = surface.shape
    centre = np.array(spot.shape[::-1], float) / 2 - 0.5
    reach = int(np.ceil(max(spot.shape) * spot_px / map_px / 2)) + 1
    ky, kx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    cx = centre[0] + kx * map_px / spot_px
    cy = centre[1] + ky * map_px / spot_px

    def bilinear(img, x, y):
        x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
        fx, fy = x - x0, y - y0

        def at(i, j):
            ok = (i >= 0) & (j >= 0) & (i < img.shape[1]) & (j < img.shape[0])
            out = np.zeros_like(x)
            out[ok] = img[j[ok], i[ok]]
            return out

        return (at(x0, y0) * (1 - fx) + at(x0 + 1, y0) * fx) * (1 - fy) + (
            at(x0, y0 + 1) * (1 - fx) + at(x0 + 1, y0 + 1) * fx
        ) * fy

    kernel = bilinear(spot, cx, cy) * (map_px / spot_px) ** 2 / (map_px / spot_px) ** 2
    # Surface extension as RIFTA's examples do: zeros around, the target raised to >= 0.
    pad = kernel.shape[0]
    big = np.zeros((h + 2 * pad, w + 2 * pad))
    valid = np.isfinite(surface)
    z = np.where(valid, surface, np.nan)
    z = z - np.nanmin(z)
    big[pad : pad + h, pad : pad + w] = np.nan_to_num(z)
    shape = big.shape
    kfull = np.zeros(shape)
    kfull[: kernel.shape[0], : kernel.shape[1]] = kernel
    kfull = np.roll(kfull, (-reach, -reach), axis=(0, 1))
    kf = np.fft.fft2(kfull)
    zf = np.fft.fft2(big)
    best = None
    for gamma in np.logspace(-4, -0.5, 36):
        keep = np.abs(kf) > gamma * np.abs(kf).max()
        inv = np.zeros_like(kf)
        inv[keep] = 1 / kf[keep]
        t = np.real(np.fft.ifft2(zf * inv))
        t = np.maximum(t, 0)
        removal = np.real(np.fft.ifft2(np.fft.fft2(t) * kf))
        r = (removal - big)[pad : pad + h, pad : pad + w][valid]
        r = r - r.mean()
        rms = np.sqrt(np.mean(r**2))
        if best is None or rms < best[0]:
            best = (rms, gamma, t)
    rms, gamma, t = best
    # Point dwell on the map's grid per pixel; at Preston's points, the dwell of the cell each
    # owns (its area of pixels), no less than the floors.
    step = points_px
    at_points = []
    for (i, j) in step:
        y0, x0 = j + pad, i + pad
        at_points.append(t[y0, x0])
    return rms, gamma, float(t[pad:-pad, pad:-pad].sum()), np.array(at_points)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def post(port, path, body):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=600)
    start = time.perf_counter()
    conn.request("POST", path, body=body, headers={"content-type": "application/json"})
    reply = conn.getresponse()
    data = reply.read()
    seconds = time.perf_counter() - start
    if reply.status != 200:
        raise SystemExit(f"{path}: {reply.status} {data[:300]!r}")
    return json.loads(data), seconds


def preston(binary, body, runs):
    port = free_port()
    server = subprocess.Popen(
        [binary, "serve", "--listen", f"127.0.0.1:{port}", "--solver-time-limit-ms", "600000",
         "--database-url", "sqlite::memory:", "--drain-delay-ms", "0"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        for _ in range(300):
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.1).close()
                break
            except OSError:
                time.sleep(0.1)
        times, answer = [], None
        for _ in range(runs + 1):
            answer, seconds = post(port, "/v1/maps/optimize", body)
            times.append(seconds)
        return answer, times[0], statistics.median(times[1:])
    finally:
        server.terminate()
        server.wait()


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", required=True)
    parser.add_argument("--problem", required=True, type=Path)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    meta, matrix, v, edges, points = load(args.problem)
    request = json.loads(REQUEST.read_text())
    request["objective"] = {"time_weight": 0.0}
    answer, cold, warm = preston(args.binary, json.dumps(request), args.runs)
    ours = np.array(answer["dwell"]["dwell_s"])
    theirs = np.array(answer["dwell"]["points_mm"])
    if theirs.shape != points.shape or np.abs(theirs - points).max() > 1e-9:
        raise SystemExit("the service's points are not the exported problem's")
    scipy_times, scipy_t = [], None
    for _ in range(max(1, args.runs // 2)):
        scipy_t, seconds, result = scipy_plan(meta, matrix, v, edges)
        scipy_times.append(seconds)
    rows = []
    for name, t, seconds in [
        ("Preston (HTTP, warm median)", ours, warm),
        ("scipy lsq_linear (trf, lsmr)", scipy_t, statistics.median(scipy_times)),
    ]:
        rms, pv, total = figures(matrix, v, t)
        rows.append((name, rms, pv, total, objective(meta, matrix, v, edges, t), seconds))
    print(f"problem: {matrix.shape[0]} pixels x {matrix.shape[1]} points, {matrix.nnz} non-zeros")
    print(f"before: {figures(matrix, v, np.zeros(matrix.shape[1]))[0]:.4f} nm RMS")
    print(f"Preston cold (first request): {cold:.2f} s; scipy status {result.status}, "
          f"{result.nit} iterations")
    print("| solver | RMS after (nm) | PV (nm) | total dwell (s) | objective | time (s) |")
    print("|---|---|---|---|---|---|")
    for name, rms, pv, total, f, seconds in rows:
        print(f"| {name} | {rms:.4f} | {pv:.2f} | {total:.0f} | {f:.6e} | {seconds:.2f} |")
    print(f"speed-up: {rows[1][5] / rows[0][5]:.1f}x")


if __name__ == "__main__":
    main()
