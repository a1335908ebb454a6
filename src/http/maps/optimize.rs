//! `POST /v1/maps/optimize`: a measured map's correction on the paper's machine — a dwell plan
//! in radius with C's speed modulated per sector, and the exact removal of what it executes.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::dto::{
    part_on_c, ApertureEcho, ClearApertureDto, DwellDto, LinearAxisDto, MachineChoiceDto,
    MachineDto, PolishingPeaksDto, ProcessDto, RadialGridDto, RotaryAxisDto, SegmentsDto,
    SpindleLimitDto, StationServoDto, SurfaceDto, ToolDto, WarningDto,
};
use super::super::endpoint::{Doc, Endpoint};
use super::super::error::ApiError;
use super::super::extract::{object, optional_count, optional_object};
use super::super::optimize::{ConstraintsDto, ObjectiveDto, SolverOptionsDto};
use super::super::state::Services;
use super::body::{self, MapForm, MapGridDto, MapOrJson, MapSource};
use super::predict::{CLawDto, MapFiguresDto};
use super::raster::{Answer, Kinds, RasterOptimizeRequest, RasterOptimizeResponse};
use super::removal_function::KinematicsDto;
use super::MapAlignmentDto;
use crate::http::openapi::any_of;
use crate::machine::{AxisLimits, MachineChoice, MachineLimitsSpec};
use crate::maps::mounted::{mounted, MountedError};
use crate::maps::HeightMap;
use crate::usecases::map_analysis::Placement;
use crate::usecases::map_optimize::{
    map_optimize, MapCorrection, MapOptimizeCommand, MapOptimizeSpec, RemovalModel, SegmentReport,
};
use crate::usecases::optimize::OptimizeSpec;
use crate::usecases::raster_optimize::{raster_optimize, RasterCorrection, RasterOptimizeCommand};
use crate::usecases::ComputeLimits;

/// C under position control: the part's spindle as an axis. Each limit optional (absent:
/// the default machine's, 360,000 deg/min and 3,600 deg/s²).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CAxisDto {
    /// Largest |angular velocity|, deg/min (> 0; above the process's part speed).
    #[schema(exclusive_minimum = 0.0)]
    pub max_velocity_deg_per_min: Option<f64>,
    /// Largest |angular acceleration|, deg/s² (> 0).
    #[schema(exclusive_minimum = 0.0)]
    pub max_acceleration_deg_per_s2: Option<f64>,
}

/// The paper's machine and its limits: X, Z and B as `/v1/optimize` takes them, and C. Each
/// limit optional (absent: the default machine's).
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PolarMachineDto {
    /// How the pad moves over the part; default `polar` (the only one yet).
    #[serde(default)]
    pub kinematics: KinematicsDto,
    /// X, the radial axis (mm).
    #[serde(default, deserialize_with = "optional_object")]
    pub x: Option<LinearAxisDto>,
    /// Z, the axial axis (mm).
    #[serde(default, deserialize_with = "optional_object")]
    pub z: Option<LinearAxisDto>,
    /// B, the tool's tilt (deg).
    #[serde(default, deserialize_with = "optional_object")]
    pub b: Option<RotaryAxisDto>,
    /// C, the part's spindle under position control (deg).
    #[serde(default, deserialize_with = "optional_object")]
    pub c: Option<CAxisDto>,
    /// The workpiece spindle's speed limit.
    #[serde(default, deserialize_with = "optional_object")]
    pub workpiece_spindle: Option<SpindleLimitDto>,
    /// The tool spindle's speed limit.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool_spindle: Option<SpindleLimitDto>,
}

impl PolarMachineDto {
    pub(super) fn choice(&self) -> MachineChoice {
        let axes = MachineDto {
            x: self.x.clone(),
            z: self.z.clone(),
            b: self.b.clone(),
            workpiece_spindle: self.workpiece_spindle.clone(),
            tool_spindle: self.tool_spindle.clone(),
        };
        let mut spec = MachineLimitsSpec::from(&axes);
        spec.c = self
            .c
            .as_ref()
            .map_or(AxisLimits::default(), |c| AxisLimits {
                min: None,
                max: None,
                max_velocity_per_min: c.max_velocity_deg_per_min,
                max_acceleration_per_s2: c.max_acceleration_deg_per_s2,
            });
        MachineChoice::Given(spec)
    }
}

