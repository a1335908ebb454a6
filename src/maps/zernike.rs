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
//! equations G·c = Aᵀz, G = AᵀA, solved by Cholesky. A map's pixels come in rows, and along a
//! straight line every term is a polynomial of degree ≤ n in the position t ∈ [−1, 1] along
//! it: Z_j(t) = Σ_a W_aj·T_a(t) exactly, W its Chebyshev coefficients from the values at
//! n + 1 Chebyshev–Gauss nodes on the line (inside the aperture, where the terms are bounded).
//! A row's contribution to G is then Wᵀ·M·W with M = Σ_i T(t_i)·T(t_i)ᵀ its (n + 1)² moments,
//! and to Aᵀz it is Wᵀ·Σ_i T(t_i)·z_i. Since T_a·T_b = (T_{a+b} + T_{|a−b|})/2, M comes from
//! the 2n + 1 sums S_k = Σ_i T_k(t_i): per pixel 3n + 2 multiply-adds (S and Σ T·z) instead of
//! J²/2 (38 against 703 at 37 terms, 62 against 26,796 at 231), the same numbers to rounding.
//! W is found once per row ([`Basis::layout`]) for the equations and the fitted surface.
//! The rows' Wᵀ·M·W are gathered as Y = Lᵀ·W (M = L·Lᵀ) in a tall matrix whose YᵀY a
//! triangular matrix product forms (rayon over rows, the parts added in order); a row too
//! short to carry its moments (fewer than 2(n + 1) pixels) adds its pixels' rows of terms
//! directly. The fitted surface is evaluated on each row from its Chebyshev coefficients W·c by
//! Clenshaw's recurrence.
//! Unit-RMS Zernikes on a disc of pixels are close to orthonormal (G near the identity), so
//! squaring the condition number costs nothing measurable; an aperture that cannot tell the
//! terms apart (too few points, a thin annulus at high order) fails the factorisation and is
//! refused rather than answered with noise.

use std::ops::Range;

use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::solvers::Solve;

use faer::{Accum, Mat, Par, Side};
use rayon::prelude::*;

use crate::wide::{lanes, widest, Wide};

/// The most terms a fit takes: every term through n = 20 (Noll, ANSI).
pub const MAX_TERMS: usize = 231;

/// The terms the Fringe ordering defines.
pub const FRINGE_TERMS: usize = 37;

