//! `POST /v1/predict`: the cumulative removal of a dwell schedule and its uniformity.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::dto::{
    setting_of, ApertureEcho, ClearApertureDto, DwellDto, FeedDto, MetricsDto, ProcessDto,
    RadialGridDto, RecommendationDto, SurfaceDto, ToolDto, WarningDto,
};
use super::endpoint::{Doc, Endpoint};
use super::error::ApiError;
use super::extract::{object, optional_object, ApiJson};
use super::state::Services;
use crate::report::results;
use crate::usecases::predict::{
    predict, DwellSpec, FeedSpec, PredictCommand, Prediction, TravelSpec,
};
use crate::usecases::ComputeLimits;

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PredictRequest {
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
    /// Tool positions (mm) and the dwell time in each one's cell (s): the tool stops for half
    /// the first and last dwell at the ends and moves at constant speed between the midpoints
    /// of neighbouring positions (the motion `/v1/program` executes). Give exactly one of
    /// `dwell` and `feed`.
    #[serde(default, deserialize_with = "optional_object")]
    pub dwell: Option<DwellDto>,
    /// One constant feed along the surface (along the arc on a curved part) instead of a dwell
    /// plan: equal dwell per unit length, computed exactly (no cells). Give exactly one of
    /// `dwell` and `feed`.
    #[serde(default, deserialize_with = "optional_object")]
    pub feed: Option<FeedDto>,
    /// Where to report removal; default 201 samples from 0 to the workpiece radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
    /// Where uniformity is judged; default the whole workpiece.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<ClearApertureDto>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct PredictResponse {
    /// Speed ratio η = −workpiece_rpm / tool_rpm (paper convention); null when tool_rpm = 0.
    #[schema(required = true)]
    pub eta: Option<f64>,
    /// The radial grid, mm.
    pub radius_mm: Vec<f64>,
    /// Arc length along the surface from the vertex to each radius of `radius_mm`, mm; present
    /// only on a curved surface.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arc_length_mm: Option<Vec<f64>>,
    /// Cumulative removal depth at each radius of `radius_mm`, nm.
    pub removal_nm: Vec<f64>,
    /// Uniformity over the clear aperture.
    pub metrics: MetricsDto,
    /// The clear aperture the metrics were taken over (defaults filled in), mm.
    pub clear_aperture: ApertureEcho,
    /// Polishing time: the sum of the dwell times, or the feed's travel time, s.
    pub total_time_s: f64,
    /// η = −1 settings and what they would buy (equal dwell removing this prediction's mean
    /// depth); null at η = −1.
    #[schema(required = true)]
    pub recommendation: Option<RecommendationDto>,
    /// What the caller should know about this prediction (e.g. positions that look like
    /// metres); empty when nothing.
    pub warnings: Vec<WarningDto>,
}

/// `POST /v1/predict`.
pub struct PredictEndpoint;

impl Endpoint for PredictEndpoint {
    const NAME: &'static str = "predict";
    const EXAMPLE: &'static str = include_str!("../../fixtures/predict_paper_exp2.json");
    const DOC: Doc = Doc {
        operation_id: "predictRemoval",
        tag: "removal",
        summary: "Predict what a dwell schedule removes.",
        description: "Cumulative removal ΔZ(r) = Σ_j R(r; r1_j)·t_j over the radial grid, with uniformity metrics\n\
over the clear aperture. `Accept: text/csv` returns radius and removal columns.",
        ok: "Predicted removal; as CSV, radius and removal columns; as SVG, a chart",
    };
    type Request = PredictRequest;
    type Body = ApiJson<PredictRequest>;
    type Command = PredictCommand;
    type Output = Prediction;
    type Response = PredictResponse;
    const CSV: Option<fn(&Prediction) -> String> = Some(results::prediction_csv);
    const SVG: Option<fn(&Prediction) -> String> = Some(results::prediction_svg);

    fn parse(req: PredictRequest, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let setting = setting_of!(req).parse(limits)?;
        let travel = TravelSpec {
            dwell: req.dwell.map(|d| DwellSpec {
                positions_mm: d.positions_mm,
                dwell_s: d.dwell_s,
            }),
            feed: req.feed.map(|f| FeedSpec {
                start_mm: f.start_mm,
                stop_mm: f.stop_mm,
                feed_mm_per_min: f.feed_mm_per_min,
            }),
        };
        Ok(PredictCommand::new(setting, travel, limits)?)
    }

    fn run(command: Self::Command, services: &Services) -> Result<Prediction, ApiError> {
        Ok(predict(command, &services.recommender, &services.operators))
    }

    fn respond(p: Prediction) -> PredictResponse {
        PredictResponse {
            eta: p.setting.process().eta().value(),
            radius_mm: p.setting.grid().radii_mm().to_vec(),
            arc_length_mm: p
                .setting
                .process()
                .arc_lengths_mm(p.setting.grid().radii_mm()),
            removal_nm: p.removal_nm,
            metrics: MetricsDto::from(&p.metrics),
            clear_aperture: ApertureEcho::from(p.setting.aperture()),
            total_time_s: p.total_time_s,
            recommendation: p.recommendation.as_ref().map(RecommendationDto::from),
            warnings: p
                .warnings
                .iter()
                .map(|w| WarningDto::new(w, "dwell.positions_mm"))
                .collect(),
        }
    }
}
