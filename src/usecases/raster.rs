//! What the X-Y machine's use cases share (`machine.kinematics: cartesian`): the tool's
//! influence function from a spot test's map, the part's frame on a map, the lattice the
//! removal is computed on, and the figures a plan is judged by.
//!
//! **The influence function.** A spot test's map holds the removal (nm, material removed
//! positive) of the tool standing still for `duration_s` seconds, or the rate (nm/s) itself
//! when no duration is given. Missing pixels count as no removal. The tool's centre is the
//! removal-weighted centroid of the positive pixels unless `centre_px` names it (column, row
//! of the map, fractions allowed). Between pixels the rate is bilinear
//! (`physics::influence`).
//!
//! **The frame.** A map's pixel (c, r) sits at x = (c − (w − 1)/2)·p, y = ((h − 1)/2 − r)·p:
//! mm from the map's centre, x right, y up, rows top first. The clear aperture is the map's
//! pixels with data. The removal is computed on the map's lattice grown on every side by the
//! tool's reach (the farthest sample of at least 1 % of the peak rate, plus a pixel) and a
//! dwell step: dwell may go wherever the tool still reaches the aperture, and only the
//! aperture judges it (surface extension, solved rather than guessed).

use crate::field::Figures;
use crate::maps::HeightMap;
use crate::physics::influence::{Influence, InfluenceError};
use crate::physics::raster::Lattice;

/// The share of the peak rate beyond which the tool is taken to reach no further.
pub const REACH_SHARE: f64 = 0.01;

/// A spot test: its map, pixel, duration and the tool's centre on it.
#[derive(Debug, Clone, PartialEq)]
pub struct SpotSpec {
    pub map: HeightMap,
    /// The map's pixel, mm; default the map's own.
    pub pixel_mm: Option<f64>,
    /// The spot's dwell, s; `None`: the map is the rate in nm/s.
    pub duration_s: Option<f64>,
    /// The tool's centre on the map (column, row); default the removal's centroid.
    pub centre_px: Option<[f64; 2]>,
}

/// Why the inputs of an X-Y use case are refused, each naming its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RasterInputError {
    #[error("the spot map's pixel is not known: give `pixel_mm` (its file does not say)")]
    SpotPixel,
    #[error("the spot's duration must be a positive number of seconds, not {0}")]
    SpotDuration(f64),
    #[error("the tool's centre must be a finite (column, row) on the spot map, not {0:?}")]
    SpotCentre([f64; 2]),
    #[error("the spot map removes nothing: no pixel holds a positive removal")]
    SpotEmpty,
    #[error(
        "the spot's peak rate is {0:e} nm/s: a tool removes between {MIN_RATE:e} and \
         {MAX_RATE:e} nm/s (is the map in nm, and `duration_s` in seconds?)"
    )]
    SpotRate(f64),
    #[error(
        "the map holds a height of {0:e} nm: a figure error is within ±{MAX_HEIGHT_NM:e} nm \
         (is the map in nm?)"
    )]
    Height(f64),
    #[error("the pixel must be between {MIN_PIXEL_MM:e} and {MAX_PIXEL_MM:e} mm, not {0}")]
    PixelRange(f64),
    #[error(
        "the spot map's pixel must be between {MIN_PIXEL_MM:e} and {MAX_PIXEL_MM:e} mm, not {0}"
    )]
    SpotPixelRange(f64),
    #[error(transparent)]
    Influence(#[from] InfluenceError),
    #[error("the map's pixel is not known: give `pixel_mm` (its file does not say)")]
    MapPixel,
    #[error("the pixel must be a positive number of mm, not {0}")]
    Pixel(f64),
    #[error("the dwell pitch must be a positive number of mm, not {0}")]
    DwellPitch(f64),
    #[error(
        "the map grown by the tool's reach is {pixels} pixels; at most {max} are computed \
         (a coarser map or a smaller tool)"
    )]
    TooManyPixels { pixels: usize, max: usize },
    #[error(
        "a dwell pitch of {pitch_mm} mm puts {points} dwell points on the part; at most {max} \
         are planned (a pitch of at least {smallest_mm:.3} mm)"
    )]
    TooManyPoints {
        pitch_mm: f64,
        points: usize,
        max: usize,
        smallest_mm: f64,
    },
}

