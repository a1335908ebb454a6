//! The numerical core of Preston: dual-rotor kinematics, the removal function, the removal
//! operator, dwell schedules and uniformity metrics. Pure: no I/O, no HTTP, JSON or OpenAPI
//! types. Lengths in mm, speeds in r/min at the boundary (rad/s inside), time in s, depths in nm.

pub mod carlson;
pub mod contact;
pub mod convolution;
pub mod curved;
pub mod grid;
pub mod influence;
pub mod kronrod;
pub mod metrics;
pub mod motion;
pub mod operator;
pub mod path;
pub mod polar;
pub mod pressure;
pub mod process;
pub mod raster;
pub mod removal;
pub mod roots;
pub mod schedule;
pub mod segment_pad;
pub mod sliding_log;

pub use curved::{Orientation, Part};
pub use grid::{check_radius, ClearAperture, GridError, RadialGrid, Reach};
pub use metrics::UniformityMetrics;
pub use motion::{Motion, SectorLaw, SectorLawError, Segment, Turning};
pub use operator::{Layout, RemovalOperator, RowReading};
pub use pressure::{PressureModel, PressureModelKind};
pub use process::{Eta, Process, ProcessError, ProcessSpec};
pub use removal::{removal_rate_nm_per_min, RemovalKernel, RunningIntegral};
pub use schedule::{check_positions, ConstantFeed, DwellSchedule, PassReading, ScheduleError};
