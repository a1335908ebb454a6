//! Per-client rate limits: requests per second with a burst (the generic cell rate algorithm
//! of the `governor` crate), counted per client. A client over its limit is told the whole
//! seconds until one more request would be allowed; other clients are not affected.
//! `http::ratelimit` is the middleware that names the client and answers 429.

use std::net::IpAddr;
use std::num::NonZeroU32;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use governor::clock::{Clock, DefaultClock};
use governor::{DefaultKeyedRateLimiter, Quota};

/// Who a limit counts against.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Client {
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

    /// Requests per second allowed to each client.
    pub fn per_second(&self) -> f64 {
        self.per_second
    }

    /// Requests a client may make at once after a quiet spell.
    pub fn burst(&self) -> u32 {
        self.burst
    }

    /// `Ok` when `client` may go on, else the whole seconds to wait.
    pub fn check(&self, client: &Client) -> Result<(), u64> {
        if self.seen.fetch_add(1, Ordering::Relaxed) % FORGET_EVERY == FORGET_EVERY - 1 {
            self.limiter.retain_recent();
        }
        self.limiter.check_key(client).map_err(|not_until| {
            let wait = not_until.wait_time_from(self.clock.now());
            wait.as_secs() + u64::from(wait.subsec_nanos() > 0)
        })
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
