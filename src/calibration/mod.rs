//! Calibration: the removal rate K, the pad radius r_t and the pad's moment share κ fitted to
//! what runs actually removed.
//!
//! A run is a ring test (the tool parked at r1 on the turning part for a time T) or a dwell
//! run (positions and dwell times, executed with the one motion model,
//! [`crate::physics::RemovalOperator`]); what it removed is measured at radii rᵢ. With g(r; θ)
//! the run's removal predicted at the nominal K (θ = (r_t, κ)), run j's model is
//!
//! ```text
//! m(rᵢ) = ρ·g(rᵢ; θ) + c_j + d_j·rᵢ²,     ρ = K / K_nominal
//! ```
//!
//! with its own piston c_j (the measurement's zero) and, optionally, its own power term d_j
//! (metrology power). A run measured as before and after form errors (`/v1/measurement/fit`'s
//! profiles, along the normal) has an axial zero: the two measurements' axial pistons differ by
//! c_j, which is c_j·cos θ(rᵢ) along the normal (θ the surface's slope angle), so its piston
//! term is c_j·cos θ(rᵢ) (on a plane, and for a removal given directly, cos θ = 1). Taking it
//! as a constant on a sphere of R = 300 mm would bias ρ by 2 % for a removal that falls off
//! toward a 40 mm aperture's edge. The fit minimises Σ wᵢ·(mᵢ − model)² by Levenberg–Marquardt
//! ([`crate::lsq`]) over (ρ, r_t, κ) (those asked for) and every c_j, d_j. ρ, c_j and d_j
//! enter linearly, so their Jacobian columns are exact (g, 1, r²); ∂g/∂r_t and ∂g/∂κ are
//! central differences (steps 1e-4·r_t and 1e-4; three-point one-sided within 1e-4 of κ's
//! bounds), whose truncation error, ~1e-8 of g, is far below any measurement's noise. Where
//! the two one-sided slopes differ by more than 2× a kink lies within the step (a pad rim
//! exactly on a measured radius, where g grows like √(r_t − |r − r1|) and its slope is
//! infinite on one side): the gentler slope is used, else Gauss–Newton would take that
//! infinite slope for the parameter's sensitivity and stall there. The
//! start is the nominal process with ρ = 1: its first Gauss–Newton step solves the linear
//! part exactly.
//!
//! **Runs measured by maps.** A run may instead be measured at a map's pixels (x, y) (a
//! ring, a dwell schedule or a polar plan under C's sector law alike): g is then the exact
//! depth the executed motion leaves at each pixel ([`crate::physics::polar`]), and the model
//! m = ρ·g + c_j + t_x,j·x + t_y,j·y (+ d_j·(x² + y²)) has the run's own tilt (the map's
//! alignment). Only ρ is fitted with a map among the runs: a point-sampled pixel's g jumps
//! where it meets the pad's rim (a pad held over the axis covers it whole or not at all), a
//! staircase in r_t and κ that no difference quotient follows. A map's residual correlates
//! from pixel to pixel, so the covariance is then the sandwich Σ_j Cov(Σ_(i∈j) a_k,i·e_i) over
//! the runs, a_k = ((JᵀWJ)⁻¹·JᵀW)_k: each map's term over its residual's autocovariance
//! ([`spatial::Sandwich`]), each profile's its residual taken as independent, all of it times
//! n/(n − p).
//!
//! A parameter no run is sensitive to (κ when no pad overhangs the edge: g does not depend on
//! it at all) is held at its nominal value and reported without a standard error; the caller
//! says why. Standard errors are √ of the diagonal of σ²·(JᵀWJ)⁻¹, σ² = S/(n − p) (profiles
//! alone; with a map, the sandwich above).

pub mod spatial;

use crate::field::{interpolate_within, DepthProfile};
use faer::Mat;

use crate::lsq::{self, Fit, LsqError, Model, RobustLoss};
use crate::physics::polar::{executed_blocks, Block, PolarPad};
use crate::physics::Turning;
use crate::physics::{
    ClearAperture, DwellSchedule, GridError, PressureModel, Process, ProcessError, ProcessSpec,
    RemovalKernel, RemovalOperator, ScheduleError,
};
use spatial::{Pixel, Sandwich};
use std::cell::RefCell;

/// Levenberg–Marquardt steps per weighting.
const MAX_STEPS: usize = 100;
/// Relative step of the r_t difference quotient, and κ's absolute step.
const RADIUS_STEP: f64 = 1e-4;
const SHARE_STEP: f64 = 1e-4;
/// One-sided slopes further apart than this factor mark a kink inside the difference step.
const KINK: f64 = 2.0;

/// A process parameter calibration can fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProcessParameter {
    PrestonCoefficient,
    ToolRadius,
    PadMomentShare,
}

impl ProcessParameter {
    /// The difference-quotient step at `values` ([ρ, r_t, κ]); ρ needs none (it is linear).
    fn step(self, values: &[f64; 3]) -> f64 {
        match self {
            ProcessParameter::ToolRadius => RADIUS_STEP * values[1],
            _ => SHARE_STEP,
        }
    }

    /// The values the model takes.
    fn bounds(self) -> (f64, f64) {
        match self {
            ProcessParameter::PadMomentShare => (0.0, 1.0),
            _ => (0.0, f64::INFINITY),
        }
    }

    /// Its name, as a calibration asks for it.
    pub fn name(self) -> &'static str {
        match self {
            ProcessParameter::PrestonCoefficient => "preston_coefficient",
            ProcessParameter::ToolRadius => "tool_radius",
            ProcessParameter::PadMomentShare => "pad_moment_share",
        }
    }

    pub const ALL: [ProcessParameter; 3] = [
        ProcessParameter::PrestonCoefficient,
        ProcessParameter::ToolRadius,
        ProcessParameter::PadMomentShare,
    ];
}

/// What the fit is free to move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Freedom {
    pub preston_coefficient: bool,
    pub tool_radius: bool,
    pub pad_moment_share: bool,
    /// Each run's own r² term.
    pub metrology_power: bool,
}

impl Freedom {
    fn frees(&self, parameter: ProcessParameter) -> bool {
        match parameter {
            ProcessParameter::PrestonCoefficient => self.preston_coefficient,
            ProcessParameter::ToolRadius => self.tool_radius,
            ProcessParameter::PadMomentShare => self.pad_moment_share,
        }
    }
}

