//! The HTTP layer: axum router, handlers, DTOs (serde + utoipa) and the problem+json error.
//! It owns every wire type and converts them to and from the engine's types in `physics`.
//!
//! CPU-heavy work runs on the blocking pool, at most `max_concurrent_computations` at a time,
//! with a bounded queue in front (see [`AppState::run`]); excess load is answered 503 with
//! Retry-After. Every request gets an `x-request-id` (kept if the client sent one), which is in
//! the log span, echoed on the response and written into problem+json bodies.

pub mod csv;
pub mod docs;
pub mod dto;
pub mod error;
pub mod eta_sweep;
pub mod extract;
pub mod health;
pub mod limits;
pub mod metrics;
pub mod openapi;
pub mod optimize;
pub mod plot;
pub mod predict;
pub mod recommend;
pub mod removal_function;

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use axum::extract::{DefaultBodyLimit, Request};
use axum::http::{header, HeaderName, HeaderValue, Method};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Extension, Router};
use serde::Serialize;
use tokio::sync::{Semaphore, TryAcquireError};
use tower_http::compression::CompressionLayer;
use tower_http::cors::{AllowOrigin, CorsLayer};
use tower_http::request_id::{MakeRequestUuid, PropagateRequestIdLayer, SetRequestIdLayer};
use tower_http::trace::{DefaultOnResponse, TraceLayer};
use tracing::Level;

use error::ApiError;
use extract::{BodyLimit, Format};
pub use limits::Limits;

/// Shared by every request.
#[derive(Clone)]
pub struct AppState {
    pub limits: Limits,
    slots: Arc<Semaphore>,
    waiting: Arc<AtomicUsize>,
    ready: Arc<AtomicBool>,
    openapi_json: Arc<str>,
}

impl AppState {
    pub fn new(limits: Limits) -> Self {
        AppState {
            slots: Arc::new(Semaphore::new(limits.max_concurrent_computations.max(1))),
            waiting: Arc::new(AtomicUsize::new(0)),
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
    ///
    /// Load shedding: at most `max_queued_computations` requests wait for a slot (more are
    /// refused at once), none waits longer than `queue_timeout`, and the whole wait plus
    /// computation is bounded by `request_timeout`; each refusal is a 503 with Retry-After.
    /// A computation that outlives its request keeps its slot until it ends, so the number
    /// running never exceeds the slots.
    pub async fn run<T, F>(&self, job: F) -> Result<T, ApiError>
    where
        T: Send + 'static,
        F: FnOnce() -> Result<T, ApiError> + Send + 'static,
    {
        let m = metrics::metrics();
        let retry_after_s = self.limits.queue_timeout.as_secs().max(1);
        let shed = |reason: &str| {
            m.shed.with_label_values(&[reason]).inc();
            ApiError::Overloaded { retry_after_s }
        };
        let work = async {
            let permit = match self.slots.clone().try_acquire_owned() {
                Ok(permit) => permit,
                Err(TryAcquireError::Closed) => {
                    return Err(ApiError::internal("computation semaphore closed"))
                }
                Err(TryAcquireError::NoPermits) => {
                    let _waiting =
                        Waiting::enter(&self.waiting, self.limits.max_queued_computations)
                            .ok_or_else(|| shed("queue_full"))?;
                    tokio::time::timeout(
                        self.limits.queue_timeout,
                        self.slots.clone().acquire_owned(),
                    )
                    .await
                    .map_err(|_| shed("queue_timeout"))?
                    .map_err(|_| ApiError::internal("computation semaphore closed"))?
                }
            };
            tokio::task::spawn_blocking(move || {
                let _permit = permit;
                let _running = Running::enter();
                job()
            })
            .await
            .map_err(|e| ApiError::internal(format!("computation task failed: {e}")))?
        };
        tokio::time::timeout(self.limits.request_timeout, work)
            .await
            .map_err(|_| shed("request_timeout"))?
    }
}

/// A place in the queue for a computation slot, given back on drop.
struct Waiting(Arc<AtomicUsize>);

impl Waiting {
    fn enter(count: &Arc<AtomicUsize>, max: usize) -> Option<Self> {
        count
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < max).then_some(n + 1)
            })
            .ok()?;
        metrics::metrics().waiting.inc();
        Some(Waiting(count.clone()))
    }
}

impl Drop for Waiting {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
        metrics::metrics().waiting.dec();
    }
}

/// A running computation, counted in the in-flight gauge while it lives.
struct Running;

impl Running {
    fn enter() -> Self {
        metrics::metrics().in_flight.inc();
        Running
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        metrics::metrics().in_flight.dec();
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
    let request_id = HeaderName::from_static(metrics::REQUEST_ID);
    let router = Router::new()
        .route("/v1/removal-function", post(removal_function::handler))
        .route("/v1/predict", post(predict::handler))
        .route("/v1/optimize", post(optimize::handler))
        .route("/v1/recommend", post(recommend::handler))
        .route("/v1/studies/eta-sweep", post(eta_sweep::handler))
        .route("/healthz", get(health::healthz))
        .route("/readyz", get(health::readyz))
        .route("/metrics", get(metrics::handler))
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
        .layer(axum::middleware::from_fn(metrics::record))
        .layer(PropagateRequestIdLayer::new(request_id.clone()))
        .layer(
            TraceLayer::new_for_http()
                .make_span_with(|req: &Request| {
                    let id = req
                        .headers()
                        .get(metrics::REQUEST_ID)
                        .and_then(|v| v.to_str().ok())
                        .unwrap_or("-");
                    tracing::info_span!("request", method = %req.method(), path = %req.uri().path(), request_id = %id)
                })
                .on_response(DefaultOnResponse::new().level(Level::INFO)),
        )
        .layer(SetRequestIdLayer::new(request_id, MakeRequestUuid));
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
