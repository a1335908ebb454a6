//! Operations: metrics after traffic, request ids, load shedding and timeouts (through the
//! router), and graceful shutdown of the real binary on SIGTERM.

use crate::common;

use std::time::{Duration, Instant};

use common::http::{app, app_with, get, post_json, post_with};
use common::service::Service;
use common::socket;
use preston::config::ServiceLimits;
use serde_json::json;

/// The value of a Prometheus sample line `name{labels} value` whose name and labels contain
/// all of `parts`.
fn sample(text: &str, parts: &[&str]) -> Option<f64> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .find(|l| parts.iter().all(|p| l.contains(p)))
        .and_then(|l| l.rsplit(' ').next())
        .and_then(|v| v.parse().ok())
}

#[tokio::test]
async fn metrics_count_requests_and_time_them_and_the_solver() {
    let app = app();
    let body = std::fs::read(common::fixture_path("predict_paper_exp2.json")).unwrap();
    for _ in 0..3 {
        assert_eq!(
            post_json(&app, "/v1/predict", body.clone()).await.status,
            200
        );
    }
    assert_eq!(post_json(&app, "/v1/predict", "{").await.status, 400);
    let optimize = json!({"process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10, "tool_rpm": 200},
                          "positions_mm": [0, 10, 20, 30, 40], "target": {"uniform_depth_nm": 10}, "radial_grid": {"count": 51}});
    assert_eq!(
        post_json(&app, "/v1/optimize", optimize.to_string())
            .await
            .status,
        200
    );
    assert_eq!(get(&app, "/no/such/thing").await.status, 404);

    let reply = get(&app, "/metrics").await;
    assert_eq!(reply.status, 200);
    assert!(reply.content_type.starts_with("text/plain; version=0.0.4"));
    let text = reply.text();
    // Counters are process-wide (other tests in this binary add to them): at least ours.
    let ok = sample(
        &text,
        &[
            "preston_http_requests_total{",
            "route=\"/v1/predict\"",
            "status=\"200\"",
        ],
    )
    .unwrap();
    assert!(ok >= 3.0, "{ok}");
    assert!(
        sample(
            &text,
            &[
                "preston_http_requests_total{",
                "route=\"/v1/predict\"",
                "status=\"400\""
            ]
        )
        .unwrap()
            >= 1.0
    );
    assert!(
        sample(
            &text,
            &[
                "preston_http_requests_total{",
                "route=\"unmatched\"",
                "status=\"404\""
            ]
        )
        .unwrap()
            >= 1.0
    );
    let count = sample(
        &text,
        &["preston_http_request_duration_seconds_count{route=\"/v1/predict\"}"],
    )
    .unwrap();
    assert!(count >= 4.0);
    assert!(
        sample(
            &text,
            &["preston_http_request_duration_seconds_bucket{route=\"/v1/predict\",le=\"+Inf\"}"]
        )
        .unwrap()
            >= 4.0
    );
    assert!(sample(&text, &["preston_solver_status_total{status=\"solved\"}"]).unwrap() >= 1.0);
    assert!(sample(&text, &["preston_solver_duration_seconds_count"]).unwrap() >= 1.0);
    assert!(sample(&text, &["preston_computations_in_flight"]).is_some());
}

#[tokio::test]
async fn request_ids_are_generated_or_propagated_and_land_in_problems() {
    let app = app();
    let reply = post_with(&app, "/v1/predict", "{", &[("x-request-id", "shop-42")]).await;
    assert_eq!(reply.status, 400);
    assert_eq!(reply.headers["x-request-id"], "shop-42");
    assert_eq!(reply.json()["request_id"], "shop-42");

    let reply = post_json(&app, "/v1/predict", "{").await;
    let generated = reply.headers["x-request-id"].to_str().unwrap().to_string();
    assert_eq!(generated.len(), 36, "a UUID: {generated}");
    assert_eq!(reply.json()["request_id"], generated.as_str());
}

/// A request that holds a computation slot for a while (about 2 s on the reference machine): an η sweep on an asphere, each
/// point an equal-dwell pass over a 2001-sample grid with 2000 positions (curved removal is
/// several times the flat cost). (The optimizer is too quick for this since its dwell went
/// into a spline basis.)
/// Waits until `happened` holds, polling as fast as the runtime allows, for at most 5 s.
async fn eventually<F, Fut>(what: &str, mut happened: F)
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = bool>,
{
    let started = Instant::now();
    while !happened().await {
        assert!(
            started.elapsed() < Duration::from_secs(5),
            "{what}: not within 5 s"
        );
        tokio::task::yield_now().await;
    }
}

