//! The HTTP layer: axum router, handlers, DTOs (serde + utoipa) and the problem+json error.
//! It owns every wire type and converts them to and from the engine's types in `physics`.
//!
//! CPU-heavy work runs on the blocking pool, at most `max_concurrent_computations` at a time;
//! a request that cannot get a slot within `queue_timeout` is answered 503 with Retry-After.

pub mod csv;
pub mod docs;
pub mod dto;
pub mod error;
pub mod eta_sweep;
pub mod extract;
pub mod health;
pub mod limits;
pub mod openapi;
pub mod optimize;
pub mod plot;
pub mod predict;
pub mod recommend;
pub mod removal_function;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use axum::extract::{DefaultBodyLimit, Request};
use axum::http::{header, HeaderValue, Method};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Extension, Router};
use serde::Serialize;
use tokio::sync::Semaphore;
use tower_http::compression::CompressionLayer;
use tower_http::cors::{AllowOrigin, CorsLayer};
use tower_http::trace::TraceLayer;

use error::ApiError;
use extract::{BodyLimit, Format};
pub use limits::Limits;

/// Shared by every request.
#[derive(Clone)]
pub struct AppState {
    pub limits: Limits,
    slots: Arc<Semaphore>,
    ready: Arc<AtomicBool>,
    openapi_json: Arc<str>,
}

impl AppState {
    pub fn new(limits: Limits) -> Self {
        AppState {
            slots: Arc::new(Semaphore::new(limits.max_concurrent_computations.max(1))),
            limits,
            ready: Arc::new(AtomicBool::new(true)),
            openapi_json: openapi::spec_json().into(),
        }
    }

    /// Marks the service as not ready (e.g. while shutting down); `/readyz` then answers 503.
    pub fn set_ready(&self, ready: bool) {
        self.ready.store(ready, Ordering::SeqCst);
    }

    pub fn is_ready(&self) -> bool {
        self.ready.load(Ordering::SeqCst)
    }

    /// Runs `job` on the blocking pool once a computation slot is free.
    pub async fn run<T, F>(&self, job: F) -> Result<T, ApiError>
    where
        T: Send + 'static,
        F: FnOnce() -> Result<T, ApiError> + Send + 'static,
    {
        let permit = tokio::time::timeout(
            self.limits.queue_timeout,
            self.slots.clone().acquire_owned(),
        )
        .await
        .map_err(|_| ApiError::Overloaded {
            retry_after_s: self.limits.queue_timeout.as_secs().max(1),
        })?
        .map_err(|_| ApiError::internal("computation semaphore closed"))?;
        tokio::task::spawn_blocking(move || {
            let _permit = permit;
            job()
        })
        .await
        .map_err(|e| ApiError::internal(format!("computation task failed: {e}")))?
    }
}

/// Non-JSON renderings a computing endpoint offers.
pub struct Renderers<Resp> {
    pub csv: Option<fn(&Resp) -> String>,
    pub svg: Option<fn(&Resp) -> String>,
}

/// The shared body of the computing handlers: negotiate the format, compute off the runtime,
/// render JSON, CSV or SVG.
async fn compute_and_render<Req, Resp>(
    state: AppState,
    headers: &axum::http::HeaderMap,
    req: Req,
    compute: fn(&Req, &Limits) -> Result<Resp, ApiError>,
    renderers: Renderers<Resp>,
) -> Result<Response, ApiError>
where
    Req: Send + 'static,
    Resp: Serialize + Send + 'static,
{
    let mut offered = vec![Format::Json];
    offered.extend(renderers.csv.map(|_| Format::Csv));
    offered.extend(renderers.svg.map(|_| Format::Svg));
    let format = extract::negotiate(headers, &offered)?;
    let limits = state.limits.clone();
    let response = state.run(move || compute(&req, &limits)).await?;
    Ok(render(format, &response, &renderers))
}

