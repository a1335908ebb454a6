//! Removal on curved parts against an independent 3-D model written here: surface points and
//! normals in 3-D from this file's own sag formulas, sliding velocities from the cross products
//! ω_w·ẑ × X − ω_t·a × (X − P₀) projected on the tangent plane, the contact decided point by
//! point (sphere: the geodesic distance |R|·∠(X − O, P₀ − O) ≤ r_t; asphere: the chord ball of
//! the mean-curvature sphere, the documented contact), and adaptive Gauss–Kronrod quadrature
//! over the whole azimuth [−π, π] of |v_t|·[in contact]. None of the library's reduction
//! (closed-form arc ends, the |v_t|² polynomial, its quadrature) is used.
//!
//! Tolerance: 1e-6 of the removal function's peak for that pad position (the bound).
//! The reference quadrature runs to 1e-10 of the largest speed times 2π, so its own error is
//! far below that.

use std::f64::consts::PI;

use crate::common::{adaptive_integral, paper_spec};
use preston::physics::{
    removal_rate_nm_per_min, Orientation, Part, PressureModel, Process, ProcessSpec,
};
use preston::surface::{PolynomialTerm, Surface, SurfaceSpec};

/// A surface as this test knows it: z = c·r²/(1 + √(1 − (1+k)c²r²)) + a4·r⁴ + a6·r⁶.
#[derive(Debug, Clone, Copy)]
pub struct Shape {
    radius: f64,
    conic: f64,
    a4: f64,
    a6: f64,
}

impl Shape {
    pub fn sphere(radius: f64) -> Shape {
        Shape {
            radius,
            conic: 0.0,
            a4: 0.0,
            a6: 0.0,
        }
    }
    fn is_sphere(&self) -> bool {
        self.conic == 0.0 && self.a4 == 0.0 && self.a6 == 0.0
    }
    pub fn sag(&self, r: f64) -> f64 {
        let c = 1.0 / self.radius;
        c * r * r / (1.0 + (1.0 - (1.0 + self.conic) * c * c * r * r).sqrt())
            + self.a4 * r.powi(4)
            + self.a6 * r.powi(6)
    }
    pub fn slope(&self, r: f64) -> f64 {
        let c = 1.0 / self.radius;
        c * r / (1.0 - (1.0 + self.conic) * c * c * r * r).sqrt()
            + 4.0 * self.a4 * r.powi(3)
            + 6.0 * self.a6 * r.powi(5)
    }
    fn second(&self, r: f64) -> f64 {
        let c = 1.0 / self.radius;
        c / (1.0 - (1.0 + self.conic) * c * c * r * r).powf(1.5)
            + 12.0 * self.a4 * r * r
            + 30.0 * self.a6 * r.powi(4)
    }
    fn spec(&self) -> SurfaceSpec {
        if self.is_sphere() {
            return SurfaceSpec::Sphere {
                radius_of_curvature_mm: self.radius,
            };
        }
        SurfaceSpec::Asphere {
            radius_of_curvature_mm: self.radius,
            conic_constant: self.conic,
            coefficients: vec![
                PolynomialTerm {
                    power: 4,
                    value: self.a4,
                },
                PolynomialTerm {
                    power: 6,
                    value: self.a6,
                },
            ],
        }
    }
    pub fn point(&self, r: f64, phi: f64) -> [f64; 3] {
        [r * phi.cos(), r * phi.sin(), self.sag(r)]
    }
    /// Unit normal toward the tool at (r, φ): the gradient of z − sag(√(x² + y²)), normalised.
    fn normal(&self, r: f64, phi: f64) -> [f64; 3] {
        let p = self.slope(r);
        let n = [-p * phi.cos(), -p * phi.sin(), 1.0];
        let len = dot(n, n).sqrt();
        [n[0] / len, n[1] / len, n[2] / len]
    }
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[derive(Debug, Clone, Copy)]
pub struct Case {
    pub shape: Shape,
    pub workpiece_rpm: f64,
    pub tool_rpm: f64,
    pub tool_radius: f64,
    pub workpiece_radius: f64,
    pub vertical: bool,
}

impl Case {
    pub fn spec(&self) -> ProcessSpec {
        ProcessSpec {
            workpiece_radius_mm: self.workpiece_radius,
            tool_radius_mm: self.tool_radius,
            workpiece_rpm: self.workpiece_rpm,
            tool_rpm: self.tool_rpm,
            part: Part {
                surface: Surface::new(&self.shape.spec()).unwrap(),
                orientation: if self.vertical {
                    Orientation::Vertical
                } else {
                    Orientation::Normal
                },
            },
            ..paper_spec(1.0, 1.0)
        }
    }

