//! Off-axis segments mounted on the C axis: N identical segments of a parent asphere, each
//! translated (not tilted) so that its centre sits on a circle about C, cut or polished in one
//! set-up; their sag in C's frame, its local frame, and the Z law along a ring of C.
//!
//! # The layout
//!
//! A segment is the disc of radius a (its clear aperture) about the point at distance h (the
//! off-axis distance) from the parent's vertex. Segment i is mounted with its centre at
//! c_i = l·e_i, e_i = (cos φ_i, sin φ_i), φ_i = 2π·i/N, its parent's vertex toward C (at
//! c_i − h·e_i, the segment keeping the orientation it had on the parent). A point p of the
//! part (C's frame, mm) in segment i has parent coordinates
//!
//! ```text
//! q = (h + (p − c_i)·e_i,  (p − c_i)·e_i⊥),   ρ = |q|,   z_i(p) = z(ρ) − z(h)
//! ```
//!
//! z the parent's sag, so each segment's centre is at Z = 0. The segments must not overlap
//! (l·sin(π/N) ≥ a for N ≥ 2) nor cover C (l > a). A decentred part is the one-segment case.
//!
//! # The local frame, exactly
//!
//! With z′ and z″ of the parent at ρ (closed forms, [`Surface`]), the gradient and Hessian of
//! z_i in q are ∇z = z′·q̂ and H = z″·q̂q̂ᵀ + (z′/ρ)·(I − q̂q̂ᵀ) (at ρ = 0: ∇z = 0, H = z″(0)·I),
//! rotated into C's frame by e_i. The unit normal toward the tool is (−∇z, 1)/w,
//! w = √(1 + |∇z|²), and the principal curvatures are the eigenvalues of the shape operator
//! (I + ∇z∇zᵀ)⁻¹·H/w, a 2 × 2 matrix similar to a symmetric one: real, in closed form.
//!
//! # Z along a ring
//!
//! A tool at radius r from C sees the part-frame points p(φ) = r·(cos φ, sin φ) pass under it as
//! C turns (φ = −C for C counter-clockwise positive: the part moves under a still tool). Over
//! segment i's arc, |p − c_i| ≤ a ⇔ cos(φ − φ_i) ≥ (r² + l² − a²)/(2rl), Z follows the surface:
//!
//! ```text
//! Z = z_i(p),   Z′ = ∇z·p′,   Z″ = p′ᵀ·H·p′ + ∇z·p″,   p′ = r·(−sin φ, cos φ),  p″ = −p
//! ```
//!
//! (derivatives in φ). Between two arcs Z follows the quintic that meets Z, Z′ and Z″ at both
//! ends (Hermite's), so Z's velocity and acceleration are continuous through every
//! transition at any C speed. Z follows each segment's surface (continued past its edge) while
//! any of the pad of radius r_t is over it, |p − c_i| ≤ a + r_t, so the pad presses on the
//! segment it covers; the quintic bridges the rest of the gap, where the pad is clear of every
//! segment, and a pad lifted there adds the clearance times sin⁴(π·s) (s ∈ [0, 1] across the
//! gap), whose value, slope and curvature vanish at both ends: a quintic spline and a sine, the
//! spline–sine idea with the jerk left free. A ring whose widened arcs leave no gap (the pad
//! is never clear) takes the arcs |p − c_i| ≤ a and is not lifted. A ring the pad never
//! reaches a segment from (|p − c_i| > a + r_t all round) has no law.
//!
//! B tilts the tool in the plane through C, so it can follow the surface's radial slope
//! s = ∇z·e_r only (the slope across the radius is the pad's compliance's). Along the ring
//! s follows the same arcs and quintics as Z (no lift): s′ = r·e_φᵀ·H·e_r + ∇z·e_φ on an arc
//! in closed form, s″ by central differences of s′.

use std::f64::consts::PI;

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

use crate::surface::{Surface, SurfaceError};

/// A layout as a caller gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentLayoutSpec {
    /// The parent asphere, its vertex the origin of each segment's parent coordinates.
    pub parent: Surface,
    /// h: a segment's centre from the parent's vertex, mm (≥ 0; 0 is an on-axis part).
    pub off_axis_mm: f64,
    /// a: a segment's clear aperture, the radius of its disc, mm (> 0).
    pub aperture_radius_mm: f64,
    /// l: the circle of the segments' centres about C, mm.
    pub mount_radius_mm: f64,
    /// N ≥ 1.
    pub count: usize,
}

