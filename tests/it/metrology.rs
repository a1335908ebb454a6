//! Surfaces and the measurement fit against independent computations written here: sag by the
//! binomial series of the conic, arc length by Gauss–Kronrod quadrature, and a reference
//! alignment fit by dense Gauss–Newton on a central-difference Jacobian.

use preston::metrology::{
    fit, radial_profile, Compensation, FitParameters, FitProblem, Probe, RobustLoss,
};
use preston::physics::{RadialGrid, Reach};
use preston::surface::{PolynomialTerm, Surface, SurfaceSpec};

use crate::common::adaptive_integral;

/// The fixture's asphere: concave R 300 mm, k −1.2, a₄ 2e-10, a₆ −1e-15 (a 100 mm part).
pub fn asphere_spec() -> (f64, f64, Vec<(u32, f64)>) {
    (300.0, -1.2, vec![(4, 2e-10), (6, -1e-15)])
}

fn surface(r: f64, k: f64, terms: &[(u32, f64)]) -> Surface {
    Surface::new(&SurfaceSpec::Asphere {
        radius_of_curvature_mm: r,
        conic_constant: k,
        coefficients: terms
            .iter()
            .map(|&(power, value)| PolynomialTerm { power, value })
            .collect(),
    })
    .unwrap()
}

/// Kahan-summed binomial series of the conic sag, c·r²·Σ aₙ·qⁿ⁻¹ with q = (1+k)c²r²,
/// aₙ₊₁ = aₙ·(2n − 1)/(2n + 2), a₁ = 1/2, summed from the smallest term up; then the
/// polynomial terms by repeated multiplication.
fn series_sag(r_mm: f64, k: f64, x: f64, terms: &[(u32, f64)]) -> f64 {
    let c = 1.0 / r_mm;
    let q = (1.0 + k) * c * c * x * x;
    let mut coefficients = vec![0.5];
    let mut power = 1.0;
    let mut series_terms = vec![0.5];
    for n in 1..4000 {
        let next = coefficients[n - 1] * (2.0 * n as f64 - 1.0) / (2.0 * n as f64 + 2.0);
        coefficients.push(next);
        power *= q;
        let term = next * power;
        if term.abs() < 1e-40 {
            break;
        }
        series_terms.push(term);
    }
    let (mut sum, mut carry) = (0.0f64, 0.0f64);
    for t in series_terms.iter().rev() {
        let y = t - carry;
        let s = sum + y;
        carry = (s - sum) - y;
        sum = s;
    }
    let poly: f64 = terms
        .iter()
        .map(|&(p, a)| a * (0..p).fold(1.0, |acc, _| acc * x.abs()))
        .sum();
    c * x * x * sum + poly
}

#[test]
fn sag_matches_the_binomial_series_and_the_sphere_formula() {
    let (r, k, terms) = asphere_spec();
    type Case = (f64, f64, Vec<(u32, f64)>, f64); // R, k, terms, reach
    let cases: Vec<Case> = vec![
        (r, k, terms.clone(), 50.0),
        (-25.0, 0.0, vec![], 20.0),
        (8.0, -0.6, vec![(4, 1e-4), (6, -2e-6), (3, 1e-5)], 3.0), // a small mould
        (-40.0, 0.8, vec![(1, 1e-5), (5, 3e-9)], 24.0),           // oblate, odd powers
    ];
    let mut worst = 0f64;
    for (radius, conic, terms, reach) in cases {
        let s = surface(radius, conic, &terms);
        for i in 0..=200 {
            let x = reach * (i as f64 / 100.0 - 1.0);
            let err = (s.sag_mm(x) - series_sag(radius, conic, x, &terms)).abs();
            worst = worst.max(err);
            assert!(err <= 1e-12, "R {radius} k {conic} x {x}: {err:e}");
        }
    }
    // A sphere also against its textbook form R − sign(R)·√(R² − r²) (rounding ~|R|·ε).
    for radius in [25.0f64, -25.0, 1000.0] {
        let s = Surface::new(&SurfaceSpec::Sphere {
            radius_of_curvature_mm: radius,
        })
        .unwrap();
        for i in 0..=100 {
            let x = 0.24 * radius.abs() * i as f64 / 100.0;
            let textbook = radius - radius.signum() * (radius * radius - x * x).sqrt();
            assert!((s.sag_mm(x) - textbook).abs() <= 1e-12, "R {radius} x {x}");
        }
    }
    eprintln!("worst sag difference {worst:e} mm");
}

