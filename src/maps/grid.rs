//! A height map as a plain text grid: Preston's own format, for maps exported from any
//! instrument or program.
//!
//! ```text
//! # pixel_mm: 0.1179
//! # unit: nm
//! 12.5, 13.1, NaN, 12.9
//! 11.0, , 12.2, 12.4
//! ```
//!
//! - **Header lines** start with `#`: `# key: value` with the keys `pixel_mm` (the pitch, mm),
//!   `unit` (`nm`, the default; `um`; `mm`; or `waves`, which needs `wavelength_nm`),
//!   `wavelength_nm` and `missing` (a word that marks no data, besides an empty cell and
//!   `NaN`). Keys are not case-sensitive; any other single word before a colon is refused (a
//!   misspelt key must not pass unnoticed). Any other `#` line is a comment.
//! - **Rows**: one line per row, the top row first, every row as long as the first. Cells are
//!   separated by tabs if the first row holds one, else by semicolons, else by commas, else by
//!   spaces; numbers take a decimal point (so `1,5;2,5` is refused, not read as 1 and 5).
//! - A height is the number times the unit (waves: times the wavelength).

use std::fmt::Write as _;

use super::HeightMap;

/// `map` in this format: its pitch and wavelength when known, heights in nm as Rust writes
/// them (the shortest text that reads back to the same number), `NaN` where there is no data,
/// cells separated by commas. [`read`] gives the same map back.
pub fn write(map: &HeightMap) -> String {
    let mut text = String::new();
    if let Some(p) = map.pixel_mm() {
        let _ = writeln!(text, "# pixel_mm: {p}");
    }
    if let Some(w) = map.wavelength_nm() {
        let _ = writeln!(text, "# wavelength_nm: {w}");
    }
    text.push_str("# unit: nm\n");
    for row in map.heights_nm().chunks(map.width()) {
        for (i, h) in row.iter().enumerate() {
            if i > 0 {
                text.push(',');
            }
            match h {
                Some(h) => {
                    let _ = write!(text, "{h}");
                }
                None => text.push_str("NaN"),
            }
        }
        text.push('\n');
    }
    text
}

/// Why a text grid cannot be read. Lines are counted from 1, header and comments included.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TextGridError {
    #[error("line {line}: `# {key}` is not a header key (pixel_mm, unit, wavelength_nm, missing)")]
    UnknownKey { line: usize, key: String },
    #[error("line {line}: {key} must be a positive number, not `{value}`")]
    NotPositive {
        line: usize,
        key: &'static str,
        value: String,
    },
    #[error("line {line}: unit `{unit}` is not one of nm, um, mm, waves")]
    Unit { line: usize, unit: String },
    #[error("unit waves needs `# wavelength_nm: …`")]
    NoWavelength,
    #[error("line {line}: `{cell}` in column {column} is not a finite number")]
    NotANumber {
        line: usize,
        column: usize,
        cell: String,
    },
    #[error("line {line} has {got} cells where the first row has {expected}")]
    Ragged {
        line: usize,
        got: usize,
        expected: usize,
    },
    #[error("the grid has no rows")]
    Empty,
    #[error("the grid has more than the {max} pixels a map may have")]
    TooLarge { max: usize },
    #[error("every pixel of the grid is missing (no data)")]
    NoData,
    #[error("the grid is not UTF-8 text")]
    NotText,
}

/// What a cell means when it is not a number.
fn missing(cell: &str, token: Option<&str>) -> bool {
    cell.is_empty() || cell.eq_ignore_ascii_case("nan") || token.is_some_and(|t| cell == t)
}

/// Reads a text grid (module docs), refusing one of more than `max_pixels` pixels.
pub fn read(bytes: &[u8], max_pixels: usize) -> Result<HeightMap, TextGridError> {
    let text = std::str::from_utf8(bytes).map_err(|_| TextGridError::NotText)?;
    let (mut pixel_mm, mut unit_nm, mut waves, mut wavelength_nm) = (None, 1.0, false, None);
    let mut token: Option<&str> = None;
    let mut separator: Option<Option<char>> = None;
    let (mut width, mut rows) = (0, 0);
    let mut heights: Vec<Option<f64>> = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let trimmed = raw.trim();
        if let Some(comment) = trimmed.strip_prefix('#') {
            let Some((key, value)) = comment.split_once(':') else {
                continue;
            };
            let (key, value) = (key.trim().to_ascii_lowercase(), value.trim());
            let positive = |key: &'static str| match value.parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
                _ => Err(TextGridError::NotPositive {
                    line,
                    key,
                    value: value.to_string(),
                }),
            };
            match key.as_str() {
                "pixel_mm" => pixel_mm = Some(positive("pixel_mm")?),
                "wavelength_nm" => wavelength_nm = Some(positive("wavelength_nm")?),
                "missing" => token = Some(value),
                "unit" => {
                    (unit_nm, waves) = match value.to_ascii_lowercase().as_str() {
                        "nm" => (1.0, false),
                        "um" | "µm" => (1e3, false),
                        "mm" => (1e6, false),
                        "waves" => (1.0, true),
                        _ => {
                            return Err(TextGridError::Unit {
                                line,
                                unit: value.to_string(),
                            })
                        }
                    }
                }
                _ if key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') => {
                    return Err(TextGridError::UnknownKey { line, key })
                }
                // A comment that happens to hold a colon.
                _ => {}
            }
            continue;
        }
        if trimmed.is_empty() {
            continue;
        }
        let split = *separator
            .get_or_insert_with(|| ['\t', ';', ','].into_iter().find(|&c| trimmed.contains(c)));
        let cells: Vec<&str> = match split {
            Some(c) => trimmed.split(c).map(str::trim).collect(),
            None => trimmed.split_whitespace().collect(),
        };
        if rows == 0 {
            width = cells.len();
        } else if cells.len() != width {
            return Err(TextGridError::Ragged {
                line,
                got: cells.len(),
                expected: width,
            });
        }
        if heights.len() + width > max_pixels {
            return Err(TextGridError::TooLarge { max: max_pixels });
        }
        for (column, cell) in cells.into_iter().enumerate() {
            if missing(cell, token) {
                heights.push(None);
                continue;
            }
            match cell.parse::<f64>() {
                Ok(v) if v.is_finite() => heights.push(Some(v)),
                _ => {
                    return Err(TextGridError::NotANumber {
                        line,
                        column: column + 1,
                        cell: cell.to_string(),
                    })
                }
            }
        }
        rows += 1;
    }
    if rows == 0 {
        return Err(TextGridError::Empty);
    }
    if waves {
        unit_nm = wavelength_nm.ok_or(TextGridError::NoWavelength)?;
    }
    if heights.iter().all(Option::is_none) {
        return Err(TextGridError::NoData);
    }
    for h in heights.iter_mut().flatten() {
        *h *= unit_nm;
    }
    Ok(HeightMap {
        width,
        height: rows,
        heights_nm: heights,
        pixel_mm,
        wavelength_nm,
    })
}
