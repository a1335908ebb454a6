//! The OpenAPI document's edits: what JSON Schema and OpenAPI can say about the API but the
//! generator's attributes cannot (utoipa, in `http::openapi`), written as edits of the
//! generated document — schema keywords, closed variants, query parameters that mirror the
//! body's fields, the record operations' links and headers. The document stays generated from
//! the code; these are its finishing, in one place and independent of serving it.

use serde_json::{json, Value};

/// Applies every edit to the generated document.
pub fn finish(doc: &mut Value) {
    for (schema, property, keyword, value) in CONSTRAINTS {
        let mut target = &mut doc["components"]["schemas"][schema]["properties"][property];
        let mut path = keyword.split('.').peekable();
        while let Some(key) = path.next() {
            if path.peek().is_none() {
                target
                    .as_object_mut()
                    .expect("constraints name existing properties")
                    .insert(key.to_string(), value());
                break;
            }
            target = &mut target[key];
        }
    }
    // The surface's and a map aperture's variants are closed objects (serde denies unknown
    // fields; utoipa says so for structs, not for an enum's variants), and a zero radius is a
    // plane, which has its own kind.
    for tagged in ["SurfaceDto", "MapApertureDto"] {
        let variants = doc["components"]["schemas"][tagged]["oneOf"]
            .as_array_mut()
            .expect("a tagged enum is a oneOf");
        for variant in variants {
            variant["additionalProperties"] = json!(false);
            if let Some(radius) = variant["properties"].get_mut("radius_of_curvature_mm") {
                radius["not"] = json!({"const": 0});
            }
        }
    }
    still_process(doc);
    query_mirrors_body(doc);
    record_operations(doc);
}

/// An X-Y machine's part stands still: its requests' process is the process with
/// `workpiece_rpm` exactly 0 (where every turning request's must not be 0), a schema of its
/// own derived from the process's.
fn still_process(doc: &mut Value) {
    let schemas = &mut doc["components"]["schemas"];
    let mut still = schemas["ProcessDto"].clone();
    still["description"] = json!(
        "The polishing process on an X-Y machine: as everywhere, but the part stands still \
         (`workpiece_rpm` 0) and the pad spins in place at `tool_rpm`."
    );
    still["properties"]["workpiece_rpm"] = json!({
        "type": "number",
        "format": "double",
        "const": 0,
        "description": "0: the part stands still on an X-Y machine.",
    });
    schemas["StillProcessDto"] = still;
    for request in STILL_PROCESS_REQUESTS {
        let process = &mut schemas[request]["properties"]["process"];
        let description = process["description"].clone();
        *process = json!({
            "$ref": "#/components/schemas/StillProcessDto",
            "description": description,
        });
    }
}

/// The requests whose process is a still part's.
const STILL_PROCESS_REQUESTS: [&str; 1] = ["StillRemovalFunctionRequest"];