/// Why a layout was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SegmentError {
    #[error("off_axis_mm must be a finite number ≥ 0")]
    OffAxis,
    #[error("aperture_radius_mm must be a finite number > 0")]
    Aperture,
    #[error("mount_radius_mm must be a finite number larger than the aperture's radius (a segment may not cover the C axis)")]
    Mount,
    #[error("count must be from 1 to {MAX_SEGMENTS}")]
    Count,
    #[error("{count} segments of radius {aperture_mm} mm overlap on a circle of {mount_mm} mm: it needs l·sin(π/N) ≥ a")]
    Overlap {
        count: usize,
        aperture_mm: f64,
        mount_mm: f64,
    },
    #[error("the parent is not defined over a segment: {0}")]
    Parent(SurfaceError),
}

/// The most segments a layout may have.
pub const MAX_SEGMENTS: usize = 64;

/// The step of the central differences for the radial slope's s″, rad: its truncation
/// (step²/6 of s′′′′) and its rounding (1e-16 of s′ over the step) are both near 1e-10.
const SLOPE_STEP_RAD: f64 = 2e-5;

/// A checked layout.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentLayout {
    spec: SegmentLayoutSpec,
    /// z(h): the parent's sag at a segment's centre.
    centre_sag_mm: f64,
}

/// A surface point's sag and its first and second derivatives in C's frame (x, y in mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    pub sag_mm: f64,
    pub gradient: [f64; 2],
    pub hessian: [[f64; 2]; 2],
}

impl SurfacePoint {
    /// The unit normal toward the tool, (−∇z, 1)/√(1 + |∇z|²).
    pub fn normal(&self) -> [f64; 3] {
        let [gx, gy] = self.gradient;
        let w = (1.0 + gx * gx + gy * gy).sqrt();
        [-gx / w, -gy / w, 1.0 / w]
    }

    /// The principal curvatures, 1/mm, smaller first (positive where the surface bends toward
    /// the tool, as a positive radius of curvature does).
    pub fn principal_curvatures(&self) -> [f64; 2] {
        let [gx, gy] = self.gradient;
        let w2 = 1.0 + gx * gx + gy * gy;
        let w = w2.sqrt();
        // (I + ggᵀ)⁻¹ = I − ggᵀ/w², times H/w.
        let inv = [
            [1.0 - gx * gx / w2, -gx * gy / w2],
            [-gx * gy / w2, 1.0 - gy * gy / w2],
        ];
        let h = self.hessian;
        let s = |i: usize, j: usize| (inv[i][0] * h[0][j] + inv[i][1] * h[1][j]) / w;
        let (a, b, c, d) = (s(0, 0), s(0, 1), s(1, 0), s(1, 1));
        let mean = 0.5 * (a + d);
        let spread = (0.25 * (a - d) * (a - d) + b * c).max(0.0).sqrt();
        [mean - spread, mean + spread]
    }
}

impl SegmentLayout {
    pub fn new(spec: SegmentLayoutSpec) -> Result<SegmentLayout, SegmentError> {
        let finite = |v: f64| v.is_finite();
        if !(finite(spec.off_axis_mm) && spec.off_axis_mm >= 0.0) {
            return Err(SegmentError::OffAxis);
        }
        if !(finite(spec.aperture_radius_mm) && spec.aperture_radius_mm > 0.0) {
            return Err(SegmentError::Aperture);
        }
        if !(finite(spec.mount_radius_mm) && spec.mount_radius_mm > spec.aperture_radius_mm) {
            return Err(SegmentError::Mount);
        }
        if !(1..=MAX_SEGMENTS).contains(&spec.count) {
            return Err(SegmentError::Count);
        }
        if spec.count >= 2
            && spec.mount_radius_mm * (PI / spec.count as f64).sin() < spec.aperture_radius_mm
        {
            return Err(SegmentError::Overlap {
                count: spec.count,
                aperture_mm: spec.aperture_radius_mm,
                mount_mm: spec.mount_radius_mm,
            });
        }
        spec.parent
            .check_defined_to(spec.off_axis_mm + spec.aperture_radius_mm)
            .map_err(SegmentError::Parent)?;
        Ok(SegmentLayout {
            centre_sag_mm: spec.parent.sag_mm(spec.off_axis_mm),
            spec,
        })
    }

