//! The HTTP layer: axum router, handlers, DTOs (serde + utoipa) and the problem+json error.
//! It owns every wire type: a request is parsed into a use case's command (every check, before
//! queueing for a computation slot), the use case runs on the blocking pool, and its result is
//! converted into the response DTO and rendered (see [`endpoint`]).
//!
//! CPU-heavy work runs on the blocking pool, at most `max_concurrent_computations` at a time,
//! with a bounded queue in front (see [`AppState::run`]); excess load is answered 503 with
//! Retry-After. Every request gets an `x-request-id` (kept if the client sent one), which is in
//! the log span, echoed on the response and written into problem+json bodies.

pub mod auth;
pub mod calibration;
pub mod csv_body;
pub mod docs;
pub mod dto;
pub mod endpoint;
pub mod error;
pub mod eta_sweep;
pub mod extract;
pub mod fields;
pub mod health;
pub mod maps;
pub mod measurement_fit;
pub mod metrics;
pub mod openapi;
pub mod optimize;
pub mod predict;
pub mod program;
pub mod ratelimit;
pub mod recommend;
pub mod records;
pub mod removal_function;
pub mod router;
pub mod state;
pub mod workbench;

pub use router::{compute_json, cors_layer, router, EndpointEntry, ENDPOINTS};
pub use state::{AppState, Services};
