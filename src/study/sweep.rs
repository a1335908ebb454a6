//! η sweeps: the tool speed held, the workpiece at −η·tool for each η, and the uniformity of
//! equal dwell (or of a given dwell schedule) at each. Points are computed in parallel.

use rayon::prelude::*;

use super::equal_dwell::{EqualDwell, Frame};
use super::StudyError;
use crate::physics::{DwellSchedule, Process, ProcessSpec, UniformityMetrics};

/// One point of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    pub eta: f64,
    pub workpiece_rpm: f64,
    pub metrics: UniformityMetrics,
}

/// The η values of a sweep, checked against the process whose tool speed it holds: the tool
/// turns (tool_rpm ≠ 0), and each η is finite, not 0, and puts the workpiece speed −η·tool_rpm
/// inside the model's domain.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepEtas {
    spec: ProcessSpec,
    etas: Vec<f64>,
}

impl SweepEtas {
    pub fn new(spec: &ProcessSpec, etas: Vec<f64>) -> Result<Self, StudyError> {
        if spec.tool_rpm == 0.0 {
            return Err(StudyError::ToolStationary);
        }
        for (index, &eta) in etas.iter().enumerate() {
            if !eta.is_finite() || eta == 0.0 {
                return Err(StudyError::InvalidEta { index });
            }
            Process::new(spec.with_eta(eta))
                .map_err(|error| StudyError::EtaOutsideDomain { index, error })?;
        }
        Ok(SweepEtas {
            spec: spec.clone(),
            etas,
        })
    }

    /// The process whose tool speed is held.
    pub fn spec(&self) -> &ProcessSpec {
        &self.spec
    }

    pub fn etas(&self) -> &[f64] {
        &self.etas
    }
}

/// Sweeps the η values at their process's tool speed. With `dwell`, that schedule is used at
/// every point; otherwise equal dwell of `frame.positions` cells removing `depth_nm`.
pub fn eta_sweep(
    etas: &SweepEtas,
    frame: Frame,
    dwell: Option<&DwellSchedule>,
    depth_nm: f64,
) -> Result<Vec<SweepPoint>, StudyError> {
    etas.etas
        .par_iter()
        .enumerate()
        .map(|(index, &eta)| {
            let spec = etas.spec.with_eta(eta);
            let process = Process::new(spec.clone())
                .map_err(|error| StudyError::EtaOutsideDomain { index, error })?;
            let metrics = match dwell {
                Some(schedule) => UniformityMetrics::over(
                    frame.grid,
                    frame.aperture,
                    &schedule.removal_nm(&process, frame.grid),
                ),
                None => {
                    EqualDwell::for_depth(&process, frame, depth_nm)
                        .ok_or(StudyError::NoRemovalInAperture)?
                        .metrics
                }
            };
            Ok(SweepPoint {
                eta,
                workpiece_rpm: spec.workpiece_rpm,
                metrics,
            })
        })
        .collect()
}
