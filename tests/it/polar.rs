//! The pad point by point on a part turning on C (`physics::polar`), against an independent,
//! time-stepped integration of the executed motion (`polar_reference`, written from the
//! physics text alone: V = |(ω2 − Ω)·p − ω2·c| in the part's frame, the pad centre at
//! dφ/dt = −Ω) and against the 1-D model it must average to.

use std::f64::consts::TAU;

use preston::physics::polar::{executed_blocks, Block, PolarPad};
use preston::physics::{
    Motion, Part, PressureModel, Process, ProcessSpec, RemovalKernel, RemovalOperator, SectorLaw,
};

use super::common::adaptive_integral;
use super::polar_reference::{depth_nm, Segment, Setup};
use preston::surface::Surface;

const K: f64 = 1e-13;
const KPA: f64 = 10.0;
const TOOL_RADIUS_MM: f64 = 10.0;

fn process(workpiece_rpm: f64, tool_rpm: f64, pressure_model: PressureModel) -> Process {
    Process::new(ProcessSpec {
        workpiece_radius_mm: 40.0,
        tool_radius_mm: TOOL_RADIUS_MM,
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
    let pad = PolarPad::new(&process);
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
        let pad = PolarPad::new(&process(workpiece_rpm, tool_rpm, PressureModel::Uniform));
        let duration = turns * 60.0 / f64::abs(workpiece_rpm);
        let segment = Segment::Ring {
            r1_mm: r1,
            omega_rpm: workpiece_rpm,
            duration_s: duration,
        };
        let (worst, peak) = against_reference(
            tool_rpm,
            start,
            &[segment],
            at_each(|r, theta| pad.ring_depth_nm(r, theta, r1, start, duration)),
        );
        assert!(
            worst <= 1e-6 * peak,
            "{workpiece_rpm} / {tool_rpm} rpm, r1 {r1}: {worst:e} nm against a peak of {peak} nm"
        );
    }
}

/// The largest difference (nm) between the depths `depths` gives at [`points`] and the
/// time-stepped reference's depth of `segments` (from the pad angle `start`) there, and the
/// reference's peak; the reference at 1.6·10⁴ steps per C revolution at the fastest speed
/// (~1e-7 of the peak).
fn against_reference(
    tool_rpm: f64,
    start: f64,
    segments: &[Segment],
    depths: impl Fn(&[(f64, f64)]) -> Vec<f64>,
) -> (f64, f64) {
    let omega_rpm = segments
        .iter()
        .map(Segment::fastest_rpm)
        .fold(0.0_f64, f64::max);
    let setup = Setup {
        part_radius_mm: 40.0,
        pad_radius_mm: 10.0,
        tool_rpm,
        scale_nm_per_mm: scale(),
        start_angle_rad: start,
    };
    let points = points();
    let reference = depth_nm(&setup, segments, &points, 1.6e4 * omega_rpm / 60.0);
    let peak = reference.iter().cloned().fold(0.0, f64::max);
    assert!(peak > 0.0);
    let worst = depths(&points)
        .iter()
        .zip(&reference)
        .map(|(got, want)| (got - want).abs())
        .fold(0.0, f64::max);
    (worst, peak)
}

/// `depth` (at r, θ) at each of `points` (x, y).
fn at_each(depth: impl Fn(f64, f64) -> f64) -> impl Fn(&[(f64, f64)]) -> Vec<f64> {
    move |points| {
        points
            .iter()
            .map(|&(x, y)| depth(x.hypot(y), y.atan2(x)))
            .collect()
    }
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
        let pad = PolarPad::new(&process);
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
        let pad = PolarPad::new(&process);
        let kernel = RemovalKernel::new(&process);
        let turns = 1.375;
        let duration = turns * 60.0 / 25.0;
        let n = 8 * 360; // n·turns an integer
        for (r, r1) in [(3.0, 8.0), (12.0, 8.0), (30.0, 24.0), (39.5, 31.0)] {
            let depths: Vec<f64> = (0..n)
                .map(|i| pad.ring_depth_nm(r, i as f64 * TAU / n as f64, r1, -0.2, duration))
                .collect();
            let want = kernel.rate_nm_per_s(r, r1) * duration;
            mean_and_ripple(&depths, want, &format!("{model:?} r {r}"));
        }
    }
}

