//! A map analysed as a metrologist does: aligned to the part, cut to a clear aperture, less
//! the terms the test does not judge, then its figures, Zernike terms, PSD, rotationally
//! symmetric part and what a rotationally symmetric process cannot remove.
//!
//! With h the heights at the aperture's valid pixels (each pixel one unit of area):
//!
//! - **Removed terms**: piston and tilt (and power on request) are the least-squares fit of
//!   Z(0,0), Z(1,±1) (and Z(2,0)) about the aperture's centre, peak-normalised on its
//!   normalisation radius; what remains, h′, is what every figure below describes except the
//!   ISO ones, which take the map less piston and tilt alone whatever was asked.
//! - **Metrics**: PV and RMS (about the mean) of h′; PVr = PV of the Zernike fit + 3 × RMS of
//!   its residual (Evans' robust PV, with the terms asked for).
//! - **ISO 10110-5 / 14999-4**, from h_t = h less piston and tilt: power (sag error) = 2·c₄,
//!   c₄ the coefficient of the peak-normalised defocus 2ρ² − 1 in the fit of piston, tilt and
//!   defocus (the height of the edge above the centre; a paraboloid is the best-fit sphere to
//!   far below a nanometre at these departures); irregularity h_i = h_t less that defocus, its
//!   PV; its rotationally symmetric part s (`radial`, about the aperture's centre) and the
//!   PV of s: rotationally symmetric irregularity. RMSt = RMS(h_t), RMSi = RMS(h_i),
//!   RMSs = RMS(s), RMSa = RMS(h_i − s), with RMSi² = RMSs² + RMSa² exactly. In fringes: a
//!   height over λ/2 (one fringe of a double-pass test), λ stated in the answer.
//! - **Zernike fit** of h′ about the aperture's centre on its normalisation radius.
//! - **PSD** of h′ (`psd`) with Sidick's window (a rectangle: Hann), and its band RMS.
//! - **Radial profile**: the rotationally symmetric part of h′ about the part's centre (the C
//!   axis), sampled every pixel pitch; e > 0 is material standing proud. **Non-axisymmetric**:
//!   RMS and PV of h′ less it, what a plan in radius alone leaves.

use super::aperture::{Alignment, Aperture, Frame};
use super::psd::{self, Spectrum};
use super::radial::{RadialFit, KNOT_SPACING_PX};
use super::zernike::{Basis, Normalization, Ordering, Term, ZernikeError};
use super::HeightMap;
use crate::field::{Figures, Tally};
use rayon::prelude::*;

/// The ISO 10110 reference wavelength (the mercury e-line), nm: fringes when the map states none.
pub const ISO_WAVELENGTH_NM: f64 = 546.07;

/// What to analyse and how (checked: `usecases::map_analysis` builds it).
#[derive(Debug, Clone, PartialEq)]
pub struct AnalysisPlan {
    pub alignment: Alignment,
    /// Whether the centre and radius were fitted from the map (else given).
    pub fitted: bool,
    pub aperture: Aperture,
    pub remove_power: bool,
    pub zernike: Basis,
    pub ordering: Ordering,
    pub bands: Vec<Band>,
    /// λ for the ISO figures in fringes, nm.
    pub fringe_wavelength_nm: f64,
}

/// A band of spatial frequencies, per mm: low ≤ |f| < high.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    pub name: String,
    pub low_per_mm: f64,
    pub high_per_mm: f64,
}

impl Band {
    /// The documented defaults for an aperture of diameter D at pitch p: `figure` below
    /// 10/D (periods longer than a tenth of the aperture), `mid_spatial` to 1/(10·p) (periods
    /// down to ten pixels), `high` beyond, to 1/p (past the grid's corner √2/(2p), so every
    /// frequency falls in one band).
    pub fn defaults(diameter_mm: f64, pixel_mm: f64) -> Vec<Band> {
        let low = 10.0 / diameter_mm;
        let mid = (1.0 / (10.0 * pixel_mm)).max(low);
        vec![
            Band::new("figure", 0.0, low),
            Band::new("mid_spatial", low, mid),
            Band::new("high", mid, 1.0 / pixel_mm),
        ]
    }

    fn new(name: &str, low_per_mm: f64, high_per_mm: f64) -> Band {
        Band {
            name: name.into(),
            low_per_mm,
            high_per_mm,
        }
    }
}

