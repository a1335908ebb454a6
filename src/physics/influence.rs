//! A tool's influence function on a grid: the removal rate (nm/s) its footprint leaves at each
//! offset from the tool's centre while the tool stands still, as a spot test measures it or as
//! the process gives it.
//!
//! # Interpolation
//!
//! Between samples the rate is bilinear, and the grid is taken to be bordered by a ring of
//! zero samples one pitch h beyond its edge, so the function is continuous everywhere and zero
//! outside the grid grown by h. For a rate f with bounded second derivatives, bilinear
//! interpolation errs by at most h²/8·(|f_xx| + |f_yy|) (each direction's linear error
//! h²/8·|f''|); for a Gaussian spot of standard deviation σ that is about (h/σ)²/8 of the peak
//! (0.5 % at h = σ/5). The samples are what was measured; the interpolant is the one
//! continuous function they define, and everything Preston computes from it is exact for it.
//!
//! # Line integrals, exactly
//!
//! A move at constant speed from offset a to offset b for T seconds removes
//! T·∫₀¹ f(a + (b − a)·u) du at the origin. Along a straight line a bilinear function is
//! quadratic in u between the line's crossings of the grid lines (x or y a whole number of
//! pitches from the grid's first sample), so the integral is the sum over those pieces of
//! Simpson's rule, which is exact for quadratics: `mean_along`.

/// The rate f(x, y), nm/s, at offsets from the tool's centre (mm), on a grid of `nx` × `ny`
/// samples `pitch_mm` apart: sample (i, j) at (x0 + i·h, y0 + j·h), rows of ascending y.
#[derive(Debug, Clone, PartialEq)]
pub struct Influence {
    nx: usize,
    ny: usize,
    pitch_mm: f64,
    origin_mm: [f64; 2],
    rate: Vec<f64>,
    peak: f64,
}

/// Why samples do not make an influence function.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InfluenceError {
    #[error("an influence function needs a grid of at least 2 × 2 samples, not {nx} × {ny}")]
    TooSmall { nx: usize, ny: usize },
    #[error("an influence function's pitch must be positive and finite, not {0} mm")]
    Pitch(f64),
    #[error("{nx} × {ny} samples need {expected} rates, not {got}")]
    Shape {
        nx: usize,
        ny: usize,
        expected: usize,
        got: usize,
    },
    #[error("sample ({i}, {j}) of the influence function is not a finite rate: {value}")]
    NotFinite { i: usize, j: usize, value: f64 },
    #[error("the influence function removes nothing: its largest rate is {0} nm/s")]
    NoRemoval(f64),
}

impl Influence {
    /// The influence of `rate_nm_per_s` (row-major, `nx` per row, rows of ascending y), sample
    /// (0, 0) at `origin_mm` from the tool's centre.
    pub fn new(
        nx: usize,
        ny: usize,
        pitch_mm: f64,
        origin_mm: [f64; 2],
        rate_nm_per_s: Vec<f64>,
    ) -> Result<Influence, InfluenceError> {
        if nx < 2 || ny < 2 {
            return Err(InfluenceError::TooSmall { nx, ny });
        }
        if !(pitch_mm.is_finite() && pitch_mm > 0.0) {
            return Err(InfluenceError::Pitch(pitch_mm));
        }
        if rate_nm_per_s.len() != nx * ny {
            return Err(InfluenceError::Shape {
                nx,
                ny,
                expected: nx * ny,
                got: rate_nm_per_s.len(),
            });
        }
        if let Some(k) = rate_nm_per_s.iter().position(|v| !v.is_finite()) {
            return Err(InfluenceError::NotFinite {
                i: k % nx,
                j: k / nx,
                value: rate_nm_per_s[k],
            });
        }
        let peak = rate_nm_per_s.iter().fold(0.0_f64, |m, &v| m.max(v));
        if peak <= 0.0 {
            return Err(InfluenceError::NoRemoval(peak));
        }
        Ok(Influence {
            nx,
            ny,
            pitch_mm,
            origin_mm,
            rate: rate_nm_per_s,
            peak,
        })
    }

