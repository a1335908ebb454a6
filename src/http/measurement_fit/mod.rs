//! `POST /v1/measurement/fit`: fit an on-machine probe trace to the design surface; the form
//! error comes back as a `/v1/optimize` target. The body is JSON, or the probe's own
//! `text/csv` export (`x_mm,z_mm` columns) with the other fields as query parameters.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

mod csv_query;

pub use csv_query::CsvQuery;

use super::csv_body::{self, CsvOrJson};
use super::dto::{ApertureEcho, ClearApertureDto, RadialGridDto, SurfaceDto, WarningDto};
use super::endpoint::{Doc, Endpoint};
use super::error::ApiError;
use super::extract::{object, optional_object};
use super::optimize::{MeasuredProfileDto, TargetDto};
use super::state::Services;
use crate::metrology::{Compensation, Parameter, PointResidual, RobustLoss, NM_PER_MM};
use crate::report::results;
use crate::usecases::measurement_fit::{
    measurement_fit, AlignmentSelection, MeasurementFit, MeasurementFitCommand, MeasurementFitSpec,
};
use crate::usecases::{ApertureSpec, ComputeLimits, GridSpec};
use utoipa::openapi::path::Operation;
use utoipa::IntoParams;

/// A meridian trace in machine coordinates, mm: X across the spindle axis (both sides
/// allowed, any order), Z along it, positive toward the tool.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TraceDto {
    /// X of each point, mm (|x| ≤ 1,000,000).
    #[schema(min_items = 2)]
    pub x_mm: Vec<f64>,
    /// Z of each point, mm (as many as x_mm; |z| ≤ 1,000,000).
    #[schema(min_items = 2)]
    pub z_mm: Vec<f64>,
}

/// How the probe-tip radius is taken out: `normal` (the tip centre sits on the surface normal;
/// exact for a ball) or `axial` (the radius subtracted from Z, which errs on slopes).
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CompensationDto {
    #[default]
    Normal,
    Axial,
}

/// A robust loss: `none` (least squares, the paper's eq. 3), `huber` (weight 1 within
/// 1.345·σ̂, then 1.345·σ̂/|e|) or `tukey` (weight (1 − (e/4.685σ̂)²)² within 4.685·σ̂, 0 beyond:
/// spikes and dust ignored); σ̂ = 1.4826·median|e|, re-estimated as the weights settle.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RobustDto {
    #[default]
    None,
    Huber,
    Tukey,
}

impl RobustDto {
    pub fn loss(self) -> RobustLoss {
        match self {
            RobustDto::None => RobustLoss::None,
            RobustDto::Huber => RobustLoss::Huber,
            RobustDto::Tukey => RobustLoss::Tukey,
        }
    }
}

/// Which parameters to fit. Defaults: lateral offset, tilt and piston, less what the surface
/// cannot determine (a plane has no lateral position; on a sphere a tilt is a lateral offset,
/// so tilt is left out); not the radius.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FitSelectionDto {
    /// ΔX, the part's offset from the spindle axis.
    pub lateral_offset: Option<bool>,
    /// Δτ, the trace's tilt.
    pub tilt: Option<bool>,
    /// Δz, the probe's zero.
    pub piston: Option<bool>,
    /// The vertex radius of curvature (conic and polynomial terms held).
    pub radius_of_curvature: Option<bool>,
}

#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MeasurementFitRequest {
    /// The design surface; default a plane.
    #[serde(default, deserialize_with = "optional_object")]
    pub surface: Option<SurfaceDto>,
    /// The measured trace.
    #[serde(deserialize_with = "object")]
    pub profile: TraceDto,
    /// Probe-tip (ball) radius, mm (0 to 100000). Default 0; > 0 means the points are tip
    /// centres.
    #[schema(minimum = 0.0, maximum = 100000.0)]
    pub probe_tip_radius_mm: Option<f64>,
    /// How the tip radius is compensated. Default `normal`.
    pub compensation: Option<CompensationDto>,
    /// Which parameters to fit.
    #[serde(default, deserialize_with = "optional_object")]
    pub fit: Option<FitSelectionDto>,
    /// Robust loss. Default `none`.
    pub robust: Option<RobustDto>,
    /// Where the radial form-error profile is reported (≥ 2 samples); default 201 samples over
    /// the radii the trace covers (from the axis out when it crosses the axis).
    #[serde(default, deserialize_with = "optional_object")]
    pub radial_grid: Option<RadialGridDto>,
    /// Where the form error's RMS and PV are taken; default the grid's span.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<ClearApertureDto>,
}

