//! `POST /v1/maps/difference`: the maps before and after a run of one part.

use serde::{Deserialize, Serialize};
use utoipa::openapi::path::Operation;
use utoipa::ToSchema;

use super::body::{MapForm, MapOrJson, MapSource};
use super::BandRmsDto;
use super::{band_rms, bands_of, origin_name, MapAlignmentDto, MapApertureDto, PsdOptionsDto};
use crate::http::calibration::RadialProfileDto;
use crate::http::dto::WarningDto;
use crate::http::endpoint::{Doc, Endpoint};
use crate::http::error::ApiError;
use crate::http::extract::optional_object;
use crate::http::state::Services;
use crate::maps::aperture::Aperture;
use crate::maps::difference::FigureAnswer;
use crate::report::results;
use crate::usecases::map_difference::{
    map_difference, MapDifferenceCommand, MapDifferenceResult, MapDifferenceSpec,
};
use crate::usecases::ComputeLimits;

/// The after map's centre relative to the before map's.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct OffsetDto {
    /// Columns, pixels (the after map's centre column less the before map's).
    pub x_px: f64,
    /// Rows, pixels.
    pub y_px: f64,
}

#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapDifferenceRequest {
    /// The map before the run: rows of heights. Or send both files as multipart/form-data
    /// (parts `before` and `after`) and the other fields as query parameters.
    #[serde(default)]
    #[schema(required = true)]
    pub before: MapSource,
    /// The map after the run.
    #[serde(default)]
    #[schema(required = true)]
    pub after: MapSource,
    /// Pixel pitch of both maps, mm (> 0, each map at most 100 m across). Default: the
    /// files'.
    pub pixel_mm: Option<f64>,
    /// Where the part sits on the before map (and, with a centre given and no offset, on the
    /// after map too). Default: each map's centre and radius fitted to its own boundary.
    #[serde(default, deserialize_with = "optional_object")]
    pub alignment: Option<MapAlignmentDto>,
    /// Registers the after map by a given offset of its centre from the before map's.
    #[serde(default, deserialize_with = "optional_object")]
    pub after_offset_px: Option<OffsetDto>,
    /// The clear aperture. Default: a circle of the part's radius.
    #[serde(default, deserialize_with = "optional_object")]
    pub clear_aperture: Option<MapApertureDto>,
    /// Remove each map's tilt before the difference (not its piston). Default false.
    pub remove_tilt: Option<bool>,
    /// The bands of the figures before and after.
    #[serde(default, deserialize_with = "optional_object")]
    pub psd: Option<PsdOptionsDto>,
}

impl MapForm for MapDifferenceRequest {
    const FILES: &'static [&'static str] = &["before", "after"];
    const QUERY_FIELDS: &'static [&'static str] = &[
        "pixel_mm",
        "alignment",
        "after_offset_px",
        "clear_aperture",
        "remove_tilt",
        "psd",
    ];

    fn set_file(&mut self, name: &str, bytes: axum::body::Bytes) {
        if name == "before" {
            self.before = MapSource::File(bytes);
        } else {
            self.after = MapSource::File(bytes);
        }
    }
}

/// What the run removed over the compared pixels.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct RemovalDto {
    /// Mean removal, nm (> 0 removed).
    pub mean_nm: f64,
    /// PV of the removal, nm.
    pub pv_nm: f64,
    /// RMS of the removal about its mean, nm.
    pub rms_nm: f64,
    /// PV / mean: the uniformity of the removal; null unless the mean is above 0.
    #[schema(required = true)]
    pub nonuniformity: Option<f64>,
    /// Pixels compared: the before map's in the aperture that the after map covers.
    pub pixels: usize,
    /// Pixels of the before map in the aperture the after map does not cover.
    pub uncovered_pixels: usize,
}

/// A map's figure over the compared pixels, less piston and tilt.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct FigureDto {
    /// PV, nm.
    pub pv_nm: f64,
    /// RMS, nm.
    pub rms_nm: f64,
    /// The bands' RMS.
    pub bands: Vec<BandRmsDto>,
}

impl From<&FigureAnswer> for FigureDto {
    fn from(f: &FigureAnswer) -> Self {
        FigureDto {
            pv_nm: f.pv_nm,
            rms_nm: f.rms_nm,
            bands: band_rms(&f.bands),
        }
    }
}

/// Where each map came from and where the part sat on it.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct RegistrationDto {
    /// The before map's format.
    pub before_format: &'static str,
    /// The after map's format.
    pub after_format: &'static str,
    /// The part's centre on the before map: column, row, pixels.
    pub before_centre_px: [f64; 2],
    /// The part's centre on the after map: column, row, pixels.
    pub after_centre_px: [f64; 2],
    /// The part's radius, mm.
    pub part_radius_mm: f64,
    /// The pixel pitch, mm.
    pub pixel_mm: f64,
}