#[test]
fn arc_length_matches_quadrature() {
    let (r, k, terms) = asphere_spec();
    let s = surface(r, k, &terms);
    // z′ written out independently of the library.
    let slope = |x: f64| {
        let c = 1.0 / r;
        c * x / (1.0 - (1.0 + k) * c * c * x * x).sqrt()
            + terms
                .iter()
                .map(|&(p, a)| p as f64 * a * x.powi(p as i32 - 1))
                .sum::<f64>()
    };
    for x in [0.5, 10.0, 33.3, 50.0] {
        let reference = adaptive_integral(&|t| (1.0 + slope(t) * slope(t)).sqrt(), 0.0, x, 1e-13);
        let err = (s.arc_length_mm(x) - reference).abs();
        assert!(err <= 1e-9, "x {x}: {err:e}");
        assert!((s.radius_at_arc_length(reference) - x).abs() <= 1e-9);
    }
    // A steep sphere near its edge (slope 7): the closed form against the same quadrature.
    let sphere = Surface::new(&SurfaceSpec::Sphere {
        radius_of_curvature_mm: -10.0,
    })
    .unwrap();
    let x = 9.9;
    let reference = adaptive_integral(&|t: f64| 10.0 / (100.0 - t * t).sqrt(), 0.0, x, 1e-13);
    assert!((sphere.arc_length_mm(x) - reference).abs() <= 1e-9);
}

/// Machine coordinates of part-frame points (x′, z′): eq. 2 inverted,
/// X = (x′+ΔX)·cos τ + (z′+Δz)·sin τ, Z = −(x′+ΔX)·sin τ + (z′+Δz)·cos τ.
pub fn to_machine(xa: f64, za: f64, dx: f64, tau: f64, dz: f64) -> (f64, f64) {
    let (u, v) = (xa + dx, za + dz);
    (
        u * tau.cos() + v * tau.sin(),
        -u * tau.sin() + v * tau.cos(),
    )
}

pub struct Planted {
    pub dx: f64,
    pub tau: f64,
    pub dz: f64,
}

pub const PLANTED: Planted = Planted {
    dx: 0.012,
    tau: 2e-4,
    dz: 0.05,
};

/// A symmetric form error along the normal, mm: a 40 nm ring and a 25 nm edge roll.
pub fn planted_form_mm(x: f64) -> f64 {
    let r = x.abs();
    1e-6 * (40.0 * (-((r - 22.0) / 8.0).powi(2)).exp() - 25.0 * (r / 50.0).powi(6))
}

/// A trace of the fixture's asphere across the axis, in machine coordinates: `n` points from
/// −48 to 48 mm, the form error (if `form`) planted along the normal, Gaussian noise of
/// `noise_nm`.
pub fn trace(n: usize, noise_nm: f64, seed: u64, form: bool) -> (Vec<f64>, Vec<f64>) {
    let (r, k, terms) = asphere_spec();
    let s = surface(r, k, &terms);
    let mut rng = fastrand::Rng::with_seed(seed);
    let gauss = |rng: &mut fastrand::Rng| {
        // Box–Muller.
        let (u1, u2) = (1.0 - rng.f64(), rng.f64());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    };
    let (mut xs, mut zs) = (Vec::new(), Vec::new());
    for i in 0..n {
        let x = -48.0 + 96.0 * i as f64 / (n - 1) as f64;
        let (nx, nz) = s.normal(x);
        let f = if form { planted_form_mm(x) } else { 0.0 } + noise_nm * 1e-6 * gauss(&mut rng);
        let (xa, za) = (x + f * nx, s.sag_mm(x) + f * nz);
        let (mx, mz) = to_machine(xa, za, PLANTED.dx, PLANTED.tau, PLANTED.dz);
        xs.push(mx);
        zs.push(mz);
    }
    (xs, zs)
}

