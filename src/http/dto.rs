//! Request and response objects shared by several endpoints (the v1 contract's stable names),
//! and their conversion into and out of the core's types.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::error::ApiError;
use super::extract::{count, optional_count};
use super::fields::surface_error;
use super::program::ToolDto;
use crate::machine::Tool;
use crate::physics::{ClearAperture, ConstantFeed, PressureModel, ProcessSpec, UniformityMetrics};
use crate::physics::{Orientation, Part};
use crate::study::{EqualDwell, Recommendation, SpeedRule};
use crate::surface::{PolynomialTerm, Surface, SurfaceSpec};
use crate::usecases::{ApertureSpec, ComputeLimits, GridSpec, Setting, Warning};

fn default_preston_coefficient() -> f64 {
    1e-13
}
fn default_pressure_kpa() -> f64 {
    10.0
}

/// The polishing process. Speeds are signed r/min in one lab frame, counter-clockwise positive
/// as seen from the tool side. The paper's speed ratio is η = −workpiece_rpm / tool_rpm, so
/// η = −1 means workpiece and tool turning the same way at the same speed (uniform removal with
/// equal dwell). The paper's experiment 1 (workpiece 10 r/min clockwise, tool 200 r/min
/// counter-clockwise) is workpiece_rpm = −10, tool_rpm = 200 (η = +0.05).
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ProcessDto {
    /// Workpiece radius r_m in mm, in [0.001, 100000].
    #[schema(example = 50.0, minimum = 0.001, maximum = 100000.0)]
    pub workpiece_radius_mm: f64,
    /// Tool (pad) radius r_t in mm, in [0.001, 100000].
    #[schema(example = 10.0, minimum = 0.001, maximum = 100000.0)]
    pub tool_radius_mm: f64,
    /// Workpiece speed in r/min, signed, lab frame, counter-clockwise positive, |·| ≤ 100000.
    /// Must not be 0: the radial model averages over workpiece revolutions.
    #[schema(example = -10.0, minimum = -100000.0, maximum = 100000.0)]
    pub workpiece_rpm: f64,
    /// Tool spin in r/min, signed, lab frame, counter-clockwise positive, |·| ≤ 100000. 0 is
    /// allowed (η is then undefined and reported as null).
    #[schema(example = 200.0, minimum = -100000.0, maximum = 100000.0)]
    pub tool_rpm: f64,
    /// Preston coefficient K in m²/N (= 1/Pa), in [0, 1e-6]. Default 1e-13.
    #[serde(default = "default_preston_coefficient")]
    #[schema(example = 1e-13, minimum = 0.0, maximum = 1e-6)]
    pub preston_coefficient_m2_per_n: f64,
    /// Nominal pad pressure in kPa, in (0, 1000000], with the whole pad on the workpiece.
    /// Default 10.
    #[serde(default = "default_pressure_kpa")]
    #[schema(example = 10.0, maximum = 1000000.0, exclusive_minimum = 0.0)]
    pub pressure_kpa: f64,
    /// How pressure depends on the tool position. Default `uniform`.
    #[serde(default)]
    pub pressure_model: PressureModelDto,
}

/// `uniform`: the nominal pressure everywhere under the pad, also when it overhangs the edge
/// (the paper's assumption; tool positions up to r_m + r_t). `constant_force`: the force of the
/// nominal pressure on the full pad rests on the part of the pad still on the workpiece, so the
/// pressure rises as the pad overhangs (tool positions up to r_m).
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PressureModelDto {
    #[default]
    Uniform,
    ConstantForce,
}

impl From<&ProcessDto> for ProcessSpec {
    fn from(p: &ProcessDto) -> Self {
        ProcessSpec {
            workpiece_radius_mm: p.workpiece_radius_mm,
            tool_radius_mm: p.tool_radius_mm,
            workpiece_rpm: p.workpiece_rpm,
            tool_rpm: p.tool_rpm,
            preston_coefficient_m2_per_n: p.preston_coefficient_m2_per_n,
            pressure_kpa: p.pressure_kpa,
            pressure_model: match p.pressure_model {
                PressureModelDto::Uniform => PressureModel::Uniform,
                PressureModelDto::ConstantForce => PressureModel::ConstantForce,
            },
            part: Part::flat(),
        }
    }
}

