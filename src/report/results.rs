//! Each use case's result as a CSV table and an SVG chart: what the API returns for
//! `Accept: text/csv` and `image/svg+xml`. The numbers are the result's own, as the JSON
//! response carries them (removal in nm, lengths in mm, times in s).

use super::chart::{self, Chart, Series};
use super::table;
use crate::machine::BlockKind;
use crate::optimize::SolveStatus;
use crate::physics::ClearAperture;
use crate::usecases::calibration::CalibrationResult;
use crate::usecases::eta_sweep::EtaSweep;
use crate::usecases::map_analysis::MapAnalysisResult;
use crate::usecases::map_difference::MapDifferenceResult;
use crate::usecases::map_predict::MapPrediction;
use crate::usecases::map_program::PolarMachineProgram;
use crate::usecases::map_removal_function::Footprint;
use crate::usecases::measurement_fit::MeasurementFit;
use crate::usecases::optimize::OptimizedPlan;
use crate::usecases::predict::Prediction;
use crate::usecases::program::MachineProgram;
use crate::usecases::raster_program::RasterMachineProgram;
use crate::usecases::removal_function::RemovalFunction;

fn header(names: &[&str]) -> Vec<String> {
    names.iter().map(|n| n.to_string()).collect()
}

fn points(x: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    x.iter().copied().zip(y.iter().copied()).collect()
}

/// The clear aperture, shaded.
fn band(aperture: &ClearAperture) -> Option<(f64, f64, String)> {
    Some(chart::aperture_band(
        aperture.inner_mm(),
        aperture.outer_mm(),
    ))
}

/// Radius, then one removal-rate column per tool position.
pub fn removal_function_csv(r: &RemovalFunction) -> String {
    let mut names = vec!["radius_mm".to_string()];
    names.extend(r.profiles.iter().map(|p| {
        format!(
            "removal_rate_nm_per_min(tool_position_mm={})",
            p.tool_position_mm
        )
    }));
    let mut columns: Vec<&[f64]> = vec![r.grid.radii_mm()];
    columns.extend(
        r.profiles
            .iter()
            .map(|p| p.removal_rate_nm_per_min.as_slice()),
    );
    table::csv(&names, &columns)
}

/// One curve R(r; r1) per tool position.
pub fn removal_function_svg(r: &RemovalFunction) -> String {
    chart::render(&Chart {
        title: match r.eta {
            Some(eta) => format!("Removal rate R(r; r1) at η = {eta}"),
            None => "Removal rate R(r; r1), tool stationary".to_string(),
        },
        x_label: "radius r (mm)".to_string(),
        y_label: "removal rate (nm/min)".to_string(),
        series: r
            .profiles
            .iter()
            .map(|p| Series {
                name: format!("r1 = {} mm", p.tool_position_mm),
                points: points(r.grid.radii_mm(), &p.removal_rate_nm_per_min),
            })
            .collect(),
        band: None,
        secondary: None,
    })
}

/// Radius and removal.
pub fn prediction_csv(p: &Prediction) -> String {
    table::csv(
        &header(&["radius_mm", "removal_nm"]),
        &[p.setting.grid().radii_mm(), &p.removal_nm],
    )
}

/// Removal against radius with the clear aperture shaded.
pub fn prediction_svg(p: &Prediction) -> String {
    let nonuniformity = p
        .metrics
        .nonuniformity
        .map_or("n/a".to_string(), |n| format!("{:.3} %", 100.0 * n));
    chart::render(&Chart {
        title: format!(
            "Predicted removal, {:.0} s total, nonuniformity {nonuniformity}",
            p.total_time_s
        ),
        x_label: "radius r (mm)".to_string(),
        y_label: "removal depth (nm)".to_string(),
        series: vec![Series {
            name: "predicted removal".to_string(),
            points: points(p.setting.grid().radii_mm(), &p.removal_nm),
        }],
        band: band(p.setting.aperture()),
        secondary: None,
    })
}

/// One row per η: the workpiece speed and the uniformity figures.
pub fn eta_sweep_csv(s: &EtaSweep) -> String {
    let column =
        |f: fn(&crate::study::SweepPoint) -> f64| -> Vec<f64> { s.points.iter().map(f).collect() };
    table::csv(
        &header(&[
            "eta",
            "workpiece_rpm",
            "nonuniformity",
            "mean_nm",
            "pv_nm",
            "rms_nm",
        ]),
        &[
            &column(|p| p.eta),
            &column(|p| p.workpiece_rpm),
            &column(|p| p.metrics.nonuniformity.unwrap_or(f64::NAN)),
            &column(|p| p.metrics.mean_nm),
            &column(|p| p.metrics.pv_nm),
            &column(|p| p.metrics.rms_nm),
        ],
    )
}

