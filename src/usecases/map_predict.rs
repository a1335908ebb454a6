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
//!
//! On segments (or a decentred part) the depth is `physics::segment_pad`'s, on the segments'
//! pixels only; nothing there is round about C, so the figures are the removal's own (its
//! non-axisymmetric part is the whole of it about its mean), each segment has its own, and no
//! azimuthal mean is reported.

use super::map_optimize::SegmentSetup;
use super::map_removal_function::square_axes;
use super::setting::{ApertureSpec, GridSpec, PartSpec, Setting};
use super::warnings::unit_warnings;
use super::{ComputeLimits, Input, InputError, Warning};
use crate::field::{Figures, Tally};
use crate::physics::polar::{executed_blocks, PolarPad};
use crate::physics::segment_pad::{SegmentPad, SegmentPadError};
use crate::physics::{
    ClearAperture, DwellSchedule, PressureModel, Process, ProcessSpec, SectorLaw, SectorLawError,
};
use std::f64::consts::PI;

/// Pixels across the part's diameter by default.
pub const DEFAULT_PIXELS_ACROSS: usize = 101;

/// The most work one prediction may take, in pixel-turns ([`map_work`]). Measured on 2 cores
/// (a 100 mm part, 101 stations, over HTTP): about 0.46 µs per pixel and turn and 0.05 µs per
/// pixel and block, so the limit is about 5 s (a synchronous request, two of which must fit
/// well inside a client's 30 s on 2 cores; longer plans wait for jobs).
pub const MAX_WORK: f64 = 1e7;

/// The work of an exact map, in pixel-turns: `pixels` depths, each passing the `turns` of C
/// cut into `blocks` (a block a tenth of a turn) and integrating the `covered` turns' worth
/// the pad spends over it ([`covered_turns`]), and `rings` exact azimuthal means, each
/// integrating every block within the pad's reach of its ring whatever the turns (a
/// ring-block about a pixel-turn: 13 rings took as long as 81 pixels under a 180-sector law of
/// 1054 turns in 282,028 blocks, nearly all pieces of spirals); all of it
/// [`surface_cost`] times dearer on a curved part.
pub(super) fn map_work(
    process: &Process,
    pixels: usize,
    rings: usize,
    turns: f64,
    blocks: f64,
    covered: f64,
) -> f64 {
    surface_cost(process)
        * (pixels as f64 * (turns + blocks / 10.0 + covered) + rings as f64 * blocks)
}

/// How much dearer a map is on a curved part: the footprint's arc is integrated rather than
/// taken in closed form, and a spiral's radius follows the arc (measured on the sector-law
/// fixture, a 30 mm part: a sphere 3.3× to 4.4× the plane, an asphere, whose arc lengths
/// and chords are quadratures, 16× to 25×).
const SPHERE_COST: f64 = 4.0;
const ASPHERE_COST: f64 = 25.0;

fn surface_cost(process: &Process) -> f64 {
    let surface = &process.part().surface;
    if surface.is_plane() {
        1.0
    } else if surface.is_sphere() {
        SPHERE_COST
    } else {
        ASPHERE_COST
    }
}

/// The most work one prediction on segments may take, in pixel-passes
/// ([`segment_map_work`]): about 8 µs each on 2 cores, so about 5 s as [`MAX_WORK`].
pub const MAX_SEGMENT_WORK: f64 = 6e5;

/// The work of an exact map on segments, in pixel-passes: the pad centre's path over the part
/// (`path_mm`) times the band its pad sweeps (2·r_t), over a pixel's area; each pass under a
/// pixel is located and integrated once.
pub(super) fn segment_map_work(path_mm: f64, pad_radius_mm: f64, pixel_mm: f64) -> f64 {
    path_mm * 2.0 * pad_radius_mm / (pixel_mm * pixel_mm)
}

/// A turn of C spent with the pad over a pixel costs about this many pixel-turns: passing a
/// turn, a pixel's depth finds where the pad meets it (a few roots), but under the pad it
/// integrates the rate to 1e-11 (measured: a 100 m pad over a 50 mm part, every pixel covered
/// all the time, 17 µs per pixel and turn against 0.46 µs).
const COVERED_TURN_COST: f64 = 40.0;

/// How much more a rate evaluation costs under a linear pad than under a nominal one, at
/// most: its pressure is solved for the pad centre's radius at each instant of a spiral, and
/// where the pad overhangs the part's edge for a lifted line (measured over a 50 mm part: 27×
/// for a 49 mm pad, about 130× for a 60 mm one).
const LINEAR_PRESSURE_COST: f64 = 150.0;

