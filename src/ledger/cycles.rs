//! Plans, their machine programs, runs, and a part's history of cycles (what a cycle is:
//! `usecases::records`).

use std::time::SystemTime;

use serde_json::Value;

use super::answers::{read, MeasurementAnswer, PlanAnswer};
use super::parts::{self, on_part};
use super::profiles::{self, current_process};
use super::{
    absent, document, fill, found, without, Computation, Compute, Document, LedgerError, Write,
};
use crate::store::Store;
use crate::usecases::records::{
    cycles, CalibrationRecord, Cycle, MeasurementHead, MeasurementRecord, PartRecord, PlanHead,
    PlanRecord, ProfileRecord, Records, RunRecord,
};

/// Plans part `id`'s next correction. `body` is a `/v1/optimize` request, or with
/// `machine.kinematics: polar` a `/v1/maps/optimize` request, without `process` (the profile's
/// current one, at the part's workpiece radius) and `surface` (the part's); `clear_aperture`
/// defaults to the part's. A radial plan's `target` defaults to the correction of the part's
/// latest measurement; a polar plan's `map` to the latest measurement's map, placed (its pixel
/// and alignment) as it was analysed.
pub async fn plan<C: Compute>(
    compute: &C,
    write: &Write<'_>,
    id: &str,
    body: Document,
) -> Result<PlanRecord, C::Problem> {
    let store = write.store();
    let part = parts::load(store, id).await?;
    let profile = profiles::load(store, &part.process_profile).await?;
    let current = profiles::current(store, &profile).await?;
    let polar = body
        .get("machine")
        .and_then(|m| m.get("kinematics"))
        .is_some_and(|k| k == "polar");
    let mut request = without(
        body,
        &[
            ("process", "the part's process profile"),
            ("surface", "the part"),
        ],
    )?;
    for (field, value) in on_part(current.process, &document(&part.body)?)? {
        if absent(&request, &field) {
            request.insert(field, value);
        }
    }
    let latest = store.measurements(id).await?.pop();
    let result = if polar {
        polar_plan(compute, store, &mut request, latest.as_ref()).await?
    } else {
        if absent(&request, "target") {
            let measurement = latest_measurement(store, latest.as_ref(), "target").await?;
            let answer: MeasurementAnswer = read(&document(&measurement.result)?, "a measurement")?;
            request.insert("target".into(), answer.correction_target().clone());
        }
        compute.compute(Computation::Optimize, &request).await?
    };
    let answer: PlanAnswer = read(&result, "an optimize answer")?;
    Ok(PlanRecord {
        stamp: write.stamp(),
        part: id.to_string(),
        measurement: latest.map(|m| m.stamp.id),
        request: Value::Object(request).to_string(),
        predicted_rms_after_nm: answer.residual_rms_nm(),
        result: result.to_string(),
    })
}

/// The part's latest measurement, which `field` defaults from; an error naming `field` when
/// the part has none.
async fn latest_measurement(
    store: &Store,
    latest: Option<&MeasurementHead>,
    field: &str,
) -> Result<MeasurementRecord, LedgerError> {
    let head = latest.ok_or_else(|| {
        LedgerError::invalid(
            field,
            format!("this part has no measurement yet: send a `{field}`, or measure it first"),
        )
    })?;
    found(
        store.measurement(&head.stamp.id).await?,
        "measurement",
        &head.stamp.id,
    )
}

/// A polar plan's answer. Without a `map`, the latest measurement's map file is corrected,
/// with the pixel and alignment its analysis had unless the request names its own.
async fn polar_plan<C: Compute>(
    compute: &C,
    store: &Store,
    request: &mut Document,
    latest: Option<&MeasurementHead>,
) -> Result<Value, C::Problem> {
    if !absent(request, "map") {
        return compute.compute(Computation::MapOptimize, request).await;
    }
    // A null map is not given: the measurement's file fills it.
    request.remove("map");
    let measurement = latest_measurement(store, latest, "map").await?;
    let sha256 = measurement.map_sha256.as_deref().ok_or_else(|| {
        LedgerError::invalid(
            "map",
            "this part's latest measurement is a probe trace, which has no angle: send a `map`, \
             or measure the part by an interferometer map",
        )
    })?;
    let file = store.blob(sha256).await?.ok_or_else(|| {
        LedgerError::Broken(format!(
            "measurement {}'s map {sha256} is not kept",
            measurement.stamp.id
        ))
    })?;
    fill(
        request,
        &document(&measurement.request)?,
        &["pixel_mm", "alignment"],
    );
    compute
        .compute_with_maps(Computation::MapOptimize, request, &[("map", &file)])
        .await
}

