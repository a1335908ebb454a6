//! `POST /v1/program` through the router: axis motion recomputed from the blocks, one 422 per
//! kind of violated limit, the G-code and CSV answers, and bad input named.

use serde_json::{json, Value};

use crate::common::http::{app, post_json, post_json_accepting};

const FIXTURE: &str = include_str!("../../fixtures/program_sphere.json");

fn fixture() -> Value {
    serde_json::from_str(FIXTURE).unwrap()
}

async fn run(request: &Value) -> (u16, Value) {
    let reply = post_json(&app(), "/v1/program", request.to_string()).await;
    (reply.status.as_u16(), reply.json())
}

fn number(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

/// Velocities ΔA/d per block and accelerations Δv/((d_k + d_{k+1})/2) between blocks (from
/// rest before the first, to rest after the last), recomputed from the JSON blocks, agree
/// with the reported peaks; the polishing blocks' time is the plan's.
#[tokio::test]
async fn axis_motion_recomputed_from_the_blocks_agrees_with_the_report() {
    let request = fixture();
    let (status, body) = run(&request).await;
    assert_eq!(status, 200, "{body}");
    let blocks = body["blocks"].as_array().unwrap();
    let durations: Vec<f64> = blocks.iter().map(|b| number(&b["duration_s"])).collect();
    for (axis, key, unit) in [
        ("x", "x_mm", "mm"),
        ("z", "z_mm", "mm"),
        ("b", "b_deg", "deg"),
    ] {
        let mut positions = vec![number(&body["start"][key])];
        positions.extend(blocks.iter().map(|b| number(&b[key])));
        let velocity: Vec<f64> = (0..blocks.len())
            .map(|k| 60.0 * (positions[k + 1] - positions[k]) / durations[k])
            .collect();
        let mut peak_acceleration = 0.0_f64;
        for k in 0..=blocks.len() {
            let (v0, d0) = if k == 0 {
                (0.0, 0.0)
            } else {
                (velocity[k - 1], durations[k - 1])
            };
            let (v1, d1) = velocity.get(k).map_or((0.0, 0.0), |&v| (v, durations[k]));
            peak_acceleration = peak_acceleration.max(((v1 - v0) / 60.0 / (0.5 * (d0 + d1))).abs());
        }
        let peak_velocity = velocity.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let report = &body["axes"][axis];
        let reported_v = number(&report[format!("peak_velocity_{unit}_per_min")]);
        let reported_a = number(&report[format!("peak_acceleration_{unit}_per_s2")]);
        // Same formulas in a different order of operations: agreement to rounding.
        assert!(
            (reported_v - peak_velocity).abs() <= 1e-9 * peak_velocity.max(1.0),
            "{axis}"
        );
        assert!(
            (reported_a - peak_acceleration).abs() <= 1e-9 * peak_acceleration.max(1.0),
            "{axis}"
        );
        let lo = positions.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(
            (number(&report[format!("min_{unit}")]) - lo).abs() < 1e-12,
            "{axis}"
        );
    }
    let polishing: f64 = blocks
        .iter()
        .filter(|b| b["kind"] == "dwell" || b["kind"] == "move")
        .map(|b| number(&b["duration_s"]))
        .sum();
    let planned: f64 = request["dwell"]["dwell_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(number)
        .sum();
    assert!((polishing - planned).abs() < 1e-9 * planned);
    assert!((number(&body["total_time_s"]) - planned).abs() < 1e-9 * planned);
}

/// A request whose `machine.<axis>.<limit>` is set to `value`, and the 422's violation there.
async fn violation(axis: &str, limit: &str, value: f64) -> Value {
    let mut request = fixture();
    request["machine"][axis][limit] = json!(value);
    let (status, body) = run(&request).await;
    assert_eq!(status, 422, "{body}");
    assert_eq!(body["type"], "urn:preston:problem:machine-limits", "{body}");
    let field = format!("machine.{axis}.{limit}");
    assert_eq!(body["field"], field.as_str(), "{body}");
    let found = body["violations"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["field"] == field.as_str())
        .unwrap_or_else(|| panic!("{field} not in {body}"))
        .clone();
    assert_eq!(found["limit_value"], json!(value));
    assert!(found["blocks"].as_u64().unwrap() >= 1);
    found
}

#[tokio::test]
async fn travel_beyond_a_stroke_end_is_refused() {
    // X reaches 57.33 mm on this convex sphere with a 60 mm pivot (the pad itself only 40).
    let v = violation("x", "max_mm", 50.0).await;
    assert!(number(&v["value"]) > 57.0);
    assert!(v["first_block"].as_u64().is_some());
}

#[tokio::test]
async fn a_velocity_beyond_the_limit_is_refused() {
    // The approach runs Z at 100 mm/min; the limit also lowers the default approach feed, so
    // the polishing moves (≈ 21 mm/min in X) are what break an X limit of 10.
    let v = violation("x", "max_velocity_mm_per_min", 10.0).await;
    assert!(number(&v["value"]) > 20.0, "{v}");
}

#[tokio::test]
async fn an_acceleration_beyond_the_limit_is_refused() {
    let v = violation("b", "max_acceleration_deg_per_s2", 1e-3).await;
    assert!(number(&v["value"]) > 1e-3);
}

#[tokio::test]
async fn a_spindle_speed_beyond_the_limit_is_refused() {
    let v = violation("tool_spindle", "max_rpm", 150.0).await;
    assert_eq!(v["value"], json!(200.0));
    assert_eq!(v["first_block"], Value::Null);
}

#[tokio::test]
async fn gcode_and_csv_answers() {
    let app = app();
    let gcode = post_json_accepting(&app, "/v1/program", FIXTURE, "text/x-gcode").await;
    assert_eq!(gcode.status, 200);
    let text = gcode.text();
    assert!(text.starts_with("(Preston machine program)\n"), "{text}");
    assert!(text.contains("eta = 0.05") && text.contains("(request sha256 "));
    assert!(text.contains("\nG93\nG4 P2.000000\n"), "{text}");
    assert!(text.trim_end().ends_with("M2"));
    let csv = post_json_accepting(&app, "/v1/program", FIXTURE, "text/csv").await;
    assert_eq!(csv.status, 200);
    let csv = csv.text();
    assert!(csv.starts_with("block,kind,position_mm,"));
    assert_eq!(csv.lines().count(), 1 + 45, "a header and 45 blocks");
}

#[tokio::test]
async fn bad_input_is_named() {
    let cases = [
        (
            json!({"dwell": {"positions_mm": [0, 1, 2], "dwell_s": [1, 0, 1]}}),
            "dwell.dwell_s[1]",
        ),
        (
            json!({"format": {"tool_spindle": {"cw": "M3 (x"}}}),
            "format.tool_spindle.cw",
        ),
        (json!({"format": {"decimals": 9}}), "format.decimals"),
        (
            json!({"machine": {"z": {"min_mm": 5, "max_mm": 5}}}),
            "machine.z.max_mm",
        ),
        (
            json!({"tool": {"pivot_length_mm": -1}}),
            "tool.pivot_length_mm",
        ),
        (
            // A part smaller than the workpiece, refused as every endpoint refuses it.
            json!({"surface": {"kind": "sphere", "radius_of_curvature_mm": 30}}),
            "process.workpiece_radius_mm",
        ),
    ];
    for (patch, field) in cases {
        let mut request = fixture();
        for (key, value) in patch.as_object().unwrap() {
            request[key] = value.clone();
        }
        let (status, body) = run(&request).await;
        assert_eq!(status, 422, "{field}: {body}");
        assert_eq!(body["field"], field, "{body}");
    }
}