/// Radii where removal is reported: `count` evenly spaced samples from `start_mm` to `stop_mm`
/// inclusive, on the workpiece. Every member is optional; the default grid is 201 samples from
/// 0 to the workpiece radius.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RadialGridDto {
    /// First radius in mm (≥ 0). Default 0.
    #[schema(example = 0.0)]
    pub start_mm: Option<f64>,
    /// Last radius in mm (≤ workpiece radius). Default: the workpiece radius.
    #[schema(example = 50.0)]
    pub stop_mm: Option<f64>,
    /// Number of samples (≥ 2, or 1 when start_mm = stop_mm; at most the server's
    /// max_radial_samples, 10001 by default). Default 201.
    #[schema(example = 201, minimum = 1, maximum = 1_000_000_000, format = Int32)]
    #[serde(default, deserialize_with = "optional_count")]
    pub count: Option<usize>,
}

impl From<Option<&RadialGridDto>> for GridSpec {
    fn from(g: Option<&RadialGridDto>) -> Self {
        g.map_or_else(GridSpec::default, |g| GridSpec {
            start_mm: g.start_mm,
            stop_mm: g.stop_mm,
            count: g.count,
        })
    }
}

/// Radii [inner_mm, outer_mm] where uniformity is judged (an annulus is allowed). Default: the
/// whole workpiece. The radial grid must span it.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ClearApertureDto {
    /// Inner radius in mm (≥ 0). Default 0.
    #[schema(example = 0.0)]
    pub inner_mm: Option<f64>,
    /// Outer radius in mm (> inner_mm, ≤ workpiece radius). Default: the workpiece radius.
    #[schema(example = 40.0)]
    pub outer_mm: Option<f64>,
}

impl From<Option<&ClearApertureDto>> for ApertureSpec {
    fn from(a: Option<&ClearApertureDto>) -> Self {
        a.map_or_else(ApertureSpec::default, |a| ApertureSpec {
            inner_mm: a.inner_mm,
            outer_mm: a.outer_mm,
        })
    }
}

/// The part a request describes: its `surface` (default a plane) and the pad's spin axis from
/// `tool.orientation` (default `normal`), the surface checked and any error naming its field.
pub fn part(surface: Option<&SurfaceDto>, tool: Option<&ToolDto>) -> Result<Part, ApiError> {
    let surface = Surface::new(&surface.map_or(SurfaceSpec::Plane, SurfaceSpec::from))
        .map_err(surface_error)?;
    let orientation = tool
        .and_then(|t| t.orientation)
        .map_or(Orientation::Normal, Orientation::from);
    // The whole tool is checked, though only its orientation matters to removal: what the
    // schema refuses is refused everywhere.
    if let Some(pivot) = tool.and_then(|t| t.pivot_length_mm) {
        Tool::new(pivot, orientation)
            .map_err(|e| ApiError::invalid("tool.pivot_length_mm", e.to_string()))?;
    }
    Ok(Part {
        surface,
        orientation,
    })
}

/// The process of a request on its part.
pub fn process_spec(
    process: &ProcessDto,
    surface: Option<&SurfaceDto>,
    tool: Option<&ToolDto>,
) -> Result<ProcessSpec, ApiError> {
    Ok(ProcessSpec {
        part: part(surface, tool)?,
        ..process.into()
    })
}

/// Where the request's process, part and pad act: the members every computing request shares.
pub struct Place<'a> {
    pub process: &'a ProcessDto,
    pub surface: Option<&'a SurfaceDto>,
    pub tool: Option<&'a ToolDto>,
}

/// The setting of a request: its process on its part, radial grid and clear aperture.
pub fn setting(
    place: Place,
    grid: Option<&RadialGridDto>,
    aperture: Option<&ClearApertureDto>,
    limits: &ComputeLimits,
) -> Result<Setting, ApiError> {
    Ok(Setting::new(
        process_spec(place.process, place.surface, place.tool)?,
        grid.into(),
        aperture.into(),
        limits,
    )?)
}

/// The clear aperture actually used (defaults filled in), in mm.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct ApertureEcho {
    /// Inner radius, mm.
    pub inner_mm: f64,
    /// Outer radius, mm.
    pub outer_mm: f64,
}

impl From<&ClearAperture> for ApertureEcho {
    fn from(a: &ClearAperture) -> Self {
        ApertureEcho {
            inner_mm: a.inner_mm(),
            outer_mm: a.outer_mm(),
        }
    }
}

