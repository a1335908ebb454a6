//! The optimizer on the paper's settings: experiment 1 (η = +0.05) made uniform, η = −1
//! uniform and no slower than equal dwell, the effect of the default regularisation, and figure correction.
//! All with r_m 50, r_t 10, 501 positions and 501 radial samples on [0, 50] mm, aperture
//! [0, 40] mm, uniform 100 nm unless said.

use crate::common;
use preston::physics::Motion;

use common::{paper_process, read_fixture};
use preston::config::ServiceLimits;
use preston::http::compute_json;
use preston::optimize::target::aperture_rows;
use preston::optimize::{optimize, Constraints, DwellBasis, DwellProblem, Objective, Solution};
use preston::physics::{
    ClearAperture, Process, RadialGrid, RemovalKernel, RemovalOperator, UniformityMetrics,
};

struct Case {
    grid: RadialGrid,
    aperture: ClearAperture,
    motion: Motion,
    operator: RemovalOperator,
}

fn case(process: &Process) -> Case {
    let grid = RadialGrid::new(process, 0.0, 50.0, 501).unwrap();
    let motion = Motion::radial(grid.radii_mm().to_vec());
    let aperture = ClearAperture::new(process, 0.0, 40.0).unwrap();
    let operator =
        RemovalOperator::assemble(&RemovalKernel::new(process), grid.radii_mm(), &motion);
    Case {
        grid,
        aperture,
        motion,
        operator,
    }
}

fn solve(c: &Case, objective: Objective) -> Solution {
    solve_in(c, objective, DwellBasis::Auto)
}

fn solve_in(c: &Case, objective: Objective, basis: DwellBasis) -> Solution {
    let rows = aperture_rows(&c.grid, &c.aperture);
    let target = vec![100.0; rows.len()];
    optimize(&DwellProblem {
        operator: &c.operator,
        motion: &c.motion,
        tool_radius_mm: 10.0,
        rows,
        target_nm: &target,
        free_piston: false,
        constraints: Constraints::default(),
        objective,
        time_limit_s: 60.0,
        basis,
        axes: &[],
        cell_path_mm: &[],
        extra_floors: &[],
    })
    .unwrap()
}

fn metrics(c: &Case, dwell: &[f64]) -> UniformityMetrics {
    UniformityMetrics::over(&c.grid, &c.aperture, &c.operator.apply(dwell))
}

/// Mean dwell over the positions in [a, b] mm.
fn mean_dwell(c: &Case, dwell: &[f64], a: f64, b: f64) -> f64 {
    let inside: Vec<f64> = c
        .motion
        .radii_mm()
        .iter()
        .zip(dwell)
        .filter(|(&r, _)| (a..=b).contains(&r))
        .map(|(_, &t)| t)
        .collect();
    inside.iter().sum::<f64>() / inside.len() as f64
}

#[test]
fn experiment_1_is_made_uniform_and_the_central_pit_is_removed() {
    let c = case(&paper_process(-10.0, 200.0));
    let equal = metrics(&c, &vec![1.0; c.motion.len()]);
    let plan = solve(&c, Objective::default());
    let m = metrics(&c, &plan.dwell_s);
    let nonuniformity = m.nonuniformity.unwrap();
    println!(
        "exp 1: optimized nonuniformity {nonuniformity:.3e} (equal dwell {:.3}), mean {:.4} nm, {} iterations",
        equal.nonuniformity.unwrap(),
        m.mean_nm,
        plan.iterations
    );
    assert!(nonuniformity <= 0.01, "{nonuniformity}");
    // Equal dwell leaves a deep centre (the paper's finding): nonuniformity above 150 %.
    assert!(equal.nonuniformity.unwrap() > 1.5);
    // The dwell falls toward the centre: the inner 2 mm get under a tenth of the mid-radius
    // dwell, and the dwell rises (never falls by more than rounding) from 0 to 20 mm.
    let centre = mean_dwell(&c, &plan.dwell_s, 0.0, 2.0);
    let middle = mean_dwell(&c, &plan.dwell_s, 20.0, 30.0);
    assert!(
        centre < 0.1 * middle,
        "centre {centre} s vs middle {middle} s"
    );
    let inner: Vec<f64> = plan.dwell_s[..=200].to_vec();
    assert!(inner.windows(2).all(|w| w[1] >= w[0] - 1e-9 * middle));
    // The mean depth is on target to within the time term's documented bias.
    assert!((m.mean_nm - 100.0).abs() < 1e-3, "{}", m.mean_nm);
}

