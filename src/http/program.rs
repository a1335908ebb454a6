//! `POST /v1/program`: a dwell plan as a machine program (X, Z, B and both spindles), checked
//! against the machine's limits; JSON blocks, `text/x-gcode` or `text/csv`.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::dto::{
    part_spec, AxesDto, DwellDto, MachineChoiceDto, ProcessDto, SurfaceDto, ToolDto, WarningDto,
};
use super::endpoint::{Doc, Endpoint};
use super::error::ApiError;
use super::extract::{object, optional_count, optional_object, ApiJson};
use super::state::Services;
use crate::machine::{BlockKind, FeedMode, GcodeFormatSpec, Skipped, SpindleWordsSpec};
use crate::report::results;
use crate::usecases::program::{program, MachineProgram, ProgramCommand, ProgramSpec};
use crate::usecases::ComputeLimits;

/// How the program gets onto the part and off it: along the tool axis.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ApproachDto {
    /// Distance from the part along the tool axis at the start and end, mm (0 to 1000; 0 = no
    /// approach or retract). Default 5.
    #[schema(minimum = 0.0, maximum = 1000.0)]
    pub clearance_mm: Option<f64>,
    /// Feed of the approach and retract, mm/min (0.001 to 1000000). Default 100, lowered so
    /// that no axis velocity or acceleration limit is exceeded (not below 0.001).
    #[schema(minimum = 0.001, maximum = 1000000.0)]
    pub feed_mm_per_min: Option<f64>,
}

/// How polishing moves carry their feed: `inverse_time` (G93, F = 1/duration in 1/min) or
/// `units_per_minute` (G94, F = the X–Z path feed in mm/min).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FeedModeDto {
    InverseTime,
    UnitsPerMinute,
}

/// The words that turn a spindle clockwise or counter-clockwise (as seen from that spindle
/// looking at its work) and stop it; the speed follows as `S<|rpm|>`. 1 to 32 printable ASCII
/// characters, no parentheses or semicolons.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SpindleWordsDto {
    /// Default `M3` (workpiece), `M3 $1` (tool).
    #[schema(min_length = 1, max_length = 32)]
    pub cw: Option<String>,
    /// Default `M4` (workpiece), `M4 $1` (tool).
    #[schema(min_length = 1, max_length = 32)]
    pub ccw: Option<String>,
    /// Default `M5` (workpiece), `M5 $1` (tool).
    #[schema(min_length = 1, max_length = 32)]
    pub stop: Option<String>,
}

/// How the G-code is written.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FormatDto {
    /// Default `inverse_time`.
    pub feed_mode: Option<FeedModeDto>,
    /// Decimals of X, Z (mm) and B (deg), 0 to 7. Default 4.
    #[serde(default, deserialize_with = "optional_count")]
    #[schema(value_type = Option<u32>, minimum = 0, maximum = 7)]
    pub decimals: Option<usize>,
    /// Words for the workpiece spindle (default spindle 0: `M3`, `M4`, `M5`); a positive workpiece speed is clockwise as its spindle sees it.
    #[serde(default, deserialize_with = "optional_object")]
    pub workpiece_spindle: Option<SpindleWordsDto>,
    /// Words for the tool spindle (default spindle 1: `M3 $1`, `M4 $1`, `M5 $1`); a positive tool speed is counter-clockwise as its spindle sees it.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool_spindle: Option<SpindleWordsDto>,
}

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ProgramRequest {
    /// The polishing process (its speeds become the spindle commands).
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// The surface; default a plane. Positions are radial coordinates of surface points.
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// The plan, as `/v1/optimize` returns it: pad-centre radii (strictly increasing) and the
    /// dwell at each.
    #[serde(deserialize_with = "object")]
    pub dwell: DwellDto,
    /// Default: pivot at the pad face, B following the normal.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool: Option<ToolDto>,
    /// The machine's limits, or `"unlimited"`; default: the default machine.
    #[serde(default)]
    pub machine: Option<MachineChoiceDto>,
    /// Default: 5 mm clearance at 100 mm/min.
    #[serde(default, deserialize_with = "optional_object")]
    pub approach: Option<ApproachDto>,
    /// Default: G93, 4 decimals, LinuxCNC spindle words.
    #[serde(default, deserialize_with = "optional_object")]
    pub format: Option<FormatDto>,
}

/// What a block does: `approach` (down onto the part along the tool axis), `dwell` (a stop,
/// the first and last half-dwells), `move` (polishing, linear in X, Z and B), `retract`.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum BlockKindDto {
    Approach,
    Dwell,
    Move,
    Retract,
}