/// What ran, as given.
#[derive(Debug, Clone, PartialEq)]
pub enum TrialSpec {
    /// The tool parked at `position_mm` for `duration_s`.
    Ring { position_mm: f64, duration_s: f64 },
    /// A dwell schedule.
    Dwell {
        positions_mm: Vec<f64>,
        dwell_s: Vec<f64>,
    },
    /// A polar plan on the paper's machine: a dwell schedule (checked against the nominal
    /// process), under C's sector law or not, its pad centre starting at the part-frame
    /// angle `start_angle_rad`.
    Polar {
        schedule: DwellSchedule,
        start_angle_rad: f64,
    },
}

/// What ran, checked: a ring, a dwell schedule (its motion built once), or for a run measured
/// by a map the executed motion's blocks (`physics::polar`) and the stations they visit.
#[derive(Debug, Clone, PartialEq)]
enum Trial {
    Ring {
        position_mm: f64,
        duration_s: f64,
    },
    Plan(DwellSchedule),
    Executed {
        blocks: Vec<Block>,
        positions_mm: Vec<f64>,
    },
}

/// What a run removed, as measured.
#[derive(Debug, Clone, PartialEq)]
pub enum Measured {
    /// Material removed (nm, positive).
    Removal(DepthProfile),
    /// The form error before and after (material to remove, as the measurement fit reports
    /// it): removal = before − after, on the before's radii within the after's span (the
    /// after linearly interpolated).
    BeforeAfter {
        before: DepthProfile,
        after: DepthProfile,
    },
    /// Material removed (nm, positive) at a map's pixels: an interferometer's map of the
    /// removal, or the difference of the maps before and after (`maps::difference`). Each
    /// pixel has its own piston, tilt and the removal's spatial correlation in the fit.
    Map(Vec<MapSample>),
}

/// One pixel of a measured removal map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSample {
    /// The pixel's column and row on the map (its neighbours, for the residual's correlation).
    pub pixel: Pixel,
    /// Where it lies in the part's C frame, mm.
    pub x_mm: f64,
    pub y_mm: f64,
    pub removal_nm: f64,
}

/// One run as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSpec {
    pub trial: TrialSpec,
    pub measured: Measured,
    /// Only the points within it count (default: all).
    pub aperture: Option<(f64, f64)>,
}

/// Which of a run's measured profiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProfileRole {
    Removal,
    Before,
    After,
}

/// Why a measured profile was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProfileError {
    #[error("radius_mm has {radii} entries but depth_nm has {depths}: they must match")]
    LengthMismatch { radii: usize, depths: usize },
    #[error("must hold at least one point")]
    Empty,
    #[error("{field}[{index}] must be a finite number")]
    NonFinite { field: &'static str, index: usize },
    #[error("radius_mm must be strictly increasing; entry {index} is not above the one before")]
    NotIncreasing { index: usize },
    #[error("radius_mm[{index}] = {value} mm lies outside the part, [0, {edge_mm}] mm")]
    OffPart {
        index: usize,
        value: f64,
        edge_mm: f64,
    },
}

impl ProfileError {
    /// The member of the profile at fault, and its index.
    pub fn field(&self) -> (&'static str, Option<usize>) {
        match self {
            ProfileError::LengthMismatch { .. } => ("depth_nm", None),
            ProfileError::Empty => ("radius_mm", None),
            ProfileError::NonFinite { field, index } => (field, Some(*index)),
            ProfileError::NotIncreasing { index } | ProfileError::OffPart { index, .. } => {
                ("radius_mm", Some(*index))
            }
        }
    }
}

/// Why a run was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    Position(ScheduleError),
    #[error("duration_s must be a finite number > 0 and at most {max_s} s")]
    Duration { max_s: f64 },
    #[error("{error}")]
    Profile {
        role: ProfileRole,
        error: ProfileError,
    },
    #[error("the before and after profiles share no radii")]
    NoOverlap,
    #[error(transparent)]
    Aperture(GridError),
    #[error("no measured point lies within the run's clear aperture")]
    NothingInAperture,
    #[error("no pixel of the map lies on the part (within its workpiece radius)")]
    NothingOnPart,
    #[error(
        "C's sector law makes the removal vary with the angle, which one profile does not \
         sample: measure this run with a map"
    )]
    LawNeedsMap,
}

/// Why a calibration was refused before fitting.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    #[error("give at least one run")]
    NoRuns,
    #[error("run {index}: {error}")]
    Run { index: usize, error: RunError },
    #[error(
        "nothing to fit: ask for at least one of preston_coefficient, tool_radius and \
         pad_moment_share"
    )]
    NothingToFit,
    #[error("pad_moment_share can be fitted only under the linear pressure model")]
    MomentShareNeedsLinear,
    #[error(
        "run {run} is measured by a map, from which only K is fitted: a pixel's predicted \
         depth jumps where it meets the pad's rim (a pad held over the axis covers it whole or \
         not at all), so the fit cannot follow r_t or κ through the map's pixels; fit them from \
         ring-test profiles and K from the map"
    )]
    ShapeFromMap { run: usize },
    #[error(
        "{points} measured points cannot determine {parameters} parameters (the process's and \
         each run's piston{}{}): give more points",
        if *power { " and power" } else { "" },
        if *tilt { ", and a map run's tilt" } else { "" }
    )]
    TooFewPoints {
        points: usize,
        parameters: usize,
        power: bool,
        tilt: bool,
    },
}

/// Why a fit failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitFailure {
    #[error("the fit did not converge within {steps} steps")]
    NotConverged { steps: usize },
    #[error("the robust reweighting did not settle within {reweightings} rounds")]
    WeightsUnsettled { reweightings: usize },
    #[error("the runs cannot tell apart {}", names(parameters))]
    Undetermined { parameters: Vec<String> },
    #[error("the fit left the model's domain: {0}")]
    OutsideModel(String),
    #[error(
        "the best fit removes no material (K = {ratio:.3} × nominal): the measured removal runs \
         opposite to the model's — are before and after swapped, or heights given as removal?"
    )]
    NoRemoval { ratio: f64 },
}

