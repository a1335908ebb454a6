//! A polar plan's removal as a map, on the paper's machine (`POST /v1/maps/predict`): the exact
//! depth the executed motion leaves at each pixel of the part (`physics::polar`). The plan is a
//! 1-D dwell plan (stations and the dwell in each one's cell, run as today's stops and moves)
//! and C's speed law: constant, or a [`SectorLaw`] of speed factors per station and sector.
//! Cut at the sector edges, the motion is a chain of blocks at constant X and C speed, each a
//! ring (closed form) or a piece of spiral (quadrature to 1e-11 of the largest rate).
//!
//! The map is square, centred on the axis, the part's diameter across, `pixel_mm` apart; the
//! pixels off the part carry no value. Over the clear aperture (an annulus about the axis) the
//! removal's figures are taken over its pixels, each standing for the same area: mean, PV, RMS
//! about the mean, nonuniformity PV/mean. Its rotationally variant part is the removal less
//! its azimuthal mean at each pixel's radius — exact, Σ ∫ R_Ω(t)(r; r1(t)) dt over the blocks
//! (the identity of `physics::polar`: the 1-D removal at each instant's C speed): what a C
//! law puts there on purpose, and what a spiral's pitch and a partial ring's ends leave as
//! ripple. The azimuthal mean is reported on a radial grid as well; with C at constant speed it
//! is `/v1/predict`'s 1-D removal.

use super::map_removal_function::square_axes;
use super::setting::{ApertureSpec, GridSpec, PartSpec, Setting};
use super::warnings::unit_warnings;
use super::{ComputeLimits, Input, InputError, Warning};
use crate::field::{Figures, Tally};
use crate::physics::polar::{executed_blocks, PolarPad};
use crate::physics::{ClearAperture, DwellSchedule, ProcessSpec, SectorLaw, SectorLawError};

/// Pixels across the part's diameter by default.
pub const DEFAULT_PIXELS_ACROSS: usize = 101;

/// The most work one prediction may take, in pixel-turns: the pixels on the part × (the turns
/// of C the plan runs + a tenth of its blocks). Measured on 2 cores (a 100 mm part, 101
/// stations, over HTTP): about 0.46 µs per pixel and turn and 0.05 µs per pixel and block, so
/// the limit is about 14 s (a synchronous request; longer plans wait for jobs).
pub const MAX_WORK: f64 = 3e7;

/// The most blocks (constant-speed pieces of the executed motion) one prediction may cut
/// (about 64 bytes each).
pub const MAX_BLOCKS: f64 = 1e6;

/// C's speed law as asked: `sectors` equal sectors per turn and, for each station, a speed
/// factor per sector (`physics::SectorLaw`).
#[derive(Debug, Clone, PartialEq)]
pub struct CLawSpec {
    pub sectors: usize,
    pub speed_factors: Vec<Vec<f64>>,
}

/// Why C's law does not fit the plan.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CLawError {
    #[error("c_law.speed_factors has {got} rows; the plan has {stations} stations, one row each")]
    Rows { stations: usize, got: usize },
    #[error("c_law.speed_factors[{station}] has {got} factors; c_law.sectors is {sectors}")]
    Row {
        station: usize,
        sectors: usize,
        got: usize,
    },
    #[error(transparent)]
    Law(SectorLawError),
}

/// The turns of C a plan under C's law runs at most (each station's dwell at its fastest
/// factor) at the part speed `omega` (rad/s), and the blocks that cuts at `per_turn` blocks a
/// turn, with one more at most where each stop or move ends.
pub(super) fn law_work(
    schedule: &DwellSchedule,
    fastest: &[f64],
    omega: f64,
    per_turn: f64,
) -> (f64, f64) {
    let turns: f64 = schedule
        .dwell_s()
        .iter()
        .zip(fastest)
        .map(|(t, f)| t * omega.abs() * f / std::f64::consts::TAU)
        .sum();
    let blocks = turns * per_turn + 2.0 * fastest.len() as f64 + 2.0;
    (turns, blocks)
}

/// `schedule` with C's `law` (unchanged without one), and each station's largest speed
/// factor (1 at constant speed).
pub(super) fn polar_schedule(
    schedule: DwellSchedule,
    law: Option<CLawSpec>,
) -> Result<(DwellSchedule, Vec<f64>), CLawError> {
    let stations = schedule.positions_mm().len();
    let Some(law) = law else {
        return Ok((schedule, vec![1.0; stations]));
    };
    SectorLaw::check_sectors(law.sectors).map_err(CLawError::Law)?;
    if law.speed_factors.len() != stations {
        return Err(CLawError::Rows {
            stations,
            got: law.speed_factors.len(),
        });
    }
    if let Some((station, row)) = law
        .speed_factors
        .iter()
        .enumerate()
        .find(|(_, row)| row.len() != law.sectors)
    {
        return Err(CLawError::Row {
            station,
            sectors: law.sectors,
            got: row.len(),
        });
    }
    let fastest = law
        .speed_factors
        .iter()
        .map(|row| row.iter().cloned().fold(0.0, f64::max))
        .collect();
    let law = SectorLaw::new(stations, law.sectors, law.speed_factors.concat())
        .map_err(CLawError::Law)?;
    let schedule = schedule.with_sector_law(law).map_err(CLawError::Law)?;
    Ok((schedule, fastest))
}

