//! `POST /v1/predict` through the router (in-process, no socket): the paper's experiment 1
//! with 201 radial samples and 201 tool positions (fixtures/predict_paper_exp1_201.json).
//! Covers JSON parsing, validation, operator assembly, metrics and serialisation.

use axum::body::Body;
use axum::http::Request;
use http_body_util::BodyExt;
use preston::config::Limits;
use preston::http::{router, AppState};
use tower::ServiceExt;

fn main() {
    divan::main();
}

#[divan::bench]
fn predict_paper_201x201(bencher: divan::Bencher) {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let app = router(AppState::new(Limits::default()), None);
    let body = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/predict_paper_exp1_201.json"
    ))
    .unwrap();
    bencher.bench(|| {
        runtime.block_on(async {
            let request = Request::post("/v1/predict")
                .header("content-type", "application/json")
                .body(Body::from(body.clone()))
                .unwrap();
            let response = app.clone().oneshot(request).await.unwrap();
            assert_eq!(response.status(), 200);
            response.into_body().collect().await.unwrap().to_bytes()
        })
    });
}
