//! Fit an on-machine probe trace to the design and hand back the form error as a correction
//! target: the alignment fit ([`crate::metrology::fit`]), the form error's RMS and PV over the
//! clear aperture, and the radial profile on a grid within the trace's reach.

use super::limits::{ComputeLimits, SizeLimitError};
use super::setting::DEFAULT_RADIAL_SAMPLES;
use super::{ApertureSpec, GridSpec, Warning};
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
pub struct AlignmentSelection {
    pub lateral_offset: Option<bool>,
    pub tilt: Option<bool>,
    pub piston: Option<bool>,
    pub radius_of_curvature: Option<bool>,
}

/// A measurement fit as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementFitSpec {
    /// The design; `None`: not given, so a plane is fitted (with a warning and the best-fit
    /// sphere beside it).
    pub surface: Option<SurfaceSpec>,
    pub x_mm: Vec<f64>,
    pub z_mm: Vec<f64>,
    /// Default 0 (the points are contact points).
    pub probe_tip_radius_mm: Option<f64>,
    /// Default normal.
    pub compensation: Option<Compensation>,
    pub fit: AlignmentSelection,
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
    /// The surface was not given: a plane was assumed.
    plane_assumed: bool,
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
        let plane_assumed = spec.surface.is_none();
        let surface =
            Surface::new(&spec.surface.unwrap_or(SurfaceSpec::Plane)).map_err(E::Surface)?;
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
            plane_assumed,
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
    /// When no surface was given: the sphere that fits the trace best (`None` inside if the
    /// trace is flat to the fit's resolution or no sphere holds it).
    pub best_fit_sphere: Option<BestFitSphere>,
    /// A plane assumed for want of a surface.
    pub warnings: Vec<Warning>,
}

/// The sphere that fits a trace best: vertex radius, lateral offset and piston free.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BestFitSphere {
    pub radius_of_curvature_mm: f64,
    /// √(Σe²/n) of the axial residual over the points the fit kept, nm.
    pub residual_rms_nm: f64,
}

/// A vertex radius beyond this, mm, is a plane to any probe (a 100 mm chord sags 125 nm).
const FLAT_RADIUS_MM: f64 = 1e7;

/// The best-fit sphere of `problem`'s trace. A start from the parabola z = a + b·x + c·x²
/// fitted by linear least squares (R₀ = 1/(2c), exact to the sag's fourth-order term), then the
/// alignment fit itself on a sphere of R₀ with the radius, the lateral offset and the piston
/// free (a tilt is a lateral offset on a sphere). `None` for a flat trace, or when the sphere
/// does not hold every point or the fit fails.
fn best_fit_sphere(problem: &FitProblem) -> Option<BestFitSphere> {
    let (x, z) = problem.trace();
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    // Normal equations of z ≈ a + b·u + c·u² in u = x − mean (centred for conditioning).
    let mut m = [[0.0_f64; 3]; 3];
    let mut rhs = [0.0_f64; 3];
    for (&xi, &zi) in x.iter().zip(z) {
        let u = xi - mean;
        let basis = [1.0, u, u * u];
        for i in 0..3 {
            rhs[i] += basis[i] * zi;
            for j in 0..3 {
                m[i][j] += basis[i] * basis[j];
            }
        }
    }
    let c = solve3(m, rhs)?[2];
    let radius = 1.0 / (2.0 * c);
    if !radius.is_finite() || radius.abs() > FLAT_RADIUS_MM {
        return None;
    }
    let sphere = Surface::new(&SurfaceSpec::Sphere {
        radius_of_curvature_mm: radius,
    })
    .ok()?;
    let parameters = FitParameters {
        lateral_offset: true,
        tilt: false,
        piston: true,
        radius_of_curvature: true,
    };
    let sphere_problem = FitProblem::new(
        sphere,
        x.to_vec(),
        z.to_vec(),
        problem.probe(),
        parameters,
        problem.robust(),
    )
    .ok()?;
    let outcome = fit(&sphere_problem).ok()?;
    let kept: Vec<f64> = outcome
        .points
        .iter()
        .filter(|p| p.weight > 0.0)
        .map(|p| p.axial_nm())
        .collect();
    let radius_of_curvature_mm = outcome.alignment.surface.radius_of_curvature_mm()?;
    Some(BestFitSphere {
        radius_of_curvature_mm,
        residual_rms_nm: (kept.iter().map(|e| e * e).sum::<f64>() / kept.len().max(1) as f64)
            .sqrt(),
    })
}

/// The solution of the 3×3 system `m·v = rhs` by Cramer's rule; `None` when singular.
fn solve3(m: [[f64; 3]; 3], rhs: [f64; 3]) -> Option<[f64; 3]> {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(m);
    if d == 0.0 || !d.is_finite() {
        return None;
    }
    let mut v = [0.0; 3];
    for (k, vk) in v.iter_mut().enumerate() {
        let mut a = m;
        for i in 0..3 {
            a[i][k] = rhs[i];
        }
        *vk = det(a) / d;
    }
    Some(v)
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
    let best_fit_sphere = command
        .plane_assumed
        .then(|| best_fit_sphere(&command.problem))
        .flatten();
    let warnings = if command.plane_assumed {
        vec![Warning::SurfaceAssumedPlane {
            plane_rms_nm: form_error.rms_nm,
            sphere: best_fit_sphere.map(|s| (s.radius_of_curvature_mm, s.residual_rms_nm)),
        }]
    } else {
        Vec::new()
    };
    Ok(MeasurementFit {
        best_fit_sphere,
        warnings,
        fitted: command.problem.parameters(),
        outcome,
        grid,
        aperture,
        profile,
        form_error,
    })
}
