//! Requests whose data may come as `text/csv` (an instrument's export) with the other fields
//! as query parameters, or as one JSON body. The query's values are the JSON body's fields
//! (JSON values; enum names may be written bare); the CSV fills the members the endpoint says
//! ([`CsvForm::merge_csv`]); the result is parsed as the JSON body would be.

use axum::extract::{FromRequest, Query, Request};
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};
use utoipa::openapi::path::{Operation, Parameter};
use utoipa::openapi::{Content, ObjectBuilder, Type};

use super::endpoint::Body;
use super::error::{ApiError, Kind};
use super::extract;

const CSV: &str = "text/csv";

/// A request that also comes as `text/csv` plus query parameters.
pub trait CsvForm: DeserializeOwned + Send {
    /// The JSON body's fields a `text/csv` request takes as query parameters.
    const QUERY_FIELDS: &'static [&'static str];
    /// Those it must have (the query's schema cannot say so: with a JSON body it takes none).
    const REQUIRED_QUERY_FIELDS: &'static [&'static str] = &[];
    /// Puts what the CSV holds into the body the query built.
    fn merge_csv(bytes: &[u8], body: &mut Map<String, Value>) -> Result<(), ApiError>;
}

/// The request from a JSON body, or from a `text/csv` body and the query.
pub struct CsvOrJson<R>(pub R);

impl<R: CsvForm> Body<R> for CsvOrJson<R> {
    fn into_request(self) -> R {
        self.0
    }
}

impl<S: Send + Sync, R: CsvForm> FromRequest<S> for CsvOrJson<R> {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        let query: Vec<(String, String)> = Query::try_from_uri(req.uri())
            .map(|Query(q)| q)
            .map_err(|e| ApiError::invalid("query", e.body_text()))?;
        extract::check_content_type(req.headers(), &[CSV])?;
        if !extract::has_media(req.headers(), &[CSV]) {
            if let Some((name, _)) = query.first() {
                return Err(ApiError::invalid(
                    name.clone(),
                    format!(
                        "query parameters configure text/csv bodies; with a JSON body put \
                         `{name}` in the body"
                    ),
                ));
            }
            return extract::json_body(req, state).await.map(CsvOrJson);
        }
        let bytes = extract::read_body(req, state).await?;
        let mut body = query_object(query, R::QUERY_FIELDS)?;
        if let Some(name) = R::REQUIRED_QUERY_FIELDS
            .iter()
            .find(|name| !body.contains_key(**name))
        {
            return Err(ApiError::invalid(
                *name,
                format!("a text/csv body needs the query parameter `{name}` (its JSON value)"),
            ));
        }
        R::merge_csv(&bytes, &mut body)?;
        query_request(body).map(CsvOrJson)
    }
}

/// The request a file body's query composes (`query_object`, and the file's own members): the
/// parameters are text to the schema (each a field's JSON value), so a value that is not its
/// field's is an invalid input, not a mismatch of the schema.
pub fn query_request<R: DeserializeOwned>(body: Map<String, Value>) -> Result<R, ApiError> {
    let text = serde_json::to_vec(&body).map_err(|e| ApiError::internal(e.to_string()))?;
    extract::parse_json(&text)
        .map_err(|e| e.mismatch_as_invalid("a query parameter: the field's JSON value"))
}

/// The query's parameters as the members of a JSON body: each value JSON, or a bare word for
/// an enum name; only `fields` may appear, each once.
pub fn query_object(
    query: Vec<(String, String)>,
    fields: &[&str],
) -> Result<Map<String, Value>, ApiError> {
    let mut body = Map::new();
    for (name, value) in query {
        if !fields.contains(&name.as_str()) {
            return Err(ApiError::new(
                Kind::SchemaMismatch,
                format!(
                    "unknown query parameter `{name}`, expected one of {}",
                    fields.join(", ")
                ),
            )
            .at(name));
        }
        // A JSON value, or a bare word for an enum name.
        let value = serde_json::from_str(&value).unwrap_or(Value::String(value));
        if body.insert(name.clone(), value).is_some() {
            return Err(ApiError::invalid(name, "given twice"));
        }
    }
    Ok(body)
}

/// Documents the `text/csv` form of an operation: the body's second media type (with
/// `example`) and the query parameters that carry the other fields.
pub fn document(operation: &mut Operation, example: &str, parameters: Vec<Parameter>) {
    let mut csv = Content::new(Some(ObjectBuilder::new().schema_type(Type::String)));
    csv.example = Some(example.into());
    if let Some(body) = operation.request_body.as_mut() {
        body.content.insert(CSV.to_string(), csv);
    }
    operation.parameters = Some(parameters);
}