/// Uniformity of the removal over the clear aperture, taken over the radial samples inside it
/// (each sample counts once: a radius average, not an area average).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct MetricsDto {
    /// Mean removal depth, nm.
    pub mean_nm: f64,
    /// Smallest removal depth, nm.
    pub min_nm: f64,
    /// Largest removal depth, nm.
    pub max_nm: f64,
    /// Peak-to-valley: max_nm − min_nm, nm.
    pub pv_nm: f64,
    /// Root-mean-square deviation from the mean, nm.
    pub rms_nm: f64,
    /// pv_nm / mean_nm, a fraction (0.01 = 1 %); null when nothing is removed in the aperture.
    #[schema(required = true)]
    pub nonuniformity: Option<f64>,
    /// Number of radial samples inside the clear aperture.
    #[schema(format = Int32)]
    pub samples: usize,
}

impl From<&UniformityMetrics> for MetricsDto {
    fn from(m: &UniformityMetrics) -> Self {
        MetricsDto {
            mean_nm: m.mean_nm,
            min_nm: m.min_nm,
            max_nm: m.max_nm,
            pv_nm: m.pv_nm,
            rms_nm: m.rms_nm,
            nonuniformity: m.nonuniformity,
            samples: m.samples,
        }
    }
}

/// Tool dwell: positions of the tool centre (mm from the workpiece axis, strictly increasing,
/// 0 to r_m + r_t under uniform pressure or 0 to r_m under constant force) and the time spent
/// at each (s, ≥ 0). Same length.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DwellDto {
    /// Tool-centre radii in mm, strictly increasing.
    #[schema(min_items = 1)]
    pub positions_mm: Vec<f64>,
    /// Dwell time at each position in s (≥ 0), one per position.
    #[schema(min_items = 1)]
    pub dwell_s: Vec<f64>,
}

/// η = −1 settings: workpiece and tool turning the same way (same sign) at the same speed,
/// where equal dwell removes a uniform layer. All comparisons use equal dwell (one constant
/// feed over [0, min(outer + r_t, reach)] mm) removing the same mean depth.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RecommendationDto {
    /// Recommended workpiece speed, r/min, signed (lab frame, CCW positive); equals tool_rpm.
    pub workpiece_rpm: f64,
    /// Recommended tool speed, r/min, signed; keeps the current tool direction.
    pub tool_rpm: f64,
    /// −1.
    pub eta: f64,
    /// `match_removal_rate`: the speed keeps the current mean removal rate over the clear
    /// aperture; `fastest_allowed`: the limits forbid that, so the fastest allowed speed.
    pub rule: SpeedRuleDto,
    /// The interval of η around −1 (tool speed held) where equal-dwell nonuniformity stays at
    /// or below the threshold; null when even η = −1 is above it.
    #[schema(required = true)]
    pub eta_window: Option<EtaWindowDto>,
    /// Predicted uniformity of equal dwell at the recommended speeds, nm.
    pub metrics: MetricsDto,
    /// Predicted uniformity of equal dwell at the current speeds, nm.
    pub current_metrics: MetricsDto,
    /// Current nonuniformity / recommended nonuniformity; null when undefined or when equal
    /// dwell at the recommended speeds is uniform to rounding (below 1e-9), as it is on a
    /// plane.
    #[schema(required = true)]
    pub improvement_factor: Option<f64>,
    /// The equal-dwell plan at the recommended speeds.
    pub equal_dwell: EqualDwellDto,
    /// The constant feed equal dwell needs at the current speeds for the same depth, mm/min.
    pub current_feed_mm_per_min: f64,
}

/// Which rule chose the recommended speed.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SpeedRuleDto {
    /// The speed keeps the current mean removal rate over the clear aperture.
    MatchRemovalRate,
    /// The machine's limits forbid that speed; the fastest allowed is used.
    FastestAllowed,
}

/// η bounds (paper convention, η = −workpiece_rpm / tool_rpm); null where no bound was found.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct EtaWindowDto {
    /// Lower η bound (below −1); null if none down to η = −51.
    #[schema(required = true)]
    pub low: Option<f64>,
    /// Upper η bound (above −1, below 0); null if none up to η = −1e-6.
    #[schema(required = true)]
    pub high: Option<f64>,
    /// The nonuniformity threshold the bounds meet (a fraction).
    pub nonuniformity_threshold: f64,
}

/// The tool travelling at one constant feed along the surface (along the arc on a curved
/// part) from `start_mm` to `stop_mm`: equal dwell per unit length, with no cells.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FeedDto {
    /// Where the pass starts: the pad centre's radial position, mm (0 to the tool's reach).
    pub start_mm: f64,
    /// Where it ends, mm (above `start_mm`, at most the tool's reach).
    pub stop_mm: f64,
    /// The feed along the surface, mm/min (> 0).
    pub feed_mm_per_min: f64,
}

