//! The pad point by point on a part turning on C (`physics::polar`), against an independent,
//! time-stepped integration of the executed motion (`polar_reference`, written from the
//! physics text alone: V = |(ω2 − Ω)·p − ω2·c| in the part's frame, the pad centre at
//! dφ/dt = −Ω) and against the 1-D model it must average to.

use std::f64::consts::TAU;

use preston::physics::polar::PolarPad;
use preston::physics::{Part, PressureModel, Process, ProcessSpec, RemovalKernel};

use super::polar_reference::{depth_nm, Segment, Setup};

const K: f64 = 1e-13;
const KPA: f64 = 10.0;

fn process(workpiece_rpm: f64, tool_rpm: f64, pressure_model: PressureModel) -> Process {
    Process::new(ProcessSpec {
        workpiece_radius_mm: 40.0,
        tool_radius_mm: 10.0,
        workpiece_rpm,
        tool_rpm,
        preston_coefficient_m2_per_n: K,
        pressure_kpa: KPA,
        pressure_model,
        part: Part::flat(),
    })
    .unwrap()
}

/// K·P in nm/s per mm/s (1 mm/s = 1e6 nm/s): the reference's scale.
fn scale() -> f64 {
    K * KPA * 1e3 * 1e6
}

/// Points over the part: 41 radii × 24 angles, offset so that none sits on a symmetry line.
fn points() -> Vec<(f64, f64)> {
    (0..41)
        .flat_map(|i| {
            let r = 0.37 + i as f64 * 0.99;
            (0..24).map(move |j| {
                let t = 0.11 + j as f64 * TAU / 24.0;
                (r * t.cos(), r * t.sin())
            })
        })
        .filter(|(x, y)| x.hypot(*y) <= 40.0)
        .collect()
}

/// The footprint is the sliding-speed formula itself: at random points and pad centres it
/// is K·P·V to rounding (1e-12 relative), 0 off the pad and off the part.
#[test]
fn the_footprint_is_preston_s_law_on_the_two_dimensional_sliding_speed() {
    let process = process(-37.0, 600.0, PressureModel::Uniform);
    let pad = PolarPad::new(&process).unwrap();
    let omega = -37.0 * TAU / 60.0;
    let tool = 600.0 * TAU / 60.0;
    let mut seen = 0;
    for (k, &p) in points().iter().enumerate() {
        let phi = 0.3 + k as f64 * 0.77;
        let c = (21.0 * phi.cos(), 21.0 * phi.sin());
        let got = pad.rate_at(p, c);
        let under = (p.0 - c.0).hypot(p.1 - c.1) <= 10.0;
        let want = if under {
            scale() * super::polar_reference::sliding_speed_mm_s(omega, tool, p, c)
        } else {
            0.0
        };
        assert!(
            (got - want).abs() <= 1e-12 * want.max(1.0),
            "{p:?}: {got} vs {want}"
        );
        seen += usize::from(under);
    }
    assert!(seen > 20, "{seen} points under the pad");
}

/// Rings at constant Ω — partial and whole turns, both directions of C, both spins, the pad
/// over the centre and over the edge — agree with the time-stepped motion to 1e-6 of the
/// peak depth (the reference's error at 1e4 steps per C revolution is ~1e-7 of the peak, its
/// second-order rule measured against closed forms).
#[test]
fn rings_at_constant_speed_match_the_time_stepped_motion() {
    let cases = [
        // workpiece rpm, tool rpm, r1, start angle, turns
        (-37.0, 600.0, 21.0, 0.4, 0.3),
        (37.0, 600.0, 21.0, -1.0, 1.7),
        (20.0, -300.0, 6.0, 2.0, 0.55),
        (90.0, 90.0, 12.0, 0.0, 0.8),    // η = −1: pure translation
        (-15.0, 200.0, 35.0, 1.3, 2.25), // over the edge
    ];
    for (workpiece_rpm, tool_rpm, r1, start, turns) in cases {
        let pad = PolarPad::new(&process(workpiece_rpm, tool_rpm, PressureModel::Uniform)).unwrap();
        let duration = turns * 60.0 / f64::abs(workpiece_rpm);
        let segment = Segment::Ring {
            r1_mm: r1,
            omega_rpm: workpiece_rpm,
            duration_s: duration,
        };
        let (worst, peak) = against_reference(tool_rpm, start, segment, |r, theta| {
            pad.ring_depth_nm(r, theta, r1, start, duration)
        });
        assert!(
            worst <= 1e-6 * peak,
            "{workpiece_rpm} / {tool_rpm} rpm, r1 {r1}: {worst:e} nm against a peak of {peak} nm"
        );
    }
}