    /// Is the surface point (r, φ) under the pad centred at r1?
    fn in_contact(&self, r: f64, phi: f64, r1: f64) -> bool {
        let s = &self.shape;
        let x = s.point(r, phi);
        let p0 = s.point(r1, 0.0);
        if s.is_sphere() {
            let centre = [0.0, 0.0, s.radius];
            let (u, w) = (sub(x, centre), sub(p0, centre));
            // atan2(|u × w|, u·w): acos of a cosine near 1 would lose half the digits, which
            // near tangency (where the arc end moves like the square root) shows at 1e-6.
            let c = cross(u, w);
            let angle = dot(c, c).sqrt().atan2(dot(u, w));
            s.radius.abs() * angle <= self.tool_radius
        } else {
            // The mean-curvature sphere's chord for an arc of r_t.
            let theta = s.slope(r1).atan();
            let meridional = s.second(r1) * theta.cos().powi(3);
            let sagittal = if r1 > 0.0 {
                theta.sin() / r1
            } else {
                s.second(0.0)
            };
            let h = 0.5 * (meridional + sagittal);
            let chord = 2.0 * (0.5 * h * self.tool_radius).sin() / h;
            let d = sub(x, p0);
            dot(d, d).sqrt() <= chord
        }
    }

    /// The reference rate in nm/min at r with the pad at r1, at the nominal pressure.
    pub fn rate(&self, r: f64, r1: f64) -> f64 {
        self.rate_pressed(r, r1, &|_| 1.0)
    }

