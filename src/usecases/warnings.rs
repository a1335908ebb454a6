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
/// A nominal pressure above this, kPa, looks like pascals typed as kilopascals: polishing
/// pressures are about 1 to 100 kPa, and 1 MPa (10 bar) is far beyond any pad's.
pub const PASCALS_ABOVE_KPA: f64 = 1000.0;

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
        "the plan sits on {}{}: the machine, not the target, decided it there",
        limit.describe(*drive),
        if *default_machine {
            ", the default machine's (a limit the request did not give: state your machine's \
             in `machine`)"
        } else {
            ""
        }
    )]
    MachineLimitActive {
        drive: Drive,
        limit: LimitKind,
        /// The limit is the default machine's, not one the caller gave.
        default_machine: bool,
    },
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
    /// The nominal pressure is above [`PASCALS_ABOVE_KPA`]: pascals typed as kilopascals?
    #[error(
        "the pressure is {pressure_kpa} kPa ({:.3} bar); polishing pressures are about 1 to \
         100 kPa: pressure_kpa is in kilopascals; is this in pascals (10 kPa = 10000 Pa)?",
        pressure_kpa / 100.0
    )]
    PressureLooksLikePascals { pressure_kpa: f64 },
    /// The request asked for no machine limits: the plan or program is a study, checked
    /// against no machine, and must not be sent to one as it is.
    #[error(
        "machine is \"unlimited\": no axis velocity, acceleration or spindle limit was kept, so \
         this is a study, not a machine program; leave machine out for the default machine, or \
         give your machine's limits"
    )]
    MachineUnlimited,
    /// A measurement fitted without a surface was fitted to a plane; the best-fit sphere says
    /// what the trace looks like.
    #[error(
        "no surface was given, so the trace was fitted to a plane: {plane_rms_nm:.1} nm RMS of \
         form error{}; give the part's surface",
        match sphere {
            Some((r, rms)) => format!(
                ". The best-fit sphere has R = {r:.6} mm (residual {rms:.1} nm RMS): \
                 if the part is that sphere, send surface {{\"kind\": \"sphere\", \
                 \"radius_of_curvature_mm\": {r:.6}}}"
            ),
            None => String::new(),
        }
    )]
    SurfaceAssumedPlane {
        plane_rms_nm: f64,
        /// The best-fit sphere's vertex radius, mm, and residual RMS, nm; `None` when the
        /// trace is flat or no sphere holds it.
        sphere: Option<(f64, f64)>,
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
    /// Calibration: the model fits the runs exactly (residual below a femtometre RMS), so
    /// they carry no estimate of their noise and no standard error can be given.
    #[error(
        "the model fits the runs exactly (residual RMS below 1e-6 nm): no measurement is that \
         exact, so the runs say nothing of their noise and no parameter has a standard error; \
         a measurement repeated unchanged as before and after does this (it removed nothing)"
    )]
    ExactFit,
    /// A production cycle's removal does not determine the removal rate: fitted to the plan's
    /// dwell as a calibration, its K is not [`super::records::SIGNIFICANT_STANDARD_ERRORS`]
    /// standard errors above 0 (`fitted`: K and its standard error, m²/N), or no K > 0 fits
    /// it at all (`None`); the profile learns nothing from it.
    #[error(
        "the cycle's removal (before − after) does not determine the removal rate: {}; nothing \
         was learned from it. The run removed nothing measurable, or the measurements do not \
         show what it removed (the same trace sent twice, another part's, before and after \
         swapped)",
        match fitted {
            Some((k, Some(se))) => format!(
                "fitted to the plan's dwell, K = {k:.3e} ± {se:.2e} m²/N, not 2 standard errors \
                 above 0"
            ),
            Some((k, None)) => format!(
                "fitted to the plan's dwell, K = {k:.3e} m²/N with no standard error (the fit is \
                 exact: the measurements carry no estimate of their noise)"
            ),
            None => "no K above 0 fits it to the plan's dwell".to_string(),
        }
    )]
    RemovalNotSignificant { fitted: Option<(f64, Option<f64>)> },
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
    /// A map's clear aperture has pixels without data beyond [`MAP_DROPOUT_FRACTION`].
    #[error(
        "{missing} of the clear aperture's {total} pixels hold no height ({:.1} %): the \
         figures describe the others (dropouts, dust, or an aperture beyond the measured area)",
        100.0 * *missing as f64 / *total as f64
    )]
    MapDropouts { missing: usize, total: usize },
    /// A result map was computed at a coarser pixel than asked, to stay within the work
    /// limit of one request.
    #[error(
        "the removal map was computed at {used_mm:.3} mm pixels, not the {asked_mm:.3} mm asked: \
         the plan runs too many turns of C to compute every pixel within one request"
    )]
    MapCoarsened { asked_mm: f64, used_mm: f64 },
    /// Harmonics of the target beyond what the plan corrects (`max_harmonic`) or what C
    /// allows remain in the residual.
    #[error(
        "the target's harmonics above m = {max_harmonic} hold {rms_nm:.3} nm RMS that the plan \
         leaves alone (raise max_harmonic, up to half the sectors)"
    )]
    HarmonicsLeft { max_harmonic: usize, rms_nm: f64 },
    /// The dwell map's solver stopped at its work or time limit before its optimality
    /// residual reached its tolerance: the plan stands (every bound kept) but may not be the
    /// best.
    #[error(
        "the solver stopped at its limit (the service's solver time, or 3,000 products) after \
         {products} products with the operator, its optimality residual at \
         {kkt_residual_s:.3e} s of dwell: the plan keeps every limit but a better one may \
         exist (a coarser dwell pitch, or more smoothing, converges faster)"
    )]
    SolverNotConverged {
        kkt_residual_s: f64,
        products: usize,
    },
}

