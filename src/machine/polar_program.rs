//! A polar plan as a program with C under position control: the part's spindle is an axis,
//! and the executed motion of [`crate::physics::polar`] (the plan's stops and moves cut at the
//! sector edges of C's law, X and C at constant speed in each piece) becomes the program's
//! blocks, each one G1 move of X, Z, B and C in inverse time.
//!
//! **C.** The lab frame's angle of the part, counter-clockwise positive seen from the pad (the
//! sign of `workpiece_rpm`): C turns at +Ω while the pad centre's part-frame angle φ falls at
//! Ω, so C = −φ, and C starts at −φ_0 (`start_rad`). C is carried unwound (cumulative); no
//! block turns it more than [`MAX_C_STEP_DEG`], so a controller that wraps C to [0°, 360°)
//! and takes the shorter way round takes the plan's way.
//!
//! **Velocity and acceleration.** Each axis's velocity is constant over a span of blocks and
//! changes between spans over the time between their midpoints ([`super::program`]'s model,
//! `physics::motion::acceleration`), spans being what the machine runs at one velocity: for X,
//! Z and B a stop or a move of the plan (the sector cuts do not change their speed), for C a
//! run of blocks at one C speed (a station's move crossing into the next station's at the
//! same factor does not change C's speed). The optimizer keeps C's limits by this model, so
//! the program's C peaks over its polishing blocks are the plan's.
//!
//! **On and off the part.** C cannot jump to speed: the approach runs C at the first block's
//! speed while the pad comes down along the tool axis, and the retract at the last block's
//! while it lifts; both take long enough that C's change from and to rest, v/(d/2), is no
//! more than the plan's own largest C acceleration, or half C's limit where that is more
//! ([`ramp_acceleration`]).
//! Without a clearance C starts and stops within the first and last polishing blocks.
//!
//! **On segments** ([`PolarPart::Segments`]: off-axis segments, or a decentred part) Z and B
//! follow each ring's law as C turns ([`crate::segments`]): at a block's end the pad centre is
//! over r·(cos φ, sin φ), φ = −C, with Z the law's height there and B (when the tool follows
//! the normal) atan of the law's radial slope, X and Z compensating B's pivot as
//! [`Tool::pose_at`] does; a tool held vertical moves Z alone, so X is the plan's radius and
//! runs at the plan's speed through a ring (the Z-only compensation). The blocks are cut finer
//! than the law's sectors: a piece turning C through Δφ is cut into parts of at most
//! √(8·ε/κ) rad, κ = 1.25 × the largest |d²Z/dφ²| sampled at [`CURVATURE_SAMPLES`] angles on
//! the rings of the stations the piece spans, so Z departs from each block's straight line by
//! at most κ·δφ²/8 ≤ ε (the chord tolerance). X, Z and B then change velocity wherever their
//! blocks do (a span per run of equal velocity within a stop or a move), and the approach
//! and retract follow the first and last rings with the clearance falling and rising along
//! the tool axis.

use super::limits::{Axis, LimitKind};
use super::pose::{Pose, Tool};
use super::program::{dwell_span, lifted, Approach, AxisMotion, BlockKind, ProgramError, Skipped};
use crate::physics::motion::{one_speed, Motion, Segment};
use crate::physics::polar::{c_changes, c_runs, executed_blocks, Track};
use crate::segments::SegmentLayout;
use crate::surface::Surface;

/// The most C turns in one block, degrees: a quarter turn, so the shorter way round is
/// unambiguous on a wrapped axis.
pub const MAX_C_STEP_DEG: f64 = 90.0;

/// Angles per turn at which a ring's Z curvature is sampled for the chord rule.
pub const CURVATURE_SAMPLES: usize = 2048;

/// The margin on the sampled curvature (the largest may fall between samples).
const CURVATURE_MARGIN: f64 = 1.25;

