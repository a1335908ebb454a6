//! The optical surface: plane, sphere, or an even asphere per ISO 10110-12 with polynomial terms
//! of any power (the form of the on-machine measurement paper, its eq. 1):
//!
//! ```text
//! z(r) = c·r² / (1 + √(1 − (1+k)·c²·r²)) + Σ aᵢ·|r|^i,    c = 1/R,  i ≥ 1,  aᵢ in mm^(1−i)
//! ```
//!
//! z runs along the rotation axis, positive toward the tool; R > 0 puts the centre of curvature
//! on the tool side (concave as the tool sees it). r is a signed coordinate along a meridian:
//! z is even in r, the slope odd. With s = √(1 − (1+k)·c²·r²) the conic part has the closed
//! forms (no cancellation anywhere on the domain s > 0)
//!
//! ```text
//! z′ = c·r/s,   z″ = c/s³,   ∂z/∂c = r²/(s·(1+s))
//! ```
//!
//! and the polynomial part is differentiated term by term. The slope angle is θ = atan z′, the
//! unit normal toward the tool n = (−sin θ, cos θ), the meridional curvature κ = z″·cos³θ.
//! Arc length from the vertex is s(r) = ∫₀^r √(1 + z′²) dr: in closed form on a plane and a
//! sphere (|R|·asin(r/|R|)), otherwise by adaptive 8-point Gauss–Legendre quadrature to
//! ~1e-13 mm; its inverse by safeguarded Newton steps.

/// Powers of the polynomial terms accepted (aᵢ·|r|^i).
pub const POWERS: std::ops::RangeInclusive<u32> = 1..=40;

/// A polynomial term aᵢ·|r|^i of an asphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolynomialTerm {
    pub power: u32,
    /// aᵢ in mm^(1−i).
    pub value: f64,
}

/// A surface as a caller describes it.
#[derive(Debug, Clone, PartialEq)]
pub enum SurfaceSpec {
    Plane,
    Sphere {
        radius_of_curvature_mm: f64,
    },
    Asphere {
        radius_of_curvature_mm: f64,
        conic_constant: f64,
        coefficients: Vec<PolynomialTerm>,
    },
}

/// Which part of a [`SurfaceSpec`] is wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SurfaceInput {
    RadiusOfCurvature,
    ConicConstant,
    /// The power of coefficient `index`.
    Power(usize),
    /// The value of coefficient `index`.
    Value(usize),
}

/// Why a surface was refused, or why it cannot hold a radius.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SurfaceError {
    #[error("must be a finite number")]
    NonFinite(SurfaceInput),
    #[error("must not be 0 (a plane has kind \"plane\")")]
    ZeroRadius,
    #[error("power {power} is out of range: powers run from 1 to 40")]
    PowerOutOfRange { index: usize, power: u32 },
    #[error("power {power} appears twice (coefficients {first} and {index})")]
    DuplicatePower {
        index: usize,
        first: usize,
        power: u32,
    },
    /// √(1 − (1+k)·c²·r²) is not real (or the slope is vertical) at this radius, or the
    /// polynomial overflows there.
    #[error("the surface is not defined at r = {radius_mm} mm{}", domain_note(*.domain_mm))]
    OutOfDomain { radius_mm: f64, domain_mm: f64 },
}

fn domain_note(domain_mm: f64) -> String {
    if domain_mm.is_finite() {
        format!(": its conic part needs |r| < {domain_mm} mm (1 − (1+k)·c²·r² > 0)")
    } else {
        " (the polynomial terms overflow)".into()
    }
}

impl SurfaceError {
    /// The input to blame, if one part of the spec is.
    pub fn input(&self) -> Option<SurfaceInput> {
        match self {
            SurfaceError::NonFinite(input) => Some(*input),
            SurfaceError::ZeroRadius => Some(SurfaceInput::RadiusOfCurvature),
            SurfaceError::PowerOutOfRange { index, .. }
            | SurfaceError::DuplicatePower { index, .. } => Some(SurfaceInput::Power(*index)),
            SurfaceError::OutOfDomain { .. } => None,
        }
    }
}

/// A validated surface. Build it with [`Surface::new`]; it is defined for |r| < [`Surface::domain_mm`].
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Vertex curvature c = 1/R, 1/mm (0 on a plane).
    curvature: f64,
    conic: f64,
    terms: Vec<PolynomialTerm>,
}

