//! Studies on top of the physics: what equal dwell removes, the η = −1 recommendation with its
//! η window, and η sweeps. Pure: no HTTP, JSON or OpenAPI types.
//!
//! The dwell policy throughout is **equal dwell**: the tool crosses the path [0, L] at one
//! constant feed, discretised as a [`ConstantFeed`](crate::physics::ConstantFeed) (cell centres,
//! dwell τ·h each). The path ends at L = min(outer + r_t, the tool's reach), so every radius
//! of the clear aperture sees the whole pad pass over it: at η = −1 the removal is then uniform
//! right down to the centre (K·P·|ω|·r_t²·τ/2, the invariant in DESIGN.md).

pub mod equal_dwell;
pub mod recommend;
pub mod sweep;
mod window;

pub use equal_dwell::{EqualDwell, Frame};
pub use recommend::{recommend, Recommendation, SpeedLimits, SpeedRule};
pub use sweep::{eta_sweep, SweepPoint};
pub use window::EtaWindow;

/// Why a study was refused; `field` names the input as the request does.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct StudyError {
    pub field: String,
    pub message: String,
}

impl StudyError {
    pub(crate) fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        StudyError {
            field: field.into(),
            message: message.into(),
        }
    }
}
