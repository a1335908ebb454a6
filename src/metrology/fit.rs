//! The alignment fit: minimise Σ wᵢ·eᵢ(p)² over the free parameters p ⊆ (ΔX, Δτ, Δz, c).
//!
//! With X′, Z′ from the paper's eq. 2 and g the probe's height over the design ([`super::probe`]),
//! e = Z′ − g(X′) has the analytic derivatives
//!
//! ```text
//! ∂e/∂ΔX = g′(X′),   ∂e/∂Δτ = (X′ + ΔX) + g′(X′)·(Z′ + Δz),   ∂e/∂Δz = −1,   ∂e/∂c = −∂z/∂c(r)
//! ```
//!
//! (r the contact radius). Each Levenberg–Marquardt step solves the damped least-squares problem
//! on the column-scaled weighted Jacobian A = W^½·J·D⁻¹ through its SVD A = U·S·Vᵀ:
//! δ̃ = −V·diag(s/(s² + λ))·Uᵀ·W^½·e, δ = D⁻¹·δ̃ (λ = 0 is the Gauss–Newton step, tried first).
//! A step is kept only if it lowers the cost and keeps every point on the design; it stops when
//! the Gauss–Newton step is below 1e-8 of the residual norm (plus 1e-13 mm per unit weight), or
//! when no step lowers the cost by more than its rounding (1e-14 relative).
//! A singular value below 1e-10 of the largest means the trace cannot tell some parameters
//! apart: that is an error naming them, never an arbitrary answer.
//!
//! Standard errors are √(σ²·(JᵀWJ)⁻¹ⱼⱼ) with σ² = Σwᵢeᵢ²/(n − m), n the points with weight > 0
//! and m the free parameters (for robust losses, the usual approximation at the final weights).
//! A robust loss reweights from the plain fit with the scale σ̂ = 1.4826·median|e|,
//! refitting from the last parameters until no weight moves by more than 1e-9.

use faer::Mat;

use super::probe::{Probe, ProbeError};
use super::{FitProblem, Parameter, RobustLoss};
use crate::lsq::{robust_scale, robust_weight};
use crate::surface::Surface;

const MAX_STEPS: usize = 200;
const MAX_REWEIGHTS: usize = 100;
const MAX_DAMPINGS: usize = 60;

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

fn cost(residual: &[f64], weights: &[f64]) -> f64 {
    residual.iter().zip(weights).map(|(e, w)| w * e * e).sum()
}

/// The scaled weighted Jacobian's SVD, and the scales D.
struct Linearisation {
    scales: Vec<f64>,
    u: Mat<f64>,
    s: Vec<f64>,
    v: Mat<f64>,
}

