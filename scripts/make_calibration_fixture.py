#!/usr/bin/env python3
"""Writes fixtures/calibration_rings.json: a ring test on the paper's 50 mm flat part
(workpiece -10 r/min, tool 200 r/min, 10 kPa, uniform pressure), the tool parked at 15 mm for
20 min and at 30 mm for 15 min, as a shop's profilometer would report the grooves: removal
every 0.25 mm within 12 mm of each ring, a planted process of K = 1.3e-13 m^2/N and a pad of
r_t = 9.8 mm (the nominal process says 1e-13 and 10 mm), an unknown zero per run (+4 and -3
nm) and 0.3 nm RMS Gaussian noise (seeded). Independent of the service: the removal rate is
the paper's integral K*P/(2*pi) * integral of |V| over the contact arc, by composite Simpson
in plain Python floats."""
import json, math, random

RM, K_TRUE, RT_TRUE, P_KPA = 50.0, 1.3e-13, 9.8, 10.0
W_RPM, T_RPM = -10.0, 200.0
RINGS = [(15.0, 20 * 60.0, 4.0), (30.0, 15 * 60.0, -3.0)]
NOISE_NM = 0.3

def rate_nm_per_s(r, r1):
    """K*P/pi * int_0^theta0 V dtheta, V^2 = (a - b)^2 + 4ab sin^2(theta/2)."""
    rpm = 2 * math.pi / 60
    w1, w2 = -W_RPM * rpm, T_RPM * rpm
    a, b = (w1 + w2) * r, w2 * r1
    if r == 0 or r1 == 0:
        theta0 = math.pi if r + r1 < RT_TRUE else 0.0
    else:
        c = (r * r + r1 * r1 - RT_TRUE * RT_TRUE) / (2 * r * r1)
        theta0 = math.pi if c <= -1 else 0.0 if c >= 1 else math.acos(c)
    if theta0 == 0.0:
        return 0.0
    n = 4000
    h = theta0 / n
    total = 0.0
    for i in range(n + 1):
        t = i * h
        v = math.sqrt(max((a - b) ** 2 + 4 * a * b * math.sin(t / 2) ** 2, 0.0))
        total += v * (1 if i in (0, n) else 4 if i % 2 else 2)
    integral = total * h / 3
    # K [1/Pa] * P [Pa] * V [mm/s] -> mm/s of removal; 1e6 nm per mm.
    return K_TRUE * P_KPA * 1e3 / math.pi * integral * 1e6

rng = random.Random(20261125)
runs = []
for r1, seconds, piston in RINGS:
    radii = [r1 - 12 + 0.25 * i for i in range(97)]
    radii = [round(r, 6) for r in radii if 0 <= r <= RM]
    depth = [round(seconds * rate_nm_per_s(r, r1) + piston + NOISE_NM * rng.gauss(0, 1), 4)
             for r in radii]
    runs.append({"ring": {"position_mm": r1, "duration_s": seconds},
                 "removal": {"radius_mm": radii, "depth_nm": depth}})

request = {
    "process": {"workpiece_radius_mm": RM, "tool_radius_mm": 10.0, "workpiece_rpm": W_RPM,
                "tool_rpm": T_RPM, "preston_coefficient_m2_per_n": 1e-13, "pressure_kpa": P_KPA},
    "runs": runs,
    "fit": {"preston_coefficient": True, "tool_radius": True},
}
with open("fixtures/calibration_rings.json", "w") as f:
    json.dump(request, f, indent=2)
    f.write("\n")