    /// The reference rate in nm/min at r with the pad at r1, the pressure at the surface point
    /// X being `pressure(X)` times the nominal pressure.
    pub fn rate_pressed(&self, r: f64, r1: f64, pressure: &dyn Fn([f64; 3]) -> f64) -> f64 {
        let rpm = 2.0 * PI / 60.0;
        let (ww, wt) = (self.workpiece_rpm * rpm, self.tool_rpm * rpm);
        let s = &self.shape;
        let p0 = s.point(r1, 0.0);
        let axis = if self.vertical {
            [0.0, 0.0, 1.0]
        } else {
            s.normal(r1, 0.0)
        };
        let speed = |phi: f64| {
            if !self.in_contact(r, phi, r1) {
                return 0.0;
            }
            let x = s.point(r, phi);
            let workpiece = cross([0.0, 0.0, ww], x);
            let tool = cross([wt * axis[0], wt * axis[1], wt * axis[2]], sub(x, p0));
            let v = sub(workpiece, tool);
            let m = s.normal(r, phi);
            let along = dot(v, m);
            let t = [
                v[0] - along * m[0],
                v[1] - along * m[1],
                v[2] - along * m[2],
            ];
            pressure(x) * dot(t, t).sqrt()
        };
        // The contact is one arc about φ = 0 (the distance grows with |φ|); its end is found by
        // bisection on the point test, so that no quadrature node can step over a narrow arc.
        let edge = if !self.in_contact(r, 0.0, r1) {
            return 0.0;
        } else if self.in_contact(r, PI, r1) {
            PI
        } else {
            let (mut inside, mut outside) = (0.0, PI);
            while outside - inside > 1e-15 {
                let mid = 0.5 * (inside + outside);
                if self.in_contact(r, mid, r1) {
                    inside = mid;
                } else {
                    outside = mid;
                }
                if mid == inside && mid == outside {
                    break;
                }
            }
            inside
        };
        let vmax = ww.abs() * (r + r1 + self.tool_radius) + wt.abs() * 2.0 * self.tool_radius;
        let integral = adaptive_integral(&speed, -edge, edge, 1e-10 * vmax * 2.0 * edge);
        let spec = self.spec();
        spec.preston_coefficient_m2_per_n * spec.pressure_kpa * 1e3 / (2.0 * PI)
            * integral
            * 1e6
            * 60.0
    }
}

fn uniform(rng: &mut fastrand::Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.f64()
}

/// ±x, the sign at random.
fn signed(x: f64, rng: &mut fastrand::Rng) -> f64 {
    if rng.bool() {
        x
    } else {
        -x
    }
}

fn random_case(rng: &mut fastrand::Rng, asphere: bool) -> Case {
    let magnitude = 10f64.powf(uniform(rng, 20f64.log10(), 3.0));
    let radius = signed(magnitude, rng);
    let tool_radius = uniform(rng, 1.0, (0.3 * magnitude).min(12.0));
    // The edge plus two pad radii of arc must stay on the hemisphere (with room to spare).
    let max_edge_arc = 0.9 * (magnitude * PI / 2.0 - 2.0 * tool_radius);
    let edge_arc = uniform(rng, 0.3, 0.9) * max_edge_arc.min(80.0);
    let workpiece_radius = magnitude * (edge_arc / magnitude).sin();
    let shape = if asphere {
        // Departures of at most ~1/20 of the base curvature over the part.
        let scale = 1.0 / (magnitude * workpiece_radius.powi(2));
        Shape {
            radius,
            conic: uniform(rng, -1.5, 0.5),
            a4: uniform(rng, -0.05, 0.05) * scale,
            a6: uniform(rng, -0.05, 0.05) * scale / workpiece_radius.powi(2),
        }
    } else {
        Shape::sphere(radius)
    };
    let tool_rpm = signed(uniform(rng, 20.0, 300.0), rng);
    let workpiece_rpm = match rng.usize(0..4) {
        0 => tool_rpm, // η = −1
        1 => -0.05 * tool_rpm,
        _ => signed(uniform(rng, 5.0, 300.0), rng),
    };
    let mut case = Case {
        shape,
        workpiece_rpm,
        tool_rpm,
        tool_radius,
        workpiece_radius,
        vertical: rng.usize(0..4) == 0,
    };
    // A conic with k > 0 ends before the sphere would: bring the edge in until the pad's reach
    // lies within the surface's domain.
    while Process::new(case.spec()).is_err() {
        case.workpiece_radius *= 0.9;
    }
    case
}

/// The production rate at r with the pad at r1, and the case's peak for that pad position.
fn production<'a>(process: &'a Process, case: &Case, r1: f64) -> (impl Fn(f64) -> f64 + 'a, f64) {
    let rate = move |r: f64| removal_rate_nm_per_min(process, r, r1);
    let peak = (0..=64)
        .map(|i| {
            let r = (r1 - case.tool_radius + 2.0 * case.tool_radius * i as f64 / 64.0)
                .clamp(0.0, case.workpiece_radius);
            rate(r)
        })
        .fold(0.0, f64::max);
    (rate, peak)
}

