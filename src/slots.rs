//! Computation slots and their queue: how many computations run at once, how many requests
//! may wait for one, and for how long.
//!
//! Load shedding: at most `max_queued` jobs wait for a slot (more are refused at once), none
//! waits longer than `queue_timeout`, and the whole wait plus computation is bounded by
//! `request_timeout`. A computation that outlives its request keeps its slot until it ends, so
//! the number running never exceeds the slots. The gauges and the refusal counter live in the
//! metrics registry (`telemetry::metrics`).
//!
//! Threads: a computation that starts while no other runs has every core: it runs on the
//! blocking pool and its parallel loops (rayon) spread over the global pool. One that starts
//! while others run takes a lane, a one-thread rayon pool of its own (one per slot), where its
//! parallel loops run inline: the cores are busy with the other computations anyway, and
//! handing work between threads cost a 201² prediction about a fifth of its CPU time under load
//! (docs/PERFORMANCE.md).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
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
    /// The lanes not in use (module docs): one per slot, so one is free whenever a
    /// computation that needs one holds a slot.
    lanes: Arc<Mutex<Vec<Arc<rayon::ThreadPool>>>>,
}

impl ComputeSlots {
    /// Slots and their lanes (a thread each, started here: like the runtime's own threads, the
    /// service cannot run without them).
    pub fn new(limits: SlotLimits, metrics: Arc<Metrics>) -> Self {
        let limits = SlotLimits {
            slots: limits.slots.max(1),
            ..limits
        };
        let lanes = (0..limits.slots)
            .map(|i| {
                let lane = rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .thread_name(move |_| format!("preston-lane-{i}"))
                    .build()
                    .expect("the operating system starts a computation lane's thread");
                Arc::new(lane)
            })
            .collect();
        ComputeSlots {
            free: Arc::new(Semaphore::new(limits.slots)),
            waiting: Arc::new(AtomicUsize::new(0)),
            limits,
            metrics,
            lanes: Arc::new(Mutex::new(lanes)),
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
            let alone = self.free.available_permits() + 1 == self.limits.slots;
            let lane = if alone { None } else { self.take_lane() };
            let Some(lane) = lane else {
                return tokio::task::spawn_blocking(move || {
                    let _permit = permit;
                    let _running = running;
                    job()
                })
                .await
                .map_err(|e| E::from(Refusal::Failed(format!("computation task failed: {e}"))))?;
            };
            let (done, result) = tokio::sync::oneshot::channel();
            let lanes = self.lanes.clone();
            let pool = lane.clone();
            pool.spawn(move || {
                let _permit = permit;
                let _running = running;
                let outcome = catch_unwind(AssertUnwindSafe(job));
                lanes.lock().unwrap_or_else(|e| e.into_inner()).push(lane);
                // The request may have timed out and gone: then nobody wants the result.
                let _ = done.send(outcome);
            });
            result
                .await
                .map_err(|_| E::from(Refusal::Failed("computation lane closed".to_string())))?
                .map_err(|_| E::from(Refusal::Failed("computation panicked".to_string())))?
        };
        tokio::time::timeout(self.limits.request_timeout, work)
            .await
            .map_err(|_| self.shed(Shed::RequestTimeout))?
    }

    /// A free lane, if any (there always is one while the caller holds a slot).
    fn take_lane(&self) -> Option<Arc<rayon::ThreadPool>> {
        self.lanes.lock().unwrap_or_else(|e| e.into_inner()).pop()
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

#[cfg(test)]
mod tests {
    use super::*;

    fn slots(count: usize) -> ComputeSlots {
        ComputeSlots::new(
            SlotLimits {
                slots: count,
                max_queued: 8,
                queue_timeout: Duration::from_secs(5),
                request_timeout: Duration::from_secs(5),
            },
            Arc::new(Metrics::default()),
        )
    }

    #[derive(Debug)]
    struct Refused(Refusal);

    impl From<Refusal> for Refused {
        fn from(refusal: Refusal) -> Self {
            Refused(refusal)
        }
    }

    fn thread_name() -> String {
        std::thread::current().name().unwrap_or("").to_string()
    }

    /// A computation alone runs off the lanes; one that starts while it runs takes a lane;
    /// a panic on a lane is a refusal and gives its lane back (every later round finds one).
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_computation_among_others_runs_on_a_lane_of_its_own() {
        let slots = slots(2);
        for round in 0..4 {
            // The last round's lane gives its slot back just after its answer.
            while slots.free.available_permits() < 2 {
                tokio::time::sleep(Duration::from_millis(1)).await;
            }
            let (release, hold) = std::sync::mpsc::channel::<()>();
            let (started, on_start) = tokio::sync::oneshot::channel();
            let first = {
                let slots = slots.clone();
                tokio::spawn(async move {
                    slots
                        .run(move || {
                            let _ = started.send(());
                            hold.recv().unwrap();
                            Ok::<_, Refused>(thread_name())
                        })
                        .await
                })
            };
            on_start.await.unwrap();
            let second = slots
                .run(move || {
                    if round == 1 {
                        panic!("a computation that fails");
                    }
                    Ok::<_, Refused>(thread_name())
                })
                .await;
            release.send(()).unwrap();
            let first = first.await.unwrap().unwrap();
            assert!(
                !first.starts_with("preston-lane-"),
                "round {round}: {first}"
            );
            match second {
                Ok(name) => assert!(name.starts_with("preston-lane-"), "round {round}: {name}"),
                Err(Refused(Refusal::Failed(why))) => {
                    assert_eq!(round, 1);
                    assert_eq!(why, "computation panicked");
                }
                Err(other) => panic!("round {round}: {other:?}"),
            }
        }
        assert_eq!(slots.lanes.lock().unwrap().len(), 2);
    }
}
