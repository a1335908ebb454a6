//! The alignment fit: minimise Σ wᵢ·eᵢ(p)² over the free parameters p ⊆ (ΔX, Δτ, Δz, c).
//!
//! With X′, Z′ from the paper's eq. 2 and g the probe's height over the design ([`super::probe`]),
//! e = Z′ − g(X′) has the analytic derivatives
//!
//! ```text
//! ∂e/∂ΔX = g′(X′),   ∂e/∂Δτ = (X′ + ΔX) + g′(X′)·(Z′ + Δz),   ∂e/∂Δz = −1,   ∂e/∂c = −∂z/∂c(r)
//! ```
//!
//! (r the contact radius). The fit is weighted least squares on these ([`crate::lsq`]:
//! Levenberg–Marquardt through the SVD of the column-scaled Jacobian, robust reweighting,
//! standard errors √(σ²·(JᵀWJ)⁻¹ⱼⱼ) with σ² over n − m). A step is kept only if it lowers the
//! cost and keeps every point on the design. A trace that cannot tell some parameters apart
//! is an error naming them, never an arbitrary answer. The vertex radius's standard error
//! comes from the curvature's by the delta method, σ_R = σ_c/c².

use faer::Mat;

use crate::lsq::{self, LsqError, Model};

use super::probe::{Probe, ProbeError};
use super::{FitProblem, Parameter};
use crate::surface::Surface;

const MAX_STEPS: usize = 200;
/// A Gauss–Newton step below this residual norm per unit weight (mm) counts as converged:
/// an exact trace's cost sits at rounding.
const RESIDUAL_FLOOR_MM: f64 = 1e-13;

/// The part's placement in the machine, and the design with the fitted radius.
#[derive(Debug, Clone, PartialEq)]
pub struct Alignment {
    pub lateral_offset_mm: f64,
    pub tilt_rad: f64,
    pub piston_mm: f64,
    /// The design surface, with the fitted vertex radius when the radius was fitted.
    pub surface: Surface,
}

/// One trace point after the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointResidual {
    pub x_mm: f64,
    pub z_mm: f64,
    /// X′, the point's abscissa in the part's frame.
    pub aligned_x_mm: f64,
    /// Signed radius on the design where the probe touches.
    pub contact_mm: f64,
    /// e = Z′ − g(X′), mm (> 0: material proud of the design).
    pub axial_mm: f64,
    /// e·cos θ, the residual along the surface normal, mm.
    pub normal_mm: f64,
    /// The point's weight in the final fit (1 without a robust loss; 0 = ignored).
    pub weight: f64,
}

/// The standard errors of the alignment, √(σ²·(JᵀWJ)⁻¹ⱼⱼ); `None` for a parameter held
/// fixed. The vertex radius's is in mm, from the curvature's by the delta method.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StandardErrors {
    pub lateral_offset_mm: Option<f64>,
    pub tilt_rad: Option<f64>,
    pub piston_mm: Option<f64>,
    pub radius_of_curvature_mm: Option<f64>,
}

/// Nanometres in a millimetre: traces are in mm, form errors are reported in nm.
pub const NM_PER_MM: f64 = 1e6;

impl PointResidual {
    /// The axial residual, nm.
    pub fn axial_nm(&self) -> f64 {
        self.axial_mm * NM_PER_MM
    }

    /// The residual along the surface normal, nm.
    pub fn normal_nm(&self) -> f64 {
        self.normal_mm * NM_PER_MM
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct FitOutcome {
    pub alignment: Alignment,
    pub standard_errors: StandardErrors,
    pub points: Vec<PointResidual>,
    /// Levenberg–Marquardt steps taken, over all reweightings.
    pub iterations: usize,
    /// Reweightings of a robust loss (0 without one).
    pub reweightings: usize,
    /// The robust scale σ̂ of the final weights, mm (`None` without a robust loss).
    pub robust_scale_mm: Option<f64>,
}

/// Why a fit did not produce an alignment.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("the fit did not converge within {steps} steps")]
    NotConverged { steps: usize },
    #[error("the robust reweighting did not settle within {reweightings} rounds")]
    WeightsUnsettled { reweightings: usize },
    #[error("the trace does not determine these parameters (they trade off against each other)")]
    Undetermined { parameters: Vec<Parameter> },
    #[error("the fit moved point {index} off the design: {error}")]
    LeftSurface { index: usize, error: ProbeError },
}

/// [ΔX, Δτ, Δz, c].
type Params = [f64; 4];

struct Evaluation {
    residual: Vec<f64>,
    /// Rows of ∂e/∂p over all four parameters.
    jacobian: Vec<[f64; 4]>,
    /// X′ of each point.
    aligned: Vec<f64>,
    /// Where the probe touches the design.
    contact: Vec<f64>,
}

impl Evaluation {
    /// The per-point report, built once for the answer (not on every trial step).
    fn points(&self, problem: &FitProblem, weights: &[f64]) -> Vec<PointResidual> {
        (0..self.residual.len())
            .map(|i| {
                let e = self.residual[i];
                PointResidual {
                    x_mm: problem.x_mm[i],
                    z_mm: problem.z_mm[i],
                    aligned_x_mm: self.aligned[i],
                    contact_mm: self.contact[i],
                    axial_mm: e,
                    normal_mm: e / self.jacobian[i][0].hypot(1.0), // e·cos θ, z′ = ∂e/∂ΔX
                    weight: weights[i],
                }
            })
            .collect()
    }
}

fn surface_at(problem: &FitProblem, p: &Params) -> Surface {
    if problem.parameters.radius_of_curvature {
        problem.surface.with_vertex_curvature(p[3])
    } else {
        problem.surface.clone()
    }
}

fn evaluate(problem: &FitProblem, p: &Params) -> Result<Evaluation, FitError> {
    let [dx, tau, dz, _] = *p;
    let surface = surface_at(problem, p);
    let probe: &Probe = &problem.probe;
    let (sin, cos) = tau.sin_cos();
    let n = problem.x_mm.len();
    let mut residual = Vec::with_capacity(n);
    let mut jacobian = Vec::with_capacity(n);
    let mut aligned = Vec::with_capacity(n);
    let mut contact = Vec::with_capacity(n);
    for (index, (&x, &z)) in problem.x_mm.iter().zip(&problem.z_mm).enumerate() {
        let xa = x * cos - z * sin - dx;
        let za = x * sin + z * cos - dz;
        let h = probe
            .height(&surface, xa)
            .map_err(|error| FitError::LeftSurface { index, error })?;
        let e = za - h.height_mm;
        residual.push(e);
        jacobian.push([
            h.slope,
            (xa + dx) + h.slope * (za + dz),
            -1.0,
            -surface.sag_derivative_by_curvature(h.contact_mm),
        ]);
        aligned.push(xa);
        contact.push(h.contact_mm);
    }
    Ok(Evaluation {
        residual,
        jacobian,
        aligned,
        contact,
    })
}

/// The fit as [`lsq`] sees it: the free parameters only, the others held at `start`.
struct AlignmentModel<'a> {
    problem: &'a FitProblem,
    free: &'a [usize],
    start: Params,
}

