//! What a probe reports over a point of the design.
//!
//! A sharp tip reports the surface: g(X) = z(X). A ball of radius ρ touches the surface at a
//! point P(r) = (r, z(r)) where its centre sits on the normal, C = P + ρ·n, n = (−sin θ, cos θ);
//! the measured points are centres, so
//!
//! ```text
//! normal:  g(X) = z(r) + ρ·cos θ(r)   with r solving  r − ρ·sin θ(r) = X,
//! axial:   g(X) = z(X) + ρ            (the tip lifted straight up, exact only where θ = 0).
//! ```
//!
//! The offset curve has the surface's slope at corresponding points (dC/dr ∥ dP/dr), so
//! g′(X) = z′(r), and moving the vertex curvature moves g exactly as it moves z at the contact
//! (∂g/∂c = ∂z/∂c(r): the envelope property). r − ρ·sin θ(r) increases while ρ·κ(r) < 1, i.e.
//! while the ball is smaller than the concave radius of curvature, which is what lets it touch
//! everywhere; the contact radius is found by Newton steps from r = X.

use crate::surface::{Surface, SurfaceError};

/// How the probe-tip radius is taken out of the trace.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compensation {
    /// Along the surface normal (exact for a ball).
    Normal,
    /// Along the axis: the tip radius subtracted from Z (the approximation that errs on slopes).
    Axial,
}

/// A probe: its tip radius and how the radius is compensated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    tip_radius_mm: f64,
    compensation: Compensation,
}

/// The largest tip radius accepted, mm: the model's largest radius (a probe is far smaller;
/// beyond it the compensated heights and their residuals in nm can overflow).
pub const MAX_TIP_RADIUS_MM: f64 = 1e5;

/// Why a probe cannot report a point.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProbeError {
    #[error("probe_tip_radius_mm must be a number in [0, {MAX_TIP_RADIUS_MM}] mm")]
    BadTipRadius,
    #[error("{0}")]
    OffSurface(SurfaceError),
    #[error(
        "the probe tip ({tip_radius_mm} mm) is larger than the surface's concave radius of \
         curvature near r = {radius_mm} mm: a ball that size cannot touch it there"
    )]
    TipTooLarge { tip_radius_mm: f64, radius_mm: f64 },
}

/// The probe's height over a point, its slope there, and where the tip touches the design.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Height {
    /// g(X), mm.
    pub height_mm: f64,
    /// g′(X) = z′(contact).
    pub slope: f64,
    /// Signed radius of the contact point on the design, mm.
    pub contact_mm: f64,
}

impl Probe {
    pub fn new(tip_radius_mm: f64, compensation: Compensation) -> Result<Probe, ProbeError> {
        if !(0.0..=MAX_TIP_RADIUS_MM).contains(&tip_radius_mm) {
            return Err(ProbeError::BadTipRadius);
        }
        Ok(Probe {
            tip_radius_mm,
            compensation,
        })
    }

    /// A sharp tip (the points are contact points).
    pub fn sharp() -> Probe {
        Probe {
            tip_radius_mm: 0.0,
            compensation: Compensation::Normal,
        }
    }

    pub fn tip_radius_mm(&self) -> f64 {
        self.tip_radius_mm
    }

    pub fn compensation(&self) -> Compensation {
        self.compensation
    }

    /// What the probe reports over `x_mm` (in the part's frame) on `surface`.
    pub fn height(&self, surface: &Surface, x_mm: f64) -> Result<Height, ProbeError> {
        let rho = self.tip_radius_mm;
        if rho == 0.0 || self.compensation == Compensation::Axial {
            surface
                .check_defined_to(x_mm)
                .map_err(ProbeError::OffSurface)?;
            return Ok(Height {
                height_mm: surface.sag_mm(x_mm) + rho,
                slope: surface.slope(x_mm),
                contact_mm: x_mm,
            });
        }
        let r = self.contact(surface, x_mm)?;
        let theta = surface.slope_angle_rad(r);
        Ok(Height {
            height_mm: surface.sag_mm(r) + rho * theta.cos(),
            slope: surface.slope(r),
            contact_mm: r,
        })
    }

