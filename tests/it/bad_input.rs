//! Bad input, endpoint by endpoint: each fixture spoiled in one place must be refused with the
//! status, problem type and field a caller would look for (at least three per endpoint).

use serde_json::{json, Value};

use crate::common;
use common::http::{app, post_json};

/// `fixture` with the member at `path` (dot-separated, `[i]` for array elements) set to
/// `value`, or removed when `value` is null.
fn spoiled(fixture: &str, path: &str, value: Value) -> Value {
    let text = std::fs::read_to_string(common::fixture_path(fixture)).unwrap();
    let mut body: Value = serde_json::from_str(&text).unwrap();
    let mut parts: Vec<&str> = path.split('.').collect();
    let last = parts.pop().unwrap();
    let mut at = &mut body;
    for part in parts {
        at = match part.split_once('[') {
            Some((name, index)) => {
                let index: usize = index.trim_end_matches(']').parse().unwrap();
                &mut at[name][index]
            }
            None => at
                .as_object_mut()
                .unwrap()
                .entry(part)
                .or_insert_with(|| json!({})),
        };
    }
    match last.split_once('[') {
        Some((name, index)) => {
            let index: usize = index.trim_end_matches(']').parse().unwrap();
            at[name][index] = value;
        }
        None if value.is_null() => {
            at.as_object_mut().unwrap().remove(last);
        }
        None => {
            at[last] = value;
        }
    }
    body
}

const INVALID: &str = "invalid-input";
const SCHEMA: &str = "schema-mismatch";

