//! The OpenAPI document, generated from the code (utoipa) with request examples taken from
//! `fixtures/`. Committed as `openapi/openapi.json`; `tests/it/openapi_drift.rs` fails when the
//! two differ (regenerate with `cargo run -- openapi > openapi/openapi.json`).

use utoipa::openapi::path::HttpMethod;
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityRequirement, SecurityScheme};
use utoipa::OpenApi;

use super::dto::{
    ApertureEcho, ClearApertureDto, DwellDto, MetricsDto, PressureModelDto, ProcessDto,
    RadialGridDto,
};
use super::endpoint::is_api_path;
use super::error::Problem;
use super::router::ENDPOINTS;
use super::{health, metrics, records};

#[derive(OpenApi)]
#[openapi(
    info(
        title = "Preston",
        description = include_str!("../../openapi/description.md")
    ),
    servers((url = "/", description = "The service that serves this document")),
    paths(
        health::healthz,
        health::readyz,
        metrics::handler,
        records::profiles::create,
        records::profiles::list,
        records::profiles::show,
        records::profiles::calibrate,
        records::profiles::calibration,
        records::parts::create,
        records::parts::list,
        records::parts::show,
        records::parts::measure,
        records::parts::measurement,
        records::cycles::plan,
        records::cycles::show_plan,
        records::cycles::program,
        records::cycles::run,
        records::cycles::show_run,
        records::cycles::history,
    ),
    components(schemas(
        Problem,
        ProcessDto,
        PressureModelDto,
        RadialGridDto,
        ClearApertureDto,
        DwellDto,
        MetricsDto,
        ApertureEcho,
    )),
    tags(
        (name = "removal", description = "Removal functions and predictions"),
        (name = "optimize", description = "Dwell optimization"),
        (name = "recommend", description = "η = −1 recommendation and η studies"),
        (name = "metrology", description = "On-machine measurement: fit a probe trace to the design"),
        (name = "machine", description = "Machine programs: axis motion within limits, G-code"),
        (name = "calibration", description = "Calibration: the removal rate, pad radius and moment share fitted to measured removal"),
        (name = "records", description = "Records: process profiles and their calibrations, parts, measurements, plans, runs and each part's correction cycles"),
        (name = "service", description = "Probes"),
    )
)]
struct ApiDoc;

/// The document: the service's own paths, and an operation (with a fixture as its example)
/// for every computing endpoint.
pub fn spec() -> utoipa::openapi::OpenApi {
    let mut doc = ApiDoc::openapi();
    let mut schemas = Vec::new();
    for endpoint in &ENDPOINTS {
        let operation = (endpoint.operation)(&mut schemas);
        doc.paths
            .add_path_operation(endpoint.path(), vec![HttpMethod::Post], operation);
    }
    records::schemas(&mut schemas);
    let components = doc.components.get_or_insert_with(Default::default);
    components.schemas.extend(schemas);
    // API keys: every /v1 operation takes a bearer key, needed only when the service runs
    // with a keys file (hence the empty alternative).
    components.add_security_scheme(
        "bearer",
        SecurityScheme::Http(
            HttpBuilder::new()
                .scheme(HttpAuthScheme::Bearer)
                .description(Some(
                    "An API key, when the service is run with a keys file \
(`--api-keys-file`): `Authorization: Bearer <key>`. Without one it is not needed. A missing, \
malformed or unknown key is a 401 problem with `WWW-Authenticate: Bearer`.",
                ))
                .build(),
        ),
    );
    for (path, item) in doc.paths.paths.iter_mut() {
        if is_api_path(path) {
            for operation in [item.get.as_mut(), item.post.as_mut()]
                .into_iter()
                .flatten()
            {
                operation.security = Some(vec![
                    SecurityRequirement::new("bearer", Vec::<String>::new()),
                    SecurityRequirement::default(),
                ]);
            }
        }
    }
    doc
}

/// What JSON Schema can say about the requests but utoipa's attributes cannot: (schema,
/// property, keyword, value). Positions are strictly increasing (so they are unique; the order
/// itself is not expressible and is stated in the field's description); the workpiece must
/// turn; η = 0 would stop it.
type Constraint = (
    &'static str,
    &'static str,
    &'static str,
    fn() -> serde_json::Value,
);

const CONSTRAINTS: [Constraint; 5] = [
    (
        "ProcessDto",
        "workpiece_rpm",
        "not",
        || serde_json::json!({"const": 0}),
    ),
    ("DwellDto", "positions_mm", "uniqueItems", || {
        serde_json::json!(true)
    }),
    ("OptimizeRequest", "positions_mm", "uniqueItems", || {
        serde_json::json!(true)
    }),
    ("MeasuredProfileDto", "radius_mm", "uniqueItems", || {
        serde_json::json!(true)
    }),
    (
        "EtaSweepRequest",
        "etas",
        "items.not",
        || serde_json::json!({"const": 0}),
    ),
];

