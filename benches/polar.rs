//! The polar prediction (`usecases::map_predict`, what `POST /v1/maps/predict` runs): the exact
//! removal map of a plan on a 100 mm part (5 mm pad, 30 r/min on C, 200 on the pad), 101
//! stations 0.5 mm apart with 2 s each, a 1 mm pixel (7845 pixels on the part); C at constant
//! speed and under a sector law of 36 sectors (10°), and of 180 (2°) at a 2 mm pixel (1961
//! pixels: at 1 mm it passes the work limit). Beside it the
//! 1-D prediction of the same plan on 201 radii (`usecases::predict`), for the cost ratio.
//!
//! The polar plan (`usecases::map_optimize`, what `POST /v1/maps/optimize` runs) of the same
//! part at 0.5 mm × 2°: 101 stations 0.5 mm apart, 101 radii, 180 sectors, harmonics up to
//! what the pad resolves at the edge (32), correcting planted astigmatism and trefoil (20 nm
//! RMS each) on a 1 mm map, its maps by the plan's harmonic model (the exact map of so long a
//! plan is `/v1/maps/predict`'s work, measured above). Beside it the 1-D plan of the same part
//! (`usecases::optimize`: a uniform layer, the same stations and radii). Every run is
//! cold: a new operator cache each time (the service's, which keeps what one request assembles
//! for its second solve).

use divan::Bencher;
use preston::maps::HeightMap;
use preston::physics::{PressureModel, ProcessSpec};
use preston::usecases::map_analysis::Placement;
use preston::usecases::map_optimize::{
    map_optimize, MapOptimizeCommand, MapOptimizeSpec, RemovalModel,
};
use preston::usecases::map_predict::{map_predict, CLawSpec, MapPredictCommand, MapPredictSpec};
use preston::usecases::optimize::{optimize, OptimizeCommand, OptimizeSpec, TargetSpec};
use preston::usecases::predict::{predict, DwellSpec, PredictCommand, TravelSpec};
use preston::usecases::{
    ApertureSpec, ComputeLimits, GridSpec, OperatorCache, PartSpec, Recommender, Setting,
};

fn main() {
    divan::main();
}

fn process() -> ProcessSpec {
    ProcessSpec {
        workpiece_radius_mm: 50.0,
        tool_radius_mm: 5.0,
        workpiece_rpm: 30.0,
        tool_rpm: 200.0,
        preston_coefficient_m2_per_n: 1e-13,
        pressure_kpa: 10.0,
        pressure_model: PressureModel::Uniform,
        part: Default::default(),
    }
}

fn plan() -> (Vec<f64>, Vec<f64>) {
    ((0..101).map(|i| i as f64 * 0.5).collect(), vec![2.0; 101])
}

fn command(sectors: Option<usize>, pixel_mm: f64) -> MapPredictCommand {
    let (positions_mm, dwell_s) = plan();
    let c_law = sectors.map(|s| CLawSpec {
        sectors: s,
        speed_factors: vec![(0..s).map(|k| if k % 2 == 0 { 0.8 } else { 1.2 }).collect(); 101],
    });
    MapPredictCommand::new(
        MapPredictSpec {
            process: process(),
            part: PartSpec::default(),
            aperture: ApertureSpec::default(),
            grid: GridSpec::default(),
            positions_mm,
            dwell_s,
            c_law,
            start_angle_deg: None,
            pixel_mm: Some(pixel_mm),
            segments: None,
        },
        &ComputeLimits::default(),
    )
    .unwrap()
}

#[divan::bench(sample_count = 5)]
fn polar_constant_speed(bencher: Bencher) {
    bencher
        .with_inputs(|| command(None, 1.0))
        .bench_values(|c| divan::black_box(map_predict(c)));
}

#[divan::bench(sample_count = 3)]
fn polar_36_sectors(bencher: Bencher) {
    bencher
        .with_inputs(|| command(Some(36), 1.0))
        .bench_values(|c| divan::black_box(map_predict(c)));
}

#[divan::bench(sample_count = 2)]
fn polar_180_sectors(bencher: Bencher) {
    bencher
        .with_inputs(|| command(Some(180), 2.0))
        .bench_values(|c| divan::black_box(map_predict(c)));
}

