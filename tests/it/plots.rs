//! `Accept: image/svg+xml`: every charting endpoint returns an SVG document that parses as XML
//! and carries its axis titles with units. The charts under docs/ (shown by the README) are
//! the same requests; `PRESTON_BLESS=1 cargo test --release --test it plots::` redraws them.

use crate::common;

use common::http::{app, post_with};
use common::read_fixture;

/// (endpoint, fixture, docs file, axis titles the chart must carry).
const CHARTS: [(&str, &str, &str, &[&str]); 4] = [
    (
        "/v1/removal-function",
        "removal_function_paper_exp1.json",
        "removal_function.svg",
        &["radius r (mm)", "removal rate (nm/min)"],
    ),
    (
        "/v1/predict",
        "predict_paper_exp1.json",
        "predict.svg",
        &[
            "radius r (mm)",
            "removal depth (nm)",
            "clear aperture [0, 40] mm",
        ],
    ),
    (
        "/v1/optimize",
        "optimize_paper_exp1.json",
        "optimize.svg",
        &["tool position r1 (mm)", "dwell (s)", "feed (mm/min)"],
    ),
    (
        "/v1/studies/eta-sweep",
        "eta_sweep_figure7.json",
        "eta_sweep.svg",
        &["η = −workpiece_rpm / tool_rpm", "nonuniformity pv/mean (%)"],
    ),
];

/// All text content of an SVG document, which must parse as XML with an <svg> root.
fn texts(svg: &str) -> Vec<String> {
    let doc = roxmltree::Document::parse(svg).expect("SVG parses as XML");
    assert_eq!(doc.root_element().tag_name().name(), "svg");
    doc.descendants()
        .filter(|n| n.is_text())
        .filter_map(|n| n.text())
        .map(|t| t.trim().to_string())
        .filter(|t| !t.is_empty())
        .collect()
}

#[tokio::test]
async fn charts_parse_and_carry_their_axis_titles() {
    let docs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs");
    for (path, fixture, file, titles) in CHARTS {
        let body = read_fixture(fixture).to_string();
        let reply = post_with(&app(), path, body, &[("accept", "image/svg+xml")]).await;
        assert_eq!(reply.status, 200, "{path}: {}", reply.text());
        assert_eq!(reply.content_type, "image/svg+xml");
        let svg = reply.text();
        let found = texts(&svg);
        for title in titles {
            assert!(
                found.iter().any(|t| t == title),
                "{path}: no `{title}` in {found:?}"
            );
        }
        if std::env::var_os("PRESTON_BLESS").is_some() {
            std::fs::create_dir_all(&docs).unwrap();
            std::fs::write(docs.join(file), &svg).unwrap();
        }
        // The committed chart is a real one of the same kind.
        let committed = std::fs::read_to_string(docs.join(file)).expect("docs chart committed");
        let found = texts(&committed);
        for title in titles {
            assert!(
                found.iter().any(|t| t == title),
                "docs/{file}: no `{title}`"
            );
        }
    }
}

#[tokio::test]
async fn svg_is_refused_where_there_is_no_chart() {
    let body = read_fixture("recommend_paper_exp1.json").to_string();
    let reply = post_with(
        &app(),
        "/v1/recommend",
        body,
        &[("accept", "image/svg+xml")],
    )
    .await;
    assert_eq!(reply.status, 406);
}
