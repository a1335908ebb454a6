//! A machine's limits (per axis: travel, velocity, acceleration; per spindle: speed), their
//! validation, and the check of a program against them.

use super::program::{AxisMotion, Program};

/// Whether an axis moves along a line (positions in mm) or turns (positions in deg).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisKind {
    Linear,
    Rotary,
}

/// A moving axis of the machine, by name; what kind it is is its property, never its place in
/// an array.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// The radial axis (on an X-Y machine, right on the part's map).
    X,
    /// An X-Y machine's second table axis (up on the part's map); the paper's machine has none.
    Y,
    /// The axial axis (positive toward the tool).
    Z,
    /// The tool's tilt in the meridian plane.
    B,
    /// The part's spindle under position control (deg, counter-clockwise seen from the pad):
    /// a program drives it only under a C speed law; otherwise it turns at the process's
    /// speed, a spindle held by `workpiece_spindle`'s limit.
    C,
}

impl Axis {
    /// Every axis a program drives, in the order reports list them.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Z, Axis::B];

    pub fn kind(self) -> AxisKind {
        match self {
            Axis::X | Axis::Y | Axis::Z => AxisKind::Linear,
            Axis::B | Axis::C => AxisKind::Rotary,
        }
    }

    /// Its name (snake case, as limits and reports name it).
    pub fn name(self) -> &'static str {
        match self {
            Axis::X => "x",
            Axis::Y => "y",
            Axis::Z => "z",
            Axis::B => "b",
            Axis::C => "c",
        }
    }

    /// Unit of its positions: mm for a linear axis, deg for a rotary one.
    pub fn unit(self) -> &'static str {
        match self.kind() {
            AxisKind::Linear => "mm",
            AxisKind::Rotary => "deg",
        }
    }
}

/// An axis or a spindle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    Axis(Axis),
    WorkpieceSpindle,
    ToolSpindle,
}

impl From<Axis> for Drive {
    fn from(axis: Axis) -> Drive {
        Drive::Axis(axis)
    }
}

impl Drive {
    /// Its name (snake case, as limits and reports name it).
    pub fn name(self) -> &'static str {
        match self {
            Drive::Axis(axis) => axis.name(),
            Drive::WorkpieceSpindle => "workpiece_spindle",
            Drive::ToolSpindle => "tool_spindle",
        }
    }

    /// Unit of its positions (an axis's) or speeds (a spindle's, r/min).
    pub fn unit(self) -> &'static str {
        match self {
            Drive::Axis(axis) => axis.unit(),
            Drive::WorkpieceSpindle | Drive::ToolSpindle => "rpm",
        }
    }
}

/// A kind of limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitKind {
    Min,
    Max,
    MaxVelocity,
    MaxAcceleration,
    MaxRpm,
}

impl LimitKind {
    /// The limit's name on `drive` (units in the name).
    pub fn name(self, drive: Drive) -> &'static str {
        let rotary = matches!(drive, Drive::Axis(axis) if axis.kind() == AxisKind::Rotary);
        match (self, rotary) {
            (LimitKind::Min, false) => "min_mm",
            (LimitKind::Min, true) => "min_deg",
            (LimitKind::Max, false) => "max_mm",
            (LimitKind::Max, true) => "max_deg",
            (LimitKind::MaxVelocity, false) => "max_velocity_mm_per_min",
            (LimitKind::MaxVelocity, true) => "max_velocity_deg_per_min",
            (LimitKind::MaxAcceleration, false) => "max_acceleration_mm_per_s2",
            (LimitKind::MaxAcceleration, true) => "max_acceleration_deg_per_s2",
            (LimitKind::MaxRpm, _) => "max_rpm",
        }
    }
}

impl LimitKind {
    /// The limit in words, for messages: `the x axis's max_velocity_mm_per_min`.
    pub fn describe(self, drive: Drive) -> String {
        let what = match drive {
            Drive::Axis(_) => "axis",
            Drive::WorkpieceSpindle | Drive::ToolSpindle => "drive",
        };
        format!("the {} {what}'s {}", drive.name(), self.name(drive))
    }
}

/// One axis's limits; `None` = unlimited. Velocities per minute, accelerations per s², in the
/// axis's unit (mm or deg).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AxisLimits {
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub max_velocity_per_min: Option<f64>,
    pub max_acceleration_per_s2: Option<f64>,
}

