//! `POST /v1/maps/removal-function`: the pad's instantaneous footprint on the part, as a map,
//! and its revolution average (the radial removal function).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::dto::{part_spec, ProcessDto, RadialGridDto, SurfaceDto, WarningDto};
use super::super::endpoint::{Doc, Endpoint, Picture};
use super::super::error::ApiError;
use super::super::extract::{object, optional_object, ApiJson};
use super::super::state::Services;
use super::body::MapGridDto;
use super::raster::{Answer, CartesianDto, CartesianMachineDto, InfluenceDto, Kinds};
use crate::http::openapi::any_of;
use crate::report::{heatmap, results};
use crate::usecases::map_removal_function::{
    map_removal_function, still_footprint, Footprint, MapRemovalFunction,
    MapRemovalFunctionCommand, MapRemovalFunctionSpec, StillFootprint, StillFootprintCommand,
    StillFootprintSpec,
};
use crate::usecases::ComputeLimits;

/// How the machine moves the pad over the part.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum KinematicsDto {
    /// The paper's machine: the part turns on C under the pad, X carries the pad along a
    /// radius (Z and B follow a curved surface).
    #[default]
    Polar,
}

/// The machine, as far as the footprint depends on it.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapMachineDto {
    /// How the pad moves over the part; default `polar`.
    #[serde(default)]
    pub kinematics: KinematicsDto,
}

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapRemovalFunctionRequest {
    /// The polishing process (radii in mm, signed speeds in r/min, CCW positive).
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// The part's surface; default a plane. On a curved part the pad conforms to it and the
    /// map is over the projection (x, y), the rate along the normal.
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// The machine; default `{"kinematics": "polar"}`.
    #[serde(default, deserialize_with = "optional_object")]
    pub machine: Option<MapMachineDto>,
    /// The pad centre's radius r1, mm (within the reach `process.pressure_model` gives).
    pub tool_position_mm: f64,
    /// The footprint's pixel, mm (> 0); default the pad's diameter / 200 (201 × 201 pixels).
    /// At most the server's max_map_pixels pixels.
    #[schema(example = 0.05)]
    pub pixel_mm: Option<f64>,
    /// Where to report the revolution average; default 201 samples from 0 to the workpiece
    /// radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct MapRemovalFunctionResponse {
    /// The machine's kinematics the footprint is for.
    pub kinematics: KinematicsDto,
    /// Speed ratio η = −workpiece_rpm / tool_rpm (paper convention); null when tool_rpm = 0.
    #[schema(required = true)]
    pub eta: Option<f64>,
    /// The pad centre's radius r1, mm.
    pub tool_position_mm: f64,
    /// The removal rate at each point of the part at one instant, the pad centre at
    /// (tool_position_mm, 0).
    pub footprint: FootprintDto,
    /// The footprint averaged over a revolution of the part: the radial removal function.
    pub revolution_average: RevolutionAverageDto,
    /// What looks wrong in the input though it is valid (radii or positions that look like
    /// metres, a pressure that looks like pascals); empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
}

/// The instantaneous removal rate ρ = K·P·(p/P)·|(ω2 − Ω)·p − ω2·c| over the pad, the pad
/// centre at c = (r1, 0) in the part's frame (x along the pad centre's radius, y a quarter turn
/// counter-clockwise): 0 off the pad, off the part and beyond a linear pad's lift line.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct FootprintDto {
    /// The grid's pixel, mm.
    pub pixel_mm: f64,
    /// The columns' x, mm (part frame), left to right; the middle one is r1.
    pub x_mm: Vec<f64>,
    /// The rows' y, mm, top (largest) first; the middle one is 0.
    pub y_mm: Vec<f64>,
    /// ρ in nm/min: one row per entry of `y_mm`, each with one value per entry of `x_mm`.
    pub removal_rate_nm_per_min: Vec<Vec<f64>>,
    /// The largest value of `removal_rate_nm_per_min`.
    pub peak_removal_rate_nm_per_min: f64,
}

/// The footprint averaged over a revolution of the part: R(r; r1), the radial removal function
/// (`/v1/removal-function` gives the same numbers). The footprint's mean over the circle of
/// radius r is R(r; r1).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RevolutionAverageDto {
    /// The radial grid, mm.
    pub radius_mm: Vec<f64>,
    /// R(r; r1) at each radius of `radius_mm`, nm/min.
    pub removal_rate_nm_per_min: Vec<f64>,
}

