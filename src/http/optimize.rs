//! `POST /v1/optimize`: dwell times at candidate positions whose removal matches a target
//! (a uniform depth or a measured profile) over the clear aperture, within the constraints.

use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::Response;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::dto::{
    check_operator_size, ApertureEcho, ClearApertureDto, DwellDto, MetricsDto, ProcessDto,
    RadialGridDto,
};
use super::error::{ApiError, ComputeProblems};
use super::extract::ApiJson;
use super::limits::Limits;
use super::metrics;
use super::plot::{Chart, Series};
use super::recommend::{for_response, RecommendationDto};
use super::{compute_and_render, csv, plot, AppState, Renderers};
use crate::optimize::problem::{DEFAULT_SMOOTHING, DEFAULT_TIME_WEIGHT, MAX_DEPTH_NM};
use crate::optimize::target::aperture_rows;
use crate::optimize::{
    optimize, resample_profile, Constraints, DwellProblem, Formulation, Motion, Objective,
    OptimizeError, Solution, SolveStatus,
};
use crate::physics::{check_positions, RemovalKernel, RemovalOperator, UniformityMetrics};

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct OptimizeRequest {
    /// The polishing process (radii in mm, signed speeds in r/min, CCW positive).
    pub process: ProcessDto,
    /// Candidate tool-centre positions, mm, strictly increasing, within the tool's reach
    /// (0 to r_m + r_t under uniform pressure, 0 to r_m under constant force); at most the
    /// server's max_optimize_positions (2001 by default).
    pub positions_mm: Vec<f64>,
    /// What to remove over the clear aperture.
    pub target: TargetDto,
    /// Limits the plan must keep; all optional.
    pub constraints: Option<ConstraintsDto>,
    /// Weights of the objective's smoothing and time terms; defaults documented there.
    pub objective: Option<ObjectiveDto>,
    /// Where removal is computed and the target is matched; default 201 samples from 0 to the
    /// workpiece radius.
    pub radial_grid: Option<RadialGridDto>,
    /// Where the target applies and uniformity is judged (an annulus is allowed); default the
    /// whole workpiece.
    pub clear_aperture: Option<ClearApertureDto>,
    /// Solver settings.
    pub solver: Option<SolverOptionsDto>,
}

/// The target: exactly one of `uniform_depth_nm` and `profile`.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TargetDto {
    /// Remove this uniform depth over the clear aperture, nm (finite, ≥ 0).
    #[schema(example = 100.0)]
    pub uniform_depth_nm: Option<f64>,
    /// Remove a measured radial error profile (figure correction).
    pub profile: Option<MeasuredProfileDto>,
    /// With `profile`: also remove the least uniform layer p ≥ 0 (nm) that lets the plan fit
    /// best, since polishing can only remove material. Default false.
    #[schema(default = false)]
    pub free_piston: Option<bool>,
}

/// A measured radial profile of the material to remove, linearly interpolated onto the radial
/// grid. It must cover the clear aperture's samples.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MeasuredProfileDto {
    /// Radii of the measurement, mm, strictly increasing (at least 2).
    pub radius_mm: Vec<f64>,
    /// Depth to remove at each radius, nm (the surface's height above the wanted figure).
    pub depth_nm: Vec<f64>,
}

/// Limits on the plan. The tool crosses the segment between neighbouring positions in half of
/// each end's dwell, so its feed there is Δr / ((t_j + t_{j+1})/2).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ConstraintsDto {
    /// Least dwell at every position, s (≥ 0). Default 0.
    #[schema(default = 0.0)]
    pub min_dwell_s: Option<f64>,
    /// Most dwell at any position, s (> 0). Default none.
    pub max_dwell_s: Option<f64>,
    /// Most total dwell time, s (> 0). Default none.
    pub max_total_time_s: Option<f64>,
    /// Highest radial feed on any segment, mm/min (> 0): t_j + t_{j+1} ≥ 2·60·Δr_j / max feed.
    /// Default none.
    pub max_feed_mm_per_min: Option<f64>,
    /// Largest change of dwell between neighbouring positions, s (≥ 0): the linear surrogate
    /// for the feed axis's acceleration limit. On positions spaced h mm apart with a feed limit
    /// v (mm/s), a dwell change δ keeps the feed acceleration at or below δ·v³/h² mm/s², so
    /// choose δ = a_max·h²/v³ for an acceleration limit a_max. Default none.
    pub max_dwell_change_s: Option<f64>,
}

