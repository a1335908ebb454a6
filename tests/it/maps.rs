//! Interferometer maps: the MetroPro reader on the real Fizeau map shipped in prysm's
//! repository, against an independent reader written here from the file format (docs of
//! `preston::maps::metropro`), and on synthetic files of every header format written by an
//! independent generator, good and broken.

use preston::maps::metropro::{read, MetroProError};

const SAMPLE: &str = "fixtures/maps/valid_zygo_dat_file.dat";
const MAX_PIXELS: usize = 4_000_000;

pub(super) fn sample() -> Vec<u8> {
    std::fs::read(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(SAMPLE)).unwrap()
}

/// The independent reader: the phase map as (width, height, heights in nm or NaN), read
/// field by field with slices, the scale in the order the MetroPro manual writes it.
pub(super) fn reference(bytes: &[u8]) -> (usize, usize, Vec<f64>) {
    let be16 = |at: usize| u16::from_be_bytes(bytes[at..at + 2].try_into().unwrap()) as usize;
    let be32 = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
    let float = |at: usize| f32::from_be_bytes(bytes[at..at + 4].try_into().unwrap()) as f64;
    let header = be32(6) as usize;
    let intensity = be32(60) as usize;
    let (w, h) = (be16(68), be16(70));
    let r = [4096.0, 32768.0, 131072.0][be16(218)];
    let (s, wl, o) = (float(164), float(168), float(176));
    let heights = (0..w * h)
        .map(|k| {
            let at = header + intensity + 4 * k;
            let raw = i32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
            if raw >= 2_147_483_640 {
                f64::NAN
            } else {
                // (raw · S · O · W / R) in m, to nm.
                (raw as f64 * s * o * wl / r) * 1e9
            }
        })
        .collect();
    (w, h, heights)
}