/// How C's law is cut and how far it may go.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CLawOptionsDto {
    /// Sectors per turn (8 to 3,600; a whole number); default 180 (2° each).
    #[schema(minimum = 8, maximum = 3600)]
    #[serde(default, deserialize_with = "optional_count")]
    pub sectors: Option<usize>,
    /// The highest angular harmonic corrected (1 to min(90, sectors/2 − 1)); default what the
    /// pad resolves at the aperture's edge, ⌈π·outer/r_t⌉.
    #[schema(minimum = 1, maximum = 90)]
    #[serde(default, deserialize_with = "optional_count")]
    pub max_harmonic: Option<usize>,
    /// The most the time over a sector may differ from its station's mean, relative (in
    /// (0, 0.9]); default 0.5: C between 2/3 and 2 times the process's speed.
    #[schema(exclusive_minimum = 0.0, maximum = 0.9)]
    pub max_modulation: Option<f64>,
}

#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapOptimizeRequest {
    /// The polishing process (radii in mm, signed speeds in r/min, CCW positive).
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// The part's surface; default a plane (a sphere or an asphere: the pad conforms to it).
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// How the tool is carried: B following the normal (default) or held vertical, and its
    /// pivot (as `/v1/maps/program` takes it). It sets the pad's spin axis in the removal
    /// and, on segments, the program whose peaks the plan reports.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool: Option<ToolDto>,
    /// The measured error: heights (nm, the surface above its design), as `/v1/maps/analysis`
    /// takes them: rows of heights, or the file itself as the body (any format that endpoint
    /// reads) with the other fields as query parameters (objects and lists as JSON). The plan
    /// removes it, less its piston and tilt, plus the least uniform layer that lets C's law
    /// reach it. Required, unless `segment_maps` gives each segment's own.
    #[serde(default)]
    pub map: MapSource,
    /// On `segments`, instead of `map`: each segment's own map, one per segment in the layout's
    /// order, each with its `pixel_mm`, in the segment's frame as it sat on the parent (its
    /// middle pixel the segment's centre, x along the direction away from C and the parent's
    /// vertex, y counter-clockwise from it, rows top first). They are mounted into one map in
    /// C's frame at the finest of their pixels (bilinear interpolation, a pixel missing where
    /// any of its four neighbours is); `alignment` is then that map's own.
    pub segment_maps: Option<Vec<MapGridDto>>,
    /// The map's pixel pitch, mm (> 0); default the map's own `pixel_mm`.
    pub pixel_mm: Option<f64>,
    /// Where the part sits on the map; default fitted to the map's boundary.
    #[serde(default, deserialize_with = "optional_object")]
    pub alignment: Option<MapAlignmentDto>,
    /// Candidate stations of the pad centre, mm, strictly increasing (as `/v1/optimize`).
    #[schema(min_items = 1)]
    pub positions_mm: Vec<f64>,
    /// Limits the mean dwell must keep; all optional (as `/v1/optimize`).
    #[serde(default, deserialize_with = "optional_object")]
    pub constraints: Option<ConstraintsDto>,
    /// Weights of the mean dwell's objective (as `/v1/optimize`).
    #[serde(default, deserialize_with = "optional_object")]
    pub objective: Option<ObjectiveDto>,
    /// The radii the map is sampled and fitted on; default 201 samples from 0 to the
    /// workpiece radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
    /// Where the map is corrected and judged (an annulus about the axis); default the whole
    /// part.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<ClearApertureDto>,
    /// Solver settings of the mean dwell.
    #[serde(default, deserialize_with = "optional_object")]
    pub solver: Option<SolverOptionsDto>,
    /// The machine; default the default machine, polar.
    #[serde(default, deserialize_with = "optional_object")]
    pub machine: Option<PolarMachineDto>,
    /// C's law: sectors, harmonics, modulation; all optional.
    #[serde(default, deserialize_with = "optional_object")]
    pub c_law: Option<CLawOptionsDto>,
    /// The result maps' pixel, mm (> 0); default the part's diameter / 80. Coarsened (with a
    /// warning) when the plan's turns make every pixel of the exact map more work than one
    /// request allows.
    #[schema(example = 1.0)]
    pub removal_pixel_mm: Option<f64>,
    /// How the removal map is computed; default `exact`.
    #[serde(default)]
    pub removal_model: RemovalModelDto,
    /// Off-axis segments mounted on C: the map is then the mounted set in C's frame (leave
    /// `surface` out: the parent is here).
    #[serde(default, deserialize_with = "optional_object")]
    pub segments: Option<SegmentsDto>,
}

