//! Weighted nonlinear least squares: minimise S(p) = Σ wᵢ·eᵢ(p)² by Levenberg–Marquardt, with
//! standard errors and robust reweighting. Used by the measurement fit and calibration.
//!
//! Each step solves the damped problem on the column-scaled weighted Jacobian
//! A = W^½·J·D⁻¹ (D the columns' norms) through its SVD A = U·S·Vᵀ:
//! δ̃ = −V·diag(s/(s² + λ))·Uᵀ·W^½·e, δ = D⁻¹·δ̃ (λ = 0, Gauss–Newton, tried first; λ grows
//! tenfold until the cost falls and shrinks tenfold after a success). A trial point the model
//! cannot evaluate (outside its domain) counts as a rise. It stops when the Gauss–Newton step
//! is below 1e-8 of the residual norm (plus the caller's floor per unit weight), or when no
//! step lowers the cost by more than its rounding (1e-14 relative). A singular value below 1e-10 of the largest means the data
//! cannot tell some parameters apart: the error names them (the columns of the weakest
//! singular direction), never an arbitrary answer.
//!
//! At the minimum the covariance is σ²·(JᵀWJ)⁻¹ with σ² = S/(n − m), n the points with
//! weight > 0 and m the parameters; (JᵀWJ)⁻¹ = D⁻¹·V·S⁻²·Vᵀ·D⁻¹.
//!
//! Robust losses (Huber, Tukey) reweight from the plain fit: wᵢ = ψ(eᵢ/σ̂)/(eᵢ/σ̂) with the
//! scale σ̂ = 1.4826·median|e|, refitting from the last parameters until no weight moves by
//! more than 1e-9.

use faer::Mat;

const MAX_DAMPINGS: usize = 60;
const MAX_REWEIGHTS: usize = 100;

/// How residuals are weighted against outliers, with σ̂ = 1.4826·median|e| of the current
/// residuals (the usual 95 %-efficiency constants for Gaussian noise).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RobustLoss {
    /// Plain least squares.
    #[default]
    None,
    /// Weight 1 within 1.345·σ̂, then 1.345·σ̂/|e|: spikes count, but only linearly.
    Huber,
    /// Weight (1 − (e/4.685σ̂)²)² within 4.685·σ̂, 0 beyond: spikes and dust are ignored.
    Tukey,
}

/// Residuals e(p) and their Jacobian ∂e/∂p of a model.
pub trait Model {
    type Error;
    fn parameters(&self) -> usize;
    /// The residuals at `p`, or why `p` is outside the model's domain.
    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, Self::Error>;
    /// ∂e/∂p at `p` (one row per residual), given the residuals there.
    fn jacobian(&self, p: &[f64], residuals: &[f64]) -> Result<Mat<f64>, Self::Error>;
}

/// Why a fit failed.
#[derive(Debug, Clone, PartialEq)]
pub enum LsqError<E> {
    /// The start (or the minimum's Jacobian) could not be evaluated.
    Model(E),
    NotConverged {
        steps: usize,
    },
    WeightsUnsettled {
        reweightings: usize,
    },
    /// The data cannot tell these parameters (indices) apart.
    Undetermined {
        parameters: Vec<usize>,
    },
}

/// A fitted model.
#[derive(Debug, Clone)]
pub struct Fit {
    pub parameters: Vec<f64>,
    pub residuals: Vec<f64>,
    /// The final weights (1 without a robust loss; 0 = ignored).
    pub weights: Vec<f64>,
    /// (JᵀWJ)⁻¹: the covariance is σ² times it.
    pub inverse_normal: Vec<Vec<f64>>,
    /// σ² = S/(n − m), the residual variance.
    pub variance: f64,
    /// n − m: the points with weight > 0 less the parameters.
    pub degrees_of_freedom: usize,
    /// Levenberg–Marquardt steps over all weightings.
    pub steps: usize,
    pub reweightings: usize,
    /// σ̂ of the final weights (robust losses only).
    pub robust_scale: Option<f64>,
}

