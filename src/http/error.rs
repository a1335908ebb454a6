//! One error type for the whole API, rendered as `application/problem+json` (RFC 9457).
//!
//! Every client error names the offending input in `field`, as a path into the request body
//! (`process.workpiece_rpm`, `dwell.positions_mm[3]`). Internal errors are logged with their
//! details and returned as a bare 500 whose body says nothing about the internals.

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use utoipa::ToSchema;

use super::auth::Refusal;
use crate::metrology::{Axis, FitError, Parameter, ProbeError, TraceError};
use crate::optimize::target::ProfileArray;
use crate::optimize::{Bound, OptimizeError, ProfileError};
use crate::physics::{GridError, ProcessError, ScheduleError};
use crate::study::StudyError;
use crate::surface::{SurfaceError, SurfaceInput};
use crate::usecases::measurement_fit::{MeasurementError, MeasurementInputError};
use crate::usecases::recommend::MIN_DEPTH_NM;
use crate::usecases::{Input, InputError, LimitError, SettingError};

/// An API error. Construct with the helpers; render with `into_response`.
#[derive(Debug, Clone, PartialEq)]
pub enum ApiError {
    /// The body is not well-formed JSON.
    MalformedJson {
        field: Option<String>,
        detail: String,
    },
    /// Well-formed JSON that does not fit the schema: wrong type, missing or unknown field.
    SchemaMismatch {
        field: String,
        detail: String,
    },
    /// Fits the schema but describes something the model cannot compute.
    InvalidInput {
        field: String,
        detail: String,
    },
    /// The optimizer's constraints cannot all hold; `fields` are those in conflict.
    Infeasible {
        fields: Vec<String>,
        detail: String,
    },
    /// A machine program would break the machine's stated limits; every violation listed.
    MachineLimits {
        violations: Vec<LimitViolation>,
        detail: String,
    },
    /// The solver stopped without a plan (time or iteration limit, numerical trouble).
    SolverFailed {
        kind: &'static str,
        field: Option<String>,
        detail: String,
    },
    /// A request exceeds a documented size limit (grid, positions).
    LimitExceeded {
        field: String,
        detail: String,
    },
    PayloadTooLarge {
        limit_bytes: usize,
    },
    UnsupportedMediaType {
        content_type: String,
    },
    NotAcceptable {
        accept: String,
        offered: String,
    },
    NotFound {
        path: String,
    },
    MethodNotAllowed,
    /// A guarded path without a known API key (`WWW-Authenticate: Bearer`).
    Unauthorized {
        reason: Refusal,
    },
    /// The client's rate limit is spent: retry after the given seconds.
    RateLimited {
        retry_after_s: u64,
        per_second: f64,
        burst: u32,
    },
    /// No computation slot came free in time: retry after the given seconds.
    Overloaded {
        retry_after_s: u64,
    },
    /// A bug or an unexpected failure; `internal` is logged, never returned.
    Internal {
        internal: String,
    },
}

