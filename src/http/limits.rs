//! Documented request limits. Each has a server flag and environment variable (see `config`).

use std::time::Duration;

/// Sizes and waits the server refuses to exceed.
#[derive(Debug, Clone)]
pub struct Limits {
    /// Largest request body, bytes (413 beyond).
    pub max_body_bytes: usize,
    /// Largest `radial_grid.count` (422 beyond).
    pub max_radial_samples: usize,
    /// Most tool positions in one request (dwell or removal-function profiles; 422 beyond).
    pub max_positions: usize,
    /// Most removal-function profiles (`tool_positions_mm`) in one request.
    pub max_profiles: usize,
    /// Largest removal operator, radial samples × tool positions (422 beyond).
    pub max_operator_entries: usize,
    /// Most candidate positions in one optimization (its Hessian is dense within the band;
    /// 422 beyond).
    pub max_optimize_positions: usize,
    /// Longest a dwell optimization may run in the solver; a request may ask for less.
    pub solver_time_limit: Duration,
    /// Computations running at once; more wait for a slot.
    pub max_concurrent_computations: usize,
    /// How long a request waits for a computation slot before a 503 with Retry-After.
    pub queue_timeout: Duration,
    /// Most requests waiting for a computation slot; more get a 503 at once.
    pub max_queued_computations: usize,
    /// Longest a computing request may take, waiting included (503 beyond).
    pub request_timeout: Duration,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_body_bytes: 4 * 1024 * 1024,
            max_radial_samples: 10_001,
            max_positions: 10_001,
            max_profiles: 201,
            max_operator_entries: 25_000_000,
            max_optimize_positions: 2001,
            solver_time_limit: Duration::from_secs(10),
            max_concurrent_computations: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(2),
            queue_timeout: Duration::from_secs(5),
            max_queued_computations: 64,
            request_timeout: Duration::from_secs(30),
        }
    }
}
