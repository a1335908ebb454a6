//! Off-axis segments mounted on C as requests give them.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::error::ApiError;
use super::super::extract::count;
use super::SurfaceDto;
use crate::machine::servo::ServoLimit;
use crate::segments::{SegmentError, SegmentLayout, SegmentLayoutSpec};
use crate::surface::{Surface, SurfaceSpec};
use crate::usecases::map_optimize::{
    SegmentSetup, StationServo, CHORD_TOLERANCE_RANGE_MM, DEFAULT_CHORD_TOLERANCE_MM,
};

/// Clearance across the gaps when the pad is lifted and none is given, mm.
pub const DEFAULT_LIFT_MM: f64 = 0.5;
/// The most clearance accepted, mm.
pub const MAX_LIFT_MM: f64 = 50.0;

/// N identical segments of a parent asphere, each translated (not tilted) so that its centre
/// sits on a circle of radius `mount_radius_mm` about C, segment i's centre at the angle
/// 360°·i/N from +x, its parent's vertex toward C. The part's map is then the mounted set in
/// C's frame (x, y as the map's alignment places it), with data on the segments: each segment's
/// own piston and tilt are removed, Z follows each segment's sag (0 at its centre) as C turns,
/// and nothing is removed off the segments. The process's pad runs on them with uniform
/// pressure; the part's `surface` must be left out (the parent is here).
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SegmentsDto {
    /// The parent surface the segments are cut from (vertex radius, conic, terms).
    pub parent: SurfaceDto,
    /// h: a segment's centre from the parent's vertex, mm (≥ 0).
    #[schema(minimum = 0.0)]
    pub off_axis_mm: f64,
    /// a: the radius of a segment's clear aperture (a disc), mm (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub aperture_radius_mm: f64,
    /// l: the radius of the circle of the segments' centres about C, mm (> a, and
    /// l·sin(180°/N) ≥ a so that they do not overlap).
    #[schema(exclusive_minimum = 0.0)]
    pub mount_radius_mm: f64,
    /// N, 1 to 64.
    #[serde(deserialize_with = "count")]
    #[schema(value_type = u32, minimum = 1, maximum = 64)]
    pub count: usize,
    /// What the pad does across the gaps between segments: `down` (default: it stays on Z's
    /// smooth law, C carrying it across) or `lifted` (raised by `lift_mm` where it is clear
    /// of every segment). Either way it presses on a segment while any of it is over one, Z
    /// following that segment's surface, so the removal is the same.
    #[serde(default)]
    pub transitions: TransitionsDto,
    /// The clearance across each gap when lifted, mm (0 to 50; default 0.5); leave it out
    /// when the pad stays down.
    #[schema(minimum = 0.0, maximum = 50.0)]
    pub lift_mm: Option<f64>,
    /// The most Z may depart from a program block's straight line, mm (1e-5 to 0.1; default
    /// 0.001): the program's blocks are cut this finely, and the plan's axis peaks are those
    /// of that program.
    #[schema(minimum = 1e-5, maximum = 0.1)]
    pub chord_tolerance_mm: Option<f64>,
}

/// What the pad does across the gaps between segments.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum TransitionsDto {
    #[default]
    Down,
    Lifted,
}

