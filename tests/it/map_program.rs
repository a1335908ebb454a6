//! `/v1/maps/program`: a polar plan as G-code with C under position control, checked by
//! reading the G-code back as a controller would (this file's own reader: absolute words,
//! G93 inverse time, C wrapped and unwrapped the shorter way round) and comparing what it
//! executes with the plan: its time, its C speeds, C's peaks by the program's acceleration
//! model, and the refusal of a plan a limit forbids.

use serde_json::{json, Value};

use crate::common::http::{app, limit_violation, post_json, post_json_accepting};
use crate::common::read_fixture;

/// One G1 block as a controller reads it: where it ends (X mm, C deg as written) and how long
/// it takes (60/F s in G93).
#[derive(Debug, Clone, Copy)]
struct Move {
    x_mm: f64,
    c_deg: f64,
    duration_s: f64,
}

/// The start (X, C) and the G1 blocks of a program written in G93 throughout.
fn read_gcode(text: &str) -> ((f64, f64), Vec<Move>) {
    let word = |line: &str, letter: char| -> Option<f64> {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(letter).and_then(|v| v.parse().ok()))
    };
    let mut start = None;
    let mut moves = Vec::new();
    let mut inverse_time = false;
    for line in text.lines().filter(|l| !l.starts_with('(')) {
        if line.contains("G93") {
            inverse_time = true;
        }
        if line.contains("G94") {
            inverse_time = false;
        }
        if line.starts_with("G0 ") {
            start = Some((word(line, 'X').unwrap(), word(line, 'C').unwrap()));
        }
        if line.starts_with("G1 ") {
            assert!(inverse_time, "a G1 outside G93: {line}");
            moves.push(Move {
                x_mm: word(line, 'X').unwrap(),
                c_deg: word(line, 'C').unwrap(),
                duration_s: 60.0 / word(line, 'F').unwrap(),
            });
        }
    }
    (start.expect("a G0 to the start"), moves)
}

/// C unwound from wrapped words: each step the shorter way round (every block turns C by at
/// most a quarter turn, so that is the plan's way).
fn unwrap(start: f64, words: &[f64]) -> Vec<f64> {
    let mut at = start;
    words
        .iter()
        .map(|&w| {
            let step = (w - at).rem_euclid(360.0);
            let step = if step > 180.0 { step - 360.0 } else { step };
            assert!(step.abs() <= 90.0 + 1e-6, "a block turns C by {step}°");
            at += step;
            at
        })
        .collect()
}

/// C's velocity per run of blocks at one speed and its largest change between runs over the
/// mean of their durations, deg/min and deg/s²: (peak velocity, peak acceleration between
/// runs). A block joins the run before it when its speed is that run's within what the words'
/// rounding allows: `rounding_deg` at each end of the block over its duration, and the F
/// word's 10 digits.
fn c_peaks(start: f64, unwound: &[f64], durations: &[f64], rounding_deg: f64) -> (f64, f64) {
    let mut runs: Vec<(f64, f64, f64)> = Vec::new(); // (travel, duration, velocity)
    let mut before = start;
    for (&c, &d) in unwound.iter().zip(durations) {
        let v = (c - before) / d;
        before = c;
        // Each speed read is a travel between two rounded words over a duration: the block's
        // and the run's so far are each off by up to 2·rounding/duration.
        let tolerance = |run: f64| 2.0 * rounding_deg * (1.0 / d + 1.0 / run) + 1e-9 * v.abs();
        match runs.last_mut() {
            Some(run) if (run.2 - v).abs() <= tolerance(run.1) => {
                run.0 += v * d;
                run.1 += d;
                run.2 = run.0 / run.1;
            }
            _ => runs.push((v * d, d, v)),
        }
    }
    let velocity = runs.iter().fold(0.0_f64, |m, r| m.max(r.2.abs())) * 60.0;
    let acceleration = runs
        .windows(2)
        .map(|w| (w[1].2 - w[0].2).abs() / (0.5 * (w[0].1 + w[1].1)))
        .fold(0.0, f64::max);
    (velocity, acceleration)
}

