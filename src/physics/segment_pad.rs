//! The pad on a part that is not round about C: off-axis segments mounted on C, or a part whose
//! parent asphere is decentred from C ([`crate::segments`]), turning on C while the pad's X, Z
//! and B follow the surface.
//!
//! **Kinematics** (as `super::curved`'s, without its symmetry). At a surface point X of
//! segment i (C's frame at the instant, mm) under the pad centred on the surface point T, with
//! the part turning at Ω about ẑ and the pad spinning at ω_t about its axis a:
//!
//! ```text
//! v = Ω·ẑ × X − ω_t·a × (X − T),     v_t = v − (v·m)·m,     ρ = K·P·|v_t|
//! ```
//!
//! m the unit normal at X, toward the tool. The feed of the pad centre and the servo's own
//! motion of Z and B (mm/s against the sliding's hundreds) are left out, as the 1-D model
//! leaves out the radial feed.
//!
//! **The pose.** B tilts the tool in the plane through C and the pad centre, so the axis follows
//! the radial slope only: with g = ∇z at T (the surface of X's segment, continued past its
//! edge if the pad straddles it) and e_r the radial unit vector of T's projection,
//! a = (−s·e_r, 1)/√(1 + s²), s = g·e_r. The surface's slope across the radius,
//! (g·e_φ) = Z′/r, is taken up by the pad's compliance (it conforms to the surface under it);
//! on a surface of revolution it is 0 and a is the normal. A tool carried vertically
//! ([`Orientation::Vertical`]: B held at 0, Z alone following the surface) has a = ẑ.
//!
//! **Contact** (the local quadric's, as on curved parts): the pad covers the points within
//! geodesic distance r_t of T, taken as the ball |X − T| ≤ c_t with the chord
//! c_t = (2/H)·sin(r_t·H/2), H = (κ1 + κ2)/2 the mean of the principal curvatures at T. It is
//! exact on a sphere; elsewhere the edge lies within r_t³·|Δ|·(2|H| + |Δ|)/24 of the geodesic
//! circle, Δ = (κ2 − κ1)/2 (a geodesic of length s has the chord s − κ_n²·s³/24 + O(s⁴), κ_n
//! = H + Δ·cos 2ψ by Euler). Only X's own segment touches the pad: the pad reaching over a
//! segment's edge presses on nothing there. (Z's law lifts the pad, when the shop asks, only
//! where it is clear of every segment: `crate::segments`.)
//! Pressure is the process's nominal P over the contact (the uniform model).
//!
//! **Depth.** A block moves the pad centre's projection along c(t) = r(t)·(cos φ(t), sin φ(t)),
//! r linear in time and φ = φ_s − Ω·t (the part turning under a still tool), and leaves
//! ∫ ρ(X; T(t)) dt at X. The time under the pad is where |X − T(t)| ≤ c_t(t): within the
//! projection's window |c(t) − x| ≤ r_t (the chord is never shorter than the projected
//! distance), its edges found by the Illinois method on |X − T|² − c_t² and the rate
//! integrated between them by adaptive Gauss–Kronrod. A ring's passes under the pad repeat
//! each turn: whole windows are integrated once.

use std::f64::consts::TAU;

use rayon::prelude::*;

use super::kronrod::adaptive_gauss_kronrod;
use super::polar::Block;
use super::pressure::PressureModel;
use super::process::Process;
use super::roots::illinois;
use super::Orientation;
use crate::segments::SegmentLayout;

/// The quadrature's tolerance, relative to the largest sliding speed times the window.
const RELATIVE_TOLERANCE: f64 = 1e-11;

/// A point of the part where the depth is wanted: its segment, place and normal.
#[derive(Debug, Clone, Copy)]
struct Site {
    segment: usize,
    x: [f64; 3],
    normal: [f64; 3],
}

/// The pad set down at a projected centre: T, its axis, its chord reach squared.
#[derive(Debug, Clone, Copy)]
struct Placed {
    centre: [f64; 3],
    axis: [f64; 3],
    reach2: f64,
}

/// Why a process cannot run on segments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SegmentPadError {
    #[error("a part that is not round about C takes the uniform pressure model only")]
    Pressure,
}

