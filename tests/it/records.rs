//! The records: the full correction cycle through the API on SQLite (always) and PostgreSQL
//! (when `PRESTON_TEST_POSTGRES_URL` names a database, as `.ci/run` does), idempotent retries,
//! the read-only role, the conventions (Location, ETag, problems) and a store that is down.
//!
//! Measurements come from an independent generator: probe traces of a sphere written from the
//! sag formula here, with a form error of our choosing and Gaussian noise, and an after-trace
//! in which the part lost exactly 90 % of the removal the plan predicted.

use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use preston::config::ServiceLimits;
use preston::http::{router, AppState};
use preston::store::{Store, StoreOptions};
use preston::usecases::records::Records;
use serde_json::{json, Value};

use crate::common::http::{get, post_with, send, Reply};

/// Every backend under test: a fresh SQLite file, and PostgreSQL when configured.
pub fn backends() -> Vec<String> {
    let sqlite = std::env::temp_dir().join(format!(
        "preston-records-{}-{}.db",
        std::process::id(),
        unique()
    ));
    let mut urls = vec![format!("sqlite://{}", sqlite.display())];
    if let Ok(url) = std::env::var("PRESTON_TEST_POSTGRES_URL") {
        urls.push(url);
    }
    urls
}

/// A token that makes names unique across tests sharing one database.
pub fn unique() -> String {
    format!(
        "{:x}{:04x}",
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos(),
        fastrand::u16(..)
    )
}

pub async fn open(url: &str) -> Store {
    Store::open(&StoreOptions {
        url: url.to_string(),
        max_connections: 4,
        timeout: Duration::from_secs(10),
    })
    .await
    .unwrap_or_else(|e| panic!("{url}: {e}"))
}

fn app(store: Store, state: AppState) -> Router {
    router(state.with_store(store), None)
}

async fn post(app: &Router, path: &str, body: &Value, headers: &[(&str, &str)]) -> Reply {
    let mut all = vec![("content-type", "application/json")];
    all.extend_from_slice(headers);
    post_with(app, path, body.to_string(), &all).await
}

async fn created(app: &Router, path: &str, body: &Value) -> Value {
    let reply = post(app, path, body, &[]).await;
    assert_eq!(reply.status, 201, "{path}: {}", reply.text());
    let location = reply.headers["location"].to_str().unwrap().to_string();
    let id = reply.json()["id"]
        .as_str()
        .or(reply.json()["name"].as_str())
        .unwrap()
        .to_string();
    assert!(location.ends_with(&id), "{location}");
    // The record reads back as written.
    let back = get(app, &location).await;
    assert_eq!(back.status, 200, "{location}");
    reply.json()
}

const SPHERE_RADIUS_MM: f64 = 300.0;

fn sag(r: f64) -> f64 {
    let c = 1.0 / SPHERE_RADIUS_MM;
    c * r * r / (1.0 + (1.0 - c * c * r * r).sqrt())
}

/// cos of the surface normal's angle to the axis at radius r.
fn cos_normal(r: f64) -> f64 {
    let c = 1.0 / SPHERE_RADIUS_MM;
    let slope = c * r / (1.0 - c * c * r * r).sqrt();
    1.0 / (1.0 + slope * slope).sqrt()
}

/// A standard normal deviate (Box–Muller).
fn gaussian(rng: &mut fastrand::Rng) -> f64 {
    let (u, v) = (1.0 - rng.f64(), rng.f64());
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// A probe trace (tip radius 0) across the sphere whose normal form error is `error_nm(r)`,
/// with `noise_nm` of Gaussian noise.
fn trace(error_nm: &dyn Fn(f64) -> f64, noise_nm: f64, seed: u64) -> Value {
    let mut rng = fastrand::Rng::with_seed(seed);
    let x: Vec<f64> = (0..=480).map(|i| -48.0 + 0.2 * i as f64).collect();
    let z: Vec<f64> = x
        .iter()
        .map(|&x| {
            let r = x.abs();
            let axial_nm = error_nm(r) / cos_normal(r) + noise_nm * gaussian(&mut rng);
            sag(r) + axial_nm * 1e-6
        })
        .collect();
    json!({"profile": {"x_mm": x, "z_mm": z}, "radial_grid": {"start_mm": 0, "stop_mm": 46, "count": 93}})
}

/// Linear interpolation of (xs, ys) at x.
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let i = xs.partition_point(|&v| v <= x).clamp(1, xs.len() - 1);
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] + t * (ys[i] - ys[i - 1])
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

const K_NOMINAL: f64 = 1.0e-13;

fn profile_body(name: &str) -> Value {
    json!({
        "name": name,
        "process": {"workpiece_radius_mm": 50, "tool_radius_mm": 10, "workpiece_rpm": -10,
                    "tool_rpm": 200, "preston_coefficient_m2_per_n": K_NOMINAL, "pressure_kpa": 10},
        "tool": {"pivot_length_mm": 60, "orientation": "normal"}
    })
}

fn part_body(name: &str, profile: &str) -> Value {
    json!({
        "name": name,
        "process_profile": profile,
        "surface": {"kind": "sphere", "radius_of_curvature_mm": SPHERE_RADIUS_MM},
        "workpiece_radius_mm": 50,
        "clear_aperture": {"inner_mm": 0, "outer_mm": 40}
    })
}

fn plan_body() -> Value {
    let positions: Vec<f64> = (0..=100).map(|i| 0.45 * i as f64).collect();
    json!({"positions_mm": positions, "radial_grid": {"start_mm": 0, "stop_mm": 48, "count": 193}})
}

/// The initial form error: a turned-edge-and-centre pattern, nm.
fn initial_error(r: f64) -> f64 {
    let u = r / 40.0;
    180.0 * u * u - 135.0 * u.powi(4) + 36.0 * (3.0 * u).cos()
}

/// A store at `url`, the service on it, and a new profile (its name) with a new part.
async fn new_part(url: &str) -> (Store, Router, String, Value) {
    let store = open(url).await;
    let app = app(store.clone(), AppState::new(ServiceLimits::default()));
    let token = unique();
    let profile = format!("shop-{token}");
    created(&app, "/v1/process-profiles", &profile_body(&profile)).await;
    let part = created(
        &app,
        "/v1/parts",
        &part_body(&format!("SN-{token}"), &profile),
    )
    .await;
    (store, app, profile, part)
}

