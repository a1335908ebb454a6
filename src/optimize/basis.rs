//! How the QP represents the dwell at the candidate positions.
//!
//! The pad cannot resolve dwell that changes over much less than its radius: the removal
//! function is 2·r_t wide, so M·t barely sees faster changes. Yet with the dwell at each
//! position as a variable, the QP's Hessian MᵀM is dense within a band 2·r_t/h wide (h the
//! spacing), factorised at every interior-point iteration: its cost grows like n³ when the
//! positions get finer, for nothing the pad can use. So, when the positions are fine, the dwell
//! is written in a smooth basis,
//!
//! ```text
//! t_j = Σ_k S_jk·c_k,     S_jk = B_k(r1_j)
//! ```
//!
//! with B_k the cubic B-splines on clamped uniform knots over [r1_0, r1_{n−1}], spaced as
//! close to [`KNOT_SPACING_PER_TOOL_RADIUS`]·r_t as an integer number of spans allows. The QP
//! then has K = spans + 3 variables (tens to a few hundred) whatever n, and its Hessian
//! SᵀMᵀMS is K × K. B_k ≥ 0 and Σ_k B_k = 1 on the knot span, so:
//!
//! - every row a·t ≤ b of the constraints becomes (a·S)·c ≤ b and still holds exactly at the
//!   positions (the dwell bounds, total time, feed and dwell-change rows, the machine's);
//! - a constant dwell is c_k = const, so every constant plan the feasibility argument of
//!   [`super::feasibility`] relies on (and the machine's starting plan) is in the basis;
//! - between positions the dwell stays within the range of its coefficients (convex hull), and
//!   it is twice continuously differentiable: a smooth feed for the axis.
//!
//! The basis is used when it has at most half as many functions as there are positions;
//! otherwise (coarse positions) the variables are the dwells themselves, S = I. A knot span
//! without a position adds a function no position sees; such functions are left out.

use std::ops::Range;

use crate::spline::Knots;

/// Knot spacing of the dwell's spline, as a fraction of the tool radius: fine enough that the
/// spline fits what the pad can remove (measured on the paper's experiments: a finer spacing
/// does not change the plan's uniformity), coarse enough to keep the QP small.
pub const KNOT_SPACING_PER_TOOL_RADIUS: f64 = 0.125;

/// Which representation of the dwell the QP uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DwellBasis {
    /// The spline when it at least halves the variables, else the positions.
    #[default]
    Auto,
    /// One variable per position (S = I).
    Positions,
}

/// The map S from the QP's dwell variables to the dwell at each position.
#[derive(Debug, Clone, PartialEq)]
pub struct Basis {
    /// Variables.
    size: usize,
    /// Terms per position (1 for the positions, 4 for the cubic spline).
    width: usize,
    /// `width` (variable, weight) terms per position, position-major; weights may be 0.
    terms: Vec<(usize, f64)>,
    /// The positions each variable reaches (contiguous: positions increase).
    support: Vec<Range<usize>>,
}

impl Basis {
    /// One variable per position.
    pub fn positions(n: usize) -> Self {
        Basis {
            size: n,
            width: 1,
            terms: (0..n).map(|j| (j, 1.0)).collect(),
            support: (0..n).map(|j| j..j + 1).collect(),
        }
    }

    /// The basis `choice` asks for, on the strictly increasing station radii `radii_mm`.
    pub fn new(radii_mm: &[f64], tool_radius_mm: f64, choice: DwellBasis) -> Self {
        let n = radii_mm.len();
        match choice {
            DwellBasis::Positions => Basis::positions(n),
            DwellBasis::Auto => Basis::spline(radii_mm, tool_radius_mm)
                .filter(|b| 2 * b.size <= n)
                .unwrap_or_else(|| Basis::positions(n)),
        }
    }