/// Weights of the objective J = fit + smoothing + time (see the crate docs of
/// `preston::optimize`): the fit is the mean squared (removal − target) over the aperture,
/// relative to the target's RMS depth; smoothing is the mean squared curvature of the dwell
/// over one pad radius; time is the total time relative to equal dwell.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ObjectiveDto {
    /// λ, dimensionless (≥ 0). Damps dwell that oscillates from one position to the next.
    /// Default 1e-6.
    #[schema(default = 1e-6)]
    pub smoothing: Option<f64>,
    /// μ, dimensionless (≥ 0). Prefers the quicker of plans that fit about equally well; it
    /// biases the mean depth low by about μ (relative). Default 2e-6.
    #[schema(default = 2e-6)]
    pub time_weight: Option<f64>,
}

/// Solver settings.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SolverOptionsDto {
    /// Wall-clock budget for the solver, s (> 0). Default and maximum: the server's solver
    /// time limit (10 s by default).
    pub time_limit_s: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct OptimizeResponse {
    /// Speed ratio η = −workpiece_rpm / tool_rpm (paper convention); null when tool_rpm = 0.
    pub eta: Option<f64>,
    /// The optimized plan: positions (mm) and dwell at each (s).
    pub dwell: DwellDto,
    /// Mean radial feed on each segment between neighbouring positions, mm/min (one fewer
    /// than positions); null where both ends have zero dwell (the axis would jump).
    pub feed_mm_per_min: Vec<Option<f64>>,
    /// Sum of the dwell times, s.
    pub total_time_s: f64,
    /// Feed and acceleration figures of the plan.
    pub motion: MotionDto,
    /// The radial grid, mm.
    pub radius_mm: Vec<f64>,
    /// Predicted removal depth at each radius of `radius_mm`, nm.
    pub removal_nm: Vec<f64>,
    /// The target at each radius (including the piston), nm; null outside the clear aperture.
    pub target_nm: Vec<Option<f64>>,
    /// removal − target at each radius, nm; null outside the clear aperture.
    pub residual_nm: Vec<Option<f64>>,
    /// Figures of the residual over the clear aperture.
    pub residual: ResidualDto,
    /// Uniformity of the predicted removal over the clear aperture.
    pub metrics: MetricsDto,
    /// The clear aperture used (defaults filled in), mm.
    pub clear_aperture: ApertureEcho,
    /// The free piston chosen, nm; null unless the target asked for one.
    pub piston_nm: Option<f64>,
    /// The objective weights used (defaults filled in) and J at the plan.
    pub objective: ObjectiveEcho,
    /// How the solver fared.
    pub solver: SolverDto,
    /// η = −1 settings and what they would buy (equal dwell removing the target's mean depth);
    /// null at η = −1.
    pub recommendation: Option<RecommendationDto>,
}

/// Feed figures of the plan (see `feed_mm_per_min`).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct MotionDto {
    /// Highest segment feed, mm/min; null if some segment is crossed in no time or there is
    /// only one position.
    pub peak_feed_mm_per_min: Option<f64>,
    /// Largest feed change per unit time between consecutive segments, mm/s² (the feed axis's
    /// acceleration); null if some segment is crossed in no time.
    pub peak_feed_acceleration_mm_per_s2: Option<f64>,
}

/// Peak-to-valley and RMS of removal − target over the clear aperture.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct ResidualDto {
    /// max − min of the residual, nm.
    pub pv_nm: f64,
    /// √(mean of residual²), nm (not about the mean: an offset counts).
    pub rms_nm: f64,
}

/// The objective's weights as used, and its value.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct ObjectiveEcho {
    /// λ used, dimensionless.
    pub smoothing: f64,
    /// μ used, dimensionless.
    pub time_weight: f64,
    /// J at the returned plan, dimensionless.
    pub value: f64,
}