/// A pixel of the aperture: where it is and its height after the removed terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pixel {
    pub column: usize,
    pub row: usize,
    /// Position in the part's C frame, mm.
    pub x_mm: f64,
    pub y_mm: f64,
    pub height_nm: f64,
}

/// The coefficients of the removed terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Removed {
    pub piston_nm: f64,
    /// The plane's slope along x and y of the C frame, nm per mm.
    pub tilt_x_nm_per_mm: f64,
    pub tilt_y_nm_per_mm: f64,
    /// Power removed (edge above centre), nm; `None` unless asked.
    pub power_nm: Option<f64>,
}

/// PV, RMS and PVr of h′, nm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Metrics {
    pub pv_nm: f64,
    pub rms_nm: f64,
    pub pvr_nm: f64,
}

/// The ISO 10110-5 / 14999-4 figures, nm (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IsoFigures {
    pub power_nm: f64,
    pub irregularity_nm: f64,
    pub rotationally_symmetric_irregularity_nm: f64,
    pub rms_t_nm: f64,
    pub rms_i_nm: f64,
    pub rms_s_nm: f64,
    pub rms_a_nm: f64,
    pub fringe_wavelength_nm: f64,
}

impl IsoFigures {
    /// A height in fringes: over λ/2.
    pub fn fringes(&self, nm: f64) -> f64 {
        nm / (self.fringe_wavelength_nm / 2.0)
    }
}

/// The Zernike fit.
#[derive(Debug, Clone, PartialEq)]
pub struct ZernikeFit {
    pub ordering: Ordering,
    pub normalization: Normalization,
    /// (index in the ordering, term, coefficient nm).
    pub terms: Vec<(usize, Term, f64)>,
    /// RMS of h′ less the fitted surface, nm.
    pub residual_rms_nm: f64,
    pub normalization_radius_mm: f64,
    pub centre_mm: (f64, f64),
}

/// The PSD and its bands.
#[derive(Debug, Clone, PartialEq)]
pub struct PsdAnswer {
    pub window: Window,
    /// (frequency per mm, PSD nm²·mm²), the azimuthal average.
    pub azimuthal: Vec<(f64, f64)>,
    /// Each band and its RMS, nm.
    pub bands: Vec<(Band, f64)>,
}

/// The window the PSD was taken through.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Window {
    Sidick,
    Hann,
}

/// What a rotationally symmetric process leaves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NonAxisymmetric {
    pub rms_nm: f64,
    pub pv_nm: f64,
}

/// Everything the analysis found.
#[derive(Debug, Clone, PartialEq)]
pub struct MapAnalysis {
    pub plan: AnalysisPlan,
    /// The aperture's valid pixels with h′.
    pub pixels: Vec<Pixel>,
    /// Pixels in the aperture, with data or without.
    pub area_pixels: usize,
    pub removed: Removed,
    pub metrics: Metrics,
    pub iso: IsoFigures,
    pub zernike: ZernikeFit,
    pub psd: PsdAnswer,
    /// (radius mm, e nm), every pixel pitch over the aperture's radii about the part's centre.
    pub radial_profile: Vec<(f64, f64)>,
    pub non_axisymmetric: NonAxisymmetric,
}

/// Why an analysis has no answer (found by computing).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AnalysisError {
    #[error(transparent)]
    Zernike(#[from] ZernikeError),
    #[error("the aperture's valid pixels span too few radii to tell a radial profile")]
    NoRadialProfile,
}

/// √(x² + y²): at the scale of a part (mm) nothing overflows, and it is several times quicker
/// than `hypot`.
pub(super) fn radius_of(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt()
}

/// The runs of consecutive pixels in one row: lines in the part's frame.
fn rows_of(pixels: &[Pixel]) -> Vec<std::ops::Range<usize>> {
    let mut lines = Vec::new();
    let mut start = 0;
    for i in 1..=pixels.len() {
        if i == pixels.len() || pixels[i].row != pixels[start].row {
            lines.push(start..i);
            start = i;
        }
    }
    lines
}

/// The map's pixels in an aperture, in one pass: the valid ones, positioned in the part's
/// frame with their raw heights, and how many lie there with data or without.
#[derive(Debug, Clone, PartialEq)]
pub struct Census {
    pub pixels: Vec<Pixel>,
    pub area_pixels: usize,
}

