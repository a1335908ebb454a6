//! `POST /v1/maps/predict` on the paper's machine against the independent time-stepped model of
//! the executed motion (`polar_reference`): the plan's stops and moves are written here from
//! the 1-D rule (half the end stations' dwell standing, each cell crossed at constant speed
//! between the midpoints), each with its station's C speeds, and the reference steps them.

use serde_json::{json, Value};

use super::common::http::{app, post_json, post_with};
use super::common::paper_spec;
use super::polar_reference::{depth_nm, Segment, Setup};
use preston::physics::{Process, ProcessSpec, RemovalKernel};

const PATH: &str = "/v1/maps/predict";

fn process(workpiece_rpm: f64, tool_rpm: f64) -> Value {
    json!({
        "workpiece_radius_mm": 40.0, "tool_radius_mm": 10.0,
        "workpiece_rpm": workpiece_rpm, "tool_rpm": tool_rpm,
        "preston_coefficient_m2_per_n": 1e-13, "pressure_kpa": 10.0,
    })
}

/// The plan's stops and moves by the 1-D rule, each a reference segment at its station's C
/// speeds (rpm per sector; one sector at constant speed).
fn segments(
    positions: &[f64],
    dwell: &[f64],
    speeds_rpm: &dyn Fn(usize) -> Vec<f64>,
) -> Vec<Segment> {
    let n = positions.len();
    let piece = |j: usize, from: f64, to: f64, t: f64| Segment::Sectors {
        r1_start_mm: from,
        r1_end_mm: to,
        omega_rpm: speeds_rpm(j),
        duration_s: t,
    };
    if n == 1 {
        return vec![piece(0, positions[0], positions[0], dwell[0])];
    }
    let mid = |j: usize| 0.5 * (positions[j] + positions[j + 1]);
    let mut out = vec![piece(0, positions[0], positions[0], dwell[0] / 2.0)];
    out.push(piece(0, positions[0], mid(0), dwell[0] / 2.0));
    for (j, &t) in dwell.iter().enumerate().take(n - 1).skip(1) {
        out.push(piece(j, mid(j - 1), mid(j), t));
    }
    out.push(piece(
        n - 1,
        mid(n - 2),
        positions[n - 1],
        dwell[n - 1] / 2.0,
    ));
    out.push(piece(
        n - 1,
        positions[n - 1],
        positions[n - 1],
        dwell[n - 1] / 2.0,
    ));
    out.into_iter().filter(|s| s.duration_s() > 0.0).collect()
}

