//! Zernike polynomials on the unit disc, their three orderings, and their least-squares fit.
//!
//! A term has a radial order n ≥ 0 and an azimuthal order m, |m| ≤ n, n − |m| even:
//!
//! ```text
//! Z_n^m(ρ, θ) = N_n^m · R_n^|m|(ρ) · { cos(mθ) (m > 0), 1 (m = 0), sin(|m|θ) (m < 0) }
//! R_n^m(ρ) = ρ^m · P_k^(0,m)(2ρ² − 1),   k = (n − m)/2,
//! ```
//!
//! θ counter-clockwise from +x, P_k^(α,β) the Jacobi polynomial, computed by its three-term
//! recurrence in k (stable to n = 20, where the explicit factorial sum loses ~6 digits to
//! cancellation). ρ^m·cos(mθ) and ρ^m·sin(mθ) are the real and imaginary parts of (x + iy)^m, so
//! nothing divides by ρ. R_n^m(1) = 1; the normalisation N is 1 (`Peak`: each term is ±1 at its
//! extreme on the edge) or √((2 − δ_m0)(n + 1)) (`UnitRms`: each term has RMS 1 over the disc,
//! so the coefficients of an orthogonal fit add in quadrature to the RMS).
//!
//! Orderings (each term a single index):
//! - `Fringe` (Zygo, Code V; from 1): groups of equal (n + |m|)/2, |m| falling within each,
//!   cos before sin; index = (1 + (n + |m|)/2)² − 2|m| (+1 for sin). Terms 1–36 follow that
//!   rule and term 37 is (12, 0), as the instruments define the set; no Fringe term beyond 37
//!   is standard, so the ordering stops there.
//! - `Noll` (Zemax "Standard"; from 1): by n, then |m| rising; even indices cos, odd sin.
//! - `Ansi` (ANSI Z80.28 / OSA; from 0): index = (n(n + 2) + m)/2.
//!
//! The fit minimises Σ(z_i − Σ_j c_j Z_j(x_i, y_i))² over the given points by the normal
//! equations: the Gram matrix AᵀA and Aᵀz are accumulated in blocks of points with a
//! triangular matrix product (rayon over blocks), and solved by Cholesky. Unit-RMS Zernikes
//! on a disc of pixels are close to orthonormal (the Gram matrix near the identity), so
//! squaring the condition number costs nothing measurable; an aperture that cannot tell the
//! terms apart (too few points, a thin annulus at high order) fails the factorisation and is
//! refused rather than answered with noise.

use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::solvers::Solve;
use faer::{Accum, Mat, Par, Side};
use rayon::prelude::*;

/// The most terms a fit takes: every term through n = 20 (Noll, ANSI).
pub const MAX_TERMS: usize = 231;

/// The terms the Fringe ordering defines.
pub const FRINGE_TERMS: usize = 37;

/// Points per block of the Gram matrix's accumulation: a block's rows (≤ 232 columns) stay in
/// cache, and the blocks give rayon enough pieces.
const BLOCK: usize = 2048;

/// How terms are numbered (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ordering {
    Fringe,
    Noll,
    Ansi,
}

/// How each term is scaled (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Normalization {
    UnitRms,
    Peak,
}

/// A term's radial and azimuthal orders: m > 0 cos, m < 0 sin.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Term {
    pub n: u32,
    pub m: i32,
}

impl Term {
    /// What opticians call it: "defocus", "astigmatism (cos)", "Z(8, -2)" when it has no name.
    pub fn name(self) -> String {
        let base = match (self.n, self.m.unsigned_abs()) {
            (0, 0) => "piston",
            (1, 1) => "tilt",
            (2, 0) => "defocus",
            (2, 2) => "astigmatism",
            (3, 1) => "coma",
            (3, 3) => "trefoil",
            (4, 0) => "spherical",
            (4, 2) => "secondary astigmatism",
            (4, 4) => "tetrafoil",
            (5, 1) => "secondary coma",
            (5, 3) => "secondary trefoil",
            (5, 5) => "pentafoil",
            (6, 0) => "secondary spherical",
            _ => return format!("Z({}, {})", self.n, self.m),
        };
        match self.m.signum() {
            1 => format!("{base} (cos)"),
            -1 => format!("{base} (sin)"),
            _ => base.to_string(),
        }
    }
}

