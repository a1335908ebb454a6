//! `POST /v1/maps/predict`: a polar plan's removal as a map, the exact depth of the motion the
//! machine executes.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::dto::{
    part_on_c, part_spec, ApertureEcho, ClearApertureDto, DwellDto, ProcessDto, RadialGridDto,
    SegmentsDto, SurfaceDto, WarningDto,
};
use super::super::endpoint::{Doc, Endpoint, Picture};
use super::super::error::ApiError;
use super::super::extract::{count, object, optional_object, ApiJson};
use super::super::state::Services;
use super::raster::{Answer, Kinds, RasterPredictRequest, RasterPredictResponse};
use super::removal_function::{KinematicsDto, MapMachineDto};
use crate::field::Figures;
use crate::http::openapi::any_of;
use crate::report::{heatmap, results};
use crate::usecases::map_predict::{
    map_predict, CLawSpec, MapPredictCommand, MapPredictSpec, MapPrediction,
};
use crate::usecases::raster_predict::{raster_predict, RasterPredictCommand, RasterPrediction};
use crate::usecases::ComputeLimits;

/// C's speed law under position control: the part's circle cut into `sectors` equal sectors of
/// the pad centre's angle in the part's frame (sector k from k·360°/sectors), and while a
/// station's dwell is spent with the pad over sector k the part turns at that station's
/// factor k times `process.workpiece_rpm` (> 0: C keeps its direction). Within a sector X and C
/// move at constant speed, as blocks in inverse time do.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CLawDto {
    /// Sectors per turn (≥ 1; a whole number, written with a fraction or not).
    #[schema(minimum = 1, maximum = 100_000)]
    #[serde(deserialize_with = "count")]
    pub sectors: usize,
    /// One row per station of `dwell.positions_mm`, each with `sectors` speed factors (> 0).
    pub speed_factors: Vec<Vec<f64>>,
}