/// The part as C turns it.
#[derive(Debug, Clone, Copy)]
pub enum PolarPart<'a> {
    /// Round about C: the pose is the surface's at the pad centre's radius.
    Round(&'a Surface),
    /// Not round (module docs): Z and B follow each ring's law within a turn.
    Segments(&'a SegmentPath),
}

/// How Z and B follow segments: the layout, the law's lift, the pad's radius, and the chord
/// tolerance the blocks are cut to, with each station's ring curvature.
#[derive(Debug, Clone)]
pub struct SegmentPath {
    layout: SegmentLayout,
    lift_mm: f64,
    pad_radius_mm: f64,
    chord_tolerance_mm: f64,
    /// The stations' radii (increasing) and κ on each one's ring, mm/rad² (0: no law).
    stations_mm: Vec<f64>,
    curvature: Vec<f64>,
}

impl SegmentPath {
    /// `stations_mm`: the plan's stations, strictly increasing; `chord_tolerance_mm` > 0.
    pub fn new(
        layout: SegmentLayout,
        lift_mm: f64,
        pad_radius_mm: f64,
        chord_tolerance_mm: f64,
        stations_mm: &[f64],
    ) -> SegmentPath {
        let curvature = stations_mm
            .iter()
            .map(|&r| {
                layout.ring(r, lift_mm, pad_radius_mm).map_or(0.0, |law| {
                    CURVATURE_MARGIN * law.largest_curvature(CURVATURE_SAMPLES)
                })
            })
            .collect();
        SegmentPath {
            layout,
            lift_mm,
            pad_radius_mm,
            chord_tolerance_mm,
            stations_mm: stations_mm.to_vec(),
            curvature,
        }
    }

    /// ε, mm.
    pub fn chord_tolerance_mm(&self) -> f64 {
        self.chord_tolerance_mm
    }

    /// The largest turn (rad) of one block between radii `from_mm` and `to_mm`: the chord
    /// rule at the largest κ of the stations in that span and of the two about it.
    pub fn max_step_rad(&self, from_mm: f64, to_mm: f64) -> f64 {
        let (lo, hi) = (from_mm.min(to_mm), from_mm.max(to_mm));
        let first = self
            .stations_mm
            .partition_point(|&r| r < lo)
            .saturating_sub(1);
        let last = self
            .stations_mm
            .partition_point(|&r| r <= hi)
            .min(self.stations_mm.len() - 1);
        let kappa = self.curvature[first..=last]
            .iter()
            .copied()
            .fold(0.0, f64::max);
        if kappa > 0.0 {
            (8.0 * self.chord_tolerance_mm / kappa).sqrt()
        } else {
            f64::INFINITY
        }
    }

    /// The pad centre's height and radial slope over `r_mm`·(cos φ, sin φ): the ring's law,
    /// or off every law the surface of the segment under it, or the lift above the
    /// segments' centres (the pad clear of them all).
    pub fn height_and_slope(&self, r_mm: f64, phi: f64) -> (f64, f64) {
        if let Some(law) = self.layout.ring(r_mm, self.lift_mm, self.pad_radius_mm) {
            return (law.at(phi)[0], law.radial_slope(phi)[0]);
        }
        let (s, c) = phi.sin_cos();
        let p = [r_mm * c, r_mm * s];
        match self.layout.segment_at(p) {
            Some(i) => {
                let point = self.layout.point(i, p);
                let g = point.gradient;
                (point.sag_mm, g[0] * c + g[1] * s)
            }
            None => (self.lift_mm, 0.0),
        }
    }

    /// The pose with the pad centre over `r_mm`·(cos φ, sin φ), `clearance_mm` off the law
    /// along the tool's axis.
    pub fn pose(&self, tool: &Tool, r_mm: f64, phi: f64, clearance_mm: f64) -> Pose {
        let (z, slope) = self.height_and_slope(r_mm, phi);
        let pose = tool.pose_at(r_mm, z, slope.atan());
        if clearance_mm > 0.0 {
            lifted(&pose, clearance_mm)
        } else {
            pose
        }
    }
}

/// One block of a polar program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolarBlock {
    pub kind: BlockKind,
    /// The plan's station whose dwell it spends (`None` for the approach and retract).
    pub station: Option<usize>,
    /// The pad centre's radial position at the block's end, mm.
    pub position_mm: f64,
    pub end: Pose,
    /// C at the block's end, deg, unwound.
    pub c_deg: f64,
    /// C's speed over the block, deg/s.
    pub c_deg_per_s: f64,
    pub duration_s: f64,
}

