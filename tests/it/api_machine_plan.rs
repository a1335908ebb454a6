//! From a plan to a program on one machine: `/v1/optimize` with `machine` limits returns a plan
//! that `/v1/program` with the same surface, tool and machine accepts, on a flat and on a
//! sphere, with limits tight enough that the plan optimized without them is refused.

use serde_json::{json, Value};

use crate::common::http::{app, post_json};

async fn post(path: &str, request: &Value) -> (u16, Value) {
    let reply = post_json(&app(), path, request.to_string()).await;
    (reply.status.as_u16(), reply.json())
}

fn process() -> Value {
    json!({
        "workpiece_radius_mm": 50.0,
        "tool_radius_mm": 10.0,
        "workpiece_rpm": -10.0,
        "tool_rpm": 200.0,
        "preston_coefficient_m2_per_n": 1e-13,
        "pressure_kpa": 10.0
    })
}

fn positions() -> Vec<f64> {
    (0..=100).map(|i| 0.5 * i as f64).collect()
}

/// The optimize request, and the program request for its plan with the same machine.
fn requests(setup: &Value) -> (Value, impl Fn(&Value) -> Value + '_) {
    let mut optimize = json!({
        "process": process(),
        "positions_mm": positions(),
        "target": {"uniform_depth_nm": 100.0},
    });
    for key in ["surface", "tool", "machine"] {
        if let Some(v) = setup.get(key) {
            optimize[key] = v.clone();
        }
    }
    let program = move |dwell: &Value| {
        let mut p = json!({"process": process(), "dwell": dwell});
        for key in ["surface", "tool", "machine"] {
            if let Some(v) = setup.get(key) {
                p[key] = v.clone();
            }
        }
        p
    };
    (optimize, program)
}

fn setup_limit(request: &Value, axis: &str, limit: &str) -> f64 {
    request["machine"][axis][limit].as_f64().unwrap()
}

fn fields(problem: &Value) -> Vec<String> {
    problem["violations"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["field"].as_str().unwrap().to_string())
        .collect()
}

