//! Contact geometry: which arc of the circle of radius r lies under a pad of radius r_t whose
//! centre sits at radius r1.
//!
//! A workpiece point (r, θ), θ measured from the direction of the tool centre, is under the pad
//! when r² + r1² − 2·r·r1·cosθ ≤ r_t², i.e. for |θ| ≤ θ0 with
//! cosθ0 = (r² + r1² − r_t²)/(2·r·r1). Rather than take arccos of that quotient (which loses
//! half the digits near tangency, where cosθ0 → ±1), we use the exact factorisations
//!
//! ```text
//! 1 − cosθ0 = (r_t − r + r1)(r_t + r − r1) / (2·r·r1) = 2 sin²(θ0/2)
//! 1 + cosθ0 = (r + r1 − r_t)(r + r1 + r_t) / (2·r·r1) = 2 cos²(θ0/2)
//! ```
//!
//! and return sin(θ0/2) and cos(θ0/2) directly, each factor clamped at zero: a negative first
//! product means no contact (θ0 = 0), a negative second product means the whole circle is under
//! the pad (θ0 = π). Both are accurate to a few ulps at tangency, and no trigonometric call is
//! needed. When r = 0 or r1 = 0 the quotient is 0/0; we use its limit from the interior
//! (r, r1 > 0): θ0 = π when r + r1 < r_t, 0 when r + r1 > r_t, and π/2 on the boundary, which is
//! the midpoint of the jump, so quadrature rules that land on it stay second-order accurate.

use std::f64::consts::FRAC_1_SQRT_2;

/// Half of the contact angle θ0, as its sine and cosine (ψ0 = θ0/2 ∈ [0, π/2]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfAngle {
    pub sin: f64,
    pub cos: f64,
}

impl HalfAngle {
    pub const NONE: HalfAngle = HalfAngle { sin: 0.0, cos: 1.0 };
    pub const FULL: HalfAngle = HalfAngle { sin: 1.0, cos: 0.0 };

    /// ψ0 = θ0/2 in radians.
    pub fn radians(self) -> f64 {
        self.sin.atan2(self.cos)
    }

    pub fn is_contact(self) -> bool {
        self.sin > 0.0
    }

    /// This arc (|θ| ≤ 2ψ on a circle of radius `r`, θ from the +x direction) less its points
    /// before the line x = `x0`: `None` when no point is left (x0 ≥ r), else the narrower of
    /// the two, the line's own half-angle being half of acos(x0/r):
    /// sin² = (r − x0)/(2r), cos² = (r + x0)/(2r).
    pub fn cut_at(self, x0: f64, r: f64) -> Option<HalfAngle> {
        if x0 >= r {
            return None;
        }
        if x0 <= -r {
            return Some(self);
        }
        let cut = HalfAngle {
            sin: ((r - x0) / (2.0 * r)).sqrt(),
            cos: ((r + x0) / (2.0 * r)).sqrt(),
        };
        Some(if cut.sin < self.sin { cut } else { self })
    }
}

/// Half contact angle for sample radius `r`, tool position `r1`, pad radius `rt` (all ≥ 0, mm).
pub fn half_angle(r: f64, r1: f64, rt: f64) -> HalfAngle {
    if r == 0.0 || r1 == 0.0 {
        return on_axis(r + r1, rt);
    }
    let (sin, cos) = half_angle_off_axis(r, r1, rt);
    HalfAngle { sin, cos }
}

/// [`half_angle`] for a pad whose reach is given by its square `reach2` (> 0), as a curved part's
/// contact is: the factors' products are reach² − (r − r1)² and (r + r1)² − reach², so the reach
/// itself (a square root) is not needed, and they are as accurate (reach² is rounded once either
/// way, before its root or here).
pub fn half_angle_of_squared_reach(r: f64, r1: f64, reach2: f64) -> HalfAngle {
    let (near, far) = (r - r1, r + r1);
    if r == 0.0 || r1 == 0.0 {
        // r + r1 ≥ 0 against the reach, both squared.
        return on_axis(far * far, reach2);
    }
    let (sin, cos) = normalised(
        (reach2 - near * near).max(0.0),
        (far * far - reach2).max(0.0),
    );
    HalfAngle { sin, cos }
}

/// The limit from the interior where r or r1 is 0 (module docs): the whole ring under the pad
/// when `span` (r + r1, from the pad's centre to the ring's far side) is below the pad's
/// `radius`, none when beyond, half on the boundary (either both given squared).
fn on_axis(span: f64, radius: f64) -> HalfAngle {
    if span < radius {
        HalfAngle::FULL
    } else if span > radius {
        HalfAngle::NONE
    } else {
        HalfAngle {
            sin: FRAC_1_SQRT_2,
            cos: FRAC_1_SQRT_2,
        }
    }
}

/// [`half_angle`]'s (sin, cos) for r, r1 > 0: no branch, so a loop over many r1 vectorises.
#[inline(always)]
pub fn half_angle_off_axis(r: f64, r1: f64, rt: f64) -> (f64, f64) {
    normalised(
        ((rt - r + r1) * (rt + r - r1)).max(0.0),
        ((r + r1 - rt) * (r + r1 + rt)).max(0.0),
    )
}