/// At η = −1 equal dwell is exactly uniform (the motion's removal, docs/MODEL.md), so the
/// optimizer cannot beat it in uniformity; with its default weights it stays within their
/// documented cost (the time term trades ~1e-4 of uniformity at the aperture's edge for time)
/// and is no slower.
#[test]
fn at_eta_minus_one_the_plan_is_uniform_and_no_slower_than_equal_dwell() {
    let c = case(&paper_process(150.0, 150.0));
    let n = c.motion.len();
    let equal = metrics(&c, &vec![1.0; n]);
    let plan = solve(&c, Objective::default());
    let m = metrics(&c, &plan.dwell_s);
    let total: f64 = plan.dwell_s.iter().sum();
    // Time per nm of mean depth: equal dwell of 1 s at n positions removes equal.mean_nm.
    let ours = total / m.mean_nm;
    let theirs = n as f64 / equal.mean_nm;
    println!(
        "η = −1: nonuniformity {:.3e} vs equal dwell {:.3e}; time per nm {ours:.4} vs {theirs:.4} s",
        m.nonuniformity.unwrap(),
        equal.nonuniformity.unwrap()
    );
    assert!(equal.nonuniformity.unwrap() <= 1e-12);
    assert!(m.nonuniformity.unwrap() <= 2e-4);
    assert!(ours <= theirs);
    // Where the pad barely removes (r1 near 0, rate ∝ r1) the plan does not park time.
    assert!(
        mean_dwell(&c, &plan.dwell_s, 0.0, 1.0) <= 1.01 * mean_dwell(&c, &plan.dwell_s, 10.0, 30.0)
    );
}

#[test]
fn the_default_regularisation_prevents_parked_and_jagged_dwell() {
    let c = case(&paper_process(150.0, 150.0));
    let bare = Objective {
        smoothing: 0.0,
        time_weight: 0.0,
    };
    let roughness = |t: &[f64]| {
        // Mean |second difference| relative to the mean dwell.
        let mean = t.iter().sum::<f64>() / t.len() as f64;
        t.windows(3)
            .map(|w| (w[0] - 2.0 * w[1] + w[2]).abs())
            .sum::<f64>()
            / (t.len() - 2) as f64
            / mean
    };
    let peak_over_median = |t: &[f64]| {
        let mut s = t.to_vec();
        s.sort_by(f64::total_cmp);
        s[s.len() - 1] / s[s.len() / 2]
    };
    let total = |t: &[f64]| t.iter().sum::<f64>();
    let mut plans = Vec::new();
    for basis in [DwellBasis::Positions, DwellBasis::Auto] {
        let bare = solve_in(&c, bare, basis);
        let default = solve_in(&c, Objective::default(), basis);
        println!(
            "{basis:?}: unregularised: roughness {:.3e}, peak/median {:.1}, total {:.0} s, nonuniformity {:.2e}; default: {:.3e}, {:.2}, {:.0} s, {:.2e}",
            roughness(&bare.dwell_s),
            peak_over_median(&bare.dwell_s),
            total(&bare.dwell_s),
            metrics(&c, &bare.dwell_s).nonuniformity.unwrap(),
            roughness(&default.dwell_s),
            peak_over_median(&default.dwell_s),
            total(&default.dwell_s),
            metrics(&c, &default.dwell_s).nonuniformity.unwrap(),
        );
        plans.push((bare, default));
    }
    let [(bare, default), (spline_bare, spline)] = &plans[..] else {
        unreachable!()
    };
    // With a variable per position, least squares alone parks time where the pad barely
    // removes and zig-zags where many plans fit equally well; with the regularisation the plan
    // is smooth and quicker. (Each column averages R over its cell, which damps the zig-zag
    // a point rule allowed: 8.9× the median and 7 % more time here, where the stationary
    // model's columns gave over 10× and 67 %.)
    assert!(peak_over_median(&bare.dwell_s) > 5.0);
    assert!(peak_over_median(&default.dwell_s) < 1.2);
    assert!(roughness(&default.dwell_s) < 0.01 * roughness(&bare.dwell_s));
    assert!(total(&default.dwell_s) < 0.95 * total(&bare.dwell_s));
    // Both fit: the regularisation costs little uniformity.
    assert!(metrics(&c, &default.dwell_s).nonuniformity.unwrap() < 1e-3);
    // In the spline basis (these 501 positions get 43 functions) the smooth dwell alone keeps
    // the plan from parking, and with the regularisation the plan is the same as with a
    // variable per position: to 0.1 % in total time and of the mean dwell anywhere.
    assert!(peak_over_median(&spline_bare.dwell_s) < 1.2);
    assert!(total(&spline_bare.dwell_s) < 0.95 * total(&bare.dwell_s));
    let mean = total(&default.dwell_s) / default.dwell_s.len() as f64;
    let apart = default
        .dwell_s
        .iter()
        .zip(&spline.dwell_s)
        .map(|(a, b)| (a - b).abs() / mean)
        .fold(0.0, f64::max);
    println!("spline vs positions, default weights: dwell apart by {apart:.2e} of the mean");
    assert!(apart < 1e-3, "{apart}");
    assert!((total(&spline.dwell_s) / total(&default.dwell_s) - 1.0).abs() < 1e-3);
    assert!(metrics(&c, &spline.dwell_s).nonuniformity.unwrap() < 1e-3);
}

