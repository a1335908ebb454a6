//! The router: the endpoint table (one entry per computing endpoint, driving the routes, the
//! CLI's `compute` command and the OpenAPI operations), the service routes, and the layers every
//! request passes (request id, tracing, metrics, compression, body limit, CORS).

use axum::extract::{DefaultBodyLimit, Request};
use axum::http::{header, HeaderName, HeaderValue, Method};
use axum::routing::{get, post, MethodRouter};
use axum::{Extension, Router};
use tower_http::compression::CompressionLayer;
use tower_http::cors::{AllowOrigin, CorsLayer};
use tower_http::request_id::{MakeRequestUuid, PropagateRequestIdLayer, SetRequestIdLayer};
use tower_http::trace::{DefaultOnResponse, TraceLayer};
use tracing::Level;
use utoipa::openapi::path::Operation;
use utoipa::openapi::{RefOr, Schema};

use super::endpoint::{compute_json as compute_json_of, handler, operation, Endpoint, API_PREFIX};
use super::error::{self, ApiError};
use super::extract::BodyLimit;
use super::state::{AppState, Services};
use super::{auth, ratelimit};
use super::{
    calibration, docs, eta_sweep, health, maps, measurement_fit, metrics, optimize, predict,
    program, recommend, records, removal_function, workbench,
};
use crate::config::ServiceLimits;
use crate::usecases::ComputeLimits;

type ComputeFn = fn(&[u8], &ComputeLimits, &Services) -> Result<String, ApiError>;
type OperationFn = fn(&mut Vec<(String, RefOr<Schema>)>) -> Operation;

/// One computing endpoint, as its [`Endpoint`] implementation registers it.
pub struct EndpointEntry {
    /// The path under `/v1/`, and the name the CLI's `compute` command takes.
    pub name: &'static str,
    /// A request body (a fixture): the OpenAPI example.
    pub example: &'static str,
    route: fn() -> MethodRouter<AppState>,
    /// Takes map files: the map body limit applies.
    large_body: bool,
    compute: ComputeFn,
    /// The OpenAPI operation, adding the schemas it refers to.
    pub operation: OperationFn,
}

impl EndpointEntry {
    /// The route path, `/v1/<name>`.
    pub fn path(&self) -> String {
        format!("{API_PREFIX}{}", self.name)
    }
}

const fn entry<E: Endpoint>() -> EndpointEntry {
    EndpointEntry {
        name: E::NAME,
        example: E::EXAMPLE,
        route: || post(handler::<E>),
        large_body: E::LARGE_BODY,
        compute: compute_json_of::<E>,
        operation: operation::<E>,
    }
}

/// Every computing endpoint, in the order the documentation lists them.
pub static ENDPOINTS: [EndpointEntry; 14] = [
    entry::<removal_function::RemovalFunctionEndpoint>(),
    entry::<predict::PredictEndpoint>(),
    entry::<optimize::OptimizeEndpoint>(),
    entry::<recommend::RecommendEndpoint>(),
    entry::<eta_sweep::EtaSweepEndpoint>(),
    entry::<measurement_fit::MeasurementFitEndpoint>(),
    entry::<program::ProgramEndpoint>(),
    entry::<calibration::CalibrationEndpoint>(),
    entry::<maps::MapAnalysisEndpoint>(),
    entry::<maps::difference::MapDifferenceEndpoint>(),
    entry::<maps::removal_function::MapRemovalFunctionEndpoint>(),
    entry::<maps::predict::MapPredictEndpoint>(),
    entry::<maps::optimize::MapOptimizeEndpoint>(),
    entry::<maps::program::MapProgramEndpoint>(),
];

/// The offline twin of the API: the exact JSON body `POST /v1/<endpoint>` would return.
pub fn compute_json(
    endpoint: &str,
    body: &[u8],
    limits: &ServiceLimits,
) -> Result<String, ApiError> {
    compute_with(endpoint, body, &limits.compute(), &Services::default())
}

/// [`compute_json`] with the use cases' limits and services given.
pub fn compute_with(
    endpoint: &str,
    body: &[u8],
    limits: &ComputeLimits,
    services: &Services,
) -> Result<String, ApiError> {
    let entry = ENDPOINTS
        .iter()
        .find(|e| e.name == endpoint)
        .ok_or_else(|| ApiError::not_found(&format!("{API_PREFIX}{endpoint}")))?;
    (entry.compute)(body, limits, services)
}

/// Cross-origin access: none unless origins are configured (`*` allows any). Browsers may send
/// `content-type`, `accept`, `authorization` (an API key) and `x-request-id`, and read
/// `x-request-id`, `retry-after` and `www-authenticate`.
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
    // A front-end sends JSON with an Accept and its own request id, and reads the request id
    // (to quote in a report) and Retry-After (to back off on a 503).
    let request_id = HeaderName::from_static(metrics::REQUEST_ID);
    Some(
        CorsLayer::new()
            .allow_origin(allow)
            .allow_methods([Method::GET, Method::POST])
            .allow_headers([
                header::CONTENT_TYPE,
                header::ACCEPT,
                header::AUTHORIZATION,
                request_id.clone(),
            ])
            .expose_headers([request_id, header::RETRY_AFTER, header::WWW_AUTHENTICATE]),
    )
}

/// The whole service.
pub fn router(state: AppState, cors: Option<CorsLayer>) -> Router {
    let body_limit = state.limits.max_body_bytes;
    let request_id = HeaderName::from_static(metrics::REQUEST_ID);
    let map_limit = state.limits.max_map_bytes;
    let computing = ENDPOINTS.iter().fold(Router::new(), |router, e| {
        let route: MethodRouter<AppState> = (e.route)();
        // The innermost limit is the one that holds: a map file's, on the map endpoints.
        let route = if e.large_body {
            route
                .layer::<_, std::convert::Infallible>(DefaultBodyLimit::max(map_limit))
                .layer::<_, std::convert::Infallible>(Extension(BodyLimit(map_limit)))
        } else {
            route
        };
        router.route(&e.path(), route)
    });
    let router = computing
        .merge(records::routes())
        .route("/", get(workbench::page))
        .route("/workbench/{name}", get(workbench::asset))
        .route("/healthz", get(health::healthz))
        .route("/readyz", get(health::readyz))
        .route("/metrics", get(metrics::handler))
        .route("/openapi.json", get(docs::openapi_json))
        .route("/docs", get(docs::redirect))
        .route("/docs/", get(docs::asset))
        .route("/docs/{*path}", get(docs::asset))
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(DefaultBodyLimit::max(body_limit))
        .layer(Extension(BodyLimit(body_limit)))
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            ratelimit::limit,
        ))
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            auth::authenticate,
        ))
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            metrics::record,
        ))
        // Problems are written after every layer that may raise one, and before compression.
        .layer(axum::middleware::from_fn(error::render))
        .layer(CompressionLayer::new())
        .with_state(state)
        .layer(PropagateRequestIdLayer::new(request_id.clone()))
        .layer(
            TraceLayer::new_for_http()
                .make_span_with(|req: &Request| {
                    let id = req
                        .headers()
                        .get(metrics::REQUEST_ID)
                        .and_then(|v| v.to_str().ok())
                        .unwrap_or("-");
                    // `key`: the API key's name, once authenticated.
                    tracing::info_span!("request", method = %req.method(), path = %req.uri().path(), request_id = %id, key = tracing::field::Empty)
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
    ApiError::not_found(req.uri().path())
}

async fn method_not_allowed() -> ApiError {
    ApiError::method_not_allowed()
}