/// The largest difference between the endpoint's map and the reference at its pixels on the
/// part, and the reference's peak.
fn against_reference(
    answer: &Value,
    tool_rpm: f64,
    start_deg: f64,
    segments: &[Segment],
) -> (f64, f64) {
    let map = &answer["removal"];
    let xs: Vec<f64> = map["x_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let ys: Vec<f64> = map["y_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let mut points = Vec::new();
    let mut got = Vec::new();
    for (row, &y) in ys.iter().enumerate() {
        for (column, &x) in xs.iter().enumerate() {
            let value = &map["removal_nm"][row][column];
            if x.hypot(y) <= 40.0 {
                points.push((x, y));
                got.push(
                    value
                        .as_f64()
                        .unwrap_or_else(|| panic!("({x}, {y}) on the part: {value}")),
                );
            } else {
                assert!(value.is_null(), "({x}, {y}) off the part: {value}");
            }
        }
    }
    let fastest = segments
        .iter()
        .map(|s| match s {
            Segment::Sectors { omega_rpm, .. } => {
                omega_rpm.iter().fold(0.0_f64, |m, w| m.max(w.abs()))
            }
            _ => unreachable!("the plans here are sectors"),
        })
        .fold(0.0_f64, f64::max);
    let setup = Setup {
        part_radius_mm: 40.0,
        pad_radius_mm: 10.0,
        tool_rpm,
        // K·P in nm/s per mm/s: 1e-13 m²/N · 10 kPa · (1e3 Pa/kPa) · (1e6 nm/mm).
        scale_nm_per_mm: 1e-13 * 10.0 * 1e3 * 1e6,
        start_angle_rad: start_deg.to_radians(),
    };
    let want = depth_nm(&setup, segments, &points, 1.6e4 * fastest / 60.0);
    let peak = want.iter().cloned().fold(0.0, f64::max);
    let worst = got
        .iter()
        .zip(&want)
        .map(|(g, w)| (g - w).abs())
        .fold(0.0, f64::max);
    (worst, peak)
}

/// Rings at constant speed, a spiral plan at constant speed and the same plan under a sector
/// law agree with the time-stepped motion at every pixel to 1e-6 of the peak.
#[tokio::test]
async fn the_map_is_the_removal_of_the_executed_motion() {
    let law = [1.0, 1.4, 0.6, 1.2, 0.8];
    // workpiece rpm, tool rpm, stations, dwell, sectors of the law (none: constant), start (deg)
    type Case = (f64, f64, Vec<f64>, Vec<f64>, Option<usize>, f64);
    let cases: [Case; 3] = [
        (25.0, 300.0, vec![14.0], vec![3.1], None, 30.0),
        (
            -30.0,
            200.0,
            vec![3.0, 9.0, 15.0, 22.0, 30.0],
            vec![1.0, 1.6, 1.2, 2.0, 1.4],
            None,
            0.0,
        ),
        (
            -30.0,
            200.0,
            vec![3.0, 9.0, 15.0, 22.0, 30.0],
            vec![1.0, 1.6, 1.2, 2.0, 1.4],
            Some(5),
            -75.0,
        ),
    ];
    for (workpiece_rpm, tool_rpm, positions, dwell, sectors, start_deg) in cases {
        // Station j's factors: the law, scaled a little per station.
        let factor = |j: usize, k: usize| law[k] * (1.0 + 0.1 * j as f64);
        let mut body = json!({
            "process": process(workpiece_rpm, tool_rpm),
            "dwell": {"positions_mm": positions, "dwell_s": dwell},
            "start_angle_deg": start_deg,
            "pixel_mm": 2.0,
        });
        if let Some(s) = sectors {
            body["c_law"] = json!({
                "sectors": s,
                "speed_factors": (0..positions.len())
                    .map(|j| (0..s).map(|k| factor(j, k)).collect::<Vec<f64>>())
                    .collect::<Vec<_>>(),
            });
        }
        let reply = post_json(&app(), PATH, body.to_string()).await;
        assert_eq!(reply.status, 200, "{}", reply.text());
        let answer = reply.json();
        let speeds = |j: usize| match sectors {
            None => vec![workpiece_rpm],
            Some(s) => (0..s).map(|k| workpiece_rpm * factor(j, k)).collect(),
        };
        let (worst, peak) = against_reference(
            &answer,
            tool_rpm,
            start_deg,
            &segments(&positions, &dwell, &speeds),
        );
        assert!(
            worst <= 1e-6 * peak,
            "{workpiece_rpm} rpm, {} stations, sectors {sectors:?}: {worst:e} nm against a peak of {peak} nm",
            positions.len()
        );
    }
}

/// A ring of whole turns at constant speed leaves the 1-D removal R(r; r1)·T at every pixel
/// (1e-12 of the peak): round, so its non-axisymmetric part is 0 to rounding.
#[tokio::test]
async fn whole_turns_leave_the_one_dimensional_removal_at_every_pixel() {
    let (workpiece_rpm, tool_rpm, r1) = (20.0, 150.0, 17.0);
    let duration = 3.0 * 60.0 / workpiece_rpm;
    let body = json!({
        "process": process(workpiece_rpm, tool_rpm),
        "dwell": {"positions_mm": [r1], "dwell_s": [duration]},
        "pixel_mm": 1.0,
    });
    let answer = post_json(&app(), PATH, body.to_string()).await.json();
    let kernel = RemovalKernel::new(
        &Process::new(ProcessSpec {
            workpiece_radius_mm: 40.0,
            ..paper_spec(workpiece_rpm, tool_rpm)
        })
        .unwrap(),
    );
    let map = &answer["removal"];
    let peak = kernel.rate_nm_per_s(r1, r1) * duration;
    let mut seen = 0;
    for (row, y) in map["y_mm"].as_array().unwrap().iter().enumerate() {
        for (column, x) in map["x_mm"].as_array().unwrap().iter().enumerate() {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            let Some(got) = map["removal_nm"][row][column].as_f64() else {
                continue;
            };
            let want = kernel.rate_nm_per_s(x.hypot(y), r1) * duration;
            assert!(
                (got - want).abs() <= 1e-12 * peak,
                "({x}, {y}): {got} vs {want}"
            );
            seen += 1;
        }
    }
    assert!(seen > 4000, "{seen} pixels");
    // Round to rounding: the removal less its exact azimuthal mean.
    let round = answer["non_axisymmetric"]["rms_nm"].as_f64().unwrap();
    assert!(
        round <= 1e-12 * peak,
        "{round} nm against a peak of {peak} nm"
    );
}

/// A C law shows as removal that is not round: the same plan's non-axisymmetric RMS is many
/// times the constant-speed plan's (whose is the spiral's ripple alone).
#[tokio::test]
async fn a_c_law_puts_removal_where_the_pad_turns_slowly() {
    let positions = [2.0, 8.0, 14.0, 20.0, 26.0];
    let dwell = [4.0, 6.0, 6.0, 6.0, 4.0];
    let constant = json!({
        "process": process(40.0, 300.0),
        "dwell": {"positions_mm": positions, "dwell_s": dwell},
        "pixel_mm": 2.0,
        "clear_aperture": {"outer_mm": 30.0},
    });
    let mut modulated = constant.clone();
    modulated["c_law"] = json!({"sectors": 2, "speed_factors": vec![[0.5, 1.5]; 5]});
    let app = app();
    let a = post_json(&app, PATH, constant.to_string()).await.json();
    let b = post_json(&app, PATH, modulated.to_string()).await.json();
    let ripple = a["non_axisymmetric"]["rms_nm"].as_f64().unwrap();
    let planted = b["non_axisymmetric"]["rms_nm"].as_f64().unwrap();
    assert!(planted > 5.0 * ripple, "{planted} against {ripple}");
    assert!(b["blocks"].as_u64().unwrap() > a["blocks"].as_u64().unwrap());
    assert_eq!(a["total_time_s"], b["total_time_s"]);
}

/// As CSV, the pixels on the part (x, y, removal); as PNG, a heat map.
#[tokio::test]
async fn the_map_comes_as_csv_and_png() {
    let body = std::fs::read_to_string(super::common::fixture_path("maps_predict_sector_law.json"))
        .unwrap();
    let app = app();
    let json = post_json(&app, PATH, body.clone()).await.json();
    let csv = post_with(
        &app,
        PATH,
        body.clone(),
        &[("content-type", "application/json"), ("accept", "text/csv")],
    )
    .await;
    assert_eq!(csv.status, 200);
    let text = csv.text();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "x_mm,y_mm,removal_nm");
    let on_part = json["removal"]["removal_nm"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|row| row.as_array().unwrap().iter())
        .filter(|v| !v.is_null())
        .count();
    assert_eq!(lines.len(), 1 + on_part);
    let png = post_with(
        &app,
        PATH,
        body,
        &[
            ("content-type", "application/json"),
            ("accept", "image/png"),
        ],
    )
    .await;
    assert_eq!(png.status, 200);
    assert_eq!(&png.body[..8], b"\x89PNG\r\n\x1a\n");
}

