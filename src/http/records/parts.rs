//! Parts and their measurements. A measurement that follows a run completes that run's cycle:
//! the run's dwell is fitted to the measured removal as a calibration of the Preston
//! coefficient, stored with the measurement (one transaction) as learned from production.

use axum::extract::{Path, Query, State};
use axum::http::{HeaderMap, Uri};
use axum::response::Response;
use serde::{Deserialize, Serialize};
use serde_json::{json, Map, Value};

use super::docs::{PartMeasurementRequest, RecordReadProblems, RecordWriteProblems};
use super::dto::{MeasurementDto, PartDto, PartListDto, PartRequest};
use super::profiles::{check_setting, current_process, fitted_coefficient, load_profile};
use super::{compute, document, fetched, not_found, store, without, Write, Writer};
use crate::http::calibration::CalibrationEndpoint;
use crate::http::csv_body::{CsvForm, CsvOrJson};
use crate::http::error::ApiError;
use crate::http::extract::ApiJson;
use crate::http::measurement_fit::MeasurementFitEndpoint;
use crate::http::state::AppState;
use crate::store::Store;
use crate::usecases::records::{
    cycles, run_completed_by_new_measurement, CalibrationRecord, MeasurementRecord, PartRecord,
    Record, Records,
};

/// Most parts a page lists.
pub const MAX_PAGE: usize = 100;

pub(super) async fn load_part(store: &Store, id: &str) -> Result<PartRecord, ApiError> {
    store.part(id).await?.ok_or_else(|| not_found("part", id))
}

pub(super) fn part_dto(part: &PartRecord) -> Result<PartDto, ApiError> {
    let body = document(&part.body)?;
    Ok(PartDto {
        id: part.stamp.id.clone(),
        name: part.name.clone(),
        process_profile: part.process_profile.clone(),
        surface: body.get("surface").cloned(),
        workpiece_radius_mm: body["workpiece_radius_mm"].as_f64().unwrap_or(f64::NAN),
        clear_aperture: body.get("clear_aperture").cloned(),
        created_at: part.stamp.created_at.clone(),
        created_by: part.stamp.created_by.clone(),
    })
}

#[utoipa::path(post, path = "/v1/parts", tag = "records", operation_id = "createPart", summary = "Create a part",
    params(("Idempotency-Key" = Option<String>, Header, description = "1–255 visible ASCII characters; a retry with the same key and request gets the first answer")), request_body = PartRequest,
    responses((status = 201, description = "Written (or the first answer to this Idempotency-Key)", body = PartDto,
        headers(("Location" = String, description = "The new record"))), RecordWriteProblems))]
/// `POST /v1/parts`
pub async fn create(
    State(state): State<AppState>,
    caller: Writer,
    headers: HeaderMap,
    ApiJson(request): ApiJson<PartRequest>,
) -> Result<Response, ApiError> {
    let name_ok = (1..=200).contains(&request.name.chars().count())
        && !request.name.chars().any(char::is_control)
        && request.name.trim() == request.name;
    if !name_ok {
        return Err(ApiError::invalid(
            "name",
            "a part's name (its serial) is 1 to 200 characters, no control characters, no \
             leading or trailing spaces",
        ));
    }
    let body = serde_json::to_value(&request).map_err(|e| ApiError::internal(e.to_string()))?;
    let store = store(&state)?;
    let write = Write::begin(caller, &headers, &format!("POST /v1/parts\n{body}"))?;
    if let Some(replay) = write.replay(store).await? {
        return Ok(replay);
    }
    let profile = store
        .profile(&request.process_profile)
        .await?
        .ok_or_else(|| {
            ApiError::invalid(
                "process_profile",
                format!("there is no process profile `{}`", request.process_profile),
            )
        })?;
    let (process, _, _) = current_process(&profile, &store.calibrations(&profile.stamp.id).await?)?;
    let setting = on_part(process, &body);
    check_setting(&state, &setting).map_err(|e| match e.field.as_deref() {
        Some("process.workpiece_radius_mm") => e.at("workpiece_radius_mm"),
        _ => e,
    })?;
    let mut stored = body.as_object().cloned().unwrap_or_default();
    for field in ["name", "process_profile"] {
        stored.remove(field);
    }
    let record = PartRecord {
        stamp: write.stamp(),
        name: request.name.clone(),
        process_profile: request.process_profile,
        body: Value::Object(stored).to_string(),
    };
    let dto = part_dto(&record)?;
    let location = format!("/v1/parts/{}", record.stamp.id);
    let taken = format!("a part named `{}` exists", request.name);
    write
        .commit(store, &[Record::Part(record)], location, &dto, Some(&taken))
        .await
}

