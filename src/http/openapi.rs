//! The OpenAPI document, generated from the code (utoipa) with request examples taken from
//! `fixtures/`, then finished by `contract` (what utoipa's attributes cannot say). Committed as `openapi/openapi.json`; `tests/it/openapi_drift.rs` fails when the
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
use crate::contract;

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
        (name = "maps", description = "Interferometer maps: read the instrument's files, analyse them as metrologists do"),
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
    // The record operations, declared with their routes (records::routes).
    doc.merge(records::paths());
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

/// The document as served and committed: pretty JSON with a final newline.
pub fn spec_json() -> String {
    let mut doc = serde_json::to_value(spec()).expect("the spec serialises");
    contract::finish(&mut doc);
    let mut json = serde_json::to_string_pretty(&doc).expect("the spec serialises");
    json.push('\n');
    json
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

/// A schema that is any of the named ones (`anyOf`: a body may fit more than one):
/// `any_of!(Name, [A, B], "doc")` declares the unit type `Name` for it; `any_of!(impl Type,
/// [A, B], "doc")` gives an existing type that schema, and `any_of!(impl Type as "Name",
/// [A, B], "doc")` names it too (a generic type's own name is not a schema's).
macro_rules! any_of {
    ($name:ident, [$($member:ty),*], $doc:literal) => {
        #[doc = $doc]
        pub struct $name;
        $crate::http::openapi::any_of!(impl $name, [$($member),*], $doc);
    };
    (impl $name:ty as $schema:literal, [$($member:ty),*], $doc:literal) => {
        $crate::http::openapi::any_of!(impl $name, [$($member),*], $doc, $schema);
    };
    (impl $name:ty, [$($member:ty),*], $doc:literal $(, $schema:literal)?) => {
        impl utoipa::PartialSchema for $name {
            fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::Schema> {
                let any = utoipa::openapi::schema::AnyOfBuilder::new().description(Some($doc));
                $(let any = any.item(utoipa::openapi::Ref::from_schema_name(
                    <$member as utoipa::ToSchema>::name(),
                ));)*
                utoipa::openapi::RefOr::T(utoipa::openapi::Schema::AnyOf(any.build()))
            }
        }

        impl utoipa::ToSchema for $name {
            $(fn name() -> std::borrow::Cow<'static, str> {
                std::borrow::Cow::Borrowed($schema)
            })?

            fn schemas(
                schemas: &mut Vec<(String, utoipa::openapi::RefOr<utoipa::openapi::Schema>)>,
            ) {
                $(
                    schemas.push((
                        <$member as utoipa::ToSchema>::name().into_owned(),
                        <$member as utoipa::PartialSchema>::schema(),
                    ));
                    <$member as utoipa::ToSchema>::schemas(schemas);
                )*
            }
        }
    };
}
pub(crate) use any_of;
