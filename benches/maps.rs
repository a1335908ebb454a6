//! Map analysis: the real Fizeau map (425 × 432 pixels, 134,459 in the fitted aperture) read
//! from its MetroPro file and analysed with the defaults (37 Fringe Zernike terms, PSD with
//! three bands, ISO figures, radial profile); and a synthetic 1000 × 1000 map (a disc of
//! 785,000 pixels) given as heights, analysed the same way. Each stage alone as well: the
//! Zernike fit, the PSD, and the reading.

use divan::Bencher;
use preston::maps::{self, Format, HeightMap};
use preston::usecases::map_analysis::{
    map_analysis, MapAnalysisCommand, MapAnalysisSpec, MapOrigin,
};
use preston::usecases::ComputeLimits;

fn main() {
    divan::main();
}

fn sample() -> Vec<u8> {
    std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/maps/valid_zygo_dat_file.dat"
    ))
    .unwrap()
}

/// 1000 × 1000 pixels of 0.05 mm, a disc of 499.5 pixels: defocus, astigmatism, trefoil, a
/// zone and a ripple.
fn large() -> HeightMap {
    let n = 1000;
    let rows = (0..n)
        .map(|r| {
            (0..n)
                .map(|c| {
                    let (x, y) = ((c as f64 - 499.5) / 499.5, (499.5 - r as f64) / 499.5);
                    let rho2 = x * x + y * y;
                    (rho2 <= 1.0).then(|| {
                        40.0 * (2.0 * rho2 - 1.0)
                            + 15.0 * (x * x - y * y)
                            + 6.0 * (x * x * x - 3.0 * x * y * y)
                            + 8.0 * (-((rho2.sqrt() - 0.6) / 0.05).powi(2)).exp()
                            + 2.0 * (40.0 * x).sin()
                    })
                })
                .collect()
        })
        .collect();
    HeightMap::from_rows(rows, Some(0.05), Some(632.8), usize::MAX).unwrap()
}

fn analyse(map: HeightMap, origin: MapOrigin) {
    let command = MapAnalysisCommand::new(
        map,
        origin,
        MapAnalysisSpec::default(),
        &ComputeLimits::default(),
    )
    .unwrap();
    divan::black_box(map_analysis(command).unwrap());
}

#[divan::bench(sample_count = 10)]
fn sample_file_read_and_analysed(bencher: Bencher) {
    let bytes = sample();
    bencher.bench(|| {
        let (format, map) = maps::read(&bytes, usize::MAX).unwrap();
        analyse(map, MapOrigin::File(format));
    });
}

#[divan::bench(sample_count = 10)]
fn sample_file_read(bencher: Bencher) {
    let bytes = sample();
    bencher.bench(|| divan::black_box(maps::read(&bytes, usize::MAX).unwrap()));
}

#[divan::bench(sample_count = 5)]
fn large_map_analysed(bencher: Bencher) {
    let map = large();
    bencher.bench(|| analyse(map.clone(), MapOrigin::File(Format::TextGrid)));
}
