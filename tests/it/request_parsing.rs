//! Reading request bodies and the `Accept` header (`http::extract`): content negotiation,
//! serde's errors turned into the field they are about, and said in JSON's words.

use axum::http::{header, HeaderMap, HeaderValue};
use preston::http::error::{ApiError, Kind};
use preston::http::extract::{negotiate, parse_json, Format};

fn accept(value: &str) -> HeaderMap {
    let mut h = HeaderMap::new();
    h.insert(header::ACCEPT, HeaderValue::from_str(value).unwrap());
    h
}

#[test]
fn negotiation_honours_q_values_and_wildcards() {
    let both = [Format::Json, Format::Csv];
    assert_eq!(negotiate(&HeaderMap::new(), &both).unwrap(), Format::Json);
    assert_eq!(negotiate(&accept("text/csv"), &both).unwrap(), Format::Csv);
    assert_eq!(negotiate(&accept("*/*"), &both).unwrap(), Format::Json);
    assert_eq!(
        negotiate(&accept("application/json;q=0.5, text/csv"), &both).unwrap(),
        Format::Csv
    );
    assert_eq!(negotiate(&accept("text/*"), &both).unwrap(), Format::Csv);
    assert!(negotiate(&accept("image/png"), &both).is_err());
    assert!(negotiate(&accept("text/csv"), &[Format::Json]).is_err());
}

#[test]
fn parse_errors_name_the_field() {
    #[derive(serde::Deserialize, Debug)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Inner {
        x: f64,
        ys: Vec<f64>,
    }
    #[derive(serde::Deserialize, Debug)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Outer {
        inner: Inner,
    }
    let field = |body: &str| match parse_json::<Outer>(body.as_bytes()).unwrap_err() {
        e @ ApiError {
            kind: Kind::SchemaMismatch | Kind::MalformedJson,
            ..
        } => e.field,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        field(r#"{"inner": {"x": "a", "ys": []}}"#).unwrap(),
        "inner.x"
    );
    assert_eq!(
        field(r#"{"inner": {"x": 1, "ys": [1, true]}}"#).unwrap(),
        "inner.ys[1]"
    );
    assert_eq!(field(r#"{"inner": {"ys": []}}"#).unwrap(), "inner.x");
    assert_eq!(
        field(r#"{"inner": {"x": 1, "ys": [], "z": 2}}"#).unwrap(),
        "inner.z"
    );
    assert_eq!(
        parse_json::<Outer>(b"{\"inner\": ").unwrap_err().kind,
        Kind::MalformedJson
    );
}

/// Errors in the API's words: JSON's types, never Rust's; an empty or non-JSON body says
/// what is expected.
#[test]
fn parse_errors_speak_json() {
    #[derive(serde::Deserialize, Debug)]
    #[allow(dead_code)]
    struct Body {
        x: f64,
        n: usize,
        ys: Vec<f64>,
        name: Option<String>,
    }
    let detail = |body: &str| match parse_json::<Body>(body.as_bytes()).unwrap_err() {
        e @ ApiError {
            kind: Kind::SchemaMismatch | Kind::MalformedJson,
            ..
        } => e.detail,
        other => panic!("{other:?}"),
    };
    let cases = [
        (
            r#"{"x": "50"}"#,
            r#"expected a number here, got the text "50""#,
        ),
        (
            r#"{"x": 1, "n": 2.5}"#,
            "expected a whole number here, got the number 2.5",
        ),
        (
            r#"{"x": 1, "n": 2, "ys": {}}"#,
            "expected a list (a JSON array) here, got an object",
        ),
        (
            r#"{"x": 1, "n": 2, "ys": [true]}"#,
            "expected a number here, got true",
        ),
        (
            r#"{"x": 1, "n": 2, "ys": [], "name": 5}"#,
            "expected text (a JSON string) here, got the number 5",
        ),
        (
            r#"[1, 2]"#,
            "expected a JSON object here, got a list (an array)",
        ),
    ];
    for (body, want) in cases {
        assert_eq!(detail(body), want, "{body}");
    }
    for (body, start) in [
        ("", "the body is empty: send one JSON object"),
        ("  \n", "the body is empty: send one JSON object"),
        (
            "process=1&dwell=2",
            "the body is not JSON: send one JSON object",
        ),
    ] {
        let got = detail(body);
        assert!(got.starts_with(start), "{body:?}: {got}");
        assert!(got.contains("Content-Type: application/json"), "{got}");
    }
    // Syntax errors in the user's words, with where they are.
    for (body, want) in [
        (
            r#"{"x": 1, "ys": ["#,
            "the JSON ends too soon: a value, bracket or brace is missing (line 1, column 16)",
        ),
        (
            r#"{"x": 1, }"#,
            "a comma before a closing bracket or brace (line 1, column 10)",
        ),
        (
            r#"{x: 1}"#,
            "a member name must be text in double quotes (line 1, column 2)",
        ),
        (
            r#"{"x": bad}"#,
            "expected a JSON value (a number, text, list or object) (line 1, column 7)",
        ),
        (
            r#"{"x": nope}"#,
            "expected a JSON value (true, false, null, or quoted text) (line 1, column 8)",
        ),
    ] {
        assert_eq!(detail(body), want, "{body}");
    }
}
