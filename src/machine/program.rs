//! A dwell plan as blocks of axis motion (module docs of [`super`] for the model) and the
//! axis kinematics of those blocks.
//!
//! The blocks are the motion of [`crate::physics::motion`], the one model every removal
//! figure is computed for: a stop of half the dwell at each end, and a constant-speed move
//! across each position's cell.

use super::limits::{Axis, AxisLimits, LimitKind};
use super::pose::{Pose, Tool};
use crate::physics::motion::{acceleration, Motion, Segment};
use crate::surface::Surface;

/// What a block does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlockKind {
    /// From above the first pose down to it, before polishing.
    Approach,
    /// A stop at a position (the first and last half-dwells).
    Dwell,
    /// Polishing motion between two poses, linear in every axis.
    Move,
    /// Up from the last pose, after polishing.
    Retract,
}

/// One block: where it ends and how long it takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    pub kind: BlockKind,
    /// The radial position of the pad centre at the block's end, mm.
    pub position_mm: f64,
    /// Arc length from the vertex to `position_mm` along the meridian, mm.
    pub arc_length_mm: f64,
    pub end: Pose,
    pub duration_s: f64,
}

/// One axis's motion over the program.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisMotion {
    /// The axis at the program's start and at the end of each block, in the axis unit.
    pub positions: Vec<f64>,
    /// Lowest and highest position reached (including the start), in the axis unit.
    pub min: f64,
    pub max: f64,
    /// Velocity in each block, unit/min (0 in a dwell).
    pub velocity_per_min: Vec<f64>,
    /// Velocity change entering block k (k = 0: from rest; k = blocks: back to rest), unit/s².
    pub acceleration_per_s2: Vec<f64>,
    pub peak_velocity_per_min: f64,
    pub peak_acceleration_per_s2: f64,
}

impl AxisMotion {
    /// `positions`: the axis at the program's start and at the end of each block; each block
    /// its own span.
    pub(super) fn of(positions: Vec<f64>, durations_s: &[f64]) -> AxisMotion {
        let spans: Vec<usize> = (0..durations_s.len()).collect();
        AxisMotion::of_spans(positions, durations_s, &spans)
    }

    /// `positions`: the axis at the program's start and at the end of each block; `spans`:
    /// a label per block, consecutive blocks with one label being one span the axis runs at
    /// one velocity (its travel over its duration). The velocity changes only between spans,
    /// over the time between their midpoints (`physics::motion::acceleration`); entries
    /// inside a span are 0.
    pub(super) fn of_spans(
        positions: Vec<f64>,
        durations_s: &[f64],
        spans: &[usize],
    ) -> AxisMotion {
        let n = durations_s.len();
        debug_assert_eq!(spans.len(), n);
        // Each block's span: (first block, end, duration, velocity per minute).
        let mut runs: Vec<(usize, usize, f64, f64)> = Vec::new();
        for k in 0..n {
            match runs.last_mut() {
                Some(run) if spans[k] == spans[run.0] => {
                    run.1 = k + 1;
                    run.2 += durations_s[k];
                }
                _ => runs.push((k, k + 1, durations_s[k], 0.0)),
            }
        }
        for run in &mut runs {
            run.3 = 60.0 * (positions[run.1] - positions[run.0]) / run.2;
        }
        let mut velocity_per_min = Vec::with_capacity(n);
        for run in &runs {
            velocity_per_min.extend(std::iter::repeat_n(run.3, run.1 - run.0));
        }
        // At rest (a zero-length span) before the first block and after the last.
        let mut acceleration_per_s2 = vec![0.0; n + 1];
        for i in 0..=runs.len() {
            let (v0, d0) = if i == 0 {
                (0.0, 0.0)
            } else {
                (runs[i - 1].3, runs[i - 1].2)
            };
            let (v1, d1, at) = if i == runs.len() {
                (0.0, 0.0, n)
            } else {
                (runs[i].3, runs[i].2, runs[i].0)
            };
            acceleration_per_s2[at] = acceleration((v1 - v0) / 60.0, d0, d1);
        }
        let peak = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        AxisMotion {
            min: positions.iter().copied().fold(f64::INFINITY, f64::min),
            max: positions.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            peak_velocity_per_min: peak(&velocity_per_min),
            peak_acceleration_per_s2: peak(&acceleration_per_s2),
            velocity_per_min,
            acceleration_per_s2,
            positions,
        }
    }