/// A map whose clear aperture lacks more than this fraction of its pixels gets a warning.
pub const MAP_DROPOUT_FRACTION: f64 = 0.02;

/// [`Warning::MapDropouts`] when `used` of an aperture's `total` pixels leave more than
/// [`MAP_DROPOUT_FRACTION`] without data.
pub fn map_dropouts(used: usize, total: usize) -> Vec<Warning> {
    let missing = total.saturating_sub(used);
    if missing as f64 > MAP_DROPOUT_FRACTION * total as f64 {
        vec![Warning::MapDropouts { missing, total }]
    } else {
        Vec::new()
    }
}

/// The unit checks on a process: radii that look like metres, a pressure that looks like
/// pascals. Every use case that takes a process runs them.
pub fn process_warnings(process: &Process) -> Vec<Warning> {
    let mut warnings = Vec::new();
    let workpiece_radius_mm = process.workpiece_radius_mm();
    if workpiece_radius_mm < 1.0 {
        warnings.push(Warning::ProcessLooksLikeMetres {
            workpiece_radius_mm,
            tool_radius_mm: process.tool_radius_mm(),
        });
    }
    let pressure_kpa = process.spec().pressure_kpa;
    if pressure_kpa > PASCALS_ABOVE_KPA {
        warnings.push(Warning::PressureLooksLikePascals { pressure_kpa });
    }
    warnings
}

/// The unit checks on a process ([`process_warnings`]) and, when its radii look right, on the
/// tool positions (all below 1 mm on a workpiece of 10 mm or more).
pub(super) fn unit_warnings(process: &Process, reached_mm: &[f64]) -> Vec<Warning> {
    let mut warnings = process_warnings(process);
    let workpiece_radius_mm = process.workpiece_radius_mm();
    let max_position_mm = reached_mm.iter().copied().fold(0.0_f64, f64::max);
    if workpiece_radius_mm >= 10.0 && max_position_mm < 1.0 {
        warnings.push(Warning::PositionsLookLikeMetres {
            max_position_mm,
            workpiece_radius_mm,
        });
    }
    warnings
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
