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

/// A probe export: optional `#` comment lines, an optional header naming `x_mm` and `z_mm`
/// (other columns ignored), then one point per row; without a header the first two columns
/// are x and z.
fn parse_trace_csv(bytes: &[u8]) -> Result<(Vec<f64>, Vec<f64>), ApiError> {
    let mut reader = ::csv::ReaderBuilder::new()
        .has_headers(false)
        .comment(Some(b'#'))
        .trim(::csv::Trim::All)
        .flexible(true)
        .from_reader(bytes);
    let (mut x_mm, mut z_mm) = (Vec::new(), Vec::new());
    let mut columns: Option<(usize, usize)> = None;
    for (line, record) in reader.records().enumerate() {
        let record = record.map_err(|e| ApiError::invalid("profile", format!("CSV: {e}")))?;
        if record.iter().all(str::is_empty) {
            continue;
        }
        let (xi, zi) = match columns {
            Some(c) => c,
            None => {
                let find = |name: &str| {
                    let name_of = |h: &str| h.trim_matches('"').eq_ignore_ascii_case(name);
                    record.iter().position(name_of)
                };
                if let (Some(x), Some(z)) = (find("x_mm"), find("z_mm")) {
                    columns = Some((x, z));
                    continue;
                }
                if record.get(0).is_none_or(|v| v.parse::<f64>().is_err()) {
                    return Err(ApiError::invalid(
                        "profile",
                        "a CSV trace starts with a header naming the columns x_mm and z_mm \
                         (or with a row of numbers: x then z)",
                    ));
                }
                columns = Some((0, 1));
                (0, 1)
            }
        };
        let index = x_mm.len();
        for (column, axis, values) in [(xi, "x_mm", &mut x_mm), (zi, "z_mm", &mut z_mm)] {
            let text = record.get(column).unwrap_or("");
            let value: f64 = text
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    ApiError::invalid(
                        format!("profile.{axis}[{index}]"),
                        format!("CSV row {}: `{text}` is not a finite number", line + 1),
                    )
                })?;
            values.push(value);
        }
    }
    Ok((x_mm, z_mm))
}