/// A correction's request: the paper's machine's or an X-Y machine's.
pub type MapOptimizeAny = Kinds<MapOptimizeRequest, RasterOptimizeRequest>;
any_of!(
    impl MapOptimizeAny as "MapOptimizeAnyRequest",
    [MapOptimizeRequest, RasterOptimizeRequest],
    "A map to correct: on the paper's machine (`machine.kinematics` `polar`, the default) or \
     on an X-Y machine (`machine.kinematics` `cartesian`)."
);

impl MapForm for MapOptimizeAny {
    const FILES: &'static [&'static str] = &["map"];
    /// Both kinds' fields (a file body's query names the machine as JSON; without
    /// `machine.kinematics: cartesian` the request is the paper's machine's).
    const QUERY_FIELDS: &'static [&'static str] = &[
        "process",
        "surface",
        "pixel_mm",
        "alignment",
        "positions_mm",
        "constraints",
        "objective",
        "radial_grid",
        "clear_aperture",
        "solver",
        "machine",
        "c_law",
        "removal_pixel_mm",
        "removal_model",
        "segments",
        "influence",
        "dwell_pitch_mm",
        "free_tilt",
    ];

    fn set_file(&mut self, _: &str, bytes: axum::body::Bytes) {
        match self {
            Kinds::Polar(r) => r.map = MapSource::File(bytes),
            Kinds::Cartesian(r) => r.map = MapSource::File(bytes),
        }
    }
}

/// A correction on either machine.
pub type MapOptimizeAnswer = Answer<MapOptimizeResponse, RasterOptimizeResponse>;
any_of!(
    impl MapOptimizeAnswer as "MapOptimizeAnyResponse",
    [MapOptimizeResponse, RasterOptimizeResponse],
    "A map's correction: a polar plan with C's law, or an X-Y machine's dwell map \
     (`kinematics` says which)."
);

/// How the result's removal map is computed.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RemovalModelDto {
    /// The exact removal of the executed motion at every pixel (the verdict). Its cost grows
    /// with C's turns: the pixel is coarsened (with a warning) to keep one request's work,
    /// and a plan of more than 1,000,000 blocks is refused (422 naming `removal_model`).
    #[default]
    Exact,
    /// The plan's own model: the mean dwell's removal plus each harmonic's first-order
    /// removal of C's law, on the radial grid's rings inside the clear aperture (null
    /// outside them), linear in the radius between rings. Its cost does not grow with the
    /// turns; it leaves out the modulation's second order, the sectors' aliases and the
    /// spiral's ripple. `/v1/maps/predict` gives the exact removal of the same plan.
    Harmonic,
}

impl From<RemovalModelDto> for RemovalModel {
    fn from(m: RemovalModelDto) -> RemovalModel {
        match m {
            RemovalModelDto::Exact => RemovalModel::Exact,
            RemovalModelDto::Harmonic => RemovalModel::Harmonic,
        }
    }
}

impl From<RemovalModel> for RemovalModelDto {
    fn from(m: RemovalModel) -> RemovalModelDto {
        match m {
            RemovalModel::Exact => RemovalModelDto::Exact,
            RemovalModel::Harmonic => RemovalModelDto::Harmonic,
        }
    }
}