/// `POST /v1/maps/removal-function` on an X-Y machine: the pad spinning on a part that stands
/// still, its influence function.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct StillRemovalFunctionRequest {
    /// The polishing process, `workpiece_rpm` 0 (the part stands still; the pad spins at
    /// `tool_rpm`).
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// The X-Y machine (`kinematics: cartesian`); its limits do not change the footprint.
    #[serde(deserialize_with = "object")]
    pub machine: CartesianMachineDto,
    /// The pad centre's distance from the part's centre, mm; default 0. The pressure is the
    /// process's model there: uniform while the pad is on the part, as the 1-D model has it
    /// overhanging the edge.
    pub tool_position_mm: Option<f64>,
    /// The footprint's pixel, mm (> 0); default the pad's diameter / 200 (201 × 201 pixels).
    #[schema(example = 0.1)]
    pub pixel_mm: Option<f64>,
}

/// The pad's influence function on a still part.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct StillRemovalFunctionResponse {
    /// `cartesian`.
    pub kinematics: CartesianDto,
    /// The pad centre's distance from the part's centre, mm.
    pub tool_position_mm: f64,
    /// ρ = K·P·(p/P)·|ω2|·|p − c| over the pad, the pad centre c at (tool_position_mm, 0):
    /// the removal rate at every instant, nm/min.
    pub footprint: FootprintDto,
    /// The same rate in nm/s, ready to send as `influence` to `/v1/maps/optimize` and
    /// `/v1/maps/predict` (`machine.kinematics: cartesian`): the map with its pixel, the pad
    /// centre at its middle pixel.
    pub influence: InfluenceDto,
}

/// A removal-function request of either machine.
pub type MapRemovalFunctionAny = Kinds<MapRemovalFunctionRequest, StillRemovalFunctionRequest>;
any_of!(
    impl MapRemovalFunctionAny as "MapRemovalFunctionAnyRequest",
    [MapRemovalFunctionRequest, StillRemovalFunctionRequest],
    "The pad on the paper's machine (`machine.kinematics` `polar`, the default: the part turns) \
     or on an X-Y machine (`cartesian`: the part stands still)."
);

/// A removal function of either machine.
pub type MapRemovalFunctionAnswer =
    Answer<MapRemovalFunctionResponse, StillRemovalFunctionResponse>;
any_of!(
    impl MapRemovalFunctionAnswer as "MapRemovalFunctionAnyResponse",
    [MapRemovalFunctionResponse, StillRemovalFunctionResponse],
    "The footprint and its revolution average (polar), or the influence function on a still \
     part (cartesian)."
);

/// What was computed, on either machine.
pub type MapRemovalFunctionOutput = Answer<MapRemovalFunction, StillFootprint>;

/// The footprint and where its pad centre is.
fn footprint_of(m: &MapRemovalFunctionOutput) -> (&Footprint, f64) {
    match m {
        Answer::Polar(p) => (&p.footprint, p.tool_position_mm),
        Answer::Cartesian(c) => (&c.footprint, c.tool_position_mm),
    }
}

fn footprint_csv(m: &MapRemovalFunctionOutput) -> String {
    results::footprint_csv(footprint_of(m).0)
}

fn footprint_png(m: &MapRemovalFunctionOutput) -> Vec<u8> {
    let (f, r1) = footprint_of(m);
    heatmap::footprint_png(f, r1)
}

fn footprint_dto(footprint: &Footprint) -> FootprintDto {
    FootprintDto {
        pixel_mm: footprint.pixel_mm,
        peak_removal_rate_nm_per_min: footprint.peak_nm_per_min(),
        removal_rate_nm_per_min: footprint
            .rate_nm_per_min
            .chunks(footprint.width())
            .map(<[f64]>::to_vec)
            .collect(),
        x_mm: footprint.x_mm.clone(),
        y_mm: footprint.y_mm.clone(),
    }
}

/// `POST /v1/maps/removal-function`.
pub struct MapRemovalFunctionEndpoint;

