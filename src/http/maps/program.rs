//! `POST /v1/maps/program`: a polar plan (a radial plan and C's speed law) as a machine
//! program with C under position control, checked against every axis's limits, C's included;
//! JSON summary, `text/x-gcode` or the block table as `text/csv`.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::dto::{
    part_on_c, part_spec, DwellDto, LinearAxisReport, PolishingPeaksDto, ProcessDto,
    RotaryAxisReport, SegmentsDto, StationServoDto, SurfaceDto, ToolDto, UtilisationDto,
    WarningDto,
};
use super::super::endpoint::{Doc, Endpoint};
use super::super::error::ApiError;
use super::super::extract::{object, optional_count, optional_object, ApiJson};
use super::super::program::{
    request_digest, tool_words_format, ApproachDto, SkippedDto, SpindleWordsDto, SpindlesDto,
};
use super::super::state::Services;
use super::optimize::PolarMachineDto;
use super::predict::CLawDto;
use super::raster::{Answer, Kinds};
use super::raster_program::{RasterProgramRequest, RasterProgramResponse};
use super::removal_function::KinematicsDto;
use crate::http::openapi::any_of;
use crate::machine::gcode::CWords;
use crate::machine::Axis;
use crate::report::results;
use crate::usecases::map_program::{
    map_program, MapProgramCommand, MapProgramSpec, PolarMachineProgram,
};
use crate::usecases::program::{ProgramCommand, ProgramSpec};
use crate::usecases::raster_program::{raster_program, RasterMachineProgram, RasterProgramCommand};
use crate::usecases::ComputeLimits;

/// How C's words are written: `wrapped` (in [0, 360); every block turns C by at most 90°, so
/// a controller that wraps C and takes the shorter way round takes the plan's way) or
/// `unwound` (cumulative degrees from the start, for a C axis without roll-over).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CWordsDto {
    Wrapped,
    Unwound,
}

impl From<CWordsDto> for CWords {
    fn from(c: CWordsDto) -> Self {
        match c {
            CWordsDto::Wrapped => CWords::Wrapped,
            CWordsDto::Unwound => CWords::Unwound,
        }
    }
}

/// How a polar program's G-code is written: always G93 inverse time (F = 1/duration in
/// 1/min), the one feed that states a move of X and C together exactly.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PolarFormatDto {
    /// Decimals of X, Z (mm), B and C (deg), 0 to 7. Default 4.
    #[serde(default, deserialize_with = "optional_count")]
    #[schema(value_type = Option<u32>, minimum = 0, maximum = 7)]
    pub decimals: Option<usize>,
    /// Default `wrapped`.
    pub c_words: Option<CWordsDto>,
    /// Words for the tool spindle (default spindle 1: `M3 $1`, `M4 $1`, `M5 $1`); a positive
    /// tool speed is counter-clockwise as its spindle sees it. The workpiece spindle is C.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool_spindle: Option<SpindleWordsDto>,
}

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapProgramRequest {
    /// The polishing process: the tool's speed becomes its spindle command, the part's is C's
    /// speed (times the law's factors).
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// The part's surface; default a plane (on a curved part Z and B follow the pad centre).
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// The plan, as `/v1/maps/optimize` returns it: stations (strictly increasing) and the
    /// dwell in each one's cell.
    #[serde(deserialize_with = "object")]
    pub dwell: DwellDto,
    /// C's speed law, as `/v1/maps/optimize` returns it; default C at `process.workpiece_rpm`
    /// throughout.
    #[serde(default, deserialize_with = "optional_object")]
    pub c_law: Option<CLawDto>,
    /// The pad centre's angle in the part's frame when the plan starts, degrees
    /// (counter-clockwise from +x); default 0. C starts the polishing at its negative.
    pub start_angle_deg: Option<f64>,
    /// Default: pivot at the pad face, B following the normal.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool: Option<ToolDto>,
    /// The machine's limits, C's among them; default the default machine.
    #[serde(default, deserialize_with = "optional_object")]
    pub machine: Option<PolarMachineDto>,
    /// Default: 5 mm clearance at 100 mm/min, slowed where C needs the time to reach its
    /// speed.
    #[serde(default, deserialize_with = "optional_object")]
    pub approach: Option<ApproachDto>,
    /// Default: 4 decimals, C wrapped, LinuxCNC's tool spindle words.
    #[serde(default, deserialize_with = "optional_object")]
    pub format: Option<PolarFormatDto>,
    /// Off-axis segments mounted on C, as the plan was made for them (leave `surface` out):
    /// Z and B then follow each ring's law as C turns, the blocks cut so that Z leaves each
    /// block's straight line by at most `segments.chord_tolerance_mm`.
    #[serde(default, deserialize_with = "optional_object")]
    pub segments: Option<SegmentsDto>,
}

