//! The dwell map of an X-Y machine: the least-squares plan on a raster
//! ([`crate::physics::raster`]) within the dwell bounds, the total time and each axis's
//! velocity and acceleration, solved by projected Newton ([`super::bounded`]).
//!
//! # The axes' limits as floors on the dwell
//!
//! The executed motion is a chain of blocks (a stop, or a half-leg of a cell at constant
//! velocity). Block b spends the share φ_b of its point k's dwell and moves each axis by Δ_b,
//! so the axis runs at v_b = c_b/t_k with c_b = Δ_b/φ_b. A velocity limit v_max is the floor
//! t_k ≥ |c_b|/v_max. Between blocks b and b + 1 (points k and k′) the acceleration model of
//! the program ([`crate::physics::motion::acceleration`]) gives
//!
//! ```text
//! a = |c_b/t_k − c_{b+1}/t_k′| / ((φ_b·t_k + φ_{b+1}·t_k′)/2)
//! ```
//!
//! If both dwells are at least f, the numerator is at most N/f, with N = max(|c_b|, |c_{b+1}|)
//! when the two velocities have one sign and |c_b| + |c_{b+1}| when they reverse, and the
//! denominator at least (φ_b + φ_{b+1})·f/2; so f = √(2N/((φ_b + φ_{b+1})·a_max)), made a floor
//! of both points, keeps a ≤ a_max whatever the dwells above it. The floors are sufficient,
//! not necessary: a plan could sometimes go below them (the radial optimizer's
//! convex–concave rows are exact), but each is a bound, which keeps the solver a
//! bound-constrained least squares, and with a leg of a millimetre at a few m/min and m/s²
//! they are milliseconds. Stops stand still (c = 0); the program approaches the first point
//! and leaves the last at rest.

use super::bounded::{self, BoundedProblem, BoundedSolution};
use super::operator::DwellOperator;
use crate::physics::motion::acceleration;
use crate::physics::raster::{Block, Raster};

/// One linear axis's limits, in the program's units; `None` is unlimited.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisCaps {
    pub max_velocity_mm_per_min: Option<f64>,
    pub max_acceleration_mm_per_s2: Option<f64>,
}

/// Peak |velocity| and |acceleration| of one axis over a motion.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisPeaks {
    pub velocity_mm_per_min: f64,
    pub acceleration_mm_per_s2: f64,
}

/// The least dwell of each point that keeps every block within the axes' (X, Y) limits
/// (module docs), s.
pub fn floors(raster: &Raster, axes: [AxisCaps; 2]) -> Vec<f64> {
    let n = raster.len();
    let unit = raster.blocks(&vec![1.0; n]);
    let mut floors = vec![0.0_f64; n];
    for (axis, caps) in axes.iter().enumerate() {
        // c_b: the block's axis velocity at a dwell of 1 s, mm/s.
        let speed: Vec<f64> = unit
            .iter()
            .map(|b| {
                if b.duration_s > 0.0 {
                    (b.to_mm[axis] - b.from_mm[axis]) / b.duration_s
                } else {
                    0.0
                }
            })
            .collect();
        if let Some(v) = caps.max_velocity_mm_per_min {
            let v = v / 60.0;
            for (b, c) in unit.iter().zip(&speed) {
                floors[b.point] = floors[b.point].max(c.abs() / v);
            }
        }
        if let Some(a) = caps.max_acceleration_mm_per_s2 {
            for (pair, c) in unit.windows(2).zip(speed.windows(2)) {
                let numerator = if c[0] * c[1] >= 0.0 {
                    c[0].abs().max(c[1].abs())
                } else {
                    c[0].abs() + c[1].abs()
                };
                let shares = pair[0].duration_s + pair[1].duration_s;
                if numerator > 0.0 && shares > 0.0 {
                    let f = (2.0 * numerator / (shares * a)).sqrt();
                    for b in pair {
                        floors[b.point] = floors[b.point].max(f);
                    }
                }
            }
        }
    }
    // A hair above the bound, so that rounding in the program's own arithmetic cannot put a
    // peak a few ulps over its limit.
    floors.iter_mut().for_each(|f| *f *= 1.0 + 1e-9);
    floors
}

/// Each axis's (X, Y) peaks over `blocks` by the program's model: a block's velocity is its
/// move over its duration, and consecutive blocks' velocities change over the mean of their
/// durations, from rest before the first and to rest after the last. A block that moves in
/// no time has an infinite velocity.
pub fn peaks(blocks: &[Block]) -> [AxisPeaks; 2] {
    let mut out = [AxisPeaks::default(); 2];
    for (axis, peak) in out.iter_mut().enumerate() {
        let velocity = |b: &Block| {
            let d = b.to_mm[axis] - b.from_mm[axis];
            if d == 0.0 {
                0.0
            } else {
                d / b.duration_s
            }
        };
        let mut before = (0.0, 0.0);
        for b in blocks.iter().chain(std::iter::once(&Block {
            point: 0,
            from_mm: [0.0; 2],
            to_mm: [0.0; 2],
            duration_s: 0.0,
        })) {
            let v = velocity(b);
            peak.velocity_mm_per_min = peak.velocity_mm_per_min.max(v.abs() * 60.0);
            let (v0, d0) = before;
            if v != v0 {
                let a = acceleration(v - v0, d0, b.duration_s).abs();
                peak.acceleration_mm_per_s2 = peak.acceleration_mm_per_s2.max(a);
            }
            before = (v, b.duration_s);
        }
    }
    out
}

