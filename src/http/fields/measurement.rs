//! Where the measurement fit's inputs sit in its request: the fitted parameters (members of
//! `fit`), the trace's points (`profile.x_mm[i]`), the probe, the grid and aperture.

use super::super::error::{ApiError, Kind};
use super::surface_error;
use crate::metrology::{FitError, Parameter, ProbeError, TraceAxis, TraceError};
use crate::usecases::measurement_fit::{MeasurementError, MeasurementInputError};

/// The request's name for a fitted parameter (a member of `fit`).
fn parameter_name(parameter: Parameter) -> &'static str {
    match parameter {
        Parameter::LateralOffset => "lateral_offset",
        Parameter::Tilt => "tilt",
        Parameter::Piston => "piston",
        Parameter::RadiusOfCurvature => "radius_of_curvature",
    }
}

fn fit_field(parameters: &[Parameter]) -> String {
    parameters
        .first()
        .map_or("fit".into(), |&p| format!("fit.{}", parameter_name(p)))
}

fn parameter_names(parameters: &[Parameter]) -> String {
    parameters
        .iter()
        .map(|&p| parameter_name(p))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A point the probe cannot place on the design.
fn off_surface(index: usize, error: &ProbeError) -> ApiError {
    ApiError::invalid(
        format!("profile.x_mm[{index}]"),
        format!("point {index} does not lie over the design: {error}"),
    )
}

impl From<MeasurementInputError> for ApiError {
    fn from(err: MeasurementInputError) -> Self {
        use MeasurementInputError as E;
        match err {
            E::Surface(e) => surface_error(e),
            E::Probe(e) => ApiError::invalid("probe_tip_radius_mm", e.to_string()),
            E::TraceSize(e) => ApiError::from_limit("profile.x_mm", e),
            E::GridSize(e) => ApiError::from_limit("radial_grid.count", e),
            E::GridCount => ApiError::invalid(
                "radial_grid.count",
                "count must be at least 2: the profile becomes an optimize target",
            ),
            E::Grid(e) => ApiError::from_grid("radial_grid", e),
            E::Aperture(e) => ApiError::from_grid("clear_aperture", e),
            E::Trace(e) => match &e {
                TraceError::LengthMismatch { .. } => {
                    ApiError::invalid("profile.z_mm", e.to_string())
                }
                TraceError::NonFinite { axis, index } => {
                    let axis = if *axis == TraceAxis::X {
                        "x_mm"
                    } else {
                        "z_mm"
                    };
                    ApiError::invalid(format!("profile.{axis}[{index}]"), e.to_string())
                }
                TraceError::TooFewPoints { .. } => ApiError::invalid("profile.x_mm", e.to_string()),
                TraceError::NothingToFit => ApiError::invalid("fit", e.to_string()),
                TraceError::Undetermined { parameters, .. } => {
                    ApiError::invalid(fit_field(parameters), e.to_string())
                }
                TraceError::OffSurface { index, error } => off_surface(*index, error),
            },
        }
    }
}

impl From<MeasurementError> for ApiError {
    fn from(err: MeasurementError) -> Self {
        match err {
            MeasurementError::Fit(FitError::Undetermined { parameters }) => ApiError::invalid(
                fit_field(&parameters),
                format!(
                    "the trace does not determine {} apart: they trade off against each other \
                     on this surface and span; fit fewer parameters",
                    parameter_names(&parameters)
                ),
            ),
            MeasurementError::Fit(FitError::LeftSurface { index, error }) => {
                off_surface(index, &error)
            }
            MeasurementError::Fit(
                e @ (FitError::NotConverged { .. } | FitError::WeightsUnsettled { .. }),
            ) => ApiError::new(
                Kind::SolverNotConverged,
                format!(
                    "{e}: the trace may not be a meridian of this surface (check surface \
                     and the units of profile), or the misalignment is too large"
                ),
            )
            .at("profile"),
            MeasurementError::Grid(e) => ApiError::from_grid("radial_grid", e),
            MeasurementError::Aperture(e) => ApiError::from_grid("clear_aperture", e),
            MeasurementError::Profile(e) => {
                let field = match e {
                    crate::metrology::RadialProfileError::NotCovered { .. } => "radial_grid",
                    crate::metrology::RadialProfileError::ApertureEmpty => "clear_aperture",
                    crate::metrology::RadialProfileError::NoPoints => "profile",
                };
                ApiError::invalid(field, e.to_string())
            }
        }
    }
}