/// Points per block of the Gram matrix's accumulation, for points on no line.
const BLOCK: usize = 256;

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

    /// Term `i`'s scale N (1 peak-normalised; √((2 − δ_m0)(n + 1)) unit-RMS).
    pub fn scale(&self, i: usize) -> f64 {
        self.plan[i].3
    }

    /// The highest radial order of the terms.
    pub fn degree(&self) -> usize {
        self.terms.iter().map(|t| t.n as usize).max().unwrap_or(0)
    }

    /// Every term at (x, y) (unit-disc coordinates) into `out` (one per term); `scratch` is
    /// reused between calls.
    pub fn evaluate(&self, x: f64, y: f64, out: &mut [f64], scratch: &mut Vec<f64>) {
        let u = 2.0 * (x * x + y * y) - 1.0;
        scratch.clear();
        // (x + iy)^m and the Jacobi polynomials P_k^(0,m)(u), k = 0 … k_max(m), for each m
        // (m ≤ 20: every term through n = 20).
        let (mut re, mut im) = (1.0, 0.0);
        let mut powers = [(0.0, 0.0); 21];
        for (m, &k_max) in self.k_max.iter().enumerate() {
            if m > 0 {
                (re, im) = (re * x - im * y, re * y + im * x);
            }
            powers[m] = (re, im);
            jacobi(m as f64, u, k_max, scratch);
        }
        for ((m, k, sin, scale), value) in self.plan.iter().zip(out.iter_mut()) {
            let (re, im) = powers[*m];
            let angular = if *sin { im } else { re };
            *value = scale * scratch[self.offsets[*m] + k] * angular;
        }
    }

    /// The least-squares coefficients of the terms over `points` (x, y in unit-disc
    /// coordinates, z the value), in the order of [`Self::terms`].
    pub fn fit(&self, points: &[(f64, f64, f64)]) -> Result<Vec<f64>, ZernikeError> {
        let all: Vec<usize> = (0..self.terms.len()).collect();
        let normal = self.normal_equations(&self.layout(points, &[]));
        normal.solve(&all, &normal.right.clone())
    }

    /// `points` (x, y in unit-disc coordinates, z the value) laid out for
    /// [`Self::normal_equations`] and [`Self::surface`]. `lines` (ranges of `points`, in
    /// order, possibly none) name runs of collinear points, a row of pixels each: on a line
    /// every term is a polynomial of degree ≤ n in the position along it, and its Chebyshev
    /// coefficients W are found here, once (module docs); other points go in blocks.
    pub fn layout<'a>(&self, points: &'a [(f64, f64, f64)], lines: &[Range<usize>]) -> Layout<'a> {
        let nodes = Nodes::new(self.degree() + 1);
        let mut pieces = Vec::with_capacity(lines.len() + 1);
        let mut next = 0;
        let mut loose = Vec::new();
        for line in lines {
            debug_assert!(line.start >= next, "lines are in order and apart");
            loose.extend(next..line.start);
            next = line.end;
            if line.len() >= LINE_FACTOR * nodes.count {
                pieces.push(Piece::Line(line.clone(), None));
            } else {
                loose.extend(line.clone());
            }
        }
        loose.extend(next..points.len());
        pieces.extend(loose.chunks(BLOCK).map(|c| Piece::Points(c.to_vec())));
        pieces
            .par_iter_mut()
            .for_each_init(Vec::new, |scratch, piece| {
                if let Piece::Line(range, basis) = piece {
                    *basis = Some(LineBasis::new(
                        self,
                        &points[range.clone()],
                        &nodes,
                        scratch,
                    ));
                }
            });
        Layout { points, pieces }
    }

    /// The normal equations of the terms over the laid-out points: on a line its Gram and
    /// right-hand side come from its Chebyshev coefficients (module docs); other points
    /// contribute their rows of terms directly.
    pub fn normal_equations(&self, layout: &Layout) -> NormalEquations {
        let j = self.terms.len();
        let points = layout.points;
        let (gram, right, zz) = layout
            .pieces
            .par_chunks(LINES_PER_TASK)
            .map(|chunk| {
                let mut rows = Rows::new(j);
                let mut right = vec![0.0; j];
                let mut zz = 0.0;
                let mut scratch = Vec::new();
                let mut values = vec![0.0; j];
                let mut direct = |indices: &mut dyn Iterator<Item = usize>,
                                  rows: &mut Rows,
                                  right: &mut [f64],
                                  zz: &mut f64| {
                    for i in indices {
                        let (x, y, z) = points[i];
                        self.evaluate(x, y, &mut values, &mut scratch);
                        rows.push(&values);
                        right.iter_mut().zip(&values).for_each(|(r, v)| *r += v * z);
                        *zz += z * z;
                    }
                };
                for piece in chunk {
                    match piece {
                        Piece::Points(indices) => {
                            direct(&mut indices.iter().copied(), &mut rows, &mut right, &mut zz)
                        }
                        Piece::Line(range, line) => {
                            let line = line.as_ref().expect("laid out with its basis");
                            let (t, m) = line.moments(&points[range.clone()]);
                            let Some(l) = cholesky(&m, line.nodes) else {
                                direct(&mut range.clone(), &mut rows, &mut right, &mut zz);
                                continue;
                            };
                            zz += points[range.clone()].iter().map(|p| p.2 * p.2).sum::<f64>();
                            let nodes = line.nodes;
                            // YᵀY = Wᵀ·M·W with Y = Lᵀ·W.
                            // Row by row of W (contiguous), each sum in the order of b.
                            let mut y = vec![0.0; j];
                            for a in 0..nodes {
                                y.fill(0.0);
                                for b in a..nodes {
                                    let lba = l[b * nodes + a];
                                    let w = &line.w[b * j..(b + 1) * j];
                                    y.iter_mut().zip(w).for_each(|(v, w)| *v += lba * w);
                                }
                                rows.push(&y);
                            }
                            let mut line_right = vec![0.0; j];
                            for (a, ta) in t.iter().enumerate() {
                                let w = &line.w[a * j..(a + 1) * j];
                                line_right.iter_mut().zip(w).for_each(|(r, w)| *r += w * ta);
                            }
                            right.iter_mut().zip(&line_right).for_each(|(r, v)| *r += v);
                        }
                    }
                }
                (rows.gram(), right, zz)
            })
            // Added in order, whatever the threads: the same answer to the last bit.
            .collect::<Vec<_>>()
            .into_iter()
            .fold(
                (Mat::<f64>::zeros(j, j), vec![0.0; j], 0.0),
                |(mut g, mut r, z), (g2, r2, z2)| {
                    g += &g2;
                    r.iter_mut().zip(&r2).for_each(|(a, b)| *a += b);
                    (g, r, z + z2)
                },
            );
        let gram = Mat::<f64>::from_fn(
            j,
            j,
            |r, c| if r >= c { gram[(r, c)] } else { gram[(c, r)] },
        );
        NormalEquations {
            gram,
            right,
            zz,
            points: points.len(),
        }
    }

    /// Σ c_j Z_j at every laid-out point (on a line, from its Chebyshev coefficients W·c by
    /// Clenshaw's recurrence).
    pub fn surface(&self, coefficients: &[f64], layout: &Layout) -> Vec<f64> {
        let j = self.terms.len();
        let points = layout.points;
        let pieces: Vec<(&Piece, Vec<f64>)> = layout
            .pieces
            .par_iter()
            .map(|piece| {
                let values = match piece {
                    Piece::Line(range, line) => {
                        let line = line.as_ref().expect("laid out with its basis");
                        let s: Vec<f64> = (0..line.nodes)
                            .map(|a| (0..j).map(|c| line.w[a * j + c] * coefficients[c]).sum())
                            .collect();
                        widest(LineSurface {
                            line,
                            s: &s,
                            points: &points[range.clone()],
                        })
                    }
                    Piece::Points(indices) => {
                        let (mut values, mut scratch) = (vec![0.0; j], Vec::new());
                        indices
                            .iter()
                            .map(|&i| {
                                let (x, y, _) = points[i];
                                self.evaluate(x, y, &mut values, &mut scratch);
                                values.iter().zip(coefficients).map(|(v, c)| v * c).sum()
                            })
                            .collect()
                    }
                };
                (piece, values)
            })
            .collect();
        let mut out = vec![f64::NAN; points.len()];
        for (piece, values) in pieces {
            match piece {
                Piece::Line(range, _) => out[range.clone()].copy_from_slice(&values),
                Piece::Points(indices) => {
                    for (&i, v) in indices.iter().zip(values) {
                        out[i] = v;
                    }
                }
            }
        }
        out
    }
}