impl CLawDto {
    /// The law as the core takes it.
    pub fn spec(self) -> CLawSpec {
        CLawSpec {
            sectors: self.sectors,
            speed_factors: self.speed_factors,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapPredictRequest {
    /// The polishing process (radii in mm, signed speeds in r/min, CCW positive).
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// The part's surface; default a plane. On a curved part the pad conforms to it, moves at
    /// constant speed along the arc within a move, and the map is over the projection (x, y).
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// The machine; default `{"kinematics": "polar"}`.
    #[serde(default, deserialize_with = "optional_object")]
    pub machine: Option<MapMachineDto>,
    /// The plan: stations and the dwell in each one's cell, run as `/v1/predict` runs them (half
    /// the end stations' dwell standing, the rest crossing each cell at constant speed).
    #[serde(deserialize_with = "object")]
    pub dwell: DwellDto,
    /// C's speed law; default C at `process.workpiece_rpm` throughout.
    #[serde(default, deserialize_with = "optional_object")]
    pub c_law: Option<CLawDto>,
    /// The pad centre's angle in the part's frame when the plan starts, degrees
    /// (counter-clockwise from +x); default 0.
    pub start_angle_deg: Option<f64>,
    /// The map's pixel, mm (> 0); default the part's diameter / 100.
    #[schema(example = 1.0)]
    pub pixel_mm: Option<f64>,
    /// Where to report the azimuthal mean; default 201 samples from 0 to the workpiece radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
    /// The clear aperture (an annulus about the axis) the figures are taken over; default the
    /// whole part.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<ClearApertureDto>,
    /// Off-axis segments mounted on C (leave `surface` out: the parent is here). The removal
    /// is then the exact one on the segments' pixels (null elsewhere), its figures the
    /// segments' in the clear aperture, and `azimuthal_mean` empty (nothing is round).
    #[serde(default, deserialize_with = "optional_object")]
    pub segments: Option<SegmentsDto>,
}

/// Figures of a removal over the clear aperture's pixels (each the same area), nm.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct MapFiguresDto {
    /// The mean, nm.
    pub mean_nm: f64,
    /// Peak to valley, nm.
    pub pv_nm: f64,
    /// About the mean.
    pub rms_nm: f64,
    /// How many pixels.
    pub pixels: usize,
}

impl From<&Figures> for MapFiguresDto {
    fn from(f: &Figures) -> Self {
        MapFiguresDto {
            mean_nm: f.mean,
            pv_nm: f.pv,
            rms_nm: f.rms,
            pixels: f.samples,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct MapPredictResponse {
    /// The machine's kinematics the prediction is for.
    pub kinematics: KinematicsDto,
    /// The removal map: square, centred on the axis, the part's diameter across.
    pub removal: RemovalMapDto,
    /// The removal over the clear aperture: mean, PV, RMS about the mean.
    pub metrics: MapFiguresDto,
    /// pv / mean over the clear aperture; null when the mean is 0.
    #[schema(required = true)]
    pub nonuniformity: Option<f64>,
    /// The removal less its azimuthal mean at each pixel's radius, over the clear aperture:
    /// what is not round — a C law's doing, a spiral's ripple, a partial ring's ends.
    pub non_axisymmetric: MapFiguresDto,
    /// The removal averaged over each circle about the axis: exactly the 1-D removal taken
    /// with the C speed of each instant (with C at constant speed, `/v1/predict`'s removal).
    pub azimuthal_mean: AzimuthalMeanDto,
    /// The clear aperture, mm: inner and outer radius.
    pub clear_aperture: ApertureEcho,
    /// The plan's total dwell, s.
    pub total_time_s: f64,
    /// How many constant-speed blocks the executed motion was cut into.
    pub blocks: usize,
    /// What looks wrong in the input though it is valid; empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
    /// On segments (or a decentred part): each segment's removal figures over its own pixels
    /// in the clear aperture, in the layout's order; else null.
    pub segments: Option<Vec<MapFiguresDto>>,
}

/// A removal profile on a radial grid.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct AzimuthalMeanDto {
    /// The radial grid, mm.
    pub radius_mm: Vec<f64>,
    /// The removal's mean over the circle at each radius, nm.
    pub removal_nm: Vec<f64>,
}

/// A map of removal in nm on the part's frame (x right, y up, mm from the axis).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RemovalMapDto {
    /// The grid's pixel, mm.
    pub pixel_mm: f64,
    /// The columns' x, mm, left to right.
    pub x_mm: Vec<f64>,
    /// The rows' y, mm, top (largest) first.
    pub y_mm: Vec<f64>,
    /// Removal in nm: one row per entry of `y_mm`, each with one value per entry of `x_mm`;
    /// null off the part.
    pub removal_nm: Vec<Vec<Option<f64>>>,
}

/// A prediction's request: the paper's machine's or an X-Y machine's.
pub type MapPredictAny = Kinds<MapPredictRequest, RasterPredictRequest>;
any_of!(
    impl MapPredictAny as "MapPredictAnyRequest",
    [MapPredictRequest, RasterPredictRequest],
    "A plan to predict: on the paper's machine (`machine.kinematics` `polar`, the default) or \
     on an X-Y machine (`machine.kinematics` `cartesian`)."
);

/// A prediction of either machine.
pub type MapPredictAnswer = Answer<MapPredictResponse, RasterPredictResponse>;
any_of!(
    impl MapPredictAnswer as "MapPredictAnyResponse",
    [MapPredictResponse, RasterPredictResponse],
    "The removal map of a polar plan, or of an X-Y machine's raster (`kinematics` says which)."
);

/// What a prediction computed, on either machine.
pub type MapPredictOutput = Answer<MapPrediction, RasterPrediction>;

fn removal_csv(r: &MapPredictOutput) -> String {
    match r {
        Answer::Polar(p) => results::removal_map_csv(p),
        Answer::Cartesian(c) => results::removal_pixels_csv(
            &c.x_mm,
            &c.y_mm,
            &c.removal_nm.iter().copied().map(Some).collect::<Vec<_>>(),
        ),
    }
}

fn removal_png(r: &MapPredictOutput) -> Vec<u8> {
    match r {
        Answer::Polar(p) => heatmap::removal_map_png(p),
        Answer::Cartesian(c) => heatmap::removal_pixels_png(
            (c.x_mm.len(), c.y_mm.len()),
            c.pixel_mm,
            &c.removal_nm.iter().copied().map(Some).collect::<Vec<_>>(),
            &c.removal,
        ),
    }
}

/// `POST /v1/maps/predict`.
pub struct MapPredictEndpoint;

impl Endpoint for MapPredictEndpoint {
    const NAME: &'static str = "maps/predict";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/maps_predict_sector_law.json");
    const DOC: Doc = Doc {
        operation_id: "predictRemovalMap",
        tag: "maps",
        summary: "A polar plan's removal as a map: the exact depth of the executed motion.",
        description: "On the paper's machine (`machine.kinematics: polar`, the default) the part \
turns on C under the pad while X runs the dwell plan; with `c_law`, C's speed is set per station \
and sector. The executed motion (blocks at constant X and C speed, cut at the sector edges) is \
integrated exactly at each pixel: rings in closed form, spirals by quadrature. Figures over the \
clear aperture, with the non-axisymmetric part separated. On a sphere or an asphere the pad \
conforms to the surface and the map is over the projection (x, y). `Accept: text/csv` returns \
x, y and removal per pixel on the part; `image/png` a heat map.",
        ok: "The removal map and its figures; as CSV, the pixels; as PNG, the heat map",
    };
    type Request = MapPredictAny;
    type Body = ApiJson<MapPredictAny>;
    type Command = Kinds<MapPredictCommand, RasterPredictCommand>;
    type Output = MapPredictOutput;
    type Response = MapPredictAnswer;
    const CSV: Option<fn(&MapPredictOutput) -> String> = Some(removal_csv);
    const PNG: Option<Picture<MapPredictOutput>> = Some(removal_png);

    fn parse(req: MapPredictAny, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let req = match req {
            Kinds::Polar(req) => req,
            Kinds::Cartesian(req) => {
                return Ok(Kinds::Cartesian(RasterPredictCommand::new(
                    req.spec(limits)?,
                )?))
            }
        };
        let KinematicsDto::Polar = req.machine.unwrap_or_default().kinematics;
        let (surface, segments) = part_on_c(
            req.surface.as_ref(),
            req.segments.as_ref(),
            req.process.workpiece_radius_mm,
        )?;
        Ok(Kinds::Polar(MapPredictCommand::new(
            MapPredictSpec {
                process: req.process.spec()?,
                part: part_spec(surface.as_ref(), None)?,
                segments,
                aperture: req.clear_aperture.as_ref().into(),
                grid: req.radial_grid.as_ref().into(),
                positions_mm: req.dwell.positions_mm,
                dwell_s: req.dwell.dwell_s,
                c_law: req.c_law.map(CLawDto::spec),
                start_angle_deg: req.start_angle_deg,
                pixel_mm: req.pixel_mm,
            },
            limits,
        )?))
    }

    fn run(command: Self::Command, _: &Services) -> Result<MapPredictOutput, ApiError> {
        Ok(match command {
            Kinds::Polar(c) => Answer::Polar(map_predict(c)),
            Kinds::Cartesian(c) => Answer::Cartesian(raster_predict(c)?),
        })
    }

    fn respond(r: MapPredictOutput) -> MapPredictAnswer {
        match r {
            Answer::Polar(r) => Answer::Polar(polar_response(r)),
            Answer::Cartesian(r) => Answer::Cartesian(r.into()),
        }
    }
}

fn polar_response(r: MapPrediction) -> MapPredictResponse {
    let width = r.x_mm.len();
    let m = &r.metrics;
    MapPredictResponse {
        kinematics: KinematicsDto::Polar,
        nonuniformity: (m.mean != 0.0).then(|| m.pv / m.mean),
        metrics: m.into(),
        non_axisymmetric: (&r.non_axisymmetric).into(),
        azimuthal_mean: AzimuthalMeanDto {
            radius_mm: r.radius_mm,
            removal_nm: r.azimuthal_mean_nm,
        },
        clear_aperture: ApertureEcho::from(&r.clear_aperture),
        total_time_s: r.total_time_s,
        blocks: r.blocks,
        warnings: WarningDto::all_at(&r.warnings, "dwell.positions_mm"),
        segments: r
            .segments
            .map(|figures| figures.iter().map(Into::into).collect()),
        removal: RemovalMapDto {
            pixel_mm: r.pixel_mm,
            removal_nm: r.removal_nm.chunks(width).map(<[_]>::to_vec).collect(),
            x_mm: r.x_mm,
            y_mm: r.y_mm,
        },
    }
}
