//! A measured map's correction on the paper's machine (`POST /v1/maps/optimize`, polar
//! kinematics): a dwell plan in radius, C's speed modulated per sector along it, and the
//! exact removal of the motion that executes them.
//!
//! The map is placed on the part (as the analysis places it) and its piston and tilt are
//! removed (a least-squares plane over the clear aperture's valid pixels: alignment, not
//! figure). On rings at the radial grid's radii inside the aperture it is sampled at N equally
//! spaced angles (at least 4·m_max + 8, and one per map pixel along the ring, so that the
//! map's finer harmonics do not fold onto those corrected; bilinear between the four nearest
//! pixels, over those with data; a ring's missing samples take its mean), and split into
//! harmonics (`optimize::harmonics`):
//!
//! 0. the best plan in radius alone (the 1-D optimizer on the azimuthal mean, C at constant
//!    speed): the comparison a machine without C under control sets, and the dwell shape t⁰;
//! 1. m ≥ 1: each harmonic's modulation y_m = t⁰·x_m, one radial problem each, fitted
//!    unbounded as x relative to t⁰ (so that the floors it asks are in proportion to a dwell
//!    that removes an even layer, which a uniform layer more meets);
//! 2. its C law's floors on each station's dwell: the modulation bound, C's velocity and its
//!    acceleration (`harmonics::law_floor`), as asked and capped at twice the radial plan's
//!    dwell ([`FLOOR_CAPS`]); for each set of floors, the 1-D optimizer
//!    (`usecases::optimize`) on the azimuthal mean with a free piston, its floors raised to
//!    those, within every 1-D limit (the total time, X, Z, B). These plans and the radial plan
//!    are the candidates for the mean dwell;
//! 3. each candidate's modulation fitted again relative to its own dwell, within C's law
//!    (`harmonics::UnboundedFit::within`: the harmonics' amplitudes together within what one
//!    law carries) for a few iterations, and the candidate kept whose residual the plan's own
//!    model predicts smallest (more dwell gives the law room, but the mean bent to floors
//!    leaves a round error of its own); the kept one's fit then runs on from where it stopped;
//! 4. the law: speed factors per station and sector;
//! 5. the removal on a square map — the exact removal of the executed motion
//!    (`physics::polar`), or the plan's own first-order model ([`RemovalModel`]) — the target
//!    sampled at the same pixels, and their difference.
//!
//! The residual's figures are about its mean (a piston is free). What is not round is each
//! map less its azimuthal mean at the pixel's own radius: the removal's from the identity of
//! `physics::polar` (exactly, or the model's), the target's from a ring of samples. (Less the
//! mean of a ring of pixels, a steep radial profile across the ring's width would count as not
//! round.) Each harmonic's RMS per band is fitted on rings of pixels (`maps::rings`). The
//! harmonic budget reports, per radius band and harmonic m, the largest amplitude (nm) the
//! plan's mean dwell can put there: the footprint's harmonic of the dwell times the most
//! modulation of m alone that C's law carries (`harmonics::ModulationBound`: 1/c_m =
//! min{δ·sinc(mπ/S), a_max/(m·Ω0²)}, δ = min{δ_max, 1 − Ω0/v_max}, the servo rule
//! A ≤ min{v_max/(2πf), a_max/(4π²f²)} for C); and since one law carries every harmonic,
//! the share of that modulation the band's target asks of all of them at once,
//! Σ_m (target amplitude)/(largest amplitude): at most 1, the budget allows the band's whole
//! correction.

use std::f64::consts::TAU;

use rayon::prelude::*;

use super::map_analysis::{MapInputError, Placement};
use super::map_predict::{
    covered_turns, figures, map_size, map_work, segment_map_work, station_turns, MAX_BLOCKS,
};
use super::map_removal_function::square_axes;
use super::optimize::{optimize, OptimizeCommand, OptimizeSpec, OptimizedPlan, TargetSpec};
use super::{ComputeLimits, InputError, OperatorCache, Recommender, Setting, Warning};
use crate::field::{DepthProfile, Figures};
use crate::machine::servo::{ring_demands, RingBreach, RingDemand, ServoLimit};
use crate::machine::{
    Approach, Axis, AxisLimits, Drive, LimitKind, MachineChoice, PolarPart, PolarProgram, PolarRun,
    SegmentPath, Violation,
};
use crate::maps::analysis::{aperture_pixels, plane_fit};
use crate::maps::aperture::{Alignment, Aperture};
use crate::maps::rings::{band_rms, ring_harmonics};
use crate::maps::HeightMap;
use crate::optimize::harmonics::{
    law_floor, law_share, sector_modulation, speed_factors, CLimits, HarmonicOperator, Harmonics,
    LawBound, ModulationBound, SectorBasis, UnboundedFit, WithinFit, ADMM_SCREEN_WORK, ADMM_WORK,
};
use crate::optimize::kinematics::Floor;
use crate::optimize::problem::Bound;
use crate::optimize::OptimizeError;
use crate::physics::polar::{c_changes, c_runs, c_schedule, executed_blocks, Block, PolarPad};
use crate::physics::segment_pad::{SegmentPad, SegmentPadError};
use crate::physics::{RemovalKernel, RemovalOperator, SectorLaw};
use crate::segments::SegmentLayout;

/// Sectors per turn by default: 2° each.
pub const DEFAULT_SECTORS: usize = 180;
/// δ_max by default: the time over a sector within ±50 % of its mean (C's speed within
/// 2/3 and 2 times the process's).
pub const DEFAULT_MAX_MODULATION: f64 = 0.5;
/// The most harmonics one plan corrects.
pub const MAX_HARMONIC: usize = 90;
/// The most work the harmonics may take in one request, in operations (about a second on 2
/// cores).
pub const MAX_HARMONIC_WORK: f64 = 3e9;
/// The most candidates for the mean dwell: the radial plan and one per floor cap.
const CANDIDATES: usize = 1 + FLOOR_CAPS.len();
/// The most work the result's removal map may take, in pixel-turns as `/v1/maps/predict`
/// counts them (`map_work`: the depths and the exact azimuthal means; about a second on 2 cores,
/// the plan solved first; a coarser map is still the exact removal at its pixels).
pub const MAX_MAP_WORK: f64 = 1.5e6;
/// The most work the result's removal map on segments may take, in pixel-passes (the pad's
/// path times its width over a pixel's area; about two seconds on 2 cores).
pub const MAX_SEGMENT_MAP_WORK: f64 = 2.5e5;
/// The result's map is coarsened for the work limit to at most this many pixels across the
/// part's radius, no fewer: a coarser map tells nothing of what is not round.
const COARSEST_PIXELS_ACROSS_RADIUS: f64 = 8.0;
/// The caps tried on the law's floors, in multiples of the radial plan's dwell (∞: the floors
/// the modulation asks). Twice the radial plan's dwell is the one kept on prysm's sample at both
/// apertures tested; uncapped floors, on planted harmonics with no round error (where the radial
/// plan's dwell leaves the law no room). A cap of 1 (about the radial plan, itself a candidate)
/// won on neither, at a 1-D solve.
const FLOOR_CAPS: &[f64] = &[2.0, f64::INFINITY];
/// The most samples the map is read at on one ring.
pub const MAX_RING_SAMPLES: usize = 16_384;
/// Pixels across the part of the result's maps by default.
pub const DEFAULT_PIXELS_ACROSS: usize = 81;

/// How the result's removal map is computed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum RemovalModel {
    /// The exact removal of the executed motion (`physics::polar`) at the map's pixels: the
    /// verdict, at a cost that grows with C's turns (the pixel is coarsened, with a warning,
    /// to keep within [`MAX_MAP_WORK`], and a plan of more than `MAX_BLOCKS` blocks is refused).
    #[default]
    Exact,
    /// The plan's own model (`optimize::harmonics`): the mean dwell's removal ĝ_0·t and each
    /// harmonic's first-order removal of the law's modulation, on the aperture's rings,
    /// linear in the radius between them. A cost independent of the turns, but blind to what
    /// the linearisation leaves out (the modulation's second order, the sectors' aliases and
    /// the spiral's ripple): `/v1/maps/predict` gives the exact removal of the same plan.
    Harmonic,
}

/// A correction as asked, besides its setting.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MapOptimizeSpec {
    /// The 1-D plan's positions, constraints, weights, time budget and machine (its `target`
    /// is the map's and must be left empty).
    pub optimize: OptimizeSpec,
    /// Where the part sits on the map.
    pub placement: Placement,
    /// C's sectors per turn; default [`DEFAULT_SECTORS`].
    pub sectors: Option<usize>,
    /// The highest harmonic corrected; default what the pad resolves at the aperture's edge
    /// (π·r/r_t), below S/2.
    pub max_harmonic: Option<usize>,
    /// δ_max; default [`DEFAULT_MAX_MODULATION`].
    pub max_modulation: Option<f64>,
    /// The result maps' pixel, mm; default the part's diameter / 80.
    pub pixel_mm: Option<f64>,
    pub removal_model: RemovalModel,
    /// Segments on C (or a decentred part): the map is then in C's frame with data on the
    /// segments only.
    pub segments: Option<SegmentSetup>,
}