pub async fn load_plan(store: &Store, id: &str) -> Result<PlanRecord, LedgerError> {
    found(store.plan(id).await?, "plan", id)
}

pub async fn load_run(store: &Store, id: &str) -> Result<RunRecord, LedgerError> {
    found(store.run(id).await?, "run", id)
}

/// A plan's machine program, as a `/v1/program` request (a polar plan's: `/v1/maps/program`).
pub struct PlanProgram {
    pub request: Document,
    /// The plan has C's speed law: its request is a `/v1/maps/program` request.
    pub polar: bool,
    /// What the program's header names: the plan and its part.
    pub provenance: String,
}

/// Plan `id`'s program request: `body` is a `/v1/program` request (a polar plan's:
/// `/v1/maps/program`) without `process`, `surface`, `dwell` (and a polar plan's `c_law`):
/// the plan's; `tool` defaults to the profile's, `machine` to the plan's.
pub async fn program_request(
    store: &Store,
    id: &str,
    body: Document,
) -> Result<PlanProgram, LedgerError> {
    let plan = load_plan(store, id).await?;
    let part = parts::load(store, &plan.part).await?;
    let profile = profiles::load(store, &part.process_profile).await?;
    let plan_request = document(&plan.request)?;
    let answer: PlanAnswer = read(&document(&plan.result)?, "a plan")?;
    let polar = answer.is_polar();
    let mut supplied = vec![
        ("process", "the plan"),
        ("surface", "the plan"),
        ("dwell", "the plan"),
    ];
    if polar {
        supplied.push(("c_law", "the plan"));
    }
    let mut request = without(body, &supplied)?;
    plan_setting(&mut request, &plan_request, &profile)?;
    // The limits it was planned within, unless the program names its own.
    fill(&mut request, &plan_request, &["machine"]);
    request.extend(answer.motion());
    Ok(PlanProgram {
        request,
        polar,
        provenance: format!(
            "plan {} of part {}, part id {}",
            plan.stamp.id, part.name, part.stamp.id
        ),
    })
}

/// What ran a plan (its `plan_request`): its process and surface, and the profile's tool
/// unless `into` names one.
pub(super) fn plan_setting(
    into: &mut Document,
    plan_request: &Value,
    profile: &ProfileRecord,
) -> Result<(), LedgerError> {
    #[derive(serde::Deserialize)]
    struct Ran {
        process: Value,
    }
    into.insert(
        "process".into(),
        read::<Ran>(plan_request, "a plan's request")?.process,
    );
    fill(into, plan_request, &["surface"]);
    fill(into, &document(&profile.body)?, &["tool"]);
    Ok(())
}

/// A run to record, checked: its plan, when it ran (RFC 3339 UTC), the machine and notes.
pub struct NewRun {
    plan: String,
    started_at: String,
    finished_at: String,
    machine: Option<String>,
    notes: Option<String>,
}

impl NewRun {
    pub fn new(
        plan: String,
        started_at: String,
        finished_at: String,
        machine: Option<String>,
        notes: Option<String>,
    ) -> Result<NewRun, LedgerError> {
        let started = timestamp("started_at", &started_at)?;
        if timestamp("finished_at", &finished_at)? <= started {
            return Err(LedgerError::invalid(
                "finished_at",
                "a run must finish after it starts (finished_at after started_at)",
            ));
        }
        for (field, text, most) in [("machine", &machine, 200), ("notes", &notes, 4000)] {
            if text.as_ref().is_some_and(|t| t.chars().count() > most) {
                return Err(LedgerError::invalid(
                    field,
                    format!("at most {most} characters"),
                ));
            }
        }
        Ok(NewRun {
            plan,
            started_at,
            finished_at,
            machine,
            notes,
        })
    }

