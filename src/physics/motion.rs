//! The motion a dwell plan stands for: Preston's one model of how the tool moves, used by the
//! prediction, the optimizer, the studies and the machine program alike.
//!
//! A plan is positions r_0 < … < r_{n−1} (radial coordinates of surface points, mm) with dwell
//! t_j ≥ 0 (s). Each position owns a **cell** between the midpoints of its neighbours,
//! m_j = (r_j + r_{j+1})/2, and the tool spends exactly t_j there:
//!
//! ```text
//! stop at r_0 for t_0/2;   r_0 → m_0 in t_0/2;   m_{j−1} → m_j in t_j (0 < j < n−1);
//! m_{n−2} → r_{n−1} in t_{n−1}/2;   stop at r_{n−1} for t_{n−1}/2
//! ```
//!
//! (a single position is a stop of t_0). Within a move the tool's speed along the surface is
//! constant: on a curved part a cell of arc length L_j is crossed at L_j/(w_j·t_j), with
//! w_j = ½ for the two end cells and 1 inside (the share of the dwell spent moving). A cell
//! whose dwell is 0 is crossed in no time: it removes nothing, and at either end of the plan
//! the tool simply starts (or ends) at its far boundary; inside a plan a machine cannot do it.
//!
//! So the removal at radius r is
//!
//! ```text
//! ΔZ(r) = Σ_j [ σ_j·t_j·R(r; r_j) + w_j·t_j/L_j · ∫_{cell j} R(r; ρ(s)) ds ]
//! ```
//!
//! with σ_j = ½ for the stops at the two ends (1 for a single position, 0 inside): a linear
//! map of the dwell, whose columns are exact integrals ([`super::path`],
//! [`super::operator`]). A constant feed v from a to b is the same integral without cells:
//! ΔZ(r) = (60/v)·∫_a^b R(r; ρ(s)) ds.

/// Where each position's cell begins and ends: r_0, the midpoints m_0 … m_{n−2}, r_{n−1}
/// (n + 1 entries for n ≥ 2 positions; the single position of a one-position plan).
pub fn cell_boundaries_mm(positions_mm: &[f64]) -> Vec<f64> {
    let n = positions_mm.len();
    if n < 2 {
        return positions_mm.to_vec();
    }
    let mut ends = Vec::with_capacity(n + 1);
    ends.push(positions_mm[0]);
    ends.extend(positions_mm.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    ends.push(positions_mm[n - 1]);
    ends
}

/// w_j: the share of position j's dwell spent moving across its cell (½ at either end of a
/// plan of n ≥ 2 positions, 1 inside, 0 for a single position).
pub fn move_share(j: usize, n: usize) -> f64 {
    if n < 2 {
        0.0
    } else if j == 0 || j == n - 1 {
        0.5
    } else {
        1.0
    }
}

/// σ_j: the share of position j's dwell spent standing at it (½ at either end of a plan of
/// n ≥ 2 positions, 0 inside, 1 for a single position).
pub fn stop_share(j: usize, n: usize) -> f64 {
    // Every second of t_j is either spent moving across the cell or standing at r_j.
    1.0 - move_share(j, n)
}

/// The acceleration model of every axis: its velocity is constant within a segment (a block
/// of a program, a cell of a plan) and changes between consecutive segments over the time
/// between their midpoints, so a change `dv` between segments lasting `before` and `after`
/// (a stop's velocity is 0: a plan's first move starts from its half-dwell stop, t_0/2 each;
/// a program is at rest before its first block and after its last, segments of 0 s) takes
///
/// ```text
/// a = dv / ((d_before + d_after) / 2)
/// ```
///
/// The program reports it ([`crate::machine`]) and the optimizer keeps it within the limits
/// (`optimize::kinematics`).
pub fn acceleration(dv: f64, before_s: f64, after_s: f64) -> f64 {
    dv / (0.5 * (before_s + after_s))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shares_account_for_every_second() {
        for n in 1..6 {
            for j in 0..n {
                let (w, s) = (move_share(j, n), stop_share(j, n));
                assert_eq!(w + s, 1.0);
                assert!(w >= 0.0 && s >= 0.0);
            }
        }
        assert_eq!((move_share(0, 1), stop_share(0, 1)), (0.0, 1.0));
        assert_eq!((move_share(0, 3), stop_share(0, 3)), (0.5, 0.5));
        assert_eq!((move_share(1, 3), stop_share(1, 3)), (1.0, 0.0));
        assert_eq!(cell_boundaries_mm(&[0.0, 1.0, 3.0]), [0.0, 0.5, 2.0, 3.0]);
    }
}
