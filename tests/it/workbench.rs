//! The workbench page at `GET /`: served from the binary with a policy that admits only this
//! origin, referencing no external URL, and wired to the API it calls — every path it posts to
//! is a route, every field it names in an error mapping is a request field of the OpenAPI
//! document, every element its script looks up by id exists. (The browser test,
//! `tests/browser/workbench.py`, drives the page itself in chromium.)

use crate::common;

use common::http::{app, get, post_json};
use preston::http::workbench::{ASSETS, CONTENT_SECURITY_POLICY};
use preston::http::{openapi, ENDPOINTS};
use serde_json::Value;

fn asset(name: &str) -> &'static str {
    ASSETS.iter().find(|(n, _, _)| *n == name).unwrap().2
}

/// The `first-answers` block of a served page, parsed, and the page with the block emptied
/// (as it is compiled in).
fn first_answers(page: &str) -> (Vec<Value>, String) {
    let open = r#"<script type="application/json" id="first-answers">"#;
    let start = page.find(open).expect("the page has a first-answers block") + open.len();
    let end = start + page[start..].find("</script>").unwrap();
    let answers: Vec<Value> = serde_json::from_str(&page[start..end]).unwrap();
    (answers, format!("{}[]{}", &page[..start], &page[end..]))
}

/// The page comes with the answers to its first view's requests: each one is what the API
/// itself answers to that request, and the requests are the default set-up's (paper experiment
/// 1). Behind API keys the page carries none (it must ask with the user's key).
#[tokio::test]
async fn the_page_carries_the_api_s_own_first_answers() {
    let app = app();
    let body = get(&app, "/").await.body.to_vec();
    let (answers, _) = first_answers(&String::from_utf8(body).unwrap());
    let paths: Vec<&str> = answers
        .iter()
        .map(|a| a["path"].as_str().unwrap())
        .collect();
    assert_eq!(
        paths,
        [
            "/v1/removal-function",
            "/v1/recommend",
            "/v1/studies/eta-sweep",
            "/v1/predict",
            "/v1/predict",
            "/v1/maps/removal-function"
        ]
    );
    for answer in &answers {
        let request = &answer["request"];
        assert_eq!(request["process"]["workpiece_radius_mm"], 50);
        let reply = post_json(&app, answer["path"].as_str().unwrap(), request.to_string()).await;
        assert_eq!(reply.status, 200, "{}", reply.text());
        assert_eq!(reply.json(), answer["response"], "{}", answer["path"]);
    }
    // The second prediction is at the recommended η = −1 speeds.
    let speeds = &answers[1]["response"]["recommendation"];
    assert_eq!(
        answers[4]["request"]["process"]["tool_rpm"],
        speeds["tool_rpm"]
    );
    let keyed = common::http::app_with_keys();
    let body = get(&keyed, "/").await.body.to_vec();
    let (answers, _) = first_answers(&String::from_utf8(body).unwrap());
    assert!(answers.is_empty());
}

/// Every `open…close` substring of `text`, without the delimiters.
fn between<'a>(text: &'a str, open: &str, close: char) -> Vec<&'a str> {
    text.match_indices(open)
        .filter_map(|(i, _)| {
            let rest = &text[i + open.len()..];
            rest.find(close).map(|end| &rest[..end])
        })
        .collect()
}

#[tokio::test]
async fn the_page_and_its_assets_are_served_with_a_same_origin_policy() {
    let app = app();
    let page = get(&app, "/").await;
    assert_eq!(page.status, 200);
    assert!(page.content_type.starts_with("text/html"));
    // The page as compiled in, but for the first answers it carries (see below).
    let body = String::from_utf8(page.body.to_vec()).unwrap();
    let (answers, page_text) = first_answers(&body);
    assert_eq!(page_text, asset("index.html"));
    assert!(!answers.is_empty());
    let csp = page.headers["content-security-policy"].to_str().unwrap();
    assert_eq!(csp, CONTENT_SECURITY_POLICY);
    // No source but 'self' (and the page's own blob:/data: URLs) for anything.
    for directive in csp.split(';') {
        for source in directive.split_whitespace().skip(1) {
            assert!(
                ["'self'", "'none'", "data:", "blob:"].contains(&source),
                "{directive}"
            );
        }
    }
    assert!(csp.contains("default-src 'none'"));
    for (path, kind) in [
        ("/workbench/workbench.js", "text/javascript"),
        ("/workbench/workbench.css", "text/css"),
    ] {
        let reply = get(&app, path).await;
        assert_eq!(reply.status, 200, "{path}");
        assert!(reply.content_type.starts_with(kind), "{path}");
        assert_eq!(reply.headers["x-content-type-options"], "nosniff");
    }
    let missing = get(&app, "/workbench/other.js").await;
    assert_eq!(missing.status, 404);
    assert_eq!(missing.content_type, "application/problem+json");
}

