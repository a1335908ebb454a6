//! Calling the router in-process (tower `oneshot`).

use axum::body::Body;
use axum::http::{Request, StatusCode};
use axum::Router;
use http_body_util::BodyExt;
use preston::config::ServiceLimits;
use preston::http::{router, AppState};
use serde_json::Value;
use tower::ServiceExt;

pub struct Reply {
    pub status: StatusCode,
    pub content_type: String,
    pub headers: axum::http::HeaderMap,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn json(&self) -> serde_json::Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&self.body)))
    }
    pub fn text(&self) -> String {
        String::from_utf8(self.body.clone()).expect("UTF-8 body")
    }
}

pub fn app() -> Router {
    app_with(ServiceLimits::default())
}

pub fn app_with(limits: ServiceLimits) -> Router {
    router(AppState::new(limits), None)
}

/// The service behind one API key (its digest in a keys file of this test process's own).
pub fn app_with_keys() -> Router {
    let dir = std::env::temp_dir().join(format!("preston-http-keys-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("keys.txt");
    // The SHA-256 digest of "key".
    let digest = "2c70e12b7a0646f92279f427c7b38e7334d8e5389cff167a1dc30e73f826b683";
    std::fs::write(&path, format!("tests:{digest}\n")).unwrap();
    let auth = preston::keys::Auth::load(path, false).unwrap();
    router(
        AppState::new(ServiceLimits::default()).with_auth(std::sync::Arc::new(auth)),
        None,
    )
}

pub async fn send(app: &Router, request: Request<Body>) -> Reply {
    let response = app.clone().oneshot(request).await.expect("infallible");
    let status = response.status();
    let headers = response.headers().clone();
    let content_type = headers
        .get("content-type")
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    let body = response
        .into_body()
        .collect()
        .await
        .unwrap()
        .to_bytes()
        .to_vec();
    Reply {
        status,
        content_type,
        headers,
        body,
    }
}

pub async fn get(app: &Router, path: &str) -> Reply {
    send(app, Request::get(path).body(Body::empty()).unwrap()).await
}

pub async fn post_json(app: &Router, path: &str, body: impl Into<Body>) -> Reply {
    post_with(app, path, body, &[("content-type", "application/json")]).await
}

/// A JSON body, the answer asked in `accept` (`text/x-gcode`, `text/csv`, …).
pub async fn post_json_accepting(
    app: &Router,
    path: &str,
    body: impl Into<Body>,
    accept: &str,
) -> Reply {
    post_with(
        app,
        path,
        body,
        &[("content-type", "application/json"), ("accept", accept)],
    )
    .await
}

pub async fn post_with(
    app: &Router,
    path: &str,
    body: impl Into<Body>,
    headers: &[(&str, &str)],
) -> Reply {
    let mut request = Request::post(path);
    for (name, value) in headers {
        request = request.header(*name, *value);
    }
    send(app, request.body(body.into()).unwrap()).await
}

/// The violation of `axis` in a 422 machine-limits problem (asserting its type), by value.
pub fn limit_violation(problem: &Value, axis: &str) -> Value {
    assert_eq!(
        problem["type"], "urn:preston:problem:machine-limits",
        "{problem}"
    );
    problem["violations"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["axis"] == axis)
        .unwrap_or_else(|| panic!("{problem}"))
        .clone()
}
