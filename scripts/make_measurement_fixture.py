#!/usr/bin/env python3
"""Writes fixtures/measurement_fit_asphere.json: a probe trace of a 100 mm concave asphere
(R 300 mm, k -1.2, a4 2e-10, a6 -1e-15) taken with a 0.5 mm ruby ball, with a planted
misalignment (dX 12 um, dtau 0.2 mrad, dz 50 um), a planted symmetric form error along the
normal (a 40 nm ring at r = 22 mm, a 25 nm edge roll), 2 nm RMS Gaussian noise (seeded), and
three 1.5 um dust spikes. Independent of the service: plain Python floats.

With --after it writes fixtures/parts/measurement_after_asphere.json instead: the same part
measured again after a polishing run (README, "Parts and cycles"), set up anew on the machine
(dX -7 um, dtau -0.15 mrad, dz 35 um), with 30 % of the planted form error left, fresh 2 nm
noise (another seed) and two dust spikes elsewhere. Same request shape as the first; it sits
in a folder of its own because every JSON file directly in fixtures/ is a compute request
with a stored response in fixtures/expected/."""
import json, math, os, random, sys

R, K, TERMS = 300.0, -1.2, [(4, 2e-10), (6, -1e-15)]
RHO = 0.5
c = 1.0 / R

# (path, misalignment dX mm, dtau rad, dz mm, share of the form error, noise seed, spikes)
BEFORE = ("fixtures/measurement_fit_asphere.json", 0.012, 2e-4, 0.05, 1.0, 20261122, {60, 250, 401})
AFTER = ("fixtures/parts/measurement_after_asphere.json", -0.007, -1.5e-4, 0.035, 0.3, 20261125, {133, 322})

def sag(x):
    r = abs(x)
    s = math.sqrt(1 - (1 + K) * c * c * r * r)
    return c * r * r / (1 + s) + sum(a * r**p for p, a in TERMS)

def slope(x):
    s = math.sqrt(1 - (1 + K) * c * c * x * x)
    poly = sum(p * a * abs(x) ** (p - 1) for p, a in TERMS)
    return c * x / s + math.copysign(poly, x)

def form_mm(x):
    r = abs(x)
    return 1e-6 * (40 * math.exp(-(((r - 22) / 8) ** 2)) - 25 * (r / 50) ** 6)

if sys.argv[1:] not in ([], ["--after"]):
    sys.exit("usage: scripts/make_measurement_fixture.py [--after]  (from the repository root)")
path, DX, TAU, DZ, SHARE, SEED, spikes = AFTER if sys.argv[1:] == ["--after"] else BEFORE
rng = random.Random(SEED)
xs, zs = [], []
n = 481
for i in range(n):
    x = -48 + 96 * i / (n - 1)
    t = math.atan(slope(x))
    nx, nz = -math.sin(t), math.cos(t)
    f = SHARE * form_mm(x) + 2e-6 * rng.gauss(0, 1)
    # Ball centre: contact point + (rho + form error) along the normal.
    xa, za = x + (RHO + f) * nx, sag(x) + (RHO + f) * nz
    if i in spikes:
        za += 1.5e-3
    u, v = xa + DX, za + DZ
    X = u * math.cos(TAU) + v * math.sin(TAU)
    Z = -u * math.sin(TAU) + v * math.cos(TAU)
    xs.append(float(f"{X:.9f}"))
    zs.append(float(f"{Z:.9f}"))

request = {
    "surface": {
        "kind": "asphere",
        "radius_of_curvature_mm": R,
        "conic_constant": K,
        "coefficients": [{"power": p, "value": a} for p, a in TERMS],
    },
    "profile": {"x_mm": xs, "z_mm": zs},
    "probe_tip_radius_mm": RHO,
    "compensation": "normal",
    "robust": "tukey",
    "radial_grid": {"start_mm": 0.0, "stop_mm": 45.0, "count": 91},
    "clear_aperture": {"inner_mm": 0.0, "outer_mm": 40.0},
}
os.makedirs(os.path.dirname(path), exist_ok=True)
with open(path, "w") as out:
    json.dump(request, out, indent=1)
    out.write("\n")
