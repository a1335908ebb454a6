//! SVG charts of results (plotters, SVG backend only: text is emitted as SVG `<text>` for
//! the viewer to render, so no font is loaded or fetched). One generic line chart serves every
//! endpoint: titled axes with units, any number of series, an optional shaded band (the clear
//! aperture) and an optional second y axis.

use plotters::prelude::*;

/// One line of a chart; non-finite points are left out (a gap in the data, not a zero).
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

/// A line chart. Axis labels carry their units, e.g. `radius (mm)`.
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// A shaded x interval with its legend label (the clear aperture).
    pub band: Option<(f64, f64, String)>,
    /// A series against a second y axis, with that axis's label.
    pub secondary: Option<(String, Series)>,
}

/// The band marking a clear aperture.
pub fn aperture_band(inner_mm: f64, outer_mm: f64) -> (f64, f64, String) {
    (
        inner_mm,
        outer_mm,
        format!("clear aperture [{inner_mm}, {outer_mm}] mm"),
    )
}

const WIDTH: u32 = 900;
const HEIGHT: u32 = 540;
const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

/// (min, max) of the finite values, widened when empty or flat so the axis has extent.
fn extent(values: impl Iterator<Item = f64>, from_zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if lo > hi {
        return (0.0, 1.0);
    }
    if from_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0);
    }
    if hi - lo <= 1e-12 * hi.abs().max(lo.abs()).max(1e-300) {
        let pad = hi.abs().max(1.0) * 0.05;
        return (lo - pad, hi + pad);
    }
    let pad = 0.05 * (hi - lo);
    (
        if from_zero && lo == 0.0 {
            0.0
        } else {
            lo - pad
        },
        hi + pad,
    )
}

fn finite(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect()
}

/// Renders `chart` as an SVG document.
pub fn render(chart: &Chart) -> String {
    let mut svg = String::new();
    if let Err(e) = draw(chart, &mut svg) {
        // Drawing into a string cannot fail for I/O reasons; keep the document well formed.
        tracing::error!(error = %e, "chart rendering failed");
        svg = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{HEIGHT}\"><text x=\"10\" y=\"20\">chart unavailable</text></svg>\n"
        );
    }
    svg
}

