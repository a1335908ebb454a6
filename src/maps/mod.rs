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
}
