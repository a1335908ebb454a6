//! `POST /v1/predict` through the router (in-process, no socket): the paper's experiment 1
//! with 201 radial samples and 201 tool positions (fixtures/predict_paper_exp1_201.json).
//! Covers JSON parsing, validation, the operator (from the cache after the first request),
//! metrics and serialisation.
//!
//! And the prediction use case on 1001 radial samples × 1001 positions, repeated on the same
//! process: with the operator from the cache, and with no cache (assembled every time).

use axum::body::Body;
use axum::http::Request;
use http_body_util::BodyExt;
use preston::config::ServiceLimits;
use preston::http::{router, AppState};
use preston::machine::MachineLimits;
use preston::physics::{PressureModel, ProcessSpec};
use preston::surface::SurfaceSpec;
use preston::usecases::predict::{predict, DwellSpec, PredictCommand, TravelSpec};
use preston::usecases::{
    ApertureSpec, ComputeLimits, GridSpec, OperatorCache, PartSpec, Recommender, Setting,
};
use tower::ServiceExt;

fn main() {
    divan::main();
}

/// The router in-process, with a runtime to drive it and the 201 × 201 fixture's text.
struct Service {
    runtime: tokio::runtime::Runtime,
    app: axum::Router,
    fixture: String,
}

impl Service {
    fn new() -> Service {
        Service {
            runtime: tokio::runtime::Builder::new_multi_thread()
                .enable_all()
                .build()
                .unwrap(),
            app: router(AppState::new(ServiceLimits::default()), None),
            fixture: std::fs::read_to_string(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/fixtures/predict_paper_exp1_201.json"
            ))
            .unwrap(),
        }
    }

    /// `POST /v1/predict` with `body`; the response's bytes.
    fn predict(&self, body: String) -> axum::body::Bytes {
        self.runtime.block_on(async {
            let request = Request::post("/v1/predict")
                .header("content-type", "application/json")
                .body(Body::from(body))
                .unwrap();
            let response = self.app.clone().oneshot(request).await.unwrap();
            assert_eq!(response.status(), 200);
            response.into_body().collect().await.unwrap().to_bytes()
        })
    }
}

#[divan::bench]
fn predict_paper_201x201(bencher: divan::Bencher) {
    let service = Service::new();
    bencher.bench(|| service.predict(service.fixture.clone()));
}

/// A cold request: the fixture with a process no earlier request had, so neither the operator
/// nor the recommendation is cached. `new_eta`: a new workpiece speed (the η window of the
/// set-up is cached, the current-speed pass is not); `new_setup`: a new tool radius (the
/// window, both passes and the operator are computed).
#[divan::bench(args = ["new_eta", "new_setup"], sample_count = 50)]
fn predict_paper_201x201_cold(bencher: divan::Bencher, what: &str) {
    let service = Service::new();
    let fixture: serde_json::Value = serde_json::from_str(&service.fixture).unwrap();
    let field = if what == "new_eta" {
        "workpiece_rpm"
    } else {
        "tool_radius_mm"
    };
    let counter = std::sync::atomic::AtomicU32::new(0);
    bencher
        .with_inputs(|| {
            let k = 1 + counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let mut body = fixture.clone();
            let value = body["process"][field].as_f64().unwrap();
            body["process"][field] = serde_json::json!(value * (1.0 + 1e-9 * k as f64));
            body.to_string()
        })
        .bench_values(|body| service.predict(body));
}

/// The paper's experiment 1 set up on `count` radial samples over [0, 50] mm, the aperture
/// [0, 40] mm, with a tool of radius `tool_radius_mm` and the workpiece at `workpiece_rpm`,
/// on `surface`.
fn paper_setting(
    count: usize,
    tool_radius_mm: f64,
    workpiece_rpm: f64,
    surface: SurfaceSpec,
) -> Setting {
    let part = PartSpec {
        surface: Some(surface),
        ..PartSpec::default()
    };
    Setting::new(
        ProcessSpec {
            workpiece_radius_mm: 50.0,
            tool_radius_mm,
            workpiece_rpm,
            tool_rpm: 200.0,
            preston_coefficient_m2_per_n: 1e-13,
            pressure_kpa: 10.0,
            pressure_model: PressureModel::Uniform,
            part: part.parse().unwrap().part,
        },
        &part,
        GridSpec {
            start_mm: Some(0.0),
            stop_mm: Some(50.0),
            count: Some(count),
        },
        ApertureSpec {
            inner_mm: Some(0.0),
            outer_mm: Some(40.0),
        },
        &ComputeLimits::default(),
    )
    .unwrap()
}