/// The problem+json body (RFC 9457), with `field` as an extension member.
#[derive(Debug, Serialize, ToSchema)]
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
    pub fn invalid(field: impl Into<String>, detail: impl Into<String>) -> Self {
        ApiError::InvalidInput {
            field: field.into(),
            detail: detail.into(),
        }
    }

    pub fn limit(field: impl Into<String>, detail: impl Into<String>) -> Self {
        ApiError::LimitExceeded {
            field: field.into(),
            detail: detail.into(),
        }
    }

    pub fn internal(internal: impl Into<String>) -> Self {
        ApiError::Internal {
            internal: internal.into(),
        }
    }

    pub fn status(&self) -> StatusCode {
        match self {
            ApiError::MalformedJson { .. } => StatusCode::BAD_REQUEST,
            ApiError::SchemaMismatch { .. }
            | ApiError::InvalidInput { .. }
            | ApiError::Infeasible { .. }
            | ApiError::MachineLimits { .. }
            | ApiError::SolverFailed { .. }
            | ApiError::LimitExceeded { .. } => StatusCode::UNPROCESSABLE_ENTITY,
            ApiError::PayloadTooLarge { .. } => StatusCode::PAYLOAD_TOO_LARGE,
            ApiError::UnsupportedMediaType { .. } => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ApiError::NotAcceptable { .. } => StatusCode::NOT_ACCEPTABLE,
            ApiError::NotFound { .. } => StatusCode::NOT_FOUND,
            ApiError::MethodNotAllowed => StatusCode::METHOD_NOT_ALLOWED,
            ApiError::Unauthorized { .. } => StatusCode::UNAUTHORIZED,
            ApiError::RateLimited { .. } => StatusCode::TOO_MANY_REQUESTS,
            ApiError::Overloaded { .. } => StatusCode::SERVICE_UNAVAILABLE,
            ApiError::Internal { .. } => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    pub fn problem(&self) -> Problem {
        let (kind, title, detail, field) = match self {
            ApiError::MalformedJson { field, detail } => (
                "malformed-json",
                "Malformed JSON",
                detail.clone(),
                field.clone(),
            ),
            ApiError::SchemaMismatch { field, detail } => (
                "schema-mismatch",
                "Request does not match the schema",
                detail.clone(),
                Some(field.clone()),
            ),
            ApiError::InvalidInput { field, detail } => (
                "invalid-input",
                "Invalid input",
                detail.clone(),
                Some(field.clone()),
            ),
            ApiError::Infeasible { fields, detail } => (
                "infeasible",
                "Constraints cannot all hold",
                detail.clone(),
                fields.first().cloned(),
            ),
            ApiError::MachineLimits { violations, detail } => (
                "machine-limits",
                "The program would exceed the machine's limits",
                detail.clone(),
                violations.first().map(|v| v.field.clone()),
            ),
            ApiError::SolverFailed {
                kind,
                field,
                detail,
            } => (
                *kind,
                "The solver found no plan",
                detail.clone(),
                field.clone(),
            ),
            ApiError::LimitExceeded { field, detail } => (
                "limit-exceeded",
                "Request exceeds a limit",
                detail.clone(),
                Some(field.clone()),
            ),
            ApiError::PayloadTooLarge { limit_bytes } => (
                "payload-too-large",
                "Request body too large",
                format!("the request body exceeds the limit of {limit_bytes} bytes"),
                None,
            ),
            ApiError::UnsupportedMediaType { content_type } => (
                "unsupported-media-type",
                "Unsupported media type",
                format!(
                    "content-type `{content_type}` is not accepted; send application/json \
                     (/v1/measurement/fit also takes text/csv)"
                ),
                None,
            ),
            ApiError::NotAcceptable { accept, offered } => (
                "not-acceptable",
                "Not acceptable",
                format!("cannot answer `accept: {accept}`; this endpoint offers {offered}"),
                None,
            ),
            ApiError::NotFound { path } => (
                "not-found",
                "Not found",
                format!("no resource at `{path}`; see /docs for the API"),
                None,
            ),
            ApiError::MethodNotAllowed => (
                "method-not-allowed",
                "Method not allowed",
                "this resource does not support that method".to_string(),
                None,
            ),
            ApiError::Unauthorized { reason } => (
                "unauthorized",
                "API key required",
                match reason {
                    Refusal::Missing => {
                        "this path needs an API key: send `Authorization: Bearer <key>`"
                    }
                    Refusal::Malformed => {
                        "the Authorization header must be `Bearer <key>` with a non-empty key"
                    }
                    Refusal::Unknown => "the API key is not valid",
                }
                .to_string(),
                None,
            ),
            ApiError::RateLimited {
                retry_after_s,
                per_second,
                burst,
            } => (
                "rate-limited",
                "Too many requests",
                format!(
                    "this client may make {per_second} requests per second with bursts of {burst}; retry in {retry_after_s} s"
                ),
                None,
            ),
            ApiError::Overloaded { retry_after_s } => (
                "overloaded",
                "Service overloaded",
                format!("all computation slots are busy; retry in {retry_after_s} s"),
                None,
            ),
            ApiError::Internal { .. } => (
                "internal",
                "Internal server error",
                "the server failed to handle this request; it has been logged".to_string(),
                None,
            ),
        };
        Problem {
            kind: format!("urn:preston:problem:{kind}"),
            title: title.to_string(),
            status: self.status().as_u16(),
            detail,
            field,
            conflicts: match self {
                ApiError::Infeasible { fields, .. } => Some(fields.clone()),
                _ => None,
            },
            violations: match self {
                ApiError::MachineLimits { violations, .. } => Some(violations.clone()),
                _ => None,
            },
            request_id: None,
        }
    }

    /// The problem+json body as bytes (also used by the offline `compute` command).
    pub fn to_json(&self) -> String {
        serde_json::to_string(&self.problem()).expect("a problem always serialises")
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if let ApiError::Internal { internal } = &self {
            tracing::error!(error = %internal, "internal error");
        }
        let mut response = (self.status(), self.to_json()).into_response();
        let headers = response.headers_mut();
        headers.insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/problem+json"),
        );
        match self {
            ApiError::Overloaded { retry_after_s }
            | ApiError::RateLimited { retry_after_s, .. } => {
                headers.insert(header::RETRY_AFTER, HeaderValue::from(retry_after_s));
            }
            // RFC 6750: a request with no credentials gets the bare challenge.
            ApiError::Unauthorized { reason } => {
                headers.insert(
                    header::WWW_AUTHENTICATE,
                    HeaderValue::from_static(match reason {
                        Refusal::Missing => "Bearer realm=\"preston\"",
                        Refusal::Malformed => "Bearer realm=\"preston\", error=\"invalid_request\"",
                        Refusal::Unknown => "Bearer realm=\"preston\", error=\"invalid_token\"",
                    }),
                );
            }
            _ => {}
        }
        response
    }
}

