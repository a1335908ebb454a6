//! The η = −1 recommendation: workpiece and tool turning the same way at the same speed, with
//! the speed chosen to keep the user's mean removal rate, and what it buys.
//!
//! At η = −1 the removal rate is K·P·|ω|·r1·θ0/π: linear in the common speed, K and P. So one
//! equal-dwell pass at η = −1 at a canonical setting ([`GeometryParts`], which depends on the
//! geometry and frame alone and can be shared by every process of a machine set-up) gives the
//! rate per r/min of any process, and the speed that keeps the user's current equal-dwell mean
//! rate over the aperture is their ratio. If the machine's limits forbid it, the fastest
//! allowed speed is taken instead. The pass at the recommended speed is the canonical pass
//! retimed: the same removal, dwell divided by the rate factor.

use super::equal_dwell::{canonical_translation, translation_rate_factor, EqualDwell, Frame};
use super::window::{window_at, EtaWindow};
use super::StudyError;
use crate::physics::process::RPM_MAX;
use crate::physics::{Process, ProcessSpec};

/// Nonuniformity below which equal dwell counts as uniform to rounding.
pub const UNIFORM_TO_ROUNDING: f64 = 1e-9;

/// Machine speed limits, r/min (magnitudes, > 0), checked by [`SpeedLimits::new`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SpeedLimits {
    max_workpiece_rpm: Option<f64>,
    max_tool_rpm: Option<f64>,
}

/// One of the machine's speed limits, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedLimit {
    MaxWorkpiece,
    MaxTool,
}

impl SpeedLimit {
    pub fn name(self) -> &'static str {
        match self {
            SpeedLimit::MaxWorkpiece => "max_workpiece_rpm",
            SpeedLimit::MaxTool => "max_tool_rpm",
        }
    }
}

/// Which rule chose the recommended speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedRule {
    /// The speed that keeps the current mean removal rate (within the limits).
    MatchRemovalRate,
    /// The limits forbid that speed; the fastest allowed is used.
    FastestAllowed,
}

/// The recommendation and the comparison behind it, both under equal dwell removing the same
/// mean depth.
#[derive(Debug, Clone, PartialEq)]
pub struct Recommendation {
    pub workpiece_rpm: f64,
    pub tool_rpm: f64,
    pub rule: SpeedRule,
    /// Equal dwell at the recommended speeds.
    pub recommended: EqualDwell,
    /// Equal dwell at the user's speeds.
    pub current: EqualDwell,
    /// current nonuniformity / recommended nonuniformity (`None` if either is undefined or
    /// the recommended one is below [`UNIFORM_TO_ROUNDING`]: on a plane equal dwell at η = −1
    /// is exactly uniform, and a ratio of 1e15 to rounding noise means nothing).
    pub improvement_factor: Option<f64>,
    /// Equal dwell at the recommended speeds is uniform to rounding (nonuniformity below
    /// [`UNIFORM_TO_ROUNDING`]) while at the current speeds it is not: the recommendation
    /// removes the nonuniformity (no finite factor says that).
    pub nonuniformity_removed: bool,
    /// `None` when equal dwell at η = −1 is itself above the threshold (e.g. an aperture out
    /// to the edge, where the pad cannot overhang).
    pub eta_window: Option<EtaWindow>,
}

impl Recommendation {
    /// The same recommendation with both equal-dwell plans removing `depth_nm` (> 0) instead:
    /// speeds, rule, improvement and window do not depend on the depth.
    pub fn scaled_to(&self, depth_nm: f64) -> Self {
        Recommendation {
            recommended: self
                .recommended
                .scaled(depth_nm / self.recommended.metrics.mean_nm),
            current: self.current.scaled(depth_nm / self.current.metrics.mean_nm),
            ..self.clone()
        }
    }
}

impl SpeedLimits {
    /// Limits of `None` (no limit) or finite numbers > 0 r/min.
    pub fn new(
        max_workpiece_rpm: Option<f64>,
        max_tool_rpm: Option<f64>,
    ) -> Result<Self, StudyError> {
        for (limit, v) in [
            (SpeedLimit::MaxWorkpiece, max_workpiece_rpm),
            (SpeedLimit::MaxTool, max_tool_rpm),
        ] {
            if let Some(v) = v {
                if !v.is_finite() || v <= 0.0 {
                    return Err(StudyError::InvalidSpeedLimit { limit });
                }
            }
        }
        Ok(SpeedLimits {
            max_workpiece_rpm,
            max_tool_rpm,
        })
    }

    pub fn max_workpiece_rpm(&self) -> Option<f64> {
        self.max_workpiece_rpm
    }

    pub fn max_tool_rpm(&self) -> Option<f64> {
        self.max_tool_rpm
    }

    /// The fastest common speed allowed: the machine's limits, and the model's domain.
    fn cap(&self) -> f64 {
        [self.max_workpiece_rpm, self.max_tool_rpm]
            .into_iter()
            .flatten()
            .fold(RPM_MAX, f64::min)
    }
}

/// What a recommendation needs that depends only on the geometry (radii, pressure model), the
/// frame and the window threshold — not on the speeds, K or P: equal dwell at η = −1 at the
/// canonical setting removing 1 nm, and the η window.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryParts {
    translation: EqualDwell,
    window: Option<EtaWindow>,
}

