//! Every returned plan keeps its constraints to 1e-9 (relative to the constraint's size),
//! checked here independently of the library; conflicting constraints are refused with the
//! conflicting fields named, never answered with a plan that breaks them.

use crate::common;
use preston::physics::Motion;

use common::paper_process;
use preston::optimize::target::aperture_rows;
use preston::optimize::{
    optimize, Constraints, ConstraintsSpec, DwellBasis, DwellProblem, Objective, OptimizeError,
};
use preston::physics::{ClearAperture, RadialGrid, RemovalKernel, RemovalOperator};

struct Setup {
    operator: RemovalOperator,
    motion: Motion,
    /// Width of each position's cell (the tool's path across it on a plane).
    cells: Vec<f64>,
    rows: std::ops::Range<usize>,
    target: Vec<f64>,
}

fn setup(workpiece_rpm: f64, tool_rpm: f64, n: usize) -> Setup {
    let process = paper_process(workpiece_rpm, tool_rpm);
    let grid = RadialGrid::new(&process, 0.0, 50.0, 2 * n + 1).unwrap();
    let positions: Vec<f64> = (0..n).map(|j| 50.0 * j as f64 / (n - 1) as f64).collect();
    let motion = Motion::radial(positions.clone());
    let aperture = ClearAperture::new(&process, 0.0, 40.0).unwrap();
    let operator =
        RemovalOperator::assemble(&RemovalKernel::new(&process), grid.radii_mm(), &motion);
    let rows = aperture_rows(&grid, &aperture);
    let target = vec![100.0; rows.len()];
    Setup {
        operator,
        cells: cell_widths(&positions),
        motion,
        rows,
        target,
    }
}

/// From the position (at the two ends) or the midpoint before it to the one after it.
fn cell_widths(positions: &[f64]) -> Vec<f64> {
    let n = positions.len();
    (0..n)
        .map(|j| {
            let lo = if j == 0 {
                positions[0]
            } else {
                0.5 * (positions[j - 1] + positions[j])
            };
            let hi = if j == n - 1 {
                positions[j]
            } else {
                0.5 * (positions[j] + positions[j + 1])
            };
            hi - lo
        })
        .collect()
}

fn run(s: &Setup, constraints: ConstraintsSpec) -> Result<Vec<f64>, OptimizeError> {
    let constraints = Constraints::new(constraints)?;
    optimize(&DwellProblem {
        operator: &s.operator,
        motion: &s.motion,
        tool_radius_mm: 10.0,
        rows: s.rows.clone(),
        target_nm: &s.target,
        free_piston: false,
        constraints,
        objective: Objective::default(),
        time_limit_s: 30.0,
        basis: DwellBasis::Auto,
        axes: &[],
        cell_path_mm: &s.cells,
        extra_floors: &[],
    })
    .map(|solution| solution.dwell_s)
}

/// The highest feed of a plan, mm/min: each cell crossed in its dwell, the two end cells in
/// half of theirs (the other half is a stop).
fn peak_feed_mm_per_min(positions: &[f64], t: &[f64]) -> f64 {
    let n = t.len();
    cell_widths(positions)
        .iter()
        .enumerate()
        .map(|(j, width)| {
            let time = if j == 0 || j == n - 1 {
                0.5 * t[j]
            } else {
                t[j]
            };
            60.0 * width / time
        })
        .fold(0.0, f64::max)
}

/// The worst violation of any constraint, relative to that constraint's size (bounds of 0
/// count against 1 s).
fn worst_violation(c: &ConstraintsSpec, positions: &[f64], t: &[f64]) -> f64 {
    let rel = |excess: f64, size: f64| excess / size.abs().max(1.0);
    let mut worst: f64 = 0.0;
    for &tj in t {
        worst = worst.max(rel(c.min_dwell_s - tj, c.min_dwell_s));
        if let Some(hi) = c.max_dwell_s {
            worst = worst.max(rel(tj - hi, hi));
        }
    }
    if let Some(total) = c.max_total_time_s {
        worst = worst.max(rel(t.iter().sum::<f64>() - total, total));
    }
    if let Some(v) = c.max_feed_mm_per_min {
        worst = worst.max((peak_feed_mm_per_min(positions, t) - v) / v);
    }
    for j in 0..t.len() - 1 {
        if let Some(d) = c.max_dwell_change_s {
            worst = worst.max(rel((t[j + 1] - t[j]).abs() - d, d));
        }
    }
    worst
}

