//! Roots of a function on a bracket by the Illinois variant of regula falsi: the secant through
//! the bracket's ends, with the value kept at an end halved whenever that end is kept twice in
//! a row, so that the bracket shrinks from both sides (superlinear, and never leaves the
//! bracket). An end whose value is not finite is approached by bisection instead.

/// A root of `f` between `a` and `b`, whose values there (given) have opposite signs or are
/// zero. Stops when |f(c)| ≤ `f_tolerance` or the bracket is `x_tolerance` wide (or after 200
/// steps), and returns the last point tried.
pub fn illinois(
    f: &dyn Fn(f64) -> f64,
    (mut a, mut fa): (f64, f64),
    (mut b, mut fb): (f64, f64),
    x_tolerance: f64,
    f_tolerance: f64,
) -> f64 {
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let mut kept = 0; // which end was kept last time (for the halving)
    for _ in 0..200 {
        let c = if fa.is_finite() && fb.is_finite() {
            (b - fb * (b - a) / (fb - fa)).clamp(a.min(b), a.max(b))
        } else {
            0.5 * (a + b)
        };
        let fc = f(c);
        if fc.abs() <= f_tolerance || (b - a).abs() <= x_tolerance {
            return c;
        }
        if (fc > 0.0) == (fb > 0.0) {
            b = c;
            fb = fc;
            if kept == -1 {
                fa *= 0.5;
            }
            kept = -1;
        } else {
            a = c;
            fa = fc;
            if kept == 1 {
                fb *= 0.5;
            }
            kept = 1;
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_roots_of_kinked_and_curved_functions() {
        // |η + 1|-like kink and a cubic: roots known exactly.
        let kink = |x: f64| 3.0 * (x + 1.0).abs() - 0.06;
        let root = illinois(&kink, (-1.0, kink(-1.0)), (-0.9, kink(-0.9)), 1e-10, 1e-9);
        assert!((root - (-0.98)).abs() < 1e-9);
        let cubic = |x: f64| x * x * x - 2.0;
        let root = illinois(&cubic, (0.0, cubic(0.0)), (2.0, cubic(2.0)), 0.0, 0.0);
        assert!((root - 2f64.cbrt()).abs() <= 4.0 * f64::EPSILON, "{root}");
        // An infinite end is approached by bisection.
        let wall = |x: f64| if x > 1.5 { f64::INFINITY } else { x - 1.0 };
        let root = illinois(&wall, (0.0, -1.0), (3.0, f64::INFINITY), 1e-12, 0.0);
        assert!((root - 1.0).abs() < 1e-9, "{root}");
    }
}
