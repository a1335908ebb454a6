//! The dwell optimizer: dwell times t_j ≥ 0 at candidate tool positions r1_j such that the
//! predicted removal M·t matches a target depth d over the clear aperture, within the
//! machine's and the shop's limits. Pure: no HTTP, JSON or OpenAPI types.
//!
//! # The quadratic program
//!
//! Let Ω be the radial samples inside the clear aperture (m_Ω of them), M the removal operator
//! (nm/s) restricted to Ω, d the target (nm) on Ω and p ≥ 0 an optional free piston (a uniform
//! extra layer, for figure correction). Two scales make the problem dimensionless, so one set
//! of default weights serves every process and depth:
//!
//! ```text
//! s_d = √(Σ_Ω d_i² / m_Ω)          depth scale (nm; 1 nm if the target is all zero)
//! ā   = Σ_Ω Σ_j M_ij / m_Ω          removal rate of one second at every position (nm/s)
//! τ   = s_d / ā                     dwell scale (s): equal dwell τ removes about s_d
//! ```
//!
//! With x = t/τ and p̃ = p/s_d the optimizer minimises
//!
//! ```text
//! J(x, p̃) = 1/(2 m_Ω) · Σ_Ω ((M·t − d − p)_i / s_d)²          fit
//!          + λ/2 · r_t⁴/(n − 2) · Σ_k (x''_k)²                  smoothing
//!          + μ · Σ_j x_j / n                                    time
//! ```
//!
//! where x''_k is the second divided difference of x at position k (1/mm², exact for
//! unevenly spaced positions) and r_t the tool radius, so the smoothing term is the mean
//! squared curvature of the dwell over one pad radius and does not change with the number
//! of positions. λ ([`Objective::smoothing`]) damps dwell that oscillates between neighbours,
//! which the pad cannot see and the fit cannot fix; μ ([`Objective::time_weight`]) makes the
//! optimizer prefer, among plans that fit about equally well, the one that takes less time,
//! so it does not park dwell where the pad barely removes (near r1 = 0 at η = −1). The time
//! term biases the mean depth low by about μ·s_d·(mean x): 2e-6 of the depth at the default.
//!
//! Constraints (all optional but t ≥ 0):
//!
//! ```text
//! min_dwell_s ≤ t_j ≤ max_dwell_s                          dwell bounds
//! Σ t_j ≤ max_total_time_s                                  total time
//! t_j ≥ 60·L_j / (w_j·max_feed)                             feed across each cell
//! |t_{j+1} − t_j| ≤ max_dwell_change_s                      acceleration surrogate
//! machine axis velocity and acceleration limits             see [`kinematics`]
//! ```
//!
//! The plan moves as its machine program does ([`crate::physics::motion`]): the cell around
//! position j (between the midpoints to its neighbours; from the position itself at the two
//! ends) is crossed at constant speed in w_j·t_j, w_j = 1 inside and ½ at the ends (which
//! stop for the other half). L_j is the length of the program's move across it (the X–Z path
//! of the B pivot, [`DwellProblem::cell_path_mm`]), so the feed limit is a floor on each dwell.
//! Bounding the dwell change δ bounds the feed acceleration: on evenly spaced positions
//! (spacing h) the feed is h/t_j and changes over (t_j + t_{j+1})/2 between interior cells, so
//! |a| ≤ h·δ / t_min³; with a feed limit v_max (mm/s), t_min ≥ h/v_max, so
//! δ = a_max·h²/v_max³ keeps an acceleration limit a_max there (4/3 of it next to the end
//! cells, whose moves take half their dwell).
//!
//! # The dwell's representation
//!
//! When the positions are finer than the pad can resolve, the variables are not the n dwells
//! but the coefficients of a cubic B-spline with knots r_t/8 apart (t = S·c, see [`basis`]):
//! tens of variables whatever n, with every constraint above still a row at the positions.
//! This is what makes the optimizer's cost grow like n (the rows) and n² (the operator) instead
//! of n³ (a Hessian dense within a band 2·r_t/h wide, factorised at every interior-point
//! iteration), and it gives the feed axis a smooth dwell. Coarse positions keep a variable
//! each, as does the rare problem the spline cannot solve (a total time only unshaped dwell
//! meets, or rows the solver keeps less tightly than the tolerance): the positions' own QP
//! then answers.
//!
//! A smoothed spline QP is first solved on about two of its position rows per function (those
//! at every stride-th position; a cubic between knots r_t/8 apart cannot dip far between
//! them). Every row its answer breaks or comes within 1e-9 of (in units of the dwell scale)
//! is added and the QP solved again; after three rounds it takes all rows. The answer that
//! keeps every omitted row with room to spare is the optimum with all of them: omitting rows
//! only widens the feasible set, so its optimum is no worse, and it is feasible for the full
//! set. With the strictly convex objective smoothing gives, that optimum is unique, so the
//! plan does not depend on which rows were omitted (without smoothing the optimum can be a
//! face, and which point of it an interior point returns depends on every row: those QPs take
//! all rows at once).
//!
//! Before any interior point, the fit's own minimum is tried: with the objective written
//! ½vᵀPv + qᵀv on the variables (P positive definite: the fit plus the smoothing), v* = −P⁻¹q
//! by a dense Cholesky factorisation (one step of iterative refinement; up to 256 variables,
//! microseconds for a spline's few dozen). When v* keeps every row (all of them, the omitted
//! ones too), no row binds and v* is the QP's optimum exactly: the KKT conditions hold with
//! zero multipliers. A uniform layer usually asks for dwell well inside its bounds and is
//! answered so (the response's `iterations` is then 0); a figure correction, or any plan on
//! its limits, goes to the interior point.
//!
//! The QP goes to Clarabel (interior point, sparse LDLᵀ) as dense normal equations: the
//! Hessian (MS)ᵀMS/m_Ω is banded (functions more than 2·r_t apart never share a sample), built
//! from the operator's column bands in parallel. (A residual formulation, M·S·c − e = d as
//! equality rows with ½‖e‖² on extra variables, was measured slower and is gone.)

pub mod basis;
pub mod bounded;
mod ccp;
mod checks;
pub mod dwell;
pub mod feasibility;
pub mod harmonics;
pub mod kinematics;
pub mod normal;
pub mod operator;
pub mod problem;
pub mod qp;
pub mod raster;
mod scaling;
pub mod solver;
pub mod target;

pub use basis::DwellBasis;
pub use dwell::{DwellProblem, Solution};
pub use operator::DwellOperator;
pub use problem::{
    Bound, Breach, Constraint, Constraints, ConstraintsSpec, Objective, OptimizeError, Weight,
};
pub use qp::optimize;
pub use solver::SolveStatus;
pub use target::{measured_profile, resample_profile, MeasuredProfileError};
