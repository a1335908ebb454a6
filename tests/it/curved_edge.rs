//! The linear edge pressure on a sphere against an independent 3-D model of the conforming
//! contact.
//!
//! The library solves the pad's balance in the developed plane (arc lengths from the vertex
//! in place of radii, the pressure linear in u = s·cos φ). The model here solves it on the
//! sphere itself: the contact C is the set of surface points within geodesic distance r_t of
//! the pad centre P₀ and inside the part's edge (r ≤ r_m); a rigid pad tilted about a tangent
//! axis through P₀ presses it along the normal in proportion to ξ = (X − P₀)·e, e the unit
//! meridional tangent at P₀ (on a sphere, the normal component of a small rotation's
//! displacement is exactly linear in ξ); the head's force is the nominal pressure over the
//! whole geodesic disc, F = 2πρ²·(1 − cos(r_t/ρ)); the balances are those of the plane with
//! ξ for x − r1 and the sphere's area element. The moments ∫ξ^k dA over C (cut at a lift
//! line ξ ≥ ξ0) are adaptive quadratures over r of the ring's arc, whose ends (the geodesic
//! ball's and the lift line's) and whose ∫cos^k φ dφ are exact; the lift line is found by
//! bisection. The removal is the 3-D sliding-speed quadrature of `curved_removal`, weighted
//! by the pressure at each surface point.
//!
//! The difference between the two is the developed plane's approximation, not rounding: the
//! test states its measured size (docs/MODEL.md quotes it) and checks that it vanishes as the
//! sphere flattens.

use crate::common::http::{app, post_json};
use crate::common::{adaptive_integral, fixture_path, numbers};
use crate::curved_removal::{dot, sub, Case, Shape};
use preston::physics::{removal_rate_nm_per_min, PressureModel, Process, ProcessSpec};
use serde_json::json;
use std::f64::consts::PI;

const RM: f64 = 50.0;
const RT: f64 = 10.0;

/// The pressure on the sphere with the pad at r1, relative to nominal.
struct SpherePressure {
    p0: [f64; 3],
    e: [f64; 3],
    /// p = max(0, level + slope·ξ).
    level: f64,
    slope: f64,
}

impl SpherePressure {
    fn at(&self, x: [f64; 3]) -> f64 {
        let xi = dot(sub(x, self.p0), self.e);
        (self.level + self.slope * xi).max(0.0)
    }
}

struct Contact {
    shape: Shape,
    r1: f64,
    p0: [f64; 3],
    e: [f64; 3],
    rho: f64,
}

impl Contact {
    fn new(radius: f64, r1: f64) -> Contact {
        let shape = Shape::sphere(radius);
        let slope = shape.slope(r1);
        let norm = slope.hypot(1.0);
        Contact {
            shape,
            r1,
            p0: shape.point(r1, 0.0),
            e: [1.0 / norm, 0.0, slope / norm],
            rho: radius.abs(),
        }
    }

    /// The ring at r's part of C beyond ξ ≥ `from`: ∫(ξ − from)^k dφ for k = 0, 1, 2 (from
    /// = −∞ gives ∫ξ^k dφ).
    fn ring(&self, r: f64, from: f64) -> [f64; 3] {
        let z = self.shape.sag(r);
        let z1 = self.p0[2];
        // ξ = α + β·cos φ.
        let alpha = -self.r1 * self.e[0] + (z - z1) * self.e[2];
        let beta = r * self.e[0];
        // Geodesic ball: the polar angles a, a1 of X and P₀ seen from the centre O and the
        // pad's α = r_t/ρ satisfy cos α ≤ cos a·cos a1 + sin a·sin a1·cos φ (spherical law of
        // cosines), i.e. sin²(φ/2) ≤ sin((α + d)/2)·sin((α − d)/2)/(sin a·sin a1), d = a − a1,
        // written so that nothing cancels near tangency.
        let (polar, polar1) = ((r / self.rho).asin(), (self.r1 / self.rho).asin());
        let (pad, d) = (RT / self.rho, polar - polar1);
        let h = (0.5 * (pad + d)).sin() * (0.5 * (pad - d)).sin() / (polar.sin() * polar1.sin());
        let ball = 2.0 * h.clamp(0.0, 1.0).sqrt().asin();
        let lift = if from.is_finite() {
            ((from - alpha) / beta).clamp(-1.0, 1.0).acos()
        } else {
            PI
        };
        let shift = if from.is_finite() { from } else { 0.0 };
        let phi = ball.min(lift);
        if phi <= 0.0 {
            return [0.0; 3];
        }
        let (s, s2) = (phi.sin(), (2.0 * phi).sin());
        let a = alpha - shift;
        [
            2.0 * phi,
            2.0 * (a * phi + beta * s),
            2.0 * (a * a * phi + 2.0 * a * beta * s + beta * beta * (0.5 * phi + 0.25 * s2)),
        ]
    }