/// Where the program starts: X, Z, B and C.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct PolarPoseDto {
    /// X, mm.
    pub x_mm: f64,
    /// Z, mm.
    pub z_mm: f64,
    /// B, deg.
    pub b_deg: f64,
    /// C, deg (the G-code writes it as `format.c_words` says).
    pub c_deg: f64,
}

/// How C moves over the program.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct CAxisReport {
    /// Turns of C from the start to the end (signed: counter-clockwise positive).
    pub turns: f64,
    /// Largest |angular velocity| of any block, deg/min.
    pub peak_velocity_deg_per_min: f64,
    /// Largest |angular acceleration| between runs of blocks at one C speed (from and to rest
    /// through the approach and retract), deg/s².
    pub peak_acceleration_deg_per_s2: f64,
    /// Fraction of each stated limit used (travel: null, C has none).
    pub utilisation: UtilisationDto,
}

/// Per-axis motion: each axis's velocity is constant over a span of blocks (a stop or move of
/// the plan for X, Z and B; a run of one C speed for C) and changes between spans over the
/// time between their midpoints.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct PolarAxesDto {
    /// X, the radial axis.
    pub x: LinearAxisReport,
    /// Z, the axial axis.
    pub z: LinearAxisReport,
    /// B, the tilt axis.
    pub b: RotaryAxisReport,
    /// C, the part's spindle under position control.
    pub c: CAxisReport,
}

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct MapProgramResponse {
    /// The machine's kinematics the program is for.
    pub kinematics: KinematicsDto,
    /// Where the program starts (the G0 before the first block).
    pub start: PolarPoseDto,
    /// How many G1 blocks the program has (the table is served with `Accept: text/csv`).
    pub blocks: usize,
    /// The polishing blocks' time: the plan's total time, s.
    pub total_time_s: f64,
    /// Every block's time, approach and retract included, s.
    pub program_time_s: f64,
    /// Per-axis travel, peak velocity and acceleration, and utilisation of the limits.
    pub axes: PolarAxesDto,
    /// The spindle speeds: the tool's as programmed, the part's C's nominal speed.
    pub spindles: SpindlesDto,
    /// Zero-dwell positions left out at the ends of the plan.
    pub skipped_positions: SkippedDto,
    /// The approach's clearance along the tool axis, mm.
    pub approach_clearance_mm: f64,
    /// The approach and retract feed as programmed (lowered for the axis limits and for C to
    /// reach its speed), mm/min.
    pub approach_feed_mm_per_min: f64,
    /// How C's words are written.
    pub c_words: CWordsDto,
    /// Each axis's peaks over the polishing blocks alone (on segments, the plan's
    /// `segments.polishing_peaks`).
    pub polishing_peaks: PolishingPeaksDto,
    /// On segments: what each station's ring asks of Z, and the chord tolerance kept.
    pub segments: Option<ProgramSegmentsDto>,
    /// What looks wrong in the input though it is valid; empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
    /// The G-code (served with `Accept: text/x-gcode`).
    #[serde(skip)]
    pub gcode: String,
}