#[tokio::test]
async fn each_endpoint_names_the_field_of_bad_input() {
    let rf = "removal_function_paper_exp1.json";
    let pr = "predict_paper_exp2.json";
    let op = "optimize_paper_exp1.json";
    let re = "recommend_paper_exp1.json";
    let sw = "eta_sweep_figure7.json";
    let mf = "measurement_fit_asphere.json";
    let pg = "program_sphere.json";
    let ca = "calibration_rings.json";
    let cm = "calibration_polar_map.json";
    let ma = "maps_analysis.json";
    let md = "maps_difference.json";
    let mr = "maps_removal_function_paper_exp1.json";
    let mp = "maps_predict_sector_law.json";
    let mo = "maps_optimize_astigmatism.json";
    let mg = "maps_program_astigmatism.json";
    // (fixture, the member spoiled, its new value, the problem type, the field named); every
    // case is a 422.
    let cases: [(&str, &str, Value, &str, &str); 66] = [
        (
            mg,
            "approach",
            json!({"clearance_mm": 999, "feed_mm_per_min": 0.001}),
            "limit-exceeded",
            "approach.feed_mm_per_min",
        ),
        (
            mg,
            "c_law.speed_factors[3]",
            json!([1.0]),
            INVALID,
            "c_law.speed_factors[3]",
        ),
        (mg, "c_law.sectors", json!(0), INVALID, "c_law.sectors"),
        (
            mg,
            "surface",
            json!({"kind": "sphere", "radius_of_curvature_mm": 20}),
            INVALID,
            "process.workpiece_radius_mm",
        ),
        (
            mg,
            "format.c_words",
            json!("rolled"),
            SCHEMA,
            "format.c_words",
        ),
        (
            mg,
            "dwell.dwell_s[2]",
            json!(0),
            INVALID,
            "dwell.dwell_s[2]",
        ),
        (md, "after", Value::Null, INVALID, "after"),
        (
            md,
            "after_offset_px",
            json!({"x_px": 400.0, "y_px": 0.0}),
            INVALID,
            "after_offset_px",
        ),
        (
            md,
            "before.heights_nm",
            json!("rows"),
            SCHEMA,
            "before.heights_nm",
        ),
        (ma, "map", Value::Null, INVALID, "map"),
        (mo, "c_law.sectors", json!(4), INVALID, "c_law.sectors"),
        (
            mo,
            "c_law.max_harmonic",
            json!(18),
            INVALID,
            "c_law.max_harmonic",
        ),
        (
            mo,
            "machine.c.max_velocity_deg_per_min",
            json!(1000),
            INVALID,
            "machine.c.max_velocity_deg_per_min",
        ),
        (
            mo,
            "removal_pixel_mm",
            json!(0),
            INVALID,
            "removal_pixel_mm",
        ),
        // ~42,000 turns of C: even an 8 mm map's exact means cost too much.
        (
            mo,
            "process.pressure_kpa",
            json!(0.25),
            "limit-exceeded",
            "removal_model",
        ),
        (
            mo,
            "positions_mm[3]",
            json!(0.5),
            INVALID,
            "positions_mm[3]",
        ),
        (
            mr,
            "tool_position_mm",
            json!(-1.0),
            INVALID,
            "tool_position_mm",
        ),
        (mr, "pixel_mm", json!(-0.1), INVALID, "pixel_mm"),
        (
            mp,
            "dwell.dwell_s[2]",
            json!(-1.0),
            INVALID,
            "dwell.dwell_s[2]",
        ),
        (
            mp,
            "c_law.speed_factors[1]",
            json!([1.0, 1.3, 1.0, 0.0]),
            INVALID,
            "c_law.speed_factors[1][3]",
        ),
        (
            mp,
            "start_angle_deg",
            json!("north"),
            SCHEMA,
            "start_angle_deg",
        ),
        (
            mr,
            "process.tool_rpm",
            json!("fast"),
            SCHEMA,
            "process.tool_rpm",
        ),
        (
            mr,
            "surface",
            json!({"kind": "sphere", "radius_of_curvature_mm": 0.0}),
            INVALID,
            "surface.radius_of_curvature_mm",
        ),
        (ma, "map.heights_nm[1]", json!([1.0, 2.0]), INVALID, "map"),
        (ma, "pixel_mm", json!(-0.1), INVALID, "pixel_mm"),
        (
            ma,
            "clear_aperture",
            json!({"shape": "circle", "radius_mm": 40.0}),
            INVALID,
            "clear_aperture",
        ),
        (
            ma,
            "clear_aperture",
            json!({"shape": "annulus", "inner_radius_mm": 5.0, "outer_radius_mm": 4.0}),
            INVALID,
            "clear_aperture",
        ),
        (ma, "zernike.terms", json!(38), INVALID, "zernike.terms"),
        (
            ma,
            "psd.bands",
            json!([{"name": "x", "low_per_mm": 2.0, "high_per_mm": 1.0}]),
            INVALID,
            "psd.bands",
        ),
        // No probe reports a kilometre; the squares of such coordinates overflow the fit
        // (schemathesis found a 200 with a null RMS).
        (
            mf,
            "profile.x_mm[2]",
            json!(7e48),
            INVALID,
            "profile.x_mm[2]",
        ),
        // κ can be fitted only under the linear model (the fixture's is uniform).
        (
            ca,
            "fit.pad_moment_share",
            json!(true),
            INVALID,
            "fit.pad_moment_share",
        ),
        (
            ca,
            "expected_noise_nm",
            json!(-1),
            INVALID,
            "expected_noise_nm",
        ),
        (ca, "runs", json!([]), INVALID, "runs"),
        // Only K is fitted from a map (its pixels' depth jumps at the pad's rim).
        (cm, "fit.tool_radius", json!(true), INVALID, "runs[0].map"),
        // A law makes the removal vary with the angle: one profile cannot measure it.
        (cm, "runs[0].map", json!(null), INVALID, "runs[0].removal"),
        (
            cm,
            "runs[0].polar.c_law.speed_factors[1]",
            json!([1.0, 1.0]),
            INVALID,
            "runs[0].polar.c_law.speed_factors[1]",
        ),
        (
            cm,
            "runs[0].map.alignment.centre_x_px",
            json!(-40),
            INVALID,
            "runs[0].map.alignment.centre_x_px",
        ),
        (
            cm,
            "runs[0].map.removal",
            json!({"heights_nm": [[1.0]]}),
            INVALID,
            "runs[0].map.removal",
        ),
        (
            ca,
            "fit.tool_radius",
            json!("yes"),
            SCHEMA,
            "fit.tool_radius",
        ),
        (
            rf,
            "tool_positions_mm",
            json!([-1]),
            INVALID,
            "tool_positions_mm[0]",
        ),
        (
            rf,
            "process.tool_radius_mm",
            json!(0),
            INVALID,
            "process.tool_radius_mm",
        ),
        // κ is the linear model's, but out of [0, 1] it is refused whatever the model.
        (
            rf,
            "process.pad_moment_share",
            json!(1.5),
            INVALID,
            "process.pad_moment_share",
        ),
        (
            pg,
            "process.pressure_model",
            json!("parabolic"),
            SCHEMA,
            "process.pressure_model",
        ),
        (
            rf,
            "radial_grid.count",
            json!("201"),
            SCHEMA,
            "radial_grid.count",
        ),
        (
            pr,
            "dwell.dwell_s[0]",
            json!(-1),
            INVALID,
            "dwell.dwell_s[0]",
        ),
        (
            pr,
            "process.workpiece_rpm",
            json!(0),
            INVALID,
            "process.workpiece_rpm",
        ),
        (
            pr,
            "feed",
            json!({"start_mm": 0, "stop_mm": 50, "feed_mm_per_min": 10}),
            INVALID,
            "dwell",
        ),
        (
            pr,
            "clear_aperture.outer_mm",
            json!(60),
            INVALID,
            "clear_aperture.outer_mm",
        ),
        (op, "target", json!({}), INVALID, "target"),
        (
            op,
            "constraints.max_dwell_s",
            json!(-1),
            INVALID,
            "constraints.max_dwell_s",
        ),
        (
            op,
            "positions_mm",
            json!([1, 0]),
            INVALID,
            "positions_mm[1]",
        ),
        (
            op,
            "machine.x.max_velocity_mm_per_min",
            json!(0),
            INVALID,
            "machine.x.max_velocity_mm_per_min",
        ),
        (
            re,
            "process.tool_radius_mm",
            json!(-1),
            INVALID,
            "process.tool_radius_mm",
        ),
        (
            re,
            "limits.max_workpiece_rpm",
            json!(-5),
            INVALID,
            "limits.max_workpiece_rpm",
        ),
        (re, "depth_nm", json!(0), INVALID, "depth_nm"),
        (re, "speed", json!(1), SCHEMA, "speed"),
        (sw, "etas", json!([]), INVALID, "etas"),
        (sw, "etas[1]", json!("x"), SCHEMA, "etas[1]"),
        (
            sw,
            "clear_aperture.inner_mm",
            json!(45),
            INVALID,
            "clear_aperture.outer_mm",
        ),
        (
            mf,
            "probe_tip_radius_mm",
            json!(-1),
            INVALID,
            "probe_tip_radius_mm",
        ),
        (mf, "profile.z_mm", json!([0.0]), INVALID, "profile.z_mm"),
        (
            mf,
            "surface.radius_of_curvature_mm",
            json!(0),
            INVALID,
            "surface.radius_of_curvature_mm",
        ),
        (pg, "format.decimals", json!(9), INVALID, "format.decimals"),
        (
            pg,
            "approach.clearance_mm",
            json!(-1),
            INVALID,
            "approach.clearance_mm",
        ),
        (
            pg,
            "dwell.positions_mm[1]",
            json!(0.0),
            INVALID,
            "dwell.positions_mm[1]",
        ),
        (
            pg,
            "tool.pivot_length_mm",
            json!(-1),
            INVALID,
            "tool.pivot_length_mm",
        ),
    ];
    let app = app();
    let mut per_endpoint = std::collections::BTreeMap::new();
    for (fixture, path, value, kind, field) in cases {
        let endpoint = common::endpoint_of(fixture);
        let body = spoiled(fixture, path, value);
        let reply = post_json(&app, endpoint, body.to_string()).await;
        let problem = reply.json();
        let case = format!("{endpoint} expecting {field}: {problem}");
        assert_eq!(reply.status.as_u16(), 422, "{case}");
        assert_eq!(reply.content_type, "application/problem+json", "{case}");
        assert_eq!(
            problem["type"],
            format!("urn:preston:problem:{kind}"),
            "{case}"
        );
        assert_eq!(problem["field"], field, "{case}");
        assert!(!problem["detail"].as_str().unwrap().is_empty(), "{case}");
        *per_endpoint.entry(endpoint).or_insert(0) += 1;
    }
    for e in &preston::http::ENDPOINTS {
        let count = per_endpoint.get(e.path().as_str()).copied().unwrap_or(0);
        assert!(count >= 3, "{} has {count} bad-input cases", e.path());
    }
}

/// A body that is not JSON, on every endpoint: 400 malformed-json.
#[tokio::test]
async fn a_body_that_is_not_json_is_malformed_everywhere() {
    let app = app();
    for e in &preston::http::ENDPOINTS {
        let reply = post_json(&app, &e.path(), "{]").await;
        assert_eq!(reply.status.as_u16(), 400, "{}", e.path());
        assert_eq!(reply.json()["type"], "urn:preston:problem:malformed-json");
    }
}
