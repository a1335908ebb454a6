//! The pad on a part turning on C, point by point: C (the part's spindle) as an axis whose
//! speed is known at every instant, and the removal at each point of the part, not only at
//! each radius.
//!
//! Lab frame, counter-clockwise positive seen from the pad: the part turns at Ω (rad/s, the
//! process's `workpiece_rpm`), the pad spins at ω2 about its centre c. At a point p of the
//! part the sliding speed is
//!
//! ```text
//! V = |(ω2 − Ω)·p − ω2·c|        (2-D vectors in any common frame)
//! ```
//!
//! the paper's eq. 5 with ω1 = −Ω: the pad's velocity ω2·J(p − c) less the part's Ω·J·p (J
//! the quarter turn, which keeps lengths). In the part's frame the pad centre sits at
//! c = r1·(cos φ, sin φ) with dφ/dt = −Ω (the part turning counter-clockwise carries the pad
//! clockwise over it). A point p = r·(cos θ, sin θ) is at α = θ − φ from the direction of the
//! pad centre, and there
//!
//! ```text
//! V(α)² = (ω2 − Ω)²·r² + ω2²·r1² − 2·r·r1·ω2·(ω2 − Ω)·cos α,
//! ρ(r, α; r1) = K·P·(p/P)·V(α)   on the pressed arc |α| ≤ θ0, 0 elsewhere,
//! ```
//!
//! the instantaneous footprint ([`PolarPad::rate_at`]): the 1-D model's V, its contact arc and
//! its pressure models (p/P = level + slope·(r·cos α − r1), short of a linear pad's lift line)
//! unchanged, since they depend only on where the pad centre is.
//!
//! **A ring at constant Ω.** While the pad centre sweeps from φ_s for a time T the point sees
//! α run from α_s = θ − φ_s to α_e = α_s + Ω·T, and dt = dα/Ω, so
//!
//! ```text
//! depth(r, θ) = (S̃(α_e) − S̃(α_s)) / Ω,    S̃(α) = 2π·R·n + S(α − 2π·n),  n = round(α/2π),
//! ```
//!
//! S(α) = ∫_0^α ρ dα′ on [−π, π] in closed form (Carlson's integrals over part of the arc,
//! [`RemovalKernel::swept_rate_integral`]) and R(r; r1) = S(π)/π the revolution-averaged rate
//! of the 1-D model. Whole turns add R·2π/|Ω| each: a ring of whole turns leaves today's
//! R·T at every θ. And for any T the azimuthal mean of the depth is exactly R·T: averaged over
//! θ, S̃(θ + c) − S̃(θ) is c/2π of a whole turn. A motion's azimuthal mean is therefore the
//! 1-D prediction at the C speed of each instant; what is left around it is the ripple of
//! where the rings begin and end.
//!
//! **A motion.** A plan's stops and moves (`Motion::segments`, the pad at constant speed along
//! the surface in each)
//! run with C at the process's Ω, or under a sector law at f·Ω over each sector of the pad
//! centre's part-frame angle; cut where that angle crosses a sector's edge, the executed
//! motion is a chain of [`Block`]s at constant speeds on both axes ([`executed_blocks`]), each
//! a ring (closed form) or a piece of spiral (quadrature) at its own Ω, and the depth is their
//! sum. Only the sliding speed depends on Ω (ω2 − Ω on a plane), so one pad per distinct
//! speed serves ([`RemovalKernel::with_part_speed`]).
//!
//! **Harmonics.** ρ is even in α, so a density of dwell u(φ) over the pad centre's angle
//! removes ∫ u(φ)·ρ(r, θ − φ) dφ, a circular convolution: harmonic m of the removal is harmonic
//! m of the density times ĝ_m(r; r1) = (1/2π)∫ρ(r, α)·cos mα dα, and ĝ_0 = R. Modulating the
//! density modulates C's speed (the time per unit angle is 1/Ω), and V depends on Ω: to first
//! order a relative modulation δ acts through h = ρ − Ω·∂ρ/∂Ω, with
//! ∂V/∂Ω = (−(ω2 − Ω)·r² + r·r1·ω2·cos α)/V ([`PolarPad::angular_spectrum`] gives the
//! coefficients of both; `optimize::harmonics` plans with them).
//!
//! **A curved part.** The pad conforms to a surface of revolution (`super::curved`): at the
//! point of the ring at projected radius r and angle α from the pad centre's meridian the
//! sliding speed is |v_t|² = E·sin²α + (B − A·r·cos α)² on the arc under the pad |α| ≤ φ0, and
//! ρ = K·P·w·|v_t| ([`CurvedKernel::footprint`]; A = ω_t·a_z − Ω carries Ω). Its integral over
//! the arc is π·R of the curved model, so whole turns and azimuthal means are the 1-D curved
//! removal as above. S(α) is integrated by adaptive Gauss–Kronrod (no closed form), a spiral's
//! rim is where r² + r1² − 2·r·r1·cos α = c², c² = c_t² − (z − z₁)² the pad's reach on the
//! ring ([`CurvedKernel::squared_reach`]), and within a move the pad centre runs at constant
//! speed along the arc, as the 1-D model's feed does ([`Track`]). The depth is along the
//! normal, at the point's projection (x, y).

use std::f64::consts::{PI, TAU};

use rayon::prelude::*;

use super::curved::{CurvedKernel, Ring, Site};
use super::kronrod::{adaptive_gauss_kronrod, kronrod_rule};
use super::motion::{acceleration, one_speed, Motion, Turning};
use super::pressure::PadPressure;
use super::process::Process;
use super::removal::RemovalKernel;
use super::roots::illinois;
use crate::surface::Surface;

