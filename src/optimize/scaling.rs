//! The QP's scales, and J evaluated from its documented formula in them.
//!
//! Depths are measured in d̄ (the target's RMS over the aperture's m rows, or what the
//! caller's extra floors remove when that is more; 1 nm for a target below 1e-6 nm) and dwell in τ = d̄/ā, ā being the mean removal rate of one second at every
//! position over those rows; so the scaled dwell x = t/τ and the scaled fit are of order one
//! whatever the units ([`super`] states J).

use super::dwell::DwellProblem;
use super::operator::Band;
use super::problem::OptimizeError;

/// Depth and dwell scales and the scaled weights.
pub(super) struct Scales {
    pub(super) m: f64,
    pub(super) n: f64,
    /// ā, nm/s.
    pub(super) rate: f64,
    pub(super) depth_nm: f64,
    pub(super) dwell_s: f64,
    /// λ·r_t⁴/(n − 2): the smoothing weight on Σ (x'')².
    pub(super) smoothing: f64,
}

impl Scales {
    /// The scales of `problem` from its operator's columns on the aperture's rows (`band`):
    /// refused when one second at every position removes nothing there.
    pub(super) fn of(problem: &DwellProblem, band: &Band) -> Result<Scales, OptimizeError> {
        let n = problem.motion.len();
        let m = problem.rows.len() as f64;
        let rate = (0..n).map(|j| band.column_sum(j)).sum::<f64>() / m;
        if rate.is_nan() || rate <= 0.0 {
            return Err(OptimizeError::NoRemovalInAperture);
        }
        let rms = (problem.target_nm.iter().map(|d| d * d).sum::<f64>() / m).sqrt();
        // Floors a caller adds can ask for far more than the target (a polar plan's C law
        // over a target whose mean is flat): the depth they remove then sets the scale.
        let floored =
            rate * problem.extra_floors.iter().map(|f| f.dwell_s).sum::<f64>() / n.max(1) as f64;
        // Below a femtometre a target is rounding (a plane fitted and removed), not a depth.
        let depth_nm = if rms.max(floored) > 1e-6 {
            rms.max(floored)
        } else {
            1.0
        };
        let rt = problem.tool_radius_mm;
        Ok(Scales {
            m,
            n: n as f64,
            rate,
            depth_nm,
            dwell_s: depth_nm / rate,
            smoothing: if n > 2 {
                problem.objective.smoothing * rt.powi(4) / (n - 2) as f64
            } else {
                0.0
            },
        })
    }
}

/// D2: the second divided differences on the positions, one row (3 coefficients, 1/mm²) per
/// interior position.
pub(super) fn second_differences(radii_mm: &[f64]) -> Vec<[f64; 3]> {
    radii_mm
        .windows(3)
        .map(|w| {
            let (h0, h1) = (w[1] - w[0], w[2] - w[1]);
            [
                2.0 / (h0 * (h0 + h1)),
                -2.0 / (h0 * h1),
                2.0 / (h1 * (h0 + h1)),
            ]
        })
        .collect()
}

/// Evaluates J at dwell `t` (s) and piston `p` (nm): the reported objective, from the
/// documented formula rather than the QP's scaled terms.
pub(super) fn objective_value(
    problem: &DwellProblem,
    band: &Band,
    s: &Scales,
    t: &[f64],
    p: f64,
) -> f64 {
    let rows = &problem.rows;
    let mut removal = vec![0.0; rows.len()];
    for (j, &tj) in t.iter().enumerate() {
        let from = band.start[j] - rows.start;
        for (o, m) in removal[from..].iter_mut().zip(band.values[j].iter()) {
            *o += m * tj;
        }
    }
    let fit: f64 = removal
        .iter()
        .zip(problem.target_nm)
        .map(|(z, d)| ((z - d - p) / s.depth_nm).powi(2))
        .sum::<f64>()
        / (2.0 * s.m);
    let x: Vec<f64> = t.iter().map(|v| v / s.dwell_s).collect();
    let smooth: f64 = second_differences(problem.motion.radii_mm())
        .iter()
        .zip(x.windows(3))
        .map(|(c, w)| (c[0] * w[0] + c[1] * w[1] + c[2] * w[2]).powi(2))
        .sum::<f64>()
        * s.smoothing
        / 2.0;
    let time = problem.objective.time_weight * x.iter().sum::<f64>() / s.n;
    fit + smooth + time
}