/// The solver's account. Responses differ from run to run only in `solve_time_ms`.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct SolverDto {
    /// `solved`, or `almost_solved` when the solver met only its reduced tolerances (the plan
    /// still keeps every constraint to 1e-9 relative).
    pub status: String,
    /// True for `almost_solved`.
    pub reduced_accuracy: bool,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Solver wall-clock time, ms.
    pub solve_time_ms: f64,
}

/// The core's error, with its field placed in the request.
fn api_error(err: OptimizeError, prefix: &str, limit_s: f64) -> ApiError {
    let detail = err.to_string();
    match err {
        OptimizeError::Invalid { field, .. } => ApiError::invalid(format!("{prefix}{field}"), detail),
        OptimizeError::Infeasible { fields, .. } => ApiError::Infeasible {
            fields: if fields.is_empty() {
                vec!["constraints".to_string()]
            } else {
                fields.iter().map(|f| format!("constraints.{f}")).collect()
            },
            detail,
        },
        OptimizeError::TimeLimit { .. } => ApiError::SolverFailed {
            kind: "solver-time-limit",
            field: Some("solver.time_limit_s".into()),
            detail: format!(
                "{detail}; use fewer positions or radial samples, or a longer time limit (at most {limit_s} s here)"
            ),
        },
        OptimizeError::IterationLimit { .. } => ApiError::SolverFailed {
            kind: "solver-iteration-limit",
            field: None,
            detail,
        },
        OptimizeError::Numerical { .. } => ApiError::SolverFailed {
            kind: "solver-numerical-error",
            field: None,
            detail,
        },
    }
}

/// Solver outcome and time in the service metrics.
fn record_solver(result: &Result<Solution, OptimizeError>) {
    let m = metrics::metrics();
    let status = match result {
        Ok(s) => {
            m.solver_seconds.observe(s.solve_time_s);
            match s.status {
                SolveStatus::Solved => "solved",
                SolveStatus::AlmostSolved => "almost_solved",
            }
        }
        Err(OptimizeError::Infeasible { .. }) => "infeasible",
        Err(OptimizeError::TimeLimit { .. }) => "time_limit",
        Err(OptimizeError::IterationLimit { .. }) => "iteration_limit",
        Err(OptimizeError::Numerical { .. }) => "numerical_error",
        Err(OptimizeError::Invalid { .. }) => return,
    };
    m.solver_status.with_label_values(&[status]).inc();
}

fn constraints(dto: Option<&ConstraintsDto>) -> Result<Constraints, ApiError> {
    let dto = dto.cloned().unwrap_or_default();
    let c = Constraints {
        min_dwell_s: dto.min_dwell_s.unwrap_or(0.0),
        max_dwell_s: dto.max_dwell_s,
        max_total_time_s: dto.max_total_time_s,
        max_feed_mm_per_min: dto.max_feed_mm_per_min,
        max_dwell_change_s: dto.max_dwell_change_s,
    };
    c.validate()
        .map_err(|e| api_error(e, "constraints.", 0.0))?;
    Ok(c)
}

fn objective(dto: Option<&ObjectiveDto>) -> Result<Objective, ApiError> {
    let dto = dto.cloned().unwrap_or_default();
    let o = Objective {
        smoothing: dto.smoothing.unwrap_or(DEFAULT_SMOOTHING),
        time_weight: dto.time_weight.unwrap_or(DEFAULT_TIME_WEIGHT),
    };
    o.validate().map_err(|e| api_error(e, "objective.", 0.0))?;
    Ok(o)
}

fn time_limit_s(dto: Option<&SolverOptionsDto>, limits: &Limits) -> Result<f64, ApiError> {
    let max = limits.solver_time_limit.as_secs_f64();
    match dto.and_then(|s| s.time_limit_s) {
        None => Ok(max),
        Some(t) if t.is_finite() && t > 0.0 && t <= max => Ok(t),
        Some(_) => Err(ApiError::invalid(
            "solver.time_limit_s",
            format!("solver.time_limit_s must be > 0 and at most this server's limit of {max} s"),
        )),
    }
}

