//! The workbench: a page at `GET /` for process engineers (set the process, predict, see what
//! η = −1 buys, optimize, fit a probe trace, download the program) that is also a worked example
//! of calling the API from a browser. Plain HTML, CSS and JavaScript compiled into the binary:
//! no library, no build step, nothing fetched from elsewhere — the Content-Security-Policy
//! admits only this origin, so the page works on a shop floor with no internet.
//!
//! The page comes with its first answers: the requests its predict view makes for the default
//! set-up, computed once per process by the same code the API runs and embedded as JSON, so the
//! first paint shows results rather than "Computing…". The script uses an embedded answer only
//! for a request equal to the one it was computed for (any other set-up, or a change of the
//! defaults, simply calls the API). Behind API keys the page carries none: it asks with the
//! user's key.

use axum::extract::{Path, State};
use axum::http::{header, HeaderValue};
use axum::response::{IntoResponse, Response};
use serde_json::{json, Value};

use super::error::ApiError;
use super::state::{AppState, Services};
use crate::usecases::ComputeLimits;

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
    Some(with_headers(text.to_string(), content_type))
}

fn with_headers(text: String, content_type: &'static str) -> Response {
    let mut response = text.into_response();
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
    response
}

/// `GET /`: the page, with its first answers (none behind API keys: there the page asks with
/// the user's key, as for everything else).
pub async fn page(State(state): State<AppState>) -> Response {
    if state.auth.is_some() {
        return with_headers(ASSETS[0].2.to_string(), ASSETS[0].1);
    }
    let (limits, services) = (state.compute.clone(), state.services.clone());
    let page = state
        .workbench_page
        .get_or_init(|| async move {
            let answers = tokio::task::spawn_blocking(move || first_answers(&limits, &services))
                .await
                .unwrap_or_default();
            with_answers(&answers).into()
        })
        .await;
    with_headers(page.to_string(), "text/html; charset=utf-8")
}

/// The page with `answers` (a JSON list) in its `first-answers` block; `</` is written `<\/`
/// so no text in the JSON can end the script element.
fn with_answers(answers: &str) -> String {
    let block = r#"id="first-answers">"#;
    let embedded = format!("{block}{}", answers.replace("</", "<\\/"));
    ASSETS[0].2.replacen(&format!("{block}[]"), &embedded, 1)
}

/// The predict view's requests for the page's default set-up and the API's answers, as
/// [{path, request, response}] (the script builds these requests from the inputs' defaults,
/// in this key order). Empty if any fails: the page then asks the API as usual.
fn first_answers(limits: &ComputeLimits, services: &Services) -> String {
    let process = json!({
        "workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10, "tool_rpm": 200,
        "preston_coefficient_m2_per_n": 1e-13, "pressure_kpa": 10
    });
    let surface = json!({"kind": "plane"});
    let aperture = json!({"inner_mm": 0, "outer_mm": 40});
    // The sweep's default text, -2:-0.05:0.05 (from, to, step), as the script expands it.
    let etas: Vec<f64> = (0..40)
        .map(|i| {
            let eta = -2.0 + f64::from(i) * 0.05;
            format!("{eta:.11e}").parse().unwrap_or(eta)
        })
        .collect();
    let answer = |name: &str, request: Value| -> Option<Value> {
        let body = serde_json::to_vec(&request).ok()?;
        let text = super::router::compute_with(name, &body, limits, services).ok()?;
        let response: Value = serde_json::from_str(&text).ok()?;
        Some(json!({
            "path": format!("{}{name}", super::endpoint::API_PREFIX),
            "request": request,
            "response": response
        }))
    };
    let all = || -> Option<Vec<Value>> {
        let removal = answer(
            "removal-function",
            json!({"process": process, "surface": surface, "tool_positions_mm": [8, 20, 34]}),
        )?;
        let recommend = answer(
            "recommend",
            json!({"process": process, "surface": surface, "clear_aperture": aperture,
                   "depth_nm": 100}),
        )?;
        let sweep = answer(
            "studies/eta-sweep",
            json!({"process": process, "surface": surface, "clear_aperture": aperture,
                   "depth_nm": 100, "etas": etas}),
        )?;
        let r = &recommend["response"]["recommendation"];
        let predict = json!({"process": process, "surface": surface,
                             "feed": r["equal_dwell"]["feed"], "clear_aperture": aperture});
        let mut recommended = predict.clone();
        recommended["process"]["workpiece_rpm"] = r["workpiece_rpm"].clone();
        recommended["process"]["tool_rpm"] = r["tool_rpm"].clone();
        let now = answer("predict", predict)?;
        let better = answer("predict", recommended)?;
        // The middle position's footprint, its pixel the pad radius / 25.
        let footprint = answer(
            "maps/removal-function",
            json!({"process": process, "surface": surface, "tool_position_mm": 20,
                   "pixel_mm": 0.4}),
        )?;
        Some(vec![removal, recommend, sweep, now, better, footprint])
    };
    all()
        .and_then(|answers| serde_json::to_string(&answers).ok())
        .unwrap_or_else(|| "[]".to_string())
}

/// `GET /workbench/{name}`: its script and style sheet.
pub async fn asset(Path(name): Path<String>) -> Response {
    serve(&name)
        .unwrap_or_else(|| ApiError::not_found(&format!("/workbench/{name}")).into_response())
}