fn names(parameters: &[String]) -> String {
    parameters.join(", ")
}

/// Why the model cannot be evaluated at a trial point (the fit then steps back).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OutsideModel {
    #[error(transparent)]
    Process(#[from] ProcessError),
    #[error("a run's tool position {position_mm} mm is beyond the process's reach")]
    OutOfReach { position_mm: f64 },
}

/// One run, checked: what ran, and the measured removal at its radii.
#[derive(Debug, Clone)]
struct Run {
    trial: Trial,
    /// The measured points' radii (a map's pixels': √(x² + y²)), mm.
    radius_mm: Vec<f64>,
    removal_nm: Vec<f64>,
    /// The piston's shape at each radius: cos θ(r) for before/after profiles, else 1.
    piston_shape: Vec<f64>,
    /// A map's pixels: where each lies (part frame, mm) and its place on the map.
    map: Option<MapPoints>,
}

/// The pixels of a run measured by a map.
#[derive(Debug, Clone)]
struct MapPoints {
    xy_mm: Vec<(f64, f64)>,
    pixels: Vec<Pixel>,
}

/// A checked calibration.
#[derive(Debug, Clone)]
pub struct Calibration {
    nominal: Process,
    runs: Vec<Run>,
    freedom: Freedom,
    robust: RobustLoss,
}

/// A fitted process parameter; without an uncertainty when the runs carry no information on
/// it (it is then held at its nominal value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub parameter: ProcessParameter,
    pub value: f64,
    pub uncertainty: Option<Uncertainty>,
}

/// How well a fitted parameter is known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Uncertainty {
    pub standard_error: f64,
    /// value ± t(0.975, n − p)·standard_error.
    pub interval_95: (f64, f64),
}

impl Estimate {
    pub fn standard_error(&self) -> Option<f64> {
        self.uncertainty.map(|u| u.standard_error)
    }
}

/// One run after the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct RunFit {
    pub piston_nm: f64,
    /// A map run's own fitted terms and its residual's correlation.
    pub map: Option<MapRunFit>,
    /// The r² term, nm/mm² (when fitted).
    pub power_nm_per_mm2: Option<f64>,
    pub residual_rms_nm: f64,
    /// Point-to-point noise of the residual: 1.4826·median|Δ²e|/√6 over its second
    /// differences (σ for white noise; blind to a smooth misfit and to a few sharp ones, such
    /// as a pad rim in the wrong place); `None` below 5 points and for a map.
    pub difference_noise_nm: Option<f64>,
    pub radius_mm: Vec<f64>,
    pub measured_nm: Vec<f64>,
    pub predicted_nm: Vec<f64>,
    /// The final weights (robust losses; 1 otherwise).
    pub weight: Vec<f64>,
}

/// What a map run adds to its fit.
#[derive(Debug, Clone, PartialEq)]
pub struct MapRunFit {
    /// The run's tilt, nm per mm along x and y of the part's frame.
    pub tilt_nm_per_mm: (f64, f64),
    /// The pixels used, and the residual (measured − model, nm) at each.
    pub pixels: Vec<Pixel>,
    pub residual_nm: Vec<f64>,
    /// The residual's correlation length as the standard errors count it, pixels
    /// ([`spatial`]).
    pub bandwidth_px: usize,
    /// How many times the first fitted parameter's variance from this run exceeds what it
    /// would be were its pixels independent (≥ 1: the variance is never taken below that).
    pub variance_inflation: f64,
}

/// A calibrated process.
#[derive(Debug, Clone)]
pub struct Calibrated {
    pub process: Process,
    pub estimates: Vec<Estimate>,
    /// The parameters with a standard error, in `estimates`' order, and their correlations.
    pub correlated: Vec<ProcessParameter>,
    pub correlation: Vec<Vec<f64>>,
    pub removal_rate_ratio: f64,
    pub runs: Vec<RunFit>,
    /// The residual is below [`EXACT_FIT_NM`] RMS: the runs carry no estimate of their noise,
    /// and no parameter has a standard error.
    pub exact_fit: bool,
    pub degrees_of_freedom: usize,
    pub steps: usize,
    pub reweightings: usize,
    pub robust_scale_nm: Option<f64>,
}

/// A fit whose residual RMS is below this, nm (a femtometre, far below any instrument's
/// resolution), is exact: its σ̂ is no estimate of the measurement noise.
pub const EXACT_FIT_NM: f64 = 1e-6;

/// The longest a ring may run, s.
pub const MAX_RING_DURATION_S: f64 = 1e9;

impl Calibration {
    /// Checks the runs against the nominal process.
    pub fn new(
        nominal: Process,
        runs: Vec<RunSpec>,
        freedom: Freedom,
        robust: RobustLoss,
    ) -> Result<Calibration, CalibrationError> {
        if runs.is_empty() {
            return Err(CalibrationError::NoRuns);
        }
        if !(freedom.preston_coefficient || freedom.tool_radius || freedom.pad_moment_share) {
            return Err(CalibrationError::NothingToFit);
        }
        if freedom.pad_moment_share
            && !matches!(nominal.pressure_model(), PressureModel::Linear { .. })
        {
            return Err(CalibrationError::MomentShareNeedsLinear);
        }
        let runs = runs
            .into_iter()
            .enumerate()
            .map(|(index, spec)| {
                check_run(&nominal, spec).map_err(|error| CalibrationError::Run { index, error })
            })
            .collect::<Result<Vec<Run>, _>>()?;
        if freedom.tool_radius || freedom.pad_moment_share {
            if let Some(run) = runs.iter().position(|run| run.map.is_some()) {
                return Err(CalibrationError::ShapeFromMap { run });
            }
        }
        let calibration = Calibration {
            nominal,
            runs,
            freedom,
            robust,
        };
        let points = calibration.points();
        let parameters = calibration.layout(&[true; 3]).len();
        if points <= parameters {
            return Err(CalibrationError::TooFewPoints {
                points,
                parameters,
                power: freedom.metrology_power,
                tilt: calibration.runs.iter().any(|run| run.map.is_some()),
            });
        }
        Ok(calibration)
    }

    fn points(&self) -> usize {
        self.runs.iter().map(|run| run.radius_mm.len()).sum()
    }

