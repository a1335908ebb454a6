//! The convex–concave procedure that keeps a plan within the machine's acceleration limits
//! between cells ([`super::kinematics`] states the rows and why each iterate keeps them), and
//! the constant dwell it starts from.

use super::checks::Attempt;
use super::dwell::DwellProblem;
use super::kinematics::{
    constant_dwell_for_acceleration, peak_acceleration_ratio, AxisPath, Floor, CCP_TOLERANCE,
    MARGIN, MAX_CCP_ITERATIONS,
};
use super::operator::Band;
use super::problem::{Bound, Constraint, OptimizeError};
use super::scaling::{objective_value, Scales};
use super::solver::SolveStatus;
use crate::physics::Motion;

pub(super) fn keeps_acceleration(axes: &[AxisPath], motion: &Motion, dwell_s: &[f64]) -> bool {
    axes.iter()
        .all(|a| peak_acceleration_ratio(a, motion, dwell_s) <= 1.0 - 0.5 * MARGIN)
}

/// The plan within the machine's acceleration limits between cells, by the convex–concave
/// procedure of [`super::kinematics`] from the constant dwell that keeps every row.
/// `solve_around(x0)` solves the QP with the acceleration rows made convex around the scaled
/// plan x0 (any solver of the problem's fit that takes those rows).
pub(super) fn within_acceleration(
    problem: &DwellProblem,
    operator: &Band,
    scales: &Scales,
    floors: &[Floor],
    mut solve_around: impl FnMut(&[f64]) -> Result<Attempt, OptimizeError>,
) -> Result<Attempt, OptimizeError> {
    let n = problem.motion.len();
    let c = &problem.constraints;
    let floors_s: Vec<f64> = floors.iter().map(|f| f.dwell_s).collect();
    let start_s = floors_s.iter().copied().fold(
        constant_dwell_for_acceleration(problem.axes, problem.motion),
        f64::max,
    );
    let fields: Vec<Bound> = problem
        .axes
        .iter()
        .filter(|a| a.max_acceleration_per_s2.is_some())
        .map(|a| a.acceleration_bound())
        .collect();
    let refuse = |bound: Constraint, detail: String| {
        let mut all = fields.clone();
        all.push(Bound::Constraint(bound));
        Err(OptimizeError::Infeasible {
            fields: all,
            detail,
        })
    };
    if let Some(hi) = c.max_dwell_s.filter(|&hi| start_s > hi) {
        return refuse(
            Constraint::MaxDwell,
            format!("within the machine's acceleration limits the optimizer starts from a constant dwell of {start_s} s per position, more than max_dwell_s ({hi} s)"),
        );
    }
    if let Some(total) = c.max_total_time_s.filter(|&t| start_s * n as f64 > t) {
        return refuse(
            Constraint::MaxTotalTime,
            format!(
                "within the machine's acceleration limits the optimizer starts from a constant dwell of {start_s} s per position, {} s in total, more than max_total_time_s ({total} s)",
                start_s * n as f64
            ),
        );
    }
    let tau = scales.dwell_s;
    // Start from the constant dwell that fits best among those keeping every row: of the
    // target's scale, so the first linearisation is well conditioned (the least constant
    // dwell may be 1e5 times shorter than the plan's, and its tangents as steep).
    let start = constant_fallback(problem, operator, scales, start_s);
    let mut around: Vec<f64> = start.dwell_s.iter().map(|t| t / tau).collect();
    let mut best: Option<Attempt> = None;
    let (mut iterations, mut solve_time_s) = (0, 0.0);
    for _ in 0..MAX_CCP_ITERATIONS {
        let next = solve_around(&around)?;
        iterations += next.iterations;
        solve_time_s += next.solve_time_s;
        // Every exact iterate keeps the limits; one that does not is the solver's inaccuracy
        // (an almost-solved, badly conditioned round): the last iterate that kept them stands.
        let kept = problem
            .axes
            .iter()
            .all(|a| peak_acceleration_ratio(a, problem.motion, &next.dwell_s) <= 1.0)
            && problem
                .constraints
                .violation(&next.dwell_s, floors, scales.dwell_s)
                .is_none();
        if !kept {
            best.get_or_insert(start);
            break;
        }
        let settled = best
            .as_ref()
            .is_some_and(|b| b.objective - next.objective <= CCP_TOLERANCE * b.objective.abs());
        // Each iterate keeps the limits; a solver's rounding may cost a little objective.
        around = next.dwell_s.iter().map(|t| t / tau).collect();
        if best.as_ref().is_none_or(|b| next.objective <= b.objective) {
            best = Some(next);
        }
        if settled {
            break;
        }
    }
    let mut best = best.expect("at least one iteration");
    best.iterations = iterations;
    best.solve_time_s = solve_time_s;
    Ok(best)
}

/// The constant dwell t (with the piston p ≥ 0 when free) that fits the target best in least
/// squares, but no less than `start_s`, the constant dwell that keeps every row: a constant
/// dwell keeps the acceleration rows the more the longer it is (velocities fall as 1/t, the
/// allowed change grows as t), sits on no dwell change, and stays within `max_dwell_s` and
/// `max_total_time_s`/n (checked above `start_s` before). The convex–concave procedure starts
/// from it, and it stands when no round improves on it within the limits (reported as almost
/// solved: within every limit, not the optimum).
fn constant_fallback(
    problem: &DwellProblem,
    band: &Band,
    scales: &Scales,
    start_s: f64,
) -> Attempt {
    let rows = &problem.rows;
    let n = problem.motion.len();
    // u: the removal of one second at every position, on the aperture's rows.
    let mut unit = vec![0.0; rows.len()];
    for j in 0..n {
        let from = band.start[j] - rows.start;
        for (o, m) in unit[from..].iter_mut().zip(band.values[j].iter()) {
            *o += m;
        }
    }
    let (mut su, mut suu, mut sd, mut sud) = (0.0, 0.0, 0.0, 0.0);
    for (&u, &d) in unit.iter().zip(problem.target_nm) {
        (su, suu, sd, sud) = (su + u, suu + u * u, sd + d, sud + u * d);
    }
    let m = unit.len() as f64;
    // min Σ (t·u − d − p)²: with p free, the normal equations t·Σu² − p·Σu = Σud,
    // −t·Σu + p·m = −Σd; p < 0 (or no piston) leaves t = Σud/Σu².
    let alone = if suu > 0.0 { sud / suu } else { 0.0 };
    let t = if problem.free_piston {
        let det = suu * m - su * su;
        let t = (sud * m - su * sd) / det;
        let p = (t * su - sd) / m;
        if det > 0.0 && p > 0.0 && t.is_finite() {
            t
        } else {
            alone
        }
    } else {
        alone
    };
    let mut t = t.max(start_s);
    let c = &problem.constraints;
    if let Some(hi) = c.max_dwell_s {
        t = t.min(hi);
    }
    if let Some(total) = c.max_total_time_s {
        t = t.min(total / n as f64);
    }
    let t = t.max(start_s);
    // The best piston for the dwell kept (p ≥ 0).
    let p = if problem.free_piston {
        ((t * su - sd) / m).max(0.0)
    } else {
        0.0
    };
    let dwell_s = vec![t; n];
    Attempt {
        objective: objective_value(problem, band, scales, &dwell_s, p),
        piston_nm: problem.free_piston.then_some(p),
        dwell_s,
        status: SolveStatus::AlmostSolved,
        iterations: 0,
        solve_time_s: 0.0,
    }
}
