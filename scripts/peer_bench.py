"""Preston against the obvious Python alternative, side by side, in one run: predict and optimize,
each request cold (a process the service has not seen) and cached (the same request again).

The process is the paper's experiment 1 (workpiece 50 mm at -10 r/min, tool 10 mm at
200 r/min, lab frame, eta = +0.05), with n tool positions evenly spaced on [0, 50] mm and the
removal sampled at n radii.

**Cold and cached.** A cold request carries a process no earlier request had: the workpiece
speed is moved by a few parts in 1e9 each time (a new eta), so neither the operator nor the
recommendation the response carries is cached; only the eta = -1 pass and the eta window,
which depend on the machine set-up alone and are shared by every speed, come from the first
request (not counted). A new set-up (a new tool radius each request) is timed too: it also
computes that eta window. A cached request repeats one request, so the operator and the
recommendation come from the caches. Preston is timed end to end over HTTP on loopback
(request body sent, JSON response read), medians over the runs.

**Predict** (n radii x n positions, 10 s at each): the peer is the removal matrix from the same
closed form with numpy/scipy's incomplete elliptic integrals (written here from
docs/MODEL.md), applied to the dwell, timed in-process. It samples R at the positions as if
the tool stood there, a cheaper model than the motion Preston integrates (the tool crossing
each cell), so the comparison favours the peer. A sphere (R = -150 mm) is timed for Preston
alone (the closed form here is the plane's).

**Optimize** (remove a uniform 100 nm over [0, 40] mm): the peer solves the dense
non-negative least squares  min ||M t - d||^2, t >= 0  with cvxpy + Clarabel, timed
in-process (matrix, problem and solve). Each plan is then checked independently: the removal
of the motion a machine program runs for it (docs/MODEL.md, "The motion of a plan": half of
each end dwell as a stop, the cell between the midpoints around each position crossed at
constant speed in its dwell) is integrated with this script's closed form, by Gauss-Legendre
quadrature over each cell, on a grid 4x finer than the request's, and the nonuniformity
(PV / mean over the aperture) reported. The peer's plan is checked the same way: whatever it
assumed, the machine moves.

Usage: python scripts/peer_bench.py --binary target/release/preston [--sizes 501 1001 2001]
(scripts/peer_bench.sh makes the virtualenv, builds Preston and runs this.)
"""

import argparse
import http.client
import json
import socket
import statistics
import subprocess
import time

import cvxpy as cp
import numpy as np
from scipy.special import ellipe, ellipeinc

WORKPIECE_MM, TOOL_MM = 50.0, 10.0
WORKPIECE_RPM, TOOL_RPM = -10.0, 200.0
K_M2_PER_N, P_KPA = 1e-13, 10.0
OUTER_MM, DEPTH_NM = 40.0, 100.0


def removal_matrix(radii, positions):
    """R(r; r1) in nm/s for every radius (rows) and position (columns).

    R = K P / pi * int_0^theta0 V dtheta with V^2 = a^2 + b^2 - 2ab cos(theta),
    a = (w1 + w2) r, b = w2 r1 (paper frame: w1 = -workpiece, w2 = tool, rad/s); the integral
    is 2|a+b| [E(m) - E(pi/2 - theta0/2 | m)] with m = 4ab/(a+b)^2 when ab >= 0, and
    2|a-b| E(theta0/2 | m) with m = -4ab/(a-b)^2 otherwise.
    """
    w1 = -WORKPIECE_RPM * 2 * np.pi / 60
    w2 = TOOL_RPM * 2 * np.pi / 60
    r = np.asarray(radii)[:, None]
    r1 = np.asarray(positions)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        c = (r**2 + r1**2 - TOOL_MM**2) / (2 * r * r1)
        theta0 = np.arccos(np.clip(c, -1.0, 1.0))
    # On the axis (r = 0 or r1 = 0) the point is under the pad all round or not at all; on
    # the pad's edge there, the limit from off the axis (a half circle).
    axis = (r * r1) == 0
    gap = np.abs(r - r1)
    theta0 = np.where(
        axis, np.where(gap < TOOL_MM, np.pi, np.where(gap == TOOL_MM, np.pi / 2, 0.0)), theta0
    )
    a = (w1 + w2) * r
    b = w2 * r1
    ab = a * b
    with np.errstate(divide="ignore", invalid="ignore"):
        m_same = np.where(a + b != 0, 4 * ab / (a + b) ** 2, 0.0)
        m_opp = np.where(a - b != 0, -4 * ab / (a - b) ** 2, 0.0)
    same = 2 * np.abs(a + b) * (
        ellipe(np.clip(m_same, 0, 1)) - ellipeinc(np.pi / 2 - theta0 / 2, np.clip(m_same, 0, 1))
    )
    opposite = 2 * np.abs(a - b) * ellipeinc(theta0 / 2, np.clip(m_opp, 0, 1))
    integral = np.where(ab >= 0, same, opposite)
    integral = np.where(theta0 > 0, integral, 0.0)
    # K [m^2/N] * P [kPa -> Pa] * V [mm/s -> m/s] -> m/s, then nm/s.
    return K_M2_PER_N * P_KPA * 1e3 * 1e-3 * 1e9 / np.pi * integral


