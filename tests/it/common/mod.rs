//! Shared test helpers: an independent adaptive quadrature, the paper's processes and fixtures.
#![allow(dead_code)] // each test binary uses a different subset

pub mod http;
pub mod service;
pub mod socket;

use preston::physics::{Part, PressureModel, Process, ProcessSpec};

/// Gauss–Kronrod (7, 15) nodes on [−1, 1] (non-negative half) and weights.
const XGK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const WGK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_18,
    0.140_653_259_715_525_92,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_83,
];
/// Gauss 7-point weights for the Kronrod nodes XGK[1], XGK[3], XGK[5], XGK[7].
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// One panel: (Kronrod estimate, |K15 − G7|, ∫|f| estimate).
fn gk15(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64, f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let fc = f(c);
    let mut kronrod = WGK[7] * fc;
    let mut gauss = WG[3] * fc;
    let mut absolute = WGK[7] * fc.abs();
    for k in 0..7 {
        let (lo, hi) = (f(c - h * XGK[k]), f(c + h * XGK[k]));
        kronrod += WGK[k] * (lo + hi);
        absolute += WGK[k] * (lo.abs() + hi.abs());
        if k % 2 == 1 {
            gauss += WG[k / 2] * (lo + hi);
        }
    }
    (
        kronrod * h,
        ((kronrod - gauss) * h).abs(),
        absolute * h.abs(),
    )
}

/// ∫_a^b f by adaptive bisection of Gauss–Kronrod (7, 15) panels. A panel is accepted when
/// |K15 − G7| is below its width's share of the absolute tolerance `tol`, or below the rounding
/// floor of the panel (100 ε·∫|f|), where no further bisection can help. Written for the tests,
/// independent of the closed forms in the library.
pub fn adaptive_integral(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    let density = tol / (b - a);
    let recurse = |a: f64, b: f64| -> f64 {
        let mut stack = vec![(a, b)];
        let mut total = 0.0;
        let mut panels = 0usize;
        while let Some((a, b)) = stack.pop() {
            panels += 1;
            assert!(panels < 1_000_000, "adaptive quadrature did not converge");
            let (value, err, absolute) = gk15(f, a, b);
            let m = 0.5 * (a + b);
            let floor = 100.0 * f64::EPSILON * absolute;
            if err <= density * (b - a) || err <= floor || m <= a || m >= b {
                total += value;
            } else {
                stack.push((m, b));
                stack.push((a, m));
            }
        }
        total
    };
    if b <= a {
        return 0.0;
    }
    recurse(a, b)
}

/// The defining integral of the removal rate in nm/min, by adaptive quadrature of the paper's
/// eq. (5) over the contact arc, with no use of the library's closed forms or contact geometry.
pub fn quadrature_rate_nm_per_min(spec: &ProcessSpec, r: f64, r1: f64) -> f64 {
    let rpm = 2.0 * std::f64::consts::PI / 60.0;
    let w1 = -spec.workpiece_rpm * rpm; // paper: workpiece clockwise positive
    let w2 = spec.tool_rpm * rpm;
    let rt = spec.tool_radius_mm;
    // Contact: r² + r1² − 2·r·r1·cosθ ≤ rt², i.e. sin²(θ/2) ≤ (rt² − (r − r1)²)/(4·r·r1),
    // equivalently cos²(θ/2) ≥ ((r + r1)² − rt²)/(4·r·r1).
    let theta0 = if r == 0.0 || r1 == 0.0 {
        let reach = r + r1;
        if reach < rt {
            std::f64::consts::PI
        } else if reach > rt {
            0.0
        } else {
            std::f64::consts::FRAC_PI_2
        }
    } else {
        // Take whichever of sin²(θ/2) and cos²(θ/2) is small: asin/acos of √x near 1 would
        // turn one rounding error in x into a √ε error in θ0.
        let sin2 = (rt - r + r1) * (rt + r - r1) / (4.0 * r * r1);
        let cos2 = (r + r1 - rt) * (r + r1 + rt) / (4.0 * r * r1);
        if sin2 <= 0.5 {
            2.0 * sin2.clamp(0.0, 1.0).sqrt().asin()
        } else {
            2.0 * cos2.clamp(0.0, 1.0).sqrt().acos()
        }
    };
    // Eq. (5), V² = (ω1+ω2)²r² + ω2²r1² − 2·r·r1·ω2·(ω1+ω2)·cosθ, with cosθ written as
    // 1 − 2sin²(θ/2) near θ = 0 and 2cos²(θ/2) − 1 near θ = π, so that a minimum of V (at either
    // end) is not lost to cancellation, which would make the integrand noisy at the 1e-9 level
    // and the adaptive rule bisect for ever.
    let (a, b) = ((w1 + w2) * r, w2 * r1);
    let v = |theta: f64| {
        let v2 = if theta.abs() <= std::f64::consts::FRAC_PI_2 {
            let half = (0.5 * theta).sin();
            (a - b).powi(2) + 4.0 * a * b * half * half
        } else {
            let half = (0.5 * theta).cos();
            (a + b).powi(2) - 4.0 * a * b * half * half
        };
        v2.max(0.0).sqrt()
    };
    // Absolute tolerance far below 1e-12 of the largest speed the arc can see.
    let vmax = a.abs() + b.abs();
    let tol = 1e-15 * (vmax * theta0).max(f64::MIN_POSITIVE);
    let integral = adaptive_integral(&v, -theta0, theta0, tol);
    // K·P/(2π)·∫V dθ, with P in Pa, V in mm/s → nm/min (1 mm = 1e6 nm, 60 s).
    spec.preston_coefficient_m2_per_n * spec.pressure_kpa * 1e3 / (2.0 * std::f64::consts::PI)
        * integral
        * 1e6
        * 60.0
}

