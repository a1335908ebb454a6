//! API keys: bearer authentication of `/v1/*` (and of `/metrics` when asked).
//!
//! A request presents `Authorization: Bearer <key>`; `keys::KeySet` identifies it. The key's
//! name (never the key) goes into the request's span, the access log and the `key` label of
//! the request metrics.

use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{header, HeaderValue};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::endpoint::is_api_path;
use super::error::{ApiError, Kind};
use super::state::AppState;
use crate::keys::{Auth, Role};

/// Whether `path` needs a key under `auth`.
fn guards(auth: &Auth, path: &str) -> bool {
    is_api_path(path) || (auth.metrics_need_key && path == "/metrics")
}

/// The authenticated key's name, on the request (for the rate limit) and on the response (for
/// the request metrics).
#[derive(Debug, Clone)]
pub struct KeyName(pub Arc<str>);

/// The authenticated key's role, on the request (record writes need `ReadWrite`).
#[derive(Debug, Clone, Copy)]
pub struct KeyRole(pub Role);

/// Why a request was not authenticated (the problem's detail; never says which keys exist).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyRefusal {
    Missing,
    Malformed,
    Unknown,
}

/// The middleware: guarded paths need a known bearer key when keys are configured.
pub async fn authenticate(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let Some(auth) = state.auth.as_ref() else {
        return next.run(request).await;
    };
    if !guards(auth, request.uri().path()) {
        return next.run(request).await;
    }
    let presented = match request.headers().get(axum::http::header::AUTHORIZATION) {
        None => Err(KeyRefusal::Missing),
        Some(value) => value
            .to_str()
            .ok()
            .and_then(|v| {
                let (scheme, token) = v.split_once(' ')?;
                let token = token.trim();
                (scheme.eq_ignore_ascii_case("bearer") && !token.is_empty())
                    .then(|| token.to_string())
            })
            .ok_or(KeyRefusal::Malformed),
    };
    let name = presented.and_then(|key| {
        auth.keys()
            .identify(&key)
            .map(|(name, role)| (Arc::<str>::from(name), role))
            .ok_or(KeyRefusal::Unknown)
    });
    match name {
        Ok((name, role)) => {
            tracing::Span::current().record("key", &*name);
            let mut request = request;
            request.extensions_mut().insert(KeyName(name.clone()));
            request.extensions_mut().insert(KeyRole(role));
            let mut response = next.run(request).await;
            response.extensions_mut().insert(KeyName(name));
            response
        }
        Err(reason) => ApiError::unauthorized(reason).into_response(),
    }
}

impl ApiError {
    /// A guarded path without a known API key (RFC 6750: no credentials, the bare challenge).
    pub fn unauthorized(reason: KeyRefusal) -> Self {
        let (detail, challenge) = match reason {
            KeyRefusal::Missing => (
                "this path needs an API key: send `Authorization: Bearer <key>`",
                "Bearer realm=\"preston\"",
            ),
            KeyRefusal::Malformed => (
                "the Authorization header must be `Bearer <key>` with a non-empty key",
                "Bearer realm=\"preston\", error=\"invalid_request\"",
            ),
            KeyRefusal::Unknown => (
                "the API key is not valid",
                "Bearer realm=\"preston\", error=\"invalid_token\"",
            ),
        };
        ApiError::new(Kind::Unauthorized, detail).with_header(
            header::WWW_AUTHENTICATE,
            HeaderValue::from_static(challenge),
        )
    }
}