    /// ∫(ξ − from)^k dA over C with ξ ≥ from.
    fn moments(&self, from: f64) -> [f64; 3] {
        let s1 = self.rho * (self.r1 / self.rho).asin();
        let lo = self.rho * ((s1 - RT) / self.rho).sin();
        let hi = (self.rho * ((s1 + RT) / self.rho).sin()).min(RM);
        let mut out = [0.0; 3];
        for (k, value) in out.iter_mut().enumerate() {
            let f = |r: f64| {
                let area = r * self.shape.slope(r).hypot(1.0);
                area * self.ring(r, from)[k]
            };
            // 1e-10 of the pad's ∫|ξ|^k dA scale: the arc ends' cosines carry ~1e-15 of noise,
            // which acos amplifies near tangency; far finer than the differences measured.
            *value = adaptive_integral(&f, lo, hi, 1e-10 * PI * RT.powi(k as i32 + 2));
        }
        out
    }

    /// The balanced pressure (see the module docs).
    fn pressure(&self, kappa: f64) -> SpherePressure {
        let force = 2.0 * PI * self.rho * self.rho * (1.0 - (RT / self.rho).cos());
        let [area, first, second] = self.moments(f64::NEG_INFINITY);
        let centroid = first / area;
        let inertia = second - first * first / area;
        let b = -kappa * force * centroid / inertia;
        let level = force / area - b * centroid;
        // The least ξ on C: the meridian point a pad radius inward.
        let s1 = self.rho * (self.r1 / self.rho).asin();
        let inner = self
            .shape
            .point(self.rho * ((s1 - RT) / self.rho).sin(), 0.0);
        let least = dot(sub(inner, self.p0), self.e);
        let pressure = |level, slope| SpherePressure {
            p0: self.p0,
            e: self.e,
            level,
            slope,
        };
        if level + b * least >= 0.0 {
            return pressure(level, b);
        }
        // Lifted: the triangular load's centroid at (1 − κ)·ξ_c.
        let target = (1.0 - kappa) * centroid;
        let outer = self.shape.point(RM, 0.0);
        let (mut lo, mut hi) = (least, dot(sub(outer, self.p0), self.e));
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            let [_, d, n] = self.moments(mid);
            if mid + n / d < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let x0 = 0.5 * (lo + hi);
        let d = self.moments(x0)[1];
        pressure(-force / d * x0, force / d)
    }
}

fn case(radius: f64, workpiece_rpm: f64, tool_rpm: f64) -> Case {
    Case {
        shape: Shape::sphere(radius),
        workpiece_rpm,
        tool_rpm,
        tool_radius: RT,
        workpiece_radius: RM,
        vertical: false,
    }
}

fn linear(case: &Case, kappa: f64) -> Process {
    Process::new(ProcessSpec {
        pressure_model: PressureModel::Linear {
            pad_moment_share: kappa,
        },
        ..case.spec()
    })
    .unwrap()
}

