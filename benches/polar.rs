//! The polar prediction (`usecases::map_predict`, what `POST /v1/maps/predict` runs): the exact
//! removal map of a plan on a 100 mm part (5 mm pad, 30 r/min on C, 200 on the pad), 101
//! stations 0.5 mm apart with 2 s each, a 1 mm pixel (7845 pixels on the part); C at constant
//! speed and under a sector law of 36 sectors (10°), and of 180 (2°) at a 2 mm pixel (1961
//! pixels: at 1 mm it passes the work limit). Beside it the
//! 1-D prediction of the same plan on 201 radii (`usecases::predict`), for the cost ratio.

use divan::Bencher;
use preston::physics::{PressureModel, ProcessSpec};
use preston::usecases::map_predict::{map_predict, CLawSpec, MapPredictCommand, MapPredictSpec};
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
