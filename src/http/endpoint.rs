//! What every computing endpoint does, written once: negotiate the response format, parse the
//! request into the use case's command (refusing bad input before queueing for a computation
//! slot), run the use case in a slot, and render the result as JSON, CSV, SVG or G-code. Each
//! resource module implements [`Endpoint`] for its own types, and that one implementation is
//! the endpoint's registration: its route, its OpenAPI operation, the CLI's `compute` and the
//! examples all read it (see `router::ENDPOINTS`).

use axum::extract::{FromRequest, State};
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use serde::de::DeserializeOwned;
use serde::Serialize;
use utoipa::openapi::path::{Operation, OperationBuilder};
use utoipa::openapi::request_body::RequestBodyBuilder;
use utoipa::openapi::response::{ResponseBuilder, ResponsesBuilder};
use utoipa::openapi::{Content, ObjectBuilder, Ref, RefOr, Required, Schema, Type};
use utoipa::{PartialSchema, ToSchema};

use super::error::ApiError;
use super::extract::{self, ApiJson, Format};
use super::openapi::ComputeProblems;
use super::state::{AppState, Services};
use crate::usecases::ComputeLimits;

/// Where the computing endpoints live: every path under it is the API proper, the part API
/// keys, rate limits and the OpenAPI security requirement apply to.
pub const API_PREFIX: &str = "/v1/";

/// Whether `path` is under [`API_PREFIX`].
pub fn is_api_path(path: &str) -> bool {
    path.starts_with(API_PREFIX)
}

/// How the OpenAPI document describes an endpoint's operation.
pub struct Doc {
    pub operation_id: &'static str,
    pub tag: &'static str,
    /// One line.
    pub summary: &'static str,
    pub description: &'static str,
    /// What the 200 response holds, in each format offered.
    pub ok: &'static str,
}

/// How a request body arrives: JSON ([`ApiJson`]), or in other forms too.
pub trait Body<R>: FromRequest<AppState, Rejection = ApiError> + Send {
    fn into_request(self) -> R;
}

impl<R: DeserializeOwned + Send> Body<R> for ApiJson<R> {
    fn into_request(self) -> R {
        self.0
    }
}

/// A computing endpoint: its name, its wire types and the steps between them.
pub trait Endpoint: 'static {
    /// The path under [`API_PREFIX`], and the name the CLI's `compute` takes.
    const NAME: &'static str;
    /// A request body (a fixture): the OpenAPI example, and a case the tests run.
    const EXAMPLE: &'static str;
    const DOC: Doc;
    type Request: DeserializeOwned + ToSchema + Send + 'static;
    type Body: Body<Self::Request>;
    type Command: Send + 'static;
    /// The use case's result, which every format renders.
    type Output: Send + 'static;
    /// The JSON body.
    type Response: Serialize + ToSchema + Send + 'static;
    /// `Accept: text/csv`, when offered (`report::results`).
    const CSV: Option<fn(&Self::Output) -> String> = None;
    /// `Accept: image/svg+xml`, when offered.
    const SVG: Option<fn(&Self::Output) -> String> = None;
    /// `Accept: text/x-gcode`, when offered.
    const GCODE: Option<fn(&Self::Output) -> String> = None;
    /// `Accept: image/png`, when offered (`report::heatmap`).
    const PNG: Option<Picture<Self::Output>> = None;
    /// The body may be an instrument's file: the map body limit applies, not the JSON one.
    const LARGE_BODY: bool = false;

    /// The request as the use case's command: every check, no computation.
    fn parse(request: Self::Request, limits: &ComputeLimits) -> Result<Self::Command, ApiError>;

    /// Runs the use case (on the blocking pool).
    fn run(command: Self::Command, services: &Services) -> Result<Self::Output, ApiError>;

    /// The result as the JSON body.
    fn respond(output: Self::Output) -> Self::Response;

    /// What the OpenAPI operation says beyond a JSON body and the offered responses (query
    /// parameters, other request media types).
    fn document(_operation: &mut Operation) {}
}

/// A renderer of an endpoint's result as image bytes.
pub type Picture<T> = fn(&T) -> Vec<u8>;

pub(super) fn offered<E: Endpoint>() -> Vec<Format> {
    let mut offered = vec![Format::Json];
    offered.extend(E::CSV.map(|_| Format::Csv));
    offered.extend(E::SVG.map(|_| Format::Svg));
    offered.extend(E::GCODE.map(|_| Format::Gcode));
    offered.extend(E::PNG.map(|_| Format::Png));
    offered
}

