#!/usr/bin/env python3
"""Writes a small synthetic Zygo Mx .datx (HDF5) file and a JSON sidecar of what a reader must get.

    python3 scripts/make_datx_fixture.py fixtures/maps/synthetic.datx
    python3 scripts/make_datx_fixture.py fixtures/maps/synthetic_gzip.datx --gzip
    python3 scripts/make_datx_fixture.py fixtures/maps/hollow.datx --hollow 4096 4096

Run from the repository root with any Python 3.9+. The first run makes a venv at
target/datx-venv with pinned h5py and numpy (h5py wheels carry their own libhdf5) and re-runs
itself there; --no-venv uses the current interpreter as it is. Nothing of the service is used.

The map: 40 rows x 48 columns (--rows/--cols), row 0 of the dataset the top of the image (Zygo
stores image order; prysm flips to y-up after reading). Heights in nm are planted first and are
the truth written to the sidecar: a tilt, a Gaussian bump near the top left, a raised
rectangle near the bottom right and a dip on the right, each rounded to 1e-6 nm; missing
pixels are column 0, a triangle in the top right corner, a round hole and one lone pixel.
The file stores raw = height / (S * O * W) in Fringes, with S the interferometric scale
factor (0.5, reflection), O the obliquity factor (1.0625) and W the wavelength
(6.327999813038332e-07 m, the 632.8 nm HeNe line as Zygo stores it), and the file's No Data
value (the dtype's maximum) at missing pixels. A reader gets height_nm = raw * S * O * W * 1e9
where raw < No Data, nothing elsewhere; pixels are 0.125 mm (--pixel-mm) in X and Y.

The layout follows what the public readers expect (prysm io.read_zygo_datx; SurfaceTopography
IO/DATX.py; several lab scripts reading /MetaData, the converters and /Attributes):
  /MetaData                 1-D compound dataset (Source, Link, Destination) of strings: a
                            graph from "Root": Root -Measurement-> {M}; {M} -Surface-> {S};
                            {S} -Path-> /Data/Surface/{S}; {M} -Intensity-> {I}; {I} -Path->
                            /Data/Intensity/{I}; {M} -Attributes-> /Attributes/{A}.
  /Data/Surface/{S}         2-D dataset (rows, cols), float64 (--dtype f32 for float32), with
                            attributes, each a 1-element array: "No Data" (same dtype),
                            "Unit" (string, "Fringes"), "Wavelength" (float64, m),
                            "Interferometric Scale Factor" and "Obliquity Factor" (float64),
                            "X Converter", "Y Converter", "Z Converter" (compound: Category,
                            BaseUnit strings and Parameters, a variable-length float64 array;
                            X/Y: "LateralCat", "Pixels", Parameters[1] = m per pixel;
                            Z: "HeightCat", "Fringes", Parameters[1..3] = W, S, O) and
                            "Coordinates" (compound of four int32: origin row and column,
                            width, height).
  /Data/Intensity/{I}       2-D float32 camera image with "No Data", "Coordinates", converters.
  /Attributes               group with "File Layout Version" (int32 [1]) and two subgroups;
                            the last by name, {A}, holds the measurement's attributes
                            ("Data Context.Data Attributes.Wavelength:Value" in m,
                            "...Interf Scale Factor:Value", "Data Context.Lateral
                            Resolution:Value" and "Surface Data Context.Lateral
                            Resolution:Value" in m, each with a ":Unit" string, camera size,
                            software name and version).
  /Measurement              group whose Surface, Intensity and Attributes are hard links to
                            the objects above (older Mx files keep the surface there).
What could not be established from public sources is a guess, marked GUESS below: the
fixed-length (default) versus variable-length (--vlen-strings) strings, the Parameters entries
other than those named, the Coordinates field names, the intensity dtype, the GUIDs (fixed
here so that the files are reproducible) and the HDF5 format version (libhdf5's oldest by
default: superblock 0, version 1 object headers, symbol-table groups; --libver latest gives
superblock 3, version 2 headers and dense attribute storage on objects with more than 8).

--gzip writes the surface chunked (16 x 16 by default, --chunk; edge chunks partial) through
the deflate filter (level 4, --shuffle adds the byte shuffle filter before it).

The sidecar (same path, .json) holds the expected heights in nm, row 0 first, null where
missing, the pixel size in mm, the scalars above, the dataset path and storage, and summary
statistics; `tolerance_nm` is what a reader's heights may differ by (rounding of the stored
raw values)."""
import argparse
import json
import math
import os
import subprocess
import sys
import uuid