/// A request's setting on a part: the process at the part's workpiece radius, the part's
/// surface and clear aperture (`part` is the part's stored body or request).
pub(super) fn on_part(mut process: Value, part: &Value) -> Map<String, Value> {
    process["workpiece_radius_mm"] = part["workpiece_radius_mm"].clone();
    let mut setting = Map::new();
    setting.insert("process".into(), process);
    for field in ["surface", "clear_aperture"] {
        if let Some(value) = part.get(field).filter(|v| !v.is_null()) {
            setting.insert(field.into(), value.clone());
        }
    }
    setting
}

/// `GET /v1/parts` query.
#[derive(Debug, Deserialize, Serialize, utoipa::IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct PartQuery {
    /// 1 to 100; default 20.
    #[param(minimum = 1, maximum = 100)]
    pub limit: Option<usize>,
    /// The `next_cursor` of the page before.
    pub cursor: Option<String>,
    /// Only the part with this name.
    pub name: Option<String>,
}

#[utoipa::path(get, path = "/v1/parts", tag = "records", operation_id = "listParts", summary = "List parts, a page at a time",
    params(PartQuery), responses((status = 200, description = "The record", body = PartListDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/parts`
pub async fn list(
    State(state): State<AppState>,
    uri: Uri,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let Query(query) = Query::<PartQuery>::try_from_uri(&uri)
        .map_err(|e| ApiError::invalid("query", e.body_text()))?;
    let limit = query.limit.unwrap_or(20);
    if !(1..=MAX_PAGE).contains(&limit) {
        return Err(ApiError::invalid("limit", "limit is from 1 to 100"));
    }
    let page = store(&state)?
        .parts(query.cursor.as_deref(), limit, query.name.as_deref())
        .await?;
    let items = page.items.iter().map(part_dto).collect::<Result<_, _>>()?;
    fetched(
        &headers,
        &PartListDto {
            items,
            next_cursor: page.next_cursor,
        },
    )
}

#[utoipa::path(get, path = "/v1/parts/{id}", tag = "records", operation_id = "getPart", summary = "A part",
    params(("id" = String, Path, description = "The part's id")), responses((status = 200, description = "The record", body = PartDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/parts/{id}`
pub async fn show(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let part = load_part(store(&state)?, &id).await?;
    fetched(&headers, &part_dto(&part)?)
}

/// A measurement request (JSON, or text/csv with the query) before the part fills it in.
#[derive(Debug, Deserialize)]
#[serde(transparent)]
pub struct MeasurementBody(Map<String, Value>);

impl CsvForm for MeasurementBody {
    const QUERY_FIELDS: &'static [&'static str] = &[
        "probe_tip_radius_mm",
        "compensation",
        "fit",
        "robust",
        "radial_grid",
        "clear_aperture",
    ];

    fn merge_csv(bytes: &[u8], body: &mut Map<String, Value>) -> Result<(), ApiError> {
        <crate::http::measurement_fit::MeasurementFitRequest as CsvForm>::merge_csv(bytes, body)
    }
}

#[utoipa::path(post, path = "/v1/parts/{id}/measurements", tag = "records", operation_id = "createMeasurement", summary = "Fit and store a measurement of the part (JSON or text/csv)",
    params(("id" = String, Path, description = "The part's id"), ("Idempotency-Key" = Option<String>, Header, description = "1–255 visible ASCII characters; a retry with the same key and request gets the first answer")), request_body = PartMeasurementRequest,
    responses((status = 201, description = "Written (or the first answer to this Idempotency-Key)", body = MeasurementDto,
        headers(("Location" = String, description = "The new record"))), RecordWriteProblems))]
/// `POST /v1/parts/{id}/measurements`
pub async fn measure(
    State(state): State<AppState>,
    Path(id): Path<String>,
    caller: Writer,
    headers: HeaderMap,
    CsvOrJson(MeasurementBody(body)): CsvOrJson<MeasurementBody>,
) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let fingerprint = format!(
        "POST /v1/parts/{id}/measurements\n{}",
        Value::Object(body.clone())
    );
    let write = Write::begin(caller, &headers, &fingerprint)?;
    if let Some(replay) = write.replay(store).await? {
        return Ok(replay);
    }
    let part = load_part(store, &id).await?;
    let part_body = document(&part.body)?;
    let mut request = without(body, &[("surface", "the part")])?;
    for field in ["surface", "clear_aperture"] {
        if let Some(value) = part_body.get(field).filter(|v| !v.is_null()) {
            request.entry(field).or_insert_with(|| value.clone());
        }
    }
    let result = compute::<MeasurementFitEndpoint>(&state, &request).await?;
    let request = Value::Object(request);
    let measurement = MeasurementRecord {
        stamp: write.stamp(),
        part: id.clone(),
        rms_nm: result["form_error"]["rms_nm"].as_f64().unwrap_or(f64::NAN),
        request: request.to_string(),
        result: result.to_string(),
    };
    let learned = learn_from_cycle(&state, store, &part, &result["profile"], &write).await?;
    let dto = MeasurementDto {
        id: measurement.stamp.id.clone(),
        part_id: id,
        rms_nm: measurement.rms_nm,
        request,
        result,
        completes_run_id: learned.as_ref().map(|(run, _)| run.clone()),
        learned_calibration_id: learned
            .as_ref()
            .and_then(|(_, c)| c.as_ref().map(|c| c.stamp.id.clone())),
        created_at: measurement.stamp.created_at.clone(),
        created_by: measurement.stamp.created_by.clone(),
    };
    let location = format!("/v1/measurements/{}", measurement.stamp.id);
    let mut records = vec![Record::Measurement(measurement)];
    records.extend(learned.and_then(|(_, c)| c).map(Record::Calibration));
    write.commit(store, &records, location, &dto, None).await
}