/// What JSON Schema can say about the requests but utoipa's attributes cannot: (schema,
/// property, keyword, value). Positions are strictly increasing (so they are unique; the order
/// itself is not expressible and is stated in the field's description); the workpiece must
/// turn; η = 0 would stop it.
type Constraint = (&'static str, &'static str, &'static str, fn() -> Value);

const CONSTRAINTS: [Constraint; 5] = [
    ("ProcessDto", "workpiece_rpm", "not", || json!({"const": 0})),
    ("DwellDto", "positions_mm", "uniqueItems", || json!(true)),
    ("OptimizeRequest", "positions_mm", "uniqueItems", || {
        json!(true)
    }),
    ("MeasuredProfileDto", "radius_mm", "uniqueItems", || {
        json!(true)
    }),
    (
        "EtaSweepRequest",
        "etas",
        "items.not",
        || json!({"const": 0}),
    ),
];

/// An operation with query parameters (the fit's `text/csv` form) takes the JSON body's other
/// fields there; each parameter gets exactly that field's schema (less its `null` branch):
/// objects as JSON-encoded values (`content: application/json`), numbers and enum names as
/// they are. A bare `type: string` would admit strings the service must refuse.
fn query_mirrors_body(doc: &mut Value) {
    let schemas = doc["components"]["schemas"].clone();
    let Some(paths) = doc["paths"].as_object_mut() else {
        return;
    };
    // (Read with `pointer` and `get_mut`: indexing a Value mutably would add the keys.)
    for post in paths.values_mut().filter_map(|item| item.get_mut("post")) {
        let body_schema = post
            .pointer("/requestBody/content/application~1json/schema/$ref")
            .and_then(Value::as_str)
            .and_then(|r| r.rsplit('/').next())
            .map(str::to_string);
        let parameters = post.get_mut("parameters").and_then(Value::as_array_mut);
        if let (Some(parameters), Some(body_schema)) = (parameters, body_schema) {
            // A body of several kinds (`anyOf` of named schemas): each parameter is any of
            // the kinds' fields of its name.
            let body = &schemas[&body_schema];
            let kinds: Vec<&Value> = match body["anyOf"].as_array() {
                Some(members) => members
                    .iter()
                    .filter_map(|m| m["$ref"].as_str())
                    .filter_map(|r| r.rsplit('/').next())
                    .map(|n| &schemas[n]["properties"])
                    .collect(),
                None => vec![&body["properties"]],
            };
            mirror(parameters, &kinds, &schemas);
        }
    }
}

fn mirror(parameters: &mut [Value], kinds: &[&Value], schemas: &Value) {
    for parameter in parameters {
        let name = parameter["name"]
            .as_str()
            .expect("parameters are named")
            .to_string();
        let mirrored: Vec<(Value, bool)> = kinds
            .iter()
            .map(|properties| &properties[&name])
            .filter(|field| !field.is_null())
            .map(|field| mirrored(field, schemas))
            .collect();
        if mirrored.is_empty() {
            // Not a body field (a path or header parameter): another edit's.
            parameter
                .as_object_mut()
                .expect("a parameter is an object")
                .insert("schema".to_string(), Value::Null);
            continue;
        }
        let is_object = mirrored.iter().any(|(_, object)| *object);
        let mut distinct: Vec<Value> = Vec::new();
        for (schema, _) in mirrored {
            if !distinct.contains(&schema) {
                distinct.push(schema);
            }
        }
        let schema = match distinct.len() {
            1 => distinct.pop().expect("one schema"),
            _ => json!({"anyOf": distinct}),
        };
        let parameter = parameter.as_object_mut().expect("a parameter is an object");
        parameter.remove("schema");
        if is_object {
            parameter.insert(
                "content".to_string(),
                json!({"application/json": {"schema": schema}}),
            );
        } else {
            parameter.insert("schema".to_string(), schema);
        }
    }
}

/// A body field's schema as its query parameter's (less its `null` branch), and whether it is
/// an object (sent as JSON).
fn mirrored(field: &Value, schemas: &Value) -> (Value, bool) {
    let mut schema = match field["oneOf"].as_array() {
        Some(branches) => branches
            .iter()
            .find(|b| b["type"] != "null")
            .expect("an optional field has a non-null branch")
            .clone(),
        None => field.clone(),
    };
    if let Some(types) = schema["type"].as_array() {
        let not_null: Vec<_> = types.iter().filter(|t| *t != "null").cloned().collect();
        schema["type"] = Value::Array(not_null);
        if let [only] = schema["type"].as_array().map(Vec::as_slice).unwrap_or(&[]) {
            schema["type"] = only.clone();
        }
    }
    let referenced = schema["$ref"]
        .as_str()
        .and_then(|r| r.rsplit('/').next())
        .map(|n| &schemas[n]);
    let is_object = referenced.is_some_and(|s| s["type"] == "object" || s["oneOf"].is_array());
    (schema, is_object)
}

/// The links between record operations, a line each: the operation (from its 201 answer), the
/// link's name, the operation it leads to, that operation's parameter and where its value
/// comes from. Clients (and schemathesis's stateful tests) follow them from a new record to
/// what can be done with it.
const LINKS: &str = "
    createProcessProfile     GetProfile      getProcessProfile        name  $response.body#/name
    createProcessProfile     Calibrate       calibrateProcessProfile  name  $response.body#/name
    calibrateProcessProfile  GetCalibration  getCalibration           id    $response.body#/id
    createPart               GetPart         getPart                  id    $response.body#/id
    createPart               Measure         createMeasurement        id    $response.body#/id
    createPart               Plan            createPlan               id    $response.body#/id
    createPart               Run             createRun                id    $response.body#/id
    createPart               History         getPartHistory           id    $response.body#/id
    createMeasurement        GetMeasurement  getMeasurement           id    $response.body#/id
    createMeasurement        PlanFromIt      createPlan               id    $response.body#/part_id
    createPlan               GetPlan         getPlan                  id    $response.body#/id
    createPlan               Program         createPlanProgram        id    $response.body#/id
    createPlan               RunIt           createRun                id    $response.body#/part_id
    createRun                GetRun          getRun                   id    $response.body#/id
";

/// The links, and the schemas utoipa leaves empty on the record operations' parameters (the
/// Idempotency-Key header's exact one, and a path parameter's beside it).
fn record_operations(doc: &mut Value) {
    measurements_take_bodies(doc);
    let Some(paths) = doc["paths"].as_object_mut() else {
        return;
    };
    for parameter in paths
        .values_mut()
        .filter_map(|item| item.get_mut("post"))
        .filter_map(|post| post.get_mut("parameters"))
        .filter_map(Value::as_array_mut)
        .flatten()
    {
        if parameter["name"] == "Idempotency-Key" {
            parameter["schema"] = json!({
                "type": "string", "minLength": 1, "maxLength": 255, "pattern": "^[!-~]+$"
            });
        } else if parameter["in"] == "path" && parameter["schema"].is_null() {
            parameter["schema"] = json!({"type": "string"});
        }
    }
    for link in LINKS.lines().filter(|l| !l.trim().is_empty()) {
        let [operation, name, target, parameter, value] = link
            .split_whitespace()
            .collect::<Vec<_>>()
            .try_into()
            .expect("a link is five words");
        let response = paths
            .values_mut()
            .filter_map(|item| item.as_object_mut())
            .flat_map(|item| item.values_mut())
            .find(|op| op["operationId"] == operation)
            .and_then(|op| op.pointer_mut("/responses/201"))
            .expect("links join documented operations");
        response["links"][name] = json!({
            "operationId": target,
            "parameters": {parameter: value},
        });
    }
}

/// A part's measurement also comes as the fit's `text/csv` form (that operation's CSV body and
/// query parameters, less `surface`: the part's) and as an interferometer map's file (the map
/// analysis's octet-stream body and query parameters, less `clear_aperture`: the part's).
fn measurements_take_bodies(doc: &mut Value) {
    measurements_take(doc, "/v1/measurement/fit", "text/csv", "surface");
    measurements_take(
        doc,
        "/v1/maps/analysis",
        "application/octet-stream",
        "clear_aperture",
    );
}

/// The part's measurement operation takes `source`'s `media` body and its query parameters
/// but `excluded`.
fn measurements_take(doc: &mut Value, source: &str, media: &str, excluded: &str) {
    let operation = &doc["paths"][source]["post"];
    let body = operation["requestBody"]["content"][media].clone();
    let query: Vec<Value> = operation["parameters"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(|p| p["in"] == "query" && p["name"] != excluded)
        .cloned()
        .collect();
    let Some(measure) = doc
        .pointer_mut("/paths/~1v1~1parts~1{id}~1measurements/post")
        .filter(|_| !body.is_null())
    else {
        return;
    };
    measure["requestBody"]["content"][media] = body;
    if let Some(parameters) = measure["parameters"].as_array_mut() {
        parameters.extend(query);
    }
}
