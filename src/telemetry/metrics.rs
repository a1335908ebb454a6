//! The service's Prometheus metrics (all prefixed `preston_`), in a registry of their own:
//! - `http_requests_total{route, method, status, key}` — requests by matched route
//!   (`unmatched` for 404s, so paths cannot blow up the label set), status code and API key
//!   name (`-` without one);
//! - `http_request_duration_seconds{route}` — latency histogram;
//! - `computations_in_flight`, `computations_waiting` — gauges of the computation slots;
//! - `load_shed_total{reason}` — requests refused with 503 (`queue_full`, `queue_timeout`,
//!   `request_timeout`);
//! - `solver_duration_seconds` — Clarabel solve time histogram;
//! - `solver_status_total{status}` — optimizations by outcome (`solved`, `almost_solved`,
//!   `infeasible`, `time_limit`, `iteration_limit`, `numerical_error`);
//! - `operator_cache_requests_total{result}` — removal operators taken from the cache (`hit`)
//!   or assembled (`miss`); `operator_cache_evictions_total`; `operator_cache_bytes` and
//!   `operator_cache_entries` — what it holds (read from the cache at each scrape).
//!
//! `http::metrics` serves them (`GET /metrics`, text format 0.0.4) and records each request.

use std::sync::{Arc, Mutex};

use crate::optimize::{OptimizeError, Solution, SolveStatus};
use crate::usecases::OperatorCache;
use prometheus::core::{Collector, Desc};
use prometheus::proto::MetricFamily;
use prometheus::{
    Encoder, Histogram, HistogramOpts, HistogramVec, IntCounter, IntCounterVec, IntGauge, Opts,
    Registry, TextEncoder,
};

/// The service's metrics in their own registry, owned by the application state (so every
/// service instance, and every test, counts only its own requests).
pub struct Metrics {
    registry: Registry,
    pub requests: IntCounterVec,
    pub latency: HistogramVec,
    pub in_flight: IntGauge,
    pub waiting: IntGauge,
    pub shed: IntCounterVec,
    pub solver_seconds: Histogram,
    pub solver_status: IntCounterVec,
}

const LATENCY_BUCKETS: [f64; 14] = [
    0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0,
];

impl Default for Metrics {
    fn default() -> Self {
        Metrics::new().expect("metric definitions are valid")
    }
}

impl Metrics {
    fn new() -> prometheus::Result<Self> {
        let registry = Registry::new_custom(Some("preston".into()), None)?;
        let requests = IntCounterVec::new(
            Opts::new(
                "http_requests_total",
                "HTTP requests by route, method and status",
            ),
            &["route", "method", "status", "key"],
        )?;
        let latency = HistogramVec::new(
            HistogramOpts::new("http_request_duration_seconds", "HTTP request latency")
                .buckets(LATENCY_BUCKETS.to_vec()),
            &["route"],
        )?;
        let in_flight = IntGauge::new("computations_in_flight", "Computations running now")?;
        let waiting = IntGauge::new(
            "computations_waiting",
            "Requests waiting for a computation slot",
        )?;
        let shed = IntCounterVec::new(
            Opts::new("load_shed_total", "Requests refused with 503 to shed load"),
            &["reason"],
        )?;
        let solver_seconds = Histogram::with_opts(
            HistogramOpts::new("solver_duration_seconds", "Dwell QP solve time")
                .buckets(LATENCY_BUCKETS.to_vec()),
        )?;
        let solver_status = IntCounterVec::new(
            Opts::new("solver_status_total", "Dwell optimizations by outcome"),
            &["status"],
        )?;
        registry.register(Box::new(requests.clone()))?;
        registry.register(Box::new(latency.clone()))?;
        registry.register(Box::new(in_flight.clone()))?;
        registry.register(Box::new(waiting.clone()))?;
        registry.register(Box::new(shed.clone()))?;
        registry.register(Box::new(solver_seconds.clone()))?;
        registry.register(Box::new(solver_status.clone()))?;
        Ok(Metrics {
            registry,
            requests,
            latency,
            in_flight,
            waiting,
            shed,
            solver_seconds,
            solver_status,
        })
    }