impl Fit {
    /// √(σ²·(JᵀWJ)⁻¹ⱼⱼ).
    pub fn standard_error(&self, j: usize) -> f64 {
        (self.variance * self.inverse_normal[j][j]).sqrt()
    }

    /// The correlation of parameters j and k (defined by the design alone, so also for an
    /// exact fit, σ² = 0).
    pub fn correlation(&self, j: usize, k: usize) -> f64 {
        let n = &self.inverse_normal;
        n[j][k] / (n[j][j] * n[k][k]).sqrt()
    }
}

fn cost(residuals: &[f64], weights: &[f64]) -> f64 {
    residuals.iter().zip(weights).map(|(e, w)| w * e * e).sum()
}

/// The scaled weighted Jacobian's SVD, and the scales D.
struct Linearisation {
    scales: Vec<f64>,
    u: Mat<f64>,
    s: Vec<f64>,
    v: Mat<f64>,
}

fn linearise<E>(jacobian: &Mat<f64>, weights: &[f64]) -> Result<Linearisation, LsqError<E>> {
    let (n, m) = (jacobian.nrows(), jacobian.ncols());
    let scales: Vec<f64> = (0..m)
        .map(|j| {
            (0..n)
                .map(|i| weights[i] * jacobian[(i, j)] * jacobian[(i, j)])
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    if let Some(j) = scales.iter().position(|&d| !(d > 0.0 && d.is_finite())) {
        return Err(LsqError::Undetermined {
            parameters: vec![j],
        });
    }
    let a = Mat::from_fn(n, m, |i, j| {
        weights[i].sqrt() * jacobian[(i, j)] / scales[j]
    });
    let svd = a
        .thin_svd()
        .map_err(|_| LsqError::NotConverged { steps: 0 })?;
    let s: Vec<f64> = (0..m).map(|k| svd.S().column_vector()[k]).collect();
    let (largest, smallest) = s
        .iter()
        .fold((0f64, f64::INFINITY), |(hi, lo), &x| (hi.max(x), lo.min(x)));
    let v = svd.V().to_owned();
    if smallest.is_nan() || smallest <= 1e-10 * largest {
        let k = (0..m)
            .min_by(|&a, &b| s[a].total_cmp(&s[b]))
            .expect("at least one parameter");
        let parameters = (0..m).filter(|&j| v[(j, k)].abs() > 0.2).collect();
        return Err(LsqError::Undetermined { parameters });
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

    /// (JᵀWJ)⁻¹.
    fn inverse_normal_matrix(&self) -> Vec<Vec<f64>> {
        let m = self.s.len();
        (0..m)
            .map(|j| {
                (0..m)
                    .map(|k| {
                        (0..m)
                            .map(|l| self.v[(j, l)] * self.v[(k, l)] / (self.s[l] * self.s[l]))
                            .sum::<f64>()
                            / (self.scales[j] * self.scales[k])
                    })
                    .collect()
            })
            .collect()
    }
}

/// A minimum: the parameters, the residuals there and the steps taken.
type Minimum = (Vec<f64>, Vec<f64>, usize);

/// Weighted least squares from `start`.
fn least_squares<M: Model>(
    model: &M,
    weights: &[f64],
    start: Vec<f64>,
    max_steps: usize,
    floor: f64,
) -> Result<Minimum, LsqError<M::Error>> {
    let total_weight: f64 = weights.iter().sum();
    let mut p = start;
    let mut residuals = model.residuals(&p).map_err(LsqError::Model)?;
    let mut current = cost(&residuals, weights);
    let mut lambda = 0.0;
    for steps in 1..=max_steps {
        let jacobian = model.jacobian(&p, &residuals).map_err(LsqError::Model)?;
        let lin = linearise(&jacobian, weights)?;
        let r: Vec<f64> = residuals
            .iter()
            .zip(weights)
            .map(|(e, w)| w.sqrt() * e)
            .collect();
        let projected: Vec<f64> = (0..lin.s.len())
            .map(|l| (0..r.len()).map(|i| lin.u[(i, l)] * r[i]).sum())
            .collect();
        let gauss_newton = lin.step(&projected, 0.0);
        let size = gauss_newton.iter().map(|d| d * d).sum::<f64>().sqrt();
        if size <= 1e-8 * current.sqrt() + floor * total_weight.sqrt() {
            return Ok((p, residuals, steps - 1));
        }
        let s_max2 = lin.s.iter().fold(0f64, |a, &s| a.max(s * s));
        let mut accepted = false;
        for _ in 0..MAX_DAMPINGS {
            let step = if lambda == 0.0 {
                gauss_newton.clone()
            } else {
                lin.step(&projected, lambda)
            };
            let trial: Vec<f64> = p
                .iter()
                .zip(&step)
                .zip(&lin.scales)
                .map(|((x, d), s)| x + d / s)
                .collect();
            if let Ok(next) = model.residuals(&trial) {
                let next_cost = cost(&next, weights);
                if next_cost < current {
                    let stalled = current - next_cost <= 1e-14 * current;
                    (p, residuals, current) = (trial, next, next_cost);
                    if stalled {
                        return Ok((p, residuals, steps));
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
            // No damping lowers the cost: the minimum, to rounding.
            return Ok((p, residuals, steps));
        }
        lambda = if lambda <= 1e-9 * s_max2 {
            0.0
        } else {
            lambda / 10.0
        };
    }
    Err(LsqError::NotConverged { steps: max_steps })
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// σ̂ = 1.4826·median|e| (about 0, not the median: the model's residuals should centre on 0,
/// and a fit pulled off by spikes must see its good points as off, so that it moves back).
pub fn robust_scale(residuals: &[f64]) -> f64 {
    let mut deviations: Vec<f64> = residuals.iter().map(|x| x.abs()).collect();
    1.4826 * median(&mut deviations)
}

/// The weight of a residual of `u` robust scales.
pub fn robust_weight(loss: RobustLoss, u: f64) -> f64 {
    let u = u.abs();
    match loss {
        RobustLoss::None => 1.0,
        RobustLoss::Huber => {
            if u <= 1.345 {
                1.0
            } else {
                1.345 / u
            }
        }
        RobustLoss::Tukey => {
            if u < 4.685 {
                let t = 1.0 - (u / 4.685).powi(2);
                t * t
            } else {
                0.0
            }
        }
    }
}

/// Fits `model` from `start` under `loss`, at most `max_steps` steps per weighting; a
/// Gauss–Newton step below `floor` (residual units per unit weight) also ends it.
pub fn fit<M: Model>(
    model: &M,
    start: Vec<f64>,
    points: usize,
    loss: RobustLoss,
    max_steps: usize,
    floor: f64,
) -> Result<Fit, LsqError<M::Error>> {
    let mut weights = vec![1.0; points];
    let (mut p, mut residuals, mut steps) =
        least_squares(model, &weights, start, max_steps, floor)?;
    let mut reweightings = 0;
    let mut robust_scale_found = None;
    if loss != RobustLoss::None {
        loop {
            let sigma = robust_scale(&residuals);
            if sigma.is_nan() || sigma <= 0.0 {
                break; // an exact fit: nothing to reweight
            }
            robust_scale_found = Some(sigma);
            let next: Vec<f64> = residuals
                .iter()
                .map(|e| robust_weight(loss, e / sigma))
                .collect();
            let moved = next
                .iter()
                .zip(&weights)
                .fold(0f64, |m, (a, b)| m.max((a - b).abs()));
            if moved <= 1e-9 {
                break;
            }
            if reweightings == MAX_REWEIGHTS {
                return Err(LsqError::WeightsUnsettled { reweightings });
            }
            weights = next;
            reweightings += 1;
            let (q, e, more) = least_squares(model, &weights, p, max_steps, floor)?;
            (p, residuals, steps) = (q, e, steps + more);
        }
    }
    let jacobian = model.jacobian(&p, &residuals).map_err(LsqError::Model)?;
    let lin = linearise(&jacobian, &weights)?;
    let kept = weights.iter().filter(|&&w| w > 0.0).count();
    let degrees_of_freedom = kept.saturating_sub(model.parameters());
    let variance = cost(&residuals, &weights) / degrees_of_freedom.max(1) as f64;
    Ok(Fit {
        parameters: p,
        residuals,
        weights,
        inverse_normal: lin.inverse_normal_matrix(),
        variance,
        degrees_of_freedom,
        steps,
        reweightings,
        robust_scale: robust_scale_found,
    })
}

/// The two-sided 95 % quantile of Student's t with `dof` degrees of freedom, by the
/// Cornish–Fisher expansion about the normal's 1.959964 to 1/dof⁴ (within 3e-4 for dof ≥ 5,
/// 1e-5 for dof ≥ 10, 4e-3 at 3; the normal's for dof = 0, where no interval means anything).
pub fn t_quantile_95(dof: usize) -> f64 {
    let z: f64 = 1.959_963_984_540_054;
    if dof == 0 {
        return z;
    }
    let n = dof as f64;
    let (z3, z5, z7, z9) = (z.powi(3), z.powi(5), z.powi(7), z.powi(9));
    z + (z3 + z) / (4.0 * n)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * n * n)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * n.powi(3))
        + (79.0 * z9 + 776.0 * z7 + 1482.0 * z5 - 1920.0 * z3 - 945.0 * z) / (92160.0 * n.powi(4))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a·exp(−b·x) sampled without noise: the fit recovers (a, b) to rounding; with one
    /// parameter absent from the model the error names it.
    struct Decay {
        x: Vec<f64>,
        y: Vec<f64>,
        ignore_b: bool,
    }

    impl Model for Decay {
        type Error = ();
        fn parameters(&self) -> usize {
            2
        }
        fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, ()> {
            let b = if self.ignore_b { 0.5 } else { p[1] };
            Ok(self
                .x
                .iter()
                .zip(&self.y)
                .map(|(x, y)| y - p[0] * (-b * x).exp())
                .collect())
        }
        fn jacobian(&self, p: &[f64], _: &[f64]) -> Result<Mat<f64>, ()> {
            Ok(Mat::from_fn(self.x.len(), 2, |i, j| {
                let x = self.x[i];
                let e = (-p[1] * x).exp();
                match (j, self.ignore_b) {
                    (0, _) => -e,
                    (_, true) => 0.0,
                    _ => p[0] * x * e,
                }
            }))
        }
    }

    #[test]
    fn recovers_an_exact_model_and_names_what_the_data_cannot_fix() {
        let x: Vec<f64> = (0..20).map(|i| i as f64 * 0.25).collect();
        let y = x.iter().map(|x| 3.0 * (-0.7 * x).exp()).collect();
        let model = Decay {
            x,
            y,
            ignore_b: false,
        };
        let fit = fit(&model, vec![1.0, 0.2], 20, RobustLoss::None, 100, 0.0).unwrap();
        assert!(
            (fit.parameters[0] - 3.0).abs() < 1e-12,
            "{:?}",
            fit.parameters
        );
        assert!(
            (fit.parameters[1] - 0.7).abs() < 1e-12,
            "{:?}",
            fit.parameters
        );
        let blind = Decay {
            ignore_b: true,
            ..model
        };
        let err = super::fit(&blind, vec![1.0, 0.2], 20, RobustLoss::None, 100, 0.0).unwrap_err();
        assert_eq!(
            err,
            LsqError::Undetermined {
                parameters: vec![1]
            }
        );
    }

    /// Against tabulated t quantiles (0.975): 12.706 (1), 2.571 (5), 2.228 (10), 2.042 (30),
    /// 1.984 (100).
    #[test]
    fn t_quantiles_match_the_tables() {
        for (dof, want, tol) in [
            (5, 2.570_582, 3e-4),
            (10, 2.228_139, 1e-5),
            (30, 2.042_272, 1e-6),
            (100, 1.983_972, 1e-6),
        ] {
            let got = t_quantile_95(dof);
            assert!((got - want).abs() < tol, "{dof}: {got} vs {want}");
        }
    }
}