/// The result's maps on one square grid centred on the axis (x right, y up, mm).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct CorrectionMapsDto {
    /// The grid's pixel, mm.
    pub pixel_mm: f64,
    /// The columns' x, mm, left to right.
    pub x_mm: Vec<f64>,
    /// The rows' y, mm, top (largest) first.
    pub y_mm: Vec<f64>,
    /// The removal as `removal_model` computes it, nm; null off the part (and, by the
    /// harmonic model, off the aperture's rings).
    pub removal_nm: Vec<Vec<Option<f64>>>,
    /// The target: the map (piston and tilt removed) plus the plan's piston, nm; null outside
    /// the clear aperture or without data.
    pub target_nm: Vec<Vec<Option<f64>>>,
    /// removal − target, nm; null where the target is.
    pub residual_nm: Vec<Vec<Option<f64>>>,
}

/// Figures before and after, over the clear aperture's pixels with data.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct CorrectionMetricsDto {
    /// The map (piston and tilt removed), about its mean.
    pub before: MapFiguresDto,
    /// The residual, about its mean (a piston is free).
    pub after: MapFiguresDto,
    /// The map's rotationally variant part: less its azimuthal mean at each pixel's radius
    /// (the mean of a ring of samples of the map at that radius).
    pub non_axisymmetric_before: MapFiguresDto,
    /// The residual's rotationally variant part.
    pub non_axisymmetric_after: MapFiguresDto,
    /// For comparison, the residual of the best plan in radius alone (C at constant speed,
    /// the same limits without the modulation's floors), about its mean. Its removal is
    /// round, so what it leaves not round is `non_axisymmetric_before`.
    pub radial_plan_after: MapFiguresDto,
    /// That radial plan's total time, s.
    pub radial_plan_time_s: f64,
}

/// C's peaks over the executed motion (the program's acceleration model: a speed change over
/// the mean of the two blocks' durations).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct CPeaksDto {
    /// Largest |speed|, deg/min.
    pub velocity_deg_per_min: f64,
    /// Largest |acceleration|, deg/s².
    pub acceleration_deg_per_s2: f64,
}

/// One radius band of the harmonic budget.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct HarmonicBandDto {
    /// The band's inner radius, mm.
    pub from_mm: f64,
    /// The band's outer radius, mm (a pad radius further, or the aperture's edge).
    pub to_mm: f64,
    /// For m = 1, 2, …: the largest amplitude of harmonic m (nm) the plan's mean dwell can
    /// remove in the band, with the most modulation C's law carries of m alone (relative to the
    /// dwell: min{δ·sinc(mπ/S), a_max/(m·Ω0²)}, δ = min{max_modulation, 1 − Ω0/v_max}).
    pub amplitude_nm: Vec<f64>,
    /// For m = 1, 2, …: the map's amplitude of harmonic m, nm (its largest over the band).
    pub target_amplitude_nm: Vec<f64>,
    /// Σ_m target_amplitude_nm/amplitude_nm: the share of C's modulation the band's target
    /// asks, every harmonic at once (one law carries them all). At most 1, the budget allows
    /// the band's whole correction; above, the plan corrects what the law leaves room for.
    /// `null` where the target has a harmonic the plan's dwell cannot put in the band at all.
    pub modulation_share: Option<f64>,
    /// For m = 1, 2, …: harmonic m's RMS over the band's pixels in the target, nm (a
    /// least-squares fit of harmonics 0 … max_harmonic on each ring one pixel wide with at
    /// least 2·(2·max_harmonic + 1) pixels); empty when no ring of the band has as many.
    pub target_rms_nm: Vec<f64>,
    /// The same of the residual: what the plan left of each harmonic.
    pub residual_rms_nm: Vec<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct MapOptimizeResponse {
    /// The machine's kinematics the plan is for.
    pub kinematics: KinematicsDto,
    /// The mean dwell per station (the 1-D plan C's law modulates): send it with `c_law` to
    /// `/v1/maps/predict` to predict the plan again.
    pub dwell: DwellDto,
    /// C's speed law: per station, a factor per sector of the process's part speed.
    pub c_law: CLawDto,
    /// The dwell over the angle: per station, the time (s) the pad centre spends over each
    /// sector.
    pub sector_dwell_s: Vec<Vec<f64>>,
    /// The highest harmonic corrected.
    pub max_harmonic: usize,
    /// The uniform layer removed beside the map, nm.
    pub piston_nm: f64,
    /// Removal, target and residual maps.
    pub maps: CorrectionMapsDto,
    /// Figures before and after.
    pub metrics: CorrectionMetricsDto,
    /// C's peak speed and acceleration.
    pub c_peaks: CPeaksDto,
    /// What each harmonic can reach, per radius band.
    pub harmonic_budget: Vec<HarmonicBandDto>,
    /// The clear aperture, mm.
    pub clear_aperture: ApertureEcho,
    /// The plan's total time, s.
    pub total_time_s: f64,
    /// How many constant-speed blocks the executed motion takes.
    pub blocks: usize,
    /// How the removal map was computed.
    pub removal_model: RemovalModelDto,
    /// Every limit the plan sits on (≥ 99.9 %), a missed target, harmonics left; empty when
    /// there is nothing to say.
    pub warnings: Vec<WarningDto>,
    /// On segments (the request's `segments`): each segment's figures and what each ring asks
    /// of Z. Absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segments: Option<SegmentsReportDto>,
}

