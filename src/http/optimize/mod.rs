//! `POST /v1/optimize`: dwell times at candidate positions whose removal matches a target
//! (a uniform depth or a measured profile) over the clear aperture, within the constraints.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

mod options;

pub use options::{ConstraintsDto, MeasuredProfileDto, ObjectiveDto, SolverOptionsDto, TargetDto};

use super::dto::{
    setting_of, ApertureEcho, ClearApertureDto, DwellDto, MetricsDto, ProcessDto, RadialGridDto,
    RecommendationDto, SurfaceDto, WarningDto,
};
use super::dto::{AxesDto, MachineChoiceDto, ToolDto};
use super::endpoint::{Doc, Endpoint};
use super::error::{ApiError, Kind};
use super::extract::{object, optional_object, ApiJson};
use super::state::Services;
use crate::optimize::{OptimizeError, SolveStatus};
use crate::report::results;
use crate::usecases::optimize::{optimize, OptimizeCommand, OptimizeSpec, OptimizedPlan};
use crate::usecases::{ComputeLimits, Warning};

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct OptimizeRequest {
    /// The polishing process (radii in mm, signed speeds in r/min, CCW positive).
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// Candidate tool-centre positions, mm, strictly increasing, within the reach
    /// `process.pressure_model` gives; at most the
    /// server's max_optimize_positions (2001 by default). When there are at least twice as many
    /// as knots r_t/8 apart over their span allow, the dwell is solved as a cubic B-spline on
    /// those knots, sampled at the positions (smooth for the feed axis; every constraint still
    /// holds at each position).
    #[schema(min_items = 1)]
    pub positions_mm: Vec<f64>,
    /// What to remove over the clear aperture.
    #[serde(deserialize_with = "object")]
    pub target: TargetDto,
    /// Limits the plan must keep; all optional.
    #[serde(default, deserialize_with = "optional_object")]
    pub constraints: Option<ConstraintsDto>,
    /// Weights of the objective's smoothing and time terms; defaults documented there.
    #[serde(default, deserialize_with = "optional_object")]
    pub objective: Option<ObjectiveDto>,
    /// Where removal is computed and the target is matched; default 201 samples from 0 to the
    /// workpiece radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
    /// Where the target applies and uniformity is judged (an annulus is allowed); default the
    /// whole workpiece.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<ClearApertureDto>,
    /// Solver settings.
    #[serde(default, deserialize_with = "optional_object")]
    pub solver: Option<SolverOptionsDto>,
    /// The machine the plan must run on: every axis velocity and acceleration limit becomes
    /// a constraint on the dwell, so that `/v1/program` with the same surface, tool and
    /// machine accepts the plan. Positions that put an axis outside its travel, or speeds
    /// over a spindle's limit, are refused (422 `machine-limits`). Default: the default
    /// machine; `"unlimited"` keeps no machine limit (a study: the plan warns
    /// `machine_unlimited`).
    #[serde(default)]
    pub machine: Option<MachineChoiceDto>,
    /// The part's surface; default a plane. Positions and the radial grid are radial
    /// coordinates of surface points; removal is along the normal, for a pad that conforms to
    /// the surface. With `machine`, the surface also gives the axes' poses.
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// The tool as the machine carries it; default: pivot at the pad face, B following the
    /// normal. `orientation` is also the pad's spin axis in the removal model.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool: Option<ToolDto>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct OptimizeResponse {
    /// Speed ratio η = −workpiece_rpm / tool_rpm (paper convention); null when tool_rpm = 0.
    #[schema(required = true)]
    pub eta: Option<f64>,
    /// The optimized plan: positions (mm) and dwell at each (s).
    pub dwell: DwellDto,
    /// Arc length along the surface from the vertex to each position of `dwell`, mm; present
    /// only on a curved surface.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_arc_length_mm: Option<Vec<f64>>,
    /// The feed across each position's cell, mm/min, one per position: the X–Z path of the
    /// program's move over its duration (the G94 F word; on a plane with the default tool, the
    /// cell's width over the time the tool spends crossing it). Null where the program has
    /// no move: a zero-dwell end cell (crossed in no time), a single position, or a plan with
    /// no program.
    pub feed_mm_per_min: Vec<Option<f64>>,
    /// Sum of the dwell times, s.
    pub total_time_s: f64,
    /// The plan's motion as `/v1/program` runs it with the same surface, tool and machine,
    /// without the approach and retract (`approach.clearance_mm: 0` there gives the same
    /// figures); null when no program can run the plan (see `warnings`).
    #[schema(required = true)]
    pub motion: Option<MotionDto>,
    /// The radial grid, mm.
    pub radius_mm: Vec<f64>,
    /// Arc length along the surface from the vertex to each radius of `radius_mm`, mm; present
    /// only on a curved surface.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arc_length_mm: Option<Vec<f64>>,
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
    #[schema(required = true)]
    pub piston_nm: Option<f64>,
    /// The objective weights used (defaults filled in) and J at the plan.
    pub objective: ObjectiveEcho,
    /// How the solver fared.
    pub solver: SolverDto,
    /// η = −1 settings and what they would buy (equal dwell removing the target's mean depth);
    /// null at η = −1.
    #[schema(required = true)]
    pub recommendation: Option<RecommendationDto>,
    /// What the caller should know about this plan: constraints it sits on (so they, not the
    /// target, decided it), a missed target, positions that look like metres; empty when
    /// nothing.
    pub warnings: Vec<WarningDto>,
}