    /// A part of radius `radius_mm` whose parent's vertex is `decenter_mm` from C, the sag in
    /// C's frame z(x + d, y) − z(d): the one-segment layout mounted on C itself (l = 0, so it
    /// covers C, which a layout of segments may not).
    pub fn decentred(
        parent: Surface,
        decenter_mm: f64,
        radius_mm: f64,
    ) -> Result<SegmentLayout, SegmentError> {
        if !(decenter_mm.is_finite() && decenter_mm >= 0.0) {
            return Err(SegmentError::OffAxis);
        }
        if !(radius_mm.is_finite() && radius_mm > 0.0) {
            return Err(SegmentError::Aperture);
        }
        parent
            .check_defined_to(decenter_mm + radius_mm)
            .map_err(SegmentError::Parent)?;
        Ok(SegmentLayout {
            centre_sag_mm: parent.sag_mm(decenter_mm),
            spec: SegmentLayoutSpec {
                parent,
                off_axis_mm: decenter_mm,
                aperture_radius_mm: radius_mm,
                mount_radius_mm: 0.0,
                count: 1,
            },
        })
    }

    pub fn spec(&self) -> &SegmentLayoutSpec {
        &self.spec
    }

    /// φ_i, rad.
    pub fn centre_angle(&self, i: usize) -> f64 {
        2.0 * PI * i as f64 / self.spec.count as f64
    }

    /// The segment whose disc holds p, if any (they do not overlap).
    pub fn segment_at(&self, p: [f64; 2]) -> Option<usize> {
        let a = self.spec.aperture_radius_mm;
        (0..self.spec.count).find(|&i| {
            let (s, c) = self.centre_angle(i).sin_cos();
            let l = self.spec.mount_radius_mm;
            (p[0] - l * c).hypot(p[1] - l * s) <= a
        })
    }

    /// z_i at p with its gradient and Hessian in C's frame (module docs).
    pub fn point(&self, i: usize, p: [f64; 2]) -> SurfacePoint {
        let (s, c) = self.centre_angle(i).sin_cos();
        let l = self.spec.mount_radius_mm;
        let (dx, dy) = (p[0] - l * c, p[1] - l * s);
        let q = [self.spec.off_axis_mm + dx * c + dy * s, -dx * s + dy * c];
        let rho = q[0].hypot(q[1]);
        let local = self.spec.parent.local(rho);
        let (gq, hq) = if rho < 1e-12 {
            let k = self.spec.parent.second_derivative(0.0);
            ([0.0, 0.0], [[k, 0.0], [0.0, k]])
        } else {
            let u = [q[0] / rho, q[1] / rho];
            let (d1, d2) = (local.slope, local.second_derivative);
            let t = d1 / rho;
            (
                [d1 * u[0], d1 * u[1]],
                [
                    [
                        d2 * u[0] * u[0] + t * (1.0 - u[0] * u[0]),
                        (d2 - t) * u[0] * u[1],
                    ],
                    [
                        (d2 - t) * u[0] * u[1],
                        d2 * u[1] * u[1] + t * (1.0 - u[1] * u[1]),
                    ],
                ],
            )
        };
        // Into C's frame: columns e_i = (c, s) and e_i⊥ = (−s, c).
        let r = [[c, -s], [s, c]];
        let gradient = [
            r[0][0] * gq[0] + r[0][1] * gq[1],
            r[1][0] * gq[0] + r[1][1] * gq[1],
        ];
        let mut hessian = [[0.0; 2]; 2];
        for (a, row) in hessian.iter_mut().enumerate() {
            for (b, v) in row.iter_mut().enumerate() {
                *v = (0..2)
                    .flat_map(|k| (0..2).map(move |m| (k, m)))
                    .map(|(k, m)| r[a][k] * hq[k][m] * r[b][m])
                    .sum();
            }
        }
        SurfacePoint {
            sag_mm: local.sag_mm - self.centre_sag_mm,
            gradient,
            hessian,
        }
    }

