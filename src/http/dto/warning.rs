//! Warnings: what a caller should know about a result that stands.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::usecases::Warning;

/// Something about a result the caller should know: the result stands, but may not be what
/// was meant.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct WarningDto {
    /// What kind of warning (machine-readable).
    pub code: WarningCode,
    /// The request field to look at, if one is; e.g. `constraints.max_total_time_s`.
    #[schema(required = true)]
    pub field: Option<String>,
    /// What it means, in words.
    pub message: String,
}

/// The kinds of warning.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum WarningCode {
    /// The optimized plan sits on the limit named in `field` (a total-time budget, a dwell
    /// bound, the feed or dwell-change limit, a machine axis's velocity or acceleration): that limit, not the target, decided the plan
    /// there; relaxing it would fit the target better.
    ConstraintActive,
    /// The optimized plan's residual RMS over the clear aperture is more than 10 % of the
    /// target's RMS.
    TargetNotMet,
    /// Every tool position is below 1 mm on a workpiece of 10 mm radius or more: positions are
    /// in millimetres, and these look like metres.
    PositionsLookLikeMetres,
    /// The workpiece radius is below 1 mm: the process's radii are in millimetres, and these
    /// look like metres (`field` names the workpiece radius).
    ProcessLooksLikeMetres,
    /// The plan has zero dwell between positions with dwell at the position in `field`: no
    /// machine program can run it (set `constraints.min_dwell_s` > 0 or a feed limit).
    NotProgrammable,
    /// The nominal pressure is above 1000 kPa (10 bar); polishing pressures are about 1 to
    /// 100 kPa, so this looks like pascals typed as kilopascals.
    PressureLooksLikePascals,
    /// `machine` is `"unlimited"`: the plan or program was checked against no machine's
    /// limits; it is a study, not a program to send to a machine.
    MachineUnlimited,
    /// A measurement was fitted without `surface`, to a plane; the message gives the
    /// best-fit sphere's radius of curvature and residual beside the plane's.
    SurfaceAssumedPlane,
    /// Calibration: no run depends on the parameter in `field` (e.g. `fit.pad_moment_share`
    /// with no pad over the edge): it was held at its nominal value, with no standard error.
    ParameterUndetermined,
    /// Calibration: the parameter in `field` was fitted, but its 95 % interval is wider than
    /// 20 % of its value (0.25 for `pad_moment_share`): the runs barely determine it.
    ParameterPoorlyDetermined,
    /// Calibration: the model fits the runs exactly (residual RMS below 1e-6 nm), so they
    /// carry no estimate of their noise: no parameter has a standard error.
    ExactFit,
    /// A production cycle's removal does not determine the removal rate (its K is not 2
    /// standard errors above 0, or has none): the profile does not learn from it.
    RemovalNotSignificant,
    /// Calibration: the run in `field` leaves a residual more than 3× its measurement noise
    /// (`expected_noise_nm`, else the noise of its point-to-point differences).
    ResidualAboveNoise,
    /// Map analysis: more than 2 % of the clear aperture's pixels hold no height; the figures
    /// describe the others.
    MapDropouts,
    /// A result map was computed at a coarser pixel than asked (`pixel_mm`), to stay within
    /// the work limit of one request.
    MapCoarsened,
    /// The target holds harmonics above the plan's `max_harmonic`, left in the residual.
    HarmonicsLeft,
    /// The dwell map's solver stopped at its work limit before it converged (`solver`
    /// reports its optimality residual): the plan keeps every limit but may not be the best.
    SolverNotConverged,
}

impl WarningDto {
    /// Warnings that name no tool positions (a request without them).
    pub fn all(warnings: &[Warning]) -> Vec<Self> {
        Self::all_at(warnings, "positions_mm")
    }

    /// Warnings whose tool positions are the request field `positions`.
    pub fn all_at(warnings: &[Warning], positions: &str) -> Vec<Self> {
        warnings.iter().map(|w| Self::new(w, positions)).collect()
    }

    /// `positions` is the request field holding the tool positions.
    pub fn new(w: &Warning, positions: &str) -> Self {
        let (code, field) = match w {
            Warning::ConstraintActive { constraint } => (
                WarningCode::ConstraintActive,
                format!("constraints.{}", constraint.name()),
            ),
            Warning::TargetNotMet { .. } => (WarningCode::TargetNotMet, "target".to_string()),
            Warning::MachineLimitActive { drive, limit, .. } => (
                WarningCode::ConstraintActive,
                super::super::fields::limit_field(*drive, *limit),
            ),
            Warning::NotProgrammable { index } => (
                WarningCode::NotProgrammable,
                format!("{positions}[{index}]"),
            ),
            Warning::ProcessLooksLikeMetres { .. } => (
                WarningCode::ProcessLooksLikeMetres,
                "process.workpiece_radius_mm".to_string(),
            ),
            Warning::PositionsLookLikeMetres { .. } => {
                (WarningCode::PositionsLookLikeMetres, positions.to_string())
            }
            Warning::PressureLooksLikePascals { .. } => (
                WarningCode::PressureLooksLikePascals,
                "process.pressure_kpa".to_string(),
            ),
            Warning::MachineUnlimited => (WarningCode::MachineUnlimited, "machine".to_string()),
            Warning::SurfaceAssumedPlane { .. } => {
                (WarningCode::SurfaceAssumedPlane, "surface".to_string())
            }
            Warning::ExactFit => (WarningCode::ExactFit, "runs".to_string()),
            Warning::RemovalNotSignificant { .. } => (
                WarningCode::RemovalNotSignificant,
                "removal_ratio".to_string(),
            ),
            Warning::ParameterUndetermined { parameter, .. } => (
                WarningCode::ParameterUndetermined,
                format!("fit.{}", parameter.name()),
            ),
            Warning::ParameterPoorlyDetermined { parameter, .. } => (
                WarningCode::ParameterPoorlyDetermined,
                format!("fit.{}", parameter.name()),
            ),
            Warning::ResidualAboveNoise { run, .. } => {
                (WarningCode::ResidualAboveNoise, format!("runs[{run}]"))
            }
            Warning::MapDropouts { .. } => (WarningCode::MapDropouts, "map".to_string()),
            Warning::MapCoarsened { .. } => {
                (WarningCode::MapCoarsened, "removal_pixel_mm".to_string())
            }
            Warning::HarmonicsLeft { .. } => {
                (WarningCode::HarmonicsLeft, "c_law.max_harmonic".to_string())
            }
            Warning::SolverNotConverged { .. } => (
                WarningCode::SolverNotConverged,
                "dwell_pitch_mm".to_string(),
            ),
        };
        WarningDto {
            code,
            field: Some(field),
            message: w.to_string(),
        }
    }
}
