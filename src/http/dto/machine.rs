//! The machine as requests describe it (the tool, the limits of each axis and spindle) and
//! as responses report it (each axis's travel, peaks and use of its limits).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::extract::optional_object;
use crate::machine::{
    Axis, AxisLimits, AxisMotion, MachineChoice, MachineLimits, MachineLimitsSpec, Orientation,
    Program, Utilisation,
};

/// How the tool is carried: `normal` (B follows the surface normal) or `vertical` (no tilt).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum OrientationDto {
    Normal,
    Vertical,
}

/// The tool as the machine carries it.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ToolDto {
    /// From the pad face centre to the B pivot along the tool axis, mm (0 to 10000). Default 0.
    #[schema(minimum = 0.0, maximum = 10000.0)]
    pub pivot_length_mm: Option<f64>,
    /// Default `normal`.
    pub orientation: Option<OrientationDto>,
}

/// Limits of a linear axis (X or Z); each optional (absent: the default machine's, which has
/// no travel limits).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct LinearAxisDto {
    /// Lowest position, mm (design frame: the surface vertex at 0, Z positive toward the tool).
    pub min_mm: Option<f64>,
    /// Highest position, mm (above min_mm).
    pub max_mm: Option<f64>,
    /// Largest |velocity|, mm/min (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_velocity_mm_per_min: Option<f64>,
    /// Largest |acceleration|, mm/s² (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_acceleration_mm_per_s2: Option<f64>,
}

/// Limits of the tilt axis B; each optional (absent: the default machine's, which has no
/// travel limits).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RotaryAxisDto {
    /// Lowest angle, deg.
    pub min_deg: Option<f64>,
    /// Highest angle, deg (above min_deg).
    pub max_deg: Option<f64>,
    /// Largest |angular velocity|, deg/min (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_velocity_deg_per_min: Option<f64>,
    /// Largest |angular acceleration|, deg/s² (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_acceleration_deg_per_s2: Option<f64>,
}

/// A spindle's speed limit (absent: the default machine's).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SpindleLimitDto {
    /// Largest |speed|, r/min (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_rpm: Option<f64>,
}

/// The machine's limits, per axis and spindle; each optional (absent: the default machine's,
/// docs/MACHINE.md; for no limits at all send `machine: "unlimited"`).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MachineDto {
    /// X, the radial axis (mm).
    #[serde(default, deserialize_with = "optional_object")]
    pub x: Option<LinearAxisDto>,
    /// Z, the axial axis (mm, positive toward the tool).
    #[serde(default, deserialize_with = "optional_object")]
    pub z: Option<LinearAxisDto>,
    /// B, the tool's tilt in the meridian plane (deg, B = θ the slope angle).
    #[serde(default, deserialize_with = "optional_object")]
    pub b: Option<RotaryAxisDto>,
    /// The workpiece spindle's speed limit.
    #[serde(default, deserialize_with = "optional_object")]
    pub workpiece_spindle: Option<SpindleLimitDto>,
    /// The tool spindle's speed limit.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool_spindle: Option<SpindleLimitDto>,
}

/// `"unlimited"`: no machine limits at all.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum UnlimitedDto {
    Unlimited,
}

/// The machine a plan or program is for: its limits (each one left out is the default
/// machine's), or `"unlimited"` for a study that keeps no limit (every response then warns
/// `machine_unlimited`). Left out: the default machine (docs/MACHINE.md: X and Z 10,000 mm/min
/// and 2,000 mm/s², B 9,000 deg/min and 1,800 deg/s², workpiece spindle 1,000 r/min, tool
/// spindle 3,000 r/min, no travel limits).
#[derive(Debug, Clone, Serialize, ToSchema)]
#[serde(untagged)]
pub enum MachineChoiceDto {
    Unlimited(UnlimitedDto),
    Limits(Box<MachineDto>),
}

impl<'de> Deserialize<'de> for MachineChoiceDto {
    /// A JSON object of limits or the text `"unlimited"`; anything else is refused in those
    /// words (serde's untagged enums only say that nothing matched).
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Choice;
        impl<'de> serde::de::Visitor<'de> for Choice {
            type Value = MachineChoiceDto;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an object of machine limits, or \"unlimited\"")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Self::Value, E> {
                match v {
                    "unlimited" => Ok(MachineChoiceDto::Unlimited(UnlimitedDto::Unlimited)),
                    other => Err(E::custom(format!(
                        "expected an object of machine limits or \"unlimited\" here, got the \
                         text \"{other}\""
                    ))),
                }
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<Self::Value, A::Error> {
                MachineDto::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(|m| MachineChoiceDto::Limits(Box::new(m)))
            }
        }
        d.deserialize_any(Choice)
    }
}

impl MachineChoiceDto {
    /// The core's choice for an optional request field.
    pub fn choice(dto: Option<&MachineChoiceDto>) -> MachineChoice {
        match dto {
            None => MachineChoice::Default,
            Some(MachineChoiceDto::Unlimited(_)) => MachineChoice::Unlimited,
            Some(MachineChoiceDto::Limits(m)) => MachineChoice::Given(m.as_ref().into()),
        }
    }
}

/// Fraction of each limit used (1 = at the limit); null where the limit is not stated.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct UtilisationDto {
    /// Travel used over the range from the minimum to the maximum (both stated).
    #[schema(required = true)]
    pub travel: Option<f64>,
    /// Peak |velocity| over its limit.
    #[schema(required = true)]
    pub velocity: Option<f64>,
    /// Peak |acceleration| over its limit.
    #[schema(required = true)]
    pub acceleration: Option<f64>,
}