/// At the centre the sweep is well defined: r = 0 is every angle at once, its depth R·T for
/// any T.
#[test]
fn the_centre_is_every_angle_at_once() {
    let process = process(30.0, 300.0, PressureModel::Uniform);
    let pad = PolarPad::new(&process);
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
    let pad = PolarPad::new(&process);
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
        let pad = PolarPad::new(&process(workpiece_rpm, tool_rpm, PressureModel::Uniform));
        let duration = turns * 60.0 / f64::abs(workpiece_rpm);
        let segment = Segment::Spiral {
            r1_start_mm: from,
            r1_end_mm: to,
            omega_rpm: workpiece_rpm,
            duration_s: duration,
        };
        let (worst, peak) = against_reference(
            tool_rpm,
            start,
            &[segment],
            at_each(|r, theta| pad.spiral_depth_nm(r, theta, (from, to), start, duration)),
        );
        assert!(
            worst <= 1e-6 * peak,
            "{workpiece_rpm} / {tool_rpm} rpm, {from} → {to} mm: {worst:e} nm against a peak of {peak} nm"
        );
    }
}

/// A spiral that does not move is a ring: the same depth to 1e-10 of the peak.
#[test]
fn a_spiral_standing_still_is_a_ring() {
    let pad = PolarPad::new(&process(-15.0, 200.0, PressureModel::ConstantForce));
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

/// The 1-D rate R(r; r1) with the part turning at `factor` times the process's speed: a
/// process of its own at that speed (nothing of the polar code).
fn rate_at_factor(
    workpiece_rpm: f64,
    tool_rpm: f64,
    model: PressureModel,
    factor: f64,
) -> RemovalKernel {
    RemovalKernel::new(&process(workpiece_rpm * factor, tool_rpm, model))
}

/// Under a sector law a ring's sectors are swept at their own speeds. Each sector of the
/// executed motion is one block of Δ/(Ω·f_k) seconds, in the order the falling (Ω > 0) or
/// rising (Ω < 0) angle meets them; and the azimuthal mean of the depth is Σ t_k·R_{f_k·Ω}:
/// the 1-D removal at each instant's C speed. Averaged over N angles, N a multiple of the
/// sectors and the ring ending on a sector's edge, every block sweeps whole steps of the grid
/// and the identity holds to rounding (1e-12), under every pressure model; the ring is not
/// round.
#[test]
fn a_sector_law_s_ring_averages_to_the_one_dimensional_removal_at_each_speed() {
    let factors = [1.0, 1.3, 0.7, 1.1, 0.9, 1.5, 0.6, 1.2];
    let sectors = factors.len();
    let width = TAU / sectors as f64;
    for (workpiece_rpm, model) in [
        (20.0, PressureModel::Uniform),
        (-20.0, PressureModel::ConstantForce),
        (
            20.0,
            PressureModel::Linear {
                pad_moment_share: 0.6,
            },
        ),
    ] {
        let tool_rpm = 240.0;
        let process = process(workpiece_rpm, tool_rpm, model);
        let omega = workpiece_rpm * TAU / 60.0;
        let r1 = 14.0;
        // 13 sectors from the edge at 0: falling, sectors 7, 6, …; rising, 0, 1, ….
        let visited: Vec<usize> = (0..13)
            .map(|i| {
                if omega > 0.0 {
                    (sectors - 1 - i % sectors) % sectors
                } else {
                    i % sectors
                }
            })
            .collect();
        let times: Vec<f64> = visited
            .iter()
            .map(|&k| width / (omega.abs() * factors[k]))
            .collect();
        let dwell = times.iter().sum::<f64>();
        let law = SectorLaw::new(1, sectors, factors.to_vec()).unwrap();
        let motion = Motion::radial(vec![r1]).with_sector_law(law).unwrap();
        let blocks = executed_blocks(&motion, &[dwell], omega, 0.0, &Surface::plane());
        assert_eq!(blocks.len(), 13);
        for (block, (&k, &t)) in blocks.iter().zip(visited.iter().zip(&times)) {
            assert!(
                (block.duration_s - t).abs() <= 1e-12 * t,
                "{block:?} vs {t}"
            );
            assert_eq!(block.part_speed_rad_per_s, omega * factors[k]);
            assert_eq!((block.from_mm, block.to_mm), (r1, r1));
        }
        let kernels: Vec<RemovalKernel> = factors
            .iter()
            .map(|&f| rate_at_factor(workpiece_rpm, tool_rpm, model, f))
            .collect();
        let pad = PolarPad::new(&process);
        let n = 8 * 360;
        for r in [4.5, 9.5, 14.0, 21.0, 23.5] {
            let circle: Vec<(f64, f64)> = (0..n)
                .map(|i| {
                    let t = i as f64 * TAU / n as f64;
                    (r * t.cos(), r * t.sin())
                })
                .collect();
            let depths = pad.depth_nm(&blocks, &circle);
            let want: f64 = visited
                .iter()
                .zip(&times)
                .map(|(&k, t)| t * kernels[k].rate_nm_per_s(r, r1))
                .sum();
            mean_and_ripple(
                &depths,
                want,
                &format!("{model:?} {workpiece_rpm} rpm, r {r}"),
            );
        }
    }
}

/// A plan of four stations (stops at its ends, spirals across its cells): with C at constant
/// speed the azimuthal mean of its 2-D depth is the 1-D prediction (`RemovalOperator`) to
/// 1e-9 of the peak; under a sector law it is ∫ R_{Ω(t)}(r; r1(t)) dt over the executed
/// blocks, the same bound. The means are taken by the tests' adaptive Gauss–Kronrod rule over
/// θ (the depth is only piecewise smooth in θ, kinked where blocks begin and end under the
/// pad) and the time integrals by the same rule over each block.
#[test]
fn a_plan_s_azimuthal_mean_is_the_one_dimensional_removal_of_its_instants() {
    let (workpiece_rpm, tool_rpm, model) = (30.0, -200.0, PressureModel::Uniform);
    let process = process(workpiece_rpm, tool_rpm, model);
    let omega = workpiece_rpm * TAU / 60.0;
    let stations = vec![6.0, 11.0, 15.0, 22.0];
    let dwell = [2.5, 3.0, 1.5, 2.0];
    let pad = PolarPad::new(&process);
    let radii = [0.4, 5.5, 12.3, 19.0, 27.9];
    let mean_of = |blocks: &[Block], r: f64, peak: f64| {
        let depth = |theta: f64| pad.depth_nm(blocks, &[(r * theta.cos(), r * theta.sin())])[0];
        adaptive_integral(&depth, 0.0, TAU, 1e-11 * peak * TAU) / TAU
    };

    let constant = Motion::radial(stations.clone());
    let blocks = executed_blocks(&constant, &dwell, omega, 0.3, &Surface::plane());
    let one_d =
        RemovalOperator::assemble(&RemovalKernel::new(&process), &radii, &constant).apply(&dwell);
    let peak = one_d.iter().cloned().fold(0.0, f64::max);
    for (&r, want) in radii.iter().zip(&one_d) {
        let mean = mean_of(&blocks, r, peak);
        assert!(
            (mean - want).abs() <= 1e-9 * peak,
            "constant C, r {r}: mean {mean} vs the 1-D {want} (peak {peak})"
        );
    }

    let factors = [0.8, 1.25, 1.0, 0.6, 1.4, 0.9];
    let law = SectorLaw::new(
        stations.len(),
        factors.len(),
        (0..stations.len())
            .flat_map(|j| factors.iter().map(move |f| f * (1.0 + 0.1 * j as f64)))
            .collect(),
    )
    .unwrap();
    let modulated = constant.with_sector_law(law).unwrap();
    let blocks = executed_blocks(&modulated, &dwell, omega, 0.3, &Surface::plane());
    assert!(blocks.len() > 3 * factors.len(), "{} blocks", blocks.len());
    let spent: f64 = blocks.iter().map(|b| b.duration_s).sum();
    assert!((spent - dwell.iter().sum::<f64>()).abs() <= 1e-12 * spent);
    for &r in &radii {
        let want: f64 = blocks
            .iter()
            .map(|b| {
                let kernel = rate_at_factor(
                    workpiece_rpm,
                    tool_rpm,
                    model,
                    b.part_speed_rad_per_s / omega,
                );
                let r1 = |t: f64| b.from_mm + (b.to_mm - b.from_mm) * t / b.duration_s;
                // R(r; r1) has a square-root edge where the pad's rim reaches r
                // (|r1 − r| = r_t): the integral is split there.
                let mut cuts = vec![0.0, b.duration_s];
                for edge in [r + TOOL_RADIUS_MM, (r - TOOL_RADIUS_MM).abs()] {
                    let t = (edge - b.from_mm) / (b.to_mm - b.from_mm) * b.duration_s;
                    if t > 0.0 && t < b.duration_s {
                        cuts.push(t);
                    }
                }
                cuts.sort_by(f64::total_cmp);
                cuts.windows(2)
                    .map(|w| {
                        adaptive_integral(
                            &|t| kernel.rate_nm_per_s(r, r1(t)),
                            w[0],
                            w[1],
                            1e-13 * peak,
                        )
                    })
                    .sum::<f64>()
            })
            .sum();
        let mean = mean_of(&blocks, r, peak);
        assert!(
            (mean - want).abs() <= 1e-9 * peak,
            "sector law, r {r}: mean {mean} vs ∫R dt {want} (peak {peak})"
        );
    }
}

/// Plans under sector laws — a ring of partial turns, and four stations (stops at the ends,
/// spirals across the cells) with one sector at η = −1 — against the time-stepped motion, its
/// sectors split where the angle crosses their edges (the reference's own `Sectors`): 1e-6
/// of the peak. The reference's segments are the plan's stops and moves, each at its
/// station's speeds; the cutting into blocks is the code's alone.
#[test]
fn sector_laws_match_the_time_stepped_motion() {
    struct Case {
        workpiece_rpm: f64,
        tool_rpm: f64,
        stations: Vec<f64>,
        dwell: Vec<f64>,
        factors: Vec<f64>,
        start: f64,
    }
    let cases = [
        Case {
            workpiece_rpm: 40.0,
            tool_rpm: 500.0,
            stations: vec![17.0],
            dwell: vec![2.35],
            factors: vec![1.0, 0.55, 1.6, 0.8, 1.2, 0.7],
            start: 0.4,
        },
        Case {
            workpiece_rpm: -45.0,
            tool_rpm: -90.0, // the third sector at twice −45 rpm: η = −1 there
            stations: vec![4.0, 10.0, 16.0, 23.0],
            dwell: vec![1.2, 0.9, 1.7, 1.1],
            factors: vec![1.0, 1.3, 2.0, 0.75, 0.9],
            start: -1.0,
        },
    ];
    for case in cases {
        let process = process(case.workpiece_rpm, case.tool_rpm, PressureModel::Uniform);
        let omega = case.workpiece_rpm * TAU / 60.0;
        let n = case.stations.len();
        let sectors = case.factors.len();
        // Station j's speeds: the factors, scaled a little per station.
        let factor = |j: usize, k: usize| case.factors[k] * (1.0 + 0.05 * j as f64);
        let law = SectorLaw::new(
            n,
            sectors,
            (0..n)
                .flat_map(|j| (0..sectors).map(move |k| factor(j, k)))
                .collect(),
        )
        .unwrap();
        let motion = Motion::radial(case.stations.clone())
            .with_sector_law(law)
            .unwrap();
        let segments: Vec<Segment> = motion
            .segments()
            .iter()
            .filter(|s| s.share() * case.dwell[s.station()] > 0.0)
            .map(|s| {
                let (from, to) = s.ends_mm();
                Segment::Sectors {
                    r1_start_mm: from,
                    r1_end_mm: to,
                    omega_rpm: (0..sectors)
                        .map(|k| case.workpiece_rpm * factor(s.station(), k))
                        .collect(),
                    duration_s: s.share() * case.dwell[s.station()],
                }
            })
            .collect();
        let blocks = executed_blocks(&motion, &case.dwell, omega, case.start, &Surface::plane());
        let pad = PolarPad::new(&process);
        let (worst, peak) = against_reference(case.tool_rpm, case.start, &segments, |points| {
            pad.depth_nm(&blocks, points)
        });
        assert!(
            worst <= 1e-6 * peak,
            "{} rpm, {n} stations: {worst:e} nm against a peak of {peak} nm",
            case.workpiece_rpm
        );
    }
}

/// Depths at N angles one sweep apart average to `want` to rounding (1e-12), and they are not
/// round (a ripple above 5 % of the mean).
fn mean_and_ripple(depths: &[f64], want: f64, case: &str) {
    let mean = depths.iter().sum::<f64>() / depths.len() as f64;
    assert!(
        (mean - want).abs() <= 1e-12 * want,
        "{case}: mean {mean} vs {want}"
    );
    let (lo, hi) = depths
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), d| (a.min(*d), b.max(*d)));
    assert!(hi - lo > 0.05 * want, "{case}: a ripple of {} nm", hi - lo);
}

