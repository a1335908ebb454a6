//! One error type for the whole API, rendered as `application/problem+json` (RFC 9457).
//!
//! Every problem has a kind, and one table ([`Kind::meta`]) gives each kind its type URN,
//! title and status. Client errors name the offending input in `field`, a path into the
//! request body (`process.workpiece_rpm`, `dwell.positions_mm[3]`; built by [`super::fields`]).
//! Internal errors are logged with their details and returned as a bare 500 whose body says
//! nothing about the internals. The body is written by [`render`], the one middleware that
//! knows the request's id, so every problem carries its `request_id`.

use axum::body::Body;
use axum::extract::Request;
use axum::http::{header, HeaderName, HeaderValue, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use utoipa::ToSchema;

/// The kinds of problem: what went wrong, as far as the caller can act on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// The body is not well-formed JSON.
    MalformedJson,
    /// Well-formed JSON that does not fit the schema: wrong type, missing or unknown field.
    SchemaMismatch,
    /// Fits the schema but describes something the model cannot compute.
    InvalidInput,
    /// The optimizer's constraints cannot all hold; `conflicts` lists them.
    Infeasible,
    /// A machine program would break the machine's stated limits; `violations` lists them.
    MachineLimits,
    /// The solver stopped without a plan: out of time, out of iterations, numerical trouble,
    /// or a fit that did not converge.
    SolverTimeLimit,
    SolverIterationLimit,
    SolverNumericalError,
    SolverNotConverged,
    /// A request exceeds a documented size limit (grid, positions).
    LimitExceeded,
    PayloadTooLarge,
    UnsupportedMediaType,
    NotAcceptable,
    NotFound,
    MethodNotAllowed,
    /// A guarded path without a known API key.
    Unauthorized,
    /// A read-only API key asked to write a record.
    Forbidden,
    /// A record's unique name is taken, or an Idempotency-Key was sent with another request.
    Conflict,
    /// The records store does not answer (compute endpoints still do).
    StoreUnavailable,
    /// The client's rate limit is spent.
    RateLimited,
    /// No computation slot came free in time.
    Overloaded,
    /// A bug or an unexpected failure.
    Internal,
}

const MACHINE_LIMITS: &str = "The program would exceed the machine's limits";

impl Kind {
    /// The solver stopped without an answer (the input may still be the cause).
    pub fn is_solver_failure(self) -> bool {
        matches!(
            self,
            Kind::SolverTimeLimit
                | Kind::SolverIterationLimit
                | Kind::SolverNumericalError
                | Kind::SolverNotConverged
        )
    }

    /// The table: the type's last segment, its title, its status.
    pub fn meta(self) -> (&'static str, &'static str, StatusCode) {
        use StatusCode as S;
        const SOLVER: &str = "The solver found no plan";
        const U: StatusCode = S::UNPROCESSABLE_ENTITY;
        match self {
            Kind::MalformedJson => ("malformed-json", "Malformed JSON", S::BAD_REQUEST),
            Kind::SchemaMismatch => ("schema-mismatch", "Request does not match the schema", U),
            Kind::InvalidInput => ("invalid-input", "Invalid input", U),
            Kind::Infeasible => ("infeasible", "Constraints cannot all hold", U),
            Kind::MachineLimits => ("machine-limits", MACHINE_LIMITS, U),
            Kind::SolverTimeLimit => ("solver-time-limit", SOLVER, U),
            Kind::SolverIterationLimit => ("solver-iteration-limit", SOLVER, U),
            Kind::SolverNumericalError => ("solver-numerical-error", SOLVER, U),
            Kind::SolverNotConverged => ("solver-not-converged", SOLVER, U),
            Kind::LimitExceeded => ("limit-exceeded", "Request exceeds a limit", U),
            Kind::PayloadTooLarge => (
                "payload-too-large",
                "Request body too large",
                S::PAYLOAD_TOO_LARGE,
            ),
            Kind::UnsupportedMediaType => (
                "unsupported-media-type",
                "Unsupported media type",
                S::UNSUPPORTED_MEDIA_TYPE,
            ),
            Kind::NotAcceptable => ("not-acceptable", "Not acceptable", S::NOT_ACCEPTABLE),
            Kind::NotFound => ("not-found", "Not found", S::NOT_FOUND),
            Kind::MethodNotAllowed => (
                "method-not-allowed",
                "Method not allowed",
                S::METHOD_NOT_ALLOWED,
            ),
            Kind::Unauthorized => ("unauthorized", "API key required", S::UNAUTHORIZED),
            Kind::Forbidden => ("forbidden", "This API key may not write", S::FORBIDDEN),
            Kind::Conflict => ("conflict", "Conflict with a record", S::CONFLICT),
            Kind::StoreUnavailable => (
                "store-unavailable",
                "The records store is unavailable",
                S::SERVICE_UNAVAILABLE,
            ),
            Kind::RateLimited => ("rate-limited", "Too many requests", S::TOO_MANY_REQUESTS),
            Kind::Overloaded => ("overloaded", "Service overloaded", S::SERVICE_UNAVAILABLE),
            Kind::Internal => (
                "internal",
                "Internal server error",
                S::INTERNAL_SERVER_ERROR,
            ),
        }
    }
}