    /// Each run measured by a map: its pixels, the executed motion's blocks and the stations
    /// they visit (what one prediction of it costs).
    pub fn measured_maps(&self) -> Vec<(usize, &[Block], &[f64])> {
        self.runs
            .iter()
            .filter_map(|run| match (&run.map, &run.trial) {
                (
                    Some(map),
                    Trial::Executed {
                        blocks,
                        positions_mm,
                    },
                ) => Some((map.pixels.len(), blocks.as_slice(), positions_mm.as_slice())),
                _ => None,
            })
            .collect()
    }

    /// The nominal process.
    pub fn nominal(&self) -> &Process {
        &self.nominal
    }

    /// The parameter vector's layout: the free process parameters (those `informative`), then
    /// each run's piston, then each map run's tilt (x, y), then each run's power term.
    fn layout(&self, informative: &[bool; 3]) -> Vec<Slot> {
        let mut slots: Vec<Slot> = ProcessParameter::ALL
            .iter()
            .zip(informative)
            .filter(|(p, &i)| self.freedom.frees(**p) && i)
            .map(|(p, _)| Slot::Process(*p))
            .collect();
        slots.extend((0..self.runs.len()).map(Slot::Piston));
        for (j, run) in self.runs.iter().enumerate() {
            if run.map.is_some() {
                slots.extend([Slot::TiltX(j), Slot::TiltY(j)]);
            }
        }
        if self.freedom.metrology_power {
            slots.extend((0..self.runs.len()).map(Slot::Power));
        }
        slots
    }

    /// Fits the process to the runs.
    pub fn fit(&self) -> Result<Calibrated, FitFailure> {
        // A parameter no run responds to is held: the fit would call it undetermined.
        let informative =
            ProcessParameter::ALL.map(|p| !self.freedom.frees(p) || self.responds_to(p));
        let model = CalibrationModel {
            calibration: self,
            slots: self.layout(&informative),
            memo: RefCell::new(Vec::new()),
        };
        let start: Vec<f64> = model
            .slots
            .iter()
            .map(|slot| match slot {
                Slot::Process(p) => self.nominal_value(*p),
                _ => 0.0,
            })
            .collect();
        let fit = lsq::fit(&model, start, self.points(), self.robust, MAX_STEPS, 0.0)
            .map_err(|e| model.failure(e))?;
        model.report(&fit)
    }

    fn nominal_value(&self, parameter: ProcessParameter) -> f64 {
        match parameter {
            ProcessParameter::PrestonCoefficient => 1.0,
            ProcessParameter::ToolRadius => self.nominal.tool_radius_mm(),
            ProcessParameter::PadMomentShare => match self.nominal.pressure_model() {
                PressureModel::Linear { pad_moment_share } => pad_moment_share,
                _ => 0.0,
            },
        }
    }

    /// Whether any run's prediction moves with `parameter` (a small step either way).
    fn responds_to(&self, parameter: ProcessParameter) -> bool {
        if parameter == ProcessParameter::PrestonCoefficient {
            return true;
        }
        let base = ProcessParameter::ALL.map(|p| self.nominal_value(p));
        let Ok(at) = self.predictions(&base) else {
            return true; // let the fit say what is wrong
        };
        let (step, (_, upper)) = (parameter.step(&base), parameter.bounds());
        let j = parameter as usize;
        let mut moved = base;
        moved[j] += if base[j] + step <= upper { step } else { -step };
        match self.predictions(&moved) {
            Ok(next) => next
                .iter()
                .flatten()
                .zip(at.iter().flatten())
                .any(|(a, b)| a != b),
            Err(_) => true,
        }
    }

    /// Each run's removal predicted at the nominal K with r_t and κ from `values`
    /// ([ρ, r_t, κ]; ρ unused), nm.
    fn predictions(&self, values: &[f64; 3]) -> Result<Vec<Vec<f64>>, OutsideModel> {
        let mut spec: ProcessSpec = self.nominal.spec().clone();
        spec.tool_radius_mm = values[1];
        if let PressureModel::Linear { .. } = spec.pressure_model {
            spec.pressure_model = PressureModel::Linear {
                pad_moment_share: values[2],
            };
        }
        let process = Process::new(spec)?;
        let kernel = RemovalKernel::new(&process);
        self.runs
            .iter()
            .map(|run| run.predict(&process, &kernel))
            .collect()
    }
}

impl Run {
    fn predict(&self, process: &Process, kernel: &RemovalKernel) -> Result<Vec<f64>, OutsideModel> {
        match &self.trial {
            Trial::Ring {
                position_mm,
                duration_s,
            } => {
                if !process.holds_position(*position_mm) {
                    return Err(OutsideModel::OutOfReach {
                        position_mm: *position_mm,
                    });
                }
                let rings = kernel.rings(&self.radius_mm);
                let mut rate = vec![0.0; self.radius_mm.len()];
                kernel.fill_column(*position_mm, &self.radius_mm, rings.as_deref(), &mut rate);
                Ok(rate.into_iter().map(|r| r * duration_s).collect())
            }
            Trial::Plan(schedule) => {
                let motion = schedule.motion();
                within_reach(process, motion.radii_mm())?;
                Ok(RemovalOperator::assemble(kernel, &self.radius_mm, motion)
                    .apply(schedule.dwell_s()))
            }
            Trial::Executed {
                blocks,
                positions_mm,
            } => {
                within_reach(process, positions_mm)?;
                // Built only for a run measured by a map: its pixels.
                let pixels = self.map.as_ref().map_or(&[][..], |m| &m.xy_mm);
                Ok(PolarPad::new(process).depth_nm(blocks, pixels))
            }
        }
    }
}

/// The nominal process held these positions; a fitted one may reach less far.
fn within_reach(process: &Process, positions_mm: &[f64]) -> Result<(), OutsideModel> {
    match positions_mm.iter().find(|&&x| !process.holds_position(x)) {
        Some(&far) => Err(OutsideModel::OutOfReach { position_mm: far }),
        None => Ok(()),
    }
}

/// The process parameters' covariance from runs measured by maps (`map_covariance`), and
/// each map run's bandwidth (pixels) and variance inflation (`None` for a profile run).
struct MapCovariance {
    covariance: Vec<Vec<f64>>,
    runs: Vec<Option<(usize, f64)>>,
}