/// What a plan on segments does to each and asks of Z. On segments nothing is round about C,
/// so the metrics' `non_axisymmetric_*` are the whole target and residual there.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct SegmentsReportDto {
    /// Per segment, in the layout's order: its target and residual over its own pixels in
    /// the clear aperture, each about its own mean (a segment's piston is its own).
    pub segments: Vec<SegmentFiguresDto>,
    /// Per station whose ring crosses a segment: Z's motion over a turn, its harmonics, and
    /// the C speed Z can follow them at (A ≤ min{L/2, v_max/(2πf), a_max/(4π²f²)} for each
    /// harmonic m at f = m·n/60 Hz, n the C speed in r/min). Where the plan's law would turn C
    /// faster than that over a station's sectors, its modulation there is scaled down.
    pub servo: Vec<StationServoDto>,
    /// The plan's program (as `/v1/maps/program` makes it from the start angle 0, with
    /// `segments.chord_tolerance_mm`): each axis's peaks over its polishing blocks, within
    /// every limit of the machine (else the plan is a 422 `machine-limits` problem).
    pub polishing_peaks: PolishingPeaksDto,
}

/// One segment's figures.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct SegmentFiguresDto {
    /// The target over the segment's pixels, about its mean.
    pub before: MapFiguresDto,
    /// The residual over the segment's pixels, about its mean.
    pub after: MapFiguresDto,
}

impl From<SegmentReport> for SegmentsReportDto {
    fn from(r: SegmentReport) -> Self {
        SegmentsReportDto {
            segments: r
                .figures
                .iter()
                .map(|[before, after]| SegmentFiguresDto {
                    before: before.into(),
                    after: after.into(),
                })
                .collect(),
            servo: r.servo.into_iter().map(Into::into).collect(),
            polishing_peaks: r.polishing_peaks.into(),
        }
    }
}

/// `POST /v1/maps/optimize`.
pub struct MapOptimizeEndpoint;

