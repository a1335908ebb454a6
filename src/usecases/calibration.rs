//! Calibration: fit the process's removal rate (and, if asked, its pad radius and moment
//! share) to what ring tests or production runs removed ([`crate::calibration`]), and say
//! which parameters the runs could not determine and which runs the model does not explain.
//!
//! A run may be a polar plan on the paper's machine (C's sector law, as `/v1/maps/predict`
//! takes it) and may be measured by maps: the removal as a map, or the maps before and after
//! (registered and differenced as `/v1/maps/difference` does). A run measured by a map is
//! predicted pixel by pixel from the motion executed (`physics::polar`), and its residual's
//! spatial correlation enters the standard errors (`calibration::spatial`).

use super::limits::{ComputeLimits, SizeLimitError};
use super::map_analysis::{check_on_map, MapInputError, MapOrigin, Placement};
use super::map_difference::{
    map_removal_pixels, DifferenceInputError, MapDifferenceCommand, MapDifferenceSpec,
};
use super::map_predict::{
    covered_turns, law_work, map_work, polar_schedule, station_turns, CLawError, CLawSpec,
    MAX_BLOCKS,
};
use super::setting::{process_on_part, SettingError};
use super::warnings::process_warnings;
use super::{PartSpec, Warning};
use crate::calibration::spatial::Pixel;
use crate::calibration::{
    Calibrated, Calibration, CalibrationError, FitFailure, Freedom, MapSample, Measured,
    ProcessParameter, RunSpec, TrialSpec,
};
use crate::lsq::RobustLoss;
use crate::maps::analysis::aperture_pixels;
use crate::maps::aperture::Aperture;
use crate::maps::difference::DifferenceError;
use crate::maps::HeightMap;
use crate::physics::{DwellSchedule, Process, ProcessSpec, ScheduleError, Turning};

/// The most runs one calibration takes.
pub const MAX_RUNS: usize = 64;
/// A fitted parameter whose 95 % interval's half-width exceeds this (relative to K and r_t,
/// absolute for κ) is reported as poorly determined: the runs barely constrain it.
pub const POOR_RELATIVE: f64 = 0.2;
pub const POOR_SHARE: f64 = 0.25;
/// A run whose residual RMS exceeds this many times its noise is flagged.
pub const NOISE_FACTOR: f64 = 3.0;

/// The most work the map runs' prediction may take, in pixel-turns (`map_predict::map_work`):
/// about 5 s on 2 cores, made once (only K is fitted from maps, and it enters linearly).
pub const MAX_MAP_WORK: f64 = super::map_predict::MAX_WORK;
/// The most pixels the map runs may hold together: their standard errors sum over up to
/// (2·24 + 1)² offsets per pixel (`calibration::spatial`), about 2 s at this many.
pub const MAX_MAP_PIXELS: usize = 200_000;

/// What ran, as asked: a ring or a dwell schedule, or a polar plan.
#[derive(Debug, Clone, PartialEq)]
pub enum TrialInput {
    /// As the core takes it: a ring or a dwell schedule (or a polar plan already checked).
    Given(TrialSpec),
    Polar(PolarTrial),
}

/// A polar plan as `/v1/maps/predict` takes it.
#[derive(Debug, Clone, PartialEq)]
pub struct PolarTrial {
    pub positions_mm: Vec<f64>,
    pub dwell_s: Vec<f64>,
    /// `None`: C at the process's constant speed.
    pub c_law: Option<CLawSpec>,
    /// Default 0.
    pub start_angle_deg: Option<f64>,
}

/// What a run removed, as asked: profiles, or maps.
#[derive(Debug, Clone, PartialEq)]
pub enum MeasuredInput {
    /// As the core takes it: profiles (or a map's samples already read).
    Given(Measured),
    Map(Box<MapMeasurement>),
}

/// A run measured by an interferometer.
#[derive(Debug, Clone, PartialEq)]
pub enum MapMeasurement {
    /// The removal itself (nm, > 0 removed), placed on the part; only the aperture's pixels
    /// (default a circle of the part's radius) count.
    Removal {
        map: HeightMap,
        placement: Placement,
        aperture: Option<Aperture>,
    },
    /// The surface before and after (heights, nm), registered and differenced.
    BeforeAfter {
        before: HeightMap,
        after: HeightMap,
        difference: MapDifferenceSpec,
    },
}

/// One run as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct RunInput {
    pub trial: TrialInput,
    pub measured: MeasuredInput,
    /// Only the points within this annulus (mm) count; default all.
    pub aperture: Option<(f64, f64)>,
}