/// C's schedule (`c_schedule`) against the executed blocks of the same plan: five stations
/// of 40 to 300 turns under a law of 12 sectors, one of them at one speed all round and one
/// running less than a turn. Every change of speed between two runs of one speed
/// (`c_runs`, `c_changes`) of the executed blocks is one of the schedule's, with the same
/// speeds and durations (to 1e-9 relative: the durations are sums of the same sectors' times
/// in another order), and the other way round; the largest speed and acceleration agree to
/// 1e-12, each station's largest acceleration too, and the block count is the executed one.
#[test]
fn c_s_schedule_holds_every_change_of_speed_the_executed_motion_does() {
    use preston::physics::polar::{c_changes, c_runs, c_schedule};
    let omega = 10.0 * TAU / 60.0;
    let stations = vec![0.0, 5.0, 9.0, 14.0, 20.0];
    let turn = TAU / omega;
    let dwell = [
        40.3 * turn,
        120.7 * turn,
        0.4 * turn,
        300.2 * turn,
        55.0 * turn,
    ];
    let sectors = 12;
    let factors: Vec<f64> = (0..stations.len())
        .flat_map(|j| {
            (0..sectors).map(move |k| {
                if j == 1 {
                    1.1
                } else {
                    1.0 + 0.3 * ((k * (j + 2)) as f64 * 0.7).sin() / (1.0 + j as f64)
                }
            })
        })
        .collect();
    let law = SectorLaw::new(stations.len(), sectors, factors).unwrap();
    let motion = Motion::radial(stations.clone())
        .with_sector_law(law)
        .unwrap();
    let full = executed_blocks(&motion, &dwell, omega, 0.2, &Surface::plane());
    let schedule = c_schedule(&motion, &dwell, omega, 0.2);
    assert_eq!(schedule.executed_blocks, full.len());
    assert!(
        schedule.blocks.len() * 20 < full.len(),
        "{} of {}",
        schedule.blocks.len(),
        full.len()
    );
    // (speed before, speed after, duration before, duration after, acceleration, station).
    let changes = |blocks: &[Block]| -> Vec<[f64; 6]> {
        let runs = c_runs(blocks);
        c_changes(&runs)
            .zip(runs.windows(2))
            .map(|((a, both), w)| {
                [
                    w[0].speed_rad_per_s,
                    w[1].speed_rad_per_s,
                    w[0].duration_s,
                    w[1].duration_s,
                    a,
                    blocks[both.end - 1].station as f64,
                ]
            })
            .collect()
    };
    let (of_full, of_schedule) = (changes(&full), changes(&schedule.blocks));
    let close = |a: &[f64; 6], b: &[f64; 6]| {
        a.iter()
            .zip(b)
            .all(|(x, y)| (x - y).abs() <= 1e-9 * x.abs().max(1e-9))
    };
    for (one, other, name) in [
        (&of_full, &of_schedule, "executed"),
        (&of_schedule, &of_full, "schedule"),
    ] {
        for c in one.iter() {
            assert!(
                other.iter().any(|d| close(c, d)),
                "a change of the {name} blocks is missing from the other: {c:?}"
            );
        }
    }
    let largest = |v: &[[f64; 6]], i: usize, station: Option<usize>| {
        v.iter()
            .filter(|c| station.is_none_or(|s| c[5] as usize == s))
            .map(|c| c[i].abs())
            .fold(0.0, f64::max)
    };
    for station in [None, Some(0), Some(2), Some(3), Some(4)] {
        let (a, b) = (
            largest(&of_full, 4, station),
            largest(&of_schedule, 4, station),
        );
        assert!((a - b).abs() <= 1e-12 * a, "{station:?}: {a} vs {b}");
    }
    let fastest = |blocks: &[Block]| {
        blocks
            .iter()
            .map(|b| b.part_speed_rad_per_s.abs())
            .fold(0.0, f64::max)
    };
    assert_eq!(fastest(&full), fastest(&schedule.blocks));
}