impl Endpoint for MapRemovalFunctionEndpoint {
    const NAME: &'static str = "maps/removal-function";
    const EXAMPLE: &'static str =
        include_str!("../../../fixtures/maps_removal_function_paper_exp1.json");
    const DOC: Doc = Doc {
        operation_id: "computeMapRemovalFunction",
        tag: "maps",
        summary: "The pad's instantaneous footprint on the part as a map, and its revolution \
                  average.",
        description: "On the paper's machine (`machine.kinematics: polar`, the default) the part \
turns on C under the pad: the footprint is the removal rate at each point of the part at one \
instant, the pad centre at (tool_position_mm, 0), exact (Preston's law on the 2-D sliding speed); \
its revolution average is the radial removal function R(r; r1). On a sphere or an asphere the \
pad conforms to the surface and the map is over the projection (x, y). `Accept: text/csv` \
returns the footprint as x, y and rate per pixel; `image/png` a heat map of it.",
        ok: "The footprint and its revolution average; as CSV, the footprint's pixels; as PNG, \
             its heat map",
    };
    type Request = MapRemovalFunctionAny;
    type Body = ApiJson<MapRemovalFunctionAny>;
    type Command = Kinds<MapRemovalFunctionCommand, StillFootprintCommand>;
    type Output = MapRemovalFunctionOutput;
    type Response = MapRemovalFunctionAnswer;
    const CSV: Option<fn(&MapRemovalFunctionOutput) -> String> = Some(footprint_csv);
    const PNG: Option<Picture<MapRemovalFunctionOutput>> = Some(footprint_png);

    fn parse(
        req: MapRemovalFunctionAny,
        limits: &ComputeLimits,
    ) -> Result<Self::Command, ApiError> {
        let req = match req {
            Kinds::Polar(req) => req,
            Kinds::Cartesian(req) => {
                req.machine.checked_caps()?;
                return Ok(Kinds::Cartesian(StillFootprintCommand::new(
                    StillFootprintSpec {
                        process: req.process.spec()?,
                        tool_position_mm: req.tool_position_mm,
                        pixel_mm: req.pixel_mm,
                    },
                    limits,
                )?));
            }
        };
        let KinematicsDto::Polar = req.machine.unwrap_or_default().kinematics;
        Ok(Kinds::Polar(MapRemovalFunctionCommand::new(
            MapRemovalFunctionSpec {
                process: req.process.spec()?,
                part: part_spec(req.surface.as_ref(), None)?,
                grid: req.radial_grid.as_ref().into(),
                tool_position_mm: req.tool_position_mm,
                pixel_mm: req.pixel_mm,
            },
            limits,
        )?))
    }

    fn run(command: Self::Command, _: &Services) -> Result<MapRemovalFunctionOutput, ApiError> {
        Ok(match command {
            Kinds::Polar(c) => Answer::Polar(map_removal_function(c)),
            Kinds::Cartesian(c) => Answer::Cartesian(still_footprint(c)),
        })
    }

    fn respond(result: MapRemovalFunctionOutput) -> MapRemovalFunctionAnswer {
        match result {
            Answer::Polar(result) => Answer::Polar(polar_response(result)),
            Answer::Cartesian(still) => {
                let f = &still.footprint;
                let centre = still.half as f64;
                Answer::Cartesian(StillRemovalFunctionResponse {
                    kinematics: CartesianDto::Cartesian,
                    tool_position_mm: still.tool_position_mm,
                    footprint: footprint_dto(f),
                    influence: InfluenceDto {
                        map: MapGridDto {
                            heights_nm: f
                                .rate_nm_per_min
                                .chunks(f.width())
                                .map(|row| row.iter().map(|v| Some(v / 60.0)).collect())
                                .collect(),
                            pixel_mm: Some(f.pixel_mm),
                            wavelength_nm: None,
                        },
                        duration_s: None,
                        centre_px: Some(vec![centre, centre]),
                    },
                })
            }
        }
    }
}

fn polar_response(result: MapRemovalFunction) -> MapRemovalFunctionResponse {
    MapRemovalFunctionResponse {
        kinematics: KinematicsDto::Polar,
        eta: result.average.eta,
        tool_position_mm: result.tool_position_mm,
        footprint: footprint_dto(&result.footprint),
        revolution_average: RevolutionAverageDto {
            radius_mm: result.average.grid.radii_mm().to_vec(),
            removal_rate_nm_per_min: result
                .average
                .profiles
                .into_iter()
                .next()
                .map(|p| p.removal_rate_nm_per_min)
                .unwrap_or_default(),
        },
        warnings: WarningDto::all_at(&result.average.warnings, "tool_position_mm"),
    }
}
