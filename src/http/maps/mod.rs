//! `POST /v1/maps/analysis`: an interferometer map analysed as metrologists do.

pub mod body;
pub mod difference;
pub mod optimize;
pub mod predict;
pub mod program;
pub mod raster;
pub mod raster_program;
pub mod removal_function;

use serde::{Deserialize, Serialize};
use utoipa::openapi::path::Operation;
use utoipa::ToSchema;

use self::body::{MapForm, MapOrJson, MapSource};
use super::dto::WarningDto;
use super::endpoint::{Doc, Endpoint, Picture};
use super::error::ApiError;
use super::extract::{optional_count, optional_object};
use super::optimize::{MeasuredProfileDto, TargetDto};
use super::state::Services;
use crate::maps::analysis::{Band, Window};
use crate::maps::aperture::Aperture;
use crate::maps::zernike::{Normalization, Ordering};
use crate::maps::Format;
use crate::report::results;
use crate::usecases::map_analysis::{
    map_analysis, MapAnalysisCommand, MapAnalysisResult, MapAnalysisSpec, MapOrigin, Placement,
};
use crate::usecases::ComputeLimits;

/// Where the part sits on the map and how the map turns into the machine's C frame.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapAlignmentDto {
    /// The part's centre: column, pixels from the left (fractional; the first pixel's centre
    /// is 0). Default: fitted to the valid pixels' outer boundary.
    pub centre_x_px: Option<f64>,
    /// The part's centre: row, pixels from the top. Default: fitted.
    pub centre_y_px: Option<f64>,
    /// The part's radius, mm (> 0). Default: fitted.
    pub part_radius_mm: Option<f64>,
    /// Counter-clockwise rotation from the map's frame (x right, y up) into the C frame,
    /// degrees. Default 0.
    pub rotation_deg: Option<f64>,
    /// Flip x before rotating (a map seen through a fold, or from behind). Default false.
    pub mirror: Option<bool>,
}

/// The clear aperture, in the part's C frame (mm, origin at the part's centre, y up).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema)]
#[serde(tag = "shape", rename_all = "snake_case", deny_unknown_fields)]
pub enum MapApertureDto {
    /// A circle about the part's centre.
    Circle { radius_mm: f64 },
    /// A ring about the part's centre, inner < ρ ≤ outer.
    Annulus {
        inner_radius_mm: f64,
        outer_radius_mm: f64,
    },
    /// A rectangle, sides along x and y of the C frame.
    Rectangle {
        #[serde(default)]
        centre_x_mm: f64,
        #[serde(default)]
        centre_y_mm: f64,
        width_mm: f64,
        height_mm: f64,
    },
    /// A circle anywhere: an off-axis segment's aperture.
    OffCentreCircle {
        centre_x_mm: f64,
        centre_y_mm: f64,
        radius_mm: f64,
    },
}

impl MapAlignmentDto {
    /// The placement it asks for, with the pixel pitch given beside it.
    pub fn placement(self, pixel_mm: Option<f64>) -> Result<Placement, ApiError> {
        let centre_px = match (self.centre_x_px, self.centre_y_px) {
            (Some(x), Some(y)) => Some((x, y)),
            (None, None) => None,
            _ => {
                return Err(ApiError::invalid(
                    "alignment.centre_x_px",
                    "give both centre_x_px and centre_y_px, or neither (fitted)",
                ))
            }
        };
        Ok(Placement {
            pixel_mm,
            centre_px,
            part_radius_mm: self.part_radius_mm,
            rotation_deg: self.rotation_deg,
            mirror: self.mirror,
        })
    }
}

impl From<MapApertureDto> for Aperture {
    fn from(a: MapApertureDto) -> Self {
        match a {
            MapApertureDto::Circle { radius_mm } => Aperture::Circle { radius_mm },
            MapApertureDto::Annulus {
                inner_radius_mm,
                outer_radius_mm,
            } => Aperture::Annulus {
                inner_radius_mm,
                outer_radius_mm,
            },
            MapApertureDto::Rectangle {
                centre_x_mm,
                centre_y_mm,
                width_mm,
                height_mm,
            } => Aperture::Rectangle {
                centre_x_mm,
                centre_y_mm,
                width_mm,
                height_mm,
            },
            MapApertureDto::OffCentreCircle {
                centre_x_mm,
                centre_y_mm,
                radius_mm,
            } => Aperture::OffCentreCircle {
                centre_x_mm,
                centre_y_mm,
                radius_mm,
            },
        }
    }
}