impl Ordering {
    /// The index of the first term: 0 for ANSI, 1 for the others.
    pub fn first_index(self) -> usize {
        match self {
            Ordering::Ansi => 0,
            Ordering::Fringe | Ordering::Noll => 1,
        }
    }

    /// How many terms the ordering numbers (up to [`MAX_TERMS`]).
    pub fn max_terms(self) -> usize {
        match self {
            Ordering::Fringe => FRINGE_TERMS,
            Ordering::Noll | Ordering::Ansi => MAX_TERMS,
        }
    }

    /// The term at `index`; `None` outside the ordering's first [`Self::max_terms`].
    pub fn term(self, index: usize) -> Option<Term> {
        let first = self.first_index();
        if index < first || index - first >= self.max_terms() {
            return None;
        }
        Some(match self {
            Ordering::Ansi => {
                // The n with n(n + 1)/2 ≤ j < (n + 1)(n + 2)/2.
                let n = block_of(index);
                Term {
                    n: n as u32,
                    m: (2 * index) as i32 - (n * (n + 2)) as i32,
                }
            }
            Ordering::Noll => {
                let n = block_of(index - 1);
                let p = index - 1 - n * (n + 1) / 2;
                let m = if n % 2 == 0 {
                    2 * p.div_ceil(2)
                } else {
                    2 * (p / 2) + 1
                } as i32;
                let sign = if m != 0 && index % 2 == 1 { -1 } else { 1 };
                Term {
                    n: n as u32,
                    m: sign * m,
                }
            }
            Ordering::Fringe if index == 37 => Term { n: 12, m: 0 },
            Ordering::Fringe => {
                // Group g holds indices g² + 1 … (g + 1)², n + |m| = 2g.
                let g = (0..)
                    .find(|g: &usize| (g + 1) * (g + 1) >= index)
                    .unwrap_or(0);
                let offset = index - (g * g + 1);
                let n = g + offset / 2;
                let m = (2 * g - n) as i32;
                Term {
                    n: n as u32,
                    m: if offset % 2 == 1 { -m } else { m },
                }
            }
        })
    }

    /// The index of `term`; `None` when the ordering does not number it.
    pub fn index(self, term: Term) -> Option<usize> {
        let first = self.first_index();
        (first..first + self.max_terms()).find(|&j| self.term(j) == Some(term))
    }
}

/// The n with n(n + 1)/2 ≤ j < (n + 1)(n + 2)/2.
fn block_of(j: usize) -> usize {
    let mut n = 0;
    while (n + 1) * (n + 2) / 2 <= j {
        n += 1;
    }
    n
}

/// A set of terms, scaled alike, evaluated together at points of the unit disc.
#[derive(Debug, Clone, PartialEq)]
pub struct Basis {
    terms: Vec<Term>,
    normalization: Normalization,
    /// Per term: |m|, k = (n − |m|)/2, sin, and the scale N.
    plan: Vec<(usize, usize, bool, f64)>,
    /// The highest k each |m| needs (index |m|), and where its P_k start in the scratch table.
    k_max: Vec<usize>,
    offsets: Vec<usize>,
}

impl Basis {
    /// The terms in the order given (every one a valid (n, m); at least one).
    pub fn new(terms: Vec<Term>, normalization: Normalization) -> Basis {
        let m_max = terms
            .iter()
            .map(|t| t.m.unsigned_abs() as usize)
            .max()
            .unwrap_or(0);
        let mut k_max = vec![0; m_max + 1];
        let plan = terms
            .iter()
            .map(|t| {
                let (n, m) = (t.n as usize, t.m.unsigned_abs() as usize);
                let k = (n - m) / 2;
                k_max[m] = k_max[m].max(k);
                let scale = match normalization {
                    Normalization::Peak => 1.0,
                    Normalization::UnitRms => {
                        (if m == 0 { 1.0 } else { 2.0 } * (n as f64 + 1.0)).sqrt()
                    }
                };
                (m, k, t.m < 0, scale)
            })
            .collect();
        let offsets = k_max
            .iter()
            .scan(0, |start, &k| {
                let here = *start;
                *start += k + 1;
                Some(here)
            })
            .collect();
        Basis {
            terms,
            normalization,
            plan,
            k_max,
            offsets,
        }
    }