/// The Must-show cycle on one backend: profile → part → measurement → plan → program → run →
/// an after-measurement in which the part lost 90 % of the predicted removal → history with
/// removal_ratio 0.90 ± 0.02 and the convergence ratio → the next plan at the learned rate.
async fn full_cycle(url: &str) {
    let (store, app, profile, part) = new_part(url).await;
    let part_id = part["id"].as_str().unwrap();

    let before = created(
        &app,
        &format!("/v1/parts/{part_id}/measurements"),
        &trace(&initial_error, 0.3, 7),
    )
    .await;
    let plan = created(&app, &format!("/v1/parts/{part_id}/plans"), &plan_body()).await;
    assert_eq!(plan["measurement_id"], before["id"]);
    assert_eq!(
        plan["request"]["process"]["preston_coefficient_m2_per_n"],
        json!(K_NOMINAL)
    );
    assert_eq!(
        plan["request"]["target"],
        before["result"]["correction_target"]
    );
    let plan_id = plan["id"].as_str().unwrap();

    let program = post(
        &app,
        &format!("/v1/plans/{plan_id}/program"),
        &json!({}),
        &[("accept", "text/x-gcode")],
    )
    .await;
    assert_eq!(program.status, 200, "{}", program.text());
    assert!(
        program.text().lines().take(3).any(|l| l.contains(plan_id)),
        "the G-code header names the plan"
    );

    created(
        &app,
        &format!("/v1/parts/{part_id}/runs"),
        &json!({"plan_id": plan_id, "started_at": from_now(1),
                "finished_at": from_now(313), "machine": "cell 3"}),
    )
    .await;

    // The part lost 90 % of the predicted removal.
    let radius = numbers(&plan["result"]["radius_mm"]);
    let removal = numbers(&plan["result"]["removal_nm"]);
    let after_error = |r: f64| initial_error(r) - 0.90 * interpolate(&radius, &removal, r);
    let after = created(
        &app,
        &format!("/v1/parts/{part_id}/measurements"),
        &trace(&after_error, 0.3, 8),
    )
    .await;
    assert!(
        after["completes_run_id"].is_string(),
        "{}",
        after["completes_run_id"]
    );
    assert!(after["learned_calibration_id"].is_string());

    let history = get(&app, &format!("/v1/parts/{part_id}/history")).await;
    assert_eq!(history.status, 200);
    let history = history.json();
    let cycle = &history["cycles"][0];
    assert_eq!(history["cycles"].as_array().unwrap().len(), 1);
    let ratio = cycle["removal_ratio"]["value"].as_f64().unwrap();
    let standard_error = cycle["removal_ratio"]["standard_error"].as_f64().unwrap();
    println!(
        "{url}: removal_ratio {ratio:.4} ± {standard_error:.4}, convergence {}",
        cycle["convergence_ratio"]
    );
    assert!((ratio - 0.90).abs() <= 0.02, "removal ratio {ratio}");
    assert!(
        standard_error > 0.0 && standard_error < 0.02,
        "{standard_error}"
    );
    let (rms_before, rms_after) = (
        before["rms_nm"].as_f64().unwrap(),
        after["rms_nm"].as_f64().unwrap(),
    );
    assert_eq!(cycle["rms_before_nm"].as_f64(), Some(rms_before));
    assert_eq!(cycle["rms_after_nm"].as_f64(), Some(rms_after));
    assert_eq!(
        cycle["convergence_ratio"].as_f64(),
        Some(rms_before / rms_after)
    );
    assert!(rms_before / rms_after > 3.0, "{rms_before} → {rms_after}");
    assert_eq!(
        cycle["predicted_rms_after_nm"],
        plan["predicted_rms_after_nm"]
    );

    // The profile learned the rate; the next plan uses it and corrects the latest measurement.
    let shown = get(&app, &format!("/v1/process-profiles/{profile}"))
        .await
        .json();
    // Every record says which code wrote it, and at which records schema (the last migration).
    let migrations = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/migrations"))
        .unwrap()
        .count();
    let run_id = cycle["run_id"].as_str().unwrap();
    let run = get(&app, &format!("/v1/runs/{run_id}")).await.json();
    for (what, record) in [
        ("part", &part),
        ("measurement", &before),
        ("plan", &plan),
        ("run", &run),
        ("profile", &shown),
        ("calibration", &shown["calibrations"][0]),
    ] {
        let by = record["computed_by"].as_str().unwrap_or_default();
        assert!(
            by.starts_with(&format!("preston {} (git ", env!("CARGO_PKG_VERSION")))
                && by.ends_with(&format!("records schema {migrations}")),
            "{what}: {by:?}"
        );
    }
    assert_eq!(shown["preston_coefficient_source"], "learned");
    assert_eq!(shown["calibrations"][0]["learned"], true);
    let learned_after_first = shown["calibrations"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["learned"] == true)
        .count();
    let learned = shown["current_process"]["preston_coefficient_m2_per_n"]
        .as_f64()
        .unwrap();
    assert!((learned / K_NOMINAL - ratio).abs() < 1e-12, "{learned}");
    let next = created(&app, &format!("/v1/parts/{part_id}/plans"), &plan_body()).await;
    assert_eq!(
        next["request"]["process"]["preston_coefficient_m2_per_n"].as_f64(),
        Some(learned)
    );
    assert_eq!(next["measurement_id"], after["id"]);
    assert_eq!(
        history["next_process"]["preston_coefficient_m2_per_n"].as_f64(),
        Some(learned)
    );

    // Runs that removed nothing: the part measured again unchanged (the same trace, then the
    // same error under fresh noise). The cycles complete, but teach nothing, and say so.
    let next_id = next["id"].as_str().unwrap();
    for (cycle, again) in [
        (1, trace(&after_error, 0.3, 8)),
        (2, trace(&after_error, 0.3, 9)),
    ] {
        let plan_id = if cycle == 1 {
            next_id.to_string()
        } else {
            created(&app, &format!("/v1/parts/{part_id}/plans"), &plan_body()).await["id"]
                .as_str()
                .unwrap()
                .to_string()
        };
        created(
            &app,
            &format!("/v1/parts/{part_id}/runs"),
            &json!({"plan_id": plan_id, "started_at": from_now(1), "finished_at": from_now(60)}),
        )
        .await;
        let repeated = created(&app, &format!("/v1/parts/{part_id}/measurements"), &again).await;
        assert!(repeated["completes_run_id"].is_string(), "{repeated}");
        assert!(repeated["learned_calibration_id"].is_null(), "{repeated}");
        assert_eq!(repeated["warnings"][0]["code"], "removal_not_significant");
        let history = get(&app, &format!("/v1/parts/{part_id}/history"))
            .await
            .json();
        let shown = &history["cycles"][cycle];
        assert_eq!(
            shown["warnings"][0]["code"], "removal_not_significant",
            "{shown}"
        );
        assert!(shown["learned_calibration_id"].is_null());
        // No standard error of 0 anywhere: no ratio (no K > 0 fits), or one with an honest
        // standard error (none for an exact fit), not 2 of them above 0.
        let ratio = &shown["removal_ratio"];
        if !ratio.is_null() {
            let value = ratio["value"].as_f64().unwrap();
            match ratio["standard_error"].as_f64() {
                Some(se) => assert!(se > 0.0 && value < 2.0 * se, "{ratio}"),
                None => assert!(ratio["standard_error"].is_null()),
            }
        }
        println!("cycle {cycle} (removed nothing): removal_ratio {ratio}");
        assert_eq!(history["cycles"][0]["warnings"], json!([]));
        let profile_now = get(&app, &format!("/v1/process-profiles/{profile}"))
            .await
            .json();
        assert_eq!(
            profile_now["current_process"]["preston_coefficient_m2_per_n"].as_f64(),
            Some(learned),
            "cycle {cycle} taught nothing"
        );
        let learned_now = profile_now["calibrations"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|c| c["learned"] == true)
            .count();
        assert_eq!(
            learned_now, learned_after_first,
            "no K learned from cycle {cycle}"
        );
    }
    store.close().await;
}

/// An RFC 3339 UTC timestamp `minutes` from now (runs cannot start before their plan exists).
fn from_now(minutes: u64) -> String {
    let at = std::time::SystemTime::now() + Duration::from_secs(60 * minutes);
    humantime::format_rfc3339_seconds(at).to_string()
}

