//! `POST /v1/measurement/fit` through the router: the loop closed with `/v1/optimize`, the CSV
//! body, the CSV and SVG answers, and each kind of bad input named.

use preston::http::error::ApiError;
use preston::metrology::{fit_within, FitError, FitParameters, FitProblem, Probe, RobustLoss};
use preston::surface::{Surface, SurfaceSpec};
use preston::usecases::measurement_fit::MeasurementError;
use serde_json::{json, Value};

use crate::common::http::{app, post_json, post_with};

const FIXTURE: &str = include_str!("../../fixtures/measurement_fit_asphere.json");

fn fixture() -> Value {
    serde_json::from_str(FIXTURE).unwrap()
}

/// Fit → optimize with the returned target: the plan leaves ≤ 10 % of the form error's RMS.
#[tokio::test]
async fn the_correction_target_closes_the_loop_with_optimize() {
    let app = app();
    let fit = post_json(&app, "/v1/measurement/fit", FIXTURE).await;
    assert_eq!(fit.status, 200, "{}", fit.text());
    let fit = fit.json();
    assert_eq!(fit["solver"]["ignored_points"], 3, "the three dust spikes");
    let target = fit["correction_target"].clone();
    let positions: Vec<f64> = (0..=100).map(|i| 0.5 * i as f64).collect();
    let request = json!({
        "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10,
                    "workpiece_rpm": 150, "tool_rpm": 150},
        "target": target,
        "positions_mm": positions,
        "radial_grid": {"start_mm": 0, "stop_mm": 45, "count": 181},
        "clear_aperture": {"inner_mm": 0, "outer_mm": 40},
    });
    let plan = post_json(&app, "/v1/optimize", request.to_string()).await;
    assert_eq!(plan.status, 200, "{}", plan.text());
    let plan = plan.json();
    // The form error's RMS over the aperture, from the profile the target was built from.
    let radius = fit["profile"]["radius_mm"].as_array().unwrap();
    let depth = fit["profile"]["depth_nm"].as_array().unwrap();
    let inside: Vec<f64> = radius
        .iter()
        .zip(depth)
        .filter(|(r, _)| r.as_f64().unwrap() <= 40.0)
        .map(|(_, d)| d.as_f64().unwrap())
        .collect();
    let mean = inside.iter().sum::<f64>() / inside.len() as f64;
    let form_rms =
        (inside.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / inside.len() as f64).sqrt();
    let residual_rms = plan["residual"]["rms_nm"].as_f64().unwrap();
    eprintln!("form error {form_rms:.2} nm RMS (about its mean) → residual {residual_rms:.3} nm");
    assert!(
        residual_rms <= 0.1 * form_rms,
        "{residual_rms} vs {form_rms}"
    );
}

/// The probe's CSV export with the fields as query parameters gives the JSON body's answer.
#[tokio::test]
async fn a_csv_trace_gives_the_json_answer() {
    let app = app();
    let body = fixture();
    let x = body["profile"]["x_mm"].as_array().unwrap();
    let z = body["profile"]["z_mm"].as_array().unwrap();
    let mut csv = String::from("# exported by the probe\r\n\"x_mm\",\"z_mm\",\"flag\"\r\n");
    for (x, z) in x.iter().zip(z) {
        csv.push_str(&format!("{x}, {z},0\r\n"));
    }
    let query: Vec<String> = [
        "surface",
        "probe_tip_radius_mm",
        "compensation",
        "robust",
        "radial_grid",
        "clear_aperture",
    ]
    .iter()
    .map(|k| {
        let v = &body[*k];
        let text = v.as_str().map_or(v.to_string(), str::to_string); // bare enum names
        format!("{k}={}", urlencode(&text))
    })
    .collect();
    let path = format!("/v1/measurement/fit?{}", query.join("&"));
    let from_csv = post_with(&app, &path, csv, &[("content-type", "text/csv")]).await;
    assert_eq!(from_csv.status, 200, "{}", from_csv.text());
    let from_json = post_json(&app, "/v1/measurement/fit", FIXTURE).await;
    assert_eq!(from_csv.json(), from_json.json());
    // Query parameters with a JSON body are refused, naming the parameter.
    let both = post_json(&app, "/v1/measurement/fit?robust=tukey", FIXTURE).await;
    assert_eq!(both.status, 422);
    assert_eq!(both.json()["field"], "robust");
}

pub fn urlencode(text: &str) -> String {
    text.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' => (b as char).to_string(),
            _ => format!("%{b:02X}"),
        })
        .collect()
}

#[tokio::test]
async fn csv_and_svg_answers() {
    let app = app();
    let csv = post_with(
        &app,
        "/v1/measurement/fit",
        FIXTURE,
        &[("accept", "text/csv")],
    )
    .await;
    assert_eq!(csv.status, 200);
    let text = csv.text();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("x_mm,z_mm,aligned_x_mm,contact_x_mm,axial_nm,normal_nm,weight")
    );
    assert_eq!(
        lines.count(),
        fixture()["profile"]["x_mm"].as_array().unwrap().len()
    );
    let svg = post_with(
        &app,
        "/v1/measurement/fit",
        FIXTURE,
        &[("accept", "image/svg+xml")],
    )
    .await;
    assert_eq!(svg.status, 200);
    let svg = svg.text();
    let doc = roxmltree::Document::parse(&svg).expect("well-formed SVG");
    let text: String = doc.descendants().filter_map(|n| n.text()).collect();
    assert!(text.contains("clear aperture [0, 40] mm") && text.contains("form error"));
}

