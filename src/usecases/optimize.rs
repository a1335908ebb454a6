//! Optimization: the dwell plan whose removal matches a target over the clear aperture within
//! the constraints (see [`crate::optimize`] for the QP), with everything a caller reports
//! about it: removal, target and residual on the grid, the program's motion, metrics, the
//! recommendation.
//!
//! The plan moves as its machine program does ([`crate::physics::motion`]): the feed limit and
//! the machine's velocity and acceleration limits are constraints on the program's blocks, and
//! the motion reported is the program's own (without approach), on the request's machine or,
//! without one, on an unlimited machine carrying the tool as given.

use std::ops::Range;

use super::warnings::{active_constraints, unit_warnings, ACTIVE_USE, TARGET_MISS_FRACTION};
use super::{ComputeLimits, Input, InputError, OperatorCache, Recommender, Setting, Warning};
use crate::field::{DepthProfile, Field};
use crate::machine::{
    cell_travel, Approach, Axis, Drive, InvalidLimit, LimitKind, MachineChoice, MachineLimits,
    Program, ProgramError, Tool, Violation,
};
use crate::optimize::kinematics::{AxisPath, Floor};
use crate::optimize::problem::MAX_DEPTH_NM;
use crate::optimize::target::aperture_rows;
use crate::optimize::{
    measured_profile, optimize as solve, Constraints, ConstraintsSpec, DwellBasis, DwellProblem,
    MeasuredProfileError, Objective, OptimizeError, Solution,
};
use crate::physics::{check_positions, Motion, RowReading, UniformityMetrics};
use crate::study::Recommendation;
use crate::surface::{Surface, SurfaceError};

/// What to remove over the clear aperture.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// A uniform depth, nm, in [0, 1e9] (checked by [`Target::uniform`]).
    Uniform { depth_nm: f64 },
    /// A measured error profile, optionally with a free uniform layer p ≥ 0 on top.
    Profile { profile: Field, free_piston: bool },
}

/// The target as given: exactly one of a uniform depth and a measured profile.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TargetSpec {
    pub uniform_depth_nm: Option<f64>,
    pub profile: Option<DepthProfile>,
    /// With a profile: also remove the least uniform layer that fits best (default false).
    pub free_piston: Option<bool>,
}

impl Target {
    /// Exactly one target; a uniform depth in [0, 1e9] nm and no free piston with it.
    pub fn parse(spec: TargetSpec) -> Result<Self, InputError> {
        match (spec.uniform_depth_nm, spec.profile) {
            (Some(depth_nm), None) => {
                if !(0.0..=MAX_DEPTH_NM).contains(&depth_nm) {
                    return Err(InputError::OutOfRange {
                        input: Input::UniformDepth,
                        max: MAX_DEPTH_NM,
                    });
                }
                if spec.free_piston == Some(true) {
                    return Err(InputError::Inapplicable {
                        input: Input::FreePiston,
                        without: Input::TargetProfile,
                    });
                }
                Ok(Target::Uniform { depth_nm })
            }
            (None, Some(profile)) => Ok(Target::Profile {
                profile: measured_profile(profile.radius_mm, profile.depth_nm)
                    .map_err(OptimizeError::from)?,
                free_piston: spec.free_piston.unwrap_or(false),
            }),
            _ => Err(InputError::OneOf(Input::UniformDepth, Input::TargetProfile)),
        }
    }
}

/// An optimization as asked, besides its setting.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OptimizeSpec {
    /// Candidate tool positions, mm.
    pub positions_mm: Vec<f64>,
    pub target: TargetSpec,
    pub constraints: ConstraintsSpec,
    pub objective: Objective,
    /// The solver's budget, s; default and most: the limits' solver time.
    pub time_limit_s: Option<f64>,
    /// The machine the plan must run on (default: the default machine).
    pub machine: MachineChoice,
}

/// The machine a plan must run on: the surface and tool that give the axes' poses, and the
/// machine's limits (checked, [`MachineLimits::new`]); made only by the optimization's command.
#[derive(Debug, Clone, PartialEq)]
pub struct Machine {
    surface: Surface,
    tool: Tool,
    limits: MachineLimits,
}

