//! `/v1/measurement/fit` as CSV (the residual table) and as SVG (residuals and form error).

use super::MeasurementFitResponse;
use crate::report::chart::{self, Chart, Series};
use crate::report::table;

pub fn to_csv(r: &MeasurementFitResponse) -> String {
    let s = &r.residual;
    table::csv(
        &[
            "x_mm",
            "z_mm",
            "aligned_x_mm",
            "contact_x_mm",
            "axial_nm",
            "normal_nm",
            "weight",
        ]
        .map(String::from),
        &[
            &s.x_mm,
            &s.z_mm,
            &s.aligned_x_mm,
            &s.contact_x_mm,
            &s.axial_nm,
            &s.normal_nm,
            &s.weight,
        ],
    )
}

/// Normal residuals of each side and the averaged profile against radius, aperture shaded.
pub fn to_svg(r: &MeasurementFitResponse) -> String {
    let side = |sign: f64| Series {
        name: if sign > 0.0 {
            "residual, x > 0".to_string()
        } else {
            "residual, x < 0".to_string()
        },
        points: {
            let mut p: Vec<(f64, f64)> = r
                .residual
                .contact_x_mm
                .iter()
                .zip(&r.residual.normal_nm)
                .zip(&r.residual.weight)
                .filter(|((x, _), &w)| w > 0.0 && x.signum() == sign)
                .map(|((x, e), _)| (x.abs(), *e))
                .collect();
            p.sort_by(|a, b| a.0.total_cmp(&b.0));
            p
        },
    };
    let mut series = vec![];
    for s in [side(1.0), side(-1.0)] {
        if !s.points.is_empty() {
            series.push(s);
        }
    }
    series.push(Series {
        name: "form error (both sides averaged)".to_string(),
        points: r
            .profile
            .radius_mm
            .iter()
            .copied()
            .zip(r.profile.depth_nm.iter().copied())
            .collect(),
    });
    chart::render(&Chart {
        title: format!(
            "Form error: {:.1} nm RMS, {:.1} nm PV over the clear aperture",
            r.form_error.rms_nm, r.form_error.pv_nm
        ),
        x_label: "radius r (mm)".to_string(),
        y_label: "residual along the normal (nm)".to_string(),
        series,
        band: Some(chart::aperture_band(
            r.clear_aperture.inner_mm,
            r.clear_aperture.outer_mm,
        )),
        secondary: None,
    })
}