/// An API error: a problem of some [`Kind`], the words for this request, the field it names
/// and what else its kind carries. Build with the constructors; render with `into_response`.
#[derive(Debug, Clone, PartialEq)]
pub struct ApiError {
    pub kind: Kind,
    pub detail: String,
    pub field: Option<String>,
    /// What only some kinds carry (boxed: errors travel in every `Result` of the layer).
    extra: Box<Extra>,
}

#[derive(Debug, Clone, Default, PartialEq)]
struct Extra {
    /// Infeasible: every request field in the conflict (`field` is the first).
    conflicts: Option<Vec<String>>,
    /// Machine limits: every limit the program would break (`field` is the first).
    violations: Option<Vec<LimitViolation>>,
    /// Headers the kind needs: Retry-After, WWW-Authenticate.
    headers: Vec<(HeaderName, HeaderValue)>,
    /// An internal error's details: logged, never returned.
    internal: Option<String>,
}

/// The problem+json body (RFC 9457), with `field` as an extension member.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct Problem {
    /// A URI reference naming the problem type (`urn:preston:problem:<kind>`).
    #[serde(rename = "type")]
    pub kind: String,
    /// A short summary of the problem type.
    pub title: String,
    /// The HTTP status code.
    pub status: u16,
    /// What went wrong with this request, in words.
    pub detail: String,
    /// Path of the offending input in the request body, e.g. `dwell.positions_mm[3]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    /// For infeasible optimizations: every request field in the conflict (`field` is the
    /// first of them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conflicts: Option<Vec<String>>,
    /// For machine programs: every limit the program would break (`field` is the first).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub violations: Option<Vec<LimitViolation>>,
    /// The request's `x-request-id` (generated when the client sent none), for matching an
    /// error report to the server's logs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub request_id: Option<String>,
}

/// A machine limit a program would break.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema)]
pub struct LimitViolation {
    /// The limit in the request, e.g. `machine.x.max_velocity_mm_per_min`.
    pub field: String,
    /// `x`, `z`, `b`, `workpiece_spindle` or `tool_spindle`.
    pub axis: String,
    /// The limit's member name, e.g. `max_acceleration_deg_per_s2`.
    pub limit: String,
    /// The stated limit, in the unit its name gives.
    pub limit_value: f64,
    /// The worst value the program would reach (a position, or a magnitude of velocity,
    /// acceleration or spindle speed), same unit.
    pub value: f64,
    /// Index into the program's blocks of the first block that breaks it (null for a spindle
    /// speed, which holds for the whole program).
    pub first_block: Option<usize>,
    /// How many blocks break it.
    pub blocks: usize,
}

impl ApiError {
    pub fn new(kind: Kind, detail: impl Into<String>) -> Self {
        ApiError {
            kind,
            detail: detail.into(),
            field: None,
            extra: Box::default(),
        }
    }

    /// The same problem naming the input at `field`.
    pub fn at(mut self, field: impl Into<String>) -> Self {
        self.field = Some(field.into());
        self
    }

    /// The same problem inside `prefix`: its field `a.b` becomes `prefix.a.b` (the body's
    /// own problems name `prefix`).
    pub fn under(mut self, prefix: &str) -> Self {
        self.field = Some(match self.field.as_deref() {
            None | Some("body") | Some(".") => prefix.to_string(),
            Some(field) => format!("{prefix}.{field}"),
        });
        self
    }

    pub fn invalid(field: impl Into<String>, detail: impl Into<String>) -> Self {
        ApiError::new(Kind::InvalidInput, detail).at(field)
    }

