//! The X-Y machine's side of the map endpoints (`machine.kinematics: cartesian`): its requests
//! and answers, and the two kinds of request each map endpoint takes, told apart by
//! `machine.kinematics`.

use serde::{Deserialize, Deserializer, Serialize};
use utoipa::ToSchema;

use super::super::error::ApiError;
use super::super::extract::{kind_from_value, object, optional_object};
use super::super::fields::limit_field;
use super::body::{MapGridDto, MapSource};
use super::predict::{MapFiguresDto, RemovalMapDto};
use crate::http::dto::{LinearAxisDto, SpindleLimitDto, WarningDto};
use crate::machine::{AxisLimits, MachineChoice, MachineLimitsSpec};
use crate::maps::HeightMap;
use crate::optimize::problem::DEFAULT_TIME_WEIGHT;
use crate::optimize::raster::{AxisCaps, AxisPeaks, DEFAULT_RASTER_SMOOTHING};
use crate::usecases::program::Provenance;
use crate::usecases::raster::SpotSpec;
use crate::usecases::raster_optimize::{RasterCorrection, RasterOptimizeSpec, SolverReport};
use crate::usecases::raster_predict::{RasterPredictSpec, RasterPrediction};
use crate::usecases::ComputeLimits;

/// Whether a request body is the X-Y machine's: `machine.kinematics` is `"cartesian"`.
pub fn is_cartesian(value: &serde_json::Value) -> bool {
    value
        .get("machine")
        .and_then(|m| m.get("kinematics"))
        .and_then(serde_json::Value::as_str)
        == Some("cartesian")
}

/// The X-Y machine: the part stands still and the tool moves over it in X and Y.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CartesianDto {
    /// X and Y carry the tool over a part that stands still.
    #[default]
    Cartesian,
}

/// An X-Y machine and its axes' limits. Each limit optional: absent, the default machine's
/// (X, Y and Z 10,000 mm/min and 2,000 mm/s², the tool spindle 3,000 r/min, no travel limits).
/// The plan is held to X's and Y's velocity and acceleration; the program
/// (`/v1/maps/program`) to every limit given, travel and Z's included.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CartesianMachineDto {
    /// `cartesian`: this is what makes the request the X-Y machine's.
    pub kinematics: CartesianDto,
    /// X (mm, right on the map).
    #[serde(default, deserialize_with = "optional_object")]
    pub x: Option<LinearAxisDto>,
    /// Y (mm, up on the map).
    #[serde(default, deserialize_with = "optional_object")]
    pub y: Option<LinearAxisDto>,
    /// Z (mm, up from the part): it moves only to approach and retract in a program.
    #[serde(default, deserialize_with = "optional_object")]
    pub z: Option<LinearAxisDto>,
    /// The tool spindle's speed limit (a program with `tool_rpm`).
    #[serde(default, deserialize_with = "optional_object")]
    pub tool_spindle: Option<SpindleLimitDto>,
}

impl CartesianMachineDto {
    /// X's and Y's velocity and acceleration limits, the default machine's where not given.
    fn caps(&self) -> [AxisCaps; 2] {
        let spec = self.choice().spec();
        [spec.x, spec.y].map(|axis| AxisCaps {
            max_velocity_mm_per_min: axis.max_velocity_per_min,
            max_acceleration_mm_per_s2: axis.max_acceleration_per_s2,
        })
    }

    /// The machine as the program checks it.
    pub fn choice(&self) -> MachineChoice {
        let linear = |a: &Option<LinearAxisDto>| a.as_ref().map(AxisLimits::from);
        MachineChoice::Given(MachineLimitsSpec {
            x: linear(&self.x).unwrap_or_default(),
            y: linear(&self.y).unwrap_or_default(),
            z: linear(&self.z).unwrap_or_default(),
            tool_max_rpm: self.tool_spindle.as_ref().and_then(|s| s.max_rpm),
            ..MachineLimitsSpec::default()
        })
    }

    /// The limits, each checked positive (a problem naming `machine.x.…`).
    /// X's and Y's velocity and acceleration limits, every limit given checked first (a
    /// problem naming `machine.<axis>.<limit>`).
    pub(super) fn checked_caps(&self) -> Result<[AxisCaps; 2], ApiError> {
        self.choice()
            .limits()
            .map_err(|e| ApiError::invalid(limit_field(e.drive, e.limit), e.to_string()))?;
        Ok(self.caps())
    }
}