/// One block of the program: the pose at its end and its duration.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct BlockDto {
    /// What the block does.
    pub kind: BlockKindDto,
    /// Radial position of the pad centre at the block's end, mm.
    pub position_mm: f64,
    /// Arc length from the vertex to position_mm along the meridian, mm.
    pub arc_length_mm: f64,
    /// X at the block's end, mm.
    pub x_mm: f64,
    /// Z at the block's end, mm.
    pub z_mm: f64,
    /// B at the block's end, deg.
    pub b_deg: f64,
    /// How long the block takes, s (> 0).
    pub duration_s: f64,
    /// The X–Z path feed (the G94 F word), mm/min (deg/min for a move of B alone); null in a
    /// dwell.
    #[schema(required = true)]
    pub feed_mm_per_min: Option<f64>,
    /// 1/duration, 1/min (the G93 F word); null in a dwell.
    #[schema(required = true)]
    pub inverse_time_per_min: Option<f64>,
}

/// The spindles as programmed.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct SpindlesDto {
    /// Signed, lab frame (CCW positive seen from the tool side).
    pub workpiece_rpm: f64,
    /// Signed, lab frame.
    pub tool_rpm: f64,
    /// η = −workpiece_rpm/tool_rpm; null when the tool does not turn.
    #[schema(required = true)]
    pub eta: Option<f64>,
}

/// Plan positions left out because their dwell is 0 (nothing happens there).
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct SkippedDto {
    /// Before the first position with dwell.
    pub leading: usize,
    /// After the last position with dwell.
    pub trailing: usize,
}

impl From<Skipped> for SkippedDto {
    fn from(s: Skipped) -> Self {
        SkippedDto {
            leading: s.leading,
            trailing: s.trailing,
        }
    }
}

/// Axis positions: X and Z in mm (design frame), B in degrees.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct PoseDto {
    /// X, mm.
    pub x_mm: f64,
    /// Z, mm.
    pub z_mm: f64,
    /// B, deg.
    pub b_deg: f64,
}

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
pub struct ProgramResponse {
    /// Where the program starts (the G0 before block 0): above the first position by the
    /// approach clearance.
    pub start: PoseDto,
    /// The program's blocks in order: approach, dwell, moves, dwell, retract.
    pub blocks: Vec<BlockDto>,
    /// The dwell and move blocks' time: the plan's total time, s.
    pub total_time_s: f64,
    /// Every block's time, approach and retract included, s.
    pub program_time_s: f64,
    /// Per-axis travel, peak velocity and acceleration, and utilisation of the limits.
    pub axes: AxesDto,
    /// The spindle speeds programmed.
    pub spindles: SpindlesDto,
    /// Zero-dwell positions left out at the ends of the plan.
    pub skipped_positions: SkippedDto,
    /// The approach's clearance along the tool axis, mm.
    pub approach_clearance_mm: f64,
    /// The approach and retract feed as programmed (after lowering for the axis limits), mm/min.
    pub approach_feed_mm_per_min: f64,
    /// Largest distance of the pad centre from the surface, along the normal, halfway through
    /// a move (linear interpolation of X, Z and B between poses), mm.
    pub max_path_deviation_mm: f64,
    /// What looks wrong in the input though it is valid (a unit mistake), and a machine asked
    /// to be `"unlimited"`; empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
    /// The G-code (served with `Accept: text/x-gcode`).
    #[serde(skip)]
    pub gcode: String,
}

impl From<&SpindleWordsDto> for SpindleWordsSpec {
    fn from(w: &SpindleWordsDto) -> Self {
        SpindleWordsSpec {
            cw: w.cw.clone(),
            ccw: w.ccw.clone(),
            stop: w.stop.clone(),
        }
    }
}

impl From<&FormatDto> for GcodeFormatSpec {
    fn from(f: &FormatDto) -> Self {
        let words = |w: &Option<SpindleWordsDto>| w.as_ref().map(Into::into).unwrap_or_default();
        GcodeFormatSpec {
            feed_mode: f.feed_mode.map(|m| match m {
                FeedModeDto::UnitsPerMinute => FeedMode::UnitsPerMinute,
                FeedModeDto::InverseTime => FeedMode::InverseTime,
            }),
            decimals: decimals(f.decimals),
            workpiece_spindle: words(&f.workpiece_spindle),
            tool_spindle: words(&f.tool_spindle),
        }
    }
}

/// Decimals as the format takes them (a count too large is refused by the format's check:
/// u32::MAX is > 7).
pub(in crate::http) fn decimals(d: Option<usize>) -> Option<u32> {
    d.map(|d| u32::try_from(d).unwrap_or(u32::MAX))
}

/// The G-code format of a program whose only spindle words are the tool's (the part's spindle
/// is C, or the part stands still): inverse time, `decimals`, the tool spindle's words.
pub(in crate::http) fn tool_words_format(
    decimals_given: Option<usize>,
    tool_spindle: Option<&SpindleWordsDto>,
) -> GcodeFormatSpec {
    GcodeFormatSpec {
        feed_mode: None,
        decimals: decimals(decimals_given),
        workpiece_spindle: Default::default(),
        tool_spindle: tool_spindle.map(Into::into).unwrap_or_default(),
    }
}