/// The tolerance of a spiral's quadrature, relative to the largest rate a point can see
/// (times the duration: the depth's absolute error).
const RELATIVE_TOLERANCE: f64 = 1e-11;

/// The pad centre's radius along a move from `from_mm` to `to_mm` lasting `duration_s`: at a
/// constant speed along the surface, as the 1-D model moves it (constant feed along the arc),
/// so linear in time on a plane.
#[derive(Debug, Clone, Copy)]
pub struct Track<'a> {
    from_mm: f64,
    to_mm: f64,
    duration_s: f64,
    /// The surface, its arc length at `from_mm` and the arc's speed (mm/s), on a curved part.
    along: Option<(&'a Surface, f64, f64)>,
}

impl<'a> Track<'a> {
    /// `surface`: `None` (or a plane) for a flat part.
    pub fn new(surface: Option<&'a Surface>, from_mm: f64, to_mm: f64, duration_s: f64) -> Self {
        let along = surface.filter(|s| !s.is_plane()).map(|surface| {
            let start = surface.arc_length_mm(from_mm);
            let speed = (surface.arc_length_mm(to_mm) - start) / duration_s;
            (surface, start, speed)
        });
        Track {
            from_mm,
            to_mm,
            duration_s,
            along,
        }
    }

    /// The radius (mm) at `elapsed_s` into the move: its ends exactly at 0 and the duration
    /// (an arc length's inverse may differ from the radius in the last bit).
    pub fn at(&self, elapsed_s: f64) -> f64 {
        match self.along {
            None => self.from_mm + (self.to_mm - self.from_mm) * (elapsed_s / self.duration_s),
            Some(_) if elapsed_s <= 0.0 || self.from_mm == self.to_mm => self.from_mm,
            Some(_) if elapsed_s >= self.duration_s => self.to_mm,
            Some((surface, start, speed)) => {
                surface.radius_at_arc_length(start + speed * elapsed_s)
            }
        }
    }

    /// When (s into the move) the pad centre passes the radius `r_mm` (between the ends).
    fn time_at(&self, r_mm: f64) -> f64 {
        match self.along {
            None => (r_mm - self.from_mm) / (self.to_mm - self.from_mm) * self.duration_s,
            Some((surface, start, speed)) => (surface.arc_length_mm(r_mm) - start) / speed,
        }
    }

    /// The radius and its speed (mm, mm/s) at `elapsed_s` into the move: ds/dt over
    /// ds/dr = √(1 + z′²) on a curved part.
    fn with_speed(&self, elapsed_s: f64) -> (f64, f64) {
        match self.along {
            None => {
                let feed = (self.to_mm - self.from_mm) / self.duration_s;
                (self.from_mm + feed * elapsed_s, feed)
            }
            Some((surface, start, speed)) => {
                let r1 = surface.radius_at_arc_length(start + speed * elapsed_s);
                (r1, speed / surface.arc_integrand(r1))
            }
        }
    }
}

/// A ring of the part and a pad position: what the footprint between them needs, made once.
enum Pair<'a> {
    Flat {
        r: f64,
        r1: f64,
        pressure: PadPressure,
    },
    Curved {
        kernel: &'a CurvedKernel,
        ring: Ring,
        site: Site,
        pressure: PadPressure,
    },
}

/// The pad of a process at the process's C speed: its footprint, and the removal of a ring or a
/// spiral.
#[derive(Debug, Clone)]
pub struct PolarPad {
    kernel: RemovalKernel,
    /// Ω and ω2, rad/s, lab frame, counter-clockwise positive.
    part_speed: f64,
    tool_speed: f64,
    /// K·P, nm/s per mm/s of sliding.
    preston: f64,
    tool_radius_mm: f64,
    workpiece_radius_mm: f64,
}

impl PolarPad {
    pub fn new(process: &Process) -> PolarPad {
        PolarPad {
            kernel: RemovalKernel::new(process),
            part_speed: -process.omega1_rad_per_s(),
            tool_speed: process.omega2_rad_per_s(),
            preston: process.preston_rate_scale(),
            tool_radius_mm: process.tool_radius_mm(),
            workpiece_radius_mm: process.workpiece_radius_mm(),
        }
    }

    /// Ω, rad/s (counter-clockwise positive; never 0: a process's part turns).
    pub fn part_speed_rad_per_s(&self) -> f64 {
        self.part_speed
    }

    /// The same pad with the part turning at `part_speed_rad_per_s` (non-zero).
    pub fn turning_at(&self, part_speed_rad_per_s: f64) -> PolarPad {
        PolarPad {
            kernel: self.kernel.with_part_speed(part_speed_rad_per_s),
            part_speed: part_speed_rad_per_s,
            ..self.clone()
        }
    }

    /// The depth (nm) `blocks` leave at each of `points` (x, y mm, part frame): each block a
    /// ring or a spiral at its own C speed, summed in the blocks' order.
    pub fn depth_nm(&self, blocks: &[Block], points: &[(f64, f64)]) -> Vec<f64> {
        self.sum_in_reach(
            blocks,
            points,
            |&(x, y)| x.hypot(y),
            |pad, &(x, y), block| pad.block_depth_nm(x.hypot(y), y.atan2(x), block),
        )
    }