impl Endpoint for MapOptimizeEndpoint {
    const NAME: &'static str = "maps/optimize";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/maps_optimize_astigmatism.json");
    const DOC: Doc = Doc {
        operation_id: "optimizeMap",
        tag: "maps",
        summary: "Correct a measured map on the paper's machine: radial dwell and C's speed law.",
        description: "The map (piston and tilt removed) is split into angular harmonics on the \
radial grid. Each harmonic m ≥ 1 is a radial problem of its own (the process is rotationally \
symmetric); its answer modulates the time the pad spends over each sector of the part, which C \
executes by its speed. The modulation's needs (its bound, C's velocity and acceleration) are \
floors on the mean dwell, solved as `/v1/optimize` solves a profile (the azimuthal mean, with a \
free piston) within every limit. The result is judged by the exact removal of the executed \
motion, on a plane, a sphere or an asphere.",
        ok: "The plan, C's law, the maps and their figures, the harmonic budget",
    };
    type Request = MapOptimizeAny;
    type Body = MapOrJson<MapOptimizeAny>;
    type Command = Kinds<MapOptimizeCommand, RasterOptimizeCommand>;
    type Output = Answer<MapCorrection, RasterCorrection>;
    type Response = MapOptimizeAnswer;

    fn document(operation: &mut utoipa::openapi::path::Operation) {
        body::document(
            operation,
            MapOptimizeAny::FILES,
            MapOptimizeAny::QUERY_FIELDS,
        );
    }

