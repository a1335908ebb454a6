//! The dwell QP (see [`super`] for the mathematics) assembled for Clarabel in the normal
//! equations, solved, and its answer mapped back to seconds and checked.

use std::borrow::Cow;
use std::ops::Range;
use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use rayon::prelude::*;

use super::basis::{Basis, DwellBasis};
use super::feasibility;
use super::kinematics::{
    acceleration_rows, constant_dwell_for_acceleration, floors, limits_acceleration,
    peak_acceleration_ratio, AxisPath, Floor, PathFeed, CCP_TOLERANCE, MARGIN, MAX_CCP_ITERATIONS,
};
use super::problem::{Bound, Constraint, Constraints, Objective, OptimizeError};
pub use super::solver::SolveStatus;
use super::solver::{
    constraint_rows, run_clarabel, Budget, ClarabelQp, CscBuilder, Rows, GAP_TOLERANCE,
    SPLINE_GAP_TOLERANCE, SPLINE_ROW_MARGIN,
};

/// A QP with at most this many variables is solved to the fine gap whatever its basis: it
/// costs microseconds, and a few coarse positions can fit a target almost exactly (J ~ 1e-6,
/// where the coarse gap would leave J ~1e-5 relative).
const SMALL_QP_VARIABLES: usize = 64;
use crate::physics::{Motion, RemovalOperator};

/// One dwell optimization: the operator over the radial grid (or over the clear aperture's
/// radii alone), the rows of the clear aperture in it, the target there, and what the plan
/// must respect.
#[derive(Debug, Clone)]
pub struct DwellProblem<'a> {
    pub operator: &'a RemovalOperator,
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
        floors(self.axes, feed, self.motion, c.min_dwell_s)
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

/// Columns cut to the aperture rows: column j covers rows start[j]..end[j] (absolute) with
/// values[j]; both bounds are non-decreasing in j because positions increase. The operator's
/// own columns are borrowed; those of M·S (one per basis function) are computed.
struct Band<'a> {
    start: Vec<usize>,
    end: Vec<usize>,
    values: Vec<Cow<'a, [f64]>>,
}

impl<'a> Band<'a> {
    fn new(op: &'a RemovalOperator, rows: &Range<usize>) -> Self {
        let n = op.cols();
        let (mut start, mut end, mut values) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for j in 0..n {
            let (first, column) = op.column(j);
            // Clamped into the aperture rows; an empty column gets start = end.
            let lo = first.clamp(rows.start, rows.end);
            let hi = (first + column.len()).clamp(rows.start, rows.end);
            start.push(lo);
            end.push(hi.max(lo));
            values.push(Cow::Borrowed(if hi > lo {
                &column[lo - first..hi - first]
            } else {
                &[]
            }));
        }
        Band { start, end, values }
    }

    /// The columns of M·S: column k is Σ_j S_jk·M_j over the positions B_k reaches.
    fn through(&self, basis: &Basis) -> Band<'a> {
        if basis.is_positions() {
            return Band {
                start: self.start.clone(),
                end: self.end.clone(),
                values: self.values.clone(),
            };
        }
        let columns: Vec<(usize, usize, Cow<'a, [f64]>)> = (0..basis.size())
            .into_par_iter()
            .map(|k| {
                let reach = basis.support(k);
                let lo = self.start[reach.start];
                let hi = self.end[reach.end - 1].max(lo);
                let mut column = vec![0.0; hi - lo];
                for j in reach {
                    let Some((_, w)) = basis.terms(j).find(|&(v, _)| v == k) else {
                        continue;
                    };
                    let from = self.start[j] - lo;
                    for (o, m) in column[from..].iter_mut().zip(self.values[j].iter()) {
                        *o += w * m;
                    }
                }
                (lo, hi, Cow::Owned(column))
            })
            .collect();
        let mut band = Band {
            start: Vec::with_capacity(columns.len()),
            end: Vec::with_capacity(columns.len()),
            values: Vec::with_capacity(columns.len()),
        };
        for (lo, hi, column) in columns {
            band.start.push(lo);
            band.end.push(hi);
            band.values.push(column);
        }
        band
    }

    fn dot(&self, j: usize, k: usize) -> f64 {
        let lo = self.start[j].max(self.start[k]);
        let hi = self.end[j].min(self.end[k]);
        if hi <= lo {
            return 0.0;
        }
        let a = &self.values[j][lo - self.start[j]..hi - self.start[j]];
        let b = &self.values[k][lo - self.start[k]..hi - self.start[k]];
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }

    fn column_sum(&self, j: usize) -> f64 {
        self.values[j].iter().sum()
    }

    /// Σ_i M_ij·y_i with y indexed from the first aperture row.
    fn dot_rows(&self, j: usize, y: &[f64], row0: usize) -> f64 {
        let from = self.start[j] - row0;
        self.values[j]
            .iter()
            .zip(&y[from..])
            .map(|(m, v)| m * v)
            .sum()
    }
}