/// Bad input is a 422 naming the field.
#[tokio::test]
async fn bad_input_names_its_field() {
    let base: Value = serde_json::from_str(
        &std::fs::read_to_string(super::common::fixture_path("maps_predict_sector_law.json"))
            .unwrap(),
    )
    .unwrap();
    let stations = base["dwell"]["positions_mm"].as_array().unwrap().len();
    let cases: Vec<(&str, Value, &str)> = vec![
        (
            "c_law",
            json!({"sectors": 2, "speed_factors": [[1.0, 1.0]]}),
            "c_law.speed_factors",
        ),
        (
            "c_law",
            json!({"sectors": 2, "speed_factors": vec![vec![1.0, 1.0, 1.0]; stations]}),
            "c_law.speed_factors[0]",
        ),
        (
            "c_law",
            json!({"sectors": 2, "speed_factors": vec![[1.0, -1.0]; stations]}),
            "c_law.speed_factors[0][1]",
        ),
        (
            "c_law",
            json!({"sectors": 0, "speed_factors": vec![Vec::<f64>::new(); stations]}),
            "c_law.sectors",
        ),
        (
            "c_law",
            json!({"sectors": 100_001.0, "speed_factors": vec![[1.0]; stations]}),
            "c_law.sectors",
        ),
        (
            "surface",
            json!({"kind": "sphere", "radius_of_curvature_mm": -20.0}),
            "process.workpiece_radius_mm",
        ),
        ("pixel_mm", json!(0.0), "pixel_mm"),
        ("pixel_mm", json!(1e-3), "pixel_mm"),
        (
            "dwell",
            json!({"positions_mm": [1.0, 2.0], "dwell_s": [1e6, 1e6]}),
            "pixel_mm",
        ),
    ];
    let app = app();
    for (key, value, field) in cases {
        let mut body = base.clone();
        body[key] = value.clone();
        if key == "dwell" {
            // A plan of its own: the fixture's law has a row per station of its own plan.
            body.as_object_mut().unwrap().remove("c_law");
        }
        let reply = post_json(&app, PATH, body.to_string()).await;
        assert_eq!(reply.status, 422, "{key} = {value}: {}", reply.text());
        assert_eq!(
            reply.json()["field"],
            field,
            "{key} = {value}: {}",
            reply.text()
        );
    }
}