/// What each entry of the parameter vector is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    Process(ProcessParameter),
    Piston(usize),
    /// A map run's tilt along x and y.
    TiltX(usize),
    TiltY(usize),
    Power(usize),
}

/// A run's own terms: piston, tilt (x, y) and power.
#[derive(Debug, Clone, Copy, Default)]
struct Offsets {
    piston: f64,
    tilt: (f64, f64),
    power: f64,
}

/// How many predictions the model remembers: a step's residuals, its Jacobian and the
/// report ask for the same r_t and κ, and a map's prediction is dear.
const MEMO: usize = 8;

/// Each run's prediction at [r_t, κ].
type Remembered = ([f64; 2], Vec<Vec<f64>>);

struct CalibrationModel<'a> {
    calibration: &'a Calibration,
    slots: Vec<Slot>,
    /// The last predictions, by [r_t, κ] (ρ does not enter them).
    memo: RefCell<Vec<Remembered>>,
}

impl CalibrationModel<'_> {
    /// [ρ, r_t, κ] from the parameter vector (the nominal values where held).
    fn process_values(&self, p: &[f64]) -> [f64; 3] {
        let mut values = ProcessParameter::ALL.map(|q| self.calibration.nominal_value(q));
        for (slot, &x) in self.slots.iter().zip(p) {
            if let Slot::Process(q) = slot {
                values[*q as usize] = x;
            }
        }
        values
    }

    fn offsets(&self, p: &[f64], run: usize) -> Offsets {
        let mut offsets = Offsets::default();
        for (slot, &x) in self.slots.iter().zip(p) {
            match slot {
                Slot::Piston(j) if *j == run => offsets.piston = x,
                Slot::TiltX(j) if *j == run => offsets.tilt.0 = x,
                Slot::TiltY(j) if *j == run => offsets.tilt.1 = x,
                Slot::Power(j) if *j == run => offsets.power = x,
                _ => {}
            }
        }
        offsets
    }

    /// Each run's removal at the nominal K with r_t and κ from `values`
    /// ([`Calibration::predictions`]), remembered.
    fn predictions(&self, values: &[f64; 3]) -> Result<Vec<Vec<f64>>, OutsideModel> {
        let key = [values[1], values[2]];
        if let Some((_, g)) = self.memo.borrow().iter().find(|(k, _)| *k == key) {
            return Ok(g.clone());
        }
        let g = self.calibration.predictions(values)?;
        let mut memo = self.memo.borrow_mut();
        if memo.len() == MEMO {
            memo.remove(0);
        }
        memo.push((key, g.clone()));
        Ok(g)
    }

    /// The model's prediction of each run (with its own terms), from g at [ρ, r_t, κ].
    fn model_values(&self, p: &[f64], g: &[Vec<f64>]) -> Vec<Vec<f64>> {
        let rho = self.process_values(p)[0];
        self.calibration
            .runs
            .iter()
            .zip(g)
            .enumerate()
            .map(|(j, (run, g))| {
                let o = self.offsets(p, j);
                (0..g.len())
                    .map(|i| {
                        let r = run.radius_mm[i];
                        let value = rho * g[i] + o.piston * run.piston_shape[i] + o.power * r * r;
                        match &run.map {
                            Some(m) => value + o.tilt.0 * m.xy_mm[i].0 + o.tilt.1 * m.xy_mm[i].1,
                            None => value,
                        }
                    })
                    .collect()
            })
            .collect()
    }

    fn residuals_from(&self, p: &[f64], g: &[Vec<f64>]) -> Vec<f64> {
        let model = self.model_values(p, g);
        self.calibration
            .runs
            .iter()
            .zip(&model)
            .flat_map(|(run, m)| run.removal_nm.iter().zip(m).map(|(y, m)| y - m))
            .collect()
    }

    /// ∂g/∂(parameter) at `values` by difference quotients; `here` is g there.
    fn derivative(
        &self,
        values: &[f64; 3],
        here: &[f64],
        parameter: ProcessParameter,
    ) -> Result<Vec<f64>, OutsideModel> {
        let j = parameter as usize;
        let (h, (lower, upper)) = (parameter.step(values), parameter.bounds());
        let at = |offset: f64| {
            let mut v = *values;
            v[j] += offset;
            self.predictions(&v)
                .map(|g| g.into_iter().flatten().collect::<Vec<f64>>())
        };
        if values[j] - h < lower || values[j] + h > upper {
            // Three points on the inner side: (−3f(x) + 4f(x ± h) − f(x ± 2h))/(±2h).
            let s = if values[j] - h < lower { h } else { -h };
            let (f1, f2) = (at(s)?, at(2.0 * s)?);
            return Ok((0..here.len())
                .map(|i| (-3.0 * here[i] + 4.0 * f1[i] - f2[i]) / (2.0 * s))
                .collect());
        }
        let (plus, minus) = (at(h)?, at(-h)?);
        Ok((0..here.len())
            .map(|i| {
                let (ahead, behind) = ((plus[i] - here[i]) / h, (here[i] - minus[i]) / h);
                let (gentle, steep) = if ahead.abs() < behind.abs() {
                    (ahead, behind)
                } else {
                    (behind, ahead)
                };
                // Same sign and far apart: a kink between (a pad rim crossing a measured
                // radius, where the removal grows like a square root): the gentler side.
                if ahead * behind > 0.0 && steep.abs() > KINK * gentle.abs() {
                    gentle
                } else {
                    0.5 * (ahead + behind)
                }
            })
            .collect())
    }

    /// The covariance of the parameters in `indices` (slots) with each map run's residual
    /// correlation counted: Σ_j Cov(Σ_(i∈j) a_k,i·e_i) over the runs, a_k = ((JᵀWJ)⁻¹·JᵀW)_k
    /// each parameter's influence, in the √w-scaled form (rows √wᵢ·Jᵢ, residuals √wᵢ·eᵢ) over
    /// the points a robust loss kept (w > 0). A map run's share is its [`Sandwich`] (its
    /// variances never below its white-noise figure); a profile's, its residual taken as
    /// independent ([`spatial::independent`]: as a calibration of profiles alone takes it, but
    /// each run with its own variance). All of it times n/(n − p), n the points kept. With
    /// it, each map run's bandwidth and its first parameter's variance inflation.
    fn map_covariance(&self, fit: &Fit, indices: &[usize]) -> Result<MapCovariance, OutsideModel> {
        let jacobian = self.jacobian(&fit.parameters, &fit.residuals)?;
        let inverse: Vec<Vec<f64>> = indices
            .iter()
            .map(|&k| fit.inverse_normal[k].clone())
            .collect();
        let q = indices.len();
        let mut covariance = vec![vec![0.0; q]; q];
        let mut runs = Vec::with_capacity(self.calibration.runs.len());
        let mut offset = 0;
        for run in &self.calibration.runs {
            let start = offset;
            offset += run.radius_mm.len();
            // The points kept, their √w-scaled Jacobian rows and residuals.
            let kept: Vec<usize> = (start..offset).filter(|&i| fit.weights[i] > 0.0).collect();
            let rows: Vec<Vec<f64>> = kept
                .iter()
                .map(|&i| {
                    let s = fit.weights[i].sqrt();
                    (0..jacobian.ncols())
                        .map(|l| s * jacobian[(i, l)])
                        .collect()
                })
                .collect();
            let residual: Vec<f64> = kept
                .iter()
                .map(|&i| fit.weights[i].sqrt() * fit.residuals[i])
                .collect();
            let influence = spatial::influence(&inverse, &rows);
            let (share, this_run) = match &run.map {
                Some(map) => {
                    let pixels: Vec<Pixel> = kept.iter().map(|&i| map.pixels[i - start]).collect();
                    let sandwich = Sandwich::new(&pixels, &influence, &residual);
                    let mut share = sandwich.covariance.clone();
                    for (k, row) in share.iter_mut().enumerate() {
                        row[k] = sandwich.variance(k);
                    }
                    let inflation = if q > 0 && sandwich.white[0][0] > 0.0 {
                        sandwich.variance(0) / sandwich.white[0][0]
                    } else {
                        1.0
                    };
                    (share, Some((sandwich.bandwidth_px, inflation)))
                }
                None => (spatial::independent(&influence, &residual), None),
            };
            for (total, part) in covariance.iter_mut().zip(&share) {
                for (t, p) in total.iter_mut().zip(part) {
                    *t += p;
                }
            }
            runs.push(this_run);
        }
        let dof =
            spatial::lost_freedom(fit.degrees_of_freedom + self.slots.len(), self.slots.len());
        for row in &mut covariance {
            for v in row.iter_mut() {
                *v *= dof;
            }
        }
        Ok(MapCovariance { covariance, runs })
    }

    fn failure(&self, error: LsqError<OutsideModel>) -> FitFailure {
        match error {
            LsqError::Model(e) => FitFailure::OutsideModel(e.to_string()),
            LsqError::NotConverged { steps } => FitFailure::NotConverged { steps },
            LsqError::WeightsUnsettled { reweightings } => {
                FitFailure::WeightsUnsettled { reweightings }
            }
            LsqError::Undetermined { parameters } => FitFailure::Undetermined {
                parameters: parameters
                    .into_iter()
                    .map(|k| self.slot_name(self.slots[k]))
                    .collect(),
            },
        }
    }

    fn slot_name(&self, slot: Slot) -> String {
        match slot {
            Slot::Process(q) => q.name().into(),
            Slot::Piston(j) => format!("the piston of run {j}"),
            Slot::TiltX(j) => format!("the x tilt of run {j}"),
            Slot::TiltY(j) => format!("the y tilt of run {j}"),
            Slot::Power(j) => format!("the power term of run {j}"),
        }
    }

    fn report(&self, fit: &Fit) -> Result<Calibrated, FitFailure> {
        let calibration = self.calibration;
        let values = self.process_values(&fit.parameters);
        let g = self
            .predictions(&values)
            .map_err(|e| FitFailure::OutsideModel(e.to_string()))?;
        let model = self.model_values(&fit.parameters, &g);
        let t = lsq::t_quantile_95(fit.degrees_of_freedom);
        // A residual this small is no measurement's: the runs are the model exactly (a
        // measurement repeated unchanged as before and after, say) and say nothing of their
        // noise, so no parameter gets a standard error (σ̂ = 0 would claim it exact).
        let exact_fit = fit.variance.sqrt() < EXACT_FIT_NM;
        let k_nominal = calibration.nominal.spec().preston_coefficient_m2_per_n;
        let scale = |q: ProcessParameter| match q {
            ProcessParameter::PrestonCoefficient => k_nominal,
            _ => 1.0,
        };
        // The fitted process parameters' slots, in ALL's order.
        let fitted: Vec<(ProcessParameter, usize)> = ProcessParameter::ALL
            .into_iter()
            .filter_map(|q| {
                let slot = self.slots.iter().position(|s| *s == Slot::Process(q))?;
                Some((q, slot))
            })
            .collect();
        let indices: Vec<usize> = fitted.iter().map(|f| f.1).collect();
        // With a map among the runs, the residual's spatial correlation enters the errors (an
        // exact fit claims none).
        let spatial = if !exact_fit && calibration.runs.iter().any(|run| run.map.is_some()) {
            Some(
                self.map_covariance(fit, &indices)
                    .map_err(|e| FitFailure::OutsideModel(e.to_string()))?,
            )
        } else {
            None
        };
        let covariance = |a: usize, b: usize| match &spatial {
            Some(s) => s.covariance[a][b],
            None => fit.variance * fit.inverse_normal[indices[a]][indices[b]],
        };
        let mut estimates = Vec::new();
        let mut correlated = Vec::new();
        for q in ProcessParameter::ALL {
            if !calibration.freedom.frees(q) {
                continue;
            }
            let slot = fitted.iter().position(|f| f.0 == q);
            let value = values[q as usize] * scale(q);
            let uncertainty = slot.filter(|_| !exact_fit).map(|a| {
                let se = covariance(a, a).sqrt() * scale(q);
                correlated.push(q);
                Uncertainty {
                    standard_error: se,
                    interval_95: (value - t * se, value + t * se),
                }
            });
            estimates.push(Estimate {
                parameter: q,
                value,
                uncertainty,
            });
        }
        let correlation = if exact_fit {
            Vec::new()
        } else {
            (0..indices.len())
                .map(|a| {
                    (0..indices.len())
                        .map(|b| match &spatial {
                            // The floors can part the variances from the covariances.
                            Some(_) => (covariance(a, b)
                                / (covariance(a, a) * covariance(b, b)).sqrt())
                            .clamp(-1.0, 1.0),
                            None => fit.correlation(indices[a], indices[b]),
                        })
                        .collect()
                })
                .collect()
        };
        let mut offset = 0;
        let runs = calibration
            .runs
            .iter()
            .enumerate()
            .map(|(j, run)| {
                let n = run.radius_mm.len();
                let residual = &fit.residuals[offset..offset + n];
                let weight = fit.weights[offset..offset + n].to_vec();
                offset += n;
                let o = self.offsets(&fit.parameters, j);
                let map = run.map.as_ref().map(|m| {
                    let (bandwidth_px, variance_inflation) =
                        spatial.as_ref().and_then(|s| s.runs[j]).unwrap_or((0, 1.0));
                    MapRunFit {
                        tilt_nm_per_mm: o.tilt,
                        pixels: m.pixels.clone(),
                        residual_nm: residual.to_vec(),
                        bandwidth_px,
                        variance_inflation,
                    }
                });
                RunFit {
                    piston_nm: o.piston,
                    map,
                    power_nm_per_mm2: calibration.freedom.metrology_power.then_some(o.power),
                    residual_rms_nm: rms(residual),
                    // A map's residual correlates from pixel to pixel (what the interferometer
                    // smooths, and the part's own mid-spatial error): its point-to-point noise
                    // would call every map unexplained.
                    difference_noise_nm: (n >= 5 && run.map.is_none()).then(|| {
                        let d: Vec<f64> = residual
                            .windows(3)
                            .map(|w| w[2] - 2.0 * w[1] + w[0])
                            .collect();
                        lsq::robust_scale(&d) / 6f64.sqrt()
                    }),
                    radius_mm: run.radius_mm.clone(),
                    measured_nm: run.removal_nm.clone(),
                    predicted_nm: model[j].clone(),
                    weight,
                }
            })
            .collect();
        let mut spec = calibration.nominal.spec().clone();
        spec.preston_coefficient_m2_per_n = values[0] * k_nominal;
        spec.tool_radius_mm = values[1];
        if let PressureModel::Linear { .. } = spec.pressure_model {
            spec.pressure_model = PressureModel::Linear {
                pad_moment_share: values[2],
            };
        }
        // K alone is not checked by the predictions (they run at the nominal K).
        if values[0] <= 0.0 {
            return Err(FitFailure::NoRemoval { ratio: values[0] });
        }
        let process = Process::new(spec).map_err(|e| FitFailure::OutsideModel(e.to_string()))?;
        Ok(Calibrated {
            process,
            estimates,
            correlated,
            correlation,
            removal_rate_ratio: values[0],
            runs,
            exact_fit,
            degrees_of_freedom: fit.degrees_of_freedom,
            steps: fit.steps,
            reweightings: fit.reweightings,
            robust_scale_nm: fit.robust_scale,
        })
    }
}

