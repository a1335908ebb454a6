//! Analyse an interferometer map: align it to the part, cut the clear aperture, report its
//! figures (`maps::analysis`).

use super::warnings::map_dropouts;
use super::{ComputeLimits, Warning};
use crate::maps::analysis::{
    self, AnalysisError, AnalysisPlan, Band, MapAnalysis, ISO_WAVELENGTH_NM,
};
use crate::maps::aperture::{boundary_circle, Alignment, Aperture};
use crate::maps::zernike::{Basis, Normalization, Ordering};
use crate::maps::{Format, HeightMap};

/// The default number of Zernike terms.
pub const DEFAULT_TERMS: usize = 37;
/// The most bands one analysis reports.
pub const MAX_BANDS: usize = 16;
/// The fewest valid pixels an aperture must hold.
pub const MIN_APERTURE_PIXELS: usize = 16;
/// The widest a map may span, mm (100 m: beyond any part; it keeps squared radii finite).
pub const MAX_MAP_EXTENT_MM: f64 = 1e5;

/// An analysis as asked (`None`: the default).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MapAnalysisSpec {
    /// Pixel pitch, mm. Default: the file's; required when the file has none.
    pub pixel_mm: Option<f64>,
    /// The part's centre (column, row), pixels. Default: fitted from the map's boundary.
    pub centre_px: Option<(f64, f64)>,
    /// The part's radius, mm. Default: fitted from the map's boundary.
    pub part_radius_mm: Option<f64>,
    /// Default 0.
    pub rotation_deg: Option<f64>,
    /// Default false.
    pub mirror: Option<bool>,
    /// Default: a circle of the part's radius.
    pub aperture: Option<Aperture>,
    /// Default false (piston and tilt only).
    pub remove_power: Option<bool>,
    /// Default Fringe.
    pub ordering: Option<Ordering>,
    /// Default unit RMS.
    pub normalization: Option<Normalization>,
    /// Default [`DEFAULT_TERMS`] (Fringe: at most 37; Noll and ANSI: 231).
    pub terms: Option<usize>,
    /// Default `Band::defaults`.
    pub bands: Option<Vec<Band>>,
    /// Default: the map's wavelength, else 546.07 nm.
    pub fringe_wavelength_nm: Option<f64>,
}

/// An input of a map analysis, by role.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapInput {
    PixelSize,
    Centre,
    PartRadius,
    Rotation,
    Aperture,
    Terms,
    Bands,
    FringeWavelength,
}

/// Why an analysis was refused before computing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapInputError {
    #[error("the file does not calibrate its pixels: give the pixel size in mm")]
    PixelSizeUnknown,
    #[error("{detail}")]
    Invalid { input: MapInput, detail: String },
    #[error(
        "the part's edge cannot be found from the map's valid pixels: give the centre (pixels) \
         and the part's radius (mm)"
    )]
    NoBoundary,
    #[error(
        "{terms} pixels × {count}² Zernike terms is more work than this server allows \
         ({max:e}); fit fewer terms or send a coarser map"
    )]
    TooMuchWork {
        terms: usize,
        count: usize,
        max: f64,
    },
}

impl MapInputError {
    /// The input at fault.
    pub fn input(&self) -> MapInput {
        match self {
            MapInputError::PixelSizeUnknown => MapInput::PixelSize,
            MapInputError::Invalid { input, .. } => *input,
            MapInputError::NoBoundary => MapInput::Centre,
            MapInputError::TooMuchWork { .. } => MapInput::Terms,
        }
    }

    fn invalid(input: MapInput, detail: impl Into<String>) -> Self {
        MapInputError::Invalid {
            input,
            detail: detail.into(),
        }
    }
}

/// Where the map came from: a file (in the format named), or heights given as such.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapOrigin {
    File(Format),
    Heights,
}

/// A checked analysis.
#[derive(Debug, Clone)]
pub struct MapAnalysisCommand {
    map: HeightMap,
    origin: MapOrigin,
    pixel_from_file: bool,
    plan: AnalysisPlan,
}

/// The analysis, and what was read.
#[derive(Debug, Clone)]
pub struct MapAnalysisResult {
    pub origin: MapOrigin,
    pub width: usize,
    pub height: usize,
    pub valid_pixels: usize,
    pub wavelength_nm: Option<f64>,
    /// The pixel pitch came from the file (else the request).
    pub pixel_from_file: bool,
    pub analysis: MapAnalysis,
    pub warnings: Vec<Warning>,
}

pub fn positive(value: f64, input: MapInput, what: &str) -> Result<f64, MapInputError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(MapInputError::invalid(
            input,
            format!("{what} must be a positive number, not {value}"),
        ))
    }
}

