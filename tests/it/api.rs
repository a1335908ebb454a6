//! The HTTP contract through the router (in-process): fixtures against stored responses, every
//! bad-input class, content negotiation, the OpenAPI document and the docs UI.

use crate::common;

use common::http::{app, app_with, get, post_json, post_with, Reply};
use preston::config::ServiceLimits;
use serde_json::{json, Value};

fn assert_problem(reply: &Reply, status: u16, field: Option<&str>) {
    assert_eq!(reply.status.as_u16(), status, "{}", reply.text());
    assert_eq!(reply.content_type, "application/problem+json");
    let body = reply.json();
    assert_eq!(body["status"], status);
    assert!(body["type"]
        .as_str()
        .unwrap()
        .starts_with("urn:preston:problem:"));
    assert!(!body["detail"].as_str().unwrap().is_empty());
    if let Some(field) = field {
        assert_eq!(body["field"], field, "{body}");
    }
}

/// Same structure, numbers equal to `tol` relative (to 1 for numbers below 1 when `tol` is
/// loose). Removal and prediction are computed by the same code, so 1e-12 catches any change
/// of the numerics; optimized plans come from an iterative solver whose last digits may move
/// with the CPU's vector width, so they get 1e-6, and `solve_time_ms` (wall clock) is skipped.
fn assert_same(got: &Value, want: &Value, path: &str, tol: f64) {
    match (got, want) {
        (Value::Number(g), Value::Number(w)) => {
            let (g, w) = (g.as_f64().unwrap(), w.as_f64().unwrap());
            let floor = if tol > 1e-12 { 1.0 } else { 1e-300 };
            assert!(
                (g - w).abs() <= tol * w.abs().max(floor),
                "{path}: {g} != {w}"
            );
        }
        (Value::Array(g), Value::Array(w)) => {
            assert_eq!(g.len(), w.len(), "{path}: length");
            for (i, (g, w)) in g.iter().zip(w).enumerate() {
                assert_same(g, w, &format!("{path}[{i}]"), tol);
            }
        }
        (Value::Object(g), Value::Object(w)) => {
            let keys = |m: &serde_json::Map<String, Value>| m.keys().cloned().collect::<Vec<_>>();
            assert_eq!(keys(g), keys(w), "{path}: members");
            for (k, w) in w {
                if k != "solve_time_ms" && k != "iterations" {
                    assert_same(&g[k], w, &format!("{path}.{k}"), tol);
                }
            }
        }
        _ => assert_eq!(got, want, "{path}"),
    }
}

/// Every request fixture is posted; its response must match `fixtures/expected/<name>`.
/// `PRESTON_BLESS=1 cargo test --release --test it api::` rewrites the expected files after a deliberate change.
#[tokio::test]
async fn every_fixture_returns_its_stored_response() {
    let app = app();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let names = common::request_fixtures();
    assert!(names.len() >= 3);
    for name in names {
        let body = std::fs::read(dir.join(&name)).unwrap();
        let reply = post_json(&app, common::endpoint_of(&name), body).await;
        assert_eq!(reply.status, 200, "{name}: {}", reply.text());
        assert_eq!(reply.content_type, "application/json");
        let expected_path = dir.join("expected").join(&name);
        if std::env::var_os("PRESTON_BLESS").is_some() {
            std::fs::create_dir_all(dir.join("expected")).unwrap();
            let pretty = serde_json::to_string_pretty(&reply.json()).unwrap();
            std::fs::write(&expected_path, pretty + "\n").unwrap();
        }
        let expected: Value =
            serde_json::from_str(&std::fs::read_to_string(&expected_path).unwrap()).unwrap();
        let tol = if name.starts_with("optimize") {
            1e-6
        } else {
            1e-12
        };
        assert_same(&reply.json(), &expected, &name, tol);
    }
}