/// The response body in the negotiated format (one the renderers offer).
fn render<T: Serialize>(format: Format, body: &T, renderers: &Renderers<T>) -> Response {
    let text = match format {
        Format::Json => serde_json::to_string(body)
            .map_err(|e| ApiError::internal(format!("serialising a response: {e}"))),
        Format::Csv => renderers
            .csv
            .map(|f| f(body))
            .ok_or_else(|| ApiError::internal("CSV negotiated but not offered")),
        Format::Svg => renderers
            .svg
            .map(|f| f(body))
            .ok_or_else(|| ApiError::internal("SVG negotiated but not offered")),
    };
    let content_type = match format {
        Format::Json => "application/json",
        Format::Csv => "text/csv; charset=utf-8",
        Format::Svg => "image/svg+xml",
    };
    match text {
        Ok(text) => ([(header::CONTENT_TYPE, content_type)], text).into_response(),
        Err(e) => e.into_response(),
    }
}

/// The offline twin of the API: the exact JSON body `POST /v1/<endpoint>` would return.
pub fn compute_json(endpoint: &str, body: &[u8], limits: &Limits) -> Result<String, ApiError> {
    fn encode<T: Serialize>(value: T) -> Result<String, ApiError> {
        serde_json::to_string(&value).map_err(|e| ApiError::internal(e.to_string()))
    }
    match endpoint {
        "removal-function" => encode(removal_function::compute(
            &extract::parse_json(body)?,
            limits,
        )?),
        "predict" => encode(predict::compute(&extract::parse_json(body)?, limits)?),
        "optimize" => encode(optimize::compute(&extract::parse_json(body)?, limits)?),
        "recommend" => encode(recommend::compute(&extract::parse_json(body)?, limits)?),
        "studies/eta-sweep" => encode(eta_sweep::compute(&extract::parse_json(body)?, limits)?),
        other => Err(ApiError::NotFound {
            path: format!("/v1/{other}"),
        }),
    }
}

/// The endpoints `compute_json` knows.
pub const COMPUTE_ENDPOINTS: [&str; 5] = [
    "removal-function",
    "predict",
    "optimize",
    "recommend",
    "studies/eta-sweep",
];

/// Cross-origin access: none unless origins are configured (`*` allows any).
pub fn cors_layer(origins: &[String]) -> Option<CorsLayer> {
    if origins.is_empty() {
        return None;
    }
    let allow = if origins.iter().any(|o| o == "*") {
        AllowOrigin::any()
    } else {
        AllowOrigin::list(
            origins
                .iter()
                .filter_map(|o| HeaderValue::from_str(o).ok())
                .collect::<Vec<_>>(),
        )
    };
    Some(
        CorsLayer::new()
            .allow_origin(allow)
            .allow_methods([Method::GET, Method::POST])
            .allow_headers([header::CONTENT_TYPE, header::ACCEPT]),
    )
}

/// The whole service.
pub fn router(state: AppState, cors: Option<CorsLayer>) -> Router {
    let body_limit = state.limits.max_body_bytes;
    let router = Router::new()
        .route("/v1/removal-function", post(removal_function::handler))
        .route("/v1/predict", post(predict::handler))
        .route("/v1/optimize", post(optimize::handler))
        .route("/v1/recommend", post(recommend::handler))
        .route("/v1/studies/eta-sweep", post(eta_sweep::handler))
        .route("/healthz", get(health::healthz))
        .route("/readyz", get(health::readyz))
        .route("/openapi.json", get(docs::openapi_json))
        .route("/docs", get(docs::redirect))
        .route("/docs/", get(docs::asset))
        .route("/docs/{*path}", get(docs::asset))
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .with_state(state)
        .layer(DefaultBodyLimit::max(body_limit))
        .layer(Extension(BodyLimit(body_limit)))
        .layer(CompressionLayer::new())
        .layer(TraceLayer::new_for_http());
    match cors {
        Some(cors) => router.layer(cors),
        None => router,
    }
}

async fn not_found(req: Request) -> ApiError {
    ApiError::NotFound {
        path: req.uri().path().to_string(),
    }
}

async fn method_not_allowed() -> ApiError {
    ApiError::MethodNotAllowed
}