    /// |velocity| per minute and |acceleration| per s² at their largest.
    pub fn peaks(&self) -> [f64; 2] {
        [self.peak_velocity_per_min, self.peak_acceleration_per_s2]
    }

    pub fn travel(&self) -> f64 {
        self.max - self.min
    }

    /// The fraction of each of `limits` this motion uses (1 = at the limit).
    pub fn utilisation(&self, limits: &AxisLimits) -> Utilisation {
        let over = |used: f64, limit: Option<f64>| limit.map(|l| used / l);
        let range = limits.min.zip(limits.max).map(|(lo, hi)| hi - lo);
        Utilisation {
            travel: over(self.travel(), range),
            velocity: over(self.peak_velocity_per_min, limits.max_velocity_per_min),
            acceleration: over(
                self.peak_acceleration_per_s2,
                limits.max_acceleration_per_s2,
            ),
        }
    }
}

/// Fractions of an axis's limits a program uses; `None` where the limit is not stated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Utilisation {
    /// Travel over the range from the minimum to the maximum (both stated).
    pub travel: Option<f64>,
    /// Peak |velocity| over its limit.
    pub velocity: Option<f64>,
    /// Peak |acceleration| over its limit.
    pub acceleration: Option<f64>,
}

/// How the program gets onto the part and off it: along the tool axis by `clearance_mm` at
/// `feed_mm_per_min` (no approach or retract when the clearance is 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Approach {
    pub clearance_mm: f64,
    pub feed_mm_per_min: f64,
}

/// Why a plan gives no program.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramError {
    #[error("every dwell is 0 s: there is nothing to program")]
    NoDwell,
    /// An interior position with zero dwell: its cell would be crossed in no time.
    #[error(
        "position {index} has 0 s of dwell between positions with dwell: the tool would cross \
         its cell in no time (infinite feed); give every position between the first and last \
         with dwell some dwell (e.g. optimize with a minimum dwell, min_dwell_s, or the \
         machine's limits)"
    )]
    ZeroInteriorDwell { index: usize },
}

/// How many positions of a plan a program leaves out at each end (their dwell is 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Skipped {
    pub leading: usize,
    pub trailing: usize,
}

/// A program: the blocks, each axis's motion, and what it polishes.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    start: Pose,
    blocks: Vec<Block>,
    /// Each axis's motion, in the order of [`Axis::ALL`].
    axes: [AxisMotion; 3],
    /// Positions of the plan left out at each end because their dwell is 0.
    pub skipped: Skipped,
    /// Time of the dwell and move blocks: the plan's total, s.
    pub polishing_time_s: f64,
    /// Time of every block, approach and retract included, s.
    pub program_time_s: f64,
    /// Largest distance, along the normal, of the pad centre from the surface halfway
    /// through a move (where linear interpolation of X, Z and B strays furthest), mm.
    pub max_path_deviation_mm: f64,
}

