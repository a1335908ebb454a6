//! Computation slots and their queue: how many computations run at once, how many requests
//! may wait for one, and for how long.
//!
//! Load shedding: at most `max_queued` jobs wait for a slot (more are refused at once), none
//! waits longer than `queue_timeout`, and the whole wait plus computation is bounded by
//! `request_timeout`. A computation that outlives its request keeps its slot until it ends, so
//! the number running never exceeds the slots. The gauges and the refusal counter live in the
//! metrics registry (`telemetry::metrics`).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use tokio::sync::{Semaphore, TryAcquireError};

use crate::telemetry::metrics::Metrics;

/// Why a job did not run to its end.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Refusal {
    /// Load shed; worth retrying after `retry_after_s` (the queue timeout, at least 1 s).
    Shed { reason: Shed, retry_after_s: u64 },
    /// The blocking task failed (a panic) or the slots were closed.
    Failed(String),
}

/// Why load was shed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shed {
    /// The queue already held its most.
    QueueFull,
    /// No slot came free within the queue timeout.
    QueueTimeout,
    /// The wait plus the computation outlasted the request timeout.
    RequestTimeout,
}

impl Shed {
    /// The `reason` label of `load_shed_total`.
    fn label(self) -> &'static str {
        match self {
            Shed::QueueFull => "queue_full",
            Shed::QueueTimeout => "queue_timeout",
            Shed::RequestTimeout => "request_timeout",
        }
    }
}

/// The sizes and timeouts of the slots.
#[derive(Debug, Clone, Copy)]
pub struct SlotLimits {
    /// Computations running at once (at least 1).
    pub slots: usize,
    pub max_queued: usize,
    pub queue_timeout: Duration,
    pub request_timeout: Duration,
}

/// Shared by every request of one service instance.
#[derive(Clone)]
pub struct ComputeSlots {
    limits: SlotLimits,
    free: Arc<Semaphore>,
    waiting: Arc<AtomicUsize>,
    metrics: Arc<Metrics>,
}

impl ComputeSlots {
    pub fn new(limits: SlotLimits, metrics: Arc<Metrics>) -> Self {
        ComputeSlots {
            free: Arc::new(Semaphore::new(limits.slots.max(1))),
            waiting: Arc::new(AtomicUsize::new(0)),
            limits,
            metrics,
        }
    }

    /// Runs `job` on the blocking pool once a slot is free; a refusal becomes `E`.
    pub async fn run<T, E, F>(&self, job: F) -> Result<T, E>
    where
        T: Send + 'static,
        E: From<Refusal> + Send + 'static,
        F: FnOnce() -> Result<T, E> + Send + 'static,
    {
        let work = async {
            let permit = match self.free.clone().try_acquire_owned() {
                Ok(permit) => permit,
                Err(TryAcquireError::Closed) => return Err(closed()),
                Err(TryAcquireError::NoPermits) => {
                    let _waiting =
                        Waiting::enter(self).ok_or_else(|| self.shed(Shed::QueueFull))?;
                    tokio::time::timeout(
                        self.limits.queue_timeout,
                        self.free.clone().acquire_owned(),
                    )
                    .await
                    .map_err(|_| self.shed(Shed::QueueTimeout))?
                    .map_err(|_| closed())?
                }
            };
            let running = Running::enter(&self.metrics);
            tokio::task::spawn_blocking(move || {
                let _permit = permit;
                let _running = running;
                job()
            })
            .await
            .map_err(|e| E::from(Refusal::Failed(format!("computation task failed: {e}"))))?
        };
        tokio::time::timeout(self.limits.request_timeout, work)
            .await
            .map_err(|_| self.shed(Shed::RequestTimeout))?
    }

    /// Counts shed load, and makes it the caller's error.
    fn shed<E: From<Refusal>>(&self, reason: Shed) -> E {
        self.metrics.shed.with_label_values(&[reason.label()]).inc();
        E::from(Refusal::Shed {
            reason,
            retry_after_s: self.limits.queue_timeout.as_secs().max(1),
        })
    }
}

fn closed<E: From<Refusal>>() -> E {
    E::from(Refusal::Failed("computation semaphore closed".to_string()))
}

/// A place in the queue for a slot, given back on drop.
struct Waiting {
    count: Arc<AtomicUsize>,
    metrics: Arc<Metrics>,
}

impl Waiting {
    fn enter(slots: &ComputeSlots) -> Option<Self> {
        let max = slots.limits.max_queued;
        slots
            .waiting
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < max).then_some(n + 1)
            })
            .ok()?;
        slots.metrics.waiting.inc();
        Some(Waiting {
            count: slots.waiting.clone(),
            metrics: slots.metrics.clone(),
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