fn draw(chart: &Chart, svg: &mut String) -> Result<(), Box<dyn std::error::Error>> {
    let all = chart.series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) = extent(
        all.clone()
            .map(|p| p.0)
            .chain(
                chart
                    .secondary
                    .iter()
                    .flat_map(|(_, s)| s.points.iter().map(|p| p.0)),
            )
            .chain(chart.band.iter().flat_map(|b| [b.0, b.1])),
        false,
    );
    let (y0, y1) = extent(all.map(|p| p.1), true);
    let root = SVGBackend::with_string(svg, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(&chart.title, ("sans-serif", 22))
        .margin(14)
        .x_label_area_size(48)
        .y_label_area_size(78);
    if chart.secondary.is_some() {
        builder.right_y_label_area_size(78);
    }
    let mut ctx = builder
        .build_cartesian_2d(x0..x1, y0..y1)?
        .set_secondary_coord(x0..x1, {
            let (a, b) = chart.secondary.as_ref().map_or((0.0, 1.0), |(_, s)| {
                extent(s.points.iter().map(|p| p.1), true)
            });
            a..b
        });
    ctx.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .axis_desc_style(("sans-serif", 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    if let Some((a, b, label)) = &chart.band {
        ctx.draw_series([Rectangle::new(
            [(*a, y0), (*b, y1)],
            COLOURS[2].mix(0.12).filled(),
        )])?
        .label(label.as_str())
        .legend(|(x, y)| {
            Rectangle::new([(x, y - 5), (x + 18, y + 5)], COLOURS[2].mix(0.3).filled())
        });
    }
    for (i, series) in chart.series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        ctx.draw_series(LineSeries::new(
            finite(&series.points),
            colour.stroke_width(2),
        ))?
        .label(series.name.as_str())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    if let Some((label, series)) = &chart.secondary {
        let colour = COLOURS[(chart.series.len()) % COLOURS.len()];
        ctx.configure_secondary_axes()
            .y_desc(label.as_str())
            .y_label_formatter(&|v| tick(*v))
            .axis_desc_style(("sans-serif", 16))
            .draw()?;
        ctx.draw_secondary_series(LineSeries::new(
            finite(&series.points),
            colour.stroke_width(2),
        ))?
        .label(series.name.as_str())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    ctx.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", 14))
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extents_pad_and_survive_empty_or_flat_data() {
        assert_eq!(extent([].into_iter(), false), (0.0, 1.0));
        let (lo, hi) = extent([5.0, 5.0].into_iter(), false);
        assert!(lo < 5.0 && hi > 5.0);
        let (lo, hi) = extent([2.0, 4.0, f64::NAN].into_iter(), true);
        assert_eq!(lo, 0.0);
        assert!((hi - 4.2).abs() < 1e-12);
    }
}

/// A tick's label: six significant figures at most, trailing zeros dropped, and never "-0"
/// (a tick at zero that the axis's arithmetic left at −1e-17 or −0.0 reads 0: no chart here
/// has an axis spanning less than 1e-12 of its unit).
fn tick(v: f64) -> String {
    let rounded: f64 = format!("{v:.5e}").parse().unwrap_or(v);
    if rounded.abs() < 1e-12 {
        return "0".to_string();
    }
    let text = rounded.to_string();
    // Plain decimals for the magnitudes charts use; scientific beyond them.
    if (1e-4..1e7).contains(&rounded.abs()) {
        text
    } else {
        format!("{rounded:e}")
    }
}

#[cfg(test)]
mod tick_tests {
    #[test]
    fn ticks_read_as_numbers_never_minus_zero() {
        assert_eq!(super::tick(-0.0), "0");
        assert_eq!(super::tick(-1.3877787807814457e-17), "0");
        assert_eq!(super::tick(0.30000000000000004), "0.3");
        assert_eq!(super::tick(-2.5), "-2.5");
        assert_eq!(super::tick(150.0), "150");
        assert_eq!(super::tick(2.5e-7), "2.5e-7");
    }
}

/// A bar chart: one bar per labelled value, from 0.
pub struct Bars {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// (label under the bar, value).
    pub bars: Vec<(String, f64)>,
}

/// The bar chart as an SVG document.
pub fn render_bars(chart: &Bars) -> String {
    let mut svg = String::new();
    if let Err(e) = draw_bars(chart, &mut svg) {
        tracing::error!(error = %e, "chart rendering failed");
        svg = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{HEIGHT}\"><text x=\"10\" y=\"20\">chart unavailable</text></svg>\n"
        );
    }
    svg
}

fn draw_bars(chart: &Bars, svg: &mut String) -> Result<(), Box<dyn std::error::Error>> {
    let n = chart.bars.len().max(1);
    let (y0, y1) = extent(chart.bars.iter().map(|b| b.1), true);
    let root = SVGBackend::with_string(svg, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut ctx = ChartBuilder::on(&root)
        .caption(&chart.title, ("sans-serif", 22))
        .margin(14)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(0.0..n as f64, y0..y1)?;
    // Every bar labelled when they fit, else every fifth.
    let every = if n <= 40 { 1 } else { 5 };
    let labels: Vec<String> = chart.bars.iter().map(|b| b.0.clone()).collect();
    ctx.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .x_labels(n.div_ceil(every))
        .x_label_formatter(&|v| {
            let i = (*v - 0.5).round();
            if i >= 0.0 && (i as usize) < labels.len() && (i as usize) % every == 0 {
                labels[i as usize].clone()
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| tick(*v))
        .axis_desc_style(("sans-serif", 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    ctx.draw_series(chart.bars.iter().enumerate().map(|(i, (_, v))| {
        let v = if v.is_finite() { *v } else { 0.0 };
        Rectangle::new(
            [(i as f64 + 0.1, 0.0), (i as f64 + 0.9, v)],
            COLOURS[0].filled(),
        )
    }))?;
    root.present()?;
    Ok(())
}

/// SVG documents one above the other in one document.
pub fn stack(documents: &[String]) -> String {
    let mut out = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{}\">\n",
        HEIGHT as usize * documents.len()
    );
    for (k, doc) in documents.iter().enumerate() {
        let body = doc.trim_start_matches(|c| c != '<');
        let body = body.strip_prefix("<?xml").map_or(body, |rest| {
            rest.split_once("?>")
                .map_or(rest, |(_, after)| after.trim_start())
        });
        out.push_str(&body.replacen("<svg ", &format!("<svg y=\"{}\" ", HEIGHT as usize * k), 1));
        out.push('\n');
    }
    out.push_str("</svg>\n");
    out
}
