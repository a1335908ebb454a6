//! X-Y machines (`machine.kinematics: cartesian`): the exact removal of the executed raster
//! against an independent time-stepped integration of the motion, written here from the
//! documented rule; a correction by `/v1/maps/optimize` judged again by `/v1/maps/predict`;
//! and the problems of bad input.

use serde_json::{json, Value};

use crate::common::http::{app, post_json, post_json_accepting};

/// An uneven spot (no symmetry to hide a flipped axis), 9 × 7 pixels of 0.4 mm, its removal in
/// nm over `SPOT_S` seconds, rows top first.
fn spot() -> Vec<Vec<f64>> {
    (0..7)
        .map(|r| {
            (0..9)
                .map(|c| {
                    let (x, y) = (c as f64 - 4.3, 2.6 - r as f64);
                    let bump = 40.0 * (-(x * x / 5.0 + y * y / 2.5 + 0.3 * x * y)).exp();
                    bump * (1.0 + 0.05 * c as f64)
                })
                .collect()
        })
        .collect()
}

const SPOT_S: f64 = 4.0;
const SPOT_PX: f64 = 0.4;
const CENTRE: [f64; 2] = [4.3, 2.6];

/// The spot's rate (nm/s) at offset (dx, dy) mm from the tool's centre: bilinear between
/// pixels in the map's own (column, row) terms, a ring of zeros around it.
fn rate(map: &[Vec<f64>], dx: f64, dy: f64) -> f64 {
    let (h, w) = (map.len() as f64, map[0].len() as f64);
    let c = CENTRE[0] + dx / SPOT_PX;
    let r = CENTRE[1] - dy / SPOT_PX;
    if !(c > -1.0 && c < w && r > -1.0 && r < h) {
        return 0.0;
    }
    let at = |ci: f64, ri: f64| {
        if ci < 0.0 || ri < 0.0 || ci >= w || ri >= h {
            0.0
        } else {
            map[ri as usize][ci as usize] / SPOT_S
        }
    };
    let (c0, r0) = (c.floor(), r.floor());
    let (fc, fr) = (c - c0, r - r0);
    (at(c0, r0) * (1.0 - fc) + at(c0 + 1.0, r0) * fc) * (1.0 - fr)
        + (at(c0, r0 + 1.0) * (1.0 - fc) + at(c0 + 1.0, r0 + 1.0) * fc) * fr
}

