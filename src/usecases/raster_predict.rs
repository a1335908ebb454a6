//! A raster plan's removal as a map on an X-Y machine (`POST /v1/maps/predict` with
//! `machine.kinematics: cartesian`): the exact removal of the motion the machine executes
//! (`physics::raster`) through dwell points in the order given, under a measured influence
//! function.
//!
//! The points lie on a square lattice of `pixel_mm` aligned with the first point; the removal
//! is reported on that lattice over the points grown by the tool's whole support. With the
//! map the plan corrects (heights, nm), the lattice is the map's frame (`usecases::raster`):
//! the points must sit on its pixels, and the residual removal − map (piston and tilt free)
//! is judged over its pixels with data.

use super::raster::{without_tilt, Placed, RasterInputError, SpotSpec};
use crate::field::Figures;
use crate::maps::HeightMap;
use crate::optimize::raster::{peaks, AxisPeaks};
use crate::physics::influence::Influence;
use crate::physics::raster::{Raster, RasterError, RasterOperator};

/// The longest dwell at one point, s (a year).
pub const MAX_DWELL_S: f64 = 3.2e7;

/// The farthest a point may be from the map's centre, mm (10 m).
pub const MAX_COORDINATE_MM: f64 = 1e4;

/// The most dwell points one prediction takes.
pub const MAX_PREDICT_POINTS: usize = super::raster::MAX_POINTS;