/// What the caller asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPredictSpec {
    pub process: ProcessSpec,
    pub part: PartSpec,
    pub aperture: ApertureSpec,
    /// Where the azimuthal mean is reported.
    pub grid: GridSpec,
    pub positions_mm: Vec<f64>,
    pub dwell_s: Vec<f64>,
    /// `None`: C at the process's constant speed.
    pub c_law: Option<CLawSpec>,
    /// The pad centre's part-frame angle when the plan starts, degrees; default 0.
    pub start_angle_deg: Option<f64>,
    /// The map's pixel, mm; default the part's diameter / 100.
    pub pixel_mm: Option<f64>,
}

/// Why a polar prediction cannot be computed as asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapPredictInputError {
    /// The process, the part, the aperture or the dwell plan (as `/v1/predict` checks them).
    #[error(transparent)]
    Setting(#[from] InputError),
    #[error(
        "the removal on a curved part is not modelled point by point yet: the part must be flat \
         (leave out surface, or give a plane)"
    )]
    CurvedPart,
    #[error(transparent)]
    Law(CLawError),
    #[error("the start angle must be a finite number of degrees, not {0}")]
    StartAngle(f64),
    #[error("the pixel must be a positive number of mm, not {0}")]
    Pixel(f64),
    #[error(
        "a pixel of {pixel_mm} mm puts {pixels} pixels on the map; at most {max} are computed"
    )]
    TooManyPixels {
        pixel_mm: f64,
        pixels: f64,
        max: usize,
    },
    #[error(
        "the plan runs C through about {turns:.0} turns in {blocks:.2e} blocks over {pixels} \
         pixels ({work:.2e} pixel-turns, counting a block as a tenth of a turn); at most \
         {max_work:.0e} pixel-turns and {max_blocks:.0e} blocks are computed (about 14 s): a \
         larger pixel, fewer sectors or a shorter plan"
    )]
    TooMuchWork {
        turns: f64,
        pixels: usize,
        work: f64,
        blocks: f64,
        max_work: f64,
        max_blocks: f64,
    },
}

/// A checked polar prediction.
#[derive(Debug, Clone)]
pub struct MapPredictCommand {
    setting: Setting,
    schedule: DwellSchedule,
    pad: PolarPad,
    start_rad: f64,
    pixel_mm: f64,
    half: usize,
    warnings: Vec<Warning>,
}

impl MapPredictCommand {
    pub fn new(spec: MapPredictSpec, limits: &ComputeLimits) -> Result<Self, MapPredictInputError> {
        let setting = Setting::new(spec.process, &spec.part, spec.grid, spec.aperture, limits)
            .map_err(InputError::from)?;
        let process = setting.process();
        let pad = PolarPad::new(process).map_err(|_| MapPredictInputError::CurvedPart)?;
        let schedule =
            DwellSchedule::new(process, spec.positions_mm, spec.dwell_s).map_err(|error| {
                InputError::Schedule {
                    input: Input::Dwell,
                    error,
                }
            })?;
        let sectors = spec.c_law.as_ref().map_or(1, |law| law.sectors);
        let (schedule, fastest) =
            polar_schedule(schedule, spec.c_law).map_err(MapPredictInputError::Law)?;
        let start_deg = spec.start_angle_deg.unwrap_or(0.0);
        if !start_deg.is_finite() {
            return Err(MapPredictInputError::StartAngle(start_deg));
        }
        let radius = process.workpiece_radius_mm();
        let pixel_mm = match spec.pixel_mm {
            None => 2.0 * radius / (DEFAULT_PIXELS_ACROSS - 1) as f64,
            Some(p) if p.is_finite() && p > 0.0 => p,
            Some(p) => return Err(MapPredictInputError::Pixel(p)),
        };
        let half = (radius / pixel_mm).ceil();
        let pixels = (2.0 * half + 1.0).powi(2);
        if pixels > limits.max_map_pixels as f64 {
            return Err(MapPredictInputError::TooManyPixels {
                pixel_mm,
                pixels,
                max: limits.max_map_pixels,
            });
        }
        // The turns C runs at each station's fastest, and the blocks that cuts.
        let (turns, blocks) = law_work(
            &schedule,
            &fastest,
            pad.part_speed_rad_per_s(),
            sectors as f64,
        );
        let on_part = (std::f64::consts::PI * (half + 0.5).powi(2)).ceil() as usize;
        let work = on_part as f64 * (turns + blocks / 10.0);
        if work > MAX_WORK || blocks > MAX_BLOCKS {
            return Err(MapPredictInputError::TooMuchWork {
                turns,
                pixels: on_part,
                work,
                blocks,
                max_work: MAX_WORK,
                max_blocks: MAX_BLOCKS,
            });
        }
        let warnings = unit_warnings(process, schedule.positions_mm());
        Ok(MapPredictCommand {
            setting,
            schedule,
            pad,
            start_rad: start_deg.to_radians(),
            pixel_mm,
            half: half as usize,
            warnings,
        })
    }
}

