//! The rotationally symmetric part of a map: the function of radius alone closest to it.
//!
//! Over the pixels (r_i, z_i) of an aperture, find the cubic spline f in s = r² (knots even in
//! r, about two pixels apart; `spline::Knots::squared`) that minimises Σ(z_i − f(r_i))². Each
//! pixel stands for the same area, so this is the area-weighted least-squares fit, and where a
//! full ring of pixels surrounds the centre f is the ring's azimuthal mean to the spline's
//! resolution. Being a projection, the residual z − f (the rotationally variant part) is
//! orthogonal to every function of radius: RMS² of the map = RMS² of f at the pixels + RMS² of
//! the residual, the split ISO 14999-4 makes between RMSs and RMSa. A profile that is a
//! polynomial in r² to degree 3 (piston, defocus, primary and secondary spherical) is
//! reproduced to rounding: a spline in s holds every cubic in s.
//!
//! The normal equations are banded (four functions reach each pixel): accumulated pixel by
//! pixel and solved by a banded Cholesky factorisation, O(pixels + knots).

use rayon::prelude::*;

use crate::spline::{Knots, Tabulated};

/// Points per parallel task: enough that a task's private normal matrix costs little.
const CHUNK: usize = 16_384;

/// Knot spacing, pixels: a zone two pixels wide is resolved, and every span holds pixels
/// (about a dozen inside the first span about the centre).
pub const KNOT_SPACING_PX: f64 = 2.0;

/// A fitted radial profile f(r) on [r_min, r_max], mm.
#[derive(Debug, Clone, PartialEq)]
pub struct RadialFit {
    knots: Tabulated,
    coefficients: Vec<f64>,
    r_min: f64,
    r_max: f64,
}

/// The four B-splines that reach one radius (span and values), for every fit from one
/// [`RadialFit::fit_each`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadialBasis {
    span: usize,
    values: [f64; 4],
}

impl RadialFit {
    /// The least-squares spline through `points` (radius mm, value), with knots about
    /// `spacing_mm` apart over the points' radii. `None` when the points do not determine
    /// it (fewer than four, or all at one radius).
    pub fn fit(points: &[(f64, f64)], spacing_mm: f64) -> Option<RadialFit> {
        let (radii, values): (Vec<f64>, Vec<f64>) = points.iter().copied().unzip();
        Self::fit_each(&radii, &[&values], spacing_mm)?.pop()
    }

    /// One fit (as [`Self::fit`]) for each of `values` over the same `radii_mm`: the same
    /// knots and normal matrix, the basis found once a point. `None` as for [`Self::fit`].
    pub fn fit_each(
        radii_mm: &[f64],
        values: &[&[f64]],
        spacing_mm: f64,
    ) -> Option<Vec<RadialFit>> {
        Self::fit_each_into(radii_mm, values, spacing_mm, &mut [])
    }

    /// [`Self::fit_each`], and the basis at each radius (what [`Self::basis`] gives there),
    /// kept from the fit for the caller's evaluations.
    pub fn fit_each_with_bases(
        radii_mm: &[f64],
        values: &[&[f64]],
        spacing_mm: f64,
    ) -> Option<(Vec<RadialFit>, Vec<RadialBasis>)> {
        let mut bases = vec![
            RadialBasis {
                span: 0,
                values: [0.0; 4]
            };
            radii_mm.len()
        ];
        let fits = Self::fit_each_into(radii_mm, values, spacing_mm, &mut bases)?;
        Some((fits, bases))
    }

