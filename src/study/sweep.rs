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

/// Sweeps `etas` (each finite and ≠ 0) at the tool speed of `spec` (≠ 0). With `dwell`, that
/// schedule is used at every point; otherwise equal dwell of `frame.positions` cells removing
/// `depth_nm`.
pub fn eta_sweep(
    spec: &ProcessSpec,
    etas: &[f64],
    frame: Frame,
    dwell: Option<&DwellSchedule>,
    depth_nm: f64,
) -> Result<Vec<SweepPoint>, StudyError> {
    if spec.tool_rpm == 0.0 {
        return Err(StudyError::new(
            "process.tool_rpm",
            "an η sweep holds the tool speed, so tool_rpm must not be 0",
        ));
    }
    for (i, &eta) in etas.iter().enumerate() {
        if !eta.is_finite() || eta == 0.0 {
            return Err(StudyError::new(
                format!("etas[{i}]"),
                format!("etas[{i}] must be finite and not 0 (η = 0 stops the workpiece)"),
            ));
        }
    }
    etas.par_iter()
        .enumerate()
        .map(|(i, &eta)| {
            let workpiece_rpm = -eta * spec.tool_rpm;
            let process = Process::new(ProcessSpec {
                workpiece_rpm,
                ..*spec
            })
            .map_err(|e| StudyError::new(format!("etas[{i}]"), e.to_string()))?;
            let removal = match dwell {
                Some(schedule) => schedule.removal_nm(&process, frame.grid),
                None => {
                    EqualDwell::for_depth(&process, frame, depth_nm)
                        .ok_or_else(|| {
                            StudyError::new(
                                "clear_aperture",
                                "equal dwell removes nothing inside the clear aperture",
                            )
                        })?
                        .removal_nm
                }
            };
            Ok(SweepPoint {
                eta,
                workpiece_rpm,
                metrics: UniformityMetrics::over(frame.grid, frame.aperture, &removal),
            })
        })
        .collect()
}