/// The peak rates an influence function may have, nm/s: a nanometre a day to a metre a
/// second, so every figure of a plan stays far inside the numbers' range.
pub const MIN_RATE: f64 = 1e-5;
pub const MAX_RATE: f64 = 1e9;
/// The largest |height| of a map to correct, nm (a metre).
pub const MAX_HEIGHT_NM: f64 = 1e9;
/// The pixels a lattice may have, mm.
pub const MIN_PIXEL_MM: f64 = 1e-6;
pub const MAX_PIXEL_MM: f64 = 1e4;

/// Whether a pixel is within [`MIN_PIXEL_MM`, `MAX_PIXEL_MM`].
pub fn check_pixel(pixel_mm: f64) -> Result<f64, RasterInputError> {
    if (MIN_PIXEL_MM..=MAX_PIXEL_MM).contains(&pixel_mm) {
        Ok(pixel_mm)
    } else {
        Err(RasterInputError::PixelRange(pixel_mm))
    }
}

/// Whether a map's heights are within ±[`MAX_HEIGHT_NM`].
pub fn check_heights(map: &HeightMap) -> Result<(), RasterInputError> {
    match map
        .heights_nm()
        .iter()
        .flatten()
        .find(|h| h.abs() > MAX_HEIGHT_NM)
    {
        Some(&h) => Err(RasterInputError::Height(h)),
        None => Ok(()),
    }
}

/// The most pixels a lattice may have (the map grown by the reach): 4,194,304, a
/// 2048 × 2048 grid, whose transforms take about 70 MB each.
pub const MAX_LATTICE_PIXELS: usize = 1 << 22;
/// The most dwell points a plan may have.
pub const MAX_POINTS: usize = 250_000;

impl SpotSpec {
    /// The influence function the spot measured, nm/s.
    pub fn influence(&self) -> Result<Influence, RasterInputError> {
        let map = &self.map;
        let pitch = self
            .pixel_mm
            .or(map.pixel_mm())
            .ok_or(RasterInputError::SpotPixel)?;
        if !(pitch.is_finite() && pitch > 0.0) {
            return Err(RasterInputError::Pixel(pitch));
        }
        check_pixel(pitch).map_err(|_| RasterInputError::SpotPixelRange(pitch))?;
        let per_second = match self.duration_s {
            None => 1.0,
            Some(d) if d.is_finite() && d > 0.0 => 1.0 / d,
            Some(d) => return Err(RasterInputError::SpotDuration(d)),
        };
        let (w, h) = (map.width(), map.height());
        let centre = match self.centre_px {
            Some(c) if c.iter().all(|v| v.is_finite()) => c,
            Some(c) => return Err(RasterInputError::SpotCentre(c)),
            None => {
                let (mut sx, mut sy, mut s) = (0.0, 0.0, 0.0);
                for (k, v) in map.heights_nm().iter().enumerate() {
                    if let Some(v) = v.filter(|v| *v > 0.0) {
                        sx += v * (k % w) as f64;
                        sy += v * (k / w) as f64;
                        s += v;
                    }
                }
                if s <= 0.0 {
                    return Err(RasterInputError::SpotEmpty);
                }
                [sx / s, sy / s]
            }
        };
        // Influence rows ascend in y: the map's bottom row first.
        let mut rates = Vec::with_capacity(w * h);
        for r in (0..h).rev() {
            for c in 0..w {
                rates.push(map.at(c, r).unwrap_or(0.0) * per_second);
            }
        }
        // Sample (0, 0) is the map's bottom-left pixel: its offset from the centre.
        let origin = [-centre[0] * pitch, -((h - 1) as f64 - centre[1]) * pitch];
        let influence = Influence::new(w, h, pitch, origin, rates)?;
        let peak = influence.peak_nm_per_s();
        if !(MIN_RATE..=MAX_RATE).contains(&peak) {
            return Err(RasterInputError::SpotRate(peak));
        }
        // A negative pixel (a spot map's noise) deeper than the peak is not a spot.
        if let Some(&low) = influence.rates().iter().find(|r| **r < -peak) {
            return Err(RasterInputError::SpotRate(low));
        }
        Ok(influence)
    }
}

/// A map placed in the part's frame (module docs) on a lattice grown around it.
#[derive(Debug, Clone, PartialEq)]
pub struct Placed {
    pub lattice: Lattice,
    /// The map's top-left pixel on the lattice (column, row).
    pub offset: [usize; 2],
    pub width: usize,
    pub height: usize,
}

