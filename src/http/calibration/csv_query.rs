//! The calibration's request from a profilometer's `text/csv` (`run,radius_mm,depth_nm`
//! columns) with the other fields as query parameters ([`super::super::csv_body`]).

use serde::Deserialize;
use serde_json::{json, Map, Value};
use utoipa::IntoParams;

use super::super::csv_body::CsvForm;
use super::super::error::{ApiError, Kind};
use super::CalibrationRequest;
use crate::report::table::read_columns;

/// Query parameters for a `text/csv` body (columns `run,radius_mm,depth_nm`: each row one
/// measured point of the removal of run `run`, counted from 0 in `runs`): each is the JSON
/// field of the same name, e.g. `?process={…}&runs=[{"ring":{"position_mm":15,"duration_s":1200}}]`.
/// Not allowed with a JSON body.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[allow(dead_code)] // documents the query; the extractor reads it as name/value pairs
pub struct CalibrationCsvQuery {
    /// `process` as JSON.
    process: Option<String>,
    /// `surface` as JSON.
    surface: Option<String>,
    /// `tool` as JSON.
    tool: Option<String>,
    /// `runs` as JSON: what each run ran (`ring` or `dwell`, and `clear_aperture`), without
    /// what it removed (the CSV's rows).
    runs: Option<String>,
    /// `fit` as JSON.
    fit: Option<String>,
    /// `robust`: `none`, `huber` or `tukey`.
    robust: Option<String>,
    /// `expected_noise_nm`, nm.
    expected_noise_nm: Option<f64>,
}

impl CsvForm for CalibrationRequest {
    const QUERY_FIELDS: &'static [&'static str] = &[
        "process",
        "surface",
        "tool",
        "runs",
        "fit",
        "robust",
        "expected_noise_nm",
    ];

    /// Each row's radius and depth join the `removal` of the run its `run` column names.
    fn merge_csv(bytes: &[u8], body: &mut Map<String, Value>) -> Result<(), ApiError> {
        let [run, radius, depth] = read_columns(bytes, ["run", "radius_mm", "depth_nm"])
            .map_err(|e| ApiError::invalid("runs", format!("the CSV body: {e}")))?;
        let Some(Value::Array(runs)) = body.get_mut("runs") else {
            return Err(ApiError::invalid(
                "runs",
                "a text/csv body needs the query parameter `runs`: a JSON array of what each \
                 run ran (ring or dwell)",
            ));
        };
        let count = runs.len();
        for (row, ((&j, &r), &d)) in run.iter().zip(&radius).zip(&depth).enumerate() {
            let index = Some(j)
                .filter(|j| j.fract() == 0.0 && *j >= 0.0 && (*j as usize) < count)
                .map(|j| j as usize)
                .ok_or_else(|| {
                    ApiError::invalid(
                        "runs",
                        format!(
                            "CSV point {row}: run {j} is not one of the query's {count} runs \
                             (counted from 0)"
                        ),
                    )
                })?;
            let Value::Object(target) = &mut runs[index] else {
                return Err(ApiError::new(
                    Kind::SchemaMismatch,
                    format!("runs[{index}] must be an object"),
                )
                .at(format!("runs[{index}]")));
            };
            let removal = target
                .entry("removal")
                .or_insert_with(|| json!({"radius_mm": [], "depth_nm": []}));
            for (member, value) in [("radius_mm", r), ("depth_nm", d)] {
                if let Some(Value::Array(values)) = removal.get_mut(member) {
                    values.push(json!(value));
                }
            }
        }
        Ok(())
    }
}
