//! A polar plan as a machine program (`POST /v1/maps/program`): the radial plan's stops and
//! moves with C under position control, its speed law executed block by block
//! ([`crate::machine::polar_program`]), checked against every limit of the machine, C's
//! included, and written as G-code in inverse time with C words. On segments Z and B follow
//! each ring's law, the blocks cut to a chord tolerance on Z, and each station's ring is held
//! to the servo rule at the law's C speeds as the correction holds it.

use std::f64::consts::TAU;

use super::map_optimize::{station_demands, station_servo, SegmentSetup, ServoError, StationServo};
use super::map_predict::{
    law_work, polar_schedule, station_turns, CLawError, CLawSpec, MAX_BLOCKS,
};
use super::program::{approach_feed, header_lines, ProgramCommand, ProgramFailure, Provenance};
use super::Warning;
use crate::machine::gcode::{self, CWords};
use crate::machine::polar_program::MAX_C_STEP_DEG;
use crate::machine::{Approach, Axis, MachineLimits};
use crate::machine::{PolarPart, PolarProgram, PolarRun, SegmentPath};
use crate::physics::polar::PolarPad;
use crate::physics::Process;

/// What the caller asks beyond a radial program.
#[derive(Debug, Clone, PartialEq)]
pub struct MapProgramSpec {
    /// `None`: C at the process's constant speed.
    pub c_law: Option<CLawSpec>,
    /// The pad centre's part-frame angle at the start, degrees; default 0.
    pub start_angle_deg: Option<f64>,
    /// Default [`CWords::Wrapped`].
    pub c_words: Option<CWords>,
    /// Segments on C (or a decentred part): Z and B follow them.
    pub segments: Option<SegmentSetup>,
}

/// Why a polar program request was refused before computing (beyond a radial program's
/// reasons).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapProgramInputError {
    #[error(transparent)]
    Law(CLawError),
    #[error("the start angle must be a finite number of degrees, not {0}")]
    StartAngle(f64),
    #[error(
        "the approach takes {duration_s:.0} s, and C turns about {turns:.0} times in it (the \
         program keeps C at its polishing speed on and off the part): a faster approach feed or \
         a smaller clearance"
    )]
    ApproachTooLong { turns: f64, duration_s: f64 },
    #[error(
        "the plan runs C through about {turns:.0} turns in about {blocks:.2e} blocks; a program \
         has at most {max:.0e} (fewer sectors, a shorter plan, or on segments a larger chord \
         tolerance)"
    )]
    TooManyBlocks { turns: f64, blocks: f64, max: f64 },
    #[error(transparent)]
    Servo(ServoError),
}

/// A checked polar program request: a radial program's, C's law applied to its motion.
#[derive(Debug, Clone)]
pub struct MapProgramCommand {
    base: ProgramCommand,
    /// Ω, rad/s (signed, lab frame).
    part_speed_rad_per_s: f64,
    start_rad: f64,
    c_words: CWords,
    sectors: Option<usize>,
    segments: Option<SegmentRun>,
}

/// A program's segments, checked: how Z and B follow them, and each station's demand on Z
/// at the law's C speed.
#[derive(Debug, Clone)]
struct SegmentRun {
    path: SegmentPath,
    servo: Vec<StationServo>,
}

impl Provenance for MapProgramCommand {
    fn with_provenance(self, line: String) -> Self {
        MapProgramCommand {
            base: self.base.with_provenance(line),
            ..self
        }
    }
}

