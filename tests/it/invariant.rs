//! The exact η = −1 invariant (docs/MODEL.md): with constant dwell density τ over a path
//! covering [r − r_t, r + r_t], removal at r is K·P·|ω|·r_t²·τ/2, whatever r.
//!
//! It holds exactly for the motion a plan stands for, not just in a limit: a constant-feed
//! pass over [0, r_m + r_t] and an equal-dwell plan over the same path (whose end half-cells
//! are crossed at the same feed; the stop at r = 0 removes nothing at η = −1, the pad's centre
//! on the axis sliding at |ω|·0) both remove the invariant depth at every radius of [0, r_m]
//! to rounding, whatever the number of cells. Tolerance 1e-10: the running integral is
//! resolved to 1e-12 of the rate, the rest is rounding in sums of ~1e3 terms.

use crate::common;

use preston::physics::{ConstantFeed, DwellSchedule, RadialGrid};

/// K·P·|ω|·r_t²·τ/2 in nm for the paper's geometry at 150 r/min and τ s/mm.
fn invariant_nm(tau: f64) -> f64 {
    let omega = 150.0 * 2.0 * std::f64::consts::PI / 60.0; // rad/s
                                                           // K·P is dimensionless; |ω|·r_t²·τ is in mm; 1 mm = 1e6 nm.
    1e-13 * 10e3 * omega * 10.0 * 10.0 * tau / 2.0 * 1e6
}

fn worst_relative_error(removal: &[f64], exact_nm: f64) -> f64 {
    removal
        .iter()
        .map(|z| (z - exact_nm).abs() / exact_nm)
        .fold(0.0, f64::max)
}

#[test]
fn a_constant_feed_at_eta_minus_one_removes_the_invariant_depth() {
    let p = common::paper_process(150.0, 150.0);
    let feed = ConstantFeed::new(&p, 0.0, 60.0, 20.0).unwrap(); // r_m + r_t
                                                                // 201 default radii and 1000 more, off any round number.
    let mut radii = RadialGrid::default_for(&p).radii_mm().to_vec();
    radii.extend((0..1000).map(|k| 50.0 * (k as f64 + 0.37) / 1000.0));
    radii.sort_by(f64::total_cmp);
    let err = worst_relative_error(
        &feed.removal_nm(&p, &radii),
        invariant_nm(feed.dwell_density_s_per_mm()),
    );
    eprintln!("constant feed: worst relative error {err:e}");
    assert!(err <= 1e-10, "{err}");
}

#[test]
fn equal_dwell_plans_at_eta_minus_one_are_uniform_whatever_the_cells() {
    let p = common::paper_process(150.0, 150.0);
    let grid = RadialGrid::default_for(&p);
    for cells in [150, 200, 333, 1000, 2001] {
        // Positions at both ends of [0, 60] mm, equal dwell t: every cell is crossed at h/t.
        let h = 60.0 / (cells - 1) as f64;
        let positions: Vec<f64> = (0..cells)
            .map(|k| 60.0 * k as f64 / (cells - 1) as f64)
            .collect();
        let t = 3.0;
        let schedule = DwellSchedule::new(&p, positions, vec![t; cells]).unwrap();
        let err = worst_relative_error(&schedule.removal_nm(&p, &grid), invariant_nm(t / h));
        eprintln!("{cells} positions: worst relative error {err:e}");
        assert!(err <= 1e-10, "{cells} positions: {err}");
    }
}