/// A polar program: its blocks and each axis's motion (X, Z, B, C).
#[derive(Debug, Clone, PartialEq)]
pub struct PolarProgram {
    start: Pose,
    start_c_deg: f64,
    blocks: Vec<PolarBlock>,
    axes: [AxisMotion; 4],
    pub skipped: Skipped,
    /// The approach and retract as run (the feed lowered where C needs the time).
    pub approach: Approach,
    /// Time of the polishing blocks: the plan's total, s.
    pub polishing_time_s: f64,
    /// Time of every block, s.
    pub program_time_s: f64,
}

/// What the program is built from beyond the plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolarRun {
    /// Ω, the process's part speed, rad/s (signed, lab frame).
    pub part_speed_rad_per_s: f64,
    /// The pad centre's part-frame angle at the start, rad.
    pub start_rad: f64,
    /// The approach and retract as asked.
    pub approach: Approach,
    /// C's acceleration limit, deg/s² (`None`: none).
    pub c_max_acceleration_deg_per_s2: Option<f64>,
}

impl PolarProgram {
    /// The program that runs `motion` (its C law included) with `dwell_s` at its stations on
    /// the part as `part` has it.
    pub fn from_motion(
        part: PolarPart<'_>,
        tool: &Tool,
        motion: &Motion,
        dwell_s: &[f64],
        run: PolarRun,
    ) -> Result<PolarProgram, ProgramError> {
        let (first, last) = dwell_span(dwell_s)?;
        let segments = motion.segments();
        let plane = Surface::plane();
        let surface = match part {
            PolarPart::Round(surface) => surface,
            PolarPart::Segments(_) => &plane,
        };
        let pieces = executed_blocks(
            motion,
            dwell_s,
            run.part_speed_rad_per_s,
            run.start_rad,
            surface,
        );
        let pose_at = |position_mm: f64, c_deg: f64, clearance_mm: f64| match part {
            PolarPart::Round(surface) => lifted(&tool.pose(surface, position_mm), clearance_mm),
            PolarPart::Segments(path) => {
                path.pose(tool, position_mm, -c_deg.to_radians(), clearance_mm)
            }
        };
        // How many equal parts a piece from `from` to `to` turning C by `turn` deg is cut
        // into: a quarter turn at most, and on segments the chord rule.
        let parts_of = |from: f64, to: f64, turn: f64| {
            let mut parts = (turn.abs() / MAX_C_STEP_DEG).ceil().max(1.0);
            if let PolarPart::Segments(path) = part {
                parts = parts.max((turn.to_radians().abs() / path.max_step_rad(from, to)).ceil());
            }
            parts as usize
        };
        // The polishing blocks, each piece cut into equal parts.
        let mut blocks = Vec::with_capacity(pieces.len());
        // Per block: its span of X, Z and B (the plan's segment).
        let mut segment_of = Vec::with_capacity(pieces.len());
        let mut c = -run.start_rad.to_degrees();
        for piece in &pieces {
            let kind = match segments[piece.segment] {
                Segment::Stop { .. } => BlockKind::Dwell,
                Segment::Move { .. } => BlockKind::Move,
            };
            let speed = piece.part_speed_rad_per_s.to_degrees();
            let turn = speed * piece.duration_s;
            let parts = parts_of(piece.from_mm, piece.to_mm, turn);
            let c0 = c;
            let track = Track::new(Some(surface), piece.from_mm, piece.to_mm, 1.0);
            for k in 1..=parts {
                let share = k as f64 / parts as f64;
                let position_mm = track.at(share);
                c = c0 + turn * share;
                blocks.push(PolarBlock {
                    kind,
                    station: Some(piece.station),
                    position_mm,
                    end: pose_at(position_mm, c, 0.0),
                    c_deg: c,
                    c_deg_per_s: speed,
                    duration_s: piece.duration_s / parts as f64,
                });
                segment_of.push(piece.segment + 1);
            }
        }
        // Pieces of a station with no dwell take no time and give no block, so `first` has
        // the first one.
        let origin = pieces[0].from_mm;
        let polishing_time_s = dwell_s[first..=last].iter().sum();
        // The plan's largest change of C's speed (the cuts above change no speed).
        let plan_peak = c_changes(&c_runs(&pieces))
            .map(|(change, _)| change.to_degrees())
            .fold(0.0, f64::max);
        let ramp = ramp_acceleration(plan_peak, run.c_max_acceleration_deg_per_s2);
        let mut start_c_deg = -run.start_rad.to_degrees();
        let mut start = pose_at(origin, start_c_deg, 0.0);
        let mut approach = run.approach;
        if approach.clearance_mm > 0.0 {
            let (v_in, v_out) = (blocks[0].c_deg_per_s, blocks[blocks.len() - 1].c_deg_per_s);
            // C from rest to v over d: v/(d/2) ≤ the ramp's acceleration.
            let mut duration_s = 60.0 * approach.clearance_mm / approach.feed_mm_per_min;
            if let Some(a) = ramp {
                duration_s = duration_s.max(2.0 * v_in.abs().max(v_out.abs()) / a);
            }
            approach.feed_mm_per_min = 60.0 * approach.clearance_mm / duration_s;
            start_c_deg -= v_in * duration_s;
            start = pose_at(origin, start_c_deg, approach.clearance_mm);
            let last = blocks[blocks.len() - 1];
            // The pad along its ring (at constant speed along the tool axis), C at speed.
            let along = |kind, r: f64, c_from: f64, c_deg_per_s: f64, lift: [f64; 2]| {
                let turn = c_deg_per_s * duration_s;
                let parts = parts_of(r, r, turn);
                (1..=parts)
                    .map(|k| {
                        let s = k as f64 / parts as f64;
                        let c_deg = c_from + turn * s;
                        PolarBlock {
                            kind,
                            station: None,
                            position_mm: r,
                            end: pose_at(r, c_deg, lift[0] + (lift[1] - lift[0]) * s),
                            c_deg,
                            c_deg_per_s,
                            duration_s: duration_s / parts as f64,
                        }
                    })
                    .collect::<Vec<_>>()
            };
            let clearance = approach.clearance_mm;
            let on = along(
                BlockKind::Approach,
                origin,
                start_c_deg,
                v_in,
                [clearance, 0.0],
            );
            let off = along(
                BlockKind::Retract,
                last.position_mm,
                last.c_deg,
                v_out,
                [0.0, clearance],
            );
            segment_of = std::iter::repeat_n(0, on.len())
                .chain(segment_of)
                .chain(std::iter::repeat_n(segments.len() + 1, off.len()))
                .collect();
            blocks = on.into_iter().chain(blocks).chain(off).collect();
        }
        let durations: Vec<f64> = blocks.iter().map(|b| b.duration_s).collect();
        let pose_axes = [0, 1, 2].map(|axis| {
            let positions: Vec<f64> = std::iter::once(start.axes()[axis])
                .chain(blocks.iter().map(|b| b.end.axes()[axis]))
                .collect();
            let spans = match part {
                PolarPart::Round(_) => segment_of.clone(),
                PolarPart::Segments(_) => even_runs(&positions, &durations, &segment_of),
            };
            AxisMotion::of_spans(positions, &durations, &spans)
        });
        let c_positions: Vec<f64> = std::iter::once(start_c_deg)
            .chain(blocks.iter().map(|b| b.c_deg))
            .collect();
        let c_motion = AxisMotion::of_spans(c_positions, &durations, &c_spans(&blocks));
        let [x, z, b] = pose_axes;
        Ok(PolarProgram {
            start,
            start_c_deg,
            program_time_s: durations.iter().sum(),
            blocks,
            axes: [x, z, b, c_motion],
            skipped: Skipped {
                leading: first,
                trailing: motion.len() - 1 - last,
            },
            approach,
            polishing_time_s,
        })
    }