fn problem(xs: Vec<f64>, zs: Vec<f64>, robust: RobustLoss) -> FitProblem {
    let (r, k, terms) = asphere_spec();
    let s = surface(r, k, &terms);
    let parameters = FitParameters::default_for(&s);
    FitProblem::new(s, xs, zs, Probe::sharp(), parameters, robust).unwrap()
}

#[test]
fn planted_misalignment_is_recovered_exactly_from_a_clean_trace() {
    let (r, k, terms) = asphere_spec();
    let s = surface(r, k, &terms);
    let (mut xs, mut zs) = (Vec::new(), Vec::new());
    for i in 0..801 {
        let x = -48.0 + 96.0 * i as f64 / 800.0;
        let (mx, mz) = to_machine(x, s.sag_mm(x), PLANTED.dx, PLANTED.tau, PLANTED.dz);
        xs.push(mx);
        zs.push(mz);
    }
    let out = fit(&problem(xs, zs, RobustLoss::None)).unwrap();
    let a = &out.alignment;
    eprintln!(
        "clean: ΔX {:e} mm, Δτ {:e} rad, Δz {:e} mm off, {} steps",
        a.lateral_offset_mm - PLANTED.dx,
        a.tilt_rad - PLANTED.tau,
        a.piston_mm - PLANTED.dz,
        out.iterations
    );
    assert!((a.lateral_offset_mm - PLANTED.dx).abs() <= 1e-9);
    assert!((a.tilt_rad - PLANTED.tau).abs() <= 1e-10);
    assert!((a.piston_mm - PLANTED.dz).abs() <= 1e-9);
    let rms = (out.points.iter().map(|p| p.axial_mm.powi(2)).sum::<f64>() / 801.0).sqrt();
    assert!(rms < 1e-12, "residual {rms:e} mm");
}

/// Dense Gauss–Newton on (ΔX, Δτ, Δz) with a central-difference Jacobian and the series sag:
/// no code shared with the library's fit.
fn reference_fit(xs: &[f64], zs: &[f64]) -> [f64; 3] {
    let (r, k, terms) = asphere_spec();
    let residuals = |p: &[f64; 3]| -> Vec<f64> {
        xs.iter()
            .zip(zs)
            .map(|(&x, &z)| {
                let xa = x * p[1].cos() - z * p[1].sin() - p[0];
                let za = x * p[1].sin() + z * p[1].cos() - p[2];
                za - series_sag(r, k, xa, &terms)
            })
            .collect()
    };
    let mut p = [0.0; 3];
    let steps = [1e-5, 1e-7, 1e-5];
    for _ in 0..50 {
        let e = residuals(&p);
        let columns: Vec<Vec<f64>> = (0..3)
            .map(|j| {
                let (mut up, mut down) = (p, p);
                up[j] += steps[j];
                down[j] -= steps[j];
                let (eu, ed) = (residuals(&up), residuals(&down));
                eu.iter()
                    .zip(&ed)
                    .map(|(a, b)| (a - b) / (2.0 * steps[j]))
                    .collect()
            })
            .collect();
        // Normal equations, solved by Gaussian elimination with partial pivoting.
        let mut m = [[0.0f64; 4]; 3];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = columns[i].iter().zip(&columns[j]).map(|(a, b)| a * b).sum();
            }
            m[i][3] = -columns[i].iter().zip(&e).map(|(a, b)| a * b).sum::<f64>();
        }
        for col in 0..3 {
            let pivot = (col..3)
                .max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))
                .unwrap();
            m.swap(col, pivot);
            let pivot_row = m[col];
            for row in m.iter_mut().skip(col + 1) {
                let f = row[col] / pivot_row[col];
                for (x, p) in row.iter_mut().zip(pivot_row).skip(col) {
                    *x -= f * p;
                }
            }
        }
        let mut delta = [0.0; 3];
        for row in (0..3).rev() {
            let tail: f64 = (row + 1..3).map(|c| m[row][c] * delta[c]).sum();
            delta[row] = (m[row][3] - tail) / m[row][row];
        }
        for j in 0..3 {
            p[j] += delta[j];
        }
        if delta[0].abs() < 1e-15 && delta[1].abs() < 1e-17 && delta[2].abs() < 1e-15 {
            break;
        }
    }
    p
}

