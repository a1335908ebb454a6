//! The plane's rate at the sliding speed's zero: its logarithm, taken out in closed form.
//!
//! On a plane at radius r the rate along the path is R(x) = 2·(K·P/π)·G(ψ0(x); ε², B)
//! ([`super::removal`]), a = (ω1 + ω2)·r, b = ω2·x, ε = a − b, B = 4ab. Where the sliding speed
//! vanishes somewhere under the pad (ε = 0, x* = a/ω2) G is not analytic in x. Splitting
//! ∫_0^φ = ∫_0^{π/2} − ∫_φ^{π/2}, the second integrand is bounded away from zero near x* and so
//! analytic in ε²; what is not analytic is the complete integral's √(ε² + B)·E(m),
//! m = B/(ε² + B), whose expansion about m = 1 (DLMF 19.12.2) has the logarithm
//!
//! ```text
//! G = H + Λ·ln|ε|,   Λ = −(2/π)·|a + b|·(K(m₁) − E(m₁)),   m₁ = ε²/(a + b)²,
//! ```
//!
//! H and Λ analytic near x* (K − E = (π/2)·(m₁/2 + 3m₁²/16 + …)). With u = ε/(2a) =
//! (x* − x)/(2x*), so a + b = 2a·(1 − u):
//!
//! ```text
//! Λ = −|a|·(u²/(1 − u) + 3u⁴/(8(1 − u)³) + …) = −|a|·(u² + u³ + 11/8·u⁴ + O(u⁵))
//! ```
//!
//! The rate less S(x) = 2·(K·P/π)·Λ₄(u)·ln|u| (Λ₄ the three terms shown; ln|ε| − ln|u| is a
//! constant) has only u⁵·ln|u| left at x*, which a Chebyshev fit resolves like an analytic
//! function, so the pieces beside x* can be fitted whole ([`super::path`]), with half the rates
//! of two halves each. S's own integral is exact: x = x*·(1 − 2u), and
//!
//! ```text
//! ∫ S dx = 4·x*·|a|·(K·P/π)·J(u),   J(u) = Σ_k c_k·u^{k+1}·(ln|u|/(k+1) − 1/(k+1)²),
//! ```
//!
//! (c₂, c₃, c₄) = (1, 1, 11/8). Any S would be exact this way; the expansion only decides how
//! well the rest is fitted. It is taken out within |x − x*| ≤ x* (|u| ≤ 1/2), where S stays of
//! the rate's size.
//!
//! Both S and J need a logarithm per point, at every rate the fit asks for and every point F is
//! read at, so [`ln`] is written without branches: a loop of them runs in vector registers.

/// Λ₄'s coefficients of u², u³ and u⁴ (over −|a|).
const LOG_COEFFS: [f64; 3] = [1.0, 1.0, 11.0 / 8.0];
/// J's: c_k/(k + 1) and c_k/(k + 1)² for k = 2, 3, 4.
const J_LOG: [f64; 3] = [1.0 / 3.0, 1.0 / 4.0, 11.0 / 40.0];
const J_POWER: [f64; 3] = [1.0 / 9.0, 1.0 / 16.0, 11.0 / 200.0];

/// The logarithmic part of one radius's flat rate, taken out over [lo, hi] (which holds x*).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlidingLog {
    /// x* = a/ω2, mm.
    zero_mm: f64,
    /// 2·(K·P/π)·|a|: S(x) = −weight·Λ₄(u)/|a|·ln|u| in nm/s.
    weight: f64,
    /// 1/(2x*), so u is a product.
    per_two_zero: f64,
    lo_mm: f64,
    hi_mm: f64,
    /// J at lo, so that the integral from lo is J(u) − j_lo.
    j_lo: f64,
}