async fn refused(body: Value, content: Option<&str>) -> (u16, String, String) {
    let app = app();
    let reply = match content {
        None => post_json(&app, "/v1/measurement/fit", body.to_string()).await,
        Some(csv) => {
            post_with(
                &app,
                "/v1/measurement/fit",
                csv.to_string(),
                &[("content-type", "text/csv")],
            )
            .await
        }
    };
    let problem = reply.json();
    (
        reply.status.as_u16(),
        problem["type"].as_str().unwrap_or("").to_string(),
        problem["field"].as_str().unwrap_or("").to_string(),
    )
}

#[tokio::test]
async fn bad_input_is_named() {
    let sphere = json!({"kind": "sphere", "radius_of_curvature_mm": 10});
    let invalid = "urn:preston:problem:invalid-input";
    // Fewer points than parameters (a sphere fits lateral offset and piston: 3 are needed).
    let few = json!({"surface": sphere, "profile": {"x_mm": [0, 1], "z_mm": [0, 0.05]}});
    assert_eq!(
        refused(few, None).await,
        (422, invalid.into(), "profile.x_mm".into())
    );
    // Mismatched lengths.
    let uneven = json!({"profile": {"x_mm": [0, 1, 2], "z_mm": [0, 0]}});
    assert_eq!(
        refused(uneven, None).await,
        (422, invalid.into(), "profile.z_mm".into())
    );
    // NaN, as a probe's CSV may carry it.
    let nan = "x_mm,z_mm\n0,0\n1,nan\n2,0\n";
    assert_eq!(
        refused(json!(null), Some(nan)).await,
        (422, invalid.into(), "profile.z_mm[1]".into())
    );
    // A trace beyond the sphere's domain (|x| < 10 mm).
    let xs: Vec<f64> = (0..=12).map(|i| i as f64).collect();
    let zs = vec![0.0; 13];
    let beyond = json!({"surface": sphere, "profile": {"x_mm": xs, "z_mm": zs}});
    assert_eq!(
        refused(beyond, None).await,
        (422, invalid.into(), "profile.x_mm[10]".into())
    );
    // Parameters the surface cannot tell apart.
    let both = json!({"surface": sphere, "fit": {"lateral_offset": true, "tilt": true},
                      "profile": {"x_mm": [0, 1, 2, 3], "z_mm": [0, 0.05, 0.2, 0.46]}});
    assert_eq!(
        refused(both, None).await,
        (422, invalid.into(), "fit.lateral_offset".into())
    );
    // A bad surface, a bad tip, an array for an object.
    let flat_sphere = json!({"surface": {"kind": "sphere", "radius_of_curvature_mm": 0},
                             "profile": {"x_mm": [0, 1, 2], "z_mm": [0, 0, 0]}});
    assert_eq!(
        refused(flat_sphere, None).await,
        (422, invalid.into(), "surface.radius_of_curvature_mm".into())
    );
    let tip = json!({"probe_tip_radius_mm": -1, "profile": {"x_mm": [0, 1, 2], "z_mm": [0, 0, 0]}});
    assert_eq!(
        refused(tip, None).await,
        (422, invalid.into(), "probe_tip_radius_mm".into())
    );
    let array = json!({"profile": [[0, 0], [1, 0]]});
    assert_eq!(
        refused(array, None).await,
        (
            422,
            "urn:preston:problem:schema-mismatch".into(),
            "profile".into()
        )
    );
    // Unknown members of a surface are refused (each variant is a closed object).
    let extra = json!({"surface": {"kind": "plane", "tilt": 1},
                       "profile": {"x_mm": [0, 1, 2], "z_mm": [0, 0, 0]}});
    assert_eq!(
        refused(extra, None).await,
        (
            422,
            "urn:preston:problem:schema-mismatch".into(),
            "surface.tilt".into()
        )
    );
    // A CSV without the columns.
    assert_eq!(
        refused(json!(null), Some("a,b\n1,2\n")).await,
        (422, invalid.into(), "profile".into())
    );
}

/// A fit stopped before it converges is a 422 naming the trace (solver-not-converged).
#[test]
fn a_fit_that_does_not_converge_is_named() {
    let surface = Surface::new(&SurfaceSpec::Asphere {
        radius_of_curvature_mm: 300.0,
        conic_constant: -1.2,
        coefficients: vec![],
    })
    .unwrap();
    let body = fixture();
    let floats = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let problem = FitProblem::new(
        surface.clone(),
        floats(&body["profile"]["x_mm"]),
        floats(&body["profile"]["z_mm"]),
        Probe::sharp(),
        FitParameters::default_for(&surface),
        RobustLoss::None,
    )
    .unwrap();
    let err = fit_within(&problem, 1).unwrap_err();
    assert_eq!(err, FitError::NotConverged { steps: 1 });
    let problem = ApiError::from(MeasurementError::Fit(err)).problem();
    assert_eq!(problem.status, 422);
    assert_eq!(problem.kind, "urn:preston:problem:solver-not-converged");
    assert_eq!(problem.field.as_deref(), Some("profile"));
}
