//! Nothing a machine cannot run, and nothing said silently: plans and programs made without
//! `machine` keep the default machine (docs/MACHINE.md) and `/v1/program` refuses what breaks
//! it; `machine: "unlimited"` warns; every compute endpoint answers `warnings` as an array and
//! flags metres typed as millimetres and pascals typed as kilopascals; a trace fitted without
//! its surface warns with the best-fit sphere; common probe exports are read; unknown values
//! and retired fields are refused in the user's words.

use serde_json::{json, Value};

use crate::common::http::{app, post_json, post_with};
use crate::common::{default_machine_limit, endpoint_of, read_fixture, request_fixtures};

async fn post(path: &str, request: &Value) -> (u16, Value) {
    let reply = post_json(&app(), path, request.to_string()).await;
    (reply.status.as_u16(), reply.json())
}

fn codes(response: &Value) -> Vec<String> {
    response["warnings"]
        .as_array()
        .unwrap_or_else(|| panic!("warnings is an array: {response}"))
        .iter()
        .map(|w| w["code"].as_str().unwrap().to_string())
        .collect()
}

/// Every axis of a program's (or a plan's motion's) `axes` within the default machine.
fn within_defaults(axes: &Value, what: &str) {
    for (axis, unit) in [("x", "mm"), ("z", "mm"), ("b", "deg")] {
        for (kind, rate) in [("velocity", "per_min"), ("acceleration", "per_s2")] {
            let limit = default_machine_limit(axis, &format!("max_{kind}_{unit}_{rate}")).unwrap();
            let peak = axes[axis][format!("peak_{kind}_{unit}_{rate}")]
                .as_f64()
                .unwrap();
            assert!(peak <= limit, "{what}: {axis} {kind} {peak} > {limit}");
        }
    }
}

/// The program request for `plan` with the optimize request's part (no machine).
fn program_for(optimize: &Value, plan: &Value) -> Value {
    let mut program = json!({"process": optimize["process"], "dwell": plan["dwell"]});
    for key in ["surface", "tool"] {
        if !optimize[key].is_null() {
            program[key] = optimize[key].clone();
        }
    }
    program
}

/// The README's two optimize examples, as written (no `machine`): plans the default machine
/// runs, and programs `/v1/program` accepts whose every block is within it.
#[tokio::test]
async fn the_readme_plans_run_on_the_default_machine() {
    for fixture in [
        "optimize_paper_exp1.json",
        "optimize_figure_correction.json",
    ] {
        let request = read_fixture(fixture);
        assert!(
            request.get("machine").is_none(),
            "{fixture} names no machine"
        );
        let (status, plan) = post("/v1/optimize", &request).await;
        assert_eq!(status, 200, "{fixture}: {plan}");
        within_defaults(&plan["motion"]["axes"], fixture);
        assert!(!codes(&plan).contains(&"machine_unlimited".to_string()));
        let (status, program) = post("/v1/program", &program_for(&request, &plan)).await;
        assert_eq!(status, 200, "{fixture}: {program}");
        within_defaults(&program["axes"], fixture);
        assert_eq!(program["warnings"], json!([]), "{fixture}");
        // Every block's own velocity, recomputed from its end poses and duration.
        let mut before = program["start"].clone();
        for (k, block) in program["blocks"].as_array().unwrap().iter().enumerate() {
            let d = block["duration_s"].as_f64().unwrap();
            for (axis, key) in [("x_mm", "x"), ("z_mm", "z")] {
                let v = 60.0 * (block[axis].as_f64().unwrap() - before[axis].as_f64().unwrap()) / d;
                let limit = default_machine_limit(key, "max_velocity_mm_per_min").unwrap();
                assert!(v.abs() <= limit, "{fixture} block {k}: {key} at {v} mm/min");
            }
            before = block.clone();
        }
    }
}