/// Solves a raster plan (`problem`'s bounds the floors and ceilings, its tolerance
/// [`TOLERANCE`]): the scales from the target and the operator ([`scales`]), then projected
/// Newton from the floors.
pub fn plan(problem: BoundedProblem) -> BoundedSolution {
    let (depth, dwell_scale) = scales(problem.operator, problem.target, problem.weights);
    let start = problem.lower.clone();
    bounded::solve(&problem, start, depth, dwell_scale)
}

/// The depth scale s_d, the target's RMS over the aperture (1 nm when it is 0), and the dwell
/// scale τ = s_d/ā, ā the mean removal per second of dwell at every point, so that τ at every
/// point removes about s_d.
pub fn scales(operator: &dyn DwellOperator, target: &[f64], weights: &[f64]) -> (f64, f64) {
    let m: f64 = weights.iter().sum::<f64>().max(1.0);
    let depth = (target
        .iter()
        .zip(weights)
        .map(|(d, w)| w * d * d)
        .sum::<f64>()
        / m)
        .sqrt();
    let depth = if depth > 0.0 { depth } else { 1.0 };
    let ones = vec![1.0; operator.cols()];
    let rate: f64 = operator
        .apply(&ones)
        .iter()
        .zip(weights)
        .map(|(r, w)| w * r)
        .sum::<f64>()
        / m;
    let dwell_scale = if rate > 0.0 { depth / rate } else { 1.0 };
    (depth, dwell_scale)
}

/// The default smoothing λ of a raster plan. A dwell map is a deconvolution: a point the
/// aperture barely sees (at the reach's edge, or under a measured spot's pedestal) has almost
/// no curvature in the objective, and without a tie to its neighbours the solver can park
/// dwell there that removes nearly nothing. Measured on the public fluid-jet case
/// (fixtures/maps): with λ = 0 the solver had not converged after 20,000 products (12.6 nm
/// RMS, 203,000 s, one edge point at 6,073 s); λ = 1e-4 converges in 2,700 products to 1.57 nm
/// and 40,400 s; 1e-2 to 2.2 nm in 400; 1 to 21 nm.
pub const DEFAULT_RASTER_SMOOTHING: f64 = 1e-4;

/// A plan has converged when no dwell would move by more than this share of the largest in
/// a scaled projected-gradient step.
pub const TOLERANCE: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::raster::{Lattice, PointGrid};

    /// Every plan at or above the floors keeps both axes within their limits, and the
    /// floors are met with equality somewhere (they are not slack by construction).
    #[test]
    fn dwell_at_the_floors_keeps_every_limit() {
        let lattice = Lattice {
            nx: 30,
            ny: 30,
            pitch_mm: 0.5,
            x0_mm: 0.0,
            y0_mm: 14.5,
        };
        let grid = PointGrid {
            i0: 2,
            j0: 1,
            step: 3,
            columns: 9,
            rows: 9,
            present: (0..81).map(|k| k % 11 != 3).collect(),
        };
        let raster = Raster::serpentine(lattice, &grid).unwrap();
        let caps = AxisCaps {
            max_velocity_mm_per_min: Some(600.0),
            max_acceleration_mm_per_s2: Some(50.0),
        };
        let f = floors(&raster, [caps; 2]);
        assert!(f.iter().all(|&v| v > 0.0));
        for scale in [1.0, 1.7, 40.0] {
            for seed in 0..5u64 {
                // Dwell at or above the floors, unevenly.
                let dwell: Vec<f64> = f
                    .iter()
                    .enumerate()
                    .map(|(k, v)| v * scale * (1.0 + ((k as u64 * 7 + seed * 13) % 5) as f64))
                    .collect();
                for p in peaks(&raster.blocks(&dwell)) {
                    assert!(p.velocity_mm_per_min <= 600.0 * (1.0 + 1e-12), "{p:?}");
                    assert!(p.acceleration_mm_per_s2 <= 50.0 * (1.0 + 1e-12), "{p:?}");
                }
            }
        }
        // At the floors themselves one axis reaches its velocity or acceleration limit.
        let at = peaks(&raster.blocks(&f));
        let reached = at.iter().any(|p| {
            p.velocity_mm_per_min >= 600.0 * (1.0 - 1e-8) || p.acceleration_mm_per_s2 >= 50.0 * 0.5
        });
        assert!(reached, "{at:?}");
    }
}