impl MapAnalysisCommand {
    pub fn new(
        map: HeightMap,
        origin: MapOrigin,
        spec: MapAnalysisSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, MapInputError> {
        use MapInput as I;
        let placement = Placement {
            pixel_mm: spec.pixel_mm,
            centre_px: spec.centre_px,
            part_radius_mm: spec.part_radius_mm,
            rotation_deg: spec.rotation_deg,
            mirror: spec.mirror,
        };
        let (alignment, fitted) = placement.place(&map)?;
        let aperture = spec.aperture.unwrap_or(Aperture::Circle {
            radius_mm: alignment.part_radius_mm,
        });
        let inside = check_on_map(&map, &alignment, &aperture)?;

        let ordering = spec.ordering.unwrap_or(Ordering::Fringe);
        let count = spec.terms.unwrap_or(DEFAULT_TERMS);
        if count == 0 || count > ordering.max_terms() {
            return Err(MapInputError::invalid(
                I::Terms,
                format!(
                    "{count} Zernike terms: the {ordering:?} ordering fits 1 to {}",
                    ordering.max_terms()
                ),
            ));
        }
        if inside < count {
            return Err(MapInputError::invalid(
                I::Terms,
                format!(
                    "{count} Zernike terms need as many valid pixels; the aperture holds {inside}"
                ),
            ));
        }
        let work = inside as f64 * (count * count) as f64;
        if work > limits.max_zernike_work {
            return Err(MapInputError::TooMuchWork {
                terms: inside,
                count,
                max: limits.max_zernike_work,
            });
        }
        let zernike = Basis::first(
            ordering,
            count,
            spec.normalization.unwrap_or(Normalization::UnitRms),
        )
        .expect("count within the ordering");
        let bands = match spec.bands {
            Some(bands) => check_bands(bands)?,
            None => Band::defaults(2.0 * aperture.normalization_radius_mm(), alignment.pixel_mm),
        };
        let fringe_wavelength_nm = match spec.fringe_wavelength_nm {
            Some(l) => positive(l, I::FringeWavelength, "the fringe wavelength")?,
            None => map.wavelength_nm().unwrap_or(ISO_WAVELENGTH_NM),
        };
        Ok(MapAnalysisCommand {
            map,
            origin,
            pixel_from_file: spec.pixel_mm.is_none(),
            plan: AnalysisPlan {
                alignment,
                fitted,
                aperture,
                remove_power: spec.remove_power.unwrap_or(false),
                zernike,
                ordering,
                bands,
                fringe_wavelength_nm,
            },
        })
    }

    pub fn map(&self) -> &HeightMap {
        &self.map
    }
}

/// Where a map's part sits, as asked (`None`: from the file, or fitted).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Placement {
    pub pixel_mm: Option<f64>,
    pub centre_px: Option<(f64, f64)>,
    pub part_radius_mm: Option<f64>,
    pub rotation_deg: Option<f64>,
    pub mirror: Option<bool>,
}

impl Placement {
    /// The alignment: the pixel pitch given or the file's, the centre and radius given or
    /// fitted to the map's boundary; and whether anything was fitted.
    pub fn place(&self, map: &HeightMap) -> Result<(Alignment, bool), MapInputError> {
        use MapInput as I;
        let pixel_mm = match (self.pixel_mm, map.pixel_mm()) {
            (Some(p), _) => positive(p, I::PixelSize, "the pixel size")?,
            (None, Some(p)) => p,
            (None, None) => return Err(MapInputError::PixelSizeUnknown),
        };
        let across_mm = map.width().max(map.height()) as f64 * pixel_mm;
        if across_mm.is_nan() || across_mm > MAX_MAP_EXTENT_MM {
            return Err(MapInputError::invalid(
                I::PixelSize,
                format!(
                    "a pixel of {pixel_mm} mm makes the {} × {} map {across_mm:e} mm across; \
                     a map may span {MAX_MAP_EXTENT_MM} mm at most",
                    map.width(),
                    map.height()
                ),
            ));
        }
        let rotation_deg = self.rotation_deg.unwrap_or(0.0);
        if !rotation_deg.is_finite() {
            return Err(MapInputError::invalid(
                I::Rotation,
                "the rotation must be a finite angle in degrees",
            ));
        }
        if let Some((c, r)) = self.centre_px {
            let inside = |v: f64, n: usize| v.is_finite() && v >= -0.5 && v <= n as f64 - 0.5;
            if !inside(c, map.width()) || !inside(r, map.height()) {
                return Err(MapInputError::invalid(
                    I::Centre,
                    format!(
                        "the centre ({c}, {r}) is not on the {} × {} map (columns and rows from 0)",
                        map.width(),
                        map.height()
                    ),
                ));
            }
        }
        if let Some(r) = self.part_radius_mm {
            positive(r, I::PartRadius, "the part's radius")?;
        }
        let fitted = self.centre_px.is_none() || self.part_radius_mm.is_none();
        let (centre_px, part_radius_mm) = if fitted {
            let (centre, radius_px) = boundary_circle(map).ok_or(MapInputError::NoBoundary)?;
            (
                self.centre_px.unwrap_or(centre),
                self.part_radius_mm.unwrap_or(radius_px * pixel_mm),
            )
        } else {
            (
                self.centre_px.unwrap_or_default(),
                self.part_radius_mm.unwrap_or_default(),
            )
        };
        let alignment = Alignment {
            centre_px,
            part_radius_mm,
            rotation_deg,
            mirror: self.mirror.unwrap_or(false),
            pixel_mm,
        };
        Ok((alignment, fitted))
    }
}

