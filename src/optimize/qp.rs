//! The dwell QP (see [`super`] for the mathematics) assembled for Clarabel in one of two
//! formulations, solved, and its answer mapped back to seconds and checked.

use std::ops::Range;

use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;
use rayon::prelude::*;

use super::feasibility;
use super::problem::{Constraints, Objective, OptimizeError};
pub use super::solver::SolveStatus;
use super::solver::{constraint_rows, run_clarabel, Budget, ClarabelQp, CscBuilder, Rows};
use crate::physics::RemovalOperator;

/// How the least-squares fit reaches Clarabel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Formulation {
    /// Hessian MᵀM/m_Ω (banded, dense within the band) on the dwell variables only.
    #[default]
    NormalEquations,
    /// Residual variables e = M·x − d tied by equality rows; the Hessian is diagonal plus
    /// the smoothing band, and M enters the constraint matrix as its band.
    Residual,
}

/// One dwell optimization: the operator over the radial grid, the rows of the clear aperture,
/// the target there, and what the plan must respect.
#[derive(Debug, Clone)]
pub struct DwellProblem<'a> {
    pub operator: &'a RemovalOperator,
    /// Candidate tool positions, mm, strictly increasing (one per operator column).
    pub positions_mm: &'a [f64],
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
    pub formulation: Formulation,
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