/// The cycle a new measurement (its form-error `profile`) completes, if any: its run, and the
/// calibration learned from it
/// (`None` when the removal does not determine the coefficient; the measurement still counts).
async fn learn_from_cycle(
    state: &AppState,
    store: &Store,
    part: &PartRecord,
    after: &Value,
    write: &Write,
) -> Result<Option<(String, Option<CalibrationRecord>)>, ApiError> {
    let id = &part.stamp.id;
    let (measurements, plans, runs) = (
        store.measurements(id).await?,
        store.plans(id).await?,
        store.runs(id).await?,
    );
    let Some((run, plan)) = run_completed_by_new_measurement(&measurements, &plans, &runs) else {
        return Ok(None);
    };
    let missing = || ApiError::internal("a cycle's plan or measurement is missing");
    let plan = store.plan(&plan.stamp.id).await?.ok_or_else(missing)?;
    let before_id = plan.measurement.as_deref().ok_or_else(missing)?;
    let before = store.measurement(before_id).await?.ok_or_else(missing)?;
    let plan_request = document(&plan.request)?;
    let plan_result = document(&plan.result)?;
    let profile = load_profile(store, &part.process_profile).await?;
    let profile_body = document(&profile.body)?;
    let mut run_fit = json!({
        "dwell": plan_result["dwell"],
        "before": document(&before.result)?["profile"],
        "after": after,
    });
    if let Some(aperture) = plan_request.get("clear_aperture") {
        run_fit["clear_aperture"] = aperture.clone();
    }
    let mut request = Map::new();
    request.insert("process".into(), plan_request["process"].clone());
    for (field, from) in [("surface", &plan_request), ("tool", &profile_body)] {
        if let Some(value) = from.get(field).filter(|v| !v.is_null()) {
            request.insert(field.into(), value.clone());
        }
    }
    request.insert("runs".into(), json!([run_fit]));
    request.insert("fit".into(), json!({"preston_coefficient": true}));
    let learned = match compute::<CalibrationEndpoint>(state, &request).await {
        Ok(result) => {
            let (k, standard_error) = fitted_coefficient(&result)?;
            Some(CalibrationRecord {
                stamp: write.stamp(),
                profile: profile.stamp.id.clone(),
                request: Value::Object(request).to_string(),
                process: result["process"].to_string(),
                result: result.to_string(),
                preston_coefficient_m2_per_n: k,
                standard_error_m2_per_n: standard_error,
                run: Some(run.stamp.id.clone()),
            })
        }
        Err(error) => {
            tracing::info!(run = %run.stamp.id, %error.detail, "the cycle's removal determines no calibration");
            None
        }
    };
    Ok(Some((run.stamp.id.clone(), learned)))
}

#[utoipa::path(get, path = "/v1/measurements/{id}", tag = "records", operation_id = "getMeasurement", summary = "A stored measurement",
    params(("id" = String, Path, description = "The measurement's id")), responses((status = 200, description = "The record", body = MeasurementDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/measurements/{id}`
pub async fn measurement(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let record = store
        .measurement(&id)
        .await?
        .ok_or_else(|| not_found("measurement", &id))?;
    let part = load_part(store, &record.part).await?;
    let (measurements, plans, runs, calibrations) = (
        store.measurements(&part.stamp.id).await?,
        store.plans(&part.stamp.id).await?,
        store.runs(&part.stamp.id).await?,
        store.calibrations(&part.process_profile).await?,
    );
    let cycle = cycles(&measurements, &plans, &runs, &calibrations)
        .into_iter()
        .find(|c| c.after.is_some_and(|m| m.stamp.id == id));
    fetched(
        &headers,
        &MeasurementDto {
            id: record.stamp.id.clone(),
            part_id: record.part.clone(),
            rms_nm: record.rms_nm,
            request: document(&record.request)?,
            result: document(&record.result)?,
            completes_run_id: cycle.as_ref().map(|c| c.run.stamp.id.clone()),
            learned_calibration_id: cycle.and_then(|c| c.learned).map(|c| c.stamp.id.clone()),
            created_at: record.stamp.created_at.clone(),
            created_by: record.stamp.created_by.clone(),
        },
    )
}