/// The aperture's pixels (see [`Census`]).
pub fn aperture_pixels(map: &HeightMap, alignment: &Alignment, aperture: &Aperture) -> Census {
    let mut pixels = Vec::with_capacity(map.valid_pixels());
    let mut area_pixels = 0;
    walk_aperture(map, alignment, aperture, |column, row, (x_mm, y_mm), h| {
        area_pixels += 1;
        if let Some(height_nm) = h {
            pixels.push(Pixel {
                column,
                row,
                x_mm,
                y_mm,
                height_nm,
            });
        }
    });
    Census {
        pixels,
        area_pixels,
    }
}

/// How many valid pixels lie in the aperture (the `pixels` of [`aperture_pixels`] alone),
/// counted by rows in parallel.
pub fn count_aperture_pixels(map: &HeightMap, alignment: &Alignment, aperture: &Aperture) -> usize {
    let frame = alignment.frame();
    map.heights_nm()
        .par_chunks(map.width())
        .enumerate()
        .map(|(row, heights)| {
            row_in_aperture(&frame, aperture, row, heights)
                .filter(|(_, _, h)| h.is_some())
                .count()
        })
        .sum()
}

/// Visits the map's pixels in the aperture in storage order: column, row, position in the
/// part's frame (mm) and height.
fn walk_aperture(
    map: &HeightMap,
    alignment: &Alignment,
    aperture: &Aperture,
    mut visit: impl FnMut(usize, usize, (f64, f64), Option<f64>),
) {
    let frame = alignment.frame();
    for (row, heights) in map.heights_nm().chunks(map.width()).enumerate() {
        for (column, position, h) in row_in_aperture(&frame, aperture, row, heights) {
            visit(column, row, position, h);
        }
    }
}

/// The pixels of one row (its `heights`) in the aperture: column, position in the part's
/// frame (mm) and height.
fn row_in_aperture<'a>(
    frame: &'a Frame,
    aperture: &'a Aperture,
    row: usize,
    heights: &'a [Option<f64>],
) -> impl Iterator<Item = (usize, (f64, f64), Option<f64>)> + 'a {
    heights.iter().enumerate().filter_map(move |(column, h)| {
        let (x, y) = frame.to_part(column as f64, row as f64);
        aperture.contains(x, y).then_some((column, (x, y), *h))
    })
}