/// The handler of every computing endpoint.
pub async fn handler<E: Endpoint>(
    State(state): State<AppState>,
    headers: HeaderMap,
    body: E::Body,
) -> Result<Response, ApiError> {
    let format = extract::negotiate(&headers, &offered::<E>())?;
    let command = E::parse(body.into_request(), &state.compute)?;
    let services = state.services.clone();
    let output = state.run(move || E::run(command, &services)).await?;
    Ok(render::<E>(format, output))
}

/// The endpoint's operation in the OpenAPI document, and the schemas it refers to.
pub fn operation<E: Endpoint>(schemas: &mut Vec<(String, RefOr<Schema>)>) -> Operation {
    for (name, schema) in [
        (E::Request::name(), E::Request::schema()),
        (E::Response::name(), E::Response::schema()),
    ] {
        schemas.push((name.into_owned(), schema));
    }
    E::Request::schemas(schemas);
    E::Response::schemas(schemas);
    let example = serde_json::from_str(E::EXAMPLE).expect("fixtures are valid JSON");
    let mut json = Content::new(Some(Ref::from_schema_name(E::Request::name())));
    json.example = Some(example);
    let body = RequestBodyBuilder::new()
        .content("application/json", json)
        .required(Some(Required::True))
        .build();
    let text = || Content::new(Some(ObjectBuilder::new().schema_type(Type::String)));
    let ok = offered::<E>().into_iter().fold(
        ResponseBuilder::new().description(E::DOC.ok),
        |ok, format| {
            let content = match format {
                Format::Json => Content::new(Some(Ref::from_schema_name(E::Response::name()))),
                Format::Png => {
                    Content::new(Some(ObjectBuilder::new().schema_type(Type::String).format(
                        Some(utoipa::openapi::SchemaFormat::KnownFormat(
                            utoipa::openapi::KnownFormat::Binary,
                        )),
                    )))
                }
                _ => text(),
            };
            ok.content(format.media_type(), content)
        },
    );
    let responses = ResponsesBuilder::new()
        .response("200", ok)
        .responses_from_into_responses::<ComputeProblems>()
        .build();
    let mut operation = OperationBuilder::new()
        .tag(E::DOC.tag)
        .summary(Some(E::DOC.summary))
        .description(Some(E::DOC.description))
        .operation_id(Some(E::DOC.operation_id))
        .request_body(Some(body))
        .responses(responses)
        .build();
    E::document(&mut operation);
    operation
}

/// The exact JSON body the endpoint would return for `body`, computed in this thread (the
/// offline `compute` command).
pub fn compute_json<E: Endpoint>(
    body: &[u8],
    limits: &ComputeLimits,
    services: &Services,
) -> Result<String, ApiError> {
    let command = E::parse(extract::parse_json(body)?, limits)?;
    let response = E::respond(E::run(command, services)?);
    serde_json::to_string(&response).map_err(|e| ApiError::internal(e.to_string()))
}

/// The response body in the negotiated format (one the endpoint offers).
pub(super) fn render<E: Endpoint>(format: Format, output: E::Output) -> Response {
    let body = &output;
    let offered = |text: Option<fn(&E::Output) -> String>, what: &str| {
        text.map(|f| f(body).into_bytes())
            .ok_or_else(|| ApiError::internal(format!("{what} negotiated but not offered")))
    };
    let bytes = match format {
        Format::Json => serde_json::to_vec(&E::respond(output))
            .map_err(|e| ApiError::internal(format!("serialising a response: {e}"))),
        Format::Csv => offered(E::CSV, "CSV"),
        Format::Svg => offered(E::SVG, "SVG"),
        Format::Gcode => offered(E::GCODE, "G-code"),
        Format::Png => E::PNG
            .map(|f| f(body))
            .ok_or_else(|| ApiError::internal("PNG negotiated but not offered")),
        Format::File => Err(ApiError::internal(
            "a file negotiated: no compute endpoint offers one",
        )),
    };
    let content_type = match format {
        Format::Json => "application/json",
        Format::Csv => "text/csv; charset=utf-8",
        Format::Svg => "image/svg+xml",
        Format::Gcode => "text/x-gcode; charset=utf-8",
        Format::File => "application/octet-stream",
        Format::Png => "image/png",
    };
    match bytes {
        Ok(bytes) => ([(header::CONTENT_TYPE, content_type)], bytes).into_response(),
        Err(e) => e.into_response(),
    }
}