impl Program {
    /// The program that runs `motion` with `dwell_s` at its stations (dwell ≥ 0, one per
    /// station, within the surface's domain; the caller checks these): its segments as blocks.
    pub fn from_motion(
        surface: &Surface,
        tool: &Tool,
        motion: &Motion,
        dwell_s: &[f64],
        approach: Approach,
    ) -> Result<Program, ProgramError> {
        let (first, last) = dwell_span(dwell_s)?;
        // Zero-dwell cells at either end are crossed in no time, so the program starts at the
        // first cell with dwell and ends after the last one: the segments of the stations with
        // dwell (a stop belongs to one of the plan's own two ends).
        let t = dwell_s;
        let block = |kind, position_mm: f64, duration_s| Block {
            kind,
            position_mm,
            arc_length_mm: surface.arc_length_mm(position_mm),
            end: tool.pose(surface, position_mm),
            duration_s,
        };
        let segments: Vec<Segment> = motion
            .segments()
            .into_iter()
            .filter(|segment| (first..=last).contains(&segment.station()))
            .collect();
        let origin = segments[0].ends_mm().0;
        let mut blocks = Vec::with_capacity(segments.len() + 2);
        for segment in &segments {
            let duration_s = segment.share() * t[segment.station()];
            blocks.push(match *segment {
                Segment::Stop { at_mm, .. } => block(BlockKind::Dwell, at_mm, duration_s),
                Segment::Move { to_mm, .. } => block(BlockKind::Move, to_mm, duration_s),
            });
        }
        let polishing_time_s = t[first..=last].iter().sum();
        let first_pose = tool.pose(surface, origin);
        let mut start = first_pose;
        if approach.clearance_mm > 0.0 {
            let lift = |pose: &Pose| lifted(pose, approach.clearance_mm);
            let duration_s = 60.0 * approach.clearance_mm / approach.feed_mm_per_min;
            start = lift(&first_pose);
            let retract = Block {
                kind: BlockKind::Retract,
                end: lift(&blocks[blocks.len() - 1].end),
                duration_s,
                ..blocks[blocks.len() - 1]
            };
            blocks.insert(0, block(BlockKind::Approach, origin, duration_s));
            blocks.push(retract);
        }
        let durations: Vec<f64> = blocks.iter().map(|b| b.duration_s).collect();
        let axes = [0, 1, 2].map(|axis| {
            let positions: Vec<f64> = std::iter::once(start.axes()[axis])
                .chain(blocks.iter().map(|b| b.end.axes()[axis]))
                .collect();
            AxisMotion::of(positions, &durations)
        });
        let max_path_deviation_mm = path_deviation(surface, tool, start, &blocks);
        Ok(Program {
            start,
            program_time_s: durations.iter().sum(),
            blocks,
            axes,
            skipped: Skipped {
                leading: first,
                trailing: motion.len() - 1 - last,
            },
            polishing_time_s,
            max_path_deviation_mm,
        })
    }

    /// The pose before the first block (above the first position when there is an approach).
    pub fn start(&self) -> Pose {
        self.start
    }

    pub fn blocks(&self) -> &[Block] {
        &self.blocks
    }

    pub fn motion(&self, axis: Axis) -> &AxisMotion {
        &self.axes[axis_index(axis)]
    }

    /// A move's feed as G94 states it: the X–Z path length over the duration, mm/min, or
    /// B's angle per minute for a move of B alone; `None` for a dwell.
    pub fn path_feed_per_min(&self, index: usize) -> Option<f64> {
        let block = &self.blocks[index];
        if block.kind == BlockKind::Dwell {
            return None;
        }
        let (before, after) = (self.before(index), block.end);
        let path = xz_path_mm(before, after);
        let path = if path > 0.0 {
            path
        } else {
            (after.b_deg - before.b_deg).abs()
        };
        Some(60.0 * path / block.duration_s)
    }

    /// The X–Z path feed across each position's cell, mm/min, one per position of the plan
    /// (0 where only B moves); `None` for a cell crossed in no time (a zero-dwell end, left
    /// out) and for a single position (it has no move).
    pub fn cell_feeds_mm_per_min(&self) -> Vec<Option<f64>> {
        let mut feeds = vec![None; self.skipped.leading];
        for (index, block) in self.blocks.iter().enumerate() {
            if block.kind == BlockKind::Move {
                let path = xz_path_mm(self.before(index), block.end);
                feeds.push(Some(60.0 * path / block.duration_s));
            }
        }
        if feeds.len() == self.skipped.leading {
            feeds.push(None);
        }
        feeds.extend(std::iter::repeat_n(None, self.skipped.trailing));
        feeds
    }

    /// The highest X–Z path feed of any move, mm/min (0 without a move).
    pub fn peak_feed_mm_per_min(&self) -> f64 {
        self.cell_feeds_mm_per_min()
            .into_iter()
            .flatten()
            .fold(0.0, f64::max)
    }

    /// The pose at the start of block `index`.
    fn before(&self, index: usize) -> Pose {
        match index {
            0 => self.start,
            _ => self.blocks[index - 1].end,
        }
    }

    /// The block an entry of an [`AxisMotion`]'s lists belongs to (`positions` for travel
    /// limits).
    pub fn block_of(&self, limit: LimitKind, index: usize) -> usize {
        block_of(limit, index, self.blocks.len())
    }
}