#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct MapDifferenceResponse {
    /// How the maps were registered.
    pub registration: RegistrationDto,
    /// The clear aperture used.
    pub clear_aperture: MapApertureDto,
    /// The removal map's figures: the paper's test of uniform removal.
    pub removal: RemovalDto,
    /// The before map's figure.
    pub before: FigureDto,
    /// The after map's figure.
    pub after: FigureDto,
    /// The removal's rotationally symmetric part about the part's centre, as a calibration
    /// run's `removal` takes it.
    pub radial_removal: RadialProfileDto,
    /// `map_dropouts` when the aperture lacks data; empty when there is nothing to say.
    pub warnings: Vec<WarningDto>,
}

/// `POST /v1/maps/difference`.
pub struct MapDifferenceEndpoint;

impl Endpoint for MapDifferenceEndpoint {
    const NAME: &'static str = "maps/difference";
    const EXAMPLE: &'static str = include_str!("../../../fixtures/maps_difference.json");
    const LARGE_BODY: bool = true;
    const DOC: Doc = Doc {
        operation_id: "differenceMaps",
        tag: "maps",
        summary: "What a run removed: the maps before and after it, registered and differenced.",
        description: "Registers the after map on the before map (each by its fitted boundary, by \
a given centre, or by a given offset), interpolates it at the before map's pixels and returns \
the removal (before − after) over the clear aperture: its mean, PV, RMS and nonuniformity \
(PV/mean); each map's PV, RMS and band RMS less piston and tilt; and the removal's radial \
profile in the form a calibration run takes. JSON with `before` and `after` as rows of heights, \
or the two files as multipart/form-data (parts `before` and `after`) with the other fields as \
query parameters. `Accept: text/csv` returns x, y and the removal per pixel.",
        ok: "The removal and the figures before and after; as CSV, the removal per pixel",
    };
    type Request = MapDifferenceRequest;
    type Body = MapOrJson<MapDifferenceRequest>;
    type Command = MapDifferenceCommand;
    type Output = MapDifferenceResult;
    type Response = MapDifferenceResponse;
    const CSV: Option<fn(&MapDifferenceResult) -> String> = Some(results::map_removal_csv);

    fn document(operation: &mut Operation) {
        super::body::document(
            operation,
            MapDifferenceRequest::FILES,
            MapDifferenceRequest::QUERY_FIELDS,
        );
    }

    fn parse(req: Self::Request, limits: &ComputeLimits) -> Result<Self::Command, ApiError> {
        let before = req.before.read("before", limits.max_map_pixels)?;
        let after = req.after.read("after", limits.max_map_pixels)?;
        let spec = MapDifferenceSpec {
            placement: req.alignment.unwrap_or_default().placement(req.pixel_mm)?,
            after_offset_px: req.after_offset_px.map(|o| (o.x_px, o.y_px)),
            aperture: req.clear_aperture.map(Aperture::from),
            remove_tilt: req.remove_tilt,
            bands: bands_of(req.psd),
        };
        Ok(MapDifferenceCommand::new(before, after, spec, limits)?)
    }

    fn run(command: Self::Command, _: &Services) -> Result<MapDifferenceResult, ApiError> {
        Ok(map_difference(command)?)
    }

    fn respond(r: MapDifferenceResult) -> MapDifferenceResponse {
        let d = &r.difference;
        let (radius_mm, depth_nm): (Vec<f64>, Vec<f64>) = d.radial_removal.iter().copied().unzip();
        MapDifferenceResponse {
            registration: RegistrationDto {
                before_format: origin_name(r.origins.0),
                after_format: origin_name(r.origins.1),
                before_centre_px: [d.plan.before.centre_px.0, d.plan.before.centre_px.1],
                after_centre_px: [d.plan.after.centre_px.0, d.plan.after.centre_px.1],
                part_radius_mm: d.plan.before.part_radius_mm,
                pixel_mm: d.plan.before.pixel_mm,
            },
            clear_aperture: d.plan.aperture.into(),
            removal: RemovalDto {
                mean_nm: d.removal.mean_nm,
                pv_nm: d.removal.pv_nm,
                rms_nm: d.removal.rms_nm,
                nonuniformity: d.removal.nonuniformity,
                pixels: d.pixels.len(),
                uncovered_pixels: d.uncovered,
            },
            before: (&d.before).into(),
            after: (&d.after).into(),
            radial_removal: RadialProfileDto {
                radius_mm,
                depth_nm,
            },
            warnings: WarningDto::all(&r.warnings),
        }
    }
}