impl Default for Surface {
    fn default() -> Surface {
        Surface::plane()
    }
}

impl Surface {
    pub fn new(spec: &SurfaceSpec) -> Result<Surface, SurfaceError> {
        let radius = |r: f64| {
            if !r.is_finite() {
                Err(SurfaceError::NonFinite(SurfaceInput::RadiusOfCurvature))
            } else if r == 0.0 {
                Err(SurfaceError::ZeroRadius)
            } else {
                Ok(1.0 / r)
            }
        };
        match spec {
            SurfaceSpec::Plane => Ok(Surface::plane()),
            SurfaceSpec::Sphere {
                radius_of_curvature_mm,
            } => Ok(Surface {
                curvature: radius(*radius_of_curvature_mm)?,
                conic: 0.0,
                terms: Vec::new(),
            }),
            SurfaceSpec::Asphere {
                radius_of_curvature_mm,
                conic_constant,
                coefficients,
            } => {
                let curvature = radius(*radius_of_curvature_mm)?;
                if !conic_constant.is_finite() {
                    return Err(SurfaceError::NonFinite(SurfaceInput::ConicConstant));
                }
                for (index, term) in coefficients.iter().enumerate() {
                    if !POWERS.contains(&term.power) {
                        return Err(SurfaceError::PowerOutOfRange {
                            index,
                            power: term.power,
                        });
                    }
                    if let Some(first) = coefficients[..index]
                        .iter()
                        .position(|t| t.power == term.power)
                    {
                        return Err(SurfaceError::DuplicatePower {
                            index,
                            first,
                            power: term.power,
                        });
                    }
                    if !term.value.is_finite() {
                        return Err(SurfaceError::NonFinite(SurfaceInput::Value(index)));
                    }
                }
                Ok(Surface {
                    curvature,
                    conic: *conic_constant,
                    terms: coefficients.clone(),
                })
            }
        }
    }

    pub fn plane() -> Surface {
        Surface {
            curvature: 0.0,
            conic: 0.0,
            terms: Vec::new(),
        }
    }

    /// The same surface with another vertex curvature (conic and polynomial terms kept).
    pub fn with_vertex_curvature(&self, curvature_per_mm: f64) -> Surface {
        Surface {
            curvature: curvature_per_mm,
            ..self.clone()
        }
    }

    /// c = 1/R in 1/mm; 0 on a plane.
    pub fn vertex_curvature_per_mm(&self) -> f64 {
        self.curvature
    }

    /// R in mm; `None` when the vertex curvature is 0.
    pub fn radius_of_curvature_mm(&self) -> Option<f64> {
        (self.curvature != 0.0).then(|| 1.0 / self.curvature)
    }

    /// Every number that defines the surface, as bits (equal surfaces give equal keys): for
    /// caches keyed on the geometry.
    pub fn key_bits(&self) -> Vec<u64> {
        // The term count first, so that a key followed by other numbers stays unambiguous.
        let mut key = vec![
            self.terms.len() as u64,
            self.curvature.to_bits(),
            self.conic.to_bits(),
        ];
        for term in &self.terms {
            key.extend([u64::from(term.power), term.value.to_bits()]);
        }
        key
    }

    pub fn is_plane(&self) -> bool {
        self.curvature == 0.0 && self.terms.is_empty()
    }

    /// A sphere: curved, with no conic or polynomial departure.
    pub fn is_sphere(&self) -> bool {
        self.curvature != 0.0 && self.conic == 0.0 && self.terms.is_empty()
    }

    /// The radius where the conic's square root stops being real: |r| must stay below it
    /// (infinite when (1+k)·c² ≤ 0).
    pub fn domain_mm(&self) -> f64 {
        let q = (1.0 + self.conic) * self.curvature * self.curvature;
        if q > 0.0 {
            1.0 / q.sqrt()
        } else {
            f64::INFINITY
        }
    }

    /// Checks that the surface, its slope and curvature are defined and finite for |r| ≤ `r_mm`.
    pub fn check_defined_to(&self, r_mm: f64) -> Result<(), SurfaceError> {
        let r = r_mm.abs();
        let domain_mm = self.domain_mm();
        let defined = r < domain_mm
            && self.root(r) > 0.0
            && [self.sag_mm(r), self.slope(r), self.second_derivative(r)]
                .iter()
                .all(|v| v.is_finite());
        if defined {
            Ok(())
        } else {
            Err(SurfaceError::OutOfDomain {
                radius_mm: r_mm,
                domain_mm,
            })
        }
    }

