//! What every computing endpoint does, written once: negotiate the response format, parse the
//! request into the use case's command (refusing bad input before queueing for a computation
//! slot), run the use case in a slot, and render the result as JSON, CSV or SVG. Each resource
//! module implements [`Endpoint`] for its own types.

use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use serde::de::DeserializeOwned;
use serde::Serialize;

use super::error::ApiError;
use super::extract::{self, Format};
use super::state::{AppState, Services};
use crate::usecases::ComputeLimits;

/// Where the computing endpoints live: every path under it is the API proper, the part API
/// keys, rate limits and the OpenAPI security requirement apply to.
pub const API_PREFIX: &str = "/v1/";

/// Whether `path` is under [`API_PREFIX`].
pub fn is_api_path(path: &str) -> bool {
    path.starts_with(API_PREFIX)
}

/// A computing endpoint: its wire types and the steps between them.
pub trait Endpoint: 'static {
    type Request: DeserializeOwned + Send + 'static;
    type Command: Send + 'static;
    type Response: Serialize + Send + 'static;
    /// `Accept: text/csv`, when offered.
    const CSV: Option<fn(&Self::Response) -> String> = None;
    /// `Accept: image/svg+xml`, when offered.
    const SVG: Option<fn(&Self::Response) -> String> = None;
    /// `Accept: text/x-gcode`, when offered.
    const GCODE: Option<fn(&Self::Response) -> String> = None;

    /// The request as the use case's command: every check, no computation.
    fn parse(request: Self::Request, limits: &ComputeLimits) -> Result<Self::Command, ApiError>;

    /// Runs the use case (on the blocking pool) and converts its result.
    fn run(command: Self::Command, services: &Services) -> Result<Self::Response, ApiError>;
}

fn offered<E: Endpoint>() -> Vec<Format> {
    let mut offered = vec![Format::Json];
    offered.extend(E::CSV.map(|_| Format::Csv));
    offered.extend(E::SVG.map(|_| Format::Svg));
    offered.extend(E::GCODE.map(|_| Format::Gcode));
    offered
}

/// The body of every computing handler.
pub async fn handle<E: Endpoint>(
    state: AppState,
    headers: &HeaderMap,
    request: E::Request,
) -> Result<Response, ApiError> {
    let format = extract::negotiate(headers, &offered::<E>())?;
    let command = E::parse(request, &state.compute)?;
    let services = state.services.clone();
    let response = state.run(move || E::run(command, &services)).await?;
    Ok(render::<E>(format, &response))
}

/// The exact JSON body the endpoint would return for `body`, computed in this thread (the
/// offline `compute` command).
pub fn compute_json<E: Endpoint>(
    body: &[u8],
    limits: &ComputeLimits,
    services: &Services,
) -> Result<String, ApiError> {
    let command = E::parse(extract::parse_json(body)?, limits)?;
    let response = E::run(command, services)?;
    serde_json::to_string(&response).map_err(|e| ApiError::internal(e.to_string()))
}

/// The response body in the negotiated format (one the endpoint offers).
fn render<E: Endpoint>(format: Format, body: &E::Response) -> Response {
    let text = match format {
        Format::Json => serde_json::to_string(body)
            .map_err(|e| ApiError::internal(format!("serialising a response: {e}"))),
        Format::Csv => E::CSV
            .map(|f| f(body))
            .ok_or_else(|| ApiError::internal("CSV negotiated but not offered")),
        Format::Svg => E::SVG
            .map(|f| f(body))
            .ok_or_else(|| ApiError::internal("SVG negotiated but not offered")),
        Format::Gcode => E::GCODE
            .map(|f| f(body))
            .ok_or_else(|| ApiError::internal("G-code negotiated but not offered")),
    };
    let content_type = match format {
        Format::Json => "application/json",
        Format::Csv => "text/csv; charset=utf-8",
        Format::Svg => "image/svg+xml",
        Format::Gcode => "text/x-gcode; charset=utf-8",
    };
    match text {
        Ok(text) => ([(header::CONTENT_TYPE, content_type)], text).into_response(),
        Err(e) => e.into_response(),
    }
}
