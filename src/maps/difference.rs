//! Two maps of one part, before and after a run: what the run removed, and what it did to
//! the figure.
//!
//! Each map sits on the part by its own alignment (`aperture`); a point (x, y) of the part's
//! frame falls at pixel (c, r) of the after map, fractional in general, where the after
//! height is the bilinear interpolation of its four neighbours (exact at whole-pixel
//! offsets, when the maps share a pixel grid; a point whose neighbours lack data is not
//! compared). Over the before map's valid pixels in the clear aperture that the after map
//! covers:
//!
//! - **removal** e = h_before − h_after (nm, > 0 removed), its mean, PV, RMS and
//!   nonuniformity PV/mean: the paper's test of uniform removal. Interferometer maps carry
//!   an arbitrary piston (and tilt): the mean is then only as absolute as the maps; on
//!   request each map's tilt is removed first (not its piston).
//! - **before and after**: PV and RMS of each map less piston and tilt (the least-squares
//!   plane over the compared pixels), and the RMS of each frequency band (`psd`), as
//!   `analysis` gives them: did the mid-spatial error improve without the figure degrading.
//! - **radial removal**: e's rotationally symmetric part about the part's centre (`radial`),
//!   sampled every pixel pitch, as a calibration run's `removal` takes it.

use super::analysis::{plane_fit, spectrum_of, tally_each, Band, Pixel, Window};
use super::aperture::{Alignment, Aperture};
use super::radial::{RadialFit, KNOT_SPACING_PX};
use super::HeightMap;

/// What to compare and how (checked: `usecases::map_difference` builds it).
#[derive(Debug, Clone, PartialEq)]
pub struct DifferencePlan {
    pub before: Alignment,
    pub after: Alignment,
    pub aperture: Aperture,
    pub remove_tilt: bool,
    pub bands: Vec<Band>,
}

/// A map's figure over the compared pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct FigureAnswer {
    /// Less piston and tilt, nm.
    pub pv_nm: f64,
    pub rms_nm: f64,
    /// Each band and its RMS, nm.
    pub bands: Vec<(Band, f64)>,
}

/// What was removed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RemovalFigures {
    pub mean_nm: f64,
    pub pv_nm: f64,
    pub rms_nm: f64,
    /// PV / mean; `None` unless the mean is above 0.
    pub nonuniformity: Option<f64>,
}

/// Everything the difference found.
#[derive(Debug, Clone, PartialEq)]
pub struct MapDifference {
    pub plan: DifferencePlan,
    /// The compared pixels (the before map's), with the removal as their height.
    pub pixels: Vec<Pixel>,
    /// Pixels of the aperture with a before height that the after map does not cover.
    pub uncovered: usize,
    /// Pixels in the aperture on the before map, with data or without.
    pub area_pixels: usize,
    pub removal: RemovalFigures,
    pub before: FigureAnswer,
    pub after: FigureAnswer,
    pub window: Window,
    /// (radius mm, removal nm) about the part's centre.
    pub radial_removal: Vec<(f64, f64)>,
}

/// Why a difference has no answer (found by computing).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DifferenceError {
    #[error(
        "the maps overlap on {0} pixels of the clear aperture: register them (the after map's \
         offset) or widen the aperture"
    )]
    TooLittleOverlap(usize),
    #[error("the compared pixels span too few radii to tell a radial removal")]
    NoRadialProfile,
}

/// The after map's height at the part-frame point (x, y), bilinear between its pixels.
fn interpolate(map: &HeightMap, alignment: &Alignment, x: f64, y: f64) -> Option<f64> {
    let (c, r) = alignment.to_pixel(x, y);
    // Within 1e-9 of a pixel centre counts as on it: maps on one grid compare exactly.
    let split = |v: f64| -> Option<(usize, f64)> {
        let nearest = v.round();
        if (v - nearest).abs() <= 1e-9 {
            return (nearest >= 0.0).then_some((nearest as usize, 0.0));
        }
        let floor = v.floor();
        (floor >= 0.0).then_some((floor as usize, v - floor))
    };
    let ((c0, fc), (r0, fr)) = (split(c)?, split(r)?);
    let at = |dc: usize, dr: usize, w: f64| -> Option<f64> {
        if w == 0.0 {
            Some(0.0)
        } else {
            map.at(c0 + dc, r0 + dr).map(|h| w * h)
        }
    };
    Some(
        at(0, 0, (1.0 - fc) * (1.0 - fr))?
            + at(1, 0, fc * (1.0 - fr))?
            + at(0, 1, (1.0 - fc) * fr)?
            + at(1, 1, fc * fr)?,
    )
}

/// The before map's valid pixels in the aperture that the after map covers, each with the
/// after height there; how many it does not cover; the aperture's pixels on the before map.
struct Registered {
    pairs: Vec<(Pixel, f64)>,
    uncovered: usize,
    area_pixels: usize,
}