/// Engine errors become 422s naming the field under the request object that carried it.
impl ApiError {
    pub fn from_process(err: ProcessError) -> Self {
        ApiError::invalid(format!("process.{}", err.field()), err.to_string())
    }

    /// `prefix` is the request object holding the grid or aperture (`radial_grid`,
    /// `clear_aperture`).
    pub fn from_grid(prefix: &str, err: GridError) -> Self {
        let field = match err {
            GridError::ApertureOutsideGrid { .. } => "clear_aperture".to_string(),
            _ => format!("{prefix}.{}", err.field()),
        };
        ApiError::invalid(field, err.to_string())
    }

    /// `prefix` is the request object holding the arrays (`dwell`), or empty for top-level.
    pub fn from_schedule(prefix: &str, err: ScheduleError) -> Self {
        let mut field = if prefix.is_empty() {
            err.field().to_string()
        } else {
            format!("{prefix}.{}", err.field())
        };
        if let Some(index) = err.index() {
            field.push_str(&format!("[{index}]"));
        }
        ApiError::invalid(field, err.to_string())
    }
}

/// Where each command input sits in the requests.
fn input_path(input: Input) -> &'static str {
    match input {
        Input::ToolPositions => "tool_positions_mm",
        Input::Dwell => "dwell.positions_mm",
        Input::Feed => "feed",
        Input::Positions => "positions_mm",
        Input::Etas => "etas",
        Input::Depth => "depth_nm",
        Input::NonuniformityThreshold => "nonuniformity_threshold",
        Input::UniformDepth => "target.uniform_depth_nm",
        Input::SolverTimeLimit => "solver.time_limit_s",
    }
}

