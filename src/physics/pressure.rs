//! Pressure models: how the pad pressure depends on where the tool centre sits.
//!
//! * [`PressureModel::Uniform`] (default, the paper's assumption): the pressure is the nominal
//!   pressure P everywhere under the pad, wherever the pad is, including when it overhangs the
//!   workpiece edge. It models a position-controlled (constant-pressure, e.g. pneumatic
//!   bladder) head and neglects the edge effects that real pads show.
//! * [`PressureModel::ConstantForce`]: the head applies a constant force F = P·π·r_t² (the
//!   nominal pressure times the full pad area). While the pad lies wholly on the workpiece the
//!   pressure is P; once it overhangs (r1 + r_t > r_m) the same force rests on the smaller
//!   contact area A(r1), the lens where the pad disc and the workpiece disc overlap, so
//!   P(r1) = F / A(r1) = P·π·r_t² / A(r1), still uniform over the contact. It assumes a rigid,
//!   flat pad and workpiece (no tilt, no pressure peak at the edge); the pressure grows without
//!   bound as the overlap vanishes, which is why this model keeps the tool centre on the
//!   workpiece (r1 ≤ r_m, see [`super::Process::max_tool_position_mm`]).
//!
//! Lens area of two discs with radii R, ρ and centre distance d (|R − ρ| < d < R + ρ):
//!
//! ```text
//! A = ρ²·acos((d² + ρ² − R²)/(2dρ)) + R²·acos((d² + R² − ρ²)/(2dR))
//!     − ½·√((−d + ρ + R)(d + ρ − R)(d − ρ + R)(d + ρ + R))
//! ```
//!
//! with each angle computed as atan2(√(…), d² + ρ² − R²) (the same angle, well conditioned
//! near tangency, where the acos of a cosine near ±1 loses half the digits).

use std::f64::consts::PI;

/// How pressure varies with the tool position (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PressureModel {
    #[default]
    Uniform,
    ConstantForce,
}

/// Area in mm² where a pad of radius `tool_radius` centred at `position` overlaps a workpiece
/// disc of radius `workpiece_radius` centred at the origin.
pub fn contact_area_mm2(workpiece_radius: f64, tool_radius: f64, position: f64) -> f64 {
    let (big, small, d) = (workpiece_radius, tool_radius, position.abs());
    if d >= big + small {
        return 0.0;
    }
    if d <= (big - small).abs() {
        let r = big.min(small);
        return PI * r * r;
    }
    // √kite is four times the area of the triangle of the centres and a crossing point.
    let kite = (-d + small + big) * (d + small - big) * (d - small + big) * (d + small + big);
    let root = kite.max(0.0).sqrt();
    let angle_small = root.atan2(d * d + small * small - big * big);
    let angle_big = root.atan2(d * d + big * big - small * small);
    small * small * angle_small + big * big * angle_big - 0.5 * root
}

/// Pressure at tool position `position` relative to the nominal pressure (a factor ≥ 1 under
/// constant force, exactly 1 under uniform pressure). Positions beyond the last contact give 0.
pub fn pressure_factor(
    model: PressureModel,
    workpiece_radius: f64,
    tool_radius: f64,
    position: f64,
) -> f64 {
    match model {
        PressureModel::Uniform => 1.0,
        PressureModel::ConstantForce => {
            let area = contact_area_mm2(workpiece_radius, tool_radius, position);
            if area > 0.0 {
                PI * tool_radius * tool_radius / area
            } else {
                0.0
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute-force overlap area by counting cell centres of a fine square grid.
    fn counted_area(big: f64, small: f64, d: f64) -> f64 {
        let n = 2000;
        let (x0, x1) = (d - small, d + small);
        let h = (x1 - x0) / n as f64;
        let mut inside = 0usize;
        for i in 0..n {
            let x = x0 + (i as f64 + 0.5) * h;
            for j in 0..n {
                let y = -small + (j as f64 + 0.5) * h;
                if (x - d) * (x - d) + y * y <= small * small && x * x + y * y <= big * big {
                    inside += 1;
                }
            }
        }
        inside as f64 * h * h
    }

    #[test]
    fn lens_area_matches_a_brute_force_count() {
        // A 2000² grid over the pad resolves the area to ~1e-3 relative (boundary cells).
        for d in [41.0, 45.0, 50.0, 55.0, 59.0] {
            let exact = contact_area_mm2(50.0, 10.0, d);
            let counted = counted_area(50.0, 10.0, d);
            assert!(
                (exact - counted).abs() < 2e-3 * exact,
                "d {d}: {exact} vs {counted}"
            );
        }
    }

    #[test]
    fn area_limits_are_exact() {
        assert_eq!(contact_area_mm2(50.0, 10.0, 30.0), PI * 100.0);
        assert_eq!(contact_area_mm2(50.0, 10.0, 40.0), PI * 100.0);
        assert_eq!(contact_area_mm2(50.0, 10.0, 60.0), 0.0);
        // Tool larger than the workpiece: the whole workpiece is covered.
        assert_eq!(contact_area_mm2(5.0, 10.0, 2.0), PI * 25.0);
        // Equal discs one radius apart: the lens is (2π/3 − √3/2)·r² exactly.
        let lens = contact_area_mm2(10.0, 10.0, 10.0);
        let want = (2.0 * PI / 3.0 - 3f64.sqrt() / 2.0) * 100.0;
        assert!((lens - want).abs() < 1e-12 * want, "{lens} vs {want}");
    }

    #[test]
    fn constant_force_raises_pressure_only_when_overhanging() {
        let f = |d| pressure_factor(PressureModel::ConstantForce, 50.0, 10.0, d);
        assert_eq!(f(0.0), 1.0);
        assert_eq!(f(40.0), 1.0);
        assert!(f(45.0) > 1.0 && f(50.0) > f(45.0));
        assert_eq!(
            pressure_factor(PressureModel::Uniform, 50.0, 10.0, 50.0),
            1.0
        );
    }
}
