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
}

impl WarningDto {
    /// `positions` is the request field holding the tool positions.
    pub fn new(w: &Warning, positions: &str) -> Self {
        match w {
            Warning::ConstraintActive { constraint } => {
                let name = constraint.name();
                WarningDto {
                    code: WarningCode::ConstraintActive,
                    field: Some(format!("constraints.{name}")),
                    message: format!(
                        "the plan sits on {name}: that limit, not the target, decided it there"
                    ),
                }
            }
            Warning::TargetNotMet {
                residual_rms_nm,
                target_rms_nm,
            } => WarningDto {
                code: WarningCode::TargetNotMet,
                field: Some("target".to_string()),
                message: format!(
                    "the residual RMS over the clear aperture is {residual_rms_nm:.4} nm, {:.1} % of the target's RMS ({target_rms_nm:.4} nm)",
                    100.0 * residual_rms_nm / target_rms_nm
                ),
            },
            Warning::MachineLimitActive { drive, limit } => {
                let field = super::super::fields::limit_field(*drive, *limit);
                WarningDto {
                    code: WarningCode::ConstraintActive,
                    message: format!(
                        "the plan sits on {field}: the machine, not the target, decided it there"
                    ),
                    field: Some(field),
                }
            }
            Warning::NotProgrammable { index } => WarningDto {
                code: WarningCode::NotProgrammable,
                field: Some(format!("{positions}[{index}]")),
                message: format!(
                    "the plan has zero dwell at {positions}[{index}] between positions with dwell, so the tool would cross its cell in no time and no program can run it: give constraints.min_dwell_s > 0, constraints.max_feed_mm_per_min or a velocity limit on X"
                ),
            },
            Warning::ProcessLooksLikeMetres {
                workpiece_radius_mm,
                tool_radius_mm,
            } => WarningDto {
                code: WarningCode::ProcessLooksLikeMetres,
                field: Some("process.workpiece_radius_mm".to_string()),
                message: format!(
                    "the workpiece radius is {workpiece_radius_mm} mm and the pad's {tool_radius_mm} mm: radii are in millimetres; are these metres?"
                ),
            },
            Warning::PositionsLookLikeMetres {
                max_position_mm,
                workpiece_radius_mm,
            } => WarningDto {
                code: WarningCode::PositionsLookLikeMetres,
                field: Some(positions.to_string()),
                message: format!(
                    "every position is below 1 mm (at most {max_position_mm} mm) on a workpiece of {workpiece_radius_mm} mm radius: positions are in millimetres; are these in metres?"
                ),
            },
        }
    }
}
