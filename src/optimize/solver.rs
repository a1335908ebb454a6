//! Clarabel plumbing shared by the dwell QP and the feasibility LP: sparse matrices built by
//! column or by row, the constraint rows of a plan, one solver call with its status mapped to
//! the optimizer's, and the wall-clock budget the calls share.
//!
//! Clarabel solves  min ½vᵀPv + qᵀv  subject to  A·v + s = b, s ∈ K  (K a product of cones).
//! Every call of one optimization draws on one [`Budget`]: the feasibility LP (at most twice)
//! and the QP together never run longer than the request's time limit.

use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolution, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};

use super::basis::Basis;
use super::problem::{Constraints, OptimizeError};

/// The wall-clock budget of one optimization, shared by every solver call it makes.
#[derive(Debug, Clone, Copy)]
pub struct Budget {
    limit_s: f64,
    started: Instant,
}

impl Budget {
    /// A budget of `limit_s` seconds, starting now.
    pub fn start(limit_s: f64) -> Self {
        Budget {
            limit_s,
            started: Instant::now(),
        }
    }

    /// The whole budget, s.
    pub fn limit_s(&self) -> f64 {
        self.limit_s
    }

    /// Seconds left; a `TimeLimit` error once none are.
    pub fn remaining_s(&self) -> Result<f64, OptimizeError> {
        let left = self.limit_s - self.started.elapsed().as_secs_f64();
        if left > 0.0 {
            Ok(left)
        } else {
            Err(OptimizeError::TimeLimit {
                limit_s: self.limit_s,
            })
        }
    }
}

/// Whether the solver met its full tolerances.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolveStatus {
    Solved,
    /// Converged to Clarabel's reduced tolerances only; the plan still keeps its constraints.
    AlmostSolved,
}

/// Compressed sparse columns built column by column (rows ascending within a column).
pub(super) struct CscBuilder {
    rows: usize,
    colptr: Vec<usize>,
    rowval: Vec<usize>,
    nzval: Vec<f64>,
}

impl CscBuilder {
    pub(super) fn new(rows: usize) -> Self {
        CscBuilder {
            rows,
            colptr: vec![0],
            rowval: Vec::new(),
            nzval: Vec::new(),
        }
    }
    pub(super) fn push_column(&mut self, entries: impl IntoIterator<Item = (usize, f64)>) {
        for (r, v) in entries {
            self.rowval.push(r);
            self.nzval.push(v);
        }
        self.colptr.push(self.rowval.len());
    }
    pub(super) fn build(self) -> CscMatrix<f64> {
        let cols = self.colptr.len() - 1;
        CscMatrix::new(self.rows, cols, self.colptr, self.rowval, self.nzval)
    }
}

/// Relative tightening of the feed and dwell-change rows in a spline basis. There the rows of
/// neighbouring positions are nearly parallel (the dwell changes slowly between them), and the
/// solver keeps them less tightly than rows on the positions' own variables; unlike the bounds
/// and the total, polishing cannot restore them. A hundred times the tolerance a plan is
/// checked to ([`super::problem::CONSTRAINT_TOLERANCE`]), far below anything a machine could
/// tell.
pub(super) const SPLINE_ROW_MARGIN: f64 = 1e-7;

/// Constraint rows a·v ≤ b, as triplets and right-hand sides.
#[derive(Default)]
pub(super) struct Rows {
    pub rows: Vec<usize>,
    pub cols: Vec<usize>,
    pub values: Vec<f64>,
    pub rhs: Vec<f64>,
}

impl Rows {
    pub(super) fn push(&mut self, entries: &[(usize, f64)], rhs: f64) {
        for &(col, v) in entries {
            self.rows.push(self.rhs.len());
            self.cols.push(col);
            self.values.push(v);
        }
        self.rhs.push(rhs);
    }

    /// These rows on the dwell at the positions (the first variables) as rows on `basis`'s
    /// variables (the same row indices; repeated entries are summed when assembled).
    pub(super) fn through(self, basis: &Basis) -> Rows {
        if basis.is_positions() {
            return self;
        }
        let mut out = Rows {
            rhs: self.rhs,
            ..Rows::default()
        };
        for ((r, j), v) in self.rows.into_iter().zip(self.cols).zip(self.values) {
            for (k, w) in basis.terms(j) {
                out.rows.push(r);
                out.cols.push(k);
                out.values.push(v * w);
            }
        }
        out
    }