impl From<Aperture> for MapApertureDto {
    fn from(a: Aperture) -> Self {
        match a {
            Aperture::Circle { radius_mm } => MapApertureDto::Circle { radius_mm },
            Aperture::Annulus {
                inner_radius_mm,
                outer_radius_mm,
            } => MapApertureDto::Annulus {
                inner_radius_mm,
                outer_radius_mm,
            },
            Aperture::Rectangle {
                centre_x_mm,
                centre_y_mm,
                width_mm,
                height_mm,
            } => MapApertureDto::Rectangle {
                centre_x_mm,
                centre_y_mm,
                width_mm,
                height_mm,
            },
            Aperture::OffCentreCircle {
                centre_x_mm,
                centre_y_mm,
                radius_mm,
            } => MapApertureDto::OffCentreCircle {
                centre_x_mm,
                centre_y_mm,
                radius_mm,
            },
        }
    }
}

/// How Zernike terms are numbered.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum OrderingDto {
    /// Zygo and Code V, from 1; 37 terms, the 37th (12, 0).
    Fringe,
    /// Zemax "Standard", from 1.
    Noll,
    /// ANSI Z80.28 / OSA, from 0.
    Ansi,
}

/// How each Zernike term is scaled.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum NormalizationDto {
    /// RMS 1 over the unit disc: coefficients add in quadrature.
    UnitRms,
    /// ±1 at the edge (Zygo's Fringe coefficients).
    Peak,
}

/// The Zernike fit asked for.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ZernikeOptionsDto {
    /// Default `fringe`.
    pub ordering: Option<OrderingDto>,
    /// Default `unit_rms`.
    pub normalization: Option<NormalizationDto>,
    /// The first this many terms of the ordering: 1 to 37 (Fringe) or 231 (Noll, ANSI, all
    /// terms through n = 20). Default 37.
    #[schema(minimum = 1, maximum = 231)]
    #[serde(default, deserialize_with = "optional_count")]
    pub terms: Option<usize>,
}

/// A band of spatial frequencies: low ≤ |f| < high.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct BandDto {
    /// What to call it.
    pub name: String,
    /// Per mm (≥ 0).
    pub low_per_mm: f64,
    /// Per mm (> low).
    pub high_per_mm: f64,
}

/// The PSD asked for.
#[derive(Debug, Clone, Default, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PsdOptionsDto {
    /// The bands whose RMS to report (1 to 16). Default, for an aperture of diameter D and
    /// pixel pitch p: `figure` below 10/D, `mid_spatial` to 1/(10p), `high` to 1/p.
    pub bands: Option<Vec<BandDto>>,
}

#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapAnalysisRequest {
    /// The map: rows of heights. Or send the file itself as the body and the other fields as
    /// query parameters.
    #[serde(default)]
    #[schema(required = true)]
    pub map: MapSource,
    /// Pixel pitch, mm (> 0, the map at most 100 m across). Default: the file's; required
    /// when it states none.
    pub pixel_mm: Option<f64>,
    /// Where the part sits. Default: fitted.
    #[serde(default, deserialize_with = "optional_object")]
    pub alignment: Option<MapAlignmentDto>,
    /// The clear aperture. Default: a circle of the part's radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<MapApertureDto>,
    /// Remove power (defocus) too, not only piston and tilt. Default false.
    pub remove_power: Option<bool>,
    /// The Zernike fit. Default: 37 Fringe terms, unit RMS.
    #[serde(default, deserialize_with = "optional_object")]
    pub zernike: Option<ZernikeOptionsDto>,
    /// The PSD's bands.
    #[serde(default, deserialize_with = "optional_object")]
    pub psd: Option<PsdOptionsDto>,
    /// Wavelength for the ISO figures in fringes (a fringe = λ/2 of height), nm (> 0).
    /// Default: the map's, else 546.07.
    pub fringe_wavelength_nm: Option<f64>,
}

impl MapForm for MapAnalysisRequest {
    const FILES: &'static [&'static str] = &["map"];
    const QUERY_FIELDS: &'static [&'static str] = &[
        "pixel_mm",
        "alignment",
        "clear_aperture",
        "remove_power",
        "zernike",
        "psd",
        "fringe_wavelength_nm",
    ];

    fn set_file(&mut self, _: &str, bytes: axum::body::Bytes) {
        self.map = MapSource::File(bytes);
    }
}

