//! A map as a PNG heat map: a map analysis's heights after the removed terms over the clear
//! aperture (PV and RMS in the title, a colour bar in nm), or a pad's footprint (its rate,
//! the position and the peak in the title, a colour bar in nm/min), coloured from their
//! minimum to their maximum, with a scale bar in mm. Pixels without a value (no data, or
//! outside the aperture) are transparent.
//!
//! Layout, in image pixels (8 × 8 bitmap text):
//!
//! - the map's pixel (column c, row r) at (4 + c·s, 14 + r·s), s × s image pixels, where
//!   s = ⌊400 / the map's longer side⌋ (at least 1); a map longer than 800 pixels is shown
//!   every k-th pixel, k = ⌈longer side / 800⌉ (then the map's pixel (c·k, r·k) at
//!   (4 + c, 14 + r));
//! - the title (`PV … nm  RMS … nm`) at (4, 3);
//! - the colour bar, 12 pixels wide, 8 pixels right of the map, as tall as it: the maximum at
//!   its top, the minimum at its bottom, labelled beside it;
//! - the scale bar, 3 pixels tall, 6 pixels below the map from its left edge: the round length
//!   (1, 2 or 5 × 10ⁿ mm) nearest a quarter of the map's width, labelled below it.
//!
//! Colours: a nine-stop perceptually ordered ramp (dark violet → yellow), linear between stops.

use font8x8::UnicodeFonts;

use crate::usecases::map_analysis::MapAnalysisResult;
use crate::usecases::map_predict::MapPrediction;
use crate::usecases::map_removal_function::Footprint;

/// The colour ramp's stops, from the minimum to the maximum.
pub const RAMP: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 81, 139],
    [44, 113, 142],
    [33, 144, 141],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];

/// The map's top-left corner in the image (module docs).
pub const MAP_ORIGIN: (usize, usize) = (4, 14);

/// An RGBA image being drawn.
struct Canvas {
    width: usize,
    height: usize,
    rgba: Vec<u8>,
}

impl Canvas {
    fn new(width: usize, height: usize) -> Canvas {
        // White and opaque; the map's missing pixels are cleared to transparent.
        Canvas {
            width,
            height,
            rgba: vec![255; width * height * 4],
        }
    }

    fn set(&mut self, x: usize, y: usize, rgba: [u8; 4]) {
        if x < self.width && y < self.height {
            let at = (y * self.width + x) * 4;
            self.rgba[at..at + 4].copy_from_slice(&rgba);
        }
    }

    fn fill(&mut self, x: usize, y: usize, w: usize, h: usize, rgba: [u8; 4]) {
        for yy in y..y + h {
            for xx in x..x + w {
                self.set(xx, yy, rgba);
            }
        }
    }

    /// `text` in black, its top-left corner at (x, y).
    fn text(&mut self, x: usize, y: usize, text: &str) {
        for (i, c) in text.chars().enumerate() {
            let glyph = font8x8::BASIC_FONTS.get(c).unwrap_or([0; 8]);
            for (row, bits) in glyph.iter().enumerate() {
                for column in 0..8 {
                    if bits & (1 << column) != 0 {
                        self.set(x + 8 * i + column, y + row, [0, 0, 0, 255]);
                    }
                }
            }
        }
    }

    fn png(&self) -> Vec<u8> {
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        // Writing into memory cannot fail but for a size PNG refuses, which the layout
        // never makes (at most ~900 × 850).
        let mut writer = encoder
            .write_header()
            .expect("a PNG header for an image of this size");
        writer
            .write_image_data(&self.rgba)
            .expect("the image's own RGBA bytes");
        writer.finish().expect("writing into memory");
        out
    }
}

/// The ramp's colour at t ∈ [0, 1].
pub fn colour(t: f64) -> [u8; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (RAMP.len() - 1) as f64;
    let i = (x as usize).min(RAMP.len() - 2);
    let f = x - i as f64;
    std::array::from_fn(|k| {
        let (a, b) = (RAMP[i][k] as f64, RAMP[i + 1][k] as f64);
        (a + f * (b - a)).round() as u8
    })
}

/// The scale and the step (module docs) for a map of `width × height` pixels.
pub fn magnification(width: usize, height: usize) -> (usize, usize) {
    let longer = width.max(height).max(1);
    ((400 / longer).max(1), longer.div_ceil(800))
}

/// The heat map (module docs) of an analysis, as PNG bytes.
pub fn map_png(r: &MapAnalysisResult) -> Vec<u8> {
    let a = &r.analysis;
    heat_png(
        (r.width, r.height),
        a.plan.alignment.pixel_mm,
        || a.pixels.iter().map(|p| (p.column, p.row, p.height_nm)),
        &format!(
            "PV {:.2} nm  RMS {:.2} nm",
            a.metrics.pv_nm, a.metrics.rms_nm
        ),
        "nm",
    )
}

