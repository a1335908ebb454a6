//! The application state every request shares: limits, the services computations use
//! (recommender, metrics), the computation slots with their queue, readiness, and the served
//! documents. Nothing here is global: each service instance (and each test) has its own.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use tokio::sync::{Semaphore, TryAcquireError};
use utoipa_swagger_ui::Config;

use crate::keys::Auth;
use axum::http::{header, HeaderValue};

use super::error::{ApiError, Kind};
use super::openapi;
use super::ratelimit::RateLimit;
use crate::config::Limits;
use crate::telemetry::metrics::Metrics;
use crate::usecases::{ComputeLimits, OperatorCache, Recommender};

/// What a computation may use besides its command.
#[derive(Clone, Default)]
pub struct Services {
    pub recommender: Arc<Recommender>,
    pub operators: Arc<OperatorCache>,
    pub metrics: Arc<Metrics>,
}

/// Shared by every request.
#[derive(Clone)]
pub struct AppState {
    pub limits: Limits,
    /// The part of `limits` the use cases enforce.
    pub compute: ComputeLimits,
    pub services: Services,
    /// API keys, when configured (`None`: every path is open).
    pub auth: Option<Arc<Auth>>,
    /// Per-client rate limit, when configured.
    pub rate_limit: Option<Arc<RateLimit>>,
    slots: Arc<Semaphore>,
    waiting: Arc<AtomicUsize>,
    ready: Arc<AtomicBool>,
    pub(super) openapi_json: Arc<str>,
    pub(super) swagger: Arc<Config<'static>>,
}

impl AppState {
    pub fn new(limits: Limits) -> Self {
        let services = Services {
            operators: Arc::new(OperatorCache::new(limits.operator_cache_bytes)),
            ..Services::default()
        };
        services
            .metrics
            .watch_operator_cache(services.operators.clone())
            .expect("the operator cache's metrics are registered once");
        AppState {
            slots: Arc::new(Semaphore::new(limits.max_concurrent_computations.max(1))),
            waiting: Arc::new(AtomicUsize::new(0)),
            compute: limits.compute(),
            limits,
            services,
            auth: None,
            rate_limit: None,
            ready: Arc::new(AtomicBool::new(true)),
            openapi_json: openapi::spec_json().into(),
            swagger: Arc::new(Config::new(["/openapi.json"]).try_it_out_enabled(true)),
        }
    }

    /// The same state with `auth` guarding `/v1/*` (and `/metrics` if it says so).
    pub fn with_auth(mut self, auth: Arc<Auth>) -> Self {
        self.auth = Some(auth);
        self
    }

    /// The same state with `limit` on each client of `/v1/*`.
    pub fn with_rate_limit(mut self, limit: Arc<RateLimit>) -> Self {
        self.rate_limit = Some(limit);
        self
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
        let metrics = self.services.metrics.clone();
        let retry_after_s = self.limits.queue_timeout.as_secs().max(1);
        let shed = |reason: &str| {
            metrics.shed.with_label_values(&[reason]).inc();
            ApiError::overloaded(retry_after_s)
        };
        let work = async {
            let permit = match self.slots.clone().try_acquire_owned() {
                Ok(permit) => permit,
                Err(TryAcquireError::Closed) => {
                    return Err(ApiError::internal("computation semaphore closed"))
                }
                Err(TryAcquireError::NoPermits) => {
                    let _waiting = Waiting::enter(
                        &self.waiting,
                        self.limits.max_queued_computations,
                        &metrics,
                    )
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
            let running = Running::enter(&metrics);
            tokio::task::spawn_blocking(move || {
                let _permit = permit;
                let _running = running;
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
struct Waiting {
    count: Arc<AtomicUsize>,
    metrics: Arc<Metrics>,
}

impl Waiting {
    fn enter(count: &Arc<AtomicUsize>, max: usize, metrics: &Arc<Metrics>) -> Option<Self> {
        count
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < max).then_some(n + 1)
            })
            .ok()?;
        metrics.waiting.inc();
        Some(Waiting {
            count: count.clone(),
            metrics: metrics.clone(),
        })
    }
}

impl Drop for Waiting {
    fn drop(&mut self) {
        self.count.fetch_sub(1, Ordering::SeqCst);
        self.metrics.waiting.dec();
    }
}

/// A running computation, counted in the in-flight gauge while it lives.
struct Running(Arc<Metrics>);

impl Running {
    fn enter(metrics: &Arc<Metrics>) -> Self {
        metrics.in_flight.inc();
        Running(metrics.clone())
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.0.in_flight.dec();
    }
}

impl ApiError {
    pub fn overloaded(retry_after_s: u64) -> Self {
        ApiError::new(
            Kind::Overloaded,
            format!("all computation slots are busy; retry in {retry_after_s} s"),
        )
        .with_header(header::RETRY_AFTER, HeaderValue::from(retry_after_s))
    }
}
