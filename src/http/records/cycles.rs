//! Plans, their machine programs, runs, and a part's history of cycles.

use axum::extract::{Path, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde_json::{Map, Value};

use super::docs::{PartPlanRequest, PlanProgramRequest, RecordReadProblems, RecordWriteProblems};
use super::dto::{CycleDto, HistoryDto, PlanDto, RatioDto, RunRecordDto, RunRequest};
use super::parts::{load_part, on_part, part_dto};
use super::profiles::{current_process, load_profile};
use super::{compute, document, fetched, not_found, store, without, Write, Writer};
use crate::http::endpoint::{offered, render, Endpoint};
use crate::http::error::ApiError;
use crate::http::extract::{self, ApiJson};
use crate::http::optimize::OptimizeEndpoint;
use crate::http::program::ProgramEndpoint;
use crate::http::state::AppState;
use crate::store::Store;
use crate::usecases::records::{cycles, Cycle, PlanRecord, Record, Records, RunRecord};

fn plan_dto(plan: &PlanRecord) -> Result<PlanDto, ApiError> {
    Ok(PlanDto {
        id: plan.stamp.id.clone(),
        part_id: plan.part.clone(),
        measurement_id: plan.measurement.clone(),
        predicted_rms_after_nm: plan.predicted_rms_after_nm,
        request: document(&plan.request)?,
        result: document(&plan.result)?,
        created_at: plan.stamp.created_at.clone(),
        created_by: plan.stamp.created_by.clone(),
    })
}

fn run_dto(run: &RunRecord) -> RunRecordDto {
    RunRecordDto {
        id: run.stamp.id.clone(),
        part_id: run.part.clone(),
        plan_id: run.plan.clone(),
        started_at: run.started_at.clone(),
        finished_at: run.finished_at.clone(),
        machine: run.machine.clone(),
        notes: run.notes.clone(),
        created_at: run.stamp.created_at.clone(),
        created_by: run.stamp.created_by.clone(),
    }
}

async fn load_plan(store: &Store, id: &str) -> Result<PlanRecord, ApiError> {
    store.plan(id).await?.ok_or_else(|| not_found("plan", id))
}

#[utoipa::path(post, path = "/v1/parts/{id}/plans", tag = "records", operation_id = "createPlan", summary = "Plan the part's next correction with its profile's current process",
    params(("id" = String, Path, description = "The part's id"), ("Idempotency-Key" = Option<String>, Header, description = "1–255 visible ASCII characters; a retry with the same key and request gets the first answer")), request_body = PartPlanRequest,
    responses((status = 201, description = "Written (or the first answer to this Idempotency-Key)", body = PlanDto,
        headers(("Location" = String, description = "The new record"))), RecordWriteProblems))]
/// `POST /v1/parts/{id}/plans`
pub async fn plan(
    State(state): State<AppState>,
    Path(id): Path<String>,
    caller: Writer,
    headers: HeaderMap,
    ApiJson(body): ApiJson<Map<String, Value>>,
) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let fingerprint = format!("POST /v1/parts/{id}/plans\n{}", Value::Object(body.clone()));
    let write = Write::begin(caller, &headers, &fingerprint)?;
    if let Some(replay) = write.replay(store).await? {
        return Ok(replay);
    }
    let part = load_part(store, &id).await?;
    let profile = load_profile(store, &part.process_profile).await?;
    let (process, _, _) = current_process(&profile, &store.calibrations(&profile.stamp.id).await?)?;
    let mut request = without(
        body,
        &[
            ("process", "the part's process profile"),
            ("surface", "the part"),
        ],
    )?;
    for (field, value) in on_part(process, &document(&part.body)?) {
        request.entry(field).or_insert(value);
    }
    let latest = store.measurements(&id).await?.pop();
    if !request.contains_key("target") {
        let head = latest.as_ref().ok_or_else(|| {
            ApiError::invalid(
                "target",
                "this part has no measurement yet: send a `target`, or measure it first",
            )
        })?;
        let measurement = store
            .measurement(&head.stamp.id)
            .await?
            .ok_or_else(|| not_found("measurement", &head.stamp.id))?;
        let target = document(&measurement.result)?["correction_target"].clone();
        request.insert("target".into(), target);
    }
    let result = compute::<OptimizeEndpoint>(&state, &request).await?;
    let plan = PlanRecord {
        stamp: write.stamp(),
        part: id,
        measurement: latest.map(|m| m.stamp.id),
        request: Value::Object(request).to_string(),
        predicted_rms_after_nm: result["residual"]["rms_nm"].as_f64().unwrap_or(f64::NAN),
        result: result.to_string(),
    };
    let dto = plan_dto(&plan)?;
    let location = format!("/v1/plans/{}", plan.stamp.id);
    write
        .commit(store, &[Record::Plan(plan)], location, &dto, None)
        .await
}

