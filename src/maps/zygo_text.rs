//! Zygo's text exports: the ASCII data file (MetroPro's `.asc`) and the XYZ file (`.xyz`).
//!
//! Both open with a title line, `Zygo ASCII Data File - Format 2` or `Zygo XYZ Data File -
//! Format 1`, and thirteen header lines of space-separated fields (quoted strings may hold
//! spaces), of which these are read (line, then field, from 1):
//!
//! ```text
//! line 4:  phase origin x, origin y, phase width, phase height   (pixels)
//! line 8:  source, scale factor S, wavelength W (m), numerical aperture, obliquity O,
//!          magnification, camera resolution (m per pixel; 0: uncalibrated), time stamp
//! line 11: phase resolution code (0 → R = 4096, 1 → 32768, 2 → 131072), phase averages,
//!          minimum area, discontinuity action, filter, connection order, tilt bias,
//!          data sign (0 as measured, 1 inverted)
//! ```
//!
//! A line `#` ends the header. **ASCII**: then the intensity counts (any number, possibly
//! none) up to a `#`, then width × height phase counts, rows top first, up to a `#`; a count
//! r ≥ 2147483640 is no data, else the height is r·S·O·W/R as in a `.dat`. **XYZ**: then one
//! line per pixel, `x y z` with x the column and y the row (from the top) in the phase
//! window and z the height in µm, or `x y No Data`; pixels not listed are missing.

use super::HeightMap;

const NO_DATA: i64 = 2_147_483_640;
const TITLE_ASCII: &str = "Zygo ASCII Data File";
const TITLE_XYZ: &str = "Zygo XYZ Data File";

/// Whether the bytes start as one of these files.
pub fn detect(bytes: &[u8]) -> bool {
    bytes.starts_with(TITLE_ASCII.as_bytes()) || bytes.starts_with(TITLE_XYZ.as_bytes())
}

/// Why a file is not a Zygo text map Preston can read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ZygoTextError {
    #[error("the file is not UTF-8 text")]
    NotText,
    #[error("the first line is not `Zygo ASCII Data File …` or `Zygo XYZ Data File …`")]
    Title,
    #[error(
        "the header has {lines} lines after the title where Zygo writes 13 before the `#` that \
         ends it"
    )]
    ShortHeader { lines: usize },
    #[error("header line {line}, field {field}: `{value}` is not {what}")]
    Field {
        line: usize,
        field: usize,
        value: String,
        what: &'static str,
    },
    #[error("the phase window is {width} × {height} pixels: it must hold at least one")]
    NoPhase { width: usize, height: usize },
    #[error("the phase map has {pixels} pixels, more than the {max} a map may have")]
    TooLarge { pixels: usize, max: usize },
    #[error(
        "the header's phase window has {pixels} pixels, more than a file of {bytes} bytes can list"
    )]
    WindowBeyondFile { pixels: usize, bytes: usize },
    #[error("unknown phase resolution code {code} (Zygo writes 0, 1 or 2)")]
    PhaseResolution { code: i64 },
    #[error("unknown data sign {code} (Zygo writes 0, as measured, or 1, inverted)")]
    DataSign { code: i64 },
    #[error("line {line}: `{value}` is not {what}")]
    Data {
        line: usize,
        value: String,
        what: &'static str,
    },
    #[error("the phase block has {got} counts where the header's window needs {expected}")]
    PhaseCount { expected: usize, got: usize },
    #[error("line {line}: pixel ({x}, {y}) is outside the {width} × {height} phase window")]
    OutsideWindow {
        line: usize,
        x: i64,
        y: i64,
        width: usize,
        height: usize,
    },
    #[error("the file ends before its {block} block's closing `#`")]
    Unterminated { block: &'static str },
    #[error("every pixel of the phase map is missing (no data)")]
    NoData,
}

