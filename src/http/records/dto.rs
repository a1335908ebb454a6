//! The records' wire types. Stored documents travel as JSON values, each documented with the
//! schema of what it is (`value_type`).

use serde::{Deserialize, Serialize};
use serde_json::Value;
use utoipa::ToSchema;

use super::docs::{PlanRequestAsRun, PlanResult};
use crate::http::calibration::CalibrationResponse;
use crate::http::dto::{ClearApertureDto, ProcessDto, SurfaceDto, ToolDto, WarningDto};
use crate::http::measurement_fit::{MeasurementFitRequest, MeasurementFitResponse};

/// `POST /v1/process-profiles`: a shop's named process.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ProcessProfileRequest {
    /// 1–64 of A–Z, a–z, 0–9, `-`, `_`, `.` (it is a path segment); unique.
    #[schema(pattern = "^[A-Za-z0-9._-]{1,64}$")]
    pub name: String,
    /// The nominal process (a part's `workpiece_radius_mm` replaces its workpiece radius).
    pub process: ProcessDto,
    /// Default for calibrations on this profile; a part's surface is its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface: Option<SurfaceDto>,
    /// The tool (pivot, orientation) used with this process.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool: Option<ToolDto>,
}

/// Where a profile's current Preston coefficient comes from.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RateSourceDto {
    /// The profile's own process: nothing calibrated yet.
    Profile,
    /// The latest calibration asked for (ring tests).
    Calibration,
    /// Learned from production cycles since that calibration (their inverse-variance mean).
    Learned,
}

/// A process profile and the process plans on it use now.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ProcessProfileDto {
    /// Its name.
    pub name: String,
    /// The process as created.
    #[schema(value_type = ProcessDto)]
    pub process: Value,
    /// The surface (null: a plane).
    #[schema(value_type = Option<SurfaceDto>)]
    pub surface: Option<Value>,
    /// The tool (null: the default).
    #[schema(value_type = Option<ToolDto>)]
    pub tool: Option<Value>,
    /// The process a plan uses now: the latest calibration asked for (or the profile's own),
    /// with the Preston coefficient learned from production since.
    #[schema(value_type = ProcessDto)]
    pub current_process: Value,
    /// Where the current Preston coefficient comes from.
    pub preston_coefficient_source: RateSourceDto,
    /// The current coefficient's standard error (null when never calibrated).
    pub preston_coefficient_standard_error_m2_per_n: Option<f64>,
    /// RFC 3339 UTC.
    pub created_at: String,
    /// The API key that wrote it (empty when the service runs without keys).
    pub created_by: String,
    /// Which code wrote it: the Preston version, the build's git revision and the records
    /// schema, e.g. `preston 0.1.0 (git 0e2373b4f1c2), records schema 6`; null for a record
    /// written before the records kept it.
    #[schema(required = true)]
    pub computed_by: Option<String>,
    /// Its calibrations, newest first (in `GET /v1/process-profiles/{name}` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibrations: Option<Vec<CalibrationRecordDto>>,
}

/// `GET /v1/process-profiles`.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ProcessProfileListDto {
    /// By name.
    pub items: Vec<ProcessProfileDto>,
}

/// A stored calibration.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct CalibrationRecordDto {
    /// The record's id (a UUIDv7: ids sort in the order records were written).
    pub id: String,
    /// The process profile's name.
    pub process_profile: String,
    /// The profile learns from it: fitted to a production cycle (`run_id`) and significant
    /// (K at least 2 standard errors above 0). A cycle's calibration that is not keeps its
    /// `run_id` but is `learned: false` and teaches nothing (its cycle warns
    /// `removal_not_significant`); a calibration asked for (ring tests) has no `run_id`.
    pub learned: bool,
    /// The production run it was fitted to (null for a calibration asked for).
    pub run_id: Option<String>,
    /// The Preston coefficient K, m²/N.
    pub preston_coefficient_m2_per_n: f64,
    /// K's standard error, m²/N (null when the data did not determine it).
    pub standard_error_m2_per_n: Option<f64>,
    /// The calibration as `/v1/calibration` answered it.
    #[schema(value_type = CalibrationResponse)]
    pub result: Value,
    /// When it was written, RFC 3339 UTC.
    pub created_at: String,
    /// The name of the API key that wrote it (empty when the service runs without keys).
    pub created_by: String,
    /// Which code wrote it: the Preston version, the build's git revision and the records
    /// schema, e.g. `preston 0.1.0 (git 0e2373b4f1c2), records schema 6`; null for a record
    /// written before the records kept it.
    #[schema(required = true)]
    pub computed_by: Option<String>,
}

