//! The optimizer moves as the program does: on 20 random set-ups (flat and spherical parts,
//! uneven positions, random tools, on the default machine or with machine limits of their own,
//! with and without feed limits) every plan that `/v1/optimize` returns for a machine is
//! accepted by `/v1/program` with the same surface, tool and machine; the motion the optimizer reports is the program's (per-axis peaks and each
//! cell's feed, to 1e-9 relative); and its warnings name exactly the limits the program uses at
//! 99.9 % or more.

use serde_json::{json, Value};

use crate::common::default_machine_limit;
use crate::common::http::{app, post_json};

async fn post(path: &str, request: &Value) -> (u16, Value) {
    let reply = post_json(&app(), path, request.to_string()).await;
    (reply.status.as_u16(), reply.json())
}

/// Relative difference, against 1 where both are tiny.
fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1e-300)
}

/// One random set-up: the optimize request without machine limits and the program request's
/// shared part (process, surface, tool).
struct Case {
    optimize: Value,
    program: Value,
}

fn random_case(rng: &mut fastrand::Rng, curved: bool) -> Case {
    let rm = 30.0 + 30.0 * rng.f64();
    let rt = 4.0 + 8.0 * rng.f64();
    let tool_rpm = 100.0 + 200.0 * rng.f64();
    let eta = -1.5 + 2.0 * rng.f64();
    let process = json!({
        "workpiece_radius_mm": rm, "tool_radius_mm": rt,
        "workpiece_rpm": -eta * tool_rpm, "tool_rpm": tool_rpm,
    });
    // Uneven steps between 0.3 and 1.7 of the mean, over [0, r_m].
    let n = rng.usize(25..90);
    let steps: Vec<f64> = (1..n).map(|_| 0.3 + 1.4 * rng.f64()).collect();
    let total: f64 = steps.iter().sum();
    let mut positions = vec![0.0];
    for s in &steps {
        positions.push(positions.last().unwrap() + rm * s / total);
    }
    *positions.last_mut().unwrap() = rm;
    let orientation = if rng.bool() { "normal" } else { "vertical" };
    let tool = json!({"pivot_length_mm": 60.0 * rng.f64(), "orientation": orientation});
    let mut optimize = json!({
        "process": process, "positions_mm": positions, "tool": tool,
        "target": {"uniform_depth_nm": 100.0},
    });
    let mut program = json!({"process": process, "tool": tool});
    if curved {
        let sign = if rng.bool() { 1.0 } else { -1.0 };
        let surface =
            json!({"kind": "sphere", "radius_of_curvature_mm": sign * (150.0 + 250.0 * rng.f64())});
        optimize["surface"] = surface.clone();
        program["surface"] = surface;
    }
    Case { optimize, program }
}

/// A limit below `peak` (50–95 % of it), and no higher than a machine's (`typical` to 10×):
/// a plain plan may park 1e-7 s at a position the pad barely reaches, which no machine could
/// cross.
fn below(rng: &mut fastrand::Rng, peak: f64, typical: f64) -> f64 {
    (peak * (0.5 + 0.45 * rng.f64())).min(typical * (1.0 + 9.0 * rng.f64()))
}

/// Machine limits below what the plain plan's program uses, on a random choice of the axes
/// that move.
fn binding_limits(rng: &mut fastrand::Rng, motion: &Value) -> Value {
    let mut machine = json!({});
    for (axis, unit) in [("x", "mm"), ("z", "mm"), ("b", "deg")] {
        // Velocity per minute, acceleration per s².
        for (kind, rate, typical) in [
            ("velocity", "per_min", 300.0),
            ("acceleration", "per_s2", 10.0),
        ] {
            let peak_key = format!("peak_{kind}_{unit}_{rate}");
            let peak = motion["axes"][axis][&peak_key].as_f64().unwrap();
            if peak > 0.0 && rng.f64() < 0.6 {
                let limit_key = format!("max_{kind}_{unit}_{rate}");
                machine[axis][limit_key] = json!(below(rng, peak, typical));
            }
        }
    }
    machine
}

