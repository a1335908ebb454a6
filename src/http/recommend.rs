//! `POST /v1/recommend`: η = −1 speeds for the user's process, what they buy under equal dwell,
//! and the η window around −1. The same `recommendation` object rides along in predict and
//! optimize responses whenever η ≠ −1 (see [`for_response`]).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::Response;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::dto::{ClearApertureDto, MetricsDto, ProcessDto, RadialGridDto};
use super::error::{ApiError, ComputeProblems};
use super::extract::ApiJson;
use super::limits::Limits;
use super::{compute_and_render, AppState, Renderers};
use crate::optimize::problem::MAX_DEPTH_NM;
use crate::physics::{ClearAperture, Process, RadialGrid};
use crate::study::{recommend, EqualDwell, Frame, Recommendation, SpeedLimits, SpeedRule};

/// Default η-window threshold on equal-dwell nonuniformity (2 %).
pub const DEFAULT_THRESHOLD: f64 = 0.02;
/// Default number of positions (cells) of the equal-dwell pass.
pub const DEFAULT_EQUAL_DWELL_POSITIONS: usize = 200;
/// Default depth of the equal-dwell plan, nm.
pub const DEFAULT_DEPTH_NM: f64 = 100.0;

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RecommendRequest {
    /// The user's current process (radii in mm, signed speeds in r/min, CCW positive).
    pub process: ProcessDto,
    /// The machine's speed limits; default none.
    pub limits: Option<SpeedLimitsDto>,
    /// Mean depth the equal-dwell plans remove over the clear aperture, nm (> 0). Default 100.
    #[schema(default = 100.0)]
    pub depth_nm: Option<f64>,
    /// Largest equal-dwell nonuniformity (pv/mean, a fraction) inside the η window, > 0.
    /// Default 0.02.
    #[schema(default = 0.02)]
    pub nonuniformity_threshold: Option<f64>,
    /// Positions of the equal-dwell pass: a constant feed from 0 to min(outer + r_t, reach) mm
    /// as this many evenly spaced cell centres (≥ 2, at most the server's max_positions).
    /// Default 200.
    #[schema(default = 200, minimum = 2)]
    pub equal_dwell_positions: Option<usize>,
    /// Where removal is computed; default 201 samples from 0 to the workpiece radius.
    pub radial_grid: Option<RadialGridDto>,
    /// Where uniformity is judged; default the whole workpiece.
    pub clear_aperture: Option<ClearApertureDto>,
}

/// Speed limits of the machine, r/min, as magnitudes (> 0).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SpeedLimitsDto {
    /// Fastest the workpiece spindle may turn, r/min (either direction).
    pub max_workpiece_rpm: Option<f64>,
    /// Fastest the tool may spin, r/min (either direction).
    pub max_tool_rpm: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RecommendResponse {
    /// The recommendation.
    pub recommendation: RecommendationDto,
}

/// η = −1 settings: workpiece and tool turning the same way (same sign) at the same speed,
/// where equal dwell removes a uniform layer. All comparisons use equal dwell (one constant
/// feed over [0, min(outer + r_t, reach)] mm) removing the same mean depth.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RecommendationDto {
    /// Recommended workpiece speed, r/min, signed (lab frame, CCW positive); equals tool_rpm.
    pub workpiece_rpm: f64,
    /// Recommended tool speed, r/min, signed; keeps the current tool direction.
    pub tool_rpm: f64,
    /// −1.
    pub eta: f64,
    /// `match_removal_rate`: the speed keeps the current mean removal rate over the clear
    /// aperture; `fastest_allowed`: the limits forbid that, so the fastest allowed speed.
    pub rule: String,
    /// The interval of η around −1 (tool speed held) where equal-dwell nonuniformity stays at
    /// or below the threshold; null when even η = −1 is above it.
    pub eta_window: Option<EtaWindowDto>,
    /// Predicted uniformity of equal dwell at the recommended speeds, nm.
    pub metrics: MetricsDto,
    /// Predicted uniformity of equal dwell at the current speeds, nm.
    pub current_metrics: MetricsDto,
    /// Current nonuniformity / recommended nonuniformity; null when undefined.
    pub improvement_factor: Option<f64>,
    /// The equal-dwell plan at the recommended speeds.
    pub equal_dwell: EqualDwellDto,
    /// The constant feed equal dwell needs at the current speeds for the same depth, mm/min.
    pub current_feed_mm_per_min: f64,
}