/// Every limit of the machine as a caller gives them; `None` = unlimited. Unchecked: see
/// [`MachineLimits::new`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MachineLimitsSpec {
    pub x: AxisLimits,
    /// An X-Y machine's Y.
    pub y: AxisLimits,
    pub z: AxisLimits,
    pub b: AxisLimits,
    /// C under position control: its velocity and acceleration (travel does not apply).
    pub c: AxisLimits,
    pub workpiece_max_rpm: Option<f64>,
    pub tool_max_rpm: Option<f64>,
}

/// The default machine: what a plan or program is held to when the request names no machine
/// (docs/MACHINE.md, "The default machine", says where each figure comes from). Linear axes
/// 10 m/min and 2 m/s² (a servo axis of a CNC polishing or diamond-turning machine: the
/// slow-tool-servo literature sizes X at 2,000 mm/s²); B moves the pad at the same speeds on
/// a 60 mm pivot (10 m/min / 60 mm ≈ 9,500 deg/min, 2 m/s² / 60 mm ≈ 1,900 deg/s²), rounded
/// down; spindles as a small-tool polisher's (workpiece 1,000 r/min, tool 3,000 r/min). No
/// travel: that depends on the machine's size, and no dwell changes it.
pub const DEFAULT_MACHINE: MachineLimitsSpec = MachineLimitsSpec {
    x: AxisLimits {
        min: None,
        max: None,
        max_velocity_per_min: Some(10_000.0),
        max_acceleration_per_s2: Some(2_000.0),
    },
    y: AxisLimits {
        min: None,
        max: None,
        max_velocity_per_min: Some(10_000.0),
        max_acceleration_per_s2: Some(2_000.0),
    },
    z: AxisLimits {
        min: None,
        max: None,
        max_velocity_per_min: Some(10_000.0),
        max_acceleration_per_s2: Some(2_000.0),
    },
    b: AxisLimits {
        min: None,
        max: None,
        max_velocity_per_min: Some(9_000.0),
        max_acceleration_per_s2: Some(1_800.0),
    },
    // C as the work spindle under position control: its speed the spindle's (1,000 r/min),
    // 10 r/s² of acceleration.
    c: AxisLimits {
        min: None,
        max: None,
        max_velocity_per_min: Some(360_000.0),
        max_acceleration_per_s2: Some(3_600.0),
    },
    workpiece_max_rpm: Some(1_000.0),
    tool_max_rpm: Some(3_000.0),
};

/// Which machine a plan or program is for.
// One per request, copied a few times: 224 bytes is nothing beside a plan, and `Copy` keeps
// the commands simple.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum MachineChoice {
    /// None named: [`DEFAULT_MACHINE`].
    #[default]
    Default,
    /// No limits at all: a study, not a program for any machine.
    Unlimited,
    /// The limits given; a limit left out is the default machine's.
    Given(MachineLimitsSpec),
}

impl AxisLimits {
    /// Each limit of `self`, or where absent, `default`'s.
    fn or(self, default: AxisLimits) -> AxisLimits {
        AxisLimits {
            min: self.min.or(default.min),
            max: self.max.or(default.max),
            max_velocity_per_min: self.max_velocity_per_min.or(default.max_velocity_per_min),
            max_acceleration_per_s2: self
                .max_acceleration_per_s2
                .or(default.max_acceleration_per_s2),
        }
    }
}

impl MachineChoice {
    /// The limits in force: the default machine's, none, or those given over the default's.
    pub fn spec(self) -> MachineLimitsSpec {
        match self {
            MachineChoice::Default => DEFAULT_MACHINE,
            MachineChoice::Unlimited => MachineLimitsSpec::default(),
            MachineChoice::Given(given) => MachineLimitsSpec {
                x: given.x.or(DEFAULT_MACHINE.x),
                y: given.y.or(DEFAULT_MACHINE.y),
                z: given.z.or(DEFAULT_MACHINE.z),
                b: given.b.or(DEFAULT_MACHINE.b),
                c: given.c.or(DEFAULT_MACHINE.c),
                workpiece_max_rpm: given
                    .workpiece_max_rpm
                    .or(DEFAULT_MACHINE.workpiece_max_rpm),
                tool_max_rpm: given.tool_max_rpm.or(DEFAULT_MACHINE.tool_max_rpm),
            },
        }
    }

    /// The limits in force, checked.
    pub fn limits(self) -> Result<MachineLimits, InvalidLimit> {
        MachineLimits::new(self.spec())
    }