/// Independent of the stored files: the removal-function fixture reproduces the docs/MODEL.md
/// sanity table (r1 = 5 and 20 mm at η = +0.05) to 4 decimals.
#[tokio::test]
async fn removal_function_fixture_matches_the_sanity_table() {
    let body = std::fs::read(common::fixture_path("removal_function_paper_exp1.json")).unwrap();
    let reply = post_json(&app(), "/v1/removal-function", body).await;
    let v = reply.json();
    assert_eq!(v["eta"], 0.05);
    let radius: Vec<f64> = serde_json::from_value(v["radius_mm"].clone()).unwrap();
    let at = |profile: usize, r: f64| {
        let i = radius.iter().position(|&x| x == r).unwrap();
        v["profiles"][profile]["removal_rate_nm_per_min"][i]
            .as_f64()
            .unwrap()
    };
    assert_eq!(v["profiles"][0]["tool_position_mm"], 5.0);
    assert!((at(0, 2.0) - 6.5635).abs() < 0.5e-4);
    assert!((at(1, 20.0) - 1.0757).abs() < 0.5e-4);
    assert!((at(1, 25.0) - 1.2418).abs() < 0.5e-4);
    assert_eq!(at(0, 20.0), 0.0);
}

fn predict_body() -> Value {
    json!({
        "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10,
                    "workpiece_rpm": 150, "tool_rpm": 150},
        "dwell": {"positions_mm": [0, 10, 20, 30, 40, 50], "dwell_s": [5, 5, 5, 5, 5, 5]},
        "radial_grid": {"count": 51},
        "clear_aperture": {"inner_mm": 0, "outer_mm": 40}
    })
}

async fn predict(body: Value) -> Reply {
    post_json(&app(), "/v1/predict", body.to_string()).await
}

#[tokio::test]
async fn predict_fills_defaults_and_echoes_what_it_used() {
    let mut body = predict_body();
    body.as_object_mut().unwrap().remove("clear_aperture");
    let v = predict(body).await.json();
    assert_eq!(v["eta"], -1.0);
    assert_eq!(v["radius_mm"].as_array().unwrap().len(), 51);
    assert_eq!(
        v["clear_aperture"],
        json!({"inner_mm": 0.0, "outer_mm": 50.0})
    );
    assert_eq!(v["total_time_s"], 30.0);
    assert_eq!(v["metrics"]["samples"], 51);
}

#[tokio::test]
async fn eta_is_null_when_the_tool_does_not_spin() {
    let mut body = predict_body();
    body["process"]["tool_rpm"] = json!(0);
    let v = predict(body).await.json();
    assert_eq!(v["eta"], Value::Null);
}

#[tokio::test]
async fn malformed_json_is_400() {
    let reply = post_json(&app(), "/v1/predict", "{\"process\": ").await;
    assert_problem(&reply, 400, None);
    let trailing = format!("{} trailing", predict_body());
    let reply = post_json(&app(), "/v1/predict", trailing).await;
    assert_problem(&reply, 400, None);
    // An empty body, and a form-encoded one (what `curl -d a=1` sends), say what is expected.
    let reply = post_json(&app(), "/v1/predict", "").await;
    assert_problem(&reply, 400, None);
    let detail = reply.json()["detail"].as_str().unwrap().to_string();
    assert!(
        detail.starts_with("the body is empty: send one JSON object"),
        "{detail}"
    );
    let form = [("content-type", "application/x-www-form-urlencoded")];
    let reply = post_with(&app(), "/v1/predict", "process=1&dwell=2", &form).await;
    assert_problem(&reply, 400, None);
    let detail = reply.json()["detail"].as_str().unwrap().to_string();
    assert!(
        detail.starts_with("the body is not JSON: send one JSON object"),
        "{detail}"
    );
}

