//! Plans, their machine programs, runs, and a part's history of cycles (`ledger::cycles`).

use axum::extract::{Path, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde_json::{Map, Value};

use super::docs::{
    PartPlanRequest, PlanProgramRequest, PlanProgramResponse, RecordReadProblems,
    RecordWriteProblems,
};
use super::dto::{CycleDto, HistoryDto, PlanDto, RatioDto, RunRecordDto, RunRequest};
use super::parts::part_dto;
use super::{begin, commit, computed_by, fetched, replayed, store, tag, Writer};
use crate::http::dto::WarningDto;
use crate::http::endpoint::{offered, render, Endpoint};
use crate::http::error::ApiError;
use crate::http::extract::{self, ApiJson};
use crate::http::maps::program::MapProgramEndpoint;
use crate::http::program::ProgramEndpoint;
use crate::http::state::AppState;
use crate::ledger::cycles::{self, NewRun};
use crate::ledger::document;
use crate::usecases::program::Provenance;
use crate::usecases::records::{Cycle, PlanRecord, Record, RunRecord};

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
        computed_by: computed_by(&plan.stamp),
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
        computed_by: computed_by(&run.stamp),
    }
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
    let write = begin(
        store,
        &caller,
        &headers,
        &format!("POST /v1/parts/{id}/plans"),
        &Value::Object(body.clone()),
    )?;
    let render = |plan: String| async move { plan_dto(&cycles::load_plan(store, &plan).await?) };
    if let Some(replay) = write.replay().await? {
        return replayed(replay, render).await;
    }
    let plan = cycles::plan(&state, &write, &id, body).await?;
    let dto = plan_dto(&plan)?;
    let id = ("/v1/plans", plan.stamp.id.clone());
    commit(write, &[Record::Plan(plan)], id, &dto, None, render).await
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
    let plan = cycles::load_plan(store(&state)?, &id).await?;
    fetched(
        &headers,
        tag(&state, "plan", [plan.stamp.id.as_str()]),
        || plan_dto(&plan),
    )
}

#[utoipa::path(post, path = "/v1/plans/{id}/program", tag = "records", operation_id = "createPlanProgram", summary = "The plan's machine program (computed from the record, not stored)",
    params(("id" = String, Path, description = "The plan's id")), request_body = PlanProgramRequest,
    responses((status = 200, description = "The program: JSON (as /v1/program, or /v1/maps/program for a polar plan) or G-code (Accept: text/x-gcode), its header naming the plan",
        content((PlanProgramResponse = "application/json"), (String = "text/x-gcode"))), RecordWriteProblems))]
/// `POST /v1/plans/{id}/program`: the plan's machine program (JSON or G-code, as
/// `/v1/program`, or `/v1/maps/program` for a polar plan), its header naming the plan and the
/// part. Computed, not stored: a read.
pub async fn program(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    ApiJson(body): ApiJson<Map<String, Value>>,
) -> Result<Response, ApiError> {
    let program = cycles::program_request(store(&state)?, &id, body).await?;
    if program.polar {
        plan_program::<MapProgramEndpoint>(&state, &headers, program, POLAR_PROGRAM).await
    } else {
        plan_program::<ProgramEndpoint>(&state, &headers, program, RADIAL_PROGRAM).await
    }
}

const RADIAL_PROGRAM: &str = "this plan is radial: its program takes `/v1/program`'s members";
const POLAR_PROGRAM: &str = "this plan is polar: its program takes `/v1/maps/program`'s members";

/// A stored plan's program by endpoint `E` (`/v1/program`, or `/v1/maps/program` for a polar
/// plan), its header naming the plan; `kind` says which members the plan's program takes
/// when the body has others.
async fn plan_program<E>(
    state: &AppState,
    headers: &HeaderMap,
    program: cycles::PlanProgram,
    kind: &str,
) -> Result<Response, ApiError>
where
    E: Endpoint,
    E::Command: Provenance,
{
    let format = extract::negotiate(headers, &offered::<E>())?;
    let bytes =
        serde_json::to_vec(&program.request).map_err(|e| ApiError::internal(e.to_string()))?;
    let request = extract::parse_json(&bytes).map_err(|e| e.mismatch_as_invalid(kind))?;
    let command = E::parse(request, &state.compute)?.with_provenance(program.provenance);
    let services = state.services.clone();
    let output = state.run(move || E::run(command, &services)).await?;
    Ok(render::<E>(format, output))
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
    let body = serde_json::to_value(&request).map_err(|e| ApiError::internal(e.to_string()))?;
    let run = NewRun::new(
        request.plan_id,
        request.started_at,
        request.finished_at,
        request.machine,
        request.notes,
    )?;
    let store = store(&state)?;
    let write = begin(
        store,
        &caller,
        &headers,
        &format!("POST /v1/parts/{id}/runs"),
        &body,
    )?;
    let render = |run: String| async move { Ok(run_dto(&cycles::load_run(store, &run).await?)) };
    if let Some(replay) = write.replay().await? {
        return replayed(replay, render).await;
    }
    let run = run.record(&write, &id).await?;
    let dto = run_dto(&run);
    let id = ("/v1/runs", run.stamp.id.clone());
    commit(write, &[Record::Run(run)], id, &dto, None, render).await
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
    let run = cycles::load_run(store(&state)?, &id).await?;
    fetched(
        &headers,
        tag(&state, "run", [run.stamp.id.as_str()]),
        || Ok(run_dto(&run)),
    )
}

fn cycle_dto(cycle: &Cycle<'_>) -> CycleDto {
    let removal_ratio = cycles::removal_ratio(cycle).map(|ratio| RatioDto {
        value: ratio.value,
        standard_error: ratio.standard_error,
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
        learned_calibration_id: cycle
            .learned
            .filter(|c| c.learned())
            .map(|c| c.stamp.id.clone()),
        warnings: WarningDto::all(&cycle.warnings()),
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
    let history = cycles::history(store(&state)?, &id).await?;
    fetched(
        &headers,
        tag(&state, "history", history.record_ids()),
        || {
            Ok(HistoryDto {
                part: part_dto(&history.part)?,
                cycles: history.cycles().iter().map(cycle_dto).collect(),
                next_process: history.next_process.clone(),
            })
        },
    )
}
