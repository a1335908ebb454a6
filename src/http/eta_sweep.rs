//! `POST /v1/studies/eta-sweep`: uniformity against η with the tool speed held.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::dto::{
    setting_of, ApertureEcho, ClearApertureDto, DwellDto, MetricsDto, ProcessDto, RadialGridDto,
    SurfaceDto, ToolDto, WarningDto,
};
use super::endpoint::{Doc, Endpoint};
use super::error::ApiError;
use super::extract::{object, optional_object, ApiJson};

use super::state::Services;
use crate::report::results;
use crate::usecases::eta_sweep::{eta_sweep, EtaSweep, EtaSweepCommand};
use crate::usecases::ComputeLimits;

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct EtaSweepRequest {
    /// The process; its `tool_rpm` (≠ 0) is held and its `workpiece_rpm` is replaced by
    /// −η·tool_rpm at each point.
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
    /// η values (paper convention, η = −workpiece_rpm / tool_rpm), each finite and ≠ 0; at
    /// most 201. Computed in parallel.
    #[schema(example = json!([-0.05, -0.25, -0.5, -0.75, -1.0, -1.25, -1.5]))]
    #[schema(min_items = 1)]
    pub etas: Vec<f64>,
    /// A dwell schedule used at every point; default equal dwell (a constant feed from 0 to
    /// min(outer + r_t, reach) mm).
    #[serde(default, deserialize_with = "optional_object")]
    pub dwell: Option<DwellDto>,
    /// Mean depth equal dwell removes at each point, nm (1e-6 to 1e9). Default 100. Ignored
    /// with `dwell`.
    #[schema(minimum = 1e-6, maximum = 1e9)]
    pub depth_nm: Option<f64>,
    /// Where removal is computed; default 201 samples from 0 to the workpiece radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
    /// Where uniformity is judged; default the whole workpiece.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<ClearApertureDto>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct EtaSweepResponse {
    /// The tool speed held, r/min (signed, CCW positive).
    pub tool_rpm: f64,
    /// The clear aperture used (defaults filled in), mm.
    pub clear_aperture: ApertureEcho,
    /// One point per requested η, in request order.
    pub points: Vec<SweepPointDto>,
    /// What looks wrong in the input though it is valid (radii that look like metres, a
    /// pressure that looks like pascals); empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
}

/// Uniformity at one η.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct SweepPointDto {
    /// η (paper convention).
    pub eta: f64,
    /// The workpiece speed it implies, −η·tool_rpm, r/min (signed, CCW positive).
    pub workpiece_rpm: f64,
    /// Uniformity over the clear aperture, nm.
    pub metrics: MetricsDto,
}

/// `POST /v1/studies/eta-sweep`.
pub struct EtaSweepEndpoint;

impl Endpoint for EtaSweepEndpoint {
    const NAME: &'static str = "studies/eta-sweep";
    const EXAMPLE: &'static str = include_str!("../../fixtures/eta_sweep_figure7.json");
    const DOC: Doc = Doc {
        operation_id: "sweepEta",
        tag: "recommend",
        summary: "Sweep η with the tool speed held.",
        description: "For each η, the workpiece turns at −η·tool_rpm and the uniformity of equal dwell (or of the\n\
given dwell schedule) over the clear aperture is reported. `Accept: text/csv` gives a table,\n\
`Accept: image/svg+xml` a chart of nonuniformity against η.",
        ok: "One point per η; as CSV a table, as SVG a chart",
    };
    type Request = EtaSweepRequest;
    type Body = ApiJson<EtaSweepRequest>;
    type Command = EtaSweepCommand;
    type Output = EtaSweep;
    type Response = EtaSweepResponse;
    const CSV: Option<fn(&EtaSweep) -> String> = Some(results::eta_sweep_csv);
    const SVG: Option<fn(&EtaSweep) -> String> = Some(results::eta_sweep_svg);

    fn parse(req: EtaSweepRequest, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let setting = setting_of!(req).parse(limits)?;
        Ok(EtaSweepCommand::new(
            setting,
            req.etas,
            req.dwell.map(|d| (d.positions_mm, d.dwell_s)),
            req.depth_nm,
            limits,
        )?)
    }

    fn run(command: Self::Command, _: &Services) -> Result<EtaSweep, ApiError> {
        Ok(eta_sweep(command)?)
    }

    fn respond(sweep: EtaSweep) -> EtaSweepResponse {
        EtaSweepResponse {
            tool_rpm: sweep.tool_rpm,
            clear_aperture: ApertureEcho::from(sweep.setting.aperture()),
            points: sweep
                .points
                .iter()
                .map(|p| SweepPointDto {
                    eta: p.eta,
                    workpiece_rpm: p.workpiece_rpm,
                    metrics: MetricsDto::from(&p.metrics),
                })
                .collect(),
            warnings: WarningDto::all(&sweep.warnings),
        }
    }
}
