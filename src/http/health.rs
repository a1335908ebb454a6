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
    /// Readiness only: whether the records store answers. Compute endpoints do not need it,
    /// so an unavailable store leaves the service ready (record endpoints answer 503).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub store: Option<StoreStatus>,
}

/// The records store, as `/readyz` sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum StoreStatus {
    Ok,
    Unavailable,
    /// The service runs without one.
    None,
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
        store: None,
    })
}

/// How long readiness waits for the records store.
const STORE_CHECK: std::time::Duration = std::time::Duration::from_millis(300);

/// Readiness: 200 while accepting work, 503 once shutdown has begun; `store` says whether the
/// records store answers.
#[utoipa::path(get, path = "/readyz", tag = "service", operation_id = "getReadiness",
    responses(
        (status = 200, description = "Ready", body = Status),
        (status = 503, description = "Shutting down", body = Status),
    ))]
pub async fn readyz(State(state): State<AppState>) -> (StatusCode, Json<Status>) {
    // Bounded well inside a probe's timeout (Kubernetes: 1 s): a database that does not
    // answer must not make the probe itself fail, or compute would stop being served too.
    let reachable = |store: &crate::store::Store| {
        let store = store.clone();
        async move {
            tokio::time::timeout(STORE_CHECK, store.is_reachable())
                .await
                .unwrap_or(false)
        }
    };
    let store = Some(match &state.store {
        None => StoreStatus::None,
        Some(store) if reachable(store).await => StoreStatus::Ok,
        Some(_) => StoreStatus::Unavailable,
    });
    if state.is_ready() {
        (
            StatusCode::OK,
            Json(Status {
                status: HealthStatus::Ready,
                store,
            }),
        )
    } else {
        (
            StatusCode::SERVICE_UNAVAILABLE,
            Json(Status {
                status: HealthStatus::ShuttingDown,
                store,
            }),
        )
    }
}