impl GeometryParts {
    pub fn new(process: &Process, frame: Frame, threshold: f64) -> Result<Self, StudyError> {
        let canonical = Process::new(canonical_translation(process.spec()))
            .map_err(StudyError::RecommendedOutsideDomain)?;
        let translation =
            EqualDwell::for_depth(&canonical, frame, 1.0).ok_or(StudyError::NoRemovalInAperture)?;
        Ok(GeometryParts {
            translation,
            window: window_at(canonical.spec(), frame, threshold),
        })
    }
}

/// Equal dwell at `process` removing 1 nm over the frame's aperture ([`EqualDwell::read`]:
/// `read` is what an operator read of the pass beside its rows, if one did).
pub fn current_pass(
    process: &Process,
    frame: Frame,
    read: Option<Vec<f64>>,
) -> Result<EqualDwell, StudyError> {
    EqualDwell::read(process, frame, read).ok_or(StudyError::NoRemovalInAperture)
}

/// Recommends η = −1 speeds for `process`, comparing equal dwell removing `depth_nm` (> 0) at
/// the user's and the recommended speeds. `parts` ([`GeometryParts::new`]) and `current`
/// (equal dwell at the user's speeds, any depth) must have been made for `process` in one
/// frame.
pub fn recommend(
    process: &Process,
    limits: SpeedLimits,
    depth_nm: f64,
    parts: &GeometryParts,
    current: &EqualDwell,
) -> Result<Recommendation, StudyError> {
    let current = current.scaled(depth_nm / current.metrics.mean_nm);
    let spec = process.spec();
    let direction = if spec.tool_rpm < 0.0 { -1.0 } else { 1.0 };
    let unit = &parts.translation;
    let per_rpm = unit.mean_rate_nm_per_min() * translation_rate_factor(spec, 1.0);
    let matching = current.mean_rate_nm_per_min() / per_rpm;
    let cap = limits.cap();
    let (speed, rule) = if rounded_speed(matching, false) <= cap {
        (rounded_speed(matching, false), SpeedRule::MatchRemovalRate)
    } else {
        (rounded_speed(cap, true), SpeedRule::FastestAllowed)
    };
    Process::new(ProcessSpec {
        workpiece_rpm: direction * speed,
        tool_rpm: direction * speed,
        ..spec.clone()
    })
    .map_err(StudyError::RecommendedOutsideDomain)?;
    let recommended = unit
        .retimed(translation_rate_factor(spec, speed))
        .scaled(depth_nm / unit.metrics.mean_nm);
    // K·P so small that the rates underflow: the process removes nothing worth planning.
    if !(per_rpm.is_normal() && recommended.is_finite() && current.is_finite()) {
        return Err(StudyError::NoRemovalInAperture);
    }
    let improvement_factor = match (
        current.metrics.nonuniformity,
        recommended.metrics.nonuniformity,
    ) {
        (Some(c), Some(r)) if r >= UNIFORM_TO_ROUNDING => Some(c / r),
        _ => None,
    };
    let nonuniformity_removed = matches!(
        (current.metrics.nonuniformity, recommended.metrics.nonuniformity),
        (Some(c), Some(r)) if r < UNIFORM_TO_ROUNDING && c >= UNIFORM_TO_ROUNDING
    );
    Ok(Recommendation {
        workpiece_rpm: direction * speed,
        tool_rpm: direction * speed,
        rule,
        recommended,
        current,
        improvement_factor,
        nonuniformity_removed,
        eta_window: parts.window,
    })
}

/// Recommended speeds are set to this resolution, r/min: what a spindle is set to (a speed
/// below 1 r/min to three significant figures instead, never 0).
pub const SPEED_RESOLUTION_RPM: f64 = 0.1;

/// `speed` (> 0) to [`SPEED_RESOLUTION_RPM`], rounded to nearest or, for a limit that must
/// not be exceeded, `down` (never above `speed`). The result is the double nearest the
/// decimal, so it prints short.
fn rounded_speed(speed: f64, down: bool) -> f64 {
    // Steps of the resolution: 1/0.1 = 10 per r/min, or three significant figures below 1.
    let per_rpm = if speed >= 1.0 {
        1.0 / SPEED_RESOLUTION_RPM
    } else {
        10f64.powi(2 - speed.log10().floor() as i32)
    };
    let steps = speed * per_rpm;
    // Rounding down, a limit that is itself a step (2.3 r/min: 22.999999999999996 steps in
    // binary) is that step, not the one below; then the step is checked against the limit.
    // n steps of an exact power of ten, divided once: the double nearest the decimal, so it
    // prints short (106.1, not 106.10000000000001).
    let decimal = |n: f64| n / per_rpm;
    if !down {
        return decimal(steps.round());
    }
    let n = (steps + 1e-9 * steps.max(1.0)).floor();
    if decimal(n) <= speed {
        decimal(n)
    } else {
        decimal(n - 1.0)
    }
}

#[cfg(test)]
mod speed_tests {
    use super::rounded_speed;

    #[test]
    fn speeds_are_set_to_a_tenth_and_limits_never_exceeded() {
        assert_eq!(rounded_speed(106.09554537664748, false), 106.1);
        assert_eq!(rounded_speed(2224.2499, false), 2224.2);
        assert_eq!(rounded_speed(0.0012345, false), 0.00123);
        // Down: a limit that is a step stays that step; anything else the step below.
        for (limit, expected) in [(2.3, 2.3), (1.9, 1.9), (1000.0, 1000.0), (2.29999, 2.2)] {
            let r = rounded_speed(limit, true);
            assert_eq!(r, expected, "{limit}");
            assert!(r <= limit);
        }
        assert_eq!(rounded_speed(0.5, true), 0.5);
        assert!(rounded_speed(0.00123999, true) <= 0.00123999);
    }
}