/// Nonuniformity (%) against η, in ascending η.
pub fn eta_sweep_svg(s: &EtaSweep) -> String {
    let mut curve: Vec<(f64, f64)> = s
        .points
        .iter()
        .map(|p| (p.eta, 100.0 * p.metrics.nonuniformity.unwrap_or(f64::NAN)))
        .collect();
    curve.sort_by(|a, b| a.0.total_cmp(&b.0));
    let aperture = s.setting.aperture();
    chart::render(&Chart {
        title: format!(
            "Equal-dwell nonuniformity against η (tool {} r/min)",
            s.tool_rpm
        ),
        x_label: "η = −workpiece_rpm / tool_rpm".to_string(),
        y_label: "nonuniformity pv/mean (%)".to_string(),
        series: vec![Series {
            name: format!("over [{}, {}] mm", aperture.inner_mm(), aperture.outer_mm()),
            points: curve,
        }],
        band: None,
        secondary: None,
    })
}

/// The plan: position and dwell.
pub fn plan_csv(p: &OptimizedPlan) -> String {
    table::csv(
        &header(&["position_mm", "dwell_s"]),
        &[p.motion.radii_mm(), &p.solution.dwell_s],
    )
}

/// Dwell against position, the feed across each cell on a second axis, aperture shaded.
pub fn plan_svg(p: &OptimizedPlan) -> String {
    let status = match p.solution.status {
        SolveStatus::Solved => "solved",
        SolveStatus::AlmostSolved => "almost_solved",
    };
    let feeds = p.cell_feeds_mm_per_min();
    chart::render(&Chart {
        title: format!("Optimized dwell, {:.0} s total ({status})", p.total_time_s),
        x_label: "tool position r1 (mm)".to_string(),
        y_label: "dwell (s)".to_string(),
        series: vec![Series {
            name: "dwell at each position".to_string(),
            points: points(p.motion.radii_mm(), &p.solution.dwell_s),
        }],
        band: band(p.setting.aperture()),
        secondary: Some((
            "feed (mm/min)".to_string(),
            Series {
                name: "feed across each cell".to_string(),
                points: p
                    .motion
                    .radii_mm()
                    .iter()
                    .zip(feeds)
                    .map(|(&x, v)| (x, v.unwrap_or(f64::NAN)))
                    .collect(),
            },
        )),
    })
}

/// One row per probe point: the trace, its placement and its residuals (nm).
/// The aperture's pixels: position in the part's C frame and height less the removed terms.
pub fn map_pixels_csv(r: &MapAnalysisResult) -> String {
    pixels_csv(&r.analysis.pixels, "height_nm")
}

/// The compared pixels: position in the part's C frame and the removal.
pub fn map_removal_csv(r: &MapDifferenceResult) -> String {
    pixels_csv(&r.difference.pixels, "removal_nm")
}

/// The Zernike coefficients as bars above the PSD's azimuthal average (log₁₀).
pub fn map_analysis_svg(r: &MapAnalysisResult) -> String {
    let a = &r.analysis;
    let bars = chart::render_bars(&chart::Bars {
        title: format!(
            "Zernike fit ({:?}, {:?}): residual {:.3} nm RMS; map {:.1} nm PV, {:.2} nm RMS",
            a.zernike.ordering,
            a.zernike.normalization,
            a.zernike.residual_rms_nm,
            a.metrics.pv_nm,
            a.metrics.rms_nm
        ),
        x_label: "term (index in the ordering)".to_string(),
        y_label: "coefficient (nm)".to_string(),
        bars: a
            .zernike
            .terms
            .iter()
            .map(|(index, _, c)| (index.to_string(), *c))
            .collect(),
    });
    let psd = chart::render(&Chart {
        title: "PSD, azimuthal average".to_string(),
        x_label: "spatial frequency (1/mm)".to_string(),
        y_label: "log10 PSD (nm²·mm²)".to_string(),
        series: vec![Series {
            name: "azimuthal average".to_string(),
            points: a
                .psd
                .azimuthal
                .iter()
                .map(|&(f, p)| (f, if p > 0.0 { p.log10() } else { f64::NAN }))
                .collect(),
        }],
        band: None,
        secondary: None,
    });
    chart::stack(&[bars, psd])
}

