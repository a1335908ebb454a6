//! How a map arrives: inside a JSON request (`map`: rows of heights), or as the body itself,
//! the file exactly as the instrument wrote it (`application/octet-stream`, `text/plain`,
//! `text/csv`), with the request's other fields as query parameters.

use axum::body::Bytes;
use axum::extract::{FromRequest, Query, Request};
use axum::http::{header, HeaderMap};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize};
use utoipa::openapi::path::{Operation, Parameter};
use utoipa::openapi::{Content, ObjectBuilder, RefOr, Schema, Type};
use utoipa::{PartialSchema, ToSchema};

use super::super::csv_body::query_object;
use super::super::endpoint::Body;
use super::super::error::ApiError;
use super::super::extract;
use crate::maps::{self, HeightMap};
use crate::usecases::map_analysis::MapOrigin;

/// The media types a map file may come as.
pub const FILE_TYPES: [&str; 3] = ["application/octet-stream", "text/plain", "text/csv"];

/// A map given as JSON: its rows of heights, top row first, and what the file would state.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapGridDto {
    /// Heights, nm: one list per row of pixels, the top row first, each row the same length;
    /// null where there is no data.
    #[schema(min_items = 1, example = json!([[null, 1.5, null], [2.0, 0.0, -1.0], [null, 0.5, null]]))]
    pub heights_nm: Vec<Vec<Option<f64>>>,
    /// Pixel pitch, mm (> 0).
    pub pixel_mm: Option<f64>,
    /// Measuring wavelength, nm (> 0).
    pub wavelength_nm: Option<f64>,
}

/// Where a request's map is: given as JSON, or the body's file. A JSON request must have it.
#[derive(Debug, Clone, Default)]
pub enum MapSource {
    #[default]
    Missing,
    Grid(MapGridDto),
    File(Bytes),
}

impl<'de> Deserialize<'de> for MapSource {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        MapGridDto::deserialize(d).map(MapSource::Grid)
    }
}

impl PartialSchema for MapSource {
    fn schema() -> RefOr<Schema> {
        utoipa::openapi::Ref::from_schema_name(MapGridDto::name()).into()
    }
}

impl ToSchema for MapSource {
    fn schemas(schemas: &mut Vec<(String, RefOr<Schema>)>) {
        schemas.push((MapGridDto::name().into_owned(), MapGridDto::schema()));
    }
}

impl MapSource {
    /// The map and where it came from; a file in any format `maps::read` tells apart (a JSON
    /// file is a [`MapGridDto`]). `field` names the map in problems.
    pub fn read(self, max_pixels: usize) -> Result<(HeightMap, MapOrigin), ApiError> {
        let grid = |g: MapGridDto| {
            HeightMap::from_rows(g.heights_nm, g.pixel_mm, g.wavelength_nm, max_pixels)
                .map_err(|e| ApiError::invalid("map", e.to_string()))
        };
        match self {
            MapSource::Missing => Err(ApiError::invalid(
                "map",
                "the map is required: `map` with its rows of heights, or the file itself as the \
                 body (Content-Type: application/octet-stream) with the other fields as query \
                 parameters",
            )),
            MapSource::Grid(g) => Ok((grid(g)?, MapOrigin::Heights)),
            MapSource::File(bytes) => {
                if bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{') {
                    let g: MapGridDto = extract::parse_json(&bytes).map_err(|e| e.under("map"))?;
                    return Ok((grid(g)?, MapOrigin::Heights));
                }
                let (format, map) = maps::read(&bytes, max_pixels)
                    .map_err(|e| ApiError::invalid("map", e.to_string()))?;
                Ok((map, MapOrigin::File(format)))
            }
        }
    }
}

/// A request whose map may be the body's file.
pub trait MapForm: DeserializeOwned + Send {
    /// The request's fields a file body takes as query parameters.
    const QUERY_FIELDS: &'static [&'static str];
    fn set_file(&mut self, bytes: Bytes);
}

/// The request from a JSON body, or from a file body and the query.
pub struct MapOrJson<R>(pub R);

impl<R: MapForm> Body<R> for MapOrJson<R> {
    fn into_request(self) -> R {
        self.0
    }
}

impl<S: Send + Sync, R: MapForm> FromRequest<S> for MapOrJson<R> {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        let query: Vec<(String, String)> = Query::try_from_uri(req.uri())
            .map(|Query(q)| q)
            .map_err(|e| ApiError::invalid("query", e.body_text()))?;
        extract::check_content_type(req.headers(), &FILE_TYPES)?;
        if !is_file(req.headers()) {
            if let Some((name, _)) = query.first() {
                return Err(ApiError::invalid(
                    name.clone(),
                    format!(
                        "query parameters configure a map file sent as the body; with a JSON \
                         body put `{name}` in the body"
                    ),
                ));
            }
            return extract::json_body(req, state).await.map(MapOrJson);
        }
        let bytes = extract::read_body(req, state).await?;
        let body = query_object(query, R::QUERY_FIELDS)?;
        let text = serde_json::to_vec(&body).map_err(|e| ApiError::internal(e.to_string()))?;
        let mut request: R = extract::parse_json(&text)?;
        request.set_file(bytes);
        Ok(MapOrJson(request))
    }
}

fn is_file(headers: &HeaderMap) -> bool {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.split(';').next())
        .is_some_and(|essence| {
            FILE_TYPES
                .iter()
                .any(|t| essence.trim().eq_ignore_ascii_case(t))
        })
}

/// Documents the file forms of an operation: the body's other media types and the query
/// parameters that carry the other fields.
pub fn document(operation: &mut Operation, parameters: Vec<Parameter>) {
    if let Some(body) = operation.request_body.as_mut() {
        let binary = || {
            Content::new(Some(ObjectBuilder::new().schema_type(Type::String).format(
                Some(utoipa::openapi::SchemaFormat::KnownFormat(
                    utoipa::openapi::KnownFormat::Binary,
                )),
            )))
        };
        for media in FILE_TYPES {
            body.content.insert(media.to_string(), binary());
        }
    }
    operation.parameters = Some(parameters);
}