/// A part that is not round about C, as the correction runs on it.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentSetup {
    pub layout: SegmentLayout,
    /// The pad's clearance where it is clear of every segment, mm (0: it stays down).
    pub lift_mm: f64,
    /// ε: the most Z may depart from a program block's straight line, mm (within
    /// [`CHORD_TOLERANCE_RANGE_MM`]).
    pub chord_tolerance_mm: f64,
}

/// A micrometre: a tenth of a typical polishing pad's compliance under its load.
pub const DEFAULT_CHORD_TOLERANCE_MM: f64 = 1e-3;

/// The chord tolerances accepted, mm.
pub const CHORD_TOLERANCE_RANGE_MM: [f64; 2] = [1e-5, 0.1];

/// What one station's ring asks of Z on segments, and the C speed Z allows it.
#[derive(Debug, Clone, PartialEq)]
pub struct StationServo {
    pub station: usize,
    pub demand: RingDemand,
    /// C's fastest over the station's sectors in the plan, r/min.
    pub plan_c_rpm: f64,
}

/// Why a correction cannot be planned as asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapOptimizeInputError {
    #[error(transparent)]
    Setting(#[from] InputError),
    #[error("{0}")]
    Map(MapInputError),
    #[error("sectors must be a whole number from 8 to 3600, not {0}")]
    Sectors(usize),
    #[error(
        "max_harmonic must be a whole number from 1 to {max} (below half the sectors), not {got}"
    )]
    MaxHarmonic { got: usize, max: usize },
    #[error("max_modulation must be a number in (0, 0.9], not {0}")]
    MaxModulation(f64),
    #[error("the pixel must be a positive number of mm, not {0}")]
    Pixel(f64),
    #[error(
        "the part's speed ({omega_deg_per_min:.0} deg/min) is at or above C's \
         max_velocity_deg_per_min ({limit:.0}): C cannot turn the part at the process's speed"
    )]
    CTooSlow { omega_deg_per_min: f64, limit: f64 },
    #[error(
        "{rows} radii × {stations} stations × harmonics up to {max_harmonic} is about \
         {work:.1e} operations, more than one request may take ({max:.0e}): fewer radial \
         samples, positions or harmonics"
    )]
    TooMuchWork {
        rows: usize,
        stations: usize,
        max_harmonic: usize,
        work: f64,
        max: f64,
    },
    #[error(
        "the map covers {covered:.1} % of the clear aperture (radius {outer_mm} mm as placed); \
         at least 50 % is needed"
    )]
    MapTooSmall { covered: f64, outer_mm: f64 },
    #[error(
        "the map covers {covered:.1} % of the segments inside the clear aperture as placed; at \
         least 50 % is needed (the map is the mounted set in C's frame)"
    )]
    SegmentsMapTooSmall { covered: f64 },
    #[error("{0}")]
    Segments(SegmentPadError),
    #[error(transparent)]
    Servo(ServoError),
}

/// Why Z cannot follow a plan's rings on segments.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ServoError {
    /// Z cannot follow a station's ring at the C speed the plan turns it.
    #[error(
        "Z cannot follow the segments at station {station} (r = {r_mm} mm): its harmonic \
         {harmonic} ({amplitude_mm:.4} mm) allows C at most {largest_rpm:.1} r/min by Z's \
         {what}, and the plan turns C at {plan_rpm:.1} r/min (a slower workpiece_rpm, or a \
         faster Z)",
        what = match .limit { ServoLimit::Velocity => "velocity", ServoLimit::Acceleration => "acceleration" }
    )]
    Speed {
        station: usize,
        r_mm: f64,
        harmonic: usize,
        amplitude_mm: f64,
        limit: ServoLimit,
        largest_rpm: f64,
        plan_rpm: f64,
    },
    /// Z's travel is too short for a station's ring at any C speed.
    #[error("{0}")]
    Travel(RingBreach),
}

/// Each station's demand on Z on `setup`'s segments (`None` where the pad never reaches
/// one), refused where Z's travel is too short or `plan_rpm(station)` (r/min) is faster than
/// the servo rule allows there.
pub(super) fn station_demands(
    layout: &SegmentLayout,
    lift_mm: f64,
    pad_radius_mm: f64,
    positions_mm: &[f64],
    z: &AxisLimits,
    plan_rpm: impl Fn(usize) -> f64,
) -> Result<Vec<Option<RingDemand>>, ServoError> {
    let mut demands = Vec::with_capacity(positions_mm.len());
    for (station, &r) in positions_mm.iter().enumerate() {
        let demand = ring_demands(layout, &[r], lift_mm, pad_radius_mm, z)
            .map_err(|breach| {
                ServoError::Travel(RingBreach {
                    ring: station,
                    ..breach
                })
            })?
            .pop();
        if let Some(d) = &demand {
            let plan_rpm = plan_rpm(station);
            if let Some((harmonic, limit)) = d.speed.binding {
                // The law's speeds are the optimizer's to the last bit or so.
                if d.speed.largest_c_rpm * (1.0 + 1e-9) < plan_rpm {
                    return Err(ServoError::Speed {
                        station,
                        r_mm: r,
                        harmonic,
                        amplitude_mm: d.amplitudes_mm[harmonic - 1],
                        limit,
                        largest_rpm: d.speed.largest_c_rpm,
                        plan_rpm,
                    });
                }
            }
        }
        demands.push(demand);
    }
    Ok(demands)
}

/// The stations' reports of their `demands` (those with one), each with the plan's fastest C
/// there, `plan_rpm(station)` r/min.
pub(super) fn station_servo(
    demands: Vec<Option<RingDemand>>,
    plan_rpm: impl Fn(usize) -> f64,
) -> Vec<StationServo> {
    demands
        .into_iter()
        .enumerate()
        .filter_map(|(station, d)| {
            d.map(|demand| StationServo {
                station,
                demand,
                plan_c_rpm: plan_rpm(station),
            })
        })
        .collect()
}

/// A checked correction.
#[derive(Debug, Clone)]
pub struct MapOptimizeCommand {
    plan: OptimizeCommand,
    setting: Setting,
    pad: PolarPad,
    /// The target (tilt-free map) on rings at the aperture's grid radii, and its harmonics.
    target: SampledMap,
    harmonics: Harmonics,
    sectors: usize,
    c: CLimits,
    /// The machine as the request named it (for warnings on the default machine's limits).
    machine: MachineChoice,
    pixel_mm: f64,
    removal_model: RemovalModel,
    /// The map's RMS above `max_harmonic` on the rings (what the plan leaves alone), nm.
    left_rms_nm: f64,
    segments: Option<Segments>,
}

/// The pad on the segments, and each station's demand on Z (`None` where its ring crosses no
/// segment).
#[derive(Debug, Clone)]
struct Segments {
    pad: SegmentPad,
    demands: Vec<Option<RingDemand>>,
    /// How the plan's program follows them.
    path: SegmentPath,
}

/// The map as the plan sees it: heights (nm) in the part's frame, piston and tilt removed.
#[derive(Debug, Clone)]
struct SampledMap {
    map: HeightMap,
    alignment: Alignment,
    /// Piston (nm) and tilt (nm/mm in x and y) removed.
    plane: [f64; 3],
    /// On segments: the layout, and each segment's own plane removed instead (its centre
    /// (x, y), piston, and tilt in x and y; off the segments the map has no data).
    segments: Option<(SegmentLayout, Vec<[f64; 5]>)>,
}

impl SampledMap {
    /// The mean of `samples` equally spaced values on the ring of radius r (over those with
    /// data; 0 when none has).
    fn ring_mean(&self, r: f64, samples: usize) -> f64 {
        let known: Vec<f64> = (0..samples)
            .filter_map(|k| {
                let (s, c) = (TAU * k as f64 / samples as f64).sin_cos();
                self.at(r * c, r * s)
            })
            .collect();
        if known.is_empty() {
            0.0
        } else {
            known.iter().sum::<f64>() / known.len() as f64
        }
    }