#[tokio::test]
async fn wrong_types_name_the_field() {
    let mut body = predict_body();
    body["process"]["tool_rpm"] = json!("50");
    let reply = predict(body).await;
    assert_problem(&reply, 422, Some("process.tool_rpm"));
    // In JSON's words, not Rust's ("expected f64").
    assert_eq!(
        reply.json()["detail"],
        r#"expected a number here, got the text "50""#
    );
    let mut body = predict_body();
    body["dwell"]["dwell_s"][2] = json!(true);
    assert_problem(&predict(body).await, 422, Some("dwell.dwell_s[2]"));
}

#[tokio::test]
async fn missing_and_unknown_fields_name_the_field() {
    let mut body = predict_body();
    body["process"]
        .as_object_mut()
        .unwrap()
        .remove("tool_radius_mm");
    assert_problem(&predict(body).await, 422, Some("process.tool_radius_mm"));
    let mut body = predict_body();
    body["process"]["tool_speed"] = json!(3);
    assert_problem(&predict(body).await, 422, Some("process.tool_speed"));
    let mut body = predict_body();
    body["extra"] = json!(1);
    assert_problem(&predict(body).await, 422, Some("extra"));
}

#[tokio::test]
async fn non_finite_numbers_are_rejected() {
    // JSON has no NaN or Infinity; an overflowing literal is the way one arrives.
    let text = predict_body()
        .to_string()
        .replace("\"tool_rpm\":150", "\"tool_rpm\":1e999");
    assert!(text.contains("1e999"));
    let reply = post_json(&app(), "/v1/predict", text).await;
    assert!(
        reply.status == 400 || reply.status == 422,
        "{}",
        reply.text()
    );
    assert_eq!(reply.content_type, "application/problem+json");
    assert_eq!(reply.json()["field"], "process.tool_rpm");
    let reply = post_json(
        &app(),
        "/v1/predict",
        predict_body().to_string().replace("150,", "NaN,"),
    )
    .await;
    assert_problem(&reply, 400, None);
}

#[tokio::test]
async fn every_invalid_process_is_a_422_naming_its_field() {
    let cases = [
        ("workpiece_radius_mm", json!(0)),
        ("workpiece_radius_mm", json!(-5)),
        ("tool_radius_mm", json!(0)),
        ("pressure_kpa", json!(0)),
        ("pressure_kpa", json!(-1)),
        ("preston_coefficient_m2_per_n", json!(-1e-13)),
        ("workpiece_rpm", json!(0)),
        // Outside the model's domain (results would overflow f64; schemathesis found these).
        ("workpiece_radius_mm", json!(6.8e16)),
        ("tool_radius_mm", json!(1e-9)),
        ("workpiece_rpm", json!(-1.7e15)),
        ("tool_rpm", json!(2e5)),
        ("preston_coefficient_m2_per_n", json!(6.8e16)),
        ("pressure_kpa", json!(1e9)),
    ];
    for (field, value) in cases {
        let mut body = predict_body();
        body["process"][field] = value;
        assert_problem(&predict(body).await, 422, Some(&format!("process.{field}")));
    }
}

#[tokio::test]
async fn dwell_errors_name_the_element() {
    let mut body = predict_body();
    body["dwell"]["dwell_s"] = json!([1, 2]);
    assert_problem(&predict(body).await, 422, Some("dwell.dwell_s"));
    let mut body = predict_body();
    body["dwell"]["positions_mm"] = json!([0, 10, 10, 30, 40, 50]);
    assert_problem(&predict(body).await, 422, Some("dwell.positions_mm[2]"));
    let mut body = predict_body();
    body["dwell"]["positions_mm"] = json!([0, 10, 20, 30, 40, 61]);
    assert_problem(&predict(body).await, 422, Some("dwell.positions_mm[5]"));
    let mut body = predict_body();
    body["dwell"]["positions_mm"] = json!([-1, 10, 20, 30, 40, 50]);
    assert_problem(&predict(body).await, 422, Some("dwell.positions_mm[0]"));
    let mut body = predict_body();
    body["dwell"]["dwell_s"][3] = json!(-2);
    assert_problem(&predict(body).await, 422, Some("dwell.dwell_s[3]"));
    let mut body = predict_body();
    body["dwell"] = json!({"positions_mm": [], "dwell_s": []});
    assert_problem(&predict(body).await, 422, Some("dwell.positions_mm"));
}

