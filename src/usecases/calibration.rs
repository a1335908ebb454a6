//! Calibration: fit the process's removal rate (and, if asked, its pad radius and moment
//! share) to what ring tests or production runs removed ([`crate::calibration`]), and say
//! which parameters the runs could not determine and which runs the model does not explain.

use super::limits::{ComputeLimits, SizeLimitError};
use super::setting::{process_on_part, SettingError};
use super::warnings::process_warnings;
use super::{PartSpec, Warning};
use crate::calibration::{
    Calibrated, Calibration, CalibrationError, FitFailure, Freedom, ProcessParameter, RunSpec,
    TrialSpec,
};
use crate::lsq::RobustLoss;
use crate::physics::ProcessSpec;

/// The most runs one calibration takes.
pub const MAX_RUNS: usize = 64;
/// A fitted parameter whose 95 % interval's half-width exceeds this (relative to K and r_t,
/// absolute for κ) is reported as poorly determined: the runs barely constrain it.
pub const POOR_RELATIVE: f64 = 0.2;
pub const POOR_SHARE: f64 = 0.25;
/// A run whose residual RMS exceeds this many times its noise is flagged.
pub const NOISE_FACTOR: f64 = 3.0;

/// What to fit, as asked (`None`: the default).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ParameterSelection {
    /// Default true.
    pub preston_coefficient: Option<bool>,
    /// Default false.
    pub tool_radius: Option<bool>,
    /// Default false.
    pub pad_moment_share: Option<bool>,
    /// Default false.
    pub metrology_power: Option<bool>,
}

/// A calibration as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationSpec {
    pub process: ProcessSpec,
    pub part: PartSpec,
    pub runs: Vec<RunSpec>,
    pub fit: ParameterSelection,
    pub robust: Option<RobustLoss>,
    /// The measurements' expected noise per point, nm (default: estimated from each run's
    /// point-to-point differences).
    pub expected_noise_nm: Option<f64>,
}

/// Why a calibration was refused before fitting.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationInputError {
    #[error(transparent)]
    Setting(SettingError),
    #[error(transparent)]
    Runs(SizeLimitError),
    #[error(transparent)]
    Points(SizeLimitError),
    #[error("run {run}: {error}")]
    Positions { run: usize, error: SizeLimitError },
    #[error("expected_noise_nm must be a finite number > 0")]
    Noise,
    #[error(transparent)]
    Calibration(CalibrationError),
}

/// A checked calibration.
#[derive(Debug, Clone)]
pub struct CalibrationCommand {
    calibration: Calibration,
    expected_noise_nm: Option<f64>,
    /// Likely unit mistakes in the nominal process.
    process_warnings: Vec<Warning>,
}

impl CalibrationCommand {
    pub fn new(
        spec: CalibrationSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, CalibrationInputError> {
        use CalibrationInputError as E;
        let (process, _) = process_on_part(spec.process, &spec.part).map_err(E::Setting)?;
        let process_warnings = process_warnings(&process);
        if spec.runs.len() > MAX_RUNS {
            return Err(E::Runs(SizeLimitError::Runs {
                count: spec.runs.len(),
                max: MAX_RUNS,
            }));
        }
        let points: usize = spec.runs.iter().map(measured_points).sum();
        limits.check_trace_points(points).map_err(E::Points)?;
        for (run, spec) in spec.runs.iter().enumerate() {
            if let TrialSpec::Dwell { positions_mm, .. } = &spec.trial {
                limits
                    .check_operator(measured_points(spec), positions_mm.len())
                    .map_err(|error| E::Positions { run, error })?;
            }
        }
        if spec
            .expected_noise_nm
            .is_some_and(|n| !(n.is_finite() && n > 0.0))
        {
            return Err(E::Noise);
        }
        let freedom = Freedom {
            preston_coefficient: spec.fit.preston_coefficient.unwrap_or(true),
            tool_radius: spec.fit.tool_radius.unwrap_or(false),
            pad_moment_share: spec.fit.pad_moment_share.unwrap_or(false),
            metrology_power: spec.fit.metrology_power.unwrap_or(false),
        };
        let calibration =
            Calibration::new(process, spec.runs, freedom, spec.robust.unwrap_or_default())
                .map_err(E::Calibration)?;
        Ok(CalibrationCommand {
            calibration,
            expected_noise_nm: spec.expected_noise_nm,
            process_warnings,
        })
    }
}

fn measured_points(run: &RunSpec) -> usize {
    use crate::calibration::Measured;
    match &run.measured {
        Measured::Removal(p) => p.radius_mm.len(),
        Measured::BeforeAfter { before, after } => before.radius_mm.len() + after.radius_mm.len(),
    }
}

/// A calibration's answer.
#[derive(Debug, Clone)]
pub struct CalibrationResult {
    pub calibrated: Calibrated,
    pub warnings: Vec<Warning>,
}

pub fn calibrate(command: CalibrationCommand) -> Result<CalibrationResult, FitFailure> {
    let calibrated = command.calibration.fit()?;
    let mut warnings = command.process_warnings.clone();
    if calibrated.exact_fit {
        warnings.push(Warning::ExactFit);
    }
    for e in &calibrated.estimates {
        let Some(u) = e.uncertainty else {
            if calibrated.exact_fit {
                continue;
            }
            warnings.push(Warning::ParameterUndetermined {
                parameter: e.parameter,
                held_at: e.value,
            });
            continue;
        };
        let half = 0.5 * (u.interval_95.1 - u.interval_95.0);
        let poor = match e.parameter {
            ProcessParameter::PadMomentShare => half > POOR_SHARE,
            _ => half > POOR_RELATIVE * e.value.abs(),
        };
        if poor {
            warnings.push(Warning::ParameterPoorlyDetermined {
                parameter: e.parameter,
                value: e.value,
                standard_error: u.standard_error,
            });
        }
    }
    for (run, fit) in calibrated.runs.iter().enumerate() {
        let noise = command.expected_noise_nm.or(fit.difference_noise_nm);
        if let Some(noise) = noise.filter(|n| *n > 0.0) {
            if fit.residual_rms_nm > NOISE_FACTOR * noise {
                warnings.push(Warning::ResidualAboveNoise {
                    run,
                    residual_rms_nm: fit.residual_rms_nm,
                    noise_nm: noise,
                    expected: command.expected_noise_nm.is_some(),
                });
            }
        }
    }
    Ok(CalibrationResult {
        calibrated,
        warnings,
    })
}
