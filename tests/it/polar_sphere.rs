//! The pad point by point on a sphere turning on C (`physics::polar` over `physics::curved`),
//! against the independent, time-stepped integration of the executed motion on a sphere
//! (`polar_reference::depth_nm_on_sphere`: the points and the pad centre in 3-D, the contact
//! by geodesic distance, the sliding speed the tangential part of Ω·ẑ × X − ω2·a × (X − P₀))
//! and against the 1-D curved model it must average to.

use std::f64::consts::TAU;

use preston::physics::polar::{executed_blocks, PolarPad};
use preston::physics::{
    Motion, Orientation, Part, PressureModel, Process, ProcessSpec, RemovalKernel, RemovalOperator,
    SectorLaw,
};
use preston::surface::{Surface, SurfaceSpec};

use super::common::adaptive_integral;
use super::polar_reference::{depth_nm_on_sphere, Segment, Setup};

const K: f64 = 1e-13;
const KPA: f64 = 10.0;
const PART_RADIUS_MM: f64 = 40.0;
const TOOL_RADIUS_MM: f64 = 10.0;

fn surface(radius_mm: f64) -> Surface {
    Surface::new(&SurfaceSpec::Sphere {
        radius_of_curvature_mm: radius_mm,
    })
    .unwrap()
}

/// The arc length (mm) from the vertex to the radius `r_mm` on the sphere of radius
/// `radius_mm`: the reference's motion is given along the arc.
fn arc(radius_mm: f64, r_mm: f64) -> f64 {
    radius_mm.abs() * (r_mm / radius_mm.abs()).asin()
}

fn process(
    radius_mm: f64,
    workpiece_rpm: f64,
    tool_rpm: f64,
    pressure_model: PressureModel,
) -> Process {
    Process::new(ProcessSpec {
        workpiece_radius_mm: PART_RADIUS_MM,
        tool_radius_mm: TOOL_RADIUS_MM,
        workpiece_rpm,
        tool_rpm,
        preston_coefficient_m2_per_n: K,
        pressure_kpa: KPA,
        pressure_model,
        part: Part {
            surface: surface(radius_mm),
            orientation: Orientation::Normal,
        },
    })
    .unwrap()
}

/// K·P in nm/s per mm/s: the reference's scale.
fn scale() -> f64 {
    K * KPA * 1e3 * 1e6
}

/// Points over the part: 27 radii × 16 angles, offset from every symmetry line.
fn points() -> Vec<(f64, f64)> {
    (0..27)
        .flat_map(|i| {
            let r = 0.37 + i as f64 * 1.49;
            (0..16).map(move |j| {
                let t = 0.11 + j as f64 * TAU / 16.0;
                (r * t.cos(), r * t.sin())
            })
        })
        .filter(|(x, y)| x.hypot(*y) <= PART_RADIUS_MM)
        .collect()
}

/// The largest difference (nm) between `depths` at [`points`] and the reference's depth of
/// `segments` on the sphere of radius `radius_mm`, and the reference's peak. The reference
/// runs 1.6·10⁴ steps per C revolution at the fastest speed: its second-order rule leaves
/// ~1e-7 of the peak (measured on the plane against closed forms; the sphere changes the
/// integrand's smoothness nowhere).
fn against_reference(
    radius_mm: f64,
    tool_rpm: f64,
    start: f64,
    segments: &[Segment],
    depths: impl Fn(&[(f64, f64)]) -> Vec<f64>,
) -> (f64, f64) {
    let fastest = segments
        .iter()
        .map(Segment::fastest_rpm)
        .fold(0.0_f64, f64::max);
    let setup = Setup {
        part_radius_mm: PART_RADIUS_MM,
        pad_radius_mm: TOOL_RADIUS_MM,
        tool_rpm,
        scale_nm_per_mm: scale(),
        start_angle_rad: start,
    };
    let points = points();
    let reference =
        depth_nm_on_sphere(&setup, radius_mm, segments, &points, 1.6e4 * fastest / 60.0);
    let peak = reference.iter().cloned().fold(0.0, f64::max);
    assert!(peak > 0.0);
    let worst = depths(&points)
        .iter()
        .zip(&reference)
        .map(|(got, want)| (got - want).abs())
        .fold(0.0, f64::max);
    (worst, peak)
}

