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


def scipy_plan(meta, matrix, v, edges, tol=1e-10):
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
    result = lsq_linear(
        a, b, bounds=(lower, upper), method="trf", lsq_solver="lsmr", tol=tol, max_iter=2000
    )
    seconds = time.perf_counter() - start
    return result.x[:n], seconds, result


def read_grid(path):
    """A fixture map: '#' header lines (pixel_mm among them), then rows of comma-separated
    values, top row first."""
    pixel, rows = None, []
    for line in Path(path).read_text().splitlines():
        if line.startswith("#"):
            if "pixel_mm:" in line:
                pixel = float(line.split(":")[1])
            continue
        if line.strip():
            rows.append([float(v) if v.strip() not in ("", "nan", "NaN") else np.nan
                         for v in line.split(",")])
    return np.array(rows), pixel


def bilinear(img, x, y):
    """img at fractional (column x, row y), zero beyond it."""
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0

    def at(i, j):
        ok = (i >= 0) & (j >= 0) & (i < img.shape[1]) & (j < img.shape[0])
        out = np.zeros(np.shape(x))
        out[ok] = img[j[ok], i[ok]]
        return out

    return (at(x0, y0) * (1 - fx) + at(x0 + 1, y0) * fx) * (1 - fy) + (
        at(x0, y0 + 1) * (1 - fx) + at(x0 + 1, y0 + 1) * fx
    ) * fy