impl ApiError {
    /// A size limit exceeded by the input at `field`.
    pub(super) fn from_limit(field: &str, err: LimitError) -> Self {
        let detail = match err {
            LimitError::RadialSamples { count, max } => {
                format!("{field} is {count}; this server allows at most {max}")
            }
            LimitError::Positions { count, max } => {
                format!("{field} has {count} entries; this server allows at most {max}")
            }
            LimitError::OperatorEntries {
                samples,
                positions,
                max,
            } => format!(
                "radial_grid.count × {field} = {samples} × {positions} exceeds the server's \
                 limit of {max} removal-operator entries"
            ),
            LimitError::Profiles { count, max } => {
                format!("{field} has {count} entries; this server allows at most {max} profiles")
            }
            LimitError::OptimizePositions { count, max } => {
                format!("{field} has {count} entries; this server optimizes at most {max}")
            }
            LimitError::Etas { count, max } => {
                format!("{field} must hold 1 to {max} values; it has {count}")
            }
            LimitError::TracePoints { count, max } => {
                format!("{field} has {count} points; this server fits at most {max}")
            }
        };
        ApiError::limit(field, detail)
    }
}

impl From<SettingError> for ApiError {
    fn from(err: SettingError) -> Self {
        match err {
            SettingError::Process(e) => ApiError::from_process(e),
            SettingError::GridSize(e) => ApiError::from_limit("radial_grid.count", e),
            SettingError::Grid(e) => ApiError::from_grid("radial_grid", e),
            SettingError::Aperture(e) => ApiError::from_grid("clear_aperture", e),
        }
    }
}

impl From<InputError> for ApiError {
    fn from(err: InputError) -> Self {
        match err {
            InputError::Setting(e) => e.into(),
            InputError::Limit { input, error } => ApiError::from_limit(input_path(input), error),
            InputError::Schedule { input, error } => {
                let prefix = match input {
                    Input::Dwell => "dwell",
                    Input::Feed => "feed",
                    _ => "",
                };
                ApiError::from_schedule(prefix, error)
            }
            InputError::OutOfRange { input, max } => {
                let field = input_path(input);
                let detail = match input {
                    Input::Depth => {
                        format!("{field} must be a number in [{MIN_DEPTH_NM}, {max}] nm")
                    }
                    Input::UniformDepth => format!("{field} must be a number in [0, {max}] nm"),
                    Input::NonuniformityThreshold => {
                        format!("{field} must be a finite fraction > 0")
                    }
                    Input::Etas => format!("{field} must hold 1 to {max} values; it is empty"),
                    Input::SolverTimeLimit => {
                        format!("{field} must be > 0 and at most this server's limit of {max} s")
                    }
                    _ => format!("{field} is out of range (at most {max})"),
                };
                ApiError::invalid(field, detail)
            }
            InputError::Optimize(e) => e.into(),
            InputError::Study(e) => e.into(),
        }
    }
}

impl From<ProfileError> for ApiError {
    fn from(err: ProfileError) -> Self {
        let (array, index) = err.location();
        let name = match array {
            ProfileArray::Radius => "radius_mm",
            ProfileArray::Depth => "depth_nm",
        };
        let field = match index {
            Some(i) => format!("target.profile.{name}[{i}]"),
            None => format!("target.profile.{name}"),
        };
        ApiError::invalid(field, err.to_string())
    }
}

