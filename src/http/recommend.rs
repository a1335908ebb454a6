//! `POST /v1/recommend`: η = −1 speeds for the user's process, what they buy under equal dwell,
//! and the η window around −1. The same `recommendation` object (`dto::RecommendationDto`)
//! rides along in predict and optimize responses whenever η ≠ −1.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::dto::{
    setting_of, ClearApertureDto, ProcessDto, RadialGridDto, RecommendationDto, SurfaceDto,
    ToolDto, WarningDto,
};
use super::endpoint::{Doc, Endpoint};
use super::error::ApiError;
use super::extract::{object, optional_object, ApiJson};

use super::state::Services;
use crate::study::SpeedLimits;
use crate::usecases::recommend::{recommend, RecommendCommand, Recommended};
use crate::usecases::ComputeLimits;

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RecommendRequest {
    /// The user's current process (radii in mm, signed speeds in r/min, CCW positive).
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
    /// The machine's speed limits; default none.
    #[serde(default, deserialize_with = "optional_object")]
    pub limits: Option<SpeedLimitsDto>,
    /// Mean depth the equal-dwell plans remove over the clear aperture, nm (1e-6 to 1e9).
    /// Default 100.
    #[schema(minimum = 1e-6, maximum = 1e9)]
    pub depth_nm: Option<f64>,
    /// Largest equal-dwell nonuniformity (pv/mean, a fraction) inside the η window, > 0.
    /// Default 0.02.
    pub nonuniformity_threshold: Option<f64>,
    /// Where removal is computed; default 201 samples from 0 to the workpiece radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
    /// Where uniformity is judged; default the whole workpiece.
    #[serde(default, deserialize_with = "optional_object")]
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
    /// What looks wrong in the input though it is valid (radii that look like metres, a
    /// pressure that looks like pascals); empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
}

/// `POST /v1/recommend`.
pub struct RecommendEndpoint;

impl Endpoint for RecommendEndpoint {
    const NAME: &'static str = "recommend";
    const EXAMPLE: &'static str = include_str!("../../fixtures/recommend_paper_exp1.json");
    const DOC: Doc = Doc {
        operation_id: "recommendSpeeds",
        tag: "recommend",
        summary: "Recommend η = −1 speeds.",
        description: "From the user's process (and the machine's speed limits), recommends workpiece and tool\n\
turning the same way at the same speed (η = −1), chosen to keep the current mean removal\n\
rate over the clear aperture where the limits allow, else the fastest allowed. Compares\n\
equal dwell at both settings for the same depth and reports the η window around −1 within\n\
which equal-dwell nonuniformity stays at or below the threshold (found by root finding on\n\
the model).",
        ok: "The recommendation",
    };
    type Request = RecommendRequest;
    type Body = ApiJson<RecommendRequest>;
    type Command = RecommendCommand;
    type Output = Recommended;
    type Response = RecommendResponse;

    fn parse(req: RecommendRequest, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let setting = setting_of!(req).parse(limits)?;
        let speed = req.limits.unwrap_or_default();
        let speed = SpeedLimits::new(speed.max_workpiece_rpm, speed.max_tool_rpm)?;
        Ok(RecommendCommand::new(
            setting,
            speed,
            req.depth_nm,
            req.nonuniformity_threshold,
        )?)
    }

    fn run(command: Self::Command, services: &Services) -> Result<Recommended, ApiError> {
        Ok(recommend(&command, &services.recommender)?)
    }

    fn respond(r: Recommended) -> RecommendResponse {
        RecommendResponse {
            recommendation: RecommendationDto::from(&r.recommendation),
            warnings: WarningDto::all(&r.warnings),
        }
    }
}
