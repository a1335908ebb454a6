//! Cubic B-splines on clamped uniform knots, evaluated by the Cox–de Boor recurrence.
//!
//! `spans` equal spans cover [start, end]; the knot sequence repeats each end four times
//! (u_0 = … = u_3 = start, u_{spans+3} = … = end), so the spline interpolates its end
//! coefficients. There are `spans + 3` functions B_0 … B_{spans+2}; on span i only
//! B_i … B_{i+3} are non-zero, they are non-negative and sum to 1 (a partition of unity), and
//! any cubic polynomial on [start, end] is exactly a combination of them.
//!
//! [`Knots::squared`] places the knots at u_i = r_i², r_i uniform in [start, end]: a cubic
//! spline in s = r², so a function of the radius that is even and smooth about r = 0 (a
//! polynomial in r² to degree 3, as the rotationally symmetric Zernike terms through n = 6
//! are) is exactly a combination, with the knots spread evenly in radius.

/// Clamped uniform knots (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knots {
    start: f64,
    end: f64,
    step: f64,
    spans: usize,
    squared: bool,
}

impl Knots {
    /// `spans` (≥ 1) equal spans over [start, end] (start < end).
    pub fn new(start: f64, end: f64, spans: usize) -> Knots {
        debug_assert!(spans >= 1 && start < end);
        Knots {
            start,
            end,
            step: (end - start) / spans as f64,
            spans,
            squared: false,
        }
    }

    /// `spans` spans uniform in r over [start, end] (0 ≤ start < end), the spline's variable
    /// being s = r²: knot u_i = r_i² (module docs). [`Self::basis`] takes s.
    pub fn squared(start: f64, end: f64, spans: usize) -> Knots {
        Knots {
            squared: true,
            ..Knots::new(start, end, spans)
        }
    }

    /// How many functions: spans + 3.
    pub fn functions(&self) -> usize {
        self.spans + 3
    }

    /// Knot u_i of the clamped sequence.
    pub fn knot(&self, i: usize) -> f64 {
        let i = i.clamp(3, self.spans + 3) - 3;
        let r = if i == self.spans {
            self.end
        } else {
            self.start + self.step * i as f64
        };
        if self.squared {
            r * r
        } else {
            r
        }
    }

    /// The span i holding `x` (the last span holds the end; points outside are put in the
    /// nearest span) and the four cubic B-splines B_i … B_{i+3} at `x`, by the Cox–de Boor
    /// recurrence raised one degree at a time.
    pub fn basis(&self, x: f64) -> (usize, [f64; 4]) {
        let r = if self.squared { x.max(0.0).sqrt() } else { x };
        let span = (((r - self.start) / self.step).floor().max(0.0) as usize).min(self.spans - 1);
        // Knot index of the span's left end.
        let mu = span + 3;
        let mut n = [1.0, 0.0, 0.0, 0.0];
        let mut left = [0.0; 4];
        let mut right = [0.0; 4];
        for d in 1..=3 {
            left[d] = x - self.knot(mu + 1 - d);
            right[d] = self.knot(mu + d) - x;
            let mut saved = 0.0;
            for r in 0..d {
                let denominator = right[r + 1] + left[d - r];
                let tmp = if denominator == 0.0 {
                    0.0
                } else {
                    n[r] / denominator
                };
                n[r] = saved + right[r + 1] * tmp;
                saved = left[d - r] * tmp;
            }
            n[d] = saved;
        }
        // Rounding at a span's end can leave −1e-17: the functions are non-negative.
        (span, n.map(|v: f64| v.max(0.0)))
    }
}

/// The same basis, tabulated: on each span the four non-zero B-splines as cubics in
/// τ = (x − u_i)/(u_{i+1} − u_i), found once per span by interpolation at four interior
/// points (the functions are cubic there, so the table is exact to rounding: ~1e-15) and then
/// evaluated by Horner's rule, without the recurrence's divisions.
#[derive(Debug, Clone, PartialEq)]
pub struct Tabulated {
    knots: Knots,
    /// Per span, per function, the coefficients of τ⁰ … τ³.
    cubics: Vec<[[f64; 4]; 4]>,
    /// Per span, its first knot u_i and the inverse of its width u_{i+1} − u_i: a multiply
    /// rather than a division per evaluation (τ to within an ulp, which the cubics take).
    spans: Vec<(f64, f64)>,
    /// 1 / the knot step in r, for the same reason.
    inverse_step: f64,
}

