//! `POST /v1/program`: a dwell plan as a machine program (X, Z, B and both spindles), checked
//! against the machine's limits; JSON blocks, `text/x-gcode` or `text/csv`.

use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::Response;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use utoipa::ToSchema;

use super::dto::{DwellDto, ProcessDto, SurfaceDto};
use super::endpoint::{handle, Endpoint};
use super::error::ApiError;
use super::extract::{object, optional_count, optional_object, ApiJson};
use super::openapi::ComputeProblems;
use super::state::{AppState, Services};
use crate::machine::{
    AxisLimits, AxisMotion, BlockKind, Drive, FeedMode, GcodeFormat, MachineLimits, Orientation,
    Program, SpindleWords, Tool,
};
use crate::physics::ProcessSpec;
use crate::surface::{Surface, SurfaceSpec};
use crate::usecases::optimize::Machine;
use crate::usecases::program::{program, ProgramCommand, ProgramInputError, ProgramSpec};
use crate::usecases::ComputeLimits;

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

/// Limits of a linear axis (X or Z); each optional (absent = unlimited).
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

/// Limits of the tilt axis B; each optional (absent = unlimited).
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

/// A spindle's speed limit.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SpindleLimitDto {
    /// Largest |speed|, r/min (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_rpm: Option<f64>,
}

/// The machine's limits, per axis and spindle; everything optional (absent = unlimited).
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
    /// Default: no limits.
    #[serde(default, deserialize_with = "optional_object")]
    pub machine: Option<MachineDto>,
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
    /// The G-code (served with `Accept: text/x-gcode`).
    #[serde(skip)]
    pub gcode: String,
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

impl From<&MachineDto> for MachineLimits {
    fn from(m: &MachineDto) -> Self {
        let linear = |a: &Option<LinearAxisDto>| {
            a.as_ref().map_or(AxisLimits::default(), |a| {
                axis_limits(
                    a.min_mm,
                    a.max_mm,
                    a.max_velocity_mm_per_min,
                    a.max_acceleration_mm_per_s2,
                )
            })
        };
        let b = m.b.as_ref().map_or(AxisLimits::default(), |b| {
            axis_limits(
                b.min_deg,
                b.max_deg,
                b.max_velocity_deg_per_min,
                b.max_acceleration_deg_per_s2,
            )
        });
        MachineLimits {
            x: linear(&m.x),
            z: linear(&m.z),
            b,
            workpiece_max_rpm: m.workpiece_spindle.as_ref().and_then(|s| s.max_rpm),
            tool_max_rpm: m.tool_spindle.as_ref().and_then(|s| s.max_rpm),
        }
    }
}

fn spindle_words(dto: &Option<SpindleWordsDto>, default: SpindleWords) -> SpindleWords {
    let Some(dto) = dto else { return default };
    SpindleWords {
        cw: dto.cw.clone().unwrap_or(default.cw),
        ccw: dto.ccw.clone().unwrap_or(default.ccw),
        stop: dto.stop.clone().unwrap_or(default.stop),
    }
}

impl From<&FormatDto> for GcodeFormat {
    fn from(f: &FormatDto) -> Self {
        let default = GcodeFormat::default();
        GcodeFormat {
            feed_mode: match f.feed_mode {
                Some(FeedModeDto::UnitsPerMinute) => FeedMode::UnitsPerMinute,
                Some(FeedModeDto::InverseTime) => FeedMode::InverseTime,
                None => default.feed_mode,
            },
            // Out of range values are refused by the check (u32::MAX is > 7).
            decimals: f
                .decimals
                .map_or(default.decimals, |d| u32::try_from(d).unwrap_or(u32::MAX)),
            workpiece_spindle: spindle_words(&f.workpiece_spindle, default.workpiece_spindle),
            tool_spindle: spindle_words(&f.tool_spindle, default.tool_spindle),
        }
    }
}

fn utilisation(used: f64, limit: Option<f64>) -> Option<f64> {
    limit.map(|l| used / l)
}

fn axis_report(motion: &AxisMotion, limits: &AxisLimits) -> (UtilisationDto, [f64; 5]) {
    let range = match (limits.min, limits.max) {
        (Some(lo), Some(hi)) => Some(hi - lo),
        _ => None,
    };
    (
        UtilisationDto {
            travel: utilisation(motion.travel(), range),
            velocity: utilisation(motion.peak_velocity_per_min, limits.max_velocity_per_min),
            acceleration: utilisation(
                motion.peak_acceleration_per_s2,
                limits.max_acceleration_per_s2,
            ),
        },
        [
            motion.min,
            motion.max,
            motion.travel(),
            motion.peak_velocity_per_min,
            motion.peak_acceleration_per_s2,
        ],
    )
}

impl AxesDto {
    /// Each axis's travel, peaks and use of `machine`'s limits over `program`.
    pub fn of(program: &Program, machine: &MachineLimits) -> Self {
        let linear = |drive| {
            let (utilisation, v) = axis_report(program.motion(drive), machine.axis(drive));
            LinearAxisReport {
                min_mm: v[0],
                max_mm: v[1],
                travel_mm: v[2],
                peak_velocity_mm_per_min: v[3],
                peak_acceleration_mm_per_s2: v[4],
                utilisation,
            }
        };
        let (b_utilisation, b) = axis_report(program.motion(Drive::B), &machine.b);
        AxesDto {
            x: linear(Drive::X),
            z: linear(Drive::Z),
            b: RotaryAxisReport {
                min_deg: b[0],
                max_deg: b[1],
                travel_deg: b[2],
                peak_velocity_deg_per_min: b[3],
                peak_acceleration_deg_per_s2: b[4],
                utilisation: b_utilisation,
            },
        }
    }
}

