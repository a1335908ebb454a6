//! The calibration's request from ring tests as `text/csv`
//! (`position_mm,duration_s,radius_mm,depth_nm` columns) with the other fields as query
//! parameters ([`super::super::csv_body`]).

use serde::Deserialize;
use serde_json::{json, Map, Value};
use utoipa::IntoParams;

use super::super::csv_body::CsvForm;
use super::super::error::ApiError;
use super::CalibrationRequest;
use crate::report::table::read_columns;

/// Query parameters for a `text/csv` body of ring tests (columns
/// `position_mm,duration_s,radius_mm,depth_nm`: each row one measured point of the groove the
/// tool cut parked at `position_mm` for `duration_s`; one run per distinct position and
/// duration, in order of first appearance): each is the JSON field of the same name, e.g.
/// `?process={…}&fit={"tool_radius":true}`. Dwell runs and before/after profiles take a JSON
/// body. Not allowed with a JSON body.
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
        "fit",
        "robust",
        "expected_noise_nm",
    ];
    const REQUIRED_QUERY_FIELDS: &'static [&'static str] = &["process"];

    /// The rows become ring runs: one per distinct (position, duration), its points in order.
    fn merge_csv(bytes: &[u8], body: &mut Map<String, Value>) -> Result<(), ApiError> {
        let names = ["position_mm", "duration_s", "radius_mm", "depth_nm"];
        let [position, duration, radius, depth] = read_columns(bytes, names)
            .map_err(|e| ApiError::invalid("runs", format!("the CSV body: {e}")))?;
        let mut keys: Vec<(f64, f64)> = Vec::new();
        let mut runs: Vec<Value> = Vec::new();
        for i in 0..position.len() {
            let key = (position[i], duration[i]);
            let j = keys.iter().position(|k| *k == key).unwrap_or_else(|| {
                keys.push(key);
                runs.push(json!({"ring": {"position_mm": key.0, "duration_s": key.1},
                                 "removal": {"radius_mm": [], "depth_nm": []}}));
                runs.len() - 1
            });
            for (member, value) in [("radius_mm", radius[i]), ("depth_nm", depth[i])] {
                if let Some(Value::Array(values)) = runs[j]["removal"].get_mut(member) {
                    values.push(json!(value));
                }
            }
        }
        body.insert("runs".to_string(), Value::Array(runs));
        Ok(())
    }
}
