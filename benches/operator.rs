//! Removal-operator assembly, paper geometry (r_m 50 mm, r_t 10 mm): radial samples on [0, 50]
//! mm × tool positions on [0, 50] mm, at η = +0.05 (general closed form) and η = −1 (fast path)
//! on a plane, and at η = +0.05 on a sphere (R = 100 mm) and an asphere (R = 100 mm, k = −0.5,
//! a₄ = 1e-7, a₆ = −2e-11), where each entry is an adaptive quadrature. The edge models side by
//! side: uniform against linear pressure (κ 1 and 0.5) at η = +0.05 with the positions on
//! [0, 49.9] mm (a free gimbal's reach is the edge itself, excluded).

use preston::physics::{
    Orientation, Part, PressureModel, Process, ProcessSpec, RemovalKernel, RemovalOperator,
};
use preston::surface::{PolynomialTerm, Surface, SurfaceSpec};

fn main() {
    divan::main();
}

fn kernel(workpiece_rpm: f64, tool_rpm: f64) -> RemovalKernel {
    kernel_on(workpiece_rpm, tool_rpm, Part::flat())
}

fn kernel_on(workpiece_rpm: f64, tool_rpm: f64, part: Part) -> RemovalKernel {
    kernel_with(workpiece_rpm, tool_rpm, part, PressureModel::Uniform)
}

fn kernel_with(
    workpiece_rpm: f64,
    tool_rpm: f64,
    part: Part,
    pressure_model: PressureModel,
) -> RemovalKernel {
    RemovalKernel::new(
        &Process::new(ProcessSpec {
            workpiece_radius_mm: 50.0,
            tool_radius_mm: 10.0,
            workpiece_rpm,
            tool_rpm,
            preston_coefficient_m2_per_n: 1e-13,
            pressure_kpa: 10.0,
            pressure_model,
            part,
        })
        .unwrap(),
    )
}

fn linspace(n: usize) -> Vec<f64> {
    (0..n).map(|i| 50.0 * i as f64 / (n - 1) as f64).collect()
}

#[divan::bench(args = [1001, 2001])]
fn eta_plus_0_05(bencher: divan::Bencher, n: usize) {
    let k = kernel(-10.0, 200.0);
    let grid = linspace(n);
    bencher.bench(|| RemovalOperator::assemble(&k, &grid, &grid));
}

#[divan::bench(args = [1001, 2001])]
fn eta_minus_1(bencher: divan::Bencher, n: usize) {
    let k = kernel(150.0, 150.0);
    let grid = linspace(n);
    bencher.bench(|| RemovalOperator::assemble(&k, &grid, &grid));
}

fn part(spec: SurfaceSpec) -> Part {
    Part {
        surface: Surface::new(&spec).unwrap(),
        orientation: Orientation::Normal,
    }
}

/// Assembly at η = +0.05 on a curved part.
fn curved(bencher: divan::Bencher, n: usize, surface: SurfaceSpec) {
    let k = kernel_on(-10.0, 200.0, part(surface));
    let grid = linspace(n);
    bencher.bench(|| RemovalOperator::assemble(&k, &grid, &grid));
}

#[divan::bench(args = [1001])]
fn sphere_eta_plus_0_05(bencher: divan::Bencher, n: usize) {
    curved(
        bencher,
        n,
        SurfaceSpec::Sphere {
            radius_of_curvature_mm: 100.0,
        },
    );
}

#[divan::bench(args = [1001])]
fn asphere_eta_plus_0_05(bencher: divan::Bencher, n: usize) {
    curved(
        bencher,
        n,
        SurfaceSpec::Asphere {
            radius_of_curvature_mm: 100.0,
            conic_constant: -0.5,
            coefficients: vec![
                PolynomialTerm {
                    power: 4,
                    value: 1e-7,
                },
                PolynomialTerm {
                    power: 6,
                    value: -2e-11,
                },
            ],
        },
    );
}

/// Assembly at η = +0.05 on a plane under `model`, positions on [0, 49.9] mm.
fn edge(bencher: divan::Bencher, n: usize, model: PressureModel) {
    let k = kernel_with(-10.0, 200.0, Part::flat(), model);
    let radii = linspace(n);
    let positions: Vec<f64> = linspace(n).iter().map(|r| r * 49.9 / 50.0).collect();
    bencher.bench(|| RemovalOperator::assemble(&k, &radii, &positions));
}

#[divan::bench(args = [1001])]
fn edge_uniform(bencher: divan::Bencher, n: usize) {
    edge(bencher, n, PressureModel::Uniform);
}

#[divan::bench(args = [1001])]
fn edge_linear_gimbal(bencher: divan::Bencher, n: usize) {
    edge(
        bencher,
        n,
        PressureModel::Linear {
            pad_moment_share: 1.0,
        },
    );
}

#[divan::bench(args = [1001])]
fn edge_linear_half(bencher: divan::Bencher, n: usize) {
    edge(
        bencher,
        n,
        PressureModel::Linear {
            pad_moment_share: 0.5,
        },
    );
}
