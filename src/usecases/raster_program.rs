//! A raster plan as a machine program for an X-Y machine (`POST /v1/maps/program` with
//! `machine.kinematics: cartesian`): the executed motion's blocks ([`crate::machine::xy_program`]),
//! checked against X's, Y's and Z's limits and the tool spindle's speed, written as G-code.
//!
//! The blocks are those the plan was optimized and predicted for, so the program removes what
//! `/v1/maps/predict` reports, and its X and Y peaks are those `/v1/maps/optimize` reported
//! (the same model, computed again here from the program's own positions and durations).

use super::program::{
    approach_cap, ProgramFailure, Provenance, APPROACH_FEED_RANGE_MM_PER_MIN,
    DEFAULT_APPROACH_FEED_MM_PER_MIN, DEFAULT_CLEARANCE_MM, MAX_CLEARANCE_MM,
};
use super::raster_predict::{check_plan, RasterPredictError};
use super::Warning;
use crate::machine::{
    gcode, Approach, Axis, GcodeFormat, GcodeFormatError, GcodeFormatSpec, InvalidLimit,
    MachineChoice, MachineLimits, XyProgram,
};
use crate::physics::raster::Path;
use crate::surface::{Surface, SurfaceError, SurfaceSpec};

/// An X-Y program as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct RasterProgramSpec {
    /// The plan in path order, mm, and each point's dwell, s.
    pub points_mm: Vec<[f64; 2]>,
    pub dwell_s: Vec<f64>,
    /// X's, Y's and Z's limits and the tool spindle's (B, C and the workpiece spindle are not
    /// an X-Y machine's).
    pub machine: MachineChoice,
    /// The tool spindle's speed, r/min (signed, counter-clockwise positive seen from the tool
    /// side); `None`: the program leaves the tool to the shop (a beam, a jet).
    pub tool_rpm: Option<f64>,
    /// The part's surface, its vertex at the plan's origin; `None`: a flat (Z stays at 0).
    pub surface: Option<SurfaceSpec>,
    /// Default [`DEFAULT_CLEARANCE_MM`].
    pub clearance_mm: Option<f64>,
    /// Default [`DEFAULT_APPROACH_FEED_MM_PER_MIN`], lowered to what Z's limits allow.
    pub approach_feed_mm_per_min: Option<f64>,
    pub format: GcodeFormatSpec,
    /// Written into the G-code header.
    pub request_digest: String,
}

/// Why an X-Y program request was refused before computing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RasterProgramInputError {
    #[error(transparent)]
    Plan(RasterPredictError),
    #[error(transparent)]
    Limits(InvalidLimit),
    #[error(transparent)]
    Format(GcodeFormatError),
    #[error("clearance_mm must be a finite number from 0 to {MAX_CLEARANCE_MM} mm")]
    Clearance,
    #[error("feed_mm_per_min must be from 0.001 to 1000000 mm/min")]
    ApproachFeed,
    #[error("the tool's speed must be a finite number of r/min, not {0}")]
    ToolRpm(f64),
    #[error(transparent)]
    Surface(SurfaceError),
    /// A point where the surface is not defined.
    #[error("point {index}: {error}")]
    PointOffSurface { index: usize, error: SurfaceError },
}

/// A checked X-Y program request.
#[derive(Debug, Clone)]
pub struct RasterProgramCommand {
    path: Path,
    dwell_s: Vec<f64>,
    surface: Surface,
    machine: MachineLimits,
    choice: MachineChoice,
    tool_rpm: Option<f64>,
    approach: Approach,
    format: GcodeFormat,
    request_digest: String,
    /// More header lines: where the plan came from.
    provenance: Vec<String>,
}

impl Provenance for RasterProgramCommand {
    fn with_provenance(mut self, line: String) -> Self {
        self.provenance.push(line);
        self
    }
}