pub struct ProgramEndpoint;

impl Endpoint for ProgramEndpoint {
    type Request = ProgramRequest;
    type Command = ProgramCommand;
    type Response = ProgramResponse;
    const CSV: Option<fn(&Self::Response) -> String> = Some(to_csv);
    const GCODE: Option<fn(&Self::Response) -> String> = Some(|r| r.gcode.clone());

    fn parse(req: ProgramRequest, limits: &ComputeLimits) -> Result<ProgramCommand, ApiError> {
        let canonical = serde_json::to_vec(&req).map_err(|e| ApiError::internal(e.to_string()))?;
        let digest: String = Sha256::digest(&canonical)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        let tool = req.tool.clone().unwrap_or_default();
        let approach = req.approach.clone().unwrap_or_default();
        let spec = ProgramSpec {
            process: ProcessSpec::from(&req.process),
            surface: req
                .surface
                .as_ref()
                .map_or(SurfaceSpec::Plane, SurfaceSpec::from),
            positions_mm: req.dwell.positions_mm,
            dwell_s: req.dwell.dwell_s,
            pivot_length_mm: tool.pivot_length_mm,
            orientation: tool.orientation.map(Orientation::from),
            machine: req
                .machine
                .as_ref()
                .map(MachineLimits::from)
                .unwrap_or_default(),
            clearance_mm: approach.clearance_mm,
            approach_feed_mm_per_min: approach.feed_mm_per_min,
            format: req
                .format
                .as_ref()
                .map(GcodeFormat::from)
                .unwrap_or_default(),
            request_digest: digest,
        };
        Ok(ProgramCommand::new(spec, limits)?)
    }

    fn run(command: ProgramCommand, _: &Services) -> Result<ProgramResponse, ApiError> {
        let m = program(command)?;
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
        Ok(ProgramResponse {
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
            skipped_positions: SkippedDto {
                leading: p.skipped.0,
                trailing: p.skipped.1,
            },
            approach_clearance_mm: m.approach.clearance_mm,
            approach_feed_mm_per_min: m.approach.feed_mm_per_min,
            max_path_deviation_mm: p.max_path_deviation_mm,
            gcode: m.gcode,
        })
    }
}

/// The machine a plan must run on (for `/v1/optimize`): the part's surface, already checked
/// with the process, and the tool and limits as given, each checked and any error naming its
/// field.
pub fn machine_setup(
    surface: &Surface,
    tool: Option<&ToolDto>,
    machine: &MachineDto,
) -> Result<Machine, ApiError> {
    let surface = surface.clone();
    let tool_dto = tool.cloned().unwrap_or_default();
    let tool = Tool::new(
        tool_dto.pivot_length_mm.unwrap_or(0.0),
        tool_dto
            .orientation
            .map_or(Orientation::Normal, Orientation::from),
    )
    .map_err(ProgramInputError::Tool)?;
    let limits = MachineLimits::from(machine);
    limits.check().map_err(ProgramInputError::Limits)?;
    Ok(Machine {
        surface,
        tool,
        limits,
    })
}

impl From<OrientationDto> for Orientation {
    fn from(o: OrientationDto) -> Self {
        match o {
            OrientationDto::Normal => Orientation::Normal,
            OrientationDto::Vertical => Orientation::Vertical,
        }
    }
}

fn to_csv(r: &ProgramResponse) -> String {
    let mut out = String::from(
        "block,kind,position_mm,arc_length_mm,x_mm,z_mm,b_deg,duration_s,feed_mm_per_min,inverse_time_per_min\n",
    );
    let optional = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for (i, b) in r.blocks.iter().enumerate() {
        let kind = match b.kind {
            BlockKindDto::Approach => "approach",
            BlockKindDto::Dwell => "dwell",
            BlockKindDto::Move => "move",
            BlockKindDto::Retract => "retract",
        };
        out.push_str(&format!(
            "{i},{kind},{},{},{},{},{},{},{},{}\n",
            b.position_mm,
            b.arc_length_mm,
            b.x_mm,
            b.z_mm,
            b.b_deg,
            b.duration_s,
            optional(b.feed_mm_per_min),
            optional(b.inverse_time_per_min)
        ));
    }
    out
}

/// Turn a dwell plan into a machine program.
///
/// Poses put the pad's centre on each surface point with its axis along the normal
/// (`orientation: normal`: X = r − L·sin θ, Z = z(r) + L·cos θ, B = θ; `vertical`: X = r,
/// Z = z(r) + L, B = 0). The tool spends each position's dwell between the midpoints to its
/// neighbours (the optimizer's motion model: it crosses each segment in half of each end's
/// dwell), with half the first and last dwells as stops. Velocity and acceleration are checked
/// per axis against `machine`; a program that would break any stated limit is a 422
/// `machine-limits` problem listing every violation, never a program. `Accept: text/x-gcode`
/// returns the G-code (RS274/NGC, LinuxCNC dialect: G21 G90, G93 inverse time or G94, G4 P
/// seconds), `text/csv` the block table.
#[utoipa::path(
    post,
    path = "/v1/program",
    operation_id = "generateProgram",
    tag = "machine",
    request_body = ProgramRequest,
    responses(
        (status = 200, description = "The blocks, per-axis motion and utilisation; as G-code, the program; as CSV, the block table", content(
            (ProgramResponse = "application/json"),
            (String = "text/x-gcode"),
            (String = "text/csv"),
        )),
        ComputeProblems,
    )
)]
pub async fn handler(
    State(state): State<AppState>,
    headers: HeaderMap,
    ApiJson(req): ApiJson<ProgramRequest>,
) -> Result<Response, ApiError> {
    handle::<ProgramEndpoint>(state, &headers, req).await
}