    /// s = √(1 − (1+k)·c²·r²).
    fn root(&self, r: f64) -> f64 {
        let cr = self.curvature * r;
        (1.0 - (1.0 + self.conic) * cr * cr).sqrt()
    }

    /// Sag z(r) in mm (even in r).
    pub fn sag_mm(&self, r: f64) -> f64 {
        self.sag_given_root(r, self.root(r))
    }

    /// z, z′ and z″ at r, the conic's root taken once (the same values as [`Self::sag_mm`],
    /// [`Self::slope`] and [`Self::second_derivative`]).
    pub fn local(&self, r: f64) -> Local {
        let s = self.root(r);
        Local {
            sag_mm: self.sag_given_root(r, s),
            slope: self.slope_given_root(r, s),
            second_derivative: self.second_derivative_given_root(r, s),
        }
    }

    /// z at r and the slope's frame there, (ds/dr, sin θ, cos θ) as [`slope_frame`] gives it.
    /// On a sphere, z = c·r²/(1 + s) with s = √(1 − c²r²), so z′ = c·r/s and √(1 + z′²) = 1/s:
    /// cos θ is the root s itself and sin θ = c·r, one root and two divisions in all.
    pub fn sag_and_frame(&self, r: f64) -> (f64, (f64, f64, f64)) {
        let s = self.root(r);
        let sag = self.sag_given_root(r, s);
        if self.is_sphere() {
            (sag, (1.0 / s, self.curvature * r, s))
        } else {
            (sag, slope_frame(self.slope_given_root(r, s)))
        }
    }

    fn sag_given_root(&self, r: f64, s: f64) -> f64 {
        let conic = self.curvature * r * r / (1.0 + s);
        let a = r.abs();
        conic
            + self
                .terms
                .iter()
                .map(|t| t.value * a.powi(t.power as i32))
                .sum::<f64>()
    }

    /// dz/dr (odd in r).
    pub fn slope(&self, r: f64) -> f64 {
        self.slope_given_root(r, self.root(r))
    }

    fn slope_given_root(&self, r: f64, s: f64) -> f64 {
        let a = r.abs();
        let poly: f64 = self
            .terms
            .iter()
            .map(|t| t.power as f64 * t.value * a.powi(t.power as i32 - 1))
            .sum();
        let poly = match r.partial_cmp(&0.0) {
            Some(std::cmp::Ordering::Less) => -poly,
            Some(std::cmp::Ordering::Greater) => poly,
            _ => 0.0, // |r| has no slope at the vertex; its one-sided slopes cancel
        };
        self.curvature * r / s + poly
    }

    /// d²z/dr² (even in r; the |r| term contributes nothing).
    pub fn second_derivative(&self, r: f64) -> f64 {
        self.second_derivative_given_root(r, self.root(r))
    }

    fn second_derivative_given_root(&self, r: f64, s: f64) -> f64 {
        let a = r.abs();
        let poly: f64 = self
            .terms
            .iter()
            .filter(|t| t.power >= 2)
            .map(|t| {
                let p = t.power as f64;
                p * (p - 1.0) * t.value * a.powi(t.power as i32 - 2)
            })
            .sum();
        self.curvature / (s * s * s) + poly
    }

    /// Slope angle θ = atan z′(r), rad.
    pub fn slope_angle_rad(&self, r: f64) -> f64 {
        self.slope(r).atan()
    }

    /// Unit normal toward the tool, (−sin θ, cos θ).
    pub fn normal(&self, r: f64) -> (f64, f64) {
        let (sin, cos) = slope_sin_cos(self.slope(r));
        (-sin, cos)
    }

    /// Meridional curvature κ = z″/(1 + z′²)^(3/2), 1/mm (> 0 concave toward the tool).
    pub fn curvature_per_mm(&self, r: f64) -> f64 {
        let cos = self.slope_angle_rad(r).cos();
        self.second_derivative(r) * cos * cos * cos
    }