/// The analysis (module docs) of `map` as `plan` says.
pub fn analyse(map: &HeightMap, plan: AnalysisPlan) -> Result<MapAnalysis, AnalysisError> {
    let Census {
        pixels: raw,
        area_pixels,
    } = aperture_pixels(map, &plan.alignment, &plan.aperture);
    let (cx, cy) = plan.aperture.centre_mm();
    let radius = plan.aperture.normalization_radius_mm();
    let unit = |p: &Pixel| ((p.x_mm - cx) / radius, (p.y_mm - cy) / radius);

    // One set of normal equations serves every fit: over the removal terms (piston, tilt,
    // defocus) and the terms asked for, on the pixels' rows (`zernike`, lines).
    let points = unit_points(&raw, &unit);
    let lines = rows_of(&raw);
    let removal = [
        Term { n: 0, m: 0 },
        Term { n: 1, m: 1 },
        Term { n: 1, m: -1 },
        Term { n: 2, m: 0 },
    ];
    let mut terms = removal.to_vec();
    let asked: Vec<usize> = plan
        .zernike
        .terms()
        .iter()
        .map(|t| {
            terms.iter().position(|u| u == t).unwrap_or_else(|| {
                terms.push(*t);
                terms.len() - 1
            })
        })
        .collect();
    let basis = Basis::new(terms, plan.zernike.normalization());
    let layout = basis.layout(&points, &lines);
    let normal = basis.normal_equations(&layout);
    let tilt_scaled = normal.solve(&[0, 1, 2], &normal.right[..3])?;
    let power_scaled = normal.solve(&[0, 1, 2, 3], &normal.right[..4])?;
    // As peak-normalised coefficients: 1, x, y and 2ρ² − 1.
    let peak = |c: &[f64]| -> Vec<f64> {
        c.iter()
            .enumerate()
            .map(|(k, v)| v * basis.scale(k))
            .collect()
    };
    let (tilt, power) = (peak(&tilt_scaled), peak(&power_scaled));
    let plane = |p: &(f64, f64, f64), c: &[f64]| c[0] + c[1] * p.0 + c[2] * p.1;
    let sphere =
        |p: &(f64, f64, f64)| plane(p, &power) + power[3] * (2.0 * (p.0 * p.0 + p.1 * p.1) - 1.0);
    // h_t (less piston and tilt) and h_i (less the sphere too) at each pixel; h′ is one of them.
    let tilted: Vec<f64> = points.par_iter().map(|q| q.2 - plane(q, &tilt)).collect();
    let irregular: Vec<f64> = points.par_iter().map(|q| q.2 - sphere(q)).collect();
    let (removed_scaled, removed_terms): (&[f64], &[usize]) = if plan.remove_power {
        (&power_scaled, &[0, 1, 2, 3])
    } else {
        (&tilt_scaled, &[0, 1, 2])
    };
    let (heights, removed) = if plan.remove_power {
        (
            &irregular,
            Removed {
                piston_nm: power[0] - power[3],
                tilt_x_nm_per_mm: power[1] / radius,
                tilt_y_nm_per_mm: power[2] / radius,
                power_nm: Some(2.0 * power[3]),
            },
        )
    } else {
        (
            &tilted,
            Removed {
                piston_nm: tilt[0],
                tilt_x_nm_per_mm: tilt[1] / radius,
                tilt_y_nm_per_mm: tilt[2] / radius,
                power_nm: None,
            },
        )
    };
    let mut pixels = raw;
    for (p, h) in pixels.iter_mut().zip(heights) {
        p.height_nm = *h;
    }
    // The terms asked for, fitted to the map less the removed terms: Aᵀh′ = Aᵀh − G·a.
    let right: Vec<f64> = asked
        .iter()
        .map(|&i| {
            normal.right[i]
                - removed_terms
                    .iter()
                    .zip(removed_scaled)
                    .map(|(&k, a)| normal.gram[(i, k)] * a)
                    .sum::<f64>()
        })
        .collect();
    let coefficients = normal.solve(&asked, &right)?;

    // Three independent parts of the answer, side by side: the PSD of h′, the rotationally
    // symmetric parts and what the Zernike terms leave.
    let (psd, (symmetric, fit)) = rayon::join(
        || spectrum(&plan, &pixels),
        || {
            rayon::join(
                || symmetric_parts(&plan, &pixels, &tilted, &irregular, heights),
                || {
                    let mut all = vec![0.0; basis.terms().len()];
                    for (&i, c) in asked.iter().zip(&coefficients) {
                        all[i] = *c;
                    }
                    let fitted = basis.surface(&all, &layout);
                    tally_each(fitted.len(), |i| [fitted[i], heights[i] - fitted[i]])
                },
            )
        },
    );
    let Symmetric {
        tilted: tilted_f,
        irregular: irregular_f,
        s: s_f,
        variant: variant_f,
        leftover: leftover_f,
        about_axis,
    } = symmetric?;
    let [fitted_f, residual_f] = fit;
    let iso = IsoFigures {
        power_nm: 2.0 * power[3],
        irregularity_nm: irregular_f.pv,
        rotationally_symmetric_irregularity_nm: s_f.pv,
        rms_t_nm: tilted_f.rms,
        rms_i_nm: irregular_f.rms,
        rms_s_nm: s_f.rms,
        rms_a_nm: variant_f.rms,
        fringe_wavelength_nm: plan.fringe_wavelength_nm,
    };
    let radial_profile = sample_profile(&about_axis, plan.alignment.pixel_mm);
    let non_axisymmetric = NonAxisymmetric {
        rms_nm: leftover_f.rms,
        pv_nm: leftover_f.pv,
    };
    // The residual's RMS about 0 (its mean is 0 to rounding when piston is among the terms).
    let residual_rms = residual_f.rms.hypot(residual_f.mean);
    let figure = if plan.remove_power {
        irregular_f
    } else {
        tilted_f
    };
    let metrics = Metrics {
        pv_nm: figure.pv,
        rms_nm: figure.rms,
        pvr_nm: fitted_f.pv + 3.0 * residual_rms,
    };
    let zernike = ZernikeFit {
        ordering: plan.ordering,
        normalization: plan.zernike.normalization(),
        terms: plan
            .zernike
            .terms()
            .iter()
            .zip(&coefficients)
            .map(|(t, c)| (plan.ordering.index(*t).unwrap_or(0), *t, *c))
            .collect(),
        residual_rms_nm: residual_rms,
        normalization_radius_mm: radius,
        centre_mm: (cx, cy),
    };

    Ok(MapAnalysis {
        plan,
        pixels,
        area_pixels,
        removed,
        metrics,
        iso,
        zernike,
        psd,
        radial_profile,
        non_axisymmetric,
    })
}

