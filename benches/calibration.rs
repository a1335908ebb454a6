//! Calibration: three rings (15, 30 and 43 mm on the paper's 50 mm part, the last overhanging),
//! K, r_t and κ fitted under linear pressure with a piston per ring, from a nominal K = 1e-13,
//! r_t = 10 mm, κ = 1. The grooves are the planted process's (K = 1.37e-13, r_t = 9.7 mm,
//! κ = 0.6) with 0.4 nm of deterministic pseudo-noise, measured every 0.25 mm within 12 mm of
//! each ring: 291 points, 6 parameters.

use preston::calibration::{Calibration, Freedom, Measured, RunSpec, TrialSpec};
use preston::field::DepthProfile;
use preston::lsq::RobustLoss;
use preston::physics::{removal_rate_nm_per_min, PressureModel, Process, ProcessSpec};

fn main() {
    divan::main();
}

fn spec(k: f64, rt: f64, kappa: f64) -> ProcessSpec {
    ProcessSpec {
        workpiece_radius_mm: 50.0,
        tool_radius_mm: rt,
        workpiece_rpm: -10.0,
        tool_rpm: 200.0,
        preston_coefficient_m2_per_n: k,
        pressure_kpa: 10.0,
        pressure_model: PressureModel::Linear {
            pad_moment_share: kappa,
        },
        part: Default::default(),
    }
}

fn runs() -> Vec<RunSpec> {
    let truth = Process::new(spec(1.37e-13, 9.7, 0.6)).unwrap();
    // A fixed pseudo-random sequence (xorshift), uniform on ±0.4·√3 nm: 0.4 nm RMS.
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state as f64 / u64::MAX as f64 - 0.5) * 2.0 * 0.4 * 3f64.sqrt()
    };
    [(15.0, 240.0), (30.0, 180.0), (43.0, 180.0)]
        .iter()
        .map(|&(r1, minutes)| {
            let radius_mm: Vec<f64> = (0..=96)
                .map(|i| r1 - 12.0 + 0.25 * i as f64)
                .filter(|r| (0.0..=50.0).contains(r))
                .collect();
            let depth_nm = radius_mm
                .iter()
                .map(|&r| minutes * removal_rate_nm_per_min(&truth, r, r1) + 2.0 + noise())
                .collect();
            RunSpec {
                trial: TrialSpec::Ring {
                    position_mm: r1,
                    duration_s: 60.0 * minutes,
                },
                measured: Measured::Removal(DepthProfile {
                    radius_mm,
                    depth_nm,
                }),
                aperture: None,
            }
        })
        .collect()
}

#[divan::bench]
fn three_rings_three_parameters(bencher: divan::Bencher) {
    let runs = runs();
    let nominal = Process::new(spec(1e-13, 10.0, 1.0)).unwrap();
    let freedom = Freedom {
        preston_coefficient: true,
        tool_radius: true,
        pad_moment_share: true,
        metrology_power: false,
    };
    bencher.bench(|| {
        Calibration::new(nominal.clone(), runs.clone(), freedom, RobustLoss::None)
            .unwrap()
            .fit()
            .unwrap()
    });
}
