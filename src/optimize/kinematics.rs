//! Machine axis limits as constraints on the dwell: the plan is optimized so that its machine
//! program ([`crate::machine`]) keeps every axis's velocity and acceleration limit.
//!
//! # The model
//!
//! Position j's cell runs from the midpoint to its left neighbour to the one to its right (from
//! r_0 itself at the first position, to r_{n−1} at the last). The program crosses it at constant
//! axis velocity in w_j·t_j, with w_j = ½ at the two ends (the other half is a stop) and 1
//! inside; an axis moving c_j across the cell (its *cell travel*, in mm or deg) has velocity
//! v_j = c_j / (w_j·t_j). Between cells the velocity changes over the time between the two
//! moves' midpoints, and at either end from and to rest over the stop:
//!
//! ```text
//! a_j      = (v_{j+1} − v_j) / ((w_j·t_j + w_{j+1}·t_{j+1})/2)      between cells j, j+1
//! a_start  = v_0 / (t_0/2) = 4·c_0 / t_0²                          from rest at r_0
//! a_end    = 4·c_{n−1} / t_{n−1}²                                   to rest at r_{n−1}
//! ```
//!
//! # As constraints
//!
//! - Velocity |v_j| ≤ v_max is the floor t_j ≥ |c_j| / (w_j·v_max): linear. The plan's feed
//!   limit is the same floor on the length of the X–Z path across the cell ([`PathFeed`]).
//! - The end accelerations are floors too: t_0 ≥ 2·√(|c_0| / a_max), likewise t_{n−1}.
//! - Between cells, σ·(v_{j+1} − v_j) ≤ a_max·(w_j·t_j + w_{j+1}·t_{j+1})/2 for σ = ±1 is not
//!   convex: its left side is a sum γ/t of terms convex where γ > 0 and concave where γ < 0.
//!   It is solved by the convex–concave procedure: around a plan t⁰ that keeps it, each
//!   concave term is replaced by its tangent (which lies above it, since 1/t ≥ 2/t⁰ − t/t⁰²),
//!   and each convex one by γ·u_j with u_j·t_j ≥ 1 (a rotated second-order cone). The result
//!   is convex, implies the original, and holds at t⁰; so every iterate keeps the machine's
//!   limits and the objective never increases. It starts from the constant dwell that keeps
//!   every row and stops when J falls by less than [`CCP_TOLERANCE`] (relative) in an
//!   iteration. The plan without these rows is tried first: when it already keeps the
//!   acceleration limits, it is the answer.
//!
//! Every limit is applied with a relative margin of [`MARGIN`], so that rounding in the
//! program's own arithmetic never puts a plan over its limit.

use super::problem::{Bound, Constraint};
use crate::machine::{Axis, LimitKind};
use crate::physics::motion::{acceleration, Motion};

/// One axis of the machine as the plan drives it.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisPath {
    pub axis: Axis,
    /// The axis's travel across each position's cell, in its unit (mm or deg); one per
    /// position (empty for a single position, which has no move).
    pub cell_travel: Vec<f64>,
    /// Largest |velocity|, unit/s.
    pub max_velocity_per_s: Option<f64>,
    /// Largest |acceleration|, unit/s².
    pub max_acceleration_per_s2: Option<f64>,
}

impl AxisPath {
    pub fn velocity_bound(&self) -> Bound {
        Bound::Machine(self.axis.into(), LimitKind::MaxVelocity)
    }

    pub fn acceleration_bound(&self) -> Bound {
        Bound::Machine(self.axis.into(), LimitKind::MaxAcceleration)
    }
}

/// Relative margin kept below every axis limit.
pub const MARGIN: f64 = 1e-6;
/// The convex–concave iterations stop when J falls by less than this, relative.
pub const CCP_TOLERANCE: f64 = 1e-3;
/// Most convex–concave iterations (each a QP solve; the time budget applies as well).
pub const MAX_CCP_ITERATIONS: usize = 40;

/// The least dwell at one position and the limit that sets it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floor {
    pub dwell_s: f64,
    pub bound: Bound,
}

/// The feed limit on the tool's path: the path's length across each position's cell (mm, one
/// per position, empty for a single position) and the most feed along it (mm/min).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathFeed<'a> {
    pub cell_path_mm: &'a [f64],
    pub max_feed_mm_per_min: f64,
}

