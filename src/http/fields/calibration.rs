//! Where the calibration's inputs sit in its request: each run's motion (`runs[i].ring`,
//! `runs[i].dwell`), its profiles (`runs[i].removal.radius_mm[k]`), its aperture, `fit`.

use super::super::error::{ApiError, Kind};
use crate::calibration::{CalibrationError, FitFailure, ProfileRole, RunError};
use crate::usecases::calibration::{CalibrationInputError, MapRunError, PolarTrialError};

fn role_name(role: ProfileRole) -> &'static str {
    match role {
        ProfileRole::Removal => "removal",
        ProfileRole::Before => "before",
        ProfileRole::After => "after",
    }
}

fn run_error(index: usize, error: RunError) -> ApiError {
    let run = format!("runs[{index}]");
    let detail = format!("run {index}: {error}");
    let field = match &error {
        // Which motion the run had is not in the error: a ring's position has no index.
        RunError::Position(e) if e.field() == "position_mm" => format!("{run}.ring.position_mm"),
        RunError::Position(e) => {
            return ApiError::from_schedule(&format!("{run}.dwell"), e.clone());
        }
        RunError::Duration { .. } => format!("{run}.ring.duration_s"),
        RunError::Profile { role, error } => {
            let (member, index) = error.field();
            let mut field = format!("{run}.{}.{member}", role_name(*role));
            if let Some(i) = index {
                field.push_str(&format!("[{i}]"));
            }
            field
        }
        RunError::NoOverlap => format!("{run}.after"),
        RunError::Aperture(e) => match e.field() {
            Some(member) => format!("{run}.clear_aperture.{member}"),
            None => format!("{run}.clear_aperture"),
        },
        RunError::NothingInAperture => format!("{run}.clear_aperture"),
        RunError::LawNeedsMap | RunError::NothingOnPart => format!("{run}.map"),
    };
    ApiError::invalid(field, detail)
}

impl From<CalibrationInputError> for ApiError {
    fn from(err: CalibrationInputError) -> Self {
        use CalibrationInputError as E;
        match err {
            E::Setting(e) => e.into(),
            E::Runs(e) => ApiError::from_limit("runs", e),
            E::Points(e) => ApiError::from_limit("runs", e),
            E::Positions { run, error } => {
                ApiError::from_limit(&format!("runs[{run}].dwell.positions_mm"), error)
            }
            E::Noise => ApiError::invalid("expected_noise_nm", err.to_string()),
            E::Polar { run, error } => {
                let at = format!("runs[{run}].polar");
                match error {
                    PolarTrialError::Schedule(e) => {
                        ApiError::from_schedule(&format!("{at}.dwell"), e)
                    }
                    PolarTrialError::Law(law) => ApiError::invalid(
                        format!("{at}.{}", super::maps::c_law_field(&law)),
                        format!("run {run}: {law}"),
                    ),
                    PolarTrialError::StartAngle(_) => ApiError::invalid(
                        format!("{at}.start_angle_deg"),
                        format!("run {run}: {error}"),
                    ),
                }
            }
            E::Map { run, error } => {
                let at = format!("runs[{run}].map");
                match error {
                    MapRunError::Removal(e) => ApiError::from(e).under(&at),
                    MapRunError::Difference(e) => ApiError::from(e).under(&at),
                    MapRunError::Differenced(e) => ApiError::from(e).under(&at),
                }
            }
            E::MapPixels { .. } | E::MapWork { .. } => ApiError::limit("runs", err.to_string()),
            E::Calibration(e) => match e {
                CalibrationError::NoRuns => ApiError::invalid("runs", e.to_string()),
                CalibrationError::Run { index, error } => run_error(index, error),
                CalibrationError::NothingToFit => ApiError::invalid("fit", e.to_string()),
                CalibrationError::MomentShareNeedsLinear => {
                    ApiError::invalid("fit.pad_moment_share", e.to_string())
                }
                CalibrationError::ShapeFromMap { run } => {
                    ApiError::invalid(format!("runs[{run}].map"), e.to_string())
                }
                CalibrationError::TooFewPoints { .. } => ApiError::invalid("runs", e.to_string()),
            },
        }
    }
}

impl From<FitFailure> for ApiError {
    fn from(err: FitFailure) -> Self {
        match &err {
            FitFailure::Undetermined { parameters } => {
                let field = parameters
                    .first()
                    .filter(|p| !p.contains(' '))
                    .map_or("fit".to_string(), |p| format!("fit.{p}"));
                ApiError::invalid(field, err.to_string())
            }
            FitFailure::NoRemoval { .. } => ApiError::invalid("runs", err.to_string()),
            _ => ApiError::new(Kind::SolverNotConverged, err.to_string()),
        }
    }
}
