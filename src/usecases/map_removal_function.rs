//! The removal function as a map, on the paper's machine (polar kinematics: the part turns on
//! C under the pad, X carries the pad along a radius). Two views of one pad at one position r1:
//!
//! - **the footprint**, the instantaneous removal rate
//!   ρ(x, y) = K·P·(p/P)·|(ω2 − Ω)·p − ω2·c| at each point p = (x, y) of the part with the
//!   pad centre at c = (r1, 0) (`physics::polar`): x along the pad centre's radius, y a quarter
//!   turn counter-clockwise from it, both in the part's frame. 0 off the pad, off the part and
//!   beyond a linear pad's lift line. Sampled on a square grid of pixels centred on the pad
//!   centre, the pad's diameter across; the first row is the top (largest y), as a map's.
//! - **its revolution average**, R(r; r1): the 1-D removal function, exactly as the radial
//!   removal function gives it (`removal_function`). The footprint averaged over the circle of
//!   radius r is R(r; r1) — the identity that makes today's 1-D model the azimuthal mean of
//!   the 2-D one.
//!
//! On an X-Y machine the part stands still (Ω = 0) and the pad spins in place: the sliding
//! speed is ω2·|p − c| and the footprint, ρ = K·P·(p/P)·|ω2|·|p − c| on the pad, is the
//! removal rate at every instant, the tool's influence function ([`still_footprint`]). Its
//! pressure is the process's model at the pad centre's distance r1 from the part's centre
//! (uniform inside the part under every model; overhanging the edge, as the 1-D model has it).
//!
//! Rates in nm/min, like the 1-D removal function's.

use super::removal_function::{removal_function, RemovalFunction, RemovalFunctionCommand};
use super::setting::PartSpec;
use super::{ComputeLimits, GridSpec, InputError};
use crate::physics::polar::PolarPad;
use crate::physics::{ProcessSpec, ScheduleError};

/// Pixels across the pad's diameter by default (odd: one sits on the pad centre).
pub const DEFAULT_PIXELS_ACROSS: usize = 201;

/// What the caller asks for: the process, its part, the radial grid of the average, the pad
/// centre's radius and the footprint's pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct MapRemovalFunctionSpec {
    pub process: ProcessSpec,
    pub part: PartSpec,
    pub grid: GridSpec,
    pub tool_position_mm: f64,
    /// The footprint's pixel, mm (> 0); default the pad's diameter / 200.
    pub pixel_mm: Option<f64>,
}

/// Why a map removal function cannot be computed as asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FootprintInputError {
    /// The process, the part or the radial grid (as the radial removal function checks them).
    #[error(transparent)]
    Setting(#[from] InputError),
    #[error("the tool position must be a finite number of mm, not {0}")]
    PositionNotFinite(f64),
    #[error(
        "the tool position {value} mm is outside the allowed tool positions [0, {max} mm{}",
        if *open { ")" } else { "]" }
    )]
    PositionOutOfReach { value: f64, max: f64, open: bool },
    #[error(
        "on an X-Y machine the part stands still: workpiece_rpm must be 0, not {0} (the pad \
         spins at tool_rpm in place)"
    )]
    PartTurning(f64),
    #[error("the pixel must be a positive number of mm, not {0}")]
    Pixel(f64),
    #[error(
        "a pixel of {pixel_mm} mm puts {pixels} pixels on the footprint; at most {max} are \
         computed (a larger pixel, at least {smallest_mm:.3e} mm)"
    )]
    TooManyPixels {
        pixel_mm: f64,
        pixels: f64,
        max: usize,
        smallest_mm: f64,
    },
}

/// A checked map removal function: the radial one for the average, the pad for the footprint.
#[derive(Debug, Clone)]
pub struct MapRemovalFunctionCommand {
    profile: RemovalFunctionCommand,
    pad: PolarPad,
    tool_position_mm: f64,
    pixel_mm: f64,
    /// Pixels from the centre to either side: the grid is 2·half + 1 across.
    half: usize,
}

impl MapRemovalFunctionCommand {
    pub fn new(
        spec: MapRemovalFunctionSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, FootprintInputError> {
        let r1 = spec.tool_position_mm;
        let profile =
            RemovalFunctionCommand::new(spec.process, &spec.part, spec.grid, vec![r1], limits)
                .map_err(|err| match err {
                    // The one position, in the map's own terms.
                    InputError::Schedule {
                        error:
                            ScheduleError::OutOfRange {
                                value, max, open, ..
                            },
                        ..
                    } => FootprintInputError::PositionOutOfReach { value, max, open },
                    InputError::Schedule {
                        error: ScheduleError::NonFinite { .. },
                        ..
                    } => FootprintInputError::PositionNotFinite(r1),
                    other => FootprintInputError::Setting(other),
                })?;
        let process = profile.process();
        let pad = PolarPad::new(process);
        let radius = process.tool_radius_mm();
        let pixel_mm = match spec.pixel_mm {
            None => 2.0 * radius / (DEFAULT_PIXELS_ACROSS - 1) as f64,
            Some(p) if p.is_finite() && p > 0.0 => p,
            Some(p) => return Err(FootprintInputError::Pixel(p)),
        };
        let half = (radius / pixel_mm).ceil();
        let pixels = (2.0 * half + 1.0).powi(2);
        if pixels > limits.max_map_pixels as f64 {
            // The most pixels from the centre to a side that the limit allows.
            let most_half = (((limits.max_map_pixels as f64).sqrt().floor() - 1.0) / 2.0).floor();
            return Err(FootprintInputError::TooManyPixels {
                pixel_mm,
                pixels,
                max: limits.max_map_pixels,
                smallest_mm: radius / most_half.max(1.0),
            });
        }
        Ok(MapRemovalFunctionCommand {
            profile,
            pad,
            tool_position_mm: r1,
            pixel_mm,
            half: half as usize,
        })
    }
}

/// The footprint on its grid (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Footprint {
    pub pixel_mm: f64,
    /// The columns' x, mm (part frame), left to right.
    pub x_mm: Vec<f64>,
    /// The rows' y, mm, top (largest) first.
    pub y_mm: Vec<f64>,
    /// ρ, nm/min, row by row from the top.
    pub rate_nm_per_min: Vec<f64>,
}

