//! Machine programs: a dwell plan as the motion of a polishing machine's axes, checked against
//! the machine's limits, and written as G-code.
//!
//! **Axes.** X moves the tool across the spindle axis, Z along it (positive toward the tool),
//! B tilts the tool spindle in the meridian plane; the workpiece and tool spindles turn at the
//! process's signed speeds. Under a C speed law the workpiece spindle is C, an axis of the
//! program ([`polar_program`]). Coordinates are in the design frame: the surface vertex at X = 0,
//! Z = 0 (a work offset maps them to the machine).
//!
//! **Pose** (the tool-radius compensation along the normal of the turning literature, applied
//! to the pad): a pad centred on the surface point at radius r, with slope angle
//! θ = atan z′(r) and unit normal n = (−sin θ, cos θ) toward the tool, has its B pivot L along
//! n from the pad face centre:
//!
//! ```text
//! normal:    X = r − L·sin θ,   Z = z(r) + L·cos θ,   B = θ (degrees)
//! vertical:  X = r,             Z = z(r) + L,         B = 0
//! ```
//!
//! Offsetting along Z alone would put the pad beside the point on a slope; along the normal it
//! touches the surface at r with its axis on the normal.
//!
//! **Motion model**: that of [`crate::physics::motion`] (docs/MODEL.md): blocks dwell t_0/2 at
//! r_0; r_0 → m_0 in t_0/2; m_{j−1} → m_j in t_j (0 < j < n−1); m_{n−2} → r_{n−1} in
//! t_{n−1}/2; dwell t_{n−1}/2, with m_j the midpoints. The blocks' times sum to Σ t_j exactly.
//! Each move is linear in X, Z and B over its duration (G1), so every axis moves at a constant
//! velocity v = ΔA/d within a block; the removal every endpoint reports is that of this motion.
//!
//! **Axis velocity and acceleration** (per axis, including Z and B on curved parts): the
//! velocity is piecewise constant, v_k = ΔA_k / d_k in block k (0 in a dwell), and changes
//! between blocks k and k+1 over the time between their midpoints, so
//! a_k = (v_{k+1} − v_k) / ((d_k + d_{k+1})/2). On a flat part with a vertical tool this is
//! the optimizer's feed and feed-acceleration model.
//!
//! **Limits** are those a servo axis is sized by (stroke, velocity, acceleration): every pose
//! within [min, max] (a stroke L is min = p₀, max = p₀ + L), |v_k| ≤ v_max, |a_k| ≤ a_max, and
//! each spindle's |speed| ≤ its maximum. A sinusoidal axis motion A·sin(2πft) meets them iff
//! A ≤ min{L/2, v_max/(2πf), a_max/(4π²f²)}; a program's blocks are checked directly instead.

pub mod gcode;
pub mod limits;
pub mod polar_program;
pub mod pose;
pub mod program;
pub mod servo;
pub mod xy_program;

pub use gcode::{
    CWords, FeedMode, GcodeFormat, GcodeFormatError, GcodeFormatSpec, SpindleWords,
    SpindleWordsSpec,
};
pub use limits::{
    Axis, AxisKind, AxisLimits, Drive, InvalidLimit, LimitKind, MachineChoice, MachineLimits,
    MachineLimitsSpec, Violation, DEFAULT_MACHINE,
};
pub use polar_program::{PolarBlock, PolarPart, PolarProgram, PolarRun, SegmentPath};
pub use pose::{Orientation, Pose, Tool, ToolError};
pub use program::{
    cell_travel, Approach, AxisMotion, Block, BlockKind, Program, ProgramError, Skipped,
    Utilisation,
};
pub use xy_program::{XyBlock, XyProgram};
