//! Process profiles and their calibrations (`ledger::profiles`).

use axum::extract::{Path, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde_json::{Map, Value};

use super::docs::{ProfileCalibrationRequest, RecordReadProblems, RecordWriteProblems};
use super::dto::{
    CalibrationRecordDto, ProcessProfileDto, ProcessProfileListDto, ProcessProfileRequest,
    RateSourceDto,
};
use super::{begin, commit, computed_by, fetched, replayed, store, tag, Writer, PROCESS_PROFILES};
use crate::http::error::ApiError;
use crate::http::extract::ApiJson;
use crate::http::state::AppState;
use crate::ledger::profiles::{self, current_process, NewProfile, RateSource};
use crate::ledger::{self, document, ProfileBody};
use crate::usecases::records::{CalibrationRecord, ProfileRecord, Record, Records};

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
        computed_by: computed_by(&record.stamp),
    })
}

fn profile_dto(
    profile: &ProfileRecord,
    calibrations: &[CalibrationRecord],
    listed: bool,
) -> Result<ProcessProfileDto, ApiError> {
    let body: ProfileBody = ledger::stored(&profile.body, "a stored process profile")?;
    let current = current_process(profile, calibrations)?;
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
        process: body.process,
        surface: body.surface,
        tool: body.tool,
        preston_coefficient_source: match current.source {
            RateSource::Profile => RateSourceDto::Profile,
            RateSource::Calibration => RateSourceDto::Calibration,
            RateSource::Learned => RateSourceDto::Learned,
        },
        preston_coefficient_standard_error_m2_per_n: current.standard_error_m2_per_n,
        current_process: current.process,
        created_at: profile.stamp.created_at.clone(),
        created_by: profile.stamp.created_by.clone(),
        computed_by: computed_by(&profile.stamp),
        calibrations,
    })
}

#[utoipa::path(post, path = PROCESS_PROFILES, tag = "records", operation_id = "createProcessProfile", summary = "Create a process profile",
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
    let body = serde_json::to_value(&request).map_err(|e| ApiError::internal(e.to_string()))?;
    let mut setting = body.as_object().cloned().unwrap_or_default();
    setting.remove("name");
    let profile = NewProfile::new(&state, request.name, setting)?;
    let store = store(&state)?;
    let write = begin(store, &caller, &headers, "POST /v1/process-profiles", &body)?;
    // The first answer shows the profile as created: no calibrations yet.
    let render =
        |name: String| async move { profile_dto(&profiles::load(store, &name).await?, &[], true) };
    if let Some(replay) = write.replay().await? {
        return replayed(replay, render).await;
    }
    let taken = format!(
        "a process profile named `{}` exists (profiles are immutable: choose a new name)",
        profile.name()
    );
    let record = profile.record(write.stamp());
    let dto = profile_dto(&record, &[], true)?;
    let id = (PROCESS_PROFILES, record.stamp.id.clone());
    let records = [Record::Profile(record)];
    commit(write, &records, id, &dto, Some(&taken), render).await
}

#[utoipa::path(get, path = PROCESS_PROFILES, tag = "records", operation_id = "listProcessProfiles", summary = "List the process profiles",
    responses((status = 200, description = "The record", body = ProcessProfileListDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/process-profiles`
pub async fn list(State(state): State<AppState>, headers: HeaderMap) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let mut profiles = Vec::new();
    for profile in store.profiles().await? {
        let calibrations = store.calibrations(&profile.stamp.id).await?;
        profiles.push((profile, calibrations));
    }
    let etag = tag(
        &state,
        "profiles",
        profiles.iter().flat_map(|(p, calibrations)| {
            std::iter::once(p.stamp.id.as_str())
                .chain(calibrations.iter().map(|c| c.stamp.id.as_str()))
        }),
    );
    fetched(&headers, etag, || {
        let items = profiles
            .iter()
            .map(|(p, calibrations)| profile_dto(p, calibrations, false))
            .collect::<Result<_, _>>()?;
        Ok(ProcessProfileListDto { items })
    })
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
    let profile = profiles::load(store, &name).await?;
    let calibrations = store.calibrations(&name).await?;
    let ids = calibrations.iter().map(|c| c.stamp.id.as_str());
    let etag = tag(
        &state,
        "profile",
        std::iter::once(profile.stamp.id.as_str()).chain(ids),
    );
    fetched(&headers, etag, || {
        profile_dto(&profile, &calibrations, true)
    })
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
    let write = begin(
        store,
        &caller,
        &headers,
        &format!("POST /v1/process-profiles/{name}/calibrations"),
        &Value::Object(body.clone()),
    )?;
    let render = |calibration: String| async move {
        calibration_dto(&profiles::load_calibration(store, &calibration).await?)
    };
    if let Some(replay) = write.replay().await? {
        return replayed(replay, render).await;
    }
    let record = profiles::calibrate(&state, &write, &name, body).await?;
    let dto = calibration_dto(&record)?;
    let id = ("/v1/calibrations", record.stamp.id.clone());
    commit(
        write,
        &[Record::Calibration(record)],
        id,
        &dto,
        None,
        render,
    )
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
    let record = profiles::load_calibration(store(&state)?, &id).await?;
    fetched(
        &headers,
        tag(&state, "calibration", [record.stamp.id.as_str()]),
        || calibration_dto(&record),
    )
}