    /// The azimuthal mean (nm) of the depth `blocks` leave at each radius of `radii_mm`: by the
    /// identity of the module docs, Σ ∫ R_Ω(r; r1(t)) dt over the blocks, each at its own C
    /// speed — a ring's T·R, a spiral's by adaptive Gauss–Kronrod in time to the spiral's
    /// tolerance (on a curved part split where R has kinks in r1).
    pub fn mean_depth_nm(&self, blocks: &[Block], radii_mm: &[f64]) -> Vec<f64> {
        self.sum_in_reach(
            &rings_merged(blocks),
            radii_mm,
            |&r| r,
            |pad, &r, block| pad.block_mean_depth_nm(r, block),
        )
    }

    /// For each item (at the radius `radius` gives), the sum over the blocks within the pad's
    /// reach of it of `each` (with the pad at the block's C speed), in the blocks' order.
    fn sum_in_reach<T: Sync>(
        &self,
        blocks: &[Block],
        items: &[T],
        radius: impl Fn(&T) -> f64 + Sync,
        each: impl Fn(&PolarPad, &T, &Block) -> f64 + Sync,
    ) -> Vec<f64> {
        // One pad per distinct C speed.
        let mut speeds: Vec<f64> = blocks.iter().map(|b| b.part_speed_rad_per_s).collect();
        speeds.sort_by(f64::total_cmp);
        speeds.dedup();
        let pads: Vec<PolarPad> = speeds.iter().map(|&w| self.turning_at(w)).collect();
        let pad_of: Vec<&PolarPad> = blocks
            .iter()
            .map(|b| {
                let i = speeds
                    .binary_search_by(|w| w.total_cmp(&b.part_speed_rad_per_s))
                    .expect("every block's speed is listed");
                &pads[i]
            })
            .collect();
        let rt = self.tool_radius_mm;
        // A plan runs outward: its blocks' radii then never fall, and the blocks within a
        // pad's reach of a point are one run of them, found by bisection.
        let outward = blocks
            .windows(2)
            .all(|w| w[0].from_mm <= w[0].to_mm && w[0].to_mm <= w[1].from_mm)
            && blocks.last().is_none_or(|b| b.from_mm <= b.to_mm);
        items
            .par_iter()
            .map(|item| {
                let r = radius(item);
                let run = if outward {
                    blocks.partition_point(|b| b.to_mm < r - rt)
                        ..blocks.partition_point(|b| b.from_mm <= r + rt)
                } else {
                    0..blocks.len()
                };
                blocks[run.clone()]
                    .iter()
                    .zip(&pad_of[run])
                    .filter(|(b, _)| {
                        r >= b.from_mm.min(b.to_mm) - rt && r <= b.from_mm.max(b.to_mm) + rt
                    })
                    .map(|(b, pad)| each(pad, item, b))
                    .sum()
            })
            .collect()
    }

    /// ∫ R(r; r1(t)) dt over one block at this pad's C speed (the block's own), nm.
    fn block_mean_depth_nm(&self, r_mm: f64, block: &Block) -> f64 {
        let rate = |r1: f64| self.kernel.rate_nm_per_s(r_mm, r1);
        if block.from_mm == block.to_mm {
            return block.duration_s * rate(block.from_mm);
        }
        let (t, from, to) = (block.duration_s, block.from_mm, block.to_mm);
        let track = self.track(from, to, t);
        let density = RELATIVE_TOLERANCE * self.largest_rate(r_mm, from.max(to));
        let Some(curved) = self.kernel.curved() else {
            let line = |s: f64| rate(from + (to - from) * s / t);
            return adaptive_gauss_kronrod(&line, 0.0, t, density);
        };
        // On a curved part R(r; r1) is split where it has kinks in r1 (the pad's tangencies,
        // the sliding speed's zero: `CurvedKernel::breakpoints`), as the 1-D path is: the
        // zero's logarithmic kink fools the rule's error estimate (~1e-5 of a block's depth).
        let (lo, hi) = (from.min(to), from.max(to));
        let mut cuts: Vec<f64> = curved
            .breakpoints(&curved.ring(r_mm), hi)
            .into_iter()
            .filter(|&x| x > lo && x < hi)
            .map(|x| track.time_at(x))
            .chain([0.0, t])
            .collect();
        cuts.sort_by(f64::total_cmp);
        cuts.windows(2)
            .map(|w| adaptive_gauss_kronrod(&|s: f64| rate(track.at(s)), w[0], w[1], density))
            .sum()
    }

    /// The depth (nm) at (r_mm, θ) of one block, at this pad's C speed (the block's own).
    fn block_depth_nm(&self, r_mm: f64, theta_rad: f64, block: &Block) -> f64 {
        if block.from_mm == block.to_mm {
            self.ring_depth_nm(
                r_mm,
                theta_rad,
                block.from_mm,
                block.start_rad,
                block.duration_s,
            )
        } else {
            self.spiral_depth_nm(
                r_mm,
                theta_rad,
                (block.from_mm, block.to_mm),
                block.start_rad,
                block.duration_s,
            )
        }
    }