/// Per-position floors: `min_dwell_s`, the feed limit (the path across cell j at
/// `cell_path_mm[j]`/(w_j·t_j) ≤ v), the velocity limits and the end accelerations, each kept
/// with [`MARGIN`].
pub fn floors(
    axes: &[AxisPath],
    feed: Option<PathFeed>,
    motion: &Motion,
    min_dwell_s: f64,
) -> Vec<Floor> {
    let n = motion.len();
    let mut floors = vec![
        Floor {
            dwell_s: min_dwell_s,
            bound: Bound::Constraint(Constraint::MinDwell),
        };
        n
    ];
    let mut raise = |j: usize, dwell_s: f64, bound| {
        if dwell_s > floors[j].dwell_s {
            floors[j] = Floor { dwell_s, bound };
        }
    };
    if let Some(feed) = feed {
        let v = feed.max_feed_mm_per_min / 60.0 * (1.0 - MARGIN);
        for (j, path) in feed.cell_path_mm.iter().enumerate() {
            raise(
                j,
                path / (motion.move_share(j) * v),
                Bound::Constraint(Constraint::MaxFeed),
            );
        }
    }
    for axis in axes {
        if let Some(v) = axis.max_velocity_per_s {
            let v = v * (1.0 - MARGIN);
            for (j, c) in axis.cell_travel.iter().enumerate() {
                raise(
                    j,
                    c.abs() / (motion.move_share(j) * v),
                    axis.velocity_bound(),
                );
            }
        }
        if let (Some(a), Some(first), Some(last)) = (
            axis.max_acceleration_per_s2,
            axis.cell_travel.first(),
            axis.cell_travel.last(),
        ) {
            let a = a * (1.0 - MARGIN);
            raise(0, 2.0 * (first.abs() / a).sqrt(), axis.acceleration_bound());
            raise(
                n - 1,
                2.0 * (last.abs() / a).sqrt(),
                axis.acceleration_bound(),
            );
        }
    }
    floors
}

/// Whether any axis limits acceleration (and moves), so the non-convex rows apply.
pub fn limits_acceleration(axes: &[AxisPath]) -> bool {
    axes.iter()
        .any(|a| a.max_acceleration_per_s2.is_some() && a.cell_travel.iter().any(|&c| c != 0.0))
}

/// Axis velocity in cell j at dwell t (unit/s); 0 for an axis that does not move there.
fn velocity(c: f64, share: f64, t: f64) -> f64 {
    if c == 0.0 {
        0.0
    } else {
        c / (share * t)
    }
}

/// The largest |acceleration| of an axis over its limit for a plan (0 without a limit):
/// between cells and from and to rest at the ends, as the program computes it.
pub fn peak_acceleration_ratio(axis: &AxisPath, motion: &Motion, dwell_s: &[f64]) -> f64 {
    let Some(a_max) = axis.max_acceleration_per_s2 else {
        return 0.0;
    };
    let n = dwell_s.len();
    let c = &axis.cell_travel;
    if c.len() != n || n < 2 {
        return 0.0;
    }
    let v: Vec<f64> = (0..n)
        .map(|j| velocity(c[j], motion.move_share(j), dwell_s[j]))
        .collect();
    // From rest through the half-dwell stop into the first move (both t_0/2), and back.
    let (first, last) = (0.5 * dwell_s[0], 0.5 * dwell_s[n - 1]);
    let ends = [
        acceleration(v[0].abs(), first, first),
        acceleration(v[n - 1].abs(), last, last),
    ];
    let between = (0..n - 1).map(|j| {
        acceleration(
            (v[j + 1] - v[j]).abs(),
            motion.move_share(j) * dwell_s[j],
            motion.move_share(j + 1) * dwell_s[j + 1],
        )
    });
    ends.into_iter()
        .chain(between)
        .map(|a| if a.is_nan() { f64::INFINITY } else { a })
        .fold(0.0, f64::max)
        / a_max
}