/// The worst difference over the removal functions of one sphere, relative to each one's peak:
/// overhangs of 0 to 3.5 mm of arc and two lifted pads, κ 1 and 0.5, at the given speeds.
fn worst_difference(radius: f64, speeds: &[(f64, f64)]) -> Worst {
    let mut worst = Worst {
        overhanging: 0.0,
        lifted: 0.0,
    };
    for &(workpiece_rpm, tool_rpm) in speeds {
        let case = case(radius, workpiece_rpm, tool_rpm);
        for kappa in [1.0, 0.5] {
            let process = linear(&case, kappa);
            let surface = &process.part().surface;
            let edge_arc = surface.arc_length_mm(RM);
            // Overhangs of 0 to 3.5 mm (the pad still pressed all over), then pads lifted on
            // their inner side: 8 mm over, and for κ = 0.5 12 mm over.
            let mut arcs: Vec<(f64, bool)> = [0.0, 0.5, 1.0, 2.0, 3.0, 3.5]
                .iter()
                .map(|o| (edge_arc - RT + o, false))
                .collect();
            arcs.push((edge_arc - 2.0, true));
            if kappa < 1.0 {
                arcs.push((edge_arc + 2.0, true));
            }
            for (arc, lifted) in arcs {
                let r1 = surface.radius_at_arc_length(arc);
                let pressure = Contact::new(radius, r1).pressure(kappa);
                let radii: Vec<f64> = (0..=40)
                    .map(|i| (r1 - RT + 2.0 * RT * i as f64 / 40.0).min(RM))
                    .collect();
                let reference: Vec<f64> = radii
                    .iter()
                    .map(|&r| case.rate_pressed(r, r1, &|x| pressure.at(x)))
                    .collect();
                let peak = reference.iter().cloned().fold(0.0, f64::max);
                let mut here: f64 = 0.0;
                for (&r, want) in radii.iter().zip(&reference) {
                    let got = removal_rate_nm_per_min(&process, r, r1);
                    assert!(
                        got.is_finite() && got >= 0.0,
                        "R {radius} r1 {r1} r {r}: {got}"
                    );
                    here = here.max((got - want).abs() / peak);
                }
                let slot = if lifted {
                    &mut worst.lifted
                } else {
                    &mut worst.overhanging
                };
                *slot = slot.max(here);
            }
        }
    }
    worst
}

/// The largest difference relative to the removal function's peak, over pads pressed all
/// over and over lifted pads.
#[derive(Debug)]
struct Worst {
    overhanging: f64,
    lifted: f64,
}

const BOTH_ETAS: [(f64, f64); 2] = [(-10.0, 200.0), (200.0, 200.0)];

/// The developed-plane balance against the sphere's own on a steep sphere (R = ±100 mm, the
/// paper's 50 mm part, 30° of slope at the edge), at η = +0.05 and −1. Measured: 2.42e-3 of
/// the peak for overhangs to 3.5 mm, 4.35e-2 for lifted pads (docs/MODEL.md); the bounds
/// are those figures rounded up.
#[test]
fn linear_pressure_on_a_steep_sphere_against_the_3d_balance() {
    // (The concave sphere at one speed: its figures are the convex one's, mirrored.)
    for (radius, speeds) in [(100.0, &BOTH_ETAS[..]), (-100.0, &BOTH_ETAS[..1])] {
        let worst = worst_difference(radius, speeds);
        assert!(
            worst.overhanging <= 2.5e-3 && worst.lifted <= 4.5e-2,
            "R {radius}: {worst:?}"
        );
    }
}

/// The difference shrinks as 1/R² as the sphere flattens (η = +0.05): measured 1.29e-4 and
/// 2.29e-3 at R = 400 mm, 1.29e-6 and 2.36e-5 at R = 4000 mm.
#[test]
fn linear_pressure_on_flatter_spheres_against_the_3d_balance() {
    for (radius, overhanging, lifted) in [(400.0, 1.5e-4, 2.5e-3), (4000.0, 1.5e-6, 2.5e-5)] {
        let worst = worst_difference(radius, &BOTH_ETAS[..1]);
        assert!(
            worst.overhanging <= overhanging && worst.lifted <= lifted,
            "R {radius}: {worst:?}"
        );
    }
}

/// On a sphere as on a plane: κ = 0 is the constant-force model (both balance the developed
/// lens), a pad wholly on the part is uniformly pressed, and through the lift's onset and deep
/// in it the removal is finite, never negative and continuous in the pad's position.
#[test]
fn linear_on_a_sphere_reduces_to_the_other_models_and_is_continuous() {
    let case = case(-150.0, -10.0, 200.0);
    let constant = Process::new(ProcessSpec {
        pressure_model: PressureModel::ConstantForce,
        ..case.spec()
    })
    .unwrap();
    let uniform = Process::new(case.spec()).unwrap();
    let level = linear(&case, 0.0);
    let gimbal = linear(&case, 1.0);
    let radii: Vec<f64> = (0..=200).map(|i| 30.0 + 20.0 * i as f64 / 200.0).collect();
    let surface = &uniform.part().surface;
    let edge_arc = surface.arc_length_mm(RM);
    for overhang in [0.0, 1.0, 3.5, 6.0, 9.0] {
        let r1 = surface.radius_at_arc_length(edge_arc - RT + overhang);
        for &r in &radii {
            let (a, b) = (
                removal_rate_nm_per_min(&level, r, r1),
                removal_rate_nm_per_min(&constant, r, r1),
            );
            assert!(
                (a - b).abs() <= 1e-12 * b.abs(),
                "r1 {r1} r {r}: {a} vs {b}"
            );
        }
    }
    for r1 in [0.0, 12.0, surface.radius_at_arc_length(edge_arc - RT)] {
        for &r in &radii {
            assert_eq!(
                removal_rate_nm_per_min(&gimbal, r, r1),
                removal_rate_nm_per_min(&uniform, r, r1),
                "r1 {r1} r {r}"
            );
        }
    }
    for kappa in [1.0, 0.5] {
        let process = linear(&case, kappa);
        let onset = process.pass_reach_mm();
        let deep = surface.radius_at_arc_length(edge_arc - 2.0);
        for r1 in [onset - 1e-6, onset, deep] {
            let peak = radii
                .iter()
                .map(|&r| removal_rate_nm_per_min(&process, r, r1))
                .fold(0.0, f64::max);
            for &r in &radii {
                let (a, b) = (
                    removal_rate_nm_per_min(&process, r, r1),
                    removal_rate_nm_per_min(&process, r, r1 + 1e-6),
                );
                assert!(a.is_finite() && a >= 0.0, "κ {kappa} r1 {r1} r {r}: {a}");
                assert!(
                    (a - b).abs() <= 1e-6 * peak,
                    "κ {kappa} r1 {r1} r {r}: {a} vs {b}"
                );
            }
        }
    }
}