/// The part a maps request puts on C: its `surface` (a decentre of 0 left out, so the part is
/// today's of revolution) and no segments; or, segmented or decentred, no surface (the pad's
/// model runs on a plane) and the segments' setup, a decentred part being the one-segment
/// layout on C of the part's radius (`workpiece_radius_mm`; left to the process's check when
/// it is not a positive number).
pub fn part_on_c(
    surface: Option<&SurfaceDto>,
    segments: Option<&SegmentsDto>,
    workpiece_radius_mm: f64,
) -> Result<(Option<SurfaceDto>, Option<SegmentSetup>), ApiError> {
    if let Some(segments) = segments {
        if surface.is_some() {
            return Err(ApiError::invalid(
                "surface",
                "a segmented part's surface is segments.parent: leave surface out",
            ));
        }
        return Ok((None, Some(segments.parse()?)));
    }
    let Some(surface) = surface else {
        return Ok((None, None));
    };
    let mut round = surface.clone();
    if let SurfaceDto::Sphere { decenter_mm, .. } | SurfaceDto::Asphere { decenter_mm, .. } =
        &mut round
    {
        *decenter_mm = None;
    }
    let d = match surface.decenter_mm() {
        None | Some(0.0) => return Ok((Some(round), None)),
        Some(d) => d,
    };
    let field = "surface.decenter_mm";
    if !(d.is_finite() && d > 0.0) {
        return Err(ApiError::invalid(
            field,
            "decenter_mm must be a finite number of mm, 0 or more",
        ));
    }
    if !(workpiece_radius_mm.is_finite() && workpiece_radius_mm > 0.0) {
        return Ok((Some(round), None));
    }
    let parent = Surface::new(&SurfaceSpec::from(surface))
        .map_err(|e| ApiError::invalid("surface", e.to_string()))?;
    let layout = SegmentLayout::decentred(parent, d, workpiece_radius_mm)
        .map_err(|e| ApiError::invalid(field, e.to_string()))?;
    Ok((
        None,
        Some(SegmentSetup {
            layout,
            lift_mm: 0.0,
            chord_tolerance_mm: DEFAULT_CHORD_TOLERANCE_MM,
        }),
    ))
}

impl SegmentsDto {
    /// The layout and its transitions, or the field at fault (under `segments.`).
    pub fn parse(&self) -> Result<SegmentSetup, ApiError> {
        let field = |name: &str| format!("segments.{name}");
        if self.parent.decenter_mm().is_some_and(|d| d != 0.0) {
            return Err(ApiError::invalid(
                field("parent.decenter_mm"),
                "the parent's vertex is placed by off_axis_mm and mount_radius_mm: leave \
                 decenter_mm out",
            ));
        }
        let parent = Surface::new(&SurfaceSpec::from(&self.parent))
            .map_err(|e| ApiError::invalid(field("parent"), e.to_string()))?;
        let layout = SegmentLayout::new(SegmentLayoutSpec {
            parent,
            off_axis_mm: self.off_axis_mm,
            aperture_radius_mm: self.aperture_radius_mm,
            mount_radius_mm: self.mount_radius_mm,
            count: self.count,
        })
        .map_err(|e| {
            let at = match &e {
                SegmentError::OffAxis => "off_axis_mm",
                SegmentError::Aperture => "aperture_radius_mm",
                SegmentError::Mount => "mount_radius_mm",
                SegmentError::Count | SegmentError::Overlap { .. } => "count",
                SegmentError::Parent(_) => "parent",
            };
            ApiError::invalid(field(at), e.to_string())
        })?;
        let lift_mm = match (self.transitions, self.lift_mm) {
            (TransitionsDto::Down, None) => 0.0,
            (TransitionsDto::Down, Some(_)) => {
                return Err(ApiError::invalid(
                    field("lift_mm"),
                    "lift_mm is the clearance of a lifted pad: leave it out, or set \
                     transitions to lifted",
                ))
            }
            (TransitionsDto::Lifted, lift) => {
                let lift = lift.unwrap_or(DEFAULT_LIFT_MM);
                if !(0.0..=MAX_LIFT_MM).contains(&lift) {
                    return Err(ApiError::invalid(
                        field("lift_mm"),
                        format!("lift_mm must be a number from 0 to {MAX_LIFT_MM} mm"),
                    ));
                }
                lift
            }
        };
        let chord_tolerance_mm = self
            .chord_tolerance_mm
            .unwrap_or(DEFAULT_CHORD_TOLERANCE_MM);
        let [lo, hi] = CHORD_TOLERANCE_RANGE_MM;
        if !(lo..=hi).contains(&chord_tolerance_mm) {
            return Err(ApiError::invalid(
                field("chord_tolerance_mm"),
                format!("chord_tolerance_mm must be a number from {lo} to {hi} mm"),
            ));
        }
        Ok(SegmentSetup {
            layout,
            lift_mm,
            chord_tolerance_mm,
        })
    }
}