def grid(n):
    return np.linspace(0.0, WORKPIECE_MM, n)


def nonuniformity(removal):
    return (removal.max() - removal.min()) / removal.mean()


# Gauss-Legendre nodes on [0, 1] per cell (a cell is a few hundredths of the pad; the rim's
# square-root kink inside a cell costs far less than the ripple being measured).
GAUSS_NODES, GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(24)
GAUSS_NODES, GAUSS_WEIGHTS = 0.5 * (GAUSS_NODES + 1.0), 0.5 * GAUSS_WEIGHTS


def motion_removal(radii, positions, dwell):
    """Removal (nm) at `radii` of the motion the program runs for the plan, on a plane."""
    positions = np.asarray(positions, dtype=float)
    dwell = np.asarray(dwell, dtype=float)
    n = len(positions)
    bounds = np.concatenate(([positions[0]], 0.5 * (positions[1:] + positions[:-1]), [positions[-1]]))
    move = np.ones(n)
    move[0] = move[-1] = 0.5
    removal = 0.5 * dwell[0] * removal_matrix(radii, positions[:1])[:, 0]
    removal += 0.5 * dwell[-1] * removal_matrix(radii, positions[-1:])[:, 0]
    for j in range(n):
        lo, hi = bounds[j], bounds[j + 1]
        rows = np.abs(radii - 0.5 * (lo + hi)) <= TOOL_MM + 0.5 * (hi - lo)
        if not rows.any() or dwell[j] == 0.0:
            continue
        x = lo + (hi - lo) * GAUSS_NODES
        # The mean rate over the cell times the time spent crossing it.
        mean_rate = removal_matrix(radii[rows], x) @ GAUSS_WEIGHTS
        removal[rows] += move[j] * dwell[j] * mean_rate
    return removal


def check(positions, dwell, n):
    """PV/mean of the plan's removal over the aperture on a grid 4x finer than the request's."""
    fine = grid(4 * (n - 1) + 1)
    fine = fine[fine <= OUTER_MM]
    return nonuniformity(motion_removal(fine, positions, dwell))


def peer(n):
    """cvxpy + Clarabel on the dense NNLS: (seconds, dwell)."""
    started = time.perf_counter()
    radii = grid(n)
    inside = radii <= OUTER_MM
    m = removal_matrix(radii[inside], radii)
    t = cp.Variable(n)
    problem = cp.Problem(
        cp.Minimize(cp.sum_squares(m @ t - DEPTH_NM)), [t >= 0]
    )
    problem.solve(solver=cp.CLARABEL)
    took = time.perf_counter() - started
    return took, np.maximum(t.value, 0.0)


def process(vary=0, field="workpiece_rpm"):
    """The paper's process; `vary` > 0 moves `field` by vary parts in 1e9 (a new process)."""
    spec = {
        "workpiece_radius_mm": WORKPIECE_MM,
        "tool_radius_mm": TOOL_MM,
        "workpiece_rpm": WORKPIECE_RPM,
        "tool_rpm": TOOL_RPM,
        "preston_coefficient_m2_per_n": K_M2_PER_N,
        "pressure_kpa": P_KPA,
    }
    spec[field] *= 1 + 1e-9 * vary
    return spec