/// Checks the aperture's dimensions and that it lies on the map (every point of its outline
/// within the pixels' extent: half a pixel beyond the outer centres, and one pixel of slack
/// for rounding) holding [`MIN_APERTURE_PIXELS`] valid pixels at least; their count.
pub fn check_on_map(
    map: &HeightMap,
    alignment: &Alignment,
    aperture: &Aperture,
) -> Result<usize, MapInputError> {
    use MapInput as I;
    check_aperture(aperture)?;
    let (w, h) = (map.width() as f64, map.height() as f64);
    if let Some((x, y)) = aperture.outline_mm().into_iter().find(|&(x, y)| {
        let (c, r) = alignment.to_pixel(x, y);
        !(c >= -1.5 && c <= w + 0.5 && r >= -1.5 && r <= h + 0.5)
    }) {
        return Err(MapInputError::invalid(
            I::Aperture,
            format!(
                "the clear aperture reaches ({x:.3}, {y:.3}) mm in the part's frame, off the \
                 {} × {} map ({:.3} × {:.3} mm)",
                map.width(),
                map.height(),
                w * alignment.pixel_mm,
                h * alignment.pixel_mm
            ),
        ));
    }
    let inside = analysis::count_aperture_pixels(map, alignment, aperture);
    if inside < MIN_APERTURE_PIXELS {
        return Err(MapInputError::invalid(
            I::Aperture,
            format!(
                "the clear aperture holds {inside} valid pixels; an analysis needs \
                 {MIN_APERTURE_PIXELS} at least"
            ),
        ));
    }
    Ok(inside)
}

fn check_aperture(aperture: &Aperture) -> Result<(), MapInputError> {
    let bad = |what: &str| Err(MapInputError::invalid(MapInput::Aperture, what.to_string()));
    let ok = |v: f64| v.is_finite() && v > 0.0;
    match *aperture {
        Aperture::Circle { radius_mm } if !ok(radius_mm) => {
            bad("radius_mm must be a positive number")
        }
        Aperture::Annulus {
            inner_radius_mm,
            outer_radius_mm,
        } if !(inner_radius_mm.is_finite()
            && inner_radius_mm >= 0.0
            && ok(outer_radius_mm)
            && inner_radius_mm < outer_radius_mm) =>
        {
            bad("an annulus needs 0 ≤ inner_radius_mm < outer_radius_mm")
        }
        Aperture::Rectangle {
            centre_x_mm,
            centre_y_mm,
            width_mm,
            height_mm,
        } if !(centre_x_mm.is_finite()
            && centre_y_mm.is_finite()
            && ok(width_mm)
            && ok(height_mm)) =>
        {
            bad("a rectangle needs a finite centre and positive width_mm and height_mm")
        }
        Aperture::OffCentreCircle {
            centre_x_mm,
            centre_y_mm,
            radius_mm,
        } if !(centre_x_mm.is_finite() && centre_y_mm.is_finite() && ok(radius_mm)) => {
            bad("an off-centre circle needs a finite centre and a positive radius_mm")
        }
        _ => Ok(()),
    }
}

pub fn check_bands(bands: Vec<Band>) -> Result<Vec<Band>, MapInputError> {
    let bad = |detail: String| Err(MapInputError::invalid(MapInput::Bands, detail));
    if bands.is_empty() || bands.len() > MAX_BANDS {
        return bad(format!("give 1 to {MAX_BANDS} bands, not {}", bands.len()));
    }
    for (k, b) in bands.iter().enumerate() {
        if !(b.low_per_mm.is_finite() && b.high_per_mm.is_finite())
            || b.low_per_mm < 0.0
            || b.high_per_mm <= b.low_per_mm
        {
            return bad(format!(
                "band {k} ({}): needs 0 ≤ low_per_mm < high_per_mm, finite",
                b.name
            ));
        }
    }
    Ok(bands)
}

/// The analysis.
pub fn map_analysis(command: MapAnalysisCommand) -> Result<MapAnalysisResult, AnalysisError> {
    let map = &command.map;
    let analysis = analysis::analyse(map, command.plan)?;
    let warnings = map_dropouts(analysis.pixels.len(), analysis.area_pixels);
    Ok(MapAnalysisResult {
        origin: command.origin,
        width: map.width(),
        height: map.height(),
        valid_pixels: map.valid_pixels(),
        wavelength_nm: map.wavelength_nm(),
        pixel_from_file: command.pixel_from_file,
        analysis,
        warnings,
    })
}