    pub fn is_unlimited(self) -> bool {
        self == MachineChoice::Unlimited
    }

    /// Whether `limit` of `drive` in force is the default machine's (not given by the caller).
    pub fn is_default(self, drive: Drive, limit: LimitKind) -> bool {
        match self {
            MachineChoice::Default => true,
            MachineChoice::Unlimited => false,
            MachineChoice::Given(given) => {
                let axis = |a: &AxisLimits| match limit {
                    LimitKind::Min => a.min,
                    LimitKind::Max => a.max,
                    LimitKind::MaxVelocity => a.max_velocity_per_min,
                    LimitKind::MaxAcceleration => a.max_acceleration_per_s2,
                    LimitKind::MaxRpm => None,
                };
                let stated = match drive {
                    Drive::Axis(Axis::X) => axis(&given.x),
                    Drive::Axis(Axis::Y) => axis(&given.y),
                    Drive::Axis(Axis::Z) => axis(&given.z),
                    Drive::Axis(Axis::B) => axis(&given.b),
                    Drive::Axis(Axis::C) => axis(&given.c),
                    Drive::WorkpieceSpindle => given.workpiece_max_rpm,
                    Drive::ToolSpindle => given.tool_max_rpm,
                };
                stated.is_none()
            }
        }
    }

    /// `violations` with each marked when the limit it breaks is the default machine's.
    pub fn mark(self, mut violations: Vec<Violation>) -> Vec<Violation> {
        for v in &mut violations {
            v.default_machine = self.is_default(v.drive, v.limit);
        }
        violations
    }
}

/// Every limit of the machine, checked ([`MachineLimits::new`] is the only way to make one;
/// the default has none).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MachineLimits {
    x: AxisLimits,
    y: AxisLimits,
    z: AxisLimits,
    b: AxisLimits,
    c: AxisLimits,
    workpiece_max_rpm: Option<f64>,
    tool_max_rpm: Option<f64>,
}

/// A limit out of its domain.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct InvalidLimit {
    pub drive: Drive,
    pub limit: LimitKind,
    pub message: String,
}

impl MachineLimits {
    /// The limits of `spec`: every value finite, velocities, accelerations and speeds
    /// positive, min below max.
    pub fn new(spec: MachineLimitsSpec) -> Result<MachineLimits, InvalidLimit> {
        let limits = MachineLimits {
            x: spec.x,
            y: spec.y,
            z: spec.z,
            b: spec.b,
            c: spec.c,
            workpiece_max_rpm: spec.workpiece_max_rpm,
            tool_max_rpm: spec.tool_max_rpm,
        };
        limits.check()?;
        Ok(limits)
    }

    /// The workpiece's and the tool's spindle speed limits, r/min (`None`: none).
    pub fn spindle_max_rpm(&self) -> (Option<f64>, Option<f64>) {
        (self.workpiece_max_rpm, self.tool_max_rpm)
    }

    /// The limits of `axis`.
    pub fn axis(&self, axis: Axis) -> &AxisLimits {
        match axis {
            Axis::X => &self.x,
            Axis::Y => &self.y,
            Axis::Z => &self.z,
            Axis::B => &self.b,
            Axis::C => &self.c,
        }
    }

    fn check(&self) -> Result<(), InvalidLimit> {
        let error = |drive, limit, message: &str| InvalidLimit {
            drive,
            limit,
            message: format!("{} {message}", LimitKind::name(limit, drive)),
        };
        for axis in Axis::ALL.into_iter().chain([Axis::Y, Axis::C]) {
            let a = self.axis(axis);
            let drive = Drive::from(axis);
            for (value, limit) in [(a.min, LimitKind::Min), (a.max, LimitKind::Max)] {
                if value.is_some_and(|v| !v.is_finite()) {
                    return Err(error(drive, limit, "must be a finite number"));
                }
            }
            if let (Some(lo), Some(hi)) = (a.min, a.max) {
                if hi <= lo {
                    return Err(error(
                        drive,
                        LimitKind::Max,
                        "must be greater than the minimum",
                    ));
                }
            }
            for (value, limit) in [
                (a.max_velocity_per_min, LimitKind::MaxVelocity),
                (a.max_acceleration_per_s2, LimitKind::MaxAcceleration),
            ] {
                if value.is_some_and(|v| !(v.is_finite() && v > 0.0)) {
                    return Err(error(drive, limit, "must be a positive finite number"));
                }
            }
        }
        for (value, drive) in [
            (self.workpiece_max_rpm, Drive::WorkpieceSpindle),
            (self.tool_max_rpm, Drive::ToolSpindle),
        ] {
            if value.is_some_and(|v| !(v.is_finite() && v > 0.0)) {
                return Err(error(
                    drive,
                    LimitKind::MaxRpm,
                    "must be a positive finite number",
                ));
            }
        }
        Ok(())
    }
}

