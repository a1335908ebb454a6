//! The fit's request from the probe's own `text/csv` export (`x_mm,z_mm` columns) with the
//! other fields as query parameters, or from a JSON body.

use axum::extract::{FromRequest, Query, Request};
use axum::http::{header, HeaderMap};
use serde::Deserialize;
use utoipa::IntoParams;

use super::super::endpoint::Body;
use super::super::error::{ApiError, Kind};
use super::super::extract;
use super::MeasurementFitRequest;
use crate::report::table::{read_columns, ReadError};

/// Query parameters for a `text/csv` body: each is the JSON field of the same name (a JSON
/// value; enum names may be written bare), e.g.
/// `?surface={"kind":"sphere","radius_of_curvature_mm":100}&robust=tukey`. Not allowed with
/// a JSON body (put the fields in the body).
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[allow(dead_code)] // documents the query; the handler reads it as name/value pairs
pub struct CsvQuery {
    /// `surface` as JSON, e.g. `{"kind":"sphere","radius_of_curvature_mm":100}`.
    surface: Option<String>,
    /// `probe_tip_radius_mm`, mm.
    probe_tip_radius_mm: Option<f64>,
    /// `compensation`: `normal` or `axial`.
    compensation: Option<String>,
    /// `fit` as JSON, e.g. `{"radius_of_curvature":true}`.
    fit: Option<String>,
    /// `robust`: `none`, `huber` or `tukey`.
    robust: Option<String>,
    /// `radial_grid` as JSON.
    radial_grid: Option<String>,
    /// `clear_aperture` as JSON.
    clear_aperture: Option<String>,
}

const QUERY_FIELDS: [&str; 7] = [
    "surface",
    "probe_tip_radius_mm",
    "compensation",
    "fit",
    "robust",
    "radial_grid",
    "clear_aperture",
];

const CSV: &str = "text/csv";

/// The request from a JSON body, or from a `text/csv` trace and the query.
pub struct FitBody(pub MeasurementFitRequest);

impl Body<MeasurementFitRequest> for FitBody {
    fn into_request(self) -> MeasurementFitRequest {
        self.0
    }
}

impl<S: Send + Sync> FromRequest<S> for FitBody {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        let query: Vec<(String, String)> = Query::try_from_uri(req.uri())
            .map(|Query(q)| q)
            .map_err(|e| ApiError::invalid("query", e.body_text()))?;
        extract::check_content_type(req.headers(), &[CSV])?;
        if !is_csv(req.headers()) {
            if let Some((name, _)) = query.first() {
                return Err(ApiError::invalid(
                    name.clone(),
                    format!(
                        "query parameters configure text/csv bodies; with a JSON body put \
                         `{name}` in the body"
                    ),
                ));
            }
            return extract::json_body(req, state).await.map(FitBody);
        }
        let bytes = extract::read_body(req, state).await?;
        let (x_mm, z_mm) = parse_trace_csv(&bytes)?;
        let mut body = serde_json::Map::new();
        for (name, value) in query {
            if !QUERY_FIELDS.contains(&name.as_str()) {
                return Err(ApiError::new(
                    Kind::SchemaMismatch,
                    format!(
                        "unknown query parameter `{name}`, expected one of {}",
                        QUERY_FIELDS.join(", ")
                    ),
                )
                .at(name));
            }
            // A JSON value, or a bare word for an enum name.
            let value = serde_json::from_str(&value).unwrap_or(serde_json::Value::String(value));
            if body.insert(name.clone(), value).is_some() {
                return Err(ApiError::invalid(name, "given twice"));
            }
        }
        body.insert(
            "profile".to_string(),
            serde_json::json!({ "x_mm": x_mm, "z_mm": z_mm }),
        );
        let text = serde_json::to_vec(&body).map_err(|e| ApiError::internal(e.to_string()))?;
        extract::parse_json(&text).map(FitBody)
    }
}

fn is_csv(headers: &HeaderMap) -> bool {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.split(';').next())
        .is_some_and(|essence| essence.trim().eq_ignore_ascii_case(CSV))
}

/// A probe export (`report::table::read_columns`): the values land in `profile`.
fn parse_trace_csv(bytes: &[u8]) -> Result<(Vec<f64>, Vec<f64>), ApiError> {
    let [x_mm, z_mm] = read_columns(bytes, ["x_mm", "z_mm"]).map_err(|e| {
        let field = match &e {
            ReadError::NotANumber { column, index, .. } => format!("profile.{column}[{index}]"),
            ReadError::Csv(_) | ReadError::NoHeader(..) => "profile".to_string(),
        };
        ApiError::invalid(field, e.to_string())
    })?;
    Ok((x_mm, z_mm))
}
