//! Request and response objects shared by several endpoints (the v1 contract's stable names),
//! and their conversion into and out of the core's types.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::error::ApiError;
use super::extract::optional_count;
use crate::physics::UniformityMetrics;
use crate::physics::{
    ClearAperture, Orientation, Part, PressureModel, PressureModelKind, ProcessSpec,
};
use crate::surface::SurfaceSpec;
use crate::usecases::{ApertureSpec, ComputeLimits, GridSpec, PartSpec, Setting};

mod machine;
mod recommendation;
mod segments;
mod surface;
mod warning;

pub use machine::*;
pub use recommendation::*;
pub use segments::*;
pub use surface::*;
pub use warning::*;

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
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
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
    /// Under `linear`: the pad's share κ of the tipping moment about its centre, in [0, 1]
    /// (1: a free gimbal, the load acting at the pad centre; 0: the head holds the pad level
    /// and the pressure is the constant-force model's). Default 1. Only `linear` uses it, but
    /// a value outside [0, 1] is refused with any model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(example = 1.0, minimum = 0.0, maximum = 1.0)]
    pub pad_moment_share: Option<f64>,
}

/// How the pad presses, and so how far out the tool may go (its reach). `uniform`: the nominal
/// pressure everywhere under the pad, also when it overhangs the edge (the paper's assumption;
/// tool positions up to r_m + r_t). `constant_force`: the force of the
/// nominal pressure on the full pad rests on the part of the pad still on the workpiece, so the
/// pressure rises as the pad overhangs (tool positions up to r_m). `linear`: a rigid pad under
/// that force with pressure linear across the contact, balanced in force and in moment (the pad
/// carries `pad_moment_share` of the tipping moment, the head the rest): overhanging, the
/// pressure rises toward the edge, and where it would turn negative the pad lifts on its inner
/// side. Tool positions must stay below where the load would rest on the edge alone (r_m for
/// `pad_moment_share` 1, up to r_m + r_t as it falls to 0). On curved parts every model is
/// taken along the surface (the overhang, the contact and its balance in arc lengths from the
/// vertex).
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PressureModelDto {
    #[default]
    Uniform,
    ConstantForce,
    Linear,
}

impl ProcessDto {
    /// A process as a request would give it (the part is the request's `surface` and `tool`).
    pub fn from_spec(spec: &ProcessSpec) -> ProcessDto {
        let (pressure_model, pad_moment_share) = match spec.pressure_model {
            PressureModel::Uniform => (PressureModelDto::Uniform, None),
            PressureModel::ConstantForce => (PressureModelDto::ConstantForce, None),
            PressureModel::Linear { pad_moment_share } => {
                (PressureModelDto::Linear, Some(pad_moment_share))
            }
        };
        ProcessDto {
            workpiece_radius_mm: spec.workpiece_radius_mm,
            tool_radius_mm: spec.tool_radius_mm,
            workpiece_rpm: spec.workpiece_rpm,
            tool_rpm: spec.tool_rpm,
            preston_coefficient_m2_per_n: spec.preston_coefficient_m2_per_n,
            pressure_kpa: spec.pressure_kpa,
            pressure_model,
            pad_moment_share,
        }
    }

    /// The process as the core takes it (its pressure model parsed with κ).
    pub fn spec(&self) -> Result<ProcessSpec, ApiError> {
        let kind = match self.pressure_model {
            PressureModelDto::Uniform => PressureModelKind::Uniform,
            PressureModelDto::ConstantForce => PressureModelKind::ConstantForce,
            PressureModelDto::Linear => PressureModelKind::Linear,
        };
        Ok(ProcessSpec {
            workpiece_radius_mm: self.workpiece_radius_mm,
            tool_radius_mm: self.tool_radius_mm,
            workpiece_rpm: self.workpiece_rpm,
            tool_rpm: self.tool_rpm,
            preston_coefficient_m2_per_n: self.preston_coefficient_m2_per_n,
            pressure_kpa: self.pressure_kpa,
            pressure_model: PressureModel::parse(kind, self.pad_moment_share)?,
            part: Part::flat(),
        })
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

/// The part and tool a request describes, as given (the use case checks them). A part of
/// revolution about C only ([`round_surface`]).
pub fn part_spec(
    surface: Option<&SurfaceDto>,
    tool: Option<&ToolDto>,
) -> Result<PartSpec, ApiError> {
    Ok(PartSpec {
        surface: round_surface(surface)?,
        pivot_length_mm: tool.and_then(|t| t.pivot_length_mm),
        orientation: tool.and_then(|t| t.orientation).map(Orientation::from),
    })
}

/// A request's surface as a part of revolution about C: a decentre other than 0 is the maps
/// endpoints' alone (`part_on_c`), refused here naming `surface.decenter_mm`.
pub fn round_surface(surface: Option<&SurfaceDto>) -> Result<Option<SurfaceSpec>, ApiError> {
    if surface
        .and_then(SurfaceDto::decenter_mm)
        .is_some_and(|d| d != 0.0)
    {
        return Err(ApiError::invalid(
            "surface.decenter_mm",
            "a decentred part is not round about C: /v1/maps/optimize, /v1/maps/predict and \
             /v1/maps/program take it (here leave decenter_mm out, or 0)",
        ));
    }
    Ok(surface.map(SurfaceSpec::from))
}

/// The members every computing request on a process shares.
pub struct SettingDtos<'a> {
    pub process: &'a ProcessDto,
    pub surface: Option<&'a SurfaceDto>,
    pub tool: Option<&'a ToolDto>,
    pub grid: Option<&'a RadialGridDto>,
    pub aperture: Option<&'a ClearApertureDto>,
}

/// The [`SettingDtos`] of a request with the usual members (`process`, `surface`, `tool`,
/// `radial_grid`, `clear_aperture`).
macro_rules! setting_of {
    ($req:expr) => {
        $crate::http::dto::SettingDtos {
            process: &$req.process,
            surface: $req.surface.as_ref(),
            tool: $req.tool.as_ref(),
            grid: $req.radial_grid.as_ref(),
            aperture: $req.clear_aperture.as_ref(),
        }
    };
}
pub(crate) use setting_of;

impl SettingDtos<'_> {
    /// The use case's setting: its process on its part, radial grid and clear aperture.
    pub fn parse(self, limits: &ComputeLimits) -> Result<Setting, ApiError> {
        Ok(Setting::new(
            self.process.spec()?,
            &part_spec(self.surface, self.tool)?,
            self.grid.into(),
            self.aperture.into(),
            limits,
        )?)
    }
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
/// within the reach `pressure_model` gives) and the time spent at each (s, ≥ 0). Same length.
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
