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
use super::maps::body::MapSource;
use super::maps::difference::OffsetDto;
use super::maps::predict::CLawDto;
use super::maps::{MapAlignmentDto, MapApertureDto};
use super::measurement_fit::RobustDto;
use super::state::Services;
use crate::calibration::spatial::{bounds, Bounds};
use crate::calibration::{MapRunFit, Measured, ProcessParameter, TrialSpec};
use crate::field::DepthProfile;
use crate::report::results;
use crate::usecases::calibration::{
    calibrate, CalibrationCommand, CalibrationResult, CalibrationSpec, MapMeasurement,
    MeasuredInput, ParameterSelection, PolarTrial, RunInput, TrialInput,
};
use crate::usecases::map_difference::MapDifferenceSpec;
use crate::usecases::ComputeLimits;

#[derive(Debug, Clone, Deserialize, ToSchema)]
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
    /// The runs: 1 to 64, each what ran (`ring`, `dwell` or `polar`) and what it removed
    /// (`removal`, or `before` and `after` profiles; or `map`). Profile points over all runs:
    /// at most 100,000; map pixels: at most 200,000.
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
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RunDto {
    /// A ring test: the tool parked at one position while the part turns. Give `ring` or
    /// `dwell`.
    #[serde(default, deserialize_with = "optional_object")]
    pub ring: Option<RingDto>,
    /// A dwell run (e.g. a plan from `/v1/optimize`), executed with the one motion model.
    #[serde(default, deserialize_with = "optional_object")]
    pub dwell: Option<DwellDto>,
    /// A polar plan on the paper's machine (e.g. from `/v1/maps/optimize`): the dwell plan and
    /// C's speed law, as `/v1/maps/predict` takes them. Under a law the removal varies with
    /// the angle: measure such a run with a `map`.
    #[serde(default, deserialize_with = "optional_object")]
    pub polar: Option<PolarRunDto>,
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
    /// What the run removed, measured by an interferometer: the removal as a map, or the
    /// maps before and after. Each pixel is predicted from the motion executed (the exact
    /// removal `/v1/maps/predict` gives), with the run's own piston and tilt; the residual's
    /// correlation from pixel to pixel enters the standard errors.
    #[serde(default, deserialize_with = "optional_object")]
    pub map: Option<MapRunDto>,
    /// Only the measured points (or pixels) within this annulus about the axis count; default
    /// all.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<ClearApertureDto>,
}

/// A polar plan, as `/v1/maps/predict` takes it.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PolarRunDto {
    /// The dwell plan: stations of the pad centre and the dwell in each one's cell.
    #[serde(deserialize_with = "object")]
    pub dwell: DwellDto,
    /// C's speed law; default C at the process's constant speed.
    #[serde(default, deserialize_with = "optional_object")]
    pub c_law: Option<CLawDto>,
    /// The pad centre's angle in the part's frame when the plan starts, degrees; default 0.
    pub start_angle_deg: Option<f64>,
}

/// A run's maps: `removal`, or `before` and `after` (heights, nm), placed on the part as
/// `/v1/maps/difference` places them.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapRunDto {
    /// The material removed, nm (> 0 removed).
    #[serde(default)]
    pub removal: MapSource,
    /// The surface before the run: heights, nm.
    #[serde(default)]
    pub before: MapSource,
    /// The surface after the run: heights, nm. Removal = before − after.
    #[serde(default)]
    pub after: MapSource,
    /// Pixel pitch, mm (> 0); default the maps' own `pixel_mm`.
    pub pixel_mm: Option<f64>,
    /// Where the part sits on the (before) map, in the C frame the plan's angles refer to;
    /// default fitted to the map's boundary, no rotation.
    #[serde(default, deserialize_with = "optional_object")]
    pub alignment: Option<MapAlignmentDto>,
    /// The after map's centre relative to the before map's; default each fitted to its own
    /// boundary.
    #[serde(default, deserialize_with = "optional_object")]
    pub after_offset_px: Option<OffsetDto>,
    /// The pixels fitted; default a circle of the part's radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<MapApertureDto>,
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
    /// A run measured by a map: its tilt, its residual and its correlation (`radius_mm`,
    /// `measured_nm` and `predicted_nm` then list the pixels' radii and values, row by row).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub map: Option<MapRunFitDto>,
}

/// What a map run adds to its fit.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct MapRunFitDto {
    /// Pixels fitted.
    pub pixels: usize,
    /// The run's fitted tilt along x of the part's frame, nm per mm.
    pub tilt_x_nm_per_mm: f64,
    /// The run's fitted tilt along y, nm per mm.
    pub tilt_y_nm_per_mm: f64,
    /// How far the residual correlates, as the standard errors count it: the flat-top
    /// kernel's bandwidth, pixels.
    pub correlation_bandwidth_px: usize,
    /// The first fitted parameter's variance from this run over what it would be were the
    /// pixels independent (≥ 1: the variance is never taken below that).
    pub variance_inflation: f64,
    /// The residual, measured − model (nm), on the fitted pixels' bounding box of the (before)
    /// map: rows from `residual_origin_px`'s, null where no pixel was fitted.
    pub residual_nm: Vec<Vec<Option<f64>>>,
    /// The bounding box's first column and row on the map, pixels.
    pub residual_origin_px: [i64; 2],
}

