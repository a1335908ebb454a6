//! `/v1/optimize` as CSV (the plan's columns) and as SVG (dwell and feed against position).

use super::OptimizeResponse;
use crate::report::chart::{self, Chart, Series};
use crate::report::table;

pub fn to_csv(response: &OptimizeResponse) -> String {
    table::csv(
        &["position_mm".to_string(), "dwell_s".to_string()],
        &[&response.dwell.positions_mm, &response.dwell.dwell_s],
    )
}

pub fn to_svg(r: &OptimizeResponse) -> String {
    let positions = &r.dwell.positions_mm;
    chart::render(&Chart {
        title: format!(
            "Optimized dwell, {:.0} s total ({})",
            r.total_time_s,
            r.solver.status.as_str()
        ),
        x_label: "tool position r1 (mm)".to_string(),
        y_label: "dwell (s)".to_string(),
        series: vec![Series {
            name: "dwell at each position".to_string(),
            points: positions
                .iter()
                .copied()
                .zip(r.dwell.dwell_s.iter().copied())
                .collect(),
        }],
        band: Some(chart::aperture_band(
            r.clear_aperture.inner_mm,
            r.clear_aperture.outer_mm,
        )),
        secondary: Some((
            "feed (mm/min)".to_string(),
            Series {
                name: "feed across each cell".to_string(),
                points: positions
                    .iter()
                    .copied()
                    .zip(&r.feed_mm_per_min)
                    .map(|(x, v)| (x, v.unwrap_or(f64::NAN)))
                    .collect(),
            },
        )),
    })
}