/// The fitted placement of the part.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct AlignmentDto {
    /// ΔX, mm (seed eq. 2: X′ = X·cos Δτ − Z·sin Δτ − ΔX).
    pub lateral_offset_mm: f64,
    /// Δτ, rad.
    pub tilt_rad: f64,
    /// Δz, mm (Z′ = X·sin Δτ + Z·cos Δτ − Δz).
    pub piston_mm: f64,
    /// The vertex radius the residuals refer to (fitted or the design's), mm; null on a plane.
    #[schema(required = true)]
    pub radius_of_curvature_mm: Option<f64>,
}

/// One standard error per alignment parameter; null for a parameter held fixed.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct StandardErrorsDto {
    /// Of ΔX, mm.
    #[schema(required = true)]
    pub lateral_offset_mm: Option<f64>,
    /// Of Δτ, rad.
    #[schema(required = true)]
    pub tilt_rad: Option<f64>,
    /// Of Δz, mm.
    #[schema(required = true)]
    pub piston_mm: Option<f64>,
    /// Of the vertex radius, mm (from the curvature's by the delta method).
    #[schema(required = true)]
    pub radius_of_curvature_mm: Option<f64>,
}

/// The parameters that were fitted (defaults filled in).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct FittedDto {
    /// ΔX was fitted.
    pub lateral_offset: bool,
    /// Δτ was fitted.
    pub tilt: bool,
    /// Δz was fitted.
    pub piston: bool,
    /// The vertex radius was fitted.
    pub radius_of_curvature: bool,
}

/// Per-point residuals, in the order of the request's points.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct PointResidualsDto {
    /// X as measured, mm.
    pub x_mm: Vec<f64>,
    /// Z as measured, mm.
    pub z_mm: Vec<f64>,
    /// X′, the point in the part's frame, mm.
    pub aligned_x_mm: Vec<f64>,
    /// Where the probe touches the design (signed radius), mm.
    pub contact_x_mm: Vec<f64>,
    /// e = Z′ − z(X′) along the axis, nm (> 0: material proud of the design).
    pub axial_nm: Vec<f64>,
    /// The residual along the surface normal, nm.
    pub normal_nm: Vec<f64>,
    /// Each point's weight in the fit (1 without a robust loss; 0 = ignored).
    pub weight: Vec<f64>,
}

/// The form error over the clear aperture (points the fit kept).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct FormErrorDto {
    /// √(Σe²/n) of the axial residual (seed eq. 3), nm.
    pub rms_nm: f64,
    /// Peak to valley of the axial residual, nm.
    pub pv_nm: f64,
    /// Points inside the clear aperture with weight > 0.
    #[schema(format = Int32)]
    pub points: usize,
    /// RMS difference between the two sides of the axis on the radial grid, nm: form error a
    /// rotationally symmetric process cannot correct. Null unless the trace covers both sides
    /// at two grid radii or more.
    #[schema(required = true)]
    pub asymmetry_rms_nm: Option<f64>,
}

/// The radial form-error profile: the normal residual of both sides averaged.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct FormProfileDto {
    /// Radius, mm.
    pub radius_mm: Vec<f64>,
    /// Material to remove along the normal, nm (> 0 = proud).
    pub depth_nm: Vec<f64>,
}

