//! `POST /v1/program` through the router (in-process, no socket): 2001 positions on a convex
//! asphere with the pad's axis along the normal, every axis limited, JSON and G-code. Covers
//! parsing and the request digest, poses, arc lengths, kinematics, the limit check, the G-code
//! and serialisation.

use axum::body::Body;
use axum::http::Request;
use http_body_util::BodyExt;
use preston::config::ServiceLimits;
use preston::http::{router, AppState};
use serde_json::json;
use tower::ServiceExt;

fn main() {
    divan::main();
}

fn request() -> Vec<u8> {
    let positions: Vec<f64> = (0..2001).map(|j| 0.02 * j as f64).collect();
    let dwell: Vec<f64> = positions.iter().map(|r| 0.1 + 0.001 * r).collect();
    let axis = json!({"min_mm": -500, "max_mm": 500, "max_velocity_mm_per_min": 5000,
                      "max_acceleration_mm_per_s2": 500});
    json!({
        "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10,
                    "workpiece_rpm": -10, "tool_rpm": 200},
        "surface": {"kind": "asphere", "radius_of_curvature_mm": -150, "conic_constant": -0.5,
                    "coefficients": [{"power": 4, "value": 1e-7}]},
        "dwell": {"positions_mm": positions, "dwell_s": dwell},
        "tool": {"pivot_length_mm": 60, "orientation": "normal"},
        "machine": {"x": axis, "z": axis,
                    "b": {"min_deg": -60, "max_deg": 60, "max_velocity_deg_per_min": 36000,
                          "max_acceleration_deg_per_s2": 3600}},
    })
    .to_string()
    .into_bytes()
}

#[divan::bench(args = ["application/json", "text/x-gcode"])]
fn program_2001_positions(bencher: divan::Bencher, accept: &str) {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let app = router(AppState::new(ServiceLimits::default()), None);
    let body = request();
    bencher.bench(|| {
        runtime.block_on(async {
            let request = Request::post("/v1/program")
                .header("content-type", "application/json")
                .header("accept", accept)
                .body(Body::from(body.clone()))
                .unwrap();
            let response = app.clone().oneshot(request).await.unwrap();
            assert_eq!(response.status(), 200);
            response.into_body().collect().await.unwrap().to_bytes()
        })
    });
}