/// Depth and dwell scales and the scaled weights.
struct Scales {
    m: f64,
    n: f64,
    /// ā, nm/s.
    rate: f64,
    depth_nm: f64,
    dwell_s: f64,
    /// λ·r_t⁴/(n − 2): the smoothing weight on Σ (x'')².
    smoothing: f64,
}

/// D2: the second divided differences on the positions, one row (3 coefficients, 1/mm²) per
/// interior position.
fn second_differences(radii_mm: &[f64]) -> Vec<[f64; 3]> {
    radii_mm
        .windows(3)
        .map(|w| {
            let (h0, h1) = (w[1] - w[0], w[2] - w[1]);
            [
                2.0 / (h0 * (h0 + h1)),
                -2.0 / (h0 * h1),
                2.0 / (h1 * (h0 + h1)),
            ]
        })
        .collect()
}

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

/// Evaluates J at dwell `t` (s) and piston `p` (nm): the reported objective, from the
/// documented formula rather than the QP's scaled terms.
fn objective_value(problem: &DwellProblem, band: &Band, s: &Scales, t: &[f64], p: f64) -> f64 {
    let rows = &problem.rows;
    let mut removal = vec![0.0; rows.len()];
    for (j, &tj) in t.iter().enumerate() {
        let from = band.start[j] - rows.start;
        for (o, m) in removal[from..].iter_mut().zip(band.values[j].iter()) {
            *o += m * tj;
        }
    }
    let fit: f64 = removal
        .iter()
        .zip(problem.target_nm)
        .map(|(z, d)| ((z - d - p) / s.depth_nm).powi(2))
        .sum::<f64>()
        / (2.0 * s.m);
    let x: Vec<f64> = t.iter().map(|v| v / s.dwell_s).collect();
    let smooth: f64 = second_differences(problem.motion.radii_mm())
        .iter()
        .zip(x.windows(3))
        .map(|(c, w)| (c[0] * w[0] + c[1] * w[1] + c[2] * w[2]).powi(2))
        .sum::<f64>()
        * s.smoothing
        / 2.0;
    let time = problem.objective.time_weight * x.iter().sum::<f64>() / s.n;
    fit + smooth + time
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

/// The interior-point answer in seconds, with the dwell bounds made exact and, if the total
/// time is over by the solver's rounding (it sums n small errors), the dwell above each floor
/// shrunk in proportion, which keeps the bounds and the dwell-change rows.
fn polish(c: &Constraints, floors_s: &[f64], x: &[f64], tau: f64) -> Vec<f64> {
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

/// One solve of the QP (around a plan for the acceleration rows, or without them), polished.
struct Attempt {
    dwell_s: Vec<f64>,
    piston_nm: Option<f64>,
    status: SolveStatus,
    iterations: u32,
    solve_time_s: f64,
    objective: f64,
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

fn keeps_acceleration(axes: &[AxisPath], motion: &Motion, dwell_s: &[f64]) -> bool {
    axes.iter()
        .all(|a| peak_acceleration_ratio(a, motion, dwell_s) <= 1.0 - 0.5 * MARGIN)
}

/// The plan within the machine's acceleration limits between cells, by the convex–concave
/// procedure of [`super::kinematics`] from the constant dwell that keeps every row.
fn within_acceleration(
    problem: &DwellProblem,
    operator: &Band,
    vars: &Variables,
    scales: &Scales,
    floors: &[Floor],
    budget: &Budget,
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
        let next = attempt(
            problem,
            operator,
            vars,
            scales,
            &floors_s,
            Some(&around),
            budget,
        )?;
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

/// Refuses a plan that breaks a constraint or the machine's acceleration limits by more than
/// the tolerance (a solver's inaccuracy: the QP keeps them all).
fn check_plan(
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
        plan = within_acceleration(problem, operator, &vars, scales, floors, budget)?;
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
    let m = problem.rows.len() as f64;
    let rate = (0..n).map(|j| band.column_sum(j)).sum::<f64>() / m;
    if rate.is_nan() || rate <= 0.0 {
        return Err(OptimizeError::NoRemovalInAperture);
    }
    let rms = (problem.target_nm.iter().map(|d| d * d).sum::<f64>() / m).sqrt();
    let depth_nm = if rms > 0.0 { rms } else { 1.0 };
    let rt = problem.tool_radius_mm;
    let scales = Scales {
        m,
        n: n as f64,
        rate,
        depth_nm,
        dwell_s: depth_nm / rate,
        smoothing: if n > 2 {
            problem.objective.smoothing * rt.powi(4) / (n - 2) as f64
        } else {
            0.0
        },
    };

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