    /// Z along the ring of radius `r_mm`, the pad `lift_mm` above the law where it is clear
    /// of every segment, `pad_radius_mm` r_t (module docs; a lift of 0: the pad stays down at
    /// zero dwell); `None` when the ring crosses no segment.
    pub fn ring(&self, r_mm: f64, lift_mm: f64, pad_radius_mm: f64) -> Option<RingLaw<'_>> {
        let (l, a) = (self.spec.mount_radius_mm, self.spec.aperture_radius_mm);
        if r_mm.is_nan() || r_mm <= 0.0 {
            return None;
        }
        // Widened to where the pad is clear (a ring just off the segments, the pad reaching
        // over their edges, among them); if that leaves no gap, the pad is never clear and is
        // not lifted.
        let n = self.spec.count as f64;
        let widened = (l > 0.0)
            .then(|| self.arcs_at(r_mm, lift_mm, a + pad_radius_mm))
            .flatten()
            .filter(|w| {
                let (_, from, to) = w.arcs[0];
                to - from < 2.0 * PI / n
            });
        widened.or_else(|| {
            self.arcs_at(r_mm, lift_mm, a).map(|narrow| RingLaw {
                lift_mm: 0.0,
                ..narrow
            })
        })
    }

    /// The law with arcs where the ring is within `reach_mm` of a segment's centre.
    fn arcs_at(&self, r_mm: f64, lift_mm: f64, reach_mm: f64) -> Option<RingLaw<'_>> {
        let l = self.spec.mount_radius_mm;
        let a = reach_mm;
        let half = if l == 0.0 {
            // A decentred part: the ring is on it whole, or off it.
            if r_mm > a {
                return None;
            }
            PI
        } else {
            let cos = (r_mm * r_mm + l * l - a * a) / (2.0 * r_mm * l);
            if cos > 1.0 {
                return None;
            }
            // A reach beyond l covers the whole ring (the caller then does not lift).
            cos.max(-1.0).acos()
        };
        let arcs = (0..self.spec.count)
            .map(|i| {
                let centre = self.centre_angle(i);
                (i, centre - half, centre + half)
            })
            .collect();
        Some(RingLaw {
            layout: self,
            r_mm,
            lift_mm,
            arcs,
        })
    }
}

/// Z (mm) as a function of the part-frame angle φ along one ring (module docs).
#[derive(Debug, Clone)]
pub struct RingLaw<'a> {
    layout: &'a SegmentLayout,
    r_mm: f64,
    lift_mm: f64,
    /// (segment, first angle, last angle) in increasing order, rad.
    arcs: Vec<(usize, f64, f64)>,
}

/// Z, dZ/dφ and d²Z/dφ² (mm, mm/rad, mm/rad²).
pub type Jet = [f64; 3];

