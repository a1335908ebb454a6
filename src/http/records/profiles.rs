//! Process profiles and their calibrations.

use axum::extract::{Path, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde_json::{Map, Value};

use super::docs::{ProfileCalibrationRequest, RecordReadProblems, RecordWriteProblems};
use super::dto::{
    CalibrationRecordDto, ProcessProfileDto, ProcessProfileListDto, ProcessProfileRequest,
    RateSourceDto,
};
use super::{compute, document, fetched, not_found, store, without, Write, Writer};
use crate::http::calibration::CalibrationEndpoint;
use crate::http::endpoint::Endpoint;
use crate::http::error::ApiError;
use crate::http::extract::ApiJson;
use crate::http::predict::PredictEndpoint;
use crate::http::state::AppState;
use crate::store::Store;
use crate::usecases::records::{current_rate, CalibrationRecord, ProfileRecord, Record, Records};

/// A name or serial that is also a path segment: 1–64 of A–Z, a–z, 0–9, `-`, `_`, `.`.
pub(super) fn check_name(field: &str, name: &str) -> Result<(), ApiError> {
    let ok = (1..=64).contains(&name.len())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
    if ok {
        Ok(())
    } else {
        Err(ApiError::invalid(
            field,
            "a name is 1 to 64 of A–Z, a–z, 0–9, '-', '_', '.'",
        ))
    }
}

/// Checks a process (with a surface and tool) as every compute endpoint would, without
/// computing: the fields keep their names (`process.*`, `surface.*`, `tool.*`,
/// `clear_aperture.*`).
pub(super) fn check_setting(
    state: &AppState,
    setting: &Map<String, Value>,
) -> Result<(), ApiError> {
    let mut request = setting.clone();
    request.insert(
        "dwell".into(),
        serde_json::json!({"positions_mm": [0.0], "dwell_s": [1.0]}),
    );
    let bytes = serde_json::to_vec(&request).map_err(|e| ApiError::internal(e.to_string()))?;
    PredictEndpoint::parse(crate::http::extract::parse_json(&bytes)?, &state.compute).map(|_| ())
}

/// The profile's process a plan uses now, and where its coefficient comes from.
pub(super) fn current_process(
    profile: &ProfileRecord,
    calibrations: &[CalibrationRecord],
) -> Result<(Value, RateSourceDto, Option<f64>), ApiError> {
    let own = document(&profile.body)?["process"].clone();
    let own_k = own["preston_coefficient_m2_per_n"]
        .as_f64()
        .unwrap_or(f64::NAN);
    let rate = current_rate(calibrations, own_k);
    let mut process = match rate.base {
        Some(base) => document(&base.process)?,
        None => own,
    };
    let source = match (rate.base, rate.learned.is_empty()) {
        (_, false) => RateSourceDto::Learned,
        (Some(_), true) => RateSourceDto::Calibration,
        (None, true) => RateSourceDto::Profile,
    };
    if let (Some(k), Some(object)) = (rate.preston_coefficient_m2_per_n, process.as_object_mut()) {
        object.insert("preston_coefficient_m2_per_n".into(), k.into());
    }
    Ok((process, source, rate.standard_error_m2_per_n))
}

pub(super) fn calibration_dto(
    record: &CalibrationRecord,
) -> Result<CalibrationRecordDto, ApiError> {
    Ok(CalibrationRecordDto {
        id: record.stamp.id.clone(),
        process_profile: record.profile.clone(),
        learned: record.learned(),
        run_id: record.run.clone(),
        preston_coefficient_m2_per_n: record.preston_coefficient_m2_per_n,
        standard_error_m2_per_n: record.standard_error_m2_per_n,
        result: document(&record.result)?,
        created_at: record.stamp.created_at.clone(),
        created_by: record.stamp.created_by.clone(),
    })
}

fn profile_dto(
    profile: &ProfileRecord,
    calibrations: &[CalibrationRecord],
    listed: bool,
) -> Result<ProcessProfileDto, ApiError> {
    let body = document(&profile.body)?;
    let (current, source, standard_error) = current_process(profile, calibrations)?;
    let calibrations = if listed {
        Some(
            calibrations
                .iter()
                .rev()
                .map(calibration_dto)
                .collect::<Result<_, _>>()?,
        )
    } else {
        None
    };
    Ok(ProcessProfileDto {
        name: profile.stamp.id.clone(),
        process: body["process"].clone(),
        surface: body.get("surface").cloned(),
        tool: body.get("tool").cloned(),
        current_process: current,
        preston_coefficient_source: source,
        preston_coefficient_standard_error_m2_per_n: standard_error,
        created_at: profile.stamp.created_at.clone(),
        created_by: profile.stamp.created_by.clone(),
        calibrations,
    })
}

pub(super) async fn load_profile(store: &Store, name: &str) -> Result<ProfileRecord, ApiError> {
    store
        .profile(name)
        .await?
        .ok_or_else(|| not_found("process profile", name))
}

#[utoipa::path(post, path = "/v1/process-profiles", tag = "records", operation_id = "createProcessProfile", summary = "Create a process profile",
    params(("Idempotency-Key" = Option<String>, Header, description = "1–255 visible ASCII characters; a retry with the same key and request gets the first answer")), request_body = ProcessProfileRequest,
    responses((status = 201, description = "Written (or the first answer to this Idempotency-Key)", body = ProcessProfileDto,
        headers(("Location" = String, description = "The new record"))), RecordWriteProblems))]