/// A plan made for no machine is refused by `/v1/program` on the default one, naming the axis,
/// the limit and the first block; with `"unlimited"` both warn, and the G-code says so.
#[tokio::test]
async fn unlimited_plans_warn_and_the_default_machine_refuses_them() {
    let mut request = read_fixture("optimize_figure_correction.json");
    request["machine"] = json!("unlimited");
    let (status, plan) = post("/v1/optimize", &request).await;
    assert_eq!(status, 200, "{plan}");
    assert_eq!(plan["warnings"][0]["code"], "machine_unlimited", "{plan}");
    assert_eq!(plan["warnings"][0]["field"], "machine");
    let peak = plan["motion"]["axes"]["x"]["peak_velocity_mm_per_min"]
        .as_f64()
        .unwrap();
    assert!(
        peak > 1e6,
        "the unlimited plan crosses a cell at {peak} mm/min"
    );

    let program = program_for(&request, &plan);
    let (status, refused) = post("/v1/program", &program).await;
    assert_eq!(status, 422, "{refused}");
    assert_eq!(refused["type"], "urn:preston:problem:machine-limits");
    let violation = refused["violations"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["limit"] == "max_velocity_mm_per_min" && v["axis"] == "x")
        .unwrap_or_else(|| panic!("X's velocity named: {refused}"));
    assert_eq!(violation["limit_value"], json!(10000.0));
    assert!(violation["first_block"].as_u64().is_some(), "{violation}");
    let detail = refused["detail"].as_str().unwrap();
    assert!(
        detail.contains("machine.x.max_velocity_mm_per_min") && detail.contains("from block"),
        "{detail}"
    );

    let mut unlimited = program.clone();
    unlimited["machine"] = json!("unlimited");
    let (status, ran) = post("/v1/program", &unlimited).await;
    assert_eq!(status, 200, "{ran}");
    assert_eq!(codes(&ran), ["machine_unlimited"]);
    let gcode = post_with(
        &app(),
        "/v1/program",
        unlimited.to_string(),
        &[("accept", "text/x-gcode")],
    )
    .await
    .text();
    assert!(
        gcode.contains("WARNING: machine unlimited"),
        "{}",
        &gcode[..400]
    );

    // Anything else than an object or "unlimited" is refused in those words.
    unlimited["machine"] = json!("none");
    let (status, refused) = post("/v1/program", &unlimited).await;
    assert_eq!(status, 422, "{refused}");
    assert_eq!(refused["field"], "machine");
    assert!(
        refused["detail"]
            .as_str()
            .unwrap()
            .contains("\"unlimited\""),
        "{refused}"
    );
    // A limit given replaces the default's; those left out keep it.
    let mut gentle = request.clone();
    gentle["machine"] = json!({"x": {"max_acceleration_mm_per_s2": 500.0}});
    let (status, plan) = post("/v1/optimize", &gentle).await;
    assert_eq!(status, 200, "{plan}");
    let x = &plan["motion"]["axes"]["x"];
    assert!(
        x["peak_acceleration_mm_per_s2"].as_f64().unwrap() <= 500.0,
        "{x}"
    );
    assert!(
        x["peak_velocity_mm_per_min"].as_f64().unwrap() <= 10_000.0,
        "{x}"
    );
}