    /// The footprint ρ (nm/s) at the part's point `point` (x, y mm, part frame) with the pad
    /// centre at `centre` (module docs): 0 off the part, off the pad or beyond the lift line.
    pub fn rate_at(&self, point: (f64, f64), centre: (f64, f64)) -> f64 {
        let (x, y) = point;
        let (cx, cy) = centre;
        let (dx, dy) = (x - cx, y - cy);
        let rt = self.tool_radius_mm;
        if x * x + y * y > self.workpiece_radius_mm * self.workpiece_radius_mm
            || dx * dx + dy * dy > rt * rt
        {
            return 0.0;
        }
        let r1 = cx.hypot(cy);
        if self.kernel.curved().is_some() {
            // The projected distance is at most the geodesic one: the test above holds on any
            // surface; the pressed arc decides.
            let r = x.hypot(y);
            let pair = self.pair(r, r1);
            // With r or r1 zero the angle is undefined and the sliding speed does not depend
            // on it; the weight then takes the pad's level, as the plane's does.
            let cos = if r * r1 > 0.0 {
                ((x * cx + y * cy) / (r * r1)).clamp(-1.0, 1.0)
            } else {
                0.0
            };
            return match self.pressed_half_angle(&pair) {
                Some(arc) if cos >= arc.cos() => self.footprint(&pair, cos),
                _ => 0.0,
            };
        }
        let pressure = self.kernel.pad_pressure(r1);
        // The point's coordinate along the pad centre's direction (the 1-D model's x).
        let along = if r1 > 0.0 {
            (x * cx + y * cy) / r1
        } else {
            0.0
        };
        let factor = (pressure.level + pressure.slope_per_mm * (along - r1)).max(0.0);
        let k = self.tool_speed - self.part_speed;
        let (vx, vy) = (k * x - self.tool_speed * cx, k * y - self.tool_speed * cy);
        self.preston * factor * vx.hypot(vy)
    }

    /// The depth (nm) at the point (r_mm, θ) of the part left by the pad centre at `r1_mm`
    /// sweeping from the part-frame angle `start_rad` for `duration_s` at this pad's Ω (module
    /// docs).
    pub fn ring_depth_nm(
        &self,
        r_mm: f64,
        theta_rad: f64,
        r1_mm: f64,
        start_rad: f64,
        duration_s: f64,
    ) -> f64 {
        let start = theta_rad - start_rad;
        let end = start + self.part_speed * duration_s;
        let whole = self.kernel.rate_nm_per_s(r_mm, r1_mm);
        let unwrapped = |alpha: f64| {
            let turns = (alpha / TAU).round();
            let partial =
                self.swept_rate_integral(r_mm, r1_mm, (alpha - turns * TAU).clamp(-PI, PI));
            TAU * whole * turns + partial
        };
        ((unwrapped(end) - unwrapped(start)) / self.part_speed).max(0.0)
    }

    /// S(α) = ∫_0^α ρ dα′ at radius `r_mm` with the pad centre at `r1_mm`, α ∈ [−π, π]
    /// (module docs): on a plane in closed form ([`RemovalKernel::swept_rate_integral`]), on a
    /// curved part by adaptive Gauss–Kronrod over the pressed arc to the spiral's tolerance
    /// (per radian, of the largest rate a point can see).
    fn swept_rate_integral(&self, r_mm: f64, r1_mm: f64, alpha_rad: f64) -> f64 {
        if let Some(flat) = self.kernel.swept_rate_integral(r_mm, r1_mm, alpha_rad) {
            return flat;
        }
        let pair = self.pair(r_mm, r1_mm);
        let Some(arc) = self.pressed_half_angle(&pair) else {
            return 0.0;
        };
        let end = alpha_rad.abs().min(arc);
        if end <= 0.0 {
            return 0.0;
        }
        let density = RELATIVE_TOLERANCE * self.largest_rate(r_mm, r1_mm);
        let rate = |alpha: f64| self.footprint(&pair, alpha.cos());
        alpha_rad.signum() * adaptive_gauss_kronrod(&rate, 0.0, end, density)
    }