/// A pad's footprint, pixel by pixel from the top row: position in the part's frame and the
/// instantaneous rate.
pub fn footprint_csv(f: &Footprint) -> String {
    let (x, y): (Vec<f64>, Vec<f64>) = f
        .y_mm
        .iter()
        .flat_map(|&y| f.x_mm.iter().map(move |&x| (x, y)))
        .unzip();
    table::csv(
        &header(&["x_mm", "y_mm", "removal_rate_nm_per_min"]),
        &[&x, &y, &f.rate_nm_per_min],
    )
}

/// A predicted removal map, pixel by pixel from the top row, the pixels on the part only:
/// position in the part's frame and the removal.
pub fn removal_map_csv(r: &MapPrediction) -> String {
    removal_pixels_csv(&r.x_mm, &r.y_mm, &r.removal_nm)
}

/// A removal on a grid (row-major from the top; the pixels with a value only): each pixel's
/// position and removal.
pub fn removal_pixels_csv(x_mm: &[f64], y_mm: &[f64], removal_nm: &[Option<f64>]) -> String {
    let width = x_mm.len();
    let (mut x, mut y, mut z) = (Vec::new(), Vec::new(), Vec::new());
    for (i, value) in removal_nm.iter().enumerate() {
        if let Some(v) = value {
            x.push(x_mm[i % width]);
            y.push(y_mm[i / width]);
            z.push(*v);
        }
    }
    table::csv(&header(&["x_mm", "y_mm", "removal_nm"]), &[&x, &y, &z])
}

fn pixels_csv(pixels: &[crate::maps::analysis::Pixel], value: &str) -> String {
    let column = |f: fn(&crate::maps::analysis::Pixel) -> f64| -> Vec<f64> {
        pixels.iter().map(f).collect()
    };
    table::csv(
        &header(&["x_mm", "y_mm", value]),
        &[
            &column(|p| p.x_mm),
            &column(|p| p.y_mm),
            &column(|p| p.height_nm),
        ],
    )
}

pub fn measurement_fit_csv(m: &MeasurementFit) -> String {
    let points = &m.outcome.points;
    let column = |f: &dyn Fn(&crate::metrology::PointResidual) -> f64| -> Vec<f64> {
        points.iter().map(f).collect()
    };
    table::csv(
        &header(&[
            "x_mm",
            "z_mm",
            "aligned_x_mm",
            "contact_x_mm",
            "axial_nm",
            "normal_nm",
            "weight",
        ]),
        &[
            &column(&|p| p.x_mm),
            &column(&|p| p.z_mm),
            &column(&|p| p.aligned_x_mm),
            &column(&|p| p.contact_mm),
            &column(&|p| p.axial_nm()),
            &column(&|p| p.normal_nm()),
            &column(&|p| p.weight),
        ],
    )
}

/// Normal residuals of each side and the averaged profile against radius, aperture shaded.
pub fn measurement_fit_svg(m: &MeasurementFit) -> String {
    let side = |sign: f64| {
        let mut curve: Vec<(f64, f64)> = m
            .outcome
            .points
            .iter()
            .filter(|p| p.weight > 0.0 && p.contact_mm.signum() == sign)
            .map(|p| (p.contact_mm.abs(), p.normal_nm()))
            .collect();
        curve.sort_by(|a, b| a.0.total_cmp(&b.0));
        Series {
            name: format!("residual, x {} 0", if sign > 0.0 { ">" } else { "<" }),
            points: curve,
        }
    };
    let mut series: Vec<Series> = [side(1.0), side(-1.0)]
        .into_iter()
        .filter(|s| !s.points.is_empty())
        .collect();
    series.push(Series {
        name: "form error (both sides averaged)".to_string(),
        points: points(&m.profile.depth.radius_mm, &m.profile.depth.depth_nm),
    });
    chart::render(&Chart {
        title: format!(
            "Form error: {:.1} nm RMS, {:.1} nm PV over the clear aperture",
            m.form_error.rms_nm, m.form_error.pv_nm
        ),
        x_label: "radius r (mm)".to_string(),
        y_label: "residual along the normal (nm)".to_string(),
        series,
        band: band(&m.aperture),
        secondary: None,
    })
}