/// The figures of h_t, h_i, s (ISO's rotationally symmetric part of h_i about the aperture's
/// centre), h_i − s and h′ less its radial profile about the C axis (what a radial plan
/// leaves), with that profile.
struct Symmetric {
    tilted: Figures,
    irregular: Figures,
    s: Figures,
    variant: Figures,
    leftover: Figures,
    about_axis: RadialFit,
}

/// [`Symmetric`] of the pixels: the two radial fits (one basis a pixel when the aperture's
/// centre is the axis), then one pass for the figures.
fn symmetric_parts(
    plan: &AnalysisPlan,
    pixels: &[Pixel],
    tilted: &[f64],
    irregular: &[f64],
    heights: &[f64],
) -> Result<Symmetric, AnalysisError> {
    let (cx, cy) = plan.aperture.centre_mm();
    let spacing = KNOT_SPACING_PX * plan.alignment.pixel_mm;
    let axis_radii: Vec<f64> = pixels
        .par_iter()
        .map(|p| radius_of(p.x_mm, p.y_mm))
        .collect();
    let centred = cx == 0.0 && cy == 0.0;
    let aperture_radii: Vec<f64> = if centred {
        Vec::new()
    } else {
        pixels
            .par_iter()
            .map(|p| radius_of(p.x_mm - cx, p.y_mm - cy))
            .collect()
    };
    // The bases at the pixels' radii about the axis come from the fit, for the pass below.
    let (symmetric, about_axis, bases) = if centred {
        let (mut fits, bases) =
            RadialFit::fit_each_with_bases(&axis_radii, &[irregular, heights], spacing)
                .ok_or(AnalysisError::NoRadialProfile)?;
        let about_axis = fits.pop().ok_or(AnalysisError::NoRadialProfile)?;
        (
            fits.pop().ok_or(AnalysisError::NoRadialProfile)?,
            about_axis,
            bases,
        )
    } else {
        let symmetric = RadialFit::fit_each(&aperture_radii, &[irregular], spacing)
            .and_then(|mut f| f.pop())
            .ok_or(AnalysisError::NoRadialProfile)?;
        let (mut fits, bases) = RadialFit::fit_each_with_bases(&axis_radii, &[heights], spacing)
            .ok_or(AnalysisError::NoRadialProfile)?;
        let about_axis = fits.pop().ok_or(AnalysisError::NoRadialProfile)?;
        (symmetric, about_axis, bases)
    };
    let [tilted, irregular_f, s, variant, leftover] = tally_each(pixels.len(), |i| {
        let b = &bases[i];
        let s = if centred {
            symmetric.at_basis(b)
        } else {
            symmetric.at(aperture_radii[i])
        };
        [
            tilted[i],
            irregular[i],
            s,
            irregular[i] - s,
            heights[i] - about_axis.at_basis(b),
        ]
    });
    Ok(Symmetric {
        tilted,
        irregular: irregular_f,
        s,
        variant,
        leftover,
        about_axis,
    })
}

/// The PSD of h′ over the aperture's box of pixels (module docs of `psd`).
fn spectrum(plan: &AnalysisPlan, pixels: &[Pixel]) -> PsdAnswer {
    spectrum_of(&plan.aperture, plan.alignment.pixel_mm, &plan.bands, pixels)
}

/// The window an aperture's PSD is taken through: Hann on a rectangle, else Sidick's.
pub fn window_for(aperture: &Aperture) -> Window {
    match aperture {
        Aperture::Rectangle { .. } => Window::Hann,
        _ => Window::Sidick,
    }
}