/// The 1-D prediction of the same plan on 201 radii, its operator assembled every time.
#[divan::bench(sample_count = 20)]
fn one_dimensional(bencher: Bencher) {
    let recommender = Recommender::default();
    bencher
        .with_inputs(|| {
            let (positions_mm, dwell_s) = plan();
            let setting = Setting::new(
                process(),
                &PartSpec::default(),
                GridSpec::default(),
                ApertureSpec::default(),
                &ComputeLimits::default(),
            )
            .unwrap();
            PredictCommand::new(
                setting,
                TravelSpec {
                    dwell: Some(DwellSpec {
                        positions_mm,
                        dwell_s,
                    }),
                    feed: None,
                },
                &ComputeLimits::default(),
            )
            .unwrap()
        })
        .bench_values(|c| divan::black_box(predict(c, &recommender, &OperatorCache::new(0))));
}

/// The planted map: astigmatism and trefoil of 20 nm RMS each over the 100 mm part (unit-RMS
/// Zernike normalisation), 1 mm pixels.
fn planted_map() -> HeightMap {
    let (radius, n) = (50.0, 101);
    let rows = (0..n)
        .map(|i| {
            let y = 50.0 - i as f64;
            (0..n)
                .map(|j| {
                    let x = j as f64 - 50.0;
                    let r = x.hypot(y);
                    (r <= radius).then(|| {
                        let (rho, theta) = (r / radius, y.atan2(x));
                        20.0 * 6f64.sqrt() * rho * rho * (2.0 * theta).cos()
                            + 20.0 * 8f64.sqrt() * rho.powi(3) * (3.0 * theta + 0.4).cos()
                    })
                })
                .collect()
        })
        .collect();
    HeightMap::from_rows(rows, Some(1.0), None, 1 << 20).unwrap()
}

fn plan_setting() -> Setting {
    Setting::new(
        ProcessSpec {
            workpiece_rpm: -10.0,
            ..process()
        },
        &PartSpec::default(),
        GridSpec {
            start_mm: Some(0.0),
            stop_mm: Some(50.0),
            count: Some(101),
        },
        ApertureSpec {
            inner_mm: Some(0.0),
            outer_mm: Some(45.0),
        },
        &ComputeLimits::default(),
    )
    .unwrap()
}

fn plan_command(sectors: usize, removal_model: RemovalModel) -> MapOptimizeCommand {
    MapOptimizeCommand::new(
        plan_setting(),
        planted_map(),
        MapOptimizeSpec {
            optimize: OptimizeSpec {
                positions_mm: plan().0,
                ..Default::default()
            },
            placement: Placement {
                centre_px: Some((50.0, 50.0)),
                part_radius_mm: Some(50.0),
                ..Default::default()
            },
            sectors: Some(sectors),
            removal_model,
            ..Default::default()
        },
        &ComputeLimits::default(),
    )
    .unwrap()
}

#[divan::bench(sample_count = 10)]
fn polar_plan_180_sectors_harmonic_model(bencher: Bencher) {
    let recommender = Recommender::default();
    bencher
        .with_inputs(|| plan_command(180, RemovalModel::Harmonic))
        .bench_values(|c| {
            divan::black_box(map_optimize(c, &recommender, &OperatorCache::default()).unwrap())
        });
}

/// The 1-D plan of the same part: a uniform 100 nm over the clear aperture, on the same
/// stations and radii.
#[divan::bench(sample_count = 20)]
fn one_dimensional_plan(bencher: Bencher) {
    let recommender = Recommender::default();
    bencher
        .with_inputs(|| {
            OptimizeCommand::new(
                plan_setting(),
                OptimizeSpec {
                    positions_mm: plan().0,
                    target: TargetSpec {
                        uniform_depth_nm: Some(100.0),
                        profile: None,
                        free_piston: None,
                    },
                    ..Default::default()
                },
                &ComputeLimits::default(),
            )
            .unwrap()
        })
        .bench_values(|c| {
            divan::black_box(optimize(c, &recommender, &OperatorCache::default()).unwrap())
        });
}
