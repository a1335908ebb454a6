//! Reproduction of the paper's experiments (Chen, Wang, Liu 2013) from the fixtures: r_m 50 mm,
//! r_t 10 mm, equal dwell at 1001 positions on [0, 50] mm.

use crate::common;

use preston::physics::{ClearAperture, DwellSchedule, Process, RadialGrid, UniformityMetrics};

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The equal-dwell schedule of a predict fixture and the removal it gives on the default grid.
fn fixture_removal(name: &str) -> (Process, RadialGrid, Vec<f64>) {
    let body = common::read_fixture(name);
    let p = &body["process"];
    let process = common::paper_process(
        p["workpiece_rpm"].as_f64().unwrap(),
        p["tool_rpm"].as_f64().unwrap(),
    );
    let positions = numbers(&body["dwell"]["positions_mm"]);
    let dwell = numbers(&body["dwell"]["dwell_s"]);
    assert_eq!(positions.len(), 1001);
    assert!(dwell.iter().all(|&t| t == dwell[0]));
    let schedule = DwellSchedule::new(&process, positions, dwell).unwrap();
    let grid = RadialGrid::default_for(&process);
    let removal = schedule.removal_nm(&process, &grid);
    (process, grid, removal)
}

fn nonuniformity(process: &Process, grid: &RadialGrid, removal: &[f64], outer: f64) -> f64 {
    let aperture = ClearAperture::new(process, 0.0, outer).unwrap();
    UniformityMetrics::over(grid, &aperture, removal)
        .nonuniformity
        .unwrap()
}

#[test]
fn experiment_1_leaves_a_deep_centre() {
    let (_, grid, removal) = fixture_removal("predict_paper_exp1.json");
    let at = |r: f64| removal[grid.radii_mm().iter().position(|&x| x == r).unwrap()];
    let ratio = at(0.0) / at(25.0);
    eprintln!("experiment 1: centre / 25 mm = {ratio:.3}");
    assert!(ratio > 3.0, "{ratio}");
}

#[test]
fn experiment_2_removes_uniformly_to_within_one_percent() {
    let (process, grid, removal) = fixture_removal("predict_paper_exp2.json");
    let nu = nonuniformity(&process, &grid, &removal, 40.0);
    eprintln!("experiment 2: nonuniformity over [0, 40] mm = {nu:e}");
    assert!(nu < 0.01, "{nu}");
}

/// Figure 7: with the tool speed held, nonuniformity falls monotonically as η goes from −0.05
/// to −1 (η = −workpiece_rpm / tool_rpm, so the workpiece turns with the tool).
#[test]
fn nonuniformity_falls_monotonically_towards_eta_minus_one() {
    let tool = 150.0;
    let positions: Vec<f64> = (0..1001).map(|i| 0.05 * i as f64).collect();
    let mut previous = f64::INFINITY;
    for eta in [-0.05, -0.25, -0.5, -0.75, -1.0] {
        let process = common::paper_process(-eta * tool, tool);
        let schedule = DwellSchedule::new(&process, positions.clone(), vec![6.0; 1001]).unwrap();
        let grid = RadialGrid::default_for(&process);
        let removal = schedule.removal_nm(&process, &grid);
        let nu = nonuniformity(&process, &grid, &removal, 40.0);
        eprintln!("eta {eta}: nonuniformity {nu:.4}");
        assert!(nu < previous, "eta {eta}: {nu} !< {previous}");
        previous = nu;
    }
}