/// The target on the aperture rows, and whether a piston is free.
fn target_on(target: &TargetDto, aperture_radii: &[f64]) -> Result<(Vec<f64>, bool), ApiError> {
    match (&target.uniform_depth_nm, &target.profile) {
        (Some(depth), None) => {
            if !(0.0..=MAX_DEPTH_NM).contains(depth) {
                return Err(ApiError::invalid(
                    "target.uniform_depth_nm",
                    format!("target.uniform_depth_nm must be a number in [0, {MAX_DEPTH_NM}] nm"),
                ));
            }
            if target.free_piston == Some(true) {
                return Err(ApiError::invalid(
                    "target.free_piston",
                    "free_piston applies to a profile target; a uniform depth has no free layer",
                ));
            }
            Ok((vec![*depth; aperture_radii.len()], false))
        }
        (None, Some(profile)) => {
            let values = resample_profile(&profile.radius_mm, &profile.depth_nm, aperture_radii)
                .map_err(|e| api_error(e, "target.profile.", 0.0))?;
            Ok((values, target.free_piston.unwrap_or(false)))
        }
        _ => Err(ApiError::invalid(
            "target",
            "give exactly one of target.uniform_depth_nm and target.profile",
        )),
    }
}

pub fn compute(req: &OptimizeRequest, limits: &Limits) -> Result<OptimizeResponse, ApiError> {
    let process = req.process.to_process()?;
    let grid = RadialGridDto::to_grid(req.radial_grid.as_ref(), &process, limits)?;
    let aperture = ClearApertureDto::to_aperture(req.clear_aperture.as_ref(), &process, &grid)?;
    let positions = &req.positions_mm;
    if positions.len() > limits.max_optimize_positions {
        return Err(ApiError::limit(
            "positions_mm",
            format!(
                "positions_mm has {} entries; this server optimizes at most {}",
                positions.len(),
                limits.max_optimize_positions
            ),
        ));
    }
    check_operator_size(
        limits,
        grid.radii_mm().len(),
        positions.len(),
        "positions_mm",
    )?;
    check_positions(&process, "positions_mm", positions, true)
        .map_err(|e| ApiError::from_schedule("", e))?;
    let constraints = constraints(req.constraints.as_ref())?;
    let objective = objective(req.objective.as_ref())?;
    let time_limit_s = time_limit_s(req.solver.as_ref(), limits)?;
    let rows = aperture_rows(&grid, &aperture);
    let (target_nm, free_piston) = target_on(&req.target, &grid.radii_mm()[rows.clone()])?;

    let operator =
        RemovalOperator::assemble(&RemovalKernel::new(&process), grid.radii_mm(), positions);
    let solution = optimize(&DwellProblem {
        operator: &operator,
        positions_mm: positions,
        tool_radius_mm: process.tool_radius_mm(),
        rows: rows.clone(),
        target_nm: &target_nm,
        free_piston,
        constraints,
        objective,
        time_limit_s,
        formulation: Formulation::default(),
    });
    record_solver(&solution);
    let solution = solution.map_err(|e| api_error(e, "", time_limit_s))?;

    let removal_nm = operator.apply(&solution.dwell_s);
    let piston = solution.piston_nm.unwrap_or(0.0);
    let mut full_target = vec![None; removal_nm.len()];
    let mut residual = vec![None; removal_nm.len()];
    for (k, i) in rows.clone().enumerate() {
        let t = target_nm[k] + piston;
        full_target[i] = Some(t);
        residual[i] = Some(removal_nm[i] - t);
    }
    let inside: Vec<f64> = residual.iter().flatten().copied().collect();
    let (lo, hi) = inside
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let rms = (inside.iter().map(|v| v * v).sum::<f64>() / inside.len() as f64).sqrt();
    let motion = Motion::of_plan(positions, &solution.dwell_s);
    let metrics = UniformityMetrics::over(&grid, &aperture, &removal_nm);
    let mean_target = target_nm.iter().sum::<f64>() / target_nm.len() as f64 + piston;
    Ok(OptimizeResponse {
        recommendation: for_response(&process, &grid, &aperture, mean_target),
        eta: process.eta().value(),
        total_time_s: solution.dwell_s.iter().sum(),
        dwell: DwellDto {
            positions_mm: positions.clone(),
            dwell_s: solution.dwell_s.clone(),
        },
        feed_mm_per_min: motion.segment_feed_mm_per_min,
        motion: MotionDto {
            peak_feed_mm_per_min: motion.peak_feed_mm_per_min,
            peak_feed_acceleration_mm_per_s2: motion.peak_acceleration_mm_per_s2,
        },
        radius_mm: grid.radii_mm().to_vec(),
        removal_nm,
        target_nm: full_target,
        residual_nm: residual,
        residual: ResidualDto {
            pv_nm: hi - lo,
            rms_nm: rms,
        },
        metrics: MetricsDto::from(&metrics),
        clear_aperture: ApertureEcho::from(&aperture),
        piston_nm: solution.piston_nm,
        objective: ObjectiveEcho {
            smoothing: objective.smoothing,
            time_weight: objective.time_weight,
            value: solution.objective,
        },
        solver: SolverDto {
            status: match solution.status {
                SolveStatus::Solved => "solved",
                SolveStatus::AlmostSolved => "almost_solved",
            }
            .to_string(),
            reduced_accuracy: solution.status == SolveStatus::AlmostSolved,
            iterations: solution.iterations,
            solve_time_ms: solution.solve_time_s * 1e3,
        },
    })
}