impl RingLaw<'_> {
    /// The segments' arcs along the ring, (segment, from, to) in rad, increasing.
    pub fn arcs(&self) -> &[(usize, f64, f64)] {
        &self.arcs
    }

    /// Z and its first two derivatives on segment i's surface at angle φ.
    fn on_segment(&self, i: usize, phi: f64) -> Jet {
        let (s, c) = phi.sin_cos();
        let r = self.r_mm;
        let p = [r * c, r * s];
        let d1 = [-r * s, r * c];
        let point = self.layout.point(i, p);
        let g = point.gradient;
        let h = point.hessian;
        let curvature = d1[0] * (h[0][0] * d1[0] + h[0][1] * d1[1])
            + d1[1] * (h[1][0] * d1[0] + h[1][1] * d1[1]);
        [
            point.sag_mm,
            g[0] * d1[0] + g[1] * d1[1],
            curvature - (g[0] * p[0] + g[1] * p[1]),
        ]
    }

    /// The radial slope s = ∇z·e_r of segment i's surface at angle φ, and its first two
    /// derivatives in φ: s′ = r·e_φᵀ·H·e_r + ∇z·e_φ in closed form, s″ by central differences
    /// of s′ (step [`SLOPE_STEP_RAD`]: an error near 1e-10 of s′'s scale, the third
    /// derivatives of the sag being left out of [`SurfacePoint`]).
    fn slope_on_segment(&self, i: usize, phi: f64) -> Jet {
        let r = self.r_mm;
        let first = |phi: f64| {
            let (s, c) = phi.sin_cos();
            let point = self.layout.point(i, [r * c, r * s]);
            let (g, h) = (point.gradient, point.hessian);
            let h_er = [h[0][0] * c + h[0][1] * s, h[1][0] * c + h[1][1] * s];
            let slope = g[0] * c + g[1] * s;
            let along = r * (-s * h_er[0] + c * h_er[1]) + (-s * g[0] + c * g[1]);
            (slope, along)
        };
        let (slope, along) = first(phi);
        let ahead = first(phi + SLOPE_STEP_RAD).1;
        let behind = first(phi - SLOPE_STEP_RAD).1;
        [slope, along, (ahead - behind) / (2.0 * SLOPE_STEP_RAD)]
    }

    /// Z at angle φ (any real), and its first two derivatives in φ.
    pub fn at(&self, phi: f64) -> Jet {
        self.follow(phi, self.lift_mm, |i, phi| self.on_segment(i, phi))
    }

    /// The radial slope the tool's B follows at angle φ (any real), s = ∂Z/∂r, and its first
    /// two derivatives in φ: on an arc its segment's (continued past its edge, as Z is);
    /// across a gap Hermite's quintic between the arcs' ends, so B's velocity and acceleration
    /// are continuous as Z's are (its acceleration to the s″ differences' error). The lift
    /// is along Z only.
    pub fn radial_slope(&self, phi: f64) -> Jet {
        self.follow(phi, 0.0, |i, phi| self.slope_on_segment(i, phi))
    }

    /// The largest |d²Z/dφ²| at `samples` equally spaced angles over a turn, mm/rad².
    pub fn largest_curvature(&self, samples: usize) -> f64 {
        (0..samples)
            .map(|k| self.at(2.0 * PI * k as f64 / samples as f64)[2].abs())
            .fold(0.0, f64::max)
    }

    /// A law along the ring: `on(i, φ)` over segment i's arc, the quintic (plus `lift_mm`'s
    /// sin⁴) across each gap.
    fn follow(&self, phi: f64, lift_mm: f64, on: impl Fn(usize, f64) -> Jet) -> Jet {
        let first = self.arcs[0].1;
        // φ brought into [first, first + 2π).
        let phi = first + (phi - first).rem_euclid(2.0 * PI);
        let n = self.arcs.len();
        for (k, &(i, from, to)) in self.arcs.iter().enumerate() {
            if phi <= to {
                return on(i, phi.max(from));
            }
            let next = self.arcs.get(k + 1).map_or(first + 2.0 * PI, |a| a.1);
            if phi < next {
                let (j, _, _) = self.arcs[(k + 1) % n];
                return transition(on(i, to), on(j, next), to, next, phi, lift_mm);
            }
        }
        unreachable!("φ is within one turn of the first arc")
    }
}