/// A program on segments: Z's demand per station at the law's C speeds.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct ProgramSegmentsDto {
    /// The most Z leaves any block's straight line, mm (the blocks are cut to it).
    pub chord_tolerance_mm: f64,
    /// Per station whose ring the pad reaches a segment from: Z over a turn, its harmonics,
    /// the largest C speed Z follows them at, and the law's fastest C there.
    pub servo: Vec<StationServoDto>,
}

/// A program's request: the paper's machine's or an X-Y machine's.
pub type MapProgramAny = Kinds<MapProgramRequest, RasterProgramRequest>;
any_of!(
    impl MapProgramAny as "MapProgramAnyRequest",
    [MapProgramRequest, RasterProgramRequest],
    "A plan to program: on the paper's machine (`machine.kinematics` `polar`, the default) or \
     on an X-Y machine (`machine.kinematics` `cartesian`)."
);

/// A program of either machine.
pub type MapProgramAnswer = Answer<MapProgramResponse, RasterProgramResponse>;
any_of!(
    impl MapProgramAnswer as "MapProgramAnyResponse",
    [MapProgramResponse, RasterProgramResponse],
    "A polar program with C words, or an X-Y machine's (`kinematics` says which)."
);

/// A program of either machine, as computed.
pub type MapProgramOutput = Answer<PolarMachineProgram, RasterMachineProgram>;

fn program_csv(m: &MapProgramOutput) -> String {
    match m {
        Answer::Polar(p) => results::polar_program_csv(p),
        Answer::Cartesian(c) => results::xy_program_csv(c),
    }
}

fn program_gcode(m: &MapProgramOutput) -> String {
    match m {
        Answer::Polar(p) => p.gcode.clone(),
        Answer::Cartesian(c) => c.gcode.clone(),
    }
}

pub struct MapProgramEndpoint;

impl Endpoint for MapProgramEndpoint {
    const NAME: &'static str = "maps/program";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/maps_program_astigmatism.json");
    const DOC: Doc = Doc {
        operation_id: "generateMapProgram",
        tag: "maps",
        summary: "Turn a polar plan (dwell and C's speed law) into a machine program with C words.",
        description:
            "The plan's stops and moves run as `/v1/program` runs them, cut where the pad \
centre crosses a sector edge of C's law: every block is one G1 of X, Z, B and C at constant \
speeds, in inverse time (G93). C is the part's spindle under position control, counter-clockwise \
positive seen from the tool side; no block turns it more than 90°. The approach and retract run \
C at the first and last blocks' speeds, long enough for C to reach them. Every axis is checked \
against `machine`, C's velocity and acceleration included; a program that would break a limit \
is a 422 `machine-limits` problem naming the axis, the limit and the first block, never a \
program. On a curved part Z and B follow the pad centre along the surface. `Accept: \
text/x-gcode` returns the G-code, `text/csv` the block table.",
        ok: "Per-axis motion and utilisation; as G-code, the program; as CSV, the block table",
    };
    type Request = MapProgramAny;
    type Body = ApiJson<MapProgramAny>;
    type Command = Kinds<MapProgramCommand, RasterProgramCommand>;
    type Output = MapProgramOutput;
    type Response = MapProgramAnswer;
    const CSV: Option<fn(&MapProgramOutput) -> String> = Some(program_csv);
    const GCODE: Option<fn(&MapProgramOutput) -> String> = Some(program_gcode);