/// The maps registered as `plan` places them (module docs).
fn register(
    before: &HeightMap,
    after: &HeightMap,
    plan: &DifferencePlan,
) -> Result<Registered, DifferenceError> {
    let census = super::analysis::aperture_pixels(before, &plan.before, &plan.aperture);
    let candidates = census.pixels;
    let pairs: Vec<(Pixel, f64)> = candidates
        .iter()
        .filter_map(|p| interpolate(after, &plan.after, p.x_mm, p.y_mm).map(|h| (*p, h)))
        .collect();
    if pairs.len() < 16 {
        return Err(DifferenceError::TooLittleOverlap(pairs.len()));
    }
    Ok(Registered {
        uncovered: candidates.len() - pairs.len(),
        area_pixels: census.area_pixels,
        pairs,
    })
}

/// The removal h_before − h_after at the compared pixels (no tilt removed), and nothing else
/// of the difference: what a calibration fits.
pub fn removal_pixels(
    before: &HeightMap,
    after: &HeightMap,
    plan: &DifferencePlan,
) -> Result<Vec<Pixel>, DifferenceError> {
    Ok(register(before, after, plan)?
        .pairs
        .into_iter()
        .map(|(p, h)| Pixel {
            height_nm: p.height_nm - h,
            ..p
        })
        .collect())
}

/// The difference (module docs) of `before` and `after` as `plan` says.
pub fn difference(
    before: &HeightMap,
    after: &HeightMap,
    plan: DifferencePlan,
) -> Result<MapDifference, DifferenceError> {
    let Registered {
        pairs,
        uncovered,
        area_pixels,
    } = register(before, after, &plan)?;
    let (cx, cy) = plan.aperture.centre_mm();
    let radius = plan.aperture.normalization_radius_mm();
    let unit = |p: &Pixel| ((p.x_mm - cx) / radius, (p.y_mm - cy) / radius);
    let with = |heights: &mut dyn Iterator<Item = f64>| -> Vec<Pixel> {
        pairs
            .iter()
            .zip(heights)
            .map(|((p, _), h)| Pixel { height_nm: h, ..*p })
            .collect()
    };
    let before_pixels = with(&mut pairs.iter().map(|(p, _)| p.height_nm));
    let after_pixels = with(&mut pairs.iter().map(|(_, h)| *h));
    // Each map's tilt, when asked (its piston stays: the removal's mean depends on it).
    let detilt = |pixels: Vec<Pixel>| -> Vec<Pixel> {
        if !plan.remove_tilt {
            return pixels;
        }
        let plane = plane_fit(&pixels, &unit);
        pixels
            .iter()
            .map(|p| {
                let (u, v) = unit(p);
                Pixel {
                    height_nm: p.height_nm - plane[1] * u - plane[2] * v,
                    ..*p
                }
            })
            .collect()
    };
    let (before_pixels, after_pixels) = (detilt(before_pixels), detilt(after_pixels));
    let removal: Vec<Pixel> = before_pixels
        .iter()
        .zip(&after_pixels)
        .map(|(b, a)| Pixel {
            height_nm: b.height_nm - a.height_nm,
            ..*b
        })
        .collect();
    let [e] = tally_each(removal.len(), |i| [removal[i].height_nm]);
    let removal_figures = RemovalFigures {
        mean_nm: e.mean,
        pv_nm: e.pv,
        rms_nm: e.rms,
        nonuniformity: (e.mean > 0.0).then(|| e.pv / e.mean),
    };
    let figure = |pixels: &[Pixel]| -> FigureAnswer {
        let plane = plane_fit(pixels, &unit);
        let flat: Vec<Pixel> = pixels
            .iter()
            .map(|p| {
                let (u, v) = unit(p);
                Pixel {
                    height_nm: p.height_nm - plane[0] - plane[1] * u - plane[2] * v,
                    ..*p
                }
            })
            .collect();
        let [f] = tally_each(flat.len(), |i| [flat[i].height_nm]);
        FigureAnswer {
            pv_nm: f.pv,
            rms_nm: f.rms,
            bands: spectrum_of(&plan.aperture, plan.before.pixel_mm, &plan.bands, &flat).bands,
        }
    };
    let (before_figure, after_figure) = (figure(&before_pixels), figure(&after_pixels));
    let pixel_mm = plan.before.pixel_mm;
    let profile = RadialFit::fit(
        &removal
            .iter()
            .map(|p| (super::analysis::radius_of(p.x_mm, p.y_mm), p.height_nm))
            .collect::<Vec<_>>(),
        KNOT_SPACING_PX * pixel_mm,
    )
    .ok_or(DifferenceError::NoRadialProfile)?;
    let radial_removal = super::analysis::sample_profile(&profile, pixel_mm);
    let window = super::analysis::window_for(&plan.aperture);
    Ok(MapDifference {
        plan,
        pixels: removal,
        uncovered,
        area_pixels,
        removal: removal_figures,
        before: before_figure,
        after: after_figure,
        window,
        radial_removal,
    })
}