#[tokio::test]
async fn grid_and_aperture_errors_name_the_field() {
    let mut body = predict_body();
    body["radial_grid"]["count"] = json!(0);
    assert_problem(&predict(body).await, 422, Some("radial_grid.count"));
    let mut body = predict_body();
    body["radial_grid"]["count"] = json!(20_000);
    assert_problem(&predict(body).await, 422, Some("radial_grid.count"));
    let mut body = predict_body();
    body["radial_grid"]["stop_mm"] = json!(55);
    assert_problem(&predict(body).await, 422, Some("radial_grid.stop_mm"));
    let mut body = predict_body();
    body["clear_aperture"] = json!({"inner_mm": 30, "outer_mm": 20});
    assert_problem(&predict(body).await, 422, Some("clear_aperture.outer_mm"));
    let mut body = predict_body();
    body["radial_grid"]["stop_mm"] = json!(30);
    assert_problem(&predict(body).await, 422, Some("clear_aperture"));
}

#[tokio::test]
async fn oversize_requests_are_refused() {
    let limits = ServiceLimits {
        max_body_bytes: 1000,
        max_positions: 100,
        ..ServiceLimits::default()
    };
    let app = app_with(limits);
    let mut body = predict_body();
    body["dwell"]["positions_mm"] = json!((0..200).map(|i| i as f64 * 0.25).collect::<Vec<_>>());
    body["dwell"]["dwell_s"] = json!(vec![1.0; 200]);
    let reply = post_json(&app, "/v1/predict", body.to_string()).await;
    assert_problem(&reply, 413, None);

    let app = app_with(ServiceLimits {
        max_positions: 100,
        ..ServiceLimits::default()
    });
    let reply = post_json(&app, "/v1/predict", body.to_string()).await;
    assert_problem(&reply, 422, Some("dwell.positions_mm"));

    let app = app_with(ServiceLimits {
        max_operator_entries: 1000,
        ..ServiceLimits::default()
    });
    let reply = post_json(&app, "/v1/predict", predict_body().to_string()).await;
    assert_eq!(reply.status, 200); // 51 × 6 = 306 entries
    let mut big = predict_body();
    big["radial_grid"]["count"] = json!(201);
    let reply = post_json(&app, "/v1/predict", big.to_string()).await;
    assert_problem(&reply, 422, Some("dwell.positions_mm"));
}

#[tokio::test]
async fn removal_function_positions_are_checked() {
    let body = json!({
        "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10,
                    "workpiece_rpm": -10, "tool_rpm": 200, "pressure_model": "constant_force"},
        "tool_positions_mm": [10, 55]
    });
    let reply = post_json(&app(), "/v1/removal-function", body.to_string()).await;
    assert_problem(&reply, 422, Some("tool_positions_mm[1]"));
    let reply = post_json(
        &app(),
        "/v1/removal-function",
        body.to_string().replace("constant_force", "sideways"),
    )
    .await;
    assert_problem(&reply, 422, Some("process.pressure_model"));
}