H5PY_VERSION = "3.11.0"
NUMPY_VERSION = "1.26.4"
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VENV = os.path.join(ROOT, "target", "datx-venv")
VENV_PY = os.path.join(VENV, "bin", "python")

WAVELENGTH_M = 6.327999813038332e-07  # 632.8 nm as a float32 would hold it, as Zygo writes it
SCALE_FACTOR = 0.5                    # waves per fringe: a surface seen in reflection
OBLIQUITY = 1.0625                    # not 1, so that a reader that drops it is caught
NAMESPACE = uuid.UUID("5b0f4f7e-6d61-4c0e-9a8c-7072657374f6")


def guid(name):
    """A Zygo-style GUID in braces, fixed per name so that the files are reproducible (GUESS:
    Zygo's are random)."""
    return "{" + str(uuid.uuid5(NAMESPACE, name)).upper() + "}"


def ensure_venv(argv):
    """Re-run this script under target/datx-venv, making it first if needed."""
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV):
        return
    check = [VENV_PY, "-c", "import h5py, numpy, sys; sys.exit(h5py.__version__ != %r or "
             "numpy.__version__ != %r)" % (H5PY_VERSION, NUMPY_VERSION)]
    if not os.path.exists(VENV_PY):
        subprocess.check_call([sys.executable, "-m", "venv", VENV])
    if subprocess.call(check, stderr=subprocess.DEVNULL) != 0:
        subprocess.check_call([VENV_PY, "-m", "pip", "install", "--quiet",
                               "h5py==" + H5PY_VERSION, "numpy==" + NUMPY_VERSION])
    os.execv(VENV_PY, [VENV_PY, os.path.abspath(__file__)] + argv)


