//! Parts and their measurements. A measurement that follows a run completes that run's cycle:
//! the run's dwell is fitted to the measured removal (before − after) as a calibration of the
//! Preston coefficient, stored with the measurement (one transaction) as learned from
//! production.

use serde_json::{json, Value};

use super::answers::{
    read, DifferenceAnswer, MeasurementAnswer, PartBody, PlanAnswer, PlanAperture,
};
use super::cycles::plan_setting;
use super::profiles::{self, calibration_record};
use super::{
    absent, document, fill, found, without, Computation, Compute, Document, LedgerError, MapFile,
    SettingOwner, Write,
};
use crate::store::Store;
use crate::usecases::records::{
    cycles, lesson_warnings, run_completed_by_new_measurement, CalibrationRecord,
    MeasurementRecord, PartRecord, Records,
};
use crate::usecases::Warning;

/// A part to create: its name (the shop's serial), its profile and its body (surface,
/// workpiece radius, clear aperture).
pub struct NewPart {
    name: String,
    process_profile: String,
    body: Document,
}

impl NewPart {
    /// A serial is 1 to 200 characters, no control characters, no leading or trailing spaces.
    pub fn new(
        name: String,
        process_profile: String,
        body: Document,
    ) -> Result<NewPart, LedgerError> {
        let ok = (1..=200).contains(&name.chars().count())
            && !name.chars().any(char::is_control)
            && name.trim() == name;
        if !ok {
            return Err(LedgerError::invalid(
                "name",
                "a part's name (its serial) is 1 to 200 characters, no control characters, no \
                 leading or trailing spaces",
            ));
        }
        Ok(NewPart {
            name,
            process_profile,
            body,
        })
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// The record, once its profile's current process on the part is a setting every compute
    /// endpoint accepts.
    pub async fn record<C: Compute>(
        self,
        compute: &C,
        write: &Write<'_>,
    ) -> Result<PartRecord, C::Problem> {
        let store = write.store();
        let profile = store.profile(&self.process_profile).await?.ok_or_else(|| {
            LedgerError::invalid(
                "process_profile",
                format!("there is no process profile `{}`", self.process_profile),
            )
        })?;
        let current = profiles::current(store, &profile).await?;
        let body = Value::Object(self.body);
        compute.check_setting(&on_part(current.process, &body)?, SettingOwner::Part)?;
        Ok(PartRecord {
            stamp: write.stamp(),
            name: self.name,
            process_profile: self.process_profile,
            body: body.to_string(),
        })
    }
}

/// A request's setting on a part: the process at the part's workpiece radius, the part's
/// surface and clear aperture (`part` is the part's stored body).
pub fn on_part(mut process: Value, part: &Value) -> Result<Document, LedgerError> {
    let radius = read::<PartBody>(part, "a part")?.workpiece_radius_mm;
    if let Some(process) = process.as_object_mut() {
        process.insert("workpiece_radius_mm".into(), Value::Number(radius));
    }
    let mut setting = Document::new();
    setting.insert("process".into(), process);
    fill(&mut setting, part, &["surface", "clear_aperture"]);
    Ok(setting)
}

pub async fn load(store: &Store, id: &str) -> Result<PartRecord, LedgerError> {
    found(store.part(id).await?, "part", id)
}

/// A measurement, and the cycle it completes.
pub struct MeasurementOutcome {
    pub measurement: MeasurementRecord,
    /// The run whose cycle it completes.
    pub completes_run: Option<String>,
    /// That cycle was measured before too (its plan's measurement), so it can teach.
    pub measured_before: bool,
    /// The calibration fitted to that cycle's removal: learned when significant
    /// ([`CalibrationRecord::learned`]); none when no K > 0 fits it, or nothing was measured
    /// before.
    pub fitted: Option<CalibrationRecord>,
}

impl MeasurementOutcome {
    /// The calibration the profile learned from the cycle, if it learned one.
    pub fn learned_calibration(&self) -> Option<&str> {
        self.fitted
            .as_ref()
            .filter(|c| c.learned())
            .map(|c| c.stamp.id.as_str())
    }

