//! The use cases: one function per question a caller can ask — the removal function, a
//! prediction, an optimized plan, a recommendation, an η sweep, a measurement fit. Pure like the rest of the core:
//! no HTTP, JSON or OpenAPI types.
//!
//! Every use case comes in two steps:
//!
//! 1. **A command**, built through its constructor from plain values (`Option`s for inputs that
//!    have defaults). The constructor fills in the defaults, checks every input and every size
//!    limit, and is cheap (no removal function is evaluated), so a caller can refuse bad input
//!    before it queues for a computation slot. A command that exists is valid: parse, don't
//!    validate.
//! 2. **The computation**, a function taking the command and returning a typed result that holds
//!    everything a response needs (removal, metrics, residual figures, motion figures, the
//!    recommendation). It fails only for reasons found by computing (equal dwell removing
//!    nothing, a solver stopping), never for bad input.
//!
//! Errors say which input is wrong in typed terms ([`Input`], and the physics, optimizer and
//! study error enums); callers map them onto their own field names.

pub mod calibration;
pub mod eta_sweep;
mod limits;
pub mod map_analysis;
pub mod map_difference;
pub mod map_optimize;
pub mod map_predict;
pub mod map_program;
pub mod map_removal_function;
pub mod measurement_fit;
pub mod operators;
pub mod optimize;
pub mod predict;
pub mod program;
pub mod raster;
pub mod raster_optimize;
pub mod raster_predict;
pub mod raster_program;
pub mod recommend;
pub mod records;
pub mod removal_function;
mod setting;
mod warnings;

pub use limits::{ComputeLimits, SizeLimitError};
pub use operators::{OperatorCache, OperatorCacheStats};
pub use recommend::Recommender;
pub use setting::{ApertureSpec, GridSpec, Mount, PartError, PartSpec, Setting, SettingError};
pub use warnings::Warning;

use crate::optimize::OptimizeError;
use crate::physics::ScheduleError;
use crate::study::StudyError;

/// An input of a command, by role (callers name it in their own terms).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input {
    /// The tool positions of a removal-function request.
    ToolPositions,
    /// A dwell schedule (positions and dwell times).
    Dwell,
    /// A constant feed (start, stop, feed).
    Feed,
    /// The candidate positions of an optimization.
    Positions,
    /// The η values of a sweep.
    Etas,
    /// The depth equal dwell removes.
    Depth,
    /// The η-window threshold on equal-dwell nonuniformity.
    NonuniformityThreshold,
    /// A uniform target depth.
    UniformDepth,
    /// The solver's time budget.
    SolverTimeLimit,
    /// A measured profile as the target.
    TargetProfile,
    /// The free uniform layer of a profile target.
    FreePiston,
}

/// Why a command could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    #[error(transparent)]
    Setting(#[from] SettingError),
    /// An input is larger than the limits allow.
    #[error("{input:?}: {error}")]
    TooLarge { input: Input, error: SizeLimitError },
    /// A dwell schedule or list of positions is malformed.
    #[error("{error}")]
    Schedule { input: Input, error: ScheduleError },
    /// A number outside its range; `max` is the largest accepted value. Says the range
    /// (the caller names the input).
    #[error("{}", out_of_range(*input, *max))]
    OutOfRange { input: Input, max: f64 },
    /// Constraints, objective weights or a measured profile.
    #[error(transparent)]
    Optimize(#[from] OptimizeError),
    /// η values or machine speed limits.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// Both or neither of two alternatives were given.
    #[error("give exactly one of {0:?} and {1:?}")]
    OneOf(Input, Input),
    /// An input that only means something together with another one.
    #[error("{input:?} applies only with {without:?}")]
    Inapplicable { input: Input, without: Input },
    /// The optimization's machine does not fit its positions.
    #[error(transparent)]
    MachineFit(#[from] optimize::MachineFitError),
}

/// The range an input must lie in, in words.
fn out_of_range(input: Input, max: f64) -> String {
    match input {
        Input::Depth => format!(
            "must be a number in [{}, {max}] nm",
            recommend::MIN_DEPTH_NM
        ),
        Input::UniformDepth => format!("must be a number in [0, {max}] nm"),
        Input::NonuniformityThreshold => "must be a finite fraction > 0".to_string(),
        Input::Etas => format!("must hold 1 to {max} values; it is empty"),
        Input::SolverTimeLimit => {
            format!("must be > 0 and at most this server's limit of {max} s")
        }
        _ => format!("is out of range (at most {max})"),
    }
}

impl InputError {
    fn limit(input: Input) -> impl FnOnce(SizeLimitError) -> InputError {
        move |error| InputError::TooLarge { input, error }
    }

    fn schedule(input: Input) -> impl FnOnce(ScheduleError) -> InputError {
        move |error| InputError::Schedule { input, error }
    }
}
