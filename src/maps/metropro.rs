//! Zygo MetroPro `.dat`: a big-endian binary header, the intensity frames, then the phase map.
//!
//! The header (834 bytes in header formats 1 and 2, 4096 in format 3; its size is the u32 at
//! byte 6) starts with the magic number 0x881B036F, 0x881B0370 or 0x881B0371 for formats 1, 2
//! and 3. The fields read here (big-endian; offsets in bytes):
//!
//! ```text
//!   0 u32 magic            4 u16 header format      6 u32 header size
//!  52 u16 intensity width 54 u16 intensity height  56 u16 intensity frames (0 means 1)
//!  60 u32 intensity bytes 68 u16 phase width       70 u16 phase height    72 u32 phase bytes
//! 164 f32 scale factor S 168 f32 wavelength W (m) 176 f32 obliquity O   184 f32 pixel (m; 0: none)
//! 218 u16 phase resolution code: 0 → R = 4096, 1 → 32768, 2 → 131072
//! 232 u16 data sign: 0 as measured, 1 inverted (the heights' sign flips)
//! ```
//!
//! After the header come the intensity frames (u16 each, width × height × frames) and then the
//! phase map: width × height i32, rows top first. A raw value r ≥ 2147483640 is no data;
//! otherwise the height is
//!
//! ```text
//! h = r · S · O · W / R   (m; here in nm)
//! ```
//!
//! A file whose stated sizes disagree with each other or with its length is refused, before
//! anything is allocated.

use super::HeightMap;

/// The magic number of header formats 1, 2 and 3.
const MAGIC: [u32; 3] = [0x881B_036F, 0x881B_0370, 0x881B_0371];
/// The header size each format writes, bytes.
const HEADER_BYTES: [usize; 3] = [834, 834, 4096];
/// Raw phase values from this one up mean no data.
const NO_DATA: i32 = 2_147_483_640;

/// Whether the bytes start with a MetroPro magic number.
pub fn detect(bytes: &[u8]) -> bool {
    bytes.len() >= 4 && MAGIC.contains(&u32_at(bytes, 0))
}

/// Why a file is not a MetroPro map Preston can read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MetroProError {
    #[error("the file has {got} bytes: a MetroPro header alone has {needed}")]
    TooShort { needed: usize, got: usize },
    #[error(
        "not a Zygo MetroPro .dat file: it starts with 0x{magic:08X}, where MetroPro writes \
         0x881B036F, 0x881B0370 or 0x881B0371"
    )]
    NotMetroPro { magic: u32 },
    #[error(
        "the header says format {stated} and {bytes} header bytes, where the magic number is \
         format {format}'s ({expected} bytes)"
    )]
    Header {
        format: usize,
        stated: u16,
        bytes: usize,
        expected: usize,
    },
    #[error("the file holds no phase map (its phase width or height is 0)")]
    NoPhase,
    #[error(
        "the header's {what} byte count ({stated}) disagrees with its {width} × {height} \
         pixels{frames}"
    )]
    ByteCount {
        what: &'static str,
        stated: usize,
        width: usize,
        height: usize,
        frames: String,
    },
    #[error("the phase map has {pixels} pixels, more than the {max} a map may have")]
    TooLarge { pixels: usize, max: usize },
    #[error(
        "the file is truncated: its header declares {declared} bytes in all, the file has {got}"
    )]
    Truncated { declared: usize, got: usize },
    #[error("unknown phase resolution code {code} (MetroPro writes 0, 1 or 2)")]
    PhaseResolution { code: u16 },
    #[error("the header's {field} is {value}: it must be a positive number")]
    Scale { field: &'static str, value: f32 },
    #[error("unknown data sign {code} (MetroPro writes 0, as measured, or 1, inverted)")]
    DataSign { code: u16 },
    #[error("every pixel of the phase map is missing (no data)")]
    NoData,
}