/// How a linear axis moves over the program.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct LinearAxisReport {
    /// Lowest position reached, mm (start included).
    pub min_mm: f64,
    /// Highest position reached, mm.
    pub max_mm: f64,
    /// max_mm − min_mm.
    pub travel_mm: f64,
    /// Largest |velocity| of any block, mm/min.
    pub peak_velocity_mm_per_min: f64,
    /// Largest |acceleration| between blocks (from and to rest at the ends), mm/s².
    pub peak_acceleration_mm_per_s2: f64,
    /// Fraction of each stated limit used.
    pub utilisation: UtilisationDto,
}

/// How the tilt axis moves over the program.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct RotaryAxisReport {
    /// Lowest angle reached, deg (start included).
    pub min_deg: f64,
    /// Highest angle reached, deg.
    pub max_deg: f64,
    /// max_deg − min_deg.
    pub travel_deg: f64,
    /// Largest |angular velocity| of any block, deg/min.
    pub peak_velocity_deg_per_min: f64,
    /// Largest |angular acceleration| between blocks, deg/s².
    pub peak_acceleration_deg_per_s2: f64,
    /// Fraction of each stated limit used.
    pub utilisation: UtilisationDto,
}

/// Per-axis motion: velocity piecewise constant per block (ΔA/duration), changing between
/// blocks over the time between their midpoints.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct AxesDto {
    /// X, the radial axis.
    pub x: LinearAxisReport,
    /// Z, the axial axis.
    pub z: LinearAxisReport,
    /// B, the tilt axis.
    pub b: RotaryAxisReport,
}

fn axis_limits(
    min: Option<f64>,
    max: Option<f64>,
    velocity: Option<f64>,
    acceleration: Option<f64>,
) -> AxisLimits {
    AxisLimits {
        min,
        max,
        max_velocity_per_min: velocity,
        max_acceleration_per_s2: acceleration,
    }
}

impl From<&LinearAxisDto> for AxisLimits {
    fn from(a: &LinearAxisDto) -> Self {
        axis_limits(
            a.min_mm,
            a.max_mm,
            a.max_velocity_mm_per_min,
            a.max_acceleration_mm_per_s2,
        )
    }
}

impl From<&MachineDto> for MachineLimitsSpec {
    fn from(m: &MachineDto) -> Self {
        let linear =
            |a: &Option<LinearAxisDto>| a.as_ref().map_or(AxisLimits::default(), Into::into);
        let b = m.b.as_ref().map_or(AxisLimits::default(), |b| {
            axis_limits(
                b.min_deg,
                b.max_deg,
                b.max_velocity_deg_per_min,
                b.max_acceleration_deg_per_s2,
            )
        });
        MachineLimitsSpec {
            x: linear(&m.x),
            // The paper's machine has no Y.
            y: AxisLimits::default(),
            z: linear(&m.z),
            b,
            // A 1-D plan turns C at the process's constant speed: the spindle's limit holds.
            c: AxisLimits::default(),
            workpiece_max_rpm: m.workpiece_spindle.as_ref().and_then(|s| s.max_rpm),
            tool_max_rpm: m.tool_spindle.as_ref().and_then(|s| s.max_rpm),
        }
    }
}

impl From<Utilisation> for UtilisationDto {
    fn from(u: Utilisation) -> Self {
        UtilisationDto {
            travel: u.travel,
            velocity: u.velocity,
            acceleration: u.acceleration,
        }
    }
}

impl LinearAxisReport {
    /// A linear axis's travel, peaks and use of its `limits` over its motion.
    pub fn of(m: &AxisMotion, limits: &AxisLimits) -> Self {
        LinearAxisReport {
            min_mm: m.min,
            max_mm: m.max,
            travel_mm: m.travel(),
            peak_velocity_mm_per_min: m.peak_velocity_per_min,
            peak_acceleration_mm_per_s2: m.peak_acceleration_per_s2,
            utilisation: m.utilisation(limits).into(),
        }
    }
}

impl AxesDto {
    /// Each axis's travel, peaks and use of `machine`'s limits over `program`.
    pub fn of(program: &Program, machine: &MachineLimits) -> Self {
        AxesDto::of_motions(Axis::ALL.map(|axis| program.motion(axis)), machine)
    }

    /// Each axis's travel, peaks and use of `machine`'s limits over its motion (X, Z, B).
    pub fn of_motions(motions: [&AxisMotion; 3], machine: &MachineLimits) -> Self {
        let [x, z, b] = motions;
        let linear = |axis, m: &AxisMotion| LinearAxisReport::of(m, machine.axis(axis));
        AxesDto {
            x: linear(Axis::X, x),
            z: linear(Axis::Z, z),
            b: RotaryAxisReport {
                min_deg: b.min,
                max_deg: b.max,
                travel_deg: b.travel(),
                peak_velocity_deg_per_min: b.peak_velocity_per_min,
                peak_acceleration_deg_per_s2: b.peak_acceleration_per_s2,
                utilisation: b.utilisation(machine.axis(Axis::B)).into(),
            },
        }
    }
}

impl From<OrientationDto> for Orientation {
    fn from(o: OrientationDto) -> Self {
        match o {
            OrientationDto::Normal => Orientation::Normal,
            OrientationDto::Vertical => Orientation::Vertical,
        }
    }
}