/// The plan's motion: the machine program's blocks (see `feed_mm_per_min`).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct MotionDto {
    /// Highest feed of any cell, mm/min (0 for a single position).
    pub peak_feed_mm_per_min: f64,
    /// Each axis's travel, peak velocity and acceleration, and use of the machine's limits,
    /// as `/v1/program` reports them.
    pub axes: AxesDto,
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

/// How the solver finished a plan it returned.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SolverStatusDto {
    /// Converged to full accuracy.
    Solved,
    /// Converged to the solver's reduced tolerances only.
    AlmostSolved,
}

impl SolverStatusDto {
    pub fn as_str(self) -> &'static str {
        match self {
            SolverStatusDto::Solved => "solved",
            SolverStatusDto::AlmostSolved => "almost_solved",
        }
    }
}

/// The solver's account. Responses differ from run to run only in `solve_time_ms`.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct SolverDto {
    /// `solved`, or `almost_solved` when the solver met only its reduced tolerances (the plan
    /// still keeps every constraint to 1e-9 relative).
    pub status: SolverStatusDto,
    /// True for `almost_solved`.
    pub reduced_accuracy: bool,
    /// Interior-point iterations: 0 when no constraint binds (the fit's own minimum keeps
    /// them all and is the plan, solved directly).
    pub iterations: u32,
    /// Solver wall-clock time, ms.
    pub solve_time_ms: f64,
}

/// `POST /v1/optimize`.
pub struct OptimizeEndpoint;

impl Endpoint for OptimizeEndpoint {
    const NAME: &'static str = "optimize";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/optimize_paper_exp1.json");
    const DOC: Doc = Doc {
        operation_id: "optimizeDwell",
        tag: "optimize",
        summary: "Optimize a dwell plan.",
        description: "Finds dwell times at the candidate positions whose predicted removal matches the target\n\
(a uniform depth, or a measured profile with an optional free piston) over the clear\n\
aperture in the least-squares sense, with a light smoothing and time preference, within\n\
the constraints. Conflicting constraints give a 422 `infeasible` problem listing them in\n\
`conflicts`; a solver that stops without a plan gives a 422 `solver-*` problem. Every\n\
returned plan keeps its constraints to 1e-9 relative. Fine positions are solved through a\n\
smooth spline basis (see `positions_mm`), which keeps the solve to milliseconds; the removal\n\
operator of a process, grid and positions is cached for repeated requests. `Accept:\n\
text/csv` returns the plan (position and dwell columns).",
        ok: "The optimized plan; as CSV, position and dwell columns; as SVG, dwell and feed against position",
    };
    type Request = OptimizeRequest;
    type Body = ApiJson<OptimizeRequest>;
    type Command = OptimizeCommand;
    type Output = OptimizedPlan;
    type Response = OptimizeResponse;
    const CSV: Option<fn(&OptimizedPlan) -> String> = Some(results::plan_csv);
    const SVG: Option<fn(&OptimizedPlan) -> String> = Some(results::plan_svg);