/// Why a machine does not fit the optimization's positions (no dwell could fix it).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MachineFitError {
    /// A candidate position where the surface is not defined.
    #[error("position {index}: {error}")]
    PositionOffSurface { index: usize, error: SurfaceError },
    /// Poses outside an axis's travel or a spindle over its speed, whatever the dwell; the
    /// blocks are those of the program without approach.
    #[error("the positions or the process exceed {} machine limit(s) whatever the dwell", .0.len())]
    Limits(Vec<Violation>),
    /// A limit out of its domain.
    #[error(transparent)]
    InvalidLimit(InvalidLimit),
}

/// An optimization, checked: positions within reach and limits, the target resampled onto the
/// aperture's rows, constraints and weights in their domains, a time budget within the limit.
#[derive(Debug, Clone, PartialEq)]
pub struct OptimizeCommand {
    /// The machine the plan runs on: without [`Self::on_machine`], an unlimited one carrying
    /// the default tool over the setting's surface.
    machine: Machine,
    /// The machine as the request named it (default, unlimited or given): an unlimited one
    /// makes the plan warn that it is a study, and warnings and errors say which limits are
    /// the default machine's.
    choice: MachineChoice,
    setting: Setting,
    /// The plan's motion through the candidate positions (built once, here).
    motion: Motion,
    rows: Range<usize>,
    target_nm: Vec<f64>,
    free_piston: bool,
    constraints: Constraints,
    objective: Objective,
    time_limit_s: f64,
    /// The most `time_limit_s` may be here (the limits' solver time), for hints.
    max_time_limit_s: f64,
    /// Floors a caller adds to the dwell (a polar plan's C law), one per position or none.
    extra_floors: Vec<Floor>,
}

impl OptimizeCommand {
    /// What looks wrong in the input though it is valid (unit mistakes), for hints on
    /// solver failures as well as for the plan's warnings.
    pub fn input_warnings(&self) -> Vec<Warning> {
        let mut warnings = unit_warnings(self.setting.process(), self.motion.radii_mm());
        if self.choice.is_unlimited() {
            warnings.push(Warning::MachineUnlimited);
        }
        warnings
    }

    /// The most a request's solver time limit may be, s.
    pub fn max_time_limit_s(&self) -> f64 {
        self.max_time_limit_s
    }

    /// The plan's motion through the candidate positions.
    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// The same optimization with each position's dwell at least `floors` (one per position):
    /// what a polar plan's C law asks of the mean dwell.
    pub fn with_floors(self, floors: Vec<Floor>) -> Self {
        debug_assert_eq!(floors.len(), self.motion.len());
        OptimizeCommand {
            extra_floors: floors,
            ..self
        }
    }

