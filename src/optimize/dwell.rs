//! One dwell optimization as every solver takes it ([`DwellProblem`]: an operator, the motion
//! whose stations are its columns, the target on the clear aperture's rows, the constraints,
//! weights and machine axes) and what it answers ([`Solution`]).

use std::ops::Range;

use super::basis::DwellBasis;
use super::kinematics::{floors, AxisPath, Floor, PathFeed};
use super::operator::DwellOperator;
use super::problem::{Constraints, Objective};
use super::solver::SolveStatus;
use crate::physics::Motion;

/// One dwell optimization: the operator over the radial grid (or over the clear aperture's
/// radii alone), the rows of the clear aperture in it, the target there, and what the plan
/// must respect.
#[derive(Debug, Clone)]
pub struct DwellProblem<'a> {
    pub operator: &'a dyn DwellOperator,
    /// The motion the plan stands for: its stations are the candidate tool positions (one
    /// per operator column).
    pub motion: &'a Motion,
    pub tool_radius_mm: f64,
    /// Operator rows inside the clear aperture.
    pub rows: Range<usize>,
    /// Target depth at each row of `rows`, nm.
    pub target_nm: &'a [f64],
    /// Add a free uniform layer p ≥ 0 to the target.
    pub free_piston: bool,
    pub constraints: Constraints,
    pub objective: Objective,
    /// Solver wall-clock budget, s.
    pub time_limit_s: f64,
    /// How the QP represents the dwell ([`super::basis`]).
    pub basis: DwellBasis,
    /// The machine's axes as the plan drives them (empty: no machine limits).
    pub axes: &'a [AxisPath],
    /// Length of the tool's path across each position's cell as the program moves it, mm (the
    /// X–Z path of the B pivot; the cell's width on a plane with a vertical tool), one per
    /// position: what `max_feed_mm_per_min` limits. Empty for one position.
    pub cell_path_mm: &'a [f64],
    /// Floors the caller adds (a polar plan's C law, [`super::harmonics::law_floor`]): empty,
    /// or one per position.
    pub extra_floors: &'a [Floor],
}

impl DwellProblem<'_> {
    /// Each position's least dwell: `min_dwell_s`, raised by the feed limit and the machine's
    /// ([`super::kinematics::floors`]).
    pub fn floors(&self) -> Vec<Floor> {
        let c = &self.constraints;
        let n = self.motion.len();
        assert!(
            c.max_feed_mm_per_min.is_none() || self.cell_path_mm.len() == n || n == 1,
            "a feed limit needs the path across each cell"
        );
        let feed = c.max_feed_mm_per_min.map(|max_feed_mm_per_min| PathFeed {
            cell_path_mm: self.cell_path_mm,
            max_feed_mm_per_min,
        });
        let mut floors = floors(self.axes, feed, self.motion, c.min_dwell_s);
        for (floor, extra) in floors.iter_mut().zip(self.extra_floors) {
            if extra.dwell_s > floor.dwell_s {
                *floor = *extra;
            }
        }
        floors
    }
}

/// An optimized plan with the solver's account of it.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    pub dwell_s: Vec<f64>,
    /// The free piston chosen, nm (`None` when not asked for).
    pub piston_nm: Option<f64>,
    pub status: SolveStatus,
    pub iterations: u32,
    pub solve_time_s: f64,
    /// J at the returned plan (dimensionless, see the module docs).
    pub objective: f64,
}
