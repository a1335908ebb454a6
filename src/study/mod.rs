//! Studies on top of the physics: what equal dwell removes, the η = −1 recommendation with its
//! η window, and η sweeps. Pure: no HTTP, JSON or OpenAPI types.
//!
//! The dwell policy throughout is **equal dwell**: the tool crosses the path [0, L] at one
//! constant feed, a [`ConstantFeed`](crate::physics::ConstantFeed), whose removal is an exact
//! integral along the path (no cells). The path ends at L = min(outer + r_t, the tool's reach), so every radius
//! of the clear aperture sees the whole pad pass over it: at η = −1 the removal is then uniform
//! right down to the centre (K·P·|ω|·r_t²·τ/2, the invariant in `docs/MODEL.md`).
//!
//! On a curved part the feed, the dwell density and r_t in L are along the surface (constant
//! dwell per unit arc length). η = −1 then is no longer a pure translation: the sliding
//! velocity is the translation ω·(the pad centre's distance from the axis) plus a spin
//! ω·(cosθ₁ − 1) about the normal (θ₁ the slope at the pad centre), second order in θ₁, so equal
//! dwell at η = −1 still removes nearly uniformly (0.1 % on R = ±100 mm, r_t = 8 mm, 50 mm of
//! arc; `tests/it/curved_plans.rs`). The recommendation and its η window are computed with the
//! curved model, so they say how uniform it actually is.

pub mod equal_dwell;
pub mod recommend;
pub mod sweep;
mod window;

pub use equal_dwell::{pass_reading, EqualDwell, Frame};
pub use recommend::{
    current_pass, recommend, GeometryParts, Recommendation, SpeedLimit, SpeedLimits, SpeedRule,
};
pub use sweep::{eta_sweep, SweepEtas, SweepPoint};
pub use window::{eta_window, EtaWindow};

use crate::physics::ProcessError;

/// Why a study was refused; each variant says which input is at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StudyError {
    /// Equal dwell removes nothing inside the clear aperture.
    #[error("equal dwell removes nothing inside the clear aperture")]
    NoRemovalInAperture,
    /// A sweep holds the tool speed, which is 0.
    #[error("an η sweep holds the tool speed, so tool_rpm must not be 0")]
    ToolStationary,
    /// η number `index` (from 0) of a sweep is not finite or is 0.
    #[error("η must be finite and not 0 (η = 0 stops the workpiece)")]
    InvalidEta { index: usize },
    /// η number `index` puts the workpiece speed outside the model's domain.
    #[error("{error}")]
    EtaOutsideDomain { index: usize, error: ProcessError },
    /// A machine speed limit is not a finite number > 0.
    #[error("{} must be a finite number > 0 r/min", limit.name())]
    InvalidSpeedLimit { limit: SpeedLimit },
    /// The recommended speeds fall outside the model's domain.
    #[error("{0}")]
    RecommendedOutsideDomain(ProcessError),
}
