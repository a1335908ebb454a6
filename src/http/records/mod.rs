//! The record endpoints: process profiles and their calibrations, parts, measurements, plans,
//! runs and a part's history. What each does is `ledger`'s (composing its computation from the
//! records, the write's transaction); `usecases::records` states the cycle and the learned
//! rate; this layer maps requests and records to the wire and implements `ledger::Compute`.
//!
//! Their conventions, written once here: records are immutable; a write is one transaction
//! and is answered 201 with `Location` only after it committed; a POST may carry an
//! `Idempotency-Key` (1–255 visible ASCII characters): the first answer is kept with the
//! records in the same transaction, a retry gets it again (never a duplicate), and the same key
//! with another request is a 422 (as the IETF draft says); GETs carry a strong `ETag` made from the ids of the records they render and the build (and answer 304 to a matching
//! `If-None-Match`); timestamps are RFC 3339 UTC; every record keeps the name of the API key
//! that wrote it; a read-only key (`:read` in the keys file) gets 403 on every record write.
//! Without a reachable store the record endpoints answer 503; compute endpoints never wait on it.

pub mod cycles;
mod docs;
mod dto;
pub mod parts;
pub mod profiles;

use std::sync::Arc;

use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Router;
use serde::Serialize;
use serde_json::Value;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::auth::{KeyName, KeyRole};
use super::calibration::CalibrationEndpoint;
use super::dto::setting_of;
use super::endpoint::Endpoint;
use super::error::{ApiError, Kind};
use super::extract;
use super::maps::body::MapForm;
use super::maps::difference::MapDifferenceEndpoint;
use super::maps::optimize::MapOptimizeEndpoint;
use super::maps::MapAnalysisEndpoint;
use super::measurement_fit::MeasurementFitEndpoint;
use super::optimize::OptimizeEndpoint;
use super::recommend::RecommendRequest;
use super::state::AppState;
use crate::keys::Role;
use crate::ledger::{
    Answer, Computation, Compute, Document, LedgerError, MapFile, SettingOwner, Write,
};
use crate::store::Store;
use crate::usecases::records::{Record, RecordsError, Replay};

pub use docs::schemas;

/// The record operations: each route and its OpenAPI path declared once, by its handler's
/// `#[utoipa::path]` (utoipa-axum reads the path and method from it).
fn operations() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(profiles::create, profiles::list))
        .routes(routes!(profiles::show))
        .routes(routes!(profiles::calibrate))
        .routes(routes!(profiles::calibration))
        .routes(routes!(parts::create, parts::list))
        .routes(routes!(parts::show))
        .routes(routes!(parts::measure))
        .routes(routes!(parts::measurement))
        .routes(routes!(parts::measurement_map))
        .routes(routes!(cycles::plan))
        .routes(routes!(cycles::show_plan))
        .routes(routes!(cycles::program))
        .routes(routes!(cycles::run))
        .routes(routes!(cycles::show_run))
        .routes(routes!(cycles::history))
}

/// The record routes.
pub fn routes() -> Router<AppState> {
    operations().split_for_parts().0
}

/// The record operations' OpenAPI paths (and the schemas they name).
pub fn paths() -> utoipa::openapi::OpenApi {
    operations().split_for_parts().1
}

impl From<RecordsError> for ApiError {
    fn from(error: RecordsError) -> Self {
        tracing::warn!(%error, "records store");
        ApiError::new(
            Kind::StoreUnavailable,
            "the records store does not answer; compute endpoints still do — retry later",
        )
        .with_header(header::RETRY_AFTER, HeaderValue::from_static("5"))
    }
}

/// The store, or 503 when the service runs without one.
fn store(state: &AppState) -> Result<&Store, ApiError> {
    state
        .store
        .as_ref()
        .ok_or_else(|| RecordsError::Unavailable("this service runs without a store".into()).into())
}

/// Who writes: the API key's name (empty without keys). Extracted before the body, so a
/// read-only key gets its 403 whatever it sent.
pub struct Writer {
    name: Arc<str>,
}

impl<S: Send + Sync> FromRequestParts<S> for Writer {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Self, ApiError> {
        let name = parts
            .extensions
            .get::<KeyName>()
            .map_or_else(|| Arc::from(""), |k| k.0.clone());
        let role = parts
            .extensions
            .get::<KeyRole>()
            .map_or(Role::ReadWrite, |r| r.0);
        if role == Role::Read {
            return Err(ApiError::new(
                Kind::Forbidden,
                format!("the API key `{name}` is read-only: it may compute and read records, not write them"),
            ));
        }
        Ok(Writer { name })
    }
}

pub const IDEMPOTENCY_KEY: &str = "idempotency-key";

/// Begins a write by `caller`, with the request's Idempotency-Key when it sent one; `request`
/// is the request's identity for the key (its path and canonical body).
fn begin<'s>(
    store: &'s Store,
    caller: &Writer,
    headers: &HeaderMap,
    operation: &str,
    body: &Value,
) -> Result<Write<'s>, ApiError> {
    let key = headers.get(IDEMPOTENCY_KEY).map(HeaderValue::as_bytes);
    Ok(Write::begin(store, &caller.name, key, operation, body)?)
}

