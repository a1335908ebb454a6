//! The polar optimizer's pieces against independent computations: the footprint's angular
//! spectrum against a brute-force sum of the footprint point by point over the angle (and
//! its Ω-derivative against finite differences of pads turning at neighbouring speeds); a
//! ring's harmonics against a trigonometric polynomial; and the whole correction
//! (`/v1/maps/optimize`) on planted astigmatism and trefoil, judged by its exact removal.

use std::f64::consts::TAU;

use preston::optimize::harmonics::Harmonics;
use preston::physics::polar::PolarPad;
use preston::physics::{PressureModel, Process, ProcessSpec};
use serde_json::{json, Value};

use crate::common::http::{app, post_json};
use crate::common::paper_spec;

fn pad_of(spec: ProcessSpec) -> PolarPad {
    PolarPad::new(&Process::new(spec).unwrap())
}

/// (1/2π)·∫ρ(r, α)·cos(mα) dα, the footprint taken point by point (`PolarPad::rate_at`, the
/// sliding speed from the 2-D vectors): the pressed arc's two ends found by bisection on
/// where the rate is positive (each side of α = 0 on its own), then the midpoint rule on `n`
/// angles between them (the whole circle when it is all pressed).
fn brute_spectrum(pad: &PolarPad, r: f64, r1: f64, m: usize, n: usize) -> f64 {
    let rate = |alpha: f64| pad.rate_at((r * alpha.cos(), r * alpha.sin()), (r1, 0.0));
    let pressed = |alpha: f64| rate(alpha) > 0.0;
    let end = |towards: f64| {
        if pressed(towards) {
            return towards;
        }
        let (mut inside, mut outside) = (0.0, towards);
        for _ in 0..80 {
            let mid = 0.5 * (inside + outside);
            if pressed(mid) {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        inside
    };
    if !pressed(0.0) {
        return 0.0;
    }
    let (lo, hi) = (end(-std::f64::consts::PI), end(std::f64::consts::PI));
    let width = (hi - lo) / n as f64;
    (0..n)
        .map(|k| {
            let alpha = lo + width * (k as f64 + 0.5);
            rate(alpha) * (m as f64 * alpha).cos()
        })
        .sum::<f64>()
        * width
        / TAU
}

/// The footprint's harmonics agree with the brute-force sum to 1e-6 of ĝ_0 (the midpoint
/// rule on 2·10⁴ angles of the pressed arc errs by (Δα)²/24·ρ″ ≈ 1e-9 of ĝ_0 where ρ is
/// smooth; a linear pad's lift line, a kink inside the arc, costs O(Δα²) too), on uniform and
/// linear pressure, inside the pad (r < r_t, the
/// whole circle pressed), across its rim and at the centre line, for m up to 24. The
/// modulation kernel h = ρ − Ω·∂ρ/∂Ω agrees with ρ − Ω·(ρ_{Ω+ε} − ρ_{Ω−ε})/2ε from pads
/// turning at neighbouring speeds (ε = 1e-4·Ω: the central difference errs by ε²·ρ‴, far
/// below the bound).
#[test]
fn the_footprint_s_angular_spectrum_is_its_fourier_series() {
    for model in [
        PressureModel::Uniform,
        PressureModel::Linear {
            pad_moment_share: 0.6,
        },
    ] {
        let mut spec = paper_spec(-10.0, 200.0);
        spec.workpiece_radius_mm = 40.0;
        spec.tool_radius_mm = 5.0;
        spec.pressure_model = model;
        let pad = pad_of(spec.clone());
        let omega = pad.part_speed_rad_per_s();
        let eps = 1e-4 * omega;
        let faster = pad.turning_at(omega + eps);
        let slower = pad.turning_at(omega - eps);
        for (r, r1) in [
            (2.0, 1.5),
            (18.0, 20.0),
            (24.6, 20.0),
            (20.0, 20.0),
            (36.0, 38.0),
        ] {
            let (rho, h) = pad.angular_spectrum(r, r1, 24);
            let scale = rho[0].abs().max(1e-300);
            for m in [0, 1, 2, 3, 7, 24] {
                let brute = brute_spectrum(&pad, r, r1, m, 20_000);
                assert!(
                    (rho[m] - brute).abs() <= 1e-6 * scale,
                    "{model:?} r {r} r1 {r1} m {m}: {} vs brute force {brute}",
                    rho[m]
                );
                let derivative = (brute_spectrum(&faster, r, r1, m, 20_000)
                    - brute_spectrum(&slower, r, r1, m, 20_000))
                    / (2.0 * eps);
                let want = brute - omega * derivative;
                assert!(
                    (h[m] - want).abs() <= 1e-5 * scale,
                    "{model:?} r {r} r1 {r1} m {m}: kernel {} vs {want}",
                    h[m]
                );
            }
        }
    }
}

/// Samples of a trigonometric polynomial of degree 5 on rings of 28 angles give back its
/// coefficients to rounding (the discrete Fourier sums are exact below N/2).
#[test]
fn a_ring_s_harmonics_are_its_trigonometric_coefficients() {
    let coefficient = |i: usize, m: usize| {
        (
            0.7 + i as f64,
            if m == 0 { 0.0 } else { 0.3 * m as f64 - 1.0 },
        )
    };
    let radii = vec![1.0, 2.0, 3.0];
    let rings: Vec<Vec<f64>> = (0..radii.len())
        .map(|i| {
            (0..28)
                .map(|k| {
                    let theta = TAU * k as f64 / 28.0;
                    (0..=5)
                        .map(|m| {
                            let (a, b) = coefficient(i, m);
                            let (s, c) = (m as f64 * theta).sin_cos();
                            if m == 0 {
                                a
                            } else {
                                a * c + b * s
                            }
                        })
                        .sum()
                })
                .collect()
        })
        .collect();
    let h = Harmonics::of_rings(radii, &rings, 6);
    for i in 0..3 {
        for m in 0..=6 {
            let want = if m <= 5 {
                coefficient(i, m)
            } else {
                (0.0, 0.0)
            };
            let got = h.coefficients[i][m];
            assert!(
                (got.0 - want.0).abs() < 1e-12 && (got.1 - want.1).abs() < 1e-12,
                "ring {i} m {m}: {got:?} vs {want:?}"
            );
        }
    }
}

/// Fringe Z5 + Z10-like planted error: astigmatism (m = 2) and trefoil (m = 3), each 20 nm
/// RMS over an 80 mm part (unit-RMS Zernike normalisation: √6·ρ²·cos 2θ and √8·ρ³·cos 3θ),
/// written as a 2 mm grid by this test's own generator.
fn planted_map() -> Value {
    let (radius, pixel, n) = (40.0, 2.0, 41);
    let rows: Vec<Vec<Option<f64>>> = (0..n)
        .map(|i| {
            let y = (n as f64 / 2.0 - 0.5 - i as f64) * pixel;
            (0..n)
                .map(|j| {
                    let x = (j as f64 - (n as f64 / 2.0 - 0.5)) * pixel;
                    let r = x.hypot(y);
                    (r <= radius).then(|| {
                        let (rho, theta) = (r / radius, y.atan2(x));
                        20.0 * 6f64.sqrt() * rho * rho * (2.0 * theta).cos()
                            + 20.0 * 8f64.sqrt() * rho.powi(3) * (3.0 * theta + 0.4).cos()
                    })
                })
                .collect()
        })
        .collect();
    json!({"heights_nm": rows, "pixel_mm": pixel})
}

/// Planted astigmatism and trefoil, 20 nm RMS each, on an 80 mm part polished by a 5 mm pad at
/// the paper's speeds (K = 4e-12 m²/N, so the plan runs ~600 turns of C and the verdict's
/// exact map fits one request's work at the 5 mm pixels asked), within C's stated limits
/// (36,000 deg/min, 360 deg/s²): the exact
/// removal of the executed motion leaves at most 10 % of the planted RMS over a 72 mm clear
/// aperture, C's peaks are within its limits, a limit the plan sits on is named in the
/// warnings, and `/v1/maps/program` accepts the plan on the same machine with C's peaks the
/// plan's. The residual figures are recomputed here from the maps the response returns.
#[tokio::test(flavor = "multi_thread")]
async fn planted_astigmatism_and_trefoil_are_corrected_within_c_s_limits() {
    let body = json!({
        "process": {"workpiece_radius_mm": 40, "tool_radius_mm": 5, "workpiece_rpm": -10, "tool_rpm": 200,
                    "preston_coefficient_m2_per_n": 4e-12},
        "map": planted_map(),
        "alignment": {"centre_x_px": 20, "centre_y_px": 20, "part_radius_mm": 40},
        "positions_mm": (0..=80).map(|k| 0.5 * k as f64).collect::<Vec<_>>(),
        "radial_grid": {"start_mm": 0, "stop_mm": 40, "count": 81},
        "clear_aperture": {"inner_mm": 0, "outer_mm": 36},
        "machine": {"c": {"max_velocity_deg_per_min": 36000, "max_acceleration_deg_per_s2": 360}},
        "c_law": {"sectors": 36, "max_harmonic": 4, "max_modulation": 0.8},
        "removal_pixel_mm": 5
    });
    let reply = post_json(&app(), "/v1/maps/optimize", body.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let out = reply.json();
    let metrics = &out["metrics"];
    let before = metrics["before"]["rms_nm"].as_f64().unwrap();
    let after = metrics["after"]["rms_nm"].as_f64().unwrap();
    // The planted 2 × 20 nm RMS (less what a 2 mm grid sampled and a 36 mm aperture keep).
    assert!(before > 20.0 && before < 30.0, "before {before}");
    assert!(after <= 0.1 * before, "residual {after} nm of {before} nm");
    // The residual map's own RMS about its mean is the reported one.
    let residual: Vec<f64> = out["maps"]["residual_nm"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|row| row.as_array().unwrap().iter().filter_map(Value::as_f64))
        .collect();
    let mean = residual.iter().sum::<f64>() / residual.len() as f64;
    let rms =
        (residual.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / residual.len() as f64).sqrt();
    assert!(
        (rms - after).abs() <= 1e-9 * after.max(1.0),
        "{rms} vs {after}"
    );
    let peaks = &out["c_peaks"];
    assert!(peaks["velocity_deg_per_min"].as_f64().unwrap() <= 36000.0);
    assert!(peaks["acceleration_deg_per_s2"].as_f64().unwrap() <= 360.0);
    let fields: Vec<&str> = out["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w["field"].as_str())
        .collect();
    // Judged at the pixels asked, not on a coarsened map.
    assert!(
        !fields.contains(&"removal_pixel_mm"),
        "{fields:?} {}",
        out["maps"]["pixel_mm"]
    );
    let at_limit = peaks["acceleration_deg_per_s2"].as_f64().unwrap() >= 0.999 * 360.0;
    assert_eq!(
        at_limit,
        fields.contains(&"machine.c.max_acceleration_deg_per_s2"),
        "{fields:?}"
    );
    // Every factor is C turning forwards within its velocity limit.
    let omega_deg_per_min = 10.0 * 360.0;
    for row in out["c_law"]["speed_factors"].as_array().unwrap() {
        for f in row.as_array().unwrap() {
            let f = f.as_f64().unwrap();
            assert!(f > 0.0 && f * omega_deg_per_min <= 36000.0, "factor {f}");
        }
    }
    // The plan as a program for the same machine: accepted, C's peaks the plan's to 1e-9.
    let program = json!({
        "process": body["process"],
        "dwell": out["dwell"],
        "c_law": out["c_law"],
        "machine": body["machine"],
    });
    let reply = post_json(&app(), "/v1/maps/program", program.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    crate::map_program::assert_c_peaks_are_the_plan_s(&reply.json(), &out);
}

/// prysm's 50 mm Fizeau sample (a real part: a strong zone and an edge roll) planned on a
/// 50 mm part with a 5 mm pad at the paper's speeds, on the default machine's C, 90 sectors,
/// harmonics up to what the pad resolves at the aperture's edge (15). K = 3e-11 m²/N: the plan
/// is the default K's scaled in time (dwell ∝ 1/K, the same law: no time-set limit binds), and
/// runs ~240 turns of C rather than 72,000, so that the exact map fits one request at 1 mm.
///
/// Judged twice: by the exact removal of the executed motion (at ~2 mm, where the work limit
/// coarsens it) and by the plan's harmonic model at 1 mm. Measured: exact, RMS 26.6 → 11.2 nm
/// beside the best plan in radius alone's 14.9, what is not round 14.7 → 9.9 nm; the model,
/// 26.2 → 10.2 beside 14.4, not round 14.2 → 8.8, much of it above m = 15, beyond what the
/// pad resolves (warned), and in the edge roll (20–23 mm), whose harmonics ask C's law for 3.3
/// times the modulation it has (`modulation_share`). The bounds check: the 2-D plan beats
/// the radial one by 5 % at least; the exact verdict and the model agree within a quarter;
/// what is not round loses a tenth at least; each band from 10 mm out loses (harmonics 1 … 15
/// together), the edge band a quarter at least.
#[tokio::test(flavor = "multi_thread")]
async fn the_real_fizeau_map_loses_what_is_not_round() {
    let bytes = std::fs::read(crate::common::fixture_path("maps/valid_zygo_dat_file.dat")).unwrap();
    let (_, map) = preston::maps::read(&bytes, 10_000_000).unwrap();
    let rows: Vec<Vec<Option<f64>>> = map
        .heights_nm()
        .chunks(map.width())
        .map(<[_]>::to_vec)
        .collect();
    let body = |model: &str, pixel: f64| {
        json!({
            "process": {"workpiece_radius_mm": 25, "tool_radius_mm": 5, "workpiece_rpm": -10, "tool_rpm": 200,
                        "preston_coefficient_m2_per_n": 3e-11},
            "map": {"heights_nm": rows, "pixel_mm": map.pixel_mm()},
            "positions_mm": (0..=50).map(|k| 0.5 * k as f64).collect::<Vec<_>>(),
            "radial_grid": {"start_mm": 0, "stop_mm": 25, "count": 51},
            "clear_aperture": {"inner_mm": 0, "outer_mm": 23},
            "c_law": {"sectors": 90},
            "removal_pixel_mm": pixel,
            "removal_model": model
        })
    };
    let run = |model: &'static str, pixel: f64| {
        let body = body(model, pixel);
        async move {
            let reply = post_json(&app(), "/v1/maps/optimize", body.to_string()).await;
            assert_eq!(reply.status, 200, "{}", reply.text());
            reply.json()
        }
    };
    let (exact, model) = (run("exact", 1.0).await, run("harmonic", 1.0).await);
    assert_eq!(exact["dwell"], model["dwell"]);
    assert_eq!(exact["c_law"], model["c_law"]);
    let rms = |out: &Value, key: &str| out["metrics"][key]["rms_nm"].as_f64().unwrap();
    for (name, out) in [("exact", &exact), ("model", &model)] {
        eprintln!(
            "real map, {name} at {} mm: RMS {:.2} → {:.2} nm (radial plan {:.2} nm in {:.0} s), \
             not round {:.2} → {:.2} nm, {:.0} s",
            out["maps"]["pixel_mm"],
            rms(out, "before"),
            rms(out, "after"),
            rms(out, "radial_plan_after"),
            out["metrics"]["radial_plan_time_s"],
            rms(out, "non_axisymmetric_before"),
            rms(out, "non_axisymmetric_after"),
            out["total_time_s"].as_f64().unwrap(),
        );
    }
    assert!(rms(&exact, "after") <= 0.95 * rms(&exact, "radial_plan_after"));
    let not_round =
        |out: &Value| rms(out, "non_axisymmetric_after") / rms(out, "non_axisymmetric_before");
    assert!(not_round(&exact) <= 0.9, "{}", exact["metrics"]);
    assert!(not_round(&model) <= 0.9, "{}", model["metrics"]);
    assert!(
        (rms(&exact, "after") / rms(&model, "after") - 1.0).abs() <= 0.25,
        "{} vs {}",
        exact["metrics"],
        model["metrics"]
    );
    assert!(
        (rms(&exact, "non_axisymmetric_after") / rms(&model, "non_axisymmetric_after") - 1.0).abs()
            <= 0.25
    );
    let fields: Vec<&str> = exact["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w["field"].as_str())
        .collect();
    assert!(fields.contains(&"c_law.max_harmonic"), "{fields:?}");
    // Band by band, from the model's 1 mm maps: harmonics 1 … M together.
    let power = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
    let mut bands = 0;
    for band in model["harmonic_budget"].as_array().unwrap() {
        let from = band["from_mm"].as_f64().unwrap();
        let before = crate::common::numbers(&band["target_rms_nm"]);
        let after = crate::common::numbers(&band["residual_rms_nm"]);
        eprintln!("{from} mm: before {before:.1?}\n        after  {after:.1?}");
        if from < 10.0 {
            continue;
        }
        bands += 1;
        let (before, after) = (power(&before), power(&after));
        assert!(after < before, "{band}");
        if from >= 20.0 {
            assert!(after <= 0.75 * before, "{band}");
        }
    }
    assert_eq!(bands, 3);
}

/// `/v1/maps/optimize` on prysm's Fizeau sample sent as its file: the body, the other fields
/// (`query`'s members) as query parameters.
async fn optimize_the_sample_file(query: Value) -> Value {
    let bytes = std::fs::read(crate::common::fixture_path("maps/valid_zygo_dat_file.dat")).unwrap();
    let query: Vec<String> = query
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| {
            let text = v.as_str().map_or_else(|| v.to_string(), str::to_string);
            format!("{k}={}", crate::api_metrology::urlencode(&text))
        })
        .collect();
    let path = format!("/v1/maps/optimize?{}", query.join("&"));
    let reply = crate::common::http::post_with(
        &app(),
        &path,
        bytes,
        &[("content-type", "application/octet-stream")],
    )
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    reply.json()
}

/// The same map and set-up judged inside its edge roll (a 36 mm clear aperture: beyond about
/// 20 mm the map falls away steeply and irregularly, and its harmonics there ask C's law for
/// three times the modulation it has, `modulation_share` 3.3). Here the budget allows every
/// band from 5 mm out (`modulation_share` 0.3–0.7; inside 5 mm, where the pad spans more than
/// half the circle, 7.8), and by the plan's model what is not round falls 10.4 → 1.9 nm; in
/// each band the budget allows, harmonics 1 … 12 together fall 6×, 11× and 12×, m = 1, 2 and 3
/// (most of what is not round) each at least 3× (the higher ones, under 1 nm to begin with,
/// less). The exact removal of the executed motion at this K (at the 2.4 mm the work limit
/// leaves, about three turns of C per station, so that each station's last part-turn leaves a
/// sector of its own: the spiral's ripple) gives 10.6 → 4.8 nm; with ten times the turns, the
/// next test, it falls 9–22× band by band.
#[tokio::test(flavor = "multi_thread")]
async fn the_real_map_falls_three_times_wherever_the_budget_allows_it() {
    let body = |model: &str| {
        json!({
            "process": {"workpiece_radius_mm": 25, "tool_radius_mm": 5, "workpiece_rpm": -10, "tool_rpm": 200,
                        "preston_coefficient_m2_per_n": 3e-11},
            "positions_mm": (0..=50).map(|k| 0.5 * k as f64).collect::<Vec<_>>(),
            "radial_grid": {"start_mm": 0, "stop_mm": 25, "count": 51},
            "clear_aperture": {"inner_mm": 0, "outer_mm": 18},
            "c_law": {"sectors": 90},
            "removal_pixel_mm": 1.0,
            "removal_model": model
        })
    };
    let run = |model: &'static str| optimize_the_sample_file(body(model));
    let (model, exact) = (run("harmonic").await, run("exact").await);
    assert_eq!(exact["dwell"], model["dwell"]);
    let rms = |out: &Value, key: &str| out["metrics"][key]["rms_nm"].as_f64().unwrap();
    let not_round =
        |out: &Value| rms(out, "non_axisymmetric_after") / rms(out, "non_axisymmetric_before");
    eprintln!(
        "inside 18 mm: model not round {:.2} → {:.2} nm, exact {:.2} → {:.2} nm",
        rms(&model, "non_axisymmetric_before"),
        rms(&model, "non_axisymmetric_after"),
        rms(&exact, "non_axisymmetric_before"),
        rms(&exact, "non_axisymmetric_after"),
    );
    // 0.18 measured; the fit scaled to C's limits afterwards, as before the fit within them,
    // gave 0.31.
    assert!(not_round(&model) <= 0.25, "{}", model["metrics"]);
    assert!(not_round(&exact) <= 0.5, "{}", exact["metrics"]);
    let power = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
    let mut allowed = 0;
    for band in model["harmonic_budget"].as_array().unwrap() {
        let from = band["from_mm"].as_f64().unwrap();
        let share = band["modulation_share"].as_f64().unwrap();
        // The share is the sum of the amplitudes' ratios, each at most the whole.
        let asked = crate::common::numbers(&band["target_amplitude_nm"]);
        let within = crate::common::numbers(&band["amplitude_nm"]);
        let sum: f64 = asked
            .iter()
            .zip(&within)
            .filter(|(a, _)| **a > 0.0)
            .map(|(a, w)| a / w)
            .sum();
        assert!((share - sum).abs() <= 1e-12 * sum, "{band}");
        let before = crate::common::numbers(&band["target_rms_nm"]);
        let after = crate::common::numbers(&band["residual_rms_nm"]);
        if share > 1.0 {
            eprintln!("{from} mm: the law would need {share:.2} of its modulation");
            continue;
        }
        allowed += 1;
        let fallen: Vec<usize> = (0..before.len())
            .filter(|&m| 3.0 * after[m] <= before[m])
            .map(|m| m + 1)
            .collect();
        eprintln!(
            "{from} mm (share {share:.2}): {:.2} → {:.2} nm; 3× lower: m = {fallen:?}",
            power(&before),
            power(&after)
        );
        assert!(3.0 * power(&after) <= power(&before), "{band}");
    }
    assert_eq!(allowed, 3);
}

/// The same plan judged by the exact removal of its executed motion rather than its model,
/// with ten times the turns (K = 3e-12 m²/N: some 20 turns of C per station, so that what each
/// station's last part-turn leaves, the spiral's ripple, is a tenth of the plan's at 3e-11).
/// The exact map of so long a plan is more work than one request does, so the removal is
/// computed here by `physics::polar` itself, at rings of 64 equally spaced points 1 mm apart,
/// against the plan's own target (its `maps.target_nm`, bilinear): in each band the budget
/// allows, harmonics 1 … M of the exact residual (discrete Fourier sums on each ring,
/// area-weighted) are at least 3× below the target's (measured 9×, 22× and 17×).
#[tokio::test(flavor = "multi_thread")]
async fn the_exact_removal_of_the_real_map_s_plan_falls_three_times_where_the_budget_allows() {
    use preston::physics::polar::executed_blocks;
    use preston::physics::{Motion, SectorLaw};
    let k = 3e-12;
    let out = optimize_the_sample_file(json!({
        "process": {"workpiece_radius_mm": 25, "tool_radius_mm": 5, "workpiece_rpm": -10, "tool_rpm": 200,
                    "preston_coefficient_m2_per_n": k, "pressure_kpa": 10, "pressure_model": "uniform"},
        "positions_mm": (0..=50).map(|k| 0.5 * k as f64).collect::<Vec<_>>(),
        "radial_grid": {"start_mm": 0, "stop_mm": 25, "count": 51},
        "clear_aperture": {"inner_mm": 0, "outer_mm": 18},
        "c_law": {"sectors": 90},
        "removal_pixel_mm": 0.5,
        "removal_model": "harmonic"
    }))
    .await;
    let process = Process::new(ProcessSpec {
        workpiece_radius_mm: 25.0,
        tool_radius_mm: 5.0,
        workpiece_rpm: -10.0,
        tool_rpm: 200.0,
        preston_coefficient_m2_per_n: k,
        pressure_kpa: 10.0,
        pressure_model: PressureModel::Uniform,
        part: preston::physics::Part::flat(),
    })
    .unwrap();
    let pad = PolarPad::new(&process);
    let positions = crate::common::numbers(&out["dwell"]["positions_mm"]);
    let dwell = crate::common::numbers(&out["dwell"]["dwell_s"]);
    let sectors = out["c_law"]["sectors"].as_u64().unwrap() as usize;
    let factors: Vec<f64> = out["c_law"]["speed_factors"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(crate::common::numbers)
        .collect();
    let motion = Motion::radial(positions.clone())
        .with_sector_law(SectorLaw::new(positions.len(), sectors, factors).unwrap())
        .unwrap();
    let turns = dwell.iter().sum::<f64>() * pad.part_speed_rad_per_s().abs() / TAU;
    let blocks = executed_blocks(
        &motion,
        &dwell,
        pad.part_speed_rad_per_s(),
        0.0,
        &process.part().surface,
    );
    // The plan's target (with its piston) on its map, bilinear between the four pixels.
    let maps = &out["maps"];
    let (xs, ys) = (
        crate::common::numbers(&maps["x_mm"]),
        crate::common::numbers(&maps["y_mm"]),
    );
    let target: Vec<Vec<Option<f64>>> = maps["target_nm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|row| row.as_array().unwrap().iter().map(Value::as_f64).collect())
        .collect();
    let pixel = xs[1] - xs[0];
    let at = |x: f64, y: f64| -> Option<f64> {
        let (fx, fy) = ((x - xs[0]) / pixel, (y - ys[0]) / (ys[1] - ys[0]));
        let (i, j) = (fy.floor() as usize, fx.floor() as usize);
        let (u, v) = (fx - j as f64, fy - i as f64);
        Some(
            target.get(i)?.get(j).copied()?? * (1.0 - u) * (1.0 - v)
                + target.get(i)?.get(j + 1).copied()?? * u * (1.0 - v)
                + target.get(i + 1)?.get(j).copied()?? * (1.0 - u) * v
                + target.get(i + 1)?.get(j + 1).copied()?? * u * v,
        )
    };
    let m_max = out["max_harmonic"].as_u64().unwrap() as usize;
    let samples = 64;
    // Harmonics 1 … M's mean square on one ring of samples.
    let power = |ring: &[f64]| -> f64 {
        (1..=m_max)
            .map(|m| {
                let (mut a, mut b) = (0.0, 0.0);
                for (k, v) in ring.iter().enumerate() {
                    let (s, c) = (TAU * (m * k) as f64 / samples as f64).sin_cos();
                    a += v * c;
                    b += v * s;
                }
                let (a, b) = (2.0 * a / samples as f64, 2.0 * b / samples as f64);
                0.5 * (a * a + b * b)
            })
            .sum()
    };
    let mut allowed = 0;
    for band in out["harmonic_budget"].as_array().unwrap() {
        let (from, to) = (
            band["from_mm"].as_f64().unwrap(),
            band["to_mm"].as_f64().unwrap(),
        );
        let share = band["modulation_share"].as_f64().unwrap();
        if share > 1.0 {
            continue;
        }
        allowed += 1;
        let (mut before, mut after, mut weight) = (0.0, 0.0, 0.0);
        let mut r = from + 0.5;
        while r < to {
            let points: Vec<(f64, f64)> = (0..samples)
                .map(|k| {
                    let (s, c) = (TAU * k as f64 / samples as f64).sin_cos();
                    (r * c, r * s)
                })
                .collect();
            let removal = pad.depth_nm(&blocks, &points);
            let wanted: Option<Vec<f64>> = points.iter().map(|&(x, y)| at(x, y)).collect();
            if let Some(wanted) = wanted {
                let residual: Vec<f64> = removal.iter().zip(&wanted).map(|(d, t)| d - t).collect();
                before += r * power(&wanted);
                after += r * power(&residual);
                weight += r;
            }
            r += 1.0;
        }
        let (before, after) = ((before / weight).sqrt(), (after / weight).sqrt());
        eprintln!(
            "exact, {turns:.0} turns of C: {from} mm (share {share:.2}): harmonics 1 … {m_max} \
             {before:.2} → {after:.2} nm ({:.1}×)",
            before / after
        );
        assert!(3.0 * after <= before, "{from} mm: {before} → {after} nm");
    }
    assert_eq!(allowed, 3);
}
