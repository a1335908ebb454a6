//! Plans on curved parts: equal dwell per unit arc length at η = −1 on spheres (the uniformity
//! fact), and an optimized plan on a sphere whose removal is re-checked with the independent
//! 3-D model of `curved_removal`.

use serde_json::json;

use crate::common::http::{app, post_json};
use crate::common::numbers;
use crate::curved_removal::{Case, Shape};
use preston::physics::{ClearAperture, Process, RadialGrid};
use preston::study::{EqualDwell, Frame};

/// η = −1, r_t = 8 mm, constant dwell per unit arc length over 0–50 mm of arc on R = ±100 mm:
/// the removal is uniform to ≤ 0.1 % (pv/mean over the aperture; the design notes measured
/// 0.08 % with an independent 3-D model), the rest being the spin about the normal that a
/// slope adds. The pass overhangs the edge by r_t of arc, as equal dwell does on a plane.
#[test]
fn equal_dwell_at_eta_minus_one_is_uniform_on_spheres() {
    for radius in [100.0, -100.0] {
        let case = Case {
            shape: Shape::sphere(radius),
            workpiece_rpm: 100.0,
            tool_rpm: 100.0,
            tool_radius: 8.0,
            workpiece_radius: 100.0 * (0.5f64).sin(), // 50 mm of arc
            vertical: false,
        };
        let process = Process::new(case.spec()).unwrap();
        let grid = RadialGrid::new(&process, 0.0, case.workpiece_radius, 401).unwrap();
        let aperture = ClearAperture::new(&process, 0.0, case.workpiece_radius).unwrap();
        let frame = Frame {
            grid: &grid,
            aperture: &aperture,
        };
        let pass = EqualDwell::for_depth(&process, frame, 100.0).unwrap();
        let nonuniformity = pass.metrics.nonuniformity.unwrap();
        println!("R {radius}: nonuniformity {nonuniformity:.3e}");
        assert!(nonuniformity <= 1e-3, "R {radius}: {nonuniformity}");
    }
}

/// `/v1/optimize` on an R = 60 mm sphere at the paper's η = +0.05: 100 nm uniform over the
/// aperture to ≤ 1 % nonuniformity, and the plan removes that when its motion's removal is
/// recomputed with the independent 3-D model (agreement to 1e-6 of the mean, which is the
/// 3-D model's accuracy, not a loosened bound).
#[tokio::test]
async fn optimized_plan_on_a_sphere_is_uniform_by_the_3d_model() {
    // The paper's 0.1 mm spacing: at η = +0.05 the removal function is sharply peaked at the
    // centre, and coarser plans (0.5 mm) leave a few per cent of ripple there.
    let positions: Vec<f64> = (0..=500).map(|i| i as f64 * 0.1).collect();
    let request = json!({
        "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10,
                    "workpiece_rpm": -10, "tool_rpm": 200},
        "surface": {"kind": "sphere", "radius_of_curvature_mm": 60},
        "positions_mm": positions,
        "target": {"uniform_depth_nm": 100},
        "radial_grid": {"start_mm": 0, "stop_mm": 50, "count": 501},
        "clear_aperture": {"inner_mm": 0, "outer_mm": 40}
    });
    let reply = post_json(&app(), "/v1/optimize", request.to_string()).await;
    let plan = reply.json();
    assert_eq!(reply.status, 200, "{plan}");
    let nonuniformity = plan["metrics"]["nonuniformity"].as_f64().unwrap();
    assert!(nonuniformity <= 0.01, "{nonuniformity}");

    let case = Case {
        shape: Shape::sphere(60.0),
        workpiece_rpm: -10.0,
        tool_rpm: 200.0,
        tool_radius: 10.0,
        workpiece_radius: 50.0,
        vertical: false,
    };
    let at = numbers(&plan["dwell"]["positions_mm"]);
    let dwell = numbers(&plan["dwell"]["dwell_s"]);
    let radii = numbers(&plan["radius_mm"]);
    let removal = numbers(&plan["removal_nm"]);
    // The motion the plan stands for (docs/MODEL.md): stops of t/2 at the two ends, and each
    // cell between neighbouring midpoints crossed at constant speed along the arc, so it
    // removes (w_j·t_j/L_j)·∫ R_3d ds over the cell; the arc length of the R = 60 mm sphere is
    // s = 60·asin(r/60), and the cell integrals are adaptive Gauss–Kronrod in s.
    let n = at.len();
    let arc = |r: f64| 60.0 * (r / 60.0).asin();
    let radius = |s: f64| 60.0 * (s / 60.0).sin();
    let mut bounds = vec![at[0]];
    bounds.extend(at.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    bounds.push(at[n - 1]);
    let mut inside = Vec::new();
    // Every tenth sample of the aperture (41 radii).
    for (i, &r) in radii
        .iter()
        .enumerate()
        .filter(|(i, &r)| r <= 40.0 && i % 10 == 0)
    {
        let mut reference = 0.0;
        for j in 0..n {
            let (lo, hi) = (bounds[j], bounds[j + 1]);
            if dwell[j] == 0.0 || lo >= r + 10.0 || hi <= r - 10.0 {
                continue;
            }
            let end = j == 0 || j == n - 1;
            let share = if end { 0.5 } else { 1.0 };
            let (s0, s1) = (arc(lo), arc(hi));
            let rate = |s: f64| case.rate(r, radius(s));
            // R in nm/min; an absolute tolerance of 1e-9 nm/min · mm per cell.
            let cell = crate::common::adaptive_integral(&rate, s0, s1, 1e-9);
            reference += share * dwell[j] / 60.0 * cell / (s1 - s0);
            if end {
                reference += 0.5 * dwell[j] / 60.0 * case.rate(r, at[j]);
            }
        }
        assert!(
            (reference - removal[i]).abs() <= 1e-6 * 100.0,
            "r {r}: service {} vs 3-D model {reference}",
            removal[i]
        );
        inside.push(reference);
    }
    let (min, max) = inside.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    let mean = inside.iter().sum::<f64>() / inside.len() as f64;
    println!(
        "3-D model: mean {mean:.4} nm, nonuniformity {:.3e}",
        (max - min) / mean
    );
    assert!((max - min) / mean <= 0.01);
    assert!((mean - 100.0).abs() <= 1.0, "{mean}");
}