/// 30 random set-ups without `machine` (flat and spherical parts, uneven positions, random
/// tools, speeds, uniform and measured targets): every plan's program is accepted on the
/// default machine, and the plan's reported peaks are within it.
#[tokio::test]
async fn random_setups_without_machine_give_runnable_programs() {
    let mut rng = fastrand::Rng::with_seed(47);
    let mut bound = 0;
    for case in 0..30 {
        let rm = 20.0 + 60.0 * rng.f64();
        let rt = 3.0 + 0.25 * rm * rng.f64();
        let tool_rpm = 50.0 + 400.0 * rng.f64();
        let eta = -1.5 + 2.0 * rng.f64();
        let n = rng.usize(30..250);
        let steps: Vec<f64> = (1..n).map(|_| 0.3 + 1.4 * rng.f64()).collect();
        let total: f64 = steps.iter().sum();
        let mut positions = vec![0.0];
        for s in &steps {
            positions.push(positions.last().unwrap() + rm * s / total);
        }
        *positions.last_mut().unwrap() = rm;
        let target = if rng.bool() {
            json!({"uniform_depth_nm": 20.0 + 500.0 * rng.f64()})
        } else {
            // Over the whole part, its last radius the workpiece's to the bit.
            let mut radius: Vec<f64> = (0..40).map(|k| rm * k as f64 / 40.0).collect();
            radius.push(rm);
            let (a, b) = (50.0 * rng.f64(), 5.0 + 10.0 * rng.f64());
            let depth: Vec<f64> = radius
                .iter()
                .map(|r| a * (r / rm).powi(2) + b * (6.0 * r / rm).cos())
                .collect();
            json!({"profile": {"radius_mm": radius, "depth_nm": depth}, "free_piston": true})
        };
        let mut request = json!({
            "process": {"workpiece_radius_mm": rm, "tool_radius_mm": rt,
                        "workpiece_rpm": -eta * tool_rpm, "tool_rpm": tool_rpm},
            "positions_mm": positions, "target": target,
            "tool": {"pivot_length_mm": 80.0 * rng.f64(),
                     "orientation": if rng.bool() { "normal" } else { "vertical" }},
        });
        if case % 2 == 1 {
            let sign = if rng.bool() { 1.0 } else { -1.0 };
            request["surface"] = json!({"kind": "sphere", "radius_of_curvature_mm": sign * (3.0 * rm + 300.0 * rng.f64())});
        }
        let (status, plan) = post("/v1/optimize", &request).await;
        assert_eq!(status, 200, "case {case}: {plan}");
        within_defaults(&plan["motion"]["axes"], &format!("case {case}"));
        if plan["warnings"].to_string().contains("machine.") {
            bound += 1;
        }
        let (status, program) = post("/v1/program", &program_for(&request, &plan)).await;
        assert_eq!(status, 200, "case {case}: {program}");
        within_defaults(&program["axes"], &format!("case {case} program"));
    }
    println!("{bound} of 30 plans sit on a default limit");
    assert!(
        bound >= 3,
        "the default machine binds on some set-ups ({bound})"
    );
}

/// Every compute endpoint's fixture answers `warnings` as an array (empty: nothing to say).
#[tokio::test]
async fn every_compute_endpoint_answers_warnings_as_an_array() {
    let mut seen = std::collections::BTreeSet::new();
    for fixture in request_fixtures() {
        let endpoint = endpoint_of(&fixture);
        let (status, response) = post(endpoint, &read_fixture(&fixture)).await;
        assert_eq!(status, 200, "{fixture}: {response}");
        assert!(
            response["warnings"].is_array(),
            "{fixture}: warnings {}",
            response["warnings"]
        );
        seen.insert(endpoint);
    }
    assert_eq!(
        seen.len(),
        preston::http::ENDPOINTS.len(),
        "every compute endpoint has a fixture: {seen:?}"
    );
}