    /// The tilt-free height at (x, y) mm (part frame): bilinear over the neighbours with data;
    /// `None` where none has.
    fn at(&self, x: f64, y: f64) -> Option<f64> {
        let (c, r) = self.alignment.to_pixel(x, y);
        let (c0, r0) = (c.floor(), r.floor());
        let (fx, fy) = (c - c0, r - r0);
        let (mut sum, mut weight) = (0.0, 0.0);
        for (dc, dr, w) in [
            (0.0, 0.0, (1.0 - fx) * (1.0 - fy)),
            (1.0, 0.0, fx * (1.0 - fy)),
            (0.0, 1.0, (1.0 - fx) * fy),
            (1.0, 1.0, fx * fy),
        ] {
            let (cc, rr) = (c0 + dc, r0 + dr);
            if cc < 0.0 || rr < 0.0 || w <= 0.0 {
                continue;
            }
            if let Some(h) = self.map.at(cc as usize, rr as usize) {
                sum += w * h;
                weight += w;
            }
        }
        if weight <= 0.0 {
            return None;
        }
        let height = sum / weight;
        Some(match &self.segments {
            None => height - self.plane[0] - self.plane[1] * x - self.plane[2] * y,
            Some((layout, planes)) => {
                let [cx, cy, piston, tx, ty] = planes[layout.segment_at([x, y])?];
                height - piston - tx * (x - cx) - ty * (y - cy)
            }
        })
    }
}