/// One row per block: its kind, where it ends (radius, arc length, axes) and its timing.
pub fn program_csv(m: &MachineProgram) -> String {
    let p = &m.program;
    let mut out = String::from(
        "block,kind,position_mm,arc_length_mm,x_mm,z_mm,b_deg,duration_s,feed_mm_per_min,\
         inverse_time_per_min\n",
    );
    let optional = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for (i, b) in p.blocks().iter().enumerate() {
        let kind = block_kind(b.kind);
        let feed = p.path_feed_per_min(i);
        out.push_str(&format!(
            "{i},{kind},{},{},{},{},{},{},{},{}\n",
            b.position_mm,
            b.arc_length_mm,
            b.end.x_mm,
            b.end.z_mm,
            b.end.b_deg,
            b.duration_s,
            optional(feed),
            optional(feed.map(|_| 60.0 / b.duration_s))
        ));
    }
    out
}

/// One row per block of a polar program: its kind, station, where it ends on every axis (C
/// unwound) and C's speed over it.
pub fn polar_program_csv(m: &PolarMachineProgram) -> String {
    let mut out = String::from(
        "block,kind,station,position_mm,x_mm,z_mm,b_deg,c_deg,c_velocity_deg_per_min,duration_s,\
         inverse_time_per_min\n",
    );
    for (i, b) in m.program.blocks().iter().enumerate() {
        out.push_str(&format!(
            "{i},{},{},{},{},{},{},{},{},{},{}\n",
            block_kind(b.kind),
            b.station.map_or(String::new(), |s| s.to_string()),
            b.position_mm,
            b.end.x_mm,
            b.end.z_mm,
            b.end.b_deg,
            b.c_deg,
            60.0 * b.c_deg_per_s,
            b.duration_s,
            60.0 / b.duration_s
        ));
    }
    out
}

/// One row per block of an X-Y program: its kind, the plan's point whose dwell it spends,
/// where it ends and its timing.
pub fn xy_program_csv(m: &RasterMachineProgram) -> String {
    let mut out = String::from("block,kind,point,x_mm,y_mm,z_mm,duration_s,inverse_time_per_min\n");
    for (i, b) in m.program.blocks().iter().enumerate() {
        out.push_str(&format!(
            "{i},{},{},{},{},{},{},{}\n",
            block_kind(b.kind),
            b.point.map_or(String::new(), |p| p.to_string()),
            b.end_mm[0],
            b.end_mm[1],
            b.end_mm[2],
            b.duration_s,
            60.0 / b.duration_s
        ));
    }
    out
}

/// A block's kind as the tables write it.
fn block_kind(kind: BlockKind) -> &'static str {
    match kind {
        BlockKind::Approach => "approach",
        BlockKind::Dwell => "dwell",
        BlockKind::Move => "move",
        BlockKind::Retract => "retract",
    }
}

/// One row per measured point: its run, radius, measured and predicted removal.
pub fn calibration_csv(c: &CalibrationResult) -> String {
    let runs = &c.calibrated.runs;
    let run: Vec<f64> = runs
        .iter()
        .enumerate()
        .flat_map(|(j, r)| std::iter::repeat_n(j as f64, r.radius_mm.len()))
        .collect();
    let join = |part: fn(&crate::calibration::RunFit) -> &Vec<f64>| -> Vec<f64> {
        runs.iter().flat_map(|r| part(r).iter().copied()).collect()
    };
    let (radius, measured, predicted) = (
        join(|r| &r.radius_mm),
        join(|r| &r.measured_nm),
        join(|r| &r.predicted_nm),
    );
    table::csv(
        &header(&["run", "radius_mm", "measured_nm", "predicted_nm"]),
        &[&run, &radius, &measured, &predicted],
    )
}

/// Measured against predicted removal, per run.
pub fn calibration_svg(c: &CalibrationResult) -> String {
    let fit = &c.calibrated;
    let mut series = Vec::new();
    for (j, run) in fit.runs.iter().enumerate() {
        series.push(Series {
            name: format!("run {j} measured"),
            points: points(&run.radius_mm, &run.measured_nm),
        });
        series.push(Series {
            name: format!("run {j} predicted"),
            points: points(&run.radius_mm, &run.predicted_nm),
        });
    }
    let k = fit.process.spec().preston_coefficient_m2_per_n;
    chart::render(&Chart {
        title: format!(
            "Calibration: K = {k:.4e} m²/N ({:.3} × nominal), r_t = {:.3} mm",
            fit.removal_rate_ratio,
            fit.process.tool_radius_mm()
        ),
        x_label: "radius r (mm)".to_string(),
        y_label: "removal (nm)".to_string(),
        series,
        band: None,
        secondary: None,
    })
}
