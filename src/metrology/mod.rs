//! On-machine measurement: fit a probe trace of one meridian to the design surface and turn the
//! residual into the form error the next polishing run removes (Chen et al. 2012, on-machine
//! measurement of aspheres).
//!
//! A trace is points (X, Z) in machine coordinates. The part may sit off the spindle axis by ΔX,
//! tilted by Δτ, and the probe's zero is arbitrary (Δz). The paper's eq. 2 takes each point into
//! the part's frame,
//!
//! ```text
//! X′ = X·cos Δτ − Z·sin Δτ − ΔX,    Z′ = X·sin Δτ + Z·cos Δτ − Δz,
//! ```
//!
//! and the axial residual is e = Z′ − g(X′), where g is the height the probe reports over X′
//! on the design ([`probe`]: the surface itself for a sharp tip; for a ball of radius ρ, the
//! curve its centre follows — the surface offset by ρ along its normal — or, in `axial`
//! compensation, the surface lifted by ρ). The alignment minimises Σ wᵢ·eᵢ² (the paper's
//! eq. 3 with weights; wᵢ = 1 unless a robust loss is asked for) over the free parameters among
//! ΔX, Δτ, Δz and the vertex curvature c = 1/R ([`fit`]: Levenberg–Marquardt on analytic
//! derivatives, iteratively reweighted for Huber or Tukey losses).
//!
//! The residual e > 0 means material standing proud of the design (z points toward the tool),
//! i.e. material to remove; along the normal it is e·cos θ. [`profile`] averages the normal
//! residual of both sides of the axis onto a radial grid: that is the correction target.

pub mod fit;
pub mod probe;
pub mod profile;

pub use fit::{
    fit, fit_within, Alignment, FitError, FitOutcome, PointResidual, StandardErrors, NM_PER_MM,
};
pub use probe::Height;
pub use probe::{Compensation, Probe, ProbeError};
pub use profile::{
    form_error, radial_profile, Coverage, FormErrorSummary, RadialProfile, RadialProfileError,
};

use crate::surface::Surface;

/// A fitted parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parameter {
    LateralOffset,
    Tilt,
    Piston,
    RadiusOfCurvature,
}

impl Parameter {
    pub const ALL: [Parameter; 4] = [
        Parameter::LateralOffset,
        Parameter::Tilt,
        Parameter::Piston,
        Parameter::RadiusOfCurvature,
    ];
}

/// Which parameters the fit moves (the others stay at 0, or at the design's radius).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FitParameters {
    pub lateral_offset: bool,
    pub tilt: bool,
    pub piston: bool,
    pub radius_of_curvature: bool,
}

impl FitParameters {
    /// Lateral offset, tilt and piston — less what the surface cannot tell apart: a plane has
    /// no lateral position, and on a sphere a tilt about the vertex is a lateral offset (turning
    /// a sphere about its centre of curvature leaves it unchanged), so the tilt is left out.
    pub fn default_for(surface: &Surface) -> FitParameters {
        FitParameters {
            lateral_offset: !surface.is_plane(),
            tilt: !surface.is_sphere(),
            piston: true,
            radius_of_curvature: false,
        }
    }

    pub fn contains(&self, parameter: Parameter) -> bool {
        match parameter {
            Parameter::LateralOffset => self.lateral_offset,
            Parameter::Tilt => self.tilt,
            Parameter::Piston => self.piston,
            Parameter::RadiusOfCurvature => self.radius_of_curvature,
        }
    }

    pub fn count(&self) -> usize {
        Parameter::ALL.iter().filter(|&&p| self.contains(p)).count()
    }
}

/// The loss that weights the residuals. Thresholds are in units of the robust scale
/// σ̂ = 1.4826·median|e| of the current residuals (the usual 95 %-efficiency
/// constants for Gaussian noise).
pub use crate::lsq::RobustLoss;

/// The largest trace coordinate accepted, mm.
pub const MAX_COORDINATE_MM: f64 = 1e6;