impl MapOptimizeCommand {
    pub fn new(
        setting: Setting,
        map: HeightMap,
        spec: MapOptimizeSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, MapOptimizeInputError> {
        use MapOptimizeInputError as E;
        let process = setting.process();
        let pad = PolarPad::new(process);
        let sectors = spec.sectors.unwrap_or(DEFAULT_SECTORS);
        if !(8..=3600).contains(&sectors) {
            return Err(E::Sectors(sectors));
        }
        let aperture = *setting.aperture();
        let (inner_mm, outer_mm) = (aperture.inner_mm(), aperture.outer_mm());
        let rt = process.tool_radius_mm();
        let highest = sectors / 2 - 1;
        let max_harmonic = match spec.max_harmonic {
            None => ((std::f64::consts::PI * outer_mm / rt).ceil() as usize)
                .clamp(1, highest.min(MAX_HARMONIC)),
            Some(m) if (1..=highest.min(MAX_HARMONIC)).contains(&m) => m,
            Some(got) => {
                return Err(E::MaxHarmonic {
                    got,
                    max: highest.min(MAX_HARMONIC),
                })
            }
        };
        let max_modulation = spec.max_modulation.unwrap_or(DEFAULT_MAX_MODULATION);
        if !(max_modulation > 0.0 && max_modulation <= 0.9) {
            return Err(E::MaxModulation(max_modulation));
        }
        let radius = process.workpiece_radius_mm();
        let pixel_mm = match spec.pixel_mm {
            None => 2.0 * radius / (DEFAULT_PIXELS_ACROSS - 1) as f64,
            Some(p) if p.is_finite() && p > 0.0 => p,
            Some(p) => return Err(E::Pixel(p)),
        };
        let machine = spec.optimize.machine;
        let c_axis = machine
            .limits()
            .map(|l| *l.axis(Axis::C))
            .unwrap_or_default();
        let omega0 = pad.part_speed_rad_per_s().abs();
        let c = CLimits {
            max_velocity_rad_per_s: c_axis.max_velocity_per_min.map(|v| v.to_radians() / 60.0),
            max_acceleration_rad_per_s2: c_axis.max_acceleration_per_s2.map(f64::to_radians),
            max_modulation,
        };
        if let Some(v) = c.max_velocity_rad_per_s {
            // The law's margin: C at Ω0 itself must stay strictly within the limit.
            if omega0 >= v * (1.0 - crate::optimize::kinematics::MARGIN) {
                return Err(E::CTooSlow {
                    omega_deg_per_min: omega0.to_degrees() * 60.0,
                    limit: v.to_degrees() * 60.0,
                });
            }
        }
        // The map on the part.
        let (alignment, _) = spec.placement.place(&map).map_err(E::Map)?;
        let plane = tilt_plane(&map, &alignment, inner_mm, outer_mm);
        let segment_planes = spec.segments.as_ref().map(|setup| {
            let layout = &setup.layout;
            let planes = (0..layout.spec().count)
                .map(|i| segment_plane(&map, &alignment, layout, i))
                .collect();
            (layout.clone(), planes)
        });
        let target = SampledMap {
            map,
            alignment,
            plane,
            segments: segment_planes,
        };
        // Rings at the grid's radii in the aperture, N angles each.
        let radii: Vec<f64> = setting
            .grid()
            .radii_mm()
            .iter()
            .copied()
            .filter(|&r| r >= inner_mm && r <= outer_mm)
            .collect();
        // The harmonic operator's spectra (a 15-point rule on up to ⌈m·π/2⌉ panels for every
        // m, at each radius and each of a station's four places) and each harmonic's normal
        // equations.
        let (rows, stations) = (radii.len() as f64, spec.optimize.positions_mm.len() as f64);
        let m = max_harmonic as f64;
        // Then the normal equations once; a Cholesky factorisation per harmonic for the
        // unbounded fit and two for each candidate mean dwell's (its unbounded fit and ADMM's
        // shifted matrix; ADMM's refactorisations counted as ten more), and ADMM's work: the
        // kept candidate's in full, the others' screening.
        let factorisations = 1.0 + 2.0 * CANDIDATES as f64 + 10.0;
        let work = rows * stations * 4.0 * 15.0 * (1.6 * m).max(4.0) * (m + 1.0)
            + m * rows * stations * stations
            + factorisations * m * stations.powi(3) / 3.0
            + ADMM_WORK
            + (CANDIDATES - 1) as f64 * ADMM_SCREEN_WORK;
        if work > MAX_HARMONIC_WORK {
            return Err(E::TooMuchWork {
                rows: radii.len(),
                stations: spec.optimize.positions_mm.len(),
                max_harmonic,
                work,
                max: MAX_HARMONIC_WORK,
            });
        }
        // At least 4·m_max + 8 samples a ring, and one per map pixel along it: a ring sampled
        // more sparsely than the map would fold the map's finer harmonics (m above N − m_max)
        // onto those the plan corrects.
        let map_pixel = target.alignment.pixel_mm;
        // Across a gap between segments the ring takes the straight line between the values at
        // its ends: the target has no step there for the plan to chase (the pad cannot make
        // one), and what it asks in the gap nothing there records.
        let segmented = target.segments.is_some();
        let (mut sampled, mut missing) = (0usize, 0usize);
        // On segments: the samples that fall on one, and those of them without data.
        let (mut on_segments, mut missing_on_segments) = (0usize, 0usize);
        let rings: Vec<Vec<f64>> = radii
            .iter()
            .map(|&r| {
                let n = ((TAU * r / map_pixel).ceil() as usize)
                    .clamp(4 * max_harmonic + 8, MAX_RING_SAMPLES);
                let values: Vec<Option<f64>> = (0..n)
                    .map(|k| {
                        let (s, c) = (TAU * k as f64 / n as f64).sin_cos();
                        target.at(r * c, r * s)
                    })
                    .collect();
                let known: Vec<f64> = values.iter().flatten().copied().collect();
                sampled += values.len();
                missing += values.len() - known.len();
                if let Some((layout, _)) = &target.segments {
                    for (k, v) in values.iter().enumerate() {
                        let (s, c) = (TAU * k as f64 / n as f64).sin_cos();
                        if layout.segment_at([r * c, r * s]).is_some() {
                            on_segments += 1;
                            missing_on_segments += usize::from(v.is_none());
                        }
                    }
                }
                let mean = if known.is_empty() {
                    0.0
                } else {
                    known.iter().sum::<f64>() / known.len() as f64
                };
                if segmented && !known.is_empty() {
                    return bridged(&values);
                }
                values.iter().map(|v| v.unwrap_or(mean)).collect()
            })
            .collect();
        let covered = 100.0 * (1.0 - missing as f64 / sampled.max(1) as f64);
        if spec.segments.is_none() && covered < 50.0 {
            return Err(E::MapTooSmall { covered, outer_mm });
        }
        // Segments have data on themselves only: it is their share that counts.
        let covered_segments =
            100.0 * (1.0 - missing_on_segments as f64 / on_segments.max(1) as f64);
        if spec.segments.is_some() && (on_segments == 0 || covered_segments < 50.0) {
            return Err(E::SegmentsMapTooSmall {
                covered: if on_segments == 0 {
                    0.0
                } else {
                    covered_segments
                },
            });
        }
        let segments = match spec.segments {
            None => None,
            Some(setup) => {
                let path = SegmentPath::new(
                    setup.layout.clone(),
                    setup.lift_mm,
                    rt,
                    setup.chord_tolerance_mm,
                    &spec.optimize.positions_mm,
                );
                let pad = SegmentPad::new(setup.layout, process).map_err(E::Segments)?;
                let z = machine
                    .limits()
                    .map(|l| *l.axis(Axis::Z))
                    .unwrap_or_default();
                let plan_rpm = omega0.abs() * 60.0 / TAU;
                let demands = station_demands(
                    pad.layout(),
                    setup.lift_mm,
                    rt,
                    &spec.optimize.positions_mm,
                    &z,
                    |_| plan_rpm,
                )
                .map_err(E::Servo)?;
                Some(Segments { pad, demands, path })
            }
        };
        let harmonics = Harmonics::of_rings(radii.clone(), &rings, max_harmonic);
        // What the rings hold above max_harmonic: their variance less the harmonics' power,
        // each ring weighted by its radius (its share of the area).
        let (mut left, mut area) = (0.0, 0.0);
        for ((ring, c), &r) in rings.iter().zip(&harmonics.coefficients).zip(&radii) {
            let mean = c[0].0;
            let variance = ring.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / ring.len() as f64;
            let captured: f64 = c.iter().skip(1).map(|(a, b)| 0.5 * (a * a + b * b)).sum();
            left += r * (variance - captured).max(0.0);
            area += r;
        }
        let left_rms_nm = if area > 0.0 {
            (left / area).sqrt()
        } else {
            0.0
        };
        let profile = DepthProfile {
            radius_mm: radii.clone(),
            depth_nm: harmonics.coefficients.iter().map(|c| c[0].0).collect(),
        };
        let plan = OptimizeCommand::new(
            setting.clone(),
            OptimizeSpec {
                target: TargetSpec {
                    uniform_depth_nm: None,
                    profile: Some(profile),
                    free_piston: Some(true),
                },
                ..spec.optimize
            },
            limits,
        )?;
        Ok(MapOptimizeCommand {
            plan,
            setting,
            pad,
            target,
            harmonics,
            sectors,
            c,
            machine,
            pixel_mm,
            removal_model: spec.removal_model,
            left_rms_nm,
            segments,
        })
    }
}

/// The polishing blocks' peaks of the program of `motion` with `dwell_s` on segments (X, Z,
/// B, C: |v| per minute, |a| per s²), or the limits they break.
fn segment_program_peaks(
    segments: &Segments,
    setting: &Setting,
    machine: MachineChoice,
    motion: &crate::physics::motion::Motion,
    dwell_s: &[f64],
) -> Result<[[f64; 2]; 4], MapOptimizeError> {
    let process = setting.process();
    let limits = machine.limits().unwrap_or_default();
    let program = PolarProgram::from_motion(
        PolarPart::Segments(&segments.path),
        &setting.mount().tool,
        motion,
        dwell_s,
        PolarRun {
            part_speed_rad_per_s: PolarPad::new(process).part_speed_rad_per_s(),
            start_rad: 0.0,
            approach: Approach {
                clearance_mm: 0.0,
                feed_mm_per_min: 1.0,
            },
            c_max_acceleration_deg_per_s2: limits.axis(Axis::C).max_acceleration_per_s2,
        },
    )
    .map_err(|e| {
        MapOptimizeError::Optimize(OptimizeError::Numerical {
            status: format!("the plan has no program: {e}"),
        })
    })?;
    let motions = program.polishing_motions();
    let spec = process.spec();
    let violations = machine.mark(limits.violations_of(
        &motions.each_ref().map(|(axis, motion)| (*axis, motion)),
        |limit, index| program.block_of(limit, index),
        program.blocks().len(),
        (spec.workpiece_rpm, spec.tool_rpm),
    ));
    if !violations.is_empty() {
        return Err(MapOptimizeError::ProgramLimits(violations));
    }
    Ok(motions.map(|(_, motion)| motion.peaks()))
}

/// The finest pixel from `pixel_mm` up (× 1.25 at a time, to the coarsest the part's `radius_mm`
/// allows) whose `work` is within `max`, or the work the coarsest would still take.
fn affordable_pixel(
    pixel_mm: f64,
    radius_mm: f64,
    max: f64,
    work: impl Fn(f64) -> f64,
) -> Result<f64, MapOptimizeError> {
    let coarsest = pixel_mm.max(radius_mm / COARSEST_PIXELS_ACROSS_RADIUS);
    let mut pixel = pixel_mm;
    while work(pixel) > max {
        if pixel >= coarsest {
            return Err(MapOptimizeError::ExactMapTooCostly {
                work: work(pixel),
                pixel_mm: pixel,
                max,
            });
        }
        pixel = (pixel * 1.25).min(coarsest);
    }
    Ok(pixel)
}

/// A ring's samples with each run of missing ones replaced by the straight line between the
/// known samples either side of it (around the ring); at least one is known.
fn bridged(values: &[Option<f64>]) -> Vec<f64> {
    let n = values.len();
    let known: Vec<usize> = (0..n).filter(|&k| values[k].is_some()).collect();
    let mut out: Vec<f64> = values.iter().map(|v| v.unwrap_or(0.0)).collect();
    for (j, &a) in known.iter().enumerate() {
        let b = known[(j + 1) % known.len()];
        let gap = (b + n - a) % n;
        let gap = if gap == 0 { n } else { gap };
        let (va, vb) = (out[a], out[b]);
        for step in 1..gap {
            let w = step as f64 / gap as f64;
            out[(a + step) % n] = (1.0 - w) * va + w * vb;
        }
    }
    out
}

/// Segment i's centre (mm), and the piston and tilt (nm, nm/mm about the centre) of the
/// least-squares plane through the map's valid pixels on it.
fn segment_plane(
    map: &HeightMap,
    alignment: &Alignment,
    layout: &SegmentLayout,
    i: usize,
) -> [f64; 5] {
    let (s, c) = layout.centre_angle(i).sin_cos();
    let (l, a) = (
        layout.spec().mount_radius_mm,
        layout.spec().aperture_radius_mm,
    );
    let (cx, cy) = (l * c, l * s);
    let aperture = Aperture::OffCentreCircle {
        centre_x_mm: cx,
        centre_y_mm: cy,
        radius_mm: a,
    };
    let census = aperture_pixels(map, alignment, &aperture);
    let [piston, x, y] = plane_fit(&census.pixels, &|p| ((p.x_mm - cx) / a, (p.y_mm - cy) / a));
    [cx, cy, piston, x / a, y / a]
}

/// Piston and tilt (nm, nm/mm) of the least-squares plane through the map's valid pixels in
/// the annulus [inner, outer] about the part's centre (the analysis's plane fit, in mm).
fn tilt_plane(map: &HeightMap, alignment: &Alignment, inner: f64, outer: f64) -> [f64; 3] {
    let aperture = Aperture::Annulus {
        inner_radius_mm: inner,
        outer_radius_mm: outer,
    };
    let census = aperture_pixels(map, alignment, &aperture);
    // In unit coordinates over the aperture, as the analysis fits it; back to nm/mm here.
    let [piston, x, y] = plane_fit(&census.pixels, &|p| (p.x_mm / outer, p.y_mm / outer));
    [piston, x / outer, y / outer]
}

/// One radius band's budget: for m = 1 … m_max, the largest amplitude (nm) of harmonic m the
/// plan can remove there.
#[derive(Debug, Clone, PartialEq)]
pub struct BudgetBand {
    pub from_mm: f64,
    pub to_mm: f64,
    pub amplitude_nm: Vec<f64>,
    /// The target's own amplitude of each harmonic in the band (its largest over the band's radii).
    pub target_amplitude_nm: Vec<f64>,
    /// Σ_m target_amplitude_nm/amplitude_nm: the share of C's modulation the band's target asks,
    /// every harmonic at once (one modulation carries them all). At most 1, the budget allows
    /// the band's whole correction; `None` where the target has a harmonic the plan's dwell
    /// cannot put in the band at all.
    pub modulation_share: Option<f64>,
    /// Each harmonic's RMS over the band's pixels (`maps::rings`), of the target and of the
    /// residual, nm; empty where no ring of the band has pixels enough to fit.
    pub target_rms_nm: Vec<f64>,
    pub residual_rms_nm: Vec<f64>,
}

/// The corrected plan and what it does.
#[derive(Debug, Clone, PartialEq)]
pub struct MapCorrection {
    /// The 1-D plan (the dwell per station, its program, its limits and warnings).
    pub plan: OptimizedPlan,
    pub sectors: usize,
    pub max_harmonic: usize,
    /// Speed factors [station][sector].
    pub speed_factors: Vec<Vec<f64>>,
    /// The time over each sector, s [station][sector].
    pub sector_dwell_s: Vec<Vec<f64>>,
    /// The result maps: pixel, axes, removal, target (with the plan's piston) and residual.
    pub pixel_mm: f64,
    pub x_mm: Vec<f64>,
    pub y_mm: Vec<f64>,
    pub removal_nm: Vec<Option<f64>>,
    pub target_nm: Vec<Option<f64>>,
    pub residual_nm: Vec<Option<f64>>,
    /// The target (tilt removed) over the aperture, about its mean; and its non-axisymmetric part.
    pub before: Figures,
    pub before_non_axisymmetric: Figures,
    /// The residual over the aperture, about its mean; and its non-axisymmetric part.
    pub after: Figures,
    pub after_non_axisymmetric: Figures,
    /// The residual of the best plan in radius alone (C at constant speed, the same limits
    /// but no modulation's floors), about its mean, and that plan's time (s). Its removal is
    /// round, so its non-axisymmetric part is the target's.
    pub radial_plan_after: Figures,
    pub radial_plan_time_s: f64,
    /// C's peaks over the executed motion, deg/min and deg/s².
    pub c_peak_velocity_deg_per_min: f64,
    pub c_peak_acceleration_deg_per_s2: f64,
    pub harmonic_budget: Vec<BudgetBand>,
    pub total_time_s: f64,
    /// How many blocks the executed motion takes.
    pub blocks: usize,
    pub removal_model: RemovalModel,
    pub warnings: Vec<Warning>,
    /// On segments: each one's figures, and each station's demand on Z.
    pub segments: Option<SegmentReport>,
}

/// What the plan does to each segment and asks of Z.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentReport {
    /// Per segment, its target and residual over its own pixels in the aperture, each about
    /// its own mean (a segment's piston is its own).
    pub figures: Vec<[Figures; 2]>,
    /// Per station whose ring crosses a segment.
    pub servo: Vec<StationServo>,
    /// The program's peaks over its polishing blocks (`PolarProgram::polishing_motion`), for
    /// X, Z, B and C: |velocity| per minute and |acceleration| per s², in each axis's unit.
    pub polishing_peaks: [[f64; 2]; 4],
}