impl From<RunSpec> for RunInput {
    fn from(run: RunSpec) -> Self {
        RunInput {
            trial: TrialInput::Given(run.trial),
            measured: MeasuredInput::Given(run.measured),
            aperture: run.aperture,
        }
    }
}

/// Why a polar run's plan was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolarTrialError {
    #[error("{0}")]
    Schedule(ScheduleError),
    #[error(transparent)]
    Law(CLawError),
    #[error("the start angle must be a finite number of degrees, not {0}")]
    StartAngle(f64),
}

/// Why a run's maps were refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapRunError {
    #[error("{0}")]
    Removal(MapInputError),
    #[error("{0}")]
    Difference(DifferenceInputError),
    #[error("{0}")]
    Differenced(DifferenceError),
}

/// What to fit, as asked (`None`: the default).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ParameterSelection {
    /// Default true.
    pub preston_coefficient: Option<bool>,
    /// Default false.
    pub tool_radius: Option<bool>,
    /// Default false.
    pub pad_moment_share: Option<bool>,
    /// Default false.
    pub metrology_power: Option<bool>,
}

/// A calibration as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationSpec {
    pub process: ProcessSpec,
    pub part: PartSpec,
    pub runs: Vec<RunInput>,
    pub fit: ParameterSelection,
    pub robust: Option<RobustLoss>,
    /// The measurements' expected noise per point, nm (default: estimated from each run's
    /// point-to-point differences).
    pub expected_noise_nm: Option<f64>,
}

/// Why a calibration was refused before fitting.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationInputError {
    #[error(transparent)]
    Setting(SettingError),
    #[error(transparent)]
    Runs(SizeLimitError),
    #[error(transparent)]
    Points(SizeLimitError),
    #[error("run {run}: {error}")]
    Positions { run: usize, error: SizeLimitError },
    #[error("expected_noise_nm must be a finite number > 0")]
    Noise,
    #[error("run {run}: {error}")]
    Polar { run: usize, error: PolarTrialError },
    #[error("run {run}: {error}")]
    Map { run: usize, error: MapRunError },
    #[error(
        "run {run}: the runs' maps hold {pixels} pixels with data up to this one; at most {max} \
         are fitted (their standard errors sum over the residual's correlation at every \
         pixel): a coarser map"
    )]
    MapPixels {
        run: usize,
        pixels: usize,
        max: usize,
    },
    #[error(
        "run {run}: predicting the runs' maps is {work:.2e} pixel-turns of work up to this one \
         (pixels × C's turns, as /v1/maps/predict counts it) in {blocks:.2e} blocks of motion; \
         at most {max_work:.1e} pixel-turns and {max_blocks:.0e} blocks are computed: a coarser \
         map, a smaller aperture or fewer sectors"
    )]
    MapWork {
        run: usize,
        work: f64,
        blocks: f64,
        max_work: f64,
        max_blocks: f64,
    },
    #[error(transparent)]
    Calibration(CalibrationError),
}

/// A checked calibration.
#[derive(Debug, Clone)]
pub struct CalibrationCommand {
    calibration: Calibration,
    expected_noise_nm: Option<f64>,
    /// Likely unit mistakes in the nominal process.
    process_warnings: Vec<Warning>,
}