    /// The rows `keep` marks, in order, renumbered from 0.
    pub(super) fn select(&self, keep: &[bool]) -> Rows {
        let mut index = vec![None; self.rhs.len()];
        let mut out = Rows::default();
        for (r, &rhs) in self.rhs.iter().enumerate() {
            if keep[r] {
                index[r] = Some(out.rhs.len());
                out.rhs.push(rhs);
            }
        }
        for ((&r, &col), &v) in self.rows.iter().zip(&self.cols).zip(&self.values) {
            if let Some(new) = index[r] {
                out.rows.push(new);
                out.cols.push(col);
                out.values.push(v);
            }
        }
        out
    }

    /// a·x − b of every row at `x`.
    pub(super) fn excess(&self, x: &[f64]) -> Vec<f64> {
        let mut excess: Vec<f64> = self.rhs.iter().map(|b| -b).collect();
        for ((&r, &col), &v) in self.rows.iter().zip(&self.cols).zip(&self.values) {
            excess[r] += v * x[col];
        }
        excess
    }

    /// (A, b) with `cols` variables.
    pub(super) fn into_csc(self, cols: usize) -> (CscMatrix<f64>, Vec<f64>) {
        let a =
            CscMatrix::new_from_triplets(self.rhs.len(), cols, self.rows, self.cols, self.values);
        (a, self.rhs)
    }
}

/// The plan's constraints as rows a·x ≤ b on x = t/τ (the first n variables): the floor of
/// each position (`floors_s`: `min_dwell_s` raised by the feed and machine limits), then the
/// constraints'. `with_total` leaves out the total-time row (for the least-time LP); `margin`
/// tightens the change rows by that fraction of their size.
pub(super) fn constraint_rows(
    c: &Constraints,
    floors_s: &[f64],
    tau: f64,
    with_total: bool,
    with_change: bool,
    margin: f64,
) -> Rows {
    let n = floors_s.len();
    let mut rows = Rows::default();
    for (j, floor) in floors_s.iter().enumerate() {
        rows.push(&[(j, -1.0)], -floor / tau);
    }
    if let Some(hi) = c.max_dwell_s {
        for j in 0..n {
            rows.push(&[(j, 1.0)], hi / tau);
        }
    }
    if let (Some(total), true) = (c.max_total_time_s, with_total) {
        let all: Vec<(usize, f64)> = (0..n).map(|j| (j, 1.0)).collect();
        rows.push(&all, total / tau);
    }
    if let (Some(delta), true) = (c.max_dwell_change_s, with_change) {
        for j in 0..n.saturating_sub(1) {
            let delta = delta * (1.0 - margin);
            rows.push(&[(j, -1.0), (j + 1, 1.0)], delta / tau);
            rows.push(&[(j, 1.0), (j + 1, -1.0)], delta / tau);
        }
    }
    rows
}

/// The QP in Clarabel's form: ½vᵀPv + qᵀv subject to A·v + s = b, s ∈ cones.
pub(super) struct ClarabelQp {
    /// Duality-gap tolerance, absolute and relative ([`GAP_TOLERANCE`] unless said).
    pub gap: f64,
    pub p: CscMatrix<f64>,
    pub q: Vec<f64>,
    pub a: CscMatrix<f64>,
    pub b: Vec<f64>,
    pub cones: Vec<SupportedConeT<f64>>,
}

/// Solves the QP within what is left of `budget` and maps Clarabel's status; `Ok` carries (v, iterations, seconds, status).
///
/// The first attempt runs without iterative refinement of the KKT solves: on these banded
/// Hessians refinement costs about a third of the solve time and does not change the answer
/// beyond the solver's tolerances (measured in `benches/optimize.rs`). If that attempt stops
/// on a numerical failure, the solve is repeated with refinement within what is left of the budget.
/// One thread: requests are already solved in parallel, one per computing slot.
pub(super) fn run_clarabel(
    qp: &ClarabelQp,
    budget: &Budget,
) -> Result<(Vec<f64>, u32, f64, SolveStatus), OptimizeError> {
    let first = solve_once(qp, budget.remaining_s()?, false)?;
    match first.status {
        SolverStatus::NumericalError | SolverStatus::InsufficientProgress => {
            let spent = first.solve_time;
            let mut second = solve_once(qp, budget.remaining_s()?, true)?;
            second.solve_time += spent;
            map_status(&second, budget)
        }
        _ => map_status(&first, budget),
    }
}