/// The tool's influence function, from a spot test: the tool stood still for `duration_s`
/// seconds and the map of what it removed (nm, material removed positive; null where not
/// measured, taken as no removal). Without `duration_s` the map is the removal rate, nm/s.
/// Between pixels the rate is bilinear; beyond the map, one pixel's fall to zero.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct InfluenceDto {
    /// The spot's removal (or rate): rows of values, top row first, with its `pixel_mm`.
    #[serde(deserialize_with = "object")]
    pub map: MapGridDto,
    /// The spot's dwell, s (> 0); absent: the map is a rate in nm/s.
    #[schema(exclusive_minimum = 0.0)]
    pub duration_s: Option<f64>,
    /// The tool's centre on the spot map: [column, row] (fractions allowed, row 0 the top);
    /// default the removal-weighted centroid of its positive pixels.
    #[schema(min_items = 2, max_items = 2)]
    pub centre_px: Option<Vec<f64>>,
}

impl InfluenceDto {
    fn spot(self, limits: &ComputeLimits) -> Result<SpotSpec, ApiError> {
        let centre_px = match self.centre_px {
            None => None,
            Some(c) if c.len() == 2 => Some([c[0], c[1]]),
            Some(c) => {
                return Err(ApiError::invalid(
                    "influence.centre_px",
                    format!("give [column, row]: two numbers, not {}", c.len()),
                ))
            }
        };
        let map = HeightMap::from_rows(
            self.map.heights_nm,
            self.map.pixel_mm,
            None,
            limits.max_map_pixels,
        )
        .map_err(|e| ApiError::invalid("influence.map", e.to_string()))?;
        Ok(SpotSpec {
            map,
            pixel_mm: None,
            duration_s: self.duration_s,
            centre_px,
        })
    }
}

/// A raster plan: the tool's centre visits the points in the order given, standing at the
/// first and the last for half their dwell and crossing each point's cell (between the
/// midpoints to its neighbours) at constant speed in its dwell.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RasterDwellDto {
    /// The points, [x, y] mm in the map's frame (mm from its centre, x right, y up), in path
    /// order, on a square lattice of the request's `pixel_mm`.
    #[schema(min_items = 1)]
    pub points_mm: Vec<Vec<f64>>,
    /// Each point's dwell, s (≥ 0).
    pub dwell_s: Vec<f64>,
}

/// `POST /v1/maps/predict` on an X-Y machine.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RasterPredictRequest {
    /// The X-Y machine (`kinematics: cartesian`) and its axes' limits.
    #[serde(deserialize_with = "object")]
    pub machine: CartesianMachineDto,
    /// The tool's influence function, from a spot test.
    #[serde(deserialize_with = "object")]
    pub influence: InfluenceDto,
    /// The plan: points in path order and their dwell.
    #[serde(deserialize_with = "object")]
    pub dwell: RasterDwellDto,
    /// The map the plan corrects (heights, nm), for the residual; optional.
    #[serde(default, deserialize_with = "optional_object")]
    pub map: Option<MapGridDto>,
    /// The lattice's pixel, mm (> 0); default the map's, else the influence map's.
    #[schema(exclusive_minimum = 0.0)]
    pub pixel_mm: Option<f64>,
}

/// The dwell bounds of a raster plan, all optional.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RasterConstraintsDto {
    /// Least dwell at every point, s (≥ 0; default 0, the axes' floors still apply).
    #[schema(minimum = 0.0)]
    pub min_dwell_s: Option<f64>,
    /// Most dwell at any point, s (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_dwell_s: Option<f64>,
    /// The plan's total dwell, s (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_total_time_s: Option<f64>,
}

/// Weights of a raster plan's objective.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RasterObjectiveDto {
    /// λ (0 to 1e6): the weight of the mean squared difference between neighbouring points'
    /// dwell, relative to the dwell scale; default 1e-4.
    #[schema(minimum = 0.0, maximum = 1e6)]
    pub smoothing: Option<f64>,
    /// μ (0 to 1e6): the weight of the total dwell; default 2e-6.
    #[schema(minimum = 0.0, maximum = 1e6)]
    pub time_weight: Option<f64>,
}