fn pv_rms(values: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let (lo, hi) = values
        .clone()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let n = values.clone().count() as f64;
    let mean = values.clone().sum::<f64>() / n;
    let rms = (values.map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    (hi - lo, rms)
}

/// The real map: its size, pitch and wavelength as its header states them, the same valid
/// pixels, and PV and RMS (about the mean, every valid pixel alike) within 1e-9 relative of
/// the independent reader (both sum the same doubles; only the scale's order differs).
#[test]
fn the_fizeau_sample_reads_as_the_independent_reader_does() {
    let bytes = sample();
    let map = read(&bytes, MAX_PIXELS).unwrap();
    let (w, h, heights) = reference(&bytes);
    assert_eq!((map.width(), map.height()), (w, h));
    assert_eq!((w, h), (425, 432));
    assert!((map.pixel_mm().unwrap() - 0.117_924_2).abs() < 1e-7);
    assert!((map.wavelength_nm().unwrap() - 632.8).abs() < 1e-4);
    let valid: Vec<f64> = heights.iter().copied().filter(|v| !v.is_nan()).collect();
    assert_eq!(map.valid_pixels(), valid.len());
    for (ours, theirs) in map.heights_nm().iter().zip(&heights) {
        assert_eq!(ours.is_none(), theirs.is_nan());
    }
    let (pv, rms) = pv_rms(map.heights_nm().iter().flatten().copied());
    let (pv_ref, rms_ref) = pv_rms(valid.iter().copied());
    println!(
        "sample: {} valid pixels of {}, PV {pv:.6} nm, RMS {rms:.6} nm",
        valid.len(),
        w * h
    );
    assert!((pv - pv_ref).abs() <= 1e-9 * pv_ref);
    assert!((rms - rms_ref).abs() <= 1e-9 * rms_ref);
    // Row 0 is the top row as stored.
    assert_eq!(map.at(0, 0), map.heights_nm()[0]);
    assert_eq!(map.at(w, 0), None);
}

/// The independent generator: a MetroPro file of header format `format` (1, 2 or 3) with an
/// intensity frame, phase resolution code `code`, and the raw phase values `raw` (w × h).
pub(super) fn synthetic(format: u16, code: u16, w: u16, h: u16, raw: &[i32]) -> Vec<u8> {
    let header = if format == 3 { 4096 } else { 834 };
    let (iw, ih) = (3_u16, 2_u16);
    let mut bytes = vec![0_u8; header];
    let put = |bytes: &mut Vec<u8>, at: usize, field: &[u8]| {
        bytes[at..at + field.len()].copy_from_slice(field)
    };
    put(
        &mut bytes,
        0,
        &(0x881B_036E + u32::from(format)).to_be_bytes(),
    );
    put(&mut bytes, 4, &format.to_be_bytes());
    put(&mut bytes, 6, &(header as u32).to_be_bytes());
    put(&mut bytes, 52, &iw.to_be_bytes());
    put(&mut bytes, 54, &ih.to_be_bytes());
    put(&mut bytes, 56, &1_u16.to_be_bytes());
    put(
        &mut bytes,
        60,
        &(2 * u32::from(iw) * u32::from(ih)).to_be_bytes(),
    );
    put(&mut bytes, 68, &w.to_be_bytes());
    put(&mut bytes, 70, &h.to_be_bytes());
    put(
        &mut bytes,
        72,
        &(4 * u32::from(w) * u32::from(h)).to_be_bytes(),
    );
    put(&mut bytes, 164, &0.5_f32.to_be_bytes());
    put(&mut bytes, 168, &632.8e-9_f32.to_be_bytes());
    put(&mut bytes, 176, &1.25_f32.to_be_bytes());
    put(&mut bytes, 184, &0.25e-3_f32.to_be_bytes());
    put(&mut bytes, 218, &code.to_be_bytes());
    bytes.extend((0..u32::from(iw) * u32::from(ih)).flat_map(|v| (v as u16 * 7).to_be_bytes()));
    bytes.extend(raw.iter().flat_map(|v| v.to_be_bytes()));
    bytes
}

/// Every header format and phase resolution: each planted raw value comes back as its height
/// (to 1e-15 relative: the same product, possibly in another order), no-data as missing, rows
/// in the order written.
#[test]
fn synthetic_files_of_every_format_and_resolution_read_back() {
    let (w, h) = (4_u16, 3_u16);
    let raw: Vec<i32> = vec![
        0,
        1,
        -1,
        4096, //
        2_147_483_640,
        123_456,
        -654_321,
        i32::MAX, //
        2_147_483_639,
        -2_147_483_648,
        17,
        2_147_483_641,
    ];
    for format in 1..=3 {
        for (code, r) in [(0_u16, 4096.0), (1, 32768.0), (2, 131_072.0)] {
            let map = read(&synthetic(format, code, w, h, &raw), MAX_PIXELS).unwrap();
            assert_eq!((map.width(), map.height()), (4, 3));
            // The header holds the pitch as an f32 in m: 2^-24 relative.
            assert!((map.pixel_mm().unwrap() - 0.25).abs() < 0.25 * 6e-8);
            let scale = 0.5 * 1.25 * f64::from(632.8e-9_f32) / r * 1e9;
            for (k, &v) in raw.iter().enumerate() {
                let got = map.at(k % 4, k / 4);
                if v >= 2_147_483_640 {
                    assert_eq!(got, None, "format {format} code {code} pixel {k}");
                } else {
                    let want = f64::from(v) * scale;
                    let got = got.unwrap();
                    assert!((got - want).abs() <= 1e-15 * want.abs(), "{got} vs {want}");
                }
            }
        }
    }
}

/// Broken files are refused with what is wrong, before anything is allocated for the sizes
/// they declare.
#[test]
fn broken_files_are_refused_naming_what_is_wrong() {
    let raw = vec![5; 6];
    let good = synthetic(1, 1, 3, 2, &raw);
    assert!(read(&good, MAX_PIXELS).is_ok());
    let err = |bytes: &[u8]| read(bytes, MAX_PIXELS).unwrap_err();

    assert!(matches!(err(&good[..3]), MetroProError::TooShort { .. }));
    assert!(matches!(
        err(&good[..500]),
        MetroProError::TooShort { needed: 834, .. }
    ));
    let mut png = good.clone();
    png[..4].copy_from_slice(b"\x89PNG");
    let e = err(&png);
    assert!(
        e.to_string().contains("not a Zygo MetroPro .dat file"),
        "{e}"
    );
    // Truncated by one byte.
    let e = err(&good[..good.len() - 1]);
    assert!(matches!(e, MetroProError::Truncated { .. }), "{e}");
    // The magic of format 3 with format 1's header size.
    let mut mixed = good.clone();
    mixed[..4].copy_from_slice(&0x881B_0371_u32.to_be_bytes());
    mixed.resize(5000, 0);
    assert!(matches!(err(&mixed), MetroProError::Header { .. }));
    // Sizes that disagree, or beyond the limit: a tiny file declaring 30000 × 30000 pixels.
    let mut huge = good.clone();
    huge[68..70].copy_from_slice(&30_000_u16.to_be_bytes());
    huge[70..72].copy_from_slice(&30_000_u16.to_be_bytes());
    assert!(matches!(
        err(&huge),
        MetroProError::ByteCount { what: "phase", .. }
    ));
    huge[72..76].copy_from_slice(&(4 * 30_000_u32 * 30_000).to_be_bytes());
    let e = err(&huge);
    assert!(
        matches!(
            e,
            MetroProError::TooLarge {
                pixels: 900_000_000,
                ..
            }
        ),
        "{e}"
    );
    let e = read(&huge, usize::MAX).unwrap_err();
    assert!(matches!(e, MetroProError::Truncated { .. }), "{e}");
    let mut frames = good.clone();
    frames[56..58].copy_from_slice(&2_u16.to_be_bytes());
    assert!(matches!(
        err(&frames),
        MetroProError::ByteCount {
            what: "intensity",
            ..
        }
    ));
    let mut code = good.clone();
    code[218..220].copy_from_slice(&7_u16.to_be_bytes());
    assert_eq!(err(&code), MetroProError::PhaseResolution { code: 7 });
    let mut scale = good.clone();
    scale[164..168].copy_from_slice(&f32::NAN.to_be_bytes());
    assert!(matches!(
        err(&scale),
        MetroProError::Scale {
            field: "scale factor",
            ..
        }
    ));
    let empty = synthetic(2, 1, 3, 2, &[2_147_483_647; 6]);
    assert_eq!(err(&empty), MetroProError::NoData);
    let mut none = good.clone();
    none[68..70].copy_from_slice(&0_u16.to_be_bytes());
    assert_eq!(err(&none), MetroProError::NoPhase);
}

/// Peak resident memory of this process so far, KiB (Linux's VmHWM).
fn peak_rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// A million mutated files: bytes flipped, header fields overwritten with boundary and random
/// values, truncated and extended, from synthetic files of every format and from the real
/// sample's header. The reader never panics, and what it accepts it holds in at most 4 bytes
/// of heights per byte of the file (16 per pixel, a pixel being 4 bytes of the file): its only
/// allocation is bounded by the input, whatever the header declares.
#[test]
fn a_million_mutated_files_never_panic_nor_allocate_beyond_the_input() {
    let mut rng = fastrand::Rng::with_seed(48_49);
    let real = sample();
    // The real header with a small phase map (its intensity frame dropped).
    let mut real_small = real[..834].to_vec();
    real_small[52..56].copy_from_slice(&[0, 0, 0, 0]);
    real_small[60..64].copy_from_slice(&0_u32.to_be_bytes());
    real_small[68..72].copy_from_slice(&[0, 8, 0, 8]);
    real_small[72..76].copy_from_slice(&256_u32.to_be_bytes());
    real_small.extend(real[834 + 614_400..][..256].iter());
    let seeds: Vec<Vec<u8>> = vec![
        synthetic(1, 1, 3, 2, &[5, -7, 2_147_483_640, 9, 11, 0]),
        synthetic(2, 0, 5, 4, &[1; 20]),
        synthetic(3, 2, 2, 2, &[i32::MIN, i32::MAX, 0, 3]),
        real_small,
    ];
    let fields = [0, 4, 6, 52, 54, 56, 60, 68, 70, 72, 164, 168, 176, 184, 218];
    let (mut accepted, mut refused) = (0_u32, 0_u32);
    const MUTATIONS: u32 = 1_000_000;
    for _ in 0..MUTATIONS {
        let mut bytes = seeds[rng.usize(..seeds.len())].clone();
        for _ in 0..rng.usize(1..=4) {
            match rng.u8(..5) {
                0 => {
                    let at = rng.usize(..bytes.len());
                    bytes[at] ^= 1 << rng.u8(..8);
                }
                1 => {
                    let at = fields[rng.usize(..fields.len())];
                    if at >= bytes.len() {
                        continue;
                    }
                    let value: [u8; 4] = match rng.u8(..4) {
                        0 => [0; 4],
                        1 => [0xFF; 4],
                        2 => [0x7F, 0xFF, 0xFF, 0xF8],
                        _ => rng.u32(..).to_be_bytes(),
                    };
                    let end = (at + 4).min(bytes.len());
                    let span = end - at;
                    bytes[at..end].copy_from_slice(&value[..span]);
                }
                2 => bytes.truncate(rng.usize(..=bytes.len())),
                3 => bytes.extend((0..rng.usize(..64)).map(|_| rng.u8(..))),
                _ => {
                    let at = rng.usize(..bytes.len().max(1));
                    if at < bytes.len() {
                        bytes[at] = rng.u8(..);
                    }
                }
            }
            if bytes.is_empty() {
                break;
            }
        }
        match read(&bytes, MAX_PIXELS) {
            Ok(map) => {
                accepted += 1;
                let held = std::mem::size_of_val(map.heights_nm());
                assert!(
                    held <= 4 * bytes.len(),
                    "{held} bytes of heights from {}",
                    bytes.len()
                );
            }
            Err(_) => refused += 1,
        }
    }
    assert_eq!(accepted + refused, MUTATIONS);
    assert!(
        accepted > 10_000 && refused > 10_000,
        "{accepted} / {refused}"
    );
    println!(
        "{MUTATIONS} mutated files: {accepted} read, {refused} refused, no panic; peak RSS {} KiB",
        peak_rss_kib().map_or("unknown".into(), |k| k.to_string())
    );
}

/// The map as a text grid (`preston::maps::grid`), every height in Rust's shortest
/// round-trip form, missing pixels as empty cells or `NaN`.
fn as_text_grid(map: &preston::maps::HeightMap) -> String {
    let mut text = format!(
        "# written by the tests\n# pixel_mm: {}\n# unit: nm\n",
        map.pixel_mm().unwrap()
    );
    for row in map.heights_nm().chunks(map.width()) {
        let cells: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(k, h)| match h {
                Some(h) => h.to_string(),
                None if k % 2 == 0 => String::new(),
                None => "NaN".to_string(),
            })
            .collect();
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    text
}

/// The real map written as a text grid reads back with the same heights, bit for bit, and
/// the same missing pixels and pitch; in µm and in waves it gives the same heights to 1e-15.
#[test]
fn the_sample_as_a_text_grid_reads_back_identically() {
    use preston::maps::grid;
    let map = read(&sample(), MAX_PIXELS).unwrap();
    let text = as_text_grid(&map);
    let again = grid::read(text.as_bytes(), MAX_PIXELS).unwrap();
    assert_eq!((again.width(), again.height()), (map.width(), map.height()));
    assert_eq!(again.pixel_mm(), map.pixel_mm());
    assert_eq!(again.heights_nm(), map.heights_nm());

    let micrometres = text
        .replace("# unit: nm", "# unit: um\n# missing: -")
        .lines()
        .map(|line| {
            if line.starts_with('#') {
                return line.to_string();
            }
            let cells: Vec<String> = line
                .split(',')
                .map(|c| match c.parse::<f64>() {
                    Ok(v) => (v / 1e3).to_string(),
                    Err(_) => "-".to_string(),
                })
                .collect();
            cells.join(";")
        })
        .collect::<Vec<_>>()
        .join("\n");
    let um = grid::read(micrometres.as_bytes(), MAX_PIXELS).unwrap();
    for (a, b) in um.heights_nm().iter().zip(map.heights_nm()) {
        match (a, b) {
            (Some(a), Some(b)) => assert!((a - b).abs() <= 1e-15 * b.abs().max(1.0)),
            _ => assert_eq!(a.is_none(), b.is_none()),
        }
    }
    let waves = grid::read(
        b"# unit: waves\n# wavelength_nm: 632.8\n0.5 -0.25\n\n1 nan\n",
        MAX_PIXELS,
    )
    .unwrap();
    assert_eq!(
        waves.heights_nm(),
        [Some(316.4), Some(-158.2), Some(632.8), None]
    );
    assert_eq!(waves.pixel_mm(), None);
}

#[test]
fn broken_text_grids_are_refused_naming_the_line() {
    use preston::maps::grid::{read, TextGridError};
    let err = |text: &str| read(text.as_bytes(), 100).unwrap_err();
    assert_eq!(
        err("1,2,3\n4,5\n"),
        TextGridError::Ragged {
            line: 2,
            got: 2,
            expected: 3
        }
    );
    assert_eq!(
        err("# pixel: 0.1\n1\n"),
        TextGridError::UnknownKey {
            line: 1,
            key: "pixel".into()
        }
    );
    assert!(matches!(
        err("# pixel_mm: -1\n1\n"),
        TextGridError::NotPositive { line: 1, .. }
    ));
    assert!(matches!(
        err("# unit: inch\n1\n"),
        TextGridError::Unit { line: 1, .. }
    ));
    assert_eq!(err("# unit: waves\n1\n"), TextGridError::NoWavelength);
    assert_eq!(
        err("1,2\n3,inf\n"),
        TextGridError::NotANumber {
            line: 2,
            column: 2,
            cell: "inf".into()
        }
    );
    assert_eq!(err("# only a header\n"), TextGridError::Empty);
    assert_eq!(err(",\nNaN,\n"), TextGridError::NoData);
    assert_eq!(err(&"1 ".repeat(101)), TextGridError::TooLarge { max: 100 });
    assert_eq!(read(b"\xff\xfe1", 100).unwrap_err(), TextGridError::NotText);
    // A comment may hold a colon after words; a decimal comma is not a decimal point.
    assert!(read(b"# measured on 2026-11-27 at 10:00\n1;2\n", 100).is_ok());
    assert!(matches!(
        err("1,5;2,5\n"),
        TextGridError::NotANumber {
            line: 1,
            column: 1,
            ..
        }
    ));
}

/// Solves the 3 × 3 system `a`·v = `b` by Gaussian elimination with partial pivoting.
fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> [f64; 3] {
    for col in 0..3 {
        let pivot = (col..3)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap();
        a.swap(col, pivot);
        b.swap(col, pivot);
        let pivot_row = a[col];
        for row in col + 1..3 {
            let f = a[row][col] / pivot_row[col];
            for (v, p) in a[row].iter_mut().zip(pivot_row).skip(col) {
                *v -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut v = [0.0; 3];
    for row in (0..3).rev() {
        let s: f64 = (row + 1..3).map(|k| a[row][k] * v[k]).sum();
        v[row] = (b[row] - s) / a[row][row];
    }
    v
}

/// Piston and tilt removed from the real map: PV and RMS within 1e-9 relative of the
/// independent reader's heights less the plane from the uncentred 3 × 3 normal equations
/// (Gaussian elimination; its rounding, ~1e-13 relative on these sums, is far below the
/// bound), and a plane planted on a synthetic map removed to 1e-9 nm.
#[test]
fn piston_and_tilt_come_off_as_an_independent_least_squares_plane() {
    let bytes = sample();
    let (w, _, heights) = reference(&bytes);
    let valid: Vec<(f64, f64, f64)> = heights
        .iter()
        .enumerate()
        .filter(|(_, z)| !z.is_nan())
        .map(|(k, &z)| ((k % w) as f64, (k / w) as f64, z))
        .collect();
    let mut normal = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    for &(x, y, z) in &valid {
        let basis = [1.0, x, y];
        for i in 0..3 {
            for j in 0..3 {
                normal[i][j] += basis[i] * basis[j];
            }
            rhs[i] += basis[i] * z;
        }
    }
    let [a, b, c] = solve3(normal, rhs);
    let residual: Vec<f64> = valid
        .iter()
        .map(|&(x, y, z)| z - a - b * x - c * y)
        .collect();
    let lo = residual.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = residual.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let rms_ref = (residual.iter().map(|r| r * r).sum::<f64>() / residual.len() as f64).sqrt();

    let map = read(&bytes, MAX_PIXELS).unwrap().without_piston_and_tilt();
    let figures = map.figures().unwrap();
    let (pv, rms) = (figures.pv, figures.rms);
    println!("sample less piston and tilt: PV {pv:.6} nm, RMS {rms:.6} nm (tilt {b:.3e}, {c:.3e} nm/pixel)");
    assert!((pv - (hi - lo)).abs() <= 1e-9 * (hi - lo));
    assert!((rms - rms_ref).abs() <= 1e-9 * rms_ref);

    // A plane planted on a synthetic map (with missing pixels) comes off entirely.
    let mut text = String::from("# unit: nm\n");
    for row in 0..7 {
        let cells: Vec<String> = (0..9)
            .map(|col| {
                if (row * 9 + col) % 5 == 3 {
                    "NaN".to_string()
                } else {
                    (12.5 + 0.75 * col as f64 - 1.25 * row as f64).to_string()
                }
            })
            .collect();
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    let flat = preston::maps::grid::read(text.as_bytes(), MAX_PIXELS)
        .unwrap()
        .without_piston_and_tilt();
    assert!(
        flat.heights_nm().iter().flatten().all(|h| h.abs() < 1e-9),
        "{flat:?}"
    );
}

/// Half a million mutated text files, through the reader that tells formats apart (Zygo XYZ
/// and ASCII, Code V, text grid; a MetroPro magic number or HDF5 signature may appear by
/// mutation too): characters flipped, tokens replaced by boundary values, lines duplicated or
/// dropped, truncated. No panic, and what is accepted holds at most 16 bytes of heights per
/// byte of the file: a text pixel takes one byte at least (an empty grid cell is its
/// separator), held as 16; the readers refuse a declared window larger than the file can list
/// before allocating it.
#[test]
fn half_a_million_mutated_text_maps_never_panic_nor_allocate_beyond_the_input() {
    let mut rng = fastrand::Rng::with_seed(49_49);
    let xyz = "Zygo XYZ Data File - Format 1\n0 8 1 0 \"date\"\n0 0 0 0 0 0\n0 0 3 2\n\"\"\n\"\"\n\"\"\n\
               0 0.5 6.328e-7 0 1 1 2.5e-4 0\n640 480 0 0 0 0 \"\"\n0 0 0 0 0 0 0 0 0 0\n1 1 20 2 0 0 0 0 0\n\
               0 \"\"\n1 0\n\"\"\n#\n0 0 0.001\n1 0 No Data\n2 0 -0.002\n0 1 0.5\n1 1 0.25\n2 1 No Data\n#\n";
    let ascii = xyz
        .split("#\n")
        .next()
        .unwrap()
        .replace("XYZ Data File - Format 1", "ASCII Data File - Format 2")
        + "#\n1 2 3\n#\n5 -7 2147483647 9\n11 0\n#\n";
    let codev =
        "! comment\ntitle\nGRD 3 2 SUR WVL 0.6328 SSZ 65536 NDA -32768\n1 2 -32768\n4 5 6\n";
    let grid = "# pixel_mm: 0.5\n# unit: um\n1,2,\n,4,5.5\n";
    let seeds: Vec<Vec<u8>> = [xyz, ascii.as_str(), codev, grid]
        .iter()
        .map(|s| s.as_bytes().to_vec())
        .collect();
    let tokens: [&[u8]; 12] = [
        b"65535",
        b"0",
        b"-1",
        b"4294967296",
        b"1e308",
        b"nan",
        b"inf",
        b"No Data",
        b"#",
        b"\"",
        b"99999999999999999999",
        b"\n",
    ];
    let (mut accepted, mut refused) = (0_u32, 0_u32);
    const MUTATIONS: u32 = 500_000;
    for _ in 0..MUTATIONS {
        let mut bytes = seeds[rng.usize(..seeds.len())].clone();
        for _ in 0..rng.usize(1..=3) {
            if bytes.is_empty() {
                break;
            }
            let at = rng.usize(..bytes.len());
            match rng.u8(..6) {
                0 => bytes[at] ^= 1 << rng.u8(..8),
                1 => {
                    // Replace the token at `at` by a boundary value.
                    let end = (at..bytes.len())
                        .find(|&i| bytes[i].is_ascii_whitespace())
                        .unwrap_or(bytes.len());
                    let token = tokens[rng.usize(..tokens.len())];
                    bytes.splice(at..end, token.iter().copied());
                }
                2 => bytes.truncate(at),
                3 => {
                    // Duplicate a line.
                    let start = bytes[..at]
                        .iter()
                        .rposition(|&b| b == b'\n')
                        .map_or(0, |i| i + 1);
                    let end = (at..bytes.len())
                        .find(|&i| bytes[i] == b'\n')
                        .map_or(bytes.len(), |i| i + 1);
                    let line = bytes[start..end].to_vec();
                    bytes.splice(start..start, line);
                }
                4 => {
                    // Drop a line.
                    let start = bytes[..at]
                        .iter()
                        .rposition(|&b| b == b'\n')
                        .map_or(0, |i| i + 1);
                    let end = (at..bytes.len())
                        .find(|&i| bytes[i] == b'\n')
                        .map_or(bytes.len(), |i| i + 1);
                    bytes.drain(start..end);
                }
                _ => bytes.insert(at, rng.u8(..)),
            }
        }
        match preston::maps::read(&bytes, MAX_PIXELS) {
            Ok((_, map)) => {
                accepted += 1;
                let held = std::mem::size_of_val(map.heights_nm());
                assert!(
                    held <= 16 * bytes.len().max(1),
                    "{held} bytes of heights from {}",
                    bytes.len()
                );
            }
            Err(_) => refused += 1,
        }
    }
    assert!(
        accepted > 10_000 && refused > 10_000,
        "{accepted} / {refused}"
    );
    println!(
        "{MUTATIONS} mutated text maps: {accepted} read, {refused} refused, no panic; peak RSS {} KiB",
        peak_rss_kib().map_or("unknown".into(), |k| k.to_string())
    );
}

/// The synthetic Zygo Mx maps (`scripts/make_datx_fixture.py`, written with h5py: contiguous,
/// and chunked with deflate) read as their generator's sidecar says: every height to 1e-9 nm
/// (the generator's own rounding is 1e-6 nm of the planted values; the sidecar holds the
/// heights the file's raw values stand for), the same pixels missing, the pitch and the
/// wavelength from the file.
#[test]
fn synthetic_datx_files_read_as_their_generator_wrote_them() {
    for name in ["synthetic", "synthetic_gzip"] {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/maps/");
        let bytes = std::fs::read(format!("{dir}{name}.datx")).unwrap();
        let truth: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(format!("{dir}{name}.json")).unwrap())
                .unwrap();
        let (format, map) = preston::maps::read(&bytes, MAX_PIXELS).unwrap();
        assert_eq!(format, preston::maps::Format::Datx);
        assert_eq!((map.width(), map.height()), (48, 40), "{name}");
        assert_eq!(map.pixel_mm(), truth["pixel_size_mm"].as_f64(), "{name}");
        let wavelength = truth["wavelength_m"].as_f64().unwrap() * 1e9;
        assert!((map.wavelength_nm().unwrap() - wavelength).abs() < 1e-9);
        let rows = truth["heights_nm"].as_array().unwrap();
        let mut worst: f64 = 0.0;
        for (r, row) in rows.iter().enumerate() {
            for (c, want) in row.as_array().unwrap().iter().enumerate() {
                match (map.at(c, r), want.as_f64()) {
                    (Some(got), Some(want)) => worst = worst.max((got - want).abs()),
                    (None, None) => {}
                    (got, want) => panic!("{name} ({c}, {r}): {got:?} vs {want:?}"),
                }
            }
        }
        assert!(worst < 1e-9, "{name}: {worst} nm");
        assert_eq!(
            map.valid_pixels() as u64,
            truth["valid_count"].as_u64().unwrap()
        );
        // Cut short, it says so.
        let error = preston::maps::read(&bytes[..2000], MAX_PIXELS)
            .unwrap_err()
            .to_string();
        assert!(
            error.starts_with("Zygo Mx .datx: the file is truncated or damaged"),
            "{error}"
        );
    }
}

/// A 3.5 kB .datx declaring a 4096 × 4096 surface it never wrote (chunked, no chunk stored,
/// `scripts/make_datx_fixture.py --hollow`): within the pixel limit, but 16.8 M values of at
/// least 4 bytes cannot come out of 3.5 kB even at deflate's largest expansion (1032×), so it
/// is refused before 134 MB are allocated for it, in words that say so.
#[test]
fn a_datx_declaring_more_than_its_file_holds_is_refused_before_allocating() {
    let bytes = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/maps/hollow.datx"
    ))
    .unwrap();
    assert!(bytes.len() < 4096);
    let error = preston::maps::read(&bytes, 4096 * 4096)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("declares 16777216 pixels, more than its")
            && error.contains("-byte file could hold"),
        "{error}"
    );
}

/// Mutated .datx files (bytes flipped or overwritten, truncated, extended) from both synthetic
/// maps: the reader never panics, and a map it accepts holds at most 16 bytes a pixel of a
/// surface whose size the pixel limit bounds before anything is read.
#[test]
fn mutated_datx_files_never_panic() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/maps/");
    let seeds: Vec<Vec<u8>> = ["synthetic.datx", "synthetic_gzip.datx"]
        .iter()
        .map(|n| std::fs::read(format!("{dir}{n}")).unwrap())
        .collect();
    let mut rng = fastrand::Rng::with_seed(50_49);
    let (mut accepted, mut refused) = (0_u32, 0_u32);
    const MUTATIONS: u32 = 200_000;
    for _ in 0..MUTATIONS {
        let mut bytes = seeds[rng.usize(..seeds.len())].clone();
        for _ in 0..rng.usize(1..=4) {
            if bytes.is_empty() {
                break;
            }
            let at = rng.usize(..bytes.len());
            match rng.u8(..5) {
                0 => bytes[at] ^= 1 << rng.u8(..8),
                1 => {
                    let value: [u8; 8] = match rng.u8(..3) {
                        0 => [0; 8],
                        1 => [0xFF; 8],
                        _ => rng.u64(..).to_le_bytes(),
                    };
                    let end = (at + 8).min(bytes.len());
                    let span = end - at;
                    bytes[at..end].copy_from_slice(&value[..span]);
                }
                2 => bytes.truncate(at),
                3 => bytes.extend((0..rng.usize(..64)).map(|_| rng.u8(..))),
                _ => bytes[at] = rng.u8(..),
            }
        }
        match preston::maps::read(&bytes, MAX_PIXELS) {
            Ok(_) => accepted += 1,
            Err(_) => refused += 1,
        }
    }
    assert_eq!(accepted + refused, MUTATIONS);
    assert!(accepted > 100 && refused > 100, "{accepted} / {refused}");
    println!(
        "{MUTATIONS} mutated .datx files: {accepted} read, {refused} refused, no panic; peak RSS {} KiB",
        peak_rss_kib().map_or("unknown".into(), |k| k.to_string())
    );
}