    fn parse(req: MapProgramAny, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let req = match req {
            Kinds::Polar(req) => req,
            Kinds::Cartesian(req) => return Ok(Kinds::Cartesian(req.command()?)),
        };
        let digest = request_digest(&req)?;
        let (surface, segments) = part_on_c(
            req.surface.as_ref(),
            req.segments.as_ref(),
            req.process.workpiece_radius_mm,
        )?;
        let approach = req.approach.clone().unwrap_or_default();
        let format = req.format.clone().unwrap_or_default();
        let machine = req.machine.clone().unwrap_or_default();
        let KinematicsDto::Polar = machine.kinematics;
        let base = ProgramCommand::new(
            ProgramSpec {
                process: req.process.spec()?,
                part: part_spec(surface.as_ref(), req.tool.as_ref())?,
                positions_mm: req.dwell.positions_mm,
                dwell_s: req.dwell.dwell_s,
                machine: machine.choice(),
                clearance_mm: approach.clearance_mm,
                approach_feed_mm_per_min: approach.feed_mm_per_min,
                format: tool_words_format(format.decimals, format.tool_spindle.as_ref()),
                request_digest: digest,
            },
            limits,
        )?;
        let spec = MapProgramSpec {
            c_law: req.c_law.map(CLawDto::spec),
            start_angle_deg: req.start_angle_deg,
            c_words: format.c_words.map(Into::into),
            segments,
        };
        Ok(Kinds::Polar(MapProgramCommand::new(base, spec)?))
    }

    fn run(command: Self::Command, _: &Services) -> Result<MapProgramOutput, ApiError> {
        Ok(match command {
            Kinds::Polar(c) => Answer::Polar(map_program(c)?),
            Kinds::Cartesian(c) => Answer::Cartesian(raster_program(c)?),
        })
    }

    fn respond(m: MapProgramOutput) -> MapProgramAnswer {
        match m {
            Answer::Polar(m) => Answer::Polar(polar_response(m)),
            Answer::Cartesian(m) => Answer::Cartesian(m.into()),
        }
    }
}

fn polar_response(m: PolarMachineProgram) -> MapProgramResponse {
    let p = &m.program;
    let spec = m.process.spec();
    let (start, start_c) = p.start();
    let axes = super::super::dto::AxesDto::of_motions(
        [Axis::X, Axis::Z, Axis::B].map(|a| p.motion(a)),
        &m.machine,
    );
    let c = p.motion(Axis::C);
    MapProgramResponse {
        kinematics: KinematicsDto::Polar,
        start: PolarPoseDto {
            x_mm: start.x_mm,
            z_mm: start.z_mm,
            b_deg: start.b_deg,
            c_deg: start_c,
        },
        blocks: p.blocks().len(),
        total_time_s: p.polishing_time_s,
        program_time_s: p.program_time_s,
        axes: PolarAxesDto {
            x: axes.x,
            z: axes.z,
            b: axes.b,
            c: CAxisReport {
                turns: (c.positions[c.positions.len() - 1] - c.positions[0]) / 360.0,
                peak_velocity_deg_per_min: c.peak_velocity_per_min,
                peak_acceleration_deg_per_s2: c.peak_acceleration_per_s2,
                utilisation: c.utilisation(m.machine.axis(Axis::C)).into(),
            },
        },
        spindles: SpindlesDto {
            workpiece_rpm: spec.workpiece_rpm,
            tool_rpm: spec.tool_rpm,
            eta: m.process.eta().value(),
        },
        skipped_positions: p.skipped.into(),
        approach_clearance_mm: p.approach.clearance_mm,
        approach_feed_mm_per_min: p.approach.feed_mm_per_min,
        c_words: match m.c_words {
            CWords::Wrapped => CWordsDto::Wrapped,
            CWords::Unwound => CWordsDto::Unwound,
        },
        polishing_peaks: p
            .polishing_motions()
            .map(|(_, motion)| motion.peaks())
            .into(),
        segments: m
            .segments
            .map(|(servo, chord_tolerance_mm)| ProgramSegmentsDto {
                chord_tolerance_mm,
                servo: servo.into_iter().map(Into::into).collect(),
            }),
        warnings: WarningDto::all_at(&m.warnings, "dwell.positions_mm"),
        gcode: m.gcode,
    }
}