/// The first and last stations with dwell; an error when there are none, or a station between
/// them has none (its cell would be crossed in no time).
pub(super) fn dwell_span(dwell_s: &[f64]) -> Result<(usize, usize), ProgramError> {
    let first = dwell_s
        .iter()
        .position(|&t| t > 0.0)
        .ok_or(ProgramError::NoDwell)?;
    let last = dwell_s.iter().rposition(|&t| t > 0.0).unwrap_or(first);
    if let Some(index) = (first..=last).find(|&j| dwell_s[j] == 0.0) {
        return Err(ProgramError::ZeroInteriorDwell { index });
    }
    Ok((first, last))
}

/// The block of `blocks` an entry of an [`AxisMotion`]'s lists belongs to (`positions` for
/// travel limits, whose entry 0 is the start, before block 0).
pub(super) fn block_of(limit: LimitKind, index: usize, blocks: usize) -> usize {
    match limit {
        LimitKind::Min | LimitKind::Max => index.saturating_sub(1),
        _ => index.min(blocks - 1),
    }
}

/// The length of the straight X–Z path between two poses, mm.
fn xz_path_mm(from: Pose, to: Pose) -> f64 {
    (to.x_mm - from.x_mm).hypot(to.z_mm - from.z_mm)
}

/// How far each axis (X, Z in mm; B in deg) moves across each station's cell of `motion`: the
/// poses at its cell bounds differenced, exactly as the program's move blocks are. Empty for
/// a single station (it has no move).
pub fn cell_travel(surface: &Surface, tool: &Tool, motion: &Motion) -> [Vec<f64>; 3] {
    if motion.len() < 2 {
        return [Vec::new(), Vec::new(), Vec::new()];
    }
    let poses: Vec<[f64; 3]> = motion
        .cell_bounds_mm()
        .iter()
        .map(|&r| tool.pose(surface, r).axes())
        .collect();
    [0, 1, 2].map(|axis| poses.windows(2).map(|w| w[1][axis] - w[0][axis]).collect())
}

/// Where `axis` sits in the program's per-axis arrays (the order of [`Axis::ALL`]).
fn axis_index(axis: Axis) -> usize {
    match axis {
        Axis::X => 0,
        Axis::Z => 1,
        Axis::B => 2,
        // A program's per-axis arrays hold the axes of `Axis::ALL`; C appears only under a
        // speed law, in its own words of the program.
        Axis::Y | Axis::C => unreachable!("a program's per-axis arrays hold X, Z and B"),
    }
}

/// The pose with the pad moved `clearance_mm` away from the part along the tool axis.
pub(super) fn lifted(pose: &Pose, clearance_mm: f64) -> Pose {
    let (sin, cos) = pose.b_deg.to_radians().sin_cos();
    Pose {
        x_mm: pose.x_mm - clearance_mm * sin,
        z_mm: pose.z_mm + clearance_mm * cos,
        b_deg: pose.b_deg,
    }
}