impl RasterProgramCommand {
    pub fn new(spec: RasterProgramSpec) -> Result<Self, RasterProgramInputError> {
        use RasterProgramInputError as E;
        check_plan(&spec.points_mm, &spec.dwell_s).map_err(E::Plan)?;
        let surface = match &spec.surface {
            Some(s) => Surface::new(s).map_err(E::Surface)?,
            None => Surface::plane(),
        };
        // The farthest point from the vertex decides whether the surface reaches them all.
        if let Some((index, r)) = spec
            .points_mm
            .iter()
            .map(|p| p[0].hypot(p[1]))
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1))
        {
            surface
                .check_defined_to(r)
                .map_err(|error| E::PointOffSurface { index, error })?;
        }
        let path = Path::through(spec.points_mm).map_err(|e| E::Plan(e.into()))?;
        let machine = spec.machine.limits().map_err(E::Limits)?;
        let format = GcodeFormat::new(spec.format).map_err(E::Format)?;
        if let Some(rpm) = spec.tool_rpm.filter(|r| !r.is_finite()) {
            return Err(E::ToolRpm(rpm));
        }
        let clearance_mm = spec.clearance_mm.unwrap_or(DEFAULT_CLEARANCE_MM);
        if !(0.0..=MAX_CLEARANCE_MM).contains(&clearance_mm) {
            return Err(E::Clearance);
        }
        let feed_mm_per_min = match spec.approach_feed_mm_per_min {
            Some(f) if APPROACH_FEED_RANGE_MM_PER_MIN.contains(&f) => f,
            Some(_) => return Err(E::ApproachFeed),
            // Z alone moves on the approach: its share of the feed is 1.
            None => DEFAULT_APPROACH_FEED_MM_PER_MIN
                .min(approach_cap(1.0, machine.axis(Axis::Z), clearance_mm))
                .max(*APPROACH_FEED_RANGE_MM_PER_MIN.start()),
        };
        Ok(RasterProgramCommand {
            path,
            dwell_s: spec.dwell_s,
            surface,
            machine,
            choice: spec.machine,
            tool_rpm: spec.tool_rpm,
            approach: Approach {
                clearance_mm,
                feed_mm_per_min,
            },
            format,
            request_digest: spec.request_digest,
            provenance: Vec::new(),
        })
    }
}

/// An X-Y program within every limit in force, and its G-code.
#[derive(Debug, Clone)]
pub struct RasterMachineProgram {
    pub warnings: Vec<Warning>,
    pub program: XyProgram,
    pub machine: MachineLimits,
    pub tool_rpm: Option<f64>,
    pub gcode: String,
}

/// X, Y and Z: the axes an X-Y program drives.
pub const XY_AXES: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

pub fn raster_program(
    command: RasterProgramCommand,
) -> Result<RasterMachineProgram, ProgramFailure> {
    let program = XyProgram::from_path(
        &command.path,
        &command.dwell_s,
        command.approach,
        &command.surface,
    )
    .map_err(ProgramFailure::Plan)?;
    let machine = command.machine;
    let axes = XY_AXES.map(|a| (a, program.motion(a)));
    let violations = command.choice.mark(machine.violations_of(
        &axes,
        |limit, index| program.block_of(limit, index),
        program.blocks().len(),
        (0.0, command.tool_rpm.unwrap_or(0.0)),
    ));
    if !violations.is_empty() {
        return Err(ProgramFailure::Limits(violations));
    }
    let mut warnings = Vec::new();
    if command.choice.is_unlimited() {
        warnings.push(Warning::MachineUnlimited);
    }
    let header = header(&command, &program);
    let gcode = gcode::write_xy(&program, &header, command.tool_rpm, &command.format);
    Ok(RasterMachineProgram {
        warnings,
        program,
        machine,
        tool_rpm: command.tool_rpm,
        gcode,
    })
}

/// Where Z = 0 is, and how Z follows the part.
fn surface_line(surface: &Surface, program: &XyProgram) -> String {
    let base = "Z = 0 is the tool's working height over the part's vertex, set by the work offset";
    match surface.radius_of_curvature_mm() {
        None => format!("{base}; a flat"),
        Some(r) => format!(
            "{base}; Z follows the {} of vertex radius {r} mm at the plan's origin \
             (steepest slope {:.3} deg, largest chord deviation {:.6} mm)",
            if surface.is_sphere() {
                "sphere"
            } else {
                "asphere"
            },
            program.max_slope_deg,
            program.max_path_deviation_mm
        ),
    }
}

/// The G-code's header comments: what was planned, on which machine, from which request.
fn header(command: &RasterProgramCommand, program: &XyProgram) -> Vec<String> {
    let axes: Vec<String> = XY_AXES
        .iter()
        .map(|&a| {
            let m = program.motion(a);
            format!(
                "{} {:.4} to {:.4} mm",
                a.name().to_uppercase(),
                m.min,
                m.max
            )
        })
        .collect();
    let tool = match command.tool_rpm {
        Some(rpm) => format!("tool spindle {rpm} rpm, CCW positive from the tool side"),
        None => "tool: switched by the shop, no spindle words".to_string(),
    };
    let mut lines = vec!["Preston machine program, X-Y machine: the part stands still".to_string()];
    lines.extend(command.provenance.iter().cloned());
    lines.extend([
        format!(
            "plan: {} points, total time {:.3} s; program with approach and retract {:.3} s",
            command.path.len(),
            program.polishing_time_s,
            program.program_time_s
        ),
        format!("axes: {}", axes.join(", ")),
        surface_line(&command.surface, program),
        tool,
        super::program::limits_line(command.choice),
        format!("request sha256 {}", command.request_digest),
    ]);
    lines
}