    /// A complete cycle that taught nothing ([`lesson_warnings`]), as its history says.
    pub fn warnings(&self) -> Vec<Warning> {
        lesson_warnings(
            self.completes_run.is_some() && self.measured_before,
            self.fitted.as_ref(),
        )
    }
}

/// What measured a part.
pub enum Measured<'a> {
    /// A probe trace: a `/v1/measurement/fit` request without `surface` (the part's);
    /// `clear_aperture` defaults to the part's.
    Trace(Document),
    /// An interferometer map: the file as the instrument wrote it, and a `/v1/maps/analysis`
    /// request without `map`; `clear_aperture` defaults to the part's (a circle, or an annulus
    /// when it has an inner radius).
    Map { request: Document, file: &'a [u8] },
}

/// Measures part `id`: the trace fitted, or the map analysed (its file kept as a blob before
/// the record that names it), and the cycle it completes learned from.
pub async fn measure<C: Compute>(
    compute: &C,
    write: &Write<'_>,
    id: &str,
    measured: Measured<'_>,
) -> Result<MeasurementOutcome, C::Problem> {
    let store = write.store();
    let part = load(store, id).await?;
    let part_body = document(&part.body)?;
    let (request, result, file) = match measured {
        Measured::Trace(body) => {
            let mut request = without(body, &[("surface", "the part")])?;
            fill(&mut request, &part_body, &["surface", "clear_aperture"]);
            let result = compute
                .compute(Computation::MeasurementFit, &request)
                .await?;
            (request, result, None)
        }
        Measured::Map { request, file } => {
            let mut request = without(request, &[("map", "the body: the map's file")])?;
            if absent(&request, "clear_aperture") {
                if let Some(aperture) = map_aperture(&part_body)? {
                    request.insert("clear_aperture".into(), aperture);
                }
            }
            let result = compute
                .compute_with_maps(Computation::MapAnalysis, &request, &[("map", file)])
                .await?;
            (request, result, Some(file))
        }
    };
    let answer: MeasurementAnswer = read(&result, "a measurement's answer")?;
    let map_sha256 = match file {
        Some(file) => Some(store.put_blob(file).await?),
        None => None,
    };
    let after = After {
        profile: answer.profile(),
        map: file.map(|f| (f, &request)),
    };
    let lesson = learn_from_cycle(compute, write, &part, &after).await?;
    let measurement = MeasurementRecord {
        stamp: write.stamp(),
        part: id.to_string(),
        rms_nm: answer.rms_nm(),
        request: Value::Object(request).to_string(),
        result: result.to_string(),
        map_sha256,
    };
    Ok(MeasurementOutcome {
        measurement,
        completes_run: lesson.as_ref().map(|l| l.run.clone()),
        measured_before: lesson.as_ref().is_some_and(|l| l.measured_before),
        fitted: lesson.and_then(|l| l.fitted),
    })
}

/// A part's clear aperture (`{inner_mm, outer_mm}`, the outer radius by default the
/// workpiece's) as a map's: a circle, or an annulus with an inner radius; none when the part
/// names none (the map's fitted part then).
fn map_aperture(part: &Value) -> Result<Option<Value>, LedgerError> {
    let body = read::<PartBody>(part, "a part")?;
    let Some(aperture) = body.clear_aperture else {
        return Ok(None);
    };
    // The numbers as the part has them (an integer stays one).
    let radius = |member: &str| aperture.get(member).filter(|v| v.is_number()).cloned();
    let outer = radius("outer_mm").unwrap_or(Value::Number(body.workpiece_radius_mm));
    let inner = radius("inner_mm").filter(|r| r.as_f64().is_some_and(|r| r > 0.0));
    Ok(Some(match inner {
        Some(inner) => {
            json!({"shape": "annulus", "inner_radius_mm": inner, "outer_radius_mm": outer})
        }
        None => json!({"shape": "circle", "radius_mm": outer}),
    }))
}

/// A new measurement as a cycle's after: its form-error profile, and for a map its file and
/// analysis request.
struct After<'a> {
    profile: &'a Value,
    map: Option<(&'a [u8], &'a Document)>,
}

