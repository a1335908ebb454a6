//! Preston: dwell-time planning for dual-rotor small-tool polishing of rotationally symmetric
//! optics. See `ARCHITECTURE.md` for the map.
//!
//! - [`physics`]: the pure numerical core (no HTTP, JSON or OpenAPI types).
//! - [`optimize`]: the dwell optimizer (a QP solved with Clarabel), pure like `physics`.
//! - [`study`]: equal dwell, the η = −1 recommendation and its η window, η sweeps (pure).
//! - [`usecases`]: one function per use case, on commands checked once (the application layer).
//! - [`http`]: the axum service, its DTOs and errors.
//! - [`config`], [`telemetry`], [`server`]: start-up, settings, logging, serving;
//!   [`healthcheck`]: the container health probe.

pub mod calibration;
pub mod config;
pub mod contract;
pub mod field;
pub mod healthcheck;
pub mod http;
pub mod keys;
pub mod ledger;
pub mod lsq;
pub mod machine;
pub mod maps;
pub mod memory;
pub mod metrology;
pub mod optimize;
pub mod physics;
pub mod ratelimit;
pub mod report;
pub mod segments;
pub mod server;
pub mod slots;
pub mod spline;
pub mod store;
pub mod study;
pub mod surface;
pub mod telemetry;
pub mod usecases;
pub mod wide;
