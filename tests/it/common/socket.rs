//! One HTTP/1.1 request over a fresh TCP connection, for the tests that talk to a real
//! socket. Written here rather than taken from an HTTP client crate: hyper's client features
//! would change how the server's own hyper is built, and `cargo run --release` after
//! `cargo test --release` would then recompile the service's dependencies.

use std::io::ErrorKind;

use tokio::net::TcpStream;

/// A response: status code and body (chunked transfer decoded).
pub struct Response {
    pub status: u16,
    pub body: Vec<u8>,
}

impl Response {
    pub fn json(&self) -> serde_json::Value {
        serde_json::from_slice(&self.body).expect("a JSON body")
    }
}

/// `GET path` at `address` (host:port).
pub async fn get(address: &str, path: &str) -> Response {
    request(address, "GET", path, &[]).await
}

/// `POST path` at `address` with a JSON `body`.
pub async fn post_json(address: &str, path: &str, body: &[u8]) -> Response {
    request(address, "POST", path, body).await
}

async fn request(address: &str, method: &str, path: &str, body: &[u8]) -> Response {
    let stream = TcpStream::connect(address).await.expect("connect");
    let head = format!(
        "{method} {path} HTTP/1.1\r\nhost: {address}\r\ncontent-type: application/json\r\n\
         content-length: {}\r\nconnection: close\r\n\r\n",
        body.len()
    );
    write_all(&stream, head.as_bytes()).await;
    write_all(&stream, body).await;
    let raw = read_to_end(&stream).await;
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a response head");
    let head = String::from_utf8_lossy(&raw[..split]).to_ascii_lowercase();
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .expect("a status code");
    let rest = &raw[split + 4..];
    let body = if head.contains("transfer-encoding: chunked") {
        dechunk(rest)
    } else {
        rest.to_vec()
    };
    Response { status, body }
}

// Readiness and non-blocking calls: tokio's read and write helpers need its `io-util`
// feature, which the service does not build.
async fn write_all(stream: &TcpStream, mut data: &[u8]) {
    while !data.is_empty() {
        stream.writable().await.expect("writable");
        match stream.try_write(data) {
            Ok(n) => data = &data[n..],
            Err(e) if e.kind() == ErrorKind::WouldBlock => {}
            Err(e) => panic!("write: {e}"),
        }
    }
}

async fn read_to_end(stream: &TcpStream) -> Vec<u8> {
    let mut raw = Vec::new();
    let mut buffer = vec![0u8; 64 * 1024];
    loop {
        stream.readable().await.expect("readable");
        match stream.try_read(&mut buffer) {
            Ok(0) => return raw,
            Ok(n) => raw.extend_from_slice(&buffer[..n]),
            Err(e) if e.kind() == ErrorKind::WouldBlock => {}
            Err(e) => panic!("read: {e}"),
        }
    }
}

/// The payload of a chunked body: hex size, CRLF, data, CRLF, … until a size of 0.
fn dechunk(mut data: &[u8]) -> Vec<u8> {
    let mut body = Vec::new();
    loop {
        let line = data
            .windows(2)
            .position(|w| w == b"\r\n")
            .expect("a chunk size");
        let size_text = String::from_utf8_lossy(&data[..line]);
        let size = usize::from_str_radix(size_text.split(';').next().unwrap().trim(), 16)
            .expect("a hex chunk size");
        if size == 0 {
            return body;
        }
        let start = line + 2;
        body.extend_from_slice(&data[start..start + size]);
        data = &data[start + size + 2..];
    }
}