#[test]
fn a_noisy_trace_agrees_with_a_reference_fit_and_recovers_the_form_error() {
    let noise_nm = 3.0;
    let (xs, zs) = trace(1201, noise_nm, 7, true);
    let reference = reference_fit(&xs, &zs);
    let out = fit(&problem(xs, zs, RobustLoss::None)).unwrap();
    let a = &out.alignment;
    for (got, want, name) in [
        (a.lateral_offset_mm, reference[0], "ΔX"),
        (a.tilt_rad, reference[1], "Δτ"),
        (a.piston_mm, reference[2], "Δz"),
    ] {
        let rel = ((got - want) / want).abs();
        eprintln!("{name}: {got:e} vs reference {want:e} (rel {rel:e})");
        assert!(rel <= 1e-7, "{name}: {got} vs {want}");
    }
    // The profile against the planted error, less what the piston absorbs (the mean axial
    // form error over the trace, seen along the normal as ·cos θ).
    let (r, k, terms) = asphere_spec();
    let s = surface(r, k, &terms);
    let absorbed: f64 = out
        .points
        .iter()
        .map(|p| planted_form_mm(p.contact_mm) * s.slope(p.contact_mm).hypot(1.0))
        .sum::<f64>()
        / out.points.len() as f64;
    let reach = Reach {
        radius_mm: 48.0,
        name: "measured radius",
    };
    let grid = RadialGrid::within(reach, 0.0, 47.5, 96).unwrap();
    let profile = radial_profile(&out.points, &grid).unwrap();
    let mut worst = 0f64;
    let mut sum2 = 0.0;
    for (&rho, &depth) in profile.depth.radius_mm.iter().zip(&profile.depth.depth_nm) {
        let cos = 1.0 / s.slope(rho).hypot(1.0);
        let expected = 1e6 * (planted_form_mm(rho) - absorbed * cos);
        worst = worst.max((depth - expected).abs());
        sum2 += (depth - expected).powi(2);
    }
    let rms = (sum2 / profile.depth.depth_nm.len() as f64).sqrt();
    eprintln!("profile vs planted: rms {rms:.3} nm, worst {worst:.3} nm (noise {noise_nm} nm)");
    // ~12 points under each side's kernel, both sides averaged: the noise left is ~σ/5.
    assert!(rms <= 0.5 * noise_nm && worst <= 1.5 * noise_nm);
    let asymmetry = profile.asymmetry_rms_nm.unwrap();
    assert!(
        asymmetry < noise_nm,
        "symmetric error, asymmetry {asymmetry}"
    );
}