/// Rings and spirals at constant Ω on a convex and a concave sphere — partial turns, both
/// directions of C, the pad over the centre and over the edge, a spiral at constant speed
/// along the arc — agree with the time-stepped motion to 1e-6 of the peak depth.
#[test]
fn rings_and_spirals_on_a_sphere_match_the_time_stepped_motion() {
    let cases = [
        // sphere radius, workpiece rpm, tool rpm, r1 from, r1 to, start angle, turns
        (120.0, -37.0, 600.0, 21.0, 21.0, 0.4, 0.3),
        (-90.0, 37.0, 600.0, 6.0, 6.0, -1.0, 1.7),
        (-90.0, -15.0, 200.0, 35.0, 35.0, 1.3, 1.25), // over the edge
        (120.0, -37.0, 600.0, 2.0, 30.0, 0.4, 2.3),
        (-90.0, 45.0, -300.0, 33.0, 8.0, -1.0, 1.6),
    ];
    for (radius, workpiece_rpm, tool_rpm, from, to, start, turns) in cases {
        let pad = PolarPad::new(&process(
            radius,
            workpiece_rpm,
            tool_rpm,
            PressureModel::Uniform,
        ));
        let duration = turns * 60.0 / f64::abs(workpiece_rpm);
        let segment = if from == to {
            Segment::Ring {
                r1_mm: arc(radius, from),
                omega_rpm: workpiece_rpm,
                duration_s: duration,
            }
        } else {
            Segment::Spiral {
                r1_start_mm: arc(radius, from),
                r1_end_mm: arc(radius, to),
                omega_rpm: workpiece_rpm,
                duration_s: duration,
            }
        };
        let (worst, peak) = against_reference(radius, tool_rpm, start, &[segment], |points| {
            points
                .iter()
                .map(|&(x, y)| {
                    let (r, theta) = (x.hypot(y), y.atan2(x));
                    if from == to {
                        pad.ring_depth_nm(r, theta, from, start, duration)
                    } else {
                        pad.spiral_depth_nm(r, theta, (from, to), start, duration)
                    }
                })
                .collect()
        });
        assert!(
            worst <= 1e-6 * peak,
            "R {radius}, {workpiece_rpm} / {tool_rpm} rpm, {from} → {to} mm: {worst:e} nm \
             against a peak of {peak} nm"
        );
    }
}

/// A plan of four stations under a sector law on a sphere (stops at the ends, spirals across
/// the cells, each station's speeds its own) against the time-stepped motion with the
/// reference's own sector stepping: 1e-6 of the peak.
#[test]
fn a_sector_law_on_a_sphere_matches_the_time_stepped_motion() {
    let (radius, workpiece_rpm, tool_rpm) = (-150.0, 40.0, 500.0);
    let process = process(radius, workpiece_rpm, tool_rpm, PressureModel::Uniform);
    let omega = workpiece_rpm * TAU / 60.0;
    let stations = vec![4.0, 10.0, 16.0, 23.0];
    let dwell = vec![1.2, 0.9, 1.7, 1.1];
    let factors = [1.0, 0.55, 1.6, 0.8, 1.2];
    let factor = |j: usize, k: usize| factors[k] * (1.0 + 0.05 * j as f64);
    let law = SectorLaw::new(
        stations.len(),
        factors.len(),
        (0..stations.len())
            .flat_map(|j| (0..factors.len()).map(move |k| factor(j, k)))
            .collect(),
    )
    .unwrap();
    let motion = Motion::radial(stations).with_sector_law(law).unwrap();
    let segments: Vec<Segment> = motion
        .segments()
        .iter()
        .filter(|s| s.share() * dwell[s.station()] > 0.0)
        .map(|s| {
            let (from, to) = s.ends_mm();
            Segment::Sectors {
                r1_start_mm: arc(radius, from),
                r1_end_mm: arc(radius, to),
                omega_rpm: (0..factors.len())
                    .map(|k| workpiece_rpm * factor(s.station(), k))
                    .collect(),
                duration_s: s.share() * dwell[s.station()],
            }
        })
        .collect();
    let start = 0.4;
    let blocks = executed_blocks(&motion, &dwell, omega, start, &surface(radius));
    let pad = PolarPad::new(&process);
    let (worst, peak) = against_reference(radius, tool_rpm, start, &segments, |points| {
        pad.depth_nm(&blocks, points)
    });
    assert!(
        worst <= 1e-6 * peak,
        "{worst:e} nm against a peak of {peak} nm"
    );
}

