//! `POST /v1/removal-function`: the removal rate R(r; r1) across the radial grid for each
//! requested tool position.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::dto::{part_spec, ProcessDto, RadialGridDto, SurfaceDto, ToolDto, WarningDto};
use super::endpoint::{Doc, Endpoint};
use super::error::ApiError;
use super::extract::{object, optional_object, ApiJson};

use super::state::Services;
use crate::report::results;
use crate::usecases::removal_function::{
    removal_function, RemovalFunction, RemovalFunctionCommand,
};
use crate::usecases::ComputeLimits;

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RemovalFunctionRequest {
    /// The polishing process (radii in mm, signed speeds in r/min, CCW positive).
    #[serde(deserialize_with = "object")]
    pub process: ProcessDto,
    /// The part's surface; default a plane. Positions and radial grids are radial coordinates
    /// (distance from the axis, mm) of surface points; removal is along the surface normal,
    /// computed for a pad that conforms to the surface (see the model documentation).
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// The pad's spin axis: `tool.orientation` `normal` (default; along the surface normal at
    /// the pad centre) or `vertical` (parallel to the workpiece axis). Only the orientation
    /// matters here.
    #[serde(default, deserialize_with = "optional_object")]
    pub tool: Option<ToolDto>,
    /// Tool-centre radii in mm, one profile each (any order; within the reach
    /// `process.pressure_model` gives).
    #[schema(min_items = 1)]
    pub tool_positions_mm: Vec<f64>,
    /// Where to report the profiles; default 201 samples from 0 to the workpiece radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RemovalFunctionResponse {
    /// Speed ratio η = −workpiece_rpm / tool_rpm (paper convention); null when tool_rpm = 0.
    #[schema(required = true)]
    pub eta: Option<f64>,
    /// The radial grid, mm.
    pub radius_mm: Vec<f64>,
    /// Arc length along the surface from the vertex to each radius of `radius_mm`, mm; present
    /// only on a curved surface.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arc_length_mm: Option<Vec<f64>>,
    /// One removal profile per requested tool position, in request order.
    pub profiles: Vec<ProfileDto>,
    /// What looks wrong in the input though it is valid (radii or positions that look like metres, a
    /// pressure that looks like pascals); empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct ProfileDto {
    /// Tool-centre radius, mm.
    pub tool_position_mm: f64,
    /// Removal rate at each radius of `radius_mm`, nm/min.
    pub removal_rate_nm_per_min: Vec<f64>,
}

/// `POST /v1/removal-function`.
pub struct RemovalFunctionEndpoint;

impl Endpoint for RemovalFunctionEndpoint {
    const NAME: &'static str = "removal-function";
    const EXAMPLE: &'static str = include_str!("../../fixtures/removal_function_paper_exp1.json");
    const DOC: Doc = Doc {
        operation_id: "computeRemovalFunction",
        tag: "removal",
        summary: "Removal rate profiles R(r; r1) of one tool at the given positions.",
        description: "Exact closed form (Carlson's elliptic integrals), ~1e-12 relative. `Accept: text/csv`\n\
returns one column per profile with a unit header.",
        ok: "Removal profiles; as CSV, one column per profile; as SVG, a chart",
    };
    type Request = RemovalFunctionRequest;
    type Body = ApiJson<RemovalFunctionRequest>;
    type Command = RemovalFunctionCommand;
    type Output = RemovalFunction;
    type Response = RemovalFunctionResponse;
    const CSV: Option<fn(&RemovalFunction) -> String> = Some(results::removal_function_csv);
    const SVG: Option<fn(&RemovalFunction) -> String> = Some(results::removal_function_svg);

    fn parse(
        req: RemovalFunctionRequest,
        limits: &ComputeLimits,
    ) -> Result<Self::Command, ApiError> {
        Ok(RemovalFunctionCommand::new(
            req.process.spec()?,
            &part_spec(req.surface.as_ref(), req.tool.as_ref())?,
            req.radial_grid.as_ref().into(),
            req.tool_positions_mm,
            limits,
        )?)
    }

    fn run(command: Self::Command, _: &Services) -> Result<RemovalFunction, ApiError> {
        Ok(removal_function(command))
    }

    fn respond(result: RemovalFunction) -> RemovalFunctionResponse {
        RemovalFunctionResponse {
            eta: result.eta,
            radius_mm: result.grid.radii_mm().to_vec(),
            arc_length_mm: result.arc_length_mm,
            profiles: result
                .profiles
                .into_iter()
                .map(|p| ProfileDto {
                    tool_position_mm: p.tool_position_mm,
                    removal_rate_nm_per_min: p.removal_rate_nm_per_min,
                })
                .collect(),
            warnings: WarningDto::all_at(&result.warnings, "tool_positions_mm"),
        }
    }
}