/// Points laid out by lines for the fit ([`Basis::layout`]).
pub struct Layout<'a> {
    points: &'a [(f64, f64, f64)],
    pieces: Vec<Piece>,
}

/// A line of at least this many times (degree + 1) points takes the Chebyshev path: its
/// moment matrix is then well conditioned.
const LINE_FACTOR: usize = 2;
/// Lines (or blocks of points) per parallel task.
const LINES_PER_TASK: usize = 16;

/// What one piece of the points contributes: a line (with its Chebyshev coefficients, once
/// laid out), or points taken one by one.
enum Piece {
    Line(Range<usize>, Option<LineBasis>),
    Points(Vec<usize>),
}

/// Rows of a tall matrix Y whose YᵀY is a part of the Gram matrix.
struct Rows {
    columns: usize,
    data: Vec<f64>,
}

impl Rows {
    fn new(columns: usize) -> Rows {
        Rows {
            columns,
            data: Vec::new(),
        }
    }

    fn push(&mut self, row: &[f64]) {
        self.data.extend_from_slice(row);
    }

    /// YᵀY (lower triangle).
    fn gram(&self) -> Mat<f64> {
        let j = self.columns;
        let n = self.data.len() / j.max(1);
        let y = faer::MatRef::from_row_major_slice(&self.data, n, j);
        let mut g = Mat::<f64>::zeros(j, j);
        triangular::matmul(
            g.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            y.transpose(),
            BlockStructure::Rectangular,
            y,
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        g
    }
}

/// Chebyshev–Gauss nodes t_k = cos θ_k, θ_k = π(k + ½)/P, and the weights that turn values
/// there into an interpolant's Chebyshev coefficients: w_a = Σ_k f(t_k)·weight[k·P + a] with
/// weight = (2 − δ_a0)/P · cos(a θ_k), exact to degree P − 1. The same for every line.
struct Nodes {
    count: usize,
    t: Vec<f64>,
    weight: Vec<f64>,
}

impl Nodes {
    fn new(count: usize) -> Nodes {
        let theta = |k: usize| std::f64::consts::PI * (k as f64 + 0.5) / count as f64;
        let t = (0..count).map(|k| theta(k).cos()).collect();
        let weight = (0..count)
            .flat_map(|k| {
                (0..count).map(move |a| {
                    (a as f64 * theta(k)).cos() * if a == 0 { 1.0 } else { 2.0 } / count as f64
                })
            })
            .collect();
        Nodes { count, t, weight }
    }
}

/// The terms along one line of points: W (nodes × terms), the Chebyshev coefficients of each
/// term in the position t ∈ [−1, 1] from the line's first point to its last.
struct LineBasis {
    mid: (f64, f64),
    half: (f64, f64),
    nodes: usize,
    w: Vec<f64>,
}

impl LineBasis {
    fn new(
        basis: &Basis,
        points: &[(f64, f64, f64)],
        nodes: &Nodes,
        scratch: &mut Vec<f64>,
    ) -> LineBasis {
        let (first, last) = (points[0], points[points.len() - 1]);
        let mid = ((first.0 + last.0) / 2.0, (first.1 + last.1) / 2.0);
        let half = ((last.0 - first.0) / 2.0, (last.1 - first.1) / 2.0);
        let j = basis.terms.len();
        let p = nodes.count;
        let mut w = vec![0.0; p * j];
        let mut values = vec![0.0; j];
        for (k, t) in nodes.t.iter().enumerate() {
            basis.evaluate(mid.0 + t * half.0, mid.1 + t * half.1, &mut values, scratch);
            for (a, weight) in nodes.weight[k * p..(k + 1) * p].iter().enumerate() {
                for (target, v) in w[a * j..(a + 1) * j].iter_mut().zip(&values) {
                    *target += weight * v;
                }
            }
        }
        LineBasis {
            mid,
            half,
            nodes: p,
            w,
        }
    }