/// The largest difference (nm) between `depth` (at r, θ) and the time-stepped reference's
/// depth of `segment` (from the pad angle `start`) over [`points`], and the reference's peak;
/// the reference at 1.2·10⁴ steps per C revolution (~1e-7 of the peak).
fn against_reference(
    tool_rpm: f64,
    start: f64,
    segment: Segment,
    depth: impl Fn(f64, f64) -> f64,
) -> (f64, f64) {
    let omega_rpm = match segment {
        Segment::Ring { omega_rpm, .. } | Segment::Spiral { omega_rpm, .. } => omega_rpm,
        Segment::Modulated { mean_omega_rpm, .. } => mean_omega_rpm,
    };
    let setup = Setup {
        part_radius_mm: 40.0,
        pad_radius_mm: 10.0,
        tool_rpm,
        scale_nm_per_mm: scale(),
        start_angle_rad: start,
    };
    let points = points();
    let reference = depth_nm(&setup, &[segment], &points, 1.2e4 * omega_rpm.abs() / 60.0);
    let peak = reference.iter().cloned().fold(0.0, f64::max);
    assert!(peak > 0.0);
    let worst = points
        .iter()
        .zip(&reference)
        .map(|(&(x, y), want)| (depth(x.hypot(y), y.atan2(x)) - want).abs())
        .fold(0.0, f64::max);
    (worst, peak)
}

/// Whole turns at constant Ω leave the 1-D prediction at every angle: R(r; r1)·T from
/// `RemovalKernel` to 1e-12 relative, under every pressure model.
#[test]
fn whole_turns_leave_the_one_dimensional_removal_at_every_angle() {
    for model in [
        PressureModel::Uniform,
        PressureModel::ConstantForce,
        PressureModel::Linear {
            pad_moment_share: 0.6,
        },
    ] {
        let process = process(-12.0, 150.0, model);
        let pad = PolarPad::new(&process).unwrap();
        let kernel = RemovalKernel::new(&process);
        let duration = 3.0 * 60.0 / 12.0;
        for r1 in [0.0, 4.0, 17.0, 33.0] {
            for i in 0..30 {
                let r = 0.5 + i as f64 * 1.35;
                let want = kernel.rate_nm_per_s(r, r1) * duration;
                for theta in [0.0, 1.1, -2.9, 3.1] {
                    let got = pad.ring_depth_nm(r, theta, r1, 0.7, duration);
                    assert!(
                        (got - want).abs() <= 1e-12 * want.max(1e-3),
                        "{model:?} r1 {r1} r {r} θ {theta}: {got} vs {want}"
                    );
                }
            }
        }
    }
}

/// For any duration the azimuthal mean of a ring's depth is R·T: averaged over N angles one
/// sweep apart divided evenly (N·Ω·T/2π an integer), every stretch of the arc is counted the
/// same number of times, so the identity holds to rounding (1e-12 of R·T), partial turns
/// included, under every pressure model; and a partial ring is not round (its ripple is
/// real).
#[test]
fn a_partial_ring_averages_to_the_one_dimensional_removal() {
    for model in [
        PressureModel::Uniform,
        PressureModel::Linear {
            pad_moment_share: 1.0,
        },
    ] {
        let process = process(25.0, -180.0, model);
        let pad = PolarPad::new(&process).unwrap();
        let kernel = RemovalKernel::new(&process);
        let turns = 1.375;
        let duration = turns * 60.0 / 25.0;
        let n = 8 * 360; // n·turns an integer
        for (r, r1) in [(3.0, 8.0), (12.0, 8.0), (30.0, 24.0), (39.5, 31.0)] {
            let depths: Vec<f64> = (0..n)
                .map(|i| pad.ring_depth_nm(r, i as f64 * TAU / n as f64, r1, -0.2, duration))
                .collect();
            let mean = depths.iter().sum::<f64>() / n as f64;
            let want = kernel.rate_nm_per_s(r, r1) * duration;
            assert!(
                (mean - want).abs() <= 1e-12 * want,
                "{model:?} r {r}: mean {mean} vs {want}"
            );
            let (lo, hi) = depths
                .iter()
                .fold((f64::INFINITY, 0.0_f64), |(a, b), d| (a.min(*d), b.max(*d)));
            assert!(hi - lo > 0.05 * want, "r {r}: a ripple of {} nm", hi - lo);
        }
    }
}

/// At the centre the sweep is well defined: r = 0 is every angle at once, its depth R·T for
/// any T.
#[test]
fn the_centre_is_every_angle_at_once() {
    let process = process(30.0, 300.0, PressureModel::Uniform);
    let pad = PolarPad::new(&process).unwrap();
    let kernel = RemovalKernel::new(&process);
    for duration in [0.37, 2.0, 5.1] {
        let want = kernel.rate_nm_per_s(0.0, 6.0) * duration;
        let got = pad.ring_depth_nm(0.0, 0.0, 6.0, 1.0, duration);
        assert!((got - want).abs() <= 1e-12 * want, "{got} vs {want}");
    }
}

