//! The record endpoints: process profiles and their calibrations, parts, measurements, plans,
//! runs and a part's history (`usecases::records` states the cycle and the learned rate).
//!
//! Their conventions, written once here: records are immutable; a write is one transaction
//! and is answered 201 with `Location` only after it committed; a POST may carry an
//! `Idempotency-Key` (1–255 visible ASCII characters): the first answer is kept with the
//! records in the same transaction, a retry gets it again (never a duplicate), and the same key
//! with another request is a 422 (as the IETF draft says); GETs carry a strong `ETag` (and answer 304 to a matching
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
use axum::routing::{get, post};
use axum::Router;
use serde::Serialize;
use serde_json::{Map, Value};
use sha2::{Digest, Sha256};

use super::auth::{KeyName, KeyRole};
use super::endpoint::Endpoint;
use super::error::{ApiError, Kind};
use super::extract;
use super::state::AppState;
use crate::keys::Role;
use crate::store::{new_stamp, Store};
use crate::usecases::records::{Claim, Record, Records, RecordsError, Replay, Stamp, Written};

pub use docs::{document_operations, schemas};

/// The record routes.
pub fn routes() -> Router<AppState> {
    Router::new()
        .route(
            "/v1/process-profiles",
            post(profiles::create).get(profiles::list),
        )
        .route("/v1/process-profiles/{name}", get(profiles::show))
        .route(
            "/v1/process-profiles/{name}/calibrations",
            post(profiles::calibrate),
        )
        .route("/v1/calibrations/{id}", get(profiles::calibration))
        .route("/v1/parts", post(parts::create).get(parts::list))
        .route("/v1/parts/{id}", get(parts::show))
        .route("/v1/parts/{id}/measurements", post(parts::measure))
        .route("/v1/measurements/{id}", get(parts::measurement))
        .route("/v1/parts/{id}/plans", post(cycles::plan))
        .route("/v1/plans/{id}", get(cycles::show_plan))
        .route("/v1/plans/{id}/program", post(cycles::program))
        .route("/v1/parts/{id}/runs", post(cycles::run))
        .route("/v1/runs/{id}", get(cycles::show_run))
        .route("/v1/parts/{id}/history", get(cycles::history))
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

/// A record write in progress: the caller, checked for the right to write, and its
/// Idempotency-Key with the request's fingerprint.
pub struct Write {
    caller: Writer,
    claim: Option<(String, String)>,
}

pub const IDEMPOTENCY_KEY: &str = "idempotency-key";

impl Write {
    /// Refuses a malformed Idempotency-Key (422); `request` is the request's identity for the
    /// key (path and canonical body).
    fn begin(caller: Writer, headers: &HeaderMap, request: &str) -> Result<Write, ApiError> {
        let claim = match headers.get(IDEMPOTENCY_KEY) {
            None => None,
            Some(value) => {
                let key = value
                    .to_str()
                    .ok()
                    .filter(|k| (1..=255).contains(&k.len()) && k.bytes().all(|b| b.is_ascii_graphic()))
                    .ok_or_else(|| {
                        ApiError::invalid(
                            "Idempotency-Key",
                            "an Idempotency-Key is 1 to 255 visible ASCII characters (a UUID will do)",
                        )
                    })?;
                let fingerprint: String = Sha256::digest(request.as_bytes())
                    .iter()
                    .map(|b| format!("{b:02x}"))
                    .collect();
                Some((key.to_string(), fingerprint))
            }
        };
        Ok(Write { caller, claim })
    }

    /// The first answer under this key, when there is one (before any work is done).
    async fn replay(&self, store: &Store) -> Result<Option<Response>, ApiError> {
        let Some((key, fingerprint)) = &self.claim else {
            return Ok(None);
        };
        match store.claimed(&self.caller.name, key).await? {
            None => Ok(None),
            Some((first, replay)) if &first == fingerprint => Ok(Some(replayed(replay))),
            Some(_) => Err(key_reused()),
        }
    }

    fn stamp(&self) -> Stamp {
        new_stamp(&self.caller.name)
    }

    /// Writes `records` (and the claim) in one transaction; 201 with `Location` once committed.
    /// `taken` is the 409's words when a record has a unique name.
    async fn commit(
        self,
        store: &Store,
        records: &[Record],
        location: String,
        body: &impl Serialize,
        taken: Option<&str>,
    ) -> Result<Response, ApiError> {
        let body = serde_json::to_string(body).map_err(|e| ApiError::internal(e.to_string()))?;
        let claim = self.claim.map(|(key, fingerprint)| Claim {
            owner: self.caller.name.to_string(),
            key,
            fingerprint,
            answer: Replay {
                status: 201,
                location: location.clone(),
                body: body.clone(),
            },
        });
        match store.write(records, claim.as_ref()).await? {
            Written::Committed => Ok(replayed(Replay {
                status: 201,
                location,
                body,
            })),
            Written::Replayed(replay) => Ok(replayed(replay)),
            Written::KeyReused => Err(key_reused()),
            // Only a unique name can be taken; ids are fresh UUIDv7s.
            Written::Taken => Err(match taken {
                Some(taken) => ApiError::new(Kind::Conflict, taken),
                None => ApiError::internal("a fresh record id collided"),
            }),
        }
    }
}

/// 422, as the IETF's Idempotency-Key draft says for a key reused with another payload.
fn key_reused() -> ApiError {
    ApiError::invalid(
        "Idempotency-Key",
        "this Idempotency-Key was sent before with another request: use a new key for a new request",
    )
}

fn replayed(replay: Replay) -> Response {
    let status = StatusCode::from_u16(replay.status).unwrap_or(StatusCode::CREATED);
    let mut response = (
        status,
        [(header::CONTENT_TYPE, "application/json")],
        replay.body,
    )
        .into_response();
    if let Ok(location) = HeaderValue::from_str(&replay.location) {
        response.headers_mut().insert(header::LOCATION, location);
    }
    response
}

/// A GET's JSON body with a strong ETag (a digest of the body), or 304 when the client has it.
fn fetched(headers: &HeaderMap, body: &impl Serialize) -> Result<Response, ApiError> {
    let body = serde_json::to_string(body).map_err(|e| ApiError::internal(e.to_string()))?;
    let digest = Sha256::digest(body.as_bytes());
    let tag: String = digest[..16].iter().map(|b| format!("{b:02x}")).collect();
    let etag = format!("\"{tag}\"");
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
            (
                header::CONTENT_TYPE,
                HeaderValue::from_static("application/json"),
            ),
            (header::ETAG, etag),
        ],
        body,
    )
        .into_response())
}