#[tokio::test]
async fn plans_move_as_their_programs_do() {
    let mut rng = fastrand::Rng::with_seed(25);
    let (mut with_machine, mut with_feed, mut active_seen) = (0, 0, 0);
    for case in 0..20 {
        let Case { optimize, program } = random_case(&mut rng, case % 2 == 1);
        let (status, plain) = post("/v1/optimize", &optimize).await;
        assert_eq!(status, 200, "case {case}: {plain}\nrequest: {optimize}");
        let mut request = optimize.clone();
        let mut machine = json!({});
        if case % 4 >= 2 && !plain["motion"].is_null() {
            machine = binding_limits(&mut rng, &plain["motion"]);
            request["machine"] = machine.clone();
            with_machine += 1;
        }
        if rng.bool() && !plain["motion"].is_null() {
            let peak = plain["motion"]["peak_feed_mm_per_min"].as_f64().unwrap();
            request["constraints"] = json!({"max_feed_mm_per_min": below(&mut rng, peak, 300.0)});
            with_feed += 1;
        }
        let (status, plan) = post("/v1/optimize", &request).await;
        assert_eq!(status, 200, "case {case}: {plan}");

        // /v1/program accepts the plan on its machine, approach and retract included.
        let mut run = program.clone();
        run["dwell"] = plan["dwell"].clone();
        run["machine"] = machine.clone();
        let (status, accepted) = post("/v1/program", &run).await;
        if plan["motion"].is_null() {
            // Only a plan with an interior zero dwell has no program, and it says so.
            assert_eq!(status, 422, "case {case}: {accepted}");
            assert!(plan["warnings"].to_string().contains("not_programmable"));
            continue;
        }
        assert_eq!(status, 200, "case {case}: {accepted}");

        // Without the approach the program is the plan's motion: the same peaks.
        run["approach"] = json!({"clearance_mm": 0.0});
        let (status, polishing) = post("/v1/program", &run).await;
        assert_eq!(status, 200, "case {case}: {polishing}");
        let reported = &plan["motion"]["axes"];
        for (axis, unit) in [("x", "mm"), ("z", "mm"), ("b", "deg")] {
            for key in [
                format!("peak_velocity_{unit}_per_min"),
                format!("peak_acceleration_{unit}_per_s2"),
            ] {
                let (a, b) = (
                    reported[axis][&key].as_f64().unwrap(),
                    polishing["axes"][axis][&key].as_f64().unwrap(),
                );
                assert!(
                    relative(a, b) <= 1e-9,
                    "case {case}: {axis} {key}: {a} vs {b}"
                );
            }
        }
        // Each cell's feed is its move block's X–Z path over the block's duration.
        let moves = polishing["blocks"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|b| b["kind"] == "move")
            .count();
        let feeds: Vec<Option<f64>> =
            serde_json::from_value(plan["feed_mm_per_min"].clone()).unwrap();
        let skipped = polishing["skipped_positions"]["leading"].as_u64().unwrap() as usize;
        let cells: Vec<f64> = feeds.iter().flatten().copied().collect();
        assert_eq!(cells.len(), moves, "case {case}");
        assert!(feeds[..skipped].iter().all(Option::is_none));
        let mut before = &polishing["start"];
        let mut peak_feed = 0.0_f64;
        let mut cell = cells.iter();
        for block in polishing["blocks"].as_array().unwrap() {
            if block["kind"] == "move" {
                let feed = *cell.next().unwrap();
                let dx = block["x_mm"].as_f64().unwrap() - before["x_mm"].as_f64().unwrap();
                let dz = block["z_mm"].as_f64().unwrap() - before["z_mm"].as_f64().unwrap();
                let want = 60.0 * dx.hypot(dz) / block["duration_s"].as_f64().unwrap();
                assert!(
                    relative(feed, want) <= 1e-9,
                    "case {case}: {feed} vs {want}"
                );
                peak_feed = peak_feed.max(want);
            }
            before = block;
        }
        let reported_feed = plan["motion"]["peak_feed_mm_per_min"].as_f64().unwrap();
        assert!(relative(reported_feed, peak_feed) <= 1e-9, "case {case}");

        // The warnings name exactly the limits used at 99.9 % or more.
        let warned: Vec<String> = plan["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|w| w["code"] == "constraint_active")
            .map(|w| w["field"].as_str().unwrap().to_string())
            .collect();
        let mut used: Vec<String> = Vec::new();
        for (axis, unit) in [("x", "mm"), ("z", "mm"), ("b", "deg")] {
            for (kind, rate) in [("velocity", "per_min"), ("acceleration", "per_s2")] {
                let limit_key = format!("max_{kind}_{unit}_{rate}");
                // The limit given, else the default machine's.
                let Some(limit) = machine[axis][&limit_key]
                    .as_f64()
                    .or_else(|| default_machine_limit(axis, &limit_key))
                else {
                    continue;
                };
                let peak = polishing["axes"][axis][format!("peak_{kind}_{unit}_{rate}")]
                    .as_f64()
                    .unwrap();
                assert!(peak <= limit, "case {case}: {axis} {kind} {peak} > {limit}");
                if peak >= 0.999 * limit {
                    used.push(format!("machine.{axis}.{limit_key}"));
                }
            }
        }
        if let Some(limit) = request["constraints"]["max_feed_mm_per_min"].as_f64() {
            assert!(
                peak_feed <= limit * (1.0 + 1e-9),
                "case {case}: feed {peak_feed} > {limit}"
            );
            if peak_feed >= 0.999 * limit {
                used.push("constraints.max_feed_mm_per_min".to_string());
            }
        }
        let mut named: Vec<String> = warned
            .into_iter()
            .filter(|w| w.starts_with("machine.") || w.ends_with("max_feed_mm_per_min"))
            .collect();
        named.sort();
        used.sort();
        assert_eq!(named, used, "case {case}");
        active_seen += used.len();
    }
    println!("{with_machine} with machine limits, {with_feed} with a feed limit, {active_seen} limits in use");
    assert!(with_machine >= 8 && with_feed >= 5 && active_seen >= 10);
}
