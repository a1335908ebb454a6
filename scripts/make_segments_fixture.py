#!/usr/bin/env python3
"""Writes fixtures/maps/segments_request.json: a /v1/maps/optimize request on four off-axis
segments of a paraboloid (R 800 mm, conic -1, 60 mm across at 120 mm off axis) mounted on a
70 mm circle about C, with 15 nm RMS of astigmatism planted on segment 0 and 15 nm RMS of
trefoil on segment 1, each in its segment's own frame (x away from C), as one 2 mm map of the
mounted set in C's frame. Plain Python 3.

    python3 scripts/make_segments_fixture.py
"""
import json
import math
import pathlib

MOUNT, APERTURE, PIXEL, COUNT = 70.0, 30.0, 2.0, 4


def planted(x, y):
    for i in range(COUNT):
        phi = 2 * math.pi * i / COUNT
        dx, dy = x - MOUNT * math.cos(phi), y - MOUNT * math.sin(phi)
        u = dx * math.cos(phi) + dy * math.sin(phi)
        v = -dx * math.sin(phi) + dy * math.cos(phi)
        rho = math.hypot(u, v) / APERTURE
        if rho <= 1:
            theta = math.atan2(v, u)
            if i == 0:
                return 15 * math.sqrt(6) * rho**2 * math.cos(2 * theta)
            if i == 1:
                return 15 * math.sqrt(8) * rho**3 * math.cos(3 * theta + 0.4)
            return 0.0
    return None


def main():
    n = int(2 * (MOUNT + APERTURE) / PIXEL) + 1
    half = (n - 1) / 2
    rows = []
    for i in range(n):
        y = (half - i) * PIXEL
        row = []
        for j in range(n):
            h = planted((j - half) * PIXEL, y)
            row.append(None if h is None else round(h, 4))
        rows.append(row)
    request = {
        "process": {"workpiece_radius_mm": 100, "tool_radius_mm": 5, "workpiece_rpm": -10,
                    "tool_rpm": 200, "preston_coefficient_m2_per_n": 2e-11},
        "map": {"heights_nm": rows, "pixel_mm": PIXEL},
        "alignment": {"centre_x_px": half, "centre_y_px": half, "part_radius_mm": 100},
        "positions_mm": [36 + k for k in range(69)],
        "radial_grid": {"start_mm": 35, "stop_mm": 100, "count": 66},
        "clear_aperture": {"inner_mm": 40, "outer_mm": 100},
        "c_law": {"sectors": 180, "max_harmonic": 60, "max_modulation": 0.8},
        "machine": {"c": {"max_velocity_deg_per_min": 36000,
                          "max_acceleration_deg_per_s2": 360}},
        "removal_pixel_mm": 2,
        "segments": {
            "parent": {"kind": "asphere", "radius_of_curvature_mm": 800, "conic_constant": -1},
            "off_axis_mm": 120, "aperture_radius_mm": APERTURE, "mount_radius_mm": MOUNT,
            "count": COUNT,
        },
    }
    out = pathlib.Path(__file__).resolve().parent.parent / "fixtures/maps/segments_request.json"
    out.write_text(json.dumps(request, separators=(",", ":")) + "\n")
    print(out, out.stat().st_size, "bytes")


if __name__ == "__main__":
    main()
