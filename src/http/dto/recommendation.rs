//! The η = −1 recommendation as responses carry it, with its equal-dwell plans.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::MetricsDto;
use crate::physics::ConstantFeed;
use crate::study::{EqualDwell, Recommendation, SpeedRule};

/// η = −1 settings: workpiece and tool turning the same way (same sign) at the same speed,
/// where equal dwell removes a uniform layer. All comparisons use equal dwell (one constant
/// feed over [0, min(outer + r_t, reach)] mm) removing the same mean depth.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RecommendationDto {
    /// Recommended workpiece speed, r/min, signed (lab frame, CCW positive); equals tool_rpm,
    /// so η is exactly −1. Set to 0.1 r/min (below 1 r/min, to three significant figures),
    /// to the nearest for `match_removal_rate` (the mean rate then matches to that
    /// resolution) and down for `fastest_allowed`; every figure is computed at this speed.
    pub workpiece_rpm: f64,
    /// Recommended tool speed, r/min, signed; keeps the current tool direction (rounded as
    /// `workpiece_rpm`).
    pub tool_rpm: f64,
    /// −1.
    pub eta: f64,
    /// `match_removal_rate`: the speed keeps the current mean removal rate over the clear
    /// aperture; `fastest_allowed`: the limits forbid that, so the fastest allowed speed.
    pub rule: SpeedRuleDto,
    /// The interval of η around −1 (tool speed held) where equal-dwell nonuniformity stays at
    /// or below the threshold; null when even η = −1 is above it.
    #[schema(required = true)]
    pub eta_window: Option<EtaWindowDto>,
    /// Predicted uniformity of equal dwell at the recommended speeds, nm.
    pub metrics: MetricsDto,
    /// Predicted uniformity of equal dwell at the current speeds, nm.
    pub current_metrics: MetricsDto,
    /// Current nonuniformity / recommended nonuniformity; null when undefined, and when equal
    /// dwell at the recommended speeds is uniform to rounding (below 1e-9, as on a plane):
    /// then `nonuniformity_removed` is true.
    #[schema(required = true)]
    pub improvement_factor: Option<f64>,
    /// True when equal dwell at the recommended speeds is uniform to rounding (nonuniformity
    /// below 1e-9) and at the current speeds it is not: the recommendation removes the
    /// nonuniformity, the largest improvement there is (no finite factor says it).
    pub nonuniformity_removed: bool,
    /// The equal-dwell plan at the recommended speeds.
    pub equal_dwell: EqualDwellDto,
    /// The constant feed equal dwell needs at the current speeds for the same depth, mm/min.
    pub current_feed_mm_per_min: f64,
}

/// Which rule chose the recommended speed.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SpeedRuleDto {
    /// The speed keeps the current mean removal rate over the clear aperture.
    MatchRemovalRate,
    /// The machine's limits forbid that speed; the fastest allowed is used.
    FastestAllowed,
}

/// η bounds (paper convention, η = −workpiece_rpm / tool_rpm); null where no bound was found.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct EtaWindowDto {
    /// Lower η bound (below −1); null if none down to η = −51.
    #[schema(required = true)]
    pub low: Option<f64>,
    /// Upper η bound (above −1, below 0); null if none up to η = −1e-6.
    #[schema(required = true)]
    pub high: Option<f64>,
    /// The nonuniformity threshold the bounds meet (a fraction).
    pub nonuniformity_threshold: f64,
}

/// The tool travelling at one constant feed along the surface (along the arc on a curved
/// part) from `start_mm` to `stop_mm`: equal dwell per unit length, with no cells.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FeedDto {
    /// Where the pass starts: the pad centre's radial position, mm (0 to the tool's reach).
    pub start_mm: f64,
    /// Where it ends, mm (above `start_mm`, at most the tool's reach).
    pub stop_mm: f64,
    /// The feed along the surface, mm/min (> 0).
    pub feed_mm_per_min: f64,
}

impl From<&ConstantFeed> for FeedDto {
    fn from(feed: &ConstantFeed) -> Self {
        FeedDto {
            start_mm: feed.start_mm(),
            stop_mm: feed.stop_mm(),
            feed_mm_per_min: feed.feed_mm_per_min(),
        }
    }
}

/// An equal-dwell plan: one constant feed over the path (ready for `/v1/predict`'s `feed`).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct EqualDwellDto {
    /// Mean depth it removes over the clear aperture, nm.
    pub depth_nm: f64,
    /// The pass: from 0 to min(outer + r_t, reach) mm at one feed.
    pub feed: FeedDto,
    /// Travel time, s.
    pub total_time_s: f64,
}

impl From<&EqualDwell> for EqualDwellDto {
    fn from(pass: &EqualDwell) -> Self {
        EqualDwellDto {
            depth_nm: pass.metrics.mean_nm,
            feed: FeedDto::from(&pass.pass),
            total_time_s: pass.total_time_s,
        }
    }
}

impl From<&Recommendation> for RecommendationDto {
    fn from(r: &Recommendation) -> Self {
        RecommendationDto {
            workpiece_rpm: r.workpiece_rpm,
            tool_rpm: r.tool_rpm,
            eta: -1.0,
            rule: match r.rule {
                SpeedRule::MatchRemovalRate => SpeedRuleDto::MatchRemovalRate,
                SpeedRule::FastestAllowed => SpeedRuleDto::FastestAllowed,
            },
            eta_window: r.eta_window.map(|w| EtaWindowDto {
                low: w.low,
                high: w.high,
                nonuniformity_threshold: w.threshold,
            }),
            metrics: MetricsDto::from(&r.recommended.metrics),
            current_metrics: MetricsDto::from(&r.current.metrics),
            improvement_factor: r.improvement_factor,
            nonuniformity_removed: r.nonuniformity_removed,
            equal_dwell: EqualDwellDto::from(&r.recommended),
            current_feed_mm_per_min: r.current.feed_mm_per_min(),
        }
    }
}
