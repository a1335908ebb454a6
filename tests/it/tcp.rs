//! The service over a real TCP socket, and the offline `preston compute` command, which must
//! print exactly what the API returns.

use crate::common;

use common::socket;
use preston::config::ServiceLimits;
use preston::http::AppState;
use tokio::net::TcpListener;

#[tokio::test]
async fn predict_over_a_real_socket_then_graceful_shutdown() {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(preston::server::serve_on(
        listener,
        AppState::new(ServiceLimits::default()),
        &[],
        async move {
            let _ = stopped.await;
        },
    ));

    let address = address.to_string();
    let body = std::fs::read(common::fixture_path("predict_paper_exp2.json")).unwrap();
    let response = socket::post_json(&address, "/v1/predict", &body).await;
    assert_eq!(response.status, 200);
    let v = response.json();
    assert_eq!(v["eta"], -1.0);
    assert_eq!(v["total_time_s"], 6006.0);
    assert!(v["metrics"]["nonuniformity"].as_f64().unwrap() < 0.01);

    let health = socket::get(&address, "/healthz").await;
    assert_eq!(health.status, 200);

    stop.send(()).unwrap();
    server.await.unwrap().unwrap();
}

/// Every request fixture, through `preston compute` and through the router: the same bytes
/// (bar the solver's wall-clock time, the one member that differs from run to run), and every
/// endpoint has a fixture.
#[tokio::test]
async fn compute_prints_exactly_the_api_response_for_every_fixture() {
    let app = common::http::app();
    let mut covered = std::collections::BTreeSet::new();
    for fixture in common::request_fixtures() {
        let endpoint = common::endpoint_of(&fixture);
        let name = endpoint.strip_prefix("/v1/").unwrap();
        covered.insert(name.to_string());
        let path = common::fixture_path(&fixture);
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_preston"))
            .args(["compute", name])
            .arg(&path)
            .output()
            .unwrap();
        assert!(output.status.success(), "{fixture}: {output:?}");
        let reply = common::http::post_json(&app, endpoint, std::fs::read(&path).unwrap()).await;
        assert_eq!(reply.status, 200, "{fixture}");
        let mut api = reply.body.clone();
        api.push(b'\n');
        assert_eq!(
            without_solve_time(&output.stdout),
            without_solve_time(&api),
            "{fixture}: CLI output differs from the API body"
        );
    }
    let endpoints: std::collections::BTreeSet<String> = preston::http::ENDPOINTS
        .iter()
        .map(|e| e.name.to_string())
        .collect();
    assert_eq!(covered, endpoints, "every endpoint has a request fixture");
}

/// The bytes with the value of `"solve_time_ms"` blanked.
fn without_solve_time(bytes: &[u8]) -> String {
    let text = String::from_utf8(bytes.to_vec()).unwrap();
    let key = "\"solve_time_ms\":";
    match text.find(key) {
        Some(i) => {
            let start = i + key.len();
            let end = start + text[start..].find([',', '}']).unwrap();
            format!("{}{}", &text[..start], &text[end..])
        }
        None => text,
    }
}

#[test]
fn compute_reports_problems_with_exit_status_2() {
    let dir = std::env::temp_dir().join(format!("preston-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad.json");
    std::fs::write(
        &file,
        r#"{"process":{"workpiece_radius_mm":50,"tool_radius_mm":10,"workpiece_rpm":0,"tool_rpm":1},
            "dwell":{"positions_mm":[1],"dwell_s":[1]}}"#,
    )
    .unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_preston"))
        .args(["compute", "predict"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(2));
    let problem: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(problem["field"], "process.workpiece_rpm");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A reader that stops early (`preston openapi | head`) is no error: the binary exits with
/// its usual status and says nothing on standard error (it used to panic on the broken pipe).
#[test]
fn output_to_a_closed_pipe_is_not_an_error() {
    use std::io::Read;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_preston"))
        .arg("openapi")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let mut first = [0u8; 16];
    stdout.read_exact(&mut first).unwrap();
    drop(stdout); // the reader goes away with most of the document unread
    let output = child.wait_with_output().unwrap();
    assert!(output.status.success(), "{output:?}");
    assert!(
        output.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}