#[derive(Debug, Clone, PartialEq)]
pub struct RasterPredictSpec {
    pub spot: SpotSpec,
    /// The dwell points in path order, mm, and their dwell, s.
    pub points_mm: Vec<[f64; 2]>,
    pub dwell_s: Vec<f64>,
    /// The lattice's pixel, mm; default the map's, else the influence function's.
    pub pixel_mm: Option<f64>,
    /// The map the plan corrects, for the residual.
    pub map: Option<HeightMap>,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RasterPredictError {
    #[error(transparent)]
    Input(#[from] RasterInputError),
    #[error("the plan needs as many dwell times as points: {points} points, {dwell} dwell times")]
    Lengths { points: usize, dwell: usize },
    #[error("dwell {index} must be a number of seconds in [0, {MAX_DWELL_S:e}], not {value}")]
    Dwell { index: usize, value: f64 },
    #[error(
        "point {index} ({x}, {y}) mm is not on the lattice of {pixel_mm} mm pixels through the \
         first point{}: the points of a raster sit on pixels",
        if *map { " and the map's pixels" } else { "" }
    )]
    OffLattice {
        index: usize,
        x: f64,
        y: f64,
        pixel_mm: f64,
        map: bool,
    },
    #[error("{0}")]
    Raster(#[from] RasterError),
    #[error("point {index} must be [x, y] mm, each within ±{MAX_COORDINATE_MM} mm")]
    Point { index: usize },
    #[error("a plan of {points} points: at most {max} are taken")]
    TooManyPoints { points: usize, max: usize },
}

#[derive(Debug)]
pub struct RasterPredictCommand {
    influence: Influence,
    placed: Placed,
    pixels: Vec<[usize; 2]>,
    dwell_s: Vec<f64>,
    map: Option<HeightMap>,
}

/// The removal and its figures.
#[derive(Debug, Clone)]
pub struct RasterPrediction {
    pub pixel_mm: f64,
    pub x_mm: Vec<f64>,
    pub y_mm: Vec<f64>,
    /// Row-major from the top: the removal, nm.
    pub removal_nm: Vec<f64>,
    /// With a map: removal − (map + the best piston and tilt) on its pixels with data.
    pub residual_nm: Option<Vec<Option<f64>>>,
    /// The removal's figures over the map's pixels with data (every pixel without a map).
    pub removal: Figures,
    /// With a map: the map's and the residual's figures, piston and tilt removed.
    pub before: Option<Figures>,
    pub after: Option<Figures>,
    pub total_time_s: f64,
    pub blocks: usize,
    pub peaks: [AxisPeaks; 2],
}

impl RasterPredictCommand {
    pub fn new(spec: RasterPredictSpec) -> Result<RasterPredictCommand, RasterPredictError> {
        let n = spec.points_mm.len();
        check_plan(&spec.points_mm, &spec.dwell_s)?;
        let influence = spec.spot.influence()?;
        let pixel = spec
            .pixel_mm
            .or(spec.map.as_ref().and_then(HeightMap::pixel_mm))
            .unwrap_or(influence.pitch_mm());
        if !(pixel.is_finite() && pixel > 0.0) {
            return Err(RasterInputError::Pixel(pixel).into());
        }
        super::raster::check_pixel(pixel)?;
        if let Some(map) = &spec.map {
            super::raster::check_heights(map)?;
        }
        // The points in pixels from the first; off the lattice beyond 1e-6 of a pixel, refused.
        let first = spec.points_mm[0];
        let mut steps = Vec::with_capacity(n);
        for (index, p) in spec.points_mm.iter().enumerate() {
            let (u, v) = ((p[0] - first[0]) / pixel, (first[1] - p[1]) / pixel);
            let (ur, vr) = (u.round(), v.round());
            if !((u - ur).abs() <= 1e-6 && (v - vr).abs() <= 1e-6)
                || ur.abs() > 1e7
                || vr.abs() > 1e7
            {
                return Err(RasterPredictError::OffLattice {
                    index,
                    x: p[0],
                    y: p[1],
                    pixel_mm: pixel,
                    map: false,
                });
            }
            steps.push([ur as i64, vr as i64]);
        }
        // The map's frame (or the first point's, without one): the map's top-left pixel at
        // (c0, r0) pixels from the first point.
        let (width, height, origin) = match &spec.map {
            Some(map) => {
                let (w, h) = (map.width(), map.height());
                let c = first[0] / pixel + (w - 1) as f64 / 2.0;
                let r = (h - 1) as f64 / 2.0 - first[1] / pixel;
                if (c - c.round()).abs() > 1e-6 || (r - r.round()).abs() > 1e-6 {
                    return Err(RasterPredictError::OffLattice {
                        index: 0,
                        x: first[0],
                        y: first[1],
                        pixel_mm: pixel,
                        map: true,
                    });
                }
                // The first point is the map's pixel (c, r): the map's corner at −(c, r).
                (w, h, [-(c.round() as i64), -(r.round() as i64)])
            }
            None => (1, 1, [0, 0]),
        };
        // The lattice: the map and the points, grown by the influence's support.
        let ([xlo, xhi], [ylo, yhi]) = influence.support_mm();
        let reach = xlo.abs().max(xhi.abs()).max(ylo.abs()).max(yhi.abs());
        let margin = (reach / pixel).ceil() as i64 + 1;
        let (mut lo, mut hi) = (
            origin,
            [origin[0] + width as i64 - 1, origin[1] + height as i64 - 1],
        );
        if spec.map.is_none() {
            lo = steps[0];
            hi = steps[0];
        }
        for s in &steps {
            lo = [lo[0].min(s[0]), lo[1].min(s[1])];
            hi = [hi[0].max(s[0]), hi[1].max(s[1])];
        }
        let (lo, hi) = (
            [lo[0] - margin, lo[1] - margin],
            [hi[0] + margin, hi[1] + margin],
        );
        let (nx, ny) = ((hi[0] - lo[0] + 1) as usize, (hi[1] - lo[1] + 1) as usize);
        if nx.saturating_mul(ny) > super::raster::MAX_LATTICE_PIXELS {
            return Err(RasterInputError::TooManyPixels {
                pixels: nx.saturating_mul(ny),
                max: super::raster::MAX_LATTICE_PIXELS,
            }
            .into());
        }
        let lattice = crate::physics::raster::Lattice {
            nx,
            ny,
            pitch_mm: pixel,
            x0_mm: first[0] + lo[0] as f64 * pixel,
            y0_mm: first[1] - lo[1] as f64 * pixel,
        };
        let (w, h) = if spec.map.is_some() {
            (width, height)
        } else {
            (nx, ny)
        };
        let offset = if spec.map.is_some() {
            [(origin[0] - lo[0]) as usize, (origin[1] - lo[1]) as usize]
        } else {
            [0, 0]
        };
        let placed = Placed {
            lattice,
            offset,
            width: w,
            height: h,
        };
        let pixels = steps
            .iter()
            .map(|s| [(s[0] - lo[0]) as usize, (s[1] - lo[1]) as usize])
            .collect();
        Ok(RasterPredictCommand {
            influence,
            placed,
            pixels,
            dwell_s: spec.dwell_s,
            map: spec.map,
        })
    }
}

/// A plan's points and dwell, as every raster endpoint takes them: one dwell per point, each
/// in [0, [`MAX_DWELL_S`]], 1 to [`MAX_PREDICT_POINTS`] points within ±[`MAX_COORDINATE_MM`].
pub fn check_plan(points_mm: &[[f64; 2]], dwell_s: &[f64]) -> Result<(), RasterPredictError> {
    let n = points_mm.len();
    if n != dwell_s.len() {
        return Err(RasterPredictError::Lengths {
            points: n,
            dwell: dwell_s.len(),
        });
    }
    if n == 0 {
        return Err(RasterError::Empty.into());
    }
    if n > MAX_PREDICT_POINTS {
        return Err(RasterPredictError::TooManyPoints {
            points: n,
            max: MAX_PREDICT_POINTS,
        });
    }
    if let Some((index, &value)) = dwell_s
        .iter()
        .enumerate()
        .find(|(_, v)| !(v.is_finite() && (0.0..=MAX_DWELL_S).contains(*v)))
    {
        return Err(RasterPredictError::Dwell { index, value });
    }
    if let Some(index) = points_mm.iter().position(|p| {
        p.iter()
            .any(|c| !c.is_finite() || c.abs() > MAX_COORDINATE_MM)
    }) {
        return Err(RasterPredictError::Point { index });
    }
    Ok(())
}

pub fn raster_predict(
    command: RasterPredictCommand,
) -> Result<RasterPrediction, RasterPredictError> {
    let RasterPredictCommand {
        influence,
        placed,
        pixels,
        dwell_s,
        map,
    } = command;
    let raster = Raster::along(placed.lattice, pixels)?;
    let operator = RasterOperator::new(&raster, &influence);
    let removal = placed.crop(&operator.apply(&dwell_s));
    let (x_mm, y_mm) = placed.axes_mm();
    let blocks = raster.blocks(&dwell_s);
    let (residual_nm, before, after) = match &map {
        Some(map) => {
            let difference: Vec<Option<f64>> = map
                .heights_nm()
                .iter()
                .zip(&removal)
                .map(|(h, m)| h.map(|h| m - h))
                .collect();
            let (_, before) = without_tilt(map.heights_nm(), placed.width);
            let (residual, after) = without_tilt(&difference, placed.width);
            (
                Some(residual.heights_nm().to_vec()),
                Some(before),
                Some(after),
            )
        }
        None => (None, None, None),
    };
    let mut tally = crate::field::Tally::new(0.0);
    for (k, v) in removal.iter().enumerate() {
        if map.as_ref().is_none_or(|m| m.heights_nm()[k].is_some()) {
            tally.push(*v);
        }
    }
    Ok(RasterPrediction {
        pixel_mm: placed.lattice.pitch_mm,
        x_mm,
        y_mm,
        removal: tally.figures(),
        removal_nm: removal,
        residual_nm,
        before,
        after,
        total_time_s: dwell_s.iter().sum(),
        blocks: blocks.len(),
        peaks: peaks(&blocks),
    })
}
