#!/usr/bin/env python3
"""Writes fixtures/calibration_polar_map.json: a polar run on the 30 mm sector-law part of
fixtures/maps_predict_sector_law.json (six stations, C 30 % faster and slower on opposite
sectors; each dwell 40x longer) measured by an interferometer before and after, as /v1/calibration takes it. The run
removed 1.25x what the nominal K (1e-13 m^2/N) predicts; the maps carry a figure (astigmatism
and trefoil), a piston and a tilt between them, and noise smoothed over 1.5 pixels at 3 % of
the removal's peak (seeded), so the fit's standard error must count the noise's correlation.

The removal at nominal K is the service's own exact map (POST /v1/maps/predict, tested against
a time-stepped integration of the executed motion in tests/it/polar.rs): run it with the
service listening on 127.0.0.1:8080 (`cargo run --release -- serve`)."""
import json, math, random, urllib.request

PLANTED, PISTON_NM, TILT = 1.25, -2.0, (0.04, -0.03)   # nm, nm/mm
NOISE_OF_PEAK, NOISE_WIDTH_PX, SEED = 0.03, 1.5, 7

predict = json.load(open("fixtures/maps_predict_sector_law.json"))
# The fixture's plan, 40x longer: a run removing tens of nm.
predict["dwell"]["dwell_s"] = [40 * t for t in predict["dwell"]["dwell_s"]]
request = urllib.request.Request(
    "http://127.0.0.1:8080/v1/maps/predict", json.dumps(predict).encode(),
    {"content-type": "application/json"})
answer = json.load(urllib.request.urlopen(request))
xs, ys = answer["removal"]["x_mm"], answer["removal"]["y_mm"]
removal = answer["removal"]["removal_nm"]          # rows, top first; null off the part
peak = max(v for row in removal for v in row if v is not None)

rng = random.Random(SEED)
reach = int(math.ceil(3 * NOISE_WIDTH_PX))
h, w = len(ys), len(xs)
white = [[rng.gauss(0, 1) for _ in range(w + 2 * reach)] for _ in range(h + 2 * reach)]
taps = [(dr, dc, math.exp(-(dr * dr + dc * dc) / (2 * NOISE_WIDTH_PX ** 2)))
        for dr in range(-reach, reach + 1) for dc in range(-reach, reach + 1)]
noise = [[sum(k * white[r + reach + dr][c + reach + dc] for dr, dc, k in taps)
          for c in range(w)] for r in range(h)]
valid = [noise[r][c] for r in range(h) for c in range(w) if removal[r][c] is not None]
scale = NOISE_OF_PEAK * peak / math.sqrt(sum(v * v for v in valid) / len(valid))

radius = predict["process"]["workpiece_radius_mm"]
before, after = [], []
for r, y in enumerate(ys):
    row_b, row_a = [], []
    for c, x in enumerate(xs):
        if removal[r][c] is None:
            row_b.append(None)
            row_a.append(None)
            continue
        u, v = x / radius, y / radius
        figure = 15.0 * (u * u - v * v) + 6.0 * (u ** 3 - 3 * u * v * v) + 5.0
        removed = PLANTED * removal[r][c] + PISTON_NM + TILT[0] * x + TILT[1] * y
        row_b.append(round(figure, 4))
        row_a.append(round(figure - removed + scale * noise[r][c], 4))
    before.append(row_b)
    after.append(row_a)

centre = (w - 1) / 2
fixture = {
    "process": predict["process"],
    "runs": [{
        "polar": {key: predict[key] for key in ("dwell", "c_law", "start_angle_deg")},
        "map": {
            "before": {"heights_nm": before},
            "after": {"heights_nm": after},
            "pixel_mm": predict["pixel_mm"],
            "alignment": {"centre_x_px": centre, "centre_y_px": centre,
                          "part_radius_mm": radius},
        },
    }],
}
with open("fixtures/calibration_polar_map.json", "w") as f:
    json.dump(fixture, f, separators=(",", ":"))
    f.write("\n")
print(f"peak {peak:.3f} nm, noise RMS {NOISE_OF_PEAK * peak:.3f} nm, {len(valid)} pixels")