impl Placed {
    /// `width` × `height` pixels of `pixel_mm` centred on the origin, grown by `margin` pixels
    /// on every side.
    pub fn new(
        width: usize,
        height: usize,
        pixel_mm: f64,
        margin: usize,
    ) -> Result<Placed, RasterInputError> {
        let (nx, ny) = (width + 2 * margin, height + 2 * margin);
        let pixels = nx.saturating_mul(ny);
        if pixels > MAX_LATTICE_PIXELS {
            return Err(RasterInputError::TooManyPixels {
                pixels,
                max: MAX_LATTICE_PIXELS,
            });
        }
        let x0 = -((width - 1) as f64 / 2.0 + margin as f64) * pixel_mm;
        let y0 = ((height - 1) as f64 / 2.0 + margin as f64) * pixel_mm;
        Ok(Placed {
            lattice: Lattice {
                nx,
                ny,
                pitch_mm: pixel_mm,
                x0_mm: x0,
                y0_mm: y0,
            },
            offset: [margin, margin],
            width,
            height,
        })
    }

    /// The lattice index of the map's pixel (c, r).
    pub fn index(&self, c: usize, r: usize) -> usize {
        self.lattice.index([c + self.offset[0], r + self.offset[1]])
    }

    /// A lattice image cut to the map's pixels, row-major from the top row.
    pub fn crop(&self, image: &[f64]) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.width * self.height);
        for r in 0..self.height {
            let start = self.index(0, r);
            out.extend_from_slice(&image[start..start + self.width]);
        }
        out
    }

    /// The map's columns' x and rows' y, mm.
    pub fn axes_mm(&self) -> (Vec<f64>, Vec<f64>) {
        let l = &self.lattice;
        (
            (0..self.width)
                .map(|c| l.x_mm(c + self.offset[0]))
                .collect(),
            (0..self.height)
                .map(|r| l.y_mm(r + self.offset[1]))
                .collect(),
        )
    }
}

/// `values` (row-major, `width` per row, `None` without data) as a map less its least-squares
/// piston and tilt (`HeightMap::without_piston_and_tilt`): the residual a metrologist quotes,
/// and its figures. At least one value must be given.
pub fn without_tilt(values: &[Option<f64>], width: usize) -> (HeightMap, Figures) {
    let rows = values.chunks(width).map(<[_]>::to_vec).collect();
    let map = HeightMap::from_rows(rows, None, None, usize::MAX)
        .expect("an aperture has a pixel with data")
        .without_piston_and_tilt();
    let figures = map.figures().expect("an aperture has a pixel with data");
    (map, figures)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spot_map_becomes_the_rate_about_its_centroid() {
        // A 5 × 3 spot, its removal peaked at column 3, row 1, over 4 s.
        let rows = vec![
            vec![Some(0.0), Some(0.0), Some(2.0), Some(4.0), Some(0.0)],
            vec![Some(0.0), Some(2.0), Some(8.0), Some(16.0), None],
            vec![Some(0.0), Some(0.0), Some(2.0), Some(4.0), Some(-1.0)],
        ];
        let map = HeightMap::from_rows(rows, Some(0.5), None, 100).unwrap();
        let spot = SpotSpec {
            map,
            pixel_mm: None,
            duration_s: Some(4.0),
            centre_px: Some([3.0, 1.0]),
        };
        let f = spot.influence().unwrap();
        assert!((f.at(0.0, 0.0) - 4.0).abs() < 1e-12);
        // A row up (y + pixel) is the top row.
        assert!((f.at(0.0, 0.5) - 1.0).abs() < 1e-12);
        assert!((f.at(-0.5, 0.0) - 2.0).abs() < 1e-12);
        assert!((f.at(0.5, -0.5) - (-0.25)).abs() < 1e-12);
        // The centroid of the positive removal.
        let centred = SpotSpec {
            centre_px: None,
            ..spot
        };
        let g = centred.influence().unwrap();
        let total: f64 = 2.0 + 4.0 + 2.0 + 8.0 + 16.0 + 2.0 + 4.0;
        let cx =
            (2.0 * 2.0 + 4.0 * 3.0 + 2.0 * 1.0 + 8.0 * 2.0 + 16.0 * 3.0 + 2.0 * 2.0 + 4.0 * 3.0)
                / total;
        assert!((g.at((3.0 - cx) * 0.5, 0.0) - 4.0).abs() < 1e-12);
    }
}
