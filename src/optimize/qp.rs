//! The dwell QP (see [`super`] for the mathematics) assembled for Clarabel in the normal
//! equations, solved, and its answer mapped back to seconds and checked.

use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use rayon::prelude::*;

use super::basis::Basis;
use super::ccp::{keeps_acceleration, within_acceleration};
use super::checks::{check_plan, polish, Attempt};
use super::dwell::{DwellProblem, Solution};
use super::feasibility;
use super::kinematics::{acceleration_rows, limits_acceleration, Floor};
use super::operator::Band;
use super::problem::{Objective, OptimizeError};
use super::scaling::{objective_value, second_differences, Scales};
use super::solver::SolveStatus;
use super::solver::{
    constraint_rows, run_clarabel, Budget, ClarabelQp, CscBuilder, Rows, GAP_TOLERANCE,
    SPLINE_GAP_TOLERANCE, SPLINE_ROW_MARGIN,
};

/// A QP with at most this many variables is solved to the fine gap whatever its basis: it
/// costs microseconds, and a few coarse positions can fit a target almost exactly (J ~ 1e-6,
/// where the coarse gap would leave J ~1e-5 relative).
const SMALL_QP_VARIABLES: usize = 64;

/// The smoothing term's Hessian w·(D2·S)ᵀ(D2·S) on the variables, by its upper band:
/// `band[k][d]` is entry (k − d, k). On the positions (S = I) the band is three wide.
struct Smoothing {
    band: Vec<Vec<f64>>,
}

impl Smoothing {
    fn new(radii_mm: &[f64], basis: &Basis, weight: f64) -> Self {
        Smoothing {
            band: smoothing_band(radii_mm, basis, weight),
        }
    }

    /// Entry (j, k), j ≤ k.
    fn entry(&self, j: usize, k: usize) -> f64 {
        self.band[k].get(k - j).copied().unwrap_or(0.0)
    }

    /// How far above the diagonal the term reaches.
    fn width(&self) -> usize {
        self.band.first().map_or(0, |c| c.len() - 1)
    }
}

fn smoothing_band(radii_mm: &[f64], basis: &Basis, weight: f64) -> Vec<Vec<f64>> {
    let forms: Vec<Vec<(usize, f64)>> = second_differences(radii_mm)
        .iter()
        .enumerate()
        .map(|(r, c)| basis.form(&[(r, c[0]), (r + 1, c[1]), (r + 2, c[2])]))
        .collect();
    let width = forms
        .iter()
        .filter_map(|f| Some(f.last()?.0 - f.first()?.0))
        .max()
        .unwrap_or(0);
    let mut band = vec![vec![0.0; width + 1]; basis.size()];
    for form in &forms {
        for (a, &(i, u)) in form.iter().enumerate() {
            for &(k, v) in &form[a..] {
                band[k][k - i] += weight * u * v;
            }
        }
    }
    band
}

/// The QP's variables: the basis of the dwell, and the objective on them.
struct Variables {
    basis: Basis,
    /// The objective on them in the normal equations (from the operator's columns through
    /// the basis, M·S, and the smoothing term), made once for every solve on these variables.
    normal: NormalObjective,
}

impl Variables {
    fn new(problem: &DwellProblem, operator: &Band, basis: Basis, s: &Scales) -> Self {
        let band = operator.through(&basis);
        let smooth = Smoothing::new(problem.motion.radii_mm(), &basis, s.smoothing);
        let normal = NormalObjective::new(problem, &basis, &band, &smooth, s);
        Variables { basis, normal }
    }

    fn size(&self) -> usize {
        self.basis.size()
    }
}