    /// X, Z, B and C's motions over the polishing blocks alone ([`Self::polishing_motion`]),
    /// in that order.
    pub fn polishing_motions(&self) -> [(Axis, AxisMotion); 4] {
        [Axis::X, Axis::Z, Axis::B, Axis::C].map(|a| (a, self.polishing_motion(a)))
    }

    /// An axis's motion over the polishing blocks alone: the velocities of blocks that spend a
    /// station's dwell, and the changes between two such blocks (the rest 0), its positions
    /// all the program's.
    pub fn polishing_motion(&self, axis: Axis) -> AxisMotion {
        let mut motion = self.motion(axis).clone();
        let polishing = |k: usize| self.blocks.get(k).is_some_and(|b| b.station.is_some());
        for (k, v) in motion.velocity_per_min.iter_mut().enumerate() {
            if !polishing(k) {
                *v = 0.0;
            }
        }
        for (k, a) in motion.acceleration_per_s2.iter_mut().enumerate() {
            if k == 0 || !(polishing(k - 1) && polishing(k)) {
                *a = 0.0;
            }
        }
        let peak = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        motion.peak_velocity_per_min = peak(&motion.velocity_per_min);
        motion.peak_acceleration_per_s2 = peak(&motion.acceleration_per_s2);
        motion
    }