    /// Reports `cache`'s counts and size with the other metrics (once per service).
    pub fn watch_operator_cache(&self, cache: Arc<OperatorCache>) -> prometheus::Result<()> {
        self.registry
            .register(Box::new(OperatorCacheCollector::new(cache)?))
    }

    /// The text exposition of every metric.
    pub fn render(&self) -> String {
        let mut out = Vec::new();
        // Encoding into memory only fails on a malformed metric, which registration prevents.
        let _ = TextEncoder::new().encode(&self.registry.gather(), &mut out);
        String::from_utf8(out).unwrap_or_default()
    }
}

/// How a dwell optimization ended, as the `status` label of `solver_status_total`.
pub fn solver_outcome(result: Result<&Solution, &OptimizeError>) -> Option<&'static str> {
    Some(match result {
        Ok(s) => match s.status {
            SolveStatus::Solved => "solved",
            SolveStatus::AlmostSolved => "almost_solved",
        },
        Err(OptimizeError::Infeasible { .. }) => "infeasible",
        Err(OptimizeError::TimeLimit { .. }) => "time_limit",
        Err(OptimizeError::IterationLimit { .. }) => "iteration_limit",
        Err(OptimizeError::Numerical { .. }) => "numerical_error",
        Err(_) => return None,
    })
}

impl Metrics {
    /// Counts a dwell optimization's outcome and, for a plan, its solve time.
    pub fn record_solver(&self, result: Result<&Solution, &OptimizeError>) {
        if let Ok(s) = result {
            self.solver_seconds.observe(s.solve_time_s);
        }
        if let Some(status) = solver_outcome(result) {
            self.solver_status.with_label_values(&[status]).inc();
        }
    }
}

/// The operator cache's own counts, read at each scrape (the cache is pure and keeps them).
struct OperatorCacheCollector {
    cache: Arc<OperatorCache>,
    requests: IntCounterVec,
    evictions: IntCounter,
    bytes: IntGauge,
    entries: IntGauge,
    /// One scrape at a time sets the metrics from the cache's counts.
    scrape: Mutex<()>,
}

impl OperatorCacheCollector {
    fn new(cache: Arc<OperatorCache>) -> prometheus::Result<Self> {
        Ok(OperatorCacheCollector {
            cache,
            requests: IntCounterVec::new(
                Opts::new(
                    "operator_cache_requests_total",
                    "Removal operators taken from the cache (hit) or assembled (miss)",
                ),
                &["result"],
            )?,
            evictions: IntCounter::with_opts(Opts::new(
                "operator_cache_evictions_total",
                "Operators dropped from the cache to stay within its memory",
            ))?,
            bytes: IntGauge::with_opts(Opts::new(
                "operator_cache_bytes",
                "Memory the cached operators hold",
            ))?,
            entries: IntGauge::with_opts(Opts::new(
                "operator_cache_entries",
                "Operators in the cache",
            ))?,
            scrape: Mutex::new(()),
        })
    }
}

impl Collector for OperatorCacheCollector {
    fn desc(&self) -> Vec<&Desc> {
        let mut all = self.requests.desc();
        all.extend(self.evictions.desc());
        all.extend(self.bytes.desc());
        all.extend(self.entries.desc());
        all
    }

    fn collect(&self) -> Vec<MetricFamily> {
        let _one = self.scrape.lock();
        let stats = self.cache.stats();
        let set = |counter: &IntCounter, value: u64| {
            counter.reset();
            counter.inc_by(value);
        };
        set(&self.requests.with_label_values(&["hit"]), stats.hits);
        set(&self.requests.with_label_values(&["miss"]), stats.misses);
        set(&self.evictions, stats.evictions);
        self.bytes.set(stats.bytes as i64);
        self.entries.set(stats.entries as i64);
        let mut families = self.requests.collect();
        families.extend(self.evictions.collect());
        families.extend(self.bytes.collect());
        families.extend(self.entries.collect());
        families
    }
}