/// Upper triangle of the normal-equations Hessian on (c, p̃).
fn normal_hessian(
    problem: &DwellProblem,
    band: &Band,
    smooth: &Smoothing,
    s: &Scales,
) -> CscMatrix<f64> {
    let n = band.start.len();
    let nv = n + usize::from(problem.free_piston);
    let fit = 1.0 / (s.m * s.rate * s.rate);
    let width = smooth.width();
    let columns: Vec<Vec<(usize, f64)>> = (0..n)
        .into_par_iter()
        .with_min_len(16)
        .map(|k| {
            // Columns j < k overlap k exactly when their band ends past k's start.
            let overlap_from = if band.end[k] > band.start[k] {
                band.end[..k].partition_point(|&e| e <= band.start[k])
            } else {
                k
            };
            let from = overlap_from.min(k.saturating_sub(width));
            (from..=k)
                .map(|j| (j, fit * band.dot(j, k) + smooth.entry(j, k)))
                .filter(|&(_, v)| v != 0.0)
                .collect()
        })
        .collect();
    let mut p = CscBuilder::new(nv);
    for column in columns {
        p.push_column(column);
    }
    if problem.free_piston {
        let cross = -1.0 / (s.m * s.rate);
        p.push_column(
            (0..n)
                .map(|j| (j, cross * band.column_sum(j)))
                .chain([(n, 1.0)]),
        );
    }
    p.build()
}

/// (the margin the change rows are tightened by, the duality gap) for these variables.
fn tolerances(vars: &Variables) -> (f64, f64) {
    let basis = &vars.basis;
    if basis.is_positions() && vars.size() > SMALL_QP_VARIABLES {
        (0.0, GAP_TOLERANCE)
    } else if basis.is_positions() {
        (0.0, SPLINE_GAP_TOLERANCE)
    } else {
        (SPLINE_ROW_MARGIN, SPLINE_GAP_TOLERANCE)
    }
}

/// The rows on the dwell at the positions that the first solve of a spline QP carries: those
/// that touch every `stride`-th position or the last (every multi-position row touches one),
/// or `None` (all rows) when the dwell has a variable per position or few positions per
/// variable. About two rows per spline function: a cubic between knots r_t/8 apart cannot
/// dip far between them, so the rest rarely bind, and those that do are added
/// ([`attempt`]).
fn first_rows(rows: &Rows, vars: &Variables, objective: &Objective) -> Option<Vec<bool>> {
    let positions = vars.basis.positions_len();
    let stride = positions / (2 * vars.size().max(1));
    // Without smoothing the optimum need not be unique, and which optimum an interior point
    // returns depends on every row, omitted ones too.
    if vars.basis.is_positions() || stride < 2 || objective.smoothing <= 0.0 {
        return None;
    }
    let mut keep = vec![false; rows.rhs.len()];
    for (&r, &j) in rows.rows.iter().zip(&rows.cols) {
        keep[r] |= j % stride == 0 || j + 1 == positions;
    }
    Some(keep)
}

/// Rounds of added rows before a spline QP takes all of its rows.
const MAX_ROW_ROUNDS: usize = 3;
/// An omitted row within this of binding (a·x > b − slack, x = t/τ) is added: the rows kept
/// then hold the optimum, and the omitted ones hold with room to spare.
const ROW_SLACK: f64 = 1e-9;

/// Most variables the unconstrained minimum is tried for: its dense factorisation costs n³/3
/// flops, microseconds for a spline's few dozen variables.
const DIRECT_MAX_VARIABLES: usize = 256;

/// The fit in the normal equations on (c, [p̃]): P's upper triangle and q.
struct NormalObjective {
    p: CscMatrix<f64>,
    q: Vec<f64>,
}

/// The objective's linear term for the total time: μ·Σ_j x_j/n_positions =
/// Σ_k c_k·(μ/n_positions)·Σ_j S_jk.
fn time_term(problem: &DwellProblem, basis: &Basis, s: &Scales) -> Vec<f64> {
    basis.transpose_apply(&vec![
        problem.objective.time_weight / s.n;
        basis.positions_len()
    ])
}

/// The target in depth units, one per aperture row.
fn scaled_target(problem: &DwellProblem, s: &Scales) -> Vec<f64> {
    problem.target_nm.iter().map(|d| d / s.depth_nm).collect()
}