/// Reads either file (module docs); at most `max_pixels` pixels.
pub fn read(bytes: &[u8], max_pixels: usize) -> Result<HeightMap, ZygoTextError> {
    let text = std::str::from_utf8(bytes).map_err(|_| ZygoTextError::NotText)?;
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    let xyz = match lines.next() {
        Some((_, t)) if t.starts_with(TITLE_ASCII) => false,
        Some((_, t)) if t.starts_with(TITLE_XYZ) => true,
        _ => return Err(ZygoTextError::Title),
    };
    let mut header = Vec::with_capacity(13);
    for (n, line) in lines.by_ref() {
        if line == "#" {
            if header.len() < 13 {
                return Err(ZygoTextError::ShortHeader {
                    lines: header.len(),
                });
            }
            break;
        }
        header.push((n, fields(line)));
    }
    if header.len() < 13 {
        return Err(ZygoTextError::ShortHeader {
            lines: header.len(),
        });
    }
    let number = |line: usize, field: usize, what: &'static str| -> Result<f64, ZygoTextError> {
        let (n, fields) = &header[line - 2];
        let value = fields.get(field - 1).copied().unwrap_or("");
        value
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| ZygoTextError::Field {
                line: *n,
                field,
                value: value.to_string(),
                what,
            })
    };
    let count = |line, field| -> Result<usize, ZygoTextError> {
        let v = number(line, field, "a pixel count")?;
        if v < 0.0 || v.fract() != 0.0 || v > 65_535.0 {
            return Err(ZygoTextError::Field {
                line,
                field,
                value: v.to_string(),
                what: "a pixel count (0 to 65535)",
            });
        }
        Ok(v as usize)
    };
    let (width, height) = (count(4, 3)?, count(4, 4)?);
    if width == 0 || height == 0 {
        return Err(ZygoTextError::NoPhase { width, height });
    }
    let pixels = width * height;
    if pixels > max_pixels {
        return Err(ZygoTextError::TooLarge {
            pixels,
            max: max_pixels,
        });
    }
    // Every pixel takes two bytes of the file at least (a count and a space; XYZ lists each
    // pixel on a line): a window the file cannot hold is refused before it is allocated.
    if pixels > bytes.len() / 2 {
        return Err(ZygoTextError::WindowBeyondFile {
            pixels,
            bytes: bytes.len(),
        });
    }
    let wavelength_m = number(8, 3, "a wavelength in metres")?;
    let positive = |v: f64, line, field, what| {
        if v > 0.0 {
            Ok(v)
        } else {
            Err(ZygoTextError::Field {
                line,
                field,
                value: v.to_string(),
                what,
            })
        }
    };
    let wavelength_m = positive(wavelength_m, 8, 3, "a positive wavelength in metres")?;
    let camera_m = number(8, 7, "a camera resolution in metres")?;
    let sign = match number(11, 8, "a data sign")? as i64 {
        0 => 1.0,
        1 => -1.0,
        code => return Err(ZygoTextError::DataSign { code }),
    };
    let mut heights_nm = vec![None; pixels];
    if xyz {
        read_xyz(&mut lines, width, height, sign, &mut heights_nm)?;
    } else {
        let scale = positive(
            number(8, 2, "a scale factor")?,
            8,
            2,
            "a positive scale factor",
        )?;
        let obliquity = positive(
            number(8, 5, "an obliquity factor")?,
            8,
            5,
            "a positive obliquity factor",
        )?;
        let resolution = match number(11, 1, "a phase resolution code")? as i64 {
            0 => 4096.0,
            1 => 32768.0,
            2 => 131_072.0,
            code => return Err(ZygoTextError::PhaseResolution { code }),
        };
        let nm_per_count = sign * scale * obliquity * wavelength_m * 1e9 / resolution;
        // The intensity block: skipped, but it must end.
        block(&mut lines, "intensity", |_, _| Ok(()))?;
        let mut got = 0;
        block(&mut lines, "phase", |n, token| {
            let raw: i64 = token.parse().map_err(|_| ZygoTextError::Data {
                line: n,
                value: token.to_string(),
                what: "an integer phase count",
            })?;
            if got < pixels && raw < NO_DATA {
                heights_nm[got] = Some(raw as f64 * nm_per_count);
            }
            got += 1;
            Ok(())
        })?;
        if got != pixels {
            return Err(ZygoTextError::PhaseCount {
                expected: pixels,
                got,
            });
        }
    }
    if heights_nm.iter().all(Option::is_none) {
        return Err(ZygoTextError::NoData);
    }
    Ok(HeightMap {
        width,
        height,
        heights_nm,
        pixel_mm: (camera_m > 0.0).then_some(camera_m * 1e3),
        wavelength_nm: Some(wavelength_m * 1e9),
    })
}

/// The XYZ body: `x y z` (µm) or `x y No Data` per line, up to a `#` or the end.
fn read_xyz<'a>(
    lines: &mut impl Iterator<Item = (usize, &'a str)>,
    width: usize,
    height: usize,
    sign: f64,
    heights_nm: &mut [Option<f64>],
) -> Result<(), ZygoTextError> {
    for (n, line) in lines {
        if line == "#" {
            break;
        }
        if line.is_empty() {
            continue;
        }
        let mut parts = line.split_whitespace();
        let mut coordinate = || -> Result<i64, ZygoTextError> {
            let token = parts.next().unwrap_or("");
            token.parse().map_err(|_| ZygoTextError::Data {
                line: n,
                value: token.to_string(),
                what: "an integer pixel coordinate",
            })
        };
        let (x, y) = (coordinate()?, coordinate()?);
        let rest: Vec<&str> = parts.collect();
        if x < 0 || y < 0 || x as usize >= width || y as usize >= height {
            return Err(ZygoTextError::OutsideWindow {
                line: n,
                x,
                y,
                width,
                height,
            });
        }
        let value = match rest.as_slice() {
            ["No", "Data"] => None,
            [z] => Some(
                z.parse::<f64>()
                    .ok()
                    .filter(|z| z.is_finite())
                    .ok_or_else(|| ZygoTextError::Data {
                        line: n,
                        value: z.to_string(),
                        what: "a height in µm or `No Data`",
                    })?
                    * 1e3
                    * sign,
            ),
            _ => {
                return Err(ZygoTextError::Data {
                    line: n,
                    value: rest.join(" "),
                    what: "a height in µm or `No Data`",
                })
            }
        };
        heights_nm[y as usize * width + x as usize] = value;
    }
    Ok(())
}

/// Every whitespace-separated token up to a line `#`, handed to `each` with its line.
fn block<'a>(
    lines: &mut impl Iterator<Item = (usize, &'a str)>,
    name: &'static str,
    mut each: impl FnMut(usize, &str) -> Result<(), ZygoTextError>,
) -> Result<(), ZygoTextError> {
    for (n, line) in lines {
        if line == "#" {
            return Ok(());
        }
        for token in line.split_whitespace() {
            each(n, token)?;
        }
    }
    Err(ZygoTextError::Unterminated { block: name })
}

/// The fields of a header line: space-separated, a quoted string counting as one.
fn fields(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = line.trim_start();
    while !rest.is_empty() {
        let end = if let Some(quoted) = rest.strip_prefix('"') {
            quoted.find('"').map_or(rest.len(), |i| i + 2)
        } else {
            rest.find(char::is_whitespace).unwrap_or(rest.len())
        };
        out.push(&rest[..end]);
        rest = rest[end..].trim_start();
    }
    out
}