/// Why a correction has no plan (found by solving).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapOptimizeError {
    #[error(transparent)]
    Optimize(#[from] OptimizeError),
    /// The plan's law would cut the motion into more blocks than one request's exact map
    /// computes.
    #[error(
        "the plan runs C through about {turns:.0} turns: at {sectors} sectors that is about \
         {blocks:.2e} blocks, and the exact removal map computes at most {max:.0e} in one \
         request (fewer sectors, a smaller correction per plan, or removal_model \"harmonic\" \
         and the exact map from /v1/maps/predict)"
    )]
    TooManyBlocks {
        turns: f64,
        sectors: usize,
        blocks: f64,
        max: f64,
    },
    /// Even the coarsest map the work limit would coarsen to costs more than one request's
    /// exact map computes (a pad over much of the part for many turns, a linear pad's
    /// pressure solved at every instant of a spiral).
    #[error(
        "the exact removal map of this plan costs about {work:.2e} pixel-turns even at \
         {pixel_mm} mm pixels, and one request computes at most {max:.1e} (a larger K or \
         pressure for fewer turns of C, a smaller pad, or removal_model \"harmonic\")"
    )]
    ExactMapTooCostly { work: f64, pixel_mm: f64, max: f64 },
    /// On segments, the program of the plan would break these limits over its polishing
    /// blocks.
    #[error("the plan's program would exceed {} machine limit(s)", .0.len())]
    ProgramLimits(Vec<Violation>),
}