    /// The pad centre's track over a move on this pad's part.
    fn track(&self, from_mm: f64, to_mm: f64, duration_s: f64) -> Track<'_> {
        Track::new(self.surface(), from_mm, to_mm, duration_s)
    }

    /// The part's surface, `None` on a plane.
    pub fn surface(&self) -> Option<&Surface> {
        self.kernel.curved().map(|curved| curved.surface())
    }

    /// What the footprint between the ring at `r_mm` and the pad centre at `r1_mm` needs,
    /// computed once.
    fn pair(&self, r_mm: f64, r1_mm: f64) -> Pair<'_> {
        let pressure = self.kernel.pad_pressure(r1_mm);
        match self.kernel.curved() {
            Some(kernel) => Pair::Curved {
                kernel,
                ring: kernel.ring(r_mm),
                site: kernel.site(r1_mm),
                pressure,
            },
            None => Pair::Flat {
                r: r_mm,
                r1: r1_mm,
                pressure,
            },
        }
    }

    /// The half-angle θ0 (rad) of the ring's arc under the pad (short of no lift line),
    /// `None` where the pad does not touch the ring.
    fn pressed_half_angle(&self, pair: &Pair) -> Option<f64> {
        match *pair {
            Pair::Flat { r, r1, .. } => {
                let rt = self.tool_radius_mm;
                // |p − c| ≤ r_t, i.e. cos α ≥ (r² + r1² − r_t²)/(2·r·r1).
                if r * r1 > 0.0 {
                    let c = (r * r + r1 * r1 - rt * rt) / (2.0 * r * r1);
                    (c < 1.0).then(|| c.max(-1.0).acos())
                } else {
                    (r.max(r1) <= rt).then_some(PI)
                }
            }
            Pair::Curved {
                kernel, ring, site, ..
            } => kernel.pressed_half_angle(&ring, &site),
        }
    }

    /// The footprint ρ (nm/s) at the point of the pair's ring at angle α (its cosine `cos`)
    /// from the pad centre's direction, on the pressed arc (module docs).
    fn footprint(&self, pair: &Pair, cos: f64) -> f64 {
        let (pressed, speed, _) = self.footprint_parts(pair, cos);
        pressed * speed
    }

    /// [`Self::footprint`] as its factors: K·P·w (nm/s per mm/s), the sliding speed V and
    /// ∂V/∂Ω (module docs).
    fn footprint_parts(&self, pair: &Pair, cos: f64) -> (f64, f64, f64) {
        match *pair {
            Pair::Flat { r, r1, pressure } => self.flat_parts(r, r1, &pressure, cos),
            Pair::Curved {
                kernel,
                ring,
                site,
                pressure,
            } => kernel.footprint(&ring, &site, &pressure, cos),
        }
    }

    /// [`Self::footprint_parts`] on a flat, branch-free (it runs a panel's nodes side by side).
    #[inline(always)]
    fn flat_parts(&self, r: f64, r1: f64, pressure: &PadPressure, cos: f64) -> (f64, f64, f64) {
        let (omega, w2) = (self.part_speed, self.tool_speed);
        let k = w2 - omega;
        let factor = (pressure.level + pressure.slope_per_mm * (r * cos - r1)).max(0.0);
        let v = (k * k * r * r + w2 * w2 * r1 * r1 - 2.0 * r * r1 * w2 * k * cos)
            .max(0.0)
            .sqrt();
        // ∂V/∂Ω = (−(ω2 − Ω)·r² + r·r1·ω2·cos α)/V, 0 where V vanishes (a point).
        let dv = if v > 0.0 {
            (-k * r * r + r * r1 * w2 * cos) / v
        } else {
            0.0
        };
        (self.preston * factor, v, dv)
    }

    /// The depth (nm) at the point (r_mm, θ) of the part left by a spiral: the pad centre
    /// moving from `r1_start_mm` to `r1_end_mm` at a constant speed (along the surface:
    /// [`Track`]) while C turns at this pad's Ω, from the part-frame angle `start_rad`, for
    /// `duration_s` (module docs).
    ///
    /// No closed form: the footprint is integrated along the time, exactly where it is
    /// smooth. The pad's rim crosses the point where g(t) = c² − |p − c(t)|² = 0 (c = r_t on a
    /// plane, the pad's reach on the point's ring on a curved part); g is
    /// largest near each time the pad centre passes the point's angle and smallest half a turn
    /// later, so [0, T] splits at those extremes (roots of g′ by the Illinois method) into
    /// pieces where g is monotone, each holding at most one crossing (found the same way).
    /// Where the point is under the pad the rate is integrated by adaptive Gauss–Kronrod to
    /// `RELATIVE_TOLERANCE` of the largest rate a point can see; its kinks (the sliding
    /// speed's zero, a linear pad's lift line) are left to the adaptive bisection.
    pub fn spiral_depth_nm(
        &self,
        r_mm: f64,
        theta_rad: f64,
        (r1_start_mm, r1_end_mm): (f64, f64),
        start_rad: f64,
        duration_s: f64,
    ) -> f64 {
        if duration_s <= 0.0 || r_mm > self.workpiece_radius_mm {
            return 0.0;
        }
        let omega = self.part_speed;
        let track = self.track(r1_start_mm, r1_end_mm, duration_s);
        let point = (r_mm * theta_rad.cos(), r_mm * theta_rad.sin());
        let r1 = |t: f64| track.with_speed(t).0;
        let alpha = |t: f64| theta_rad - start_rad + omega * t;
        // The squared reach c² of the pad and its derivative in r1: r_t² on a plane, the
        // chord less the sag's difference on a curved part (`CurvedKernel::squared_reach`).
        let ring = self
            .kernel
            .curved()
            .map(|curved| (curved, curved.ring(r_mm)));
        let rt2 = self.tool_radius_mm * self.tool_radius_mm;
        let squared_reach = |r1: f64| match &ring {
            Some((curved, ring)) => curved.squared_reach(ring, r1),
            None => (rt2, 0.0),
        };
        let reach = |t: f64| {
            squared_reach(r1(t)).0 - r_mm * r_mm - r1(t) * r1(t)
                + 2.0 * r_mm * r1(t) * alpha(t).cos()
        };
        let slope = |t: f64| {
            let (s, c) = alpha(t).sin_cos();
            let (r1, feed) = track.with_speed(t);
            squared_reach(r1).1 * feed - 2.0 * r1 * feed + 2.0 * r_mm * feed * c
                - 2.0 * r_mm * r1 * omega * s
        };
        let rate = |t: f64| match &ring {
            // Only where the reach says the point is under the pad (below), so the ring's
            // footprint needs no test of its own.
            Some((kernel, ring)) => {
                let r1 = r1(t);
                let pair = Pair::Curved {
                    kernel,
                    ring: *ring,
                    site: kernel.site(r1),
                    pressure: self.kernel.pad_pressure(r1),
                };
                self.footprint(&pair, alpha(t).cos())
            }
            None => {
                let phi = start_rad - omega * t;
                self.rate_at(point, (r1(t) * phi.cos(), r1(t) * phi.sin()))
            }
        };
        // The extremes of g: near each time α passes a multiple of π (a quarter turn either
        // side brackets the root of g′ while the feed is slower than r·Ω, as any pass is).
        let quarter = PI / 2.0 / omega.abs();
        let first = ((alpha(0.0) / PI).min(alpha(duration_s) / PI)).floor() as i64;
        let last = ((alpha(0.0) / PI).max(alpha(duration_s) / PI)).ceil() as i64;
        let mut cuts = vec![0.0, duration_s];
        for k in first..=last {
            let passing = (k as f64 * PI - alpha(0.0)) / omega;
            let (a, b) = (
                (passing - quarter).max(0.0),
                (passing + quarter).min(duration_s),
            );
            if a >= b {
                continue;
            }
            let (sa, sb) = (slope(a), slope(b));
            if sa * sb < 0.0 {
                cuts.push(illinois(&slope, (a, sa), (b, sb), 1e-15 * duration_s, 0.0));
            }
        }
        cuts.sort_by(f64::total_cmp);
        // Each monotone piece: its crossing, if any, then the parts under the pad.
        let largest = self.largest_rate(r_mm, r1_start_mm.max(r1_end_mm));
        let density = RELATIVE_TOLERANCE * largest;
        let mut depth = 0.0;
        for piece in cuts.windows(2) {
            let (a, b) = (piece[0], piece[1]);
            if b <= a {
                continue;
            }
            let (ga, gb) = (reach(a), reach(b));
            let mut ends = vec![a];
            if ga * gb < 0.0 {
                ends.push(illinois(&reach, (a, ga), (b, gb), 1e-15 * duration_s, 0.0));
            }
            ends.push(b);
            for part in ends.windows(2) {
                let (lo, hi) = (part[0], part[1]);
                if hi > lo && reach(0.5 * (lo + hi)) >= 0.0 {
                    depth += adaptive_gauss_kronrod(&rate, lo, hi, density);
                }
            }
        }
        depth
    }

    /// The footprint's angular spectrum at radius `r_mm` with the pad centre at `r1_mm`, for
    /// m = 0 … `m_max` (module docs, **Harmonics**): the cosine coefficients
    /// ĝ_m = (1/2π)·∫ρ(r, α)·cos(mα) dα of the footprint, and those of the modulation kernel
    /// h = ρ − Ω·∂ρ/∂Ω. ĝ_0 is R(r; r1). By a 15-point Kronrod rule on equal panels of the
    /// pressed half-arc [0, θ0] (ρ is even in α), each spanning at most 2 rad of m_max·α (a
    /// third of a period): the rule's degree 22 then resolves every cos(mα); what limits the
    /// accuracy is the sliding speed's kink and a linear pad's lift line inside the arc.
    pub fn angular_spectrum(&self, r_mm: f64, r1_mm: f64, m_max: usize) -> (Vec<f64>, Vec<f64>) {
        let mut rho = vec![0.0; m_max + 1];
        let mut kernel = vec![0.0; m_max + 1];
        let pair = self.pair(r_mm, r1_mm);
        let Some(half_arc) = self.pressed_half_angle(&pair) else {
            return (rho, kernel);
        };
        let omega = self.part_speed;
        let panels = ((m_max as f64 * half_arc / 2.0).ceil() as usize).max(4);
        let width = half_arc / panels as f64;
        // cos(mα) by the recurrence cos((m+1)α) = 2·cos α·cos(mα) − cos((m−1)α), run on a
        // panel's 16 lanes at once: one lane's recurrence is a chain of dependent operations,
        // sixteen side by side are independent (vector instructions), and each lane keeps its
        // own sums, added once at the end.
        const LANES: usize = 16;
        let mut rho_lanes = vec![[0.0; LANES]; m_max + 1];
        let mut kernel_lanes = vec![[0.0; LANES]; m_max + 1];
        // The panels are equal: each node is its panel's centre plus an offset they all share,
        // so cos α = cos(centre)·cos(offset) − sin(centre)·sin(offset), one sincos a panel.
        let (mut cos_offset, mut sin_offset, mut weights) =
            ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for (lane, (offset, weight)) in kronrod_rule(-0.5 * width, 0.5 * width).enumerate() {
            (sin_offset[lane], cos_offset[lane]) = offset.sin_cos();
            weights[lane] = weight / PI;
        }
        for panel in 0..panels {
            let (sin_centre, cos_centre) = ((panel as f64 + 0.5) * width).sin_cos();
            let (mut c, mut a, mut b) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
            for lane in 0..LANES {
                c[lane] = cos_centre * cos_offset[lane] - sin_centre * sin_offset[lane];
            }
            // On a flat every lane, the rule's zero weight included (its node is inside the
            // panel: finite), side by side; a curved pair's footprint node by node.
            let mut parts = [(0.0, 0.0, 0.0); LANES];
            match pair {
                Pair::Flat { r, r1, pressure } => {
                    for (part, &cos) in parts.iter_mut().zip(&c) {
                        *part = self.flat_parts(r, r1, &pressure, cos);
                    }
                }
                Pair::Curved { .. } => {
                    for (lane, &weight) in weights.iter().enumerate() {
                        if weight != 0.0 {
                            parts[lane] = self.footprint_parts(&pair, c[lane]);
                        }
                    }
                }
            }
            for lane in 0..LANES {
                let (pressed, v, dv) = parts[lane];
                let scale = pressed * weights[lane];
                (a[lane], b[lane]) = (scale * v, scale * (v - omega * dv));
            }
            let (mut before, mut now) = ([1.0; LANES], c);
            for k in 0..LANES {
                rho_lanes[0][k] += a[k];
                kernel_lanes[0][k] += b[k];
            }
            for m in 1..=m_max {
                for k in 0..LANES {
                    rho_lanes[m][k] += a[k] * now[k];
                    kernel_lanes[m][k] += b[k] * now[k];
                    let next = 2.0 * c[k] * now[k] - before[k];
                    before[k] = now[k];
                    now[k] = next;
                }
            }
        }
        for m in 0..=m_max {
            rho[m] = rho_lanes[m].iter().sum();
            kernel[m] = kernel_lanes[m].iter().sum();
        }
        (rho, kernel)
    }

    /// An upper bound of the footprint's rate at radius `r_mm` with the pad centre within
    /// `r1_max_mm` of the axis (nm/s): K·P times the largest pressure factor and sliding speed.
    fn largest_rate(&self, r_mm: f64, r1_max_mm: f64) -> f64 {
        let speed = if self.kernel.curved().is_some() {
            // |Ω·ẑ × X| = Ω·r, and |a × (X − P₀)| is at most the chord, at most r_t.
            self.part_speed.abs() * r_mm + self.tool_speed.abs() * self.tool_radius_mm
        } else {
            (self.tool_speed - self.part_speed).abs() * r_mm + self.tool_speed.abs() * r1_max_mm
        };
        let pressure = self.kernel.pad_pressure(r1_max_mm);
        let factor = pressure.level + pressure.slope_per_mm.abs() * 2.0 * self.tool_radius_mm;
        self.preston * factor.max(1.0) * speed.max(f64::MIN_POSITIVE)
    }
}

