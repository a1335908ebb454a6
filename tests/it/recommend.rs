//! The η = −1 recommendation and the η sweep through the API, checked against independent
//! predictions of the same plans (`/v1/predict`).

use crate::common;

use common::http::{app, post_json, Reply};
use common::read_fixture;
use serde_json::{json, Value};

fn exp1() -> Value {
    json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10, "tool_rpm": 200})
}

async fn post(path: &str, body: Value) -> Reply {
    let reply = post_json(&app(), path, body.to_string()).await;
    assert_eq!(reply.status, 200, "{path}: {}", reply.text());
    reply
}

/// Equal-dwell nonuniformity at η with the tool at `tool_rpm`, by predicting the
/// recommendation's constant feed (nonuniformity does not depend on the feed's size).
async fn nonuniformity_at(eta: f64, tool_rpm: f64, feed: &Value) -> f64 {
    let body = json!({
        "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10,
                    "workpiece_rpm": -eta * tool_rpm, "tool_rpm": tool_rpm},
        "feed": feed,
        "clear_aperture": {"outer_mm": 40}
    });
    post("/v1/predict", body).await.json()["metrics"]["nonuniformity"]
        .as_f64()
        .unwrap()
}

#[tokio::test]
async fn experiment_1_is_told_to_turn_both_the_same_way_at_the_same_speed() {
    let r = post("/v1/recommend", read_fixture("recommend_paper_exp1.json"))
        .await
        .json();
    let rec = &r["recommendation"];
    let (w, t) = (
        rec["workpiece_rpm"].as_f64().unwrap(),
        rec["tool_rpm"].as_f64().unwrap(),
    );
    assert_eq!(w, t);
    assert!(t > 0.0, "keeps the tool's direction");
    assert_eq!(rec["eta"], -1.0);
    assert_eq!(rec["rule"], "match_removal_rate");
    let ours = rec["metrics"]["nonuniformity"].as_f64().unwrap();
    let theirs = rec["current_metrics"]["nonuniformity"].as_f64().unwrap();
    println!("exp 1: recommended {t:.2} r/min, nonuniformity {ours:.2e} vs current {theirs:.3}");
    // Equal dwell at η = −1 is exactly uniform on a plane: to rounding, so no finite factor.
    assert!(ours <= 1e-12 && theirs >= 1.5);
    assert_eq!(rec["improvement_factor"], Value::Null);

    // The speed keeps the mean removal rate to its resolution: set to 0.1 r/min, it is within
    // 0.05 r/min of the matching speed, and at η = −1 the rate is proportional to the speed.
    // So the same plan (same feed, same time) removes the same mean depth at the current and
    // the recommended speeds, predicted independently, to 0.05/t relative.
    assert!(
        ((t * 10.0).round() - t * 10.0).abs() < 1e-9,
        "{t} is set to 0.1 r/min"
    );
    let resolution = 0.05 / t;
    let plan = &rec["equal_dwell"];
    let depth_at = |process: Value| json!({"process": process, "feed": plan["feed"], "clear_aperture": {"outer_mm": 40}});
    let now = post("/v1/predict", depth_at(exp1())).await.json();
    let then = post("/v1/predict", depth_at(json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": w, "tool_rpm": t}))).await.json();
    let (a, b) = (
        now["metrics"]["mean_nm"].as_f64().unwrap(),
        then["metrics"]["mean_nm"].as_f64().unwrap(),
    );
    assert!((a - b).abs() <= resolution * a, "{a} vs {b}");
    assert!(
        (b - 100.0).abs() <= 1e-9 * 100.0,
        "the plan removes the requested depth: {b}"
    );
    let (current, recommended) = (
        rec["current_feed_mm_per_min"].as_f64().unwrap(),
        plan["feed"]["feed_mm_per_min"].as_f64().unwrap(),
    );
    assert!(
        (current - recommended).abs() <= resolution * current,
        "{current} vs {recommended}"
    );
    assert_eq!(rec["nonuniformity_removed"], true);
}

#[tokio::test]
async fn a_workpiece_limit_below_the_tool_speed_caps_the_recommendation() {
    for (limits, cap) in [
        (json!({"max_workpiece_rpm": 60}), 60.0),
        (json!({"max_workpiece_rpm": 90, "max_tool_rpm": 80}), 80.0),
    ] {
        let body = json!({"process": exp1(), "limits": limits, "clear_aperture": {"outer_mm": 40}});
        let rec = post("/v1/recommend", body).await.json()["recommendation"].clone();
        assert_eq!(rec["rule"], "fastest_allowed", "{rec}");
        assert_eq!(rec["workpiece_rpm"], cap);
        assert_eq!(rec["tool_rpm"], cap);
    }
    // A generous limit leaves the rate-matching speed alone.
    let body = json!({"process": exp1(), "limits": {"max_workpiece_rpm": 1000}, "clear_aperture": {"outer_mm": 40}});
    assert_eq!(
        post("/v1/recommend", body).await.json()["recommendation"]["rule"],
        "match_removal_rate"
    );
}

#[tokio::test]
async fn the_eta_window_meets_its_threshold_at_both_ends_and_stays_below_inside() {
    for threshold in [0.005, 0.02, 0.1] {
        let body = json!({"process": exp1(), "clear_aperture": {"outer_mm": 40},
                          "nonuniformity_threshold": threshold});
        let rec = post("/v1/recommend", body).await.json()["recommendation"].clone();
        let tool = rec["tool_rpm"].as_f64().unwrap();
        let window = &rec["eta_window"];
        assert_eq!(window["nonuniformity_threshold"], threshold);
        let (low, high) = (
            window["low"].as_f64().unwrap(),
            window["high"].as_f64().unwrap(),
        );
        assert!(low < -1.0 && high > -1.0);
        let feed = &rec["equal_dwell"]["feed"];
        for bound in [low, high] {
            let n = nonuniformity_at(bound, tool, feed).await;
            assert!(
                (n - threshold).abs() <= 1e-3,
                "threshold {threshold}: N({bound}) = {n}"
            );
        }
        for k in 1..8 {
            let eta = low + (high - low) * k as f64 / 8.0;
            let n = nonuniformity_at(eta, tool, feed).await;
            assert!(
                n < threshold,
                "threshold {threshold}: N({eta}) = {n} inside [{low}, {high}]"
            );
        }
        println!("threshold {threshold}: η window [{low:.6}, {high:.6}]");
    }
}

#[tokio::test]
async fn predict_and_optimize_carry_the_recommendation_unless_eta_is_minus_one() {
    let exp1_body = read_fixture("predict_paper_exp1.json");
    let r = post("/v1/predict", exp1_body).await.json();
    assert_eq!(r["recommendation"]["eta"], -1.0);
    assert!(r["recommendation"]["eta_window"]["low"].is_number());
    let exp2 = post("/v1/predict", read_fixture("predict_paper_exp2.json"))
        .await
        .json();
    assert_eq!(exp2["recommendation"], Value::Null);
    let o = post("/v1/optimize", json!({"process": exp1(), "positions_mm": [0, 10, 20, 30, 40, 50],
                                         "target": {"uniform_depth_nm": 50}, "radial_grid": {"count": 51}})).await.json();
    assert_eq!(o["recommendation"]["equal_dwell"]["depth_nm"], 50.0);
}

#[tokio::test]
async fn the_figure_7_sweep_falls_to_minus_one_and_rises_beyond() {
    let r = post(
        "/v1/studies/eta-sweep",
        read_fixture("eta_sweep_figure7.json"),
    )
    .await
    .json();
    let points = r["points"].as_array().unwrap();
    let eta: Vec<f64> = points.iter().map(|p| p["eta"].as_f64().unwrap()).collect();
    let n: Vec<f64> = points
        .iter()
        .map(|p| p["metrics"]["nonuniformity"].as_f64().unwrap())
        .collect();
    let minus_one = eta.iter().position(|&e| e == -1.0).unwrap();
    println!(
        "figure 7 sweep: {:?}",
        eta.iter().zip(&n).collect::<Vec<_>>()
    );
    assert!(
        eta[..=minus_one].windows(2).all(|w| w[1] < w[0]),
        "η runs from −0.05 down to −1"
    );
    assert!(
        n[..=minus_one].windows(2).all(|w| w[1] < w[0]),
        "falls monotonically to η = −1"
    );
    assert!(
        n[minus_one..].windows(2).all(|w| w[1] > w[0]),
        "rises beyond −1"
    );
    assert!(n[0] > 1.5 && n[minus_one] < 1e-3);
    for p in points {
        let e = p["eta"].as_f64().unwrap();
        assert_eq!(p["workpiece_rpm"].as_f64().unwrap(), -e * 150.0);
    }
}

#[tokio::test]
async fn bad_study_inputs_name_the_field() {
    let cases = [
        (
            "/v1/recommend",
            json!({"process": exp1(), "limits": {"max_tool_rpm": 0}}),
            "limits.max_tool_rpm",
        ),
        (
            "/v1/recommend",
            json!({"process": exp1(), "depth_nm": -5}),
            "depth_nm",
        ),
        (
            "/v1/recommend",
            json!({"process": exp1(), "nonuniformity_threshold": 0}),
            "nonuniformity_threshold",
        ),
        (
            "/v1/studies/eta-sweep",
            json!({"process": exp1(), "etas": [-1, 0]}),
            "etas[1]",
        ),
        (
            "/v1/studies/eta-sweep",
            json!({"process": exp1(), "etas": []}),
            "etas",
        ),
        (
            "/v1/studies/eta-sweep",
            json!({"process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": 5, "tool_rpm": 0}, "etas": [-1]}),
            "process.tool_rpm",
        ),
        (
            "/v1/studies/eta-sweep",
            json!({"process": exp1(), "etas": vec![-1.0; 202]}),
            "etas",
        ),
    ];
    for (path, body, field) in cases {
        let reply = post_json(&app(), path, body.to_string()).await;
        assert_eq!(reply.status, 422, "{path} {field}: {}", reply.text());
        assert_eq!(reply.json()["field"], field);
    }
}

#[tokio::test]
async fn speeds_at_the_edge_of_the_domain_are_answered_not_crashed() {
    // Schemathesis found these: a workpiece near 100,000 r/min (the model's limit) may ask for
    // an η = −1 speed beyond it, and the η window would step the workpiece past it.
    for (w, t) in [(99999.0, 200.0), (99999.0, -99999.0)] {
        let process = json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": w, "tool_rpm": t});
        let body = json!({"process": process, "clear_aperture": {"outer_mm": 40}});
        let rec = post("/v1/recommend", body).await.json()["recommendation"].clone();
        let speed = rec["tool_rpm"].as_f64().unwrap().abs();
        assert!(speed <= 1e5, "{rec}");
        if rec["rule"] == "fastest_allowed" {
            assert_eq!(speed, 1e5);
        }
        let predict = json!({"process": process,
                             "dwell": {"positions_mm": [10, 20, 30], "dwell_s": [1, 1, 1]}});
        let reply = post_json(&app(), "/v1/predict", predict.to_string()).await;
        assert_eq!(reply.status, 200);
    }
}

/// The paper's set-up with every default (no aperture, grid or depth given): equal dwell at
/// η = −1 is uniform (the pass is an exact integral, not a sum over cells whose count could
/// decide it) and the η window exists; on a sphere (R = 200 mm, 60 mm part, 12 mm pad) the
/// window exists too, η = −1 there being uniform to the spin term a slope adds.
#[tokio::test]
async fn every_default_gives_uniform_eta_minus_one_and_a_window_on_planes_and_spheres() {
    let sphere = json!({"process": {"workpiece_radius_mm": 60, "tool_radius_mm": 12,
                                    "workpiece_rpm": -20, "tool_rpm": 180},
                        "surface": {"kind": "sphere", "radius_of_curvature_mm": 200}});
    for (body, bound) in [(json!({"process": exp1()}), 1e-4), (sphere, 1e-3)] {
        let rec = post("/v1/recommend", body.clone()).await.json()["recommendation"].clone();
        let nonuniformity = rec["metrics"]["nonuniformity"].as_f64().unwrap();
        let window = &rec["eta_window"];
        println!("{body}: η = −1 nonuniformity {nonuniformity:.2e}, window {window}");
        assert!(nonuniformity <= bound, "{rec}");
        let (low, high) = (window["low"].as_f64(), window["high"].as_f64());
        assert!(
            low.is_some_and(|l| l < -1.0) && high.is_some_and(|h| h > -1.0),
            "{rec}"
        );
    }
}
