//! `POST /v1/calibration`: the process's removal rate (and pad radius, moment share) fitted to
//! what ring tests or production runs removed.

mod csv_query;

use csv_query::CalibrationCsvQuery;

use serde::{Deserialize, Serialize};
use utoipa::openapi::path::Operation;
use utoipa::{IntoParams, ToSchema};

use super::csv_body::{self, CsvOrJson};
use super::dto::{ClearApertureDto, DwellDto, ProcessDto, SurfaceDto, ToolDto, WarningDto};
use super::endpoint::{Doc, Endpoint};
use super::error::ApiError;
use super::extract::{object, optional_object};
use super::measurement_fit::RobustDto;
use super::state::Services;
use crate::calibration::{Measured, ProcessParameter, RunSpec, TrialSpec};
use crate::field::DepthProfile;
use crate::report::results;
use crate::usecases::calibration::{
    calibrate, CalibrationCommand, CalibrationResult, CalibrationSpec, ParameterSelection,
};
use crate::usecases::ComputeLimits;

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CalibrationRequest {
    /// The nominal process: its K, r_t and κ are the fit's starting values (and the values
    /// held for what is not fitted); everything else is as the runs ran.
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// The part's surface; default a plane.
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// The pad's spin axis (`tool.orientation`); only the orientation matters here.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool: Option<ToolDto>,
    /// The runs: 1 to 64, each what ran (`ring` or `dwell`) and what it removed (`removal`,
    /// or `before` and `after`). Measured points over all runs: at most 100,000.
    #[schema(min_items = 1, max_items = 64)]
    pub runs: Vec<RunDto>,
    /// What to fit; default the Preston coefficient alone.
    #[serde(default, deserialize_with = "optional_object")]
    pub fit: Option<CalibrationFitDto>,
    /// Robust reweighting against outlying points: `none` (default), `huber` or `tukey`.
    pub robust: Option<RobustDto>,
    /// The measurements' noise per point, nm (> 0). A run whose residual RMS exceeds 3× it is
    /// flagged. Default: each run's point-to-point noise (1.4826·median|Δ²e|/√6 over the
    /// residual's second differences), which assumes uncorrelated noise; give this for
    /// smoothed profiles.
    #[schema(exclusive_minimum = 0.0)]
    pub expected_noise_nm: Option<f64>,
}

/// One run: what ran and what it removed.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RunDto {
    /// A ring test: the tool parked at one position while the part turns. Give `ring` or
    /// `dwell`.
    #[serde(default, deserialize_with = "optional_object")]
    pub ring: Option<RingDto>,
    /// A dwell run (e.g. a plan from `/v1/optimize`), executed with the one motion model.
    #[serde(default, deserialize_with = "optional_object")]
    pub dwell: Option<DwellDto>,
    /// Material removed (nm, positive), measured at radii. Give `removal`, or `before` and
    /// `after`.
    #[serde(default, deserialize_with = "optional_object")]
    pub removal: Option<RadialProfileDto>,
    /// The form error before the run, as `/v1/measurement/fit` reports it in `profile`
    /// (material to remove, nm). Removal = before − after, on the before's radii within the
    /// after's span (the after interpolated linearly).
    #[serde(default, deserialize_with = "optional_object")]
    pub before: Option<RadialProfileDto>,
    /// The form error after the run.
    #[serde(default, deserialize_with = "optional_object")]
    pub after: Option<RadialProfileDto>,
    /// Only the measured points within it count; default all.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<ClearApertureDto>,
}

/// The tool parked at `position_mm` for `duration_s`.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RingDto {
    /// Tool-centre radius, mm (within the process's reach).
    #[schema(example = 30.0)]
    pub position_mm: f64,
    /// How long the tool stayed, s (> 0, at most 1e9).
    #[schema(example = 600.0, exclusive_minimum = 0.0, maximum = 1e9)]
    pub duration_s: f64,
}

/// A radial profile: radii (mm, strictly increasing, on the part) and depths (nm).
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RadialProfileDto {
    /// Radii, mm (strictly increasing, within the part).
    #[schema(min_items = 1)]
    pub radius_mm: Vec<f64>,
    /// Depth at each radius, nm.
    #[schema(min_items = 1)]
    pub depth_nm: Vec<f64>,
}

/// What to fit. Each run always gets its own piston (the measurement's zero).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFitDto {
    /// The Preston coefficient K (default true).
    pub preston_coefficient: Option<bool>,
    /// The pad radius r_t (default false).
    pub tool_radius: Option<bool>,
    /// The pad's moment share κ (default false; needs `pressure_model: linear` and a run
    /// whose pad overhangs the edge).
    pub pad_moment_share: Option<bool>,
    /// Each run's own r² term, for a measurement's power error (default false).
    pub metrology_power: Option<bool>,
}