impl Knots {
    pub fn tabulated(&self) -> Tabulated {
        // The inverse of the Vandermonde matrix at τ = 1/8, 3/8, 5/8, 7/8, applied by
        // solving: small and well conditioned.
        let taus = [0.125, 0.375, 0.625, 0.875];
        let cubics = (0..self.spans)
            .map(|span| {
                let (a, b) = (self.knot(span + 3), self.knot(span + 4));
                let values: Vec<[f64; 4]> = taus
                    .iter()
                    .map(|t| {
                        let (at, w) = self.basis(a + t * (b - a));
                        debug_assert_eq!(at, span);
                        w
                    })
                    .collect();
                let mut out = [[0.0; 4]; 4];
                for (f, coefficients) in out.iter_mut().enumerate() {
                    *coefficients = cubic_through(
                        &taus,
                        &[values[0][f], values[1][f], values[2][f], values[3][f]],
                    );
                }
                out
            })
            .collect();
        Tabulated {
            knots: *self,
            cubics,
            spans: (0..self.spans)
                .map(|span| {
                    let a = self.knot(span + 3);
                    (a, 1.0 / (self.knot(span + 4) - a))
                })
                .collect(),
            inverse_step: 1.0 / self.step,
        }
    }
}

impl Tabulated {
    /// As [`Knots::basis`].
    pub fn basis(&self, x: f64) -> (usize, [f64; 4]) {
        let k = &self.knots;
        let r = if k.squared { x.max(0.0).sqrt() } else { x };
        self.on_span(self.span_of(r), x)
    }

    /// [`Self::basis`] at s = r² on squared knots, from r ≥ 0 itself: no square root to find
    /// the span.
    #[inline]
    pub fn basis_at_radius(&self, r: f64) -> (usize, [f64; 4]) {
        debug_assert!(self.knots.squared);
        self.on_span(self.span_of(r), r * r)
    }

    /// The span holding r (uniform knots in r), clamped to the spans.
    #[inline]
    fn span_of(&self, r: f64) -> usize {
        let k = &self.knots;
        // `as` truncates, which is the floor of a non-negative number (and a libm call less).
        (((r - k.start) * self.inverse_step).max(0.0) as usize).min(k.spans - 1)
    }

    /// The four functions of `span` at x.
    #[inline]
    fn on_span(&self, span: usize, x: f64) -> (usize, [f64; 4]) {
        let (a, inverse_width) = self.spans[span];
        let t = (x - a) * inverse_width;
        let c = &self.cubics[span];
        let at = |f: usize| c[f][0] + t * (c[f][1] + t * (c[f][2] + t * c[f][3]));
        (span, [at(0), at(1), at(2), at(3)].map(|v: f64| v.max(0.0)))
    }

    /// How many functions.
    pub fn functions(&self) -> usize {
        self.knots.functions()
    }
}

/// The coefficients of the cubic through (xᵢ, yᵢ), four points, by Newton's divided
/// differences expanded to powers.
fn cubic_through(x: &[f64; 4], y: &[f64; 4]) -> [f64; 4] {
    let mut d = *y;
    for level in 1..4 {
        for i in (level..4).rev() {
            d[i] = (d[i] - d[i - 1]) / (x[i] - x[i - level]);
        }
    }
    // p(t) = d0 + d1(t − x0) + d2(t − x0)(t − x1) + d3(t − x0)(t − x1)(t − x2), expanded.
    let mut poly = [d[3], 0.0, 0.0, 0.0];
    for (degree, i) in (0..3).rev().enumerate() {
        // poly ← poly·(t − x_i) + d_i
        let mut next = [0.0; 4];
        for k in 0..=degree {
            next[k + 1] += poly[k];
            next[k] -= x[i] * poly[k];
        }
        next[0] += d[i];
        poly = next;
    }
    poly
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table gives the recurrence's values to rounding, uniform and squared knots alike.
    #[test]
    fn the_table_matches_the_recurrence() {
        for knots in [Knots::new(0.3, 50.3, 40), Knots::squared(0.0, 25.0, 120)] {
            let table = knots.tabulated();
            let end = if knots.squared { 625.0 } else { 50.3 };
            let start = if knots.squared { 0.0 } else { 0.3 };
            for i in 0..=10_000 {
                let x = start + (end - start) * i as f64 / 10_000.0;
                let (s1, w1) = knots.basis(x);
                let (s2, w2) = table.basis(x);
                assert_eq!(s1, s2, "{x}");
                for f in 0..4 {
                    assert!((w1[f] - w2[f]).abs() < 1e-12, "{x}: {w1:?} vs {w2:?}");
                }
            }
        }
    }
}