#[tokio::test]
async fn media_types_are_negotiated() {
    let body = predict_body().to_string();
    let reply = post_with(
        &app(),
        "/v1/predict",
        body.clone(),
        &[("content-type", "text/plain")],
    )
    .await;
    assert_problem(&reply, 415, None);
    // Each endpoint says what it takes: JSON, and for the fit a CSV trace too.
    assert!(
        reply.json()["detail"]
            .as_str()
            .unwrap()
            .ends_with("send application/json"),
        "{}",
        reply.json()
    );
    let reply = post_with(
        &app(),
        "/v1/measurement/fit",
        "x_mm,z_mm\n0,0\n",
        &[("content-type", "text/plain")],
    )
    .await;
    assert_problem(&reply, 415, None);
    assert!(
        reply.json()["detail"]
            .as_str()
            .unwrap()
            .ends_with("send application/json or text/csv"),
        "{}",
        reply.json()
    );
    // curl -d sends form encoding by default: accepted, the body is still JSON.
    let reply = post_with(
        &app(),
        "/v1/predict",
        body.clone(),
        &[("content-type", "application/x-www-form-urlencoded")],
    )
    .await;
    assert_eq!(reply.status, 200);
    let reply = post_with(
        &app(),
        "/v1/predict",
        body.clone(),
        &[("accept", "image/png")],
    )
    .await;
    assert_problem(&reply, 406, None);

    let reply = post_with(&app(), "/v1/predict", body, &[("accept", "text/csv")]).await;
    assert_eq!(reply.status, 200);
    assert_eq!(reply.content_type, "text/csv; charset=utf-8");
    let text = reply.text();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("radius_mm,removal_nm"));
    assert_eq!(lines.count(), 51);

    let rf = std::fs::read(common::fixture_path("removal_function_paper_exp1.json")).unwrap();
    let reply = post_with(
        &app(),
        "/v1/removal-function",
        rf,
        &[("accept", "text/csv")],
    )
    .await;
    let header = reply.text().lines().next().unwrap().to_string();
    assert_eq!(
        header,
        "radius_mm,removal_rate_nm_per_min(tool_position_mm=5),\
         removal_rate_nm_per_min(tool_position_mm=20),removal_rate_nm_per_min(tool_position_mm=45)"
    );
}

#[tokio::test]
async fn large_responses_are_gzipped_on_request() {
    let body = std::fs::read(common::fixture_path("predict_paper_exp1.json")).unwrap();
    let reply = post_with(
        &app(),
        "/v1/predict",
        body,
        &[
            ("content-type", "application/json"),
            ("accept-encoding", "gzip"),
        ],
    )
    .await;
    assert_eq!(reply.status, 200);
    assert_eq!(reply.headers["content-encoding"], "gzip");
}

#[tokio::test]
async fn unknown_routes_and_methods_are_problems() {
    assert_problem(&get(&app(), "/v1/nothing").await, 404, None);
    assert_problem(&get(&app(), "/v1/predict").await, 405, None);
}

#[tokio::test]
async fn probes_answer() {
    let reply = get(&app(), "/healthz").await;
    assert_eq!(
        (reply.status.as_u16(), reply.json()["status"].clone()),
        (200, json!("ok"))
    );
    let reply = get(&app(), "/readyz").await;
    assert_eq!(
        (reply.status.as_u16(), reply.json()["status"].clone()),
        (200, json!("ready"))
    );
}

#[tokio::test]
async fn served_openapi_equals_the_committed_file_byte_for_byte() {
    let reply = get(&app(), "/openapi.json").await;
    assert_eq!(reply.status, 200);
    assert_eq!(reply.content_type, "application/json");
    let committed = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("openapi/openapi.json"),
    )
    .unwrap();
    assert!(
        reply.body == committed,
        "served /openapi.json differs from openapi/openapi.json"
    );
}

/// The docs page and every asset it loads come from the binary; none is fetched from elsewhere.
#[tokio::test]
async fn docs_render_from_the_binary_alone() {
    let app = app();
    let redirect = get(&app, "/docs").await;
    assert!(redirect.status.is_redirection());
    let index = get(&app, "/docs/").await;
    assert_eq!(index.status, 200);
    assert!(index.content_type.starts_with("text/html"));
    let html = index.text();
    assert!(html.contains("swagger-ui"));
    // Every script and stylesheet is relative: no network at view time.
    let mut assets = Vec::new();
    for attr in ["src=\"", "href=\""] {
        for piece in html.split(attr).skip(1) {
            let url = piece.split('"').next().unwrap();
            assert!(
                !url.contains("://") && !url.starts_with("//"),
                "external asset {url}"
            );
            assets.push(url.trim_start_matches("./").to_string());
        }
    }
    assert!(assets.len() >= 3, "{assets:?}");
    for asset in &assets {
        let reply = get(&app, &format!("/docs/{asset}")).await;
        assert_eq!(reply.status, 200, "{asset}");
    }
    let init = get(&app, "/docs/swagger-initializer.js").await.text();
    assert!(init.contains("/openapi.json"), "{init}");
}