/// A fitted parameter. Without a standard error (null) the runs carry no information on it
/// and it holds its nominal value, or the fit is exact and carries no estimate of the noise
/// (see `warnings`: `parameter_undetermined`, `exact_fit`).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct EstimateDto {
    /// The fitted value (in the parameter's unit).
    pub value: f64,
    /// √ of its variance, σ²·(JᵀWJ)⁻¹, σ² the residual variance over n − p; null when no
    /// run depends on it, or when the fit is exact (residual below 1e-6 nm RMS: σ̂ = 0 is no
    /// measurement's noise, so no standard error is claimed, never 0).
    #[schema(required = true)]
    pub standard_error: Option<f64>,
    /// value ± t(0.975, n − p)·standard_error.
    #[schema(required = true)]
    pub interval_95: Option<[f64; 2]>,
}

/// The fitted parameters (those asked for).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct ParametersDto {
    /// K, m²/N.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preston_coefficient_m2_per_n: Option<EstimateDto>,
    /// r_t, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tool_radius_mm: Option<EstimateDto>,
    /// κ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pad_moment_share: Option<EstimateDto>,
}

/// Correlations of the fitted parameters that have a standard error.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct CorrelationDto {
    /// Their names, in the matrix's order.
    pub parameters: Vec<String>,
    /// matrix[i][j] = cov(i, j)/(σ_i·σ_j), in [−1, 1].
    pub matrix: Vec<Vec<f64>>,
}

/// One run after the fit.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RunFitDto {
    /// The run's fitted piston (its measurement's zero), nm: along the axis for before/after
    /// profiles (along the normal it is this × cos θ), else as the removal is given.
    pub piston_nm: f64,
    /// The run's r² term, nm/mm² (with `fit.metrology_power`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub power_nm_per_mm2: Option<f64>,
    /// RMS of measured − predicted, nm.
    pub residual_rms_nm: f64,
    /// The radii used (within the run's clear aperture), mm.
    pub radius_mm: Vec<f64>,
    /// The measured removal there, nm.
    pub measured_nm: Vec<f64>,
    /// The calibrated process's removal plus the run's piston (and power), nm.
    pub predicted_nm: Vec<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct CalibrationResponse {
    /// Each parameter asked for in `fit`.
    pub parameters: ParametersDto,
    /// How the fitted parameters' errors go together.
    pub correlation: CorrelationDto,
    /// Fitted K / nominal K.
    pub removal_rate_ratio: f64,
    /// The calibrated process, accepted as is by every endpoint.
    pub process: ProcessDto,
    /// One per run, in request order.
    pub runs: Vec<RunFitDto>,
    /// Measured points less fitted parameters.
    pub degrees_of_freedom: usize,
    /// Parameters the runs cannot determine, runs the model does not explain.
    pub warnings: Vec<WarningDto>,
}

/// `POST /v1/calibration`.
pub struct CalibrationEndpoint;

fn profile(dto: RadialProfileDto) -> DepthProfile {
    DepthProfile {
        radius_mm: dto.radius_mm,
        depth_nm: dto.depth_nm,
    }
}

/// A run as the core takes it; exactly one motion and one measurement.
fn run_spec(index: usize, run: RunDto) -> Result<RunSpec, ApiError> {
    let at = |member: &str| format!("runs[{index}].{member}");
    let trial = match (run.ring, run.dwell) {
        (Some(ring), None) => TrialSpec::Ring {
            position_mm: ring.position_mm,
            duration_s: ring.duration_s,
        },
        (None, Some(dwell)) => TrialSpec::Dwell {
            positions_mm: dwell.positions_mm,
            dwell_s: dwell.dwell_s,
        },
        _ => {
            return Err(ApiError::invalid(
                at("ring"),
                "give exactly one of ring and dwell",
            ))
        }
    };
    let measured = match (run.removal, run.before, run.after) {
        (Some(removal), None, None) => Measured::Removal(profile(removal)),
        (None, Some(before), Some(after)) => Measured::BeforeAfter {
            before: profile(before),
            after: profile(after),
        },
        _ => {
            return Err(ApiError::invalid(
                at("removal"),
                "give removal, or before and after (not both)",
            ))
        }
    };
    Ok(RunSpec {
        trial,
        measured,
        aperture: run.clear_aperture.map(|a| {
            (
                a.inner_mm.unwrap_or(0.0),
                a.outer_mm.unwrap_or(f64::INFINITY),
            )
        }),
    })
}