/// Operator columns cut to the aperture rows: column j covers rows start[j]..end[j] (absolute)
/// with values[j]; both bounds are non-decreasing in j because positions increase.
struct Band<'a> {
    start: Vec<usize>,
    end: Vec<usize>,
    values: Vec<&'a [f64]>,
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
            values.push(if hi > lo {
                &column[lo - first..hi - first]
            } else {
                &[]
            });
        }
        Band { start, end, values }
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
fn second_differences(positions_mm: &[f64]) -> Vec<[f64; 3]> {
    positions_mm
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

/// The upper band of w·D2ᵀD2: `[diag, first super-diagonal, second super-diagonal]` per column
/// index j (entries (j, j), (j−1, j), (j−2, j)).
fn smoothing_band(positions_mm: &[f64], weight: f64) -> Vec<[f64; 3]> {
    let mut band = vec![[0.0; 3]; positions_mm.len()];
    for (r, c) in second_differences(positions_mm).iter().enumerate() {
        for a in 0..3 {
            for b in a..3 {
                band[r + b][b - a] += weight * c[a] * c[b];
            }
        }
    }
    band
}

/// Evaluates J at dwell `t` (s) and piston `p` (nm): the reported objective, the same for
/// both formulations.
fn objective_value(problem: &DwellProblem, band: &Band, s: &Scales, t: &[f64], p: f64) -> f64 {
    let rows = &problem.rows;
    let mut removal = vec![0.0; rows.len()];
    for (j, &tj) in t.iter().enumerate() {
        let from = band.start[j] - rows.start;
        for (o, m) in removal[from..].iter_mut().zip(band.values[j]) {
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
    let smooth: f64 = second_differences(problem.positions_mm)
        .iter()
        .zip(x.windows(3))
        .map(|(c, w)| (c[0] * w[0] + c[1] * w[1] + c[2] * w[2]).powi(2))
        .sum::<f64>()
        * s.smoothing
        / 2.0;
    let time = problem.objective.time_weight * x.iter().sum::<f64>() / s.n;
    fit + smooth + time
}

/// Upper triangle of the normal-equations Hessian on (x, p̃).
fn normal_hessian(problem: &DwellProblem, band: &Band, s: &Scales) -> CscMatrix<f64> {
    let n = problem.positions_mm.len();
    let nv = n + usize::from(problem.free_piston);
    let smooth = smoothing_band(problem.positions_mm, s.smoothing);
    let fit = 1.0 / (s.m * s.rate * s.rate);
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
            let from = overlap_from.min(k.saturating_sub(2));
            (from..=k)
                .map(|j| {
                    let d = k - j;
                    let sm = if d < 3 { smooth[k][d] } else { 0.0 };
                    (j, fit * band.dot(j, k) + sm)
                })
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

fn assemble(problem: &DwellProblem, band: &Band, s: &Scales) -> ClarabelQp {
    let n = problem.positions_mm.len();
    let m = problem.rows.len();
    let g: Vec<f64> = problem.target_nm.iter().map(|d| d / s.depth_nm).collect();
    let time = problem.objective.time_weight / s.n;
    let c = &problem.constraints;
    match problem.formulation {
        Formulation::NormalEquations => {
            let nv = n + usize::from(problem.free_piston);
            let lin = 1.0 / (s.m * s.rate);
            let mut q: Vec<f64> = (0..n)
                .map(|j| time - lin * band.dot_rows(j, &g, problem.rows.start))
                .collect();
            if problem.free_piston {
                q.push(g.iter().sum::<f64>() / s.m);
            }
            let mut rows = constraint_rows(problem.positions_mm, c, s.dwell_s, true, true);
            if problem.free_piston {
                rows.push(&[(nv - 1, -1.0)], 0.0);
            }
            let count = rows.rhs.len();
            let (a, b) = rows.into_csc(nv);
            ClarabelQp {
                p: normal_hessian(problem, band, s),
                q,
                a,
                b,
                cones: vec![SupportedConeT::NonnegativeConeT(count)],
            }
        }
        Formulation::Residual => {
            // Variables (x, e, [p̃]); rows: M·x/ā − e − p̃ = g (zero cone), then inequalities.
            let nv = n + m + usize::from(problem.free_piston);
            let smooth = smoothing_band(problem.positions_mm, s.smoothing);
            let mut p = CscBuilder::new(nv);
            for (k, diag) in smooth.iter().enumerate() {
                p.push_column(
                    (k.saturating_sub(2)..=k)
                        .map(|j| (j, diag[k - j]))
                        .filter(|&(_, v)| v != 0.0),
                );
            }
            for i in 0..m {
                p.push_column([(n + i, 1.0 / s.m)]);
            }
            if problem.free_piston {
                p.push_column([]);
            }
            let mut q = vec![time; n];
            q.resize(nv, 0.0);

            let mut rows = Rows::default();
            for j in 0..n {
                for (k, &v) in band.values[j].iter().enumerate() {
                    rows.rows.push(band.start[j] - problem.rows.start + k);
                    rows.cols.push(j);
                    rows.values.push(v / s.rate);
                }
            }
            for i in 0..m {
                rows.rows.push(i);
                rows.cols.push(n + i);
                rows.values.push(-1.0);
                if problem.free_piston {
                    rows.rows.push(i);
                    rows.cols.push(nv - 1);
                    rows.values.push(-1.0);
                }
            }
            rows.rhs = g;
            rows.append(constraint_rows(
                problem.positions_mm,
                c,
                s.dwell_s,
                true,
                true,
            ));
            if problem.free_piston {
                rows.push(&[(nv - 1, -1.0)], 0.0);
            }
            let count = rows.rhs.len();
            let (a, b) = rows.into_csc(nv);
            ClarabelQp {
                p: p.build(),
                q,
                a,
                b,
                cones: vec![
                    SupportedConeT::ZeroConeT(m),
                    SupportedConeT::NonnegativeConeT(count - m),
                ],
            }
        }
    }
}

/// The interior-point answer in seconds, with the dwell bounds made exact and, if the total
/// time is over by the solver's rounding (it sums n small errors), the dwell above the lower
/// bound shrunk in proportion, which keeps the bounds and the dwell-change rows.
fn polish(c: &Constraints, x: &[f64], tau: f64) -> Vec<f64> {
    let mut t: Vec<f64> = x
        .iter()
        .map(|x| {
            let t = (x * tau).max(c.min_dwell_s);
            c.max_dwell_s.map_or(t, |hi| t.min(hi))
        })
        .collect();
    if let Some(total) = c.max_total_time_s {
        let sum: f64 = t.iter().sum();
        let floor = c.min_dwell_s * t.len() as f64;
        if sum > total && sum > floor {
            let k = ((total - floor) / (sum - floor)).max(0.0);
            for tj in &mut t {
                *tj = c.min_dwell_s + (*tj - c.min_dwell_s) * k;
            }
        }
    }
    t
}

/// Finds the plan: checks feasibility (naming conflicting constraints), solves, clamps the
/// dwell bounds exactly and checks every constraint to
/// [`super::problem::CONSTRAINT_TOLERANCE`] before returning. The constraints and weights
/// are expected valid ([`Constraints::validate`], [`Objective::validate`]: callers parse them
/// once, before asking for a computation slot). The feasibility LP and the QP share one
/// budget of `time_limit_s`.
pub fn optimize(problem: &DwellProblem) -> Result<Solution, OptimizeError> {
    let budget = Budget::start(problem.time_limit_s);
    let n = problem.positions_mm.len();
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
    feasibility::check(problem.positions_mm, &problem.constraints, &budget)?;

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

    let qp = assemble(problem, &band, &scales);
    let (v, iterations, solve_time_s, status) = run_clarabel(&qp, &budget)?;

    let dwell_s = polish(&problem.constraints, &v[..n], scales.dwell_s);
    let c = &problem.constraints;
    let piston_nm = problem
        .free_piston
        .then(|| v[v.len() - 1].max(0.0) * scales.depth_nm);
    if let Some((name, index, excess)) = c.violation(problem.positions_mm, &dwell_s, scales.dwell_s)
    {
        return Err(OptimizeError::Numerical {
            status: format!(
                "{status:?}, but the plan breaks {name} at index {index} by {excess:e} s"
            ),
        });
    }
    let objective = objective_value(problem, &band, &scales, &dwell_s, piston_nm.unwrap_or(0.0));
    Ok(Solution {
        dwell_s,
        piston_nm,
        status,
        iterations,
        solve_time_s,
        objective,
    })
}
