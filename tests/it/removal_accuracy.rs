//! The closed-form removal function against independent adaptive quadrature of its defining
//! integral, over ≥ 10,000 seeded random parameter sets.
//!
//! Tolerance: ≤ 1e-10 relative, or ≤ 1e-12 of the profile's peak, whichever is looser (the
//! issue's bound). The quadrature is run to ~1e-15 of the integrand's scale, so its own error
//! is negligible against that bound. The peak (max over r of R(r; r1)) only scales the
//! absolute floor; it is estimated from 65 samples of the profile.

use crate::common;

use common::{adaptive_integral, quadrature_rate_nm_per_min};
use preston::physics::{removal_rate_nm_per_min, Part, PressureModel, Process, ProcessSpec};

#[test]
fn quadrature_integrates_known_integrals() {
    let pi = std::f64::consts::PI;
    let got = adaptive_integral(&|x: f64| x.sin(), 0.0, pi, 1e-14);
    assert!((got - 2.0).abs() < 1e-13);
    // A kink at the midpoint: ∫_{-1}^{1} √|x| dx = 4/3.
    let got = adaptive_integral(&|x: f64| x.abs().sqrt(), -1.0, 1.0, 1e-14);
    assert!((got - 4.0 / 3.0).abs() < 1e-12, "{got}");
}

#[derive(Debug, Clone, Copy)]
enum Speeds {
    General,
    EtaMinusOne,
    SmallEta,
    LargeEta,
    NearMinusOne,
    EtaMinusTwo,
    ToolStationary,
}

#[derive(Debug, Clone, Copy)]
enum Geometry {
    Anywhere,
    CentreSample,
    CentreTool,
    Tangent,
    NearTangent,
    FullCoverage,
    InternalTangency,
    SameRadius,
}

fn sign(rng: &mut fastrand::Rng) -> f64 {
    if rng.bool() {
        1.0
    } else {
        -1.0
    }
}

fn uniform(rng: &mut fastrand::Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.f64()
}

fn random_case(
    rng: &mut fastrand::Rng,
    speeds: Speeds,
    geometry: Geometry,
) -> (ProcessSpec, f64, f64) {
    let rm = uniform(rng, 5.0, 500.0);
    let rt = rm * uniform(rng, 0.02, 1.2);
    let w = sign(rng) * uniform(rng, 0.5, 500.0);
    // Speeds stay inside the model's domain (|r/min| ≤ 1e5): tiny |η| comes from a slow
    // workpiece under a fast tool.
    let (w, t) = match speeds {
        Speeds::General => (w, sign(rng) * uniform(rng, 0.5, 3000.0)),
        Speeds::EtaMinusOne => (w, w),
        Speeds::SmallEta => {
            let t = sign(rng) * uniform(rng, 1e3, 1e5);
            (sign(rng) * t.abs() * 10f64.powf(-uniform(rng, 2.0, 6.0)), t)
        }
        Speeds::LargeEta => (w, sign(rng) * w.abs() * 10f64.powf(-uniform(rng, 2.0, 6.0))),
        Speeds::NearMinusOne => (
            w,
            w * (1.0 + sign(rng) * 10f64.powf(-uniform(rng, 3.0, 10.0))),
        ),
        Speeds::EtaMinusTwo => (w, 0.5 * w),
        Speeds::ToolStationary => (w, 0.0),
    };
    let reach = rm + rt;
    let (r, r1) = match geometry {
        Geometry::Anywhere => {
            let r1 = uniform(rng, 0.0, reach);
            (uniform(rng, (r1 - rt).max(0.0), (r1 + rt).min(rm)), r1)
        }
        Geometry::CentreSample => (0.0, uniform(rng, 0.0, 1.5 * rt)),
        Geometry::CentreTool => (uniform(rng, 0.0, rm.min(1.5 * rt)), 0.0),
        Geometry::Tangent => {
            let r1 = uniform(rng, rt, reach);
            (
                if rng.bool() || r1 + rt > rm {
                    r1 - rt
                } else {
                    r1 + rt
                },
                r1,
            )
        }
        Geometry::NearTangent => {
            // |r − r1| = r_t·(1 − 10^-k): just inside tangency, on either side of the pad.
            let inside = rt * (1.0 - 10f64.powf(-uniform(rng, 1.0, 12.0)));
            if rng.bool() || inside >= rm {
                let r1 = uniform(rng, inside, inside + rm);
                (r1 - inside, r1)
            } else {
                let r1 = uniform(rng, 0.0, rm - inside);
                (r1 + inside, r1)
            }
        }
        Geometry::FullCoverage => {
            let r1 = uniform(rng, 0.0, rt.min(rm));
            (uniform(rng, 0.0, (rt - r1).min(rm)), r1)
        }
        Geometry::InternalTangency => {
            let r1 = uniform(rng, 0.0, rt.min(rm));
            ((rt - r1).min(rm), r1)
        }
        Geometry::SameRadius => {
            let r = uniform(rng, 0.0, rm);
            (r, r)
        }
    };
    let spec = ProcessSpec {
        workpiece_radius_mm: rm,
        tool_radius_mm: rt,
        workpiece_rpm: w,
        tool_rpm: t,
        preston_coefficient_m2_per_n: 10f64.powf(uniform(rng, -15.0, -12.0)),
        pressure_kpa: uniform(rng, 1.0, 50.0),
        pressure_model: PressureModel::Uniform,
        part: Part::flat(),
    };
    (spec, r, r1)
}