/// The pad of a process over a segment layout.
#[derive(Debug, Clone)]
pub struct SegmentPad {
    layout: SegmentLayout,
    tool_radius_mm: f64,
    /// ω_t, rad/s, counter-clockwise positive seen from the tool.
    tool_speed: f64,
    /// K·P, nm/s per mm/s of sliding.
    preston: f64,
    orientation: Orientation,
}

impl SegmentPad {
    pub fn new(layout: SegmentLayout, process: &Process) -> Result<SegmentPad, SegmentPadError> {
        if process.pressure_model() != PressureModel::Uniform {
            return Err(SegmentPadError::Pressure);
        }
        Ok(SegmentPad {
            layout,
            tool_radius_mm: process.tool_radius_mm(),
            tool_speed: process.omega2_rad_per_s(),
            preston: process.preston_rate_scale(),
            orientation: process.part().orientation,
        })
    }

    pub fn layout(&self) -> &SegmentLayout {
        &self.layout
    }

    fn site(&self, p: [f64; 2]) -> Option<Site> {
        let segment = self.layout.segment_at(p)?;
        let point = self.layout.point(segment, p);
        Some(Site {
            segment,
            x: [p[0], p[1], point.sag_mm],
            normal: point.normal(),
        })
    }

    /// The pad centred over the projected point `c`, pressed on `segment`'s surface (continued
    /// past its edge).
    fn placed(&self, segment: usize, c: [f64; 2]) -> Placed {
        let point = self.layout.point(segment, c);
        let r = c[0].hypot(c[1]);
        let radial = if r > 0.0 {
            [c[0] / r, c[1] / r]
        } else {
            [1.0, 0.0]
        };
        let g = point.gradient;
        let s = match self.orientation {
            Orientation::Normal => g[0] * radial[0] + g[1] * radial[1],
            Orientation::Vertical => 0.0,
        };
        let w = (1.0 + s * s).sqrt();
        let [k1, k2] = point.principal_curvatures();
        let h = 0.5 * (k1 + k2);
        let rt = self.tool_radius_mm;
        let chord = if (h * rt).abs() < 1e-9 {
            rt
        } else {
            2.0 / h * (0.5 * rt * h).sin()
        };
        Placed {
            centre: [c[0], c[1], point.sag_mm],
            axis: [-s * radial[0] / w, -s * radial[1] / w, 1.0 / w],
            reach2: chord * chord,
        }
    }