/// (sin, cos) of the half-angle from 4·r·r1 times their squares, each clamped at zero.
#[inline(always)]
fn normalised(sin2: f64, cos2: f64) -> (f64, f64) {
    // sin2 + cos2 = 4·r·r1 > 0 whenever neither is clamped; if one is, the other is positive.
    // Below the least normal number (r1 ~ 1e-308 mm) its reciprocal overflows: scale both up
    // first (by 1 otherwise: the same bits, and a select, so the loop still vectorises).
    let sum = sin2 + cos2;
    let scale = if sum < f64::MIN_POSITIVE { 1e200 } else { 1.0 };
    let per_norm = 1.0 / (sum * scale);
    (
        (sin2 * scale * per_norm).sqrt(),
        (cos2 * scale * per_norm).sqrt(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

    #[test]
    fn agrees_with_arccos_away_from_tangency() {
        for (r, r1) in [(3.0, 8.0), (12.0, 15.0), (20.0, 25.0), (7.0, 4.0)] {
            let cos_theta: f64 = (r * r + r1 * r1 - 100.0) / (2.0 * r * r1);
            let theta0 = cos_theta.clamp(-1.0, 1.0).acos();
            let psi = half_angle(r, r1, 10.0).radians();
            assert!((2.0 * psi - theta0).abs() < 1e-14, "{r} {r1}");
        }
    }

    #[test]
    fn handles_tangency_coverage_and_the_centre() {
        assert_eq!(half_angle(25.0, 15.0, 10.0), HalfAngle::NONE); // external tangency
        assert_eq!(half_angle(5.0, 15.0, 10.0), HalfAngle::NONE); // tangency from inside
        assert_eq!(half_angle(40.0, 15.0, 10.0), HalfAngle::NONE); // far away
        assert_eq!(half_angle(4.0, 6.0, 10.0), HalfAngle::FULL); // internal tangency
        assert_eq!(half_angle(2.0, 3.0, 10.0), HalfAngle::FULL); // covered
        assert_eq!(half_angle(0.0, 3.0, 10.0), HalfAngle::FULL);
        assert_eq!(half_angle(3.0, 0.0, 10.0), HalfAngle::FULL);
        assert_eq!(half_angle(0.0, 12.0, 10.0), HalfAngle::NONE);
        assert!((half_angle(0.0, 10.0, 10.0).radians() - FRAC_PI_4).abs() < 1e-15);
        // Approaching r = 0 along r1 = r_t tends to θ0 = π/2, the value used at r = 0.
        assert!((2.0 * half_angle(1e-9, 10.0, 10.0).radians() - FRAC_PI_2).abs() < 1e-9);
    }

    /// From the reach's square: the same angle as from the reach to a few ulps of the
    /// half-angle's sine and cosine (≤ 1), over rings and pads in and out of contact, at
    /// tangency and on the axis. Just inside tangency (δ = 1e-9 mm) the sine is as accurate as
    /// a curved part's reach allows: reach² = c_t² − Δz² is rounded (~1e-16 of it) whether or not
    /// its root is taken, which is 2·r_t·δ·1e-6 here, so 1e-6 of the sine's square.
    #[test]
    fn the_squared_reach_gives_the_same_angle() {
        let mut worst: f64 = 0.0;
        for i in 0..=60 {
            for j in 0..=60 {
                for reach in [0.5, 7.3, 10.0, 19.9] {
                    let (r, r1) = (0.5 * i as f64, 0.5 * j as f64);
                    let want = half_angle(r, r1, reach);
                    let got = half_angle_of_squared_reach(r, r1, reach * reach);
                    worst = worst
                        .max((got.sin - want.sin).abs())
                        .max((got.cos - want.cos).abs());
                }
            }
        }
        assert!(worst < 1e-14, "{worst:e}");
        let (r, rt) = (20.0_f64, 10.0);
        let r1 = r + rt - 1e-9;
        let delta = (r + rt) - r1;
        let want = (delta * (2.0 * rt - delta) / (4.0 * r * r1)).sqrt();
        let got = half_angle_of_squared_reach(r, r1, rt * rt).sin;
        assert!((got - want).abs() < 1e-6 * want, "{got:e} vs {want:e}");
    }

    #[test]
    fn is_accurate_just_inside_tangency() {
        // r1 − r = r_t − δ: sin²(θ0/2) = δ(2r_t − δ)/(4 r r1) exactly.
        let (r, rt) = (20.0_f64, 10.0);
        let r1 = r + rt - 1e-9;
        let delta = (r + rt) - r1; // exact (Sterbenz), the δ actually represented
        let want = (delta * (2.0 * rt - delta) / (4.0 * r * r1)).sqrt();
        let got = half_angle(r, r1, rt).sin;
        // arccos of the quotient would be off by ~1e-8 relative here; we keep ~1e-15.
        assert!((got - want).abs() < 1e-13 * want, "{got:e} vs {want:e}");
    }
}