/// How the fit went.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema, PartialEq)]
pub struct FitReportDto {
    /// Levenberg–Marquardt steps, over all reweightings.
    #[schema(format = Int32)]
    pub iterations: usize,
    /// Rounds of robust reweighting (0 without a robust loss).
    #[schema(format = Int32)]
    pub reweightings: usize,
    /// The robust scale σ̂ at the final weights, nm; null without a robust loss.
    #[schema(required = true)]
    pub robust_scale_nm: Option<f64>,
    /// Points the fit ignored (weight 0).
    #[schema(format = Int32)]
    pub ignored_points: usize,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct MeasurementFitResponse {
    /// The fitted placement of the trace (seed eq. 2), and the radius used.
    pub alignment: AlignmentDto,
    /// Standard errors of the alignment, from the Jacobian at the solution:
    /// √(σ²·(JᵀWJ)⁻¹ⱼⱼ), σ² = Σwe²/(n − parameters).
    pub standard_errors: StandardErrorsDto,
    /// Which parameters were fitted (defaults filled in).
    pub fitted: FittedDto,
    /// Per-point residuals, in the request's order.
    pub residual: PointResidualsDto,
    /// RMS and PV of the form error over the clear aperture, and the asymmetry.
    pub form_error: FormErrorDto,
    /// The radial form-error profile on the radial grid.
    pub profile: FormProfileDto,
    /// The clear aperture the form error was taken over, mm.
    pub clear_aperture: ApertureEcho,
    /// The `target` of a `/v1/optimize` request that removes this form error: the profile with
    /// a free piston (polishing only removes, so the least uniform layer is added).
    pub correction_target: TargetDto,
    /// How the fit went.
    pub solver: FitReportDto,
    /// Only when the request gave no `surface` (a plane was fitted): the sphere that fits the
    /// trace best, beside the plane's `form_error`; null when a surface was given, the trace
    /// is flat (R beyond 10 km) or no sphere holds it.
    #[schema(required = true)]
    pub best_fit_sphere: Option<BestFitSphereDto>,
    /// `surface_assumed_plane` when no surface was given; empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
}

/// A sphere fitted to the trace with its vertex radius, lateral offset and piston free.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct BestFitSphereDto {
    /// Vertex radius of curvature, mm (> 0 concave as the tool sees it).
    pub radius_of_curvature_mm: f64,
    /// RMS of the axial residual on that sphere, nm (over the points the fit kept).
    pub residual_rms_nm: f64,
}

/// `POST /v1/measurement/fit`.
pub struct MeasurementFitEndpoint;

impl Endpoint for MeasurementFitEndpoint {
    const NAME: &'static str = "measurement/fit";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/measurement_fit_asphere.json");
    const DOC: Doc = Doc {
        operation_id: "fitMeasurement",
        tag: "metrology",
        summary: "Fit a probe trace to the design surface (on-machine measurement).",
        description: "Finds the lateral offset ΔX, tilt Δτ and piston Δz of the trace (optionally the vertex\n\
radius) minimising the RMS axial residual, by Levenberg–Marquardt on analytic derivatives\n\
(optionally robust), and returns the per-point residuals, the form error's RMS and PV, the\n\
radial form-error profile (both sides of the axis averaged) and a ready `/v1/optimize`\n\
target. The body may be JSON, or `text/csv` with `x_mm,z_mm` columns and the other fields\n\
as query parameters. `Accept: text/csv` returns the residual table; `image/svg+xml` a chart.",
        ok: "The alignment, residuals, form error and correction target; as CSV, the residual table; as SVG, a chart",
    };
    type Request = MeasurementFitRequest;
    type Body = CsvOrJson<MeasurementFitRequest>;
    type Command = MeasurementFitCommand;
    type Output = MeasurementFit;
    type Response = MeasurementFitResponse;
    const CSV: Option<fn(&MeasurementFit) -> String> = Some(results::measurement_fit_csv);
    const SVG: Option<fn(&MeasurementFit) -> String> = Some(results::measurement_fit_svg);

    /// The body may also be the probe's `text/csv` export, with the other fields in the query.
    fn document(operation: &mut Operation) {
        let example = "x_mm,z_mm\n-10.0,0.1667\n0.0,0.0\n10.0,0.1667\n";
        csv_body::document(operation, example, CsvQuery::into_params(|| None));
    }

