//! Interferometer maps: heights measured on a rectangular grid of pixels, as the shop's
//! instrument wrote them, and the readers of its files.
//!
//! A [`HeightMap`] is `width × height` pixels, row-major with the top row first (the order
//! instruments write rows in: image order, y growing downwards), each a height in nm or
//! missing (no data: outside the part, a dropout). Its pixel pitch (mm) and measuring
//! wavelength (nm) are what the file states, when it states them.
//!
//! Readers refuse what does not hold together, in a metrologist's words, and check every size
//! a file declares against the file's length and the caller's pixel limit before anything is
//! allocated: a file of n bytes never makes a reader allocate more than a small multiple of n.
//!
//! - [`metropro`]: Zygo MetroPro `.dat` (binary).
//! - [`grid`]: a plain text grid with a `#` header (Preston's own, documented there).

pub mod grid;
pub mod metropro;

use crate::field::Figures;

/// Heights on a grid of pixels (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct HeightMap {
    width: usize,
    height: usize,
    heights_nm: Vec<Option<f64>>,
    pixel_mm: Option<f64>,
    wavelength_nm: Option<f64>,
}

impl HeightMap {
    /// Pixels per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Every pixel's height, nm, row-major from the top row; `None` where there is no data.
    pub fn heights_nm(&self) -> &[Option<f64>] {
        &self.heights_nm
    }

    /// The height at column `x` of row `y` (0 = the top row), nm; `None` where there is no
    /// data or outside the map.
    pub fn at(&self, x: usize, y: usize) -> Option<f64> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.heights_nm[y * self.width + x]
    }

    /// The pixel pitch, mm, when the file calibrates it.
    pub fn pixel_mm(&self) -> Option<f64> {
        self.pixel_mm
    }

    /// The measuring wavelength, nm, when the file states it.
    pub fn wavelength_nm(&self) -> Option<f64> {
        self.wavelength_nm
    }

    /// How many pixels hold a height.
    pub fn valid_pixels(&self) -> usize {
        self.heights_nm.iter().flatten().count()
    }

    /// The valid pixels as (column, row, height in nm).
    fn valid(&self) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        self.heights_nm
            .iter()
            .enumerate()
            .filter_map(|(k, h)| h.map(|h| ((k % self.width) as f64, (k / self.width) as f64, h)))
    }

    /// The map less its piston and tilt: the plane a + b·x + c·y fitted to the valid pixels
    /// by least squares (x, y their column and row; centred on their means, so the fit's
    /// normal equations split into the mean and a 2 × 2 system), subtracted from each.
    /// Without a tilt to fit (the valid pixels on one line or one point), only the piston.
    pub fn without_piston_and_tilt(&self) -> HeightMap {
        let n = self.valid_pixels() as f64;
        let (mx, my, mz) = self.valid().fold((0.0, 0.0, 0.0), |(a, b, c), (x, y, z)| {
            (a + x / n, b + y / n, c + z / n)
        });
        let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (x, y, z) in self.valid() {
            let (dx, dy, dz) = (x - mx, y - my, z - mz);
            (sxx, sxy, syy) = (sxx + dx * dx, sxy + dx * dy, syy + dy * dy);
            (sxz, syz) = (sxz + dx * dz, syz + dy * dz);
        }
        let det = sxx * syy - sxy * sxy;
        let (b, c) = if det > 1e-12 * (sxx * syy).max(f64::MIN_POSITIVE) {
            ((syy * sxz - sxy * syz) / det, (sxx * syz - sxy * sxz) / det)
        } else {
            (0.0, 0.0)
        };
        let heights_nm = self
            .heights_nm
            .iter()
            .enumerate()
            .map(|(k, h)| {
                let (x, y) = ((k % self.width) as f64, (k / self.width) as f64);
                h.map(|z| z - mz - b * (x - mx) - c * (y - my))
            })
            .collect();
        HeightMap {
            heights_nm,
            ..self.clone()
        }
    }

    /// The figures of the valid pixels, every pixel alike (PV, RMS about the mean, …): a
    /// missing pixel weighs 0. `None` when no pixel holds a height.
    pub fn figures(&self) -> Option<Figures> {
        let values: Vec<f64> = self.heights_nm.iter().map(|h| h.unwrap_or(0.0)).collect();
        let weights: Vec<f64> = self
            .heights_nm
            .iter()
            .map(|h| if h.is_some() { 1.0 } else { 0.0 })
            .collect();
        Figures::weighted(&values, &weights)
    }
}