#[utoipa::path(get, path = "/v1/plans/{id}", tag = "records", operation_id = "getPlan", summary = "A stored plan",
    params(("id" = String, Path, description = "The plan's id")), responses((status = 200, description = "The record", body = PlanDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/plans/{id}`
pub async fn show_plan(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let plan = load_plan(store(&state)?, &id).await?;
    fetched(&headers, &plan_dto(&plan)?)
}

#[utoipa::path(post, path = "/v1/plans/{id}/program", tag = "records", operation_id = "createPlanProgram", summary = "The plan's machine program (computed from the record, not stored)",
    params(("id" = String, Path, description = "The plan's id")), request_body = PlanProgramRequest,
    responses((status = 200, description = "The program: JSON (as /v1/program) or G-code (Accept: text/x-gcode), its header naming the plan",
        content((crate::http::program::ProgramResponse = "application/json"), (String = "text/x-gcode"))), RecordWriteProblems))]
/// `POST /v1/plans/{id}/program`: the plan's machine program (JSON or G-code, as
/// `/v1/program`), its header naming the plan and the part. Computed, not stored: a read.
pub async fn program(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    ApiJson(body): ApiJson<Map<String, Value>>,
) -> Result<Response, ApiError> {
    let format = extract::negotiate(&headers, &offered::<ProgramEndpoint>())?;
    let store = store(&state)?;
    let plan = load_plan(store, &id).await?;
    let part = load_part(store, &plan.part).await?;
    let profile_body = document(&load_profile(store, &part.process_profile).await?.body)?;
    let plan_request = document(&plan.request)?;
    let mut request = without(
        body,
        &[
            ("process", "the plan"),
            ("surface", "the plan"),
            ("dwell", "the plan"),
        ],
    )?;
    request.insert("process".into(), plan_request["process"].clone());
    request.insert("dwell".into(), document(&plan.result)?["dwell"].clone());
    if let Some(surface) = plan_request.get("surface") {
        request.insert("surface".into(), surface.clone());
    }
    if let Some(tool) = profile_body.get("tool") {
        request.entry("tool").or_insert_with(|| tool.clone());
    }
    let bytes = serde_json::to_vec(&request).map_err(|e| ApiError::internal(e.to_string()))?;
    let command = ProgramEndpoint::parse(extract::parse_json(&bytes)?, &state.compute)?
        .with_provenance(format!(
            "plan {} of part {}, part id {}",
            plan.stamp.id, part.name, part.stamp.id
        ));
    let services = state.services.clone();
    let output = state
        .run(move || ProgramEndpoint::run(command, &services))
        .await?;
    Ok(render::<ProgramEndpoint>(format, output))
}

/// An RFC 3339 UTC timestamp, as given.
fn timestamp(field: &str, text: &str) -> Result<std::time::SystemTime, ApiError> {
    humantime::parse_rfc3339(text).map_err(|_| {
        ApiError::invalid(
            field,
            "an RFC 3339 UTC timestamp, such as 2026-11-25T08:00:00Z",
        )
    })
}

#[utoipa::path(post, path = "/v1/parts/{id}/runs", tag = "records", operation_id = "createRun", summary = "Record a run of a plan on the machine",
    params(("id" = String, Path, description = "The part's id"), ("Idempotency-Key" = Option<String>, Header, description = "1–255 visible ASCII characters; a retry with the same key and request gets the first answer")), request_body = RunRequest,
    responses((status = 201, description = "Written (or the first answer to this Idempotency-Key)", body = RunRecordDto,
        headers(("Location" = String, description = "The new record"))), RecordWriteProblems))]
/// `POST /v1/parts/{id}/runs`
pub async fn run(
    State(state): State<AppState>,
    Path(id): Path<String>,
    caller: Writer,
    headers: HeaderMap,
    ApiJson(request): ApiJson<RunRequest>,
) -> Result<Response, ApiError> {
    let started = timestamp("started_at", &request.started_at)?;
    let finished = timestamp("finished_at", &request.finished_at)?;
    if finished < started {
        return Err(ApiError::invalid(
            "finished_at",
            "a run cannot finish before it started",
        ));
    }
    for (field, text, most) in [
        ("machine", &request.machine, 200),
        ("notes", &request.notes, 4000),
    ] {
        if text.as_ref().is_some_and(|t| t.chars().count() > most) {
            return Err(ApiError::invalid(
                field,
                format!("at most {most} characters"),
            ));
        }
    }
    let body = serde_json::to_value(&request).map_err(|e| ApiError::internal(e.to_string()))?;
    let store = store(&state)?;
    let write = Write::begin(
        caller,
        &headers,
        &format!("POST /v1/parts/{id}/runs\n{body}"),
    )?;
    if let Some(replay) = write.replay(store).await? {
        return Ok(replay);
    }
    let part = load_part(store, &id).await?;
    let plan = store
        .plan(&request.plan_id)
        .await?
        .filter(|p| p.part == part.stamp.id)
        .ok_or_else(|| {
            ApiError::invalid(
                "plan_id",
                format!("part `{id}` has no plan `{}`", request.plan_id),
            )
        })?;
    let run = RunRecord {
        stamp: write.stamp(),
        part: id,
        plan: plan.stamp.id,
        started_at: request.started_at,
        finished_at: request.finished_at,
        machine: request.machine,
        notes: request.notes,
    };
    let dto = run_dto(&run);
    let location = format!("/v1/runs/{}", run.stamp.id);
    write
        .commit(store, &[Record::Run(run)], location, &dto, None)
        .await
}

#[utoipa::path(get, path = "/v1/runs/{id}", tag = "records", operation_id = "getRun", summary = "A stored run",
    params(("id" = String, Path, description = "The run's id")), responses((status = 200, description = "The record", body = RunRecordDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/runs/{id}`
pub async fn show_run(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let run = store(&state)?
        .run(&id)
        .await?
        .ok_or_else(|| not_found("run", &id))?;
    fetched(&headers, &run_dto(&run))
}

fn cycle_dto(cycle: &Cycle<'_>) -> CycleDto {
    // The learned calibration's ratio is K_fit / K_plan (the plan's process was its nominal);
    // read alone, the rest of the answer skipped unparsed (a history reads a hundred of them).
    #[derive(serde::Deserialize)]
    struct Ratio {
        removal_rate_ratio: f64,
    }
    let removal_ratio = cycle.learned.and_then(|c| {
        let value = serde_json::from_str::<Ratio>(&c.result)
            .ok()?
            .removal_rate_ratio;
        Some(RatioDto {
            value,
            standard_error: c
                .standard_error_m2_per_n
                .map(|se| se * value / c.preston_coefficient_m2_per_n),
        })
    });
    CycleDto {
        run_id: cycle.run.stamp.id.clone(),
        plan_id: cycle.plan.stamp.id.clone(),
        measurement_before_id: cycle.before.map(|m| m.stamp.id.clone()),
        measurement_after_id: cycle.after.map(|m| m.stamp.id.clone()),
        rms_before_nm: cycle.rms_before_nm(),
        predicted_rms_after_nm: cycle.plan.predicted_rms_after_nm,
        rms_after_nm: cycle.rms_after_nm(),
        convergence_ratio: cycle.convergence_ratio(),
        removal_ratio,
        learned_calibration_id: cycle.learned.map(|c| c.stamp.id.clone()),
    }
}

#[utoipa::path(get, path = "/v1/parts/{id}/history", tag = "records", operation_id = "getPartHistory", summary = "The part's correction cycles and the process of its next plan",
    params(("id" = String, Path, description = "The part's id")), responses((status = 200, description = "The record", body = HistoryDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/parts/{id}/history`
pub async fn history(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let part = load_part(store, &id).await?;
    let profile = load_profile(store, &part.process_profile).await?;
    let (measurements, plans, runs, calibrations) = (
        store.measurements(&id).await?,
        store.plans(&id).await?,
        store.runs(&id).await?,
        store.calibrations(&part.process_profile).await?,
    );
    let (process, _, _) = current_process(&profile, &calibrations)?;
    let part_body = document(&part.body)?;
    let next_process = on_part(process, &part_body)
        .remove("process")
        .unwrap_or_default();
    let cycles = cycles(&measurements, &plans, &runs, &calibrations)
        .iter()
        .map(cycle_dto)
        .collect();
    fetched(
        &headers,
        &HistoryDto {
            part: part_dto(&part)?,
            cycles,
            next_process,
        },
    )
}