/// Optimizer errors; a time limit is reported by the optimize endpoint, which knows the
/// server's limit (see `http::optimize`).
impl From<OptimizeError> for ApiError {
    fn from(err: OptimizeError) -> Self {
        let detail = err.to_string();
        match err {
            OptimizeError::InvalidConstraint { constraint, .. } => {
                ApiError::invalid(format!("constraints.{}", constraint.name()), detail)
            }
            OptimizeError::InvalidWeight { weight, .. } => {
                ApiError::invalid(format!("objective.{}", weight.name()), detail)
            }
            OptimizeError::Profile(e) => e.into(),
            OptimizeError::EmptyAperture => ApiError::invalid("clear_aperture", detail),
            OptimizeError::NoRemovalInAperture => ApiError::invalid("positions_mm", detail),
            OptimizeError::Infeasible { fields, .. } => ApiError::Infeasible {
                fields: if fields.is_empty() {
                    vec!["constraints".to_string()]
                } else {
                    fields
                        .iter()
                        .map(|f| match f {
                            Bound::Constraint(c) => format!("constraints.{}", c.name()),
                            Bound::Machine(drive, limit) => limit.field(*drive),
                        })
                        .collect()
                },
                detail,
            },
            OptimizeError::TimeLimit { .. } => ApiError::SolverFailed {
                kind: "solver-time-limit",
                field: Some("solver.time_limit_s".into()),
                detail,
            },
            OptimizeError::IterationLimit { .. } => ApiError::SolverFailed {
                kind: "solver-iteration-limit",
                field: None,
                detail,
            },
            OptimizeError::Numerical { .. } => ApiError::SolverFailed {
                kind: "solver-numerical-error",
                field: None,
                detail,
            },
        }
    }
}

impl From<StudyError> for ApiError {
    fn from(err: StudyError) -> Self {
        let detail = err.to_string();
        let field = match &err {
            StudyError::NoRemovalInAperture => "clear_aperture".to_string(),
            StudyError::ToolStationary => "process.tool_rpm".to_string(),
            StudyError::InvalidEta { index } => {
                let field = format!("etas[{index}]");
                return ApiError::invalid(field.clone(), format!("{field}: {detail}"));
            }
            StudyError::EtaOutsideDomain { index, .. } => format!("etas[{index}]"),
            StudyError::InvalidSpeedLimit { limit } => format!("limits.{}", limit.name()),
            StudyError::RecommendedOutsideDomain(e) => format!("process.{}", e.field()),
        };
        ApiError::invalid(field, detail)
    }
}

/// The error responses every computing endpoint can give, described once for the OpenAPI
/// document (the values are built as [`ApiError`]s, never as this enum).
#[derive(utoipa::IntoResponses)]
#[allow(dead_code)]
pub enum ComputeProblems {
    /// Malformed JSON
    #[response(status = 400, content_type = "application/problem+json")]
    Malformed(Problem),
    /// Body too large
    #[response(status = 413, content_type = "application/problem+json")]
    TooLarge(Problem),
    /// Invalid input, naming the field
    #[response(status = 422, content_type = "application/problem+json")]
    Invalid(Problem),
    /// No valid API key (only when the service has keys configured); `WWW-Authenticate: Bearer`
    #[response(status = 401, content_type = "application/problem+json")]
    Unauthorized(Problem),
    /// The client's rate limit is spent (only when the service limits rates); retry after
    /// Retry-After seconds
    #[response(status = 429, content_type = "application/problem+json")]
    RateLimited(Problem),
    /// Overloaded; retry after Retry-After seconds
    #[response(status = 503, content_type = "application/problem+json")]
    Overloaded(Problem),
}

/// A surface that was refused, at its field.
pub(super) fn surface_error(e: SurfaceError) -> ApiError {
    let field = surface_field(e.input());
    ApiError::invalid(field.clone(), format!("{field}: {e}"))
}

pub(super) fn surface_field(input: Option<SurfaceInput>) -> String {
    match input {
        Some(SurfaceInput::RadiusOfCurvature) => "surface.radius_of_curvature_mm".into(),
        Some(SurfaceInput::ConicConstant) => "surface.conic_constant".into(),
        Some(SurfaceInput::Power(i)) => format!("surface.coefficients[{i}].power"),
        Some(SurfaceInput::Value(i)) => format!("surface.coefficients[{i}].value"),
        None => "surface".into(),
    }
}