    fn parse(req: OptimizeRequest, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let setting = setting_of!(req).parse(limits)?;
        let spec = OptimizeSpec {
            positions_mm: req.positions_mm,
            target: req.target.into(),
            constraints: ConstraintsDto::to_constraints(req.constraints.as_ref()),
            objective: ObjectiveDto::to_objective(req.objective.as_ref()),
            time_limit_s: req.solver.and_then(|s| s.time_limit_s),
            machine: MachineChoiceDto::choice(req.machine.as_ref()),
        };
        Ok(OptimizeCommand::new(setting, spec, limits)?)
    }

    fn run(command: Self::Command, services: &Services) -> Result<OptimizedPlan, ApiError> {
        let max_time_limit_s = command.max_time_limit_s();
        // Lengths in metres can make the solver fail; a pascal pressure or a study machine
        // cannot, so only those are suspects.
        let suspect = command
            .input_warnings()
            .iter()
            .find(|w| {
                matches!(
                    w,
                    Warning::ProcessLooksLikeMetres { .. }
                        | Warning::PositionsLookLikeMetres { .. }
                )
            })
            .map(|w| WarningDto::new(w, "positions_mm"));
        let plan = optimize(command, &services.recommender, &services.operators);
        services
            .metrics
            .record_solver(plan.as_ref().map(|p| &p.solution));
        plan.map_err(|e| {
            let error = match e {
                OptimizeError::TimeLimit { .. } => ApiError::new(
                    Kind::SolverTimeLimit,
                    format!(
                        "{e}; use fewer positions or radial samples, or a longer time limit (at most {max_time_limit_s} s here)"
                    ),
                )
                .at("solver.time_limit_s"),
                other => other.into(),
            };
            with_suspect(error, suspect)
        })
    }

    fn respond(plan: OptimizedPlan) -> OptimizeResponse {
        OptimizeResponse::from(plan)
    }
}

/// A solver that found no plan for input that looks wrong (positions in metres): the problem
/// names that input and says why.
fn with_suspect(error: ApiError, suspect: Option<WarningDto>) -> ApiError {
    match (error, suspect) {
        (mut error, Some(w)) if error.kind.is_solver_failure() => {
            error.detail = format!("{}. Look at the input first: {}", error.detail, w.message);
            error.field = w.field;
            error
        }
        (error, _) => error,
    }
}

impl From<OptimizedPlan> for OptimizeResponse {
    fn from(p: OptimizedPlan) -> Self {
        let s = &p.solution;
        let feed_mm_per_min = p.cell_feeds_mm_per_min();
        OptimizeResponse {
            recommendation: p.recommendation.as_ref().map(RecommendationDto::from),
            warnings: p
                .warnings
                .iter()
                .map(|w| WarningDto::new(w, "positions_mm"))
                .collect(),
            eta: p.setting.process().eta().value(),
            total_time_s: p.total_time_s,
            position_arc_length_mm: p.setting.process().arc_lengths_mm(p.motion.radii_mm()),
            arc_length_mm: p
                .setting
                .process()
                .arc_lengths_mm(p.setting.grid().radii_mm()),
            dwell: DwellDto {
                positions_mm: p.motion.radii_mm().to_vec(),
                dwell_s: s.dwell_s.clone(),
            },
            feed_mm_per_min,
            motion: p.program.as_ref().map(|program| MotionDto {
                peak_feed_mm_per_min: program.peak_feed_mm_per_min(),
                axes: AxesDto::of(program, &p.machine_limits),
            }),
            radius_mm: p.setting.grid().radii_mm().to_vec(),
            removal_nm: p.removal_nm,
            target_nm: p.target_nm,
            residual_nm: p.residual_nm,
            residual: ResidualDto {
                pv_nm: p.residual_pv_nm,
                rms_nm: p.residual_rms_nm,
            },
            metrics: MetricsDto::from(&p.metrics),
            clear_aperture: ApertureEcho::from(p.setting.aperture()),
            piston_nm: s.piston_nm,
            objective: ObjectiveEcho {
                smoothing: p.objective.smoothing,
                time_weight: p.objective.time_weight,
                value: s.objective,
            },
            solver: SolverDto {
                status: match s.status {
                    SolveStatus::Solved => SolverStatusDto::Solved,
                    SolveStatus::AlmostSolved => SolverStatusDto::AlmostSolved,
                },
                reduced_accuracy: s.status == SolveStatus::AlmostSolved,
                iterations: s.iterations,
                solve_time_ms: s.solve_time_s * 1e3,
            },
        }
    }
}