/// What one station's ring asks of Z on the segments.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct StationServoDto {
    /// The station's index in `dwell.positions_mm`.
    pub station: usize,
    /// Its radius, mm.
    pub r_mm: f64,
    /// Z's least over a turn, mm (each segment's centre at Z = 0).
    pub z_min_mm: f64,
    /// Z's greatest over a turn, mm.
    pub z_max_mm: f64,
    /// Z's harmonics per turn, m = 1 … 32: amplitude, mm (Z's motion is
    /// Σ A_m·cos(m·C + ψ_m); their frequency is m·n/60 Hz at n r/min).
    pub z_amplitude_mm: Vec<f64>,
    /// The fastest C speed at which Z follows every harmonic, r/min; null when Z's limits
    /// bound none.
    pub largest_c_rpm: Option<f64>,
    /// The harmonic that sets it.
    pub binding_harmonic: Option<usize>,
    /// Which of Z's limits sets it: `velocity` or `acceleration`.
    pub binding_limit: Option<String>,
    /// C's fastest over the station's sectors in the plan, r/min.
    pub plan_c_rpm: f64,
    /// largest_c_rpm / plan_c_rpm: at least 1; null when unbounded.
    pub margin: Option<f64>,
}

/// The harmonics of Z a station's report lists.
const REPORTED_HARMONICS: usize = 32;

impl From<StationServo> for StationServoDto {
    fn from(s: StationServo) -> Self {
        let d = s.demand;
        let largest = d
            .speed
            .largest_c_rpm
            .is_finite()
            .then_some(d.speed.largest_c_rpm);
        StationServoDto {
            station: s.station,
            r_mm: d.r_mm,
            z_min_mm: d.z_range_mm[0],
            z_max_mm: d.z_range_mm[1],
            z_amplitude_mm: d
                .amplitudes_mm
                .iter()
                .take(REPORTED_HARMONICS)
                .copied()
                .collect(),
            largest_c_rpm: largest,
            binding_harmonic: d.speed.binding.map(|(m, _)| m),
            binding_limit: d.speed.binding.map(|(_, l)| {
                match l {
                    ServoLimit::Velocity => "velocity",
                    ServoLimit::Acceleration => "acceleration",
                }
                .to_string()
            }),
            plan_c_rpm: s.plan_c_rpm,
            margin: largest
                .filter(|_| s.plan_c_rpm > 0.0)
                .map(|l| l / s.plan_c_rpm),
        }
    }
}

/// Each axis's peaks over a polar program's polishing blocks (the plan's own motion, without
/// the approach and retract; velocities constant in each block, changing between blocks over
/// the time between their midpoints).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct PolishingPeaksDto {
    /// X's largest |velocity|, mm/min.
    pub x_velocity_mm_per_min: f64,
    /// X's largest |acceleration|, mm/s².
    pub x_acceleration_mm_per_s2: f64,
    /// Z's largest |velocity|, mm/min.
    pub z_velocity_mm_per_min: f64,
    /// Z's largest |acceleration|, mm/s².
    pub z_acceleration_mm_per_s2: f64,
    /// B's largest |angular velocity|, deg/min.
    pub b_velocity_deg_per_min: f64,
    /// B's largest |angular acceleration|, deg/s².
    pub b_acceleration_deg_per_s2: f64,
    /// C's largest |angular velocity|, deg/min.
    pub c_velocity_deg_per_min: f64,
    /// C's largest |angular acceleration|, deg/s².
    pub c_acceleration_deg_per_s2: f64,
}

/// X, Z, B and C's (|velocity| per minute, |acceleration| per s²).
impl From<[[f64; 2]; 4]> for PolishingPeaksDto {
    fn from([x, z, b, c]: [[f64; 2]; 4]) -> Self {
        PolishingPeaksDto {
            x_velocity_mm_per_min: x[0],
            x_acceleration_mm_per_s2: x[1],
            z_velocity_mm_per_min: z[0],
            z_acceleration_mm_per_s2: z[1],
            b_velocity_deg_per_min: b[0],
            b_acceleration_deg_per_s2: b[1],
            c_velocity_deg_per_min: c[0],
            c_acceleration_deg_per_s2: c[1],
        }
    }
}