/// `POST /v1/maps/optimize` on an X-Y machine.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RasterOptimizeRequest {
    /// The X-Y machine (`kinematics: cartesian`) and its axes' limits.
    #[serde(deserialize_with = "object")]
    pub machine: CartesianMachineDto,
    /// The tool's influence function, from a spot test.
    #[serde(deserialize_with = "object")]
    pub influence: InfluenceDto,
    /// The measured error: heights (nm, the surface above its design), rows top first, null
    /// where there is no data. Its pixels with data are the clear aperture.
    #[serde(default)]
    #[schema(required = true)]
    pub map: MapSource,
    /// The map's pixel, mm (> 0); default the map's own.
    #[schema(exclusive_minimum = 0.0)]
    pub pixel_mm: Option<f64>,
    /// The dwell points' pitch, mm (> 0), rounded to whole pixels; default half the radius
    /// within which the tool removes at least half its peak rate.
    #[schema(exclusive_minimum = 0.0)]
    pub dwell_pitch_mm: Option<f64>,
    /// Whether the plan may leave a tilt, as it may a piston; default false.
    pub free_tilt: Option<bool>,
    /// Dwell bounds and the total time; all optional.
    #[serde(default, deserialize_with = "optional_object")]
    pub constraints: Option<RasterConstraintsDto>,
    /// The objective's smoothing and time weights; all optional.
    #[serde(default, deserialize_with = "optional_object")]
    pub objective: Option<RasterObjectiveDto>,
}

/// One axis's peaks over the executed motion (the program's acceleration model).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct AxisPeaksDto {
    /// Largest |velocity|, mm/min.
    pub velocity_mm_per_min: f64,
    /// Largest |acceleration|, mm/s².
    pub acceleration_mm_per_s2: f64,
}

impl From<AxisPeaks> for AxisPeaksDto {
    fn from(p: AxisPeaks) -> Self {
        AxisPeaksDto {
            velocity_mm_per_min: p.velocity_mm_per_min,
            acceleration_mm_per_s2: p.acceleration_mm_per_s2,
        }
    }
}

/// X's and Y's peaks.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct XyPeaksDto {
    /// X's.
    pub x: AxisPeaksDto,
    /// Y's.
    pub y: AxisPeaksDto,
}

fn xy(peaks: [AxisPeaks; 2]) -> XyPeaksDto {
    XyPeaksDto {
        x: peaks[0].into(),
        y: peaks[1].into(),
    }
}

/// The removal of a raster plan.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RasterPredictResponse {
    /// The machine's kinematics the prediction is for: `cartesian`.
    pub kinematics: CartesianDto,
    /// The removal map: the map's frame with a map, else the lattice around the points.
    pub removal: RemovalMapDto,
    /// The removal's figures over the map's pixels with data (every pixel without a map).
    pub metrics: MapFiguresDto,
    /// With a map: removal − map on its pixels, less the best piston and tilt, nm.
    #[schema(required = true)]
    pub residual_nm: Option<Vec<Vec<Option<f64>>>>,
    /// With a map: its figures, piston and tilt removed.
    #[schema(required = true)]
    pub before: Option<MapFiguresDto>,
    /// With a map: the residual's figures, piston and tilt removed.
    #[schema(required = true)]
    pub after: Option<MapFiguresDto>,
    /// The plan's total dwell, s.
    pub total_time_s: f64,
    /// Constant-velocity blocks of the executed motion.
    pub blocks: usize,
    /// X's and Y's peaks.
    pub axes: XyPeaksDto,
}

/// The solver's account of a raster plan.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RasterSolverDto {
    /// Whether the optimality residual reached its tolerance (1e-6 of the largest dwell).
    pub converged: bool,
    /// The most any dwell would still move in one diagonally scaled projected-gradient step,
    /// s: 0 exactly at the optimum.
    pub kkt_residual_s: f64,
    /// Projected Newton steps.
    pub newton_iterations: usize,
    /// Conjugate-gradient steps over all of them.
    pub cg_iterations: usize,
    /// Products with the removal operator (each with its transpose as well).
    pub products: usize,
    /// Distinct cell shapes of the raster (each one kernel).
    pub shapes: usize,
    /// Of those, the ones summed by FFT (the others column by column).
    pub fft_shapes: usize,
}