/// The SHA-256 of a request as parsed (its canonical JSON), written into a program's header.
pub(in crate::http) fn request_digest(req: &impl Serialize) -> Result<String, ApiError> {
    let canonical = serde_json::to_vec(req).map_err(|e| ApiError::internal(e.to_string()))?;
    Ok(crate::store::sha256_hex(&canonical))
}

pub struct ProgramEndpoint;

impl Endpoint for ProgramEndpoint {
    const NAME: &'static str = "program";
    const EXAMPLE: &'static str = include_str!("../../fixtures/program_sphere.json");
    const DOC: Doc = Doc {
        operation_id: "generateProgram",
        tag: "machine",
        summary: "Turn a dwell plan into a machine program.",
        description: "Poses put the pad's centre on each surface point with its axis along the normal\n\
(`orientation: normal`: X = r − L·sin θ, Z = z(r) + L·cos θ, B = θ; `vertical`: X = r,\n\
Z = z(r) + L, B = 0). The tool spends each position's dwell between the midpoints to its\n\
neighbours (the optimizer's motion model: it crosses each segment in half of each end's\n\
dwell), with half the first and last dwells as stops. Velocity and acceleration are checked\n\
per axis against `machine`; a program that would break any stated limit is a 422\n\
`machine-limits` problem listing every violation, never a program. `Accept: text/x-gcode`\n\
returns the G-code (RS274/NGC, LinuxCNC dialect: G21 G90, G93 inverse time or G94, G4 P\n\
seconds), `text/csv` the block table.",
        ok: "The blocks, per-axis motion and utilisation; as G-code, the program; as CSV, the block table",
    };
    type Request = ProgramRequest;
    type Body = ApiJson<ProgramRequest>;
    type Command = ProgramCommand;
    type Output = MachineProgram;
    type Response = ProgramResponse;
    const CSV: Option<fn(&MachineProgram) -> String> = Some(results::program_csv);
    const GCODE: Option<fn(&MachineProgram) -> String> = Some(|m| m.gcode.clone());

    fn parse(req: ProgramRequest, limits: &ComputeLimits) -> Result<ProgramCommand, ApiError> {
        let digest = request_digest(&req)?;
        let approach = req.approach.clone().unwrap_or_default();
        let spec = ProgramSpec {
            process: req.process.spec()?,
            part: part_spec(req.surface.as_ref(), req.tool.as_ref())?,
            positions_mm: req.dwell.positions_mm,
            dwell_s: req.dwell.dwell_s,
            machine: MachineChoiceDto::choice(req.machine.as_ref()),
            clearance_mm: approach.clearance_mm,
            approach_feed_mm_per_min: approach.feed_mm_per_min,
            format: req
                .format
                .as_ref()
                .map(GcodeFormatSpec::from)
                .unwrap_or_default(),
            request_digest: digest,
        };
        Ok(ProgramCommand::new(spec, limits)?)
    }

    fn run(command: ProgramCommand, _: &Services) -> Result<MachineProgram, ApiError> {
        Ok(program(command)?)
    }

    fn respond(m: MachineProgram) -> ProgramResponse {
        let p = &m.program;
        let blocks = p
            .blocks()
            .iter()
            .enumerate()
            .map(|(index, b)| {
                let feed = p.path_feed_per_min(index);
                BlockDto {
                    kind: match b.kind {
                        BlockKind::Approach => BlockKindDto::Approach,
                        BlockKind::Dwell => BlockKindDto::Dwell,
                        BlockKind::Move => BlockKindDto::Move,
                        BlockKind::Retract => BlockKindDto::Retract,
                    },
                    position_mm: b.position_mm,
                    arc_length_mm: b.arc_length_mm,
                    x_mm: b.end.x_mm,
                    z_mm: b.end.z_mm,
                    b_deg: b.end.b_deg,
                    duration_s: b.duration_s,
                    feed_mm_per_min: feed,
                    inverse_time_per_min: feed.map(|_| 60.0 / b.duration_s),
                }
            })
            .collect();
        let spec = m.process.spec();
        let start = p.start();
        ProgramResponse {
            start: PoseDto {
                x_mm: start.x_mm,
                z_mm: start.z_mm,
                b_deg: start.b_deg,
            },
            blocks,
            total_time_s: p.polishing_time_s,
            program_time_s: p.program_time_s,
            axes: AxesDto::of(p, &m.machine),
            spindles: SpindlesDto {
                workpiece_rpm: spec.workpiece_rpm,
                tool_rpm: spec.tool_rpm,
                eta: m.process.eta().value(),
            },
            skipped_positions: p.skipped.into(),
            approach_clearance_mm: m.approach.clearance_mm,
            approach_feed_mm_per_min: m.approach.feed_mm_per_min,
            max_path_deviation_mm: p.max_path_deviation_mm,
            warnings: WarningDto::all_at(&m.warnings, "dwell.positions_mm"),
            gcode: m.gcode,
        }
    }
}