/// η bounds (paper convention, η = −workpiece_rpm / tool_rpm); null where no bound was found.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct EtaWindowDto {
    /// Lower η bound (below −1); null if none down to η = −51.
    pub low: Option<f64>,
    /// Upper η bound (above −1, below 0); null if none up to η = −1e-6.
    pub high: Option<f64>,
    /// The nonuniformity threshold the bounds meet (a fraction).
    pub nonuniformity_threshold: f64,
}

/// An equal-dwell plan: one constant feed, the same dwell at every cell centre.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct EqualDwellDto {
    /// Mean depth it removes over the clear aperture, nm.
    pub depth_nm: f64,
    /// The radial feed, mm/min.
    pub feed_mm_per_min: f64,
    /// Cell-centre positions, mm.
    pub positions_mm: Vec<f64>,
    /// Dwell at each position, s (all equal).
    pub dwell_s: Vec<f64>,
    /// Total time, s.
    pub total_time_s: f64,
}

impl From<&EqualDwell> for EqualDwellDto {
    fn from(pass: &EqualDwell) -> Self {
        EqualDwellDto {
            depth_nm: pass.metrics.mean_nm,
            feed_mm_per_min: pass.feed_mm_per_min,
            positions_mm: pass.schedule.positions_mm().to_vec(),
            dwell_s: pass.schedule.dwell_s().to_vec(),
            total_time_s: pass.schedule.total_time_s(),
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
                SpeedRule::MatchRemovalRate => "match_removal_rate",
                SpeedRule::FastestAllowed => "fastest_allowed",
            }
            .to_string(),
            eta_window: r.eta_window.map(|w| EtaWindowDto {
                low: w.low,
                high: w.high,
                nonuniformity_threshold: w.threshold,
            }),
            metrics: MetricsDto::from(&r.recommended.metrics),
            current_metrics: MetricsDto::from(&r.current.metrics),
            improvement_factor: r.improvement_factor,
            equal_dwell: EqualDwellDto::from(&r.recommended),
            current_feed_mm_per_min: r.current.feed_mm_per_min,
        }
    }
}

/// Recommendations already computed, keyed by every input but the depth (plans scale with
/// it). Bounded: emptied when it reaches [`CACHE_CAPACITY`] entries. The η window takes a few
/// dozen equal-dwell evaluations; shops ask about the same process again and again.
const CACHE_CAPACITY: usize = 256;
type CacheKey = Vec<u64>;
static CACHE: OnceLock<Mutex<HashMap<CacheKey, Arc<Recommendation>>>> = OnceLock::new();

fn cache_key(process: &Process, frame: Frame, limits: &SpeedLimits, threshold: f64) -> CacheKey {
    let Frame {
        grid,
        aperture,
        positions,
    } = frame;
    let s = process.spec();
    let model = format!("{:?}", s.pressure_model);
    let mut key: Vec<u64> = [
        s.workpiece_radius_mm,
        s.tool_radius_mm,
        s.workpiece_rpm,
        s.tool_rpm,
        s.preston_coefficient_m2_per_n,
        s.pressure_kpa,
        grid.start_mm(),
        grid.stop_mm(),
        aperture.inner_mm(),
        aperture.outer_mm(),
        limits.max_workpiece_rpm.unwrap_or(-1.0),
        limits.max_tool_rpm.unwrap_or(-1.0),
        threshold,
    ]
    .iter()
    .map(|v| v.to_bits())
    .collect();
    key.extend([grid.radii_mm().len() as u64, positions as u64]);
    key.extend(model.bytes().map(u64::from));
    key
}

/// The recommendation for these inputs at `depth_nm` (> 0), from the cache when possible.
pub fn recommendation(
    process: &Process,
    frame: Frame,
    limits: SpeedLimits,
    depth_nm: f64,
    threshold: f64,
) -> Result<RecommendationDto, ApiError> {
    let key = cache_key(process, frame, &limits, threshold);
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    let cached = cache.lock().ok().and_then(|c| c.get(&key).cloned());
    let unit = match cached {
        Some(r) => r,
        None => {
            let r = Arc::new(
                recommend(process, frame, limits, 1.0, threshold)
                    .map_err(|e| ApiError::invalid(e.field, e.message))?,
            );
            if let Ok(mut c) = cache.lock() {
                if c.len() >= CACHE_CAPACITY {
                    c.clear();
                }
                c.insert(key, r.clone());
            }
            r
        }
    };
    Ok(RecommendationDto::from(&unit.scaled_to(depth_nm)))
}