/// What was read.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct MapInfoDto {
    /// `metropro_dat`, `zygo_text`, `codev_int`, `text_grid` or `json`.
    pub format: &'static str,
    /// Pixels per row.
    pub width_px: usize,
    /// Rows.
    pub height_px: usize,
    /// Pixels holding a height.
    pub valid_pixels: usize,
    /// The pitch used, mm.
    pub pixel_mm: f64,
    /// `file` or `request`.
    pub pixel_mm_from: &'static str,
    /// As the file states it, nm.
    #[schema(required = true)]
    pub wavelength_nm: Option<f64>,
}

/// Where the part sat.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct AlignmentAnswerDto {
    /// The part's centre: column, pixels from the left.
    pub centre_x_px: f64,
    /// The part's centre: row, pixels from the top.
    pub centre_y_px: f64,
    /// The part's radius, mm.
    pub part_radius_mm: f64,
    /// Counter-clockwise rotation into the C frame, degrees.
    pub rotation_deg: f64,
    /// x was flipped before the rotation.
    pub mirror: bool,
    /// The centre or radius was fitted to the map's boundary.
    pub fitted: bool,
}

/// The clear aperture and the valid pixels in it.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct MapApertureEcho {
    /// The aperture used (defaults filled in).
    pub aperture: MapApertureDto,
    /// Valid pixels inside it: what every figure is taken over.
    pub pixels: usize,
}

/// The removed terms' coefficients.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct RemovedDto {
    /// The plane's height at the aperture's centre, nm.
    pub piston_nm: f64,
    /// Slope along x of the C frame, nm/mm.
    pub tilt_x_nm_per_mm: f64,
    /// Slope along y, nm/mm.
    pub tilt_y_nm_per_mm: f64,
    /// Power removed (the edge's height above the centre), nm; null unless asked.
    #[schema(required = true)]
    pub power_nm: Option<f64>,
}

/// PV, RMS and PVr of the map less the removed terms over the aperture.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct MapMetricsDto {
    /// Peak to valley, nm.
    pub pv_nm: f64,
    /// About the mean, every pixel alike (area-weighted).
    pub rms_nm: f64,
    /// PV of the Zernike fit + 3 × RMS of its residual (Evans).
    pub pvr_nm: f64,
}

/// The ISO 10110-5 / ISO 14999-4 figures, from the map less piston and tilt.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct IsoDto {
    /// Sag error: the best-fit sphere's edge above its centre, nm.
    pub power_nm: f64,
    /// PV after power, nm.
    pub irregularity_nm: f64,
    /// PV of the irregularity's rotationally symmetric part, nm.
    pub rotationally_symmetric_irregularity_nm: f64,
    /// RMS after piston and tilt, nm.
    pub rms_t_nm: f64,
    /// RMS of the irregularity, nm.
    pub rms_i_nm: f64,
    /// RMS of its rotationally symmetric part, nm.
    pub rms_s_nm: f64,
    /// RMS of its rotationally variant part, nm (RMSi² = RMSs² + RMSa²).
    pub rms_a_nm: f64,
    /// λ for the fringes, nm: a fringe is λ/2 of height.
    pub fringe_wavelength_nm: f64,
    /// Power in fringes (ISO 10110-5's A in 3/A(B/C)).
    pub power_fringes: f64,
    /// Irregularity in fringes (B).
    pub irregularity_fringes: f64,
    /// Rotationally symmetric irregularity in fringes (C).
    pub rotationally_symmetric_irregularity_fringes: f64,
}

/// One Zernike term.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ZernikeTermDto {
    /// Its index in the ordering.
    pub index: usize,
    /// Radial order.
    pub n: u32,
    /// Azimuthal order: > 0 cos(mθ), < 0 sin(|m|θ), θ counter-clockwise from +x.
    pub m: i32,
    /// What opticians call it (`defocus`, `coma (sin)`; `Z(n, m)` beyond the sixth order).
    pub name: String,
    /// Its coefficient, nm, in the normalisation asked for.
    pub coefficient_nm: f64,
}