/// A plan with a target of its own (nothing measured before), run, then measured: the
/// measurement completes the cycle, which teaches nothing and warns nothing, and its POST and
/// GET say the same.
async fn cycle_without_a_measurement_before(url: &str) {
    let (store, app, _, part) = new_part(url).await;
    let part_id = part["id"].as_str().unwrap();
    // A view's ETag names the records it renders: the history's changes when a plan joins
    // it, holds while nothing does, and the old tag no longer gets a 304.
    let history_path = format!("/v1/parts/{part_id}/history");
    let etag = |reply: &Reply| reply.headers["etag"].to_str().unwrap().to_string();
    let empty = etag(&get(&app, &history_path).await);
    let mut body = plan_body();
    body["target"] = json!({"uniform_depth_nm": 50});
    let plan = created(&app, &format!("/v1/parts/{part_id}/plans"), &body).await;
    assert!(plan["measurement_id"].is_null());
    let planned = etag(&get(&app, &history_path).await);
    assert_ne!(planned, empty);
    assert_eq!(etag(&get(&app, &history_path).await), planned);
    let status = |tag: String| {
        let app = app.clone();
        let path = history_path.clone();
        async move {
            get_with(&app, &path, &[("if-none-match", &tag)])
                .await
                .status
        }
    };
    assert_eq!(status(empty).await, 200);
    assert_eq!(status(planned).await, 304);
    created(
        &app,
        &format!("/v1/parts/{part_id}/runs"),
        &json!({"plan_id": plan["id"], "started_at": from_now(1), "finished_at": from_now(60)}),
    )
    .await;
    let posted = created(
        &app,
        &format!("/v1/parts/{part_id}/measurements"),
        &trace(&initial_error, 0.3, 7),
    )
    .await;
    let fetched = get(
        &app,
        &format!("/v1/measurements/{}", posted["id"].as_str().unwrap()),
    )
    .await
    .json();
    for key in ["completes_run_id", "learned_calibration_id", "warnings"] {
        assert_eq!(posted[key], fetched[key], "{key}");
    }
    assert!(posted["completes_run_id"].is_string(), "{posted}");
    assert_eq!(posted["warnings"], json!([]));
    let history = get(&app, &format!("/v1/parts/{part_id}/history"))
        .await
        .json();
    assert_eq!(history["cycles"][0]["warnings"], json!([]));
    assert!(history["cycles"][0]["removal_ratio"].is_null());
    store.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cycle_not_measured_before_completes_and_teaches_nothing() {
    for url in backends() {
        cycle_without_a_measurement_before(&url).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_full_cycle_learns_the_removal_rate_on_every_backend() {
    for url in backends() {
        full_cycle(&url).await;
    }
}

/// Retries under one Idempotency-Key: the first answer every time, one record; the same key
/// with another body: 422 naming the header; concurrent retries: still one record.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn idempotent_retries_never_duplicate_a_record() {
    for url in backends() {
        let store = open(&url).await;
        let app = app(store.clone(), AppState::new(ServiceLimits::default()));
        let token = unique();
        let profile = format!("idem-{token}");
        created(&app, "/v1/process-profiles", &profile_body(&profile)).await;
        let body = part_body(&format!("SN-{token}"), &profile);
        let key = format!("key-{token}");
        let retries = (0..8).map(|_| {
            let (app, body, key) = (app.clone(), body.clone(), key.clone());
            tokio::spawn(async move {
                post(&app, "/v1/parts", &body, &[("idempotency-key", &key)]).await
            })
        });
        let mut answers = Vec::new();
        for retry in retries {
            let reply = retry.await.unwrap();
            assert_eq!(reply.status, 201, "{}", reply.text());
            answers.push((reply.headers["location"].clone(), reply.body.clone()));
        }
        assert!(
            answers.windows(2).all(|w| w[0] == w[1]),
            "every retry gets the first answer"
        );
        let listed = get(&app, &format!("/v1/parts?name=SN-{token}"))
            .await
            .json();
        assert_eq!(listed["items"].as_array().unwrap().len(), 1, "{url}");

        let mut other = body.clone();
        other["workpiece_radius_mm"] = json!(49);
        let reused = post(&app, "/v1/parts", &other, &[("idempotency-key", &key)]).await;
        assert_eq!(reused.status, 422, "{}", reused.text());
        assert_eq!(reused.json()["field"], "Idempotency-Key");

        // A malformed key is refused before anything is written: 1 to 255 visible ASCII
        // characters (256 is one too many; a space is not visible).
        for malformed in ["k".repeat(256), "a key".to_string()] {
            let refused = post(
                &app,
                "/v1/parts",
                &other,
                &[("idempotency-key", &malformed)],
            )
            .await;
            assert_eq!(refused.status, 422, "{}", refused.text());
            assert_eq!(refused.json()["field"], "Idempotency-Key");
        }
        let listed = get(&app, &format!("/v1/parts?name=SN-{token}"))
            .await
            .json();
        assert_eq!(listed["items"].as_array().unwrap().len(), 1, "{url}");

        // A retry whose members (and nested members) come in another order is the same
        // request: the first answer, one record.
        let part_id = listed["items"][0]["id"].as_str().unwrap().to_string();
        let plan_key = format!("plan-{token}");
        let positions: Vec<f64> = (0..=40).map(f64::from).collect();
        let in_order: Value = serde_json::from_str(&format!(
            r#"{{"positions_mm": {}, "target": {{"uniform_depth_nm": 50, "free_piston": null}}}}"#,
            json!(positions)
        ))
        .unwrap();
        let reordered: Value = serde_json::from_str(&format!(
            r#"{{"target": {{"free_piston": null, "uniform_depth_nm": 50}}, "positions_mm": {}}}"#,
            json!(positions)
        ))
        .unwrap();
        assert_ne!(in_order.to_string(), reordered.to_string());
        let path = format!("/v1/parts/{part_id}/plans");
        let first = post(&app, &path, &in_order, &[("idempotency-key", &plan_key)]).await;
        let retry = post(&app, &path, &reordered, &[("idempotency-key", &plan_key)]).await;
        assert_eq!(first.status, 201, "{}", first.text());
        assert_eq!(retry.status, 201, "{}", retry.text());
        assert_eq!(first.headers["location"], retry.headers["location"]);
        assert_eq!(first.body, retry.body);
        // The claim keeps the status, the Location and the record's id, not the body: the
        // retry's answer is the record rendered again, byte for byte the first.
        let (_, claim) = store.claimed("", &plan_key).await.unwrap().unwrap();
        let plan_id = first.json()["id"].as_str().unwrap().to_string();
        assert_eq!(
            (claim.status, claim.record.as_str()),
            (201, plan_id.as_str())
        );
        assert_eq!(claim.location, format!("/v1/plans/{plan_id}"));
        assert!(claim.body.is_empty(), "{}", claim.body);

        // A member the schema does not name is refused, null or not (it used to be dropped).
        for stray in [json!({"": null}), json!({"feed_mode": null})] {
            let refused = post(&app, &format!("/v1/plans/{plan_id}/program"), &stray, &[]).await;
            assert_eq!(refused.status, 422, "{stray}: {}", refused.text());
        }

        // Without a key, the same serial again is a conflict, not a second part.
        let again = post(&app, "/v1/parts", &body, &[]).await;
        assert_eq!(again.status, 409, "{}", again.text());
        assert_eq!(again.content_type, "application/problem+json");
        store.close().await;
    }
}

/// A read-only key computes and reads, and gets 403 on every record POST.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_read_only_key_reads_and_computes_but_never_writes() {
    let url = &backends()[0];
    let dir = std::env::temp_dir().join(format!("preston-roles-{}", unique()));
    std::fs::create_dir_all(&dir).unwrap();
    let keys = dir.join("keys.txt");
    let digest = |key: &str| -> String {
        use sha2::Digest;
        sha2::Sha256::digest(key.as_bytes())
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    };
    std::fs::write(
        &keys,
        format!(
            "mes:{}\nviewer:{}:read\n",
            digest("writer-key"),
            digest("reader-key")
        ),
    )
    .unwrap();
    let auth = preston::keys::Auth::load(keys, false).unwrap();
    let store = open(url).await;
    let state = AppState::new(ServiceLimits::default()).with_auth(Arc::new(auth));
    let app = app(store.clone(), state);
    let writer = [("authorization", "Bearer writer-key")];
    let reader = [("authorization", "Bearer reader-key")];
    let token = unique();
    let profile = format!("roles-{token}");

    let made = post(
        &app,
        "/v1/process-profiles",
        &profile_body(&profile),
        &writer,
    )
    .await;
    assert_eq!(made.status, 201);
    assert_eq!(made.json()["created_by"], "mes");
    let part = post(
        &app,
        "/v1/parts",
        &part_body(&format!("SN-{token}"), &profile),
        &writer,
    )
    .await;
    let part_id = part.json()["id"].as_str().unwrap().to_string();
    let measured = post(
        &app,
        &format!("/v1/parts/{part_id}/measurements"),
        &trace(&initial_error, 0.3, 7),
        &writer,
    )
    .await;
    assert_eq!(measured.status, 201);
    let plan = post(
        &app,
        &format!("/v1/parts/{part_id}/plans"),
        &plan_body(),
        &writer,
    )
    .await;
    let plan_id = plan.json()["id"].as_str().unwrap().to_string();

    let writes = [
        (
            "/v1/process-profiles".to_string(),
            profile_body(&format!("{profile}-2")),
        ),
        (
            format!("/v1/process-profiles/{profile}/calibrations"),
            json!({"runs": []}),
        ),
        (
            "/v1/parts".to_string(),
            part_body(&format!("SN2-{token}"), &profile),
        ),
        (
            format!("/v1/parts/{part_id}/measurements"),
            trace(&initial_error, 0.3, 7),
        ),
        (format!("/v1/parts/{part_id}/plans"), plan_body()),
        (
            format!("/v1/parts/{part_id}/runs"),
            json!({"plan_id": plan_id, "started_at": "2026-11-25T08:00:00Z", "finished_at": "2026-11-25T09:00:00Z"}),
        ),
    ];
    for (path, body) in &writes {
        let refused = post(&app, path, body, &reader).await;
        assert_eq!(refused.status, 403, "{path}: {}", refused.text());
        assert_eq!(refused.content_type, "application/problem+json");
    }
    for path in [
        "/v1/process-profiles".to_string(),
        format!("/v1/process-profiles/{profile}"),
        "/v1/parts".to_string(),
        format!("/v1/parts/{part_id}"),
        format!("/v1/parts/{part_id}/history"),
        format!("/v1/plans/{plan_id}"),
    ] {
        let request = axum::http::Request::get(&path)
            .header("authorization", "Bearer reader-key")
            .body(axum::body::Body::empty())
            .unwrap();
        assert_eq!(send(&app, request).await.status, 200, "{path}");
    }
    let program = post(
        &app,
        &format!("/v1/plans/{plan_id}/program"),
        &json!({}),
        &reader,
    )
    .await;
    assert_eq!(program.status, 200, "{}", program.text());
    let fixture = crate::common::read_fixture("predict_paper_exp1.json");
    let computed = post(&app, "/v1/predict", &fixture, &reader).await;
    assert_eq!(computed.status, 200);
    // Nothing the reader sent was written.
    let parts = post(&app, "/v1/parts", &json!({}), &reader).await;
    assert_eq!(parts.status, 403);
    let listed = get_with(&app, &format!("/v1/parts?name=SN2-{token}"), &reader).await;
    assert_eq!(listed.json()["items"], json!([]));
    store.close().await;
}

async fn get_with(app: &Router, path: &str, headers: &[(&str, &str)]) -> Reply {
    let mut request = axum::http::Request::get(path);
    for (name, value) in headers {
        request = request.header(*name, *value);
    }
    send(app, request.body(axum::body::Body::empty()).unwrap()).await
}

/// GETs carry an ETag and answer 304 to it; unknown records are 404 problems; a plan of
/// another part, a run that ends before it starts and a part of an unknown profile are 422s
/// naming the field.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn records_follow_the_conventions() {
    let url = &backends()[0];
    let store = open(url).await;
    let app = app(store.clone(), AppState::new(ServiceLimits::default()));
    let token = unique();
    let profile = format!("conv-{token}");
    created(&app, "/v1/process-profiles", &profile_body(&profile)).await;
    let part = created(
        &app,
        "/v1/parts",
        &part_body(&format!("SN-{token}"), &profile),
    )
    .await;
    let part_id = part["id"].as_str().unwrap();
    let path = format!("/v1/parts/{part_id}");
    let first = get(&app, &path).await;
    let etag = first.headers["etag"].to_str().unwrap().to_string();
    assert!(etag.starts_with('"') && etag.len() == 34, "{etag}");
    assert_eq!(
        get_with(&app, &path, &[("if-none-match", &etag)])
            .await
            .status,
        304
    );
    assert!(first.json()["created_at"].as_str().unwrap().ends_with('Z'));

    for missing in [
        "/v1/parts/nope",
        "/v1/plans/nope",
        "/v1/runs/nope",
        "/v1/measurements/nope",
        "/v1/calibrations/nope",
        "/v1/process-profiles/nope",
        "/v1/parts/nope/history",
    ] {
        let reply = get(&app, missing).await;
        assert_eq!(reply.status, 404, "{missing}");
        assert_eq!(reply.content_type, "application/problem+json");
    }
    let cases = [
        (
            "/v1/parts".to_string(),
            part_body(&format!("X-{token}"), "no-such-profile"),
            "process_profile",
        ),
        (
            "/v1/parts".to_string(),
            json!({"name": format!("Y-{token}"), "process_profile": profile, "workpiece_radius_mm": -5}),
            "workpiece_radius_mm",
        ),
        (
            format!("/v1/parts/{part_id}/runs"),
            json!({"plan_id": "nope", "started_at": "2026-11-25T08:00:00Z", "finished_at": "2026-11-25T09:00:00Z"}),
            "plan_id",
        ),
        (
            format!("/v1/parts/{part_id}/runs"),
            json!({"plan_id": "nope", "started_at": "2026-11-25T10:00:00Z", "finished_at": "2026-11-25T09:00:00Z"}),
            "finished_at",
        ),
        (
            format!("/v1/parts/{part_id}/runs"),
            json!({"plan_id": "nope", "started_at": "yesterday", "finished_at": "2026-11-25T09:00:00Z"}),
            "started_at",
        ),
        (format!("/v1/parts/{part_id}/plans"), plan_body(), "target"),
        (
            format!("/v1/parts/{part_id}/plans"),
            json!({"surface": {"kind": "plane"}, "positions_mm": [0, 1]}),
            "surface",
        ),
        (
            "/v1/process-profiles".to_string(),
            json!({"name": "has space", "process": profile_body("x")["process"]}),
            "name",
        ),
    ];
    for (path, body, field) in cases {
        let reply = post(&app, &path, &body, &[]).await;
        assert_eq!(reply.status, 422, "{path} {body}: {}", reply.text());
        assert_eq!(reply.json()["field"], field, "{path}: {}", reply.text());
    }
    store.close().await;
}