/// A linear pad on a sphere through the API: a plan for a uniform 100 nm over the whole part
/// (to the rim), its removal predicted back from its dwell, its program, the recommendation
/// and an η sweep.
#[tokio::test]
async fn a_linear_pad_on_a_sphere_plans_to_the_rim() {
    let app = app();
    let process = json!({"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10,
                         "tool_rpm": 200, "pressure_model": "linear", "pad_moment_share": 1});
    let sphere = json!({"kind": "sphere", "radius_of_curvature_mm": -150});
    let grid = json!({"start_mm": 0, "stop_mm": 50, "count": 101});
    let ask = |path: &'static str, body: serde_json::Value| {
        let app = app.clone();
        async move {
            let reply = post_json(&app, path, body.to_string()).await;
            assert_eq!(reply.status, 200, "{path}: {}", reply.text());
            reply.json()
        }
    };
    let mut program: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(fixture_path("program_sphere.json")).unwrap(),
    )
    .unwrap();
    // A free gimbal cannot sit at the edge itself: positions stop 0.25 mm short of it. The
    // plan keeps to the fixture's machine, so that its program runs.
    let positions: Vec<f64> = (0..200).map(|i| 0.25 * i as f64).collect();
    let plan = ask(
        "/v1/optimize",
        json!({"process": process, "surface": sphere, "positions_mm": positions,
               "target": {"uniform_depth_nm": 100}, "radial_grid": grid,
               "clear_aperture": {"inner_mm": 0, "outer_mm": 50},
               "machine": program["machine"], "tool": program["tool"]}),
    )
    .await;
    let nonuniformity = plan["metrics"]["nonuniformity"].as_f64().unwrap();
    assert!(nonuniformity < 0.05, "{nonuniformity}");
    let removal = numbers(&plan["removal_nm"]);
    assert!(removal[100] > 95.0, "rim {}", removal[100]);
    let dwell = json!({"positions_mm": positions, "dwell_s": plan["dwell"]["dwell_s"]});
    let predicted = ask(
        "/v1/predict",
        json!({"process": process, "surface": sphere, "dwell": dwell, "radial_grid": grid}),
    )
    .await;
    for (a, b) in numbers(&predicted["removal_nm"]).iter().zip(&removal) {
        assert!((a - b).abs() <= 1e-9 * 100.0, "{a} vs {b}");
    }
    program["process"] = process.clone();
    program["surface"] = sphere.clone();
    program["dwell"] = dwell;
    let program = ask("/v1/program", program).await;
    let planned: f64 = numbers(&plan["dwell"]["dwell_s"]).iter().sum();
    let run = program["total_time_s"].as_f64().unwrap();
    assert!(
        (run - planned).abs() <= 1e-9 * planned,
        "{run} vs {planned}"
    );
    ask(
        "/v1/recommend",
        json!({"process": process, "surface": sphere}),
    )
    .await;
    let sweep = ask(
        "/v1/studies/eta-sweep",
        json!({"process": process, "surface": sphere, "etas": [-1, 0.05]}),
    )
    .await;
    assert_eq!(sweep["points"].as_array().unwrap().len(), 2, "{sweep}");
}