    /// The cubic spline basis on knots spaced about [`KNOT_SPACING_PER_TOOL_RADIUS`]·r_t;
    /// `None` for fewer than two positions.
    pub fn spline(radii_mm: &[f64], tool_radius_mm: f64) -> Option<Self> {
        let (&a, &b) = (radii_mm.first()?, radii_mm.last()?);
        if radii_mm.len() < 2 || b <= a {
            return None;
        }
        let target = KNOT_SPACING_PER_TOOL_RADIUS * tool_radius_mm;
        let spans = ((b - a) / target).round().max(1.0) as usize;
        let knots = Knots::new(a, b, spans);
        let mut terms = Vec::with_capacity(4 * radii_mm.len());
        for &r in radii_mm {
            let (span, weights) = knots.basis(r);
            terms.extend((0..4).map(|i| (span + i, weights[i])));
        }
        // Leave out functions no position sees, renumbering the others in order.
        let mut seen = vec![false; spans + 3];
        for &(k, w) in &terms {
            seen[k] |= w != 0.0;
        }
        let mut index = vec![0; spans + 3];
        let mut size = 0;
        for (k, s) in seen.iter().enumerate() {
            index[k] = size;
            size += usize::from(*s);
        }
        // (first, one past the last) position each function reaches.
        let mut reach = vec![(usize::MAX, 0); size];
        for (p, term) in terms.iter_mut().enumerate() {
            if term.1 == 0.0 {
                *term = (0, 0.0);
                continue;
            }
            term.0 = index[term.0];
            let r = &mut reach[term.0];
            let j = p / 4;
            *r = (r.0.min(j), r.1.max(j + 1));
        }
        let support = reach.into_iter().map(|(a, b)| a..b).collect();
        Some(Basis {
            size,
            width: 4,
            terms,
            support,
        })
    }

    /// Number of variables.
    pub fn size(&self) -> usize {
        self.size
    }

    /// Number of positions.
    pub fn positions_len(&self) -> usize {
        self.terms.len() / self.width
    }

    pub fn is_positions(&self) -> bool {
        self.width == 1
    }

    /// The non-zero (variable, weight) terms of position `j`'s dwell.
    pub fn terms(&self, j: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.terms[j * self.width..(j + 1) * self.width]
            .iter()
            .copied()
            .filter(|&(_, w)| w != 0.0)
    }

    /// The positions variable `k` reaches.
    pub fn support(&self, k: usize) -> Range<usize> {
        self.support[k].clone()
    }

    /// The dwell at each position, S·c.
    pub fn dwell(&self, c: &[f64]) -> Vec<f64> {
        (0..self.positions_len())
            .map(|j| self.terms(j).map(|(k, w)| w * c[k]).sum())
            .collect()
    }

