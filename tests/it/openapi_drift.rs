//! The committed OpenAPI document must be exactly what the code generates. After an
//! intentional API change: `cargo run -- openapi > openapi/openapi.json`.

#[test]
fn committed_openapi_matches_the_generated_document() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("openapi/openapi.json");
    let committed = std::fs::read_to_string(&path).expect("openapi/openapi.json is committed");
    let generated = preston::http::openapi::spec_json();
    assert!(
        committed == generated,
        "openapi/openapi.json is out of date: run `cargo run -- openapi > openapi/openapi.json`"
    );
}

/// Every schema property documents itself (units live in the names and descriptions).
#[test]
fn every_request_and_response_field_has_a_description() {
    let spec: serde_json::Value =
        serde_json::from_str(&preston::http::openapi::spec_json()).unwrap();
    let schemas = spec["components"]["schemas"].as_object().unwrap();
    let mut missing = Vec::new();
    for (name, schema) in schemas {
        if let Some(props) = schema["properties"].as_object() {
            for (field, prop) in props {
                // Optional objects carry their description on the non-null `oneOf` member.
                let described = prop.get("description").is_some()
                    || prop["oneOf"].as_array().is_some_and(|members| {
                        members.iter().any(|m| m.get("description").is_some())
                    });
                if !described {
                    missing.push(format!("{name}.{field}"));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "fields without a description: {missing:?}"
    );
}
