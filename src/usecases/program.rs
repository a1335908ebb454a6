//! A machine program from a dwell plan: poses, blocks and axis motion ([`crate::machine`]),
//! checked against the machine's limits, and its G-code.

use super::limits::{ComputeLimits, SizeLimitError};
use super::setting::{process_on_part, Mount, PartSpec, SettingError};
use super::warnings::process_warnings;
use super::Warning;
use crate::machine::{
    gcode, Approach, Axis, AxisLimits, AxisMotion, GcodeFormat, GcodeFormatError, GcodeFormatSpec,
    InvalidLimit, MachineChoice, MachineLimits, Program, ProgramError, Tool, Violation,
};
use crate::physics::{DwellSchedule, Process, ProcessSpec, ScheduleError};
use crate::surface::SurfaceError;

/// Clearance of the approach and retract along the tool axis by default, mm.
pub const DEFAULT_CLEARANCE_MM: f64 = 5.0;
/// Feed of the approach and retract by default, mm/min (less where an axis limit needs it).
pub const DEFAULT_APPROACH_FEED_MM_PER_MIN: f64 = 100.0;
/// Largest clearance accepted, mm.
pub const MAX_CLEARANCE_MM: f64 = 1000.0;
/// Approach feeds accepted, mm/min (keeps the approach's duration finite and meaningful).
pub const APPROACH_FEED_RANGE_MM_PER_MIN: std::ops::RangeInclusive<f64> = 0.001..=1e6;

/// A program as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramSpec {
    pub process: ProcessSpec,
    pub part: PartSpec,
    pub positions_mm: Vec<f64>,
    pub dwell_s: Vec<f64>,
    pub machine: MachineChoice,
    /// Default [`DEFAULT_CLEARANCE_MM`].
    pub clearance_mm: Option<f64>,
    /// Default [`DEFAULT_APPROACH_FEED_MM_PER_MIN`], lowered to what the axis limits allow.
    pub approach_feed_mm_per_min: Option<f64>,
    pub format: GcodeFormatSpec,
    /// Written into the G-code header (e.g. a digest of the request).
    pub request_digest: String,
}

/// Why a program request was refused before computing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramInputError {
    /// The process or the part.
    #[error(transparent)]
    Setting(SettingError),
    /// A plan position where the surface is not defined.
    #[error("position {index}: {error}")]
    PositionOffSurface { index: usize, error: SurfaceError },
    #[error(transparent)]
    Size(SizeLimitError),
    #[error(transparent)]
    Schedule(ScheduleError),
    #[error(transparent)]
    Limits(InvalidLimit),
    #[error(transparent)]
    Format(GcodeFormatError),
    #[error("clearance_mm must be a finite number from 0 to {MAX_CLEARANCE_MM} mm")]
    Clearance,
    #[error("feed_mm_per_min must be from 0.001 to 1000000 mm/min")]
    ApproachFeed,
}

/// A checked program request.
#[derive(Debug, Clone)]
pub struct ProgramCommand {
    pub(super) process: Process,
    pub(super) schedule: DwellSchedule,
    pub(super) tool: Tool,
    pub(super) machine: MachineLimits,
    /// Which machine the limits are, for the header.
    pub(super) choice: MachineChoice,
    pub(super) clearance_mm: f64,
    pub(super) approach_feed_mm_per_min: Option<f64>,
    pub(super) format: GcodeFormat,
    pub(super) request_digest: String,
    /// More header lines: where the plan came from.
    pub(super) provenance: Vec<String>,
    /// Likely unit mistakes, and a machine asked to be unlimited.
    pub(super) warnings: Vec<Warning>,
}

/// A program command whose header can say where its plan came from.
pub trait Provenance: Sized {
    /// The command with a header line saying where its plan came from (a stored plan's id).
    fn with_provenance(self, line: String) -> Self;
}

impl Provenance for ProgramCommand {
    fn with_provenance(mut self, line: String) -> Self {
        self.provenance.push(line);
        self
    }
}