/// Waits until a computation holds the one slot of `app`.
async fn slot_taken(app: &axum::Router) {
    eventually("the slow computation takes the slot", || async {
        let metrics = get(app, "/metrics").await.text();
        sample(&metrics, &["preston_computations_in_flight"]) == Some(1.0)
    })
    .await;
}

const SLOW_PATH: &str = "/v1/studies/eta-sweep";

fn slow_computation() -> String {
    // A 2001-position plan on an asphere at 24 speeds: twenty-four 2001 × 2001 curved
    // operators (about 0.6 s here; eight took 0.2 s, too short for the drain test's 300 ms).
    let positions: Vec<f64> = (0..2001).map(|k| 0.025 * k as f64).collect();
    let etas: Vec<f64> = (0..24).map(|k| -0.05 - 0.1 * k as f64).collect();
    json!({"process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": 7.5, "tool_rpm": 150},
           "surface": {"kind": "asphere", "radius_of_curvature_mm": -150, "conic_constant": -0.5,
                       "coefficients": [{"power": 4, "value": 1e-7}]},
           "etas": etas,
           "dwell": {"positions_mm": positions, "dwell_s": vec![1.0; 2001]},
           "radial_grid": {"count": 2001}})
    .to_string()
}

#[tokio::test]
async fn excess_load_is_shed_with_503_and_retry_after() {
    let app = app_with(ServiceLimits {
        max_concurrent_computations: 1,
        max_queued_computations: 0,
        ..ServiceLimits::default()
    });
    let busy = {
        let app = app.clone();
        tokio::spawn(async move { post_json(&app, SLOW_PATH, slow_computation()).await })
    };
    slot_taken(&app).await;
    let body = std::fs::read(common::fixture_path("predict_paper_exp2.json")).unwrap();
    let shed = post_json(&app, "/v1/predict", body).await;
    assert_eq!(shed.status, 503, "{}", shed.text());
    assert_eq!(shed.content_type, "application/problem+json");
    assert_eq!(shed.headers["retry-after"], "5");
    assert_eq!(
        busy.await.unwrap().status,
        200,
        "the running request is not disturbed"
    );
}

/// Bad input is refused before it queues for a computation slot: with the only slot busy
/// (and room in the queue), an invalid request to every computing endpoint still gets its 422
/// at once, naming the field.
#[tokio::test]
async fn invalid_requests_are_refused_at_once_while_every_slot_is_busy() {
    let app = app_with(ServiceLimits {
        max_concurrent_computations: 1,
        ..ServiceLimits::default()
    });
    let busy = {
        let app = app.clone();
        tokio::spawn(async move { post_json(&app, SLOW_PATH, slow_computation()).await })
    };
    slot_taken(&app).await;
    let process = json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10, "tool_rpm": 200});
    let stationary = json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": 0, "tool_rpm": 200});
    let cases = [
        (
            "/v1/predict",
            json!({"process": stationary, "dwell": {"positions_mm": [1], "dwell_s": [1]}}),
            "process.workpiece_rpm",
        ),
        (
            "/v1/removal-function",
            json!({"process": process, "tool_positions_mm": [-1]}),
            "tool_positions_mm[0]",
        ),
        (
            "/v1/optimize",
            json!({"process": process, "positions_mm": [0, 1], "target": {"uniform_depth_nm": 1}, "constraints": {"max_dwell_s": -1}}),
            "constraints.max_dwell_s",
        ),
        (
            "/v1/recommend",
            json!({"process": process, "nonuniformity_threshold": -1}),
            "nonuniformity_threshold",
        ),
        (
            "/v1/studies/eta-sweep",
            json!({"process": process, "etas": [-1, 0]}),
            "etas[1]",
        ),
    ];
    for (path, body, field) in cases {
        let sent = Instant::now();
        let reply = post_json(&app, path, body.to_string()).await;
        let waited = sent.elapsed();
        assert_eq!(reply.status, 422, "{path}: {}", reply.text());
        assert_eq!(reply.json()["field"], field, "{path}");
        assert!(
            waited < Duration::from_millis(100),
            "{path}: 422 after {waited:?}"
        );
    }
    assert!(!busy.is_finished(), "the slot stayed busy throughout");
    assert_eq!(busy.await.unwrap().status, 200);
}