/// The largest normal distance of the pad centre from the surface at the middle of a move.
fn path_deviation(surface: &Surface, tool: &Tool, start: Pose, blocks: &[Block]) -> f64 {
    let mut before = start;
    let mut worst = 0.0_f64;
    for b in blocks {
        if b.kind == BlockKind::Move {
            let [x0, z0, b0] = before.axes();
            let [x1, z1, b1] = b.end.axes();
            let middle = Pose {
                x_mm: 0.5 * (x0 + x1),
                z_mm: 0.5 * (z0 + z1),
                b_deg: 0.5 * (b0 + b1),
            };
            let (x, z) = tool.pad_centre(&middle);
            let cos = surface.slope_angle_rad(x).cos();
            let deviation = ((z - surface.sag_mm(x)) * cos).abs();
            if deviation.is_finite() {
                worst = worst.max(deviation);
            }
        }
        before = b.end;
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::Orientation;

    fn flat_program(dwell: &[f64], clearance_mm: f64) -> Result<Program, ProgramError> {
        let positions: Vec<f64> = (0..dwell.len()).map(|j| j as f64).collect();
        let tool = Tool::new(0.0, Orientation::Vertical).unwrap();
        let approach = Approach {
            clearance_mm,
            feed_mm_per_min: 60.0,
        };
        let motion = Motion::radial(positions);
        Program::from_motion(&Surface::plane(), &tool, &motion, dwell, approach)
    }

    #[test]
    fn each_position_gets_its_dwell_within_its_cell() {
        let p = flat_program(&[2.0, 4.0, 6.0], 0.0).unwrap();
        let kinds: Vec<_> = p.blocks().iter().map(|b| b.kind).collect();
        use BlockKind::*;
        assert_eq!(kinds, [Dwell, Move, Move, Move, Dwell]);
        let ends: Vec<_> = p.blocks().iter().map(|b| b.position_mm).collect();
        assert_eq!(ends, [0.0, 0.5, 1.5, 2.0, 2.0]);
        let durations: Vec<_> = p.blocks().iter().map(|b| b.duration_s).collect();
        assert_eq!(durations, [1.0, 1.0, 4.0, 3.0, 3.0]);
        assert_eq!(p.polishing_time_s, 12.0);
        // X: 0.5 mm in 1 s, 1 mm in 4 s, 0.5 mm in 3 s → 30, 15, 10 mm/min.
        assert_eq!(
            p.motion(Axis::X).velocity_per_min,
            [0.0, 30.0, 15.0, 10.0, 0.0]
        );
        // From the dwell into the first move: 0.5 mm/s over (1 + 1)/2 s.
        assert_eq!(p.motion(Axis::X).acceleration_per_s2[1], 0.5);
    }

    #[test]
    fn zero_dwell_ends_are_skipped_and_interior_ones_refused() {
        let p = flat_program(&[0.0, 0.0, 2.0, 2.0, 0.0], 0.0).unwrap();
        assert_eq!(
            p.skipped,
            Skipped {
                leading: 2,
                trailing: 1
            }
        );
        // The plan's cells: the tool starts at the midpoint 1.5 (cells 0 and 1 take no time)
        // and crosses cells 2 and 3, [1.5, 2.5] and [2.5, 3.5], in 2 s each; no stop.
        assert_eq!(p.start().x_mm, 1.5);
        let ends: Vec<_> = p.blocks().iter().map(|b| (b.kind, b.position_mm)).collect();
        assert_eq!(ends, [(BlockKind::Move, 2.5), (BlockKind::Move, 3.5)]);
        assert_eq!(p.polishing_time_s, 4.0);
        assert_eq!(
            flat_program(&[1.0, 0.0, 1.0], 0.0),
            Err(ProgramError::ZeroInteriorDwell { index: 1 })
        );
        assert_eq!(flat_program(&[0.0, 0.0], 0.0), Err(ProgramError::NoDwell));
    }

    #[test]
    fn each_cell_has_its_feed() {
        // Positions 1 mm apart; cells 1 to 3 are 1 mm wide, crossed in 2, 4 and 2 s.
        for clearance_mm in [0.0, 5.0] {
            let p = flat_program(&[0.0, 2.0, 4.0, 2.0, 0.0], clearance_mm).unwrap();
            let feeds = p.cell_feeds_mm_per_min();
            assert_eq!(feeds, [None, Some(30.0), Some(15.0), Some(30.0), None]);
        }
        // The end cells are half a cell in half the dwell: 0.5 mm in 1 s.
        let p = flat_program(&[2.0, 2.0], 0.0).unwrap();
        assert_eq!(p.cell_feeds_mm_per_min(), [Some(30.0), Some(30.0)]);
        let p = flat_program(&[2.0], 0.0).unwrap();
        assert_eq!(p.cell_feeds_mm_per_min(), [None]);
    }

    #[test]
    fn approach_and_retract_are_along_the_tool_axis() {
        let p = flat_program(&[2.0, 2.0], 3.0).unwrap();
        assert_eq!(p.start().z_mm, 3.0);
        let blocks = p.blocks();
        assert_eq!(blocks[0].kind, BlockKind::Approach);
        assert_eq!(blocks[0].duration_s, 3.0);
        assert_eq!(blocks.last().unwrap().end.z_mm, 3.0);
        assert_eq!(p.polishing_time_s, 4.0);
        assert_eq!(p.program_time_s, 10.0);
    }
}