/// Why a trace cannot be fitted as given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TraceError {
    #[error("x_mm has {x} points but z_mm has {z}")]
    LengthMismatch { x: usize, z: usize },
    /// (Larger coordinates are no probe's, and their squares overflow the fit's residual.)
    #[error("must be a finite number within ±{MAX_COORDINATE_MM} mm")]
    NonFinite { axis: TraceAxis, index: usize },
    #[error(
        "{points} points cannot determine {parameters} parameters: a fit needs at least {} \
         (one more than the parameters, so the residual has a degree of freedom)",
        parameters + 1
    )]
    TooFewPoints { points: usize, parameters: usize },
    #[error("no parameter to fit: fit at least one of the lateral offset, tilt, piston and vertex radius")]
    NothingToFit,
    #[error("{reason}")]
    Undetermined {
        parameters: Vec<Parameter>,
        reason: &'static str,
    },
    #[error("{error}")]
    OffSurface { index: usize, error: ProbeError },
}

/// A trace coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TraceAxis {
    X,
    Z,
}

/// Everything a fit needs, checked: build it with [`FitProblem::new`].
#[derive(Debug, Clone)]
pub struct FitProblem {
    surface: Surface,
    x_mm: Vec<f64>,
    z_mm: Vec<f64>,
    probe: Probe,
    parameters: FitParameters,
    robust: RobustLoss,
}

impl FitProblem {
    pub fn new(
        surface: Surface,
        x_mm: Vec<f64>,
        z_mm: Vec<f64>,
        probe: Probe,
        parameters: FitParameters,
        robust: RobustLoss,
    ) -> Result<FitProblem, TraceError> {
        if x_mm.len() != z_mm.len() {
            return Err(TraceError::LengthMismatch {
                x: x_mm.len(),
                z: z_mm.len(),
            });
        }
        for (axis, values) in [(TraceAxis::X, &x_mm), (TraceAxis::Z, &z_mm)] {
            if let Some(index) = values
                .iter()
                .position(|v| !(v.is_finite() && v.abs() <= MAX_COORDINATE_MM))
            {
                return Err(TraceError::NonFinite { axis, index });
            }
        }
        if parameters.count() == 0 {
            return Err(TraceError::NothingToFit);
        }
        if x_mm.len() <= parameters.count() {
            return Err(TraceError::TooFewPoints {
                points: x_mm.len(),
                parameters: parameters.count(),
            });
        }
        if parameters.lateral_offset && surface.is_plane() {
            return Err(TraceError::Undetermined {
                parameters: vec![Parameter::LateralOffset],
                reason: "a plane looks the same wherever its axis is: the trace cannot determine \
                         a lateral offset (do not fit the lateral offset)",
            });
        }
        if parameters.lateral_offset && parameters.tilt && surface.is_sphere() {
            return Err(TraceError::Undetermined {
                parameters: vec![Parameter::LateralOffset, Parameter::Tilt],
                reason: "on a sphere a tilt is indistinguishable from a lateral offset (turning a \
                         sphere about its centre of curvature leaves it unchanged): fit the \
                         lateral offset or the tilt, not both",
            });
        }
        // Every point must land on the design as given (the fit starts from no misalignment).
        for (index, &x) in x_mm.iter().enumerate() {
            probe
                .height(&surface, x)
                .map_err(|error| TraceError::OffSurface { index, error })?;
        }
        Ok(FitProblem {
            surface,
            x_mm,
            z_mm,
            probe,
            parameters,
            robust,
        })
    }

    pub fn surface(&self) -> &Surface {
        &self.surface
    }
    pub fn parameters(&self) -> FitParameters {
        self.parameters
    }
    pub fn points(&self) -> usize {
        self.x_mm.len()
    }
    /// The trace, (X, Z) in machine coordinates, mm.
    pub fn trace(&self) -> (&[f64], &[f64]) {
        (&self.x_mm, &self.z_mm)
    }
    pub fn probe(&self) -> Probe {
        self.probe
    }
    pub fn robust(&self) -> RobustLoss {
        self.robust
    }
}
