//! A raster plan of an X-Y machine as a program: the tool over a part that stands still, X
//! and Y carrying it through the blocks of [`crate::physics::raster`], and Z keeping the
//! tool's working height over the surface (on a flat, Z only approaches and retracts).
//!
//! **Curved parts.** With the part's surface (its vertex at the plan's origin, the map's
//! centre), every block ends at Z = z(√(x² + y²)), the sag there, so the tool stays at its
//! working height over the part at each cell boundary and point; within a move, X, Y and Z run
//! linearly, and the chord leaves the surface by at most about ℓ²·κ/8 for a half-leg ℓ and
//! curvature κ (0.5 µm for 0.64 mm on R = 100 mm). The program reports the largest normal
//! distance at the middle of a move, measured, and the steepest slope under the points: the
//! plan itself is made in the X-Y projection with the influence function as measured, which
//! holds while the slope is small (the footprint stretches by 1/cos θ along the slope).
//!
//! **Blocks.** The plan's executed motion is a stop of half the dwell at the first point, each
//! point's cell as two straight half-legs at one speed, and a stop at the last
//! ([`Path::blocks`]); the program runs exactly those blocks, so the removal every endpoint
//! reports is the removal of the program. Points with no dwell at either end of the path are
//! left out (their cells would be crossed in no time), as the radial program leaves them; one
//! between points with dwell is refused. With a clearance, Z comes down at the approach feed
//! above the first polishing block's start and goes up above the last one's end.
//!
//! **Axis kinematics**, per axis, the model of [`super::program`]: the velocity is constant in
//! a block (its travel over its duration, 0 in a stop) and changes between blocks over the
//! time between their midpoints, from rest before the first block and back to rest after the
//! last. On X and Y it is the model the plan's floors were derived for
//! (`optimize::raster::peaks`), so a plan within its limits is a program within them.

use super::limits::{Axis, LimitKind};
use super::program::{
    block_of, dwell_span, Approach, AxisMotion, BlockKind, ProgramError, Skipped,
};
use crate::physics::raster::Path;
use crate::surface::Surface;

/// One block of an X-Y program: where the tool ends (X, Y, Z in mm) and how long it takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XyBlock {
    pub kind: BlockKind,
    /// X, Y and Z at the block's end, mm (Z = 0 on the part).
    pub end_mm: [f64; 3],
    pub duration_s: f64,
    /// The plan's point whose dwell the block spends (`None` for the approach and retract).
    pub point: Option<usize>,
}

/// An X-Y program: its blocks and each axis's motion.
#[derive(Debug, Clone, PartialEq)]
pub struct XyProgram {
    start_mm: [f64; 3],
    blocks: Vec<XyBlock>,
    /// X's, Y's and Z's motion.
    axes: [AxisMotion; 3],
    /// Points left out at each end because their dwell is 0.
    pub skipped: Skipped,
    /// Time of the stop and move blocks: the plan's total, s.
    pub polishing_time_s: f64,
    /// Time of every block, approach and retract included, s.
    pub program_time_s: f64,
    pub approach: Approach,
    /// The largest normal distance of the tool's centre from the surface at the middle of a
    /// move, mm (0 on a flat).
    pub max_path_deviation_mm: f64,
    /// The steepest slope of the surface at a block's end, degrees.
    pub max_slope_deg: f64,
}

impl XyProgram {
    /// The program that runs `path` with `dwell_s` at its points (≥ 0, one per point; the
    /// caller checks these) over `surface` (defined to the points' largest radius: the caller
    /// checks it).
    pub fn from_path(
        path: &Path,
        dwell_s: &[f64],
        approach: Approach,
        surface: &Surface,
    ) -> Result<XyProgram, ProgramError> {
        let (first, last) = dwell_span(dwell_s)?;
        let executed: Vec<_> = path
            .blocks(dwell_s)
            .into_iter()
            .filter(|b| (first..=last).contains(&b.point))
            .collect();
        let on_surface = |[x, y]: [f64; 2]| [x, y, surface.sag_mm(x.hypot(y))];
        let origin = on_surface(executed[0].from_mm);
        let mut max_path_deviation_mm = 0.0_f64;
        let mut max_slope_deg = surface.slope_angle_rad(origin[0].hypot(origin[1])).abs();
        for b in &executed {
            let [x, y] = b.to_mm;
            max_slope_deg = max_slope_deg.max(surface.slope_angle_rad(x.hypot(y)).abs());
            if b.from_mm != b.to_mm {
                let ([x0, y0, z0], [x1, y1, z1]) = (on_surface(b.from_mm), on_surface(b.to_mm));
                let r = (0.5 * (x0 + x1)).hypot(0.5 * (y0 + y1));
                let deviation = ((0.5 * (z0 + z1) - surface.sag_mm(r))
                    * surface.slope_angle_rad(r).cos())
                .abs();
                max_path_deviation_mm = max_path_deviation_mm.max(deviation);
            }
        }
        let max_slope_deg = max_slope_deg.to_degrees();
        let mut blocks: Vec<XyBlock> = executed
            .iter()
            .map(|b| XyBlock {
                kind: if b.from_mm == b.to_mm {
                    BlockKind::Dwell
                } else {
                    BlockKind::Move
                },
                end_mm: on_surface(b.to_mm),
                duration_s: b.duration_s,
                point: Some(b.point),
            })
            .collect();
        let polishing_time_s = dwell_s[first..=last].iter().sum();
        let mut start_mm = origin;
        if approach.clearance_mm > 0.0 {
            let duration_s = 60.0 * approach.clearance_mm / approach.feed_mm_per_min;
            let lift = |p: [f64; 3]| [p[0], p[1], p[2] + approach.clearance_mm];
            start_mm = lift(origin);
            let end = blocks.last().map_or(origin, |b| b.end_mm);
            blocks.insert(
                0,
                XyBlock {
                    kind: BlockKind::Approach,
                    end_mm: origin,
                    duration_s,
                    point: None,
                },
            );
            blocks.push(XyBlock {
                kind: BlockKind::Retract,
                end_mm: lift(end),
                duration_s,
                point: None,
            });
        }
        let durations: Vec<f64> = blocks.iter().map(|b| b.duration_s).collect();
        let axes = [0, 1, 2].map(|axis| {
            let positions: Vec<f64> = std::iter::once(start_mm[axis])
                .chain(blocks.iter().map(|b| b.end_mm[axis]))
                .collect();
            AxisMotion::of(positions, &durations)
        });
        Ok(XyProgram {
            start_mm,
            program_time_s: durations.iter().sum(),
            blocks,
            axes,
            skipped: Skipped {
                leading: first,
                trailing: path.len() - 1 - last,
            },
            polishing_time_s,
            approach,
            max_path_deviation_mm,
            max_slope_deg,
        })
    }