/// Metres typed as millimetres and pascals typed as kilopascals warn on every endpoint that
/// takes a process, naming the process field.
#[tokio::test]
async fn unit_mistakes_in_the_process_warn_on_every_endpoint() {
    let mut metres = std::collections::BTreeSet::new();
    for fixture in request_fixtures() {
        let request = read_fixture(&fixture);
        if request.get("process").is_none() {
            continue; // the measurement fit takes a trace, not a process
        }
        let endpoint = endpoint_of(&fixture);
        let mut pascals = request.clone();
        pascals["process"]["pressure_kpa"] = json!(10_000.0);
        let (status, response) = post(endpoint, &pascals).await;
        assert_eq!(status, 200, "{fixture}: {response}");
        let warning = response["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .find(|w| w["code"] == "pressure_looks_like_pascals")
            .unwrap_or_else(|| panic!("{fixture}: {}", response["warnings"]));
        assert_eq!(warning["field"], "process.pressure_kpa");

        // The paper's part in metres (a 0.05 mm workpiece, a 0.01 mm pad), in the body each
        // endpoint takes.
        let mut body = json!({
            "process": {"workpiece_radius_mm": 0.05, "tool_radius_mm": 0.01,
                        "workpiece_rpm": -10, "tool_rpm": 200},
        });
        let positions = json!([0.0, 0.01, 0.02, 0.03, 0.04, 0.05]);
        match endpoint {
            "/v1/removal-function" => body["tool_positions_mm"] = json!([0.02]),
            "/v1/predict" => {
                body["feed"] = json!({"start_mm": 0.0, "stop_mm": 0.05, "feed_mm_per_min": 0.02})
            }
            "/v1/optimize" => {
                body["positions_mm"] = positions;
                body["target"] = json!({"uniform_depth_nm": 100});
            }
            "/v1/program" => {
                body["dwell"] = json!({"positions_mm": positions, "dwell_s": [1, 1, 1, 1, 1, 1]})
            }
            "/v1/calibration" => {
                body["runs"] = json!([{"ring": {"position_mm": 0.02, "duration_s": 60},
                    "removal": {"radius_mm": [0.01, 0.015, 0.02, 0.025, 0.03],
                                "depth_nm": [1, 3, 4, 3, 1]}}])
            }
            "/v1/studies/eta-sweep" => body["etas"] = json!([-1.0, -0.5]),
            "/v1/maps/removal-function" => body["tool_position_mm"] = json!(0.02),
            "/v1/maps/predict" | "/v1/maps/program" => {
                body["dwell"] = json!({"positions_mm": positions, "dwell_s": [1, 1, 1, 1, 1, 1]})
            }
            "/v1/maps/optimize" => {
                // A tilted plane (all alignment, removed): the plan is the mean dwell alone.
                let rows: Vec<Vec<f64>> = (0..11)
                    .map(|i| (0..11).map(|j| (i + j) as f64).collect())
                    .collect();
                body["map"] = json!({"heights_nm": rows, "pixel_mm": 0.01});
                body["alignment"] =
                    json!({"centre_x_px": 5, "centre_y_px": 5, "part_radius_mm": 0.05});
                body["positions_mm"] = positions;
                body["removal_pixel_mm"] = json!(0.01);
            }
            _ => {}
        }
        let (status, response) = post(endpoint, &body).await;
        assert_eq!(status, 200, "{endpoint}: {response}");
        let warning = response["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .find(|w| w["code"] == "process_looks_like_metres")
            .unwrap_or_else(|| panic!("{endpoint}: {}", response["warnings"]));
        assert_eq!(warning["field"], "process.workpiece_radius_mm");
        metres.insert(endpoint);
    }
    assert_eq!(
        metres.len(),
        11,
        "every endpoint that takes a process: {metres:?}"
    );
}

/// A concave sphere traced with a lateral offset and noise, fitted without `surface`: a
/// warning, the plane's residual, and the best-fit sphere's radius within 0.1 % of the truth.
#[tokio::test]
async fn a_trace_fitted_without_its_surface_warns_with_the_best_fit_sphere() {
    let mut rng = fastrand::Rng::with_seed(12);
    for truth in [120.0_f64, -300.0, 800.0] {
        let offset = 0.03;
        let (x, z): (Vec<f64>, Vec<f64>) = (0..=400)
            .map(|k| {
                let x = -40.0 + 80.0 * k as f64 / 400.0;
                let u = x - offset;
                // The exact sphere, independent of the service's sag: z = R − sign·√(R² − u²).
                let sag = truth - truth.signum() * (truth * truth - u * u).sqrt();
                let noise = 20e-6 * (rng.f64() - 0.5);
                (x, sag + 0.002 + noise)
            })
            .unzip();
        let (status, fit) = post(
            "/v1/measurement/fit",
            &json!({"profile": {"x_mm": x, "z_mm": z}}),
        )
        .await;
        assert_eq!(status, 200, "{fit}");
        assert_eq!(codes(&fit), ["surface_assumed_plane"], "{fit}");
        assert_eq!(fit["warnings"][0]["field"], "surface");
        let sphere = &fit["best_fit_sphere"];
        let radius = sphere["radius_of_curvature_mm"].as_f64().unwrap();
        assert!(
            (radius / truth - 1.0).abs() < 1e-3,
            "R = {radius} against {truth}"
        );
        assert!(
            sphere["residual_rms_nm"].as_f64().unwrap() < 20.0,
            "{sphere}"
        );
        let message = fit["warnings"][0]["message"].as_str().unwrap();
        assert!(message.contains("best-fit sphere"), "{message}");
        // With the surface given: no warning, no sphere.
        let given = json!({"profile": {"x_mm": x, "z_mm": z},
                           "surface": {"kind": "sphere", "radius_of_curvature_mm": truth}});
        let (status, fit) = post("/v1/measurement/fit", &given).await;
        assert_eq!(status, 200, "{fit}");
        assert_eq!(fit["warnings"], json!([]));
        assert!(fit["best_fit_sphere"].is_null());
    }
}

/// The probe exports shops send are read, and a malformed one names its line and what it read.
#[tokio::test]
async fn common_probe_exports_are_read_and_bad_lines_named() {
    let query = "/v1/measurement/fit?surface=%7B%22kind%22:%22sphere%22,%22radius_of_curvature_mm%22:300%7D";
    let send = |body: &'static str| async move {
        let reply = post_with(&app(), query, body, &[("content-type", "text/csv")]).await;
        (reply.status.as_u16(), reply.json())
    };
    let rows = [
        (-20.0, 0.6678),
        (-10.0, 0.1667),
        (0.0, 0.0),
        (10.0, 0.1667),
        (20.0, 0.6678),
    ];
    for body in [
        "Point,X [mm],Z [mm]\n1,-20,0.6678\n2,-10,0.1667\n3,0,0\n4,10,0.1667\n5,20,0.6678\n",
        "Probe trace SN-0042 2026-11-25\nx_mm,z_mm\n-20,0.6678\n-10,0.1667\n0,0\n10,0.1667\n20,0.6678\n",
        "X (mm);Z (mm)\n-20;0,6678\n-10;0,1667\n0;0\n10;0,1667\n20;0,6678\n",
    ] {
        let (status, fit) = send(body).await;
        assert_eq!(status, 200, "{body}: {fit}");
        let (x, z) = (&fit["residual"]["x_mm"], &fit["residual"]["z_mm"]);
        for (k, (xk, zk)) in rows.iter().enumerate() {
            assert_eq!((x[k].as_f64(), z[k].as_f64()), (Some(*xk), Some(*zk)), "{body}");
        }
    }
    let (status, refused) = send("x_mm,z_mm\n-20,0.6678\n-10,0.1667\n0,zero\n").await;
    assert_eq!(status, 422, "{refused}");
    assert_eq!(refused["field"], "profile.z_mm[2]");
    let detail = refused["detail"].as_str().unwrap();
    assert!(
        detail.contains("line 4") && detail.contains("`0,zero`"),
        "{detail}"
    );
    let (status, refused) = send("Position,Height\n1,2\n3,4\n").await;
    assert_eq!(status, 422, "{refused}");
    let detail = refused["detail"].as_str().unwrap();
    assert!(
        detail.contains("line 1 reads `Position,Height`") && detail.contains("x_mm, z_mm"),
        "{detail}"
    );
}

/// Unknown enum values list the accepted ones; a retired field says what replaced it.
#[tokio::test]
async fn unknown_values_and_retired_fields_are_refused_in_the_users_words() {
    let (status, refused) = post(
        "/v1/removal-function",
        &json!({"process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10,
                            "tool_rpm": 200},
                "surface": {"kind": "spherical", "radius_of_curvature_mm": 60},
                "tool_positions_mm": [5]}),
    )
    .await;
    assert_eq!(status, 422, "{refused}");
    assert_eq!(refused["field"], "surface.kind");
    assert_eq!(
        refused["detail"],
        "\"spherical\" is not accepted here: use \"plane\", \"sphere\" or \"asphere\""
    );
    let (status, refused) = post(
        "/v1/recommend",
        &json!({"process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10,
                            "tool_rpm": 200},
                "equal_dwell_positions": 200}),
    )
    .await;
    assert_eq!(status, 422, "{refused}");
    assert_eq!(refused["field"], "equal_dwell_positions");
    let detail = refused["detail"].as_str().unwrap();
    assert!(
        detail.contains("retired")
            && detail.contains("`feed`")
            && detail.contains("equal_dwell.feed"),
        "{detail}"
    );
}

