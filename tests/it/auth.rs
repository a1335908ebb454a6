//! API keys over a real socket with the real binary: no key, a malformed header, a wrong key
//! and a right one; the open endpoints; `/metrics` behind a key when asked; SIGHUP reloading a
//! new set (and keeping the old one when the new file is malformed); a malformed file at
//! start-up; rate limits per key (a burst gets 429 while another key goes on) and per address.
//! The service is `common::service`; the client is a few lines of HTTP/1.1 on a `TcpStream`, so
//! nothing between the test and the service interprets the headers.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::Command;

use sha2::{Digest, Sha256};

use crate::common;
use common::service::Service;

fn sha256_hex(key: &str) -> String {
    Sha256::digest(key.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

struct Reply {
    status: u16,
    headers: String,
    body: String,
}

/// One request on a fresh connection (`Connection: close`).
fn http(address: &str, method: &str, path: &str, headers: &[&str], body: &[u8]) -> Reply {
    let mut stream = TcpStream::connect(address).unwrap();
    let mut request =
        format!("{method} {path} HTTP/1.1\r\nHost: {address}\r\nConnection: close\r\n");
    for h in headers {
        request.push_str(h);
        request.push_str("\r\n");
    }
    if !body.is_empty() {
        request.push_str(&format!(
            "Content-Type: application/json\r\nContent-Length: {}\r\n",
            body.len()
        ));
    }
    request.push_str("\r\n");
    stream.write_all(request.as_bytes()).unwrap();
    stream.write_all(body).unwrap();
    let mut raw = Vec::new();
    stream.read_to_end(&mut raw).unwrap();
    let text = String::from_utf8_lossy(&raw).to_string();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let status = head.split(' ').nth(1).unwrap().parse().unwrap();
    Reply {
        status,
        headers: head.to_ascii_lowercase(),
        body: body.to_string(),
    }
}

/// `POST /v1/predict` of the paper's experiment 2 with `headers`.
fn predict(service: &Service, headers: &[&str]) -> Reply {
    let body = std::fs::read(common::fixture_path("predict_paper_exp2.json")).unwrap();
    http(&service.address, "POST", "/v1/predict", headers, &body)
}

fn keys_file(name: &str, lines: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("preston-auth-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, lines).unwrap();
    path
}

fn arg(path: &Path) -> &str {
    path.to_str().unwrap()
}

#[test]
fn keys_guard_v1_and_name_the_caller_while_health_and_docs_stay_open() {
    let file = keys_file(
        "keys.txt",
        &format!(
            "# test keys\nmes:{}\n\nengineering:{}\n",
            sha256_hex("mes-key-1"),
            sha256_hex("eng-key-2")
        ),
    );
    let service = Service::start(&["--api-keys-file", arg(&file)]);
    let cases: [(&[&str], &str, &str); 5] = [
        (&[], "bearer realm=\"preston\"\r", "needs an API key"),
        (
            &["Authorization: Basic bWVzOmtleQ=="],
            "error=\"invalid_request\"",
            "must be `Bearer <key>`",
        ),
        (
            &["Authorization: Bearer"],
            "error=\"invalid_request\"",
            "must be `Bearer <key>`",
        ),
        (
            &["Authorization: Bearer mes-key-2"],
            "error=\"invalid_token\"",
            "not valid",
        ),
        (
            &["Authorization: Bearer MES-KEY-1"],
            "error=\"invalid_token\"",
            "not valid",
        ),
    ];
    for (headers, challenge, detail) in cases {
        let reply = predict(&service, headers);
        assert_eq!(reply.status, 401, "{headers:?}: {}", reply.body);
        assert!(
            reply
                .headers
                .contains("content-type: application/problem+json"),
            "{}",
            reply.headers
        );
        let www = reply
            .headers
            .lines()
            .find(|l| l.starts_with("www-authenticate:"))
            .unwrap_or_else(|| panic!("{headers:?}: no challenge in {}", reply.headers));
        assert!(format!("{www}\r").contains(challenge), "{headers:?}: {www}");
        let problem: serde_json::Value = serde_json::from_str(&reply.body).unwrap();
        assert_eq!(problem["type"], "urn:preston:problem:unauthorized");
        assert!(
            problem["detail"].as_str().unwrap().contains(detail),
            "{problem}"
        );
        // The refusal never echoes a key or names the configured ones.
        for secret in ["mes-key", "eng-key", "mes\"", "engineering"] {
            assert!(!reply.body.contains(secret), "{}", reply.body);
        }
    }
    for (key, name) in [("mes-key-1", "mes"), ("eng-key-2", "engineering")] {
        let header = format!("Authorization: Bearer {key}");
        let reply = predict(&service, &[&header]);
        assert_eq!(reply.status, 200, "{}", reply.body);
        // Scheme names are case-insensitive.
        let lower = format!("authorization: bearer {key}");
        assert_eq!(predict(&service, &[&lower]).status, 200);
        service.wait_for_log(&format!("key=\"{name}\""), 2);
    }
    assert!(!service.log.lock().unwrap().contains("mes-key-1"));
    for path in ["/healthz", "/readyz", "/openapi.json", "/docs/", "/metrics"] {
        let reply = http(&service.address, "GET", path, &[], b"");
        assert_eq!(reply.status, 200, "{path}");
    }
    let metrics = http(&service.address, "GET", "/metrics", &[], b"").body;
    assert!(metrics.contains("key=\"mes\""), "{metrics}");
    assert!(metrics.contains("status=\"401\""));
    // A wrong method or path under /v1 is refused for the key before anything else.
    assert_eq!(
        http(&service.address, "GET", "/v1/nothing", &[], b"").status,
        401
    );
}

#[test]
fn metrics_can_require_a_key() {
    let file = keys_file(
        "metrics-keys.txt",
        &format!("ops:{}\n", sha256_hex("ops-key")),
    );
    let service = Service::start(&["--api-keys-file", arg(&file), "--metrics-require-key"]);
    assert_eq!(
        http(&service.address, "GET", "/metrics", &[], b"").status,
        401
    );
    let reply = http(
        &service.address,
        "GET",
        "/metrics",
        &["Authorization: Bearer ops-key"],
        b"",
    );
    assert_eq!(reply.status, 200);
    assert_eq!(
        http(&service.address, "GET", "/healthz", &[], b"").status,
        200
    );
}

#[test]
fn sighup_reloads_the_keys_and_a_malformed_file_keeps_the_old_ones() {
    let file = keys_file("reload.txt", &format!("old:{}\n", sha256_hex("old-key")));
    let service = Service::start(&["--api-keys-file", arg(&file)]);
    let old = ["Authorization: Bearer old-key"];
    let new = ["Authorization: Bearer new-key"];
    assert_eq!(predict(&service, &old).status, 200);
    assert_eq!(predict(&service, &new).status, 401);

    std::fs::write(&file, format!("new:{}\n", sha256_hex("new-key"))).unwrap();
    service.signal("HUP");
    service.wait_for_log("API keys reloaded", 1);
    assert_eq!(predict(&service, &new).status, 200);
    assert_eq!(
        predict(&service, &old).status,
        401,
        "a removed key stops working"
    );

    std::fs::write(&file, "new:not-a-digest\n").unwrap();
    service.signal("HUP");
    service.wait_for_log("API keys not reloaded", 1);
    assert!(service.log.lock().unwrap().contains("line 1"));
    assert_eq!(
        predict(&service, &new).status,
        200,
        "the previous keys stay"
    );
}

#[test]
fn a_malformed_keys_file_stops_the_service_at_start_naming_the_line() {
    let file = keys_file(
        "bad.txt",
        &format!(
            "# ok so far\nmes:{}\nerp {}\n",
            sha256_hex("a"),
            sha256_hex("b")
        ),
    );
    let output = Command::new(env!("CARGO_BIN_EXE_preston"))
        .args(["--listen", "127.0.0.1:0", "--api-keys-file", arg(&file)])
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("bad.txt, line 3: "), "{stderr}");
    assert!(stderr.contains("no ':'"), "{stderr}");
    let missing = Command::new(env!("CARGO_BIN_EXE_preston"))
        .args([
            "--listen",
            "127.0.0.1:0",
            "--api-keys-file",
            "/nonexistent/keys",
        ])
        .output()
        .unwrap();
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("cannot read /nonexistent/keys"));
}

#[test]
fn a_burst_over_a_keys_limit_gets_429_with_retry_after_and_other_keys_go_on() {
    let file = keys_file(
        "limited.txt",
        &format!(
            "batch:{}\nmes:{}\n",
            sha256_hex("batch-key"),
            sha256_hex("mes-key")
        ),
    );
    let service = Service::start(&[
        "--api-keys-file",
        arg(&file),
        "--rate-limit-per-second",
        "0.5",
        "--rate-limit-burst",
        "3",
    ]);
    let batch = ["Authorization: Bearer batch-key"];
    for _ in 0..3 {
        assert_eq!(predict(&service, &batch).status, 200);
    }
    let refused = predict(&service, &batch);
    assert_eq!(refused.status, 429, "{}", refused.body);
    assert!(
        refused.headers.contains("retry-after: 2"),
        "{}",
        refused.headers
    );
    assert!(refused
        .headers
        .contains("content-type: application/problem+json"));
    let problem: serde_json::Value = serde_json::from_str(&refused.body).unwrap();
    assert_eq!(problem["type"], "urn:preston:problem:rate-limited");
    // The MES is unaffected by the batch script's burst; the probes are never limited.
    for _ in 0..3 {
        assert_eq!(
            predict(&service, &["Authorization: Bearer mes-key"]).status,
            200
        );
    }
    for _ in 0..5 {
        assert_eq!(
            http(&service.address, "GET", "/healthz", &[], b"").status,
            200
        );
    }
    let metrics = http(&service.address, "GET", "/metrics", &[], b"").body;
    assert!(
        metrics.contains("key=\"batch\",method=\"POST\",route=\"/v1/predict\",status=\"429\"} 1"),
        "{metrics}"
    );
}

#[test]
fn without_keys_the_limit_is_per_address_and_off_by_default() {
    let open = Service::start(&[]);
    for _ in 0..8 {
        assert_eq!(predict(&open, &[]).status, 200);
    }
    let limited = Service::start(&["--rate-limit-per-second", "0.2", "--rate-limit-burst", "2"]);
    assert_eq!(predict(&limited, &[]).status, 200);
    assert_eq!(predict(&limited, &[]).status, 200);
    let refused = predict(&limited, &[]);
    assert_eq!(refused.status, 429);
    assert!(
        refused.headers.contains("retry-after: 5"),
        "{}",
        refused.headers
    );
    let bad = Command::new(env!("CARGO_BIN_EXE_preston"))
        .args(["--listen", "127.0.0.1:0", "--rate-limit-per-second=-1"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--rate-limit-per-second"));
}