impl From<&SolverReport> for RasterSolverDto {
    fn from(s: &SolverReport) -> Self {
        RasterSolverDto {
            converged: s.converged,
            kkt_residual_s: s.kkt_residual_s,
            newton_iterations: s.newton_iterations,
            cg_iterations: s.cg_iterations,
            products: s.products,
            shapes: s.shapes,
            fft_shapes: s.fft_shapes,
        }
    }
}

/// The maps of a raster plan on the map's pixels (x right, y up, mm from its centre).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RasterMapsDto {
    /// The map's pixel, mm.
    pub pixel_mm: f64,
    /// The columns' x, mm, left to right.
    pub x_mm: Vec<f64>,
    /// The rows' y, mm, top (largest) first.
    pub y_mm: Vec<f64>,
    /// The exact removal of the executed motion, nm.
    pub removal_nm: Vec<Vec<f64>>,
    /// The map plus the plan's piston (and tilt), nm; null without data.
    pub target_nm: Vec<Vec<Option<f64>>>,
    /// removal − target, nm; null without data.
    pub residual_nm: Vec<Vec<Option<f64>>>,
}

/// A raster plan's figures, piston and tilt removed, over the map's pixels with data.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RasterMetricsDto {
    /// The map, piston and tilt removed.
    pub before: MapFiguresDto,
    /// The residual, piston and tilt removed.
    pub after: MapFiguresDto,
}

/// A measured map's correction on an X-Y machine.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RasterOptimizeResponse {
    /// The machine's kinematics the plan is for: `cartesian`.
    pub kinematics: CartesianDto,
    /// The plan in path order (a serpentine, row by row from the top): send it to
    /// `/v1/maps/predict` or `/v1/maps/program` as it is.
    pub dwell: RasterDwellDto,
    /// The points' pitch, mm (whole pixels).
    pub dwell_pitch_mm: f64,
    /// Removal, target and residual on the map's pixels.
    pub maps: RasterMapsDto,
    /// Figures before and after.
    pub metrics: RasterMetricsDto,
    /// The uniform layer removed beside the map, nm.
    pub piston_nm: f64,
    /// The tilt removed beside it, [x, y] nm/mm; null unless `free_tilt`.
    #[schema(required = true)]
    pub tilt_nm_per_mm: Option<Vec<f64>>,
    /// The plan's total dwell, s.
    pub total_time_s: f64,
    /// Constant-velocity blocks of the executed motion.
    pub blocks: usize,
    /// X's and Y's peaks.
    pub axes: XyPeaksDto,
    /// How the solver got there.
    pub solver: RasterSolverDto,
    /// A solver stopped at its work limit; empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
}

impl RasterPredictRequest {
    pub fn spec(self, limits: &ComputeLimits) -> Result<RasterPredictSpec, ApiError> {
        self.machine.checked_caps()?;
        let points_mm = points(self.dwell.points_mm)?;
        let map = self
            .map
            .map(|m| {
                HeightMap::from_rows(
                    m.heights_nm,
                    m.pixel_mm,
                    m.wavelength_nm,
                    limits.max_map_pixels,
                )
                .map_err(|e| ApiError::invalid("map", e.to_string()))
            })
            .transpose()?;
        Ok(RasterPredictSpec {
            spot: self.influence.spot(limits)?,
            points_mm,
            dwell_s: self.dwell.dwell_s,
            pixel_mm: self.pixel_mm,
            map,
        })
    }
}

pub(super) fn points(raw: Vec<Vec<f64>>) -> Result<Vec<[f64; 2]>, ApiError> {
    raw.into_iter()
        .enumerate()
        .map(|(k, p)| match p.as_slice() {
            [x, y] if x.is_finite() && y.is_finite() => Ok([*x, *y]),
            _ => Err(ApiError::invalid(
                format!("dwell.points_mm[{k}]"),
                "a point is [x, y], two finite numbers of mm",
            )),
        })
        .collect()
}