impl Footprint {
    /// The grid's columns (and rows: it is square).
    pub fn width(&self) -> usize {
        self.x_mm.len()
    }

    pub fn height(&self) -> usize {
        self.y_mm.len()
    }

    /// The largest rate on the grid, nm/min.
    pub fn peak_nm_per_min(&self) -> f64 {
        self.rate_nm_per_min.iter().cloned().fold(0.0, f64::max)
    }
}

/// The footprint and its revolution average.
#[derive(Debug, Clone, PartialEq)]
pub struct MapRemovalFunction {
    pub tool_position_mm: f64,
    /// The radial removal function at the position: η, the grid, R(r; r1), warnings.
    pub average: RemovalFunction,
    pub footprint: Footprint,
}

/// The axes of a square grid of 2·half + 1 pixels of `pixel_mm` centred on (centre_x_mm, 0):
/// the columns' x left to right, the rows' y from the top.
pub fn square_axes(centre_x_mm: f64, half: usize, pixel_mm: f64) -> (Vec<f64>, Vec<f64>) {
    let offset = |i: usize| (i as f64 - half as f64) * pixel_mm;
    let across = 2 * half + 1;
    (
        (0..across).map(|c| centre_x_mm + offset(c)).collect(),
        (0..across).map(|r| -offset(r)).collect(),
    )
}

pub fn map_removal_function(command: MapRemovalFunctionCommand) -> MapRemovalFunction {
    let MapRemovalFunctionCommand {
        profile,
        pad,
        tool_position_mm: r1,
        pixel_mm,
        half,
    } = command;
    MapRemovalFunction {
        tool_position_mm: r1,
        average: removal_function(profile),
        footprint: footprint(&pad, r1, half, pixel_mm),
    }
}

/// The pad's influence function on a part that stands still: the process (its
/// `workpiece_rpm` 0), where the pad centre is and the footprint's pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct StillFootprintSpec {
    pub process: ProcessSpec,
    /// The pad centre's distance from the part's centre, mm; default 0.
    pub tool_position_mm: Option<f64>,
    /// Default the pad's diameter / 200.
    pub pixel_mm: Option<f64>,
}

/// A checked still-part footprint: the pad with the part at rest.
#[derive(Debug, Clone)]
pub struct StillFootprintCommand {
    pad: PolarPad,
    tool_position_mm: f64,
    pixel_mm: f64,
    half: usize,
}

impl StillFootprintCommand {
    pub fn new(
        spec: StillFootprintSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, FootprintInputError> {
        if spec.process.workpiece_rpm != 0.0 {
            return Err(FootprintInputError::PartTurning(spec.process.workpiece_rpm));
        }
        // A process is checked as a turning one; the footprint depends on the part's speed
        // only through the sliding speed (ω2 − Ω)·p − ω2·c, set to Ω = 0 below, so any speed
        // stands in for the check.
        let turning = ProcessSpec {
            workpiece_rpm: 1.0,
            ..spec.process
        };
        let command = MapRemovalFunctionCommand::new(
            MapRemovalFunctionSpec {
                process: turning,
                part: PartSpec::default(),
                grid: GridSpec::default(),
                tool_position_mm: spec.tool_position_mm.unwrap_or(0.0),
                pixel_mm: spec.pixel_mm,
            },
            limits,
        )?;
        Ok(StillFootprintCommand {
            pad: command.pad.turning_at(0.0),
            tool_position_mm: command.tool_position_mm,
            pixel_mm: command.pixel_mm,
            half: command.half,
        })
    }
}

/// The influence function of the pad on a still part.
#[derive(Debug, Clone, PartialEq)]
pub struct StillFootprint {
    pub tool_position_mm: f64,
    /// On the grid centred on the pad centre: its middle pixel (`half`, `half`).
    pub footprint: Footprint,
    pub half: usize,
}

pub fn still_footprint(command: StillFootprintCommand) -> StillFootprint {
    let StillFootprintCommand {
        pad,
        tool_position_mm: r1,
        pixel_mm,
        half,
    } = command;
    StillFootprint {
        tool_position_mm: r1,
        footprint: footprint(&pad, r1, half, pixel_mm),
        half,
    }
}

/// The footprint of `pad` with its centre at (r1, 0) on the square grid of 2·half + 1 pixels.
fn footprint(pad: &PolarPad, r1: f64, half: usize, pixel_mm: f64) -> Footprint {
    let (x_mm, y_mm) = square_axes(r1, half, pixel_mm);
    let rate_nm_per_min = y_mm
        .iter()
        .flat_map(|&y| x_mm.iter().map(move |&x| (x, y)))
        .map(|p| 60.0 * pad.rate_at(p, (r1, 0.0)))
        .collect();
    Footprint {
        pixel_mm,
        x_mm,
        y_mm,
        rate_nm_per_min,
    }
}