/// The heat map of a pad's footprint (its rate in nm/min over its grid, the pad centre at
/// `tool_position_mm`), as PNG bytes.
pub fn footprint_png(f: &Footprint, tool_position_mm: f64) -> Vec<u8> {
    let width = f.width();
    heat_png(
        (width, f.height()),
        f.pixel_mm,
        || {
            f.rate_nm_per_min
                .iter()
                .enumerate()
                .map(move |(i, &v)| (i % width, i / width, v))
        },
        &format!(
            "r1 {} mm  peak {:.4} nm/min",
            tool_position_mm,
            f.peak_nm_per_min()
        ),
        "nm/min",
    )
}

/// The heat map of a predicted removal map (the pixels on the part), as PNG bytes.
pub fn removal_map_png(r: &MapPrediction) -> Vec<u8> {
    removal_pixels_png(
        (r.x_mm.len(), r.y_mm.len()),
        r.pixel_mm,
        &r.removal_nm,
        &r.metrics,
    )
}

/// The heat map of a removal on a grid of `size` pixels (row-major from the top, `None`
/// transparent) with its figures in the title, as PNG bytes.
pub fn removal_pixels_png(
    size: (usize, usize),
    pixel_mm: f64,
    removal_nm: &[Option<f64>],
    figures: &crate::field::Figures,
) -> Vec<u8> {
    let width = size.0;
    heat_png(
        size,
        pixel_mm,
        || {
            removal_nm
                .iter()
                .enumerate()
                .filter_map(move |(i, v)| v.map(|v| (i % width, i / width, v)))
        },
        &format!(
            "mean {:.2} nm  PV {:.2} nm  RMS {:.2} nm",
            figures.mean, figures.pv, figures.rms
        ),
        "nm",
    )
}

/// The heat map (module docs) of `cells` (column, row, value) on a grid of `size` pixels of
/// `pixel_mm`, coloured from their minimum to their maximum; a cell not given is transparent.
fn heat_png<I: Iterator<Item = (usize, usize, f64)>>(
    (columns, rows): (usize, usize),
    pixel_mm: f64,
    cells: impl Fn() -> I,
    title: &str,
    unit: &str,
) -> Vec<u8> {
    let (scale, step) = magnification(columns, rows);
    let (map_w, map_h) = (columns.div_ceil(step) * scale, rows.div_ceil(step) * scale);
    let (x0, y0) = MAP_ORIGIN;
    let (low, high) = cells().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), (_, _, v)| {
        (l.min(v), h.max(v))
    });
    let labels = [format!("{high:.1} {unit}"), format!("{low:.1} {unit}")];
    let label_w = 8 * labels.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    let bar_x = x0 + map_w + 8;
    let width = (bar_x + 12 + 4 + label_w + 4).max(x0 + 8 * 34);
    let height = y0 + map_h + 6 + 3 + 3 + 8 + 4;
    let mut canvas = Canvas::new(width, height);
    canvas.fill(x0, y0, map_w, map_h, [0, 0, 0, 0]);
    let span = high - low;
    for (column, row, value) in cells() {
        if column % step != 0 || row % step != 0 {
            continue;
        }
        let t = if span > 0.0 {
            (value - low) / span
        } else {
            0.5
        };
        let [red, green, blue] = colour(t);
        let (x, y) = (x0 + column / step * scale, y0 + row / step * scale);
        canvas.fill(x, y, scale, scale, [red, green, blue, 255]);
    }
    canvas.text(x0, 3, title);
    for y in 0..map_h {
        let t = 1.0 - y as f64 / (map_h - 1).max(1) as f64;
        let [red, green, blue] = colour(t);
        canvas.fill(bar_x, y0 + y, 12, 1, [red, green, blue, 255]);
    }
    canvas.text(bar_x + 16, y0, &labels[0]);
    canvas.text(bar_x + 16, (y0 + map_h).saturating_sub(8), &labels[1]);
    let mm_per_px = pixel_mm * step as f64 / scale as f64;
    let (length_mm, length_px) = scale_bar(map_w as f64 * mm_per_px / 4.0, mm_per_px);
    let bar_y = y0 + map_h + 6;
    canvas.fill(x0, bar_y, length_px, 3, [0, 0, 0, 255]);
    canvas.text(x0, bar_y + 6, &format!("{length_mm} mm"));
    canvas.png()
}

/// The round length (1, 2 or 5 × 10ⁿ mm) nearest `target_mm` in log terms, and its length in
/// image pixels of `mm_per_px`.
pub fn scale_bar(target_mm: f64, mm_per_px: f64) -> (f64, usize) {
    let decade = 10f64.powf(target_mm.max(1e-9).log10().floor());
    let length = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * decade)
        .min_by(|a, b| {
            (a / target_mm)
                .ln()
                .abs()
                .total_cmp(&(b / target_mm).ln().abs())
        })
        .unwrap_or(decade);
    // Written as a short decimal (0.5, 2, 10): the round length itself.
    let length = (length * 1e9).round() / 1e9;
    (length, (length / mm_per_px).round().max(1.0) as usize)
}
