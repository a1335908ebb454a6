//! Code V interferogram files (`.int`), grid form.
//!
//! Lines starting `!` are comments; the first other line is a title; the next is the header,
//! Code V keywords with their values:
//!
//! ```text
//! GRD nx ny      the grid: nx columns, ny rows
//! SUR | WFR      surface deformation | wavefront (read alike: the values are heights)
//! WVL λ          the wavelength, µm
//! SSZ s          counts per wave (the scale size)
//! NDA n          the count that means no data
//! ```
//!
//! Then nx × ny integer counts, row by row from the top row, any number per line; the height
//! of a count c is c / s waves, c·λ/s (here in nm). A grid file carries no pixel size.

use super::HeightMap;

/// Why a file is not a Code V grid Preston can read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CodeVError {
    #[error("the file is not UTF-8 text")]
    NotText,
    #[error("the file has no header line after its title (`GRD nx ny … WVL … SSZ … NDA …`)")]
    NoHeader,
    #[error("header keyword `{keyword}`: `{value}` is not {what}")]
    Value {
        keyword: &'static str,
        value: String,
        what: &'static str,
    },
    #[error("header keyword `{0}` is not one Preston reads (GRD, SUR, WFR, WVL, SSZ, NDA)")]
    Keyword(String),
    #[error("the header has no {0}")]
    Missing(&'static str),
    #[error("the grid has {pixels} pixels, more than the {max} a map may have")]
    TooLarge { pixels: usize, max: usize },
    #[error("the header's grid has {pixels} pixels, more than a file of {bytes} bytes can list")]
    GridBeyondFile { pixels: usize, bytes: usize },
    #[error("`{0}` in the data is not an integer count")]
    Count(String),
    #[error("the data has {got} counts where the {nx} × {ny} grid needs {expected}")]
    CountMismatch {
        nx: usize,
        ny: usize,
        expected: usize,
        got: usize,
    },
    #[error("every pixel of the grid is missing (no data)")]
    NoData,
}

/// Whether the bytes look like a Code V file: a `!` comment first, or a header line with
/// `GRD` as the second line.
pub fn detect(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(4096)];
    let Ok(text) =
        std::str::from_utf8(head).or_else(|e| std::str::from_utf8(&head[..e.valid_up_to()]))
    else {
        return false;
    };
    let mut lines = text.lines().map(str::trim).filter(|l| !l.starts_with('!'));
    lines.next();
    lines.next().is_some_and(|l| {
        l.split_whitespace()
            .next()
            .is_some_and(|k| k.eq_ignore_ascii_case("GRD"))
    })
}

/// Reads a grid file (module docs); at most `max_pixels` pixels.
pub fn read(bytes: &[u8], max_pixels: usize) -> Result<HeightMap, CodeVError> {
    let text = std::str::from_utf8(bytes).map_err(|_| CodeVError::NotText)?;
    let mut lines = text.lines().filter(|l| !l.trim_start().starts_with('!'));
    let _title = lines.next().ok_or(CodeVError::NoHeader)?;
    let header = lines.next().ok_or(CodeVError::NoHeader)?;
    let tokens: Vec<&str> = header.split_whitespace().collect();
    let (mut grid, mut wavelength_um, mut scale, mut no_data) = (None, None, None, None);
    let mut i = 0;
    let value = |i: usize, keyword: &'static str, what: &'static str| -> Result<f64, CodeVError> {
        let v = tokens.get(i).copied().unwrap_or("");
        v.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| CodeVError::Value {
                keyword,
                value: v.to_string(),
                what,
            })
    };
    while i < tokens.len() {
        match tokens[i].to_ascii_uppercase().as_str() {
            "GRD" => {
                let size = |j, what| {
                    let v = value(j, "GRD", what)?;
                    if v >= 1.0 && v.fract() == 0.0 && v <= 65_535.0 {
                        Ok(v as usize)
                    } else {
                        Err(CodeVError::Value {
                            keyword: "GRD",
                            value: tokens[j].to_string(),
                            what,
                        })
                    }
                };
                grid = Some((
                    size(i + 1, "a column count (1 to 65535)")?,
                    size(i + 2, "a row count (1 to 65535)")?,
                ));
                i += 3;
            }
            "SUR" | "WFR" => i += 1,
            "WVL" => {
                let v = value(i + 1, "WVL", "a wavelength in µm")?;
                if v <= 0.0 {
                    return Err(CodeVError::Value {
                        keyword: "WVL",
                        value: tokens[i + 1].to_string(),
                        what: "a positive wavelength in µm",
                    });
                }
                wavelength_um = Some(v);
                i += 2;
            }
            "SSZ" => {
                let v = value(i + 1, "SSZ", "a scale size (counts per wave)")?;
                if v == 0.0 {
                    return Err(CodeVError::Value {
                        keyword: "SSZ",
                        value: tokens[i + 1].to_string(),
                        what: "a non-zero scale size",
                    });
                }
                scale = Some(v);
                i += 2;
            }
            "NDA" => {
                no_data = Some(value(i + 1, "NDA", "an integer no-data count")? as i64);
                i += 2;
            }
            other => return Err(CodeVError::Keyword(other.to_string())),
        }
    }
    let (nx, ny) = grid.ok_or(CodeVError::Missing("GRD (the grid's size)"))?;
    let wavelength_um = wavelength_um.ok_or(CodeVError::Missing("WVL (the wavelength)"))?;
    let scale = scale.ok_or(CodeVError::Missing("SSZ (counts per wave)"))?;
    let pixels = nx * ny;
    if pixels > max_pixels {
        return Err(CodeVError::TooLarge {
            pixels,
            max: max_pixels,
        });
    }
    if pixels > bytes.len() / 2 {
        return Err(CodeVError::GridBeyondFile {
            pixels,
            bytes: bytes.len(),
        });
    }
    let nm_per_count = wavelength_um * 1e3 / scale;
    let mut heights_nm = Vec::with_capacity(pixels);
    let mut got = 0usize;
    for token in lines.flat_map(str::split_whitespace) {
        let c: i64 = token
            .parse()
            .map_err(|_| CodeVError::Count(token.to_string()))?;
        if got < pixels {
            heights_nm.push((Some(c) != no_data).then_some(c as f64 * nm_per_count));
        }
        got += 1;
    }
    if got != pixels {
        return Err(CodeVError::CountMismatch {
            nx,
            ny,
            expected: pixels,
            got,
        });
    }
    if heights_nm.iter().all(Option::is_none) {
        return Err(CodeVError::NoData);
    }
    Ok(HeightMap {
        width: nx,
        height: ny,
        heights_nm,
        pixel_mm: None,
        wavelength_nm: Some(wavelength_um * 1e3),
    })
}