    /// ρ (nm/s) at the site with the pad as placed and the part at Ω, 0 beyond the reach.
    fn rate(&self, site: &Site, pad: &Placed, part_speed: f64) -> f64 {
        let x = site.x;
        let d = [
            x[0] - pad.centre[0],
            x[1] - pad.centre[1],
            x[2] - pad.centre[2],
        ];
        if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > pad.reach2 {
            return 0.0;
        }
        let a = pad.axis;
        let spin = [
            a[1] * d[2] - a[2] * d[1],
            a[2] * d[0] - a[0] * d[2],
            a[0] * d[1] - a[1] * d[0],
        ];
        let v = [
            -part_speed * x[1] - self.tool_speed * spin[0],
            part_speed * x[0] - self.tool_speed * spin[1],
            -self.tool_speed * spin[2],
        ];
        let m = site.normal;
        let along = v[0] * m[0] + v[1] * m[1] + v[2] * m[2];
        let t = [
            v[0] - along * m[0],
            v[1] - along * m[1],
            v[2] - along * m[2],
        ];
        self.preston * (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt()
    }

    /// The footprint ρ (nm/s) at the part's point `point` with the pad centre's projection at
    /// `centre` (x, y mm, part frame), the part at Ω: 0 off the segments and off the pad.
    pub fn rate_at(&self, point: [f64; 2], centre: [f64; 2], part_speed_rad_per_s: f64) -> f64 {
        let Some(site) = self.site(point) else {
            return 0.0;
        };
        self.rate(
            &site,
            &self.placed(site.segment, centre),
            part_speed_rad_per_s,
        )
    }

    /// The depth (nm) `blocks` leave at each of `points` (x, y mm, part frame; 0 off the
    /// segments), summed in the blocks' order.
    ///
    /// A stop under a sector law runs the same sector blocks turn after turn, and blocks that
    /// are the same motion (radii, C speed, duration, and start angle modulo a turn, the last
    /// two to 1e-12) leave the same depth: each distinct block is integrated once, times its
    /// count.
    pub fn depth_nm(&self, blocks: &[Block], points: &[[f64; 2]]) -> Vec<f64> {
        let distinct = distinct_blocks(blocks);
        points
            .par_iter()
            .map(|&p| {
                let Some(site) = self.site(p) else {
                    return 0.0;
                };
                let r = p[0].hypot(p[1]);
                let rt = self.tool_radius_mm;
                distinct
                    .iter()
                    .filter(|(b, _)| {
                        b.from_mm.min(b.to_mm) - rt <= r && r <= b.from_mm.max(b.to_mm) + rt
                    })
                    .map(|(b, count)| *count as f64 * self.block_depth_nm(&site, b))
                    .sum()
            })
            .collect()
    }

    /// ∫ ρ dt over one block at one site: over each pass of the pad centre's angle through the
    /// projection's window about the site's angle θ, |φ − θ| ≤ α, with α the widest the
    /// window gets over the block's radii (a spiral's radius changes little in a block: its
    /// window is taken at the widest, and the reach decides within it).
    fn block_depth_nm(&self, site: &Site, block: &Block) -> f64 {
        let omega = block.part_speed_rad_per_s;
        let (x, y) = (site.x[0], site.x[1]);
        let r = x.hypot(y);
        let theta = y.atan2(x);
        let rt = self.tool_radius_mm;
        let (lo, hi) = (
            block.from_mm.min(block.to_mm),
            block.from_mm.max(block.to_mm),
        );
        let path = |t: f64| -> [f64; 2] {
            let radius = block.from_mm + (block.to_mm - block.from_mm) * (t / block.duration_s);
            let (s, c) = (block.start_rad - omega * t).sin_cos();
            [radius * c, radius * s]
        };
        // cos α = (r² + r1² − r_t²)/(2·r·r1) at its least over r1 ∈ [lo, hi]: at an end, or
        // at r1 = √(r² − r_t²) where it is stationary.
        let cos_at = |r1: f64| {
            if r * r1 > 0.0 {
                (r * r + r1 * r1 - rt * rt) / (2.0 * r * r1)
            } else if (r - r1).abs() <= rt {
                -1.0
            } else {
                2.0
            }
        };
        let mut cos = cos_at(lo).min(cos_at(hi));
        let stationary = (r * r - rt * rt).max(0.0).sqrt();
        if stationary > lo && stationary < hi {
            cos = cos.min(cos_at(stationary));
        }
        if cos > 1.0 {
            return 0.0;
        }
        let half = cos.max(-1.0).acos();
        let t_turn = TAU / omega.abs();
        if half >= std::f64::consts::PI {
            // The pad may cover the point's projection all round: turn by turn.
            let turns = (block.duration_s / t_turn).floor();
            let ring = block.from_mm == block.to_mm;
            let mut total = 0.0;
            let mut whole: Option<f64> = None;
            let mut k = 0.0;
            while k < turns {
                let (a, b) = (k * t_turn, (k + 1.0) * t_turn);
                total += match (ring, whole) {
                    (true, Some(w)) => w,
                    _ => {
                        let w = self.window_depth(site, &path, a, b, omega);
                        whole = Some(w);
                        w
                    }
                };
                k += 1.0;
            }
            return total + self.window_depth(site, &path, turns * t_turn, block.duration_s, omega);
        }
        // Entry times of the window, one per turn: φ(t) = θ + α (Ω > 0) or θ − α.
        let entry_angle = if omega > 0.0 {
            theta + half
        } else {
            theta - half
        };
        let first = ((block.start_rad - entry_angle) / omega).rem_euclid(t_turn) - t_turn;
        let width = 2.0 * half / omega.abs();
        let ring = block.from_mm == block.to_mm;
        let mut total = 0.0;
        let mut full: Option<f64> = None;
        let mut start = first;
        while start < block.duration_s {
            let (a, b) = (start.max(0.0), (start + width).min(block.duration_s));
            if b > a {
                let whole = a == start && b == start + width;
                total += match (ring && whole, full) {
                    // A ring's every whole pass is the same pass, a turn later.
                    (true, Some(w)) => w,
                    (true, None) => *full.insert(self.window_depth(site, &path, a, b, omega)),
                    _ => self.window_depth(site, &path, a, b, omega),
                };
            }
            start += t_turn;
        }
        total
    }

    /// ∫ ρ dt over [t0, t1] (s) along `path`, where the pad covers the site: the edges of its
    /// reach located between samples and the rate integrated between them.
    fn window_depth(
        &self,
        site: &Site,
        path: &dyn Fn(f64) -> [f64; 2],
        t0: f64,
        t1: f64,
        omega: f64,
    ) -> f64 {
        // Out of reach: > 0.
        let gap = |t: f64| -> f64 {
            let pad = self.placed(site.segment, path(t));
            let d = [
                site.x[0] - pad.centre[0],
                site.x[1] - pad.centre[1],
                site.x[2] - pad.centre[2],
            ];
            d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - pad.reach2
        };
        let rate = |t: f64| self.rate(site, &self.placed(site.segment, path(t)), omega);
        // Samples close enough that the reach (a ball about the pad centre) is entered and
        // left once between two of them: the pad centre moves at most r_t/4 from one to the
        // next (a pass that enters and leaves between two crosses the reach on a chord of
        // less than that, where the rate is a sliver of the pass's).
        let (a, b) = (path(t0), path(t1));
        let radius = a[0].hypot(a[1]).max(b[0].hypot(b[1]));
        let travel = omega.abs() * radius * (t1 - t0) + (a[0].hypot(a[1]) - b[0].hypot(b[1])).abs();
        let samples = ((4.0 * travel / self.tool_radius_mm).ceil() as usize).clamp(4, 256);
        let dt = (t1 - t0) / samples as f64;
        let times: Vec<f64> = (0..=samples).map(|k| t0 + k as f64 * dt).collect();
        let gaps: Vec<f64> = times.iter().map(|&t| gap(t)).collect();
        let tolerance_t = 1e-14 * (t1.abs() + 1.0);
        let edge = |k: usize| -> f64 {
            illinois(
                &gap,
                (times[k], gaps[k]),
                (times[k + 1], gaps[k + 1]),
                tolerance_t,
                0.0,
            )
        };
        let peak = self.preston
            * self.tool_speed.abs().max(omega.abs())
            * 2.0
            * (site.x[0].hypot(site.x[1]) + 2.0 * self.tool_radius_mm);
        let mut total = 0.0;
        let mut inside_from = if gaps[0] <= 0.0 { Some(t0) } else { None };
        for k in 0..samples {
            match (inside_from, gaps[k + 1] <= 0.0) {
                (None, true) => inside_from = Some(edge(k)),
                (Some(a), false) => {
                    let b = edge(k);
                    total += adaptive_gauss_kronrod(&rate, a, b, RELATIVE_TOLERANCE * peak);
                    inside_from = None;
                }
                _ => {}
            }
        }
        if let Some(a) = inside_from {
            total += adaptive_gauss_kronrod(&rate, a, t1, RELATIVE_TOLERANCE * peak);
        }
        total
    }
}

/// The distinct motions among `blocks` and how many times each runs, in the order of their
/// first run; the start angle brought into [0, 2π).
fn distinct_blocks(blocks: &[Block]) -> Vec<(Block, usize)> {
    let mut index: std::collections::HashMap<(u64, u64, u64, i64, i64), usize> =
        std::collections::HashMap::new();
    let mut distinct: Vec<(Block, usize)> = Vec::new();
    for block in blocks {
        let start = block.start_rad.rem_euclid(TAU);
        let key = (
            block.from_mm.to_bits(),
            block.to_mm.to_bits(),
            block.part_speed_rad_per_s.to_bits(),
            (start * 1e9).round() as i64,
            (block.duration_s.ln() * 1e9).round() as i64,
        );
        match index.get(&key) {
            Some(&k) => distinct[k].1 += 1,
            None => {
                index.insert(key, distinct.len());
                distinct.push((
                    Block {
                        start_rad: start,
                        ..*block
                    },
                    1,
                ));
            }
        }
    }
    distinct
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::polar::PolarPad;
    use crate::physics::{Orientation, Part, ProcessSpec};
    use crate::surface::{Surface, SurfaceSpec};

    fn process(part: Part, workpiece_radius_mm: f64) -> Process {
        Process::new(ProcessSpec {
            workpiece_radius_mm,
            tool_radius_mm: 10.0,
            workpiece_rpm: 20.0,
            tool_rpm: -300.0,
            preston_coefficient_m2_per_n: 1e-13,
            pressure_kpa: 20.0,
            pressure_model: PressureModel::Uniform,
            part,
        })
        .unwrap()
    }

    fn ring(r1: f64, start: f64, duration: f64, part_speed: f64) -> Block {
        Block {
            station: 0,
            segment: 0,
            from_mm: r1,
            to_mm: r1,
            start_rad: start,
            duration_s: duration,
            part_speed_rad_per_s: part_speed,
        }
    }

    /// Points on a polar lattice out to `outer`, off the axis's exact centre.
    fn points(outer: f64) -> Vec<[f64; 2]> {
        (0..=24)
            .flat_map(|i| {
                (0..13).map(move |j| {
                    let r = 0.3 + outer * i as f64 / 24.0;
                    let t = 0.37 + std::f64::consts::TAU * j as f64 / 13.0;
                    [r * t.cos(), r * t.sin()]
                })
            })
            .collect()
    }

    fn worst_against(got: &[f64], want: &[f64]) -> f64 {
        let scale = want.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(scale > 0.0);
        got.iter()
            .zip(want)
            .map(|(g, w)| (g - w).abs() / scale)
            .fold(0.0, f64::max)
    }

    /// A plane's parent decentred by any d is the flat part: the depth of rings (part and
    /// whole turns, C either way, one about C itself) and of a spiral equals the flat model's
    /// closed form (`physics::polar`) to 1e-9 of the largest depth (the quadrature's 1e-11
    /// per window and the edges' root finding, summed over a few windows).
    #[test]
    fn a_decentred_plane_is_the_flat_model() {
        let flat = process(Part::flat(), 60.0);
        let plane = Surface::new(&SurfaceSpec::Plane).unwrap();
        let pad =
            SegmentPad::new(SegmentLayout::decentred(plane, 17.0, 60.0).unwrap(), &flat).unwrap();
        let omega = 20.0 * TAU / 60.0;
        let blocks = [
            ring(30.0, 0.3, 1.7 * TAU / omega, omega),
            ring(42.0, -1.0, 0.4, -1.5 * omega),
            ring(4.0, 2.0, 2.3 * TAU / omega, omega),
            Block {
                from_mm: 25.0,
                to_mm: 35.0,
                duration_s: 0.8,
                ..ring(0.0, 0.9, 0.0, omega)
            },
        ];
        let pts = points(48.0);
        let want = PolarPad::new(&flat).depth_nm(
            &blocks,
            &pts.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>(),
        );
        let got = pad.depth_nm(&blocks, &pts);
        let worst = worst_against(&got, &want);
        assert!(worst < 1e-9, "worst {worst:e} of the largest depth");
    }

    /// A sphere's parent on C (d = 0) is the curved part of revolution: rings' depths equal
    /// `physics::polar`'s curved model (its sliding speed by the same kinematics in another
    /// form, its arc from the ring's geometry) to 1e-8 of the largest, convex and concave,
    /// the tool along the normal and held vertical.
    #[test]
    fn a_sphere_on_c_is_the_curved_model_of_revolution() {
        for (radius, orientation) in [
            (120.0, Orientation::Normal),
            (-90.0, Orientation::Normal),
            (120.0, Orientation::Vertical),
            (-90.0, Orientation::Vertical),
        ] {
            let surface = Surface::new(&SurfaceSpec::Sphere {
                radius_of_curvature_mm: radius,
            })
            .unwrap();
            let curved = process(
                Part {
                    surface: surface.clone(),
                    orientation,
                },
                40.0,
            );
            let pad = SegmentPad::new(
                SegmentLayout::decentred(surface, 0.0, 40.0).unwrap(),
                &curved,
            )
            .unwrap();
            let omega = 20.0 * TAU / 60.0;
            let blocks = [
                ring(22.0, 0.3, 1.3 * TAU / omega, omega),
                ring(8.0, -1.0, 0.4, -omega),
            ];
            let pts = points(35.0);
            let want = PolarPad::new(&curved).depth_nm(
                &blocks,
                &pts.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>(),
            );
            let got = pad.depth_nm(&blocks, &pts);
            let worst = worst_against(&got, &want);
            assert!(
                worst < 1e-8,
                "R {radius} {orientation:?}: worst {worst:e} of the largest depth"
            );
        }
    }
}