    /// Whether Z follows a curved surface (else it moves only to approach and retract).
    pub fn follows_surface(&self) -> bool {
        self.blocks
            .iter()
            .filter(|b| b.point.is_some())
            .any(|b| b.end_mm[2] != 0.0)
    }

    /// X, Y and Z before the first block (above the first point with an approach), mm.
    pub fn start_mm(&self) -> [f64; 3] {
        self.start_mm
    }

    pub fn blocks(&self) -> &[XyBlock] {
        &self.blocks
    }

    /// The motion of X, Y or Z.
    pub fn motion(&self, axis: Axis) -> &AxisMotion {
        &self.axes[match axis {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
            Axis::B | Axis::C => unreachable!("an X-Y machine has no {}", axis.name()),
        }]
    }

    /// The block an entry of an [`AxisMotion`]'s lists belongs to.
    pub fn block_of(&self, limit: LimitKind, index: usize) -> usize {
        block_of(limit, index, self.blocks.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path() -> Path {
        Path::through(vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
        ])
        .unwrap()
    }

    #[test]
    fn the_program_spends_the_plan_and_ends_where_it_began_lifted() {
        let approach = Approach {
            clearance_mm: 5.0,
            feed_mm_per_min: 100.0,
        };
        let dwell = [2.0, 1.0, 3.0, 1.5, 4.0];
        let p = XyProgram::from_path(&path(), &dwell, approach, &Surface::plane()).unwrap();
        let polishing: f64 = p
            .blocks()
            .iter()
            .filter(|b| b.point.is_some())
            .map(|b| b.duration_s)
            .sum();
        // Each block's share of its point's dwell sums to the dwell: to rounding.
        assert!((polishing - 11.5).abs() < 1e-12);
        assert_eq!(p.polishing_time_s, 11.5);
        assert!((p.program_time_s - 11.5 - 6.0).abs() < 1e-12);
        assert_eq!(p.start_mm(), [0.0, 0.0, 5.0]);
        assert_eq!(p.blocks().last().unwrap().end_mm, [1.0, 1.0, 5.0]);
        // The cell of point 1 (from x = 0.5 to 1.5 in 1 s): X at 60 mm/min.
        let x = p.motion(Axis::X);
        assert!(x.velocity_per_min.iter().any(|v| (v - 60.0).abs() < 1e-9));
        // Y moves only on the turn; Z only in the approach and retract.
        let z = p.motion(Axis::Z);
        assert_eq!(z.peak_velocity_per_min, 100.0);
    }

    #[test]
    fn zero_dwell_at_the_ends_is_left_out_and_inside_refused() {
        let approach = Approach {
            clearance_mm: 0.0,
            feed_mm_per_min: 100.0,
        };
        let p = XyProgram::from_path(
            &path(),
            &[0.0, 1.0, 3.0, 1.5, 0.0],
            approach,
            &Surface::plane(),
        )
        .unwrap();
        assert_eq!(
            p.skipped,
            Skipped {
                leading: 1,
                trailing: 1
            }
        );
        // It starts at the cell boundary between points 0 and 1, at rest.
        assert_eq!(p.start_mm(), [0.5, 0.0, 0.0]);
        assert_eq!(p.blocks().last().unwrap().end_mm, [1.5, 1.0, 0.0]);
        assert!(p.blocks().iter().all(|b| b.duration_s > 0.0));
        assert_eq!(
            XyProgram::from_path(
                &path(),
                &[1.0, 0.0, 1.0, 1.0, 1.0],
                approach,
                &Surface::plane()
            ),
            Err(ProgramError::ZeroInteriorDwell { index: 1 })
        );
    }
}