/// `POST /v1/parts`.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PartRequest {
    /// The shop's serial: 1–200 characters, no control characters, no leading or trailing
    /// white space; unique.
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = "^[^\\s\\x00-\\x1f\\x7f]([^\\x00-\\x1f\\x7f]*[^\\s\\x00-\\x1f\\x7f])?$"
    )]
    pub name: String,
    /// The profile its plans use.
    pub process_profile: String,
    /// Default a plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface: Option<SurfaceDto>,
    /// The part's radius, mm (it replaces the profile process's workpiece radius).
    #[schema(exclusive_minimum = 0.0)]
    pub workpiece_radius_mm: f64,
    /// Default for its measurements and plans: the whole part.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clear_aperture: Option<ClearApertureDto>,
}

/// A part.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct PartDto {
    /// The record's id (a UUIDv7: ids sort in the order records were written).
    pub id: String,
    /// Its name.
    pub name: String,
    /// The process profile's name.
    pub process_profile: String,
    /// The surface (null: a plane).
    #[schema(value_type = Option<SurfaceDto>)]
    pub surface: Option<Value>,
    /// The part's radius, mm (it replaces the profile process's workpiece radius).
    pub workpiece_radius_mm: f64,
    /// The clear aperture (null: the whole part).
    #[schema(value_type = Option<ClearApertureDto>)]
    pub clear_aperture: Option<Value>,
    /// When it was written, RFC 3339 UTC.
    pub created_at: String,
    /// The name of the API key that wrote it (empty when the service runs without keys).
    pub created_by: String,
    /// Which code wrote it: the Preston version, the build's git revision and the records
    /// schema, e.g. `preston 0.1.0 (git 0e2373b4f1c2), records schema 6`; null for a record
    /// written before the records kept it.
    #[schema(required = true)]
    pub computed_by: Option<String>,
}

/// `GET /v1/parts`: a page in creation order.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct PartListDto {
    /// The items.
    pub items: Vec<PartDto>,
    /// Pass as `cursor` for the next page; null on the last.
    pub next_cursor: Option<String>,
}

/// A measurement's request as run: a probe trace's fit, or a map's analysis (less the file).
#[derive(ToSchema)]
#[serde(untagged)]
#[allow(dead_code)]
pub enum MeasurementRequestAsRun {
    Trace(Box<MeasurementFitRequest>),
    Map(super::docs::PartMapMeasurementRequest),
}

/// A measurement's answer: a probe trace's fit, or a map's analysis.
#[derive(ToSchema)]
#[serde(untagged)]
#[allow(dead_code)]
pub enum MeasurementAnswer {
    Trace(MeasurementFitResponse),
    Map(crate::http::maps::MapAnalysisResponse),
}

/// A stored measurement: the fit as run and its answer.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct MeasurementDto {
    /// The record's id (a UUIDv7: ids sort in the order records were written).
    pub id: String,
    /// The part's id.
    pub part_id: String,
    /// The form error's RMS over the clear aperture (a map's after piston and tilt, its
    /// `metrics.rms_nm`).
    pub rms_nm: f64,
    /// The request as run (with what the records supplied): a `/v1/measurement/fit` request,
    /// or for a map the `/v1/maps/analysis` request less its file.
    #[schema(value_type = MeasurementRequestAsRun)]
    pub request: Value,
    /// Its answer, as the endpoint returned it.
    #[schema(value_type = MeasurementAnswer)]
    pub result: Value,
    /// The map's file (its SHA-256) when an interferometer map measured the part:
    /// `GET /v1/measurements/{id}/map` returns it byte for byte. Null for a probe trace.
    pub map_sha256: Option<String>,
    /// The run this measurement completed (its cycle's after-measurement), if any.
    pub completes_run_id: Option<String>,
    /// The calibration learned from that cycle, if the removal determined one.
    pub learned_calibration_id: Option<String>,
    /// `removal_not_significant` when this measurement completed a cycle that taught
    /// nothing; empty otherwise.
    pub warnings: Vec<WarningDto>,
    /// When it was written, RFC 3339 UTC.
    pub created_at: String,
    /// The name of the API key that wrote it (empty when the service runs without keys).
    pub created_by: String,
    /// Which code wrote it: the Preston version, the build's git revision and the records
    /// schema, e.g. `preston 0.1.0 (git 0e2373b4f1c2), records schema 6`; null for a record
    /// written before the records kept it.
    #[schema(required = true)]
    pub computed_by: Option<String>,
}