impl ProgramCommand {
    pub fn new(spec: ProgramSpec, limits: &ComputeLimits) -> Result<Self, ProgramInputError> {
        use ProgramInputError as E;
        let (process, Mount { tool, .. }) =
            process_on_part(spec.process, &spec.part).map_err(E::Setting)?;
        limits
            .check_positions(spec.positions_mm.len())
            .map_err(E::Size)?;
        let schedule =
            DwellSchedule::new(&process, spec.positions_mm, spec.dwell_s).map_err(E::Schedule)?;
        // Positions increase from ≥ 0: the last is the farthest from the axis.
        if let Some(index) = schedule.positions_mm().len().checked_sub(1) {
            let r = schedule.positions_mm()[index];
            process
                .part()
                .surface
                .check_defined_to(r)
                .map_err(|error| E::PositionOffSurface { index, error })?;
        }
        let machine = spec.machine.limits().map_err(E::Limits)?;
        let mut warnings = process_warnings(&process);
        if spec.machine.is_unlimited() {
            warnings.push(Warning::MachineUnlimited);
        }
        let format = GcodeFormat::new(spec.format).map_err(E::Format)?;
        let clearance_mm = spec.clearance_mm.unwrap_or(DEFAULT_CLEARANCE_MM);
        if !(0.0..=MAX_CLEARANCE_MM).contains(&clearance_mm) {
            return Err(E::Clearance);
        }
        if spec
            .approach_feed_mm_per_min
            .is_some_and(|f| !APPROACH_FEED_RANGE_MM_PER_MIN.contains(&f))
        {
            return Err(E::ApproachFeed);
        }
        Ok(ProgramCommand {
            process,
            schedule,
            tool,
            machine,
            choice: spec.machine,
            clearance_mm,
            approach_feed_mm_per_min: spec.approach_feed_mm_per_min,
            format,
            request_digest: spec.request_digest,
            provenance: Vec::new(),
            warnings,
        })
    }
}

/// Why a checked request gives no program.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramFailure {
    #[error(transparent)]
    Plan(ProgramError),
    /// The program would break these limits (never emitted).
    #[error("the program would exceed {} machine limit(s)", .0.len())]
    Limits(Vec<Violation>),
}

/// A program within every limit in force, and its G-code.
#[derive(Debug, Clone)]
pub struct MachineProgram {
    /// Likely unit mistakes, and a machine asked to be unlimited.
    pub warnings: Vec<Warning>,
    pub program: Program,
    pub process: Process,
    pub tool: Tool,
    pub machine: MachineLimits,
    pub approach: Approach,
    pub gcode: String,
}

/// The fastest approach feed (mm/min) at which an axis taking the share `share` (> 0) of it
/// over `clearance_mm`, starting from rest, stays within its limits (docs of
/// [`approach_feed`]); unbounded without limits.
pub(super) fn approach_cap(share: f64, limit: &AxisLimits, clearance_mm: f64) -> f64 {
    let mut feed = f64::INFINITY;
    // Each bound less a hair, so rounding in the program's own arithmetic never puts the
    // approach over the limit it was slowed for (at the bound itself a Z velocity came out
    // 1 ulp above its limit, and the program was refused).
    if let Some(v) = limit.max_velocity_per_min {
        feed = feed.min(v / share * (1.0 - 1e-9));
    }
    if let Some(a) = limit.max_acceleration_per_s2 {
        let bound = 60.0 * (a * clearance_mm / (2.0 * share)).sqrt();
        feed = feed.min(bound * (1.0 - 1e-9));
    }
    feed
}

/// The approach feed: the one asked, or the default lowered so that neither X nor Z exceeds
/// its velocity or acceleration limit moving along the tool axis at either end of the plan.
/// An axis taking the share s of feed f over the clearance c starts from rest at
/// a = s·(f/60) / (d/2) with d = 60·c/f, so a ≤ a_max needs f ≤ 60·√(a_max·c / (2·s)).
pub(super) fn approach_feed(command: &ProgramCommand) -> f64 {
    if let Some(feed) = command.approach_feed_mm_per_min {
        return feed;
    }
    let positions = command.schedule.positions_mm();
    let ends = [positions[0], positions[positions.len() - 1]];
    let mut feed = DEFAULT_APPROACH_FEED_MM_PER_MIN;
    for r in ends {
        let (sin, cos) = command
            .tool
            .pose(&command.process.part().surface, r)
            .b_deg
            .to_radians()
            .sin_cos();
        for (share, limit) in [
            (sin, command.machine.axis(Axis::X)),
            (cos, command.machine.axis(Axis::Z)),
        ] {
            let share = share.abs();
            if share == 0.0 {
                continue;
            }
            feed = feed.min(approach_cap(share, limit, command.clearance_mm));
        }
    }
    // A limit tighter than the slowest approach is then reported as a violation.
    feed.max(*APPROACH_FEED_RANGE_MM_PER_MIN.start())
}