/// The recommended speeds are set to 0.1 r/min, η stays exactly −1, and a nonuniformity the
/// recommendation brings to rounding is reported as removed.
#[tokio::test]
async fn recommended_speeds_are_rounded_and_removal_of_nonuniformity_is_said() {
    let (status, r) = post("/v1/recommend", &read_fixture("recommend_paper_exp1.json")).await;
    assert_eq!(status, 200, "{r}");
    let rec = &r["recommendation"];
    let (w, t) = (
        rec["workpiece_rpm"].as_f64().unwrap(),
        rec["tool_rpm"].as_f64().unwrap(),
    );
    assert_eq!(w, t);
    assert_eq!(rec["eta"], json!(-1.0));
    assert!(
        ((w * 10.0).round() - w * 10.0).abs() < 1e-9,
        "{w} is set to 0.1 r/min"
    );
    // On a plane equal dwell at η = −1 is uniform to rounding: removed, not a factor.
    assert_eq!(rec["nonuniformity_removed"], json!(true), "{rec}");
    assert!(rec["improvement_factor"].is_null());
    assert!(rec["current_metrics"]["nonuniformity"].as_f64().unwrap() > 1.0);
}

/// A spindle over the default machine's limit is refused at the speed asked for, saying whose
/// limit it is; the recommendation inside a plan keeps the spindle limits in force.
#[tokio::test]
async fn the_default_machine_is_named_where_it_refuses_or_binds() {
    let mut request = read_fixture("optimize_paper_exp1.json");
    request["process"]["tool_rpm"] = json!(3500.0);
    let (status, refused) = post("/v1/optimize", &request).await;
    assert_eq!(status, 422, "{refused}");
    assert_eq!(refused["field"], "process.tool_rpm");
    assert!(
        refused["detail"]
            .as_str()
            .unwrap()
            .contains("default machine"),
        "{refused}"
    );
    // Given, the same speed is the caller's own limit's business.
    request["machine"] = json!({"tool_spindle": {"max_rpm": 5000}});
    let (status, plan) = post("/v1/optimize", &request).await;
    assert_eq!(status, 200, "{plan}");

    // Workpiece −900, tool 2900 r/min: matching the removal rate at η = −1 needs about
    // 2,200 r/min, beyond the default workpiece spindle's 1,000; the plan's recommendation
    // keeps the limit.
    let mut fast = read_fixture("optimize_paper_exp1.json");
    fast["process"]["workpiece_rpm"] = json!(-900.0);
    fast["process"]["tool_rpm"] = json!(2900.0);
    let (status, plan) = post("/v1/optimize", &fast).await;
    assert_eq!(status, 200, "{plan}");
    let rec = &plan["recommendation"];
    assert_eq!(rec["rule"], "fastest_allowed", "{rec}");
    assert_eq!(rec["workpiece_rpm"], json!(1000.0), "{rec}");
    // The warning for a default limit the plan sits on says whose it is.
    let (_, plan) = post("/v1/optimize", &read_fixture("optimize_paper_exp1.json")).await;
    let message = plan["warnings"][0]["message"].as_str().unwrap();
    assert!(message.contains("the default machine's"), "{message}");
}

