//! `POST /v1/optimize` through the router: defaults and echoes, every class of bad input,
//! conflicts as 422 `infeasible` naming the constraints, solver limits, CSV.

use crate::common;

use common::http::{app, app_with, post_json, post_with, Reply};
use preston::config::ServiceLimits;
use serde_json::{json, Value};

fn body() -> Value {
    json!({
        "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10, "tool_rpm": 200},
        "positions_mm": (0..=50).map(|i| i as f64).collect::<Vec<_>>(),
        "target": {"uniform_depth_nm": 100},
        "radial_grid": {"count": 101},
        "clear_aperture": {"outer_mm": 40}
    })
}

async fn optimize(body: Value) -> Reply {
    post_json(&app(), "/v1/optimize", body.to_string()).await
}

fn problem(reply: &Reply, status: u16, kind: &str, field: Option<&str>) -> Value {
    assert_eq!(reply.status.as_u16(), status, "{}", reply.text());
    assert_eq!(reply.content_type, "application/problem+json");
    let p = reply.json();
    assert_eq!(p["type"], format!("urn:preston:problem:{kind}"), "{p}");
    assert_eq!(p["field"].as_str(), field, "{p}");
    p
}

#[tokio::test]
async fn a_plan_echoes_what_it_used_and_agrees_with_predict() {
    let reply = optimize(body()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let r = reply.json();
    assert_eq!(r["eta"], 0.05);
    assert_eq!(r["solver"]["status"], "solved");
    assert_eq!(r["solver"]["reduced_accuracy"], false);
    assert_eq!(r["objective"]["smoothing"], 1e-6);
    assert_eq!(r["objective"]["time_weight"], 2e-6);
    assert_eq!(
        r["clear_aperture"],
        json!({"inner_mm": 0.0, "outer_mm": 40.0})
    );
    assert_eq!(r["piston_nm"], Value::Null);
    let dwell = r["dwell"]["dwell_s"].as_array().unwrap();
    assert_eq!(dwell.len(), 51);
    // The feed across each cell: 1 mm in its dwell, the two 0.5 mm end cells in half of theirs.
    let feed: Vec<f64> = serde_json::from_value(r["feed_mm_per_min"].clone()).unwrap();
    assert_eq!(feed.len(), 51);
    for (j, (f, t)) in feed.iter().zip(dwell).enumerate() {
        let want = 60.0 / t.as_f64().unwrap();
        assert!((f - want).abs() <= 1e-12 * want, "cell {j}: {f} vs {want}");
    }
    let total: f64 = dwell.iter().map(|v| v.as_f64().unwrap()).sum();
    assert!((r["total_time_s"].as_f64().unwrap() - total).abs() <= 1e-9 * total);
    // The target and residual are null outside the aperture (radius > 40 mm).
    assert_eq!(r["target_nm"][81], Value::Null);
    assert_eq!(r["target_nm"][80], 100.0);
    // Point dwells 1 mm apart leave a ripple of about ±1 nm between them at η = +0.05.
    assert!(r["metrics"]["nonuniformity"].as_f64().unwrap() < 0.05);

    // Predict on the returned plan gives the same removal and metrics.
    let predict = post_json(
        &app(),
        "/v1/predict",
        json!({
            "process": body()["process"], "dwell": r["dwell"],
            "radial_grid": {"count": 101}, "clear_aperture": {"outer_mm": 40}
        })
        .to_string(),
    )
    .await
    .json();
    assert_eq!(predict["removal_nm"], r["removal_nm"]);
    assert_eq!(predict["metrics"], r["metrics"]);
    // Residual figures follow from the residual array.
    let residual: Vec<f64> = r["residual_nm"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|v| v.as_f64())
        .collect();
    assert_eq!(residual.len(), 81);
    let rms = (residual.iter().map(|v| v * v).sum::<f64>() / 81.0).sqrt();
    assert!((r["residual"]["rms_nm"].as_f64().unwrap() - rms).abs() <= 1e-12 * rms.max(1e-300));
}

#[tokio::test]
async fn constraints_hold_and_the_motion_figures_respect_them() {
    let mut b = body();
    b["constraints"] = json!({"min_dwell_s": 20, "max_dwell_s": 400, "max_feed_mm_per_min": 2.0, "max_dwell_change_s": 30});
    let r = optimize(b).await;
    assert_eq!(r.status, 200, "{}", r.text());
    let r = r.json();
    let dwell: Vec<f64> = serde_json::from_value(r["dwell"]["dwell_s"].clone()).unwrap();
    assert!(dwell.iter().all(|&t| (20.0..=400.0).contains(&t)));
    assert!(dwell
        .windows(2)
        .all(|w| (w[1] - w[0]).abs() <= 30.0 * (1.0 + 1e-9)));
    let feed: Vec<f64> = serde_json::from_value(r["feed_mm_per_min"].clone()).unwrap();
    let peak = r["motion"]["peak_feed_mm_per_min"].as_f64().unwrap();
    assert_eq!(peak, feed.iter().copied().fold(0.0, f64::max));
    assert!(peak <= 2.0 * (1.0 + 1e-9), "{peak}");
    // On a plane with the default tool the feed is X's velocity, and nothing else moves.
    let axes = &r["motion"]["axes"];
    assert!((axes["x"]["peak_velocity_mm_per_min"].as_f64().unwrap() - peak).abs() <= 1e-12 * peak);
    assert_eq!(axes["z"]["peak_velocity_mm_per_min"], 0.0);
    assert_eq!(axes["b"]["peak_velocity_deg_per_min"], 0.0);
    assert!(r["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w["field"] == "constraints.max_feed_mm_per_min"));
}

#[tokio::test]
async fn conflicting_constraints_are_422_infeasible_listing_them() {
    let mut b = body();
    b["constraints"] = json!({"min_dwell_s": 10, "max_total_time_s": 500});
    let p = problem(
        &optimize(b).await,
        422,
        "infeasible",
        Some("constraints.min_dwell_s"),
    );
    assert_eq!(
        p["conflicts"],
        json!(["constraints.min_dwell_s", "constraints.max_total_time_s"])
    );
    assert!(p["detail"].as_str().unwrap().contains("510"), "{p}");

    let mut b = body();
    b["constraints"] = json!({"max_feed_mm_per_min": 60, "max_total_time_s": 45});
    // Each 1 mm cell takes 1 s at 60 mm/min (the 0.5 mm end cells 1 s of dwell too).
    let p = problem(
        &optimize(b).await,
        422,
        "infeasible",
        Some("constraints.max_feed_mm_per_min"),
    );
    assert_eq!(
        p["conflicts"],
        json!([
            "constraints.max_feed_mm_per_min",
            "constraints.max_total_time_s"
        ])
    );
    assert!(p["detail"].as_str().unwrap().contains("51.0000"), "{p}");
}

#[tokio::test]
async fn bad_targets_name_the_field() {
    let cases = [
        (json!({}), "target"),
        (
            json!({"uniform_depth_nm": 100, "profile": {"radius_mm": [0, 40], "depth_nm": [1, 2]}}),
            "target",
        ),
        (json!({"uniform_depth_nm": -1}), "target.uniform_depth_nm"),
        (
            json!({"uniform_depth_nm": 10, "free_piston": true}),
            "target.free_piston",
        ),
        (
            json!({"profile": {"radius_mm": [0, 30], "depth_nm": [1, 2]}}),
            "target.profile.radius_mm",
        ),
        (
            json!({"profile": {"radius_mm": [0, 40], "depth_nm": [1]}}),
            "target.profile.depth_nm",
        ),
        (
            json!({"profile": {"radius_mm": [0, 20, 20, 40], "depth_nm": [1, 2, 3, 4]}}),
            "target.profile.radius_mm[2]",
        ),
    ];
    for (target, field) in cases {
        let mut b = body();
        b["target"] = target;
        problem(&optimize(b).await, 422, "invalid-input", Some(field));
    }
    let mut b = body();
    b["target"] = json!({"uniform_depth_nm": 100, "depth": 3});
    problem(
        &optimize(b).await,
        422,
        "schema-mismatch",
        Some("target.depth"),
    );
}

#[tokio::test]
async fn bad_constraints_objective_and_positions_name_the_field() {
    let cases = [
        (
            "constraints",
            json!({"max_dwell_s": 0}),
            "constraints.max_dwell_s",
        ),
        (
            "constraints",
            json!({"min_dwell_s": -1}),
            "constraints.min_dwell_s",
        ),
        (
            "constraints",
            json!({"max_feed_mm_per_min": -3}),
            "constraints.max_feed_mm_per_min",
        ),
        (
            "constraints",
            json!({"max_dwell_change_s": -3}),
            "constraints.max_dwell_change_s",
        ),
        (
            "constraints",
            json!({"max_total_time_s": 0}),
            "constraints.max_total_time_s",
        ),
        ("objective", json!({"smoothing": -1}), "objective.smoothing"),
        (
            "objective",
            json!({"time_weight": -1}),
            "objective.time_weight",
        ),
        ("solver", json!({"time_limit_s": 0}), "solver.time_limit_s"),
        (
            "solver",
            json!({"time_limit_s": 1e6}),
            "solver.time_limit_s",
        ),
        ("positions_mm", json!([0, 2, 1]), "positions_mm[2]"),
        ("positions_mm", json!([0, 61]), "positions_mm[1]"),
        ("positions_mm", json!([]), "positions_mm"),
    ];
    for (key, value, field) in cases {
        let mut b = body();
        b[key] = value;
        problem(&optimize(b).await, 422, "invalid-input", Some(field));
    }
    // Positions that never reach the aperture.
    let mut b = body();
    b["positions_mm"] = json!([55, 58]);
    problem(
        &optimize(b).await,
        422,
        "invalid-input",
        Some("positions_mm"),
    );
}

#[tokio::test]
async fn limits_are_enforced() {
    let app = app_with(ServiceLimits {
        max_optimize_positions: 20,
        ..ServiceLimits::default()
    });
    let reply = post_json(&app, "/v1/optimize", body().to_string()).await;
    problem(&reply, 422, "limit-exceeded", Some("positions_mm"));

    // A solver budget too short to converge is a 422 naming the time limit, not a plan.
    let mut b = body();
    b["solver"] = json!({"time_limit_s": 1e-9});
    problem(
        &optimize(b).await,
        422,
        "solver-time-limit",
        Some("solver.time_limit_s"),
    );
}

#[tokio::test]
async fn the_plan_is_offered_as_csv() {
    let reply = post_with(
        &app(),
        "/v1/optimize",
        body().to_string(),
        &[("accept", "text/csv")],
    )
    .await;
    assert_eq!(reply.status, 200);
    let text = reply.text();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("position_mm,dwell_s"));
    assert_eq!(lines.count(), 51);
}

fn paper_body() -> Value {
    serde_json::from_slice(
        &std::fs::read(common::fixture_path("optimize_paper_exp1.json")).unwrap(),
    )
    .unwrap()
}

/// A time budget too short for the target: the plan is `solved`, but the response says the
/// budget, not the target, decided it, and that the target was missed.
#[tokio::test]
async fn a_binding_time_budget_is_reported_as_a_warning() {
    // 10 s for a 17,528 s layer: on the default machine the acceleration limits bind at
    // every cell too; this is about the budget alone.
    let mut body = paper_body();
    body["machine"] = json!("unlimited");
    body["constraints"] = json!({"max_total_time_s": 10});
    let reply = post_json(&app(), "/v1/optimize", body.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let r = reply.json();
    assert_eq!(r["solver"]["status"], "solved");
    let total = r["total_time_s"].as_f64().unwrap();
    assert!((total - 10.0).abs() < 1e-6, "{total}");
    let warnings = r["warnings"].as_array().unwrap();
    let codes: Vec<(&str, &str)> = warnings
        .iter()
        .map(|w| (w["code"].as_str().unwrap(), w["field"].as_str().unwrap()))
        .collect();
    assert!(
        codes.contains(&("constraint_active", "constraints.max_total_time_s")),
        "{codes:?}"
    );
    assert!(codes.contains(&("target_not_met", "target")), "{codes:?}");
    assert!(
        codes.contains(&("machine_unlimited", "machine")),
        "{codes:?}"
    );
    // The same plan without the budget: nothing to warn about but the machine.
    body.as_object_mut().unwrap().remove("constraints");
    let reply = post_json(&app(), "/v1/optimize", body.to_string()).await;
    assert_eq!(reply.json()["warnings"].as_array().unwrap().len(), 1);
}

/// Positions given in metres (0–0.05 on a 50 mm workpiece): whatever the solver makes of
/// them, the answer points at positions_mm and says why.
#[tokio::test]
async fn positions_in_metres_get_a_hint() {
    let mut body = paper_body();
    let metres: Vec<f64> = body["positions_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_f64().unwrap() / 1000.0)
        .collect();
    body["positions_mm"] = json!(metres);
    let reply = post_json(&app(), "/v1/optimize", body.to_string()).await;
    let r = reply.json();
    if reply.status == 200 {
        let w = &r["warnings"][0];
        assert_eq!(w["code"], "positions_look_like_metres", "{r}");
        assert_eq!(w["field"], "positions_mm");
    } else {
        assert_eq!(reply.status, 422, "{r}");
        assert_eq!(r["field"], "positions_mm", "{r}");
        assert!(r["detail"].as_str().unwrap().contains("metres"), "{r}");
    }
    let predict = json!({"process": body["process"], "dwell": {"positions_mm": [0.0, 0.01, 0.02], "dwell_s": [1, 1, 1]}});
    let r = post_json(&app(), "/v1/predict", predict.to_string())
        .await
        .json();
    assert_eq!(
        r["warnings"][0]["code"], "positions_look_like_metres",
        "{r}"
    );
    assert_eq!(r["warnings"][0]["field"], "dwell.positions_mm");
}

/// A process typed in metres (a 0.05 m part, a 0.01 m pad) is accepted — it is a valid, if
/// tiny, process — but every plan on it says what looks wrong, naming the workpiece radius.
#[tokio::test]
async fn a_process_in_metres_gets_a_hint() {
    let process = json!({"workpiece_radius_mm": 0.05, "tool_radius_mm": 0.01, "workpiece_rpm": -10, "tool_rpm": 200});
    let predict = json!({"process": process, "dwell": {"positions_mm": [0.0, 0.02, 0.04], "dwell_s": [1, 1, 1]}});
    let optimize = json!({"process": process, "positions_mm": [0.0, 0.01, 0.02, 0.03, 0.04, 0.05], "target": {"uniform_depth_nm": 100}});
    for (path, body) in [("/v1/predict", predict), ("/v1/optimize", optimize)] {
        let reply = post_json(&app(), path, body.to_string()).await;
        assert_eq!(reply.status, 200, "{}", reply.text());
        let w = &reply.json()["warnings"][0];
        assert_eq!(w["code"], "process_looks_like_metres", "{path}: {w}");
        assert_eq!(w["field"], "process.workpiece_radius_mm");
        assert!(w["message"].as_str().unwrap().contains("0.05 mm"), "{w}");
    }
    // A small but plausible part (a 2 mm lens) is not questioned.
    let small = json!({"process": {"workpiece_radius_mm": 1.0, "tool_radius_mm": 0.3, "workpiece_rpm": -10, "tool_rpm": 200},
                       "dwell": {"positions_mm": [0.0, 0.5, 1.0], "dwell_s": [1, 1, 1]}});
    let reply = post_json(&app(), "/v1/predict", small.to_string()).await;
    assert_eq!(reply.json()["warnings"], json!([]), "{}", reply.text());
}

/// A uniform depth so small (a denormal number of nm) that equal dwell's feed overflows: the
/// plan stands, with no η = −1 recommendation rather than one whose feeds are not numbers (a
/// case the contract fuzzer found).
#[tokio::test]
async fn a_denormal_depth_plans_without_a_recommendation() {
    let reply = optimize(json!({
        "positions_mm": [0.3466388844911519],
        "target": {"uniform_depth_nm": 5e-324},
        "process": {"workpiece_rpm": -1.6201956367709252e-180, "tool_radius_mm": 0.8000933031658438,
                    "workpiece_radius_mm": 0.9219909695617657, "tool_rpm": 0.7215713813017821}
    }))
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    assert!(reply.json()["recommendation"].is_null(), "{}", reply.text());
    // A depth of a nanometre on the same set-up keeps its recommendation, feeds finite.
    let reply = optimize(json!({
        "positions_mm": [0.3466388844911519],
        "target": {"uniform_depth_nm": 1.0},
        "process": {"workpiece_rpm": -1.6201956367709252e-180, "tool_radius_mm": 0.8000933031658438,
                    "workpiece_radius_mm": 0.9219909695617657, "tool_rpm": 0.7215713813017821}
    }))
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let recommendation = &reply.json()["recommendation"];
    assert!(
        recommendation["current_feed_mm_per_min"].is_f64(),
        "{recommendation}"
    );
}