/// The Zernike fit of the map less the removed terms.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ZernikeDto {
    /// The ordering of `terms`.
    pub ordering: OrderingDto,
    /// The terms' scaling.
    pub normalization: NormalizationDto,
    /// ρ = 1 at this radius about the centre below, mm (the aperture's; a rectangle's
    /// half-diagonal).
    pub normalization_radius_mm: f64,
    /// The terms' centre in the C frame, x, mm (the aperture's).
    pub centre_x_mm: f64,
    /// The terms' centre, y, mm.
    pub centre_y_mm: f64,
    /// The first terms of the ordering, in its order.
    pub terms: Vec<ZernikeTermDto>,
    /// RMS of the map less the fit, nm.
    pub residual_rms_nm: f64,
}

/// A band's RMS.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct BandRmsDto {
    /// The band's name.
    pub name: String,
    /// Lowest frequency, per mm.
    pub low_per_mm: f64,
    /// Frequencies below this, per mm.
    pub high_per_mm: f64,
    /// RMS of the heights in the band, nm: √(Σ PSD·Δf²) over the 2-D grid.
    pub rms_nm: f64,
}

/// The PSD: the azimuthal average of the 2-D PSD, and the bands' RMS.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct PsdDto {
    /// `sidick` (1 − ρ⁸ on a circle) or `hann` (a rectangle).
    pub window: &'static str,
    /// Spatial frequency, per mm.
    pub frequency_per_mm: Vec<f64>,
    /// PSD, nm²·mm².
    pub psd_nm2_mm2: Vec<f64>,
    /// The bands asked for (or the defaults) with their RMS.
    pub bands: Vec<BandRmsDto>,
}

/// The rotationally symmetric part about the part's centre (the C axis).
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct MapProfileDto {
    /// Radius from the part's centre, mm, every pixel pitch over the aperture.
    pub radius_mm: Vec<f64>,
    /// Material standing proud, nm (> 0 proud), as `/v1/measurement/fit` reports it.
    pub depth_nm: Vec<f64>,
}

/// What a plan in radius alone leaves: the map less its rotationally symmetric part.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct NonAxisymmetricDto {
    /// RMS, nm: what a rotationally symmetric process cannot correct.
    pub rms_nm: f64,
    /// PV, nm.
    pub pv_nm: f64,
}

#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct MapAnalysisResponse {
    /// What was read.
    pub map: MapInfoDto,
    /// Where the part sat on the map.
    pub alignment: AlignmentAnswerDto,
    /// The aperture and its valid pixels.
    pub clear_aperture: MapApertureEcho,
    /// The terms removed before the figures.
    pub removed: RemovedDto,
    /// PV, RMS and PVr.
    pub metrics: MapMetricsDto,
    /// The ISO 10110-5 / 14999-4 figures.
    pub iso_10110: IsoDto,
    /// The Zernike fit.
    pub zernike: ZernikeDto,
    /// The PSD and band RMS.
    pub psd: PsdDto,
    /// The rotationally symmetric part about the C axis.
    pub radial_profile: MapProfileDto,
    /// The `target` of a `/v1/optimize` request that removes the rotationally symmetric part:
    /// the profile with a free piston.
    pub correction_target: TargetDto,
    /// What a plan in radius alone leaves.
    pub non_axisymmetric: NonAxisymmetricDto,
    /// `map_dropouts` when the aperture lacks data; empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
}

/// How the response names where a map came from.
pub fn origin_name(origin: MapOrigin) -> &'static str {
    match origin {
        MapOrigin::Heights => "json",
        MapOrigin::File(Format::MetroPro) => "metropro_dat",
        MapOrigin::File(Format::Datx) => "zygo_datx",
        MapOrigin::File(Format::ZygoText) => "zygo_text",
        MapOrigin::File(Format::CodeV) => "codev_int",
        MapOrigin::File(Format::TextGrid) => "text_grid",
    }
}

/// The bands asked for, as the core takes them.
fn bands_of(psd: Option<PsdOptionsDto>) -> Option<Vec<Band>> {
    psd.and_then(|p| p.bands).map(|bands| {
        bands
            .into_iter()
            .map(|b| Band {
                name: b.name,
                low_per_mm: b.low_per_mm,
                high_per_mm: b.high_per_mm,
            })
            .collect()
    })
}

