//! Conflicts between constraints, found before the QP is solved and reported by name.
//!
//! Given the dwell bounds lo ≤ t_j ≤ hi, the feed rows t_j + t_{j+1} ≥ c_j, the change rows
//! |t_{j+1} − t_j| ≤ δ and the total Σ t_j ≤ T, only three conflicts are possible:
//!
//! - lo > hi;
//! - a feed row asks more than both ends can give: c_j > 2·hi;
//! - the least total time the other rows allow exceeds T. Without a feed limit that least time
//!   is n·lo (constant dwell lo keeps every other row); with one it is the value of the LP
//!   min Σ t subject to the other rows, solved here with Clarabel.
//!
//! Otherwise the constant plan t_j = max(lo, max_j c_j/2) keeps the bounds, feed and change
//! rows, so the feasible set is not empty.

use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;

use super::problem::{Constraints, OptimizeError};
use super::solver::{constraint_rows, run_clarabel, Budget, ClarabelQp};

/// Relative margin by which a bound must be exceeded before we call it a conflict (well above
/// the LP's own accuracy, so rounding never refuses a feasible request).
const MARGIN: f64 = 1e-7;

fn conflict(fields: Vec<&'static str>, detail: String) -> OptimizeError {
    OptimizeError::Infeasible { fields, detail }
}

/// Refuses constraints that cannot all hold, naming those in conflict.
pub fn check(positions_mm: &[f64], c: &Constraints, budget: &Budget) -> Result<(), OptimizeError> {
    let n = positions_mm.len();
    let lo = c.min_dwell_s;
    let need = c.segment_min_dwell_sum_s(positions_mm);
    if let Some(hi) = c.max_dwell_s {
        if lo > hi {
            return Err(conflict(
                vec!["min_dwell_s", "max_dwell_s"],
                format!("min_dwell_s ({lo} s) exceeds max_dwell_s ({hi} s)"),
            ));
        }
        if let Some(need) = &need {
            if let Some((j, c_j)) = need
                .iter()
                .enumerate()
                .find(|(_, &c_j)| c_j > 2.0 * hi * (1.0 + MARGIN))
            {
                return Err(conflict(
                    vec!["max_feed_mm_per_min", "max_dwell_s"],
                    format!(
                        "crossing from positions_mm[{j}] to positions_mm[{}] ({} mm) at no more than max_feed_mm_per_min needs {c_j} s of dwell at its two ends together, but max_dwell_s allows only {} s",
                        j + 1,
                        positions_mm[j + 1] - positions_mm[j],
                        2.0 * hi
                    ),
                ));
            }
        }
    }
    let Some(total) = c.max_total_time_s else {
        return Ok(());
    };
    let floor = n as f64 * lo;
    if floor > total * (1.0 + MARGIN) {
        return Err(conflict(
            vec!["min_dwell_s", "max_total_time_s"],
            format!(
                "min_dwell_s ({lo} s) × {n} positions = {floor} s exceeds max_total_time_s ({total} s)"
            ),
        ));
    }
    let Some(need) = need else {
        return Ok(());
    };
    let least = least_total_time_s(positions_mm, c, &need, true, budget)?;
    if least <= total * (1.0 + MARGIN) {
        return Ok(());
    }
    let mut fields = vec!["max_total_time_s", "max_feed_mm_per_min"];
    if lo > 0.0 {
        fields.push("min_dwell_s");
    }
    if c.max_dwell_change_s.is_some()
        && least_total_time_s(positions_mm, c, &need, false, budget)? < least * (1.0 - MARGIN)
    {
        fields.push("max_dwell_change_s");
    }
    Err(conflict(
        fields,
        format!(
            "the plan needs at least {least:.6} s in total to keep max_feed_mm_per_min (and the other dwell limits), more than max_total_time_s ({total} s)"
        ),
    ))
}

/// min Σ t over the bounds, feed rows and (if `with_change`) change rows: a small sparse LP.
fn least_total_time_s(
    positions_mm: &[f64],
    c: &Constraints,
    need: &[f64],
    with_change: bool,
    budget: &Budget,
) -> Result<f64, OptimizeError> {
    let n = positions_mm.len();
    // Scale so the LP's variables are of order one.
    let scale = need
        .iter()
        .fold(c.min_dwell_s, |m, &c_j| m.max(0.5 * c_j))
        .max(f64::MIN_POSITIVE);
    let rows = constraint_rows(positions_mm, c, scale, false, with_change);
    let count = rows.rhs.len();
    let (a, b) = rows.into_csc(n);
    let lp = ClarabelQp {
        p: CscMatrix::zeros((n, n)),
        q: vec![1.0; n],
        a,
        b,
        cones: vec![SupportedConeT::NonnegativeConeT(count)],
    };
    let (x, ..) = run_clarabel(&lp, budget)?;
    Ok(x.iter().sum::<f64>() * scale)
}