/// With C at constant speed the map's azimuthal mean is `/v1/predict`'s 1-D removal of the same
/// plan on the same grid to 1e-9 of its peak, on a plane and on a convex and a concave sphere
/// (the identity of the 2-D model, tested against the map itself by quadrature over θ in
/// `polar.rs` and `polar_sphere.rs`); under a sector law it is not.
#[tokio::test]
async fn with_c_at_constant_speed_the_azimuthal_mean_is_the_one_dimensional_prediction() {
    let app = app();
    let plan = json!({"positions_mm": [0.0, 4.0, 9.0, 15.0, 22.0, 30.0],
                      "dwell_s": [2.0, 1.5, 3.0, 2.5, 1.0, 2.0]});
    for surface in [
        json!({"kind": "plane"}),
        json!({"kind": "sphere", "radius_of_curvature_mm": -150.0}),
        json!({"kind": "sphere", "radius_of_curvature_mm": 120.0}),
    ] {
        let body = json!({
            "process": process(-30.0, 200.0),
            "surface": surface,
            "dwell": plan,
            "pixel_mm": 4.0,
            "radial_grid": {"start_mm": 0.0, "stop_mm": 40.0, "count": 81},
        });
        let two_d = post_json(&app, PATH, body.to_string()).await.json();
        let one_d = post_json(
            &app,
            "/v1/predict",
            json!({"process": body["process"], "surface": surface, "dwell": plan,
                   "radial_grid": body["radial_grid"]})
            .to_string(),
        )
        .await
        .json();
        assert_eq!(two_d["azimuthal_mean"]["radius_mm"], one_d["radius_mm"]);
        let want = super::common::numbers(&one_d["removal_nm"]);
        let got = super::common::numbers(&two_d["azimuthal_mean"]["removal_nm"]);
        let peak = want.iter().cloned().fold(0.0, f64::max);
        assert!(peak > 0.0);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (g - w).abs() <= 1e-9 * peak,
                "{surface}, sample {i}: {g} vs {w} (peak {peak})"
            );
        }
        let mut modulated = body.clone();
        modulated["c_law"] = json!({"sectors": 3, "speed_factors": vec![[0.5, 1.0, 2.0]; 6]});
        let law = post_json(&app, PATH, modulated.to_string()).await.json();
        let moved = super::common::numbers(&law["azimuthal_mean"]["removal_nm"])
            .iter()
            .zip(&want)
            .map(|(g, w)| (g - w).abs())
            .fold(0.0, f64::max);
        assert!(moved > 1e-3 * peak, "{surface}: {moved}");
    }
}
