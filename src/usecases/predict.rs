//! Prediction: the cumulative removal of a dwell plan (or a constant feed) and its uniformity.
//! Both are the motion of [`crate::physics::motion`].

use super::warnings::unit_warnings;
use super::{ComputeLimits, Input, InputError, OperatorCache, Recommender, Setting, Warning};
use crate::machine::MachineChoice;
use crate::physics::{ConstantFeed, DwellSchedule, RowReading, UniformityMetrics};
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

/// What the tool does, as asked: exactly one of a dwell plan and a constant feed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TravelSpec {
    pub dwell: Option<DwellSpec>,
    pub feed: Option<FeedSpec>,
}

/// Tool positions, mm, and the dwell in each one's cell, s.
#[derive(Debug, Clone, PartialEq)]
pub struct DwellSpec {
    pub positions_mm: Vec<f64>,
    pub dwell_s: Vec<f64>,
}

/// One constant feed along the surface from `start_mm` to `stop_mm` (radii within reach).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedSpec {
    pub start_mm: f64,
    pub stop_mm: f64,
    pub feed_mm_per_min: f64,
}

impl PredictCommand {
    pub fn new(
        setting: Setting,
        travel: TravelSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, InputError> {
        let travel = match (travel.dwell, travel.feed) {
            (Some(dwell), None) => {
                limits
                    .check_operator(setting.samples(), dwell.positions_mm.len())
                    .map_err(InputError::limit(Input::Dwell))?;
                let schedule =
                    DwellSchedule::new(setting.process(), dwell.positions_mm, dwell.dwell_s)
                        .map_err(InputError::schedule(Input::Dwell))?;
                Travel::Dwell(schedule)
            }
            (None, Some(feed)) => Travel::Feed(
                ConstantFeed::new(
                    setting.process(),
                    feed.start_mm,
                    feed.stop_mm,
                    feed.feed_mm_per_min,
                )
                .map_err(InputError::schedule(Input::Feed))?,
            ),
            _ => return Err(InputError::OneOf(Input::Dwell, Input::Feed)),
        };
        Ok(PredictCommand { setting, travel })
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
    // The recommendation's pass at these speeds is read beside a newly assembled operator.
    let pass = Recommender::pass_to_read(&setting);
    let (removal_nm, total_time_s, warnings, passed) = match &travel {
        Travel::Dwell(schedule) => {
            let (operator, passed) = operators.operator_reading(
                process,
                radii,
                schedule.motion(),
                pass.as_ref().map(|p| p as &dyn RowReading),
            );
            (
                operator.apply(schedule.dwell_s()),
                schedule.total_time_s(),
                unit_warnings(process, schedule.positions_mm()),
                passed,
            )
        }
        Travel::Feed(feed) => (
            feed.removal_nm(process, radii),
            feed.total_time_s(process),
            unit_warnings(process, &[feed.start_mm(), feed.stop_mm()]),
            None,
        ),
    };
    let metrics = UniformityMetrics::over(setting.grid(), setting.aperture(), &removal_nm);
    Prediction {
        warnings,
        // A prediction names no machine: its recommendation keeps the default machine's
        // spindle limits, as the plans made without one will.
        recommendation: recommender.for_plan(
            &setting,
            metrics.mean_nm,
            passed,
            &MachineChoice::Default.limits().unwrap_or_default(),
        ),
        total_time_s,
        setting,
        removal_nm,
        metrics,
    }
}
