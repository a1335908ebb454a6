//! Zygo Mx `.datx`: an HDF5 file, read with the pure-Rust `hdf5-reader`.
//!
//! The surface is the 2-D dataset in `/Data/Surface` (named by a GUID; the first by name when
//! there are several), or `/Measurement/Surface` in files of older Mx versions. Its rows are in
//! image order, the top row first, as [`HeightMap`] keeps them. Its attributes, each a
//! one-element array:
//!
//! - `No Data`: a raw value at or above it (or not finite) is a missing pixel;
//! - `Unit`: `Fringes`, `NanoMeters`, `MicroMeters`, `MilliMeters` or `Meters`;
//! - `Wavelength` (m), `Interferometric Scale Factor` S and `Obliquity Factor` O: in fringes,
//!   height = raw · S · O · λ (S is 0.5 for a reflection test: a fringe is λ/2 of surface);
//! - `X Converter`: a compound whose `Parameters` (a list of numbers) hold the lateral
//!   resolution, m per pixel, at index 1; no pitch when it is absent or not positive.
//!
//! Every size is checked before the heights are read: against the pixel limit, and against
//! what the file could carry: its values (4 bytes each at the least) cannot take more than
//! [`DEFLATE_RATIO`] times the file's length, deflate's largest expansion, so a small file
//! declaring a large surface (all fill values, or chunks that are not there) is refused before
//! anything is allocated for it. The values are read as the dataset stores them (64- or
//! 32-bit floats, 32-bit integers).

use hdf5_reader::{Attribute, Dataset, Datatype, Hdf5File, VarLenKind};

use super::{HeightMap, MapError};

/// Deflate's largest expansion: a stored byte stands for at most 1032 (RFC 1951's longest
/// match, 258 bytes, in the shortest code, about two bits).
const DEFLATE_RATIO: usize = 1032;

