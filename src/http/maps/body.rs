//! How a map arrives: inside a JSON request (`map`: rows of heights), or as the body itself,
//! the file exactly as the instrument wrote it (`application/octet-stream`, `text/plain`,
//! `text/csv`), with the request's other fields as query parameters. A request of two maps
//! (before and after) takes its files as `multipart/form-data`, one part per map.

use axum::body::Bytes;
use axum::extract::{FromRequest, Multipart, Query, Request};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize};
use utoipa::openapi::path::{Operation, Parameter, ParameterBuilder, ParameterIn};
use utoipa::openapi::{Content, ObjectBuilder, RefOr, Required, Schema, Type};
use utoipa::{PartialSchema, ToSchema};

use super::super::csv_body::{query_object, query_request};
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
    /// Pixel pitch, mm (> 0, the map at most 100 m across).
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
    pub fn read(self, field: &str, max_pixels: usize) -> Result<(HeightMap, MapOrigin), ApiError> {
        let grid = |g: MapGridDto| {
            HeightMap::from_rows(g.heights_nm, g.pixel_mm, g.wavelength_nm, max_pixels)
                .map_err(|e| ApiError::invalid(field, e.to_string()))
        };
        match self {
            MapSource::Missing => Err(ApiError::invalid(
                field,
                format!(
                    "`{field}` is required: its rows of heights, or its file as the body \
                     (Content-Type: application/octet-stream; two maps: multipart/form-data, a \
                     part each) with the other fields as query parameters"
                ),
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

/// The media type of a request carrying several files.
pub const MULTIPART: &str = "multipart/form-data";

/// A request whose maps may be files.
pub trait MapForm: DeserializeOwned + Send {
    /// The request's map fields: one (the body is the file) or more (multipart, a part each).
    const FILES: &'static [&'static str];
    /// The request's fields a file body takes as query parameters.
    const QUERY_FIELDS: &'static [&'static str];
    /// Puts the file of map field `name` in the request.
    fn set_file(&mut self, name: &str, bytes: Bytes);
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
        let multipart = R::FILES.len() > 1;
        let media: &[&str] = if multipart { &[MULTIPART] } else { &FILE_TYPES };
        extract::check_content_type(req.headers(), media)?;
        if !extract::has_media(req.headers(), media) {
            if let Some((name, _)) = query.first() {
                return Err(ApiError::invalid(
                    name.clone(),
                    format!(
                        "query parameters configure map files sent as the body; with a JSON \
                         body put `{name}` in the body"
                    ),
                ));
            }
            return extract::json_body(req, state).await.map(MapOrJson);
        }
        let mut request: R = query_request(query_object(query, R::QUERY_FIELDS)?)?;
        if !multipart {
            request.set_file(R::FILES[0], extract::read_body(req, state).await?);
            return Ok(MapOrJson(request));
        }
        let mut form = Multipart::from_request(req, state)
            .await
            .map_err(|e| ApiError::invalid("body", e.body_text()))?;
        let mut seen = Vec::new();
        while let Some(field) = form.next_field().await.map_err(|e| {
            if e.status() == axum::http::StatusCode::PAYLOAD_TOO_LARGE {
                ApiError::invalid("body", e.body_text())
            } else {
                ApiError::invalid(
                    "body",
                    format!("a multipart part could not be read: {}", e.body_text()),
                )
            }
        })? {
            let name = field.name().unwrap_or("").to_string();
            let Some(known) = R::FILES.iter().find(|f| **f == name) else {
                return Err(ApiError::invalid(
                    "body",
                    format!(
                        "unknown part `{name}`: the parts are {}",
                        R::FILES.join(" and ")
                    ),
                ));
            };
            if seen.contains(known) {
                return Err(ApiError::invalid(*known, "given twice"));
            }
            let bytes = field
                .bytes()
                .await
                .map_err(|e| ApiError::invalid(*known, e.body_text()))?;
            request.set_file(known, bytes);
            seen.push(*known);
        }
        if let Some(missing) = R::FILES.iter().find(|f| !seen.contains(f)) {
            return Err(ApiError::invalid(
                *missing,
                format!("the multipart body has no `{missing}` part (its map file)"),
            ));
        }
        Ok(MapOrJson(request))
    }
}

/// Documents the file forms of an operation: the body's other media types and the query
/// parameters that carry the other fields.
pub fn document(operation: &mut Operation, files: &[&str], fields: &[&str]) {
    let parameters: Vec<Parameter> = fields
        .iter()
        .map(|name| {
            ParameterBuilder::new()
                .name(*name)
                .parameter_in(ParameterIn::Query)
                .required(Required::False)
                .description(Some(
                    "With file bodies: the JSON field of the same name, as its JSON value (enum \
                     names may be bare)",
                ))
                .schema(Some(ObjectBuilder::new().schema_type(Type::String)))
                .build()
        })
        .collect();
    if let Some(body) = operation.request_body.as_mut() {
        if files.len() > 1 {
            let mut form = ObjectBuilder::new();
            for name in files {
                form = form
                    .property(
                        *name,
                        ObjectBuilder::new().schema_type(Type::String).format(Some(
                            utoipa::openapi::SchemaFormat::KnownFormat(
                                utoipa::openapi::KnownFormat::Binary,
                            ),
                        )),
                    )
                    .required(*name);
            }
            body.content
                .insert(MULTIPART.to_string(), Content::new(Some(form)));
            operation.parameters = Some(parameters);
            return;
        }
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
