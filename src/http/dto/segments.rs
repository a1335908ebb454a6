//! Off-axis segments mounted on C as requests give them.

use serde::Deserialize;
use utoipa::ToSchema;

use super::super::error::ApiError;
use super::super::extract::count;
use super::SurfaceDto;
use crate::segments::{SegmentError, SegmentLayout, SegmentLayoutSpec};
use crate::surface::{Surface, SurfaceSpec};
use crate::usecases::map_optimize::SegmentSetup;

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
#[derive(Debug, Clone, Deserialize, ToSchema)]
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
}

/// What the pad does across the gaps between segments.
#[derive(Debug, Clone, Copy, Default, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum TransitionsDto {
    #[default]
    Down,
    Lifted,
}

impl SegmentsDto {
    /// The layout and its transitions, or the field at fault (under `segments.`).
    pub fn parse(&self) -> Result<SegmentSetup, ApiError> {
        let field = |name: &str| format!("segments.{name}");
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
        Ok(SegmentSetup { layout, lift_mm })
    }
}