    /// The first `count` terms of `ordering`; `None` beyond its [`Ordering::max_terms`].
    pub fn first(ordering: Ordering, count: usize, normalization: Normalization) -> Option<Basis> {
        let first = ordering.first_index();
        let terms = (first..first + count)
            .map(|j| ordering.term(j))
            .collect::<Option<Vec<_>>>()?;
        (!terms.is_empty()).then(|| Basis::new(terms, normalization))
    }

    pub fn terms(&self) -> &[Term] {
        &self.terms
    }

    pub fn normalization(&self) -> Normalization {
        self.normalization
    }

    /// Every term at (x, y) (unit-disc coordinates) into `out` (one per term); `scratch` is
    /// reused between calls.
    pub fn evaluate(&self, x: f64, y: f64, out: &mut [f64], scratch: &mut Vec<f64>) {
        let u = 2.0 * (x * x + y * y) - 1.0;
        scratch.clear();
        // (x + iy)^m and the Jacobi polynomials P_k^(0,m)(u), k = 0 … k_max(m), for each m.
        let (mut re, mut im) = (1.0, 0.0);
        let mut powers = Vec::with_capacity(self.k_max.len());
        for (m, &k_max) in self.k_max.iter().enumerate() {
            if m > 0 {
                (re, im) = (re * x - im * y, re * y + im * x);
            }
            powers.push((re, im));
            jacobi(m as f64, u, k_max, scratch);
        }
        for ((m, k, sin, scale), value) in self.plan.iter().zip(out.iter_mut()) {
            let (re, im) = powers[*m];
            let angular = if *sin { im } else { re };
            *value = scale * scratch[self.offsets[*m] + k] * angular;
        }
    }

    /// The fitted surface Σ c_j Z_j at (x, y).
    pub fn surface(&self, coefficients: &[f64], x: f64, y: f64, scratch: &mut Vec<f64>) -> f64 {
        let mut values = vec![0.0; self.terms.len()];
        self.evaluate(x, y, &mut values, scratch);
        values.iter().zip(coefficients).map(|(z, c)| z * c).sum()
    }

    /// The least-squares coefficients of the terms over `points` (x, y in unit-disc
    /// coordinates, z the value), in the order of [`Self::terms`].
    pub fn fit(&self, points: &[(f64, f64, f64)]) -> Result<Vec<f64>, ZernikeError> {
        let j = self.terms.len();
        if points.len() < j {
            return Err(ZernikeError::TooFewPoints {
                points: points.len(),
                terms: j,
            });
        }
        // The Gram matrix of [A z] (lower triangle): AᵀA, then zᵀA in the last row.
        let gram = points
            .par_chunks(BLOCK)
            .map(|chunk| {
                let mut a = Mat::<f64>::zeros(chunk.len(), j + 1);
                let mut row = vec![0.0; j];
                let mut scratch = Vec::new();
                for (i, &(x, y, z)) in chunk.iter().enumerate() {
                    self.evaluate(x, y, &mut row, &mut scratch);
                    for (c, v) in row.iter().enumerate() {
                        a[(i, c)] = *v;
                    }
                    a[(i, j)] = z;
                }
                let mut g = Mat::<f64>::zeros(j + 1, j + 1);
                triangular::matmul(
                    g.as_mut(),
                    BlockStructure::TriangularLower,
                    Accum::Replace,
                    a.transpose(),
                    BlockStructure::Rectangular,
                    a.as_ref(),
                    BlockStructure::Rectangular,
                    1.0,
                    Par::Seq,
                );
                g
            })
            .reduce(
                || Mat::<f64>::zeros(j + 1, j + 1),
                |mut a, b| {
                    a += &b;
                    a
                },
            );
        let normal = Mat::<f64>::from_fn(
            j,
            j,
            |r, c| {
                if r >= c {
                    gram[(r, c)]
                } else {
                    gram[(c, r)]
                }
            },
        );
        let right = Mat::<f64>::from_fn(j, 1, |r, _| gram[(j, r)]);
        let llt = normal
            .llt(Side::Lower)
            .map_err(|_| ZernikeError::Inseparable)?;
        // A pivot far below the diagonal's scale means two terms look alike on these points.
        let l = llt.L();
        let smallest = (0..j)
            .map(|k| l[(k, k)] * l[(k, k)] / normal[(k, k)])
            .fold(f64::INFINITY, f64::min);
        if smallest.is_nan() || smallest < 1e-10 {
            return Err(ZernikeError::Inseparable);
        }
        let solution = llt.solve(&right);
        Ok((0..j).map(|k| solution[(k, 0)]).collect())
    }
}