    /// Sᵀ·y for y over the positions.
    pub fn transpose_apply(&self, y: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.size];
        for (j, v) in y.iter().enumerate() {
            for (k, w) in self.terms(j) {
                out[k] += w * v;
            }
        }
        out
    }

    /// A linear form over (positions, then `extra` other variables) as one over (this basis's
    /// variables, then the same others): position entries expand through S, the others shift.
    /// Repeated variables are summed.
    pub fn form(&self, entries: &[(usize, f64)]) -> Vec<(usize, f64)> {
        let n = self.positions_len();
        let mut out: Vec<(usize, f64)> = Vec::with_capacity(entries.len() * self.width);
        for &(col, v) in entries {
            if col < n {
                out.extend(self.terms(col).map(|(k, w)| (k, v * w)));
            } else {
                out.push((col - n + self.size, v));
            }
        }
        if !self.is_positions() {
            out.sort_by_key(|&(k, _)| k);
            out.dedup_by(|b, a| {
                let same = a.0 == b.0;
                if same {
                    a.1 += b.1;
                }
                same
            });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn even(n: usize, length: f64) -> Vec<f64> {
        (0..n).map(|j| length * j as f64 / (n - 1) as f64).collect()
    }

    /// Partition of unity and non-negativity at every position, and linear precision: the
    /// coefficients ξ_k (Greville abscissae, the mean of the three inner knots of B_k)
    /// reproduce t(r) = r exactly (to rounding).
    #[test]
    fn the_spline_is_a_partition_of_unity_with_linear_precision() {
        let positions: Vec<f64> = even(401, 50.0).iter().map(|r| r + 0.3).collect();
        let basis = Basis::spline(&positions, 10.0).unwrap();
        assert_eq!(basis.size(), 40 + 3);
        let knots = Knots::new(0.3, 50.3, 40);
        let greville: Vec<f64> = (0..basis.size())
            .map(|k| (knots.knot(k + 1) + knots.knot(k + 2) + knots.knot(k + 3)) / 3.0)
            .collect();
        let ones = basis.dwell(&vec![1.0; basis.size()]);
        let line = basis.dwell(&greville);
        for (j, &r) in positions.iter().enumerate() {
            assert!((ones[j] - 1.0).abs() < 1e-14, "{j}: {}", ones[j]);
            assert!((line[j] - r).abs() < 1e-12, "{j}: {} vs {r}", line[j]);
            assert!(basis.terms(j).all(|(_, w)| w > 0.0 && w <= 1.0));
        }
        // The ends are interpolated: clamped knots.
        assert_eq!(basis.terms(0).collect::<Vec<_>>(), vec![(0, 1.0)]);
        assert_eq!(basis.terms(400).collect::<Vec<_>>(), vec![(42, 1.0)]);
        // Each function reaches the positions within its four spans (1.25 mm, 10 positions
        // each; a position on a knot may or may not count, by rounding).
        let first = basis.support(0);
        assert!(
            first.start == 0 && (10..=11).contains(&first.end),
            "{first:?}"
        );
        let middle = basis.support(20);
        assert!(
            (169..=171).contains(&middle.start) && (209..=211).contains(&middle.end),
            "{middle:?}"
        );
    }

    /// Coarse positions keep one variable per position; functions no position sees are left
    /// out (a gap of several spans between two clusters).
    #[test]
    fn coarse_positions_keep_their_own_variables_and_unseen_functions_are_dropped() {
        let coarse = even(20, 50.0);
        assert!(Basis::new(&coarse, 10.0, DwellBasis::Auto).is_positions());
        let fine = even(501, 50.0);
        assert_eq!(Basis::new(&fine, 10.0, DwellBasis::Auto).size(), 43);
        assert!(Basis::new(&fine, 10.0, DwellBasis::Positions).is_positions());

        let mut clusters = even(100, 5.0);
        clusters.extend(even(100, 5.0).iter().map(|r| r + 45.0));
        let basis = Basis::spline(&clusters, 10.0).unwrap();
        assert!(basis.size() < 43);
        let ones = basis.dwell(&vec![1.0; basis.size()]);
        assert!(ones.iter().all(|v| (v - 1.0).abs() < 1e-14));
        for k in 0..basis.size() {
            assert!(!basis.support(k).is_empty());
        }
    }

    /// Forms expand through S and merge repeated variables; other variables shift.
    #[test]
    fn forms_expand_position_entries_and_shift_the_others() {
        let positions = even(501, 50.0);
        let basis = Basis::spline(&positions, 10.0).unwrap();
        let all: Vec<(usize, f64)> = (0..501).map(|j| (j, 1.0)).chain([(501, 2.0)]).collect();
        let form = basis.form(&all);
        // Σ_j t_j = Σ_k c_k·Σ_j S_jk, then the piston (variable 501) becomes variable 43.
        let column_sums = basis.transpose_apply(&[1.0; 501]);
        assert_eq!(form.len(), 44);
        for (k, &(var, v)) in form.iter().enumerate().take(43) {
            assert_eq!(var, k);
            assert!((v - column_sums[k]).abs() < 1e-12);
        }
        assert_eq!(form[43], (43, 2.0));
        assert!((column_sums.iter().sum::<f64>() - 501.0).abs() < 1e-9);
    }
}