    fn parse(req: Self::Request, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let fit = req.fit.unwrap_or_default();
        let spec = MeasurementFitSpec {
            surface: super::dto::round_surface(req.surface.as_ref())?,
            x_mm: req.profile.x_mm,
            z_mm: req.profile.z_mm,
            probe_tip_radius_mm: req.probe_tip_radius_mm,
            compensation: req.compensation.map(|c| match c {
                CompensationDto::Normal => Compensation::Normal,
                CompensationDto::Axial => Compensation::Axial,
            }),
            fit: AlignmentSelection {
                lateral_offset: fit.lateral_offset,
                tilt: fit.tilt,
                piston: fit.piston,
                radius_of_curvature: fit.radius_of_curvature,
            },
            robust: req.robust.map(RobustDto::loss),
            grid: GridSpec::from(req.radial_grid.as_ref()),
            aperture: ApertureSpec::from(req.clear_aperture.as_ref()),
        };
        Ok(MeasurementFitCommand::new(spec, limits)?)
    }

    fn run(command: Self::Command, _: &Services) -> Result<MeasurementFit, ApiError> {
        Ok(measurement_fit(command)?)
    }

    fn respond(m: MeasurementFit) -> MeasurementFitResponse {
        let points = &m.outcome.points;
        let column = |f: fn(&PointResidual) -> f64| -> Vec<f64> { points.iter().map(f).collect() };
        let se = m.outcome.standard_errors;
        let profile = FormProfileDto {
            radius_mm: m.profile.depth.radius_mm.clone(),
            depth_nm: m.profile.depth.depth_nm.clone(),
        };
        MeasurementFitResponse {
            alignment: AlignmentDto {
                lateral_offset_mm: m.outcome.alignment.lateral_offset_mm,
                tilt_rad: m.outcome.alignment.tilt_rad,
                piston_mm: m.outcome.alignment.piston_mm,
                radius_of_curvature_mm: m.outcome.alignment.surface.radius_of_curvature_mm(),
            },
            standard_errors: StandardErrorsDto {
                lateral_offset_mm: se.lateral_offset_mm,
                tilt_rad: se.tilt_rad,
                piston_mm: se.piston_mm,
                radius_of_curvature_mm: se.radius_of_curvature_mm,
            },
            fitted: FittedDto {
                lateral_offset: m.fitted.contains(Parameter::LateralOffset),
                tilt: m.fitted.contains(Parameter::Tilt),
                piston: m.fitted.contains(Parameter::Piston),
                radius_of_curvature: m.fitted.contains(Parameter::RadiusOfCurvature),
            },
            residual: PointResidualsDto {
                x_mm: column(|p| p.x_mm),
                z_mm: column(|p| p.z_mm),
                aligned_x_mm: column(|p| p.aligned_x_mm),
                contact_x_mm: column(|p| p.contact_mm),
                axial_nm: column(PointResidual::axial_nm),
                normal_nm: column(PointResidual::normal_nm),
                weight: column(|p| p.weight),
            },
            form_error: FormErrorDto {
                rms_nm: m.form_error.rms_nm,
                pv_nm: m.form_error.pv_nm,
                points: m.form_error.points,
                asymmetry_rms_nm: m.profile.asymmetry_rms_nm,
            },
            correction_target: TargetDto {
                uniform_depth_nm: None,
                profile: Some(MeasuredProfileDto {
                    radius_mm: profile.radius_mm.clone(),
                    depth_nm: profile.depth_nm.clone(),
                }),
                free_piston: Some(true),
            },
            profile,
            clear_aperture: ApertureEcho::from(&m.aperture),
            solver: FitReportDto {
                iterations: m.outcome.iterations,
                reweightings: m.outcome.reweightings,
                robust_scale_nm: m.outcome.robust_scale_mm.map(|s| s * NM_PER_MM),
                ignored_points: points.iter().filter(|p| p.weight == 0.0).count(),
            },
            best_fit_sphere: m.best_fit_sphere.map(|s| BestFitSphereDto {
                radius_of_curvature_mm: s.radius_of_curvature_mm,
                residual_rms_nm: s.residual_rms_nm,
            }),
            warnings: WarningDto::all(&m.warnings),
        }
    }
}