def planted_heights(rows, cols):
    """The truth: heights in nm (None where missing), in image order (row 0 at the top),
    from plain Python floats."""
    h = [[None] * cols for _ in range(rows)]
    hole_r, hole_c, hole_rad = 0.5 * rows, 0.75 * cols, 0.075 * min(rows, cols) + 0.5
    for r in range(rows):
        for c in range(cols):
            missing = (
                c == 0                                           # a dead column at the left
                or (c - (cols - 9)) > r                          # the top right corner
                or (r - hole_r) ** 2 + (c - hole_c) ** 2 <= hole_rad ** 2   # a round hole
                or (r, c) == (rows // 8, cols // 3)              # one lone pixel
            )
            if missing:
                continue
            z = 0.8 * c - 0.5 * r + 3.0                          # tilt
            z += 60.0 * math.exp(-((r - rows / 4) ** 2 + (c - cols / 4) ** 2) / (2 * 4.0 ** 2))
            if 0.65 * rows <= r < 0.85 * rows and 0.6 * cols <= c < 0.87 * cols:
                z += 25.0                                        # raised rectangle
            z -= 12.0 * math.exp(-((r - 0.7 * rows) ** 2 + (c - 0.3 * cols) ** 2) / (2 * 3.0 ** 2))
            h[r][c] = round(z, 6)
    return h


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out", help="path of the .datx to write; the sidecar gets .json instead")
    p.add_argument("--gzip", action="store_true", help="chunked surface through deflate")
    p.add_argument("--level", type=int, default=4, help="deflate level (default 4)")
    p.add_argument("--chunk", type=int, nargs=2, default=[16, 16], metavar=("ROWS", "COLS"))
    p.add_argument("--shuffle", action="store_true", help="byte shuffle before deflate")
    p.add_argument("--dtype", choices=["f64", "f32"], default="f64", help="surface dtype")
    p.add_argument("--rows", type=int, default=40)
    p.add_argument("--cols", type=int, default=48)
    p.add_argument("--pixel-mm", type=float, default=0.125, help="lateral resolution, mm/pixel")
    p.add_argument("--vlen-strings", action="store_true",
                   help="variable-length strings instead of fixed-length ones")
    p.add_argument("--libver", choices=["earliest", "v108", "v110", "latest"],
                   default="earliest", help="oldest HDF5 format the file may use")
    p.add_argument("--no-venv", action="store_true", help="use this interpreter as it is")
    p.add_argument("--no-verify", action="store_true", help="skip reading the file back")
    p.add_argument("--hollow", type=int, nargs=2, metavar=("ROWS", "COLS"),
                   help="instead: a surface of ROWS x COLS declared and never written (chunked, "
                        "no chunk stored: a few kB that read as fill values), no sidecar")
    args = p.parse_args(argv)
    if not args.no_venv:
        ensure_venv(argv)
    if args.hollow:
        write_hollow(args.out, *args.hollow)
    else:
        write(args)


def write_hollow(out, rows, cols):
    import h5py
    import numpy as np

    with h5py.File(out, "w", libver=("earliest", "latest")) as f:
        ds = f.create_dataset("/Data/Surface/" + guid("surface"), shape=(rows, cols),
                              dtype=np.float64, chunks=(256, 256))
        ds.attrs.create("Unit", np.array([b"NanoMeters"]))


def write(args):
    import h5py
    import numpy as np

    rows, cols = args.rows, args.cols
    truth = planted_heights(rows, cols)
    dtype = np.dtype(np.float64 if args.dtype == "f64" else np.float32)
    no_data = np.finfo(dtype).max                # GUESS: a float surface's No Data is its max
    nm_per_fringe = SCALE_FACTOR * OBLIQUITY * WAVELENGTH_M * 1e9
    raw = np.full((rows, cols), no_data, dtype=dtype)
    for r in range(rows):
        for c in range(cols):
            if truth[r][c] is not None:
                raw[r, c] = truth[r][c] / nm_per_fringe
    pixel_m = args.pixel_mm * 1e-3

    if args.vlen_strings:
        sdt = h5py.string_dtype("ascii")

        def strs(*values):
            return np.array([v.encode("ascii") for v in values], dtype=sdt)
    else:
        sdt = None

        def strs(*values):
            return np.array([v.encode("ascii") for v in values])  # fixed length, null padded

    def str_field(width):
        return sdt if sdt is not None else "S%d" % width

    converter_dt = np.dtype([("Category", str_field(10)), ("BaseUnit", str_field(10)),
                             ("Parameters", h5py.vlen_dtype(np.float64))])

    def converter(category, unit, params):
        a = np.empty(1, dtype=converter_dt)
        a[0] = (category.encode("ascii"), unit.encode("ascii"), np.asarray(params, np.float64))
        return a

    # GUESS: the field names; the order is what readers index ([0][0] row, [0][1] column,
    # [0][2] width, [0][3] height).
    coords_dt = np.dtype([("Row", "<i4"), ("Column", "<i4"), ("Width", "<i4"), ("Height", "<i4")])
    coords = np.array([(0, 0, cols, rows)], dtype=coords_dt)

    def one(value, dt):
        return np.array([value], dtype=dt)

    s_id, i_id, m_id = guid("surface"), guid("intensity"), guid("measurement")
    a_root, a_meas = guid("attributes-0"), guid("attributes-1")
    if a_root > a_meas:                           # readers take the last subgroup by name
        a_root, a_meas = a_meas, a_root
    surface_path = "/Data/Surface/" + s_id

    with h5py.File(args.out, "w", libver=(args.libver, "latest")) as f:
        # Attributes ------------------------------------------------------------------------
        attrs = f.create_group("Attributes")
        attrs.attrs.create("File Layout Version", one(1, "<i4"))
        g0 = attrs.create_group(a_root)
        g0.attrs.create("Data Context.Data Attributes.Software Info Name", strs("Mx"))
        g = attrs.create_group(a_meas)
        for key, value, unit in [
            ("Data Context.Data Attributes.Wavelength", WAVELENGTH_M, "Meters"),
            ("Data Context.Data Attributes.Interf Scale Factor", SCALE_FACTOR, None),
            ("Data Context.Lateral Resolution", pixel_m, "Meters"),
            ("Surface Data Context.Lateral Resolution", pixel_m, "Meters"),
        ]:
            g.attrs.create(key + ":Value", one(value, "<f8"))
            if unit:
                g.attrs.create(key + ":Unit", strs(unit))
        g.attrs.create("Data Context.Data Attributes.Camera Width:Value", one(cols, "<i4"))
        g.attrs.create("Data Context.Data Attributes.Camera Height:Value", one(rows, "<i4"))
        g.attrs.create("Data Context.Data Attributes.Software Info Name", strs("Mx"))
        g.attrs.create("Data Context.Data Attributes.Software Info Version", strs("7.7.0.0"))

        # Surface ---------------------------------------------------------------------------
        kw = {}
        if args.gzip:
            kw = dict(chunks=tuple(args.chunk), compression="gzip",
                      compression_opts=args.level, shuffle=args.shuffle)
        ds = f.create_dataset(surface_path, data=raw, dtype=dtype, **kw)
        ds.attrs.create("No Data", one(no_data, dtype))
        ds.attrs.create("Unit", strs("Fringes"))
        ds.attrs.create("Wavelength", one(WAVELENGTH_M, "<f8"))
        ds.attrs.create("Interferometric Scale Factor", one(SCALE_FACTOR, "<f8"))
        ds.attrs.create("Obliquity Factor", one(OBLIQUITY, "<f8"))
        ds.attrs.create("X Converter", converter("LateralCat", "Pixels", [0.0, pixel_m, 0.0, 0.0]))
        ds.attrs.create("Y Converter", converter("LateralCat", "Pixels", [0.0, pixel_m, 0.0, 0.0]))
        ds.attrs.create("Z Converter", converter("HeightCat", "Fringes",
                                                 [0.0, WAVELENGTH_M, SCALE_FACTOR, OBLIQUITY]))
        ds.attrs.create("Coordinates", coords)

        # Intensity (GUESS: float32; prysm casts it to uint16 after reading) ----------------
        missing = raw == no_data
        phase = np.where(missing, 0.0, raw.astype(np.float64))
        inten = (1000.0 + 800.0 * np.cos(2 * np.pi * phase)).astype(np.float32)
        inten[missing] = np.finfo(np.float32).max
        di = f.create_dataset("/Data/Intensity/" + i_id, data=inten)
        di.attrs.create("No Data", one(np.finfo(np.float32).max, np.float32))
        di.attrs.create("X Converter", converter("LateralCat", "Pixels", [0.0, pixel_m, 0.0, 0.0]))
        di.attrs.create("Y Converter", converter("LateralCat", "Pixels", [0.0, pixel_m, 0.0, 0.0]))
        di.attrs.create("Coordinates", coords)

        # Measurement: hard links to the same objects ----------------------------------------
        meas = f.create_group("Measurement")
        meas["Surface"] = ds
        meas["Intensity"] = di
        meas["Attributes"] = g

        # MetaData: the graph readers walk from "Root" -----------------------------------------
        links = [
            ("Root", "Measurement", m_id),
            (m_id, "Attributes", "/Attributes/" + a_meas),
            (m_id, "Surface", s_id),
            (s_id, "Path", surface_path),
            (m_id, "Intensity", i_id),
            (i_id, "Path", "/Data/Intensity/" + i_id),
        ]
        width = max(len(x) for row in links for x in row)
        md_dt = np.dtype([("Source", str_field(width)), ("Link", str_field(width)),
                          ("Destination", str_field(width))])
        md = np.array([tuple(x.encode("ascii") for x in row) for row in links], dtype=md_dt)
        f.create_dataset("MetaData", data=md)

    valid = [h for row in truth for h in row if h is not None]
    mean = sum(valid) / len(valid)
    side = {
        "file": os.path.basename(args.out),
        "generator": "scripts/make_datx_fixture.py " + " ".join(sys.argv[1:]),
        "h5py": h5py.__version__,
        "hdf5": h5py.version.hdf5_version,
        "libver": args.libver,
        "dataset_path": surface_path,
        "rows": rows,
        "cols": cols,
        "row_order": "top_first",
        "dtype": str(dtype),
        "storage": "chunked" if args.gzip else "contiguous",
        "chunks": list(args.chunk) if args.gzip else None,
        "filters": (["shuffle"] if args.gzip and args.shuffle else []) + (["deflate"] if args.gzip else []),
        "deflate_level": args.level if args.gzip else None,
        "strings": "variable_length" if args.vlen_strings else "fixed_length",
        "unit": "Fringes",
        "wavelength_m": WAVELENGTH_M,
        "interferometric_scale_factor": SCALE_FACTOR,
        "obliquity_factor": OBLIQUITY,
        "no_data": float(no_data),
        "missing_rule": "raw >= No Data",
        "nm_per_raw_unit": nm_per_fringe,
        "pixel_size_mm": args.pixel_mm,
        "pixel_size_x_mm": args.pixel_mm,
        "pixel_size_y_mm": args.pixel_mm,
        "valid_count": len(valid),
        "missing_count": rows * cols - len(valid),
        "stats_nm": {
            "min": min(valid),
            "max": max(valid),
            "mean": round(mean, 9),
            "rms_about_mean": round(math.sqrt(sum((v - mean) ** 2 for v in valid) / len(valid)), 9),
        },
        "tolerance_nm": 1e-6 if args.dtype == "f64" else 1e-4,
        "heights_nm": truth,
    }
    side_path = os.path.splitext(args.out)[0] + ".json"
    with open(side_path, "w") as fh:
        json.dump(side, fh, indent=None, separators=(",", ":"))
        fh.write("\n")

    if not args.no_verify:
        verify(args.out, side)
    print("wrote %s (%d bytes) and %s (%d bytes)" % (args.out, os.path.getsize(args.out),
                                                     side_path, os.path.getsize(side_path)))


def verify(path, side):
    """Read the file back the way prysm's read_zygo_datx does and compare with the truth."""
    import h5py
    import numpy as np

    with h5py.File(path, "r") as f:
        key = list(f["Data"]["Surface"].keys())[0]
        obj = f["Data"]["Surface"][key]
        no_data = obj.attrs["No Data"][0]
        unit = obj.attrs["Unit"][0]
        unit = unit.decode() if isinstance(unit, bytes) else unit
        assert unit == "Fringes", unit
        k = (obj.attrs["Wavelength"][0] * 1e9 * obj.attrs["Interferometric Scale Factor"][0]
             * obj.attrs["Obliquity Factor"][0])
        raw = obj[()].astype(np.float64)
        missing = raw >= no_data
        heights = np.where(missing, np.nan, np.where(missing, 0.0, raw) * k)
        lateral = obj.attrs["X Converter"][0]["Parameters"][1]
        # the MetaData graph leads to the same dataset
        md = {(r["Source"].decode() if isinstance(r["Source"], bytes) else r["Source"],
               r["Link"].decode() if isinstance(r["Link"], bytes) else r["Link"]):
              (r["Destination"].decode() if isinstance(r["Destination"], bytes) else r["Destination"])
              for r in f["MetaData"][()]}
        m = md[("Root", "Measurement")]
        assert md[(md[(m, "Surface")], "Path")] == side["dataset_path"] == obj.name
        assert f["/Measurement/Surface"] == obj
    truth = np.array([[np.nan if v is None else v for v in row] for row in side["heights_nm"]])
    assert heights.shape == truth.shape
    assert np.array_equal(np.isnan(heights), np.isnan(truth))
    err = np.nanmax(np.abs(heights - truth))
    assert err <= side["tolerance_nm"], err
    assert abs(lateral * 1e3 - side["pixel_size_mm"]) < 1e-12


if __name__ == "__main__":
    main(sys.argv[1:])