/// The paper's geometry (r_m 50 mm, r_t 10 mm, K 1e-13, 10 kPa) at the given speeds.
pub fn paper_spec(workpiece_rpm: f64, tool_rpm: f64) -> ProcessSpec {
    ProcessSpec {
        workpiece_radius_mm: 50.0,
        tool_radius_mm: 10.0,
        workpiece_rpm,
        tool_rpm,
        preston_coefficient_m2_per_n: 1e-13,
        pressure_kpa: 10.0,
        pressure_model: PressureModel::Uniform,
        part: Part::flat(),
    }
}

pub fn paper_process(workpiece_rpm: f64, tool_rpm: f64) -> Process {
    Process::new(paper_spec(workpiece_rpm, tool_rpm)).unwrap()
}

/// Path of a file in fixtures/.
pub fn fixture_path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

pub fn read_fixture(name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(fixture_path(name)).expect("fixture readable");
    serde_json::from_str(&text).expect("fixture is JSON")
}

/// A JSON array of numbers (a response's column).
pub fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

/// The endpoint a request fixture is for, by its name's prefix.
pub fn endpoint_of(fixture: &str) -> &'static str {
    if fixture.starts_with("removal_function") {
        "/v1/removal-function"
    } else if fixture.starts_with("predict") {
        "/v1/predict"
    } else if fixture.starts_with("optimize") {
        "/v1/optimize"
    } else if fixture.starts_with("recommend") {
        "/v1/recommend"
    } else if fixture.starts_with("eta_sweep") {
        "/v1/studies/eta-sweep"
    } else if fixture.starts_with("measurement_fit") {
        "/v1/measurement/fit"
    } else if fixture.starts_with("program") {
        "/v1/program"
    } else if fixture.starts_with("calibration") {
        "/v1/calibration"
    } else if fixture.starts_with("maps_analysis") {
        "/v1/maps/analysis"
    } else if fixture.starts_with("maps_difference") {
        "/v1/maps/difference"
    } else if fixture.starts_with("maps_predict") {
        "/v1/maps/predict"
    } else if fixture.starts_with("maps_optimize") {
        "/v1/maps/optimize"
    } else if fixture.starts_with("maps_program") {
        "/v1/maps/program"
    } else if fixture.starts_with("maps_removal_function") {
        "/v1/maps/removal-function"
    } else {
        panic!("no endpoint for fixture {fixture}")
    }
}

/// Every request fixture: its file name, sorted.
pub fn request_fixtures() -> Vec<String> {
    let dir = fixture_path("");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| {
            let name = e.unwrap().file_name().into_string().unwrap();
            name.ends_with(".json").then_some(name)
        })
        .collect();
    names.sort();
    names
}

/// The default machine's limit `key` on `axis` (docs/MACHINE.md, "The default machine"),
/// written out here from the docs, not read from the code: X and Z 10,000 mm/min and
/// 2,000 mm/s², B 9,000 deg/min and 1,800 deg/s², no travel limits.
pub fn default_machine_limit(axis: &str, key: &str) -> Option<f64> {
    match (axis, key) {
        ("x" | "z", "max_velocity_mm_per_min") => Some(10_000.0),
        ("x" | "z", "max_acceleration_mm_per_s2") => Some(2_000.0),
        ("b", "max_velocity_deg_per_min") => Some(9_000.0),
        ("b", "max_acceleration_deg_per_s2") => Some(1_800.0),
        _ => None,
    }
}