/// A band's RMS as the response gives it.
fn band_rms(bands: &[(Band, f64)]) -> Vec<BandRmsDto> {
    bands
        .iter()
        .map(|(b, rms)| BandRmsDto {
            name: b.name.clone(),
            low_per_mm: b.low_per_mm,
            high_per_mm: b.high_per_mm,
            rms_nm: *rms,
        })
        .collect()
}

/// `POST /v1/maps/analysis`.
pub struct MapAnalysisEndpoint;

impl Endpoint for MapAnalysisEndpoint {
    const NAME: &'static str = "maps/analysis";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/maps_analysis.json");
    const LARGE_BODY: bool = true;
    const DOC: Doc = Doc {
        operation_id: "analyseMap",
        tag: "maps",
        summary: "Analyse an interferometer map: figures, ISO 10110, Zernike, PSD, radial profile.",
        description: "The map is aligned to the part (its centre and radius fitted to the valid \
pixels' boundary unless given), cut to the clear aperture, and less piston and tilt (and power \
on request) it is described: PV, RMS and PVr; the ISO 10110-5 / 14999-4 figures in nm and \
fringes; a Zernike fit; the PSD's azimuthal average and band RMS; the rotationally symmetric \
profile about the C axis with a ready `/v1/optimize` target; and what a plan in radius alone \
leaves (`non_axisymmetric`). The body is JSON with `map` as rows of heights, or the \
instrument's file itself (`application/octet-stream`, `text/plain` or `text/csv`: MetroPro \
.dat, Zygo ASCII or XYZ, Code V .int, Preston's text grid, or the JSON map) with the other \
fields as query parameters (JSON values). `Accept: text/csv` returns x, y, height per pixel; `image/svg+xml` the Zernike bars above \
the PSD; `image/png` a heat map of the heights (PV and RMS in its title, a colour bar in nm, a \
scale bar in mm, pixels without a height transparent).",
        ok: "The analysis; as CSV, the aperture's pixels (x_mm, y_mm, height_nm); as SVG, the Zernike bars and the PSD; as PNG, the heat map",
    };
    type Request = MapAnalysisRequest;
    type Body = MapOrJson<MapAnalysisRequest>;
    type Command = MapAnalysisCommand;
    type Output = MapAnalysisResult;
    type Response = MapAnalysisResponse;
    const CSV: Option<fn(&MapAnalysisResult) -> String> = Some(results::map_pixels_csv);
    const SVG: Option<fn(&MapAnalysisResult) -> String> = Some(results::map_analysis_svg);
    const PNG: Option<Picture<MapAnalysisResult>> = Some(crate::report::heatmap::map_png);

    fn document(operation: &mut Operation) {
        body::document(
            operation,
            MapAnalysisRequest::FILES,
            MapAnalysisRequest::QUERY_FIELDS,
        );
    }

    fn parse(req: Self::Request, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let (map, origin) = req.map.read("map", limits.max_map_pixels)?;
        let placement = req.alignment.unwrap_or_default().placement(req.pixel_mm)?;
        let zernike = req.zernike.unwrap_or_default();
        let spec = MapAnalysisSpec {
            pixel_mm: placement.pixel_mm,
            centre_px: placement.centre_px,
            part_radius_mm: placement.part_radius_mm,
            rotation_deg: placement.rotation_deg,
            mirror: placement.mirror,
            aperture: req.clear_aperture.map(Aperture::from),
            remove_power: req.remove_power,
            ordering: zernike.ordering.map(|o| match o {
                OrderingDto::Fringe => Ordering::Fringe,
                OrderingDto::Noll => Ordering::Noll,
                OrderingDto::Ansi => Ordering::Ansi,
            }),
            normalization: zernike.normalization.map(|n| match n {
                NormalizationDto::UnitRms => Normalization::UnitRms,
                NormalizationDto::Peak => Normalization::Peak,
            }),
            terms: zernike.terms,
            bands: bands_of(req.psd),
            fringe_wavelength_nm: req.fringe_wavelength_nm,
        };
        Ok(MapAnalysisCommand::new(map, origin, spec, limits)?)
    }

    fn run(command: Self::Command, _: &Services) -> Result<MapAnalysisResult, ApiError> {
        Ok(map_analysis(command)?)
    }