impl SlidingLog {
    /// The part at radius r for a = (ω1 + ω2)·r, ω2 and the kernel's K·P/π (`scale`), taken
    /// out over the pieces [`lo_mm`, x*] and [x*, `hi_mm`], each only if it lies within
    /// |x − x*| ≤ x* (a piece is given with the logarithm out everywhere or nowhere: a jump in
    /// it would cost its fit dearly); `None` unless x* > 0 lies strictly between them and one
    /// piece is taken.
    pub fn new(a: f64, omega2: f64, scale: f64, lo_mm: f64, hi_mm: f64) -> Option<Self> {
        let zero_mm = a / omega2;
        if !(zero_mm > 0.0 && zero_mm.is_finite() && lo_mm < zero_mm && zero_mm < hi_mm) {
            return None;
        }
        let lo_mm = if lo_mm >= 0.0 { lo_mm } else { zero_mm };
        let hi_mm = if hi_mm <= 2.0 * zero_mm {
            hi_mm
        } else {
            zero_mm
        };
        if lo_mm == hi_mm {
            return None;
        }
        let mut log = SlidingLog {
            zero_mm,
            weight: 2.0 * scale * a.abs(),
            per_two_zero: 0.5 / zero_mm,
            lo_mm,
            hi_mm,
            j_lo: 0.0,
        };
        log.j_lo = j(log.u(lo_mm));
        (log.weight.is_finite() && log.weight > 0.0).then_some(log)
    }

    /// Where the logarithm is taken out.
    pub fn range_mm(&self) -> (f64, f64) {
        (self.lo_mm, self.hi_mm)
    }

    /// The sliding speed's zero x*.
    pub fn zero_mm(&self) -> f64 {
        self.zero_mm
    }

    /// u = (x* − x)/(2x*).
    #[inline(always)]
    fn u(&self, x: f64) -> f64 {
        (self.zero_mm - x) * self.per_two_zero
    }

    /// Takes S(x) off every rate `out[i]` at `xs[i]` inside the range (nm/s).
    pub fn subtract(&self, xs: &[f64], out: &mut [f64]) {
        crate::wide::widest(Work {
            log: self,
            xs,
            out,
            add_integrals: false,
        })
    }

    /// Adds ∫ S from lo to x (x clamped to the range) to every `out[i]` at `xs[i]`.
    pub fn add_integrals(&self, xs: &[f64], out: &mut [f64]) {
        crate::wide::widest(Work {
            log: self,
            xs,
            out,
            add_integrals: true,
        })
    }

    /// [`Self::subtract`]'s loop.
    #[inline(always)]
    fn subtract_here(&self, xs: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(xs) {
            let u = self.u(x);
            let poly = u * u * (LOG_COEFFS[0] + u * (LOG_COEFFS[1] + u * LOG_COEFFS[2]));
            // At u = 0 exactly, u²·ln(tiny) is 0, not 0·∞.
            let s = -self.weight * poly * ln(u.abs().max(f64::MIN_POSITIVE));
            let inside = (x >= self.lo_mm) & (x <= self.hi_mm);
            *o -= if inside { s } else { 0.0 };
        }
    }

    /// [`Self::add_integrals`]'s loop.
    #[inline(always)]
    fn add_integrals_here(&self, xs: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(xs) {
            *o += self.integral_to(x);
        }
    }

    /// ∫ S from lo to x (x clamped to the range), nm/s·mm.
    #[inline(always)]
    pub fn integral_to(&self, x: f64) -> f64 {
        let u = self.u(x.clamp(self.lo_mm, self.hi_mm));
        // dx = −2x*·du and S = −weight·Λ₄/|a|·ln|u|: ∫ S dx = 2x*·weight·J(u) (with Λ₄/|a|).
        2.0 * self.zero_mm * self.weight * (j(u) - self.j_lo)
    }
}

/// [`SlidingLog::subtract`]'s or [`SlidingLog::add_integrals`]' work, for
/// [`crate::wide::widest`].
struct Work<'a> {
    log: &'a SlidingLog,
    xs: &'a [f64],
    out: &'a mut [f64],
    add_integrals: bool,
}

impl crate::wide::Wide for Work<'_> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        if self.add_integrals {
            self.log.add_integrals_here(self.xs, self.out)
        } else {
            self.log.subtract_here(self.xs, self.out)
        }
    }
}

/// J(u) = Σ_k c_k·u^{k+1}·(ln|u|/(k+1) − 1/(k+1)²), k = 2, 3, 4 (0 at u = 0).
#[inline(always)]
fn j(u: f64) -> f64 {
    let l = ln(u.abs().max(f64::MIN_POSITIVE));
    let term = |k: usize| l * J_LOG[k] - J_POWER[k];
    u * u * u * (term(0) + u * (term(1) + u * term(2)))
}