impl AlignmentModel<'_> {
    fn params(&self, p: &[f64]) -> Params {
        let mut all = self.start;
        for (&j, &x) in self.free.iter().zip(p) {
            all[j] = x;
        }
        all
    }
}

impl Model for AlignmentModel<'_> {
    type Error = FitError;

    fn parameters(&self) -> usize {
        self.free.len()
    }

    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, FitError> {
        Ok(evaluate(self.problem, &self.params(p))?.residual)
    }

    fn jacobian(&self, p: &[f64], _: &[f64]) -> Result<Mat<f64>, FitError> {
        let eval = evaluate(self.problem, &self.params(p))?;
        Ok(Mat::from_fn(
            eval.jacobian.len(),
            self.free.len(),
            |i, k| eval.jacobian[i][self.free[k]],
        ))
    }
}

/// Fits the alignment (and optionally the radius) of a checked problem.
pub fn fit(problem: &FitProblem) -> Result<FitOutcome, FitError> {
    fit_within(problem, MAX_STEPS)
}

/// [`fit`] with at most `max_steps` Levenberg–Marquardt steps per weighting.
pub fn fit_within(problem: &FitProblem, max_steps: usize) -> Result<FitOutcome, FitError> {
    let free: Vec<usize> = (0..4)
        .filter(|&j| problem.parameters.contains(Parameter::ALL[j]))
        .collect();
    let start = [0.0, 0.0, 0.0, problem.surface.vertex_curvature_per_mm()];
    let model = AlignmentModel {
        problem,
        free: &free,
        start,
    };
    let first: Vec<f64> = free.iter().map(|&j| start[j]).collect();
    let n = problem.x_mm.len();
    let found = lsq::fit(
        &model,
        first,
        n,
        problem.robust,
        max_steps,
        RESIDUAL_FLOOR_MM,
    )
    .map_err(|e| match e {
        LsqError::Model(e) => e,
        LsqError::NotConverged { steps } => FitError::NotConverged { steps },
        LsqError::WeightsUnsettled { reweightings } => FitError::WeightsUnsettled { reweightings },
        LsqError::Undetermined { parameters } => FitError::Undetermined {
            parameters: parameters
                .iter()
                .map(|&k| Parameter::ALL[free[k]])
                .collect(),
        },
    })?;
    let p = model.params(&found.parameters);
    let eval = evaluate(problem, &p)?;
    let mut standard_errors = StandardErrors::default();
    for (k, &j) in free.iter().enumerate() {
        let se = found.standard_error(k);
        let e = &mut standard_errors;
        match Parameter::ALL[j] {
            Parameter::LateralOffset => e.lateral_offset_mm = Some(se),
            Parameter::Tilt => e.tilt_rad = Some(se),
            Parameter::Piston => e.piston_mm = Some(se),
            // The fit's parameter is the curvature c = 1/R: σ_R = σ_c / c².
            Parameter::RadiusOfCurvature => {
                e.radius_of_curvature_mm = (p[3] != 0.0).then(|| se / (p[3] * p[3]))
            }
        }
    }
    let (iterations, reweightings, scale, weights) = (
        found.steps,
        found.reweightings,
        found.robust_scale,
        found.weights,
    );
    Ok(FitOutcome {
        alignment: Alignment {
            lateral_offset_mm: p[0],
            tilt_rad: p[1],
            piston_mm: p[2],
            surface: surface_at(problem, &p),
        },
        standard_errors,
        points: eval.points(problem, &weights),
        iterations,
        reweightings,
        robust_scale_mm: scale,
    })
}