    /// The pose and C (deg) before the first block.
    pub fn start(&self) -> (Pose, f64) {
        (self.start, self.start_c_deg)
    }

    pub fn blocks(&self) -> &[PolarBlock] {
        &self.blocks
    }

    pub fn motion(&self, axis: Axis) -> &AxisMotion {
        &self.axes[match axis {
            Axis::X => 0,
            Axis::Z => 1,
            Axis::B => 2,
            Axis::C => 3,
            Axis::Y => unreachable!("the paper's machine has no Y"),
        }]
    }

    /// The block an entry of an [`AxisMotion`]'s lists belongs to.
    pub fn block_of(&self, limit: LimitKind, index: usize) -> usize {
        super::program::block_of(limit, index, self.blocks.len())
    }
}

/// The acceleration C takes from and to rest in the approach and retract, deg/s²: the plan's
/// own largest, so the program's peak is the plan's, but at least half C's limit (a plan
/// whose law hardly changes C's speed would otherwise spend hours reaching it) and at most the
/// limit; `None` (no limit): the approach as asked decides.
pub fn ramp_acceleration(plan_peak: f64, limit: Option<f64>) -> Option<f64> {
    limit.map(|l| plan_peak.max(0.5 * l).min(l))
}

/// C's spans: runs of blocks at one C speed ([`one_speed`]), labelled by the block that opens each. The
/// approach and the retract are spans of their own (their speed is the first and last
/// polishing block's, and their change from and to rest is sized on its own).
fn c_spans(blocks: &[PolarBlock]) -> Vec<usize> {
    let mut label = 0;
    blocks
        .iter()
        .enumerate()
        .map(|(k, b)| {
            if k > 0 {
                let before = &blocks[k - 1];
                if !one_speed(before.c_deg_per_s, b.c_deg_per_s)
                    || before.station.is_some() != b.station.is_some()
                {
                    label = k;
                }
            }
            label
        })
        .collect()
}

