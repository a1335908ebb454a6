//! Calibration against synthetic measurements from an independent generator: ring grooves of
//! a planted process computed by `edge_pressure`'s reference (the contact's moments
//! integrated numerically, the balance solved by bisection, the removal by quadrature of
//! p·V — none of the library's closed forms), plus a piston per run and Gaussian noise
//! (Box–Muller on fastrand, seeded).
//!
//! Planted: K = 1.37e-13 m²/N, r_t = 9.7 mm, κ = 0.6 under linear pressure, on the paper's
//! 50 mm part at −10 / 200 r/min, 10 kPa; rings at 15, 30 and 43 mm (the last overhanging by
//! 2.7 mm) for 4, 3 and 3 hours (grooves 630, 210 and 200 nm deep), 0.4 nm of noise, measured
//! every 0.25 mm within 12 mm of the ring's centre. The nominal process the fit starts from:
//! K = 1e-13, r_t = 10 mm, κ = 1.

use crate::common::paper_spec;
use crate::edge_pressure::reference_rate;
use preston::calibration::{
    Calibrated, Calibration, Freedom, Measured, Motion, ProcessParameter, Profile, RunSpec,
};
use preston::lsq::RobustLoss;
use preston::physics::{PressureModel, Process, ProcessSpec};

const K: f64 = 1.37e-13;
const RT: f64 = 9.7;
const KAPPA: f64 = 0.6;
const RINGS: [(f64, f64); 3] = [(15.0, 240.0), (30.0, 180.0), (43.0, 180.0)];
const PISTONS: [f64; 3] = [3.0, -2.0, 5.5];
const NOISE_NM: f64 = 0.4;

fn spec(k: f64, rt: f64, kappa: f64) -> ProcessSpec {
    ProcessSpec {
        preston_coefficient_m2_per_n: k,
        tool_radius_mm: rt,
        pressure_model: PressureModel::Linear {
            pad_moment_share: kappa,
        },
        ..paper_spec(-10.0, 200.0)
    }
}

/// Each ring's measured radii and the planted process's groove there (nm, no piston, no
/// noise), from the independent reference.
fn grooves() -> Vec<(Vec<f64>, Vec<f64>)> {
    let truth = spec(K, RT, KAPPA);
    RINGS
        .iter()
        .map(|&(r1, minutes)| {
            let radii: Vec<f64> = (0..=96)
                .map(|i| r1 - 12.0 + 0.25 * i as f64)
                .filter(|r| (0.0..=50.0).contains(r))
                .collect();
            let depth = radii
                .iter()
                .map(|&r| minutes * reference_rate(&truth, KAPPA, r, r1))
                .collect();
            (radii, depth)
        })
        .collect()
}

fn gauss(rng: &mut fastrand::Rng) -> f64 {
    let (u1, u2) = (1.0 - rng.f64(), rng.f64());
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn runs(grooves: &[(Vec<f64>, Vec<f64>)], seed: u64) -> Vec<RunSpec> {
    let mut rng = fastrand::Rng::with_seed(seed);
    grooves
        .iter()
        .zip(RINGS)
        .zip(PISTONS)
        .map(|(((radii, depth), (r1, minutes)), piston)| RunSpec {
            motion: Motion::Ring {
                position_mm: r1,
                duration_s: 60.0 * minutes,
            },
            measured: Measured::Removal(Profile {
                radius_mm: radii.clone(),
                depth_nm: depth
                    .iter()
                    .map(|d| d + piston + NOISE_NM * gauss(&mut rng))
                    .collect(),
            }),
            aperture: None,
        })
        .collect()
}

const ALL_THREE: Freedom = Freedom {
    preston_coefficient: true,
    tool_radius: true,
    pad_moment_share: true,
    metrology_power: false,
};

fn calibrate(runs: Vec<RunSpec>, freedom: Freedom) -> Calibrated {
    let nominal = Process::new(spec(1e-13, 10.0, 1.0)).unwrap();
    Calibration::new(nominal, runs, freedom, RobustLoss::None)
        .unwrap()
        .fit()
        .unwrap()
}

fn estimate(fit: &Calibrated, parameter: ProcessParameter) -> (f64, f64) {
    let e = fit
        .estimates
        .iter()
        .find(|e| e.parameter == parameter)
        .unwrap();
    (e.value, e.standard_error.unwrap())
}

/// K within 0.5 %, r_t within 0.02 mm, κ within 0.03; the calibrated process predicts each
/// measured ring within 1 % of its peak.
#[test]
fn three_rings_recover_the_planted_process() {
    let grooves = grooves();
    let fit = calibrate(runs(&grooves, 1), ALL_THREE);
    let (k, _) = estimate(&fit, ProcessParameter::PrestonCoefficient);
    let (rt, _) = estimate(&fit, ProcessParameter::ToolRadius);
    let (kappa, _) = estimate(&fit, ProcessParameter::PadMomentShare);
    println!("K {k:e} r_t {rt} κ {kappa}, {} steps", fit.steps);
    assert!((k / K - 1.0).abs() <= 0.005, "K {k:e}");
    assert!((rt - RT).abs() <= 0.02, "r_t {rt}");
    assert!((kappa - KAPPA).abs() <= 0.03, "κ {kappa}");
    assert!((fit.removal_rate_ratio - k / 1e-13).abs() <= 1e-12 * fit.removal_rate_ratio);
    for (run, (_, depth)) in fit.runs.iter().zip(&grooves) {
        let peak = depth.iter().cloned().fold(0.0, f64::max);
        for (m, p) in run.measured_nm.iter().zip(&run.predicted_nm) {
            assert!((m - p).abs() <= 0.01 * peak, "{m} vs {p} (peak {peak})");
        }
        // The residual is the noise planted.
        assert!(
            (run.residual_rms_nm / NOISE_NM - 1.0).abs() < 0.25,
            "{}",
            run.residual_rms_nm
        );
    }
}

/// Over 200 noise seeds the fraction of |estimate − truth| ≤ 2·standard error lies in
/// [0.90, 0.99] for each parameter (2σ covers 95.4 % of a normal estimate; with 200 seeds the
/// binomial spread of that fraction is ±1.5 %).
#[test]
fn standard_errors_are_honest() {
    let grooves = grooves();
    let truth = [
        (ProcessParameter::PrestonCoefficient, K),
        (ProcessParameter::ToolRadius, RT),
        (ProcessParameter::PadMomentShare, KAPPA),
    ];
    let mut covered = [0usize; 3];
    let seeds = 200;
    for seed in 0..seeds {
        let fit = calibrate(runs(&grooves, 1000 + seed), ALL_THREE);
        for (slot, (parameter, value)) in covered.iter_mut().zip(truth) {
            let (estimate, se) = estimate(&fit, parameter);
            if (estimate - value).abs() <= 2.0 * se {
                *slot += 1;
            }
        }
    }
    for (count, (parameter, _)) in covered.iter().zip(truth) {
        let fraction = *count as f64 / seeds as f64;
        println!("{parameter:?}: {fraction}");
        assert!(
            (0.90..=0.99).contains(&fraction),
            "{parameter:?}: {fraction}"
        );
    }
}