/// What a new measurement's cycle taught.
struct Lesson {
    run: String,
    measured_before: bool,
    fitted: Option<CalibrationRecord>,
}

/// The cycle a new measurement completes, if any: its run, and the calibration fitted to its
/// removal (kept whether or not it is significant: the profile learns only from those that
/// are). When maps measured the part before and after, every pixel of their difference is
/// fitted by the removal the plan's motion leaves there (registered as the after map was
/// analysed; K's error counts the residual's correlation from pixel to pixel), or, for a plan
/// too long to predict pixel by pixel, their difference's radial removal; else before − after
/// of the radial profiles. A computation that could not run (the service overloaded) fails the
/// write, to be retried; one that refuses the removal (no K > 0 fits it) leaves the cycle
/// without a calibration.
async fn learn_from_cycle<C: Compute>(
    compute: &C,
    write: &Write<'_>,
    part: &PartRecord,
    after: &After<'_>,
) -> Result<Option<Lesson>, C::Problem> {
    let store = write.store();
    let id = &part.stamp.id;
    let (measurements, plans, runs) = (
        store.measurements(id).await?,
        store.plans(id).await?,
        store.runs(id).await?,
    );
    let Some((run, plan)) = run_completed_by_new_measurement(&measurements, &plans, &runs) else {
        return Ok(None);
    };
    let missing = || LedgerError::Broken("a cycle's plan or measurement is missing".into());
    let plan = store.plan(&plan.stamp.id).await?.ok_or_else(missing)?;
    let Some(before_id) = plan.measurement.as_deref() else {
        // Planned with a target of its own: nothing measured before, nothing to learn.
        return Ok(Some(Lesson {
            run: run.stamp.id.clone(),
            measured_before: false,
            fitted: None,
        }));
    };
    let before = store.measurement(before_id).await?.ok_or_else(missing)?;
    let plan_request = document(&plan.request)?;
    let profile = profiles::load(store, &part.process_profile).await?;
    // What ran: the plan's dwell, and a polar plan's C law.
    let answer = read::<PlanAnswer>(&document(&plan.result)?, "a plan")?;
    let polar = answer.is_polar();
    let mut run_fit = if polar {
        json!({"polar": answer.motion()})
    } else {
        Value::Object(answer.motion())
    };
    if let Some(aperture) = read::<PlanAperture>(&plan_request, "a plan request")?.clear_aperture {
        run_fit["clear_aperture"] = aperture;
    }
    let mut setting = Document::new();
    plan_setting(&mut setting, &plan_request, &profile)?;
    setting.insert("fit".into(), json!({"preston_coefficient": true}));
    let calibration = |run: Value| {
        let mut request = setting.clone();
        request.insert("runs".into(), json!([run]));
        request
    };
    let fitted = match (&before.map_sha256, after.map) {
        (Some(sha256), Some((file, analysed))) => {
            let before_file = store.blob(sha256).await?.ok_or_else(missing)?;
            let maps = [("before", before_file.as_slice()), ("after", file)];
            // Where the maps sit on the part, as the after map was analysed.
            let mut placed = Document::new();
            fill(
                &mut placed,
                &Value::Object(analysed.clone()),
                &["pixel_mm", "alignment", "clear_aperture"],
            );
            // Every pixel predicted from the motion run, K's error with the residual's
            // correlation counted.
            let mut map_run = run_fit.clone();
            map_run["map"] = Value::Object(placed.clone());
            match fit_run(compute, &run.stamp.id, calibration(map_run), &maps).await? {
                Some(fitted) => Some(fitted),
                // A polar plan's law shows only pixel by pixel (a profile of it is refused).
                None if polar => None,
                None => {
                    tracing::info!(run = %run.stamp.id, "the maps' pixels determine no calibration: their radial removal is fitted");
                    run_fit["removal"] = radial_removal(compute, placed, analysed, &maps).await?;
                    fit_run(compute, &run.stamp.id, calibration(run_fit), &[]).await?
                }
            }
        }
        _ => {
            let answer: MeasurementAnswer = read(&document(&before.result)?, "a measurement")?;
            run_fit["before"] = answer.profile().clone();
            run_fit["after"] = after.profile.clone();
            fit_run(compute, &run.stamp.id, calibration(run_fit), &[]).await?
        }
    };
    let fitted = match fitted {
        Some((request, result)) => Some(calibration_record(
            write.stamp(),
            &profile.stamp.id,
            &request,
            &result,
            Some(run.stamp.id.clone()),
        )?),
        None => None,
    };
    Ok(Some(Lesson {
        run: run.stamp.id.clone(),
        measured_before: true,
        fitted,
    }))
}