    /// A point's position t along the line (−1 at the first point, 1 at the last).
    #[inline(always)]
    fn parameter(&self, p: &(f64, f64, f64)) -> f64 {
        let (dx, dy) = (p.0 - self.mid.0, p.1 - self.mid.1);
        (dx * self.half.0 + dy * self.half.1)
            / (self.half.0 * self.half.0 + self.half.1 * self.half.1)
    }

    /// Σ T_a(t_i)·z_i and M = Σ T(t_i)·T(t_i)ᵀ (nodes × nodes, row-major) over the points.
    /// T_a·T_b = (T_{a+b} + T_{|a−b|})/2, so M comes from the sums S_k = Σ T_k(t_i),
    /// k < 2P − 1: 2P − 1 additions a point rather than P(P + 1)/2 multiply-adds.
    /// The recurrence T_{k+1} = 2t·T_k − T_{k−1} is a chain of dependent operations, so it
    /// runs for [`LANES`] points side by side, each lane summing on its own, in the widest
    /// build the CPU has (`crate::wide`: the same operations lane by lane, the same bits).
    fn moments(&self, points: &[(f64, f64, f64)]) -> (Vec<f64>, Vec<f64>) {
        widest(Moments { line: self, points })
    }

    /// [`LineBasis::moments`]'s work, inlined into each build.
    #[inline(always)]
    fn moments_here(&self, points: &[(f64, f64, f64)]) -> (Vec<f64>, Vec<f64>) {
        let p = self.nodes;
        let q = 2 * p - 1;
        let mut sums = vec![[0.0; LANES]; q];
        let mut t = vec![[0.0; LANES]; p];
        for chunk in points.chunks(LANES) {
            // A short last chunk is padded with points of weight 0 (z = 0, counted 0 times).
            let mut x = [0.0; LANES];
            let mut z = [0.0; LANES];
            let mut count = [0.0; LANES];
            for (l, point) in chunk.iter().enumerate() {
                (x[l], z[l], count[l]) = (self.parameter(point), point.2, 1.0);
            }
            let (mut previous, mut current) = (count, x);
            for l in 0..LANES {
                current[l] *= count[l];
                sums[0][l] += count[l];
                t[0][l] += z[l];
            }
            for k in 1..q {
                if k > 1 {
                    let next: [f64; LANES] = lanes(|l| 2.0 * x[l] * current[l] - previous[l]);
                    (previous, current) = (current, next);
                }
                for l in 0..LANES {
                    sums[k][l] += current[l];
                }
                if k < p {
                    for l in 0..LANES {
                        t[k][l] += current[l] * z[l];
                    }
                }
            }
        }
        let total = |lanes: &[f64; LANES]| lanes.iter().sum::<f64>();
        let sums: Vec<f64> = sums.iter().map(total).collect();
        let mut m = vec![0.0; p * p];
        for a in 0..p {
            for b in 0..p {
                m[a * p + b] = (sums[a + b] + sums[a.abs_diff(b)]) / 2.0;
            }
        }
        (t.iter().map(total).collect(), m)
    }
}

/// Points whose Chebyshev recurrences run side by side.
const LANES: usize = 8;

/// A line's moments, for [`widest`].
struct Moments<'a> {
    line: &'a LineBasis,
    points: &'a [(f64, f64, f64)],
}