fn linearise(
    eval: &Evaluation,
    weights: &[f64],
    free: &[usize],
) -> Result<Linearisation, FitError> {
    let n = eval.residual.len();
    let scales: Vec<f64> = free
        .iter()
        .map(|&j| {
            eval.jacobian
                .iter()
                .zip(weights)
                .map(|(row, w)| w * row[j] * row[j])
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    if let Some(k) = scales.iter().position(|&d| !(d > 0.0 && d.is_finite())) {
        return Err(FitError::Undetermined {
            parameters: vec![Parameter::ALL[free[k]]],
        });
    }
    let a = Mat::from_fn(n, free.len(), |i, k| {
        weights[i].sqrt() * eval.jacobian[i][free[k]] / scales[k]
    });
    let svd = a
        .thin_svd()
        .map_err(|_| FitError::NotConverged { steps: 0 })?;
    let s: Vec<f64> = (0..free.len())
        .map(|k| svd.S().column_vector()[k])
        .collect();
    let (largest, smallest) = s
        .iter()
        .fold((0f64, f64::INFINITY), |(hi, lo), &x| (hi.max(x), lo.min(x)));
    let v = svd.V().to_owned();
    if smallest.is_nan() || smallest <= 1e-10 * largest {
        let k = (0..free.len())
            .min_by(|&a, &b| s[a].total_cmp(&s[b]))
            .expect("at least one parameter");
        let parameters = (0..free.len())
            .filter(|&j| v[(j, k)].abs() > 0.2)
            .map(|j| Parameter::ALL[free[j]])
            .collect();
        return Err(FitError::Undetermined { parameters });
    }
    Ok(Linearisation {
        scales,
        u: svd.U().to_owned(),
        s,
        v,
    })
}

impl Linearisation {
    /// The damped step in scaled coordinates, δ̃ = −V·diag(s/(s² + λ))·Uᵀ·r.
    fn step(&self, projected: &[f64], lambda: f64) -> Vec<f64> {
        let m = self.s.len();
        (0..m)
            .map(|j| {
                -(0..m)
                    .map(|l| {
                        self.v[(j, l)] * self.s[l] / (self.s[l] * self.s[l] + lambda) * projected[l]
                    })
                    .sum::<f64>()
            })
            .collect()
    }

    /// (JᵀWJ)⁻¹ⱼⱼ for the free parameter j.
    fn covariance_diagonal(&self, j: usize) -> f64 {
        let m = self.s.len();
        (0..m)
            .map(|l| (self.v[(j, l)] / self.s[l]).powi(2))
            .sum::<f64>()
            / (self.scales[j] * self.scales[j])
    }
}

/// Weighted least squares from `start`: the parameters, the evaluation there, the steps taken.
fn least_squares(
    problem: &FitProblem,
    weights: &[f64],
    start: Params,
    free: &[usize],
    max_steps: usize,
) -> Result<(Params, Evaluation, usize), FitError> {
    let mut p = start;
    let mut eval = evaluate(problem, &p)?;
    let mut current = cost(&eval.residual, weights);
    let total_weight: f64 = weights.iter().sum();
    let mut lambda = 0.0;
    for steps in 1..=max_steps {
        let lin = linearise(&eval, weights, free)?;
        let r: Vec<f64> = eval
            .residual
            .iter()
            .zip(weights)
            .map(|(e, w)| w.sqrt() * e)
            .collect();
        let projected: Vec<f64> = (0..free.len())
            .map(|l| (0..r.len()).map(|i| lin.u[(i, l)] * r[i]).sum())
            .collect();
        let gauss_newton = lin.step(&projected, 0.0);
        let size = gauss_newton.iter().map(|d| d * d).sum::<f64>().sqrt();
        if size <= 1e-8 * current.sqrt() + 1e-13 * total_weight.sqrt() {
            return Ok((p, eval, steps - 1));
        }
        let s_max2 = lin.s.iter().fold(0f64, |a, &s| a.max(s * s));
        let mut accepted = false;
        for _ in 0..MAX_DAMPINGS {
            let step = if lambda == 0.0 {
                gauss_newton.clone()
            } else {
                lin.step(&projected, lambda)
            };
            let mut trial = p;
            for (k, &j) in free.iter().enumerate() {
                trial[j] += step[k] / lin.scales[k];
            }
            if let Ok(next) = evaluate(problem, &trial) {
                let next_cost = cost(&next.residual, weights);
                if next_cost < current {
                    let stalled = current - next_cost <= 1e-14 * current;
                    (p, eval, current) = (trial, next, next_cost);
                    if stalled {
                        // Less than rounding's worth of progress: this is the minimum.
                        return Ok((p, eval, steps));
                    }
                    accepted = true;
                    break;
                }
            }
            lambda = if lambda == 0.0 {
                1e-6 * s_max2
            } else {
                lambda * 10.0
            };
        }
        if !accepted {
            // No damping lowers the cost: we are at the minimum to rounding.
            return Ok((p, eval, steps));
        }
        lambda = if lambda <= 1e-9 * s_max2 {
            0.0
        } else {
            lambda / 10.0
        };
    }
    Err(FitError::NotConverged { steps: max_steps })
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
    let mut weights = vec![1.0; problem.x_mm.len()];
    let (mut p, mut eval, mut iterations) =
        least_squares(problem, &weights, start, &free, max_steps)?;
    let mut reweightings = 0;
    let mut scale = None;
    if problem.robust != RobustLoss::None {
        loop {
            let sigma = robust_scale(&eval.residual);
            if sigma.is_nan() || sigma <= 0.0 {
                break; // an exact fit: nothing to reweight
            }
            scale = Some(sigma);
            let next: Vec<f64> = eval
                .residual
                .iter()
                .map(|e| robust_weight(problem.robust, e / sigma))
                .collect();
            let moved = next
                .iter()
                .zip(&weights)
                .fold(0f64, |m, (a, b)| m.max((a - b).abs()));
            if moved <= 1e-9 {
                break;
            }
            if reweightings == MAX_REWEIGHTS {
                return Err(FitError::WeightsUnsettled { reweightings });
            }
            weights = next;
            reweightings += 1;
            let (q, e, steps) = least_squares(problem, &weights, p, &free, max_steps)?;
            (p, eval, iterations) = (q, e, iterations + steps);
        }
    }
    let lin = linearise(&eval, &weights, &free)?;
    let kept = weights.iter().filter(|&&w| w > 0.0).count();
    let variance = cost(&eval.residual, &weights) / (kept.saturating_sub(free.len()).max(1)) as f64;
    let mut standard_errors = StandardErrors::default();
    for (k, &j) in free.iter().enumerate() {
        let se = (variance * lin.covariance_diagonal(k)).sqrt();
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
