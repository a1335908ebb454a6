#!/usr/bin/env python3
"""Writes fixtures/measurement_fit_asphere.json: a probe trace of a 100 mm concave asphere
(R 300 mm, k -1.2, a4 2e-10, a6 -1e-15) taken with a 0.5 mm ruby ball, with a planted
misalignment (dX 12 um, dtau 0.2 mrad, dz 50 um), a planted symmetric form error along the
normal (a 40 nm ring at r = 22 mm, a 25 nm edge roll), 2 nm RMS Gaussian noise (seeded), and
three 1.5 um dust spikes. Independent of the service: plain Python floats."""
import json, math, random

R, K, TERMS = 300.0, -1.2, [(4, 2e-10), (6, -1e-15)]
RHO = 0.5
DX, TAU, DZ = 0.012, 2e-4, 0.05
c = 1.0 / R

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

rng = random.Random(20261122)
xs, zs = [], []
n = 481
spikes = {60, 250, 401}
for i in range(n):
    x = -48 + 96 * i / (n - 1)
    t = math.atan(slope(x))
    nx, nz = -math.sin(t), math.cos(t)
    f = form_mm(x) + 2e-6 * rng.gauss(0, 1)
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
with open("fixtures/measurement_fit_asphere.json", "w") as out:
    json.dump(request, out, indent=1)
    out.write("\n")