pub fn map_optimize(
    command: MapOptimizeCommand,
    recommender: &Recommender,
    operators: &OperatorCache,
) -> Result<MapCorrection, MapOptimizeError> {
    let MapOptimizeCommand {
        plan,
        setting,
        pad,
        target,
        harmonics,
        sectors,
        c,
        machine,
        pixel_mm,
        removal_model,
        left_rms_nm,
        segments,
    } = command;
    let process = setting.process();
    let rt = process.tool_radius_mm();
    let motion = plan.motion().clone();
    let m_max = harmonics.coefficients[0].len() - 1;
    // 0. The best plan in radius alone: for comparison, and the shape the modulation is
    // fitted relative to.
    let radial_plan = optimize(plan.clone(), recommender, operators)?;
    // 1. Each harmonic's modulation.
    let operator = HarmonicOperator::new(&pad, &motion, &harmonics.radii_mm, m_max);
    let omega0 = pad.part_speed_rad_per_s().abs();
    let m_accel = c
        .max_acceleration_rad_per_s2
        .map_or(f64::INFINITY, |a| a / (c.max_modulation * omega0 * omega0));
    // A ring's share of the area (the centre keeps a little weight).
    let weights: Vec<f64> = harmonics.radii_mm.iter().map(|&r| r + 1e-3 * rt).collect();
    let largest = radial_plan
        .solution
        .dwell_s
        .iter()
        .fold(0.0_f64, |a, &t| a.max(t));
    // Fitted as δ relative to that dwell (a station's share of it least 1e-3 of the largest),
    // the modulation asks floors in proportion to a dwell that removes an even layer, which a
    // uniform layer more then meets; fitted in seconds, it asked floors of any shape, and the
    // mean dwell bent to them left its own profile (on prysm's sample 17 nm RMS of it, not 2).
    let shape: Vec<f64> = radial_plan
        .solution
        .dwell_s
        .iter()
        .map(|&t| t.max(1e-3 * largest).max(f64::MIN_POSITIVE))
        .collect();
    let fit = operator.fit_setup(&harmonics, &weights, motion.radii_mm(), rt, m_accel);
    // 2–3. The mean dwell (module docs): the radial plan, and the plans under the floors of
    // the unbounded modulation capped at each share of FLOOR_CAPS, each modulated within C's
    // law relative to its own dwell; the one whose residual the plan's own model predicts
    // smallest is kept.
    let bound = ModulationBound::new(&c, omega0, sectors, m_max)
        .expect("C's velocity was checked above Ω0");
    let unbounded = in_seconds(
        operator.fit(&fit, &shape).coefficients().to_vec(),
        &shape,
        sectors,
    );
    let grid = setting.grid().radii_mm().to_vec();
    // The distinct sets of floors the radial plan does not already meet (it is then the
    // optimum: no solve), solved side by side.
    let mut distinct: Vec<Vec<Floor>> = Vec::new();
    for &cap in FLOOR_CAPS {
        let capped: Vec<Vec<f64>> = unbounded
            .iter()
            .zip(&shape)
            .map(|(y, &t)| {
                let share = if cap.is_finite() {
                    law_share(y, cap * t, omega0, &c)
                } else {
                    1.0
                };
                y.iter().map(|v| v * share).collect()
            })
            .collect();
        let floors = law_floors(&capped, omega0, &c);
        let meets = floors
            .iter()
            .zip(&radial_plan.solution.dwell_s)
            .all(|(floor, &t)| floor.dwell_s <= t);
        let same = |other: &Vec<Floor>| {
            other
                .iter()
                .zip(&floors)
                .all(|(a, b)| a.dwell_s == b.dwell_s)
        };
        if !meets && !distinct.iter().any(same) {
            distinct.push(floors);
        }
    }
    let solved: Vec<Result<OptimizedPlan, OptimizeError>> = distinct
        .into_par_iter()
        .map(|floors| optimize(plan.clone().with_floors(floors), recommender, operators))
        .collect();
    let mut candidates = vec![radial_plan.clone()];
    for result in solved {
        // Floors the 1-D limits cannot meet leave the candidate out: the radial plan stands
        // (but a request out of time is out of time).
        match result {
            Ok(candidate) => candidates.push(candidate),
            Err(error @ OptimizeError::TimeLimit { .. }) => return Err(error.into()),
            Err(_) => {}
        }
    }
    // Compared after a few iterations each of the fit within the law; the one kept goes on
    // to the full fit from where it stopped.
    let fits: Vec<UnboundedFit> = candidates
        .par_iter()
        .map(|candidate| operator.fit(&fit, &candidate.solution.dwell_s))
        .collect();
    let screened: Vec<(f64, WithinFit)> = candidates
        .par_iter()
        .zip(&fits)
        .map(|(candidate, free)| {
            let mut within = free.within(&bound);
            within.run(ADMM_SCREEN_WORK);
            let modulation =
                in_seconds(within.coefficients(), &candidate.solution.dwell_s, sectors);
            let score = predicted_residual(
                &operator,
                &harmonics,
                &weights,
                &grid,
                candidate,
                &modulation,
            );
            (score, within)
        })
        .collect();
    // The first of equal scores, as the candidates are ordered (the radial plan first).
    let mut best: Option<(f64, usize, WithinFit)> = None;
    for (k, (score, within)) in screened.into_iter().enumerate() {
        if best.as_ref().is_none_or(|(best, ..)| score < *best) {
            best = Some((score, k, within));
        }
    }
    let (_, kept, mut within) = best.expect("the radial plan is a candidate");
    within.run(ADMM_WORK - ADMM_SCREEN_WORK);
    let modulation = within.coefficients();
    let plan = candidates.swap_remove(kept);
    let mut modulation = in_seconds(modulation, &plan.solution.dwell_s, sectors);
    let dwell = &plan.solution.dwell_s;
    // The blocks the law cuts the motion into (a block per sector passed; a turn under the
    // law takes as long as at constant speed), before any is made: the exact map needs them.
    let turns: f64 = dwell.iter().sum::<f64>() * omega0 / TAU;
    let estimate = turns * sectors as f64 + 2.0 * motion.len() as f64;
    if removal_model == RemovalModel::Exact && estimate > MAX_BLOCKS {
        return Err(MapOptimizeError::TooManyBlocks {
            turns,
            sectors,
            blocks: estimate,
            max: MAX_BLOCKS,
        });
    }
    // 4. The law, checked on the executed motion: the floors bound each station's own
    // sectors, but a station's law meets its neighbour's where the plan passes from one to the
    // other (and a segment may end just after a sector edge), so C's schedule is checked as
    // the program will run it (`c_schedule`: every change of speed the executed blocks hold,
    // without their repeated turns), and where it breaks a limit the stations' modulation is
    // scaled down (which keeps every floor: the plan stands).
    let mut round = 0;
    let (factors, executed, schedule, peaks) = loop {
        let factors = speed_factors(&modulation, dwell);
        let law = SectorLaw::new(motion.len(), sectors, factors.concat()).map_err(|e| {
            OptimizeError::Numerical {
                status: format!("the C law is not one: {e}"),
            }
        })?;
        let executed =
            motion
                .clone()
                .with_sector_law(law)
                .map_err(|e| OptimizeError::Numerical {
                    status: format!("the C law does not fit the plan: {e}"),
                })?;
        let schedule = c_schedule(&executed, dwell, pad.part_speed_rad_per_s(), 0.0);
        let mut peaks = c_peaks(&schedule.blocks, motion.len(), &c);
        if let Some(segments) = &segments {
            // Z's servo caps C per station, as C's own velocity limit does.
            for b in &schedule.blocks {
                if let Some(d) = &segments.demands[b.station] {
                    let cap = d.speed.largest_c_rpm * TAU / 60.0;
                    let over = &mut peaks.over[b.station];
                    *over = over.max(b.part_speed_rad_per_s.abs() / cap);
                }
            }
        }
        if peaks.over.iter().all(|&o| o <= 1.0) {
            break (factors, executed, schedule, peaks);
        }
        round += 1;
        if round > MAX_LAW_ROUNDS {
            return Err(OptimizeError::Infeasible {
                fields: vec![Bound::Machine(
                    Drive::Axis(Axis::C),
                    LimitKind::MaxAcceleration,
                )],
                detail: format!(
                    "C's law still breaks a limit of the c axis after {MAX_LAW_ROUNDS} rounds of \
                     scaling its modulation down"
                ),
            }
            .into());
        }
        for (j, &over) in peaks.over.iter().enumerate() {
            if over > 1.0 {
                for y in &mut modulation[j] {
                    *y /= over * (1.0 + LAW_MARGIN);
                }
            }
        }
    };
    let dwell = &plan.solution.dwell_s;
    // On segments, the plan's program (as `/v1/maps/program` makes it, from the same start):
    // its polishing blocks within every limit, and their peaks reported.
    let polishing_peaks = match &segments {
        None => None,
        Some(s) => Some(segment_program_peaks(
            s, &setting, machine, &executed, dwell,
        )?),
    };
    let sector_dwell_s: Vec<Vec<f64>> = modulation
        .iter()
        .zip(dwell)
        .map(|(y, &t)| y.iter().map(|v| (t + v) / sectors as f64).collect())
        .collect();
    // 5. The removal on a square map: exact at a pixel the work limit allows, or the model's.
    let radius = process.workpiece_radius_mm();
    let mut pixel = pixel_mm;
    if removal_model == RemovalModel::Exact && segments.is_none() {
        let blocks = schedule.executed_blocks as f64;
        // Under the law a turn takes as long as at constant speed.
        let at_constant_speed = vec![1.0; dwell.len()];
        let covered = covered_turns(
            process,
            motion.radii_mm(),
            &station_turns(dwell, &at_constant_speed, omega0),
        );
        let aperture = setting.aperture();
        let work = |pixel: f64| {
            let half = (radius / pixel).ceil() as usize;
            let (pixels, rings) = map_size(
                pixel,
                half,
                radius,
                (aperture.inner_mm(), aperture.outer_mm()),
            );
            map_work(process, pixels, rings, turns, blocks, covered)
        };
        pixel = affordable_pixel(pixel_mm, radius, MAX_MAP_WORK, work)?;
    }
    let blocks_on_segments =
        (removal_model == RemovalModel::Exact && segments.is_some()).then(|| {
            executed_blocks(
                &executed,
                dwell,
                pad.part_speed_rad_per_s(),
                0.0,
                &setting.process().part().surface,
            )
        });
    if let Some(blocks) = &blocks_on_segments {
        // Pixel-passes: the pad centre's path over the part times the band it sweeps, over a
        // pixel's area (each pass integrated between its located edges).
        let path_mm: f64 = blocks
            .iter()
            .map(|b| {
                0.5 * (b.from_mm + b.to_mm) * b.part_speed_rad_per_s.abs() * b.duration_s
                    + (b.to_mm - b.from_mm).abs()
            })
            .sum();
        let work = |pixel: f64| segment_map_work(path_mm, rt, pixel);
        pixel = affordable_pixel(pixel_mm, radius, MAX_SEGMENT_MAP_WORK, work)?;
    }
    let mut warnings = plan.warnings.clone();
    if left_rms_nm > HARMONICS_LEFT_FRACTION * before_rms_of(&harmonics) {
        warnings.push(Warning::HarmonicsLeft {
            max_harmonic: m_max,
            rms_nm: left_rms_nm,
        });
    }
    if pixel > pixel_mm {
        warnings.push(Warning::MapCoarsened {
            asked_mm: pixel_mm,
            used_mm: pixel,
        });
    }
    let half = (radius / pixel).ceil() as usize;
    let (x_mm, y_mm) = square_axes(0.0, half, pixel);
    let points: Vec<(f64, f64)> = y_mm
        .iter()
        .flat_map(|&y| x_mm.iter().map(move |&x| (x, y)))
        .collect();
    let on: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.hypot(points[i].1) <= radius)
        .collect();
    let on_points: Vec<(f64, f64)> = on.iter().map(|&i| points[i]).collect();
    // The removal at the pixels, and its azimuthal mean at any radius (to tell what is not
    // round from a steep radial profile within a ring of pixels).
    let removal = match removal_model {
        RemovalModel::Exact if blocks_on_segments.is_some() => {
            Removal::OnSegments(blocks_on_segments.expect("just checked"))
        }
        RemovalModel::Exact => Removal::Exact(executed_blocks(
            &executed,
            dwell,
            pad.part_speed_rad_per_s(),
            0.0,
            &setting.process().part().surface,
        )),
        RemovalModel::Harmonic => {
            let grid = setting.grid().radii_mm();
            let mean: Vec<f64> = harmonics
                .radii_mm
                .iter()
                .map(|r| plan.removal_nm[grid.partition_point(|g| g < r)])
                .collect();
            Removal::Model(ModelRemoval::new(
                &operator,
                &harmonics.radii_mm,
                &mean,
                &modulation,
            ))
        }
    };
    let segment_pad = segments.as_ref().map(|s| &s.pad);
    let depths = removal.depth_nm(&pad, segment_pad, &on_points);
    let piston = plan.solution.piston_nm.unwrap_or(0.0);
    let mut removal_nm = vec![None; points.len()];
    let mut target_nm = vec![None; points.len()];
    let mut residual_nm = vec![None; points.len()];
    let (inner, outer) = (setting.aperture().inner_mm(), setting.aperture().outer_mm());
    // The aperture's pixels with data.
    let mut inside = Vec::new();
    for (&i, &d) in on.iter().zip(&depths) {
        let Some(d) = d else { continue };
        removal_nm[i] = Some(d);
        let (x, y) = points[i];
        let r = x.hypot(y);
        if r < inner || r > outer {
            continue;
        }
        if let Some(e) = target.at(x, y) {
            target_nm[i] = Some(e + piston);
            residual_nm[i] = Some(d - e - piston);
            inside.push(Inside {
                r,
                theta: y.atan2(x),
                removal: d,
                target: e,
                residual: d - e - piston,
                target_variant: 0.0,
                residual_variant: 0.0,
            });
        }
    }
    // What is not round: each less its azimuthal mean at the pixel's own radius (the
    // removal's from its model or exactly, the target's from a ring of samples).
    let mut radii: Vec<f64> = inside.iter().map(|p| p.r).collect();
    radii.sort_by(f64::total_cmp);
    radii.dedup();
    let removal_means = match segment_pad {
        // Nothing on segments is round about C: every part of the map is C's law's to correct.
        Some(_) => vec![0.0; radii.len()],
        None => removal.mean_nm(&pad, &radii),
    };
    // The radial plan's removal is round: at each radius its 1-D removal, exactly.
    let radial_removal = RemovalOperator::assemble(&RemovalKernel::new(process), &radii, &motion)
        .apply(&radial_plan.solution.dwell_s);
    let radial_piston = radial_plan.solution.piston_nm.unwrap_or(0.0);
    let samples = 4 * m_max + 8;
    let target_means: Vec<f64> = radii
        .par_iter()
        .map(|&r| target.ring_mean(r, samples))
        .collect();
    for p in &mut inside {
        let k = radii.partition_point(|&r| r < p.r);
        if segment_pad.is_some() {
            p.target_variant = p.target;
            p.residual_variant = p.residual;
            continue;
        }
        p.target_variant = p.target - target_means[k];
        p.residual_variant = p.removal - removal_means[k] - p.target_variant;
    }
    let radial_after =
        figures(inside.iter().map(|p| {
            radial_removal[radii.partition_point(|&r| r < p.r)] - p.target - radial_piston
        }));
    let before = figures(inside.iter().map(|p| p.target));
    let after = figures(inside.iter().map(|p| p.residual));
    let before_non_axisymmetric = figures(inside.iter().map(|p| p.target_variant));
    let after_non_axisymmetric = figures(inside.iter().map(|p| p.residual_variant));
    let [target_fits, residual_fits] = ring_harmonics(
        &inside
            .iter()
            .map(|p| (p.r, p.theta, [p.target_variant, p.residual_variant]))
            .collect::<Vec<_>>(),
        pixel,
        m_max,
    );
    let segment_report = segments.as_ref().map(|segments| {
        let layout = segments.pad.layout();
        let of: Vec<Option<usize>> = inside
            .iter()
            .map(|p| layout.segment_at([p.r * p.theta.cos(), p.r * p.theta.sin()]))
            .collect();
        let figures = (0..layout.spec().count)
            .map(|i| {
                let mine = || inside.iter().zip(&of).filter(move |(_, s)| **s == Some(i));
                [
                    figures(mine().map(|(p, _)| p.target)),
                    figures(mine().map(|(p, _)| p.residual)),
                ]
            })
            .collect();
        let mut fastest = vec![0.0_f64; motion.len()];
        for b in &schedule.blocks {
            fastest[b.station] = fastest[b.station].max(b.part_speed_rad_per_s.abs());
        }
        let servo = station_servo(segments.demands.clone(), |station| {
            fastest[station] * 60.0 / TAU
        });
        SegmentReport {
            figures,
            servo,
            polishing_peaks: polishing_peaks.expect("made on segments"),
        }
    });
    let (peak_v, peak_a) = (peaks.velocity_rad_per_s, peaks.acceleration_rad_per_s2);
    let near = |peak: f64, limit: Option<f64>| {
        limit.is_some_and(|l| peak >= l * super::warnings::ACTIVE_USE)
    };
    for (peak, limit, kind) in [
        (peak_v, c.max_velocity_rad_per_s, LimitKind::MaxVelocity),
        (
            peak_a,
            c.max_acceleration_rad_per_s2,
            LimitKind::MaxAcceleration,
        ),
    ] {
        if near(peak, limit) {
            warnings.push(Warning::MachineLimitActive {
                drive: Drive::Axis(Axis::C),
                limit: kind,
                default_machine: machine.is_default(Drive::Axis(Axis::C), kind),
            });
        }
    }
    // The harmonic budget, per band of one pad radius.
    let harmonic_budget = band_budgets(&operator, &harmonics, dwell, &bound, (inner, outer), rt)
        .into_iter()
        .map(|b| {
            let last = b.to_mm >= outer;
            let band = |fits| {
                // The last band takes in the ring at the aperture's edge.
                band_rms(fits, b.from_mm, if last { f64::INFINITY } else { b.to_mm })
                    .unwrap_or_default()
            };
            BudgetBand {
                target_rms_nm: band(&target_fits),
                residual_rms_nm: band(&residual_fits),
                ..b
            }
        })
        .collect();
    Ok(MapCorrection {
        total_time_s: plan.total_time_s,
        plan,
        sectors,
        max_harmonic: m_max,
        speed_factors: factors,
        sector_dwell_s,
        pixel_mm: pixel,
        x_mm,
        y_mm,
        removal_nm,
        target_nm,
        residual_nm,
        before,
        before_non_axisymmetric,
        after,
        after_non_axisymmetric,
        radial_plan_after: radial_after,
        radial_plan_time_s: radial_plan.total_time_s,
        c_peak_velocity_deg_per_min: peak_v.to_degrees() * 60.0,
        c_peak_acceleration_deg_per_s2: peak_a.to_degrees(),
        harmonic_budget,
        blocks: schedule.executed_blocks,
        removal_model,
        warnings,
        segments: segment_report,
    })
}