/// The record collections whose path two operations share (create and list).
const PARTS: &str = "/v1/parts";
const PROCESS_PROFILES: &str = "/v1/process-profiles";

/// Commits a write whose answer is `dto`, the record `id` of `collection` (its Location is
/// `collection/id`); when a retry under the same key won meanwhile, answers as that one did
/// (`render`, as for [`replayed`]).
async fn commit<T, F, Fut>(
    write: Write<'_>,
    records: &[Record],
    (collection, id): (&str, String),
    dto: &T,
    taken: Option<&str>,
    render: F,
) -> Result<Response, ApiError>
where
    T: Serialize,
    F: FnOnce(String) -> Fut,
    Fut: std::future::Future<Output = Result<T, ApiError>>,
{
    let location = format!("{collection}/{id}");
    match write.commit(records, location.clone(), id, taken).await? {
        Answer::Fresh => Ok(answer(StatusCode::CREATED, &location, to_json(dto)?)),
        Answer::Replay(replay) => replayed(replay, render).await,
    }
}

impl From<LedgerError> for ApiError {
    fn from(error: LedgerError) -> Self {
        match error {
            LedgerError::Invalid { field, detail } => ApiError::invalid(field, detail),
            LedgerError::NotFound { what, id } => {
                ApiError::new(Kind::NotFound, format!("there is no {what} `{id}`"))
            }
            LedgerError::Taken(taken) => ApiError::new(Kind::Conflict, taken),
            LedgerError::Store(error) => error.into(),
            LedgerError::Broken(defect) => ApiError::internal(defect),
        }
    }
}

/// A problem in a log line (the ledger logs a cycle whose removal determines no calibration):
/// its detail.
impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.detail)
    }
}

/// The record use cases' computations: the compute endpoints' own parse (problems name the
/// request's fields) and run, in a computation slot.
impl Compute for AppState {
    type Problem = ApiError;

    async fn compute(&self, what: Computation, request: &Document) -> Result<Value, ApiError> {
        computation(self, what, request, &[]).await
    }

    async fn compute_with_maps(
        &self,
        what: Computation,
        request: &Document,
        files: &[MapFile<'_>],
    ) -> Result<Value, ApiError> {
        computation(self, what, request, files).await
    }

    fn refuses(problem: &ApiError) -> bool {
        problem.kind.meta().2.is_client_error()
    }

    fn check_setting(&self, setting: &Document, of: SettingOwner) -> Result<(), ApiError> {
        // A setting (process, surface, tool, grid, aperture) is a recommendation request
        // without its options: read as one, and checked by the setting parser alone.
        let bytes = serde_json::to_vec(setting).map_err(|e| ApiError::internal(e.to_string()))?;
        let request: RecommendRequest = extract::parse_json(&bytes)?;
        setting_of!(request)
            .parse(&self.compute)
            .map(|_| ())
            .map_err(|e| match (of, e.field.as_deref()) {
                // A part's workpiece radius is its own field.
                (SettingOwner::Part, Some("process.workpiece_radius_mm")) => {
                    e.at("workpiece_radius_mm")
                }
                _ => e,
            })
    }
}

/// The first answer under an Idempotency-Key again: its status and Location, and its body —
/// the record it created rendered as that answer showed it (`render` from the record's id;
/// records are immutable), or the body an older claim kept.
async fn replayed<T, F, Fut>(replay: Replay, render: F) -> Result<Response, ApiError>
where
    T: Serialize,
    F: FnOnce(String) -> Fut,
    Fut: std::future::Future<Output = Result<T, ApiError>>,
{
    let status = StatusCode::from_u16(replay.status).unwrap_or(StatusCode::CREATED);
    let body = if replay.body.is_empty() {
        to_json(&render(replay.record).await?)?
    } else {
        replay.body
    };
    Ok(answer(status, &replay.location, body))
}

fn to_json(body: &impl Serialize) -> Result<String, ApiError> {
    serde_json::to_string(body).map_err(|e| ApiError::internal(e.to_string()))
}

/// A write's answer: `status`, JSON `body`, `Location`.
fn answer(status: StatusCode, location: &str, body: String) -> Response {
    let mut response = (status, [(header::CONTENT_TYPE, "application/json")], body).into_response();
    if let Ok(location) = HeaderValue::from_str(location) {
        response.headers_mut().insert(header::LOCATION, location);
    }
    response
}

/// A strong validator for the view `view` (the route, so two views never share a tag) that
/// this build renders from the records `ids` (and any other text that shapes it, such as a
/// page's cursor): records are never updated, so an id names content fixed at write, and the
/// build ([`AppState`]'s) names the rendering. Nothing of the body is serialized or hashed.
fn tag<'a>(state: &AppState, view: &str, ids: impl IntoIterator<Item = &'a str>) -> String {
    let mut text = format!("{}\n{view}", state.build);
    for id in ids {
        text.push('\n');
        text.push_str(id);
    }
    format!("\"{}\"", &crate::store::sha256_hex(text.as_bytes())[..32])
}

