//! The X-Y machine's plan (`usecases::raster_optimize`, what `POST /v1/maps/optimize` runs with
//! `machine.kinematics: cartesian`), in-process and cold (nothing is cached between runs):
//!
//! - `fluid_jet`: the public case in fixtures/maps (a measured 26 × 372 surface of 0.32 mm
//!   pixels, a measured 115 × 115 fluid-jet spot), at the default pitch: 1,501 points.
//! - `scale`: a synthetic 1000 × 1000 map of 0.1 mm pixels, every pixel with data (a 100 mm
//!   square with astigmatism, trefoil and a zone), a Gaussian spot of σ = 1 mm on 0.2 mm
//!   samples, and dwell points 0.5 mm apart: 40,000 over the map, and the ring of those
//!   beyond it that the spot still reaches. One sample (it takes minutes); its peak memory
//!   is the process's high-water mark.

use divan::Bencher;
use preston::maps::{self, HeightMap};
use preston::optimize::problem::DEFAULT_TIME_WEIGHT;
use preston::optimize::raster::{AxisCaps, DEFAULT_RASTER_SMOOTHING};
use preston::usecases::raster::SpotSpec;
use preston::usecases::raster_optimize::{
    raster_optimize, RasterOptimizeCommand, RasterOptimizeSpec,
};

fn main() {
    divan::main();
}

fn fixture(name: &str) -> HeightMap {
    let path = format!("{}/fixtures/maps/{name}", env!("CARGO_MANIFEST_DIR"));
    maps::read(&std::fs::read(path).unwrap(), 1 << 24)
        .unwrap()
        .1
}

fn spec(spot: HeightMap, map: HeightMap, pitch: Option<f64>) -> RasterOptimizeSpec {
    RasterOptimizeSpec {
        spot: SpotSpec {
            map: spot,
            pixel_mm: None,
            duration_s: None,
            centre_px: None,
        },
        map,
        pixel_mm: None,
        dwell_pitch_mm: pitch,
        tilt_free: false,
        min_dwell_s: None,
        max_dwell_s: None,
        max_total_time_s: None,
        axes: [AxisCaps {
            max_velocity_mm_per_min: Some(10_000.0),
            max_acceleration_mm_per_s2: Some(2_000.0),
        }; 2],
        smoothing: DEFAULT_RASTER_SMOOTHING,
        time_weight: DEFAULT_TIME_WEIGHT,
        time_limit_s: f64::INFINITY,
    }
}

#[divan::bench(sample_count = 10)]
fn fluid_jet(bencher: Bencher) {
    let (spot, map) = (
        fixture("fluid_jet_tif.txt"),
        fixture("fluid_jet_surface.txt"),
    );
    bencher.bench(|| {
        let command = RasterOptimizeCommand::new(spec(spot.clone(), map.clone(), None)).unwrap();
        divan::black_box(raster_optimize(command).unwrap())
    });
}

fn scale_case() -> (HeightMap, HeightMap) {
    let n = 1000;
    let rows = (0..n)
        .map(|r| {
            (0..n)
                .map(|c| {
                    let (x, y) = (
                        (c as f64 - 499.5) * 0.1 / 50.0,
                        (499.5 - r as f64) * 0.1 / 50.0,
                    );
                    let (rho2, theta) = (x * x + y * y, y.atan2(x));
                    Some(
                        60.0 * rho2 * (2.0 * theta).cos()
                            + 40.0 * rho2.powf(1.5) * (3.0 * theta).cos()
                            + 30.0 * (-(rho2.sqrt() - 0.6).powi(2) / 0.005).exp(),
                    )
                })
                .collect()
        })
        .collect();
    let map = HeightMap::from_rows(rows, Some(0.1), None, 1 << 24).unwrap();
    let spot_rows = (0..41)
        .map(|r| {
            (0..41)
                .map(|c| {
                    let (x, y) = ((c as f64 - 20.0) * 0.2, (r as f64 - 20.0) * 0.2);
                    Some(10.0 * (-(x * x + y * y) / 2.0).exp())
                })
                .collect()
        })
        .collect();
    let spot = HeightMap::from_rows(spot_rows, Some(0.2), None, 1 << 24).unwrap();
    (spot, map)
}

#[divan::bench(sample_count = 1, sample_size = 1)]
fn scale(bencher: Bencher) {
    let (spot, map) = scale_case();
    bencher.bench(|| {
        let command =
            RasterOptimizeCommand::new(spec(spot.clone(), map.clone(), Some(0.5))).unwrap();
        let plan = raster_optimize(command).unwrap();
        eprintln!(
            "scale: {} points, {:.2} → {:.3} nm RMS, {:?}, peak memory {}",
            plan.points_mm.len(),
            plan.before.rms,
            plan.after.rms,
            plan.solver,
            std::fs::read_to_string("/proc/self/status")
                .ok()
                .and_then(|s| s
                    .lines()
                    .find(|l| l.starts_with("VmHWM"))
                    .map(str::to_string))
                .unwrap_or_default()
        );
        divan::black_box(plan)
    });
}