/// The request's name for a fitted parameter (a member of `fit`).
fn parameter_name(parameter: Parameter) -> &'static str {
    match parameter {
        Parameter::LateralOffset => "lateral_offset",
        Parameter::Tilt => "tilt",
        Parameter::Piston => "piston",
        Parameter::RadiusOfCurvature => "radius_of_curvature",
    }
}

fn fit_field(parameters: &[Parameter]) -> String {
    parameters
        .first()
        .map_or("fit".into(), |&p| format!("fit.{}", parameter_name(p)))
}

fn parameter_names(parameters: &[Parameter]) -> String {
    parameters
        .iter()
        .map(|&p| parameter_name(p))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A point the probe cannot place on the design.
fn off_surface(index: usize, error: &ProbeError) -> ApiError {
    ApiError::invalid(
        format!("profile.x_mm[{index}]"),
        format!("point {index} does not lie over the design: {error}"),
    )
}

impl From<MeasurementInputError> for ApiError {
    fn from(err: MeasurementInputError) -> Self {
        use MeasurementInputError as E;
        match err {
            E::Surface(e) => {
                let field = surface_field(e.input());
                ApiError::invalid(field.clone(), format!("{field}: {e}"))
            }
            E::Probe(e) => ApiError::invalid("probe_tip_radius_mm", e.to_string()),
            E::TraceSize(e) => ApiError::from_limit("profile.x_mm", e),
            E::GridSize(e) => ApiError::from_limit("radial_grid.count", e),
            E::GridCount => ApiError::invalid(
                "radial_grid.count",
                "count must be at least 2: the profile becomes an optimize target",
            ),
            E::Grid(e) => ApiError::from_grid("radial_grid", e),
            E::Aperture(e) => ApiError::from_grid("clear_aperture", e),
            E::Trace(e) => match &e {
                TraceError::LengthMismatch { .. } => {
                    ApiError::invalid("profile.z_mm", e.to_string())
                }
                TraceError::NonFinite { axis, index } => {
                    let axis = if *axis == Axis::X { "x_mm" } else { "z_mm" };
                    ApiError::invalid(format!("profile.{axis}[{index}]"), e.to_string())
                }
                TraceError::TooFewPoints { .. } => ApiError::invalid("profile.x_mm", e.to_string()),
                TraceError::NothingToFit => ApiError::invalid("fit", e.to_string()),
                TraceError::Undetermined { parameters, .. } => {
                    ApiError::invalid(fit_field(parameters), e.to_string())
                }
                TraceError::OffSurface { index, error } => off_surface(*index, error),
            },
        }
    }
}

impl From<MeasurementError> for ApiError {
    fn from(err: MeasurementError) -> Self {
        match err {
            MeasurementError::Fit(FitError::Undetermined { parameters }) => ApiError::invalid(
                fit_field(&parameters),
                format!(
                    "the trace does not determine {} apart: they trade off against each other \
                     on this surface and span; fit fewer parameters",
                    parameter_names(&parameters)
                ),
            ),
            MeasurementError::Fit(FitError::LeftSurface { index, error }) => {
                off_surface(index, &error)
            }
            MeasurementError::Fit(
                e @ (FitError::NotConverged { .. } | FitError::WeightsUnsettled { .. }),
            ) => ApiError::SolverFailed {
                kind: "solver-not-converged",
                field: Some("profile".into()),
                detail: format!(
                    "{e}: the trace may not be a meridian of this surface (check surface \
                         and the units of profile), or the misalignment is too large"
                ),
            },
            MeasurementError::Grid(e) => ApiError::from_grid("radial_grid", e),
            MeasurementError::Aperture(e) => ApiError::from_grid("clear_aperture", e),
            MeasurementError::Profile(e) => {
                let field = match e {
                    crate::metrology::ProfileError::NotCovered { .. } => "radial_grid",
                    crate::metrology::ProfileError::ApertureEmpty => "clear_aperture",
                    crate::metrology::ProfileError::NoPoints => "profile",
                };
                ApiError::invalid(field, e.to_string())
            }
        }
    }
}
