//! What is not round, harmonic by harmonic: a map's angular harmonics on rings about the axis.
//!
//! The pixels are grouped into rings one pixel wide (ring k holds the pixels with
//! ⌊r/pixel⌋ = k), and on each ring the least-squares fit of
//!
//! ```text
//! v(θ) ≈ a_0 + Σ_{m=1}^{M} a_m·cos mθ + b_m·sin mθ
//! ```
//!
//! to its pixels gives harmonic m's mean square on the ring, (a_m² + b_m²)/2. A ring's pixels
//! sit at nearly, not exactly, equal angles, so harmonics above M would leak into the fit of
//! those below: each ring is fitted to as many harmonics as it has pixels for (M′ with
//! n ≥ 2·(2M′ + 1), up to M + [`EXTRA_HARMONICS`]), and harmonics 1 … M are reported. A ring
//! with too few pixels for M (near the axis, where a pad sees little but the mean anyway) is
//! not fitted.

use faer::linalg::solvers::Solve;
use faer::Mat;
use rayon::prelude::*;

/// The most harmonics a ring is fitted to beyond those reported.
pub const EXTRA_HARMONICS: usize = 16;

/// One ring's fit.
#[derive(Debug, Clone, PartialEq)]
pub struct RingFit {
    /// The mean radius of its pixels, mm.
    pub radius_mm: f64,
    pub pixels: usize,
    /// Harmonic m's mean square (nm²) for m = 1 … M (index m − 1).
    pub power: Vec<f64>,
}

/// The rings of `points` (r mm, θ rad, and K values nm at the pixel) one `pixel_mm` wide,
/// fitted to harmonics 1 … `m_max`, in order of radius, for each of the K values (maps on the
/// same pixels share each ring's design and its factorisation); rings too small to fit are left
/// out.
pub fn ring_harmonics<const K: usize>(
    points: &[(f64, f64, [f64; K])],
    pixel_mm: f64,
    m_max: usize,
) -> [Vec<RingFit>; K] {
    let mut rings: Vec<Vec<(f64, f64, [f64; K])>> = Vec::new();
    for &p in points {
        let k = (p.0 / pixel_mm).floor() as usize;
        if rings.len() <= k {
            rings.resize(k + 1, Vec::new());
        }
        rings[k].push(p);
    }
    let fits: Vec<[RingFit; K]> = rings
        .par_iter()
        .filter_map(|ring| {
            let fitted = (ring.len() / 2).saturating_sub(1) / 2;
            if fitted < m_max {
                return None;
            }
            let mut fits = fit_ring(ring, fitted.min(m_max + EXTRA_HARMONICS))?;
            for fit in &mut fits {
                fit.power.truncate(m_max);
            }
            Some(fits)
        })
        .collect();
    std::array::from_fn(|k| fits.iter().map(|f| f[k].clone()).collect())
}

/// One ring's least squares for each of its K values by its normal equations (Cholesky);
/// `None` if they are singular (pixels bunched at a few angles).
fn fit_ring<const K: usize>(ring: &[(f64, f64, [f64; K])], m_max: usize) -> Option<[RingFit; K]> {
    let unknowns = 2 * m_max + 1;
    // cos mθ, sin mθ by turning through θ once per harmonic.
    let basis = |theta: f64, row: &mut [f64]| {
        let (step_sin, step_cos) = theta.sin_cos();
        let (mut c, mut s) = (1.0, 0.0);
        row[0] = 1.0;
        for m in 1..=m_max {
            (c, s) = (c * step_cos - s * step_sin, s * step_cos + c * step_sin);
            row[2 * m - 1] = c;
            row[2 * m] = s;
        }
    };
    let mut design = Mat::<f64>::zeros(ring.len(), unknowns);
    let mut row = vec![0.0; unknowns];
    for (i, &(_, theta, _)) in ring.iter().enumerate() {
        basis(theta, &mut row);
        for (a, &v) in row.iter().enumerate() {
            design[(i, a)] = v;
        }
    }
    let values = Mat::from_fn(ring.len(), K, |i, k| ring[i].2[k]);
    let normal = design.transpose() * &design;
    let right = design.transpose() * &values;
    let solution = normal.llt(faer::Side::Lower).ok()?.solve(&right);
    let radius_mm = ring.iter().map(|p| p.0).sum::<f64>() / ring.len() as f64;
    Some(std::array::from_fn(|k| RingFit {
        radius_mm,
        pixels: ring.len(),
        power: (1..=m_max)
            .map(|m| 0.5 * (solution[(2 * m - 1, k)].powi(2) + solution[(2 * m, k)].powi(2)))
            .collect(),
    }))
}

/// Harmonic m's RMS (nm, m = 1 … M) over the fitted rings whose mean radius is in
/// [from_mm, to_mm), each ring weighted by its pixels; `None` when no ring is.
pub fn band_rms(rings: &[RingFit], from_mm: f64, to_mm: f64) -> Option<Vec<f64>> {
    let inside: Vec<&RingFit> = rings
        .iter()
        .filter(|r| r.radius_mm >= from_mm && r.radius_mm < to_mm)
        .collect();
    let pixels: usize = inside.iter().map(|r| r.pixels).sum();
    let m_max = inside.first()?.power.len();
    Some(
        (0..m_max)
            .map(|m| {
                let power: f64 = inside.iter().map(|r| r.pixels as f64 * r.power[m]).sum();
                (power / pixels as f64).sqrt()
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pixels of a 1 mm grid on a disc of radius 30 mm carrying 3·cos 2θ + 4·sin 5θ plus a
    /// piston: each ring's fit gives exactly those harmonics' mean squares, 4.5 and 8 nm² (the
    /// model holds the data, so the least squares is exact to rounding), and every other 0.
    #[test]
    fn a_ring_s_harmonics_are_recovered() {
        let mut points = Vec::new();
        for i in -30..=30 {
            for j in -30..=30 {
                let (x, y) = (i as f64, j as f64);
                let (r, theta) = (x.hypot(y), y.atan2(x));
                if r <= 30.0 {
                    let value = 7.0 + 3.0 * (2.0 * theta).cos() + 4.0 * (5.0 * theta).sin();
                    points.push((r, theta, [value]));
                }
            }
        }
        let [rings] = ring_harmonics(&points, 1.0, 6);
        assert!(!rings.is_empty());
        for ring in &rings {
            assert_eq!(ring.power.len(), 6);
            assert!((ring.power[1] - 4.5).abs() < 1e-9, "{ring:?}");
            assert!((ring.power[4] - 8.0).abs() < 1e-9, "{ring:?}");
            for m in [0, 2, 3, 5] {
                assert!(ring.power[m].abs() < 1e-9, "{ring:?}");
            }
        }
        // 2·13 pixels are needed for 13 unknowns: rings 0 to 4 (1 to 24 pixels) are not
        // fitted, ring 5 (40) is.
        assert!(
            rings[0].radius_mm >= 5.0 && rings[0].radius_mm < 6.0,
            "{:?}",
            rings[0]
        );
        assert_eq!(rings[0].pixels, 40);
        let band = band_rms(&rings, 10.0, 20.0).unwrap();
        assert!((band[1] - 4.5f64.sqrt()).abs() < 1e-9);
        assert!((band[4] - 8f64.sqrt()).abs() < 1e-9);
        assert!(band_rms(&rings, 40.0, 50.0).is_none());
    }
}
