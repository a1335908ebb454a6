//! From per-point residuals to a radial form-error profile and its figures.
//!
//! The normal residual E(x) along the signed meridian coordinate x (the contact radius) is
//! smoothed by local linear regression with the biweight kernel (1 − ((x − x₀)/h)²)², each point
//! also carrying its fit weight, over a half-width h = max(grid step, 2.5 × the trace's mean point
//! spacing): unbiased for a linear trend, so the profile keeps its level at the ends of the trace,
//! and it averages the noise of the ~5 or more points under the kernel. The profile at radius ρ
//! is the mean of E(+ρ) and E(−ρ) over the sides the trace covers; where it covers both, the RMS
//! of E(+ρ) − E(−ρ) over the grid is the asymmetry, which a rotationally symmetric process cannot
//! correct.
//!
//! The form error's RMS and PV are the paper's eq. 3 figures over the points kept by the fit
//! (weight > 0) whose contact radius lies in the clear aperture, from the axial residual.

use super::fit::PointResidual;
use crate::field::DepthProfile;
use crate::physics::{ClearAperture, RadialGrid};

/// The signed extent of the kept points' contact radii, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coverage {
    pub min_mm: f64,
    pub max_mm: f64,
}

impl Coverage {
    /// The kept points' extent; `None` when no point has weight.
    pub fn of(points: &[PointResidual]) -> Option<Coverage> {
        let kept = points
            .iter()
            .filter(|p| p.weight > 0.0)
            .map(|p| p.contact_mm);
        kept.fold(None, |c: Option<Coverage>, x| {
            Some(match c {
                None => Coverage {
                    min_mm: x,
                    max_mm: x,
                },
                Some(c) => Coverage {
                    min_mm: c.min_mm.min(x),
                    max_mm: c.max_mm.max(x),
                },
            })
        })
    }

    /// The radii some side covers, [start, stop]: from the axis out when the trace crosses it.
    pub fn radial_span_mm(&self) -> (f64, f64) {
        if self.min_mm <= 0.0 && self.max_mm >= 0.0 {
            (0.0, self.max_mm.max(-self.min_mm))
        } else if self.min_mm > 0.0 {
            (self.min_mm, self.max_mm)
        } else {
            (-self.max_mm, -self.min_mm)
        }
    }

    fn contains(&self, x: f64) -> bool {
        let slack = 1e-12 * self.max_mm.abs().max(self.min_mm.abs());
        x >= self.min_mm - slack && x <= self.max_mm + slack
    }
}

/// The form error on a radial grid.
#[derive(Debug, Clone, PartialEq)]
pub struct RadialProfile {
    /// Along the normal, nm; > 0 = material to remove.
    pub depth: DepthProfile,
    /// RMS of E(+ρ) − E(−ρ) where the trace covers both sides (at two samples or more), nm.
    pub asymmetry_rms_nm: Option<f64>,
}

/// Why the profile cannot be formed on the grid asked for.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RadialProfileError {
    #[error("the fit kept no point")]
    NoPoints,
    #[error(
        "the radial grid reaches r = {radius_mm} mm, where the trace has no point on either side \
         (it covers x from {min_mm} to {max_mm} mm)"
    )]
    NotCovered {
        radius_mm: f64,
        min_mm: f64,
        max_mm: f64,
    },
    #[error("no trace point kept by the fit lies in the clear aperture")]
    ApertureEmpty,
}

/// Local linear smoother over the sorted kept points.
struct Smoother {
    x: Vec<f64>,
    y: Vec<f64>,
    w: Vec<f64>,
    half_width: f64,
}

impl Smoother {
    fn new(points: &[PointResidual], grid_step: f64) -> Smoother {
        let mut kept: Vec<(f64, f64, f64)> = points
            .iter()
            .filter(|p| p.weight > 0.0)
            .map(|p| (p.contact_mm, p.normal_nm(), p.weight))
            .collect();
        kept.sort_by(|a, b| a.0.total_cmp(&b.0));
        let span = kept.last().map_or(0.0, |l| l.0) - kept.first().map_or(0.0, |f| f.0);
        let spacing = span / (kept.len().max(2) - 1) as f64;
        Smoother {
            x: kept.iter().map(|k| k.0).collect(),
            y: kept.iter().map(|k| k.1).collect(),
            w: kept.iter().map(|k| k.2).collect(),
            half_width: grid_step.max(2.5 * spacing),
        }
    }