def request_body(n, vary=0, field="workpiece_rpm"):
    return json.dumps(
        {
            "process": process(vary, field),
            "positions_mm": grid(n).tolist(),
            "target": {"uniform_depth_nm": DEPTH_NM},
            "radial_grid": {"start_mm": 0, "stop_mm": WORKPIECE_MM, "count": n},
            "clear_aperture": {"inner_mm": 0, "outer_mm": OUTER_MM},
            # The peer keeps no machine limits; nor does Preston here (its default machine
            # would add the axes' limits as constraints: docs/MACHINE.md).
            "machine": "unlimited",
        }
    ).encode()


PREDICT_DWELL_S = 10.0
SPHERE_MM = -150.0


def predict_body(n, vary=0, field="workpiece_rpm", sphere=False):
    body = {
        "process": process(vary, field),
        "dwell": {"positions_mm": grid(n).tolist(), "dwell_s": [PREDICT_DWELL_S] * n},
        "radial_grid": {"start_mm": 0, "stop_mm": WORKPIECE_MM, "count": n},
        "clear_aperture": {"inner_mm": 0, "outer_mm": OUTER_MM},
    }
    if sphere:
        body["surface"] = {"kind": "sphere", "radius_of_curvature_mm": SPHERE_MM}
    return json.dumps(body).encode()