    /// The command, every input checked: positions, target, constraints, weights, the time
    /// budget and, when the spec names a machine or the setting describes the part or the
    /// tool, the machine ([`Self::on_machine`]).
    pub fn new(
        setting: Setting,
        spec: OptimizeSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, InputError> {
        let OptimizeSpec {
            positions_mm,
            target,
            constraints,
            objective,
            time_limit_s,
            machine,
        } = spec;
        let target = Target::parse(target)?;
        let input = Input::Positions;
        limits
            .check_optimize_positions(positions_mm.len())
            .map_err(InputError::limit(input))?;
        limits
            .check_operator(setting.samples(), positions_mm.len())
            .map_err(InputError::limit(input))?;
        check_positions(setting.process(), "positions_mm", &positions_mm, true)
            .map_err(InputError::schedule(input))?;
        let constraints = Constraints::new(constraints)?;
        objective.validate()?;
        let max_s = limits.solver_time_limit.as_secs_f64();
        let time_limit_s = match time_limit_s {
            None => max_s,
            Some(t) if t.is_finite() && t > 0.0 && t <= max_s => t,
            Some(_) => {
                return Err(InputError::OutOfRange {
                    input: Input::SolverTimeLimit,
                    max: max_s,
                })
            }
        };
        let rows = aperture_rows(setting.grid(), setting.aperture());
        let (target_nm, free_piston) = match target {
            Target::Uniform { depth_nm } => (vec![depth_nm; rows.len()], false),
            Target::Profile {
                profile,
                free_piston,
            } => (
                profile
                    .resample(&setting.grid().radii_mm()[rows.clone()])
                    .map_err(|e| OptimizeError::from(MeasuredProfileError::from(e)))?,
                free_piston,
            ),
        };
        let command = OptimizeCommand {
            machine: Machine {
                surface: setting.process().part().surface.clone(),
                tool: Tool::default(),
                limits: MachineLimits::default(),
            },
            choice: machine,
            setting,
            motion: Motion::radial(positions_mm),
            rows,
            target_nm,
            free_piston,
            constraints,
            objective,
            time_limit_s,
            max_time_limit_s: max_s,
            extra_floors: Vec::new(),
        };
        Ok(command.on_machine(machine)?)
    }

    /// The machine the plan must run on: the positions are checked against the poses, and
    /// the limits in force bind the plan. Only an unlimited machine on an undescribed part
    /// and tool leaves the plan the motion alone.
    fn on_machine(self, choice: MachineChoice) -> Result<Self, MachineFitError> {
        let mount = self.setting.mount();
        if choice.is_unlimited() && !mount.described {
            return Ok(self);
        }
        let limits = choice.limits().map_err(MachineFitError::InvalidLimit)?;
        let machine = Machine {
            surface: mount.part.surface.clone(),
            tool: mount.tool,
            limits,
        };
        self.with_machine(machine)
    }

    /// The plan must also run on `machine`: its axis velocity and acceleration limits become
    /// constraints on the dwell ([`crate::optimize::kinematics`]). Refused when the positions
    /// leave the surface, or put an axis outside its travel or a spindle over its speed (which
    /// no dwell can change).
    fn with_machine(mut self, machine: Machine) -> Result<Self, MachineFitError> {
        let motion = &self.motion;
        let last = motion.len() - 1;
        machine
            .surface
            .check_defined_to(motion.radii_mm()[last])
            .map_err(|error| MachineFitError::PositionOffSurface { index: last, error })?;
        // Travel and spindle speed do not depend on the dwell: check them on unit dwell.
        let program = Program::from_motion(
            &machine.surface,
            &machine.tool,
            motion,
            &vec![1.0; motion.len()],
            NO_APPROACH,
        )
        .expect("positive dwell everywhere gives a program");
        let spec = self.setting.process().spec();
        let fixed: Vec<Violation> = machine
            .limits
            .violations(&program, (spec.workpiece_rpm, spec.tool_rpm))
            .into_iter()
            .filter(|v| matches!(v.limit, LimitKind::Min | LimitKind::Max | LimitKind::MaxRpm))
            .collect();
        if !fixed.is_empty() {
            return Err(MachineFitError::Limits(self.choice.mark(fixed)));
        }
        self.machine = machine;
        Ok(self)
    }
}

/// The optimizer's plan is the polishing motion alone; the program adds its approach.
const NO_APPROACH: Approach = Approach {
    clearance_mm: 0.0,
    feed_mm_per_min: 1.0,
};

/// The machine's axes as `motion` drives them.
fn axis_paths(machine: &Machine, motion: &Motion) -> Vec<AxisPath> {
    let travel = cell_travel(&machine.surface, &machine.tool, motion);
    Axis::ALL
        .iter()
        .zip(travel)
        .map(|(&axis, cell_travel)| {
            let limits = machine.limits.axis(axis);
            AxisPath {
                axis,
                cell_travel,
                max_velocity_per_s: limits.max_velocity_per_min.map(|v| v / 60.0),
                max_acceleration_per_s2: limits.max_acceleration_per_s2,
            }
        })
        .collect()
}

/// The length of the tool's X–Z path across each position's cell, mm.
fn cell_path_mm(axes: &[AxisPath]) -> Vec<f64> {
    let travel = |axis| {
        axes.iter()
            .find(|a| a.axis == axis)
            .map_or(&[][..], |a| &a.cell_travel[..])
    };
    travel(Axis::X)
        .iter()
        .zip(travel(Axis::Z))
        .map(|(x, z)| x.hypot(*z))
        .collect()
}

/// The plan's polishing motion as its machine program runs it (no approach): `None` when it
/// has none (no dwell at all, or an interior zero dwell, which also gives a warning).
fn program_of(
    machine: &Machine,
    motion: &Motion,
    dwell_s: &[f64],
    warnings: &mut Vec<Warning>,
) -> Option<Program> {
    match Program::from_motion(
        &machine.surface,
        &machine.tool,
        motion,
        dwell_s,
        NO_APPROACH,
    ) {
        Ok(program) => Some(program),
        Err(ProgramError::ZeroInteriorDwell { index }) => {
            warnings.push(Warning::NotProgrammable { index });
            None
        }
        Err(ProgramError::NoDwell) => None,
    }
}

/// The machine limits the program sits on, checked: a program that breaks a limit is a defect
/// of the optimizer, never returned.
fn machine_warnings(
    machine: &Machine,
    choice: MachineChoice,
    process: &crate::physics::Process,
    program: &Program,
) -> Result<Vec<Warning>, OptimizeError> {
    let mut warnings = Vec::new();
    let spec = process.spec();
    let broken = machine
        .limits
        .violations(program, (spec.workpiece_rpm, spec.tool_rpm));
    if let Some(v) = broken.first() {
        return Err(OptimizeError::Numerical {
            status: format!(
                "the plan's program would exceed {} ({} > {})",
                v.limit.describe(v.drive),
                v.value,
                v.limit_value
            ),
        });
    }
    // Which limits the plan sits on: used at 99.9 % or more (the optimizer keeps 1e-6 below).
    for axis in Axis::ALL {
        let motion = program.motion(axis);
        let limits = machine.limits.axis(axis);
        let drive = Drive::from(axis);
        let near = |peak: f64, limit: Option<f64>| limit.is_some_and(|l| peak >= l * ACTIVE_USE);
        if near(motion.peak_velocity_per_min, limits.max_velocity_per_min) {
            warnings.push(Warning::MachineLimitActive {
                drive,
                limit: LimitKind::MaxVelocity,
                default_machine: choice.is_default(drive, LimitKind::MaxVelocity),
            });
        }
        if near(
            motion.peak_acceleration_per_s2,
            limits.max_acceleration_per_s2,
        ) {
            warnings.push(Warning::MachineLimitActive {
                drive,
                limit: LimitKind::MaxAcceleration,
                default_machine: choice.is_default(drive, LimitKind::MaxAcceleration),
            });
        }
    }
    Ok(warnings)
}

/// An optimized plan and what it does.
#[derive(Debug, Clone, PartialEq)]
pub struct OptimizedPlan {
    pub setting: Setting,
    /// The plan's motion (its stations: the candidate positions).
    pub motion: Motion,
    /// Dwell, piston, solver account and objective value.
    pub solution: Solution,
    /// The weights used.
    pub objective: Objective,
    pub total_time_s: f64,
    /// The plan's polishing motion as the program runs it (no approach); `None` when it has
    /// none (every dwell zero, or an interior zero dwell).
    pub program: Option<Program>,
    /// The limits of the machine it runs on (all absent without one).
    pub machine_limits: MachineLimits,
    /// Removal at each grid radius, nm.
    pub removal_nm: Vec<f64>,
    /// Target (with the piston) at each grid radius; `None` outside the aperture.
    pub target_nm: Vec<Option<f64>>,
    /// removal − target at each grid radius; `None` outside the aperture.
    pub residual_nm: Vec<Option<f64>>,
    /// max − min of the residual over the aperture, nm.
    pub residual_pv_nm: f64,
    /// √(mean of residual²) over the aperture, nm (an offset counts).
    pub residual_rms_nm: f64,
    /// Uniformity of the removal over the aperture.
    pub metrics: UniformityMetrics,
    /// η = −1 settings for the target's mean depth; `None` at η = −1.
    pub recommendation: Option<Recommendation>,
    /// Binding constraints, a missed target, a likely unit mistake.
    pub warnings: Vec<Warning>,
}

impl OptimizedPlan {
    /// The path feed across each position's cell as the program runs it, mm/min; `None` for
    /// a position without a move (a skipped end, or no program at all).
    pub fn cell_feeds_mm_per_min(&self) -> Vec<Option<f64>> {
        self.program.as_ref().map_or_else(
            || vec![None; self.solution.dwell_s.len()],
            Program::cell_feeds_mm_per_min,
        )
    }
}

/// Solves the plan. Fails only when the constraints conflict or the solver finds no plan.
pub fn optimize(
    command: OptimizeCommand,
    recommender: &Recommender,
    operators: &OperatorCache,
) -> Result<OptimizedPlan, OptimizeError> {
    let mut warnings = command.input_warnings();
    let OptimizeCommand {
        machine,
        setting,
        motion,
        rows,
        target_nm,
        free_piston,
        constraints,
        objective,
        time_limit_s,
        max_time_limit_s: _,
        choice,
        extra_floors,
    } = command;
    // The recommendation's pass at these speeds is read beside a newly assembled operator.
    let pass = Recommender::pass_to_read(&setting);
    let axes = axis_paths(&machine, &motion);
    let cell_path_mm = cell_path_mm(&axes);
    // The solver reads the aperture's rows alone; a new operator's others are assembled
    // while it runs.
    let (operator, passed, solution) = operators.operator_while(
        setting.process(),
        setting.grid().radii_mm(),
        &motion,
        pass.as_ref().map(|p| p as &dyn RowReading),
        rows.clone(),
        |operator, rows| {
            solve(&DwellProblem {
                operator,
                motion: &motion,
                tool_radius_mm: setting.process().tool_radius_mm(),
                rows,
                target_nm: &target_nm,
                free_piston,
                constraints,
                objective,
                time_limit_s,
                basis: DwellBasis::default(),
                axes: &axes,
                cell_path_mm: &cell_path_mm,
                extra_floors: &extra_floors,
            })
        },
    );
    let solution = solution?;
    let program = program_of(&machine, &motion, &solution.dwell_s, &mut warnings);
    if let Some(program) = &program {
        warnings.extend(machine_warnings(
            &machine,
            choice,
            setting.process(),
            program,
        )?);
    }

    let removal_nm = operator.apply(&solution.dwell_s);
    let piston = solution.piston_nm.unwrap_or(0.0);
    let mut full_target = vec![None; removal_nm.len()];
    let mut residual = vec![None; removal_nm.len()];
    for (k, i) in rows.enumerate() {
        let t = target_nm[k] + piston;
        full_target[i] = Some(t);
        residual[i] = Some(removal_nm[i] - t);
    }
    let inside: Vec<f64> = residual.iter().flatten().copied().collect();
    let (lo, hi) = inside
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let rms = (inside.iter().map(|v| v * v).sum::<f64>() / inside.len() as f64).sqrt();
    let metrics = UniformityMetrics::over(setting.grid(), setting.aperture(), &removal_nm);
    let mean_target = target_nm.iter().sum::<f64>() / target_nm.len() as f64 + piston;
    let peak_feed_mm_per_min = program.as_ref().map(Program::peak_feed_mm_per_min);
    warnings.extend(active_constraints(
        &constraints,
        &solution.dwell_s,
        peak_feed_mm_per_min,
    ));
    let target_rms_nm = (target_nm.iter().map(|d| (d + piston).powi(2)).sum::<f64>()
        / target_nm.len() as f64)
        .sqrt();
    if rms > TARGET_MISS_FRACTION * target_rms_nm {
        warnings.push(Warning::TargetNotMet {
            residual_rms_nm: rms,
            target_rms_nm,
        });
    }
    Ok(OptimizedPlan {
        warnings,
        recommendation: recommender.for_plan(&setting, mean_target, passed, &machine.limits),
        total_time_s: solution.dwell_s.iter().sum(),
        setting,
        motion,
        objective,
        program,
        machine_limits: machine.limits,
        removal_nm,
        target_nm: full_target,
        residual_nm: residual,
        residual_pv_nm: hi - lo,
        residual_rms_nm: rms,
        metrics,
        solution,
    })
}