/// The turns' worth, per pixel of the part on average, that a plan holding `turns[j]` turns of
/// C at `positions_mm[j]` spends with the pad over the pixel (the share of a turn a ring of
/// radius r is under a pad at r1 is θ0/π, cos θ0 = (r² + r1² − rt²)/(2·r·r1)), in pixel-turns
/// of work ([`COVERED_TURN_COST`], [`LINEAR_PRESSURE_COST`]). Averaged over the part's area by
/// the midpoint rule on 64 rings: an estimate of cost, not a figure.
pub(super) fn covered_turns(process: &Process, positions_mm: &[f64], turns: &[f64]) -> f64 {
    const RINGS: usize = 64;
    let (big, rt) = (process.workpiece_radius_mm(), process.tool_radius_mm());
    let share = |r: f64, r1: f64| {
        if r + r1 <= rt {
            1.0
        } else if (r - r1).abs() >= rt {
            0.0
        } else {
            ((r * r + r1 * r1 - rt * rt) / (2.0 * r * r1))
                .clamp(-1.0, 1.0)
                .acos()
                / PI
        }
    };
    let covered: f64 = positions_mm
        .iter()
        .zip(turns)
        .map(|(&r1, &n)| {
            let area_mean: f64 = (0..RINGS)
                .map(|i| {
                    let r = big * (i as f64 + 0.5) / RINGS as f64;
                    share(r, r1) * 2.0 * r / big
                })
                .sum::<f64>()
                / RINGS as f64;
            n * area_mean
        })
        .sum();
    let cost = match process.pressure_model() {
        PressureModel::Linear { .. } => COVERED_TURN_COST * LINEAR_PRESSURE_COST,
        PressureModel::Uniform | PressureModel::ConstantForce => COVERED_TURN_COST,
    };
    cost * covered
}

/// The pixels of a square map `pixel_mm` apart about the axis, `half` either side, on a part
/// of `radius_mm`, and the distinct radii among those within [`inner_mm`, `outer_mm`] (where
/// the azimuthal mean is taken).
pub(super) fn map_size(
    pixel_mm: f64,
    half: usize,
    radius_mm: f64,
    (inner_mm, outer_mm): (f64, f64),
) -> (usize, usize) {
    // Beyond a thousand pixels either side (more than any work limit allows) the count is
    // estimated rather than enumerated: the disc's area, and every whole r² in the annulus.
    if half > 1000 {
        let across = radius_mm / pixel_mm;
        let pixels = (PI * (across + 0.5).powi(2)).ceil() as usize;
        let (lo, hi) = (inner_mm / pixel_mm, outer_mm.min(radius_mm) / pixel_mm);
        return (pixels, (hi * hi - lo * lo).max(0.0) as usize + 1);
    }
    let mut pixels = 0;
    let mut rings = std::collections::BTreeSet::new();
    for i in 0..=half {
        for j in 0..=half {
            let square = i * i + j * j;
            let r = pixel_mm * (square as f64).sqrt();
            if r > radius_mm {
                continue;
            }
            // The quadrant's pixels, the axes' counted once.
            pixels += match (i, j) {
                (0, 0) => 1,
                (0, _) | (_, 0) => 2,
                _ => 4,
            };
            if r >= inner_mm && r <= outer_mm {
                rings.insert(square);
            }
        }
    }
    (pixels, rings.len())
}

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
    let turns: f64 = station_turns(schedule.dwell_s(), fastest, omega)
        .iter()
        .sum();
    let blocks = turns * per_turn + 2.0 * fastest.len() as f64 + 2.0;
    (turns, blocks)
}

/// The turns of C each station's dwell `dwell_s` runs at `factor` times the part speed `omega`
/// (rad/s).
pub(super) fn station_turns(dwell_s: &[f64], factor: &[f64], omega: f64) -> Vec<f64> {
    dwell_s
        .iter()
        .zip(factor)
        .map(|(t, f)| t * omega.abs() * f / std::f64::consts::TAU)
        .collect()
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
    /// Segments on C (or a decentred part); the part's surface is then the plane.
    pub segments: Option<SegmentSetup>,
}

/// Why a polar prediction cannot be computed as asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapPredictInputError {
    /// The process, the part, the aperture or the dwell plan (as `/v1/predict` checks them).
    #[error(transparent)]
    Setting(#[from] InputError),
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
         pixels and {rings} rings' means, {work:.2e} pixel-turns of work (a block a tenth of a \
         turn, a ring's block one, a turn the pad spends over a pixel {covered}, {linear} under \
         a linear pad; all of it {sphere}× on a sphere, {asphere}× on an asphere); at most \
         {max_work:.1e} pixel-turns and {max_blocks:.0e} blocks are computed (about 5 s): a \
         larger pixel, fewer sectors or a shorter plan",
        covered = COVERED_TURN_COST,
        linear = COVERED_TURN_COST * LINEAR_PRESSURE_COST,
        sphere = SPHERE_COST,
        asphere = ASPHERE_COST
    )]
    TooMuchWork {
        turns: f64,
        pixels: usize,
        rings: usize,
        work: f64,
        blocks: f64,
        max_work: f64,
        max_blocks: f64,
    },
    #[error("{0}")]
    Segments(SegmentPadError),
    #[error(
        "the exact removal on the segments is about {work:.2e} pixel-passes at a pixel of \
         {pixel_mm} mm (the pad's path over the part times its width, over a pixel's area); at \
         most {max:.1e} are computed (about 5 s): a larger pixel or a shorter plan"
    )]
    SegmentsTooMuchWork { work: f64, pixel_mm: f64, max: f64 },
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
    segments: Option<SegmentPad>,
}