/// The curved model reaches every endpoint: on an R = 100 mm sphere the recommendation's η = −1
/// equal dwell is nearly uniform (the curved fact) and differs from the plane's; the spin axis
/// (`tool.orientation`) changes the removal function; the η sweep and predict carry the part;
/// responses give arc lengths; a bad pivot length is refused even where only the orientation
/// matters.
#[tokio::test]
async fn every_endpoint_computes_on_the_part() {
    let app = app();
    let process = json!({"workpiece_radius_mm": 48, "tool_radius_mm": 8,
                         "workpiece_rpm": -10, "tool_rpm": 200});
    let sphere = json!({"kind": "sphere", "radius_of_curvature_mm": 100});
    let ask = |path: &'static str, body: serde_json::Value| {
        let app = app.clone();
        async move {
            let reply = post_json(&app, path, body.to_string()).await;
            let value = reply.json();
            assert_eq!(reply.status, 200, "{path}: {value}");
            value
        }
    };
    let recommend = |surface: serde_json::Value| json!({"process": process, "surface": surface, "radial_grid": {"count": 241}});
    let curved = ask("/v1/recommend", recommend(sphere.clone())).await;
    let flat = ask("/v1/recommend", recommend(json!({"kind": "plane"}))).await;
    let on = |r: &serde_json::Value| {
        r["recommendation"]["metrics"]["nonuniformity"]
            .as_f64()
            .unwrap()
    };
    assert!(on(&curved) <= 1e-3, "{}", on(&curved));
    assert_ne!(on(&curved), on(&flat));
    let window = &curved["recommendation"]["eta_window"];
    assert!(window["low"].as_f64().unwrap() < -1.0 && window["high"].as_f64().unwrap() > -1.0);

    let removal = |orientation: &str| {
        json!({"process": process, "surface": sphere, "tool": {"orientation": orientation},
               "tool_positions_mm": [30]})
    };
    let normal = ask("/v1/removal-function", removal("normal")).await;
    let vertical = ask("/v1/removal-function", removal("vertical")).await;
    assert_ne!(normal["profiles"], vertical["profiles"]);
    assert_eq!(normal["arc_length_mm"].as_array().unwrap().len(), 201);

    let sweep = ask(
        "/v1/studies/eta-sweep",
        json!({"process": process, "surface": sphere, "etas": [-1, 0.05]}),
    )
    .await;
    assert_eq!(sweep["points"].as_array().unwrap().len(), 2, "{sweep}");

    let mut bad = removal("normal");
    bad["tool"]["pivot_length_mm"] = json!(-1);
    let reply = post_json(&app, "/v1/removal-function", bad.to_string()).await;
    assert_eq!(reply.status, 422);
    assert_eq!(reply.json()["field"], "tool.pivot_length_mm");
}