impl NormalObjective {
    fn new(
        problem: &DwellProblem,
        basis: &Basis,
        band: &Band,
        smooth: &Smoothing,
        s: &Scales,
    ) -> Self {
        let g = scaled_target(problem, s);
        let time = time_term(problem, basis, s);
        let lin = 1.0 / (s.m * s.rate);
        let mut q: Vec<f64> = (0..basis.size())
            .map(|k| time[k] - lin * band.dot_rows(k, &g, problem.rows.start))
            .collect();
        if problem.free_piston {
            q.push(g.iter().sum::<f64>() / s.m);
        }
        NormalObjective {
            p: normal_hessian(problem, band, smooth, s),
            q,
        }
    }

    /// The minimiser of ½vᵀPv + qᵀv over every v, −P⁻¹q: a dense Cholesky factorisation and
    /// one step of iterative refinement. `None` for more than [`DIRECT_MAX_VARIABLES`]
    /// variables, or when P is not (numerically) positive definite.
    fn unconstrained_minimum(&self) -> Option<Vec<f64>> {
        let n = self.q.len();
        if n > DIRECT_MAX_VARIABLES {
            return None;
        }
        let mut dense = Mat::<f64>::zeros(n, n);
        let p = &self.p;
        for j in 0..n {
            for idx in p.colptr[j]..p.colptr[j + 1] {
                let i = p.rowval[idx];
                dense[(i, j)] = p.nzval[idx];
                dense[(j, i)] = p.nzval[idx];
            }
        }
        let llt = dense.llt(Side::Lower).ok()?;
        let minus_q = Mat::<f64>::from_fn(n, 1, |i, _| -self.q[i]);
        let mut v = minus_q.clone();
        llt.solve_in_place(v.as_mut());
        // One refinement step: the residual −q − P·v, solved and added.
        let mut step = &minus_q - &dense * &v;
        llt.solve_in_place(step.as_mut());
        let v: Vec<f64> = (0..n).map(|i| v[(i, 0)] + step[(i, 0)]).collect();
        v.iter().all(|x| x.is_finite()).then_some(v)
    }
}

/// The QP for Clarabel on the variables (c, [p̃], [u]): the fit in the normal equations. `floors_s`: each position's least
/// dwell. With `around` (a scaled plan that keeps the machine's acceleration limits), the
/// between-cell acceleration rows made convex around it are added, with their cone variables
/// u_j ≥ 1/x_j after the others ([`super::kinematics`]). Rows on the dwell at the positions
/// reach the variables through the basis.
fn assemble(
    problem: &DwellProblem,
    vars: &Variables,
    s: &Scales,
    position_rows: Rows,
    around: Option<&[f64]>,
) -> ClarabelQp {
    let basis = &vars.basis;
    let (_, gap) = tolerances(vars);
    let mut rows = position_rows.through(basis);
    let (mut p, mut q) = (vars.normal.p.clone(), vars.normal.q.clone());
    let mut nv = q.len();
    if problem.free_piston {
        rows.push(&[(nv - 1, -1.0)], 0.0);
    }
    let mut cones = Vec::new();
    let Some(x0) = around else {
        cones.push(SupportedConeT::NonnegativeConeT(rows.rhs.len()));
        let (a, b) = rows.into_csc(nv);
        return ClarabelQp {
            gap,
            p,
            q,
            a,
            b,
            cones,
        };
    };
    // One cone variable per position a row needs it for, numbered after the others.
    let accel = acceleration_rows(problem.axes, problem.motion, x0, s.dwell_s);
    let mut u_index = vec![None; basis.positions_len()];
    for row in &accel {
        for &(j, _) in &row.u {
            if u_index[j].is_none() {
                u_index[j] = Some(nv);
                nv += 1;
            }
        }
    }
    for row in &accel {
        let mut entries = basis.form(&row.x);
        entries.extend(
            row.u
                .iter()
                .map(|&(j, v)| (u_index[j].expect("numbered above"), v)),
        );
        rows.push(&entries, row.rhs);
    }
    cones.push(SupportedConeT::NonnegativeConeT(rows.rhs.len()));
    // (x_j + u_j, u_j − x_j, 2) in the second-order cone ⟺ x_j·u_j ≥ 1, x_j + u_j ≥ 0.
    for (j, u) in u_index.iter().enumerate() {
        if let Some(u) = *u {
            let mut sum = basis.form(&[(j, -1.0)]);
            sum.push((u, -1.0));
            rows.push(&sum, 0.0);
            let mut difference = basis.form(&[(j, 1.0)]);
            difference.push((u, -1.0));
            rows.push(&difference, 0.0);
            rows.push(&[], 2.0);
            cones.push(SupportedConeT::SecondOrderConeT(3));
        }
    }
    q.resize(nv, 0.0);
    p = extend_columns(p, nv);
    let (a, b) = rows.into_csc(nv);
    ClarabelQp {
        gap,
        p,
        q,
        a,
        b,
        cones,
    }
}