/// The quintic from `start` at φ0 to `end` at φ1, plus `lift_mm`·sin⁴, at φ.
fn transition(start: Jet, end: Jet, phi0: f64, phi1: f64, phi: f64, lift_mm: f64) -> Jet {
    let w = phi1 - phi0;
    let s = (phi - phi0) / w;
    let (s2, s3) = (s * s, s * s * s);
    let (s4, s5) = (s3 * s, s3 * s2);
    // Hermite's quintic basis on [0, 1] and its first two derivatives in s.
    let basis = [
        [
            1.0 - 10.0 * s3 + 15.0 * s4 - 6.0 * s5,
            -30.0 * s2 + 60.0 * s3 - 30.0 * s4,
            -60.0 * s + 180.0 * s2 - 120.0 * s3,
        ],
        [
            s - 6.0 * s3 + 8.0 * s4 - 3.0 * s5,
            1.0 - 18.0 * s2 + 32.0 * s3 - 15.0 * s4,
            -36.0 * s + 96.0 * s2 - 60.0 * s3,
        ],
        [
            0.5 * (s2 - 3.0 * s3 + 3.0 * s4 - s5),
            0.5 * (2.0 * s - 9.0 * s2 + 12.0 * s3 - 5.0 * s4),
            0.5 * (2.0 - 18.0 * s + 36.0 * s2 - 20.0 * s3),
        ],
        [
            0.5 * (s3 - 2.0 * s4 + s5),
            0.5 * (3.0 * s2 - 8.0 * s3 + 5.0 * s4),
            0.5 * (6.0 * s - 24.0 * s2 + 20.0 * s3),
        ],
        [
            -4.0 * s3 + 7.0 * s4 - 3.0 * s5,
            -12.0 * s2 + 28.0 * s3 - 15.0 * s4,
            -24.0 * s + 84.0 * s2 - 60.0 * s3,
        ],
        [
            10.0 * s3 - 15.0 * s4 + 6.0 * s5,
            30.0 * s2 - 60.0 * s3 + 30.0 * s4,
            60.0 * s - 180.0 * s2 + 120.0 * s3,
        ],
    ];
    // Coefficients in s: derivatives in φ times w and w².
    let weights = [
        start[0],
        start[1] * w,
        start[2] * w * w,
        end[2] * w * w,
        end[1] * w,
        end[0],
    ];
    let mut jet = [0.0; 3];
    for (b, weight) in basis.iter().zip(weights) {
        for d in 0..3 {
            jet[d] += weight * b[d];
        }
    }
    // sin⁴(πs) and its derivatives in s.
    if lift_mm != 0.0 {
        let (sn, cs) = (PI * s).sin_cos();
        jet[0] += lift_mm * sn.powi(4);
        jet[1] += lift_mm * 4.0 * PI * sn.powi(3) * cs;
        jet[2] += lift_mm * 4.0 * PI * PI * sn * sn * (3.0 * cs * cs - sn * sn);
    }
    [jet[0], jet[1] / w, jet[2] / (w * w)]
}

impl RingLaw<'_> {
    /// Z at `samples` equally spaced angles over one turn, from φ = 0.
    pub fn samples(&self, samples: usize) -> Vec<f64> {
        (0..samples)
            .map(|k| self.at(2.0 * PI * k as f64 / samples as f64)[0])
            .collect()
    }
}

