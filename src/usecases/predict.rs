//! Prediction: the cumulative removal of a dwell plan (or a constant feed) and its uniformity.
//! Both are the motion of [`crate::physics::motion`].

use super::warnings::unit_warning;
use super::{ComputeLimits, Input, InputError, OperatorCache, Recommender, Setting, Warning};
use crate::physics::{ConstantFeed, DwellSchedule, UniformityMetrics};
use crate::study::Recommendation;

/// What the tool does: a dwell plan, or one constant feed along the surface.
#[derive(Debug, Clone, PartialEq)]
pub enum Travel {
    Dwell(DwellSchedule),
    Feed(ConstantFeed),
}

/// A dwell plan or a constant feed to predict in a setting.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictCommand {
    setting: Setting,
    travel: Travel,
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
        Ok(PredictCommand {
            setting,
            travel: Travel::Dwell(schedule),
        })
    }

    /// A constant feed from `start_mm` to `stop_mm` (radii within reach) at `feed_mm_per_min`
    /// along the surface.
    pub fn with_feed(
        setting: Setting,
        start_mm: f64,
        stop_mm: f64,
        feed_mm_per_min: f64,
    ) -> Result<Self, InputError> {
        let feed = ConstantFeed::new(setting.process(), start_mm, stop_mm, feed_mm_per_min)
            .map_err(InputError::schedule(Input::Feed))?;
        Ok(PredictCommand {
            setting,
            travel: Travel::Feed(feed),
        })
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
    let PredictCommand { setting, travel } = command;
    let process = setting.process();
    let radii = setting.grid().radii_mm();
    let (removal_nm, total_time_s, warnings) = match &travel {
        Travel::Dwell(schedule) => (
            operators
                .operator(process, radii, schedule.positions_mm())
                .apply(schedule.dwell_s()),
            schedule.total_time_s(),
            unit_warning(process, schedule.positions_mm())
                .into_iter()
                .collect(),
        ),
        Travel::Feed(feed) => (
            feed.removal_nm(process, radii),
            feed.total_time_s(process),
            unit_warning(process, &[feed.start_mm(), feed.stop_mm()])
                .into_iter()
                .collect(),
        ),
    };
    let metrics = UniformityMetrics::over(setting.grid(), setting.aperture(), &removal_nm);
    Prediction {
        warnings,
        recommendation: recommender.for_plan(&setting, metrics.mean_nm),
        total_time_s,
        setting,
        removal_nm,
        metrics,
    }
}