    /// The fits, and the bases into `bases` unless it is empty.
    fn fit_each_into(
        radii_mm: &[f64],
        values: &[&[f64]],
        spacing_mm: f64,
        bases: &mut [RadialBasis],
    ) -> Option<Vec<RadialFit>> {
        let (r_min, r_max) = radii_mm
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
                (a.min(*r), b.max(*r))
            });
        if radii_mm.len() < 4 || r_max <= r_min || spacing_mm <= 0.0 {
            return None;
        }
        // A span about the centre reaches r = 0, where s = r² is flat: start there.
        let start = if r_min < spacing_mm { 0.0 } else { r_min };
        let spans = (((r_max - start) / spacing_mm).round() as usize).max(1);
        let knots = Knots::squared(start, r_max, spans).tabulated();
        let k = knots.functions();
        // Band of the normal matrix: band[i][d] = G[i][i + d], d = 0 … 3.
        // Accumulated over chunks of points in parallel, then added.
        let zero = || (vec![[0.0; 4]; k], vec![vec![0.0; k]; values.len()]);
        // Each chunk of radii with its chunk of `bases`, if kept.
        let mut slots: Vec<Option<&mut [RadialBasis]>> = if bases.is_empty() {
            (0..radii_mm.len().div_ceil(CHUNK)).map(|_| None).collect()
        } else {
            bases.chunks_mut(CHUNK).map(Some).collect()
        };
        let (mut band, rights) = radii_mm
            .par_chunks(CHUNK)
            .zip(slots.par_iter_mut())
            .enumerate()
            .map(|(c, (radii, kept))| {
                let (mut band, mut rights) = zero();
                for (i, &r) in (c * CHUNK..).zip(radii) {
                    let (span, b) = knots.basis_at_radius(r);
                    if let Some(kept) = kept {
                        kept[i - c * CHUNK] = RadialBasis { span, values: b };
                    }
                    for p in 0..4 {
                        for q in p..4 {
                            band[span + p][q - p] += b[p] * b[q];
                        }
                    }
                    for (right, z) in rights.iter_mut().zip(values) {
                        for p in 0..4 {
                            right[span + p] += b[p] * z[i];
                        }
                    }
                }
                (band, rights)
            })
            // Added in order, whatever the threads: the same answer to the last bit.
            .collect::<Vec<_>>()
            .into_iter()
            .fold(zero(), |(mut band, mut rights), (band2, rights2)| {
                for (a, b) in band.iter_mut().zip(&band2) {
                    for d in 0..4 {
                        a[d] += b[d];
                    }
                }
                for (a, b) in rights.iter_mut().zip(&rights2) {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                }
                (band, rights)
            });
        // A function no pixel reaches (a span without pixels) is held at its neighbours'
        // level by a ridge far below rounding of the others.
        let scale = band.iter().map(|b| b[0]).fold(0.0, f64::max);
        for b in &mut band {
            b[0] += 1e-14 * scale;
        }
        rights
            .iter()
            .map(|right| {
                Some(RadialFit {
                    knots: knots.clone(),
                    coefficients: solve_banded(&band, right)?,
                    r_min: start,
                    r_max,
                })
            })
            .collect()
    }

    /// f(r), mm → the fitted value; beyond the spline's radii, the value at the nearer end.
    pub fn at(&self, r: f64) -> f64 {
        self.at_basis(&self.basis(r))
    }

    /// The B-splines at radius r (clamped as [`Self::at`] does).
    pub fn basis(&self, r: f64) -> RadialBasis {
        let r = r.clamp(self.r_min, self.r_max);
        let (span, values) = self.knots.basis_at_radius(r);
        RadialBasis { span, values }
    }

    /// f at the radius `basis` was found for, by this fit or one from the same
    /// [`Self::fit_each`].
    pub fn at_basis(&self, basis: &RadialBasis) -> f64 {
        (0..4)
            .map(|p| basis.values[p] * self.coefficients[basis.span + p])
            .sum()
    }

    /// The radii the spline covers, mm: the data's, from 0 when the data come within a knot
    /// spacing of the centre (the spline in r² is flat there, as any smooth even function).
    pub fn range_mm(&self) -> (f64, f64) {
        (self.r_min, self.r_max)
    }
}

/// Solves G·x = b for a symmetric positive definite G of half-bandwidth 3, given its upper
/// band, by the banded Cholesky factorisation G = L·Lᵀ. `None` when G is not positive.
fn solve_banded(band: &[[f64; 4]], b: &[f64]) -> Option<Vec<f64>> {
    let n = band.len();
    // l[i][t] = L[i][i − t].
    let mut l = vec![[0.0; 4]; n];
    for i in 0..n {
        for t in (0..4).rev() {
            if t > i {
                continue;
            }
            let j = i - t;
            // G[i][j] = G[j][i] = band[j][t].
            let mut sum = band[j][t];
            for k in i.saturating_sub(3)..j {
                sum -= l[i][i - k] * l[j][j - k];
            }
            if t == 0 {
                if sum <= 0.0 || !sum.is_finite() {
                    return None;
                }
                l[i][0] = sum.sqrt();
            } else {
                l[i][t] = sum / l[j][0];
            }
        }
    }
    let mut y = vec![0.0; n];
    for i in 0..n {
        let mut sum = b[i];
        for k in i.saturating_sub(3)..i {
            sum -= l[i][i - k] * y[k];
        }
        y[i] = sum / l[i][0];
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let mut sum = y[i];
        for k in i + 1..(i + 4).min(n) {
            sum -= l[k][k - i] * x[k];
        }
        x[i] = sum / l[i][0];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A profile that is a cubic in r² comes back to rounding; the banded solve agrees with
    /// the profile at every sample.
    #[test]
    fn a_cubic_in_r_squared_is_reproduced() {
        let f = |r: f64| 3.0 - 2.0 * r * r + 0.5 * r.powi(4) - 0.07 * r.powi(6);
        let mut points: Vec<(f64, f64)> = (0..4000)
            .map(|i| {
                let r = 2.0 * ((i as f64 * 0.618_034) % 1.0).sqrt();
                (r, f(r))
            })
            .collect();
        points.push((2.0, f(2.0)));
        let fit = RadialFit::fit(&points, 0.05).unwrap();
        for i in 0..=100 {
            let r = 2.0 * i as f64 / 100.0;
            assert!(
                (fit.at(r) - f(r)).abs() < 1e-10,
                "{r}: {} vs {}",
                fit.at(r),
                f(r)
            );
        }
    }
}