fn to_csv(response: &OptimizeResponse) -> String {
    csv::table(
        &["position_mm".to_string(), "dwell_s".to_string()],
        &[&response.dwell.positions_mm, &response.dwell.dwell_s],
    )
}

fn to_svg(r: &OptimizeResponse) -> String {
    let positions = &r.dwell.positions_mm;
    let midpoints = positions.windows(2).map(|w| 0.5 * (w[0] + w[1]));
    plot::render(&Chart {
        title: format!(
            "Optimized dwell, {:.0} s total ({})",
            r.total_time_s, r.solver.status
        ),
        x_label: "tool position r1 (mm)".to_string(),
        y_label: "dwell (s)".to_string(),
        series: vec![Series {
            name: "dwell at each position".to_string(),
            points: positions
                .iter()
                .copied()
                .zip(r.dwell.dwell_s.iter().copied())
                .collect(),
        }],
        band: Some(plot::aperture_band(&r.clear_aperture)),
        secondary: Some((
            "feed (mm/min)".to_string(),
            Series {
                name: "feed on each segment".to_string(),
                points: midpoints
                    .zip(&r.feed_mm_per_min)
                    .map(|(x, v)| (x, v.unwrap_or(f64::NAN)))
                    .collect(),
            },
        )),
    })
}

/// Optimize a dwell plan.
///
/// Finds dwell times at the candidate positions whose predicted removal matches the target
/// (a uniform depth, or a measured profile with an optional free piston) over the clear
/// aperture in the least-squares sense, with a light smoothing and time preference, within
/// the constraints. Conflicting constraints give a 422 `infeasible` problem listing them in
/// `conflicts`; a solver that stops without a plan gives a 422 `solver-*` problem. Every
/// returned plan keeps its constraints to 1e-9 relative. `Accept: text/csv` returns the plan
/// (position and dwell columns).
#[utoipa::path(
    post,
    path = "/v1/optimize",
    tag = "optimize",
    request_body = OptimizeRequest,
    responses(
        (status = 200, description = "The optimized plan; as CSV, position and dwell columns; as SVG, dwell and feed against position", content(
            (OptimizeResponse = "application/json"),
            (String = "text/csv"),
            (String = "image/svg+xml"),
        )),
        ComputeProblems,
    )
)]
pub async fn handler(
    State(state): State<AppState>,
    headers: HeaderMap,
    ApiJson(req): ApiJson<OptimizeRequest>,
) -> Result<Response, ApiError> {
    let renderers = Renderers {
        csv: Some(to_csv),
        svg: Some(to_svg),
    };
    compute_and_render(state, &headers, req, compute, renderers).await
}