/// A limit the program would break: the worst value, the first block that breaks it and how
/// many do.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    pub drive: Drive,
    pub limit: LimitKind,
    pub limit_value: f64,
    /// The worst value (a position, |velocity| per minute, |acceleration| per s², |speed|).
    pub value: f64,
    /// The first block breaking it; `None` for a spindle speed (the whole program).
    pub first_block: Option<usize>,
    pub blocks: usize,
    /// The limit is the default machine's, not one the caller gave ([`MachineChoice::mark`]).
    pub default_machine: bool,
}

impl MachineLimits {
    /// Every limit the program breaks with these spindle speeds (r/min, signed), one entry
    /// per (drive, limit). Empty means the program is within every stated limit.
    pub fn violations(&self, program: &Program, spindle_rpm: (f64, f64)) -> Vec<Violation> {
        let axes = Axis::ALL.map(|axis| (axis, program.motion(axis)));
        self.violations_of(
            &axes,
            |limit, index| program.block_of(limit, index),
            program.blocks().len(),
            spindle_rpm,
        )
    }

    /// Every limit broken by the `axes`' motions over a program of `blocks` blocks
    /// (`block_of` says which block an entry of a motion's lists belongs to) with these
    /// spindle speeds, one entry per (drive, limit).
    pub fn violations_of(
        &self,
        axes: &[(Axis, &AxisMotion)],
        block_of: impl Fn(LimitKind, usize) -> usize,
        blocks: usize,
        spindle_rpm: (f64, f64),
    ) -> Vec<Violation> {
        let mut found = Vec::new();
        for &(axis, motion) in axes {
            let limits = self.axis(axis);
            let drive = Drive::from(axis);
            // (limit, values, compared as magnitudes, an upper bound)
            let checks = [
                (limits.min, LimitKind::Min, &motion.positions, false, false),
                (limits.max, LimitKind::Max, &motion.positions, false, true),
                (
                    limits.max_velocity_per_min,
                    LimitKind::MaxVelocity,
                    &motion.velocity_per_min,
                    true,
                    true,
                ),
                (
                    limits.max_acceleration_per_s2,
                    LimitKind::MaxAcceleration,
                    &motion.acceleration_per_s2,
                    true,
                    true,
                ),
            ];
            for (limit_value, limit, values, magnitude, upper) in checks {
                let Some(limit_value) = limit_value else {
                    continue;
                };
                let breaks = |v: f64| {
                    if upper {
                        v > limit_value
                    } else {
                        v < limit_value
                    }
                };
                let bad: Vec<(usize, f64)> = values
                    .iter()
                    .map(|&v| if magnitude { v.abs() } else { v })
                    .enumerate()
                    .filter(|&(_, v)| breaks(v))
                    .collect();
                if let Some(&(first, _)) = bad.first() {
                    let worst = bad.iter().map(|&(_, v)| v);
                    let value = if upper {
                        worst.fold(f64::NEG_INFINITY, f64::max)
                    } else {
                        worst.fold(f64::INFINITY, f64::min)
                    };
                    found.push(Violation {
                        drive,
                        limit,
                        limit_value,
                        value,
                        first_block: Some(block_of(limit, first)),
                        blocks: bad.len(),
                        default_machine: false,
                    });
                }
            }
        }
        for (max, rpm, drive) in [
            (
                self.workpiece_max_rpm,
                spindle_rpm.0,
                Drive::WorkpieceSpindle,
            ),
            (self.tool_max_rpm, spindle_rpm.1, Drive::ToolSpindle),
        ] {
            if let Some(max) = max.filter(|&m| rpm.abs() > m) {
                found.push(Violation {
                    drive,
                    limit: LimitKind::MaxRpm,
                    limit_value: max,
                    value: rpm.abs(),
                    first_block: None,
                    blocks,
                    default_machine: false,
                });
            }
        }
        found
    }
}