/// The constant dwell (s) at which every axis keeps its acceleration limits between cells
/// (with [`MARGIN`]): σ·(c_{j+1}/w_{j+1} − c_j/w_j)/T ≤ a·T·(w_j + w_{j+1})/2.
pub fn constant_dwell_for_acceleration(axes: &[AxisPath], motion: &Motion) -> f64 {
    let mut t = 0.0_f64;
    for axis in axes {
        let Some(a) = axis.max_acceleration_per_s2 else {
            continue;
        };
        let a = a * (1.0 - MARGIN);
        let c = &axis.cell_travel;
        for j in 0..c.len().saturating_sub(1) {
            let (w0, w1) = (motion.move_share(j), motion.move_share(j + 1));
            let jump = (c[j + 1] / w1 - c[j] / w0).abs();
            t = t.max((2.0 * jump / (a * (w0 + w1))).sqrt());
        }
    }
    t
}

/// One linearized acceleration row, a·(x, u) ≤ b on the scaled dwell x = t/τ and the cone
/// variables u_j ≥ 1/x_j: entries (x index or u's position index, value), and b.
#[derive(Debug, Clone, PartialEq)]
pub struct AccelerationRow {
    pub x: Vec<(usize, f64)>,
    pub u: Vec<(usize, f64)>,
    pub rhs: f64,
}