    /// E(x0); the kernel widens (up to 16×) until it holds two distinct abscissae.
    fn at(&self, x0: f64) -> Option<f64> {
        let mut h = self.half_width;
        for _ in 0..5 {
            if let Some(v) = self.local_linear(x0, h) {
                return Some(v);
            }
            h *= 2.0;
        }
        None
    }

    fn local_linear(&self, x0: f64, h: f64) -> Option<f64> {
        if h.is_nan() || h <= 0.0 {
            // One abscissa only: the weighted mean of the points there.
            let (s, t) = self
                .w
                .iter()
                .zip(&self.y)
                .fold((0.0, 0.0), |(s, t), (w, y)| (s + w, t + w * y));
            return (s > 0.0).then(|| t / s);
        }
        let lo = self.x.partition_point(|&x| x < x0 - h);
        let hi = self.x.partition_point(|&x| x <= x0 + h);
        let (mut s0, mut s1, mut s2, mut t0, mut t1) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in lo..hi {
            let d = self.x[i] - x0;
            let u = d / h;
            let k = self.w[i] * (1.0 - u * u).powi(2);
            s0 += k;
            s1 += k * d;
            s2 += k * d * d;
            t0 += k * self.y[i];
            t1 += k * d * self.y[i];
        }
        let det = s0 * s2 - s1 * s1;
        if s0 > 0.0 && det > 1e-12 * s0 * s2 {
            Some((s2 * t0 - s1 * t1) / det)
        } else {
            None
        }
    }
}

/// The normal residual averaged over both sides onto `grid`.
pub fn radial_profile(
    points: &[PointResidual],
    grid: &RadialGrid,
) -> Result<RadialProfile, RadialProfileError> {
    let coverage = Coverage::of(points).ok_or(RadialProfileError::NoPoints)?;
    let radii = grid.radii_mm();
    let step = if radii.len() > 1 {
        radii[1] - radii[0]
    } else {
        0.0
    };
    let smoother = Smoother::new(points, step);
    let not_covered = |radius_mm| RadialProfileError::NotCovered {
        radius_mm,
        min_mm: coverage.min_mm,
        max_mm: coverage.max_mm,
    };
    let mut depth_nm = Vec::with_capacity(radii.len());
    let mut differences = Vec::new();
    for &rho in radii {
        let side = |x: f64| coverage.contains(x).then(|| smoother.at(x)).flatten();
        let plus = side(rho);
        let minus = if rho > 0.0 { side(-rho) } else { None };
        depth_nm.push(match (plus, minus) {
            (Some(a), Some(b)) => {
                differences.push(a - b);
                0.5 * (a + b)
            }
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => return Err(not_covered(rho)),
        });
    }
    let asymmetry_rms_nm = (differences.len() >= 2).then(|| {
        (differences.iter().map(|d| d * d).sum::<f64>() / differences.len() as f64).sqrt()
    });
    Ok(RadialProfile {
        depth: DepthProfile {
            radius_mm: radii.to_vec(),
            depth_nm,
        },
        asymmetry_rms_nm,
    })
}

/// The paper's eq. 3 figures over the kept points inside the aperture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormErrorSummary {
    /// √(Σe²/n) of the axial residual, nm.
    pub rms_nm: f64,
    /// max e − min e, nm.
    pub pv_nm: f64,
    /// How many points the figures cover.
    pub points: usize,
}

pub fn form_error(
    points: &[PointResidual],
    aperture: &ClearAperture,
) -> Result<FormErrorSummary, RadialProfileError> {
    let inside: Vec<f64> = points
        .iter()
        .filter(|p| p.weight > 0.0 && aperture.contains(p.contact_mm.abs()))
        .map(PointResidual::axial_nm)
        .collect();
    if inside.is_empty() {
        return Err(RadialProfileError::ApertureEmpty);
    }
    let n = inside.len() as f64;
    let (lo, hi) = inside
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &e| {
            (lo.min(e), hi.max(e))
        });
    Ok(FormErrorSummary {
        rms_nm: (inside.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
        pv_nm: hi - lo,
        points: inside.len(),
    })
}