#[test]
fn tukey_ignores_spikes_that_pull_least_squares_away() {
    let (xs, zs) = trace(1001, 3.0, 11, false);
    let clean = fit(&problem(xs.clone(), zs.clone(), RobustLoss::None)).unwrap();
    let se = clean.standard_errors;
    // 3 % of the points become 2 µm dust spikes (up, along Z).
    let mut rng = fastrand::Rng::with_seed(5);
    let mut dusty = zs.clone();
    let mut hit = 0;
    while hit < 30 {
        let i = rng.usize(..dusty.len());
        if dusty[i] == zs[i] {
            dusty[i] += 2e-3;
            hit += 1;
        }
    }
    let plain = fit(&problem(xs.clone(), dusty.clone(), RobustLoss::None)).unwrap();
    let robust = fit(&problem(xs, dusty, RobustLoss::Tukey)).unwrap();
    let off = |a: &preston::metrology::Alignment| {
        [
            (a.lateral_offset_mm - clean.alignment.lateral_offset_mm)
                / se.lateral_offset_mm.unwrap(),
            (a.tilt_rad - clean.alignment.tilt_rad) / se.tilt_rad.unwrap(),
            (a.piston_mm - clean.alignment.piston_mm) / se.piston_mm.unwrap(),
        ]
    };
    let (p, r) = (off(&plain.alignment), off(&robust.alignment));
    eprintln!("in noise-only standard errors: plain {p:?}, Tukey {r:?}");
    assert!(r.iter().all(|x| x.abs() <= 3.0), "Tukey moved: {r:?}");
    assert!(p.iter().any(|x| x.abs() > 3.0), "plain LS held: {p:?}");
    let ignored = robust.points.iter().filter(|p| p.weight == 0.0).count();
    assert_eq!(ignored, 30, "every spike, and only the spikes, ignored");
    assert!(robust.reweightings > 0);
}

/// Tip-centre trace of a ball of radius ρ on a sphere of radius R: the concentric sphere of
/// radius |R| ∓ ρ about the centre of curvature (0, R).
fn ball_on_sphere(radius: f64, rho: f64, xs: &[f64]) -> Vec<f64> {
    xs.iter()
        .map(|&x| {
            let centre_distance = radius.abs() - radius.signum() * rho;
            radius - radius.signum() * (centre_distance * centre_distance - x * x).sqrt()
        })
        .collect()
}

#[test]
fn normal_compensation_is_exact_on_a_sphere_and_axial_errs_as_predicted() {
    let rho = 0.25;
    for radius in [20.0, -20.0] {
        let design = Surface::new(&SurfaceSpec::Sphere {
            radius_of_curvature_mm: radius,
        })
        .unwrap();
        let xs: Vec<f64> = (0..=240).map(|i| -12.0 + 0.1 * i as f64).collect();
        let zs = ball_on_sphere(radius, rho, &xs);
        let only_piston = FitParameters {
            lateral_offset: false,
            tilt: false,
            piston: true,
            radius_of_curvature: false,
        };
        let normal = Probe::new(rho, Compensation::Normal).unwrap();
        let params = FitParameters::default_for(&design);
        let out = fit(&FitProblem::new(
            design.clone(),
            xs.clone(),
            zs.clone(),
            normal,
            params,
            RobustLoss::None,
        )
        .unwrap())
        .unwrap();
        let rms_nm =
            1e6 * (out.points.iter().map(|p| p.normal_mm.powi(2)).sum::<f64>() / 241.0).sqrt();
        assert!(rms_nm <= 0.01, "R {radius}: {rms_nm} nm");
        // Axial compensation (piston only): the residual is the gap between the ball's
        // sphere and the design lifted by ρ, less its mean — seed 003's error of axial offsets.
        let axial = Probe::new(rho, Compensation::Axial).unwrap();
        let out = fit(&FitProblem::new(
            design.clone(),
            xs.clone(),
            zs.clone(),
            axial,
            only_piston,
            RobustLoss::None,
        )
        .unwrap())
        .unwrap();
        let gap: Vec<f64> = xs
            .iter()
            .zip(&zs)
            .map(|(&x, &z)| z - rho - (radius - radius.signum() * (radius * radius - x * x).sqrt()))
            .collect();
        let mean = gap.iter().sum::<f64>() / gap.len() as f64;
        let mut worst = 0f64;
        for (p, g) in out.points.iter().zip(&gap) {
            worst = worst.max((p.axial_mm - (g - mean)).abs());
        }
        let rms_nm =
            1e6 * (gap.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / gap.len() as f64).sqrt();
        eprintln!("R {radius}: axial compensation leaves {rms_nm:.0} nm RMS; normal ≤ 0.01 nm");
        assert!(worst <= 1e-12, "R {radius}: {worst:e}");
        assert!(
            rms_nm > 1000.0,
            "the axial error is microns at 37° slope: {rms_nm}"
        );
    }
}