/// `p` with empty columns (and rows) added up to `size`.
fn extend_columns(p: CscMatrix<f64>, size: usize) -> CscMatrix<f64> {
    let mut colptr = p.colptr;
    let last = *colptr.last().expect("a CSC matrix has a column pointer");
    colptr.resize(size + 1, last);
    CscMatrix::new(size, size, colptr, p.rowval, p.nzval)
}

fn attempt(
    problem: &DwellProblem,
    operator: &Band,
    vars: &Variables,
    scales: &Scales,
    floors_s: &[f64],
    around: Option<&[f64]>,
    budget: &Budget,
) -> Result<Attempt, OptimizeError> {
    let n = vars.size();
    let (margin, _) = tolerances(vars);
    let rows = constraint_rows(
        &problem.constraints,
        floors_s,
        scales.dwell_s,
        true,
        true,
        margin,
    );
    // A spline QP is solved on a few of its rows first; any other row the answer comes near
    // is added and the QP solved again. The answer that keeps every row it omits is the
    // optimum with all of them (omitting rows only widens the feasible set).
    let (mut iterations, mut solve_time_s) = (0, 0.0);
    let started = Instant::now();
    // Where the fit's own minimum keeps every row, no row binds: it is the QP's optimum (the
    // KKT conditions hold with zero multipliers), exactly, without an interior point. A
    // uniform layer usually asks for dwell well inside its bounds.
    let unconstrained = Some(&vars.normal)
        .filter(|_| around.is_none())
        .and_then(NormalObjective::unconstrained_minimum)
        .filter(|v| {
            let keeps_rows = rows
                .excess(&vars.basis.dwell(&v[..n]))
                .iter()
                .all(|&e| e <= 0.0);
            keeps_rows && (!problem.free_piston || v[n] >= 0.0)
        });
    let mut solve = |rows: Rows| {
        let qp = assemble(problem, vars, scales, rows, around);
        let (v, its, seconds, status) = run_clarabel(&qp, budget)?;
        iterations += its;
        solve_time_s += seconds;
        Ok::<_, OptimizeError>((v, status))
    };
    let (v, status) = if let Some(v) = unconstrained {
        // As any solver call, within the budget.
        budget.remaining_s()?;
        solve_time_s = started.elapsed().as_secs_f64();
        (v, SolveStatus::Solved)
    } else {
        match first_rows(&rows, vars, &problem.objective) {
            None => solve(rows)?,
            Some(mut keep) => {
                let mut rounds = 0;
                loop {
                    if rounds == MAX_ROW_ROUNDS {
                        break solve(rows)?;
                    }
                    let (v, status) = solve(rows.select(&keep))?;
                    let excess = rows.excess(&vars.basis.dwell(&v[..n]));
                    let mut added = false;
                    for (r, e) in excess.into_iter().enumerate() {
                        if !keep[r] && e > -ROW_SLACK {
                            keep[r] = true;
                            added = true;
                        }
                    }
                    if !added {
                        break (v, status);
                    }
                    rounds += 1;
                }
            }
        }
    };
    let dwell_s = polish(
        &problem.constraints,
        floors_s,
        &vars.basis.dwell(&v[..n]),
        scales.dwell_s,
    );
    let piston_nm = problem.free_piston.then(|| v[n].max(0.0) * scales.depth_nm);
    let objective = objective_value(
        problem,
        operator,
        scales,
        &dwell_s,
        piston_nm.unwrap_or(0.0),
    );
    Ok(Attempt {
        dwell_s,
        piston_nm,
        status,
        iterations,
        solve_time_s,
        objective,
    })
}