/// A stored plan: the optimization as run (with the process and surface it used) and its answer.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct PlanDto {
    /// The record's id (a UUIDv7: ids sort in the order records were written).
    pub id: String,
    /// The part's id.
    pub part_id: String,
    /// The part's latest measurement when planned (the cycle's before).
    pub measurement_id: Option<String>,
    /// The residual's RMS over the clear aperture the plan predicts.
    pub predicted_rms_after_nm: f64,
    /// The request as run (with what the records supplied).
    #[schema(value_type = PlanRequestAsRun)]
    pub request: Value,
    /// Its answer, as the endpoint returned it.
    #[schema(value_type = PlanResult)]
    pub result: Value,
    /// When it was written, RFC 3339 UTC.
    pub created_at: String,
    /// The name of the API key that wrote it (empty when the service runs without keys).
    pub created_by: String,
    /// Which code wrote it: the Preston version, the build's git revision and the records
    /// schema, e.g. `preston 0.1.0 (git 0e2373b4f1c2), records schema 6`; null for a record
    /// written before the records kept it.
    #[schema(required = true)]
    pub computed_by: Option<String>,
}

/// `POST /v1/parts/{id}/runs`: a plan run on the machine.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RunRequest {
    /// A plan of this part.
    pub plan_id: String,
    /// RFC 3339 UTC, e.g. `2026-11-25T08:00:00Z`.
    pub started_at: String,
    /// RFC 3339 UTC, not before `started_at`.
    pub finished_at: String,
    /// The machine's name (up to 200 characters).
    #[serde(default)]
    pub machine: Option<String>,
    /// Up to 4000 characters.
    #[serde(default)]
    pub notes: Option<String>,
}

/// A run.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct RunRecordDto {
    /// The record's id (a UUIDv7: ids sort in the order records were written).
    pub id: String,
    /// The part's id.
    pub part_id: String,
    /// The plan's id.
    pub plan_id: String,
    /// RFC 3339 UTC.
    pub started_at: String,
    /// RFC 3339 UTC.
    pub finished_at: String,
    /// The machine's name.
    pub machine: Option<String>,
    /// Free text.
    pub notes: Option<String>,
    /// When it was written, RFC 3339 UTC.
    pub created_at: String,
    /// The name of the API key that wrote it (empty when the service runs without keys).
    pub created_by: String,
    /// Which code wrote it: the Preston version, the build's git revision and the records
    /// schema, e.g. `preston 0.1.0 (git 0e2373b4f1c2), records schema 6`; null for a record
    /// written before the records kept it.
    #[schema(required = true)]
    pub computed_by: Option<String>,
}

/// A value with its standard error.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct RatioDto {
    /// The value.
    pub value: f64,
    /// Its standard error (null when not determined).
    pub standard_error: Option<f64>,
}

/// One cycle: measurement before → plan → run → measurement after.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct CycleDto {
    /// The run's id.
    pub run_id: String,
    /// The plan's id.
    pub plan_id: String,
    /// The measurement before (the plan's).
    pub measurement_before_id: Option<String>,
    /// The first measurement after the run (null until measured, or when another run came first).
    pub measurement_after_id: Option<String>,
    /// The form error's RMS before, over the clear aperture, nm.
    pub rms_before_nm: Option<f64>,
    /// The residual's RMS the plan predicted, over the clear aperture, nm.
    pub predicted_rms_after_nm: f64,
    /// The form error's RMS after, over the clear aperture, nm.
    pub rms_after_nm: Option<f64>,
    /// RMS before / RMS after over the clear aperture.
    pub convergence_ratio: Option<f64>,
    /// Actual / predicted removal: the run's dwell fitted to before − after as a calibration
    /// of the Preston coefficient, relative to the coefficient the plan used.
    pub removal_ratio: Option<RatioDto>,
    /// The calibration the profile learned from this cycle (none when its removal did not
    /// determine K: then `warnings` says so, and `removal_ratio` is the fit's, if one fitted).
    pub learned_calibration_id: Option<String>,
    /// `removal_not_significant` when the cycle is complete but taught nothing (its removal
    /// is not 2 standard errors above 0: the run removed nothing measurable); empty otherwise.
    pub warnings: Vec<WarningDto>,
}

/// `GET /v1/parts/{id}/history`.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct HistoryDto {
    /// The part.
    pub part: PartDto,
    /// Oldest first.
    pub cycles: Vec<CycleDto>,
    /// The process the next plan will use (the profile's current one, on this part).
    #[schema(value_type = ProcessDto)]
    pub next_process: Value,
}