/// Why a `.datx` file cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DatxError {
    #[error("not a readable HDF5 file ({0})")]
    Hdf5(String),
    #[error("no surface: the file has no dataset in /Data/Surface (nor /Measurement/Surface)")]
    NoSurface,
    #[error("the file is truncated or damaged where its surface should be ({0})")]
    Damaged(String),
    #[error("the surface has {0} dimensions where a map has 2")]
    NotAMap(usize),
    #[error("the surface's {rows} × {columns} pixels are more than the {max} a map may have")]
    TooLarge { rows: u64, columns: u64, max: usize },
    #[error(
        "the surface declares {pixels} pixels, more than its {bytes}-byte file could hold \
         (a damaged file, or one whose heights are not in it)"
    )]
    LargerThanFile { pixels: usize, bytes: usize },
    #[error("the surface holds {0}, not floating-point or 32-bit integer heights")]
    Values(String),
    #[error("the surface's attribute `{name}` {why}")]
    Attribute { name: &'static str, why: String },
    #[error("the surface's unit `{0}` is not one of Fringes, NanoMeters, MicroMeters, MilliMeters, Meters")]
    Unit(String),
    #[error("{0}")]
    Map(#[from] MapError),
}

/// Reads a `.datx` file (module docs), refusing one of more than `max_pixels` pixels.
pub fn read(bytes: &[u8], max_pixels: usize) -> Result<HeightMap, DatxError> {
    let hdf5 = |e: hdf5_reader::error::Error| DatxError::Hdf5(e.to_string());
    let file = Hdf5File::from_bytes(bytes).map_err(hdf5)?;
    let surface = surface(&file)?;
    let (rows, columns) = match surface.shape() {
        [rows, columns] => (*rows, *columns),
        other => return Err(DatxError::NotAMap(other.len())),
    };
    let pixels = rows
        .checked_mul(columns)
        .and_then(|p| usize::try_from(p).ok())
        .filter(|&p| p <= max_pixels)
        .ok_or(DatxError::TooLarge {
            rows,
            columns,
            max: max_pixels,
        })?;
    if pixels.saturating_mul(4) > bytes.len().saturating_mul(DEFLATE_RATIO) {
        return Err(DatxError::LargerThanFile {
            pixels,
            bytes: bytes.len(),
        });
    }
    let raw = values(&surface, pixels)?;
    let no_data = match surface.attribute("No Data") {
        Ok(a) => Some(number(&a, "No Data")?),
        Err(_) => None,
    };
    let scale = scale_to_nm(&surface)?;
    let wavelength_nm = match surface.attribute("Wavelength") {
        Ok(a) => Some(number(&a, "Wavelength")? * 1e9).filter(|w| *w > 0.0 && w.is_finite()),
        Err(_) => None,
    };
    let pixel_mm = match surface.attribute("X Converter") {
        Ok(a) => converter_parameters(&surface, &a)?
            .get(1)
            .map(|m| m * 1e3)
            .filter(|p| *p > 0.0 && p.is_finite()),
        Err(_) => None,
    };
    let columns = columns as usize;
    let heights: Vec<Vec<Option<f64>>> = raw
        .chunks(columns.max(1))
        .map(|row| {
            row.iter()
                .map(|&v| {
                    let missing = !v.is_finite() || no_data.is_some_and(|n| v >= n);
                    (!missing).then_some(v * scale)
                })
                .collect()
        })
        .collect();
    Ok(HeightMap::from_rows(
        heights,
        pixel_mm,
        wavelength_nm,
        max_pixels,
    )?)
}

/// The surface dataset (module docs). When there is none, the first error met looking for
/// it says why (a truncated or damaged file), else the file has none.
fn surface(file: &Hdf5File) -> Result<Dataset, DatxError> {
    let mut failure = None;
    for path in ["/Data/Surface", "/Measurement/Surface"] {
        let names = file.group(path).and_then(|group| {
            let (_, mut names) = group.member_names()?;
            // Link order differs between HDF5 format versions: by name, as h5py lists them.
            names.sort();
            Ok((group, names))
        });
        let (group, names) = match names {
            Ok(found) => found,
            Err(e) => {
                failure.get_or_insert(e);
                continue;
            }
        };
        for name in names {
            match group.dataset(&name) {
                Ok(dataset) => return Ok(dataset),
                Err(e) => {
                    failure.get_or_insert(e);
                }
            }
        }
    }
    Err(match failure {
        Some(e) if !e.to_string().to_ascii_lowercase().contains("not found") => {
            DatxError::Damaged(e.to_string())
        }
        _ => DatxError::NoSurface,
    })
}

/// The dataset's `pixels` values as f64, as it stores them.
fn values(surface: &Dataset, pixels: usize) -> Result<Vec<f64>, DatxError> {
    let hdf5 = |e: hdf5_reader::error::Error| DatxError::Hdf5(e.to_string());
    Ok(match surface.dtype() {
        Datatype::FloatingPoint { size: 8, .. } => {
            let mut v = vec![0f64; pixels];
            surface.read_into(&mut v).map_err(hdf5)?;
            v
        }
        Datatype::FloatingPoint { size: 4, .. } => {
            let mut v = vec![0f32; pixels];
            surface.read_into(&mut v).map_err(hdf5)?;
            v.into_iter().map(f64::from).collect()
        }
        Datatype::FixedPoint {
            size: 4,
            signed: true,
            ..
        } => {
            let mut v = vec![0i32; pixels];
            surface.read_into(&mut v).map_err(hdf5)?;
            v.into_iter().map(f64::from).collect()
        }
        other => return Err(DatxError::Values(format!("{other:?}"))),
    })
}

/// A one-element numeric attribute.
fn number(attribute: &Attribute, name: &'static str) -> Result<f64, DatxError> {
    attribute
        .read_as_f64()
        .map_err(|e| DatxError::Attribute {
            name,
            why: format!("is not a number ({e})"),
        })
        .and_then(|v| {
            if v.is_nan() {
                Err(DatxError::Attribute {
                    name,
                    why: "is not a number".into(),
                })
            } else {
                Ok(v)
            }
        })
}

/// nm per raw unit (module docs).
fn scale_to_nm(surface: &Dataset) -> Result<f64, DatxError> {
    let unit = surface
        .attribute("Unit")
        .and_then(|a| a.read_strings())
        .ok()
        .and_then(|mut s| (!s.is_empty()).then(|| s.remove(0)))
        .ok_or(DatxError::Attribute {
            name: "Unit",
            why: "is missing: the heights' unit is unknown".into(),
        })?;
    let positive = |name: &'static str| -> Result<f64, DatxError> {
        let a = surface.attribute(name).map_err(|_| DatxError::Attribute {
            name,
            why: "is missing, and heights in fringes need it".into(),
        })?;
        let v = number(&a, name)?;
        if v > 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(DatxError::Attribute {
                name,
                why: format!("is {v}, where a positive number is needed"),
            })
        }
    };
    Ok(match unit.trim_end_matches('\0').trim() {
        "Fringes" => {
            positive("Wavelength")?
                * positive("Interferometric Scale Factor")?
                * positive("Obliquity Factor")?
                * 1e9
        }
        "NanoMeters" => 1.0,
        "MicroMeters" => 1e3,
        "MilliMeters" => 1e6,
        "Meters" => 1e9,
        other => return Err(DatxError::Unit(other.to_string())),
    })
}

/// The numbers of a converter's `Parameters` member.
fn converter_parameters(surface: &Dataset, a: &Attribute) -> Result<Vec<f64>, DatxError> {
    let bad = |why: &str| DatxError::Attribute {
        name: "X Converter",
        why: why.to_string(),
    };
    let Datatype::Compound { fields, .. } = &a.datatype else {
        return Err(bad("is not a compound (Category, BaseUnit, Parameters)"));
    };
    let field = fields
        .iter()
        .find(|f| f.name == "Parameters")
        .ok_or_else(|| bad("has no Parameters"))?;
    let at = a
        .raw_data
        .get(field.byte_offset as usize..)
        .ok_or_else(|| bad("is shorter than its type"))?;
    let bytes = match &field.datatype {
        Datatype::VarLen {
            kind: VarLenKind::Sequence,
            ..
        } => {
            let size = surface.vlen_reference_size();
            let reference = at
                .get(..size)
                .ok_or_else(|| bad("is shorter than its type"))?;
            surface
                .resolve_vlen_reference_bytes(reference, 8)
                .map_err(|e| bad(&format!("has unreadable Parameters ({e})")))?
        }
        Datatype::Array { dims, .. } => {
            let count: u64 = dims.iter().product();
            let length = usize::try_from(count)
                .ok()
                .and_then(|c| c.checked_mul(8))
                .ok_or_else(|| bad("declares too many Parameters"))?;
            at.get(..length)
                .ok_or_else(|| bad("is shorter than its type"))?
                .to_vec()
        }
        other => return Err(bad(&format!("has Parameters of type {other:?}"))),
    };
    Ok(bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("chunks of 8")))
        .collect())
}
