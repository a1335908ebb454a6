//! Where each input sits in the requests: the one table that turns the core's typed errors
//! into problems naming the offending request field (`process.tool_rpm`,
//! `dwell.positions_mm[3]`, `machine.x.max_velocity_mm_per_min`).

mod calibration;
mod maps;
mod measurement;
mod raster;

use super::error::{ApiError, Kind, LimitViolation};
use crate::machine::{Drive, GcodeFormatError, LimitKind, ProgramError, Violation};
use crate::optimize::target::ProfileArray;
use crate::optimize::{Bound, MeasuredProfileError, OptimizeError};
use crate::physics::{GridError, ProcessError, ScheduleError};
use crate::study::StudyError;
use crate::surface::{SurfaceError, SurfaceInput};
use crate::usecases::optimize::MachineFitError;
use crate::usecases::program::{ProgramFailure, ProgramInputError};
use crate::usecases::{Input, InputError, PartError, SettingError, SizeLimitError};

/// Engine errors become 422s naming the field under the request object that carried it.
impl ApiError {
    fn from_process(err: ProcessError) -> Self {
        ApiError::invalid(format!("process.{}", err.field()), err.to_string())
    }

    /// `prefix` is the request object holding the grid or aperture (`radial_grid`,
    /// `clear_aperture`).
    fn from_grid(prefix: &str, err: GridError) -> Self {
        let field = match err.field() {
            Some(member) => format!("{prefix}.{member}"),
            None => "clear_aperture".to_string(),
        };
        ApiError::invalid(field, err.to_string())
    }

    /// `prefix` is the request object holding the arrays (`dwell`), or empty for top-level.
    fn from_schedule(prefix: &str, err: ScheduleError) -> Self {
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
        Input::TargetProfile => "target.profile",
        Input::FreePiston => "target.free_piston",
    }
}

/// Two alternatives as a request names them, and the field a problem with them points at:
/// siblings by their paths under their parent; otherwise by their top members, at the first.
fn alternatives(a: &'static str, b: &'static str) -> (&'static str, &'static str, &'static str) {
    match (a.rsplit_once('.'), b.rsplit_once('.')) {
        (Some((parent, _)), Some((other, _))) if parent == other => (parent, a, b),
        _ => {
            let top = |p: &'static str| p.split('.').next().unwrap_or(p);
            (top(a), top(a), top(b))
        }
    }
}

impl ApiError {
    /// A size limit exceeded by the input at `field`.
    fn from_limit(field: &str, err: SizeLimitError) -> Self {
        ApiError::limit(field, format!("{field}: {err}"))
    }
}

impl From<ProcessError> for ApiError {
    fn from(err: ProcessError) -> Self {
        ApiError::from_process(err)
    }
}

impl From<PartError> for ApiError {
    fn from(err: PartError) -> Self {
        match err {
            PartError::Surface(e) => surface_error(e),
            PartError::Tool(e) => ApiError::invalid("tool.pivot_length_mm", e.to_string()),
        }
    }
}

impl From<MachineFitError> for ApiError {
    fn from(err: MachineFitError) -> Self {
        match err {
            MachineFitError::PositionOffSurface { index, .. } => {
                ApiError::invalid(format!("positions_mm[{index}]"), err.to_string())
            }
            MachineFitError::Limits(found) => machine_limits_error(&found, "positions"),
            MachineFitError::InvalidLimit(e) => {
                ApiError::invalid(limit_field(e.drive, e.limit), e.to_string())
            }
        }
    }
}

impl From<SettingError> for ApiError {
    fn from(err: SettingError) -> Self {
        match err {
            SettingError::Part(e) => e.into(),
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
            InputError::TooLarge { input, error } => ApiError::from_limit(input_path(input), error),
            InputError::Schedule { input, error } => {
                let prefix = match input {
                    Input::Dwell => "dwell",
                    Input::Feed => "feed",
                    _ => "",
                };
                ApiError::from_schedule(prefix, error)
            }
            InputError::OutOfRange { input, .. } => {
                let field = input_path(input);
                ApiError::invalid(field, format!("{field} {err}"))
            }
            InputError::Optimize(e) => e.into(),
            InputError::Study(e) => e.into(),
            InputError::OneOf(a, b) => {
                let (field, a, b) = alternatives(input_path(a), input_path(b));
                ApiError::invalid(field, format!("give exactly one of {a} and {b}"))
            }
            InputError::Inapplicable { input, without } => {
                let field = input_path(input);
                ApiError::invalid(
                    field,
                    format!("{field} applies only with {}", input_path(without)),
                )
            }
            InputError::MachineFit(e) => e.into(),
        }
    }
}