/// The paper's experiment 1 on `count` radial samples × `count` positions (10 s each), at
/// workpiece speed `workpiece_rpm`, on `surface`.
fn paper(count: usize, workpiece_rpm: f64, surface: SurfaceSpec) -> PredictCommand {
    let limits = ComputeLimits::default();
    let setting = paper_setting(count, 10.0, workpiece_rpm, surface);
    let positions: Vec<f64> = (0..count)
        .map(|j| 50.0 * j as f64 / (count - 1) as f64)
        .collect();
    let travel = TravelSpec {
        dwell: Some(DwellSpec {
            dwell_s: vec![10.0; count],
            positions_mm: positions,
        }),
        feed: None,
    };
    PredictCommand::new(setting, travel, &limits).unwrap()
}

fn paper_1001() -> PredictCommand {
    paper(1001, -10.0, SurfaceSpec::Plane)
}

/// The prediction use case for a process no earlier request had (a new workpiece speed, so a
/// new η, each time: the operator and the equal-dwell pass at the user's speeds are computed;
/// the set-up's η = −1 pass and η window, shared by every speed, come from the first request).
/// On a plane at 1001 × 1001 and on a convex sphere (R = −150 mm) at 201 × 201.
#[divan::bench(args = ["plane_1001", "sphere_201"], sample_count = 50)]
fn predict_cold(bencher: divan::Bencher, what: &str) {
    let (count, surface) = match what {
        "plane_1001" => (1001, SurfaceSpec::Plane),
        _ => (
            201,
            SurfaceSpec::Sphere {
                radius_of_curvature_mm: -150.0,
            },
        ),
    };
    let recommender = Recommender::new();
    let operators = OperatorCache::new(64 << 20);
    predict(
        paper(count, -10.0, surface.clone()),
        &recommender,
        &operators,
    );
    let counter = std::sync::atomic::AtomicU32::new(0);
    bencher
        .with_inputs(|| {
            let k = 1 + counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            paper(count, -10.0 * (1.0 + 1e-9 * k as f64), surface.clone())
        })
        .bench_values(|c| predict(c, &recommender, &operators));
}

/// The recommendation alone for a new machine set-up (a new tool radius each time, so the
/// η = −1 pass, the η window and the pass at the user's speeds are all computed), 201 radial
/// samples on the paper's part.
#[divan::bench(sample_count = 30)]
fn recommendation_new_setup(bencher: divan::Bencher) {
    let recommender = Recommender::new();
    let counter = std::sync::atomic::AtomicU32::new(0);
    bencher
        .with_inputs(|| {
            let k = 1 + counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            paper_setting(
                201,
                10.0 * (1.0 + 1e-9 * k as f64),
                -10.0,
                SurfaceSpec::Plane,
            )
        })
        .bench_values(|setting| {
            recommender
                .for_plan(&setting, 100.0, None, &MachineLimits::default())
                .unwrap()
        });
}

#[divan::bench(args = [true, false], sample_count = 50)]
fn predict_1001x1001_operator_cached(bencher: divan::Bencher, cached: bool) {
    let recommender = Recommender::new();
    let operators = OperatorCache::new(if cached { 64 << 20 } else { 0 });
    let command = paper_1001();
    // The first request fills the caches (operator, recommendation).
    predict(command.clone(), &recommender, &operators);
    bencher
        .with_inputs(|| command.clone())
        .bench_values(|c| predict(c, &recommender, &operators));
}