/// The metrics registry belongs to the service instance: a new one counts only its own requests.
#[tokio::test]
async fn each_service_counts_only_its_own_requests() {
    let app = app();
    let body = std::fs::read(common::fixture_path("predict_paper_exp2.json")).unwrap();
    let labels = [
        "preston_http_requests_total",
        "route=\"/v1/predict\"",
        "status=\"200\"",
    ];
    assert_eq!(sample(&get(&app, "/metrics").await.text(), &labels), None);
    for _ in 0..3 {
        assert_eq!(
            post_json(&app, "/v1/predict", body.clone()).await.status,
            200
        );
    }
    assert_eq!(
        sample(&get(&app, "/metrics").await.text(), &labels),
        Some(3.0)
    );
}

/// Repeated predictions and optimizations on one process, grid and positions share one
/// operator: the first assembles it, the others hit, and the answers are the same bytes;
/// with no cache memory every request assembles its own.
#[tokio::test]
async fn repeated_requests_share_the_operator_and_metrics_count_hits() {
    let body = std::fs::read(common::fixture_path("predict_paper_exp2.json")).unwrap();
    let hits = ["preston_operator_cache_requests_total", "result=\"hit\""];
    let misses = ["preston_operator_cache_requests_total", "result=\"miss\""];
    for (budget, expect_hits) in [
        (ServiceLimits::default().operator_cache_bytes, 2.0),
        (0, 0.0),
    ] {
        let app = app_with(ServiceLimits {
            operator_cache_bytes: budget,
            ..ServiceLimits::default()
        });
        let mut answers = Vec::new();
        for _ in 0..3 {
            let reply = post_json(&app, "/v1/predict", body.clone()).await;
            assert_eq!(reply.status, 200);
            answers.push(reply.text());
        }
        assert!(answers.iter().all(|a| *a == answers[0]));
        let metrics = get(&app, "/metrics").await.text();
        assert_eq!(sample(&metrics, &hits), Some(expect_hits), "{metrics}");
        assert_eq!(sample(&metrics, &misses), Some(3.0 - expect_hits));
        let held = sample(&metrics, &["preston_operator_cache_entries"]);
        assert_eq!(held, Some(if budget > 0 { 1.0 } else { 0.0 }));
    }
}

#[tokio::test]
async fn a_request_over_its_time_budget_is_503() {
    let app = app_with(ServiceLimits {
        request_timeout: Duration::from_millis(20),
        ..ServiceLimits::default()
    });
    let reply = post_json(&app, SLOW_PATH, slow_computation()).await;
    assert_eq!(reply.status, 503, "{}", reply.text());
    assert_eq!(reply.json()["type"], "urn:preston:problem:overloaded");
}

#[test]
fn sigterm_turns_readiness_503_first_and_lets_a_long_computation_finish() {
    let mut service = Service::start_with(
        &[
            "serve",
            "--listen",
            "127.0.0.1:0",
            "--drain-delay-ms",
            "300",
        ],
        &[],
    );
    let address = service.address.clone();

    let runtime = tokio::runtime::Runtime::new().unwrap();
    runtime.block_on(async {
        let long = {
            let address = address.clone();
            tokio::spawn(async move {
                let started = Instant::now();
                let response =
                    socket::post_json(&address, SLOW_PATH, slow_computation().as_bytes()).await;
                (response.status, started.elapsed())
            })
        };
        eventually("the computation takes its slot", || async {
            let metrics = socket::get(&address, "/metrics").await.body;
            let metrics = String::from_utf8(metrics).unwrap();
            sample(&metrics, &["preston_computations_in_flight"]) == Some(1.0)
        })
        .await;
        let ready = socket::get(&address, "/readyz").await;
        assert_eq!(ready.status, 200);

        let signalled = Instant::now();
        service.signal("TERM");
        eventually("readiness turns 503", || async {
            socket::get(&address, "/readyz").await.status == 503
        })
        .await;
        assert!(
            !long.is_finished(),
            "the computation is still running when readiness drops"
        );

        let (status, took) = long.await.unwrap();
        assert_eq!(status, 200, "the in-flight computation completes");
        let after = signalled.elapsed();
        println!("long request took {took:?}, ending {after:?} after SIGTERM");
        // It outlived the 300 ms drain: the listener had closed while it ran.
        assert!(after > Duration::from_millis(300), "{after:?}");
    });
    let exit = service.wait();
    assert!(exit.success(), "exits cleanly after draining: {exit:?}");
}
