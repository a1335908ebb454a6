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
//! - [`datx`]: Zygo Mx `.datx` (HDF5).
//! - [`zygo_text`]: Zygo's ASCII and XYZ exports.
//! - [`codev`]: Code V interferogram grids (`.int`).
//! - [`grid`]: a plain text grid with a `#` header (Preston's own, documented there).
//!
//! [`read`] tells them apart by their first bytes.
//!
//! The analysis ([`analysis`]) aligns a map to the part and its clear aperture ([`aperture`]),
//! fits Zernike terms ([`zernike`]), takes its PSD ([`psd`]) and its rotationally symmetric
//! part ([`radial`]); [`rings`] splits what is not round into angular harmonics ring by ring.

pub mod analysis;
pub mod aperture;
pub mod codev;
pub mod datx;
pub mod difference;
pub mod grid;
pub mod metropro;
pub mod mounted;
pub mod psd;
pub mod radial;
pub mod rings;
pub mod zernike;
pub mod zygo_text;

use crate::field::Figures;

/// The file formats [`read`] tells apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    MetroPro,
    Datx,
    ZygoText,
    CodeV,
    TextGrid,
}

impl Format {
    /// The format the bytes start as: MetroPro's magic number, HDF5's signature (a `.datx`),
    /// Zygo's text titles, a Code V header, else a text grid.
    pub fn detect(bytes: &[u8]) -> Format {
        if bytes.len() >= 4 && metropro::detect(bytes) {
            Format::MetroPro
        } else if bytes.starts_with(HDF5_SIGNATURE) {
            Format::Datx
        } else if zygo_text::detect(bytes) {
            Format::ZygoText
        } else if codev::detect(bytes) {
            Format::CodeV
        } else {
            Format::TextGrid
        }
    }
}

/// The first eight bytes of every HDF5 file.
const HDF5_SIGNATURE: &[u8] = b"\x89HDF\r\n\x1a\n";

/// Why a file could not be read, by the format it was taken for.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReadError {
    #[error("MetroPro .dat: {0}")]
    MetroPro(#[from] metropro::MetroProError),
    #[error("Zygo Mx .datx: {0}")]
    Datx(#[from] datx::DatxError),
    #[error("Zygo text export: {0}")]
    ZygoText(#[from] zygo_text::ZygoTextError),
    #[error("Code V grid: {0}")]
    CodeV(#[from] codev::CodeVError),
    #[error("text grid: {0}")]
    TextGrid(#[from] grid::TextGridError),
}

/// Reads a map file in any format Preston knows, told apart by its first bytes; at most
/// `max_pixels` pixels.
pub fn read(bytes: &[u8], max_pixels: usize) -> Result<(Format, HeightMap), ReadError> {
    let format = Format::detect(bytes);
    let map = match format {
        Format::MetroPro => metropro::read(bytes, max_pixels)?,
        Format::Datx => datx::read(bytes, max_pixels)?,
        Format::ZygoText => zygo_text::read(bytes, max_pixels)?,
        Format::CodeV => codev::read(bytes, max_pixels)?,
        Format::TextGrid => grid::read(bytes, max_pixels)?,
    };
    Ok((format, map))
}

/// Why heights given directly do not make a map.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapError {
    #[error("the map has no rows, or a row with no pixels")]
    Empty,
    #[error("row {row} has {got} pixels where the first has {expected}")]
    Ragged {
        row: usize,
        expected: usize,
        got: usize,
    },
    #[error("row {row}, column {column}: a height must be a finite number (null for no data)")]
    NotFinite { row: usize, column: usize },
    #[error("the map has {pixels} pixels, more than the {max} a map may have")]
    TooLarge { pixels: usize, max: usize },
    #[error("every pixel of the map is missing (no data)")]
    NoData,
    #[error("{field} must be a positive number")]
    NotPositive { field: &'static str },
}

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
    /// A map from its rows (top first; `None` for no data), pixel pitch (mm) and measuring
    /// wavelength (nm) when known; at most `max_pixels` pixels.
    pub fn from_rows(
        rows: Vec<Vec<Option<f64>>>,
        pixel_mm: Option<f64>,
        wavelength_nm: Option<f64>,
        max_pixels: usize,
    ) -> Result<HeightMap, MapError> {
        let width = rows.first().map_or(0, Vec::len);
        if width == 0 {
            return Err(MapError::Empty);
        }
        let pixels = width.saturating_mul(rows.len());
        if pixels > max_pixels {
            return Err(MapError::TooLarge {
                pixels,
                max: max_pixels,
            });
        }
        for (field, value) in [("pixel_mm", pixel_mm), ("wavelength_nm", wavelength_nm)] {
            if value.is_some_and(|v| !(v.is_finite() && v > 0.0)) {
                return Err(MapError::NotPositive { field });
            }
        }
        let mut heights_nm = Vec::with_capacity(pixels);
        for (row, values) in rows.iter().enumerate() {
            if values.len() != width {
                return Err(MapError::Ragged {
                    row,
                    expected: width,
                    got: values.len(),
                });
            }
            for (column, h) in values.iter().enumerate() {
                if h.is_some_and(|h| !h.is_finite()) {
                    return Err(MapError::NotFinite { row, column });
                }
            }
            heights_nm.extend_from_slice(values);
        }
        if heights_nm.iter().all(Option::is_none) {
            return Err(MapError::NoData);
        }
        Ok(HeightMap {
            width,
            height: rows.len(),
            heights_nm,
            pixel_mm,
            wavelength_nm,
        })
    }

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
