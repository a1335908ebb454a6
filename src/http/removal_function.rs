//! `POST /v1/removal-function`: the removal rate R(r; r1) across the radial grid for each
//! requested tool position.

use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::Response;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::dto::{check_operator_size, ProcessDto, RadialGridDto};
use super::error::{ApiError, ComputeProblems};
use super::extract::ApiJson;
use super::limits::Limits;
use super::plot::{Chart, Series};
use super::{compute_and_render, csv, plot, AppState, Renderers};
use crate::physics::schedule::check_positions;
use crate::physics::RemovalKernel;

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RemovalFunctionRequest {
    /// The polishing process (radii in mm, signed speeds in r/min, CCW positive).
    pub process: ProcessDto,
    /// Tool-centre radii in mm, one profile each (any order; 0 to r_m + r_t under uniform
    /// pressure, 0 to r_m under constant force).
    pub tool_positions_mm: Vec<f64>,
    /// Where to report the profiles; default 201 samples from 0 to the workpiece radius.
    pub radial_grid: Option<RadialGridDto>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct RemovalFunctionResponse {
    /// Speed ratio η = −workpiece_rpm / tool_rpm (paper convention); null when tool_rpm = 0.
    pub eta: Option<f64>,
    /// The radial grid, mm.
    pub radius_mm: Vec<f64>,
    /// One removal profile per requested tool position, in request order.
    pub profiles: Vec<ProfileDto>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct ProfileDto {
    /// Tool-centre radius, mm.
    pub tool_position_mm: f64,
    /// Removal rate at each radius of `radius_mm`, nm/min.
    pub removal_rate_nm_per_min: Vec<f64>,
}

pub fn compute(
    req: &RemovalFunctionRequest,
    limits: &Limits,
) -> Result<RemovalFunctionResponse, ApiError> {
    let process = req.process.to_process()?;
    let grid = RadialGridDto::to_grid(req.radial_grid.as_ref(), &process, limits)?;
    let positions = &req.tool_positions_mm;
    if positions.len() > limits.max_profiles {
        return Err(ApiError::limit(
            "tool_positions_mm",
            format!(
                "tool_positions_mm has {} entries; this server allows at most {} profiles",
                positions.len(),
                limits.max_profiles
            ),
        ));
    }
    check_operator_size(
        limits,
        grid.radii_mm().len(),
        positions.len(),
        "tool_positions_mm",
    )?;
    check_positions(&process, "tool_positions_mm", positions, false)
        .map_err(|e| ApiError::from_schedule("", e))?;

    let kernel = RemovalKernel::new(&process);
    let profiles = positions
        .iter()
        .map(|&r1| {
            let factor = kernel.pressure_factor(r1);
            ProfileDto {
                tool_position_mm: r1,
                removal_rate_nm_per_min: grid
                    .radii_mm()
                    .iter()
                    .map(|&r| 60.0 * factor * kernel.nominal_rate_nm_per_s(r, r1))
                    .collect(),
            }
        })
        .collect();
    Ok(RemovalFunctionResponse {
        eta: process.eta().value(),
        radius_mm: grid.radii_mm().to_vec(),
        profiles,
    })
}

fn to_csv(response: &RemovalFunctionResponse) -> String {
    let mut header = vec!["radius_mm".to_string()];
    header.extend(response.profiles.iter().map(|p| {
        format!(
            "removal_rate_nm_per_min(tool_position_mm={})",
            p.tool_position_mm
        )
    }));
    let mut columns: Vec<&[f64]> = vec![&response.radius_mm];
    columns.extend(
        response
            .profiles
            .iter()
            .map(|p| p.removal_rate_nm_per_min.as_slice()),
    );
    csv::table(&header, &columns)
}

fn to_svg(response: &RemovalFunctionResponse) -> String {
    plot::render(&Chart {
        title: match response.eta {
            Some(eta) => format!("Removal rate R(r; r1) at η = {eta}"),
            None => "Removal rate R(r; r1), tool stationary".to_string(),
        },
        x_label: "radius r (mm)".to_string(),
        y_label: "removal rate (nm/min)".to_string(),
        series: response
            .profiles
            .iter()
            .map(|p| Series {
                name: format!("r1 = {} mm", p.tool_position_mm),
                points: response
                    .radius_mm
                    .iter()
                    .copied()
                    .zip(p.removal_rate_nm_per_min.iter().copied())
                    .collect(),
            })
            .collect(),
        band: None,
        secondary: None,
    })
}

/// Removal rate profiles R(r; r1) of one tool at the given positions.
///
/// Exact closed form (Carlson's elliptic integrals), ~1e-12 relative. `Accept: text/csv`
/// returns one column per profile with a unit header.
#[utoipa::path(
    post,
    path = "/v1/removal-function",
    tag = "removal",
    request_body = RemovalFunctionRequest,
    responses(
        (status = 200, description = "Removal profiles; as CSV, one column per profile; as SVG, a chart", content(
            (RemovalFunctionResponse = "application/json"),
            (String = "text/csv"),
            (String = "image/svg+xml"),
        )),
        ComputeProblems,
    )
)]
pub async fn handler(
    State(state): State<AppState>,
    headers: HeaderMap,
    ApiJson(req): ApiJson<RemovalFunctionRequest>,
) -> Result<Response, ApiError> {
    let renderers = Renderers {
        csv: Some(to_csv),
        svg: Some(to_svg),
    };
    compute_and_render(state, &headers, req, compute, renderers).await
}
