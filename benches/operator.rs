//! Removal-operator assembly, paper geometry (r_m 50 mm, r_t 10 mm): radial samples on [0, 50]
//! mm × tool positions on [0, 50] mm, at η = +0.05 (general closed form) and η = −1 (fast path)
//! on a plane, and at η = +0.05 on a sphere (R = 100 mm) and an asphere (R = 100 mm, k = −0.5,
//! a₄ = 1e-7, a₆ = −2e-11), where each entry is an adaptive quadrature. The edge models side by
//! side: uniform against linear pressure (κ 1 and 0.5) at η = +0.05 with the positions on
//! [0, 49.9] mm (a free gimbal's reach is the edge itself, excluded).
//! Carlson's integrals alone (`carlson_triples`): the lanes every flat rate goes through.

use preston::physics::{
    Motion, Orientation, Part, PressureModel, Process, ProcessSpec, RemovalKernel, RemovalOperator,
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
    let motion = Motion::radial(grid.clone());
    bencher.bench(|| RemovalOperator::assemble(&k, &grid, &motion));
}

#[divan::bench(args = [1001, 2001])]
fn eta_minus_1(bencher: divan::Bencher, n: usize) {
    let k = kernel(150.0, 150.0);
    let grid = linspace(n);
    let motion = Motion::radial(grid.clone());
    bencher.bench(|| RemovalOperator::assemble(&k, &grid, &motion));
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
    let motion = Motion::radial(grid.clone());
    bencher.bench(|| RemovalOperator::assemble(&k, &grid, &motion));
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
    let motion = Motion::radial(linspace(n).iter().map(|r| r * 49.9 / 50.0).collect());
    bencher.bench(|| RemovalOperator::assemble(&k, &radii, &motion));
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

/// Carlson's R_F and R_D for 4,096 argument triples of the flat rate's form (A·c², A + B·s²,
/// A) with A/B from 1e-4 to 1 and φ up to 1.5 rad, handed over 16 at a time as a row's panel
/// levels hand them (the duplication's lanes and their stopping rule).
#[divan::bench]
fn carlson_triples(bencher: divan::Bencher) {
    use preston::physics::carlson::rf_rd_many;
    let n = 4096;
    let (mut x, mut y, mut z) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..n {
        // A fixed low-discrepancy spread of (A, φ), so every run times the same triples.
        let u = (k as f64 * 0.618_033_988_749_895).fract();
        let v = (k as f64 + 0.5) / n as f64;
        let a = 10f64.powf(-4.0 * u);
        let (s, c) = (1.5 * v).sin_cos();
        (x[k], y[k], z[k]) = (a * c * c, a + s * s, a);
    }
    let (mut rf, mut rd) = (vec![0.0; n], vec![0.0; n]);
    bencher.bench_local(|| {
        for k in (0..n).step_by(16) {
            rf_rd_many(
                &x[k..k + 16],
                &y[k..k + 16],
                &z[k..k + 16],
                &mut rf[k..k + 16],
                &mut rd[k..k + 16],
            );
        }
        divan::black_box(rf[n - 1] + rd[n - 1])
    });
}