/// `POST /v1/process-profiles`
pub async fn create(
    State(state): State<AppState>,
    caller: Writer,
    headers: HeaderMap,
    ApiJson(request): ApiJson<ProcessProfileRequest>,
) -> Result<Response, ApiError> {
    check_name("name", &request.name)?;
    let body = serde_json::to_value(&request).map_err(|e| ApiError::internal(e.to_string()))?;
    let mut setting = body.as_object().cloned().unwrap_or_default();
    setting.remove("name");
    check_setting(&state, &setting)?;
    let store = store(&state)?;
    let write = Write::begin(
        caller,
        &headers,
        &format!("POST /v1/process-profiles\n{body}"),
    )?;
    if let Some(replay) = write.replay(store).await? {
        return Ok(replay);
    }
    let mut stamp = write.stamp();
    stamp.id = request.name.clone();
    let record = ProfileRecord {
        stamp,
        body: Value::Object(setting).to_string(),
    };
    let dto = profile_dto(&record, &[], true)?;
    let location = format!("/v1/process-profiles/{}", request.name);
    let taken = format!(
        "a process profile named `{}` exists (profiles are immutable: choose a new name)",
        request.name
    );
    write
        .commit(
            store,
            &[Record::Profile(record)],
            location,
            &dto,
            Some(&taken),
        )
        .await
}

#[utoipa::path(get, path = "/v1/process-profiles", tag = "records", operation_id = "listProcessProfiles", summary = "List the process profiles",
    responses((status = 200, description = "The record", body = ProcessProfileListDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/process-profiles`
pub async fn list(State(state): State<AppState>, headers: HeaderMap) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let mut items = Vec::new();
    for profile in store.profiles().await? {
        let calibrations = store.calibrations(&profile.stamp.id).await?;
        items.push(profile_dto(&profile, &calibrations, false)?);
    }
    fetched(&headers, &ProcessProfileListDto { items })
}

#[utoipa::path(get, path = "/v1/process-profiles/{name}", tag = "records", operation_id = "getProcessProfile", summary = "A process profile with its calibrations, newest first",
    params(("name" = String, Path, description = "The profile's name")), responses((status = 200, description = "The record", body = ProcessProfileDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/process-profiles/{name}`
pub async fn show(
    State(state): State<AppState>,
    Path(name): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let profile = load_profile(store, &name).await?;
    let calibrations = store.calibrations(&name).await?;
    fetched(&headers, &profile_dto(&profile, &calibrations, true)?)
}

/// The estimate and standard error of the Preston coefficient in a calibration's answer.
pub(super) fn fitted_coefficient(result: &Value) -> Result<(f64, Option<f64>), ApiError> {
    let estimate = &result["parameters"]["preston_coefficient_m2_per_n"];
    let value = estimate["value"]
        .as_f64()
        .ok_or_else(|| ApiError::internal("a calibration without a Preston coefficient"))?;
    Ok((value, estimate["standard_error"].as_f64()))
}

#[utoipa::path(post, path = "/v1/process-profiles/{name}/calibrations", tag = "records", operation_id = "calibrateProcessProfile", summary = "Calibrate a process profile: the fit becomes its current process",
    params(("name" = String, Path, description = "The profile's name"), ("Idempotency-Key" = Option<String>, Header, description = "1–255 visible ASCII characters; a retry with the same key and request gets the first answer")), request_body = ProfileCalibrationRequest,
    responses((status = 201, description = "Written (or the first answer to this Idempotency-Key)", body = CalibrationRecordDto,
        headers(("Location" = String, description = "The new record"))), RecordWriteProblems))]
/// `POST /v1/process-profiles/{name}/calibrations`
pub async fn calibrate(
    State(state): State<AppState>,
    Path(name): Path<String>,
    caller: Writer,
    headers: HeaderMap,
    ApiJson(body): ApiJson<Map<String, Value>>,
) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let fingerprint = format!(
        "POST /v1/process-profiles/{name}/calibrations\n{}",
        Value::Object(body.clone())
    );
    let write = Write::begin(caller, &headers, &fingerprint)?;
    if let Some(replay) = write.replay(store).await? {
        return Ok(replay);
    }
    let profile = load_profile(store, &name).await?;
    let calibrations = store.calibrations(&name).await?;
    let mut request = without(body, &[("process", "the process profile")])?;
    let (process, _, _) = current_process(&profile, &calibrations)?;
    let profile_body = document(&profile.body)?;
    request.insert("process".into(), process);
    for field in ["surface", "tool"] {
        if let Some(value) = profile_body.get(field) {
            request.entry(field).or_insert_with(|| value.clone());
        }
    }
    let result = compute::<CalibrationEndpoint>(&state, &request).await?;
    let (k, standard_error) = fitted_coefficient(&result)?;
    let record = CalibrationRecord {
        stamp: write.stamp(),
        profile: name,
        request: Value::Object(request).to_string(),
        process: result["process"].to_string(),
        result: result.to_string(),
        preston_coefficient_m2_per_n: k,
        standard_error_m2_per_n: standard_error,
        run: None,
    };
    let dto = calibration_dto(&record)?;
    let location = format!("/v1/calibrations/{}", record.stamp.id);
    write
        .commit(store, &[Record::Calibration(record)], location, &dto, None)
        .await
}

#[utoipa::path(get, path = "/v1/calibrations/{id}", tag = "records", operation_id = "getCalibration", summary = "A stored calibration",
    params(("id" = String, Path, description = "The calibration's id")), responses((status = 200, description = "The record", body = CalibrationRecordDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/calibrations/{id}`
pub async fn calibration(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let record = store(&state)?
        .calibration(&id)
        .await?
        .ok_or_else(|| not_found("calibration", &id))?;
    fetched(&headers, &calibration_dto(&record)?)
}
