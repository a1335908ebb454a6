//! The application state every request shares: limits, the services computations use
//! (recommender, metrics), the computation slots with their queue, readiness, and the served
//! documents. Nothing here is global: each service instance (and each test) has its own.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use utoipa_swagger_ui::Config;

use crate::keys::Auth;
use axum::http::{header, HeaderValue};

use super::error::{ApiError, Kind};
use super::openapi;
use crate::config::ServiceLimits;
use crate::ratelimit::RateLimit;
use crate::slots::{ComputeSlots, Refusal, SlotLimits};
use crate::store::Store;
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
    pub limits: ServiceLimits,
    /// The part of `limits` the use cases enforce.
    pub compute: ComputeLimits,
    pub services: Services,
    /// API keys, when configured (`None`: every path is open).
    pub auth: Option<Arc<Auth>>,
    /// Per-client rate limit, when configured.
    pub rate_limit: Option<Arc<RateLimit>>,
    /// The records store, when the service runs with one (compute endpoints never use it).
    pub store: Option<Store>,
    slots: ComputeSlots,
    ready: Arc<AtomicBool>,
    pub(super) openapi_json: Arc<str>,
    pub(super) swagger: Arc<Config<'static>>,
    /// The workbench page with its first answers, made on the first request for it.
    pub(super) workbench_page: Arc<tokio::sync::OnceCell<Arc<str>>>,
    /// Which build renders the records ([`build_identity`]): part of every record ETag.
    pub(super) build: Arc<str>,
}

/// The build as the record ETags name it: the crate version, git revision and records schema,
/// and the running executable's length and modification time, which differ between builds
/// even of one revision (uncommitted changes). Without the executable's metadata, a value of
/// this process alone: tags then change at a restart, never go stale.
fn build_identity() -> String {
    let executable = std::env::current_exe().and_then(std::fs::metadata);
    let stamp = executable.ok().and_then(|m| {
        let modified = m
            .modified()
            .ok()?
            .duration_since(std::time::UNIX_EPOCH)
            .ok()?;
        Some(format!("{} bytes, {} ns", m.len(), modified.as_nanos()))
    });
    let stamp = stamp.unwrap_or_else(|| format!("process {}", uuid::Uuid::now_v7()));
    format!("{}; {stamp}", crate::store::computed_by())
}

impl AppState {
    pub fn new(limits: ServiceLimits) -> Self {
        let services = Services {
            operators: Arc::new(OperatorCache::new(limits.operator_cache_bytes)),
            ..Services::default()
        };
        services
            .metrics
            .watch_operator_cache(services.operators.clone())
            .expect("the operator cache's metrics are registered once");
        AppState {
            slots: ComputeSlots::new(
                SlotLimits {
                    slots: limits.max_concurrent_computations,
                    max_queued: limits.max_queued_computations,
                    queue_timeout: limits.queue_timeout,
                    request_timeout: limits.request_timeout,
                },
                services.metrics.clone(),
            ),
            compute: limits.compute(),
            limits,
            services,
            auth: None,
            rate_limit: None,
            store: None,
            ready: Arc::new(AtomicBool::new(true)),
            openapi_json: openapi::spec_json().into(),
            // No validator: its default is an outside host, which a shop network may not reach
            // and which would learn of the document.
            swagger: Arc::new(
                Config::new(["/openapi.json"])
                    .try_it_out_enabled(true)
                    .validator_url("none"),
            ),
            workbench_page: Arc::default(),
            build: build_identity().into(),
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

    pub fn with_store(mut self, store: Store) -> Self {
        self.store = Some(store);
        self
    }

    /// Marks the service as not ready (e.g. while shutting down); `/readyz` then answers 503.
    pub fn set_ready(&self, ready: bool) {
        self.ready.store(ready, Ordering::SeqCst);
    }

    pub fn is_ready(&self) -> bool {
        self.ready.load(Ordering::SeqCst)
    }

    /// Runs `job` on the blocking pool once a computation slot is free (`crate::slots`: a
    /// refusal is a 503 with Retry-After).
    pub async fn run<T, F>(&self, job: F) -> Result<T, ApiError>
    where
        T: Send + 'static,
        F: FnOnce() -> Result<T, ApiError> + Send + 'static,
    {
        self.slots.run(job).await
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

impl From<Refusal> for ApiError {
    fn from(refusal: Refusal) -> Self {
        match refusal {
            Refusal::Shed { retry_after_s, .. } => ApiError::overloaded(retry_after_s),
            Refusal::Failed(reason) => ApiError::internal(reason),
        }
    }
}
