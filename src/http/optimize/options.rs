//! What `/v1/optimize` takes besides the setting: the target, the constraints, the
//! objective's weights and the solver's budget.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::extract::optional_object;
use crate::field::DepthProfile;
use crate::optimize::{ConstraintsSpec, Objective};
use crate::usecases::optimize::TargetSpec;

/// The target: exactly one of `uniform_depth_nm` and `profile`.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TargetDto {
    /// Remove this uniform depth over the clear aperture, nm (finite, ≥ 0).
    #[schema(example = 100.0)]
    pub uniform_depth_nm: Option<f64>,
    /// Remove a measured radial error profile (figure correction).
    #[serde(default, deserialize_with = "optional_object")]
    pub profile: Option<MeasuredProfileDto>,
    /// With `profile`: also remove the least uniform layer p ≥ 0 (nm) that lets the plan fit
    /// best, since polishing can only remove material. Default false.
    pub free_piston: Option<bool>,
}

/// A measured radial profile of the material to remove, linearly interpolated onto the radial
/// grid. It must cover the clear aperture's samples.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MeasuredProfileDto {
    /// Radii of the measurement, mm, strictly increasing (at least 2).
    #[schema(min_items = 2)]
    pub radius_mm: Vec<f64>,
    /// Depth to remove at each radius, nm (the surface's height above the wanted figure).
    #[schema(min_items = 2)]
    pub depth_nm: Vec<f64>,
}

/// Limits on the plan. The tool moves as the machine program does (docs/MODEL.md, "The
/// motion of a plan"): the cell around position j, from the midpoint before it to the one
/// after (from the position itself at the two ends), is crossed at constant speed in t_j (in
/// t_j/2 at the two ends, which stop for the other half).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ConstraintsDto {
    /// Least dwell at every position, s (≥ 0). Default 0.
    pub min_dwell_s: Option<f64>,
    /// Most dwell at any position, s (> 0). Default none.
    pub max_dwell_s: Option<f64>,
    /// Most total dwell time, s (> 0). Default none.
    pub max_total_time_s: Option<f64>,
    /// Highest feed across any cell, mm/min (1e-6 to 1e9): the X–Z path of the program's move
    /// over its duration, as `feed_mm_per_min` in the response reports it (the cell's width on
    /// a plane with the default tool). Each cell then takes at least its path / max feed.
    /// Default none.
    pub max_feed_mm_per_min: Option<f64>,
    /// Largest change of dwell between neighbouring positions, s (≥ 0): a linear surrogate
    /// for the feed axis's acceleration limit. On positions spaced h mm apart with a feed limit
    /// v (mm/s), a dwell change δ keeps the feed acceleration between interior cells at or
    /// below δ·v³/h² mm/s² (4/3 of that next to the end cells; the start and stop at the two
    /// ends are not bounded by it); give `machine` instead to have an acceleration limit kept
    /// exactly. Default none.
    pub max_dwell_change_s: Option<f64>,
}

/// Weights of the objective J = fit + smoothing + time (see the crate docs of
/// `preston::optimize`): the fit is the mean squared (removal − target) over the aperture,
/// relative to the target's RMS depth; smoothing is the mean squared curvature of the dwell
/// over one pad radius; time is the total time relative to equal dwell.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ObjectiveDto {
    /// λ, dimensionless (≥ 0). Damps dwell that oscillates from one position to the next.
    /// Default 1e-6.
    pub smoothing: Option<f64>,
    /// μ, dimensionless (≥ 0). Prefers the quicker of plans that fit about equally well; it
    /// biases the mean depth low by about μ (relative). Default 2e-6.
    pub time_weight: Option<f64>,
}

/// Solver settings.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SolverOptionsDto {
    /// Wall-clock budget for the solver, s (> 0). Default and maximum: the server's solver
    /// time limit (10 s by default).
    pub time_limit_s: Option<f64>,
}

impl ConstraintsDto {
    pub(crate) fn to_constraints(dto: Option<&ConstraintsDto>) -> ConstraintsSpec {
        let dto = dto.cloned().unwrap_or_default();
        ConstraintsSpec {
            min_dwell_s: dto.min_dwell_s.unwrap_or(0.0),
            max_dwell_s: dto.max_dwell_s,
            max_total_time_s: dto.max_total_time_s,
            max_feed_mm_per_min: dto.max_feed_mm_per_min,
            max_dwell_change_s: dto.max_dwell_change_s,
        }
    }
}

impl ObjectiveDto {
    pub(crate) fn to_objective(dto: Option<&ObjectiveDto>) -> Objective {
        let dto = dto.cloned().unwrap_or_default();
        let default = Objective::default();
        Objective {
            smoothing: dto.smoothing.unwrap_or(default.smoothing),
            time_weight: dto.time_weight.unwrap_or(default.time_weight),
        }
    }
}

impl From<TargetDto> for TargetSpec {
    fn from(t: TargetDto) -> Self {
        TargetSpec {
            uniform_depth_nm: t.uniform_depth_nm,
            profile: t.profile.map(|p| DepthProfile {
                radius_mm: p.radius_mm,
                depth_nm: p.depth_nm,
            }),
            free_piston: t.free_piston,
        }
    }
}