/// The harmonics of a turn's equally spaced samples (a power of two is fastest), m = 1 …
/// `count`: the amplitude of cos(mφ + ψ) in them.
pub fn harmonics(samples: &[f64], count: usize) -> Vec<f64> {
    let n = samples.len();
    let mut values: Vec<Complex<f64>> = samples.iter().map(|&v| Complex::new(v, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut values);
    (1..=count.min((n / 2).saturating_sub(1)))
        .map(|m| 2.0 * values[m].norm() / n as f64)
        .collect()
}

/// A paraboloid of R = 800 mm cut into four segments of 60 mm (a = 30) at h = 120 mm,
/// mounted on l = 70 mm: the case of the tests.
#[cfg(test)]
pub(crate) fn four_paraboloid_segments() -> SegmentLayout {
    use crate::surface::SurfaceSpec;
    SegmentLayout::new(SegmentLayoutSpec {
        parent: Surface::new(&SurfaceSpec::Asphere {
            radius_of_curvature_mm: 800.0,
            conic_constant: -1.0,
            coefficients: vec![],
        })
        .unwrap(),
        off_axis_mm: 120.0,
        aperture_radius_mm: 30.0,
        mount_radius_mm: 70.0,
        count: 4,
    })
    .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case() -> SegmentLayout {
        four_paraboloid_segments()
    }

    /// The sag, gradient and Hessian against the paraboloid's own closed form in C's frame,
    /// z = |P|²/(2R) − h²/(2R) with P the parent point, and its finite differences; the
    /// principal curvatures of a paraboloid at parent radius ρ, 1/(R·w) across the meridian
    /// and 1/(R·w³) along it (w = √(1 + ρ²/R²)).
    #[test]
    fn the_local_frame_is_the_paraboloids() {
        let layout = case();
        let rr = 800.0;
        for (i, p) in [(0, [80.0, 10.0]), (1, [-12.0, 95.0]), (3, [20.0, -60.0])] {
            assert_eq!(layout.segment_at(p), Some(i));
            let phi = layout.centre_angle(i);
            let (s, c) = phi.sin_cos();
            // The parent's vertex in C's frame.
            let v = [(70.0 - 120.0) * c, (70.0 - 120.0) * s];
            let z = |x: f64, y: f64| {
                ((x - v[0]).powi(2) + (y - v[1]).powi(2)) / (2.0 * rr) - 120.0 * 120.0 / (2.0 * rr)
            };
            let pt = layout.point(i, p);
            assert!((pt.sag_mm - z(p[0], p[1])).abs() < 1e-12, "{pt:?}");
            let g = [(p[0] - v[0]) / rr, (p[1] - v[1]) / rr];
            for (k, (ours, exact)) in pt.gradient.iter().zip(g).enumerate() {
                assert!((ours - exact).abs() < 1e-13);
                for (m, h) in pt.hessian[k].iter().enumerate() {
                    let expected = if k == m { 1.0 / rr } else { 0.0 };
                    assert!((h - expected).abs() < 1e-15, "{pt:?}");
                }
            }
            let rho = (p[0] - v[0]).hypot(p[1] - v[1]);
            let w = (1.0 + (rho / rr).powi(2)).sqrt();
            let [k1, k2] = pt.principal_curvatures();
            assert!((k1 - 1.0 / (rr * w.powi(3))).abs() < 1e-15);
            assert!((k2 - 1.0 / (rr * w)).abs() < 1e-15);
            let n = pt.normal();
            assert!((n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0).abs() < 1e-15);
        }
    }

    /// Through every transition of every ring Z, Z′ and Z″ are continuous: the two one-sided
    /// limits (the surface's law at the arc's end, the transition at s = 0 or 1) agree to
    /// rounding, with the pad down and lifted. Everywhere, the law's derivatives agree with its
    /// own central differences (so the jets are the law's derivatives, not numbers beside it).
    #[test]
    fn the_transitions_keep_velocity_and_acceleration() {
        let layout = case();
        for r in [45.0, 60.0, 70.0, 85.0, 99.0] {
            for lift in [0.0, 2.0] {
                let law = layout.ring(r, lift, 5.0).unwrap();
                let arcs = law.arcs().to_vec();
                assert_eq!(arcs.len(), 4);
                for (k, &(i, _, to)) in arcs.iter().enumerate() {
                    let (j, next, _) = arcs[(k + 1) % 4];
                    let next = if k == 3 { next + 2.0 * PI } else { next };
                    for (edge, segment) in [(to, i), (next, j)] {
                        let on = law.on_segment(segment, edge);
                        let quintic = transition(
                            law.on_segment(i, to),
                            law.on_segment(j, next),
                            to,
                            next,
                            edge,
                            lift,
                        );
                        for d in 0..3 {
                            let scale = on[d].abs().max(1.0);
                            assert!(
                                (quintic[d] - on[d]).abs() <= 1e-12 * scale,
                                "r {r} lift {lift} d{d}: {} vs {}",
                                quintic[d],
                                on[d]
                            );
                        }
                    }
                }
                let h = 1e-5;
                for k in 0..200 {
                    let phi = 2.0 * PI * (k as f64 + 0.37) / 200.0;
                    let (a, b, c) = (law.at(phi - h), law.at(phi), law.at(phi + h));
                    let d1 = (c[0] - a[0]) / (2.0 * h);
                    let d2 = (c[0] - 2.0 * b[0] + a[0]) / (h * h);
                    assert!((d1 - b[1]).abs() < 1e-6 * b[1].abs().max(1.0), "{phi}");
                    assert!((d2 - b[2]).abs() < 1e-3 * b[2].abs().max(1.0), "{phi}");
                }
            }
        }
    }

    /// The case's rings: four identical segments a quarter turn apart give Z only the
    /// harmonics 4, 8, 12, … (the others vanish to rounding, 1e-12 of the largest), and the
    /// amplitudes carry Z's variance over the turn (Parseval: Σ A_m²/2 equals the samples'
    /// variance to 1e-9 of it with 128 harmonics of a C² law). Printed with `--nocapture`:
    /// the table of the docs.
    #[test]
    fn the_case_has_only_the_layouts_harmonics() {
        let layout = case();
        for r in [42.0, 55.0, 70.0, 85.0, 98.0] {
            let law = layout.ring(r, 0.0, 5.0).unwrap();
            let samples = 4096;
            let z = law.samples(samples);
            let mean = z.iter().sum::<f64>() / samples as f64;
            let variance = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / samples as f64;
            let (lo, hi) = z
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            let amplitudes = harmonics(&z, 2047);
            let largest = amplitudes.iter().fold(0.0_f64, |m, &a| m.max(a));
            for (k, a) in amplitudes.iter().enumerate() {
                if (k + 1) % 4 != 0 {
                    assert!(*a <= 1e-12 * largest, "r {r} m {}: {a}", k + 1);
                }
            }
            let energy: f64 = amplitudes.iter().take(128).map(|a| a * a / 2.0).sum();
            assert!(
                (energy - variance).abs() <= 1e-9 * variance,
                "r {r}: {energy} vs {variance}"
            );
            println!(
                "r {r} mm: Z from {lo:.4} to {hi:.4} mm (PV {:.4}); A4 {:.4}, A8 {:.5}, A12 {:.6} mm",
                hi - lo,
                amplitudes[3],
                amplitudes[7],
                amplitudes[11]
            );
        }
        // The pad reaches the segments from rings up to its radius off them.
        assert!(layout.ring(34.9, 0.0, 5.0).is_none() && layout.ring(105.1, 0.0, 5.0).is_none());
        assert!(layout.ring(36.0, 0.0, 5.0).is_some() && layout.ring(104.0, 0.0, 5.0).is_some());
    }

    /// B's law, the radial slope: on an arc it is the surface's ∇z·e_r; its first derivative
    /// agrees with central differences of s (1e-7 of its scale: the differences' own error at
    /// h = 1e-5), its second with differences of s′ (1e-6); through every transition s, s′
    /// and s″ are continuous to 1e-9 of their scale (s″'s own differences, 1e-10, on each
    /// side).
    #[test]
    fn the_radial_slope_is_continuous() {
        let layout = case();
        for r in [37.0, 55.0, 70.0, 98.0, 103.0] {
            let law = layout.ring(r, 1.0, 5.0).unwrap();
            let scale = (0..720)
                .map(|k| law.radial_slope(k as f64 * PI / 360.0))
                .fold([1e-3_f64; 3], |m, s| {
                    [0, 1, 2].map(|d| m[d].max(s[d].abs()))
                });
            // s‴'s bound, for how far s″ moves across the 2e-9 rad stepped over.
            let third = (0..720)
                .map(|k| {
                    let phi = k as f64 * PI / 360.0;
                    (law.radial_slope(phi + 1e-4)[2] - law.radial_slope(phi)[2]).abs() / 1e-4
                })
                .fold(0.0_f64, f64::max);
            for &(i, from, to) in law.arcs() {
                let mid = 0.5 * (from + to);
                let (s, c) = mid.sin_cos();
                let g = layout.point(i, [r * c, r * s]).gradient;
                assert!((law.radial_slope(mid)[0] - (g[0] * c + g[1] * s)).abs() < 1e-15);
                for edge in [from, to] {
                    let (before, after) =
                        (law.radial_slope(edge - 1e-9), law.radial_slope(edge + 1e-9));
                    for d in 0..3 {
                        // Over 2e-9 rad each value moves by its derivative times that.
                        let drift = 2.0 * 2e-9 * if d < 2 { scale[d + 1] } else { third };
                        assert!(
                            (before[d] - after[d]).abs() <= 1e-9 * scale[d] + drift,
                            "r {r} d{d} at {edge}: {} vs {}",
                            before[d],
                            after[d]
                        );
                    }
                }
            }
            let h = 1e-5;
            for k in 0..100 {
                let phi = 2.0 * PI * (k as f64 + 0.29) / 100.0;
                let (a, b, c) = (
                    law.radial_slope(phi - h),
                    law.radial_slope(phi),
                    law.radial_slope(phi + h),
                );
                assert!(
                    ((c[0] - a[0]) / (2.0 * h) - b[1]).abs() < 1e-7 * scale[1],
                    "{r} {phi}"
                );
                assert!(
                    ((c[1] - a[1]) / (2.0 * h) - b[2]).abs() < 1e-6 * scale[2],
                    "{r} {phi}"
                );
            }
        }
    }
}