    /// The samples across (x) and down (y).
    pub fn size(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    pub fn pitch_mm(&self) -> f64 {
        self.pitch_mm
    }

    /// Sample (0, 0)'s offset from the tool's centre, mm.
    pub fn origin_mm(&self) -> [f64; 2] {
        self.origin_mm
    }

    /// The rates, nm/s, row-major with rows of ascending y.
    pub fn rates(&self) -> &[f64] {
        &self.rate
    }

    /// The largest rate, nm/s.
    pub fn peak_nm_per_s(&self) -> f64 {
        self.peak
    }

    /// The volume removed per second, nm·mm²/s: the interpolant's integral (a bilinear
    /// function's integral over its cells is the trapezoid rule's, and the zero border makes
    /// every sample count with weight h²).
    pub fn volume_rate(&self) -> f64 {
        self.rate.iter().sum::<f64>() * self.pitch_mm * self.pitch_mm
    }

    /// Where the rate may be non-zero: offsets within [x_lo, x_hi] × [y_lo, y_hi], mm (the
    /// grid grown by one pitch, open at its edge).
    pub fn support_mm(&self) -> ([f64; 2], [f64; 2]) {
        let h = self.pitch_mm;
        let [x0, y0] = self.origin_mm;
        (
            [x0 - h, x0 + self.nx as f64 * h],
            [y0 - h, y0 + self.ny as f64 * h],
        )
    }

    /// The distance from the centre within which every sample of at least `share` of the
    /// peak lies, mm: how far the tool reaches, for practical purposes.
    pub fn reach_mm(&self, share: f64) -> f64 {
        let h = self.pitch_mm;
        let [x0, y0] = self.origin_mm;
        let cut = share * self.peak;
        let mut reach: f64 = 0.0;
        for j in 0..self.ny {
            for i in 0..self.nx {
                if self.rate[j * self.nx + i] >= cut {
                    let (x, y) = (x0 + i as f64 * h, y0 + j as f64 * h);
                    reach = reach.max(x.hypot(y));
                }
            }
        }
        reach + h
    }

    fn sample(&self, i: isize, j: isize) -> f64 {
        if i < 0 || j < 0 || i >= self.nx as isize || j >= self.ny as isize {
            0.0
        } else {
            self.rate[j as usize * self.nx + i as usize]
        }
    }

    /// f at offset (x, y) from the centre, nm/s.
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let u = (x - self.origin_mm[0]) / self.pitch_mm;
        let v = (y - self.origin_mm[1]) / self.pitch_mm;
        // Outside the grid grown by one pitch, and for NaN, nothing.
        if !(u > -1.0 && v > -1.0 && u < self.nx as f64 && v < self.ny as f64) {
            return 0.0;
        }
        let (i, j) = (u.floor(), v.floor());
        let (fx, fy) = (u - i, v - j);
        let (i, j) = (i as isize, j as isize);
        let bottom = self.sample(i, j) * (1.0 - fx) + self.sample(i + 1, j) * fx;
        let top = self.sample(i, j + 1) * (1.0 - fx) + self.sample(i + 1, j + 1) * fx;
        bottom * (1.0 - fy) + top * fy
    }