#[test]
fn the_page_references_no_external_url() {
    let html = asset("index.html");
    let script = asset("workbench.js");
    let style = asset("workbench.css");
    // Attributes that load or link: same-origin paths, fragments, or the empty data: icon.
    for value in between(html, "src=\"", '"')
        .into_iter()
        .chain(between(html, "href=\"", '"'))
    {
        let local = (value.starts_with('/') && !value.starts_with("//"))
            || value.starts_with('#')
            || value == "data:,";
        assert!(local, "index.html links to `{value}`");
    }
    // No scheme anywhere but the SVG namespace name (an identifier, never fetched).
    for (name, text) in [
        ("index.html", html),
        ("workbench.js", script),
        ("workbench.css", style),
    ] {
        for (i, _) in text.match_indices("://") {
            let start = text[..i].rfind(['\'', '"', ' ', '(']).map_or(0, |s| s + 1);
            let url: String = text[start..]
                .chars()
                .take_while(|c| !matches!(c, '\'' | '"' | ' ' | ')'))
                .collect();
            assert_eq!(url, "http://www.w3.org/2000/svg", "{name} names `{url}`");
        }
        assert!(!text.contains("@import"), "{name}");
        assert!(!text.contains("url("), "{name}");
    }
    // The script calls only its own origin.
    for call in between(script, "fetch(", ')') {
        assert!(
            call == "url, init" || call == "'/openapi.json'",
            "fetch({call})"
        );
    }
}

/// Every property path (`a`, `a.b`) of the computing endpoints' request bodies, following
/// `$ref`, `oneOf` and `anyOf`.
fn request_fields() -> Vec<String> {
    let spec: Value = serde_json::from_str(&openapi::spec_json()).unwrap();
    let resolve = |v: &Value| -> Value {
        match v.get("$ref").and_then(Value::as_str) {
            Some(r) => spec["components"]["schemas"][r.rsplit('/').next().unwrap()].clone(),
            None => v.clone(),
        }
    };
    fn properties(v: &Value, resolve: &dyn Fn(&Value) -> Value) -> Vec<(String, Value)> {
        let v = resolve(v);
        let mut out: Vec<(String, Value)> = v["properties"]
            .as_object()
            .map(|p| p.iter().map(|(k, s)| (k.clone(), s.clone())).collect())
            .unwrap_or_default();
        for key in ["oneOf", "anyOf"] {
            for alternative in v[key].as_array().into_iter().flatten() {
                out.extend(properties(alternative, resolve));
            }
        }
        out
    }
    let mut fields = Vec::new();
    for paths in spec["paths"].as_object().unwrap().values() {
        let Some(content) = paths["post"]["requestBody"]["content"].as_object() else {
            continue;
        };
        // Every path into the body, to any depth (`machine.x.max_velocity_mm_per_min`).
        let mut open = properties(&content["application/json"]["schema"], &resolve);
        while let Some((name, schema)) = open.pop() {
            for (inner, inner_schema) in properties(&schema, &resolve) {
                open.push((format!("{name}.{inner}"), inner_schema));
            }
            fields.push(name);
        }
    }
    fields
}

#[test]
fn the_page_is_wired_to_the_api() {
    let html = asset("index.html");
    let script = asset("workbench.js");

    // Fields the page maps errors to are fields of the requests.
    let fields = request_fields();
    let named = between(html, "data-field=\"", '"');
    assert!(named.len() >= 20, "{} inputs name a field", named.len());
    for field in named {
        assert!(
            fields.iter().any(|f| f == field),
            "data-field `{field}` is no request field"
        );
    }

    // The script's one table of paths is the service's, and it posts only to those.
    let table = script
        .split_once("const API = {")
        .and_then(|(_, rest)| rest.split_once("};"))
        .expect("the script has its table of paths")
        .0;
    let paths = between(table, ": '", '\'');
    let spec: Value = serde_json::from_str(&openapi::spec_json()).unwrap();
    for endpoint in ENDPOINTS.iter() {
        assert!(
            paths.contains(&endpoint.path().as_str()),
            "the script's table lacks {}",
            endpoint.path()
        );
    }
    for path in &paths {
        assert!(
            spec["paths"].get(*path).is_some(),
            "the script's table has {path}, which the API does not serve"
        );
    }
    assert_eq!(
        script.matches("/v1/").count(),
        paths.len(),
        "a path written outside the table"
    );
    let mut posted = between(script, "post(view, ", ',');
    posted.extend(between(script, "repeat(view, ", ','));
    assert!(posted.len() >= 6);
    // (`path` is the helpers' own parameter; a record's path is a table path with its id.)
    for name in posted.into_iter().filter(|n| *n != "path") {
        assert!(
            name.starts_with("API.") || name.starts_with("`${API."),
            "the script posts to {name}"
        );
    }

    // Elements the script looks up by id exist.
    let ids = between(html, "id=\"", '"');
    for id in between(script, "$('#", '\'')
        .into_iter()
        .chain(between(script, "value('", '\''))
        .chain(between(script, "getElementById('", '\''))
    {
        let id = id.split([' ', '.', '[']).next().unwrap();
        assert!(ids.contains(&id), "the script looks up #{id}");
    }
}
