//! η sweeps: uniformity against η with the tool speed held.

use super::recommend::equal_dwell_depth;
use super::warnings::process_warnings;
use super::{ComputeLimits, Input, InputError, Setting, Warning};
use crate::physics::DwellSchedule;
use crate::study::{self, StudyError, SweepEtas, SweepPoint};

/// A sweep over η values in a setting, with a given dwell schedule or equal dwell.
#[derive(Debug, Clone, PartialEq)]
pub struct EtaSweepCommand {
    setting: Setting,
    etas: SweepEtas,
    dwell: Option<DwellSchedule>,
    depth_nm: f64,
}

impl EtaSweepCommand {
    /// `dwell` is (positions_mm, dwell_s); without it equal dwell (a constant feed) removes
    /// `depth_nm` (default 100) at each point.
    pub fn new(
        setting: Setting,
        etas: Vec<f64>,
        dwell: Option<(Vec<f64>, Vec<f64>)>,
        depth_nm: Option<f64>,
        limits: &ComputeLimits,
    ) -> Result<Self, InputError> {
        if etas.is_empty() {
            return Err(InputError::OutOfRange {
                input: Input::Etas,
                max: limits.max_etas as f64,
            });
        }
        limits
            .check_etas(etas.len())
            .map_err(InputError::limit(Input::Etas))?;
        let depth_nm = equal_dwell_depth(depth_nm)?;
        let dwell = match dwell {
            Some((positions_mm, dwell_s)) => {
                limits
                    .check_operator(setting.samples(), positions_mm.len())
                    .map_err(InputError::limit(Input::Dwell))?;
                Some(
                    DwellSchedule::new(setting.process(), positions_mm, dwell_s)
                        .map_err(InputError::schedule(Input::Dwell))?,
                )
            }
            None => None,
        };
        let etas = SweepEtas::new(setting.process().spec(), etas)?;
        Ok(EtaSweepCommand {
            setting,
            etas,
            dwell,
            depth_nm,
        })
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct EtaSweep {
    pub setting: Setting,
    /// The tool speed held, r/min.
    pub tool_rpm: f64,
    /// One point per η, in the command's order.
    pub points: Vec<SweepPoint>,
    /// Likely unit mistakes in the process.
    pub warnings: Vec<Warning>,
}

pub fn eta_sweep(command: EtaSweepCommand) -> Result<EtaSweep, StudyError> {
    let EtaSweepCommand {
        setting,
        etas,
        dwell,
        depth_nm,
    } = command;
    let points = study::eta_sweep(&etas, setting.frame(), dwell.as_ref(), depth_nm)?;
    Ok(EtaSweep {
        warnings: process_warnings(setting.process()),
        tool_rpm: etas.spec().tool_rpm,
        setting,
        points,
    })
}