fn rms(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

impl Model for CalibrationModel<'_> {
    type Error = OutsideModel;

    fn parameters(&self) -> usize {
        self.slots.len()
    }

    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, OutsideModel> {
        let g = self.predictions(&self.process_values(p))?;

        Ok(self.residuals_from(p, &g))
    }

    fn jacobian(&self, p: &[f64], _residuals: &[f64]) -> Result<Mat<f64>, OutsideModel> {
        let values = self.process_values(p);
        let g: Vec<f64> = self.predictions(&values)?.into_iter().flatten().collect();
        // Each point's run, radius, piston shape and place (x, y; 0 on a profile).
        let run_of: Vec<(usize, f64, f64, (f64, f64))> = self
            .calibration
            .runs
            .iter()
            .enumerate()
            .flat_map(|(j, run)| {
                (0..run.radius_mm.len()).map(move |i| {
                    let xy = run.map.as_ref().map_or((0.0, 0.0), |m| m.xy_mm[i]);
                    (j, run.radius_mm[i], run.piston_shape[i], xy)
                })
            })
            .collect();
        let mut columns = Vec::with_capacity(self.slots.len());
        for slot in &self.slots {
            let column: Vec<f64> = match *slot {
                Slot::Process(ProcessParameter::PrestonCoefficient) => {
                    g.iter().map(|g| -g).collect()
                }
                Slot::Process(q) => self
                    .derivative(&values, &g, q)?
                    .into_iter()
                    .map(|d| -values[0] * d)
                    .collect(),
                Slot::Piston(j) => run_of
                    .iter()
                    .map(|&(k, _, shape, _)| if k == j { -shape } else { 0.0 })
                    .collect(),
                Slot::TiltX(j) => run_of
                    .iter()
                    .map(|&(k, _, _, (x, _))| if k == j { -x } else { 0.0 })
                    .collect(),
                Slot::TiltY(j) => run_of
                    .iter()
                    .map(|&(k, _, _, (_, y))| if k == j { -y } else { 0.0 })
                    .collect(),
                Slot::Power(j) => run_of
                    .iter()
                    .map(|&(k, r, _, _)| if k == j { -r * r } else { 0.0 })
                    .collect(),
            };
            columns.push(column);
        }
        Ok(Mat::from_fn(g.len(), columns.len(), |i, k| columns[k][i]))
    }
}