    /// ∂z/∂c at fixed r and k: how the sag moves with the vertex curvature.
    pub fn sag_derivative_by_curvature(&self, r: f64) -> f64 {
        let s = self.root(r);
        r * r / (s * (1.0 + s))
    }

    /// Arc length along the meridian from the vertex to r, mm (odd in r).
    pub fn arc_length_mm(&self, r: f64) -> f64 {
        let a = r.abs();
        let length = if self.is_plane() {
            a
        } else if self.is_sphere() {
            let c = self.curvature.abs();
            (c * a).asin() / c
        } else {
            self.arc_between(0.0, a)
        };
        length.copysign(r)
    }

    /// The radius whose arc length from the vertex is `s_mm` (odd); the inverse of
    /// [`Surface::arc_length_mm`] on the surface's domain.
    pub fn radius_at_arc_length(&self, s_mm: f64) -> f64 {
        let target = s_mm.abs();
        let r = if self.is_plane() {
            target
        } else if self.is_sphere() {
            let c = self.curvature.abs();
            (c * target).min(std::f64::consts::FRAC_PI_2).sin() / c
        } else {
            self.invert_arc(target)
        };
        r.copysign(s_mm)
    }

    /// ds/dr = √(1 + z′²) at r.
    pub fn arc_integrand(&self, r: f64) -> f64 {
        stretch(self.slope(r))
    }

    fn arc_between(&self, a: f64, b: f64) -> f64 {
        adaptive_gauss_legendre(&|r| self.arc_integrand(r), a, b, 1e-14)
    }

    /// Newton on s(r) = target from r = target (s ≥ r, so r ≤ target), each step integrating
    /// only the stretch since the last iterate; bisection keeps it inside the bracket.
    fn invert_arc(&self, target: f64) -> f64 {
        // Just inside a finite domain, where the slope is still finite (the arc there is the
        // most the surface has; beyond it the caller sees s(r) fall short of the target).
        let (mut lo, mut hi) = (0.0, target.min(self.domain_mm() * (1.0 - 1e-12)));
        // Start inside, away from a domain edge where the arc integral is ill-conditioned
        // (each step only adds the stretch since the last iterate, so a poor start would stay).
        let mut r = if target < self.domain_mm() {
            hi
        } else {
            0.5 * hi
        };
        let mut s = self.arc_between(0.0, r);
        for _ in 0..100 {
            let miss = s - target;
            if miss > 0.0 {
                hi = r;
            } else {
                lo = r;
            }
            if miss.abs() <= 1e-15 * target.max(1.0) || hi - lo <= 1e-15 * hi {
                break;
            }
            let mut next = r - miss / self.arc_integrand(r);
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            s += if next > r {
                self.arc_between(r, next)
            } else {
                -self.arc_between(next, r)
            };
            r = next;
        }
        r
    }
}

/// A surface near one radius: z, z′ and z″ there.
#[derive(Debug, Clone, Copy)]
pub struct Local {
    pub sag_mm: f64,
    pub slope: f64,
    pub second_derivative: f64,
}

impl Local {
    /// ds/dr = √(1 + z′²), as [`Surface::arc_integrand`].
    pub fn arc_integrand(&self) -> f64 {
        stretch(self.slope)
    }

    /// (sin θ, cos θ) of the slope angle θ = atan z′.
    pub fn slope_sin_cos(&self) -> (f64, f64) {
        slope_sin_cos(self.slope)
    }
}

/// (sin θ, cos θ) of the slope angle θ = atan z′, without trigonometry:
/// cos θ = 1/√(1 + z′²), sin θ = z′·cos θ.
fn slope_sin_cos(slope: f64) -> (f64, f64) {
    let (_, sin, cos) = slope_frame(slope);
    (sin, cos)
}

/// (ds/dr, sin θ, cos θ) for the slope z′, from one square root: ds/dr = √(1 + z′²), and
/// [`slope_sin_cos`]'s sine and cosine.
pub fn slope_frame(slope: f64) -> (f64, f64, f64) {
    let stretch = stretch(slope);
    let cos = 1.0 / stretch;
    (stretch, slope * cos, cos)
}

/// ds/dr = √(1 + z′²) for the slope z′, directly: hypot's guard against overflow costs more
/// than the square, which no finite slope of a part overflows.
fn stretch(slope: f64) -> f64 {
    (1.0 + slope * slope).sqrt()
}