impl From<&MapRunFit> for MapRunFitDto {
    fn from(fit: &MapRunFit) -> Self {
        let Bounds {
            column0,
            row0,
            columns,
            rows,
        } = bounds(&fit.pixels);
        let mut residual_nm = vec![vec![None; columns]; rows];
        for (p, e) in fit.pixels.iter().zip(&fit.residual_nm) {
            residual_nm[(p.row - row0) as usize][(p.column - column0) as usize] = Some(*e);
        }
        MapRunFitDto {
            pixels: fit.pixels.len(),
            tilt_x_nm_per_mm: fit.tilt_nm_per_mm.0,
            tilt_y_nm_per_mm: fit.tilt_nm_per_mm.1,
            correlation_bandwidth_px: fit.bandwidth_px,
            variance_inflation: fit.variance_inflation,
            residual_nm,
            residual_origin_px: [column0, row0],
        }
    }
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

/// A run as the use case takes it; exactly one motion and one measurement.
fn run_input(index: usize, run: RunDto, limits: &ComputeLimits) -> Result<RunInput, ApiError> {
    let at = |member: &str| format!("runs[{index}].{member}");
    let trial = match (run.ring, run.dwell, run.polar) {
        (Some(ring), None, None) => TrialInput::Given(TrialSpec::Ring {
            position_mm: ring.position_mm,
            duration_s: ring.duration_s,
        }),
        (None, Some(dwell), None) => TrialInput::Given(TrialSpec::Dwell {
            positions_mm: dwell.positions_mm,
            dwell_s: dwell.dwell_s,
        }),
        (None, None, Some(polar)) => TrialInput::Polar(PolarTrial {
            positions_mm: polar.dwell.positions_mm,
            dwell_s: polar.dwell.dwell_s,
            c_law: polar.c_law.map(CLawDto::spec),
            start_angle_deg: polar.start_angle_deg,
        }),
        _ => {
            return Err(ApiError::invalid(
                at("ring"),
                "give exactly one of ring, dwell and polar",
            ))
        }
    };
    let measured = match (run.removal, run.before, run.after, run.map) {
        (Some(removal), None, None, None) => {
            MeasuredInput::Given(Measured::Removal(profile(removal)))
        }
        (None, Some(before), Some(after), None) => MeasuredInput::Given(Measured::BeforeAfter {
            before: profile(before),
            after: profile(after),
        }),
        (None, None, None, Some(map)) => MeasuredInput::Map(Box::new(
            map_measurement(map, limits).map_err(|e| e.under(&at("map")))?,
        )),
        _ => {
            return Err(ApiError::invalid(
                at("removal"),
                "give removal, or before and after, or map (one of them)",
            ))
        }
    };
    Ok(RunInput {
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

/// A run's maps (fields relative to its `map`).
fn map_measurement(map: MapRunDto, limits: &ComputeLimits) -> Result<MapMeasurement, ApiError> {
    let placement = map.alignment.unwrap_or_default().placement(map.pixel_mm)?;
    let given = |source: &MapSource| !matches!(source, MapSource::Missing);
    match (given(&map.removal), given(&map.before), given(&map.after)) {
        (true, false, false) => {
            if map.after_offset_px.is_some() {
                return Err(ApiError::invalid(
                    "after_offset_px",
                    "an after map's offset needs before and after maps, not a removal map",
                ));
            }
            Ok(MapMeasurement::Removal {
                map: map.removal.read("removal", limits.max_map_pixels)?.0,
                placement,
                aperture: map.clear_aperture.map(Into::into),
            })
        }
        (false, true, true) => Ok(MapMeasurement::BeforeAfter {
            before: map.before.read("before", limits.max_map_pixels)?.0,
            after: map.after.read("after", limits.max_map_pixels)?.0,
            difference: MapDifferenceSpec {
                placement,
                after_offset_px: map.after_offset_px.map(|o| (o.x_px, o.y_px)),
                aperture: map.clear_aperture.map(Into::into),
                remove_tilt: None,
                bands: None,
            },
        }),
        _ => Err(ApiError::invalid(
            "removal",
            "give removal, or before and after (not both)",
        )),
    }
}

impl CalibrationRequest {
    /// The request with map files (as an instrument wrote them, any format `/v1/maps/analysis`
    /// reads) as its first run's `map.before` and `map.after` (a cycle measured by maps, as the
    /// records compose it).
    pub fn with_map_files(mut self, files: &[(&str, &[u8])]) -> Result<Self, ApiError> {
        let map = self
            .runs
            .first_mut()
            .and_then(|run| run.map.as_mut())
            .ok_or_else(|| ApiError::invalid("runs[0].map", "the map files need a map run"))?;
        for (member, file) in files {
            let source = MapSource::File(axum::body::Bytes::copy_from_slice(file));
            match *member {
                "before" => map.before = source,
                "after" => map.after = source,
                "removal" => map.removal = source,
                other => {
                    return Err(ApiError::internal(format!("no map member `{other}`")));
                }
            }
        }
        Ok(self)
    }
}

impl Endpoint for CalibrationEndpoint {
    const NAME: &'static str = "calibration";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/calibration_rings.json");
    const DOC: Doc = Doc {
        operation_id: "calibrate",
        tag: "calibration",
        summary: "Fit the removal rate (and pad radius, moment share) to measured removal.",
        description: "Each run is what ran (a ring test, a dwell schedule or a polar plan with C's speed law) and\n\
what it removed (a removal profile, the form error before and after, or interferometer maps:\n\
the removal, or the surface before and after). K, and if asked r_t and κ, are fitted by\n\
nonlinear least squares with a free piston per run (and a tilt per map); standard errors\n\
come from the Jacobian and the residual variance with n − p degrees of freedom, and for\n\
maps count the residual's correlation from pixel to pixel. The answer's `process` is the\n\
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
        let part = super::dto::part_spec(req.surface.as_ref(), req.tool.as_ref())?;
        let runs = req
            .runs
            .into_iter()
            .enumerate()
            .map(|(i, run)| run_input(i, run, limits))
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
                    map: r.map.as_ref().map(Into::into),
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