    fn parse(req: MapOptimizeAny, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let req = match req {
            Kinds::Polar(req) => req,
            Kinds::Cartesian(req) => {
                return Ok(Kinds::Cartesian(RasterOptimizeCommand::new(
                    req.spec(limits)?,
                )?))
            }
        };
        let machine = req.machine.clone().unwrap_or_default();
        let KinematicsDto::Polar = machine.kinematics;
        let (surface, segments) = part_on_c(
            req.surface.as_ref(),
            req.segments.as_ref(),
            req.process.workpiece_radius_mm,
        )?;
        let setting = super::super::dto::SettingDtos {
            process: &req.process,
            surface: surface.as_ref(),
            tool: req.tool.as_ref(),
            grid: req.radial_grid.as_ref(),
            aperture: req.clear_aperture.as_ref(),
        }
        .parse(limits)?;
        let (map, placement) = match (req.segment_maps, &segments) {
            (None, _) => {
                let (map, _) = req.map.read("map", limits.max_map_pixels)?;
                (
                    map,
                    req.alignment.unwrap_or_default().placement(req.pixel_mm)?,
                )
            }
            (Some(_), None) => {
                return Err(ApiError::invalid(
                    "segment_maps",
                    "segment_maps are the maps of segments: give segments as well",
                ))
            }
            (Some(_), Some(_)) if !matches!(req.map, MapSource::Missing) => {
                return Err(ApiError::invalid(
                    "map",
                    "give the mounted set's map or each segment's (segment_maps), not both",
                ))
            }
            (Some(_), Some(_)) if req.alignment.is_some() || req.pixel_mm.is_some() => {
                return Err(ApiError::invalid(
                    "alignment",
                    "the segments' maps are mounted in C's frame, C at the middle: leave \
                     alignment and pixel_mm out",
                ))
            }
            (Some(grids), Some(setup)) => {
                let maps = grids
                    .into_iter()
                    .enumerate()
                    .map(|(i, g)| {
                        HeightMap::from_rows(
                            g.heights_nm,
                            g.pixel_mm,
                            g.wavelength_nm,
                            limits.max_map_pixels,
                        )
                        .map_err(|e| ApiError::invalid(format!("segment_maps[{i}]"), e.to_string()))
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                let map = mounted(&setup.layout, &maps, limits.max_map_pixels).map_err(|e| {
                    let at = match &e {
                        MountedError::Pixel { segment } => {
                            format!("segment_maps[{segment}].pixel_mm")
                        }
                        _ => "segment_maps".to_string(),
                    };
                    ApiError::invalid(at, e.to_string())
                })?;
                let middle = 0.5 * (map.width() as f64 - 1.0);
                let placement = Placement {
                    pixel_mm: None,
                    centre_px: Some((middle, middle)),
                    part_radius_mm: Some(req.process.workpiece_radius_mm),
                    rotation_deg: None,
                    mirror: None,
                };
                (map, placement)
            }
        };
        let law = req.c_law.unwrap_or_default();
        let spec = MapOptimizeSpec {
            optimize: OptimizeSpec {
                positions_mm: req.positions_mm,
                target: Default::default(),
                constraints: ConstraintsDto::to_constraints(req.constraints.as_ref()),
                objective: ObjectiveDto::to_objective(req.objective.as_ref()),
                time_limit_s: req.solver.and_then(|s| s.time_limit_s),
                machine: match &req.machine {
                    None => MachineChoiceDto::choice(None),
                    Some(m) => m.choice(),
                },
            },
            placement,
            sectors: law.sectors,
            max_harmonic: law.max_harmonic,
            max_modulation: law.max_modulation,
            pixel_mm: req.removal_pixel_mm,
            removal_model: req.removal_model.into(),
            segments,
        };
        Ok(Kinds::Polar(MapOptimizeCommand::new(
            setting, map, spec, limits,
        )?))
    }

    fn run(command: Self::Command, services: &Services) -> Result<Self::Output, ApiError> {
        Ok(match command {
            Kinds::Polar(c) => {
                Answer::Polar(map_optimize(c, &services.recommender, &services.operators)?)
            }
            Kinds::Cartesian(c) => Answer::Cartesian(raster_optimize(c)?),
        })
    }

    fn respond(r: Self::Output) -> MapOptimizeAnswer {
        match r {
            Answer::Polar(r) => Answer::Polar(polar_response(r)),
            Answer::Cartesian(r) => Answer::Cartesian(r.into()),
        }
    }
}

/// A polar correction's answer.
pub fn polar_response(r: MapCorrection) -> MapOptimizeResponse {
    let width = r.x_mm.len();
    let rows = |v: Vec<Option<f64>>| v.chunks(width).map(<[_]>::to_vec).collect();
    MapOptimizeResponse {
        kinematics: KinematicsDto::Polar,
        dwell: DwellDto {
            positions_mm: r.plan.motion.radii_mm().to_vec(),
            dwell_s: r.plan.solution.dwell_s.clone(),
        },
        c_law: CLawDto {
            sectors: r.sectors,
            speed_factors: r.speed_factors,
        },
        sector_dwell_s: r.sector_dwell_s,
        max_harmonic: r.max_harmonic,
        piston_nm: r.plan.solution.piston_nm.unwrap_or(0.0),
        maps: CorrectionMapsDto {
            pixel_mm: r.pixel_mm,
            removal_nm: rows(r.removal_nm),
            target_nm: rows(r.target_nm),
            residual_nm: rows(r.residual_nm),
            x_mm: r.x_mm,
            y_mm: r.y_mm,
        },
        metrics: CorrectionMetricsDto {
            before: (&r.before).into(),
            after: (&r.after).into(),
            non_axisymmetric_before: (&r.before_non_axisymmetric).into(),
            non_axisymmetric_after: (&r.after_non_axisymmetric).into(),
            radial_plan_after: (&r.radial_plan_after).into(),
            radial_plan_time_s: r.radial_plan_time_s,
        },
        c_peaks: CPeaksDto {
            velocity_deg_per_min: r.c_peak_velocity_deg_per_min,
            acceleration_deg_per_s2: r.c_peak_acceleration_deg_per_s2,
        },
        harmonic_budget: r
            .harmonic_budget
            .into_iter()
            .map(|b| HarmonicBandDto {
                from_mm: b.from_mm,
                to_mm: b.to_mm,
                amplitude_nm: b.amplitude_nm,
                target_amplitude_nm: b.target_amplitude_nm,
                modulation_share: b.modulation_share,
                target_rms_nm: b.target_rms_nm,
                residual_rms_nm: b.residual_rms_nm,
            })
            .collect(),
        clear_aperture: ApertureEcho::from(r.plan.setting.aperture()),
        total_time_s: r.total_time_s,
        blocks: r.blocks,
        removal_model: r.removal_model.into(),
        warnings: WarningDto::all(&r.warnings),
        segments: r.segments.map(Into::into),
    }
}