/// 8-point Gauss–Legendre nodes and weights on [−1, 1] (positive half).
pub(crate) const GL8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
];

fn gauss_legendre(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
    half * GL8
        .iter()
        .map(|&(x, w)| w * (f(mid - half * x) + f(mid + half * x)))
        .sum::<f64>()
}

/// ∫ₐᵇ f by bisection until a panel's rule and its two halves agree to `tol` per unit length
/// (absolute), with a floor at the rounding of the panel's value.
/// Most panels one arc-length integral is split into.
const MAX_PANELS: usize = 20_000;

fn adaptive_gauss_legendre(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    let density = tol / (b - a).max(1.0);
    let mut stack = vec![(a, b, gauss_legendre(f, a, b))];
    let mut total = 0.0;
    let mut panels = 0;
    while let Some((a, b, whole)) = stack.pop() {
        panels += 1;
        let m = 0.5 * (a + b);
        let (left, right) = (gauss_legendre(f, a, m), gauss_legendre(f, m, b));
        let error = (left + right - whole).abs();
        // A non-finite panel (outside the domain) cannot improve by splitting: it is kept,
        // and the total is not finite.
        if error <= density * (b - a)
            || !error.is_finite()
            || error <= 4.0 * f64::EPSILON * whole.abs()
            // Near the edge of a conic's domain the slope itself is ill-conditioned (1 − q²
            // cancels), so rounding noise may never let two rules agree: a panel budget keeps
            // the cost bounded, the result then as good as the slope can be evaluated.
            || panels >= MAX_PANELS
            || m <= a
            || m >= b
        {
            total += left + right;
        } else {
            stack.push((m, b, right));
            stack.push((a, m, left));
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    fn asphere(r: f64, k: f64, terms: &[(u32, f64)]) -> Result<Surface, SurfaceError> {
        Surface::new(&SurfaceSpec::Asphere {
            radius_of_curvature_mm: r,
            conic_constant: k,
            coefficients: terms
                .iter()
                .map(|&(power, value)| PolynomialTerm { power, value })
                .collect(),
        })
    }

    #[test]
    fn gauss_legendre_is_exact_for_degree_fifteen() {
        // ∫₀¹ x¹⁵ = 1/16, ∫₋₁¹ x¹⁴ = 2/15: one panel, error only from rounding (and the nodes).
        assert!((gauss_legendre(&|x| x.powi(15), 0.0, 1.0) - 1.0 / 16.0).abs() < 1e-16);
        assert!((gauss_legendre(&|x| x.powi(14), -1.0, 1.0) - 2.0 / 15.0).abs() < 1e-15);
        let sin = adaptive_gauss_legendre(&f64::cos, 0.0, 3.0, 1e-14);
        assert!((sin - 3f64.sin()).abs() < 1e-14);
    }

    #[test]
    fn derivatives_match_central_differences() {
        let s = asphere(-40.0, -0.7, &[(1, 1e-4), (4, 2e-6), (6, -3e-9), (7, 1e-11)]).unwrap();
        for r in [-14.0, -3.0, 0.5, 7.0, 15.0] {
            let h = 1e-5;
            let d1 = (s.sag_mm(r + h) - s.sag_mm(r - h)) / (2.0 * h);
            let d2 = (s.slope(r + h) - s.slope(r - h)) / (2.0 * h);
            // Central differences are O(h²) ≈ 1e-10 here, rounding ~eps·z/h ≈ 1e-11.
            assert!((d1 - s.slope(r)).abs() < 1e-9, "slope at {r}");
            assert!((d2 - s.second_derivative(r)).abs() < 1e-8, "z'' at {r}");
            let c = s.vertex_curvature_per_mm();
            let dc = 1e-9;
            let by_c = (s.with_vertex_curvature(c + dc).sag_mm(r)
                - s.with_vertex_curvature(c - dc).sag_mm(r))
                / (2.0 * dc);
            assert!((by_c - s.sag_derivative_by_curvature(r)).abs() < 1e-6 * by_c.abs().max(1.0));
        }
    }

    /// A sphere's frame in closed form (cos θ = s, sin θ = c·r, ds/dr = 1/s) is the general one
    /// from its slope, to a few ulps, convex and concave, from the vertex to near the edge of
    /// the hemisphere (where s → 0 and ds/dr grows as 1/s: compared relative to it).
    #[test]
    fn a_spheres_frame_is_its_slopes() {
        for radius in [100.0, -60.0, 12.5] {
            let sphere = Surface::new(&SurfaceSpec::Sphere {
                radius_of_curvature_mm: radius,
            })
            .unwrap();
            for i in 0..200 {
                let r = 0.99 * f64::abs(radius) * i as f64 / 200.0;
                let (sag, (stretch, sin, cos)) = sphere.sag_and_frame(r);
                let (want_stretch, want_sin, want_cos) = slope_frame(sphere.slope(r));
                assert_eq!(sag, sphere.sag_mm(r));
                assert!(
                    (stretch - want_stretch).abs() < 1e-14 * want_stretch,
                    "{radius} {r}"
                );
                assert!((sin - want_sin).abs() < 1e-14, "{radius} {r}");
                assert!((cos - want_cos).abs() < 1e-14, "{radius} {r}");
            }
        }
    }

    #[test]
    fn refuses_bad_specs_naming_the_input() {
        let bad = |spec| Surface::new(&spec).unwrap_err();
        assert_eq!(
            bad(SurfaceSpec::Sphere {
                radius_of_curvature_mm: 0.0
            }),
            SurfaceError::ZeroRadius
        );
        assert_eq!(
            asphere(10.0, f64::NAN, &[]).unwrap_err().input(),
            Some(SurfaceInput::ConicConstant)
        );
        assert_eq!(
            asphere(10.0, 0.0, &[(4, 1.0), (0, 1.0)]).unwrap_err(),
            SurfaceError::PowerOutOfRange { index: 1, power: 0 }
        );
        assert_eq!(
            asphere(10.0, 0.0, &[(4, 1.0), (6, 1.0), (4, 2.0)]).unwrap_err(),
            SurfaceError::DuplicatePower {
                index: 2,
                first: 0,
                power: 4
            }
        );
        assert_eq!(
            asphere(10.0, 0.0, &[(4, f64::INFINITY)])
                .unwrap_err()
                .input(),
            Some(SurfaceInput::Value(0))
        );
    }

    #[test]
    fn the_domain_ends_where_the_root_turns_imaginary() {
        let sphere = Surface::new(&SurfaceSpec::Sphere {
            radius_of_curvature_mm: -20.0,
        })
        .unwrap();
        assert_eq!(sphere.domain_mm(), 20.0);
        assert!(sphere.check_defined_to(19.99).is_ok());
        let err = sphere.check_defined_to(-20.0).unwrap_err();
        assert!(matches!(err, SurfaceError::OutOfDomain { radius_mm, .. } if radius_mm == -20.0));
        // A hyperbola (k < −1) is defined everywhere; an oblate ellipse (k > 0) less far.
        assert_eq!(asphere(20.0, -2.0, &[]).unwrap().domain_mm(), f64::INFINITY);
        assert!((asphere(20.0, 3.0, &[]).unwrap().domain_mm() - 10.0).abs() < 1e-15);
        // Polynomial overflow is out of the domain as well.
        assert!(asphere(20.0, -2.0, &[(40, 1e300)])
            .unwrap()
            .check_defined_to(100.0)
            .is_err());
    }

    #[test]
    fn arc_length_inverts_and_is_odd() {
        let s = asphere(30.0, -1.5, &[(4, 1e-6), (6, 2e-10)]).unwrap();
        for r in [-12.0, -0.01, 0.0, 3.0, 12.0] {
            let length = s.arc_length_mm(r);
            assert!((s.arc_length_mm(-r) + length).abs() <= 1e-15 * length.abs().max(1.0));
            assert!(
                (s.radius_at_arc_length(length) - r).abs() < 1e-12,
                "r = {r}"
            );
        }
        let sphere = Surface::new(&SurfaceSpec::Sphere {
            radius_of_curvature_mm: 25.0,
        })
        .unwrap();
        let quarter = sphere.arc_length_mm(25.0 * 0.5f64.sqrt());
        assert!((quarter - 25.0 * std::f64::consts::FRAC_PI_4).abs() < 1e-13);
        assert!((sphere.radius_at_arc_length(quarter) - 25.0 * 0.5f64.sqrt()).abs() < 1e-13);
    }
}