impl RasterOptimizeRequest {
    pub fn spec(self, limits: &ComputeLimits) -> Result<RasterOptimizeSpec, ApiError> {
        let axes = self.machine.checked_caps()?;
        let (map, _) = self.map.read("map", limits.max_map_pixels)?;
        let constraints = self.constraints.unwrap_or_default();
        let objective = self.objective.unwrap_or_default();
        for (name, v) in [
            ("smoothing", objective.smoothing),
            ("time_weight", objective.time_weight),
        ] {
            if let Some(v) = v.filter(|v| !(v.is_finite() && (0.0..=1e6).contains(v))) {
                return Err(ApiError::invalid(
                    format!("objective.{name}"),
                    format!("must be a number in [0, 1e6], not {v}"),
                ));
            }
        }
        Ok(RasterOptimizeSpec {
            spot: self.influence.spot(limits)?,
            map,
            pixel_mm: self.pixel_mm,
            dwell_pitch_mm: self.dwell_pitch_mm,
            tilt_free: self.free_tilt.unwrap_or(false),
            min_dwell_s: constraints.min_dwell_s,
            max_dwell_s: constraints.max_dwell_s,
            max_total_time_s: constraints.max_total_time_s,
            axes,
            smoothing: objective.smoothing.unwrap_or(DEFAULT_RASTER_SMOOTHING),
            time_weight: objective.time_weight.unwrap_or(DEFAULT_TIME_WEIGHT),
            time_limit_s: limits.solver_time_limit.as_secs_f64(),
        })
    }
}

fn rows<T: Clone>(values: &[T], width: usize) -> Vec<Vec<T>> {
    values.chunks(width.max(1)).map(<[T]>::to_vec).collect()
}

impl From<RasterPrediction> for RasterPredictResponse {
    fn from(r: RasterPrediction) -> Self {
        let width = r.x_mm.len();
        RasterPredictResponse {
            kinematics: CartesianDto::Cartesian,
            metrics: (&r.removal).into(),
            residual_nm: r.residual_nm.as_deref().map(|v| rows(v, width)),
            before: r.before.as_ref().map(Into::into),
            after: r.after.as_ref().map(Into::into),
            total_time_s: r.total_time_s,
            blocks: r.blocks,
            axes: xy(r.peaks),
            removal: RemovalMapDto {
                pixel_mm: r.pixel_mm,
                removal_nm: rows(&r.removal_nm, width)
                    .into_iter()
                    .map(|row| row.into_iter().map(Some).collect())
                    .collect(),
                x_mm: r.x_mm,
                y_mm: r.y_mm,
            },
        }
    }
}

impl From<RasterCorrection> for RasterOptimizeResponse {
    fn from(r: RasterCorrection) -> Self {
        let width = r.x_mm.len();
        RasterOptimizeResponse {
            kinematics: CartesianDto::Cartesian,
            dwell: RasterDwellDto {
                points_mm: r.points_mm.iter().map(|p| p.to_vec()).collect(),
                dwell_s: r.dwell_s,
            },
            dwell_pitch_mm: r.dwell_pitch_mm,
            maps: RasterMapsDto {
                pixel_mm: r.pixel_mm,
                removal_nm: rows(&r.removal_nm, width),
                target_nm: rows(&r.target_nm, width),
                residual_nm: rows(&r.residual_nm, width),
                x_mm: r.x_mm,
                y_mm: r.y_mm,
            },
            metrics: RasterMetricsDto {
                before: (&r.before).into(),
                after: (&r.after).into(),
            },
            piston_nm: r.piston_nm,
            tilt_nm_per_mm: r.tilt_nm_per_mm.map(|t| t.to_vec()),
            total_time_s: r.total_time_s,
            blocks: r.blocks,
            axes: xy(r.peaks),
            solver: (&r.solver).into(),
            warnings: WarningDto::all(&r.warnings),
        }
    }
}

/// A request of either machine: the paper's (`polar`, the default) or an X-Y one.
#[derive(Debug, Clone)]
pub enum Kinds<P, C> {
    Polar(P),
    Cartesian(C),
}

impl<'de, P: serde::de::DeserializeOwned, C: serde::de::DeserializeOwned> Deserialize<'de>
    for Kinds<P, C>
{
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let value = serde_json::Value::deserialize(d)?;
        if is_cartesian(&value) {
            kind_from_value(value).map(Kinds::Cartesian)
        } else {
            kind_from_value(value).map(Kinds::Polar)
        }
    }
}

impl<P: Provenance, C: Provenance> Provenance for Kinds<P, C> {
    fn with_provenance(self, line: String) -> Self {
        match self {
            Kinds::Polar(p) => Kinds::Polar(p.with_provenance(line)),
            Kinds::Cartesian(c) => Kinds::Cartesian(c.with_provenance(line)),
        }
    }
}

/// An answer of either machine.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum Answer<P, C> {
    Polar(P),
    Cartesian(C),
}
