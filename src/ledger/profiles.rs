//! Process profiles and their calibrations: a profile's current process (its own, or its latest
//! calibration's, with the Preston coefficient learned from production since: the rule is
//! `usecases::records::current_rate`).

use super::answers::{read, CalibrationAnswer, ProcessRate, ProfileBody};
use serde_json::Value;

use super::{
    document, fill, found, without, Computation, Compute, Document, LedgerError, SettingOwner,
    Write,
};
use crate::store::Store;
use crate::usecases::records::{current_rate, CalibrationRecord, ProfileRecord, Records, Stamp};

/// A profile to create, checked: its name and its setting (process, surface, tool).
pub struct NewProfile {
    name: String,
    setting: Document,
}

impl NewProfile {
    /// `name` is also a path segment: 1–64 of A–Z, a–z, 0–9, `-`, `_`, `.`; the setting is
    /// checked as every compute endpoint would check it.
    pub fn new<C: Compute>(
        compute: &C,
        name: String,
        setting: Document,
    ) -> Result<NewProfile, C::Problem> {
        let ok = (1..=64).contains(&name.len())
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
        if !ok {
            return Err(LedgerError::invalid(
                "name",
                "a name is 1 to 64 of A–Z, a–z, 0–9, '-', '_', '.'",
            )
            .into());
        }
        compute.check_setting(&setting, SettingOwner::Profile)?;
        Ok(NewProfile { name, setting })
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// The record: a profile's id is its name.
    pub fn record(self, mut stamp: Stamp) -> ProfileRecord {
        stamp.id = self.name;
        ProfileRecord {
            stamp,
            body: Value::Object(self.setting).to_string(),
        }
    }
}

/// Where a profile's current Preston coefficient comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RateSource {
    /// The profile's own process: nothing calibrated yet.
    Profile,
    /// The latest calibration asked for.
    Calibration,
    /// Learned from production cycles since that calibration.
    Learned,
}

/// The process a plan on the profile uses now.
#[derive(Debug, Clone, PartialEq)]
pub struct CurrentProcess {
    /// As a request's `process`.
    pub process: Value,
    pub source: RateSource,
    /// The coefficient's standard error, m²/N (none when never calibrated).
    pub standard_error_m2_per_n: Option<f64>,
}

/// The profile's process a plan uses now, from its calibrations (oldest first).
pub fn current_process(
    profile: &ProfileRecord,
    calibrations: &[CalibrationRecord],
) -> Result<CurrentProcess, LedgerError> {
    let own = read::<ProfileBody>(&document(&profile.body)?, "a process profile")?.process;
    let own_k =
        read::<ProcessRate>(&own, "a process profile's process")?.preston_coefficient_m2_per_n;
    let rate = current_rate(calibrations, own_k);
    let mut process = match rate.base {
        Some(base) => document(&base.process)?,
        None => own,
    };
    let source = match (rate.base, rate.learned.is_empty()) {
        (_, false) => RateSource::Learned,
        (Some(_), true) => RateSource::Calibration,
        (None, true) => RateSource::Profile,
    };
    if let (Some(k), Some(object)) = (rate.preston_coefficient_m2_per_n, process.as_object_mut()) {
        object.insert("preston_coefficient_m2_per_n".into(), k.into());
    }
    Ok(CurrentProcess {
        process,
        source,
        standard_error_m2_per_n: rate.standard_error_m2_per_n,
    })
}

/// The profile's current process, from its calibrations in the store.
pub(super) async fn current(
    store: &Store,
    profile: &ProfileRecord,
) -> Result<CurrentProcess, LedgerError> {
    current_process(profile, &store.calibrations(&profile.stamp.id).await?)
}

pub async fn load(store: &Store, name: &str) -> Result<ProfileRecord, LedgerError> {
    found(store.profile(name).await?, "process profile", name)
}

pub async fn load_calibration(store: &Store, id: &str) -> Result<CalibrationRecord, LedgerError> {
    found(store.calibration(id).await?, "calibration", id)
}

/// A calibration asked for (ring tests): `body` is a `/v1/calibration` request without
/// `process`, which is the profile's current one; `surface` and `tool` default to the
/// profile's.
pub async fn calibrate<C: Compute>(
    compute: &C,
    write: &Write<'_>,
    name: &str,
    body: Document,
) -> Result<CalibrationRecord, C::Problem> {
    let store = write.store();
    let profile = load(store, name).await?;
    let mut request = without(body, &[("process", "the process profile")])?;
    request.insert("process".into(), current(store, &profile).await?.process);
    fill(
        &mut request,
        &document(&profile.body)?,
        &["surface", "tool"],
    );
    let result = compute.compute(Computation::Calibration, &request).await?;
    Ok(calibration_record(
        write.stamp(),
        name,
        &request,
        &result,
        None,
    )?)
}

/// A calibration's record: the request, the answer, the calibrated process and its fitted
/// Preston coefficient; `run` is the production run it was learned from.
pub(super) fn calibration_record(
    stamp: Stamp,
    profile: &str,
    request: &Document,
    result: &Value,
    run: Option<String>,
) -> Result<CalibrationRecord, LedgerError> {
    let answer: CalibrationAnswer = read(result, "a calibration's answer")?;
    let estimate = answer.parameters.preston_coefficient_m2_per_n;
    Ok(CalibrationRecord {
        stamp,
        profile: profile.to_string(),
        request: Value::Object(request.clone()).to_string(),
        process: answer.process.to_string(),
        result: result.to_string(),
        preston_coefficient_m2_per_n: estimate.value,
        standard_error_m2_per_n: estimate.standard_error,
        run,
    })
}