impl MapProgramCommand {
    pub fn new(base: ProgramCommand, spec: MapProgramSpec) -> Result<Self, MapProgramInputError> {
        use MapProgramInputError as E;
        let pad = PolarPad::new(&base.process);
        let sectors = spec.c_law.as_ref().map(|law| law.sectors);
        let (schedule, fastest) =
            polar_schedule(base.schedule.clone(), spec.c_law).map_err(E::Law)?;
        let start_deg = spec.start_angle_deg.unwrap_or(0.0);
        if !start_deg.is_finite() {
            return Err(E::StartAngle(start_deg));
        }
        let omega = pad.part_speed_rad_per_s();
        // A block per sector passed (a quarter turn at most).
        let per_turn = (360.0 / MAX_C_STEP_DEG).max(sectors.unwrap_or(1) as f64);
        let (turns, mut blocks) = law_work(&schedule, &fastest, omega, per_turn);
        let segments = match spec.segments {
            None => None,
            Some(setup) => {
                let rt = base.process.tool_radius_mm();
                let positions = schedule.positions_mm();
                let plan_rpm = |j: usize| omega.abs() * fastest[j] * 60.0 / TAU;
                let demands = station_demands(
                    &setup.layout,
                    setup.lift_mm,
                    rt,
                    positions,
                    base.machine.axis(Axis::Z),
                    plan_rpm,
                )
                .map_err(E::Servo)?;
                let path = SegmentPath::new(
                    setup.layout,
                    setup.lift_mm,
                    rt,
                    setup.chord_tolerance_mm,
                    positions,
                );
                // The chord rule's blocks, station by station.
                let station_turns = station_turns(schedule.dwell_s(), &fastest, omega);
                blocks += positions
                    .iter()
                    .zip(&station_turns)
                    .map(|(&r, turns)| turns * TAU / path.max_step_rad(r, r))
                    .sum::<f64>();
                let servo = station_servo(demands, plan_rpm);
                Some(SegmentRun { path, servo })
            }
        };
        // The approach and retract at C's fastest, each as long as its feed or C's ramp
        // (from half C's limit, `ramp_acceleration`) makes it, in quarter turns.
        let fastest_deg_per_s =
            omega.abs().to_degrees() * fastest.iter().cloned().fold(0.0, f64::max);
        let mut approach_s = 60.0 * base.clearance_mm / approach_feed(&base);
        if let Some(a) = base.machine.axis(Axis::C).max_acceleration_per_s2 {
            approach_s = approach_s.max(4.0 * fastest_deg_per_s / a);
        }
        let ramps = if base.clearance_mm > 0.0 {
            2.0 * (fastest_deg_per_s * approach_s / MAX_C_STEP_DEG).ceil()
        } else {
            0.0
        };
        if ramps > MAX_BLOCKS / 10.0 {
            return Err(E::ApproachTooLong {
                turns: ramps * MAX_C_STEP_DEG / 720.0,
                duration_s: approach_s,
            });
        }
        if blocks + ramps > MAX_BLOCKS {
            return Err(E::TooManyBlocks {
                turns,
                blocks: blocks + ramps,
                max: MAX_BLOCKS,
            });
        }
        Ok(MapProgramCommand {
            base: ProgramCommand { schedule, ..base },
            part_speed_rad_per_s: omega,
            start_rad: start_deg.to_radians(),
            c_words: spec.c_words.unwrap_or_default(),
            sectors,
            segments,
        })
    }
}

/// A polar program within every limit in force, and its G-code.
#[derive(Debug, Clone)]
pub struct PolarMachineProgram {
    pub warnings: Vec<Warning>,
    pub program: PolarProgram,
    pub process: Process,
    pub machine: MachineLimits,
    pub c_words: CWords,
    pub gcode: String,
    /// On segments: each station's demand on Z, and the chord tolerance the blocks keep, mm.
    pub segments: Option<(Vec<StationServo>, f64)>,
}

pub fn map_program(command: MapProgramCommand) -> Result<PolarMachineProgram, ProgramFailure> {
    let MapProgramCommand {
        base,
        part_speed_rad_per_s,
        start_rad,
        c_words,
        sectors,
        segments,
    } = command;
    let approach = Approach {
        clearance_mm: base.clearance_mm,
        feed_mm_per_min: approach_feed(&base),
    };
    let machine = base.machine;
    let part = match &segments {
        Some(s) => PolarPart::Segments(&s.path),
        None => PolarPart::Round(&base.process.part().surface),
    };
    let program = PolarProgram::from_motion(
        part,
        &base.tool,
        base.schedule.motion(),
        base.schedule.dwell_s(),
        PolarRun {
            part_speed_rad_per_s,
            start_rad,
            approach,
            c_max_acceleration_deg_per_s2: machine.axis(Axis::C).max_acceleration_per_s2,
        },
    )
    .map_err(ProgramFailure::Plan)?;
    let spec = base.process.spec();
    let axes = [Axis::X, Axis::Z, Axis::B, Axis::C].map(|a| (a, program.motion(a)));
    let violations = base.choice.mark(machine.violations_of(
        &axes,
        |limit, index| program.block_of(limit, index),
        program.blocks().len(),
        (spec.workpiece_rpm, spec.tool_rpm),
    ));
    if !violations.is_empty() {
        return Err(ProgramFailure::Limits(violations));
    }
    let c = program.motion(Axis::C);
    let law = match sectors {
        Some(s) => format!("a speed law of {s} sectors per turn"),
        None => "the process's constant speed".to_string(),
    };
    let c_line = format!(
        "C: the part's spindle under position control at {law}, {:.3} turns, words {}",
        (c.max - c.min) / 360.0,
        match c_words {
            CWords::Wrapped => "wrapped to 0 to 360 deg, at most 90 deg a block",
            CWords::Unwound => "unwound (cumulative)",
        }
    );
    let header = header_lines(
        &base,
        program.polishing_time_s,
        program.program_time_s,
        &axes[..3],
        &[c_line],
    );
    let gcode = gcode::write_polar(&program, &header, spec.tool_rpm, &base.format, c_words);
    Ok(PolarMachineProgram {
        warnings: base.warnings,
        program,
        process: base.process,
        machine,
        c_words,
        gcode,
        segments: segments.map(|s| (s.servo, s.path.chord_tolerance_mm())),
    })
}