/// A piece of the executed motion at constant speed on both axes: the pad centre from the
/// radius `from_mm` to `to_mm` (at constant speed along the surface, [`Track`]: linear in time
/// on a plane) and from the part-frame angle `start_rad`, for
/// `duration_s`, with the part turning at `part_speed_rad_per_s` (so the pad centre's angle
/// falls at that rate). A ring when `from_mm == to_mm`, else a piece of spiral.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    /// The station whose dwell the block spends.
    pub station: usize,
    /// Which of `Motion::segments` (a stop or a move) it is part of.
    pub segment: usize,
    pub from_mm: f64,
    pub to_mm: f64,
    pub start_rad: f64,
    pub duration_s: f64,
    pub part_speed_rad_per_s: f64,
}

/// `blocks` with each stop's rings at one C speed merged into one ring of their total time:
/// a ring's azimuthal mean is T·R_Ω(r; r1) whatever its start angle, so the merged blocks
/// have the same means, and a stop under a sector law (thousands of turns, a block per
/// sector passed) costs one term per distinct speed. The order stays outward.
fn rings_merged(blocks: &[Block]) -> Vec<Block> {
    let mut merged: Vec<Block> = Vec::with_capacity(blocks.len());
    // Where the current stop's merged rings begin in `merged`.
    let mut stop_start = 0;
    for (i, block) in blocks.iter().enumerate() {
        let same_stop = i > 0 && blocks[i - 1].segment == block.segment;
        if !same_stop {
            stop_start = merged.len();
        }
        if block.from_mm == block.to_mm {
            if let Some(ring) = merged[stop_start..].iter_mut().find(|b| {
                b.from_mm == b.to_mm
                    && b.from_mm == block.from_mm
                    && b.part_speed_rad_per_s == block.part_speed_rad_per_s
            }) {
                ring.duration_s += block.duration_s;
                continue;
            }
        }
        merged.push(*block);
    }
    merged
}