def rifta(points, lower, matrix, v):
    """RIFTA on the map's pixels (module docs): returns its own figures and its plan at
    Preston's points as the machine executes it."""
    surface, px = read_grid(ROOT / "fixtures/maps/fluid_jet_surface.txt")
    spot, spot_px = read_grid(ROOT / "fixtures/maps/fluid_jet_tif.txt")
    spot = np.nan_to_num(spot)
    h, w = surface.shape
    # The influence function (nm/s) at the map's pixel offsets about its removal centroid.
    weights = np.where(spot > 0, spot, 0)
    rr, cc = np.mgrid[0 : spot.shape[0], 0 : spot.shape[1]]
    centre = ((cc * weights).sum() / weights.sum(), (rr * weights).sum() / weights.sum())
    reach = int(np.ceil(max(spot.shape) * spot_px / px / 2)) + 1
    ky, kx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    kernel = bilinear(spot, centre[0] + kx * px / spot_px, centre[1] + ky * px / spot_px)
    # The dwell grid: the map extended by the reach on every side, the surface continued by
    # its edge values there (the extension RIFTA needs to plan dwell at the edges), lifted
    # so that what is to be removed is non-negative.
    pad = 2 * reach
    big = np.pad(surface, pad, mode="edge")
    big = big - np.nanmin(big)
    shape = (big.shape[0] + 2 * reach, big.shape[1] + 2 * reach)
    kfull = np.zeros(shape)
    kfull[: kernel.shape[0], : kernel.shape[1]] = kernel
    kfull = np.roll(kfull, (-reach, -reach), axis=(0, 1))
    kf = np.fft.fft2(kfull)
    zbig = np.zeros(shape)
    zbig[: big.shape[0], : big.shape[1]] = big
    zf = np.fft.fft2(zbig)
    inner = (slice(pad, pad + h), slice(pad, pad + w))

    def attempt(gamma):
        keep = np.abs(kf) > gamma * np.abs(kf).max()
        inverse = np.zeros_like(kf)
        inverse[keep] = 1 / kf[keep]
        t = np.real(np.fft.ifft2(zf * inverse))[: big.shape[0], : big.shape[1]]
        t = t - min(t.min(), 0.0)  # RIFTA's piston: the dwell made non-negative
        full = np.zeros(shape)
        full[: big.shape[0], : big.shape[1]] = t
        removal = np.real(np.fft.ifft2(np.fft.fft2(full) * kf))[: big.shape[0], : big.shape[1]]
        r = (removal - big)[inner]
        return t, r

    # Its plan at Preston's points: the dwell density over each point's cell (the point's
    # pixel, whole pixels around it to half a pitch, half weight on the cell's edge pixels),
    # no less than the axes' floors.
    step = int(round(np.hypot(*(points[1] - points[0])) / px))
    half = step // 2
    taps = np.ones(2 * half + 1)
    taps[0] = taps[-1] = 0.5
    cells = [
        (int(round((h - 1) / 2 - y / px)) + pad, int(round(x / px + (w - 1) / 2)) + pad)
        for x, y in points
    ]

    def at_points(t):
        dwell = []
        for r, c in cells:
            window = np.zeros((2 * half + 1, 2 * half + 1))
            r0, c0 = r - half, c - half
            rs = slice(max(r0, 0), min(r + half + 1, t.shape[0]))
            cs = slice(max(c0, 0), min(c + half + 1, t.shape[1]))
            window[rs.start - r0 : rs.stop - r0, cs.start - c0 : cs.stop - c0] = t[rs, cs]
            dwell.append(taps @ window @ taps)
        return np.maximum(np.array(dwell), lower)

    start = time.perf_counter()
    best = None
    # The threshold searched, as RIFTA's outer loop does, for the least residual in the
    # aperture: here the residual of its plan as the machine executes it (the choice most
    # favourable to it), its own point-dwell model's beside.
    grid = np.mgrid[0:h, 0:w].reshape(2, -1)
    basis = np.column_stack([np.ones(h * w), *grid])
    for gamma in np.logspace(-6, -0.5, 56):
        t, r = attempt(gamma)
        coef, *_ = np.linalg.lstsq(basis, r.ravel(), rcond=None)
        own = float(np.sqrt(np.mean((r.ravel() - basis @ coef) ** 2)))
        dwell = at_points(t)
        executed = figures(matrix, v, dwell)[0]
        if best is None or executed < best[0]:
            best = (executed, gamma, t, own, dwell)
    seconds = time.perf_counter() - start
    _, gamma, t, rms, dwell = best
    return {
        "own_rms": rms,
        "own_total": float(t.sum()),
        "gamma": float(gamma),
        "seconds": seconds,
        "dwell": dwell,
    }


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
    # To the optimum: a tolerance at which further tightening changes the objective by < 1e-8.
    tight_t, tight_s, tight = scipy_plan(meta, matrix, v, edges, tol=1e-12)
    riftas = [rifta(points, v["lower"], matrix, v) for _ in range(max(1, args.runs // 2))]
    riffed = riftas[0]
    rows = []
    for name, t, seconds in [
        ("Preston (HTTP, warm median)", ours, warm),
        ("scipy lsq_linear (trf, lsmr), default tol 1e-10", scipy_t,
         statistics.median(scipy_times)),
        ("scipy lsq_linear, tol 1e-12 (to the optimum)", tight_t, tight_s),
        ("RIFTA, executed at Preston's points", riffed["dwell"],
         statistics.median(r["seconds"] for r in riftas)),
    ]:
        rms, pv, total = figures(matrix, v, t)
        rows.append((name, rms, pv, total, objective(meta, matrix, v, edges, t), seconds))
    print(f"problem: {matrix.shape[0]} pixels x {matrix.shape[1]} points, {matrix.nnz} non-zeros")
    print(f"before: {figures(matrix, v, np.zeros(matrix.shape[1]))[0]:.4f} nm RMS")
    print(f"Preston cold (first request): {cold:.2f} s, {answer['solver']['products']} products, "
          f"converged {answer['solver']['converged']}; scipy: {result.nit} iterations "
          f"(status {result.status}), at tol 1e-12 {tight.nit}")
    print("| solver | RMS after (nm) | PV (nm) | total dwell (s) | objective | time (s) |")
    print("|---|---|---|---|---|---|")
    for name, rms, pv, total, f, seconds in rows:
        print(f"| {name} | {rms:.6f} | {pv:.2f} | {total:.0f} | {f:.8e} | {seconds:.2f} |")
    print(f"speed-up over scipy: {rows[1][5] / rows[0][5]:.1f}x at its default tolerance, "
          f"{rows[2][5] / rows[0][5]:.1f}x to the optimum")
    print(f"RIFTA as it plans (point dwell on the map's pixels, its own model): "
          f"{riffed['own_rms']:.4f} nm RMS, {riffed['own_total']:.0f} s, threshold "
          f"{riffed['gamma']:.2e}")


if __name__ == "__main__":
    main()