pub fn program(command: ProgramCommand) -> Result<MachineProgram, ProgramFailure> {
    let approach = Approach {
        clearance_mm: command.clearance_mm,
        feed_mm_per_min: approach_feed(&command),
    };
    let program = Program::from_motion(
        &command.process.part().surface,
        &command.tool,
        command.schedule.motion(),
        command.schedule.dwell_s(),
        approach,
    )
    .map_err(ProgramFailure::Plan)?;
    let spec = command.process.spec();
    let violations = command.choice.mark(
        command
            .machine
            .violations(&program, (spec.workpiece_rpm, spec.tool_rpm)),
    );
    if !violations.is_empty() {
        return Err(ProgramFailure::Limits(violations));
    }
    let header = header(&command, &program);
    let gcode = gcode::write(
        &program,
        &header,
        spec.workpiece_rpm,
        spec.tool_rpm,
        &command.format,
    );
    Ok(MachineProgram {
        warnings: command.warnings,
        program,
        process: command.process,
        tool: command.tool,
        machine: command.machine,
        approach,
        gcode,
    })
}

/// The G-code's header comments: what was planned, for whom, from which request.
fn header(command: &ProgramCommand, program: &Program) -> Vec<String> {
    let axes = Axis::ALL.map(|axis| (axis, program.motion(axis)));
    header_lines(
        command,
        program.polishing_time_s,
        program.program_time_s,
        &axes,
        &[],
    )
}

/// The header's line saying which limits the program was checked against.
pub(super) fn limits_line(choice: MachineChoice) -> String {
    match choice {
        MachineChoice::Default => "limits: Preston's default machine".to_string(),
        MachineChoice::Given(_) => {
            "limits: the machine as given (the default machine's where not given)".to_string()
        }
        MachineChoice::Unlimited => {
            "WARNING: machine unlimited: no limit was checked; a study, not a program to run"
                .to_string()
        }
    }
}

/// The header's lines for a program of these times whose `axes` move so, with `more` lines
/// after the axes' ranges.
pub(super) fn header_lines(
    command: &ProgramCommand,
    polishing_time_s: f64,
    program_time_s: f64,
    axes: &[(Axis, &AxisMotion)],
    more: &[String],
) -> Vec<String> {
    let spec = command.process.spec();
    let eta = match command.process.eta().value() {
        Some(eta) => format!("{eta}"),
        None => "undefined (tool stationary)".to_string(),
    };
    let surface = match command.process.part().surface.radius_of_curvature_mm() {
        None => "plane".to_string(),
        Some(r) if command.process.part().surface.is_sphere() => format!("sphere R = {r} mm"),
        Some(r) => format!("asphere R = {r} mm"),
    };
    let axes: Vec<String> = axes
        .iter()
        .map(|&(d, m)| {
            format!(
                "{} {:.4} to {:.4} {}",
                d.name().to_uppercase(),
                m.min,
                m.max,
                d.unit()
            )
        })
        .collect();
    let mut lines = vec!["Preston machine program".to_string()];
    lines.extend(command.provenance.iter().cloned());
    lines.extend([
        format!(
            "process: workpiece {} rpm, tool {} rpm (lab frame, CCW positive from the tool side), eta = {eta}",
            spec.workpiece_rpm, spec.tool_rpm
        ),
        format!(
            "workpiece radius {} mm, tool radius {} mm, surface {surface}",
            spec.workpiece_radius_mm, spec.tool_radius_mm
        ),
        format!(
            "plan: {} positions, total time {:.3} s; program with approach and retract {:.3} s",
            command.schedule.positions_mm().len(),
            polishing_time_s,
            program_time_s
        ),
        format!("axes: {}", axes.join(", ")),
    ]);
    lines.extend(more.iter().cloned());
    lines.extend([
        limits_line(command.choice),
        format!("request sha256 {}", command.request_digest),
    ]);
    lines
}