/// Spans of an axis on segments: runs of blocks within one stop or move of the plan
/// (`segment_of`) whose velocities are one ([`one_speed`]), labelled by the block that opens
/// each.
fn even_runs(positions: &[f64], durations_s: &[f64], segment_of: &[usize]) -> Vec<usize> {
    let velocity = |k: usize| (positions[k + 1] - positions[k]) / durations_s[k];
    let mut label = 0;
    (0..durations_s.len())
        .map(|k| {
            if k > 0
                && (segment_of[k] != segment_of[k - 1] || !one_speed(velocity(k - 1), velocity(k)))
            {
                label = k;
            }
            label
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::motion::SectorLaw;
    use crate::physics::Orientation;
    use crate::segments::four_paraboloid_segments;

    /// Five stations over the case's segments under a 36-sector law that swings C's speed by
    /// ±30 %, at 10 r/min: about 22 turns.
    fn plan() -> (Motion, Vec<f64>, PolarRun) {
        let stations = 5;
        let sectors = 36;
        let factors = (0..stations * sectors)
            .map(|i| 1.0 + 0.3 * (TAU * (i % sectors) as f64 / sectors as f64 + i as f64).sin())
            .collect();
        let motion = Motion::radial(vec![45.0, 55.0, 70.0, 85.0, 98.0])
            .with_sector_law(SectorLaw::new(stations, sectors, factors).unwrap())
            .unwrap();
        let run = PolarRun {
            part_speed_rad_per_s: 10.0 * TAU / 60.0,
            start_rad: 0.3,
            approach: Approach {
                clearance_mm: 2.0,
                feed_mm_per_min: 60.0,
            },
            c_max_acceleration_deg_per_s2: None,
        };
        (motion, vec![20.0, 30.0, 30.0, 30.0, 20.0], run)
    }

    use std::f64::consts::TAU;

    /// The chord rule: between every two block ends (the pad centre's radius and C linear in
    /// between), the law's Z at 7 interior points departs from the block's straight line by at
    /// most ε, and by more than ε/4 somewhere (the cut is not needlessly fine: the margin
    /// 1.25 and the rounding up of the parts leave about ε/1.6 to ε), at ε = 1 µm and 10 µm.
    /// Z at every end is the law's plus the pivot (a vertical tool).
    #[test]
    fn on_segments_z_leaves_no_block_s_chord_by_more_than_the_tolerance() {
        let layout = four_paraboloid_segments();
        let (motion, dwell, run) = plan();
        for tolerance in [1e-3, 1e-2] {
            let path = SegmentPath::new(layout.clone(), 0.5, 5.0, tolerance, motion.radii_mm());
            let tool = Tool::new(150.0, Orientation::Vertical).unwrap();
            let program =
                PolarProgram::from_motion(PolarPart::Segments(&path), &tool, &motion, &dwell, run)
                    .unwrap();
            let (start, start_c) = program.start();
            let mut before = (start, start_c, program.blocks()[0].position_mm);
            let mut worst = 0.0_f64;
            for b in program.blocks() {
                let (pose, c, r) = before;
                let law = |s: f64| {
                    let r = r + (b.position_mm - r) * s;
                    let c = c + (b.c_deg - c) * s;
                    path.height_and_slope(r, -c.to_radians()).0 + 150.0
                };
                if b.station.is_some() {
                    assert!((law(1.0) - b.end.z_mm).abs() < 1e-12);
                    for t in 1..8 {
                        let s = t as f64 / 8.0;
                        let chord = pose.z_mm + (b.end.z_mm - pose.z_mm) * s;
                        worst = worst.max((law(s) - chord).abs());
                    }
                }
                before = (b.end, b.c_deg, b.position_mm);
            }
            assert!(
                worst <= tolerance && worst > tolerance / 4.0,
                "ε {tolerance}: worst {worst}"
            );
            eprintln!(
                "ε {tolerance} mm: worst chord departure {worst:.3e} mm over {} blocks",
                program.blocks().len()
            );
        }
    }

    /// Z-only compensation: with the tool held vertical (whatever its pivot) X is the pad
    /// centre's radius, so its velocity is 0 through every stop and one speed through each
    /// move, as the plan's; with B following the radial slope and a 150 mm pivot, X moves
    /// within the stops to compensate B (by more than 10 mm/min here).
    #[test]
    fn a_vertical_tool_keeps_x_at_the_plan_s_speed_within_a_ring() {
        let layout = four_paraboloid_segments();
        let (motion, dwell, run) = plan();
        let path = SegmentPath::new(layout.clone(), 0.0, 5.0, 1e-3, motion.radii_mm());
        for (orientation, moves_in_stops) in
            [(Orientation::Vertical, false), (Orientation::Normal, true)]
        {
            let tool = Tool::new(150.0, orientation).unwrap();
            let program =
                PolarProgram::from_motion(PolarPart::Segments(&path), &tool, &motion, &dwell, run)
                    .unwrap();
            let x = program.motion(Axis::X);
            let mut in_stops = 0.0_f64;
            let mut move_speed: Option<(usize, f64)> = None;
            for (k, b) in program.blocks().iter().enumerate() {
                let v = x.velocity_per_min[k];
                match (b.kind, b.station) {
                    (BlockKind::Dwell, Some(_)) => in_stops = in_stops.max(v.abs()),
                    (BlockKind::Move, Some(station)) if !moves_in_stops => {
                        // One speed per move: the stations' spacing over the move's time.
                        match move_speed {
                            Some((s, speed)) if s == station => {
                                assert!((v - speed).abs() <= 1e-9 * speed.abs(), "{k}")
                            }
                            _ => move_speed = Some((station, v)),
                        }
                    }
                    _ => {}
                }
            }
            if moves_in_stops {
                assert!(in_stops > 10.0, "{in_stops}");
            } else {
                assert_eq!(in_stops, 0.0);
            }
        }
    }
}