/// A run of consecutive blocks at one C speed ([`one_speed`]): what C executes without a
/// change of speed, the span its acceleration model takes.
#[derive(Debug, Clone, PartialEq)]
pub struct CRun {
    /// The first block's C speed, rad/s.
    pub speed_rad_per_s: f64,
    pub duration_s: f64,
    /// Its blocks.
    pub blocks: std::ops::Range<usize>,
}

/// The runs of one C speed in `blocks`, in order.
pub fn c_runs(blocks: &[Block]) -> Vec<CRun> {
    let mut runs: Vec<CRun> = Vec::new();
    for (i, b) in blocks.iter().enumerate() {
        match runs.last_mut() {
            Some(run) if one_speed(run.speed_rad_per_s, b.part_speed_rad_per_s) => {
                run.duration_s += b.duration_s;
                run.blocks.end = i + 1;
            }
            _ => runs.push(CRun {
                speed_rad_per_s: b.part_speed_rad_per_s,
                duration_s: b.duration_s,
                blocks: i..i + 1,
            }),
        }
    }
    runs
}

/// C's acceleration between each two consecutive runs (rad/s², by
/// `physics::motion::acceleration`: the change over the mean of their durations) and the
/// blocks of both.
pub fn c_changes(runs: &[CRun]) -> impl Iterator<Item = (f64, std::ops::Range<usize>)> + '_ {
    runs.windows(2).map(|w| {
        let (a, b) = (&w[0], &w[1]);
        let change = acceleration(
            (b.speed_rad_per_s - a.speed_rad_per_s).abs(),
            a.duration_s,
            b.duration_s,
        );
        (change, a.blocks.start..b.blocks.end)
    })
}

/// The blocks `motion` runs with `dwell_s` at its stations on `surface`: its stops and moves in
/// order (`Motion::segments`), the pad centre at constant speed along the surface within each
/// ([`Track`]; X at constant speed on a plane); C at `part_speed_rad_per_s` (the
/// process's Ω) throughout, or under a sector law at Ω times the factor of the sector the pad
/// centre is over, each segment then cut where the pad centre crosses a sector's edge. C's
/// speed changes only at a sector's edge: a sector takes the factor of the station whose
/// segment is running when the pad centre enters it, and keeps it when the plan passes to
/// the next station within the sector (so C's speed is constant over every whole sector,
/// which is what its acceleration is planned on). The
/// pad centre starts at the part-frame angle `start_rad`, and its angle is continuous from
/// segment to segment (dφ/dt = −Ω); a segment of no dwell takes no time and no block.
pub fn executed_blocks(
    motion: &Motion,
    dwell_s: &[f64],
    part_speed_rad_per_s: f64,
    start_rad: f64,
    surface: &Surface,
) -> Vec<Block> {
    walk(
        motion,
        dwell_s,
        part_speed_rad_per_s,
        start_rad,
        Some(surface),
    )
    .blocks
}

