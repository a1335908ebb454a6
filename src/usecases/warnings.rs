//! Warnings: a result that stands but may not be what the caller meant — a constraint, not
//! the target, decided an optimized plan; the plan misses its target; the input looks like a
//! unit mistake.

use crate::calibration::ProcessParameter;
use crate::machine::{Drive, LimitKind};
use crate::optimize::{Constraint, Constraints};
use crate::physics::Process;

/// Relative closeness to a limit at which a plan counts as sitting on it (interior-point
/// answers come within ~1e-8; the optimizer then clamps to the bounds exactly).
const ACTIVE: f64 = 1e-6;
/// A feed or machine limit a plan uses at this fraction or more counts as one it sits on
/// (the optimizer keeps 1e-6 below them).
pub(super) const ACTIVE_USE: f64 = 0.999;
/// A plan whose residual RMS exceeds this fraction of the target's RMS misses its target.
pub const TARGET_MISS_FRACTION: f64 = 0.1;

/// Something about a result the caller should know; its `Display` says it in words (naming
/// inputs by their role; the caller adds where they sit in its request).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Warning {
    /// The plan sits on this limit: relaxing it would let the plan fit the target better.
    #[error(
        "the plan sits on {}: that limit, not the target, decided it there",
        constraint.name()
    )]
    ConstraintActive { constraint: Constraint },
    /// The plan's residual RMS is more than [`TARGET_MISS_FRACTION`] of the target's RMS.
    #[error(
        "the residual RMS over the clear aperture is {residual_rms_nm:.4} nm, {:.1} % of the \
         target's RMS ({target_rms_nm:.4} nm)",
        100.0 * residual_rms_nm / target_rms_nm
    )]
    TargetNotMet {
        residual_rms_nm: f64,
        target_rms_nm: f64,
    },
    /// The plan sits on this axis limit of the machine somewhere.
    #[error(
        "the plan sits on {}: the machine, not the target, decided it there",
        limit.describe(*drive)
    )]
    MachineLimitActive { drive: Drive, limit: LimitKind },
    /// The plan has zero dwell at this position between positions with dwell, so the tool
    /// would cross its cell in no time: no program can run it (give `min_dwell_s`, a feed
    /// limit or the machine's velocity limits).
    #[error(
        "the plan has zero dwell at position {index} between positions with dwell, so the tool \
         would cross its cell in no time and no program can run it: give min_dwell_s > 0, \
         max_feed_mm_per_min or a velocity limit on X"
    )]
    NotProgrammable { index: usize },
    /// Every tool position is below 1 mm on a workpiece of 10 mm radius or more: positions in
    /// metres rather than millimetres?
    #[error(
        "every position is below 1 mm (at most {max_position_mm} mm) on a workpiece of \
         {workpiece_radius_mm} mm radius: positions are in millimetres; are these in metres?"
    )]
    PositionsLookLikeMetres {
        max_position_mm: f64,
        workpiece_radius_mm: f64,
    },
    /// The workpiece radius is below 1 mm: the process's radii in metres rather than
    /// millimetres? (A 0.05 m part with a 0.01 m pad plans for months.)
    #[error(
        "the workpiece radius is {workpiece_radius_mm} mm and the pad's {tool_radius_mm} mm: \
         radii are in millimetres; are these metres?"
    )]
    ProcessLooksLikeMetres {
        workpiece_radius_mm: f64,
        tool_radius_mm: f64,
    },
    /// Calibration: no run responds to this parameter (κ with no pad over the edge, say), so
    /// it was held at its nominal value.
    #[error(
        "{}: no run's removal depends on it (for pad_moment_share: no pad overhangs the edge), \
         so the runs carry no information on it; held at its nominal {held_at} (standard \
         error unbounded)",
        parameter.name()
    )]
    ParameterUndetermined {
        parameter: ProcessParameter,
        held_at: f64,
    },
    /// Calibration: the fitted value's 95 % interval is wider than the parameter could
    /// plausibly be known without calibrating.
    #[error(
        "{} = {value:.6e} ± {standard_error:.3e} (standard error): the runs barely determine \
         it; treat it as unknown (add runs that depend on it)",
        parameter.name()
    )]
    ParameterPoorlyDetermined {
        parameter: ProcessParameter,
        value: f64,
        standard_error: f64,
    },
    /// Calibration: a run's residual is far above its measurement noise: the model does not
    /// explain it.
    #[error(
        "run {run}: the residual RMS {residual_rms_nm:.3} nm is more than 3× the {} noise of \
         {noise_nm:.3} nm: the model does not explain this run (another process, motion or \
         part, or a measurement artefact)",
        if *expected { "expected" } else { "point-to-point" }
    )]
    ResidualAboveNoise {
        run: usize,
        residual_rms_nm: f64,
        noise_nm: f64,
        expected: bool,
    },
}

/// The unit check on the process's radii, then on the tool positions.
pub(super) fn unit_warning(process: &Process, positions_mm: &[f64]) -> Option<Warning> {
    let workpiece_radius_mm = process.workpiece_radius_mm();
    if workpiece_radius_mm < 1.0 {
        return Some(Warning::ProcessLooksLikeMetres {
            workpiece_radius_mm,
            tool_radius_mm: process.tool_radius_mm(),
        });
    }
    let max_position_mm = positions_mm.iter().copied().fold(0.0_f64, f64::max);
    let workpiece_radius_mm = process.workpiece_radius_mm();
    (max_position_mm < 1.0 && workpiece_radius_mm >= 10.0).then_some(
        Warning::PositionsLookLikeMetres {
            max_position_mm,
            workpiece_radius_mm,
        },
    )
}

/// The limits a plan sits on, in the order of [`Constraints`]' fields. `peak_feed_mm_per_min`:
/// the highest path feed of the plan's program, if it has one.
pub(super) fn active_constraints(
    c: &Constraints,
    dwell_s: &[f64],
    peak_feed_mm_per_min: Option<f64>,
) -> Vec<Warning> {
    let near = |value: f64, limit: f64| (value - limit).abs() <= ACTIVE * limit.abs().max(1e-300);
    let mut active = Vec::new();
    if c.min_dwell_s() > 0.0 && dwell_s.iter().any(|&t| near(t, c.min_dwell_s())) {
        active.push(Constraint::MinDwell);
    }
    if let Some(hi) = c.max_dwell_s() {
        if dwell_s.iter().any(|&t| near(t, hi)) {
            active.push(Constraint::MaxDwell);
        }
    }
    if let Some(total) = c.max_total_time_s() {
        if near(dwell_s.iter().sum(), total) {
            active.push(Constraint::MaxTotalTime);
        }
    }
    if let (Some(limit), Some(peak)) = (c.max_feed_mm_per_min(), peak_feed_mm_per_min) {
        if peak >= ACTIVE_USE * limit {
            active.push(Constraint::MaxFeed);
        }
    }
    if let Some(delta) = c.max_dwell_change_s() {
        if delta > 0.0 && dwell_s.windows(2).any(|w| near((w[1] - w[0]).abs(), delta)) {
            active.push(Constraint::MaxDwellChange);
        }
    }
    active
        .into_iter()
        .map(|constraint| Warning::ConstraintActive { constraint })
        .collect()
}