/// A GET's JSON body `body()` with its strong ETag `etag` ([`tag`]), or 304 without rendering
/// it when the client has it.
fn fetched<T: Serialize>(
    headers: &HeaderMap,
    etag: String,
    body: impl FnOnce() -> Result<T, ApiError>,
) -> Result<Response, ApiError> {
    fetched_as(headers, etag, "application/json", || {
        serde_json::to_vec(&body()?).map_err(|e| ApiError::internal(e.to_string()))
    })
}

/// [`fetched`] for a body of any `media_type`.
fn fetched_as(
    headers: &HeaderMap,
    etag: String,
    media_type: &'static str,
    body: impl FnOnce() -> Result<Vec<u8>, ApiError>,
) -> Result<Response, ApiError> {
    let matches = headers
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.split(',').any(|t| t.trim() == etag || t.trim() == "*"));
    let etag = HeaderValue::from_str(&etag).expect("hex in quotes is a header value");
    if matches {
        return Ok((StatusCode::NOT_MODIFIED, [(header::ETAG, etag)]).into_response());
    }
    Ok((
        [
            (header::CONTENT_TYPE, HeaderValue::from_static(media_type)),
            (header::ETAG, etag),
        ],
        body()?,
    )
        .into_response())
}

/// Runs endpoint `E` on a request assembled from records: parsed (errors name its fields),
/// computed in a slot, answered as its JSON body.
async fn compute<E: Endpoint>(state: &AppState, request: &Document) -> Result<Value, ApiError> {
    compute_request::<E>(state, parsed::<E>(request)?).await
}

/// `request` as endpoint `E` reads its body.
fn parsed<E: Endpoint>(request: &Document) -> Result<E::Request, ApiError> {
    let bytes = serde_json::to_vec(request).map_err(|e| ApiError::internal(e.to_string()))?;
    extract::parse_json(&bytes)
}

/// Runs endpoint `E` on its request, as the endpoint would, and answers its JSON.
async fn compute_request<E: Endpoint>(
    state: &AppState,
    request: E::Request,
) -> Result<Value, ApiError> {
    let command = E::parse(request, &state.compute)?;
    let services = state.services.clone();
    let output = state.run(move || E::run(command, &services)).await?;
    serde_json::to_value(E::respond(output)).map_err(|e| ApiError::internal(e.to_string()))
}

/// Runs `what` on `request` with map `files` (none but for the map computations).
async fn computation(
    state: &AppState,
    what: Computation,
    request: &Document,
    files: &[MapFile<'_>],
) -> Result<Value, ApiError> {
    match what {
        Computation::MeasurementFit => compute::<MeasurementFitEndpoint>(state, request).await,
        Computation::Calibration if files.is_empty() => {
            compute::<CalibrationEndpoint>(state, request).await
        }
        Computation::Calibration => {
            let request = parsed::<CalibrationEndpoint>(request)?.with_map_files(files)?;
            compute_request::<CalibrationEndpoint>(state, request).await
        }
        Computation::Optimize => compute::<OptimizeEndpoint>(state, request)
            .await
            .map_err(|e| e.mismatch_as_invalid(RADIAL_PLAN)),
        Computation::MapOptimize => compute_maps::<MapOptimizeEndpoint>(state, request, files)
            .await
            .map_err(|e| e.mismatch_as_invalid(POLAR_PLAN)),
        Computation::MapAnalysis => {
            compute_maps::<MapAnalysisEndpoint>(state, request, files).await
        }
        Computation::MapDifference => {
            compute_maps::<MapDifferenceEndpoint>(state, request, files).await
        }
    }
}

/// What a radial plan's request takes, and how a polar plan is asked for: a records body is
/// either kind's, so a member of the other kind is an invalid input saying so
/// ([`ApiError::mismatch_as_invalid`]).
const RADIAL_PLAN: &str = "a radial plan is a `/v1/optimize` request (a polar plan \
     says `machine.kinematics: polar` and is a `/v1/maps/optimize` request)";
/// What a polar plan's request takes.
const POLAR_PLAN: &str = "a polar plan is a `/v1/maps/optimize` request";

/// [`compute`] for an endpoint that reads map files: each file put in its request member.
async fn compute_maps<E: Endpoint>(
    state: &AppState,
    request: &Document,
    files: &[MapFile<'_>],
) -> Result<Value, ApiError>
where
    E::Request: MapForm,
{
    let mut request = parsed::<E>(request)?;
    for (member, file) in files {
        request.set_file(member, axum::body::Bytes::copy_from_slice(file));
    }
    compute_request::<E>(state, request).await
}

/// A record's `computed_by` as its wire form: null for one written before it was kept.
fn computed_by(stamp: &crate::usecases::records::Stamp) -> Option<String> {
    (!stamp.computed_by.is_empty()).then(|| stamp.computed_by.clone())
}