/// With PostgreSQL unreachable the service starts, record endpoints answer 503 problems and
/// compute endpoints 200, and `/readyz` says the store is unavailable.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_store_that_is_down_fails_records_not_computations() {
    let store = Store::open(&StoreOptions {
        url: "postgres://preston:secret@127.0.0.1:9/preston".into(),
        max_connections: 2,
        timeout: Duration::from_millis(300),
    })
    .await
    .expect("PostgreSQL connects lazily");
    let app = app(store, AppState::new(ServiceLimits::default()));
    let records = get(&app, "/v1/parts").await;
    assert_eq!(records.status, 503, "{}", records.text());
    assert_eq!(
        records.json()["type"],
        "urn:preston:problem:store-unavailable"
    );
    assert!(!records.text().contains("secret"));
    let write = post(&app, "/v1/process-profiles", &profile_body("down"), &[]).await;
    assert_eq!(write.status, 503);
    let fixture = crate::common::read_fixture("predict_paper_exp1.json");
    assert_eq!(post(&app, "/v1/predict", &fixture, &[]).await.status, 200);
    let ready = get(&app, "/readyz").await;
    assert_eq!(ready.status, 200);
    assert_eq!(ready.json()["store"], "unavailable");
}

/// One blocking HTTP/1.1 exchange that tolerates a server that dies: `None` unless a whole
/// response arrived.
fn exchange(address: &str, method: &str, path: &str, body: &str) -> Option<(u16, String)> {
    use std::io::{Read, Write};
    let mut stream = std::net::TcpStream::connect(address).ok()?;
    stream
        .set_read_timeout(Some(Duration::from_secs(20)))
        .ok()?;
    let head = format!(
        "{method} {path} HTTP/1.1\r\nhost: {address}\r\ncontent-type: application/json\r\n\
         content-length: {}\r\nconnection: close\r\n\r\n{body}",
        body.len()
    );
    stream.write_all(head.as_bytes()).ok()?;
    let mut raw = String::new();
    stream.read_to_string(&mut raw).ok()?;
    let (head, rest) = raw.split_once("\r\n\r\n")?;
    let status = head.split_whitespace().nth(1)?.parse().ok()?;
    let length: usize = head.lines().find_map(|l| {
        l.to_ascii_lowercase()
            .strip_prefix("content-length:")
            .map(|v| v.trim().parse().ok())
    })??;
    (rest.len() == length).then(|| (status, rest.to_string()))
}

