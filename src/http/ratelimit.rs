//! The rate-limit middleware (the limiter is `crate::ratelimit`): per API key when keys are
//! configured, else per client address when asked (off by default). A request over its client's limit gets 429 problem+json with
//! `Retry-After` (whole seconds until one more request would be allowed); other clients are
//! not affected. The limit guards the same paths as the keys (`/v1/*`).

use std::net::SocketAddr;

use axum::extract::{ConnectInfo, Request, State};
use axum::http::{header, HeaderValue};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::auth::KeyName;
use super::endpoint::is_api_path;
use super::error::{ApiError, Kind};
use super::state::AppState;
use crate::ratelimit::Client;

/// The middleware: inside authentication, so a key's name is known; without keys, by the
/// client's address (the connection's peer).
pub async fn limit(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let Some(limit) = state.rate_limit.as_ref() else {
        return next.run(request).await;
    };
    if !is_api_path(request.uri().path()) {
        return next.run(request).await;
    }
    let client = match request.extensions().get::<KeyName>() {
        Some(name) => Some(Client::Key(name.0.clone())),
        None => request
            .extensions()
            .get::<ConnectInfo<SocketAddr>>()
            .map(|c| Client::Address(c.0.ip())),
    };
    match client.map(|c| limit.check(&c)) {
        Some(Err(retry_after_s)) => {
            ApiError::rate_limited(retry_after_s.max(1), limit.per_second(), limit.burst())
                .into_response()
        }
        _ => next.run(request).await,
    }
}

impl ApiError {
    pub fn rate_limited(retry_after_s: u64, per_second: f64, burst: u32) -> Self {
        ApiError::new(
            Kind::RateLimited,
            format!(
                "this client may make {per_second} requests per second with bursts of {burst}; \
                 retry in {retry_after_s} s"
            ),
        )
        .with_header(header::RETRY_AFTER, HeaderValue::from(retry_after_s))
    }
}
