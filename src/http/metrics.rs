//! Prometheus metrics over HTTP: `GET /metrics` (text format 0.0.4; the metrics are listed in
//! `telemetry::metrics`) and the middleware that records every request.

use std::time::Instant;

use super::auth::KeyName;
use super::state::AppState;
use axum::extract::{MatchedPath, Request, State};
use axum::http::header;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

/// The request-id header, generated when absent and echoed on the response.
pub const REQUEST_ID: &str = "x-request-id";

/// Prometheus metrics.
///
/// Text exposition format 0.0.4: requests by route and status, latency histograms,
/// computations in flight and waiting, load shed, solver time and outcomes.
#[utoipa::path(
    get,
    path = "/metrics",
    operation_id = "getMetrics",
    tag = "service",
    responses(
        (status = 200, description = "Prometheus text format", content_type = "text/plain", body = String),
        (status = 401, description = "Only when the service runs with `--metrics-require-key`: no valid API key", content_type = "application/problem+json", body = super::error::Problem),
    ),
    security(("bearer" = []), ())
)]
pub async fn handler(State(state): State<AppState>) -> Response {
    (
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        state.services.metrics.render(),
    )
        .into_response()
}

/// Records the request in the metrics.
pub async fn record(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let started = Instant::now();
    let route = request
        .extensions()
        .get::<MatchedPath>()
        .map_or("unmatched".to_string(), |p| p.as_str().to_string());
    let method = request.method().as_str().to_string();
    let response = next.run(request).await;
    let key = response
        .extensions()
        .get::<KeyName>()
        .map_or("-", |k| &*k.0)
        .to_string();
    let m = &state.services.metrics;
    m.requests
        .with_label_values(&[&route, &method, response.status().as_str(), &key])
        .inc();
    m.latency
        .with_label_values(&[&route])
        .observe(started.elapsed().as_secs_f64());
    response
}