    /// ∫₀¹ f(a + (b − a)·u) du: the mean rate along the straight line from offset `a` to offset
    /// `b` (mm), exact for the bilinear interpolant (module docs). `f(a)` when a = b.
    pub fn mean_along(&self, a: [f64; 2], b: [f64; 2]) -> f64 {
        let h = self.pitch_mm;
        // The line in grid units: p(u) = pa + u·d.
        let pa = [
            (a[0] - self.origin_mm[0]) / h,
            (a[1] - self.origin_mm[1]) / h,
        ];
        let d = [(b[0] - a[0]) / h, (b[1] - a[1]) / h];
        // Where the line is inside the support (−1, n) in both coordinates.
        let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
        for (k, n) in [self.nx, self.ny].into_iter().enumerate() {
            let (p, dk) = (pa[k], d[k]);
            if dk == 0.0 {
                if !(p > -1.0 && p < n as f64) {
                    return 0.0;
                }
            } else {
                let (u1, u2) = ((-1.0 - p) / dk, (n as f64 - p) / dk);
                lo = lo.max(u1.min(u2));
                hi = hi.min(u1.max(u2));
            }
        }
        if hi <= lo {
            // Outside, or a stop (a = b) inside, where the integrand is constant.
            return if d == [0.0, 0.0] {
                self.at(a[0], a[1])
            } else {
                0.0
            };
        }
        // The crossings of whole grid lines within (lo, hi), both coordinates, in order.
        let mut breaks = vec![lo, hi];
        for k in 0..2 {
            let dk = d[k];
            if dk == 0.0 {
                continue;
            }
            let (s, e) = (pa[k] + lo * dk, pa[k] + hi * dk);
            let (first, last) = (s.min(e).floor() as i64 + 1, s.max(e).ceil() as i64 - 1);
            for line in first..=last {
                let u = (line as f64 - pa[k]) / dk;
                if u > lo && u < hi {
                    breaks.push(u);
                }
            }
        }
        breaks.sort_by(f64::total_cmp);
        let point = |u: f64| self.at(a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u);
        breaks
            .windows(2)
            .map(|w| {
                let (u0, u1) = (w[0], w[1]);
                (u1 - u0) / 6.0 * (point(u0) + 4.0 * point(0.5 * (u0 + u1)) + point(u1))
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5 × 4 grid of arbitrary rates, off centre.
    fn uneven() -> Influence {
        let rates = (0..20)
            .map(|k| ((k * 7919) % 13) as f64 + 0.5)
            .collect::<Vec<_>>();
        Influence::new(5, 4, 0.3, [-0.7, -0.4], rates).unwrap()
    }

    #[test]
    fn the_interpolant_meets_every_sample_and_vanishes_beyond_the_border() {
        let f = uneven();
        for j in 0..4 {
            for i in 0..5 {
                let (x, y) = (-0.7 + i as f64 * 0.3, -0.4 + j as f64 * 0.3);
                assert!((f.at(x, y) - f.rates()[j * 5 + i]).abs() < 1e-12);
            }
        }
        // One pitch beyond the last sample the zero border is reached, and the rate is
        // continuous there (half way out, half the edge sample).
        assert_eq!(f.at(-0.7 - 0.3, -0.4), 0.0);
        assert!((f.at(-0.7 - 0.15, -0.4) - 0.5 * f.rates()[0]).abs() < 1e-12);
        assert_eq!(f.at(5.0, 0.0), 0.0);
        assert_eq!(f.at(f64::NAN, 0.0), 0.0);
    }

    /// The mean along a line against a fine composite Simpson rule on the same interpolant:
    /// 200,000 panels put its error (the interpolant's kinks, O(Δu²)) below 1e-9 of the rates.
    #[test]
    fn the_mean_along_a_line_is_exact_for_the_interpolant() {
        let f = uneven();
        let lines = [
            ([-1.2, -0.9], [1.0, 0.8]),
            ([-0.5, 0.1], [0.6, 0.1]),
            ([0.2, -1.0], [0.2, 1.5]),
            ([-3.0, 0.0], [3.0, 0.2]),
            ([0.1, 0.2], [0.1, 0.2]),
            ([5.0, 5.0], [6.0, 6.0]),
        ];
        for (a, b) in lines {
            let n = 200_000;
            let du = 1.0 / n as f64;
            let point = |u: f64| f.at(a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u);
            let fine: f64 = (0..n)
                .map(|k| {
                    let u = k as f64 * du;
                    du / 6.0 * (point(u) + 4.0 * point(u + 0.5 * du) + point(u + du))
                })
                .sum();
            let exact = f.mean_along(a, b);
            assert!(
                (exact - fine).abs() < 1e-9,
                "{a:?}→{b:?}: {exact} vs {fine}"
            );
        }
    }

    #[test]
    fn the_volume_is_the_interpolants_integral() {
        // The interpolant's integral by a fine midpoint sum (its kinks cost O(Δ²)).
        let f = uneven();
        let ([x0, x1], [y0, y1]) = f.support_mm();
        let n = 1500;
        let (dx, dy) = ((x1 - x0) / n as f64, (y1 - y0) / n as f64);
        let mut sum = 0.0;
        for j in 0..n {
            for i in 0..n {
                sum += f.at(x0 + (i as f64 + 0.5) * dx, y0 + (j as f64 + 0.5) * dy);
            }
        }
        let fine = sum * dx * dy;
        assert!((fine - f.volume_rate()).abs() < 1e-5 * f.volume_rate());
    }

    #[test]
    fn bad_grids_are_named() {
        assert!(matches!(
            Influence::new(1, 3, 1.0, [0.0; 2], vec![1.0; 3]),
            Err(InfluenceError::TooSmall { .. })
        ));
        assert!(matches!(
            Influence::new(2, 2, 0.0, [0.0; 2], vec![1.0; 4]),
            Err(InfluenceError::Pitch(_))
        ));
        assert!(matches!(
            Influence::new(2, 2, 1.0, [0.0; 2], vec![1.0; 3]),
            Err(InfluenceError::Shape { .. })
        ));
        assert!(matches!(
            Influence::new(2, 2, 1.0, [0.0; 2], vec![1.0, f64::NAN, 1.0, 1.0]),
            Err(InfluenceError::NotFinite { i: 1, j: 0, .. })
        ));
        assert!(matches!(
            Influence::new(2, 2, 1.0, [0.0; 2], vec![0.0, -1.0, 0.0, 0.0]),
            Err(InfluenceError::NoRemoval(_))
        ));
    }
}