/// The document as served and committed: pretty JSON with a final newline.
pub fn spec_json() -> String {
    let mut doc = serde_json::to_value(spec()).expect("the spec serialises");
    for (schema, property, keyword, value) in CONSTRAINTS {
        let mut target = &mut doc["components"]["schemas"][schema]["properties"][property];
        let mut path = keyword.split('.').peekable();
        while let Some(key) = path.next() {
            if path.peek().is_none() {
                target
                    .as_object_mut()
                    .expect("constraints name existing properties")
                    .insert(key.to_string(), value());
                break;
            }
            target = &mut target[key];
        }
    }
    // The surface variants are closed objects (serde denies unknown fields), and a zero
    // radius is a plane, which has its own kind.
    let variants = doc["components"]["schemas"]["SurfaceDto"]["oneOf"]
        .as_array_mut()
        .expect("SurfaceDto is a oneOf");
    for variant in variants {
        variant["additionalProperties"] = serde_json::json!(false);
        if let Some(radius) = variant["properties"].get_mut("radius_of_curvature_mm") {
            radius["not"] = serde_json::json!({"const": 0});
        }
    }
    query_mirrors_body(&mut doc);
    records::document_operations(&mut doc);
    let mut json = serde_json::to_string_pretty(&doc).expect("the spec serialises");
    json.push('\n');
    json
}

/// An operation with query parameters (the fit's `text/csv` form) takes the JSON body's other
/// fields there; each parameter gets exactly that field's schema (less its `null` branch):
/// objects as JSON-encoded values (`content: application/json`), numbers and enum names as
/// they are. A bare `type: string` would admit strings the service must refuse.
fn query_mirrors_body(doc: &mut serde_json::Value) {
    let schemas = doc["components"]["schemas"].clone();
    let Some(paths) = doc["paths"].as_object_mut() else {
        return;
    };
    // (Read with `pointer` and `get_mut`: indexing a Value mutably would add the keys.)
    for post in paths.values_mut().filter_map(|item| item.get_mut("post")) {
        let body_schema = post
            .pointer("/requestBody/content/application~1json/schema/$ref")
            .and_then(serde_json::Value::as_str)
            .and_then(|r| r.rsplit('/').next())
            .map(str::to_string);
        let parameters = post
            .get_mut("parameters")
            .and_then(serde_json::Value::as_array_mut);
        if let (Some(parameters), Some(body_schema)) = (parameters, body_schema) {
            mirror(parameters, &schemas[&body_schema]["properties"], &schemas);
        }
    }
}

fn mirror(
    parameters: &mut [serde_json::Value],
    properties: &serde_json::Value,
    schemas: &serde_json::Value,
) {
    for parameter in parameters {
        let name = parameter["name"].as_str().expect("parameters are named");
        let field = &properties[name];
        let mut schema = match field["oneOf"].as_array() {
            Some(branches) => branches
                .iter()
                .find(|b| b["type"] != "null")
                .expect("an optional field has a non-null branch")
                .clone(),
            None => field.clone(),
        };
        let parameter = parameter.as_object_mut().expect("a parameter is an object");
        if let Some(types) = schema["type"].as_array() {
            let not_null: Vec<_> = types.iter().filter(|t| *t != "null").cloned().collect();
            schema["type"] = serde_json::Value::Array(not_null);
            if let [only] = schema["type"].as_array().map(Vec::as_slice).unwrap_or(&[]) {
                schema["type"] = only.clone();
            }
        }
        let referenced = schema["$ref"]
            .as_str()
            .and_then(|r| r.rsplit('/').next())
            .map(|n| &schemas[n]);
        let is_object = referenced.is_some_and(|s| s["type"] == "object" || s["oneOf"].is_array());
        parameter.remove("schema");
        if is_object {
            parameter.insert(
                "content".to_string(),
                serde_json::json!({"application/json": {"schema": schema}}),
            );
        } else {
            parameter.insert("schema".to_string(), schema);
        }
    }
}

/// The error responses every computing endpoint can give, described once for the OpenAPI
/// document (the values are built as [`ApiError`]s, never as this enum).
#[derive(utoipa::IntoResponses)]
#[allow(dead_code)]
pub enum ComputeProblems {
    /// Malformed JSON
    #[response(status = 400, content_type = "application/problem+json")]
    Malformed(super::error::Problem),
    /// Body too large
    #[response(status = 413, content_type = "application/problem+json")]
    TooLarge(super::error::Problem),
    /// Invalid input, naming the field
    #[response(status = 422, content_type = "application/problem+json")]
    Invalid(super::error::Problem),
    /// No valid API key (only when the service has keys configured); `WWW-Authenticate: Bearer`
    #[response(status = 401, content_type = "application/problem+json")]
    Unauthorized(super::error::Problem),
    /// The client's rate limit is spent (only when the service limits rates); retry after
    /// Retry-After seconds
    #[response(status = 429, content_type = "application/problem+json")]
    RateLimited(super::error::Problem),
    /// Overloaded; retry after Retry-After seconds
    #[response(status = 503, content_type = "application/problem+json")]
    Overloaded(super::error::Problem),
}
