//! Liveness and readiness probes.

use axum::extract::State;
use axum::http::StatusCode;
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use super::state::AppState;

#[derive(Serialize, ToSchema)]
pub struct Status {
    /// `ok` (alive), `ready` or `shutting_down`.
    pub status: HealthStatus,
}

/// What a probe reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum HealthStatus {
    /// The process is up (liveness).
    Ok,
    /// Accepting work (readiness).
    Ready,
    /// Shutdown has begun; no new work.
    ShuttingDown,
}

/// Liveness: the process is up and answering.
#[utoipa::path(get, path = "/healthz", tag = "service", operation_id = "getLiveness",
    responses((status = 200, description = "Alive", body = Status)))]
pub async fn healthz() -> Json<Status> {
    Json(Status {
        status: HealthStatus::Ok,
    })
}

/// Readiness: 200 while accepting work, 503 once shutdown has begun.
#[utoipa::path(get, path = "/readyz", tag = "service", operation_id = "getReadiness",
    responses(
        (status = 200, description = "Ready", body = Status),
        (status = 503, description = "Shutting down", body = Status),
    ))]
pub async fn readyz(State(state): State<AppState>) -> (StatusCode, Json<Status>) {
    if state.is_ready() {
        (
            StatusCode::OK,
            Json(Status {
                status: HealthStatus::Ready,
            }),
        )
    } else {
        (
            StatusCode::SERVICE_UNAVAILABLE,
            Json(Status {
                status: HealthStatus::ShuttingDown,
            }),
        )
    }
}