fn u16_at(bytes: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([bytes[at], bytes[at + 1]])
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

fn f32_at(bytes: &[u8], at: usize) -> f32 {
    f32::from_bits(u32_at(bytes, at))
}

/// Reads a MetroPro `.dat` file (module docs), refusing a phase map of more than `max_pixels`.
pub fn read(bytes: &[u8], max_pixels: usize) -> Result<HeightMap, MetroProError> {
    let smallest = HEADER_BYTES[0];
    if bytes.len() < 4 {
        return Err(MetroProError::TooShort {
            needed: smallest,
            got: bytes.len(),
        });
    }
    let magic = u32_at(bytes, 0);
    let format = MAGIC
        .iter()
        .position(|&m| m == magic)
        .ok_or(MetroProError::NotMetroPro { magic })?;
    let expected = HEADER_BYTES[format];
    if bytes.len() < expected {
        return Err(MetroProError::TooShort {
            needed: expected,
            got: bytes.len(),
        });
    }
    let (stated, header) = (u16_at(bytes, 4), u32_at(bytes, 6) as usize);
    if usize::from(stated) != format + 1 || header != expected {
        return Err(MetroProError::Header {
            format: format + 1,
            stated,
            bytes: header,
            expected,
        });
    }
    let (width, height) = (
        usize::from(u16_at(bytes, 68)),
        usize::from(u16_at(bytes, 70)),
    );
    if width == 0 || height == 0 {
        return Err(MetroProError::NoPhase);
    }
    // u16 dimensions: none of these products overflows a 64-bit usize.
    let pixels = width * height;
    let phase_bytes = 4 * pixels;
    let stated_phase = u32_at(bytes, 72) as usize;
    if stated_phase != phase_bytes {
        return Err(MetroProError::ByteCount {
            what: "phase",
            stated: stated_phase,
            width,
            height,
            frames: String::new(),
        });
    }
    let (iw, ih) = (
        usize::from(u16_at(bytes, 52)),
        usize::from(u16_at(bytes, 54)),
    );
    let frames = usize::from(u16_at(bytes, 56)).max(1);
    let intensity_bytes = if iw == 0 || ih == 0 {
        0
    } else {
        2 * iw * ih * frames
    };
    let stated_intensity = u32_at(bytes, 60) as usize;
    if stated_intensity != intensity_bytes {
        return Err(MetroProError::ByteCount {
            what: "intensity",
            stated: stated_intensity,
            width: iw,
            height: ih,
            frames: format!(" in {frames} frame(s)"),
        });
    }
    if pixels > max_pixels {
        return Err(MetroProError::TooLarge {
            pixels,
            max: max_pixels,
        });
    }
    let declared = header + intensity_bytes + phase_bytes;
    if bytes.len() < declared {
        return Err(MetroProError::Truncated {
            declared,
            got: bytes.len(),
        });
    }
    let resolution = match u16_at(bytes, 218) {
        0 => 4096.0,
        1 => 32768.0,
        2 => 131_072.0,
        code => return Err(MetroProError::PhaseResolution { code }),
    };
    let positive = |field, at| {
        let value = f32_at(bytes, at);
        if value.is_finite() && value > 0.0 {
            Ok(f64::from(value))
        } else {
            Err(MetroProError::Scale { field, value })
        }
    };
    let scale = positive("scale factor", 164)?;
    let wavelength_m = positive("wavelength", 168)?;
    let obliquity = positive("obliquity factor", 176)?;
    let sign = match u16_at(bytes, 232) {
        0 => 1.0,
        1 => -1.0,
        code => return Err(MetroProError::DataSign { code }),
    };
    let nm_per_count = sign * scale * obliquity * wavelength_m / resolution * 1e9;
    let start = header + intensity_bytes;
    let heights_nm: Vec<Option<f64>> = bytes[start..start + phase_bytes]
        .chunks_exact(4)
        .map(|raw| {
            let raw = i32::from_be_bytes([raw[0], raw[1], raw[2], raw[3]]);
            (raw < NO_DATA).then(|| f64::from(raw) * nm_per_count)
        })
        .collect();
    if heights_nm.iter().all(Option::is_none) {
        return Err(MetroProError::NoData);
    }
    let pixel_m = f64::from(f32_at(bytes, 184));
    Ok(HeightMap {
        width,
        height,
        heights_nm,
        pixel_mm: (pixel_m.is_finite() && pixel_m > 0.0).then_some(pixel_m * 1e3),
        wavelength_nm: Some(wavelength_m * 1e9),
    })
}
