//! Predict removes what the motion of docs/MODEL.md removes: a plan with uneven spacing
//! (cells from 0.05 to 11 mm, a position on the axis and one past the edge) through
//! `/v1/predict`, against an integration of that motion written here: half-dwell stops at the
//! two ends, and each cell between neighbouring midpoints crossed at constant speed, removing
//! (w_j·t_j/L_j)·∫ R dρ over the cell with R by adaptive quadrature of the paper's eq. (5)
//! (`common::quadrature_rate_nm_per_min`) and the cell integral by adaptive Gauss–Kronrod,
//! split where R has kinks (ρ = |r − r_t|, r + r_t and the sliding speed's zero
//! ρ = (ω1 + ω2)·r/ω2). Agreement to 1e-8 of the peak depth: both sides are accurate to
//! ~1e-11 of the rate, and the sums have ~10 terms.

use serde_json::json;

use crate::common::{self, adaptive_integral, quadrature_rate_nm_per_min};
use common::http::{app, post_json};

#[tokio::test]
async fn predict_is_the_integral_of_the_executed_motion() {
    let positions = [
        0.0, 0.05, 1.1, 3.0, 3.2, 7.9, 12.0, 12.05, 20.0, 31.3, 45.0, 56.0,
    ];
    let dwell = [
        40.0, 3.0, 25.0, 60.0, 5.0, 80.0, 30.0, 2.0, 120.0, 90.0, 150.0, 70.0,
    ];
    for (workpiece_rpm, tool_rpm) in [(-10.0, 200.0), (150.0, 150.0), (30.0, -45.0)] {
        let spec = common::paper_spec(workpiece_rpm, tool_rpm);
        let body = json!({
            "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10,
                        "workpiece_rpm": workpiece_rpm, "tool_rpm": tool_rpm},
            "dwell": {"positions_mm": positions, "dwell_s": dwell},
            "radial_grid": {"start_mm": 0, "stop_mm": 50, "count": 101}
        });
        let reply = post_json(&app(), "/v1/predict", body.to_string()).await;
        assert_eq!(reply.status, 200, "{}", reply.text());
        let value = reply.json();
        let removal: Vec<f64> = value["removal_nm"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let n = positions.len();
        let mut bounds = vec![positions[0]];
        bounds.extend(positions.windows(2).map(|w| 0.5 * (w[0] + w[1])));
        bounds.push(positions[n - 1]);
        let (w1, w2) = (-workpiece_rpm, tool_rpm); // paper convention, r/min (ratios only)
        let peak = removal.iter().fold(0.0_f64, |m, &z| m.max(z));
        let mut worst = 0.0_f64;
        for (i, &z) in removal.iter().enumerate() {
            let r = 0.5 * i as f64;
            let rate = |rho: f64| quadrature_rate_nm_per_min(&spec, r, rho) / 60.0; // nm/s
            let mut kinks = vec![(r - 10.0).abs(), r + 10.0];
            if w1 + w2 != 0.0 {
                kinks.push((w1 + w2) * r / w2);
            }
            let mut want = 0.0;
            for j in 0..n {
                let (lo, hi) = (bounds[j], bounds[j + 1]);
                let end = j == 0 || j == n - 1;
                if end {
                    want += 0.5 * dwell[j] * rate(positions[j]);
                }
                let mut cuts: Vec<f64> = kinks
                    .iter()
                    .copied()
                    .filter(|&k| k > lo && k < hi)
                    .collect();
                cuts.sort_by(f64::total_cmp);
                let mut edges = vec![lo];
                edges.extend(cuts);
                edges.push(hi);
                let cell: f64 = edges
                    .windows(2)
                    .map(|e| adaptive_integral(&rate, e[0], e[1], 1e-13 * (e[1] - e[0])))
                    .sum();
                let share = if end { 0.5 } else { 1.0 };
                want += share * dwell[j] * cell / (hi - lo);
            }
            worst = worst.max((z - want).abs() / peak);
        }
        println!("{workpiece_rpm}/{tool_rpm} r/min: worst difference {worst:.2e} of the peak {peak:.3} nm");
        assert!(worst <= 1e-8, "{workpiece_rpm}/{tool_rpm}: {worst:e}");
    }
}