/// The plan with the dwell in `basis`: the QP, then, if the machine's acceleration limits
/// between cells are not kept, the convex–concave procedure.
fn plan_in(
    problem: &DwellProblem,
    operator: &Band,
    basis: Basis,
    scales: &Scales,
    floors: &[Floor],
    budget: &Budget,
) -> Result<Attempt, OptimizeError> {
    let vars = Variables::new(problem, operator, basis, scales);
    let floors_s: Vec<f64> = floors.iter().map(|f| f.dwell_s).collect();
    let mut plan = attempt(problem, operator, &vars, scales, &floors_s, None, budget)?;
    if limits_acceleration(problem.axes)
        && !keeps_acceleration(problem.axes, problem.motion, &plan.dwell_s)
    {
        let first = (plan.iterations, plan.solve_time_s);
        plan = within_acceleration(problem, operator, scales, floors, |around| {
            attempt(
                problem,
                operator,
                &vars,
                scales,
                &floors_s,
                Some(around),
                budget,
            )
        })?;
        plan.iterations += first.0;
        plan.solve_time_s += first.1;
    }
    Ok(plan)
}

/// Finds the plan: checks feasibility (naming conflicting constraints), solves, clamps the
/// dwell bounds exactly and checks every constraint (the machine's limits included) to
/// [`super::problem::CONSTRAINT_TOLERANCE`] before returning. The constraints and weights
/// are expected valid ([`Constraints::validate`], [`Objective::validate`]: callers parse them
/// once, before asking for a computation slot). Every solver call shares one budget of
/// `time_limit_s`.
pub fn optimize(problem: &DwellProblem) -> Result<Solution, OptimizeError> {
    let budget = Budget::start(problem.time_limit_s);
    let n = problem.motion.len();
    assert_eq!(
        n,
        problem.operator.cols(),
        "one position per operator column"
    );
    debug_assert!(problem.constraints.validate().is_ok());
    debug_assert!(problem.objective.validate().is_ok());
    if problem.rows.is_empty() {
        return Err(OptimizeError::EmptyAperture);
    }
    assert_eq!(
        problem.target_nm.len(),
        problem.rows.len(),
        "one target per aperture row"
    );
    let c = &problem.constraints;
    let floors = problem.floors();
    feasibility::check(c, &floors, &budget)?;

    let band = Band::new(problem.operator, &problem.rows);
    let scales = Scales::of(problem, &band)?;
    let rt = problem.tool_radius_mm;

    let basis = Basis::new(problem.motion.radii_mm(), rt, problem.basis);
    let checked = |basis: Basis| {
        let plan = plan_in(problem, &band, basis, &scales, &floors, &budget)?;
        check_plan(problem, &floors, &scales, &plan).map(|()| plan)
    };
    let plan = if basis.is_positions() {
        checked(basis)?
    } else {
        // The spline holds every constant plan, so it is feasible whenever the positions are,
        // unless the total time is so tight that only dwell it cannot shape meets it. Its rows
        // are combinations of the positions' rows, which the solver keeps less tightly. In
        // either case the positions' own variables answer.
        match checked(basis) {
            Err(OptimizeError::Infeasible { fields, .. }) if fields.is_empty() => {
                checked(Basis::positions(n))?
            }
            Err(OptimizeError::Numerical { .. }) => checked(Basis::positions(n))?,
            other => other?,
        }
    };
    Ok(Solution {
        dwell_s: plan.dwell_s,
        piston_nm: plan.piston_nm,
        status: plan.status,
        iterations: plan.iterations,
        solve_time_s: plan.solve_time_s,
        objective: plan.objective,
    })
}