/// Clarabel's duality-gap tolerance (its default is 1e-8). Its objective leaves out the fit's
/// constant ½‖d/s_d‖²/m_Ω (about ½), so the gap is absolute on J, and a well-fitted plan has
/// J ≈ 1e-4: 1e-10 keeps J to about 1e-6 relative (1.1e-7 worst in tests/it/optimize_reference.rs)
/// for two or three more iterations on a variable per position; 1e-12 would cost four.
pub(super) const GAP_TOLERANCE: f64 = 1e-10;
/// The gap for the spline basis's small QP, whose plans fit better (J down to ~1e-6): four
/// more iterations cost little there.
pub(super) const SPLINE_GAP_TOLERANCE: f64 = 1e-12;

fn solve_once(
    qp: &ClarabelQp,
    time_limit_s: f64,
    refine: bool,
) -> Result<DefaultSolution<f64>, OptimizeError> {
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .time_limit(time_limit_s)
        .direct_solve_method("faer".to_string())
        .max_threads(1)
        .iterative_refinement_enable(refine)
        .tol_gap_abs(qp.gap)
        .tol_gap_rel(qp.gap)
        .build()
        .map_err(|e| OptimizeError::Numerical {
            status: format!("settings rejected: {e}"),
        })?;
    let mut solver =
        DefaultSolver::new(&qp.p, &qp.q, &qp.a, &qp.b, &qp.cones, settings).map_err(|e| {
            OptimizeError::Numerical {
                status: format!("problem rejected: {e}"),
            }
        })?;
    solver.solve();
    Ok(solver.solution)
}

fn map_status(
    sol: &DefaultSolution<f64>,
    budget: &Budget,
) -> Result<(Vec<f64>, u32, f64, SolveStatus), OptimizeError> {
    let status = match sol.status {
        SolverStatus::Solved => SolveStatus::Solved,
        SolverStatus::AlmostSolved => SolveStatus::AlmostSolved,
        SolverStatus::MaxTime => {
            return Err(OptimizeError::TimeLimit {
                limit_s: budget.limit_s(),
            })
        }
        SolverStatus::MaxIterations => {
            return Err(OptimizeError::IterationLimit {
                iterations: sol.iterations,
            })
        }
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
            return Err(OptimizeError::Infeasible {
                fields: Vec::new(),
                detail: "the constraints cannot all hold at once".into(),
            })
        }
        other => {
            return Err(OptimizeError::Numerical {
                status: format!("{other:?}"),
            })
        }
    };
    Ok((sol.x.clone(), sol.iterations, sol.solve_time, status))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every call of one optimization draws on the same budget: what one call spent is gone
    /// for the next, and an exhausted budget is a time-limit error naming the whole budget.
    #[test]
    fn the_budget_is_shared_and_runs_out() {
        let budget = Budget::start(0.05);
        let first = budget.remaining_s().unwrap();
        assert!(first <= 0.05 && first > 0.0);
        std::thread::sleep(std::time::Duration::from_millis(20));
        let second = budget.remaining_s().unwrap();
        assert!(second <= first - 0.019, "{first} then {second}");
        std::thread::sleep(std::time::Duration::from_millis(40));
        assert_eq!(
            budget.remaining_s(),
            Err(OptimizeError::TimeLimit { limit_s: 0.05 })
        );
        // A solver call on an exhausted budget does not start.
        let lp = ClarabelQp {
            gap: GAP_TOLERANCE,
            p: CscMatrix::zeros((1, 1)),
            q: vec![1.0],
            a: CscMatrix::new(1, 1, vec![0, 1], vec![0], vec![-1.0]),
            b: vec![0.0],
            cones: vec![SupportedConeT::NonnegativeConeT(1)],
        };
        assert!(matches!(
            run_clarabel(&lp, &budget),
            Err(OptimizeError::TimeLimit { limit_s }) if limit_s == 0.05
        ));
        assert!(run_clarabel(&lp, &Budget::start(10.0)).is_ok());
    }
}