impl CalibrationCommand {
    pub fn new(
        spec: CalibrationSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, CalibrationInputError> {
        use CalibrationInputError as E;
        let (process, _) = process_on_part(spec.process, &spec.part).map_err(E::Setting)?;
        let process_warnings = process_warnings(&process);
        if spec.runs.len() > MAX_RUNS {
            return Err(E::Runs(SizeLimitError::Runs {
                count: spec.runs.len(),
                max: MAX_RUNS,
            }));
        }
        let points: usize = spec
            .runs
            .iter()
            .filter_map(|run| match &run.measured {
                MeasuredInput::Given(m) => Some(profile_points(m)),
                MeasuredInput::Map(_) => None,
            })
            .sum();
        limits.check_trace_points(points).map_err(E::Points)?;
        for (run, input) in spec.runs.iter().enumerate() {
            let positions = match &input.trial {
                TrialInput::Given(TrialSpec::Dwell { positions_mm, .. }) => positions_mm.len(),
                TrialInput::Polar(polar) => polar.positions_mm.len(),
                _ => continue,
            };
            if let MeasuredInput::Given(m) = &input.measured {
                limits
                    .check_operator(profile_points(m), positions)
                    .map_err(|error| E::Positions { run, error })?;
            }
        }
        let mut maps = MapTally::default();
        let runs = spec
            .runs
            .into_iter()
            .enumerate()
            .map(|(run, input)| run_spec(&process, input, run, limits, &mut maps))
            .collect::<Result<Vec<RunSpec>, _>>()?;
        if spec
            .expected_noise_nm
            .is_some_and(|n| !(n.is_finite() && n > 0.0))
        {
            return Err(E::Noise);
        }
        let freedom = Freedom {
            preston_coefficient: spec.fit.preston_coefficient.unwrap_or(true),
            tool_radius: spec.fit.tool_radius.unwrap_or(false),
            pad_moment_share: spec.fit.pad_moment_share.unwrap_or(false),
            metrology_power: spec.fit.metrology_power.unwrap_or(false),
        };
        let calibration = Calibration::new(process, runs, freedom, spec.robust.unwrap_or_default())
            .map_err(E::Calibration)?;
        Ok(CalibrationCommand {
            calibration,
            expected_noise_nm: spec.expected_noise_nm,
            process_warnings,
        })
    }
}

fn profile_points(measured: &Measured) -> usize {
    match measured {
        Measured::Removal(p) => p.radius_mm.len(),
        Measured::BeforeAfter { before, after } => before.radius_mm.len() + after.radius_mm.len(),
        Measured::Map(samples) => samples.len(),
    }
}

/// What the map runs read so far hold: pixels with data, and the work and blocks of
/// predicting them (`map_predict::map_work`), each checked against its limit run by run, before
/// anything dear is computed.
#[derive(Debug, Default)]
struct MapTally {
    pixels: usize,
    work: f64,
    blocks: f64,
}

/// The run as the core takes it: a polar plan's schedule built, a map's pixels read.
fn run_spec(
    process: &Process,
    input: RunInput,
    run: usize,
    limits: &ComputeLimits,
    maps: &mut MapTally,
) -> Result<RunSpec, CalibrationInputError> {
    let (trial, fastest) = match input.trial {
        TrialInput::Given(trial) => (trial, None),
        TrialInput::Polar(polar) => {
            let (trial, fastest) = polar_trial(process, polar)
                .map_err(|error| CalibrationInputError::Polar { run, error })?;
            (trial, Some(fastest))
        }
    };
    let measured = match input.measured {
        MeasuredInput::Given(measured) => measured,
        MeasuredInput::Map(map) => {
            let pixels = map.pixels();
            maps.pixels += pixels;
            if maps.pixels > MAX_MAP_PIXELS {
                return Err(CalibrationInputError::MapPixels {
                    run,
                    pixels: maps.pixels,
                    max: MAX_MAP_PIXELS,
                });
            }
            let (turns, blocks, covered) = motion_work(process, &trial, fastest.as_deref());
            maps.work += map_work(process, pixels, 0, turns, blocks, covered);
            maps.blocks += blocks;
            if maps.work > MAX_MAP_WORK || maps.blocks > MAX_BLOCKS {
                return Err(CalibrationInputError::MapWork {
                    run,
                    work: maps.work,
                    blocks: maps.blocks,
                    max_work: MAX_MAP_WORK,
                    max_blocks: MAX_BLOCKS,
                });
            }
            Measured::Map(
                map_samples(*map, limits)
                    .map_err(|error| CalibrationInputError::Map { run, error })?,
            )
        }
    };
    Ok(RunSpec {
        trial,
        measured,
        aperture: input.aperture,
    })
}

/// A polar plan's trial and each station's fastest speed factor (1 at constant speed).
fn polar_trial(
    process: &Process,
    polar: PolarTrial,
) -> Result<(TrialSpec, Vec<f64>), PolarTrialError> {
    let schedule = DwellSchedule::new(process, polar.positions_mm, polar.dwell_s)
        .map_err(PolarTrialError::Schedule)?;
    let (schedule, fastest) =
        polar_schedule(schedule, polar.c_law).map_err(PolarTrialError::Law)?;
    let start_deg = polar.start_angle_deg.unwrap_or(0.0);
    if !start_deg.is_finite() {
        return Err(PolarTrialError::StartAngle(start_deg));
    }
    let trial = TrialSpec::Polar {
        schedule,
        start_angle_rad: start_deg.to_radians(),
    };
    Ok((trial, fastest))
}

/// The turns of C a trial runs (each station at its `fastest` factor), the blocks its motion
/// is cut into, and the turns the pad spends over a pixel ([`covered_turns`]): one prediction's
/// work per pixel, estimated before the motion is built. A dwell schedule the core will refuse
/// counts nothing.
fn motion_work(process: &Process, trial: &TrialSpec, fastest: Option<&[f64]>) -> (f64, f64, f64) {
    let omega = -process.omega1_rad_per_s();
    let estimate = |schedule: &DwellSchedule, sectors: f64| {
        let ones = vec![1.0; schedule.positions_mm().len()];
        let fastest = fastest.unwrap_or(&ones);
        let (turns, blocks) = law_work(schedule, fastest, omega, sectors);
        let covered = covered_turns(
            process,
            schedule.positions_mm(),
            &station_turns(schedule.dwell_s(), fastest, omega),
        );
        (turns, blocks, covered)
    };
    match trial {
        TrialSpec::Ring {
            position_mm,
            duration_s,
        } => {
            let turns = station_turns(&[*duration_s], &[1.0], omega);
            let covered = covered_turns(process, &[*position_mm], &turns);
            (turns[0], 1.0, covered)
        }
        TrialSpec::Dwell {
            positions_mm,
            dwell_s,
        } => match DwellSchedule::new(process, positions_mm.clone(), dwell_s.clone()) {
            Ok(schedule) => estimate(&schedule, 1.0),
            Err(_) => (0.0, 0.0, 0.0),
        },
        TrialSpec::Polar { schedule, .. } => {
            let sectors = match schedule.motion().turning() {
                Turning::Sectors(law) => law.sectors() as f64,
                Turning::Constant => 1.0,
            };
            estimate(schedule, sectors)
        }
    }
}

impl MapMeasurement {
    /// The pixels with data on the map the removal is read on (the removal's, or the before
    /// map's): at most what the fit gets.
    fn pixels(&self) -> usize {
        match self {
            MapMeasurement::Removal { map, .. } => map.valid_pixels(),
            MapMeasurement::BeforeAfter { before, .. } => before.valid_pixels(),
        }
    }
}

/// A map run's pixels in the part's frame and the removal at each.
fn map_samples(map: MapMeasurement, limits: &ComputeLimits) -> Result<Vec<MapSample>, MapRunError> {
    let pixels = match map {
        MapMeasurement::Removal {
            map,
            placement,
            aperture,
        } => {
            let (alignment, _) = placement.place(&map).map_err(MapRunError::Removal)?;
            let aperture = aperture.unwrap_or(Aperture::Circle {
                radius_mm: alignment.part_radius_mm,
            });
            check_on_map(&map, &alignment, &aperture).map_err(MapRunError::Removal)?;
            aperture_pixels(&map, &alignment, &aperture).pixels
        }
        MapMeasurement::BeforeAfter {
            before,
            after,
            difference,
        } => {
            let command = MapDifferenceCommand::new(
                (before, MapOrigin::Heights),
                (after, MapOrigin::Heights),
                difference,
                limits,
            )
            .map_err(MapRunError::Difference)?;
            map_removal_pixels(&command).map_err(MapRunError::Differenced)?
        }
    };
    Ok(pixels
        .into_iter()
        .map(|p| MapSample {
            pixel: Pixel {
                column: p.column as i64,
                row: p.row as i64,
            },
            x_mm: p.x_mm,
            y_mm: p.y_mm,
            removal_nm: p.height_nm,
        })
        .collect())
}

/// A calibration's answer.
#[derive(Debug, Clone)]
pub struct CalibrationResult {
    pub calibrated: Calibrated,
    pub warnings: Vec<Warning>,
}

pub fn calibrate(command: CalibrationCommand) -> Result<CalibrationResult, FitFailure> {
    let calibrated = command.calibration.fit()?;
    let mut warnings = command.process_warnings.clone();
    if calibrated.exact_fit {
        warnings.push(Warning::ExactFit);
    }
    for e in &calibrated.estimates {
        let Some(u) = e.uncertainty else {
            if calibrated.exact_fit {
                continue;
            }
            warnings.push(Warning::ParameterUndetermined {
                parameter: e.parameter,
                held_at: e.value,
            });
            continue;
        };
        let half = 0.5 * (u.interval_95.1 - u.interval_95.0);
        let poor = match e.parameter {
            ProcessParameter::PadMomentShare => half > POOR_SHARE,
            _ => half > POOR_RELATIVE * e.value.abs(),
        };
        if poor {
            warnings.push(Warning::ParameterPoorlyDetermined {
                parameter: e.parameter,
                value: e.value,
                standard_error: u.standard_error,
            });
        }
    }
    for (run, fit) in calibrated.runs.iter().enumerate() {
        let noise = command.expected_noise_nm.or(fit.difference_noise_nm);
        if let Some(noise) = noise.filter(|n| *n > 0.0) {
            if fit.residual_rms_nm > NOISE_FACTOR * noise {
                warnings.push(Warning::ResidualAboveNoise {
                    run,
                    residual_rms_nm: fit.residual_rms_nm,
                    noise_nm: noise,
                    expected: command.expected_noise_nm.is_some(),
                });
            }
        }
    }
    Ok(CalibrationResult {
        calibrated,
        warnings,
    })
}