/// The PSD (its azimuthal average, the bands' RMS) of `pixels` (heights as they are) over
/// the aperture's box of pixels.
pub fn spectrum_of(
    aperture: &Aperture,
    pixel_mm: f64,
    bands: &[Band],
    pixels: &[Pixel],
) -> PsdAnswer {
    let (c0, c1, r0, r1) = pixels
        .iter()
        .fold((usize::MAX, 0, usize::MAX, 0), |(a, b, c, d), p| {
            (a.min(p.column), b.max(p.column), c.min(p.row), d.max(p.row))
        });
    let (columns, rows) = (c1 + 1 - c0, r1 + 1 - r0);
    let (cx, cy) = aperture.centre_mm();
    let radius = aperture.normalization_radius_mm();
    let window_at = |p: &Pixel| match *aperture {
        Aperture::Rectangle {
            width_mm,
            height_mm,
            ..
        } => psd::hann_window(
            (p.x_mm - cx) / width_mm + 0.5,
            (p.y_mm - cy) / height_mm + 0.5,
        ),
        _ => psd::sidick_window(radius_of(p.x_mm - cx, p.y_mm - cy) / radius),
    };
    let windows: Vec<f64> = pixels.par_iter().map(window_at).collect();
    let mut values = vec![0.0; columns * rows];
    let mut power = 0.0;
    for (p, w) in pixels.iter().zip(&windows) {
        values[(p.row - r0) * columns + (p.column - c0)] = p.height_nm * w;
        power += w * w;
    }
    let window = window_for(aperture);
    match Spectrum::new(&values, columns, rows, pixel_mm, power) {
        Some(s) => {
            let limits: Vec<(f64, f64)> = bands
                .iter()
                .map(|b| (b.low_per_mm, b.high_per_mm))
                .collect();
            let summary = s.summary(&limits);
            PsdAnswer {
                window,
                azimuthal: summary.azimuthal,
                bands: bands.iter().cloned().zip(summary.band_rms).collect(),
            }
        }
        None => PsdAnswer {
            window,
            azimuthal: Vec::new(),
            bands: bands.iter().map(|b| (b.clone(), 0.0)).collect(),
        },
    }
}

/// Each pixel as (x, y, height) with x, y in the aperture's unit coordinates (`unit`): what
/// the Zernike fits take.
fn unit_points(
    pixels: &[Pixel],
    unit: &(dyn Fn(&Pixel) -> (f64, f64) + Sync),
) -> Vec<(f64, f64, f64)> {
    pixels
        .par_iter()
        .map(|p| {
            let (x, y) = unit(p);
            (x, y, p.height_nm)
        })
        .collect()
}

/// Piston, tilt x and tilt y (peak-normalised, in the aperture's unit coordinates) of the
/// least-squares plane through `pixels`; zeros when they cannot carry a plane.
pub fn plane_fit(pixels: &[Pixel], unit: &(dyn Fn(&Pixel) -> (f64, f64) + Sync)) -> [f64; 3] {
    let basis = Basis::first(Ordering::Fringe, 3, Normalization::Peak).expect("Fringe has 3 terms");
    match basis.fit(&unit_points(pixels, unit)) {
        Ok(c) => [c[0], c[1], c[2]],
        Err(_) => [0.0; 3],
    }
}

/// A radial fit sampled every pixel pitch over its radii (and at its outer end).
pub fn sample_profile(fit: &RadialFit, pixel_mm: f64) -> Vec<(f64, f64)> {
    let (r_min, r_max) = fit.range_mm();
    let samples = ((r_max - r_min) / pixel_mm).floor() as usize;
    let mut profile: Vec<(f64, f64)> = (0..=samples)
        .map(|k| r_min + k as f64 * pixel_mm)
        .chain((r_min + samples as f64 * pixel_mm < r_max).then_some(r_max))
        .map(|r| (r, fit.at(r)))
        .collect();
    profile.dedup_by(|a, b| a.0 == b.0);
    profile
}

/// The figures of each of the K values `value(i)` gives, i < n, in one parallel pass that
/// stores nothing ([`Tally`]).
pub(super) fn tally_each<const K: usize>(
    n: usize,
    value: impl Fn(usize) -> [f64; K] + Sync,
) -> [Figures; K] {
    const CHUNK: usize = 16_384;
    if n == 0 {
        return [Tally::new(0.0).figures(); K];
    }
    let shifts = value(0);
    let fresh = || shifts.map(Tally::new);
    let starts: Vec<usize> = (0..n).step_by(CHUNK).collect();
    let tallies = starts
        .par_iter()
        .map(|&start| {
            let mut tallies = fresh();
            for i in start..(start + CHUNK).min(n) {
                for (t, v) in tallies.iter_mut().zip(value(i)) {
                    t.push(v);
                }
            }
            tallies
        })
        // Added in order, whatever the threads: the same answer to the last bit.
        .collect::<Vec<_>>()
        .into_iter()
        .fold(fresh(), |mut a, b| {
            for (a, b) in a.iter_mut().zip(&b) {
                a.merge(b);
            }
            a
        });
    tallies.map(|t| t.figures())
}