/// Whole turns at constant Ω on a sphere leave the 1-D curved prediction at every angle:
/// R(r; r1)·T from `RemovalKernel` to 1e-9 relative (the arc's quadrature and the 1-D rule's
/// each hold 1e-10 of the largest speed), under every pressure model.
#[test]
fn whole_turns_on_a_sphere_leave_the_one_dimensional_removal_at_every_angle() {
    for model in [
        PressureModel::Uniform,
        PressureModel::ConstantForce,
        PressureModel::Linear {
            pad_moment_share: 0.6,
        },
    ] {
        let process = process(110.0, -12.0, 150.0, model);
        let pad = PolarPad::new(&process);
        let kernel = RemovalKernel::new(&process);
        let duration = 3.0 * 60.0 / 12.0;
        let peak = (0..60)
            .map(|i| kernel.rate_nm_per_s(i as f64 * 0.66, 17.0) * duration)
            .fold(0.0, f64::max);
        for r1 in [0.0, 4.0, 17.0, 33.0] {
            for i in 0..30 {
                let r = 0.5 + i as f64 * 1.35;
                let want = kernel.rate_nm_per_s(r, r1) * duration;
                for theta in [0.0, 1.1, -2.9, 3.1] {
                    let got = pad.ring_depth_nm(r, theta, r1, 0.7, duration);
                    assert!(
                        (got - want).abs() <= 1e-9 * peak,
                        "{model:?} r1 {r1} r {r} θ {theta}: {got} vs {want}"
                    );
                }
            }
        }
    }
}

/// A plan of four stations on a sphere with C at constant speed: the azimuthal mean of its
/// 2-D depth is the 1-D prediction (`RemovalOperator`, the curved model) to 1e-9 of the peak,
/// with the pressure uniform and under constant force (a linear pad's whole turns are
/// checked above; its pressure, solved at each instant, makes this quadrature slow), the mean
/// taken by the tests' adaptive Gauss–Kronrod rule over
/// θ.
#[test]
fn a_plan_on_a_sphere_averages_to_the_one_dimensional_removal() {
    for model in [PressureModel::Uniform, PressureModel::ConstantForce] {
        let process = process(-130.0, 30.0, -200.0, model);
        let omega = 30.0 * TAU / 60.0;
        let motion = Motion::radial(vec![6.0, 11.0, 15.0, 22.0]);
        let dwell = [2.5, 3.0, 1.5, 2.0];
        let pad = PolarPad::new(&process);
        let radii = [0.4, 5.5, 12.3, 19.0, 27.9];
        let blocks = executed_blocks(&motion, &dwell, omega, 0.3, &surface(-130.0));
        let one_d =
            RemovalOperator::assemble(&RemovalKernel::new(&process), &radii, &motion).apply(&dwell);
        let peak = one_d.iter().cloned().fold(0.0, f64::max);
        for (&r, want) in radii.iter().zip(&one_d) {
            let depth =
                |theta: f64| pad.depth_nm(&blocks, &[(r * theta.cos(), r * theta.sin())])[0];
            let mean = adaptive_integral(&depth, 0.0, TAU, 1e-11 * peak * TAU) / TAU;
            assert!(
                (mean - want).abs() <= 1e-9 * peak,
                "{model:?} r {r}: mean {mean} vs the 1-D {want} (peak {peak})"
            );
        }
    }
}