#[test]
fn random_constraint_sets_give_plans_that_keep_them() {
    let mut rng = fastrand::Rng::with_seed(4);
    let (mut plans, mut refused) = (0, 0);
    for case in 0..40 {
        let (w, tool) = if case % 2 == 0 {
            (-10.0, 200.0)
        } else {
            (150.0, 150.0)
        };
        // Up to 85 positions keep a variable each; from 86 on the dwell is a 43-function spline.
        let s = setup(w, tool, rng.usize(30..240));
        let n = s.motion.len();
        // Equal dwell that removes about 100 nm sets the scale of the limits.
        let unit = {
            let z = s.operator.apply(&vec![1.0; n]);
            100.0 / (z[s.rows.clone()].iter().sum::<f64>() / s.rows.len() as f64)
        };
        let pick = |rng: &mut fastrand::Rng, lo: f64, hi: f64| {
            rng.bool().then(|| unit * (lo + (hi - lo) * rng.f64()))
        };
        let c = ConstraintsSpec {
            min_dwell_s: pick(&mut rng, 0.0, 0.8).unwrap_or(0.0),
            max_dwell_s: pick(&mut rng, 1.0, 4.0),
            max_total_time_s: pick(&mut rng, 0.5 * n as f64, 1.5 * n as f64),
            max_feed_mm_per_min: rng.bool().then(|| {
                // Cell width h over a dwell of 0.3–2 units.
                60.0 * (50.0 / (n - 1) as f64) / (unit * (0.3 + 1.7 * rng.f64()))
            }),
            max_dwell_change_s: pick(&mut rng, 0.001, 0.2),
        };
        match run(&s, c) {
            Ok(t) => {
                plans += 1;
                let v = worst_violation(&c, s.motion.radii_mm(), &t);
                assert!(v <= 1e-9, "case {case}: violation {v:e} with {c:?}");
            }
            Err(OptimizeError::Infeasible { fields, .. }) => {
                refused += 1;
                assert!(!fields.is_empty(), "case {case}: conflicts must be named");
            }
            Err(other) => panic!("case {case}: {other:?} with {c:?}"),
        }
    }
    println!("{plans} plans, {refused} infeasible refusals");
    assert!(
        plans >= 20 && refused >= 3,
        "{plans} plans, {refused} refusals"
    );
}

fn conflict(s: &Setup, c: ConstraintsSpec) -> Vec<String> {
    match run(s, c) {
        Err(OptimizeError::Infeasible { fields, .. }) => {
            fields.iter().map(|f| f.describe()).collect()
        }
        other => panic!("expected a conflict, got {other:?}"),
    }
}

#[test]
fn each_kind_of_conflict_names_its_constraints() {
    let s = setup(-10.0, 200.0, 51); // 1 mm apart
    assert_eq!(
        conflict(
            &s,
            ConstraintsSpec {
                min_dwell_s: 5.0,
                max_dwell_s: Some(4.0),
                ..Default::default()
            }
        ),
        ["min_dwell_s", "max_dwell_s"]
    );
    // 51 positions × 10 s = 510 s > 500 s.
    assert_eq!(
        conflict(
            &s,
            ConstraintsSpec {
                min_dwell_s: 10.0,
                max_total_time_s: Some(500.0),
                ..Default::default()
            }
        ),
        ["min_dwell_s", "max_total_time_s"]
    );
    // A 1 mm cell at 6 mm/min takes 10 s, more than a dwell of at most 4 s.
    assert_eq!(
        conflict(
            &s,
            ConstraintsSpec {
                max_dwell_s: Some(4.0),
                max_feed_mm_per_min: Some(6.0),
                ..Default::default()
            }
        ),
        ["max_feed_mm_per_min", "max_dwell_s"]
    );
    // At 60 mm/min each of the 51 cells takes 1 s of dwell (the half-width end cells half of
    // theirs), 51 s in all.
    assert_eq!(
        conflict(
            &s,
            ConstraintsSpec {
                max_feed_mm_per_min: Some(60.0),
                max_total_time_s: Some(45.0),
                ..Default::default()
            }
        ),
        ["max_feed_mm_per_min", "max_total_time_s"]
    );
    // Exactly feasible at the boundary is not refused: min dwell 1 s × 51 = 51 s.
    let t = run(
        &s,
        ConstraintsSpec {
            min_dwell_s: 1.0,
            max_total_time_s: Some(51.0),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(t.iter().all(|&x| x >= 1.0));
    assert!(t.iter().sum::<f64>() <= 51.0 * (1.0 + 1e-9));
}