/// A calibration of one run: the request and its answer, or None when the run determines
/// none (the calibration refuses it: nothing to learn, not an error of the measurement).
async fn fit_run<C: Compute>(
    compute: &C,
    run: &str,
    request: Document,
    maps: &[MapFile<'_>],
) -> Result<Option<(Document, Value)>, C::Problem> {
    match compute
        .compute_with_maps(Computation::Calibration, &request, maps)
        .await
    {
        Ok(result) => Ok(Some((request, result))),
        Err(error) if C::refuses(&error) => {
            tracing::info!(run, %error, "the cycle's removal determines no calibration");
            Ok(None)
        }
        Err(error) => Err(error),
    }
}

/// The radial removal of the maps' difference (for a plan too long to predict pixel by pixel),
/// with the after map's analysis's PSD settings; placed without the alignment, which the
/// difference does itself.
async fn radial_removal<C: Compute>(
    compute: &C,
    mut placed: Document,
    analysed: &Document,
    maps: &[MapFile<'_>],
) -> Result<Value, C::Problem> {
    placed.remove("alignment");
    fill(&mut placed, &Value::Object(analysed.clone()), &["psd"]);
    let difference = compute
        .compute_with_maps(Computation::MapDifference, &placed, maps)
        .await?;
    Ok(read::<DifferenceAnswer>(&difference, "a map difference")?.radial_removal)
}

/// A stored measurement, and the cycle it completed.
pub async fn measurement(store: &Store, id: &str) -> Result<MeasurementOutcome, LedgerError> {
    let measurement = found(store.measurement(id).await?, "measurement", id)?;
    let part = load(store, &measurement.part).await?;
    let (measurements, plans, runs, calibrations) = (
        store.measurements(&part.stamp.id).await?,
        store.plans(&part.stamp.id).await?,
        store.runs(&part.stamp.id).await?,
        store.calibrations(&part.process_profile).await?,
    );
    let cycle = cycles(&measurements, &plans, &runs, &calibrations)
        .into_iter()
        .find(|c| c.after.is_some_and(|m| m.stamp.id == id));
    Ok(MeasurementOutcome {
        completes_run: cycle.as_ref().map(|c| c.run.stamp.id.clone()),
        measured_before: cycle.as_ref().is_some_and(|c| c.before.is_some()),
        fitted: cycle.and_then(|c| c.learned).cloned(),
        measurement,
    })
}

/// Measurement `id`'s map file, as the instrument wrote it (404 for a probe trace's).
pub async fn measurement_map(store: &Store, id: &str) -> Result<(String, Vec<u8>), LedgerError> {
    let measurement = found(store.measurement(id).await?, "measurement", id)?;
    let sha256 = found(measurement.map_sha256, "map of measurement", id)?;
    let file = store.blob(&sha256).await?.ok_or_else(|| {
        LedgerError::Broken(format!("measurement {id}'s map {sha256} is not kept"))
    })?;
    Ok((sha256, file))
}