/// With CORS on, a browser may send its own request id and read the one on the response (and
/// Retry-After); without origins configured there are no CORS headers at all.
#[tokio::test]
async fn cors_lets_a_front_end_send_and_read_the_request_id() {
    use axum::body::Body;
    use axum::http::Request;
    use preston::http::{cors_layer, router, AppState};

    let cors = router(
        AppState::new(ServiceLimits::default()),
        cors_layer(&["https://bench.example".to_string()]),
    );
    let preflight = Request::builder()
        .method("OPTIONS")
        .uri("/v1/predict")
        .header("origin", "https://bench.example")
        .header("access-control-request-method", "POST")
        .header(
            "access-control-request-headers",
            "content-type,x-request-id",
        )
        .body(Body::empty())
        .unwrap();
    let reply = common::http::send(&cors, preflight).await;
    assert_eq!(reply.status, 200);
    let allowed = reply.headers["access-control-allow-headers"]
        .to_str()
        .unwrap()
        .to_ascii_lowercase();
    assert!(allowed.contains("x-request-id"), "{allowed}");
    assert!(allowed.contains("content-type"), "{allowed}");

    let body = std::fs::read(common::fixture_path("predict_paper_exp2.json")).unwrap();
    let reply = post_with(
        &cors,
        "/v1/predict",
        body,
        &[
            ("origin", "https://bench.example"),
            ("x-request-id", "bench-7"),
        ],
    )
    .await;
    assert_eq!(reply.status, 200);
    assert_eq!(reply.headers["x-request-id"], "bench-7");
    let exposed = reply.headers["access-control-expose-headers"]
        .to_str()
        .unwrap()
        .to_ascii_lowercase();
    assert!(
        exposed.contains("x-request-id") && exposed.contains("retry-after"),
        "{exposed}"
    );

    let plain = post_with(
        &app(),
        "/v1/predict",
        "{",
        &[("origin", "https://bench.example")],
    )
    .await;
    assert!(plain.headers.get("access-control-allow-origin").is_none());
}

fn assert_problem_type(reply: &Reply, kind: &str, field: &str) {
    assert_problem(reply, 422, Some(field));
    assert_eq!(
        reply.json()["type"],
        format!("urn:preston:problem:{kind}"),
        "{}",
        reply.text()
    );
}

fn exp1_process() -> Value {
    json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10, "tool_rpm": 200})
}

/// serde would fill a struct from an array by position (`[50, 10, 200, -10]` as a process,
/// speeds wherever they land): the body must be an object.
#[tokio::test]
async fn an_array_for_the_body_is_refused() {
    for path in ["/v1/predict", "/v1/optimize", "/v1/recommend"] {
        let reply = post_json(&app(), path, "[50, 10, 200, -10]").await;
        assert_problem_type(&reply, "schema-mismatch", "body");
        let detail = reply.json()["detail"].as_str().unwrap().to_string();
        assert!(
            detail.contains("JSON object") && detail.contains("array"),
            "{detail}"
        );
    }
}