/// C's schedule ([`c_schedule`]): a few of the executed motion's blocks, and how many it has.
#[derive(Debug, Clone, PartialEq)]
pub struct CSchedule {
    pub blocks: Vec<Block>,
    /// How many blocks [`executed_blocks`] gives for the same motion.
    pub executed_blocks: usize,
}

/// C's schedule over the motion [`executed_blocks`] gives, in as many blocks as a plan has
/// stations times two turns of sectors rather than as many as C turns through sectors: where
/// a segment under a sector law holds three whole turns or more of its station's law past its
/// first edge, all but two are left out (a station whose sectors all take one speed keeps
/// them as one block at that speed). Every two consecutive runs of one C speed
/// ([`c_runs`], [`c_changes`]) of the full motion are then two consecutive runs here, with the
/// same speeds and durations: C's peaks and where they fall are the executed motion's, at a
/// cost that does not grow with the plan's time. The blocks' radii and angles are not the
/// motion's and carry no removal.
pub fn c_schedule(
    motion: &Motion,
    dwell_s: &[f64],
    part_speed_rad_per_s: f64,
    start_rad: f64,
) -> CSchedule {
    walk(motion, dwell_s, part_speed_rad_per_s, start_rad, None)
}

/// [`executed_blocks`] on `surface`, or without one [`c_schedule`].
fn walk(
    motion: &Motion,
    dwell_s: &[f64],
    part_speed_rad_per_s: f64,
    start_rad: f64,
    surface: Option<&Surface>,
) -> CSchedule {
    let skip_turns = surface.is_none();
    debug_assert_eq!(dwell_s.len(), motion.len());
    let mut left_out_blocks = 0;
    let omega = part_speed_rad_per_s;
    let mut phi = start_rad;
    let mut blocks = Vec::new();
    // The sector the pad centre is over (by the edge it meets next) and its factor.
    let mut entered: Option<(i64, f64)> = None;
    for (index, segment) in motion.segments().into_iter().enumerate() {
        let station = segment.station();
        let duration = segment.share() * dwell_s[station];
        if duration <= 0.0 {
            continue;
        }
        let (from, to) = segment.ends_mm();
        let track = Track::new(surface, from, to, duration);
        let at = |elapsed: f64| track.at(elapsed);
        match motion.turning() {
            Turning::Constant => {
                blocks.push(Block {
                    station,
                    segment: index,
                    from_mm: from,
                    to_mm: to,
                    start_rad: phi,
                    duration_s: duration,
                    part_speed_rad_per_s: omega,
                });
                phi -= omega * duration;
            }
            Turning::Sectors(law) => {
                let width = law.sector_rad();
                let falling = omega > 0.0;
                // The next sector edge the pad centre meets, as a multiple of the width, and
                // the sector it is over until then.
                let mut edge = if falling {
                    (phi / width).ceil() as i64 - 1
                } else {
                    (phi / width).floor() as i64 + 1
                };
                let mut elapsed = 0.0;
                let mut skipped = !skip_turns;
                while elapsed < duration {
                    let sector = if falling { edge } else { edge - 1 }
                        .rem_euclid(law.sectors() as i64) as usize;
                    // C's speed changes only at a sector's edge: a sector keeps the factor of
                    // the station the plan was at when the pad centre entered it.
                    let factor = match entered {
                        Some((e, f)) if e == edge => f,
                        _ => law.factor(station, sector),
                    };
                    entered = Some((edge, factor));
                    let speed = omega * factor;
                    let to_edge = (edge as f64 * width - phi).abs() / speed.abs();
                    let time = to_edge.min(duration - elapsed);
                    blocks.push(Block {
                        station,
                        segment: index,
                        from_mm: at(elapsed),
                        to_mm: if time < to_edge {
                            to
                        } else {
                            at(elapsed + time)
                        },
                        start_rad: phi,
                        duration_s: time,
                        part_speed_rad_per_s: speed,
                    });
                    if time < to_edge {
                        phi -= speed * time;
                        break;
                    }
                    phi = edge as f64 * width;
                    edge += if falling { -1 } else { 1 };
                    if elapsed + time == elapsed {
                        // A sector too brief to count against the segment's time: the
                        // caller bounds the blocks a plan may take, so this is never reached
                        // by a checked plan; stop rather than spin.
                        break;
                    }
                    elapsed += time;
                    // At the segment's first edge, the whole turns beyond two (c_schedule).
                    if !skipped {
                        skipped = true;
                        // A turn of this station's law from an edge, s, and whether it is
                        // one speed.
                        let turn = (0..law.sectors())
                            .map(|k| width / (omega * law.factor(station, k)).abs())
                            .sum::<f64>();
                        let first = law.factor(station, 0);
                        let uniform =
                            (1..law.sectors()).all(|k| one_speed(first, law.factor(station, k)));
                        let whole = ((duration - elapsed) / turn).floor();
                        if whole >= 3.0 {
                            let left_out = whole - 2.0;
                            if uniform {
                                blocks.push(Block {
                                    station,
                                    segment: index,
                                    from_mm: at(elapsed),
                                    to_mm: at(elapsed + left_out * turn),
                                    start_rad: phi,
                                    duration_s: left_out * turn,
                                    part_speed_rad_per_s: omega * first,
                                });
                            }
                            elapsed += left_out * turn;
                            let sectors = left_out as i64 * law.sectors() as i64;
                            left_out_blocks += sectors as usize - usize::from(uniform);
                            edge += if falling { -sectors } else { sectors };
                            phi -= (if falling { 1.0 } else { -1.0 }) * sectors as f64 * width;
                        }
                    }
                }
            }
        }
    }
    CSchedule {
        executed_blocks: blocks.len() + left_out_blocks,
        blocks,
    }
}