impl Wide for Moments<'_> {
    type Output = (Vec<f64>, Vec<f64>);

    #[inline(always)]
    fn run(self) -> Self::Output {
        self.line.moments_here(self.points)
    }
}

/// Σ s_a T_a(t) at each of a line's points, for [`widest`].
struct LineSurface<'a> {
    line: &'a LineBasis,
    s: &'a [f64],
    points: &'a [(f64, f64, f64)],
}

impl Wide for LineSurface<'_> {
    type Output = Vec<f64>;

    #[inline(always)]
    fn run(self) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.points.len());
        for chunk in self.points.chunks(LANES) {
            let t = lanes(|l| chunk.get(l).map_or(0.0, |p| self.line.parameter(p)));
            out.extend_from_slice(&clenshaw(self.s, t)[..chunk.len()]);
        }
        out
    }
}

/// Σ s_a T_a(t) by Clenshaw's recurrence, at [`LANES`] points side by side.
#[inline(always)]
fn clenshaw(s: &[f64], t: [f64; LANES]) -> [f64; LANES] {
    let (mut b1, mut b2) = ([0.0; LANES], [0.0; LANES]);
    for &c in s.iter().skip(1).rev() {
        (b1, b2) = (lanes(|l| 2.0 * t[l] * b1[l] - b2[l] + c), b1);
    }
    lanes(|l| s[0] + t[l] * b1[l] - b2[l])
}

/// The lower Cholesky factor of the n × n row-major `m`; `None` when a pivot falls below
/// 1e-12 of the largest diagonal (the line's points cannot carry its polynomials).
fn cholesky(m: &[f64], n: usize) -> Option<Vec<f64>> {
    let scale = (0..n).map(|i| m[i * n + i]).fold(0.0, f64::max);
    let mut l = vec![0.0; n * n];
    for i in 0..n {
        for k in 0..=i {
            let sum: f64 = m[i * n + k] - (0..k).map(|q| l[i * n + q] * l[k * n + q]).sum::<f64>();
            if i == k {
                // NaN fails too.
                if sum.is_nan() || sum <= 1e-12 * scale {
                    return None;
                }
                l[i * n + i] = sum.sqrt();
            } else {
                l[i * n + k] = sum / l[k * n + k];
            }
        }
    }
    Some(l)
}

/// The normal equations of a basis over some points: G = AᵀA, Aᵀz and zᵀz.
#[derive(Debug, Clone)]
pub struct NormalEquations {
    /// J × J, symmetric.
    pub gram: Mat<f64>,
    pub right: Vec<f64>,
    pub zz: f64,
    pub points: usize,
}

impl NormalEquations {
    /// The least-squares coefficients of the terms `indices` alone, with the right-hand side
    /// `right` (one per index): G_II·c = right, by Cholesky.
    pub fn solve(&self, indices: &[usize], right: &[f64]) -> Result<Vec<f64>, ZernikeError> {
        let j = indices.len();
        if self.points < j {
            return Err(ZernikeError::TooFewPoints {
                points: self.points,
                terms: j,
            });
        }
        let normal = Mat::<f64>::from_fn(j, j, |r, c| self.gram[(indices[r], indices[c])]);
        let rhs = Mat::<f64>::from_fn(j, 1, |r, _| right[r]);
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
        let solution = llt.solve(&rhs);
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
