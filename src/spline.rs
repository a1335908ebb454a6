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
