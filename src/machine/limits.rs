//! A machine's limits (per axis: travel, velocity, acceleration; per spindle: speed), their
//! validation, and the check of a program against them.

use super::program::Program;

/// An axis or a spindle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    X,
    Z,
    B,
    WorkpieceSpindle,
    ToolSpindle,
}

impl Drive {
    pub const AXES: [Drive; 3] = [Drive::X, Drive::Z, Drive::B];

    /// Its name (snake case, as limits and reports name it).
    pub fn name(self) -> &'static str {
        match self {
            Drive::X => "x",
            Drive::Z => "z",
            Drive::B => "b",
            Drive::WorkpieceSpindle => "workpiece_spindle",
            Drive::ToolSpindle => "tool_spindle",
        }
    }

    /// Unit of its positions: mm for X and Z, deg for B.
    pub fn unit(self) -> &'static str {
        match self {
            Drive::B => "deg",
            Drive::X | Drive::Z => "mm",
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
        let rotary = drive == Drive::B;
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
            Drive::X | Drive::Z | Drive::B => "axis",
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
    pub z: AxisLimits,
    pub b: AxisLimits,
    pub workpiece_max_rpm: Option<f64>,
    pub tool_max_rpm: Option<f64>,
}

/// Every limit of the machine, checked ([`MachineLimits::new`] is the only way to make one;
/// the default has none).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MachineLimits {
    x: AxisLimits,
    z: AxisLimits,
    b: AxisLimits,
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
            z: spec.z,
            b: spec.b,
            workpiece_max_rpm: spec.workpiece_max_rpm,
            tool_max_rpm: spec.tool_max_rpm,
        };
        limits.check()?;
        Ok(limits)
    }

    /// The limits of axis `drive` (X, Z or B).
    pub fn axis(&self, drive: Drive) -> &AxisLimits {
        match drive {
            Drive::X => &self.x,
            Drive::Z => &self.z,
            _ => &self.b,
        }
    }

    fn check(&self) -> Result<(), InvalidLimit> {
        let error = |drive, limit, message: &str| InvalidLimit {
            drive,
            limit,
            message: format!("{} {message}", LimitKind::name(limit, drive)),
        };
        for drive in Drive::AXES {
            let a = self.axis(drive);
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
}

impl MachineLimits {
    /// Every limit the program breaks with these spindle speeds (r/min, signed), one entry
    /// per (drive, limit). Empty means the program is within every stated limit.
    pub fn violations(&self, program: &Program, spindle_rpm: (f64, f64)) -> Vec<Violation> {
        let mut found = Vec::new();
        for drive in Drive::AXES {
            let limits = self.axis(drive);
            let motion = program.motion(drive);
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
                        first_block: Some(program.block_of(limit, first)),
                        blocks: bad.len(),
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
                    blocks: program.blocks().len(),
                });
            }
        }
        found
    }
}