    /// The contact radius r with r − ρ·sin θ(r) = x, by Newton steps (f′ = 1 − ρ·κ > 0).
    fn contact(&self, surface: &Surface, x: f64) -> Result<f64, ProbeError> {
        let rho = self.tip_radius_mm;
        let mut r = x;
        for _ in 0..100 {
            surface
                .check_defined_to(r)
                .map_err(ProbeError::OffSurface)?;
            let theta = surface.slope_angle_rad(r);
            let derivative = 1.0 - rho * surface.curvature_per_mm(r);
            if derivative <= 0.0 {
                return Err(ProbeError::TipTooLarge {
                    tip_radius_mm: rho,
                    radius_mm: r,
                });
            }
            let step = (r - rho * theta.sin() - x) / derivative;
            r -= step;
            if step.abs() <= 4.0 * f64::EPSILON * r.abs().max(rho) {
                surface
                    .check_defined_to(r)
                    .map_err(ProbeError::OffSurface)?;
                return Ok(r);
            }
        }
        // f is increasing with f′ bounded away from 0 on the way: Newton converges long before
        // 100 steps unless f′ approaches 0, i.e. the tip is about as large as the radius.
        Err(ProbeError::TipTooLarge {
            tip_radius_mm: rho,
            radius_mm: r,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::SurfaceSpec;

    fn sphere(radius_mm: f64) -> Surface {
        Surface::new(&SurfaceSpec::Sphere {
            radius_of_curvature_mm: radius_mm,
        })
        .unwrap()
    }

    /// The centre of a ball rolling on a sphere of radius R (centre (0, R)) stays at distance
    /// |R| − ρ (concave) or |R| + ρ (convex) from the sphere's centre.
    #[test]
    fn a_ball_on_a_sphere_follows_a_concentric_sphere() {
        for radius in [12.0, -12.0, 80.0] {
            let surface = sphere(radius);
            let probe = Probe::new(0.25, Compensation::Normal).unwrap();
            for x in [-9.0, -1.0, 0.0, 0.3, 6.0, 9.5] {
                let h = probe.height(&surface, x).unwrap();
                let distance = x.hypot(h.height_mm - radius);
                assert!(
                    (distance - (radius.abs() - 0.25 * radius.signum())).abs() < 1e-13,
                    "R {radius}, x {x}: {distance}"
                );
                // The contact lies on the line from the centre of curvature through the ball.
                let cross = h.contact_mm * (h.height_mm - radius)
                    - x * (surface.sag_mm(h.contact_mm) - radius);
                assert!(cross.abs() < 1e-11, "R {radius}, x {x}: {cross}");
            }
        }
    }

    #[test]
    fn a_ball_larger_than_a_concave_radius_cannot_touch() {
        let probe = Probe::new(5.0, Compensation::Normal).unwrap();
        assert!(matches!(
            probe.height(&sphere(4.0), 1.0),
            Err(ProbeError::TipTooLarge { .. })
        ));
        assert!(probe.height(&sphere(-4.0), 1.0).is_ok());
        assert_eq!(
            Probe::new(-1.0, Compensation::Normal),
            Err(ProbeError::BadTipRadius)
        );
        // Found by schemathesis: a 5.7e307 mm tip overflowed the residuals to null.
        for tip in [5.673911824096479e307, f64::INFINITY, f64::NAN, 1.0001e5] {
            assert_eq!(
                Probe::new(tip, Compensation::Normal),
                Err(ProbeError::BadTipRadius)
            );
        }
        assert!(Probe::new(1e5, Compensation::Normal).is_ok());
        assert!(matches!(
            Probe::sharp().height(&sphere(4.0), 4.5),
            Err(ProbeError::OffSurface(_))
        ));
    }
}
