//! Fit an on-machine probe trace to the design and hand back the form error as a correction
//! target: the alignment fit ([`crate::metrology::fit`]), the form error's RMS and PV over the
//! clear aperture, and the radial profile on a grid within the trace's reach.

use super::limits::{ComputeLimits, SizeLimitError};
use super::setting::DEFAULT_RADIAL_SAMPLES;
use super::{ApertureSpec, GridSpec};
use crate::metrology::{
    fit, form_error, radial_profile, Compensation, Coverage, FitError, FitOutcome, FitParameters,
    FitProblem, FormErrorSummary, Probe, ProbeError, RadialProfile, RadialProfileError, RobustLoss,
    TraceError,
};
use crate::physics::{check_radius, ClearAperture, GridError, RadialGrid, Reach};
use crate::surface::{Surface, SurfaceError, SurfaceSpec};

/// Which parameters to fit, as asked (`None`: the default for the surface, see
/// [`FitParameters::default_for`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FitSelection {
    pub lateral_offset: Option<bool>,
    pub tilt: Option<bool>,
    pub piston: Option<bool>,
    pub radius_of_curvature: Option<bool>,
}

/// A measurement fit as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementFitSpec {
    pub surface: SurfaceSpec,
    pub x_mm: Vec<f64>,
    pub z_mm: Vec<f64>,
    /// Default 0 (the points are contact points).
    pub probe_tip_radius_mm: Option<f64>,
    /// Default normal.
    pub compensation: Option<Compensation>,
    pub fit: FitSelection,
    /// Default none.
    pub robust: Option<RobustLoss>,
    /// Default: 201 samples over the radii the trace covers.
    pub grid: GridSpec,
    /// Default: the grid's span.
    pub aperture: ApertureSpec,
}

/// Why a measurement fit was refused before computing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeasurementInputError {
    #[error(transparent)]
    Surface(SurfaceError),
    #[error(transparent)]
    Probe(ProbeError),
    #[error(transparent)]
    Trace(TraceError),
    #[error(transparent)]
    TraceSize(SizeLimitError),
    #[error(transparent)]
    GridSize(SizeLimitError),
    /// A profile needs two samples at least (it becomes an optimize target).
    #[error("count must be at least 2")]
    GridCount,
    #[error(transparent)]
    Grid(GridError),
    #[error(transparent)]
    Aperture(GridError),
}

/// A checked measurement fit.
#[derive(Debug, Clone)]
pub struct MeasurementFitCommand {
    problem: FitProblem,
    grid: GridSpec,
    aperture: ApertureSpec,
}

/// The checks on radii that need no trace: finite, ≥ 0, ordered when both ends are given.
fn check_span(
    lower: Option<f64>,
    upper: Option<f64>,
    names: (&'static str, &'static str),
) -> Result<(), GridError> {
    // The trace's reach is known only after the fit; until then, no bound.
    let unbounded = Reach {
        radius_mm: f64::INFINITY,
        name: "measured radius",
    };
    for (value, field) in [(lower, names.0), (upper, names.1)] {
        value.map_or(Ok(()), |v| check_radius(field, v, unbounded))?;
    }
    if upper.is_some_and(|hi| hi <= lower.unwrap_or(0.0)) {
        return Err(GridError::NotAbove {
            field: names.1,
            lower: names.0,
        });
    }
    Ok(())
}

impl MeasurementFitCommand {
    pub fn new(
        spec: MeasurementFitSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, MeasurementInputError> {
        use MeasurementInputError as E;
        let surface = Surface::new(&spec.surface).map_err(E::Surface)?;
        let probe = Probe::new(
            spec.probe_tip_radius_mm.unwrap_or(0.0),
            spec.compensation.unwrap_or(Compensation::Normal),
        )
        .map_err(E::Probe)?;
        limits
            .check_trace_points(spec.x_mm.len().max(spec.z_mm.len()))
            .map_err(E::TraceSize)?;
        let count = spec.grid.count.unwrap_or(DEFAULT_RADIAL_SAMPLES);
        limits.check_radial_samples(count).map_err(E::GridSize)?;
        if count < 2 {
            return Err(E::GridCount);
        }
        check_span(
            spec.grid.start_mm,
            spec.grid.stop_mm,
            ("start_mm", "stop_mm"),
        )
        .map_err(E::Grid)?;
        check_span(
            spec.aperture.inner_mm,
            spec.aperture.outer_mm,
            ("inner_mm", "outer_mm"),
        )
        .map_err(E::Aperture)?;
        let defaults = FitParameters::default_for(&surface);
        let parameters = FitParameters {
            lateral_offset: spec.fit.lateral_offset.unwrap_or(defaults.lateral_offset),
            tilt: spec.fit.tilt.unwrap_or(defaults.tilt),
            piston: spec.fit.piston.unwrap_or(defaults.piston),
            radius_of_curvature: spec
                .fit
                .radius_of_curvature
                .unwrap_or(defaults.radius_of_curvature),
        };
        let problem = FitProblem::new(
            surface,
            spec.x_mm,
            spec.z_mm,
            probe,
            parameters,
            spec.robust.unwrap_or(RobustLoss::None),
        )
        .map_err(E::Trace)?;
        Ok(MeasurementFitCommand {
            problem,
            grid: spec.grid,
            aperture: spec.aperture,
        })
    }
}

/// Why a fit found no usable answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeasurementError {
    #[error(transparent)]
    Fit(FitError),
    #[error(transparent)]
    Grid(GridError),
    #[error(transparent)]
    Aperture(GridError),
    #[error(transparent)]
    Profile(RadialProfileError),
}

/// Everything a measurement-fit response needs.
#[derive(Debug, Clone)]
pub struct MeasurementFit {
    pub outcome: FitOutcome,
    pub fitted: FitParameters,
    pub grid: RadialGrid,
    pub aperture: ClearAperture,
    pub profile: RadialProfile,
    pub form_error: FormErrorSummary,
}

pub fn measurement_fit(command: MeasurementFitCommand) -> Result<MeasurementFit, MeasurementError> {
    use MeasurementError as E;
    let outcome = fit(&command.problem).map_err(E::Fit)?;
    let coverage = Coverage::of(&outcome.points).ok_or(E::Profile(RadialProfileError::NoPoints))?;
    let (start, stop) = coverage.radial_span_mm();
    let reach = Reach {
        radius_mm: stop,
        name: "radius the trace reaches",
    };
    let grid = RadialGrid::within(
        reach,
        command.grid.start_mm.unwrap_or(start),
        command.grid.stop_mm.unwrap_or(stop),
        command.grid.count.unwrap_or(DEFAULT_RADIAL_SAMPLES),
    )
    .map_err(E::Grid)?;
    let aperture = ClearAperture::within(
        reach,
        command.aperture.inner_mm.unwrap_or(grid.start_mm()),
        command.aperture.outer_mm.unwrap_or(grid.stop_mm()),
    )
    .map_err(E::Aperture)?;
    aperture.check_covered_by(&grid).map_err(E::Aperture)?;
    let profile = radial_profile(&outcome.points, &grid).map_err(E::Profile)?;
    let form_error = form_error(&outcome.points, &aperture).map_err(E::Profile)?;
    Ok(MeasurementFit {
        fitted: command.problem.parameters(),
        outcome,
        grid,
        aperture,
        profile,
        form_error,
    })
}