    /// The record of a run on part `id`, whose plan it must be.
    pub async fn record(self, write: &Write<'_>, id: &str) -> Result<RunRecord, LedgerError> {
        let store = write.store();
        let part = parts::load(store, id).await?;
        let plan = store
            .plan(&self.plan)
            .await?
            .filter(|p| p.part == part.stamp.id)
            .ok_or_else(|| {
                LedgerError::invalid(
                    "plan_id",
                    format!("part `{id}` has no plan `{}`", self.plan),
                )
            })?;
        // A run cannot start before its plan existed (a plan id mixed up); the MES's clock may
        // differ from the service's, and write whole seconds, by up to CLOCK_SKEW.
        let planned = timestamp("plan_id", &plan.stamp.created_at)?;
        if timestamp("started_at", &self.started_at)? + CLOCK_SKEW < planned {
            return Err(LedgerError::invalid(
                "started_at",
                format!(
                    "the run starts more than {} min before its plan was made ({}): a run \
                     cannot start before its plan exists (check plan_id, or the MES's clock)",
                    CLOCK_SKEW.as_secs() / 60,
                    plan.stamp.created_at
                ),
            ));
        }
        Ok(RunRecord {
            stamp: write.stamp(),
            part: id.to_string(),
            plan: plan.stamp.id,
            started_at: self.started_at,
            finished_at: self.finished_at,
            machine: self.machine,
            notes: self.notes,
        })
    }
}

/// How far a run's start may precede its plan's creation: the MES's clock against the
/// service's, and its whole seconds against the record's milliseconds.
const CLOCK_SKEW: std::time::Duration = std::time::Duration::from_secs(300);

/// An RFC 3339 UTC timestamp, as given.
fn timestamp(field: &str, text: &str) -> Result<SystemTime, LedgerError> {
    humantime::parse_rfc3339(text).map_err(|_| {
        LedgerError::invalid(
            field,
            "an RFC 3339 UTC timestamp, such as 2026-11-25T08:00:00Z",
        )
    })
}

/// A part's records and the process its next plan uses.
pub struct History {
    pub part: PartRecord,
    measurements: Vec<MeasurementHead>,
    plans: Vec<PlanHead>,
    runs: Vec<RunRecord>,
    calibrations: Vec<CalibrationRecord>,
    /// The profile's current process at the part's workpiece radius.
    pub next_process: Value,
}

impl History {
    /// The ids of every record the history is made of (the part, its measurements, plans
    /// and runs, its profile's calibrations), in that order.
    pub fn record_ids(&self) -> Vec<&str> {
        let stamps = std::iter::once(&self.part.stamp)
            .chain(self.measurements.iter().map(|m| &m.stamp))
            .chain(self.plans.iter().map(|p| &p.stamp))
            .chain(self.runs.iter().map(|r| &r.stamp))
            .chain(self.calibrations.iter().map(|c| &c.stamp));
        stamps.map(|s| s.id.as_str()).collect()
    }

    /// The part's cycles, in the order they ran.
    pub fn cycles(&self) -> Vec<Cycle<'_>> {
        cycles(
            &self.measurements,
            &self.plans,
            &self.runs,
            &self.calibrations,
        )
    }
}

pub async fn history(store: &Store, id: &str) -> Result<History, LedgerError> {
    let part = parts::load(store, id).await?;
    let profile = profiles::load(store, &part.process_profile).await?;
    let calibrations = store.calibrations(&part.process_profile).await?;
    let current = current_process(&profile, &calibrations)?;
    let next_process = on_part(current.process, &document(&part.body)?)?
        .remove("process")
        .unwrap_or_default();
    Ok(History {
        measurements: store.measurements(id).await?,
        plans: store.plans(id).await?,
        runs: store.runs(id).await?,
        calibrations,
        next_process,
        part,
    })
}

/// A ratio and its standard error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ratio {
    pub value: f64,
    pub standard_error: Option<f64>,
}

/// A cycle's removal ratio, actual / predicted removal: its learned calibration's
/// K_fit / K_plan (the plan's process was its nominal), with the standard error scaled alike.
pub fn removal_ratio(cycle: &Cycle<'_>) -> Option<Ratio> {
    // Read alone, the rest of the answer skipped unparsed (a history reads a hundred of them).
    #[derive(serde::Deserialize)]
    struct RatioAnswer {
        removal_rate_ratio: f64,
    }
    let learned = cycle.learned?;
    let value = serde_json::from_str::<RatioAnswer>(&learned.result)
        .ok()?
        .removal_rate_ratio;
    Some(Ratio {
        value,
        standard_error: learned
            .standard_error_m2_per_n
            .map(|se| se * value / learned.preston_coefficient_m2_per_n),
    })
}
