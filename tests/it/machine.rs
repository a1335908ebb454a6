//! Machine programs in the core: poses against independent formulas, the G-code read back by
//! an independent parser (the `gcode` crate), and the program's removal recomputed from its
//! motion against the plan's prediction.

use preston::machine::{
    gcode, Approach, BlockKind, GcodeFormat, GcodeFormatSpec, Orientation, Program,
    SpindleWordsSpec, Tool,
};
use preston::physics::Motion;
use preston::physics::{DwellSchedule, RadialGrid, RemovalKernel};
use preston::surface::{PolynomialTerm, Surface, SurfaceSpec};

use crate::common::paper_process;

fn sphere(radius_mm: f64) -> Surface {
    Surface::new(&SurfaceSpec::Sphere {
        radius_of_curvature_mm: radius_mm,
    })
    .unwrap()
}

/// On a sphere sin θ = r/R exactly, so X = r − L·r/R, Z = z + L·√(1 − r²/R²), B = asin(r/R),
/// with z = R − sgn(R)·√(R² − r²): formulas that share nothing with the code's atan of a slope.
#[test]
fn poses_on_spheres_match_the_closed_form() {
    let pivot = 75.0;
    let tool = Tool::new(pivot, Orientation::Normal).unwrap();
    for radius in [60.0, -60.0, 250.0, -1000.0] {
        let surface = sphere(radius);
        for i in 0..=40 {
            let r = 45.0 * i as f64 / 40.0;
            let pose = tool.pose(&surface, r);
            let sin = r / radius;
            let cos = (1.0 - sin * sin).sqrt();
            let z = radius - radius.signum() * (radius * radius - r * r).sqrt();
            let (x, z, b) = (r - pivot * sin, z + pivot * cos, sin.asin().to_degrees());
            // 1e-9 mm and deg: the largest term is L ≈ 75 mm, so this is ~1e-11 relative.
            assert!(
                (pose.x_mm - x).abs() < 1e-9,
                "R {radius}, r {r}: X {} vs {x}",
                pose.x_mm
            );
            assert!(
                (pose.z_mm - z).abs() < 1e-9,
                "R {radius}, r {r}: Z {} vs {z}",
                pose.z_mm
            );
            assert!(
                (pose.b_deg - b).abs() < 1e-9,
                "R {radius}, r {r}: B {} vs {b}",
                pose.b_deg
            );
        }
    }
}

/// On an asphere, the conic written as (1 − √(1 − (1+k)c²r²))/((1+k)c) (not the code's
/// rationalised form) with its own derivative c·r/√(…), plus the polynomial's.
#[test]
fn poses_on_an_asphere_match_an_independent_sag() {
    let (radius, k, a4, a6) = (-120.0_f64, -0.6_f64, 3e-7_f64, -2e-11_f64);
    let surface = Surface::new(&SurfaceSpec::Asphere {
        radius_of_curvature_mm: radius,
        conic_constant: k,
        coefficients: vec![
            PolynomialTerm {
                power: 4,
                value: a4,
            },
            PolynomialTerm {
                power: 6,
                value: a6,
            },
        ],
    })
    .unwrap();
    let c = 1.0 / radius;
    let pivot = 40.0;
    let tool = Tool::new(pivot, Orientation::Normal).unwrap();
    let vertical = Tool::new(pivot, Orientation::Vertical).unwrap();
    for i in 0..=30 {
        let r = 50.0 * i as f64 / 30.0;
        let root = (1.0 - (1.0 + k) * c * c * r * r).sqrt();
        let z = (1.0 - root) / ((1.0 + k) * c) + a4 * r.powi(4) + a6 * r.powi(6);
        let slope = c * r / root + 4.0 * a4 * r.powi(3) + 6.0 * a6 * r.powi(5);
        let theta = slope.atan();
        let pose = tool.pose(&surface, r);
        assert!(
            (pose.x_mm - (r - pivot * theta.sin())).abs() < 1e-9,
            "r {r}"
        );
        assert!(
            (pose.z_mm - (z + pivot * theta.cos())).abs() < 1e-9,
            "r {r}"
        );
        assert!((pose.b_deg - theta.to_degrees()).abs() < 1e-9, "r {r}");
        // Vertical: X = r, Z = z + L, B = 0.
        let pose = vertical.pose(&surface, r);
        assert_eq!((pose.x_mm, pose.b_deg), (r, 0.0));
        assert!((pose.z_mm - (z + pivot)).abs() < 1e-9, "r {r}");
    }
}

fn plan(n: usize, spacing_mm: f64) -> (Vec<f64>, Vec<f64>) {
    let positions: Vec<f64> = (0..n).map(|j| spacing_mm * j as f64).collect();
    // A smooth, varying dwell (s per position scales with the spacing: a dwell density).
    let dwell = positions
        .iter()
        .map(|r| spacing_mm * (3.0 + 2.0 * (r / 12.0).sin() + 0.02 * r))
        .collect();
    (positions, dwell)
}

