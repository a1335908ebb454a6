//! Conflicts between constraints, found before the QP is solved and reported by name.
//!
//! Given the dwell bounds lo_j ≤ t_j ≤ hi (lo_j: `min_dwell_s`, raised where the feed limit,
//! the machine's velocity limits or its acceleration at the ends ask more, see
//! [`super::kinematics`]), the change rows |t_{j+1} − t_j| ≤ δ and the total Σ t_j ≤ T, only two
//! conflicts are possible:
//!
//! - lo_j > hi;
//! - the least total time the other rows allow exceeds T. That least time is Σ lo_j unless a
//!   change limit binds between unequal floors; then it is the value of the LP min Σ t subject
//!   to the other rows, solved here with Clarabel.
//!
//! Otherwise the constant plan t_j = max_j lo_j keeps the bounds and change rows, so the
//! feasible set is not empty. (The machine's acceleration limits between cells are not
//! convex; the optimizer checks its own starting plan against them.)

use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;

use super::kinematics::Floor;
use super::problem::{Bound, Constraint, Constraints, OptimizeError};
use super::solver::{constraint_rows, run_clarabel, Budget, ClarabelQp, GAP_TOLERANCE};

/// Relative margin by which a bound must be exceeded before we call it a conflict (well above
/// the LP's own accuracy, so rounding never refuses a feasible request).
const MARGIN: f64 = 1e-7;

const MIN_DWELL: Bound = Bound::Constraint(Constraint::MinDwell);
const MAX_DWELL: Bound = Bound::Constraint(Constraint::MaxDwell);
const MAX_TOTAL_TIME: Bound = Bound::Constraint(Constraint::MaxTotalTime);

fn conflict(fields: Vec<Bound>, detail: String) -> OptimizeError {
    OptimizeError::Infeasible { fields, detail }
}

/// The distinct limits that set positive floors, in order of first appearance.
fn floor_bounds(floors: &[Floor]) -> Vec<Bound> {
    let mut bounds = Vec::new();
    for f in floors.iter().filter(|f| f.dwell_s > 0.0) {
        if !bounds.contains(&f.bound) {
            bounds.push(f.bound);
        }
    }
    bounds
}

fn names(bounds: &[Bound]) -> String {
    bounds
        .iter()
        .map(|b| b.describe())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Refuses constraints that cannot all hold, naming those in conflict. `floors`: each
/// position's least dwell (`min_dwell_s` raised by the feed and machine limits).
pub fn check(c: &Constraints, floors: &[Floor], budget: &Budget) -> Result<(), OptimizeError> {
    if let Some(hi) = c.max_dwell_s {
        if let Some((j, floor)) = floors
            .iter()
            .enumerate()
            .find(|(_, f)| f.dwell_s > hi * (1.0 + MARGIN))
        {
            let lo = floor.dwell_s;
            let detail = if floor.bound == MIN_DWELL {
                format!("min_dwell_s ({lo} s) exceeds max_dwell_s ({hi} s)")
            } else {
                format!(
                    "position {j} needs at least {lo} s of dwell to keep {}, more than max_dwell_s ({hi} s)",
                    floor.bound.describe()
                )
            };
            return Err(conflict(vec![floor.bound, MAX_DWELL], detail));
        }
    }
    let Some(total) = c.max_total_time_s else {
        return Ok(());
    };
    let least: f64 = floors.iter().map(|f| f.dwell_s).sum();
    if least > total * (1.0 + MARGIN) {
        let mut fields = floor_bounds(floors);
        let detail = if fields == [MIN_DWELL] {
            let n = floors.len();
            format!(
                "min_dwell_s ({} s) × {n} positions = {least} s exceeds max_total_time_s ({total} s)",
                c.min_dwell_s
            )
        } else {
            format!(
                "the least dwell at each position ({}) adds up to {least} s, more than max_total_time_s ({total} s)",
                names(&fields)
            )
        };
        fields.push(MAX_TOTAL_TIME);
        return Err(conflict(fields, detail));
    }
    // Σ lo_j is the least time unless a change limit binds between unequal floors.
    let uneven = floors.windows(2).any(|w| w[0].dwell_s != w[1].dwell_s);
    if !(uneven && c.max_dwell_change_s.is_some()) {
        return Ok(());
    }
    let least = least_total_time_s(c, floors, true, budget)?;
    if least <= total * (1.0 + MARGIN) {
        return Ok(());
    }
    let mut fields = vec![MAX_TOTAL_TIME];
    fields.extend(floor_bounds(floors));
    if c.max_dwell_change_s.is_some()
        && least_total_time_s(c, floors, false, budget)? < least * (1.0 - MARGIN)
    {
        fields.push(Bound::Constraint(Constraint::MaxDwellChange));
    }
    let detail = format!(
        "the plan needs at least {least:.6} s in total to keep {}, more than max_total_time_s ({total} s)",
        names(&fields[1..])
    );
    Err(conflict(fields, detail))
}

/// min Σ t over the bounds and (if `with_change`) change rows: a small sparse LP.
fn least_total_time_s(
    c: &Constraints,
    floors: &[Floor],
    with_change: bool,
    budget: &Budget,
) -> Result<f64, OptimizeError> {
    let n = floors.len();
    // Scale so the LP's variables are of order one.
    let floors_s: Vec<f64> = floors.iter().map(|f| f.dwell_s).collect();
    let scale = floors_s
        .iter()
        .copied()
        .fold(0.0_f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let rows = constraint_rows(c, &floors_s, scale, false, with_change, 0.0);
    let count = rows.rhs.len();
    let (a, b) = rows.into_csc(n);
    let lp = ClarabelQp {
        gap: GAP_TOLERANCE,
        p: CscMatrix::zeros((n, n)),
        q: vec![1.0; n],
        a,
        b,
        cones: vec![SupportedConeT::NonnegativeConeT(count)],
    };
    let (x, ..) = run_clarabel(&lp, budget)?;
    Ok(x.iter().sum::<f64>() * scale)
}
