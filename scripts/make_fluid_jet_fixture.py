"""Converts the public fluid-jet case of TWANG006/surface-extension (MIT) to Preston's grid
format, for fixtures/maps (see fixtures/maps/NOTICE.md).

The repository's data/example_surf_rf.mat holds a measured surface error (X, Y, Z in metres,
26 x 372 samples 0.32 mm apart, rows of ascending Y) and data/step_0_fluid_jet_tif.mat a
measured fluid-jet influence function (X, Y, Z, 115 x 115 samples of m_per_pixel; Z is the
removal rate in m/s: its peak, 6.27 nm/s, is the 125 nm in 20 s its scripts state). Preston's
grid rows run top first, so the rows are reversed; heights in nm, rates in nm/s.

Usage: python scripts/make_fluid_jet_fixture.py SURFACE.mat TIF.mat OUT_DIR
(needs numpy and scipy).
"""

import json
import sys
from pathlib import Path

import numpy as np
from scipy.io import loadmat


def write(path, values, pixel_mm, comment):
    with open(path, "w") as f:
        f.write(f"# {comment}\n")
        f.write(f"# pixel_mm: {pixel_mm!r}\n# unit: nm\n")
        for row in values[::-1]:
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def main():
    surface, tif, out = sys.argv[1], sys.argv[2], Path(sys.argv[3])
    s = loadmat(surface)
    x, y, z = s["X"], s["Y"], s["Z"]
    pitch = float(np.median(np.diff(x[0, :]))) * 1e3
    assert np.all(np.diff(y[:, 0]) > 0), "rows of ascending y"
    write(out / "fluid_jet_surface.txt", np.round(z * 1e9, 6), round(pitch, 9),
          "surface error, nm (TWANG006/surface-extension data/example_surf_rf.mat)")
    t = loadmat(tif)
    tx, ty, tz = t["X"], t["Y"], t["Z"]
    assert np.all(np.diff(ty[:, 0]) > 0), "rows of ascending y"
    write(out / "fluid_jet_tif.txt", np.round(tz * 1e9, 9), float(t["m_per_pixel"][0, 0]) * 1e3,
          "fluid-jet removal rate, nm/s (TWANG006/surface-extension "
          "data/step_0_fluid_jet_tif.mat)")
    request(out)


def rows(path):
    """A grid file's rows and pixel, as Preston reads them."""
    pixel, values = None, []
    for line in open(path):
        if line.startswith("#"):
            if "pixel_mm" in line:
                pixel = float(line.split(":")[1])
            continue
        values.append([float(v) for v in line.strip().split(",")])
    return values, pixel


def request(out):
    surface, surface_px = rows(out / "fluid_jet_surface.txt")
    tif, tif_px = rows(out / "fluid_jet_tif.txt")
    axis = {"max_velocity_mm_per_min": 10000, "max_acceleration_mm_per_s2": 2000}
    body = {
        "machine": {"kinematics": "cartesian", "x": axis, "y": axis},
        "influence": {"map": {"heights_nm": tif, "pixel_mm": tif_px}},
        "map": {"heights_nm": surface, "pixel_mm": surface_px},
    }
    with open(out / "fluid_jet_request.json", "w") as f:
        json.dump(body, f, separators=(",", ":"))


if __name__ == "__main__":
    main()