fn check_profile(role: ProfileRole, profile: &DepthProfile, edge_mm: f64) -> Result<(), RunError> {
    let fail = |error| RunError::Profile { role, error };
    let DepthProfile {
        radius_mm,
        depth_nm,
    } = profile;
    if radius_mm.len() != depth_nm.len() {
        return Err(fail(ProfileError::LengthMismatch {
            radii: radius_mm.len(),
            depths: depth_nm.len(),
        }));
    }
    if radius_mm.is_empty() {
        return Err(fail(ProfileError::Empty));
    }
    for (index, (&r, &d)) in radius_mm.iter().zip(depth_nm).enumerate() {
        if !r.is_finite() {
            return Err(fail(ProfileError::NonFinite {
                field: "radius_mm",
                index,
            }));
        }
        if !d.is_finite() {
            return Err(fail(ProfileError::NonFinite {
                field: "depth_nm",
                index,
            }));
        }
        if !(0.0..=edge_mm).contains(&r) {
            return Err(fail(ProfileError::OffPart {
                index,
                value: r,
                edge_mm,
            }));
        }
        if index > 0 && r <= radius_mm[index - 1] {
            return Err(fail(ProfileError::NotIncreasing { index }));
        }
    }
    Ok(())
}

/// The measured removal at the before's radii within the after's span (the after linearly
/// interpolated: [`interpolate_within`]; a single after point is its own span).
fn removal_between(before: &DepthProfile, after: &DepthProfile) -> DepthProfile {
    let at = |r: f64| interpolate_within(&after.radius_mm, &after.depth_nm, r);
    let (radius_mm, depth_nm) = before
        .radius_mm
        .iter()
        .zip(&before.depth_nm)
        .filter_map(|(&r, &b)| at(r).map(|a| (r, b - a)))
        .unzip();
    DepthProfile {
        radius_mm,
        depth_nm,
    }
}