/// The between-cell acceleration rows of every axis, made convex around `x0` (scaled dwell,
/// every entry that enters a row positive) as described in the module docs. Each row is
/// divided by a·τ²/2 so its dwell coefficients are of order one.
pub fn acceleration_rows(
    axes: &[AxisPath],
    motion: &Motion,
    x0: &[f64],
    tau: f64,
) -> Vec<AccelerationRow> {
    let mut rows = Vec::new();
    for axis in axes {
        let Some(a) = axis.max_acceleration_per_s2 else {
            continue;
        };
        let scale = 0.5 * a * (1.0 - MARGIN) * tau * tau;
        let c = &axis.cell_travel;
        for j in 0..c.len().saturating_sub(1) {
            let (w0, w1) = (motion.move_share(j), motion.move_share(j + 1));
            for sign in [1.0, -1.0] {
                // σ·(c_{j+1}/(w_{j+1}·t_{j+1}) − c_j/(w_j·t_j)), times τ: γ/x per position.
                let terms = [(j + 1, sign * c[j + 1] / w1), (j, -sign * c[j] / w0)];
                if terms.iter().all(|&(_, g)| g == 0.0) {
                    continue;
                }
                let mut row = AccelerationRow {
                    x: vec![(j, -w0), (j + 1, -w1)],
                    u: Vec::new(),
                    rhs: 0.0,
                };
                for (k, g) in terms {
                    let g = g / scale;
                    if g > 0.0 {
                        row.u.push((k, g));
                    } else if g < 0.0 {
                        // g/x ≤ g·(2/x0 − x/x0²): the tangent of the convex 1/x lies below it.
                        row.x.push((k, -g / (x0[k] * x0[k])));
                        row.rhs -= 2.0 * g / x0[k];
                    }
                }
                rows.push(row);
            }
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    /// n stations 1 mm apart (the shares depend only on n).
    fn stations(n: usize) -> Motion {
        Motion::radial((0..n).map(|j| j as f64).collect())
    }

    fn axis(cell_travel: Vec<f64>, v: Option<f64>, a: Option<f64>) -> AxisPath {
        AxisPath {
            axis: Axis::X,
            cell_travel,
            max_velocity_per_s: v,
            max_acceleration_per_s2: a,
        }
    }

    #[test]
    fn floors_keep_velocity_and_end_accelerations() {
        // Cells 0.5, 1, 1, 0.5 mm (positions 1 mm apart); 2 mm/s; 1 mm/s².
        let x = axis(vec![0.5, 1.0, 1.0, 0.5], Some(2.0), Some(1.0));
        let f = floors(std::slice::from_ref(&x), None, &stations(4), 0.1);
        let m = 1.0 / (1.0 - MARGIN);
        // Ends: velocity 0.5/(½·2) = 0.5 s; acceleration 2·√0.5 = 1.414 s.
        assert!((f[0].dwell_s - 2.0 * (0.5 * m).sqrt()).abs() < 1e-12);
        assert_eq!(f[0].bound, x.acceleration_bound());
        assert!((f[1].dwell_s - 0.5 * m).abs() < 1e-12);
        assert_eq!(f[1].bound, x.velocity_bound());
        // At the floors the program's end acceleration is at the limit (less the margin).
        let t = [f[0].dwell_s, 1.0, 1.0, f[3].dwell_s];
        let r = peak_acceleration_ratio(&x, &stations(t.len()), &t);
        assert!((r - (1.0 - MARGIN)).abs() < 1e-12, "{r}");
    }

    #[test]
    fn acceleration_matches_the_definition() {
        // Velocities: 0.5/(½·2) = 0.5, 1/4 = 0.25, 0.5/(½·1) = 1 mm/s.
        let x = axis(vec![0.5, 1.0, 0.5], None, Some(1.0));
        let t = [2.0, 4.0, 1.0];
        // Ends: 0.5/1 = 0.5, 1/0.5 = 2; between: 0.25/((1 + 4)/2) = 0.1, 0.75/((4 + 0.5)/2).
        let expected = [0.5_f64, 2.0, 0.1, 0.75 / 2.25]
            .into_iter()
            .fold(0.0, f64::max);
        assert_eq!(
            peak_acceleration_ratio(&x, &stations(t.len()), &t),
            expected
        );
        assert_eq!(
            peak_acceleration_ratio(&axis(vec![], None, None), &stations(1), &[1.0]),
            0.0
        );
    }

    /// The linearized rows imply the true constraint: on random plans near and far from the
    /// linearization point, whenever every row holds, the acceleration is within its limit.
    #[test]
    fn linearized_rows_are_sufficient() {
        let x = axis(vec![0.3, 0.9, -0.4, 1.2, 0.2], None, Some(0.7));
        let tau = 1.7;
        let mut seed = 7_u64;
        let mut uniform = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut kept = 0;
        for _ in 0..20_000 {
            let x0: Vec<f64> = (0..5).map(|_| 0.2 + 3.0 * uniform()).collect();
            let xs: Vec<f64> = (0..5).map(|_| 0.05 + 4.0 * uniform()).collect();
            let rows = acceleration_rows(std::slice::from_ref(&x), &stations(5), &x0, tau);
            let holds = rows.iter().all(|r| {
                let lhs: f64 = r.x.iter().map(|&(k, v)| v * xs[k]).sum::<f64>()
                    + r.u.iter().map(|&(k, v)| v / xs[k]).sum::<f64>();
                lhs <= r.rhs
            });
            // At their own point the rows are exact (the tangent touches there).
            let limit = axis(x.cell_travel.clone(), None, Some(0.7 * (1.0 - MARGIN)));
            let t0: Vec<f64> = x0.iter().map(|v| v * tau).collect();
            let r0 = between_ratio(&limit, &t0);
            if (r0 - 1.0).abs() > 1e-9 {
                let at_x0 = rows.iter().all(|r| {
                    let lhs: f64 = r.x.iter().map(|&(k, v)| v * x0[k]).sum::<f64>()
                        + r.u.iter().map(|&(k, v)| v / x0[k]).sum::<f64>();
                    lhs <= r.rhs
                });
                assert_eq!(at_x0, r0 < 1.0, "at {x0:?}: ratio {r0}");
            }
            if holds {
                kept += 1;
                let t: Vec<f64> = xs.iter().map(|v| v * tau).collect();
                let r = between_ratio(&limit, &t);
                assert!(r <= 1.0 + 1e-12, "rows hold at {xs:?} but the ratio is {r}");
            }
        }
        assert!(kept > 100, "only {kept} samples kept the rows");
    }

    /// The between-cell part of [`peak_acceleration_ratio`].
    fn between_ratio(axis: &AxisPath, t: &[f64]) -> f64 {
        let n = t.len();
        let motion = stations(n);
        let c = &axis.cell_travel;
        let v: Vec<f64> = (0..n)
            .map(|j| c[j] / (motion.move_share(j) * t[j]))
            .collect();
        (0..n - 1)
            .map(|j| {
                (v[j + 1] - v[j]).abs()
                    / (0.5 * (motion.move_share(j) * t[j] + motion.move_share(j + 1) * t[j + 1]))
            })
            .fold(0.0, f64::max)
            / axis.max_acceleration_per_s2.unwrap()
    }

    #[test]
    fn the_constant_start_keeps_the_between_cell_rows() {
        let x = axis(vec![0.3, 0.9, -0.4, 1.2, 0.2], None, Some(0.7));
        let t = constant_dwell_for_acceleration(std::slice::from_ref(&x), &stations(5));
        let r = between_ratio(&x, &[t; 5]);
        assert!(r <= 1.0 - MARGIN + 1e-12 && r > 0.99, "{r}");
    }
}
