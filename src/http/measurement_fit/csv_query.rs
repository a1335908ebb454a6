//! The fit's request from the probe's own `text/csv` export (`x_mm,z_mm` columns) with the
//! other fields as query parameters ([`super::super::csv_body`]).

use serde::Deserialize;
use serde_json::{json, Map, Value};
use utoipa::IntoParams;

use super::super::csv_body::CsvForm;
use super::super::error::ApiError;
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

impl CsvForm for MeasurementFitRequest {
    const QUERY_FIELDS: &'static [&'static str] = &[
        "surface",
        "probe_tip_radius_mm",
        "compensation",
        "fit",
        "robust",
        "radial_grid",
        "clear_aperture",
    ];

    /// A probe export (`report::table::read_columns`): the values land in `profile`.
    fn merge_csv(bytes: &[u8], body: &mut Map<String, Value>) -> Result<(), ApiError> {
        let [x_mm, z_mm] = read_columns(bytes, ["x_mm", "z_mm"]).map_err(|e| {
            let field = match &e {
                ReadError::NotANumber { column, index, .. } => {
                    format!("profile.{column}[{index}]")
                }
                ReadError::Csv { .. } | ReadError::NoHeader { .. } => "profile".to_string(),
            };
            ApiError::invalid(field, e.to_string())
        })?;
        body.insert("profile".to_string(), json!({ "x_mm": x_mm, "z_mm": z_mm }));
        Ok(())
    }
}
