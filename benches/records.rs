//! Records: how long a record write takes (one transaction, answered once committed: p50 and
//! p99 of 1,000 part writes, one after another) and `GET /v1/parts/{id}/history` of a part
//! with 100 complete cycles (median of 50, in-process through the router), on SQLite (a
//! fresh file) and on PostgreSQL when `PRESTON_BENCH_POSTGRES_URL` names a database.
//!
//! The cycles' records carry bodies of the real sizes: the fixtures' measurement fit (90 kB
//! answer), correction plan (31 kB) and calibration (13 kB) answers.
//!
//! `cargo bench --bench records`

use std::time::{Duration, Instant};

use axum::body::Body;
use axum::http::Request;
use preston::config::ServiceLimits;
use preston::http::{router, AppState};
use preston::store::{new_stamp, Store, StoreOptions};
use preston::usecases::records::{
    CalibrationRecord, MeasurementRecord, PartRecord, PlanRecord, ProfileRecord, Record, Records,
    RunRecord,
};
use tower::ServiceExt;

fn fixture(name: &str) -> String {
    std::fs::read_to_string(format!("{}/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

async fn bench(url: &str) {
    let store = Store::open(&StoreOptions {
        url: url.to_string(),
        max_connections: 8,
        timeout: Duration::from_secs(5),
    })
    .await
    .unwrap();
    let token = uuid_like();
    let mut profile = new_stamp("bench");
    profile.id = format!("bench-{token}");
    let process = r#"{"workpiece_radius_mm":50.0,"tool_radius_mm":10.0,"workpiece_rpm":-10.0,"tool_rpm":200.0,"preston_coefficient_m2_per_n":1e-13,"pressure_kpa":10.0,"pressure_model":"uniform"}"#;
    store
        .write(
            &[Record::Profile(ProfileRecord {
                stamp: profile.clone(),
                body: format!(r#"{{"process":{process}}}"#),
            })],
            None,
        )
        .await
        .unwrap();
    let part_body = r#"{"surface":{"kind":"sphere","radius_of_curvature_mm":300.0},"workpiece_radius_mm":50.0,"clear_aperture":{"inner_mm":0.0,"outer_mm":40.0}}"#;

    // Writes.
    let mut times = Vec::with_capacity(1000);
    let mut first_part = None;
    for i in 0..1000 {
        let record = PartRecord {
            stamp: new_stamp("bench"),
            name: format!("SN-{token}-{i}"),
            process_profile: profile.id.clone(),
            body: part_body.to_string(),
        };
        first_part.get_or_insert_with(|| record.stamp.id.clone());
        let started = Instant::now();
        store.write(&[Record::Part(record)], None).await.unwrap();
        times.push(started.elapsed());
    }
    times.sort();
    println!(
        "{}: record write (a part, one transaction) p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms over {}",
        scheme(url),
        ms(percentile(&times, 0.5)),
        ms(percentile(&times, 0.99)),
        ms(times[times.len() - 1]),
        times.len()
    );

    // A part with 100 complete cycles.
    let part = first_part.unwrap();
    let (measurement, plan, calibration) = (
        fixture("expected/measurement_fit_asphere.json"),
        fixture("expected/optimize_figure_correction.json"),
        fixture("expected/calibration_rings.json"),
    );
    let measure = |store: &Store| {
        let record = MeasurementRecord {
            stamp: new_stamp("bench"),
            part: part.clone(),
            request: "{}".into(),
            result: measurement.clone(),
            rms_nm: 10.0,
            map_sha256: None,
        };
        let id = record.stamp.id.clone();
        let store = store.clone();
        async move {
            store
                .write(&[Record::Measurement(record)], None)
                .await
                .unwrap();
            id
        }
    };
    let mut before = measure(&store).await;
    for _ in 0..100 {
        let plan_record = PlanRecord {
            stamp: new_stamp("bench"),
            part: part.clone(),
            measurement: Some(before.clone()),
            request: format!(r#"{{"process":{process}}}"#),
            result: plan.clone(),
            predicted_rms_after_nm: 1.0,
        };
        let run = RunRecord {
            stamp: new_stamp("bench"),
            part: part.clone(),
            plan: plan_record.stamp.id.clone(),
            started_at: "2026-11-25T08:00:00Z".into(),
            finished_at: "2026-11-25T12:00:00Z".into(),
            machine: Some("cell 3".into()),
            notes: None,
        };
        let learned = CalibrationRecord {
            stamp: new_stamp("bench"),
            profile: profile.id.clone(),
            request: "{}".into(),
            result: calibration.clone(),
            process: process.to_string(),
            preston_coefficient_m2_per_n: 0.9e-13,
            standard_error_m2_per_n: Some(1e-16),
            run: Some(run.stamp.id.clone()),
        };
        store
            .write(&[Record::Plan(plan_record), Record::Run(run)], None)
            .await
            .unwrap();
        before = measure(&store).await;
        store
            .write(&[Record::Calibration(learned)], None)
            .await
            .unwrap();
    }
    let app = router(
        AppState::new(ServiceLimits::default()).with_store(store.clone()),
        None,
    );
    let mut times = Vec::with_capacity(50);
    for _ in 0..51 {
        let started = Instant::now();
        let response = app
            .clone()
            .oneshot(
                Request::get(format!("/v1/parts/{part}/history"))
                    .body(Body::empty())
                    .unwrap(),
            )
            .await
            .unwrap();
        assert_eq!(response.status(), 200);
        let body = http_body_util::BodyExt::collect(response.into_body())
            .await
            .unwrap()
            .to_bytes();
        times.push(started.elapsed());
        assert!(body.len() > 1000);
    }
    let cold = times.remove(0);
    times.sort();
    println!(
        "{}: history of a part with 100 cycles: first {:.2} ms, then median {:.2} ms, p99 {:.2} ms over {}",
        scheme(url),
        ms(cold),
        ms(percentile(&times, 0.5)),
        ms(percentile(&times, 0.99)),
        times.len()
    );
    store.close().await;
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn scheme(url: &str) -> &str {
    url.split(':').next().unwrap_or(url)
}

fn uuid_like() -> String {
    format!(
        "{:x}",
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos()
    )
}

fn main() {
    // `cargo bench` passes --bench; other runs (`cargo test --benches`) only build it.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let file = std::env::temp_dir().join(format!("preston-bench-records-{}.db", uuid_like()));
    let mut urls = vec![format!("sqlite://{}", file.display())];
    if let Ok(url) = std::env::var("PRESTON_BENCH_POSTGRES_URL") {
        urls.push(url);
    }
    for url in &urls {
        runtime.block_on(bench(url));
    }
    for suffix in ["", "-wal", "-shm"] {
        let _ = std::fs::remove_file(format!("{}{suffix}", file.display()));
    }
}