/// SIGKILL of the real binary while 50 record writes are under way, then a restart on the same
/// store: every write answered 201 is there (5 rounds on each backend).
#[test]
fn no_acknowledged_record_is_lost_to_sigkill() {
    for url in backends() {
        let mut acknowledged_total = 0;
        for round in 0..5 {
            let mut service = crate::common::service::Service::start_on(&url);
            let token = unique();
            let profile = format!("kill-{token}");
            let (status, _) = exchange(
                &service.address,
                "POST",
                "/v1/process-profiles",
                &profile_body(&profile).to_string(),
            )
            .unwrap();
            assert_eq!(status, 201);
            let acknowledged = Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
            let writers: Vec<_> = (0..50)
                .map(|i| {
                    let (address, body, acknowledged) = (
                        service.address.clone(),
                        part_body(&format!("SN-{token}-{i}"), &profile).to_string(),
                        acknowledged.clone(),
                    );
                    std::thread::spawn(move || {
                        std::thread::sleep(Duration::from_millis(2 * i));
                        if let Some((201, body)) = exchange(&address, "POST", "/v1/parts", &body) {
                            let id = serde_json::from_str::<Value>(&body).unwrap()["id"]
                                .as_str()
                                .unwrap()
                                .to_string();
                            acknowledged.lock().unwrap().push(id);
                        }
                    })
                })
                .collect();
            // Kill once some, not all, writes are answered.
            let started = std::time::Instant::now();
            while acknowledged.lock().unwrap().len() < 10 + 5 * round
                && started.elapsed() < Duration::from_secs(20)
            {
                std::thread::sleep(Duration::from_millis(1));
            }
            service.signal("KILL");
            service.wait();
            for writer in writers {
                writer.join().unwrap();
            }
            let acknowledged = acknowledged.lock().unwrap().clone();
            assert!(
                acknowledged.len() < 50,
                "the kill came after every write: {}",
                acknowledged.len()
            );
            let restarted = crate::common::service::Service::start_on(&url);
            let missing: Vec<&String> = acknowledged
                .iter()
                .filter(|id| {
                    exchange(&restarted.address, "GET", &format!("/v1/parts/{id}"), "").map(|r| r.0)
                        != Some(200)
                })
                .collect();
            println!(
                "{url} round {round}: {} acknowledged before SIGKILL, {} missing after restart",
                acknowledged.len(),
                missing.len()
            );
            assert!(missing.is_empty(), "lost: {missing:?}");
            acknowledged_total += acknowledged.len();
        }
        assert!(acknowledged_total > 0);
    }
}

/// Two service processes on one PostgreSQL see each other's writes at once.
#[test]
fn two_processes_share_one_postgresql() {
    let Ok(url) = std::env::var("PRESTON_TEST_POSTGRES_URL") else {
        println!("PRESTON_TEST_POSTGRES_URL is not set: skipped (CI sets it)");
        return;
    };
    let (a, b) = (
        crate::common::service::Service::start_on(&url),
        crate::common::service::Service::start_on(&url),
    );
    let token = unique();
    let profile = format!("two-{token}");
    let (status, _) = exchange(
        &a.address,
        "POST",
        "/v1/process-profiles",
        &profile_body(&profile).to_string(),
    )
    .unwrap();
    assert_eq!(status, 201);
    assert_eq!(
        exchange(
            &b.address,
            "GET",
            &format!("/v1/process-profiles/{profile}"),
            ""
        )
        .unwrap()
        .0,
        200
    );
    let (status, part) = exchange(
        &b.address,
        "POST",
        "/v1/parts",
        &part_body(&format!("SN-{token}"), &profile).to_string(),
    )
    .unwrap();
    assert_eq!(status, 201);
    let id = serde_json::from_str::<Value>(&part).unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let (status, shown) = exchange(&a.address, "GET", &format!("/v1/parts/{id}"), "").unwrap();
    assert_eq!(status, 200);
    assert_eq!(
        serde_json::from_str::<Value>(&shown).unwrap()["name"],
        format!("SN-{token}")
    );
    // The same serial through the other process is a conflict, not a second part.
    let (status, _) = exchange(
        &a.address,
        "POST",
        "/v1/parts",
        &part_body(&format!("SN-{token}"), &profile).to_string(),
    )
    .unwrap();
    assert_eq!(status, 409);
}

/// A part's measurement as the fit's text/csv form (the trace as CSV, the rest as query
/// parameters) is the same measurement as its JSON body.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_measurement_comes_as_csv_too() {
    let store = open(&backends()[0]).await;
    let app = app(store.clone(), AppState::new(ServiceLimits::default()));
    let token = unique();
    let profile = format!("csv-{token}");
    created(&app, "/v1/process-profiles", &profile_body(&profile)).await;
    let part = created(
        &app,
        "/v1/parts",
        &part_body(&format!("SN-{token}"), &profile),
    )
    .await;
    let path = format!("/v1/parts/{}/measurements", part["id"].as_str().unwrap());
    let body = trace(&initial_error, 0.3, 11);
    let json = created(&app, &path, &body).await;
    let (x, z) = (
        numbers(&body["profile"]["x_mm"]),
        numbers(&body["profile"]["z_mm"]),
    );
    let csv: String = std::iter::once("x_mm,z_mm\n".to_string())
        .chain(x.iter().zip(&z).map(|(x, z)| format!("{x},{z}\n")))
        .collect();
    let query = "radial_grid=%7B%22start_mm%22%3A0%2C%22stop_mm%22%3A46%2C%22count%22%3A93%7D";
    let reply = post_with(
        &app,
        &format!("{path}?{query}"),
        csv,
        &[("content-type", "text/csv")],
    )
    .await;
    assert_eq!(reply.status, 201, "{}", reply.text());
    assert_eq!(reply.json()["rms_nm"], json["rms_nm"]);
    assert_eq!(reply.json()["result"]["profile"], json["result"]["profile"]);
    store.close().await;
}

/// A 20 MB blob (a map's worth) is kept and read back byte for byte on every backend, under
/// its SHA-256; the same bytes again are the same blob; an unknown name is none.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_twenty_megabyte_blob_round_trips_on_every_backend() {
    use sha2::{Digest, Sha256};
    let mut rng = fastrand::Rng::with_seed(48);
    let bytes: Vec<u8> = (0..20 * 1024 * 1024).map(|_| rng.u8(..)).collect();
    let expected: String = Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    for url in backends() {
        let store = open(&url).await;
        let name = store.put_blob(&bytes).await.unwrap();
        assert_eq!(name, expected, "{url}");
        assert_eq!(
            store.put_blob(&bytes).await.unwrap(),
            name,
            "{url}: kept once"
        );
        let back = store.blob(&name).await.unwrap().expect("the blob is there");
        assert!(
            back == bytes,
            "{url}: {} bytes back, not the same",
            back.len()
        );
        assert_eq!(store.blob(&"0".repeat(64)).await.unwrap(), None);
        store.close().await;
    }
}

