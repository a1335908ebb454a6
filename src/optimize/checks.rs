//! A solver's answer made exact and checked before it is returned: the dwell bounds clamped,
//! the total time kept against the solver's rounding ([`polish`]), and every constraint and
//! acceleration limit checked to the tolerance ([`check_plan`]).

use super::dwell::DwellProblem;
use super::kinematics::{peak_acceleration_ratio, Floor};
use super::problem::{Constraints, OptimizeError};
use super::scaling::Scales;
use super::solver::SolveStatus;

/// One solve of the QP (around a plan for the acceleration rows, or without them), polished.
pub(super) struct Attempt {
    pub(super) dwell_s: Vec<f64>,
    pub(super) piston_nm: Option<f64>,
    pub(super) status: SolveStatus,
    pub(super) iterations: u32,
    pub(super) solve_time_s: f64,
    pub(super) objective: f64,
}

/// The interior-point answer in seconds, with the dwell bounds made exact and, if the total
/// time is over by the solver's rounding (it sums n small errors), the dwell above each floor
/// shrunk in proportion, which keeps the bounds and the dwell-change rows.
pub(super) fn polish(c: &Constraints, floors_s: &[f64], x: &[f64], tau: f64) -> Vec<f64> {
    let mut t: Vec<f64> = x
        .iter()
        .zip(floors_s)
        .map(|(x, &lo)| {
            let t = (x * tau).max(lo);
            c.max_dwell_s.map_or(t, |hi| t.min(hi))
        })
        .collect();
    if let Some(total) = c.max_total_time_s {
        let sum: f64 = t.iter().sum();
        let floor: f64 = floors_s.iter().sum();
        if sum > total && sum > floor {
            let k = ((total - floor) / (sum - floor)).max(0.0);
            for (tj, lo) in t.iter_mut().zip(floors_s) {
                *tj = lo + (*tj - lo) * k;
            }
        }
    }
    t
}

/// Refuses a plan that breaks a constraint or the machine's acceleration limits by more than
/// the tolerance (a solver's inaccuracy: the QP keeps them all).
pub(super) fn check_plan(
    problem: &DwellProblem,
    floors: &[Floor],
    scales: &Scales,
    plan: &Attempt,
) -> Result<(), OptimizeError> {
    let status = plan.status;
    if let Some(breach) = problem
        .constraints
        .violation(&plan.dwell_s, floors, scales.dwell_s)
    {
        return Err(OptimizeError::Numerical {
            status: format!(
                "{status:?}, but the plan breaks {} at index {} by {:e} s",
                breach.bound.describe(),
                breach.index,
                breach.excess_s
            ),
        });
    }
    if let Some((axis, ratio)) = problem
        .axes
        .iter()
        .map(|a| (a, peak_acceleration_ratio(a, problem.motion, &plan.dwell_s)))
        .find(|&(_, ratio)| ratio > 1.0)
    {
        return Err(OptimizeError::Numerical {
            status: format!(
                "{status:?}, but the plan exceeds {} by a factor {ratio}",
                axis.acceleration_bound().describe()
            ),
        });
    }
    Ok(())
}
