//! What the ledger reads of the compute endpoints' answers and of its stored documents, as
//! typed projections in the API's own member names: a document that lacks a member is a broken
//! record ([`LedgerError::Broken`]), never a NaN or a silent default.

use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::Value;

use super::{Document, LedgerError};

/// `value` read as `T`; `what` names the document in the error.
pub(super) fn read<T: DeserializeOwned>(value: &Value, what: &str) -> Result<T, LedgerError> {
    T::deserialize(value).map_err(|e| LedgerError::Broken(format!("{what}: {e}")))
}

/// An RMS figure.
#[derive(Debug, Deserialize)]
pub(super) struct Rms {
    pub rms_nm: f64,
}

/// A part's plan: a `/v1/optimize` answer (the dwell over radius, C at the process's speed)
/// or a `/v1/maps/optimize` answer (the mean dwell and C's speed law).
#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub(super) enum PlanAnswer {
    Polar {
        dwell: Value,
        c_law: Value,
        metrics: PolarPlanFigures,
    },
    Radial {
        dwell: Value,
        residual: Rms,
    },
}

#[derive(Debug, Deserialize)]
pub(super) struct PolarPlanFigures {
    pub after: Rms,
}

impl PlanAnswer {
    /// The residual's RMS over the clear aperture the plan predicts, nm.
    pub fn residual_rms_nm(&self) -> f64 {
        match self {
            PlanAnswer::Polar { metrics, .. } => metrics.after.rms_nm,
            PlanAnswer::Radial { residual, .. } => residual.rms_nm,
        }
    }

    /// What the plan runs, as a calibration run's and a program request's members: the dwell,
    /// and a polar plan's C law.
    pub fn motion(self) -> Document {
        let mut motion = Document::new();
        if let PlanAnswer::Polar { c_law, .. } = &self {
            motion.insert("c_law".into(), c_law.clone());
        }
        let (PlanAnswer::Polar { dwell, .. } | PlanAnswer::Radial { dwell, .. }) = self;
        motion.insert("dwell".into(), dwell);
        motion
    }

    pub fn is_polar(&self) -> bool {
        matches!(self, PlanAnswer::Polar { .. })
    }
}

/// A measurement's answer: a probe trace's (`/v1/measurement/fit`: the form error, its radial
/// profile and the correction) or a map's (`/v1/maps/analysis`: its metrics, its rotationally
/// symmetric part and the correction of that).
#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub(super) enum MeasurementAnswer {
    Trace {
        form_error: Rms,
        profile: Value,
        correction_target: Value,
    },
    Map {
        metrics: Rms,
        radial_profile: Value,
        correction_target: Value,
    },
}

impl MeasurementAnswer {
    /// The RMS of the form error (a map's after piston and tilt), nm.
    pub fn rms_nm(&self) -> f64 {
        match self {
            MeasurementAnswer::Trace { form_error: r, .. }
            | MeasurementAnswer::Map { metrics: r, .. } => r.rms_nm,
        }
    }

    /// The radial profile of the form error ({radius_mm, depth_nm}, e > 0 proud).
    pub fn profile(&self) -> &Value {
        match self {
            MeasurementAnswer::Trace { profile, .. } => profile,
            MeasurementAnswer::Map { radial_profile, .. } => radial_profile,
        }
    }

    /// The `target` of the `/v1/optimize` request that corrects it.
    pub fn correction_target(&self) -> &Value {
        match self {
            MeasurementAnswer::Trace {
                correction_target, ..
            }
            | MeasurementAnswer::Map {
                correction_target, ..
            } => correction_target,
        }
    }
}

/// A `/v1/maps/difference` answer: the radial removal, in a calibration run's `removal` form.
#[derive(Debug, Deserialize)]
pub(super) struct DifferenceAnswer {
    pub radial_removal: Value,
}

/// A `/v1/calibration` answer: K with its standard error, and the calibrated process.
#[derive(Debug, Deserialize)]
pub(super) struct CalibrationAnswer {
    pub parameters: CalibratedParameters,
    pub process: Value,
}

#[derive(Debug, Deserialize)]
pub(super) struct CalibratedParameters {
    pub preston_coefficient_m2_per_n: ValueAndError,
}

#[derive(Debug, Deserialize)]
pub(super) struct ValueAndError {
    pub value: f64,
    pub standard_error: Option<f64>,
}

/// A part's stored body (its request as written): the workpiece radius keeps its number as
/// written (an integer stays one).
#[derive(Debug, Deserialize)]
pub struct PartBody {
    pub surface: Option<Value>,
    pub workpiece_radius_mm: serde_json::Number,
    pub clear_aperture: Option<Value>,
}

/// A process profile's stored body (its request as written).
#[derive(Debug, Deserialize)]
pub struct ProfileBody {
    pub process: Value,
    pub surface: Option<Value>,
    pub tool: Option<Value>,
}

/// A plan request's clear aperture, when it names one (`Some(null)` when it names null).
#[derive(Debug, Deserialize)]
pub(super) struct PlanAperture {
    #[serde(default, deserialize_with = "present")]
    pub clear_aperture: Option<Value>,
}

/// A member that is there, null or not (an absent one is `None` by its default).
fn present<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Value>, D::Error> {
    Value::deserialize(d).map(Some)
}

/// A process document's Preston coefficient (profiles store it filled in).
#[derive(Debug, Deserialize)]
pub(super) struct ProcessRate {
    pub preston_coefficient_m2_per_n: f64,
}