/// P_k^(0,β)(u) for k = 0 … k_max, pushed onto `out`, by the three-term recurrence
/// 2k(k + β)(2k + β − 2)·P_k = (2k + β − 1)[(2k + β)(2k + β − 2)u − β²]·P_{k−1}
///                            − 2(k − 1)(k + β − 1)(2k + β)·P_{k−2},
/// P_0 = 1, P_1 = 1 + (β + 2)(u − 1)/2.
fn jacobi(beta: f64, u: f64, k_max: usize, out: &mut Vec<f64>) {
    out.push(1.0);
    if k_max == 0 {
        return;
    }
    let (mut previous, mut current) = (1.0, 1.0 + (beta + 2.0) * (u - 1.0) / 2.0);
    out.push(current);
    for k in 2..=k_max {
        let k = k as f64;
        let s = 2.0 * k + beta;
        let a = 2.0 * k * (k + beta) * (s - 2.0);
        let b = (s - 1.0) * (s * (s - 2.0) * u - beta * beta);
        let c = 2.0 * (k - 1.0) * (k + beta - 1.0) * s;
        (previous, current) = (current, (b * current - c * previous) / a);
        out.push(current);
    }
}

/// Why a fit has no answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ZernikeError {
    #[error("{points} valid pixels in the aperture cannot fit {terms} Zernike terms")]
    TooFewPoints { points: usize, terms: usize },
    #[error(
        "the aperture's pixels cannot tell these Zernike terms apart (too few, or an annulus too \
         thin for the orders asked); fit fewer terms"
    )]
    Inseparable,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The orderings' published tables, first terms.
    #[test]
    fn the_orderings_number_the_terms_as_published() {
        let nm = |o: Ordering, js: std::ops::RangeInclusive<usize>| -> Vec<(u32, i32)> {
            js.map(|j| o.term(j).map(|t| (t.n, t.m)).unwrap()).collect()
        };
        assert_eq!(
            nm(Ordering::Fringe, 1..=11),
            [
                (0, 0),
                (1, 1),
                (1, -1),
                (2, 0),
                (2, 2),
                (2, -2),
                (3, 1),
                (3, -1),
                (4, 0),
                (3, 3),
                (3, -3)
            ]
        );
        assert_eq!(nm(Ordering::Fringe, 36..=37), [(10, 0), (12, 0)]);
        assert_eq!(Ordering::Fringe.term(38), None);
        assert_eq!(
            nm(Ordering::Noll, 1..=11),
            [
                (0, 0),
                (1, 1),
                (1, -1),
                (2, 0),
                (2, -2),
                (2, 2),
                (3, -1),
                (3, 1),
                (3, -3),
                (3, 3),
                (4, 0)
            ]
        );
        assert_eq!(
            nm(Ordering::Ansi, 0..=9),
            [
                (0, 0),
                (1, -1),
                (1, 1),
                (2, -2),
                (2, 0),
                (2, 2),
                (3, -3),
                (3, -1),
                (3, 1),
                (3, 3)
            ]
        );
        assert_eq!(Ordering::Ansi.term(230).map(|t| (t.n, t.m)), Some((20, 20)));
        assert_eq!(Ordering::Noll.term(231).map(|t| t.n), Some(20));
        assert_eq!(Ordering::Noll.term(232), None);
    }

    /// R_n^m(1) = 1, and the radial polynomials against their explicit sums at low order.
    #[test]
    fn the_recurrence_gives_the_radial_polynomials() {
        let basis = Basis::new(
            vec![
                Term { n: 4, m: 0 },
                Term { n: 3, m: 1 },
                Term { n: 20, m: 0 },
                Term { n: 19, m: 7 },
            ],
            Normalization::Peak,
        );
        let mut out = vec![0.0; 4];
        let mut scratch = Vec::new();
        basis.evaluate(1.0, 0.0, &mut out, &mut scratch);
        for v in &out {
            assert!((v - 1.0).abs() < 1e-13, "{v}");
        }
        let (x, y) = (0.3, -0.4);
        let r2: f64 = x * x + y * y;
        basis.evaluate(x, y, &mut out, &mut scratch);
        assert!((out[0] - (6.0 * r2 * r2 - 6.0 * r2 + 1.0)).abs() < 1e-15);
        assert!((out[1] - (3.0 * r2 - 2.0) * x).abs() < 1e-15);
    }
}