impl From<MeasuredProfileError> for ApiError {
    fn from(err: MeasuredProfileError) -> Self {
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
            OptimizeError::Infeasible { fields, .. } => ApiError::infeasible(
                if fields.is_empty() {
                    vec!["constraints".to_string()]
                } else {
                    fields
                        .iter()
                        .map(|f| match f {
                            Bound::Constraint(c) => format!("constraints.{}", c.name()),
                            Bound::Machine(drive, limit) => limit_field(*drive, *limit),
                        })
                        .collect()
                },
                detail,
            ),
            OptimizeError::TimeLimit { .. } => {
                ApiError::new(Kind::SolverTimeLimit, detail).at("solver.time_limit_s")
            }
            OptimizeError::IterationLimit { .. } => {
                ApiError::new(Kind::SolverIterationLimit, detail)
            }
            OptimizeError::Numerical { .. } => ApiError::new(Kind::SolverNumericalError, detail),
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

/// A surface that was refused, at its field.
pub(super) fn surface_error(e: SurfaceError) -> ApiError {
    let field = surface_field(e.input());
    ApiError::invalid(field.clone(), format!("{field}: {e}"))
}

fn surface_field(input: Option<SurfaceInput>) -> String {
    match input {
        Some(SurfaceInput::RadiusOfCurvature) => "surface.radius_of_curvature_mm".into(),
        Some(SurfaceInput::ConicConstant) => "surface.conic_constant".into(),
        Some(SurfaceInput::Power(i)) => format!("surface.coefficients[{i}].power"),
        Some(SurfaceInput::Value(i)) => format!("surface.coefficients[{i}].value"),
        None => "surface".into(),
    }
}

/// The 422 `machine-limits` problem listing every violation; `what` reaches the values
/// (`program`, or the optimization's `positions`).
pub fn machine_limits_error(found: &[Violation], what: &str) -> ApiError {
    let violations: Vec<LimitViolation> = found
        .iter()
        .map(|v| LimitViolation {
            field: limit_field(v.drive, v.limit),
            axis: v.drive.name().to_string(),
            limit: v.limit.name(v.drive).to_string(),
            limit_value: v.limit_value,
            value: v.value,
            first_block: v.first_block,
            blocks: v.blocks,
        })
        .collect();
    let detail = violations
        .iter()
        .map(|v| {
            let at = v
                .first_block
                .map_or(String::new(), |b| format!(" from block {b}"));
            format!(
                "{} = {} but the {what} reach {}{at} ({} block(s))",
                v.field, v.limit_value, v.value, v.blocks
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    // A default limit the caller never wrote: say where it comes from, and for a spindle
    // point at the speed asked for.
    let defaults = found.iter().any(|v| v.default_machine);
    let note = if defaults {
        " (the default machine's limits, docs/MACHINE.md, as no machine gave them: state your \
         machine's in `machine`, or send machine: \"unlimited\" for a study)"
    } else {
        ""
    };
    let mut error = ApiError::machine_limits(
        violations,
        format!("no program within the machine's limits: {detail}{note}"),
    );
    if let Some(spindle) = found
        .first()
        .filter(|v| v.default_machine && v.limit == LimitKind::MaxRpm)
    {
        error.field = Some(match spindle.drive {
            Drive::WorkpieceSpindle => "process.workpiece_rpm".to_string(),
            _ => "process.tool_rpm".to_string(),
        });
    }
    error
}

impl From<ProgramFailure> for ApiError {
    fn from(err: ProgramFailure) -> Self {
        match err {
            ProgramFailure::Plan(e) => {
                let field = match e {
                    ProgramError::NoDwell => "dwell.dwell_s".to_string(),
                    ProgramError::ZeroInteriorDwell { index } => {
                        format!("dwell.dwell_s[{index}]")
                    }
                };
                ApiError::invalid(field, e.to_string())
            }
            ProgramFailure::Limits(found) => machine_limits_error(&found, "program would"),
        }
    }
}

impl From<ProgramInputError> for ApiError {
    fn from(err: ProgramInputError) -> Self {
        use ProgramInputError as E;
        let detail = err.to_string();
        match err {
            E::Setting(e) => e.into(),
            E::PositionOffSurface { index, .. } => {
                ApiError::invalid(format!("dwell.positions_mm[{index}]"), detail)
            }
            E::Size(e) => ApiError::from_limit("dwell.positions_mm", e),
            E::Schedule(e) => ApiError::from_schedule("dwell", e),
            E::Limits(e) => ApiError::invalid(limit_field(e.drive, e.limit), detail),
            E::Format(e) => {
                let field = match e {
                    GcodeFormatError::Decimals => "format.decimals".to_string(),
                    GcodeFormatError::Word { spindle, word } => format!("format.{spindle}.{word}"),
                };
                ApiError::invalid(field, detail)
            }
            E::Clearance => ApiError::invalid("approach.clearance_mm", detail),
            E::ApproachFeed => ApiError::invalid("approach.feed_mm_per_min", detail),
        }
    }
}

/// A machine limit's path in a request: `machine.<drive>.<limit>`.
pub fn limit_field(drive: Drive, limit: LimitKind) -> String {
    format!("machine.{}.{}", drive.name(), limit.name(drive))
}