    /// A request composed from what the schema states only as text or as a union (query
    /// parameters' JSON values, a records body of either kind of plan) that its endpoint refuses
    /// as not its schema: an invalid input naming the member, `why` saying what was expected.
    /// Any other problem as it is.
    pub fn mismatch_as_invalid(self, why: &str) -> Self {
        if self.kind != Kind::SchemaMismatch {
            return self;
        }
        let field = self.field.unwrap_or_else(|| "body".into());
        ApiError::invalid(field, format!("{} ({why})", self.detail))
    }

    pub fn limit(field: impl Into<String>, detail: impl Into<String>) -> Self {
        ApiError::new(Kind::LimitExceeded, detail).at(field)
    }

    pub fn infeasible(fields: Vec<String>, detail: impl Into<String>) -> Self {
        let mut error = ApiError::new(Kind::Infeasible, detail);
        error.field = fields.first().cloned();
        error.extra.conflicts = Some(fields);
        error
    }

    pub fn machine_limits(violations: Vec<LimitViolation>, detail: impl Into<String>) -> Self {
        let mut error = ApiError::new(Kind::MachineLimits, detail);
        error.field = violations.first().map(|v| v.field.clone());
        error.extra.violations = Some(violations);
        error
    }

    pub fn internal(internal: impl Into<String>) -> Self {
        let mut error = ApiError::new(
            Kind::Internal,
            "the server failed to handle this request; it has been logged",
        );
        error.extra.internal = Some(internal.into());
        error
    }

    pub fn not_found(path: &str) -> Self {
        ApiError::new(
            Kind::NotFound,
            format!("no resource at `{path}`; see /docs for the API"),
        )
    }

    pub fn method_not_allowed() -> Self {
        ApiError::new(
            Kind::MethodNotAllowed,
            "this resource does not support that method",
        )
    }

    pub fn payload_too_large(limit_bytes: usize) -> Self {
        ApiError::new(
            Kind::PayloadTooLarge,
            format!("the request body exceeds the limit of {limit_bytes} bytes"),
        )
    }

    /// `accepted`: the media types the endpoint takes, in words.
    pub fn unsupported_media_type(content_type: &str, accepted: &str) -> Self {
        ApiError::new(
            Kind::UnsupportedMediaType,
            format!("content-type `{content_type}` is not accepted here; send {accepted}"),
        )
    }

    pub fn not_acceptable(accept: &str, offered: &str) -> Self {
        ApiError::new(
            Kind::NotAcceptable,
            format!("cannot answer `accept: {accept}`; this endpoint offers {offered}"),
        )
    }

    pub(super) fn with_header(mut self, name: HeaderName, value: HeaderValue) -> Self {
        self.extra.headers.push((name, value));
        self
    }

    pub fn status(&self) -> StatusCode {
        self.kind.meta().2
    }

    pub fn problem(&self) -> Problem {
        let (kind, title, status) = self.kind.meta();
        Problem {
            kind: format!("urn:preston:problem:{kind}"),
            title: title.to_string(),
            status: status.as_u16(),
            detail: self.detail.clone(),
            field: self.field.clone(),
            conflicts: self.extra.conflicts.clone(),
            violations: self.extra.violations.clone(),
            request_id: None,
        }
    }

    /// The problem+json body as bytes (also used by the offline `compute` command).
    pub fn to_json(&self) -> String {
        serde_json::to_string(&self.problem()).expect("a problem always serialises")
    }
}

/// The response: status and headers; the body is the [`Problem`], written by [`render`] with
/// the request's id.
impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if let Some(internal) = &self.extra.internal {
            tracing::error!(error = %internal, "internal error");
        }
        let mut response = self.status().into_response();
        let headers = response.headers_mut();
        headers.insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/problem+json"),
        );
        for (name, value) in &self.extra.headers {
            headers.insert(name, value.clone());
        }
        response.extensions_mut().insert(self.problem());
        response
    }
}

/// The middleware that writes every problem's body, stamped with the request's id (set by the
/// request-id layer outside it), so a user's error report can be matched to the logs.
pub async fn render(request: Request, next: Next) -> Response {
    let request_id = request
        .headers()
        .get(super::metrics::REQUEST_ID)
        .and_then(|v| v.to_str().ok())
        .map(str::to_string);
    let mut response = next.run(request).await;
    if let Some(mut problem) = response.extensions_mut().remove::<Problem>() {
        problem.request_id = request_id;
        let body = serde_json::to_string(&problem).expect("a problem always serialises");
        response.headers_mut().remove(header::CONTENT_LENGTH);
        *response.body_mut() = Body::from(body);
    }
    response
}