/// The law's modulation Y_jk (s) at each station's sectors, of harmonics fitted relative to the
/// dwell (`relative`: x^c_m, x^s_m per station, y = t·x).
fn in_seconds(
    relative: Vec<(Vec<f64>, Vec<f64>)>,
    dwell_s: &[f64],
    sectors: usize,
) -> Vec<Vec<f64>> {
    let mut modulation = sector_modulation(&relative, dwell_s.len(), sectors);
    for (y, &t) in modulation.iter_mut().zip(dwell_s) {
        for v in y.iter_mut() {
            *v *= t;
        }
    }
    modulation
}

/// The harmonic budget's amplitudes (module docs) with the mean dwell `dwell_s`, per band of
/// one pad radius across the aperture `(inner, outer)` (mm), without the bands' RMS.
fn band_budgets(
    operator: &HarmonicOperator,
    harmonics: &Harmonics,
    dwell_s: &[f64],
    bound: &ModulationBound,
    (inner, outer): (f64, f64),
    rt: f64,
) -> Vec<BudgetBand> {
    let m_max = operator.m_max();
    // The most relative modulation of harmonic m alone that the law carries: 1/c_m.
    let allowed = |m: usize| 1.0 / bound.weights[m - 1];
    let per_m: Vec<Vec<f64>> = (1..=m_max)
        .map(|m| operator.footprint_apply(m, dwell_s))
        .collect();
    let mut bands = Vec::new();
    let mut from = inner;
    while from < outer {
        let to = (from + rt).min(outer);
        let rows: Vec<usize> = (0..harmonics.radii_mm.len())
            .filter(|&i| harmonics.radii_mm[i] >= from && harmonics.radii_mm[i] <= to)
            .collect();
        if !rows.is_empty() {
            let amplitude_nm: Vec<f64> = (1..=m_max)
                .map(|m| {
                    rows.iter().map(|&i| per_m[m - 1][i].abs()).sum::<f64>() / rows.len() as f64
                        * allowed(m)
                })
                .collect();
            let target_amplitude_nm: Vec<f64> = (1..=m_max)
                .map(|m| {
                    rows.iter()
                        .map(|&i| {
                            let (a, b) = harmonics.coefficients[i][m];
                            a.hypot(b)
                        })
                        .fold(0.0, f64::max)
                })
                .collect();
            // None where the target has a harmonic the plan's dwell cannot put there at all.
            let modulation_share = target_amplitude_nm
                .iter()
                .zip(&amplitude_nm)
                .filter(|(t, _)| **t > 0.0)
                .map(|(t, a)| (*a > 0.0).then(|| t / a))
                .sum();
            bands.push(BudgetBand {
                from_mm: from,
                to_mm: to,
                amplitude_nm,
                target_amplitude_nm,
                modulation_share,
                target_rms_nm: Vec::new(),
                residual_rms_nm: Vec::new(),
            });
        }
        from = to;
    }
    bands
}

/// How many times the modulation is scaled down where C's law breaks a limit on the executed
/// motion before the plan is refused.
const MAX_LAW_ROUNDS: usize = 20;
/// Where it breaks a limit by a factor, a station's modulation is scaled down by that factor
/// and this much more.
const LAW_MARGIN: f64 = 0.01;

/// C's peaks over a plan's executed blocks, and for each station how far the blocks it
/// takes part in exceed C's limits (the largest of peak/limit, ≤ 1 when within).
struct CPeaks {
    velocity_rad_per_s: f64,
    acceleration_rad_per_s2: f64,
    over: Vec<f64>,
}

/// The floors C's law puts under each station's dwell (`law_floor`), named by what sets them.
fn law_floors(modulation: &[Vec<f64>], omega0: f64, c: &CLimits) -> Vec<Floor> {
    modulation
        .par_iter()
        .map(|y| {
            let (dwell_s, bound) =
                law_floor(y, omega0, c).expect("C's velocity was checked above Ω0");
            Floor {
                dwell_s,
                bound: match bound {
                    LawBound::Modulation => {
                        Bound::Constraint(crate::optimize::problem::Constraint::MinDwell)
                    }
                    LawBound::Velocity => {
                        Bound::Machine(Drive::Axis(Axis::C), LimitKind::MaxVelocity)
                    }
                    LawBound::Acceleration => {
                        Bound::Machine(Drive::Axis(Axis::C), LimitKind::MaxAcceleration)
                    }
                },
            }
        })
        .collect()
}