impl From<&ConstantFeed> for FeedDto {
    fn from(feed: &ConstantFeed) -> Self {
        FeedDto {
            start_mm: feed.start_mm(),
            stop_mm: feed.stop_mm(),
            feed_mm_per_min: feed.feed_mm_per_min(),
        }
    }
}

/// An equal-dwell plan: one constant feed over the path (ready for `/v1/predict`'s `feed`).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct EqualDwellDto {
    /// Mean depth it removes over the clear aperture, nm.
    pub depth_nm: f64,
    /// The pass: from 0 to min(outer + r_t, reach) mm at one feed.
    pub feed: FeedDto,
    /// Travel time, s.
    pub total_time_s: f64,
}

impl From<&EqualDwell> for EqualDwellDto {
    fn from(pass: &EqualDwell) -> Self {
        EqualDwellDto {
            depth_nm: pass.metrics.mean_nm,
            feed: FeedDto::from(&pass.pass),
            total_time_s: pass.total_time_s,
        }
    }
}

impl From<&Recommendation> for RecommendationDto {
    fn from(r: &Recommendation) -> Self {
        RecommendationDto {
            workpiece_rpm: r.workpiece_rpm,
            tool_rpm: r.tool_rpm,
            eta: -1.0,
            rule: match r.rule {
                SpeedRule::MatchRemovalRate => SpeedRuleDto::MatchRemovalRate,
                SpeedRule::FastestAllowed => SpeedRuleDto::FastestAllowed,
            },
            eta_window: r.eta_window.map(|w| EtaWindowDto {
                low: w.low,
                high: w.high,
                nonuniformity_threshold: w.threshold,
            }),
            metrics: MetricsDto::from(&r.recommended.metrics),
            current_metrics: MetricsDto::from(&r.current.metrics),
            improvement_factor: r.improvement_factor,
            equal_dwell: EqualDwellDto::from(&r.recommended),
            current_feed_mm_per_min: r.current.feed_mm_per_min(),
        }
    }
}

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
                let field = super::fields::limit_field(*drive, *limit);
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

/// The design surface. z runs along the rotation axis, positive toward the tool; R > 0 puts
/// the centre of curvature on the tool side (concave as the tool sees it), R < 0 convex.
/// Sag z(r) = c·r²/(1 + √(1 − (1+k)·c²·r²)) + Σ aᵢ·|r|^i with c = 1/R (ISO 10110-12); the
/// square root must stay real over the part.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SurfaceDto {
    /// A plane.
    Plane {},
    /// A sphere of vertex radius R (mm, ≠ 0).
    Sphere { radius_of_curvature_mm: f64 },
    /// An even asphere with optional polynomial terms of any power 1–40.
    Asphere {
        /// Vertex radius R, mm (≠ 0).
        radius_of_curvature_mm: f64,
        /// Conic constant k (0 sphere, −1 paraboloid, < −1 hyperboloid). Default 0.
        #[serde(default)]
        conic_constant: f64,
        /// Polynomial terms aᵢ·|r|^i, each power once. Default none.
        #[serde(default)]
        coefficients: Vec<CoefficientDto>,
    },
}

/// One polynomial term aᵢ·|r|^i.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CoefficientDto {
    /// The power i, 1 to 40.
    #[serde(deserialize_with = "count")]
    #[schema(value_type = u32, minimum = 1, maximum = 40)]
    pub power: usize,
    /// aᵢ in mm^(1−i).
    pub value: f64,
}

impl From<&SurfaceDto> for SurfaceSpec {
    fn from(s: &SurfaceDto) -> Self {
        match s {
            SurfaceDto::Plane {} => SurfaceSpec::Plane,
            SurfaceDto::Sphere {
                radius_of_curvature_mm,
            } => SurfaceSpec::Sphere {
                radius_of_curvature_mm: *radius_of_curvature_mm,
            },
            SurfaceDto::Asphere {
                radius_of_curvature_mm,
                conic_constant,
                coefficients,
            } => SurfaceSpec::Asphere {
                radius_of_curvature_mm: *radius_of_curvature_mm,
                conic_constant: *conic_constant,
                coefficients: coefficients
                    .iter()
                    .map(|c| PolynomialTerm {
                        // Beyond u32 is beyond 1–40: refused by the surface check.
                        power: u32::try_from(c.power).unwrap_or(u32::MAX),
                        value: c.value,
                    })
                    .collect(),
            },
        }
    }
}