#[test]
fn closed_form_matches_adaptive_quadrature_on_random_parameters() {
    let speeds = [
        Speeds::General,
        Speeds::EtaMinusOne,
        Speeds::SmallEta,
        Speeds::LargeEta,
        Speeds::NearMinusOne,
        Speeds::EtaMinusTwo,
        Speeds::ToolStationary,
    ];
    let geometries = [
        Geometry::Anywhere,
        Geometry::CentreSample,
        Geometry::CentreTool,
        Geometry::Tangent,
        Geometry::NearTangent,
        Geometry::FullCoverage,
        Geometry::InternalTangency,
        Geometry::SameRadius,
    ];
    let mut rng = fastrand::Rng::with_seed(20_130_417);
    let cases = 12_000;
    let mut worst_rel: f64 = 0.0;
    let mut counts = std::collections::BTreeMap::new();
    for case in 0..cases {
        // Every (speeds, geometry) pair is visited, then repeated with fresh draws.
        let s = speeds[case % speeds.len()];
        let g = geometries[(case / speeds.len()) % geometries.len()];
        let (spec, r, r1) = random_case(&mut rng, s, g);
        let process = Process::new(spec.clone()).unwrap();
        let closed = removal_rate_nm_per_min(&process, r, r1);
        let reference = quadrature_rate_nm_per_min(&spec, r, r1);
        let peak = (0..=64)
            .map(|k| {
                let rr = (r1 - spec.tool_radius_mm).max(0.0)
                    + (2.0 * spec.tool_radius_mm) * k as f64 / 64.0;
                removal_rate_nm_per_min(&process, rr.min(spec.workpiece_radius_mm), r1)
            })
            .fold(closed.max(reference), f64::max);
        let err = (closed - reference).abs();
        let bound = (1e-10 * reference.abs()).max(1e-12 * peak);
        assert!(
            err <= bound,
            "case {case} {s:?}/{g:?}: r {r} r1 {r1} {spec:?}: closed {closed:e} quadrature {reference:e} (err {err:e} > {bound:e})"
        );
        if reference > 1e-3 * peak {
            worst_rel = worst_rel.max(err / reference);
        }
        *counts.entry(format!("{s:?}")).or_insert(0) += 1;
    }
    eprintln!("{cases} cases {counts:?}; worst relative error where R > 1e-3·peak: {worst_rel:e}");
}

/// Exactly zero where the pad never touches the circle, and at exact tangency.
#[test]
fn no_contact_and_tangency_give_exact_zero() {
    let p = common::paper_process(-10.0, 200.0);
    for (r, r1) in [
        (0.0, 10.5),
        (30.0, 15.0),
        (25.0, 15.0),
        (5.0, 15.0),
        (50.0, 35.0),
    ] {
        assert_eq!(removal_rate_nm_per_min(&p, r, r1), 0.0, "r {r} r1 {r1}");
    }
}