/// The removal map and its figures.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPrediction {
    pub pixel_mm: f64,
    /// The columns' x, mm (part frame), left to right.
    pub x_mm: Vec<f64>,
    /// The rows' y, mm, top (largest) first.
    pub y_mm: Vec<f64>,
    /// Removal, nm, row by row from the top; `None` off the part.
    pub removal_nm: Vec<Option<f64>>,
    /// Over the clear aperture's pixels.
    pub metrics: Figures,
    /// The removal less its azimuthal mean, over the clear aperture's pixels.
    pub non_axisymmetric: Figures,
    /// The radial grid, mm, and the removal's azimuthal mean on it, nm (Σ ∫ R_Ω(t) dt).
    pub radius_mm: Vec<f64>,
    pub azimuthal_mean_nm: Vec<f64>,
    pub clear_aperture: ClearAperture,
    pub total_time_s: f64,
    /// Blocks of the executed motion.
    pub blocks: usize,
    pub warnings: Vec<Warning>,
}

pub fn map_predict(command: MapPredictCommand) -> MapPrediction {
    let MapPredictCommand {
        setting,
        schedule,
        pad,
        start_rad,
        pixel_mm,
        half,
        warnings,
    } = command;
    let process = setting.process();
    let radius = process.workpiece_radius_mm();
    let (x_mm, y_mm) = square_axes(0.0, half, pixel_mm);
    let points: Vec<(f64, f64)> = y_mm
        .iter()
        .flat_map(|&y| x_mm.iter().map(move |&x| (x, y)))
        .collect();
    let on_part: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.hypot(points[i].1) <= radius)
        .collect();
    let blocks = executed_blocks(
        schedule.motion(),
        schedule.dwell_s(),
        pad.part_speed_rad_per_s(),
        start_rad,
    );
    let targets: Vec<(f64, f64)> = on_part.iter().map(|&i| points[i]).collect();
    let depths = pad.depth_nm(&blocks, &targets);
    let mut removal_nm = vec![None; points.len()];
    for (&i, &d) in on_part.iter().zip(&depths) {
        removal_nm[i] = Some(d);
    }
    let aperture = setting.aperture();
    let (inner, outer) = (aperture.inner_mm(), aperture.outer_mm());
    let inside: Vec<(f64, f64)> = targets
        .iter()
        .zip(&depths)
        .map(|(&(x, y), &d)| (x.hypot(y), d))
        .filter(|&(r, _)| r >= inner && r <= outer)
        .collect();
    let metrics = figures(inside.iter().map(|p| p.1));
    // What is not round: the removal less its azimuthal mean at the pixel's radius (exact, by
    // the identity of `physics::polar`).
    // A square grid repeats each radius up to eight times: each distinct one is computed once.
    let mut radii: Vec<f64> = inside.iter().map(|p| p.0).collect();
    radii.sort_by(f64::total_cmp);
    radii.dedup();
    let means = pad.mean_depth_nm(&blocks, &radii);
    let mean_at = |r: f64| means[radii.partition_point(|&q| q < r)];
    let non_axisymmetric = figures(inside.iter().map(|&(r, d)| d - mean_at(r)));
    let grid = setting.grid();
    let azimuthal_mean_nm = pad.mean_depth_nm(&blocks, grid.radii_mm());
    MapPrediction {
        pixel_mm,
        x_mm,
        y_mm,
        removal_nm,
        metrics,
        non_axisymmetric,
        radius_mm: grid.radii_mm().to_vec(),
        azimuthal_mean_nm,
        clear_aperture: *aperture,
        total_time_s: schedule.total_time_s(),
        blocks: blocks.len(),
        warnings,
    }
}

/// The figures of `values` in one pass.
pub(super) fn figures(values: impl Iterator<Item = f64>) -> Figures {
    let mut values = values.peekable();
    let mut tally = Tally::new(values.peek().copied().unwrap_or(0.0));
    values.for_each(|v| tally.push(v));
    tally.figures()
}