/// The G-code read back by the `gcode` crate: every polishing block's X, Z, B to the written
/// decimals, and its move and dwell times summing to the plan's total.
#[test]
fn gcode_reads_back_through_an_independent_parser() {
    let (positions, dwell) = plan(301, 0.15);
    let surface = sphere(-90.0);
    let tool = Tool::new(50.0, Orientation::Normal).unwrap();
    let approach = Approach {
        clearance_mm: 5.0,
        feed_mm_per_min: 100.0,
    };
    let program = Program::from_motion(
        &surface,
        &tool,
        &Motion::radial(positions.clone()),
        &dwell,
        approach,
    )
    .unwrap();
    // The parser reads words as letter + number, so the tool spindle gets plain M words here.
    let format = GcodeFormat::new(GcodeFormatSpec {
        tool_spindle: SpindleWordsSpec {
            cw: Some("M13".into()),
            ccw: Some("M14".into()),
            stop: Some("M15".into()),
        },
        ..GcodeFormatSpec::default()
    })
    .unwrap();
    let text = gcode::write(&program, &["header".into()], -10.0, 200.0, &format);
    // This parser reports a word-bearing code twice, first without its arguments: keep the
    // complete one.
    let codes: Vec<_> = ::gcode::parse(&text)
        .filter(|c| !c.arguments().is_empty() || ![1, 4].contains(&c.major_number()))
        .collect();
    let mut inverse_time = false;
    let mut polishing_s = 0.0_f64;
    let mut moves = Vec::new();
    for code in &codes {
        match (code.mnemonic(), code.major_number()) {
            (::gcode::Mnemonic::General, 93) => inverse_time = true,
            (::gcode::Mnemonic::General, 94) => inverse_time = false,
            (::gcode::Mnemonic::General, 4) => {
                polishing_s += f64::from(code.value_for('P').unwrap());
            }
            (::gcode::Mnemonic::General, 1) if inverse_time => {
                polishing_s += 60.0 / f64::from(code.value_for('F').unwrap());
                moves.push(code);
            }
            _ => {}
        }
    }
    let expected: Vec<_> = program
        .blocks()
        .iter()
        .filter(|b| b.kind == BlockKind::Move)
        .collect();
    assert_eq!(moves.len(), expected.len());
    // The parser holds f32: 4 decimals of a value below 100 survive with room to spare
    // (f32 spacing there ≤ 7.6e-6), so the bound is half the last written digit plus that.
    let bound = 0.5e-4 + 1e-5;
    for (code, block) in moves.iter().zip(&expected) {
        for (letter, value) in [
            ('X', block.end.x_mm),
            ('Z', block.end.z_mm),
            ('B', block.end.b_deg),
        ] {
            let read = f64::from(code.value_for(letter).unwrap());
            assert!((read - value).abs() < bound, "{letter}: {read} vs {value}");
        }
    }
    // Times: 6 decimals of P and 10 significant digits of F, read as f32 (relative 6e-8 each).
    let total: f64 = dwell.iter().sum();
    let tolerance = 1e-7 * total + 1e-6 * codes.len() as f64;
    assert!(
        (polishing_s - total).abs() < tolerance,
        "{polishing_s} vs {total} (±{tolerance})"
    );
    // Spindles: workpiece −10 (clockwise seen from the tool) is M4 to its own spindle.
    assert!(text.contains("\nM4 S10.000\n") && text.contains("\nM14 S200.000\n"));
}

/// The program's removal, recomputed from the blocks' motion (each move integrated by adaptive
/// Gauss–Kronrod at its constant feed, each dwell at its pose), against the plan's prediction.
/// Returns the largest difference relative to the largest depth.
fn removal_gap(spacing_mm: f64) -> f64 {
    let process = paper_process(-10.0, 200.0);
    let kernel = RemovalKernel::new(&process);
    let n = (40.0 / spacing_mm).round() as usize + 1;
    let (positions, dwell) = plan(n, spacing_mm);
    let tool = Tool::new(30.0, Orientation::Normal).unwrap();
    let approach = Approach {
        clearance_mm: 0.0,
        feed_mm_per_min: 1.0,
    };
    let program = Program::from_motion(
        &Surface::plane(),
        &tool,
        &Motion::radial(positions.clone()),
        &dwell,
        approach,
    )
    .unwrap();
    let grid = RadialGrid::new(&process, 0.0, 50.0, 201).unwrap();
    let planned = DwellSchedule::new(&process, positions.clone(), dwell.clone())
        .unwrap()
        .removal_nm(&process, &grid);
    // On a plane the pad centre is at X (B = 0), so the motion is X(t) linear in each block.
    let mut before = program.start().x_mm;
    let mut removed = vec![0.0; grid.radii_mm().len()];
    for block in program.blocks() {
        let after = block.end.x_mm;
        for (i, &r) in grid.radii_mm().iter().enumerate() {
            removed[i] += if block.kind == BlockKind::Dwell {
                block.duration_s * kernel.rate_nm_per_s(r, after)
            } else {
                let rate = |x: f64| kernel.rate_nm_per_s(r, x);
                let (lo, hi) = (before.min(after), before.max(after));
                // Split where the pad's rim crosses r, so each piece is smooth.
                let mut edges = vec![lo];
                edges.extend(
                    [(r - 10.0).abs(), r + 10.0]
                        .into_iter()
                        .filter(|&k| k > lo && k < hi),
                );
                edges.push(hi);
                edges.sort_by(f64::total_cmp);
                let integral: f64 = edges
                    .windows(2)
                    .map(|e| {
                        crate::common::adaptive_integral(&rate, e[0], e[1], 1e-15 * (e[1] - e[0]))
                    })
                    .sum();
                block.duration_s * integral / (hi - lo)
            };
        }
        before = after;
    }
    let peak = planned.iter().fold(0.0_f64, |m, &v| m.max(v));
    let gap = removed
        .iter()
        .zip(&planned)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0_f64, f64::max);
    gap / peak
}

/// The prediction is the removal of the program's own blocks, whatever the spacing (it was a
/// midpoint rule of it, 7.4e-3 of the peak depth away at 0.5 mm cells, before Preston modelled
/// the motion). Bound 1e-9: both sides resolve the rate's integral to ~1e-12.
#[test]
fn the_programs_removal_is_the_plans() {
    for spacing in [0.5, 0.25] {
        let gap = removal_gap(spacing);
        eprintln!("removal gap at {spacing} mm: {gap:.3e} of the peak depth");
        assert!(gap < 1e-9, "{spacing} mm: {gap}");
    }
}