def peer_predict(n):
    """numpy + scipy: the removal of n positions' dwell at n radii (seconds, removal)."""
    started = time.perf_counter()
    removal = removal_matrix(grid(n), grid(n)) @ np.full(n, PREDICT_DWELL_S)
    return time.perf_counter() - started, removal


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Preston:
    def __init__(self, binary, *flags):
        self.port = free_port()
        self.process = subprocess.Popen(
            [binary, "--listen", f"127.0.0.1:{self.port}", *flags],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        for _ in range(200):
            try:
                self.connection = http.client.HTTPConnection("127.0.0.1", self.port)
                self.connection.request("GET", "/healthz")
                self.connection.getresponse().read()
                return
            except OSError:
                time.sleep(0.05)
        raise RuntimeError("Preston did not start")

    def post(self, body, path="/v1/optimize"):
        """(seconds, parsed response) for one request to `path`, end to end."""
        started = time.perf_counter()
        self.connection.request("POST", path, body, {"content-type": "application/json"})
        response = self.connection.getresponse()
        data = response.read()
        took = time.perf_counter() - started
        if response.status != 200:
            raise RuntimeError(f"{response.status}: {data[:300]!r}")
        return took, json.loads(data)

    def stop(self):
        self.process.terminate()
        self.process.wait()


def timed(server, bodies, path):
    """Median seconds over `bodies` (each posted once to `path`) and the last response."""
    runs = [server.post(body, path) for body in bodies]
    return statistics.median(t for t, _ in runs), runs[-1][1]


def cold_and_cached(server, make, path, runs, offset):
    """(cold, new set-up, cached) medians for requests made by make(vary, field).

    The first request of the set-up is sent and not counted (it computes the set-up's eta
    window, shared by every speed); the cold requests then each carry a new workpiece speed,
    the new set-up ones a new tool radius; the cached ones repeat the first request. The
    variations start at `offset`, so that each table row takes ones no other row took and
    none is served by another's caches.
    """
    fresh = [offset + k for k in range(1, runs + 1)]
    server.post(make(0, "workpiece_rpm"), path)
    cold, response = timed(server, [make(k, "workpiece_rpm") for k in fresh], path)
    setup, _ = timed(server, [make(k, "tool_radius_mm") for k in fresh], path)
    cached, _ = timed(server, [make(0, "workpiece_rpm")] * runs, path)
    return cold, setup, cached, response


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", default="target/release/preston")
    parser.add_argument("--sizes", type=int, nargs="+", default=[501, 1001, 2001])
    parser.add_argument("--preston-runs", type=int, default=20)
    parser.add_argument("--peer-runs", type=int, default=3)
    args = parser.parse_args()

    server = Preston(args.binary)
    # The closed form here against Preston's removal function (a few columns).
    probe = [0.0, 3.0, 10.0, 25.0, 44.0]
    _, answer = server.post(
        json.dumps(
            {
                "process": process(),
                "tool_positions_mm": probe,
                "radial_grid": {"start_mm": 0, "stop_mm": WORKPIECE_MM, "count": 501},
            }
        ).encode(),
        "/v1/removal-function",
    )
    ours = removal_matrix(grid(501), probe)
    agreement = max(
        np.max(np.abs(np.asarray(p["removal_rate_nm_per_min"]) / 60 - ours[:, k])) / ours.max()
        for k, p in enumerate(answer["profiles"])
    )
    print(f"closed form here vs Preston's removal function: {agreement:.1e} of the peak")

    print()
    print("Predict, n radii x n positions (ms; ratio = peer / Preston cold)")
    print()
    print("| part | n | Preston cold (new speed) | Preston new set-up | Preston cached "
          "| numpy + scipy | ratio |")
    print("|---|---|---|---|---|---|---|")
    cases = [(False, 201), (False, 1001), (True, 201), (True, 1001)]
    for row, (sphere, n) in enumerate(cases):
        make = lambda vary, field, n=n, sphere=sphere: predict_body(n, vary, field, sphere)
        cold, setup, cached, response = cold_and_cached(
            server, make, "/v1/predict", args.preston_runs, 1000 * (row + 1)
        )
        if sphere:
            peer_cell, ratio = "", ""
        else:
            peer_s = statistics.median(peer_predict(n)[0] for _ in range(args.peer_runs))
            peer_cell, ratio = f"{peer_s * 1e3:.0f}", f"{peer_s / cold:.0f}x"
            # The peer's point samples against Preston's motion: close, not equal.
            gap = np.max(np.abs(peer_predict(n)[1] - response["removal_nm"]))
            print(f"plane {n}: peer's point-sampled removal differs from the motion's by "
                  f"{gap / max(response['removal_nm']):.1e} of the peak")
        print(f"| {'sphere R = -150 mm' if sphere else 'plane'} | {n} | {cold * 1e3:.2f} "
              f"| {setup * 1e3:.2f} | {cached * 1e3:.2f} | {peer_cell} | {ratio} |")

    rows = []
    for row, n in enumerate(args.sizes):
        make = lambda vary, field, n=n: request_body(n, vary, field)
        cold, setup, cached, plan = cold_and_cached(
            server, make, "/v1/optimize", args.preston_runs, 1000 * (len(cases) + row + 1)
        )
        peer_runs = [peer(n) for _ in range(args.peer_runs)]
        peer_s = statistics.median(t for t, _ in peer_runs)
        positions = plan["dwell"]["positions_mm"]
        if not rows:
            # This script's motion model against Preston's prediction of the same plan.
            fine = grid(4 * (n - 1) + 1)
            predict = json.loads(make(0, "workpiece_rpm"))
            del predict["positions_mm"], predict["target"]
            predict["dwell"] = plan["dwell"]
            predict["radial_grid"]["count"] = len(fine)
            _, predicted = server.post(json.dumps(predict).encode(), "/v1/predict")
            ours = motion_removal(fine, positions, plan["dwell"]["dwell_s"])
            theirs = np.asarray(predicted["removal_nm"])
            print()
            print(
                f"motion removal here vs Preston's predict ({n} positions, {len(fine)} radii): "
                f"{np.max(np.abs(ours - theirs)) / theirs.max():.1e} of the peak"
            )
        rows.append(
            (
                n,
                cold,
                setup,
                cached,
                peer_s,
                plan["metrics"]["nonuniformity"],
                check(positions, plan["dwell"]["dwell_s"], n),
                check(grid(n), peer_runs[-1][1], n),
            )
        )
    server.stop()

    print()
    print("Optimize, n positions (ms; ratios = peer / Preston cold and cached)")
    print()
    print(
        "| positions | Preston cold (new speed) | Preston new set-up | Preston cached "
        "| cvxpy + Clarabel | ratio cold / cached | nonuniformity: Preston reports "
        "| Preston, checked 4x finer | cvxpy, checked 4x finer |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for n, cold, setup, cached, peer_s, reported, checked, peer_checked in rows:
        print(
            f"| {n} | {cold * 1e3:.1f} | {setup * 1e3:.1f} | {cached * 1e3:.1f} "
            f"| {peer_s * 1e3:.0f} | {peer_s / cold:.0f}x / {peer_s / cached:.0f}x "
            f"| {reported:.2e} | {checked:.2e} | {peer_checked:.2e} |"
        )


if __name__ == "__main__":
    main()