fn not_found(what: &str, id: &str) -> ApiError {
    ApiError::new(Kind::NotFound, format!("there is no {what} `{id}`"))
}

/// A stored document (JSON text this layer wrote).
fn document(text: &str) -> Result<Value, ApiError> {
    serde_json::from_str(text).map_err(|e| ApiError::internal(format!("a stored record: {e}")))
}

/// A request body that must not name `fields` (the record supplies them).
fn without(
    mut body: Map<String, Value>,
    fields: &[(&str, &str)],
) -> Result<Map<String, Value>, ApiError> {
    for (field, from) in fields {
        if body.contains_key(*field) {
            return Err(ApiError::invalid(
                *field,
                format!("`{field}` comes from {from}: leave it out"),
            ));
        }
    }
    body.retain(|_, v| !v.is_null());
    Ok(body)
}

/// Runs endpoint `E` on a request assembled from records: parsed (errors name its fields),
/// computed in a slot, answered as its JSON body.
async fn compute<E: Endpoint>(
    state: &AppState,
    request: &Map<String, Value>,
) -> Result<Value, ApiError> {
    let bytes = serde_json::to_vec(request).map_err(|e| ApiError::internal(e.to_string()))?;
    let command = E::parse(extract::parse_json(&bytes)?, &state.compute)?;
    let services = state.services.clone();
    let output = state.run(move || E::run(command, &services)).await?;
    serde_json::to_value(E::respond(output)).map_err(|e| ApiError::internal(e.to_string()))
}