/// ln 2 in two parts (fdlibm's): the high one has trailing zeros, so e·LN2_HI is exact for
/// |e| < 2¹¹.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);

/// ln x for a positive normal x, without branches (so loops of it vectorise), within a few
/// ulps: x = 2^e·m with m in [√½, √2), ln m = 2·atanh(z) = 2·(z + z³/3 + … + z²¹/21),
/// z = (m − 1)/(m + 1), |z| ≤ 0.172 (the next term is below 2.4e-16 of the sum).
#[inline(always)]
pub fn ln(x: f64) -> f64 {
    let bits = x.to_bits();
    let exponent = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let mantissa = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    let big = mantissa > std::f64::consts::SQRT_2;
    let m = if big { 0.5 * mantissa } else { mantissa };
    let e = (exponent + big as i64) as f64;
    let z = (m - 1.0) / (m + 1.0);
    let z2 = z * z;
    let mut series = 1.0 / 21.0;
    for k in (0..10).rev() {
        series = 1.0 / (2 * k + 1) as f64 + z2 * series;
    }
    e * LN2_HI + (e * LN2_LO + 2.0 * z * series)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_is_the_logarithm_to_a_few_ulps() {
        let mut worst: f64 = 0.0;
        let mut x = 1e-300_f64;
        while x < 1e300 {
            for y in [
                x,
                x * 1.000_000_1,
                x * std::f64::consts::SQRT_2 * (1.0 - 1e-9),
                x * std::f64::consts::SQRT_2 * (1.0 + 1e-9),
                x * 1.7,
            ] {
                let (got, want) = (ln(y), y.ln());
                // Relative to |ln y|, or to 1 where ln y is near zero (its absolute error).
                worst = worst.max((got - want).abs() / want.abs().max(1.0));
            }
            x *= 1.37;
        }
        for y in [1.0, 1.0 + 1e-15, 1.0 - 1e-15, 0.999, 1.001, 2.0, 0.5] {
            worst = worst.max((ln(y) - y.ln()).abs() / y.ln().abs().max(1.0));
        }
        // A few ulps of the result (the series and the reduction each round a little).
        assert!(worst < 4.0 * f64::EPSILON, "worst {worst:e}");
    }

    /// The integral's derivative is S: ∫ S over [x0, x1] by adaptive Gauss–Kronrod on each
    /// side of x* (S is smooth there) against integral_to's difference, on both sides.
    #[test]
    fn the_integral_is_the_integral_of_what_is_taken_out() {
        use crate::physics::kronrod::adaptive_gauss_kronrod;
        let log = SlidingLog::new(3.0, 0.2, 0.7, 4.0, 27.0).unwrap();
        assert_eq!(log.zero_mm(), 15.0);
        assert_eq!(log.range_mm(), (4.0, 27.0));
        let s = |x: f64| {
            let mut out = [0.0];
            log.subtract(&[x], &mut out);
            -out[0]
        };
        for (x0, x1) in [(4.0, 15.0), (15.0, 27.0), (6.5, 11.0), (16.0, 26.0)] {
            let want = adaptive_gauss_kronrod(&s, x0, x1, 1e-15);
            let got = log.integral_to(x1) - log.integral_to(x0);
            assert!(
                (got - want).abs() <= 1e-12 * want.abs(),
                "[{x0}, {x1}]: {got} vs {want}"
            );
        }
        // Outside the range nothing is taken out and the integral stays at its ends.
        assert_eq!(s(3.0), 0.0);
        assert_eq!(s(28.0), 0.0);
        assert_eq!(log.integral_to(2.0), 0.0);
        assert_eq!(log.integral_to(40.0), log.integral_to(27.0));
    }

    #[test]
    fn only_pieces_within_the_expansion_are_taken() {
        let log = SlidingLog::new(3.0, 0.2, 0.7, 4.0, 45.0).unwrap();
        assert_eq!(log.range_mm(), (4.0, 15.0));
        let log = SlidingLog::new(3.0, 0.2, 0.7, 15.0 - 1e-9, 30.0).unwrap();
        assert_eq!(log.range_mm(), (15.0 - 1e-9, 30.0));
        assert!(SlidingLog::new(3.0, 0.2, 0.7, 15.0, 30.0).is_none());
        assert!(SlidingLog::new(3.0, -0.2, 0.7, 0.0, 30.0).is_none());
    }
}