/// The pipeline on one setup: without the limits the plan's program breaks `broken`; with
/// them, the program is accepted, uses at most each limit, sits on `active`, and the plan
/// still removes the layer (nonuniformity below `nonuniformity`).
async fn pipeline(setup: Value, broken: &[&str], active: &str, nonuniformity: f64) {
    let (with_machine, program_for) = requests(&setup);
    let mut without = with_machine.clone();
    without.as_object_mut().unwrap().remove("machine");
    let (status, plain) = post("/v1/optimize", &without).await;
    assert_eq!(status, 200, "{plain}");
    let (status, refused) = post("/v1/program", &program_for(&plain["dwell"])).await;
    assert_eq!(
        status, 422,
        "the plain plan should break the limits: {refused}"
    );
    let mut found = fields(&refused);
    found.sort();
    let mut expected: Vec<String> = broken.iter().map(|s| s.to_string()).collect();
    expected.sort();
    assert_eq!(found, expected, "{refused}");

    let (status, plan) = post("/v1/optimize", &with_machine).await;
    assert_eq!(status, 200, "{plan}");
    let warned: Vec<&str> = plan["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w["field"].as_str())
        .collect();
    assert!(warned.contains(&active), "{warned:?}");
    let got = plan["metrics"]["nonuniformity"].as_f64().unwrap();
    assert!(got < nonuniformity, "nonuniformity {got}");

    let (status, program) = post("/v1/program", &program_for(&plan["dwell"])).await;
    assert_eq!(status, 200, "{program}");
    // Every stated limit used at most once over; the active one to within the optimizer's
    // margin (1e-6) and the test's 1e-5.
    let (axis, limit) = active
        .strip_prefix("machine.")
        .unwrap()
        .split_once('.')
        .unwrap();
    let kind = if limit.starts_with("max_velocity") {
        "velocity"
    } else {
        "acceleration"
    };
    for a in ["x", "z", "b"] {
        for k in ["travel", "velocity", "acceleration"] {
            if let Some(u) = program["axes"][a]["utilisation"][k].as_f64() {
                assert!(u <= 1.0, "{a} {k} {u}");
                if a == axis && k == kind {
                    assert!(u > 1.0 - 1e-5, "{a} {k} not active: {u}");
                }
            }
        }
    }
    if kind == "acceleration" {
        // The limit binds between two moves (the rows the optimizer makes convex), not only
        // from or to rest at the ends: recomputed from the blocks.
        let key = if axis == "b" { "b_deg" } else { "x_mm" };
        let limit_value = setup_limit(&with_machine, axis, limit);
        let blocks = program["blocks"].as_array().unwrap();
        let mut before = program["start"][key].as_f64().unwrap();
        let mut moves: Vec<(f64, f64)> = Vec::new(); // consecutive moves: (velocity, duration)
        let mut peak_between = 0.0_f64;
        for b in blocks {
            let (end, d) = (b[key].as_f64().unwrap(), b["duration_s"].as_f64().unwrap());
            if b["kind"] == "move" {
                let v = (end - before) / d;
                if let Some(&(v0, d0)) = moves.last() {
                    peak_between = peak_between.max(((v - v0) / (0.5 * (d0 + d))).abs());
                }
                moves.push((v, d));
            } else {
                moves.clear();
            }
            before = end;
        }
        let ratio = peak_between / limit_value;
        assert!(ratio > 1.0 - 1e-5 && ratio <= 1.0, "between moves: {ratio}");
    }
    // The program polishes for the plan's time.
    let total = plan["total_time_s"].as_f64().unwrap();
    let polishing = program["total_time_s"].as_f64().unwrap();
    assert!(
        (polishing - total).abs() <= 1e-9 * total,
        "{polishing} vs {total}"
    );
}

/// Flat part, vertical tool: X's velocity and acceleration limits. The plain plan reaches about
/// 34 mm/min and 1.3 mm/s² (between cells near the axis, where dwell changes fastest).
#[tokio::test]
async fn flat_plan_within_x_limits_is_programmable() {
    let setup = json!({
        "tool": {"orientation": "vertical"},
        "machine": {"x": {"max_velocity_mm_per_min": 25.0, "max_acceleration_mm_per_s2": 2e-4}}
    });
    pipeline(
        setup,
        &[
            "machine.x.max_velocity_mm_per_min",
            "machine.x.max_acceleration_mm_per_s2",
        ],
        "machine.x.max_acceleration_mm_per_s2",
        0.5,
    )
    .await;
}

/// A convex sphere, the tool on the normal with a 40 mm pivot: B tilts 39° over the part and
/// its limits bind (limits on X and Z hold too); removal is still the flat model's (and the
/// plan says so).
#[tokio::test]
async fn sphere_plan_within_b_and_z_limits_is_programmable() {
    let setup = json!({
        "surface": {"kind": "sphere", "radius_of_curvature_mm": -80.0},
        "tool": {"pivot_length_mm": 40.0, "orientation": "normal"},
        "machine": {
            "x": {"max_velocity_mm_per_min": 600.0, "max_acceleration_mm_per_s2": 10.0},
            "z": {"max_velocity_mm_per_min": 2.0},
            "b": {"max_velocity_deg_per_min": 5.0, "max_acceleration_deg_per_s2": 1e-4}
        }
    });
    pipeline(
        setup,
        // The plain plan (curved removal) leaves near-empty cells the axes would cross in a
        // blink: it breaks every velocity limit and two acceleration limits.
        &[
            "machine.b.max_velocity_deg_per_min",
            "machine.b.max_acceleration_deg_per_s2",
            "machine.x.max_velocity_mm_per_min",
            "machine.x.max_acceleration_mm_per_s2",
            "machine.z.max_velocity_mm_per_min",
        ],
        "machine.b.max_acceleration_deg_per_s2",
        0.5,
    )
    .await;
}

/// Travel does not depend on the dwell: positions that leave an axis's stroke are refused by
/// `/v1/optimize` itself, with every violation listed.
#[tokio::test]
async fn positions_beyond_an_axis_stroke_are_refused_up_front() {
    let (mut request, _) = requests(&json!({}));
    request["machine"] =
        json!({"x": {"min_mm": 0.0, "max_mm": 40.0}, "tool_spindle": {"max_rpm": 100.0}});
    let (status, problem) = post("/v1/optimize", &request).await;
    assert_eq!(status, 422, "{problem}");
    assert_eq!(problem["type"], "urn:preston:problem:machine-limits");
    assert_eq!(
        fields(&problem),
        ["machine.x.max_mm", "machine.tool_spindle.max_rpm"]
    );
    assert_eq!(problem["violations"][0]["value"], 50.0);
}

/// A machine limit that needs more dwell than max_dwell_s allows is a named conflict.
#[tokio::test]
async fn machine_limits_in_conflict_with_constraints_are_named() {
    let (mut request, _) = requests(&json!({}));
    request["machine"] = json!({"x": {"max_velocity_mm_per_min": 1.0}});
    request["constraints"] = json!({"max_dwell_s": 10.0});
    let (status, problem) = post("/v1/optimize", &request).await;
    assert_eq!(status, 422, "{problem}");
    assert_eq!(problem["type"], "urn:preston:problem:infeasible");
    // 0.5 mm at 1 mm/min takes 30 s, more than 10.
    assert_eq!(
        problem["conflicts"],
        json!([
            "machine.x.max_velocity_mm_per_min",
            "constraints.max_dwell_s"
        ])
    );
    request["machine"] = json!({"x": {"max_acceleration_mm_per_s2": 1e-9}});
    let (status, problem) = post("/v1/optimize", &request).await;
    assert_eq!(status, 422, "{problem}");
    assert_eq!(
        problem["conflicts"][0],
        "machine.x.max_acceleration_mm_per_s2"
    );
}

/// A surface or tool given without a machine is still checked, and a curved surface shapes
/// the removal (the response carries arc lengths).
#[tokio::test]
async fn surface_and_tool_alone_are_checked() {
    let (mut request, _) = requests(&json!({}));
    request["tool"] = json!({"pivot_length_mm": -1.0});
    let (status, problem) = post("/v1/optimize", &request).await;
    assert_eq!(status, 422, "{problem}");
    assert_eq!(problem["field"], "tool.pivot_length_mm");

    request["tool"] = json!({"pivot_length_mm": 10.0});
    request["surface"] = json!({"kind": "sphere", "radius_of_curvature_mm": 30.0});
    let (status, problem) = post("/v1/optimize", &request).await;
    assert_eq!(status, 422, "{problem}");
    // The sphere of radius 30 mm ends at r = 30; the workpiece edge is at 50.
    assert_eq!(problem["field"], "process.workpiece_radius_mm");

    request["surface"] = json!({"kind": "sphere", "radius_of_curvature_mm": 300.0});
    let (status, plan) = post("/v1/optimize", &request).await;
    assert_eq!(status, 200, "{plan}");
    // s(r) = 300·asin(r/300): 50 mm of radius is 50.23 mm of arc.
    let arcs = plan["arc_length_mm"].as_array().unwrap();
    let last = arcs.last().unwrap().as_f64().unwrap();
    assert!(
        (last - 300.0 * (50.0f64 / 300.0).asin()).abs() < 1e-9,
        "{last}"
    );
    assert_eq!(
        plan["position_arc_length_mm"].as_array().unwrap().len(),
        plan["dwell"]["positions_mm"].as_array().unwrap().len()
    );
}
