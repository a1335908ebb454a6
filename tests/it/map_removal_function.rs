//! `POST /v1/maps/removal-function` on the paper's machine: the footprint pixel by pixel
//! against Preston's law on the 2-D sliding speed written here (the reference model's
//! `sliding_speed_mm_s`), its revolution average against the radial endpoint and against the
//! adaptive quadrature of the paper's eq. 5, and its refusals.

use serde_json::{json, Value};

use super::common::http::{app, post_json, post_with};
use super::common::{numbers, paper_spec, quadrature_rate_nm_per_min, read_fixture};
use super::polar_reference::sliding_speed_mm_s;

const PATH: &str = "/v1/maps/removal-function";

fn request() -> Value {
    read_fixture("maps_removal_function_paper_exp1.json")
}

/// Every pixel of the footprint is K·P·V at that point with the pad centre at (r1, 0), V from
/// the reference's sliding speed, where the point is on the pad and on the part, and 0
/// elsewhere: 1e-12 relative. Over the part's edge too, and at η = −1.
#[tokio::test]
async fn the_footprint_is_preston_s_law_at_every_pixel() {
    for (workpiece_rpm, tool_rpm, r1) in [
        (-10.0, 200.0, 20.0),
        (30.0, 30.0, 8.0),
        (-10.0, 200.0, 47.0),
    ] {
        let mut body = request();
        body["process"]["workpiece_rpm"] = json!(workpiece_rpm);
        body["process"]["tool_rpm"] = json!(tool_rpm);
        body["tool_position_mm"] = json!(r1);
        let reply = post_json(&app(), PATH, body.to_string()).await;
        assert_eq!(reply.status, 200, "{}", reply.text());
        let answer = reply.json();
        let footprint = &answer["footprint"];
        let (xs, ys) = (numbers(&footprint["x_mm"]), numbers(&footprint["y_mm"]));
        assert_eq!((xs.len(), ys.len()), (41, 41));
        assert_eq!((xs[20], ys[20]), (r1, 0.0));
        // K·P = 1e-13 m²/N · 10 kPa = 1e-9 m/s per m/s of sliding: 1e-9·60·1e6 nm/min per mm/s.
        let scale = 1e-13 * 10e3 * 60.0 * 1e6;
        let rpm = std::f64::consts::TAU / 60.0;
        let (mut under, mut peak) = (0, 0.0_f64);
        for (row, &y) in ys.iter().enumerate() {
            let rates = numbers(&footprint["removal_rate_nm_per_min"][row]);
            for (&x, got) in xs.iter().zip(rates) {
                let on = (x - r1).hypot(y) <= 10.0 && x.hypot(y) <= 50.0;
                let want = if on {
                    scale
                        * sliding_speed_mm_s(workpiece_rpm * rpm, tool_rpm * rpm, (x, y), (r1, 0.0))
                } else {
                    0.0
                };
                assert!(
                    (got - want).abs() <= 1e-12 * want.max(1e-9),
                    "{workpiece_rpm}/{tool_rpm} rpm, r1 {r1}, ({x}, {y}): {got} vs {want}"
                );
                under += usize::from(on);
                peak = peak.max(want);
            }
        }
        assert!(under > 400, "{under} pixels under the pad");
        let reported = footprint["peak_removal_rate_nm_per_min"].as_f64().unwrap();
        assert!(
            (reported - peak).abs() <= 1e-12 * peak,
            "{reported} vs {peak}"
        );
    }
}