/// The residual's mean square over the target's rings, area-weighted (`weights`), about its
/// mean, that the plan's own model ([`ModelRemoval`]) predicts for `plan` under `modulation`:
/// ring by ring, the 1-D removal less the target's mean, and for each harmonic m = 1 … M half
/// the square of the removal's coefficients less the target's. What lies above M is the
/// same for every plan and left out.
fn predicted_residual(
    operator: &HarmonicOperator,
    harmonics: &Harmonics,
    weights: &[f64],
    grid_mm: &[f64],
    plan: &OptimizedPlan,
    modulation: &[Vec<f64>],
) -> f64 {
    let mean: Vec<f64> = harmonics
        .radii_mm
        .iter()
        .map(|r| plan.removal_nm[grid_mm.partition_point(|g| g < r)])
        .collect();
    let model = ModelRemoval::new(operator, &harmonics.radii_mm, &mean, modulation);
    let (mut total, mut first, mut second, mut rest) = (0.0, 0.0, 0.0, 0.0);
    for ((removal, target), &w) in model.rings.iter().zip(&harmonics.coefficients).zip(weights) {
        let round = removal[0].0 - target[0].0;
        total += w;
        first += w * round;
        second += w * round * round;
        for ((c, s), (a, b)) in removal.iter().zip(target).skip(1) {
            rest += w * 0.5 * ((c - a).powi(2) + (s - b).powi(2));
        }
    }
    (second - first * first / total + rest) / total
}

/// C's speed in each block and its acceleration between consecutive runs of one C speed
/// (`physics::polar::c_runs`, `c_changes`: the program's model), and how far each station's
/// blocks go over C's limits.
fn c_peaks(blocks: &[Block], stations: usize, c: &CLimits) -> CPeaks {
    let mut peaks = CPeaks {
        velocity_rad_per_s: 0.0,
        acceleration_rad_per_s2: 0.0,
        over: vec![0.0; stations],
    };
    let ratio = |value: f64, limit: Option<f64>| limit.map_or(0.0, |l| value / l);
    for b in blocks {
        let v = b.part_speed_rad_per_s.abs();
        peaks.velocity_rad_per_s = peaks.velocity_rad_per_s.max(v);
        let over = &mut peaks.over[b.station];
        *over = over.max(ratio(v, c.max_velocity_rad_per_s));
    }
    for (change, both) in c_changes(&c_runs(blocks)) {
        peaks.acceleration_rad_per_s2 = peaks.acceleration_rad_per_s2.max(change);
        let r = ratio(change, c.max_acceleration_rad_per_s2);
        if r > 0.0 {
            for block in &blocks[both] {
                let over = &mut peaks.over[block.station];
                *over = over.max(r);
            }
        }
    }
    peaks
}

/// The target's harmonics above max_harmonic earn a warning when their RMS exceeds this
/// fraction of the RMS of those it corrects.
const HARMONICS_LEFT_FRACTION: f64 = 0.25;

/// The RMS of harmonics 1 … m_max over the rings, each weighted by its radius, nm.
fn before_rms_of(harmonics: &Harmonics) -> f64 {
    let (mut power, mut area) = (0.0, 0.0);
    for (c, &r) in harmonics.coefficients.iter().zip(&harmonics.radii_mm) {
        power += r * c
            .iter()
            .skip(1)
            .map(|(a, b)| 0.5 * (a * a + b * b))
            .sum::<f64>();
        area += r;
    }
    if area > 0.0 {
        (power / area).sqrt()
    } else {
        0.0
    }
}

/// A pixel of the clear aperture with data: its radius (mm), angle, the removal, the target
/// and the residual (nm), and the target's and the residual's parts that are not round.
struct Inside {
    r: f64,
    theta: f64,
    removal: f64,
    target: f64,
    residual: f64,
    target_variant: f64,
    residual_variant: f64,
}

/// The removal as the result computes it: the executed blocks, or the plan's model.
enum Removal {
    Exact(Vec<Block>),
    Model(ModelRemoval),
    /// The executed blocks on segments (`physics::segment_pad`).
    OnSegments(Vec<Block>),
}

impl Removal {
    /// At the points (x, y mm); `None` where the model has no ring.
    /// At the points (x, y mm); `None` where the model has no ring, or off the segments.
    fn depth_nm(
        &self,
        pad: &PolarPad,
        segments: Option<&SegmentPad>,
        points: &[(f64, f64)],
    ) -> Vec<Option<f64>> {
        let on =
            |&(x, y): &(f64, f64)| segments.is_none_or(|s| s.layout().segment_at([x, y]).is_some());
        match self {
            Removal::Exact(blocks) => pad.depth_nm(blocks, points).into_iter().map(Some).collect(),
            Removal::Model(model) => points
                .iter()
                .map(|p| on(p).then(|| model.at(p.0, p.1)).flatten())
                .collect(),
            Removal::OnSegments(blocks) => {
                let pad = segments.expect("segments' blocks come with their pad");
                let at: Vec<[f64; 2]> = points.iter().map(|&(x, y)| [x, y]).collect();
                pad.depth_nm(blocks, &at)
                    .into_iter()
                    .zip(points)
                    .map(|(d, p)| on(p).then_some(d))
                    .collect()
            }
        }
    }

    /// The azimuthal mean at each radius: exactly by the identity of `physics::polar` (at the
    /// C speed of each instant), or the model's.
    fn mean_nm(&self, pad: &PolarPad, radii_mm: &[f64]) -> Vec<f64> {
        match self {
            Removal::Exact(blocks) | Removal::OnSegments(blocks) => {
                pad.mean_depth_nm(blocks, radii_mm)
            }
            Removal::Model(model) => radii_mm.iter().map(|&r| model.mean_at(r)).collect(),
        }
    }
}

/// The removal the plan's model predicts (`RemovalModel::Harmonic`): the 1-D plan's exact
/// removal (the azimuthal mean at constant C) plus, for each harmonic m, the modulation kernel's G_m applied to harmonic m of the
/// law as executed — sector values Y_jk constant over each sector, whose coefficients are
/// sinc(mπ/S)·(2/S)·Σ_k Y_jk·(cos, sin)(m·c_k) (exact for m < S/2, as the law was built from
/// them: `optimize::harmonics`) — on the rings `radii_mm`, linear in the radius between them.
struct ModelRemoval {
    radii_mm: Vec<f64>,
    /// Per ring, (a_m, b_m) for m = 0 … m_max.
    rings: Vec<Vec<(f64, f64)>>,
}

impl ModelRemoval {
    /// `mean_nm`: the removal's azimuthal mean on the rings (the 1-D plan's exact removal).
    fn new(
        operator: &HarmonicOperator,
        radii_mm: &[f64],
        mean_nm: &[f64],
        modulation: &[Vec<f64>],
    ) -> ModelRemoval {
        let sectors = modulation.first().map_or(1, Vec::len);
        let m_max = operator.m_max();
        let basis = SectorBasis::new(sectors, m_max);
        let law: Vec<Vec<(f64, f64)>> = modulation.iter().map(|y| basis.harmonics(y)).collect();
        let mut rings: Vec<Vec<(f64, f64)>> =
            mean_nm.iter().map(|&mean| vec![(mean, 0.0)]).collect();
        for m in 1..=m_max {
            let (cosines, sines): (Vec<f64>, Vec<f64>) = law.iter().map(|h| h[m - 1]).unzip();
            let (c, s) = (operator.apply(m, &cosines), operator.apply(m, &sines));
            for (i, ring) in rings.iter_mut().enumerate() {
                ring.push((c[i], s[i]));
            }
        }
        ModelRemoval {
            radii_mm: radii_mm.to_vec(),
            rings,
        }
    }

    /// The rings either side of r and the weight of the outer one; `None` outside their span.
    fn between(&self, r: f64) -> Option<(usize, usize, f64)> {
        let radii = &self.radii_mm;
        let above = radii.partition_point(|&v| v < r);
        if above == radii.len() {
            return None;
        }
        if radii[above] == r {
            return Some((above, above, 0.0));
        }
        if above == 0 {
            return None;
        }
        let (a, b) = (radii[above - 1], radii[above]);
        Some((above - 1, above, (r - a) / (b - a)))
    }

    fn ring_at(&self, i: usize, theta: f64) -> f64 {
        // cos mθ, sin mθ by turning through θ once per harmonic.
        let (step_sin, step_cos) = theta.sin_cos();
        let (mut cs, mut sn) = (1.0, 0.0);
        let mut sum = 0.0;
        for &(c, s) in &self.rings[i] {
            sum += c * cs + s * sn;
            (cs, sn) = (cs * step_cos - sn * step_sin, sn * step_cos + cs * step_sin);
        }
        sum
    }

    /// The removal at (x, y) mm.
    fn at(&self, x: f64, y: f64) -> Option<f64> {
        let theta = y.atan2(x);
        let (i, j, w) = self.between(x.hypot(y))?;
        Some((1.0 - w) * self.ring_at(i, theta) + w * self.ring_at(j, theta))
    }

    /// Its azimuthal mean at r (0 where out of span: no pixel there has a removal).
    fn mean_at(&self, r: f64) -> f64 {
        self.between(r).map_or(0.0, |(i, j, w)| {
            (1.0 - w) * self.rings[i][0].0 + w * self.rings[j][0].0
        })
    }
}
