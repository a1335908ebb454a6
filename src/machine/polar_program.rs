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

use super::limits::{Axis, LimitKind};
use super::pose::{Pose, Tool};
use super::program::{dwell_span, lifted, Approach, AxisMotion, BlockKind, ProgramError, Skipped};
use crate::physics::motion::{one_speed, Motion, Segment};
use crate::physics::polar::{c_changes, c_runs, executed_blocks, Track};
use crate::surface::Surface;

/// The most C turns in one block, degrees: a quarter turn, so the shorter way round is
/// unambiguous on a wrapped axis.
pub const MAX_C_STEP_DEG: f64 = 90.0;

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
    /// The program that runs `motion` (its C law included) with `dwell_s` at its stations.
    pub fn from_motion(
        surface: &Surface,
        tool: &Tool,
        motion: &Motion,
        dwell_s: &[f64],
        run: PolarRun,
    ) -> Result<PolarProgram, ProgramError> {
        let (first, last) = dwell_span(dwell_s)?;
        let segments = motion.segments();
        let pieces = executed_blocks(
            motion,
            dwell_s,
            run.part_speed_rad_per_s,
            run.start_rad,
            surface,
        );
        // The polishing blocks, each piece cut into equal parts of at most a quarter turn.
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
            let parts = (turn.abs() / MAX_C_STEP_DEG).ceil().max(1.0) as usize;
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
                    end: tool.pose(surface, position_mm),
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
        let first_pose = tool.pose(surface, origin);
        let mut start = first_pose;
        let mut start_c_deg = -run.start_rad.to_degrees();
        let mut approach = run.approach;
        if approach.clearance_mm > 0.0 {
            let (v_in, v_out) = (blocks[0].c_deg_per_s, blocks[blocks.len() - 1].c_deg_per_s);
            // C from rest to v over d: v/(d/2) ≤ the ramp's acceleration.
            let mut duration_s = 60.0 * approach.clearance_mm / approach.feed_mm_per_min;
            if let Some(a) = ramp {
                duration_s = duration_s.max(2.0 * v_in.abs().max(v_out.abs()) / a);
            }
            approach.feed_mm_per_min = 60.0 * approach.clearance_mm / duration_s;
            start = lifted(&first_pose, approach.clearance_mm);
            start_c_deg -= v_in * duration_s;
            let last = blocks[blocks.len() - 1];
            let on = linear_blocks(
                BlockKind::Approach,
                (start, start_c_deg),
                (first_pose, start_c_deg + v_in * duration_s),
                origin,
                v_in,
                duration_s,
            );
            let off = linear_blocks(
                BlockKind::Retract,
                (last.end, last.c_deg),
                (
                    lifted(&last.end, approach.clearance_mm),
                    last.c_deg + v_out * duration_s,
                ),
                last.position_mm,
                v_out,
                duration_s,
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
            AxisMotion::of_spans(positions, &durations, &segment_of)
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

/// A straight move from `from` to `to` (pose, C) at C speed `c_deg_per_s` over `duration_s`,
/// cut into equal blocks of at most a quarter turn of C.
fn linear_blocks(
    kind: BlockKind,
    from: (Pose, f64),
    to: (Pose, f64),
    position_mm: f64,
    c_deg_per_s: f64,
    duration_s: f64,
) -> Vec<PolarBlock> {
    let parts = ((to.1 - from.1).abs() / MAX_C_STEP_DEG).ceil().max(1.0) as usize;
    let [a, b] = [from.0.axes(), to.0.axes()];
    (1..=parts)
        .map(|k| {
            let s = k as f64 / parts as f64;
            let at = |i: usize| a[i] + (b[i] - a[i]) * s;
            PolarBlock {
                kind,
                station: None,
                position_mm,
                end: Pose {
                    x_mm: at(0),
                    z_mm: at(1),
                    b_deg: at(2),
                },
                c_deg: from.1 + (to.1 - from.1) * s,
                c_deg_per_s,
                duration_s: duration_s / parts as f64,
            }
        })
        .collect()
}
