//! The workbench: a page at `GET /` for process engineers (set the process, predict, see what
//! η = −1 buys, optimize, fit a probe trace, download the program) that is also a worked example
//! of calling the API from a browser. Plain HTML, CSS and JavaScript compiled into the binary:
//! no library, no build step, nothing fetched from elsewhere — the Content-Security-Policy
//! admits only this origin, so the page works on a shop floor with no internet.

use axum::extract::Path;
use axum::http::{header, HeaderValue};
use axum::response::{IntoResponse, Response};

use super::error::ApiError;

/// The page and its assets: (name under `/workbench/`, content type, text).
pub const ASSETS: [(&str, &str, &str); 3] = [
    (
        "index.html",
        "text/html; charset=utf-8",
        include_str!("workbench/index.html"),
    ),
    (
        "workbench.js",
        "text/javascript; charset=utf-8",
        include_str!("workbench/workbench.js"),
    ),
    (
        "workbench.css",
        "text/css; charset=utf-8",
        include_str!("workbench/workbench.css"),
    ),
];

/// Everything from this origin, nothing from elsewhere. `blob:` carries the downloads the page
/// builds; `data:` the empty favicon (so the browser does not ask for /favicon.ico).
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'none'; script-src 'self'; \
    style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; base-uri 'none'; \
    form-action 'none'; frame-ancestors 'none'";

fn serve(name: &str) -> Option<Response> {
    let (_, content_type, text) = ASSETS.iter().find(|(n, _, _)| *n == name)?;
    let mut response = (*text).into_response();
    let headers = response.headers_mut();
    headers.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    headers.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(CONTENT_SECURITY_POLICY),
    );
    headers.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    // Small and compiled in: revalidate rather than cache stale pages across upgrades.
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    Some(response)
}

/// `GET /`: the page.
pub async fn page() -> Response {
    serve("index.html")
        .unwrap_or_else(|| ApiError::internal("workbench page missing").into_response())
}

/// `GET /workbench/{name}`: its script and style sheet.
pub async fn asset(Path(name): Path<String>) -> Response {
    serve(&name)
        .unwrap_or_else(|| ApiError::not_found(&format!("/workbench/{name}")).into_response())
}