    fn respond(r: MapAnalysisResult) -> MapAnalysisResponse {
        let a = &r.analysis;
        let plan = &a.plan;
        let iso = &a.iso;
        let (radius_mm, depth_nm): (Vec<f64>, Vec<f64>) = a.radial_profile.iter().copied().unzip();
        MapAnalysisResponse {
            map: MapInfoDto {
                format: origin_name(r.origin),
                width_px: r.width,
                height_px: r.height,
                valid_pixels: r.valid_pixels,
                pixel_mm: plan.alignment.pixel_mm,
                pixel_mm_from: if r.pixel_from_file { "file" } else { "request" },
                wavelength_nm: r.wavelength_nm,
            },
            alignment: AlignmentAnswerDto {
                centre_x_px: plan.alignment.centre_px.0,
                centre_y_px: plan.alignment.centre_px.1,
                part_radius_mm: plan.alignment.part_radius_mm,
                rotation_deg: plan.alignment.rotation_deg,
                mirror: plan.alignment.mirror,
                fitted: plan.fitted,
            },
            clear_aperture: MapApertureEcho {
                aperture: plan.aperture.into(),
                pixels: a.pixels.len(),
            },
            removed: RemovedDto {
                piston_nm: a.removed.piston_nm,
                tilt_x_nm_per_mm: a.removed.tilt_x_nm_per_mm,
                tilt_y_nm_per_mm: a.removed.tilt_y_nm_per_mm,
                power_nm: a.removed.power_nm,
            },
            metrics: MapMetricsDto {
                pv_nm: a.metrics.pv_nm,
                rms_nm: a.metrics.rms_nm,
                pvr_nm: a.metrics.pvr_nm,
            },
            iso_10110: IsoDto {
                power_nm: iso.power_nm,
                irregularity_nm: iso.irregularity_nm,
                rotationally_symmetric_irregularity_nm: iso.rotationally_symmetric_irregularity_nm,
                rms_t_nm: iso.rms_t_nm,
                rms_i_nm: iso.rms_i_nm,
                rms_s_nm: iso.rms_s_nm,
                rms_a_nm: iso.rms_a_nm,
                fringe_wavelength_nm: iso.fringe_wavelength_nm,
                power_fringes: iso.fringes(iso.power_nm),
                irregularity_fringes: iso.fringes(iso.irregularity_nm),
                rotationally_symmetric_irregularity_fringes: iso
                    .fringes(iso.rotationally_symmetric_irregularity_nm),
            },
            zernike: ZernikeDto {
                ordering: match a.zernike.ordering {
                    Ordering::Fringe => OrderingDto::Fringe,
                    Ordering::Noll => OrderingDto::Noll,
                    Ordering::Ansi => OrderingDto::Ansi,
                },
                normalization: match a.zernike.normalization {
                    Normalization::UnitRms => NormalizationDto::UnitRms,
                    Normalization::Peak => NormalizationDto::Peak,
                },
                normalization_radius_mm: a.zernike.normalization_radius_mm,
                centre_x_mm: a.zernike.centre_mm.0,
                centre_y_mm: a.zernike.centre_mm.1,
                terms: a
                    .zernike
                    .terms
                    .iter()
                    .map(|(index, t, c)| ZernikeTermDto {
                        index: *index,
                        n: t.n,
                        m: t.m,
                        name: t.name(),
                        coefficient_nm: *c,
                    })
                    .collect(),
                residual_rms_nm: a.zernike.residual_rms_nm,
            },
            psd: PsdDto {
                window: match a.psd.window {
                    Window::Sidick => "sidick",
                    Window::Hann => "hann",
                },
                frequency_per_mm: a.psd.azimuthal.iter().map(|p| p.0).collect(),
                psd_nm2_mm2: a.psd.azimuthal.iter().map(|p| p.1).collect(),
                bands: band_rms(&a.psd.bands),
            },
            correction_target: TargetDto {
                uniform_depth_nm: None,
                profile: Some(MeasuredProfileDto {
                    radius_mm: radius_mm.clone(),
                    depth_nm: depth_nm.clone(),
                }),
                free_piston: Some(true),
            },
            radial_profile: MapProfileDto {
                radius_mm,
                depth_nm,
            },
            non_axisymmetric: NonAxisymmetricDto {
                rms_nm: a.non_axisymmetric.rms_nm,
                pv_nm: a.non_axisymmetric.pv_nm,
            },
            warnings: WarningDto::all(&r.warnings),
        }
    }
}