/// Under a linear pad over the edge (pressure rising across the pad, a lift line) a partial
/// ring's closed form matches the footprint integrated along the executed sweep: the
/// midpoint rule over 400,000 steps of `rate_at` (the sliding-speed formula, checked above
/// against the reference). Its error is dominated by the rim's two jumps, at most half a
/// step's rate each, so each point is held to (its largest rate)·dt plus 1e-9 of the peak
/// (the smooth part's error is far below). The azimuthal-mean identity alone would not see a
/// wrong shape of the partial arc; this does.
#[test]
fn a_linear_pad_s_partial_ring_is_its_footprint_swept() {
    let process = process(
        -20.0,
        240.0,
        PressureModel::Linear {
            pad_moment_share: 0.6,
        },
    );
    let pad = PolarPad::new(&process).unwrap();
    let omega = pad.part_speed_rad_per_s();
    let (r1, start, duration) = (33.0, 0.9, 0.62 * 60.0 / 20.0);
    let steps = 400_000;
    let dt = duration / steps as f64;
    let sample: Vec<(f64, f64)> = points().into_iter().step_by(7).collect();
    let swept: Vec<(f64, f64)> = sample
        .iter()
        .map(|&p| {
            (0..steps).fold((0.0, 0.0_f64), |(sum, most), i| {
                let phi = start - omega * (i as f64 + 0.5) * dt;
                let rate = pad.rate_at(p, (r1 * phi.cos(), r1 * phi.sin()));
                (sum + rate * dt, most.max(rate))
            })
        })
        .collect();
    let peak = swept.iter().map(|s| s.0).fold(0.0, f64::max);
    assert!(peak > 0.0);
    let mut checked = 0;
    for (&(x, y), &(want, most)) in sample.iter().zip(&swept) {
        let got = pad.ring_depth_nm(x.hypot(y), y.atan2(x), r1, start, duration);
        assert!(
            (got - want).abs() <= most * dt + 1e-9 * peak,
            "({x}, {y}): {got} vs {want} (peak {peak}, bound {})",
            most * dt
        );
        checked += usize::from(want > 0.0);
    }
    assert!(checked > 10, "{checked} points touched");
}

/// Spirals at constant Ω — the pad moving in or out while C turns, over the centre and over
/// the edge, both directions of C — agree with the time-stepped motion to 1e-6 of the peak
/// depth (the reference at 1.2·10⁴ steps per C revolution, ~1e-7 of the peak).
#[test]
fn spirals_match_the_time_stepped_motion() {
    let cases = [
        // workpiece rpm, tool rpm, r1 from, r1 to, start angle, turns
        (-37.0, 600.0, 2.0, 30.0, 0.4, 3.3),
        (45.0, -300.0, 33.0, 8.0, -1.0, 2.6),
        (20.0, 200.0, 14.0, 16.0, 2.0, 1.45),
    ];
    for (workpiece_rpm, tool_rpm, from, to, start, turns) in cases {
        let pad = PolarPad::new(&process(workpiece_rpm, tool_rpm, PressureModel::Uniform)).unwrap();
        let duration = turns * 60.0 / f64::abs(workpiece_rpm);
        let segment = Segment::Spiral {
            r1_start_mm: from,
            r1_end_mm: to,
            omega_rpm: workpiece_rpm,
            duration_s: duration,
        };
        let (worst, peak) = against_reference(tool_rpm, start, segment, |r, theta| {
            pad.spiral_depth_nm(r, theta, (from, to), start, duration)
        });
        assert!(
            worst <= 1e-6 * peak,
            "{workpiece_rpm} / {tool_rpm} rpm, {from} → {to} mm: {worst:e} nm against a peak of {peak} nm"
        );
    }
}

/// A spiral that does not move is a ring: the same depth to 1e-10 of the peak.
#[test]
fn a_spiral_standing_still_is_a_ring() {
    let pad = PolarPad::new(&process(-15.0, 200.0, PressureModel::ConstantForce)).unwrap();
    let duration = 1.7 * 60.0 / 15.0;
    let points = points();
    let rings: Vec<f64> = points
        .iter()
        .map(|&(x, y)| pad.ring_depth_nm(x.hypot(y), y.atan2(x), 31.0, 0.3, duration))
        .collect();
    let peak = rings.iter().cloned().fold(0.0, f64::max);
    for (&(x, y), ring) in points.iter().zip(&rings) {
        let spiral = pad.spiral_depth_nm(x.hypot(y), y.atan2(x), (31.0, 31.0), 0.3, duration);
        assert!(
            (spiral - ring).abs() <= 1e-10 * peak,
            "({x}, {y}): {spiral} vs {ring}"
        );
    }
}
