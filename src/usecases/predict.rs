//! Prediction: the cumulative removal of a dwell schedule and its uniformity.

use super::warnings::positions_unit;
use super::{ComputeLimits, Input, InputError, OperatorCache, Recommender, Setting, Warning};
use crate::physics::{DwellSchedule, UniformityMetrics};
use crate::study::Recommendation;

/// A dwell schedule to predict in a setting.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictCommand {
    setting: Setting,
    schedule: DwellSchedule,
}

impl PredictCommand {
    pub fn new(
        setting: Setting,
        positions_mm: Vec<f64>,
        dwell_s: Vec<f64>,
        limits: &ComputeLimits,
    ) -> Result<Self, InputError> {
        limits
            .check_operator(setting.samples(), positions_mm.len())
            .map_err(InputError::limit(Input::Dwell))?;
        let schedule = DwellSchedule::new(setting.process(), positions_mm, dwell_s)
            .map_err(InputError::schedule(Input::Dwell))?;
        Ok(PredictCommand { setting, schedule })
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    pub setting: Setting,
    /// Removal at each grid radius, nm.
    pub removal_nm: Vec<f64>,
    /// Uniformity over the clear aperture.
    pub metrics: UniformityMetrics,
    pub total_time_s: f64,
    /// η = −1 settings and what they buy; `None` at η = −1.
    pub recommendation: Option<Recommendation>,
    pub warnings: Vec<Warning>,
}

/// The prediction, with the operator from (or into) `operators`.
pub fn predict(
    command: PredictCommand,
    recommender: &Recommender,
    operators: &OperatorCache,
) -> Prediction {
    let PredictCommand { setting, schedule } = command;
    let removal_nm = operators
        .operator(
            setting.process(),
            setting.grid().radii_mm(),
            schedule.positions_mm(),
        )
        .apply(schedule.dwell_s());
    let metrics = UniformityMetrics::over(setting.grid(), setting.aperture(), &removal_nm);
    let warnings = positions_unit(setting.process(), schedule.positions_mm())
        .into_iter()
        .collect();
    Prediction {
        warnings,
        recommendation: recommender.for_plan(&setting, metrics.mean_nm),
        total_time_s: schedule.total_time_s(),
        setting,
        removal_nm,
        metrics,
    }
}