/// The executed motion as (from, to, seconds) pieces, by the documented rule: half the end
/// points' dwell standing there, each point's cell (between the midpoints to its neighbours,
/// from the point itself at the ends) crossed at one speed in the rest of its dwell.
fn executed(points: &[[f64; 2]], dwell: &[f64]) -> Vec<([f64; 2], [f64; 2], f64)> {
    let n = points.len();
    let mid = |a: [f64; 2], b: [f64; 2]| [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
    let len = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
    let mut pieces = vec![(points[0], points[0], dwell[0] / 2.0)];
    for k in 0..n {
        let p = points[k];
        let from = if k == 0 { p } else { mid(points[k - 1], p) };
        let to = if k == n - 1 { p } else { mid(p, points[k + 1]) };
        let moving = if k == 0 || k == n - 1 {
            dwell[k] / 2.0
        } else {
            dwell[k]
        };
        let (a, b) = (len(from, p), len(p, to));
        pieces.push((from, p, moving * a / (a + b)));
        pieces.push((p, to, moving * b / (a + b)));
    }
    pieces.push((points[n - 1], points[n - 1], dwell[n - 1] / 2.0));
    pieces
}

/// The removal at q: each piece stepped through in `steps` equal times (midpoint rule).
fn stepped(
    map: &[Vec<f64>],
    pieces: &[([f64; 2], [f64; 2], f64)],
    q: [f64; 2],
    steps: usize,
) -> f64 {
    let mut total = 0.0;
    for &(a, b, seconds) in pieces {
        if seconds == 0.0 {
            continue;
        }
        let dt = seconds / steps as f64;
        for s in 0..steps {
            let u = (s as f64 + 0.5) / steps as f64;
            let c = [a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u];
            total += rate(map, q[0] - c[0], q[1] - c[1]) * dt;
        }
    }
    total
}

fn influence() -> Value {
    json!({
        "map": {"heights_nm": spot(), "pixel_mm": SPOT_PX},
        "duration_s": SPOT_S,
        "centre_px": CENTRE,
    })
}

/// A path the given order allows: a serpentine's turn, a diagonal leg, a long jump and a
/// point revisited later (its own cell each time), on a 0.2 mm lattice.
fn path() -> (Vec<[f64; 2]>, Vec<f64>) {
    let points = vec![
        [-1.0, 0.6],
        [-0.6, 0.6],
        [-0.2, 0.6],
        [0.2, 0.6],
        [0.2, 0.2],
        [-0.2, 0.2],
        [-0.6, -0.2],
        [-0.6, -1.0],
        [1.4, -1.0],
        [1.4, -0.6],
        [-0.2, 0.2],
        [0.6, 0.6],
    ];
    let dwell = vec![3.0, 1.5, 0.0, 2.2, 4.1, 0.7, 1.9, 2.5, 3.3, 0.4, 1.1, 2.8];
    (points, dwell)
}

/// `/v1/maps/predict` on an X-Y machine against the time-stepped motion at every pixel of its
/// map, to 1e-6 of the peak. The stepping's own error: the midpoint rule on 4,000 steps a
/// piece errs by at most Δ²/24·|f″| where f is smooth and O(Δ²·|jump of f′|) at each kink of
/// the bilinear rate; with pieces of at most 2.1 mm, Δ ≤ 5e-4 mm against the spot's 0.4 mm
/// pixels, about 1e-7 of the peak.
#[tokio::test]
async fn the_removal_is_the_executed_motions_exactly() {
    let (points, dwell) = path();
    let body = json!({
        "machine": {"kinematics": "cartesian"},
        "influence": influence(),
        "dwell": {"points_mm": points, "dwell_s": dwell},
        "pixel_mm": 0.2,
    });
    let reply = post_json(&app(), "/v1/maps/predict", body.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let out = reply.json();
    assert_eq!(out["kinematics"], "cartesian");
    let x: Vec<f64> = serde_json::from_value(out["removal"]["x_mm"].clone()).unwrap();
    let y: Vec<f64> = serde_json::from_value(out["removal"]["y_mm"].clone()).unwrap();
    let removal: Vec<Vec<f64>> =
        serde_json::from_value(out["removal"]["removal_nm"].clone()).unwrap();
    let map = spot();
    let pieces = executed(&points, &dwell);
    let reference: Vec<Vec<f64>> = y
        .iter()
        .map(|&yv| {
            x.iter()
                .map(|&xv| stepped(&map, &pieces, [xv, yv], 4000))
                .collect()
        })
        .collect();
    let peak = reference.iter().flatten().fold(0.0_f64, |m, v| m.max(*v));
    assert!(peak > 10.0, "{peak}");
    let mut worst = 0.0_f64;
    for (row, expected) in removal.iter().zip(&reference) {
        for (a, b) in row.iter().zip(expected) {
            worst = worst.max((a - b).abs());
        }
    }
    assert!(worst <= 1e-6 * peak, "worst {worst} of peak {peak}");
    // The map reaches past the points by the spot's whole support, where nothing is removed.
    assert_eq!(removal[0][0], 0.0);
    assert_eq!(out["total_time_s"], dwell.iter().sum::<f64>());
}

/// A planted error (a bump and a ridge on a 24 × 16 map of 0.4 mm) corrected by the spot:
/// what `/v1/maps/optimize` reports is what `/v1/maps/predict` gives for its plan on the same
/// map, the figure falls at least tenfold, and the plan keeps its dwell bounds, the total time
/// and both axes' limits.
#[tokio::test]
async fn a_correction_is_its_own_prediction_and_keeps_its_limits() {
    let heights: Vec<Vec<f64>> = (0..16)
        .map(|r| {
            (0..24)
                .map(|c| {
                    let (x, y) = (c as f64 * 0.4 - 4.6, 3.0 - r as f64 * 0.4);
                    30.0 * (-(x - 1.0).powi(2) / 4.0 - y * y / 3.0).exp()
                        + 12.0 * (1.3 * x + 0.4 * y).sin()
                        + 2.0 * x
                })
                .collect()
        })
        .collect();
    let machine = json!({
        "kinematics": "cartesian",
        "x": {"max_velocity_mm_per_min": 3000.0, "max_acceleration_mm_per_s2": 200.0},
        "y": {"max_velocity_mm_per_min": 2000.0, "max_acceleration_mm_per_s2": 100.0}
    });
    let map = json!({"heights_nm": heights, "pixel_mm": 0.4});
    let body = json!({
        "machine": machine,
        "influence": influence(),
        "map": map,
        "dwell_pitch_mm": 0.8,
        "constraints": {"min_dwell_s": 0.05, "max_dwell_s": 30.0},
    });
    let reply = post_json(&app(), "/v1/maps/optimize", body.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let plan = reply.json();
    assert_eq!(plan["kinematics"], "cartesian");
    assert!(
        plan["solver"]["converged"].as_bool().unwrap(),
        "{}",
        plan["solver"]
    );
    let (before, after) = (
        plan["metrics"]["before"]["rms_nm"].as_f64().unwrap(),
        plan["metrics"]["after"]["rms_nm"].as_f64().unwrap(),
    );
    assert!(after < before / 10.0, "{before} → {after}");
    let dwell: Vec<f64> = serde_json::from_value(plan["dwell"]["dwell_s"].clone()).unwrap();
    assert!(
        dwell.iter().all(|&t| (0.05..=30.0).contains(&t)),
        "{dwell:?}"
    );
    for (axis, v, a) in [("x", 3000.0, 200.0), ("y", 2000.0, 100.0)] {
        let peaks = &plan["axes"][axis];
        assert!(peaks["velocity_mm_per_min"].as_f64().unwrap() <= v * (1.0 + 1e-12));
        assert!(peaks["acceleration_mm_per_s2"].as_f64().unwrap() <= a * (1.0 + 1e-12));
    }
    // Predicted again from its own dwell, on the same map.
    let again = json!({
        "machine": {"kinematics": "cartesian"},
        "influence": influence(),
        "dwell": plan["dwell"],
        "map": map,
    });
    let reply = post_json(&app(), "/v1/maps/predict", again.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let predicted = reply.json();
    let (ours, theirs) = (
        &plan["maps"]["removal_nm"],
        &predicted["removal"]["removal_nm"],
    );
    let peak = ours
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|r| r.as_array().unwrap())
        .fold(0.0_f64, |m, v| m.max(v.as_f64().unwrap()));
    for (a, b) in ours
        .as_array()
        .unwrap()
        .iter()
        .zip(theirs.as_array().unwrap())
    {
        for (a, b) in a.as_array().unwrap().iter().zip(b.as_array().unwrap()) {
            assert!((a.as_f64().unwrap() - b.as_f64().unwrap()).abs() <= 1e-9 * peak);
        }
    }
    let after_again = predicted["after"]["rms_nm"].as_f64().unwrap();
    assert!(
        (after_again - after).abs() <= 1e-9 * before,
        "{after_again} vs {after}"
    );
    // The peaks are the plan's to rounding (the points' mm read back from JSON).
    for axis in ["x", "y"] {
        for peak in ["velocity_mm_per_min", "acceleration_mm_per_s2"] {
            let (a, b) = (
                predicted["axes"][axis][peak].as_f64().unwrap(),
                plan["axes"][axis][peak].as_f64().unwrap(),
            );
            assert!((a - b).abs() <= 1e-9 * b, "{axis} {peak}: {a} vs {b}");
        }
    }
    program_keeps_the_plans_limits(&plan, &machine).await;
    // A total time the plan must meet binds, and is met (to 1e-5 below: the multiplier's
    // search stops where its solves' own tolerance does).
    let total = plan["total_time_s"].as_f64().unwrap();
    let mut tight = body.clone();
    tight["constraints"]["max_total_time_s"] = json!(0.8 * total);
    let reply = post_json(&app(), "/v1/maps/optimize", tight.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let squeezed = reply.json()["total_time_s"].as_f64().unwrap();
    assert!(
        squeezed <= 0.8 * total * (1.0 + 1e-12) && squeezed >= 0.8 * total * (1.0 - 1e-5),
        "{squeezed} of {total}: {}",
        reply.text()
    );
}

/// Bad input names its field, in the request's terms, for either kind of request.
#[tokio::test]
async fn bad_raster_input_names_its_field() {
    let (points, dwell) = path();
    let good = json!({
        "machine": {"kinematics": "cartesian"},
        "influence": influence(),
        "dwell": {"points_mm": points, "dwell_s": dwell},
        "pixel_mm": 0.2,
    });
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|b| b["dwell"]["points_mm"][3] = json!([0.3, 0.6])),
            "dwell.points_mm[3]",
        ),
        (
            Box::new(|b| b["dwell"]["dwell_s"][2] = json!(-1.0)),
            "dwell.dwell_s[2]",
        ),
        (
            Box::new(|b| b["dwell"]["dwell_s"] = json!([1.0])),
            "dwell.dwell_s",
        ),
        (
            Box::new(|b| b["dwell"]["points_mm"][1] = json!([-1.0, 0.6])),
            "dwell.points_mm[1]",
        ),
        (
            Box::new(|b| b["influence"]["duration_s"] = json!(0.0)),
            "influence.duration_s",
        ),
        (
            Box::new(|b| b["influence"]["centre_px"] = json!([1.0])),
            "influence.centre_px",
        ),
        (
            Box::new(|b| b["influence"]["map"]["heights_nm"] = json!([[0.0, 0.0], [0.0, 0.0]])),
            "influence.map",
        ),
        (
            Box::new(|b| b["influence"]["colour"] = json!(1)),
            "influence.colour",
        ),
        (
            Box::new(|b| b["dwell"]["dwell_s"][0] = json!("3")),
            "dwell.dwell_s[0]",
        ),
        (
            Box::new(|b| b["machine"]["x"] = json!({"max_velocity_mm_per_min": -5.0})),
            "machine.x.max_velocity_mm_per_min",
        ),
    ];
    for (edit, field) in cases {
        let mut body = good.clone();
        edit(&mut body);
        let reply = post_json(&app(), "/v1/maps/predict", body.to_string()).await;
        assert!(
            reply.status == 422 || reply.status == 400,
            "{field}: {}",
            reply.text()
        );
        assert_eq!(reply.json()["field"], field, "{}", reply.text());
    }
    // The polar machine's request names its own fields, as before.
    let polar = json!({"machine": {"kinematics": "polar"}, "influence": {}});
    let reply = post_json(&app(), "/v1/maps/predict", polar.to_string()).await;
    assert_eq!(reply.status, 422, "{}", reply.text());
    assert_eq!(reply.json()["field"], "influence", "{}", reply.text());
}

/// The G-code's G1 and G4 blocks, read back: (X, Y, seconds) per block from the start, the
/// approach and retract (Z words) left out as the plan's own motion has none.
/// The number after `letter` in a G-code line, if the line has that word.
fn word(line: &str, letter: char) -> Option<f64> {
    line.split_whitespace()
        .find(|w| w.starts_with(letter))
        .map(|w| w[1..].parse::<f64>().unwrap())
}

fn gcode_blocks(gcode: &str) -> (Vec<[f64; 2]>, Vec<f64>) {
    let (mut at, mut ends, mut seconds) = ([f64::NAN; 2], vec![], vec![]);
    for line in gcode.lines() {
        if line.starts_with("G0 ") {
            at = [word(line, 'X').unwrap(), word(line, 'Y').unwrap()];
            ends.push(at);
        } else if line.starts_with("G4 ") {
            ends.push(at);
            seconds.push(word(line, 'P').unwrap());
        } else if line.starts_with("G1 X") {
            at = [word(line, 'X').unwrap(), word(line, 'Y').unwrap()];
            ends.push(at);
            // G93: F is the block's inverse time, 1/min.
            seconds.push(60.0 / word(line, 'F').unwrap());
        }
    }
    (ends, seconds)
}

/// `/v1/maps/program` of `body` is a 422 `machine-limits` problem whose first violation is
/// `field`.
async fn refused_for(body: &Value, field: &str) {
    let reply = post_json(&app(), "/v1/maps/program", body.to_string()).await;
    assert_eq!(reply.status, 422, "{}", reply.text());
    assert_eq!(
        reply.json()["violations"][0]["field"],
        field,
        "{}",
        reply.text()
    );
}

/// `/v1/maps/program` of the plan on the same machine: accepted; X's and Y's peaks equal the
/// plan's to 1e-9 (one model, computed again from the program's own blocks); and the G-code
/// read back gives them again by the documented model (velocity constant in a block, changed
/// over the time between block midpoints, from and to rest), to the G-code's rounding: 7
/// decimals of a 0.4 mm half-leg and 10 digits of F are 1e-6 relative at worst.
async fn program_keeps_the_plans_limits(plan: &Value, machine: &Value) {
    let body = json!({
        "machine": machine,
        "dwell": plan["dwell"],
        "format": {"decimals": 7},
    });
    let reply = post_json(&app(), "/v1/maps/program", body.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let program = reply.json();
    assert_eq!(program["kinematics"], "cartesian");
    // A flat: Z keeps its height, no chord leaves the part.
    assert_eq!(program["max_path_deviation_mm"], 0.0);
    assert_eq!(program["max_slope_deg"], 0.0);
    let total = plan["total_time_s"].as_f64().unwrap();
    assert!((program["total_time_s"].as_f64().unwrap() - total).abs() <= 1e-9 * total);
    let names = [
        ("velocity_mm_per_min", "peak_velocity_mm_per_min"),
        ("acceleration_mm_per_s2", "peak_acceleration_mm_per_s2"),
    ];
    for axis in ["x", "y"] {
        for (ours, theirs) in names {
            let (a, b) = (
                program["axes"][axis][theirs].as_f64().unwrap(),
                plan["axes"][axis][ours].as_f64().unwrap(),
            );
            assert!((a - b).abs() <= 1e-9 * b, "{axis} {ours}: {a} vs {b}");
        }
    }
    let reply =
        post_json_accepting(&app(), "/v1/maps/program", body.to_string(), "text/x-gcode").await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let gcode = reply.text();
    assert!(
        gcode.contains("G93") && gcode.trim_end().ends_with("M2"),
        "{gcode}"
    );
    let (ends, seconds) = gcode_blocks(&gcode);
    assert_eq!(ends.len(), seconds.len() + 1);
    let read: f64 = seconds.iter().sum();
    assert!((read - total).abs() <= 1e-6 * total, "{read} vs {total}");
    for (axis, name) in [(0, "x"), (1, "y")] {
        let v: Vec<f64> = (0..seconds.len())
            .map(|k| (ends[k + 1][axis] - ends[k][axis]) / seconds[k])
            .collect();
        let mut peak_a = 0.0_f64;
        for k in 0..=v.len() {
            let (v0, d0) = if k == 0 {
                (0.0, 0.0)
            } else {
                (v[k - 1], seconds[k - 1])
            };
            let (v1, d1) = if k == v.len() {
                (0.0, 0.0)
            } else {
                (v[k], seconds[k])
            };
            if (v1 - v0).abs() > 1e-9 * v0.abs().max(v1.abs()) {
                peak_a = peak_a.max((v1 - v0).abs() / ((d0 + d1) / 2.0));
            }
        }
        let peak_v = 60.0 * v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        for (read, name2) in [(peak_v, names[0].1), (peak_a, names[1].1)] {
            let reported = program["axes"][name][name2].as_f64().unwrap();
            assert!(
                (read - reported).abs() <= 1e-5 * reported,
                "{name} {name2}: read {read} vs {reported}"
            );
        }
    }
    // The same plan on a machine with X at half the plan's peak velocity: a 422 naming the
    // limit, never a program.
    let peak = plan["axes"]["x"]["velocity_mm_per_min"].as_f64().unwrap();
    let mut slow = body.clone();
    slow["machine"]["x"]["max_velocity_mm_per_min"] = json!(peak / 2.0);
    refused_for(&slow, "machine.x.max_velocity_mm_per_min").await;
}

/// On a curved part Z follows the surface: a 3 × 3 plan of 2 mm pitch off the vertex of a
/// sphere of R = 40 mm. Every G1 block ends at the sphere's sag there, R − √(R² − x² − y²)
/// from the block's own X and Y, to the G-code's 7 decimals; the start is that plus the
/// clearance; the reported chord deviation is the largest normal distance of a move's middle
/// from the sphere, | |m − c| − R | for the centre c = (0, 0, R), computed here from the
/// G-code (to its rounding); the steepest slope is asin(r/R) at the farthest point.
/// Z's velocity limit below the moves' peak is a 422 naming it; a point beyond the sphere's
/// rim, naming the point.
#[tokio::test]
async fn the_program_follows_a_curved_part() {
    let r_mm = 40.0;
    let mut points = vec![];
    for row in 0..3 {
        for k in 0..3 {
            let col = if row % 2 == 0 { k } else { 2 - k };
            points.push([5.0 + 2.0 * col as f64, -3.0 + 2.0 * row as f64]);
        }
    }
    let dwell: Vec<f64> = (0..9).map(|k| 1.0 + 0.5 * k as f64).collect();
    let body = json!({
        "machine": {"kinematics": "cartesian"},
        "dwell": {"points_mm": points, "dwell_s": dwell},
        "surface": {"kind": "sphere", "radius_of_curvature_mm": r_mm},
        "approach": {"clearance_mm": 3.0, "feed_mm_per_min": 1.0},
        "format": {"decimals": 7},
    });
    let reply = post_json(&app(), "/v1/maps/program", body.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let program = reply.json();
    let sag = |x: f64, y: f64| r_mm - (r_mm * r_mm - x * x - y * y).sqrt();
    let reply =
        post_json_accepting(&app(), "/v1/maps/program", body.to_string(), "text/x-gcode").await;
    let gcode = reply.text();
    let mut at = [f64::NAN; 3];
    let mut worst = 0.0_f64;
    let mut moves = 0;
    for line in gcode.lines() {
        if line.starts_with("G0 ") {
            let [x, y, z] = ['X', 'Y', 'Z'].map(|c| word(line, c).unwrap());
            assert!((z - sag(x, y) - 3.0).abs() < 1e-7, "{line}");
            at = [x, y, z - 3.0];
        } else if line.starts_with("G1 X") {
            let [x, y, z] = ['X', 'Y', 'Z'].map(|c| word(line, c).unwrap());
            assert!((z - sag(x, y)).abs() < 1e-7, "{line}");
            let middle = [0.5 * (at[0] + x), 0.5 * (at[1] + y), 0.5 * (at[2] + z)];
            let distance =
                (middle[0].powi(2) + middle[1].powi(2) + (middle[2] - r_mm).powi(2)).sqrt();
            worst = worst.max((distance - r_mm).abs());
            at = [x, y, z];
            moves += 1;
        }
    }
    assert_eq!(moves, 16, "{gcode}");
    let reported = program["max_path_deviation_mm"].as_f64().unwrap();
    // The G-code's 7 decimals move a middle by up to 1e-7 mm; the vertical gap times the
    // cosine differs from the normal distance at second order, gap·tan²θ/(2R) ≈ 1e-6 of it.
    assert!(
        (reported - worst).abs() <= 2e-7 + 1e-5 * worst,
        "{reported} vs {worst}"
    );
    let farthest = (9.0_f64.powi(2) + 3.0_f64.powi(2)).sqrt();
    let slope = (farthest / r_mm).asin().to_degrees();
    assert!((program["max_slope_deg"].as_f64().unwrap() - slope).abs() < 1e-9);
    // Z moves within the polishing now: its peak velocity is the moves', above the approach's
    // 1 mm/min.
    let z_peak = program["axes"]["z"]["peak_velocity_mm_per_min"]
        .as_f64()
        .unwrap();
    assert!(z_peak > 2.0, "{z_peak}");
    let mut slow = body.clone();
    slow["machine"]["z"] = json!({"max_velocity_mm_per_min": 0.5 * z_peak});
    refused_for(&slow, "machine.z.max_velocity_mm_per_min").await;
    let mut beyond = body.clone();
    beyond["surface"]["radius_of_curvature_mm"] = json!(9.0);
    let reply = post_json(&app(), "/v1/maps/program", beyond.to_string()).await;
    assert_eq!(reply.status, 422, "{}", reply.text());
    // R = 9 mm: the farthest point, (9, −3) at r = √90, is named.
    assert_eq!(
        reply.json()["field"],
        "dwell.points_mm[2]",
        "{}",
        reply.text()
    );
}

/// The area, centroid abscissa and second moment about it of the lens where a pad of radius
/// `rt` centred at (r1, 0) meets a part of radius `rm`: A = ∫2h dx, x_c = ∫2h·x dx / A,
/// I_c = ∫2h·(x − x_c)² dx, h the half-chord, on the two pieces each circle bounds, each by
/// Simpson's rule in θ with x = a + (b − a)(1 − cos θ)/2 (which takes the square-root ends
/// away: the integrand becomes smooth, and 20,000 panels are exact to rounding).
fn lens(rt: f64, rm: f64, r1: f64) -> (f64, f64, f64) {
    let cross = (r1 * r1 + rm * rm - rt * rt) / (2.0 * r1);
    type HalfChord = Box<dyn Fn(f64) -> f64>;
    let pieces: [(f64, f64, HalfChord); 2] = [
        (
            r1 - rt,
            cross,
            Box::new(move |x: f64| (rt * rt - (x - r1).powi(2)).max(0.0).sqrt()),
        ),
        (
            cross,
            rm,
            Box::new(move |x: f64| (rm * rm - x * x).max(0.0).sqrt()),
        ),
    ];
    let integral = |g: &dyn Fn(f64) -> f64| -> f64 {
        let n = 20_000;
        pieces
            .iter()
            .map(|(a, b, h)| {
                let f = |t: f64| {
                    let x = a + (b - a) * (1.0 - t.cos()) / 2.0;
                    2.0 * h(x) * g(x) * (b - a) * t.sin() / 2.0
                };
                let dt = std::f64::consts::PI / n as f64;
                (0..=n)
                    .map(|i| {
                        let w = if i == 0 || i == n {
                            1.0
                        } else if i % 2 == 1 {
                            4.0
                        } else {
                            2.0
                        };
                        w * f(i as f64 * dt)
                    })
                    .sum::<f64>()
                    * dt
                    / 3.0
            })
            .sum()
    };
    let area = integral(&|_| 1.0);
    let centroid = integral(&|x| x) / area;
    let second = integral(&|x: f64| (x - centroid).powi(2));
    (area, centroid, second)
}

/// Preston's pad on a part that stands still (`/v1/maps/removal-function`, cartesian): at
/// every pixel the rate is K·p·|ω2|·ρ, ρ the distance from the pad centre (the sliding speed
/// of a pad spinning in place), against this test's own pressure: nominal on the part; under
/// constant force and the linear (moment-balance) model overhanging the edge, the force
/// P·π·r_t² on the lens the part leaves, p = F/A + b·(x − x_c), b = κ·F·(r1 − x_c)/I_c, with
/// A, x_c, I_c by the quadrature above. Agreement to 1e-9 of the peak. Its `influence` drives
/// `/v1/maps/predict` as it is: one point's dwell of 10 s removes 10 s of the rate.
#[tokio::test]
async fn the_pad_on_a_still_part_is_its_sliding_speed() {
    let (rm, rt, rpm, k, kpa) = (50.0, 10.0, 200.0, 1e-13, 10.0);
    let omega = rpm * std::f64::consts::TAU / 60.0;
    let f = kpa * 1e3 * std::f64::consts::PI * rt * rt;
    for (model, r1) in [
        ("uniform", 0.0),
        ("uniform", 44.0),
        ("constant_force", 44.0),
        ("linear", 44.0),
    ] {
        let body = json!({
            "process": {
                "workpiece_radius_mm": rm, "tool_radius_mm": rt,
                "workpiece_rpm": 0.0, "tool_rpm": rpm,
                "preston_coefficient_m2_per_n": k, "pressure_kpa": kpa,
                "pressure_model": model, "pad_moment_share": 1.0,
            },
            "machine": {"kinematics": "cartesian"},
            "tool_position_mm": r1,
            "pixel_mm": 0.25,
        });
        let reply = post_json(&app(), "/v1/maps/removal-function", body.to_string()).await;
        assert_eq!(reply.status, 200, "{}", reply.text());
        let answer = reply.json();
        assert_eq!(answer["kinematics"], "cartesian");
        let (area, xc, ic) = lens(rt, rm, r1);
        // Pressure (Pa) at abscissa x on the contact.
        let pressure = |x: f64| match (model, r1) {
            ("uniform", _) | (_, 0.0) => kpa * 1e3,
            ("constant_force", _) => f / area,
            _ => f / area + f * (r1 - xc) / ic * (x - xc),
        };
        if model == "linear" {
            // The least pressure, on the pad's inner rim: 0.37 of nominal (a 4 mm overhang).
            let least = pressure(r1 - rt) / (kpa * 1e3);
            assert!((least - 0.37).abs() < 0.005, "{least}");
        }
        let fp = &answer["footprint"];
        let xs: Vec<f64> = serde_json::from_value(fp["x_mm"].clone()).unwrap();
        let ys: Vec<f64> = serde_json::from_value(fp["y_mm"].clone()).unwrap();
        let rates: Vec<Vec<f64>> =
            serde_json::from_value(fp["removal_rate_nm_per_min"].clone()).unwrap();
        let peak = fp["peak_removal_rate_nm_per_min"].as_f64().unwrap();
        let mut worst = 0.0_f64;
        for (row, &y) in rates.iter().zip(&ys) {
            for (&got, &x) in row.iter().zip(&xs) {
                let (dx, dy) = (x - r1, y);
                let on = x * x + y * y <= rm * rm && dx * dx + dy * dy <= rt * rt;
                let want = if on {
                    60.0 * 1e6 * k * pressure(x) * omega * dx.hypot(dy)
                } else {
                    0.0
                };
                worst = worst.max((got - want).abs());
            }
        }
        assert!(worst <= 1e-9 * peak, "{model} at {r1}: {worst} of {peak}");
        // The influence is the same map in nm/s, centred on the pad.
        let influence = &answer["influence"];
        let centre = (xs.len() - 1) / 2;
        assert_eq!(
            influence["centre_px"],
            json!([centre as f64, centre as f64])
        );
        let per_s = influence["map"]["heights_nm"][centre + 3][centre - 7]
            .as_f64()
            .unwrap();
        assert!((per_s * 60.0 - rates[centre + 3][centre - 7]).abs() <= 1e-12 * peak);
        if r1 == 0.0 {
            let predict = json!({
                "machine": {"kinematics": "cartesian"},
                "influence": influence,
                "dwell": {"points_mm": [[0.0, 0.0]], "dwell_s": [10.0]},
            });
            let reply = post_json(&app(), "/v1/maps/predict", predict.to_string()).await;
            assert_eq!(reply.status, 200, "{}", reply.text());
            let removal = reply.json()["removal"]["removal_nm"].clone();
            let removal: Vec<Vec<f64>> = serde_json::from_value(removal).unwrap();
            let most = removal.iter().flatten().fold(0.0_f64, |m, v| m.max(*v));
            // The rim's peak rate, 10 s of it (the lattice holds the spot's pixels).
            assert!(
                (most - 10.0 * peak / 60.0).abs() <= 1e-9 * most,
                "{most} vs {peak}"
            );
        }
    }
    // A part that turns is not an X-Y machine's.
    let turning = json!({
        "process": {"workpiece_radius_mm": rm, "tool_radius_mm": rt, "workpiece_rpm": 5.0, "tool_rpm": rpm},
        "machine": {"kinematics": "cartesian"},
    });
    let reply = post_json(&app(), "/v1/maps/removal-function", turning.to_string()).await;
    assert_eq!(reply.status, 422, "{}", reply.text());
    assert_eq!(reply.json()["field"], "process.workpiece_rpm");
}