/// Ring grooves that are the model's own prediction: the fit is exact, so it carries no
/// estimate of the noise: no standard error (never 0) and the `exact_fit` warning.
#[tokio::test]
async fn an_exact_calibration_claims_no_standard_error() {
    let process = json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10,
                         "workpiece_rpm": -10, "tool_rpm": 200});
    let radii: Vec<f64> = (0..=40).map(|k| 10.0 + 0.5 * k as f64).collect();
    let (status, rf) = post(
        "/v1/removal-function",
        &json!({"process": process, "tool_positions_mm": [20.0],
                "radial_grid": {"start_mm": 10, "stop_mm": 30, "count": 41}}),
    )
    .await;
    assert_eq!(status, 200, "{rf}");
    let minutes = 30.0;
    let depth: Vec<f64> = rf["profiles"][0]["removal_rate_nm_per_min"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_f64().unwrap() * minutes)
        .collect();
    let (status, fit) = post(
        "/v1/calibration",
        &json!({"process": process, "runs": [{"ring": {"position_mm": 20.0, "duration_s": 60.0 * minutes},
                 "removal": {"radius_mm": radii, "depth_nm": depth}}]}),
    )
    .await;
    assert_eq!(status, 200, "{fit}");
    let k = &fit["parameters"]["preston_coefficient_m2_per_n"];
    assert!(
        (k["value"].as_f64().unwrap() / 1e-13 - 1.0).abs() < 1e-9,
        "{k}"
    );
    assert!(k["standard_error"].is_null(), "{k}");
    assert!(codes(&fit).contains(&"exact_fit".to_string()), "{fit}");
}