/// An interferometer map of the part as Preston's text grid, from an independent generator:
/// 101 × 101 pixels of 1 mm over the 50 mm part (centre pixel 50, 50), the rotationally
/// symmetric error `error_nm(r)` plus 12 nm of astigmatism that no radial plan removes.
fn map_file(error_nm: &dyn Fn(f64) -> f64) -> String {
    let mut text = String::from("# pixel_mm: 1\n# wavelength_nm: 632.8\n");
    for row in 0..101 {
        let cells: Vec<String> = (0..101)
            .map(|column| {
                let (x, y) = (column as f64 - 50.0, 50.0 - row as f64);
                let r = x.hypot(y);
                if r > 50.0 {
                    return "NaN".into();
                }
                let astigmatism = 12.0 * (x * x - y * y) / 2500.0;
                format!("{}", error_nm(r) + astigmatism)
            })
            .collect();
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    text
}

async fn measure_map(app: &Router, part_id: &str, file: &str) -> Value {
    let reply = post_with(
        app,
        &format!("/v1/parts/{part_id}/measurements"),
        file.to_string(),
        &[("content-type", "application/octet-stream")],
    )
    .await;
    assert_eq!(reply.status, 201, "{}", reply.text());
    reply.json()
}

/// Two correction cycles measured by maps on one backend: each map kept byte for byte and
/// analysed on the part's aperture; each plan corrects its map's rotationally symmetric part;
/// each after-map lost 90 % of the predicted removal, so each cycle's removal ratio (from the
/// map difference) is 0.90 ± 0.02 and the profile learns it; the history's RMS come from the
/// maps, and what no radial plan removes (the astigmatism) stays.
async fn map_cycles(url: &str) {
    let (store, app, profile, part) = new_part(url).await;
    let part_id = part["id"].as_str().unwrap();
    let mut error: Box<dyn Fn(f64) -> f64> = Box::new(initial_error);
    let mut measured = vec![];
    let file = map_file(&error);
    let first = measure_map(&app, part_id, &file).await;
    assert_eq!(first["request"]["clear_aperture"]["shape"], "circle");
    assert_eq!(
        first["request"]["clear_aperture"]["radius_mm"].as_f64(),
        Some(40.0)
    );
    measured.push((first, file));
    for cycle in 0..2 {
        let plan = created(&app, &format!("/v1/parts/{part_id}/plans"), &plan_body()).await;
        let before = &measured.last().unwrap().0;
        assert_eq!(plan["measurement_id"], before["id"]);
        assert_eq!(
            plan["request"]["target"],
            before["result"]["correction_target"]
        );
        let plan_id = plan["id"].as_str().unwrap();
        created(
            &app,
            &format!("/v1/parts/{part_id}/runs"),
            &json!({"plan_id": plan_id, "started_at": from_now(1), "finished_at": from_now(300)}),
        )
        .await;
        let radius = numbers(&plan["result"]["radius_mm"]);
        let removal = numbers(&plan["result"]["removal_nm"]);
        let previous = error;
        error = Box::new(move |r| previous(r) - 0.90 * interpolate(&radius, &removal, r));
        let file = map_file(&error);
        let after = measure_map(&app, part_id, &file).await;
        assert!(after["completes_run_id"].is_string(), "{after}");
        assert!(after["learned_calibration_id"].is_string(), "{after}");
        let history = get(&app, &format!("/v1/parts/{part_id}/history"))
            .await
            .json();
        let shown = &history["cycles"][cycle];
        let ratio = shown["removal_ratio"]["value"].as_f64().unwrap();
        println!(
            "{url}: map cycle {cycle}: removal_ratio {ratio:.4} ± {}, RMS {} → {} nm",
            shown["removal_ratio"]["standard_error"], shown["rms_before_nm"], shown["rms_after_nm"]
        );
        assert!((ratio - 0.90).abs() <= 0.02, "cycle {cycle}: {ratio}");
        let (rms_before, rms_after) = (
            before["result"]["metrics"]["rms_nm"].as_f64().unwrap(),
            after["result"]["metrics"]["rms_nm"].as_f64().unwrap(),
        );
        assert_eq!(shown["rms_before_nm"].as_f64(), Some(rms_before));
        assert_eq!(shown["rms_after_nm"].as_f64(), Some(rms_after));
        assert_eq!(
            shown["convergence_ratio"].as_f64(),
            Some(rms_before / rms_after)
        );
        assert!(rms_after < rms_before, "{rms_before} → {rms_after}");
        // The astigmatism is what a radial plan leaves: 12·(r/50)²·cos 2θ has RMS
        // 12·(40/50)²/√6 = 3.135 nm over the 40 mm aperture (to 2 % on 1 mm pixels).
        let left = after["result"]["non_axisymmetric"]["rms_nm"]
            .as_f64()
            .unwrap();
        let astigmatism = 12.0 * 0.64 / 6f64.sqrt();
        assert!((left - astigmatism).abs() < 0.02 * astigmatism, "{left}");
        measured.push((after, file));
    }
    let shown = get(&app, &format!("/v1/process-profiles/{profile}"))
        .await
        .json();
    let learned = shown["calibrations"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["learned"] == true)
        .count();
    assert_eq!(learned, 2, "{shown}");
    // Every stored file comes back byte for byte; as CSV, the same heights.
    for (record, file) in &measured {
        let id = record["id"].as_str().unwrap();
        let back = get(&app, &format!("/v1/measurements/{id}/map")).await;
        assert_eq!(back.status, 200);
        assert_eq!(back.content_type, "application/octet-stream");
        assert_eq!(back.body, file.as_bytes(), "measurement {id}");
        let etag = back.headers["etag"].to_str().unwrap();
        let again = send(
            &app,
            axum::http::Request::get(format!("/v1/measurements/{id}/map"))
                .header("if-none-match", etag)
                .body(axum::body::Body::empty())
                .unwrap(),
        )
        .await;
        assert_eq!(again.status, 304);
        let csv = send(
            &app,
            axum::http::Request::get(format!("/v1/measurements/{id}/map"))
                .header("accept", "text/csv")
                .body(axum::body::Body::empty())
                .unwrap(),
        )
        .await;
        assert_eq!(csv.content_type, "text/csv");
        let values = |text: &str| -> Vec<f64> {
            text.lines()
                .filter(|l| !l.starts_with('#'))
                .flat_map(|l| l.split(',').map(|c| c.parse::<f64>().unwrap()))
                .collect()
        };
        let (got, want) = (values(&csv.text()), values(file));
        assert_eq!(got.len(), want.len());
        assert!(got
            .iter()
            .zip(&want)
            .all(|(g, w)| g == w || (g.is_nan() && w.is_nan())));
    }
    // A probe trace's measurement has no map.
    let trace_measurement = created(
        &app,
        &format!("/v1/parts/{part_id}/measurements"),
        &trace(&initial_error, 0.3, 11),
    )
    .await;
    let id = trace_measurement["id"].as_str().unwrap();
    assert_eq!(
        get(&app, &format!("/v1/measurements/{id}/map"))
            .await
            .status,
        404
    );
    store.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_part_measured_by_maps_learns_over_two_cycles_on_every_backend() {
    for url in backends() {
        map_cycles(&url).await;
    }
}

/// A flat 20 mm part's map as Preston's text grid at 1 mm (centre pixel 20, 20): `height(x, y)`
/// within the part, NaN beyond; and the same heights as JSON rows (null beyond).
fn flat_map(height: &dyn Fn(i64, i64) -> f64) -> (String, Value) {
    let mut text = String::from("# pixel_mm: 1\n");
    let mut rows = Vec::new();
    for row in 0..41i64 {
        let (mut cells, mut json_row) = (Vec::new(), Vec::new());
        for column in 0..41i64 {
            let (x, y) = (column - 20, 20 - row);
            if ((x * x + y * y) as f64).sqrt() > 20.0 {
                cells.push("NaN".to_string());
                json_row.push(Value::Null);
            } else {
                let h = height(x, y);
                cells.push(format!("{h}"));
                json_row.push(json!(h));
            }
        }
        text.push_str(&cells.join(","));
        text.push('\n');
        rows.push(Value::Array(json_row));
    }
    (text, Value::Array(rows))
}

/// A cycle measured by maps learns K as a calibration of its maps does: the part (a flat 20 mm
/// one) measured before with a figure, astigmatism and noise correlated over 1.5 pixels, the
/// plan's run removing 90 % of its exact removal (the motion it executes, pixel by pixel), and
/// measured after with fresh noise. The cycle's removal ratio and its standard error are those
/// of `/v1/calibration` given the same maps as a map run, to rounding: the records add nothing
/// and lose nothing, so the ratio inherits the map fit's tested coverage (±2σ over 200 seeds,
/// `map_calibration`), where the radial removal's error, fitted to a smoothed profile as if its
/// samples were independent, is several times smaller than the scatter.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cycle_measured_by_maps_learns_what_a_calibration_of_its_maps_gives() {
    use crate::map_calibration::correlated_noise;
    use preston::calibration::spatial::Pixel;
    use preston::physics::polar::{executed_blocks, PolarPad};
    use preston::physics::{Motion, Part, PressureModel, Process, ProcessSpec};
    use preston::surface::Surface;

    let url = &backends()[0];
    let store = open(url).await;
    let app = app(store.clone(), AppState::new(ServiceLimits::default()));
    let token = unique();
    let process = json!({"workpiece_radius_mm": 20, "tool_radius_mm": 5, "workpiece_rpm": -10,
                         "tool_rpm": 200, "preston_coefficient_m2_per_n": K_NOMINAL,
                         "pressure_kpa": 10});
    let profile = format!("flat-{token}");
    created(
        &app,
        "/v1/process-profiles",
        &json!({"name": profile, "process": process}),
    )
    .await;
    let part = created(
        &app,
        "/v1/parts",
        &json!({"name": format!("F-{token}"), "process_profile": profile,
                "workpiece_radius_mm": 20, "clear_aperture": {"inner_mm": 0, "outer_mm": 18}}),
    )
    .await;
    let part_id = part["id"].as_str().unwrap();
    let pixels: Vec<Pixel> = (-20..=20)
        .flat_map(|row| (-20..=20).map(move |column| Pixel { column, row }))
        .collect();
    let at = |values: &[f64], x: i64, y: i64| values[((y + 20) * 41 + (x + 20)) as usize];
    let noise_before = correlated_noise(&pixels, 1.5, 0.4, 71);
    let figure = |x: i64, y: i64| {
        let (u, v) = (x as f64 / 18.0, y as f64 / 18.0);
        30.0 * (u * u + v * v) + 8.0 * (u * u - v * v) + at(&noise_before, x, y)
    };
    let (before_text, before_rows) = flat_map(&figure);
    measure_map(&app, part_id, &before_text).await;
    let positions: Vec<f64> = (0..=36).map(|i| 0.5 * i as f64).collect();
    let plan = created(
        &app,
        &format!("/v1/parts/{part_id}/plans"),
        &json!({"positions_mm": positions}),
    )
    .await;
    let dwell = &plan["result"]["dwell"];
    created(
        &app,
        &format!("/v1/parts/{part_id}/runs"),
        &json!({"plan_id": plan["id"], "started_at": from_now(1), "finished_at": from_now(300)}),
    )
    .await;
    // The plan's exact removal at every pixel: the motion it executes, at the K it planned with.
    let process = Process::new(ProcessSpec {
        workpiece_radius_mm: 20.0,
        tool_radius_mm: 5.0,
        workpiece_rpm: -10.0,
        tool_rpm: 200.0,
        preston_coefficient_m2_per_n: K_NOMINAL,
        pressure_kpa: 10.0,
        pressure_model: PressureModel::Uniform,
        part: Part::flat(),
    })
    .unwrap();
    let pad = PolarPad::new(&process);
    let blocks = executed_blocks(
        &Motion::radial(numbers(&dwell["positions_mm"])),
        &numbers(&dwell["dwell_s"]),
        pad.part_speed_rad_per_s(),
        0.0,
        &Surface::plane(),
    );
    let points: Vec<(f64, f64)> = pixels
        .iter()
        .map(|p| (p.column as f64, p.row as f64))
        .collect();
    let removal = pad.depth_nm(&blocks, &points);
    let noise_after = correlated_noise(&pixels, 1.5, 0.4, 72);
    // The surface less 90 % of the removal, measured with fresh noise.
    let after = |x: i64, y: i64| {
        figure(x, y) - at(&noise_before, x, y) - 0.9 * at(&removal, x, y) + at(&noise_after, x, y)
    };
    let (after_text, after_rows) = flat_map(&after);
    let measured = measure_map(&app, part_id, &after_text).await;
    assert!(measured["learned_calibration_id"].is_string(), "{measured}");
    let history = get(&app, &format!("/v1/parts/{part_id}/history"))
        .await
        .json();
    let ratio = &history["cycles"][0]["removal_ratio"];
    let (value, se) = (
        ratio["value"].as_f64().unwrap(),
        ratio["standard_error"].as_f64().unwrap(),
    );
    // The same maps as a map run of `/v1/calibration`, placed as the after map was analysed.
    let direct = post(
        &app,
        "/v1/calibration",
        &json!({
            "process": process_json_of(&plan),
            "runs": [{
                "dwell": dwell,
                "clear_aperture": plan["request"]["clear_aperture"],
                "map": {
                    "before": {"heights_nm": before_rows},
                    "after": {"heights_nm": after_rows},
                    "pixel_mm": 1.0,
                    "clear_aperture": measured["request"]["clear_aperture"],
                },
            }],
        }),
        &[],
    )
    .await;
    assert_eq!(direct.status, 200, "{}", direct.text());
    let direct = direct.json();
    let k = &direct["parameters"]["preston_coefficient_m2_per_n"];
    let (direct_value, direct_se) = (
        direct["removal_rate_ratio"].as_f64().unwrap(),
        k["standard_error"].as_f64().unwrap() / K_NOMINAL,
    );
    println!(
        "map cycle: removal_ratio {value:.5} ± {se:.5}, direct {direct_value:.5} ± {direct_se:.5}, \
         bandwidth {} px, inflation {:.2}",
        direct["runs"][0]["map"]["correlation_bandwidth_px"],
        direct["runs"][0]["map"]["variance_inflation"].as_f64().unwrap()
    );
    assert!(
        (value - direct_value).abs() <= 1e-12 * direct_value,
        "{value} against {direct_value}"
    );
    assert!(
        (se - direct_se).abs() <= 1e-9 * direct_se,
        "{se} against {direct_se}"
    );
    assert!((value - 0.9).abs() <= 4.0 * se, "{value} ± {se}");
    store.close().await;
}

/// A plan's process (its request's), as a calibration's nominal.
fn process_json_of(plan: &Value) -> Value {
    plan["request"]["process"].clone()
}

/// A polar plan is a part's plan: planned from the part's latest map (its file, placed as it
/// was analysed) it answers what `/v1/maps/optimize` answers on that map's heights, exactly;
/// its program is `/v1/maps/program`'s on the plan's dwell and C law, its header naming the
/// plan; and its cycle, measured by maps, learns K from every pixel of the plan's polar motion:
/// an after map that lost 0.9 of the plan's predicted removal (`/v1/maps/predict`, the same
/// exact removal) gives a removal ratio of 0.9 to the fit's rounding. (K 20× the nominal: a
/// plan of some 80 turns, whose exact map one request predicts.)
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_polar_plan_corrects_the_parts_map_and_learns_from_its_maps() {
    let url = &backends()[0];
    let store = open(url).await;
    let app = app(store.clone(), AppState::new(ServiceLimits::default()));
    let token = unique();
    let process = json!({"workpiece_radius_mm": 20, "tool_radius_mm": 5, "workpiece_rpm": -10,
                         "tool_rpm": 200, "preston_coefficient_m2_per_n": 20.0 * K_NOMINAL,
                         "pressure_kpa": 10});
    let profile = format!("polar-{token}");
    created(
        &app,
        "/v1/process-profiles",
        &json!({"name": profile, "process": process}),
    )
    .await;
    let new_part = |serial: String| {
        json!({"name": serial, "process_profile": profile, "workpiece_radius_mm": 20,
               "clear_aperture": {"inner_mm": 0, "outer_mm": 18}})
    };
    let positions: Vec<f64> = (0..=36).map(|i| 0.5 * i as f64).collect();
    let polar = json!({"positions_mm": positions, "machine": {"kinematics": "polar"},
                       "c_law": {"sectors": 16}});

    // Nothing measured yet, or a trace last: the plan names `map`.
    let bare = created(&app, "/v1/parts", &new_part(format!("P0-{token}"))).await;
    let refused = post(
        &app,
        &format!("/v1/parts/{}/plans", bare["id"].as_str().unwrap()),
        &polar,
        &[],
    )
    .await;
    assert_eq!(refused.status, 422, "{}", refused.text());
    assert_eq!(refused.json()["field"], "map", "{}", refused.text());
    let traced = created(&app, "/v1/parts", &new_part(format!("P2-{token}"))).await;
    let traced_id = traced["id"].as_str().unwrap();
    let flat_trace: Vec<f64> = (0..=200).map(|i| -20.0 + 0.2 * i as f64).collect();
    created(
        &app,
        &format!("/v1/parts/{traced_id}/measurements"),
        &json!({"profile": {"x_mm": flat_trace,
                            "z_mm": flat_trace.iter().map(|x| 1e-6 * x * x).collect::<Vec<_>>()}}),
    )
    .await;
    let refused = post(&app, &format!("/v1/parts/{traced_id}/plans"), &polar, &[]).await;
    assert_eq!(refused.status, 422, "{}", refused.text());
    assert_eq!(refused.json()["field"], "map", "{}", refused.text());
    assert!(refused.text().contains("probe trace"), "{}", refused.text());
    // A polar member in a radial plan's body: an invalid input naming it, saying how a polar
    // plan is asked for.
    let refused = post(
        &app,
        &format!("/v1/parts/{traced_id}/plans"),
        &json!({"positions_mm": positions, "c_law": {"sectors": 16}}),
        &[],
    )
    .await;
    assert_eq!(refused.status, 422, "{}", refused.text());
    let problem = refused.json();
    assert_eq!(problem["field"], "c_law", "{problem}");
    assert_eq!(problem["type"], "urn:preston:problem:invalid-input");
    assert!(problem["detail"]
        .as_str()
        .unwrap()
        .contains("machine.kinematics: polar"));

    let part = created(&app, "/v1/parts", &new_part(format!("P1-{token}"))).await;
    let part_id = part["id"].as_str().unwrap();
    let figure = |x: i64, y: i64| {
        let (u, v) = (x as f64 / 18.0, y as f64 / 18.0);
        20.0 * (u * u + v * v) + 12.0 * (u * u - v * v) + 6.0 * u * (u * u - 3.0 * v * v)
    };
    let (before_text, before_rows) = flat_map(&figure);
    let measured = measure_map(&app, part_id, &before_text).await;
    let plan = created(&app, &format!("/v1/parts/{part_id}/plans"), &polar).await;
    assert_eq!(plan["measurement_id"], measured["id"]);
    assert!(
        plan["request"].get("map").is_none(),
        "the map is the measurement's file"
    );

    // The same plan from `/v1/maps/optimize`, the map as its rows.
    let mut direct_request = plan["request"].clone();
    direct_request["map"] = json!({"heights_nm": before_rows, "pixel_mm": 1.0});
    let direct = post(&app, "/v1/maps/optimize", &direct_request, &[]).await;
    assert_eq!(direct.status, 200, "{}", direct.text());
    assert_eq!(
        plan["result"],
        direct.json(),
        "the plan is maps/optimize's answer"
    );
    let metrics = &plan["result"]["metrics"];
    assert_eq!(plan["predicted_rms_after_nm"], metrics["after"]["rms_nm"]);
    let (asym_before, asym_after) = (
        metrics["non_axisymmetric_before"]["rms_nm"]
            .as_f64()
            .unwrap(),
        metrics["non_axisymmetric_after"]["rms_nm"]
            .as_f64()
            .unwrap(),
    );
    assert!(asym_after < 0.5 * asym_before, "{metrics}");

    // Its program: maps/program's on the plan's motion, the header naming the plan.
    let plan_id = plan["id"].as_str().unwrap();
    let (dwell, c_law) = (&plan["result"]["dwell"], &plan["result"]["c_law"]);
    let program = post(
        &app,
        &format!("/v1/plans/{plan_id}/program"),
        &json!({}),
        &[],
    )
    .await;
    assert_eq!(program.status, 200, "{}", program.text());
    let program = program.json();
    let direct_program = post(
        &app,
        "/v1/maps/program",
        &json!({"process": process_json_of(&plan), "dwell": dwell, "c_law": c_law}),
        &[],
    )
    .await;
    assert_eq!(direct_program.status, 200, "{}", direct_program.text());
    let direct_program = direct_program.json();
    assert_eq!(program["axes"], direct_program["axes"]);
    assert_eq!(program["blocks"], direct_program["blocks"]);
    let gcode = post(
        &app,
        &format!("/v1/plans/{plan_id}/program"),
        &json!({}),
        &[("accept", "text/x-gcode")],
    )
    .await;
    assert_eq!(gcode.status, 200, "{}", gcode.text());
    assert!(
        gcode.text().lines().take(3).any(|l| l.contains(plan_id)),
        "the G-code header names the plan"
    );
    assert!(
        gcode
            .text()
            .lines()
            .any(|l| l.starts_with("G1") && l.contains(" C")),
        "moves with C words"
    );
    let refused = post(
        &app,
        &format!("/v1/plans/{plan_id}/program"),
        &json!({"c_law": c_law}),
        &[],
    )
    .await;
    assert_eq!(refused.status, 422, "{}", refused.text());
    assert_eq!(refused.json()["field"], "c_law");
    // A radial program's member: an invalid input here (the body's schema is either kind's).
    let refused = post(
        &app,
        &format!("/v1/plans/{plan_id}/program"),
        &json!({"clearance_mm": 5}),
        &[],
    )
    .await;
    assert_eq!(refused.status, 422, "{}", refused.text());
    let problem = refused.json();
    assert_eq!(problem["field"], "clearance_mm", "{problem}");
    assert_eq!(problem["type"], "urn:preston:problem:invalid-input");
    assert!(problem["detail"]
        .as_str()
        .unwrap()
        .contains("this plan is polar"));

    // Run it; the after map lost 0.9 of the plan's exact removal.
    created(
        &app,
        &format!("/v1/parts/{part_id}/runs"),
        &json!({"plan_id": plan_id, "started_at": from_now(1), "finished_at": from_now(300)}),
    )
    .await;
    let predicted = post(
        &app,
        "/v1/maps/predict",
        &json!({"process": process_json_of(&plan), "dwell": dwell, "c_law": c_law,
                "pixel_mm": 1.0}),
        &[],
    )
    .await;
    assert_eq!(predicted.status, 200, "{}", predicted.text());
    let predicted = predicted.json();
    let removal = &predicted["removal"]["removal_nm"];
    let x_mm = numbers(&predicted["removal"]["x_mm"]);
    let y_mm = numbers(&predicted["removal"]["y_mm"]);
    assert_eq!(x_mm.len(), 41, "a pixel a millimetre across the part");
    let removal_at = |x: i64, y: i64| {
        let column = x_mm.iter().position(|&v| v == x as f64).unwrap();
        let row = y_mm.iter().position(|&v| v == y as f64).unwrap();
        removal[row][column].as_f64().unwrap()
    };
    let (after_text, _) = flat_map(&|x, y| figure(x, y) - 0.9 * removal_at(x, y));
    let after = measure_map(&app, part_id, &after_text).await;
    // Noiseless maps fit exactly: K with no standard error, so nothing is learned from it.
    assert!(after["completes_run_id"].is_string(), "{after}");
    let history = get(&app, &format!("/v1/parts/{part_id}/history"))
        .await
        .json();
    let ratio = history["cycles"][0]["removal_ratio"]["value"]
        .as_f64()
        .unwrap();
    println!("polar cycle: removal ratio {ratio:.9}");
    assert!((ratio - 0.9).abs() <= 1e-6, "{ratio}");
    store.close().await;
}