#[test]
fn a_measured_error_profile_is_corrected_to_two_percent_of_its_rms() {
    let body = read_fixture("optimize_figure_correction.json");
    let bytes = serde_json::to_vec(&body).unwrap();
    let response: serde_json::Value =
        serde_json::from_str(&compute_json("optimize", &bytes, &ServiceLimits::default()).unwrap())
            .unwrap();
    let profile = &body["target"]["profile"];
    let radius: Vec<f64> = serde_json::from_value(profile["radius_mm"].clone()).unwrap();
    let depth: Vec<f64> = serde_json::from_value(profile["depth_nm"].clone()).unwrap();
    let grid: Vec<f64> = serde_json::from_value(response["radius_mm"].clone()).unwrap();
    let removal: Vec<f64> = serde_json::from_value(response["removal_nm"].clone()).unwrap();
    let outer = body["clear_aperture"]["outer_mm"].as_f64().unwrap();
    // The error left after polishing, at the grid radii inside the aperture (linear
    // interpolation of the measurement, independently of the service's resampling).
    let interpolate = |r: f64| {
        let k = radius
            .iter()
            .rposition(|&x| x <= r)
            .unwrap()
            .min(radius.len() - 2);
        let w = (r - radius[k]) / (radius[k + 1] - radius[k]);
        depth[k] + w * (depth[k + 1] - depth[k])
    };
    let rms_about_mean = |v: &[f64]| {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
    };
    let (mut before, mut after) = (Vec::new(), Vec::new());
    for (&r, &z) in grid.iter().zip(&removal) {
        if r <= outer {
            before.push(interpolate(r));
            after.push(interpolate(r) - z);
        }
    }
    let (initial, left) = (rms_about_mean(&before), rms_about_mean(&after));
    println!(
        "figure correction: RMS {initial:.2} nm → {left:.3} nm ({:.2} %), piston {} nm, PV before {:.1} nm",
        100.0 * left / initial,
        response["piston_nm"],
        before.iter().cloned().fold(f64::MIN, f64::max) - before.iter().cloned().fold(f64::MAX, f64::min)
    );
    assert!(
        initial > 50.0,
        "the fixture carries a few hundred nm of error"
    );
    assert!(left <= 0.02 * initial);
    assert!(response["piston_nm"].as_f64().unwrap() >= 0.0);
    let dwell: Vec<f64> = serde_json::from_value(response["dwell"]["dwell_s"].clone()).unwrap();
    assert!(dwell.iter().all(|&t| t >= 0.0));
}
