//! The dwell optimizer on the paper's experiment 1 (workpiece −10, tool 200 r/min, r_m 50,
//! r_t 10): uniform 100 nm over [0, 40] mm, positions and radial samples evenly spaced on
//! [0, 50] mm. Operator assembly is outside the timed part; the QP build and the Clarabel
//! solve are inside. Both dwell bases are measured (see
//! `preston::optimize`).

use preston::optimize::target::aperture_rows;
use preston::optimize::{optimize, Constraints, DwellBasis, DwellProblem, Objective};
use preston::physics::{
    ClearAperture, Motion, Part, PressureModel, Process, ProcessSpec, RadialGrid, RemovalKernel,
    RemovalOperator,
};

fn main() {
    divan::main();
}

struct Case {
    operator: RemovalOperator,
    motion: Motion,
    rows: std::ops::Range<usize>,
    target: Vec<f64>,
}

fn paper_case(n: usize) -> Case {
    let process = Process::new(ProcessSpec {
        workpiece_radius_mm: 50.0,
        tool_radius_mm: 10.0,
        workpiece_rpm: -10.0,
        tool_rpm: 200.0,
        preston_coefficient_m2_per_n: 1e-13,
        pressure_kpa: 10.0,
        pressure_model: PressureModel::Uniform,
        part: Part::flat(),
    })
    .unwrap();
    let grid = RadialGrid::new(&process, 0.0, 50.0, n).unwrap();
    let motion = Motion::radial(grid.radii_mm().to_vec());
    let aperture = ClearAperture::new(&process, 0.0, 40.0).unwrap();
    let operator =
        RemovalOperator::assemble(&RemovalKernel::new(&process), grid.radii_mm(), &motion);
    let rows = aperture_rows(&grid, &aperture);
    let target = vec![100.0; rows.len()];
    Case {
        operator,
        motion,
        rows,
        target,
    }
}

/// The default: the dwell as a spline (43 functions here) when positions are fine.
#[divan::bench(args = [501, 1001, 2001], sample_count = 20)]
fn spline(bencher: divan::Bencher, n: usize) {
    run(bencher, n, DwellBasis::Auto);
}

/// A variable per position (the optimizer before the spline basis).
#[divan::bench(args = [501, 1001], sample_count = 10)]
fn positions(bencher: divan::Bencher, n: usize) {
    run(bencher, n, DwellBasis::Positions);
}

fn run(bencher: divan::Bencher, n: usize, basis: DwellBasis) {
    let case = paper_case(n);
    bencher.bench(|| {
        let problem = DwellProblem {
            operator: &case.operator,
            motion: &case.motion,
            tool_radius_mm: 10.0,
            rows: case.rows.clone(),
            target_nm: &case.target,
            free_piston: false,
            constraints: Constraints::default(),
            objective: Objective::default(),
            time_limit_s: 60.0,
            basis,
            axes: &[],
            cell_path_mm: &[],
            extra_floors: &[],
        };
        optimize(&problem).unwrap()
    });
}