/// The same for every object nested in a request: process, grid, aperture, dwell, target,
/// profile, constraints, objective, solver, limits.
#[tokio::test]
async fn an_array_for_a_nested_object_is_refused() {
    let dwell = json!({"positions_mm": [1], "dwell_s": [1]});
    let cases = [
        (
            "/v1/predict",
            json!({"process": [50, 10, 200, -10], "dwell": dwell}),
            "process",
        ),
        (
            "/v1/predict",
            json!({"process": exp1_process(), "dwell": [[1], [1]]}),
            "dwell",
        ),
        (
            "/v1/predict",
            json!({"process": exp1_process(), "dwell": dwell, "clear_aperture": [0, 40]}),
            "clear_aperture",
        ),
        (
            "/v1/predict",
            json!({"process": exp1_process(), "dwell": dwell, "clear_aperture": [0, 40, 99]}),
            "clear_aperture",
        ),
        (
            "/v1/removal-function",
            json!({"process": exp1_process(), "tool_positions_mm": [1], "radial_grid": [0, 50, 11]}),
            "radial_grid",
        ),
        (
            "/v1/optimize",
            json!({"process": exp1_process(), "positions_mm": [0, 1], "target": [100]}),
            "target",
        ),
        (
            "/v1/optimize",
            json!({"process": exp1_process(), "positions_mm": [0, 1], "target": {"profile": [[0, 50], [1, 1]]}}),
            "target.profile",
        ),
        (
            "/v1/optimize",
            json!({"process": exp1_process(), "positions_mm": [0, 1], "target": {"uniform_depth_nm": 1}, "constraints": [0, 10]}),
            "constraints",
        ),
        (
            "/v1/optimize",
            json!({"process": exp1_process(), "positions_mm": [0, 1], "target": {"uniform_depth_nm": 1}, "objective": [0, 0]}),
            "objective",
        ),
        (
            "/v1/optimize",
            json!({"process": exp1_process(), "positions_mm": [0, 1], "target": {"uniform_depth_nm": 1}, "solver": [1]}),
            "solver",
        ),
        (
            "/v1/recommend",
            json!({"process": exp1_process(), "limits": [100, 100]}),
            "limits",
        ),
        (
            "/v1/studies/eta-sweep",
            json!({"process": exp1_process(), "etas": [-1], "dwell": [[1], [1]]}),
            "dwell",
        ),
    ];
    for (path, body, field) in cases {
        let reply = post_json(&app(), path, body.to_string()).await;
        assert_problem_type(&reply, "schema-mismatch", field);
    }
    // Absent or null optional objects still take their defaults.
    let reply = post_json(
        &app(),
        "/v1/predict",
        json!({"process": exp1_process(), "dwell": dwell, "clear_aperture": null}).to_string(),
    )
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
}

/// Empty arrays where at least one entry is needed (the schema says `minItems`).
#[tokio::test]
async fn empty_arrays_are_refused() {
    let cases = [
        (
            "/v1/predict",
            json!({"process": exp1_process(), "dwell": {"positions_mm": [], "dwell_s": []}}),
            "dwell.positions_mm",
        ),
        (
            "/v1/removal-function",
            json!({"process": exp1_process(), "tool_positions_mm": []}),
            "tool_positions_mm",
        ),
        (
            "/v1/optimize",
            json!({"process": exp1_process(), "positions_mm": [], "target": {"uniform_depth_nm": 1}}),
            "positions_mm",
        ),
        (
            "/v1/studies/eta-sweep",
            json!({"process": exp1_process(), "etas": []}),
            "etas",
        ),
    ];
    for (path, body, field) in cases {
        let reply = post_json(&app(), path, body.to_string()).await;
        assert_problem_type(&reply, "invalid-input", field);
    }
}

/// A stationary workpiece (the schema says `not: {const: 0}`) on every computing endpoint.
#[tokio::test]
async fn a_stationary_workpiece_is_refused() {
    let process = json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": 0, "tool_rpm": 200});
    let cases = [
        (
            "/v1/removal-function",
            json!({"process": process, "tool_positions_mm": [1]}),
        ),
        (
            "/v1/predict",
            json!({"process": process, "dwell": {"positions_mm": [1], "dwell_s": [1]}}),
        ),
        (
            "/v1/optimize",
            json!({"process": process, "positions_mm": [0, 1], "target": {"uniform_depth_nm": 1}}),
        ),
        ("/v1/recommend", json!({"process": process})),
        (
            "/v1/studies/eta-sweep",
            json!({"process": process, "etas": [-1]}),
        ),
    ];
    for (path, body) in cases {
        let reply = post_json(&app(), path, body.to_string()).await;
        assert_problem_type(&reply, "invalid-input", "process.workpiece_rpm");
    }
}