#[test]
fn curved_removal_matches_an_independent_3d_model() {
    let mut rng = fastrand::Rng::with_seed(20261122);
    let mut compared = 0;
    let mut worst: f64 = 0.0;
    for index in 0..560 {
        let case = random_case(&mut rng, index % 2 == 1);
        let process = Process::new(case.spec()).unwrap_or_else(|e| panic!("{case:?}: {e}"));
        let surface = &process.part().surface;
        let r1 = match index % 7 {
            0 => 0.0,
            _ => uniform(&mut rng, 0.0, process.max_tool_position_mm()),
        };
        let (rate, peak) = production(&process, &case, r1);
        // r: anywhere in the band, the centre, and the two tangencies along the meridian.
        let s1 = surface.arc_length_mm(r1);
        let tangent_out = surface.radius_at_arc_length(s1 + case.tool_radius);
        let tangent_in = surface.radius_at_arc_length(s1 - case.tool_radius);
        let mut radii = vec![
            uniform(
                &mut rng,
                (r1 - case.tool_radius).max(0.0),
                (r1 + case.tool_radius).min(case.workpiece_radius),
            ),
            0.0,
        ];
        // (With the pad on the axis every ring is wholly in or out, and the removal jumps at
        // r = r_t, where the library takes the jump's midpoint: no test point there.)
        for r in [tangent_out, tangent_in] {
            if r1 > 0.0 && r > 0.0 && r <= case.workpiece_radius {
                radii.push(r);
            }
        }
        for r in radii {
            let got = rate(r);
            let want = case.rate(r, r1);
            let scale = if peak > 0.0 {
                peak
            } else {
                // η = −1 with the pad on the axis of a sphere removes nothing at all.
                1e-300
            };
            let error = (got - want).abs() / scale;
            worst = worst.max(error);
            assert!(
                error <= 1e-6,
                "{case:?} r1 {r1} r {r}: {got} vs reference {want} (peak {peak})"
            );
            compared += 1;
        }
    }
    assert!(compared >= 1500, "{compared}");
    println!("{compared} comparisons, worst {worst:e} of the peak");
}

/// A sphere of radius ±1e9 mm is a plane to the digits the flat closed form carries.
#[test]
fn a_huge_sphere_is_the_flat_closed_form() {
    for (workpiece_rpm, tool_rpm) in [(-10.0, 200.0), (150.0, 150.0), (40.0, -90.0)] {
        let flat = Process::new(paper_spec(workpiece_rpm, tool_rpm)).unwrap();
        for radius in [1e9, -1e9] {
            let curved = Process::new(ProcessSpec {
                part: Part {
                    surface: Surface::new(&SurfaceSpec::Sphere {
                        radius_of_curvature_mm: radius,
                    })
                    .unwrap(),
                    orientation: Orientation::Normal,
                },
                ..paper_spec(workpiece_rpm, tool_rpm)
            })
            .unwrap();
            for r1 in [0.0, 3.0, 10.0, 27.5, 59.0] {
                let peak = (0..=100)
                    .map(|i| removal_rate_nm_per_min(&flat, i as f64 * 0.5, r1))
                    .fold(0.0, f64::max);
                for i in 0..=100 {
                    let r = i as f64 * 0.5;
                    let want = removal_rate_nm_per_min(&flat, r, r1);
                    let got = removal_rate_nm_per_min(&curved, r, r1);
                    assert!(
                        (got - want).abs() <= 1e-10 * peak,
                        "R {radius} r1 {r1} r {r}: {got} vs {want}"
                    );
                }
            }
        }
    }
}

/// A surface that cannot hold the pad at its farthest position is refused, naming the edge.
#[test]
fn a_sphere_too_small_for_the_reach_is_refused() {
    let spec = ProcessSpec {
        part: Part {
            surface: Surface::new(&SurfaceSpec::Sphere {
                radius_of_curvature_mm: 60.0,
            })
            .unwrap(),
            orientation: Orientation::Normal,
        },
        ..paper_spec(-10.0, 200.0)
    };
    // A 50 mm edge on R = 60 is 59.1 mm of arc, two 10 mm pads more 79.1 mm < 60·π/2 = 94.2
    // mm: it fits. A 58 mm edge is 78.8 mm of arc, 98.8 mm with the pads: it does not. A 61
    // mm edge is off the sphere.
    assert!(Process::new(spec.clone()).is_ok());
    let err = Process::new(ProcessSpec {
        workpiece_radius_mm: 58.0,
        ..spec.clone()
    })
    .unwrap_err();
    assert_eq!(err.field(), "workpiece_radius_mm", "{err}");
    let err = Process::new(ProcessSpec {
        workpiece_radius_mm: 61.0,
        pressure_model: PressureModel::ConstantForce,
        ..spec
    })
    .unwrap_err();
    assert_eq!(err.field(), "workpiece_radius_mm", "{err}");
}