/// The recommendation a predict or optimize response carries: `None` at η = −1 or when
/// equal dwell removes nothing in the aperture. Uses the default threshold and pass.
pub fn for_response(
    process: &Process,
    grid: &RadialGrid,
    aperture: &ClearAperture,
    depth_nm: f64,
) -> Option<RecommendationDto> {
    if process.is_eta_minus_one() {
        return None;
    }
    let depth = if depth_nm > 0.0 && depth_nm.is_finite() {
        depth_nm
    } else {
        DEFAULT_DEPTH_NM
    };
    let frame = Frame {
        grid,
        aperture,
        positions: DEFAULT_EQUAL_DWELL_POSITIONS,
    };
    recommendation(
        process,
        frame,
        SpeedLimits::default(),
        depth,
        DEFAULT_THRESHOLD,
    )
    .ok()
}

pub fn compute(req: &RecommendRequest, limits: &Limits) -> Result<RecommendResponse, ApiError> {
    let process = req.process.to_process()?;
    let grid = RadialGridDto::to_grid(req.radial_grid.as_ref(), &process, limits)?;
    let aperture = ClearApertureDto::to_aperture(req.clear_aperture.as_ref(), &process, &grid)?;
    let speed_limits = req.limits.clone().unwrap_or_default();
    let speed_limits = SpeedLimits {
        max_workpiece_rpm: speed_limits.max_workpiece_rpm,
        max_tool_rpm: speed_limits.max_tool_rpm,
    };
    speed_limits
        .validate()
        .map_err(|e| ApiError::invalid(format!("limits.{}", e.field), e.message))?;
    let depth = req.depth_nm.unwrap_or(DEFAULT_DEPTH_NM);
    check_depth(depth)?;
    let threshold = req.nonuniformity_threshold.unwrap_or(DEFAULT_THRESHOLD);
    if !threshold.is_finite() || threshold <= 0.0 {
        return Err(ApiError::invalid(
            "nonuniformity_threshold",
            "nonuniformity_threshold must be a finite fraction > 0",
        ));
    }
    let positions = equal_dwell_positions(req.equal_dwell_positions)?;
    super::dto::check_operator_size(
        limits,
        grid.radii_mm().len(),
        positions,
        "equal_dwell_positions",
    )?;
    Ok(RecommendResponse {
        recommendation: recommendation(
            &process,
            Frame {
                grid: &grid,
                aperture: &aperture,
                positions,
            },
            speed_limits,
            depth,
            threshold,
        )?,
    })
}

/// A requested equal-dwell depth: in (0, 1e9] nm.
pub fn check_depth(depth_nm: f64) -> Result<(), ApiError> {
    if depth_nm > 0.0 && depth_nm <= MAX_DEPTH_NM {
        Ok(())
    } else {
        Err(ApiError::invalid(
            "depth_nm",
            format!("depth_nm must be a number in (0, {MAX_DEPTH_NM}] nm"),
        ))
    }
}

/// The requested equal-dwell position count (at least 2). Its upper limit is the operator's,
/// checked with the grid by `check_operator_size`.
pub fn equal_dwell_positions(requested: Option<usize>) -> Result<usize, ApiError> {
    let n = requested.unwrap_or(DEFAULT_EQUAL_DWELL_POSITIONS);
    if n < 2 {
        return Err(ApiError::invalid(
            "equal_dwell_positions",
            "equal_dwell_positions must be at least 2",
        ));
    }
    Ok(n)
}

/// Recommend η = −1 speeds.
///
/// From the user's process (and the machine's speed limits), recommends workpiece and tool
/// turning the same way at the same speed (η = −1), chosen to keep the current mean removal
/// rate over the clear aperture where the limits allow, else the fastest allowed. Compares
/// equal dwell at both settings for the same depth and reports the η window around −1 within
/// which equal-dwell nonuniformity stays at or below the threshold (found by root finding on
/// the model).
#[utoipa::path(
    post,
    path = "/v1/recommend",
    tag = "recommend",
    request_body = RecommendRequest,
    responses(
        (status = 200, description = "The recommendation", body = RecommendResponse),
        ComputeProblems,
    )
)]
pub async fn handler(
    State(state): State<AppState>,
    headers: HeaderMap,
    ApiJson(req): ApiJson<RecommendRequest>,
) -> Result<Response, ApiError> {
    let renderers = Renderers {
        csv: None,
        svg: None,
    };
    compute_and_render(state, &headers, req, compute, renderers).await
}