fn check_run(process: &Process, spec: RunSpec) -> Result<Run, RunError> {
    let by_map = matches!(spec.measured, Measured::Map(_));
    // A run measured by a map is predicted pixel by pixel from the motion C and X executed,
    // the part turning at Ω = −ω₁ (`physics::polar`).
    let omega = -process.omega1_rad_per_s();
    let executed = |schedule: DwellSchedule, start_rad: f64| Trial::Executed {
        blocks: executed_blocks(
            schedule.motion(),
            schedule.dwell_s(),
            omega,
            start_rad,
            &process.part().surface,
        ),
        positions_mm: schedule.positions_mm().to_vec(),
    };
    let trial = match spec.trial {
        TrialSpec::Ring {
            position_mm,
            duration_s,
        } => {
            crate::physics::check_positions(process, "position_mm", &[position_mm], false)
                .map_err(RunError::Position)?;
            if !(duration_s.is_finite() && duration_s > 0.0 && duration_s <= MAX_RING_DURATION_S) {
                return Err(RunError::Duration {
                    max_s: MAX_RING_DURATION_S,
                });
            }
            if by_map {
                Trial::Executed {
                    blocks: vec![Block {
                        station: 0,
                        segment: 0,
                        from_mm: position_mm,
                        to_mm: position_mm,
                        start_rad: 0.0,
                        duration_s,
                        part_speed_rad_per_s: omega,
                    }],
                    positions_mm: vec![position_mm],
                }
            } else {
                Trial::Ring {
                    position_mm,
                    duration_s,
                }
            }
        }
        TrialSpec::Dwell {
            positions_mm,
            dwell_s,
        } => {
            let schedule =
                DwellSchedule::new(process, positions_mm, dwell_s).map_err(RunError::Position)?;
            if by_map {
                executed(schedule, 0.0)
            } else {
                Trial::Plan(schedule)
            }
        }
        TrialSpec::Polar {
            schedule,
            start_angle_rad,
        } => {
            if by_map {
                executed(schedule, start_angle_rad)
            } else if matches!(schedule.motion().turning(), Turning::Sectors(_)) {
                return Err(RunError::LawNeedsMap);
            } else {
                // C at constant speed: a profile is the 1-D removal, the dwell run's.
                Trial::Plan(schedule)
            }
        }
    };
    let edge = process.workpiece_radius_mm();
    let axial_zero = matches!(spec.measured, Measured::BeforeAfter { .. });
    let measured = match spec.measured {
        Measured::Removal(profile) => {
            check_profile(ProfileRole::Removal, &profile, edge)?;
            profile
        }
        Measured::BeforeAfter { before, after } => {
            check_profile(ProfileRole::Before, &before, edge)?;
            check_profile(ProfileRole::After, &after, edge)?;
            let removal = removal_between(&before, &after);
            if removal.radius_mm.is_empty() {
                return Err(RunError::NoOverlap);
            }
            removal
        }
        Measured::Map(samples) => {
            // A map may reach past the part's edge (its boundary fitted to the pixels): only
            // the part's pixels count, and of them those in the run's aperture.
            let aperture = run_aperture(process, spec.aperture)?;
            let on_part: Vec<MapSample> = samples
                .into_iter()
                .filter(|s| s.removal_nm.is_finite() && s.x_mm.hypot(s.y_mm) <= edge)
                .collect();
            if on_part.is_empty() {
                return Err(RunError::NothingOnPart);
            }
            let kept: Vec<MapSample> = on_part
                .into_iter()
                .filter(|s| aperture.is_none_or(|a| a.contains(s.x_mm.hypot(s.y_mm))))
                .collect();
            if kept.is_empty() {
                return Err(RunError::NothingInAperture);
            }
            return Ok(Run {
                trial,
                radius_mm: kept.iter().map(|s| s.x_mm.hypot(s.y_mm)).collect(),
                removal_nm: kept.iter().map(|s| s.removal_nm).collect(),
                piston_shape: vec![1.0; kept.len()],
                map: Some(MapPoints {
                    xy_mm: kept.iter().map(|s| (s.x_mm, s.y_mm)).collect(),
                    pixels: kept.iter().map(|s| s.pixel).collect(),
                }),
            });
        }
    };
    let aperture = run_aperture(process, spec.aperture)?;
    let (radius_mm, removal_nm): (Vec<f64>, Vec<f64>) = measured
        .radius_mm
        .iter()
        .zip(&measured.depth_nm)
        .filter(|(r, _)| aperture.is_none_or(|a| a.contains(**r)))
        .map(|(r, d)| (*r, *d))
        .unzip();
    if radius_mm.is_empty() {
        return Err(RunError::NothingInAperture);
    }
    let surface = &process.part().surface;
    let piston_shape = radius_mm
        .iter()
        .map(|&r| if axial_zero { surface.normal(r).1 } else { 1.0 })
        .collect();
    Ok(Run {
        trial,
        radius_mm,
        removal_nm,
        piston_shape,
        map: None,
    })
}

/// A run's clear aperture, checked; `None`: every point counts.
fn run_aperture(
    process: &Process,
    aperture: Option<(f64, f64)>,
) -> Result<Option<ClearAperture>, RunError> {
    aperture
        .map(|(inner, outer)| ClearAperture::new(process, inner, outer))
        .transpose()
        .map_err(RunError::Aperture)
}