/// JSON Schema's integers include `3.0`; counts take them, and refuse what is not a whole
/// number ≥ 0, naming the field.
#[tokio::test]
async fn counts_take_whole_numbers_written_with_a_fraction() {
    let body = |count: Value| {
        json!({"process": exp1_process(), "tool_positions_mm": [5], "radial_grid": {"count": count}})
            .to_string()
    };
    let reply = post_json(&app(), "/v1/removal-function", body(json!(3.0))).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    assert_eq!(reply.json()["radius_mm"], json!([0.0, 25.0, 50.0]));
    for bad in [json!(3.5), json!(-1), json!("3")] {
        let reply = post_json(&app(), "/v1/removal-function", body(bad)).await;
        assert_problem_type(&reply, "schema-mismatch", "radial_grid.count");
    }
    // equal_dwell_positions is retired (equal dwell is an exact constant feed): refused by name.
    let reply = post_json(
        &app(),
        "/v1/recommend",
        json!({"process": exp1_process(), "equal_dwell_positions": 200}).to_string(),
    )
    .await;
    assert_problem_type(&reply, "schema-mismatch", "equal_dwell_positions");
}

/// Cases schemathesis found. A 1 µm pad on a 9 m part: each contact is 2 µm of path 9 m from
/// the axis, where x is known to 5e-10 of the piece, and the path integral used to halve its
/// panels to the deepest level (minutes per request). A depth of 2e-311 nm made the
/// equal-dwell feed overflow to a null in a 200.
#[tokio::test]
async fn extreme_but_valid_recommendations_answer() {
    // A tool position at the least normal number on a 1 µm part: the contact's normalisation
    // overflowed there and a rate came back null (schemathesis).
    let reply = post_json(
        &app(),
        "/v1/removal-function",
        json!({"process": {"tool_radius_mm": 0.001, "tool_rpm": 0.001,
                           "workpiece_radius_mm": 0.001, "workpiece_rpm": -100000.0},
               "tool_positions_mm": [2.2250738585072014e-308]})
        .to_string(),
    )
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let rates = reply.json()["profiles"][0]["removal_rate_nm_per_min"].clone();
    assert!(
        rates
            .as_array()
            .unwrap()
            .iter()
            .all(|r| r.as_f64().is_some_and(f64::is_finite)),
        "{rates}"
    );
    let tiny_pad = json!({"tool_radius_mm": 0.001, "tool_rpm": 0.001, "workpiece_rpm": -100000.0, "workpiece_radius_mm": 9143.786284385247});
    let reply = post_json(
        &app(),
        "/v1/recommend",
        json!({ "process": tiny_pad }).to_string(),
    )
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let r = reply.json();
    // Uniform to the rounding of radii 9 m from the axis against a 2 µm contact.
    let n = r["recommendation"]["metrics"]["nonuniformity"]
        .as_f64()
        .unwrap();
    assert!(n < 1e-8, "{n}");

    let process = exp1_process();
    let reply = post_json(
        &app(),
        "/v1/recommend",
        json!({"process": process, "depth_nm": 2.225073858507e-311}).to_string(),
    )
    .await;
    assert_problem_type(&reply, "invalid-input", "depth_nm");
    assert!(
        reply.text().contains("[0.000001, 1000000000] nm"),
        "{}",
        reply.text()
    );
    let reply = post_json(
        &app(),
        "/v1/recommend",
        json!({"process": process, "depth_nm": 1e-6}).to_string(),
    )
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let feed = &reply.json()["recommendation"]["current_feed_mm_per_min"];
    assert!(feed.as_f64().is_some_and(f64::is_finite), "{feed}");
}
