//! `POST /v1/maps/program` on an X-Y machine (`machine.kinematics: cartesian`): the request,
//! the answer, and their conversion to and from the core's.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::dto::{LinearAxisReport, SurfaceDto, WarningDto};
use super::super::error::ApiError;
use super::super::extract::{object, optional_count, optional_object};
use super::super::program::{
    request_digest, tool_words_format, ApproachDto, SkippedDto, SpindleWordsDto,
};
use super::raster::{points, CartesianDto, CartesianMachineDto, RasterDwellDto};
use crate::usecases::raster_program::{
    RasterMachineProgram, RasterProgramCommand, RasterProgramSpec, XY_AXES,
};

/// How an X-Y program's G-code is written: X and Y in G93 inverse time (F = 1/duration in
/// 1/min), stops as G4 P (seconds), Z's approach and retract in G94.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct XyFormatDto {
    /// Decimals of X, Y and Z (mm), 0 to 7. Default 4.
    #[serde(default, deserialize_with = "optional_count")]
    #[schema(value_type = Option<u32>, minimum = 0, maximum = 7)]
    pub decimals: Option<usize>,
    /// Words for the tool spindle (default `M3 $1`, `M4 $1`, `M5 $1`), written only with
    /// `tool_rpm`; a positive tool speed is counter-clockwise as its spindle sees it.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool_spindle: Option<SpindleWordsDto>,
}

/// `POST /v1/maps/program` on an X-Y machine.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RasterProgramRequest {
    /// The X-Y machine (`kinematics: cartesian`) and its limits.
    #[serde(deserialize_with = "object")]
    pub machine: CartesianMachineDto,
    /// The plan as `/v1/maps/optimize` returns it: the points in path order and their dwell.
    #[serde(deserialize_with = "object")]
    pub dwell: RasterDwellDto,
    /// The tool spindle's speed, r/min (signed, counter-clockwise positive seen from the tool
    /// side); absent: no spindle words (a beam or a jet the shop switches).
    pub tool_rpm: Option<f64>,
    /// The part's surface, its vertex at the plan's origin (the map's centre). On a curved
    /// part Z follows it: every block ends at the sag there, Z = 0 at the vertex. Default a
    /// flat (Z moves only to approach and retract).
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// Default: 5 mm clearance in Z at 100 mm/min (slower where Z's limits need it).
    #[serde(default, deserialize_with = "optional_object")]
    pub approach: Option<ApproachDto>,
    /// Default: 4 decimals, LinuxCNC's tool spindle words.
    #[serde(default, deserialize_with = "optional_object")]
    pub format: Option<XyFormatDto>,
}

/// Where an X-Y program starts: X, Y and Z, mm.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct XyPoseDto {
    /// X, mm (right on the map).
    pub x_mm: f64,
    /// Y, mm (up on the map).
    pub y_mm: f64,
    /// Above the part by the approach's clearance (Z = 0 is the tool's working height over
    /// the vertex).
    pub z_mm: f64,
}

/// Each axis over the program: X's and Y's velocity is constant in a block and changes between
/// blocks over the time between their midpoints (from and to rest at the ends), the model the
/// plan's `axes` were computed by, so their peaks are the plan's.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct XyAxesDto {
    /// X: the plan's moves along the map's rows.
    pub x: LinearAxisReport,
    /// Y: the plan's moves between rows.
    pub y: LinearAxisReport,
    /// Z: the approach and retract, and on a curved part the surface's sag.
    pub z: LinearAxisReport,
}

/// An X-Y program: its summary (the G-code with `Accept: text/x-gcode`, the block table with
/// `text/csv`).
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct RasterProgramResponse {
    /// The machine's kinematics the program is for: `cartesian`.
    pub kinematics: CartesianDto,
    /// Where the program starts (the G0 before the first block).
    pub start: XyPoseDto,
    /// G1 and G4 blocks of the program.
    pub blocks: usize,
    /// The polishing blocks' time: the plan's total time, s.
    pub total_time_s: f64,
    /// Every block's time, approach and retract included, s.
    pub program_time_s: f64,
    /// Per-axis travel, peak velocity and acceleration, and utilisation of the limits.
    pub axes: XyAxesDto,
    /// The tool spindle's speed as programmed, r/min; null without spindle words.
    #[schema(required = true)]
    pub tool_rpm: Option<f64>,
    /// Zero-dwell points left out at the ends of the plan.
    pub skipped_positions: SkippedDto,
    /// The approach's clearance in Z, mm.
    pub approach_clearance_mm: f64,
    /// The approach and retract feed as programmed, mm/min.
    pub approach_feed_mm_per_min: f64,
    /// The largest normal distance of the tool's centre from the surface at the middle of a
    /// move (X, Y and Z run linearly within a block), mm; 0 on a flat.
    pub max_path_deviation_mm: f64,
    /// The surface's steepest slope under the program's points, degrees. The plan is made in
    /// the X-Y projection with the influence function as measured, which holds while this is
    /// small (a footprint stretches by 1/cos θ along the slope).
    pub max_slope_deg: f64,
    /// `machine_unlimited` for a study; empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
    /// The G-code (served with `Accept: text/x-gcode`).
    #[serde(skip)]
    pub gcode: String,
}

impl RasterProgramRequest {
    pub fn command(self) -> Result<RasterProgramCommand, ApiError> {
        let digest = request_digest(&self)?;
        self.machine.checked_caps()?;
        let approach = self.approach.unwrap_or_default();
        let format = self.format.unwrap_or_default();
        Ok(RasterProgramCommand::new(RasterProgramSpec {
            points_mm: points(self.dwell.points_mm)?,
            dwell_s: self.dwell.dwell_s,
            machine: self.machine.choice(),
            tool_rpm: self.tool_rpm,
            surface: self.surface.as_ref().map(Into::into),
            clearance_mm: approach.clearance_mm,
            approach_feed_mm_per_min: approach.feed_mm_per_min,
            format: tool_words_format(format.decimals, format.tool_spindle.as_ref()),
            request_digest: digest,
        })?)
    }
}

impl From<RasterMachineProgram> for RasterProgramResponse {
    fn from(m: RasterMachineProgram) -> Self {
        let p = &m.program;
        let [x, y, z] = XY_AXES.map(|a| LinearAxisReport::of(p.motion(a), m.machine.axis(a)));
        let start = p.start_mm();
        RasterProgramResponse {
            kinematics: CartesianDto::Cartesian,
            start: XyPoseDto {
                x_mm: start[0],
                y_mm: start[1],
                z_mm: start[2],
            },
            blocks: p.blocks().len(),
            total_time_s: p.polishing_time_s,
            program_time_s: p.program_time_s,
            axes: XyAxesDto { x, y, z },
            tool_rpm: m.tool_rpm,
            skipped_positions: p.skipped.into(),
            approach_clearance_mm: p.approach.clearance_mm,
            approach_feed_mm_per_min: p.approach.feed_mm_per_min,
            max_path_deviation_mm: p.max_path_deviation_mm,
            max_slope_deg: p.max_slope_deg,
            warnings: WarningDto::all(&m.warnings),
            gcode: m.gcode,
        }
    }
}
