//! Per-client rate limits: requests per second with a burst (the generic cell rate algorithm
//! of the `governor` crate), per API key when keys are configured, else per client address
//! when asked (off by default). A request over its client's limit gets 429 problem+json with
//! `Retry-After` (whole seconds until one more request would be allowed); other clients are
//! not affected. The limit guards the same paths as the keys (`/v1/*`).

use std::net::{IpAddr, SocketAddr};
use std::num::NonZeroU32;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use axum::extract::{ConnectInfo, Request, State};
use axum::http::{header, HeaderValue};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use governor::clock::{Clock, DefaultClock};
use governor::{DefaultKeyedRateLimiter, Quota};

use super::auth::KeyName;
use super::endpoint::is_api_path;
use super::error::{ApiError, Kind};
use super::state::AppState;

/// Who a limit counts against.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
enum Client {
    Key(Arc<str>),
    Address(IpAddr),
}

/// The limiter: one cell-rate state per client.
pub struct RateLimit {
    limiter: DefaultKeyedRateLimiter<Client>,
    clock: DefaultClock,
    per_second: f64,
    burst: u32,
    /// Requests seen, to forget idle clients now and then (addresses are not bounded).
    seen: AtomicU64,
}

impl std::fmt::Debug for RateLimit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RateLimit")
            .field("per_second", &self.per_second)
            .field("burst", &self.burst)
            .finish()
    }
}

/// Every this many requests, the states of clients back at a full burst are dropped.
const FORGET_EVERY: u64 = 4096;

impl RateLimit {
    /// `per_second` requests per second (> 0, finite) with bursts of `burst` (≥ 1); `None` when
    /// either is out of range.
    pub fn new(per_second: f64, burst: u32) -> Option<Self> {
        if !(per_second.is_finite() && per_second > 0.0) {
            return None;
        }
        let period = Duration::try_from_secs_f64(1.0 / per_second)
            .ok()
            .filter(|p| !p.is_zero())?;
        let quota = Quota::with_period(period)?.allow_burst(NonZeroU32::new(burst)?);
        Some(RateLimit {
            limiter: DefaultKeyedRateLimiter::dashmap(quota),
            clock: DefaultClock::default(),
            per_second,
            burst,
            seen: AtomicU64::new(0),
        })
    }

    /// `Ok` when `client` may go on, else the whole seconds to wait.
    fn check(&self, client: &Client) -> Result<(), u64> {
        if self.seen.fetch_add(1, Ordering::Relaxed) % FORGET_EVERY == FORGET_EVERY - 1 {
            self.limiter.retain_recent();
        }
        self.limiter.check_key(client).map_err(|not_until| {
            let wait = not_until.wait_time_from(self.clock.now());
            wait.as_secs() + u64::from(wait.subsec_nanos() > 0)
        })
    }
}

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
            ApiError::rate_limited(retry_after_s.max(1), limit.per_second, limit.burst)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_burst_is_allowed_then_refused_per_client() {
        let limit = RateLimit::new(0.5, 3).unwrap();
        let a = Client::Key("a".into());
        let b = Client::Key("b".into());
        for _ in 0..3 {
            assert_eq!(limit.check(&a), Ok(()));
        }
        // One more every 2 s: the next is about 2 s away.
        assert_eq!(limit.check(&a), Err(2));
        assert_eq!(limit.check(&b), Ok(()));
        assert!(RateLimit::new(0.0, 3).is_none());
        assert!(RateLimit::new(f64::NAN, 3).is_none());
        assert!(RateLimit::new(1.0, 0).is_none());
    }
}