impl Endpoint for CalibrationEndpoint {
    const NAME: &'static str = "calibration";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/calibration_rings.json");
    const DOC: Doc = Doc {
        operation_id: "calibrate",
        tag: "calibration",
        summary: "Fit the removal rate (and pad radius, moment share) to measured removal.",
        description: "Each run is what ran (a ring test or a dwell schedule) and what it removed (a removal\n\
profile, or the form error before and after). K, and if asked r_t and κ, are fitted by\n\
nonlinear least squares with a free piston per run; standard errors come from the Jacobian\n\
and the residual variance with n − p degrees of freedom. The answer's `process` is the\n\
calibrated process, for every other endpoint. The body may be JSON, or ring tests as `text/csv`\n\
(`position_mm,duration_s,radius_mm,depth_nm` columns: one run per distinct position and\n\
duration) with the other fields as query parameters. `Accept: text/csv` gives one row per\n\
measured point (run, radius, measured, predicted), `Accept: image/svg+xml` a chart.",
        ok: "The fitted parameters, per-run fits and the calibrated process; as CSV the points, as SVG a chart",
    };
    type Request = CalibrationRequest;
    type Body = CsvOrJson<CalibrationRequest>;
    type Command = CalibrationCommand;
    type Output = CalibrationResult;
    type Response = CalibrationResponse;
    const CSV: Option<fn(&CalibrationResult) -> String> = Some(results::calibration_csv);
    const SVG: Option<fn(&CalibrationResult) -> String> = Some(results::calibration_svg);

    /// The body may also be the profilometer's `text/csv`, with the other fields in the query.
    fn document(operation: &mut Operation) {
        let example = "position_mm,duration_s,radius_mm,depth_nm\n15,1200,14.0,61.2\n\
                       15,1200,15.0,63.0\n30,900,30.0,48.7\n";
        csv_body::document(
            operation,
            example,
            CalibrationCsvQuery::into_params(|| None),
        );
    }

    fn parse(req: CalibrationRequest, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let process = req.process.spec()?;
        let part = super::dto::part_spec(req.surface.as_ref(), req.tool.as_ref());
        let runs = req
            .runs
            .into_iter()
            .enumerate()
            .map(|(i, run)| run_spec(i, run))
            .collect::<Result<Vec<_>, _>>()?;
        let fit = req.fit.unwrap_or_default();
        let spec = CalibrationSpec {
            process,
            part,
            runs,
            fit: ParameterSelection {
                preston_coefficient: fit.preston_coefficient,
                tool_radius: fit.tool_radius,
                pad_moment_share: fit.pad_moment_share,
                metrology_power: fit.metrology_power,
            },
            robust: req.robust.map(RobustDto::loss),
            expected_noise_nm: req.expected_noise_nm,
        };
        Ok(CalibrationCommand::new(spec, limits)?)
    }

    fn run(command: Self::Command, _: &Services) -> Result<CalibrationResult, ApiError> {
        Ok(calibrate(command)?)
    }

    fn respond(result: CalibrationResult) -> CalibrationResponse {
        let c = &result.calibrated;
        let estimate = |q: ProcessParameter| {
            c.estimates
                .iter()
                .find(|e| e.parameter == q)
                .map(|e| EstimateDto {
                    value: e.value,
                    standard_error: e.standard_error(),
                    interval_95: e.uncertainty.map(|u| [u.interval_95.0, u.interval_95.1]),
                })
        };
        CalibrationResponse {
            parameters: ParametersDto {
                preston_coefficient_m2_per_n: estimate(ProcessParameter::PrestonCoefficient),
                tool_radius_mm: estimate(ProcessParameter::ToolRadius),
                pad_moment_share: estimate(ProcessParameter::PadMomentShare),
            },
            correlation: CorrelationDto {
                parameters: c.correlated.iter().map(|q| q.name().to_string()).collect(),
                matrix: c.correlation.clone(),
            },
            removal_rate_ratio: c.removal_rate_ratio,
            process: ProcessDto::from_spec(c.process.spec()),
            runs: c
                .runs
                .iter()
                .map(|r| RunFitDto {
                    piston_nm: r.piston_nm,
                    power_nm_per_mm2: r.power_nm_per_mm2,
                    residual_rms_nm: r.residual_rms_nm,
                    radius_mm: r.radius_mm.clone(),
                    measured_nm: r.measured_nm.clone(),
                    predicted_nm: r.predicted_nm.clone(),
                })
                .collect(),
            degrees_of_freedom: c.degrees_of_freedom,
            warnings: result
                .warnings
                .iter()
                .map(|w| WarningDto::new(w, "runs"))
                .collect(),
        }
    }
}