/// The revolution average is the radial removal function: the same numbers as
/// `/v1/removal-function` at the same position (bit for bit: one computation), and the
/// adaptive quadrature of eq. 5 to 1e-9 of its peak.
#[tokio::test]
async fn the_revolution_average_is_the_radial_removal_function() {
    let app = app();
    let mut body = request();
    body["radial_grid"] = json!({"start_mm": 0.0, "stop_mm": 50.0, "count": 101});
    let answer = post_json(&app, PATH, body.to_string()).await.json();
    let average = &answer["revolution_average"];
    let radial = post_json(
        &app,
        "/v1/removal-function",
        json!({
            "process": body["process"],
            "tool_positions_mm": [20.0],
            "radial_grid": body["radial_grid"],
        })
        .to_string(),
    )
    .await
    .json();
    assert_eq!(average["radius_mm"], radial["radius_mm"]);
    assert_eq!(
        average["removal_rate_nm_per_min"],
        radial["profiles"][0]["removal_rate_nm_per_min"]
    );
    assert_eq!(answer["eta"], radial["eta"]);
    // The fixture's process: the paper's geometry at −10 / 200 r/min.
    let spec = paper_spec(-10.0, 200.0);
    let rates = numbers(&average["removal_rate_nm_per_min"]);
    let peak = rates.iter().cloned().fold(0.0, f64::max);
    assert!(peak > 1.0, "{peak}");
    for (r, got) in numbers(&average["radius_mm"]).into_iter().zip(rates) {
        let want = quadrature_rate_nm_per_min(&spec, r, 20.0);
        assert!((got - want).abs() <= 1e-9 * peak, "r {r}: {got} vs {want}");
    }
}

/// As CSV, the footprint's pixels from the top row (x, y, rate, with units in the header); as
/// PNG, a heat map.
#[tokio::test]
async fn the_footprint_comes_as_csv_and_png() {
    let app = app();
    let body = request().to_string();
    let json = post_json(&app, PATH, body.clone()).await.json();
    let csv = post_with(
        &app,
        PATH,
        body.clone(),
        &[("content-type", "application/json"), ("accept", "text/csv")],
    )
    .await;
    assert_eq!(csv.status, 200);
    assert!(
        csv.content_type.starts_with("text/csv"),
        "{}",
        csv.content_type
    );
    let text = csv.text();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "x_mm,y_mm,removal_rate_nm_per_min");
    assert_eq!(lines.len(), 1 + 41 * 41);
    // The middle pixel (row 20, column 20) is the pad centre.
    let middle: Vec<f64> = lines[1 + 20 * 41 + 20]
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(middle[..2], [20.0, 0.0]);
    let want = json["footprint"]["removal_rate_nm_per_min"][20][20]
        .as_f64()
        .unwrap();
    assert!(
        (middle[2] - want).abs() <= 1e-12 * want.max(1e-9),
        "{middle:?} vs {want}"
    );
    let png = post_with(
        &app,
        PATH,
        body,
        &[
            ("content-type", "application/json"),
            ("accept", "image/png"),
        ],
    )
    .await;
    assert_eq!(png.status, 200);
    assert_eq!(png.content_type, "image/png");
    assert_eq!(&png.body[..8], b"\x89PNG\r\n\x1a\n");
}

/// Bad input is a 422 naming the field: a sphere that does not reach the part's edge
/// (`process.workpiece_radius_mm`), a position beyond the reach
/// (`tool_position_mm`), a pixel that is not positive or so small that the grid passes the map
/// limit (`pixel_mm`), a kinematics the endpoint does not know (`machine.kinematics`).
#[tokio::test]
async fn bad_input_names_its_field() {
    let app = app();
    let cases: [(&str, Value, &str); 6] = [
        (
            "surface",
            json!({"kind": "sphere", "radius_of_curvature_mm": -20.0}),
            "process.workpiece_radius_mm",
        ),
        ("tool_position_mm", json!(61.0), "tool_position_mm"),
        ("pixel_mm", json!(0.0), "pixel_mm"),
        ("pixel_mm", json!(1e-4), "pixel_mm"),
        // On an X-Y machine the part stands still: a turning part is refused by its field.
        (
            "machine",
            json!({"kinematics": "cartesian"}),
            "process.workpiece_rpm",
        ),
        (
            "machine",
            json!({"kinematics": "milling"}),
            "machine.kinematics",
        ),
    ];
    for (key, value, field) in cases {
        let mut body = request();
        body[key] = value.clone();
        let reply = post_json(&app, PATH, body.to_string()).await;
        assert_eq!(reply.status, 422, "{key} = {value}: {}", reply.text());
        let problem = reply.json();
        assert_eq!(problem["field"], field, "{key} = {value}: {problem}");
    }
}