impl MapPredictCommand {
    pub fn new(spec: MapPredictSpec, limits: &ComputeLimits) -> Result<Self, MapPredictInputError> {
        let setting = Setting::new(spec.process, &spec.part, spec.grid, spec.aperture, limits)
            .map_err(InputError::from)?;
        let process = setting.process();
        let pad = PolarPad::new(process);
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
        let aperture = setting.aperture();
        let (on_part, rings) = map_size(
            pixel_mm,
            half as usize,
            process.workpiece_radius_mm(),
            (aperture.inner_mm(), aperture.outer_mm()),
        );
        // The azimuthal mean is reported on the radial grid as well.
        let rings = rings + setting.grid().radii_mm().len();
        let turns_at = station_turns(schedule.dwell_s(), &fastest, pad.part_speed_rad_per_s());
        let covered = covered_turns(process, schedule.positions_mm(), &turns_at);
        let segments = match spec.segments {
            None => None,
            Some(setup) => {
                let pad = SegmentPad::new(setup.layout, process)
                    .map_err(MapPredictInputError::Segments)?;
                // The pad centre's path: each station's turns round its ring, and the moves.
                let positions = schedule.positions_mm();
                let path_mm: f64 = positions
                    .iter()
                    .zip(&turns_at)
                    .map(|(r, n)| n * 2.0 * PI * r)
                    .sum::<f64>()
                    + (positions[positions.len() - 1] - positions[0]).abs();
                let work = segment_map_work(path_mm, process.tool_radius_mm(), pixel_mm);
                if work > MAX_SEGMENT_WORK {
                    return Err(MapPredictInputError::SegmentsTooMuchWork {
                        work,
                        pixel_mm,
                        max: MAX_SEGMENT_WORK,
                    });
                }
                Some(pad)
            }
        };
        let work = map_work(process, on_part, rings, turns, blocks, covered);
        if segments.is_none() && work > MAX_WORK || blocks > MAX_BLOCKS {
            return Err(MapPredictInputError::TooMuchWork {
                turns,
                pixels: on_part,
                rings,
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
            segments,
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
    /// On segments: each one's removal figures over its own pixels in the clear aperture.
    pub segments: Option<Vec<Figures>>,
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
        segments,
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
        &process.part().surface,
    );
    if let Some(segment_pad) = &segments {
        return on_segments(
            segment_pad,
            &setting,
            &schedule,
            &blocks,
            (x_mm, y_mm, pixel_mm),
            warnings,
        );
    }
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
        segments: None,
    }
}

/// The prediction on segments (module docs): depths on the segments' pixels, their figures
/// over the clear aperture, and each segment's.
fn on_segments(
    pad: &SegmentPad,
    setting: &Setting,
    schedule: &DwellSchedule,
    blocks: &[crate::physics::polar::Block],
    (x_mm, y_mm, pixel_mm): (Vec<f64>, Vec<f64>, f64),
    warnings: Vec<Warning>,
) -> MapPrediction {
    let layout = pad.layout();
    let mut on: Vec<(usize, [f64; 2], usize)> = Vec::new();
    for (i, &y) in y_mm.iter().enumerate() {
        for (j, &x) in x_mm.iter().enumerate() {
            if let Some(segment) = layout.segment_at([x, y]) {
                on.push((i * x_mm.len() + j, [x, y], segment));
            }
        }
    }
    let at: Vec<[f64; 2]> = on.iter().map(|p| p.1).collect();
    let depths = pad.depth_nm(blocks, &at);
    let mut removal_nm = vec![None; x_mm.len() * y_mm.len()];
    for (p, &d) in on.iter().zip(&depths) {
        removal_nm[p.0] = Some(d);
    }
    let aperture = setting.aperture();
    let inside = |p: &[f64; 2]| {
        let r = p[0].hypot(p[1]);
        r >= aperture.inner_mm() && r <= aperture.outer_mm()
    };
    let within = || on.iter().zip(&depths).filter(|(p, _)| inside(&p.1));
    let metrics = figures(within().map(|(_, &d)| d));
    let per_segment = (0..layout.spec().count)
        .map(|i| figures(within().filter(|(p, _)| p.2 == i).map(|(_, &d)| d)))
        .collect();
    MapPrediction {
        pixel_mm,
        x_mm,
        y_mm,
        removal_nm,
        metrics,
        non_axisymmetric: metrics,
        radius_mm: Vec::new(),
        azimuthal_mean_nm: Vec::new(),
        clear_aperture: *aperture,
        total_time_s: schedule.total_time_s(),
        blocks: blocks.len(),
        warnings,
        segments: Some(per_segment),
    }
}

/// The figures of `values` in one pass.
pub(super) fn figures(values: impl Iterator<Item = f64>) -> Figures {
    let mut values = values.peekable();
    let mut tally = Tally::new(values.peek().copied().unwrap_or(0.0));
    values.for_each(|v| tally.push(v));
    tally.figures()
}
