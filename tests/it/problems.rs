//! The problem table and the problem body, checked directly (the HTTP tests see them only
//! through responses).

use axum::http::{header, StatusCode};
use axum::response::IntoResponse;
use preston::http::error::{ApiError, Kind, Problem};

const KINDS: [Kind; 19] = [
    Kind::MalformedJson,
    Kind::SchemaMismatch,
    Kind::InvalidInput,
    Kind::Infeasible,
    Kind::MachineLimits,
    Kind::SolverTimeLimit,
    Kind::SolverIterationLimit,
    Kind::SolverNumericalError,
    Kind::SolverNotConverged,
    Kind::LimitExceeded,
    Kind::PayloadTooLarge,
    Kind::UnsupportedMediaType,
    Kind::NotAcceptable,
    Kind::NotFound,
    Kind::MethodNotAllowed,
    Kind::Unauthorized,
    Kind::RateLimited,
    Kind::Overloaded,
    Kind::Internal,
];

/// Each kind has its own type, a title, and a status in the class its meaning needs:
/// the caller's fault 4xx, the service's 5xx; every solver failure is a 422.
#[test]
fn the_table_gives_every_kind_its_own_type_and_a_fitting_status() {
    let mut types: Vec<&str> = KINDS.iter().map(|k| k.meta().0).collect();
    types.sort();
    types.dedup();
    assert_eq!(types.len(), KINDS.len());
    for kind in KINDS {
        let (slug, title, status) = kind.meta();
        assert!(!title.is_empty() && slug.chars().all(|c| c.is_ascii_lowercase() || c == '-'));
        let server_side = matches!(kind, Kind::Overloaded | Kind::Internal);
        assert_eq!(status.is_server_error(), server_side, "{kind:?}");
        assert_eq!(status.is_client_error(), !server_side, "{kind:?}");
        if kind.is_solver_failure() {
            assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
        }
    }
}

/// The body carries what the kind needs and nothing internal.
#[test]
fn problems_carry_their_members() {
    let p = ApiError::infeasible(vec!["a.b".into(), "c".into()], "no").problem();
    assert_eq!(p.kind, "urn:preston:problem:infeasible");
    assert_eq!(p.status, 422);
    assert_eq!(p.field.as_deref(), Some("a.b"));
    assert_eq!(p.conflicts, Some(vec!["a.b".to_string(), "c".to_string()]));
    let p = ApiError::internal("secret path /etc").problem();
    assert!(!p.detail.contains("secret") && p.field.is_none() && p.status == 500);
    let response = ApiError::overloaded(5).into_response();
    assert_eq!(response.headers()[header::RETRY_AFTER], "5");
    assert_eq!(
        response.headers()[header::CONTENT_TYPE],
        "application/problem+json"
    );
    let p = response.extensions().get::<Problem>().unwrap();
    assert_eq!(p.kind, "urn:preston:problem:overloaded");
}