/// The committed correction's plan (`fixtures/maps_optimize_astigmatism.json` through
/// `/v1/maps/optimize`) and the program request for it on the same machine.
async fn planned() -> (Value, Value) {
    let request = read_fixture("maps_optimize_astigmatism.json");
    let reply = post_json(&app(), "/v1/maps/optimize", request.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let plan = reply.json();
    let program = json!({
        "process": request["process"],
        "dwell": plan["dwell"],
        "c_law": plan["c_law"],
        "machine": request["machine"],
        "format": {"decimals": 7}
    });
    (plan, program)
}

/// A program's C peaks (`axes.c`) are its plan's `c_peaks` to 1e-9.
pub fn assert_c_peaks_are_the_plan_s(program: &Value, plan: &Value) {
    let (c, peaks) = (&program["axes"]["c"], &plan["c_peaks"]);
    for (got, want) in [
        (
            &c["peak_velocity_deg_per_min"],
            &peaks["velocity_deg_per_min"],
        ),
        (
            &c["peak_acceleration_deg_per_s2"],
            &peaks["acceleration_deg_per_s2"],
        ),
    ] {
        let (got, want) = (got.as_f64().unwrap(), want.as_f64().unwrap());
        assert!(close(got, want, 1e-9), "program {got} vs plan {want}");
    }
}

fn close(a: f64, b: f64, relative: f64) -> bool {
    (a - b).abs() <= relative * a.abs().max(b.abs())
}

/// The program of a planned correction is accepted on the machine it was planned for, and
/// C's peaks over its blocks (the program's own model: velocity per run of one C speed, the
/// change between runs over the mean of their durations, from and to rest through the
/// approach and retract) are the plan's to 1e-9 — the optimizer and the program hold C by
/// the same model. Its time is the plan's.
#[tokio::test(flavor = "multi_thread")]
async fn a_planned_correction_s_program_has_the_plan_s_c_peaks() {
    let (plan, request) = planned().await;
    let reply = post_json(&app(), "/v1/maps/program", request.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let program = reply.json();
    assert_c_peaks_are_the_plan_s(&program, &plan);
    let total = program["total_time_s"].as_f64().unwrap();
    let planned = plan["total_time_s"].as_f64().unwrap();
    assert!(close(total, planned, 1e-12), "{total} vs {planned}");
}

/// Read back as a controller reads it (G93, C wrapped, every word rounded to 7 decimals), the
/// G-code runs the program's time, turns C by at most a quarter turn a block, and its C peaks
/// (runs told apart within the words' rounding, the approach and retract — where Z moves —
/// runs of their own) are the plan's to 1e-6: the words' rounding (5e-8°) over runs of
/// degrees. Written
/// unwound, the words are the wrapped ones unwrapped (to the words' rounding).
#[tokio::test(flavor = "multi_thread")]
async fn the_g_code_executes_the_plan_s_c_law() {
    let (plan, request) = planned().await;
    let gcode = |request: &Value| {
        let request = request.to_string();
        async move {
            let reply =
                post_json_accepting(&app(), "/v1/maps/program", request, "text/x-gcode").await;
            assert_eq!(reply.status, 200, "{}", reply.text());
            reply.text()
        }
    };
    let wrapped = gcode(&request).await;
    let ((x0, c0), moves) = read_gcode(&wrapped);
    assert!(moves.iter().all(|m| (0.0..360.0).contains(&m.c_deg)));
    let words: Vec<f64> = moves.iter().map(|m| m.c_deg).collect();
    let unwound = unwrap(c0, &words);
    let durations: Vec<f64> = moves.iter().map(|m| m.duration_s).collect();
    let json = post_json(&app(), "/v1/maps/program", request.to_string())
        .await
        .json();
    let time: f64 = durations.iter().sum();
    let program_time = json["program_time_s"].as_f64().unwrap();
    assert!(close(time, program_time, 1e-9), "{time} vs {program_time}");
    // The approach and retract: the blocks where Z moves (a flat part: Z is constant while
    // polishing), each its own run of C.
    let z: Vec<f64> = wrapped
        .lines()
        .filter(|l| l.starts_with("G1 "))
        .map(|l| {
            l.split_whitespace()
                .find_map(|w| w.strip_prefix('Z'))
                .unwrap()
                .parse()
                .unwrap()
        })
        .collect();
    let polishing_z = z[z.len() / 2];
    let polishing: Vec<usize> = (0..moves.len())
        .filter(|&k| z[k] == polishing_z && (k == 0 || z[k - 1] == polishing_z))
        .collect();
    let (first, last) = (polishing[0], polishing[polishing.len() - 1]);
    assert_eq!(
        polishing.len(),
        last - first + 1,
        "polishing is one stretch"
    );
    let (velocity, acceleration) = c_peaks(
        unwound[first - 1],
        &unwound[first..=last],
        &durations[first..=last],
        5e-8,
    );
    let peaks = &plan["c_peaks"];
    let (v, a) = (
        peaks["velocity_deg_per_min"].as_f64().unwrap(),
        peaks["acceleration_deg_per_s2"].as_f64().unwrap(),
    );
    assert!(close(velocity, v, 1e-6), "{velocity} vs {v}");
    assert!(close(acceleration, a, 1e-6), "{acceleration} vs {a}");
    let polishing_time: f64 = durations[first..=last].iter().sum();
    let planned = plan["total_time_s"].as_f64().unwrap();
    assert!(
        close(polishing_time, planned, 1e-9),
        "{polishing_time} vs {planned}"
    );
    // X: from the first station's radius outward to the last.
    let radii: Vec<f64> = plan["dwell"]["positions_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!((moves[last].x_mm - radii[radii.len() - 1]).abs() < 1e-6);
    assert!(x0 >= radii[0] - 1e-6);
    // The same program with C's words unwound.
    let mut unwound_request = request.clone();
    unwound_request["format"]["c_words"] = json!("unwound");
    let ((_, c0_unwound), moves_unwound) = read_gcode(&gcode(&unwound_request).await);
    assert!((c0_unwound.rem_euclid(360.0) - c0).abs() < 1e-6);
    let offset = c0_unwound - c0;
    for (m, u) in moves_unwound.iter().zip(&unwound) {
        assert!(
            (m.c_deg - (u + offset)).abs() < 1e-6,
            "{} vs {}",
            m.c_deg,
            u + offset
        );
    }
}

/// A plan that breaks C's acceleration limit of the machine named is refused: a 422
/// machine-limits problem naming C, the limit and the first block that breaks it.
#[tokio::test(flavor = "multi_thread")]
async fn a_plan_c_cannot_follow_is_refused_naming_the_axis_limit_and_block() {
    let (plan, mut request) = planned().await;
    let peak = plan["c_peaks"]["acceleration_deg_per_s2"].as_f64().unwrap();
    request["machine"]["c"]["max_acceleration_deg_per_s2"] = json!(0.5 * peak);
    let reply = post_json(&app(), "/v1/maps/program", request.to_string()).await;
    assert_eq!(reply.status, 422, "{}", reply.text());
    let violation = limit_violation(&reply.json(), "c");
    assert_eq!(violation["limit"], "max_acceleration_deg_per_s2");
    assert_eq!(violation["field"], "machine.c.max_acceleration_deg_per_s2");
    assert!(close(violation["value"].as_f64().unwrap(), peak, 1e-9));
    assert!(violation["first_block"].as_u64().is_some(), "{violation}");
}

/// Without a law C turns at the process's speed: every polishing block turns it at Ω, the
/// polishing blocks turn it Σt·|rpm|/60 times in all, and X moves as `/v1/program`'s X does
/// (its peak velocity and acceleration equal to 1e-9: the same stops and moves, the sector
/// cuts changing no speed).
#[tokio::test(flavor = "multi_thread")]
async fn at_constant_c_the_program_is_the_radial_one_with_c_turning() {
    let body = json!({
        "process": {"workpiece_radius_mm": 40, "tool_radius_mm": 5, "workpiece_rpm": -10, "tool_rpm": 200},
        "dwell": {"positions_mm": [0, 5, 10, 15, 20, 25, 30, 35], "dwell_s": [30, 20, 25, 40, 35, 50, 45, 60]},
        "format": {"decimals": 7}
    });
    let radial = post_json(&app(), "/v1/program", body.to_string()).await;
    assert_eq!(radial.status, 200, "{}", radial.text());
    let radial = radial.json();
    let polar = post_json(&app(), "/v1/maps/program", body.to_string()).await;
    assert_eq!(polar.status, 200, "{}", polar.text());
    let polar = polar.json();
    for key in ["peak_velocity_mm_per_min", "peak_acceleration_mm_per_s2"] {
        let (a, b) = (
            radial["axes"]["x"][key].as_f64().unwrap(),
            polar["axes"]["x"][key].as_f64().unwrap(),
        );
        assert!(close(a, b, 1e-9), "{key}: {a} vs {b}");
    }
    let reply =
        post_json_accepting(&app(), "/v1/maps/program", body.to_string(), "text/x-gcode").await;
    let ((_, c0), moves) = read_gcode(&reply.text());
    let words: Vec<f64> = moves.iter().map(|m| m.c_deg).collect();
    let unwound = unwrap(c0, &words);
    let total: f64 = 30.0 + 20.0 + 25.0 + 40.0 + 35.0 + 50.0 + 45.0 + 60.0;
    let omega_deg_per_s = -10.0 * 6.0;
    let mut before = c0;
    for (m, &c) in moves.iter().zip(&unwound) {
        let speed = (c - before) / m.duration_s;
        before = c;
        assert!(close(speed, omega_deg_per_s, 1e-6), "{speed}");
    }
    let turns = (unwound[unwound.len() - 1] - c0) / 360.0;
    let program_time = polar["program_time_s"].as_f64().unwrap();
    assert!(
        close(turns, program_time * omega_deg_per_s / 360.0, 1e-9),
        "{turns}"
    );
    assert!(close(polar["total_time_s"].as_f64().unwrap(), total, 1e-12));
}
