//! Request parsing and content negotiation, with every failure as an [`ApiError`] that names
//! the field.
//!
//! Bodies are parsed with `serde_path_to_error`, so a type error deep in the body reports its
//! path (`dwell.positions_mm[3]`). Accepted content types: `application/json` and any `+json`
//! type; also no content type at all and `application/x-www-form-urlencoded`, which is what
//! `curl -d @file` sends unless told otherwise: the body must still be JSON.

use axum::body::Bytes;
use axum::extract::{FromRequest, Request};
use axum::http::{header, HeaderMap, StatusCode};
use serde::de::{DeserializeOwned, Visitor};
use serde::{Deserialize, Deserializer};

use super::error::{ApiError, Kind};

/// Parses a JSON body (an object) into `T`, mapping serde's errors to problems that name the
/// field, in the API's words (numbers, text, lists, objects — not Rust's types).
pub fn parse_json<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, ApiError> {
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(ApiError::new(
            Kind::MalformedJson,
            NOT_JSON.replace("{what}", "the body is empty"),
        ));
    }
    let mut deserializer = serde_json::Deserializer::from_slice(bytes);
    let value = serde_path_to_error::deserialize(ObjectOnly(&mut deserializer)).map_err(|err| {
        let path = err.path().to_string();
        let inner = err.into_inner();
        // A body that is not JSON at all (form-encoded `a=1&b=2`, plain text) fails on its
        // first character: say what is expected rather than where the parser stopped.
        if path == "." && inner.is_syntax() && inner.line() == 1 && inner.column() <= 1 {
            return ApiError::new(
                Kind::MalformedJson,
                NOT_JSON.replace("{what}", "the body is not JSON"),
            );
        }
        problem_of(&path, inner)
    })?;
    // Trailing characters after the JSON value.
    deserializer.end().map_err(|e| problem_of(".", e))?;
    Ok(value)
}

/// What a body must be, after `{what}` went wrong.
const NOT_JSON: &str = "{what}: send one JSON object, such as {\"process\": {...}}, with \
    Content-Type: application/json (curl: -H 'Content-Type: application/json' -d @file.json)";

/// Marks a failure's path inside a request of one of several kinds ([`kind_from_value`]), so
/// that [`problem_of`] names the field as if the kind had been parsed directly.
const PATH_MARK: char = '\u{1f}';

/// A request of several kinds, told apart by a member, parsed as the kind chosen: its failure
/// carries its path (below the outer one) for [`problem_of`].
pub fn kind_from_value<T: DeserializeOwned, E: serde::de::Error>(
    value: serde_json::Value,
) -> Result<T, E> {
    serde_path_to_error::deserialize(value).map_err(|err| {
        let path = err.path().to_string();
        E::custom(format!("{PATH_MARK}{path}{PATH_MARK}{}", err.into_inner()))
    })
}

fn problem_of(path: &str, inner: serde_json::Error) -> ApiError {
    let raw = strip_position(&inner.to_string());
    // A kind's own failure: its path below ours, and its message.
    let (joined, raw) = match raw
        .strip_prefix(PATH_MARK)
        .and_then(|r| r.split_once(PATH_MARK))
    {
        Some((inner_path, message)) => {
            let joined = match (path, inner_path) {
                (".", p) => p.to_string(),
                (p, ".") => p.to_string(),
                (p, q) => format!("{p}.{q}"),
            };
            (joined, message.to_string())
        }
        None => (path.to_string(), raw),
    };
    let path = joined.as_str();
    let field = field_of(path, &raw);
    let message = in_users_words(raw);
    match inner.classify() {
        serde_json::error::Category::Data => ApiError::new(Kind::SchemaMismatch, message)
            .at(field.unwrap_or_else(|| "body".to_string())),
        _ => {
            let detail = format!(
                "{message} (line {}, column {})",
                inner.line(),
                inner.column()
            );
            let mut error = ApiError::new(Kind::MalformedJson, detail);
            error.field = field;
            error
        }
    }
}

/// serde says "invalid type: string \"50\", expected f64" or "EOF while parsing a value"; say
/// it in JSON's terms: "expected a number here, got the text \"50\"".
fn in_users_words(message: String) -> String {
    // The syntax errors serde_json reports in its own words.
    for (serde, ours) in [
        (
            "EOF while parsing",
            "the JSON ends too soon: a value, bracket or brace is missing",
        ),
        (
            "expected value",
            "expected a JSON value (a number, text, list or object)",
        ),
        (
            "expected ident",
            "expected a JSON value (true, false, null, or quoted text)",
        ),
        (
            "key must be a string",
            "a member name must be text in double quotes",
        ),
        (
            "trailing comma",
            "a comma before a closing bracket or brace",
        ),
        (
            "trailing characters",
            "more after the JSON object: send one object",
        ),
    ] {
        if message.starts_with(serde) {
            return ours.to_string();
        }
    }
    if let Some(words) = unknown_variant(&message).or_else(|| retired_field(&message)) {
        return words;
    }
    let Some((got, expected)) = message
        .strip_prefix("invalid type: ")
        .and_then(|rest| rest.rsplit_once(", expected "))
    else {
        return message;
    };
    let expected = match expected {
        "f64" | "f32" => "a number",
        "u8" | "u16" | "u32" | "u64" | "usize" | "i8" | "i16" | "i32" | "i64" | "isize" => {
            "a whole number"
        }
        "a string" | "a borrowed string" => "text (a JSON string)",
        "a sequence" => "a list (a JSON array)",
        "a boolean" => "true or false",
        "a map" => "a JSON object",
        other if other.starts_with("struct ") => "a JSON object",
        other => other,
    };
    let got = if let Some(text) = got.strip_prefix("string ") {
        format!("the text {text}")
    } else if let Some(number) = ["integer `", "floating point `"]
        .iter()
        .find_map(|p| got.strip_prefix(p))
    {
        format!("the number {}", number.trim_end_matches('`'))
    } else {
        match got {
            "sequence" => "a list (an array)".to_string(),
            "map" => "an object".to_string(),
            "boolean `true`" => "true".to_string(),
            "boolean `false`" => "false".to_string(),
            "unit value" => "null".to_string(),
            other => other.to_string(),
        }
    };
    format!("expected {expected} here, got {got}")
}

/// Fields the API no longer takes, each with what replaced it.
const RETIRED_FIELDS: &[(&str, &str)] = &[(
    "equal_dwell_positions",
    "equal_dwell_positions is retired: equal dwell is no longer cut into cells but computed \
     exactly as one constant feed, so there is no count to give. The recommendation returns \
     that pass as equal_dwell.feed, and /v1/predict takes it as `feed` ({\"start_mm\", \
     \"stop_mm\", \"feed_mm_per_min\"}) in place of `dwell`",
)];

/// serde's "unknown field `equal_dwell_positions`, expected one of …" for a retired field:
/// what replaced it.
fn retired_field(message: &str) -> Option<String> {
    let name = message.strip_prefix("unknown field `")?.split('`').next()?;
    RETIRED_FIELDS
        .iter()
        .find(|(retired, _)| *retired == name)
        .map(|(_, words)| words.to_string())
}

/// serde's "unknown variant `spherical`, expected one of `plane`, `sphere`" (or "expected
/// `plane` or `sphere`") in the user's words: the values accepted, listed.
fn unknown_variant(message: &str) -> Option<String> {
    let rest = message.strip_prefix("unknown variant `")?;
    let (got, expected) = rest.split_once("`, expected ")?;
    let accepted: Vec<&str> = expected
        .trim_start_matches("one of ")
        .split(['`', ','])
        .map(str::trim)
        .filter(|w| !w.is_empty() && *w != "or")
        .collect();
    let list = match accepted.as_slice() {
        [] => return None,
        [one] => format!("\"{one}\""),
        [init @ .., last] => format!(
            "{} or \"{last}\"",
            init.iter()
                .map(|w| format!("\"{w}\""))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    Some(format!("\"{got}\" is not accepted here: use {list}"))
}

/// A deserializer that gives structs only a JSON object. serde's derive also fills a struct
/// from an array, by position (`[50, 10, 200, -10]` as a process, with the speeds wherever
/// they land): the API refuses that. Used for the body (see [`parse_json`]) and, through
/// [`object`] and [`optional_object`], for every struct-valued request field.
struct ObjectOnly<D>(D);

impl<'de, D: Deserializer<'de>> Deserializer<'de> for ObjectOnly<D> {
    type Error = D::Error;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, D::Error> {
        self.0.deserialize_any(visitor)
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, D::Error> {
        self.0.deserialize_map(visitor)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
        ignored_any
    }
}

/// `deserialize_with` for a struct-valued field: a JSON object only (see [`ObjectOnly`]).
pub fn object<'de, D: Deserializer<'de>, T: Deserialize<'de>>(d: D) -> Result<T, D::Error> {
    T::deserialize(ObjectOnly(d))
}

/// `deserialize_with` for an optional struct-valued field (with `#[serde(default)]`): absent
/// or null, or a JSON object.
pub fn optional_object<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    struct Object<T>(T);
    impl<'de, T: Deserialize<'de>> Deserialize<'de> for Object<T> {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            object(d).map(Object)
        }
    }
    Ok(Option::<Object<T>>::deserialize(d)?.map(|o| o.0))
}

/// `deserialize_with` for an optional count (with `#[serde(default)]`): JSON Schema's
/// `integer` includes numbers written with a fraction of zero (`204.0`), so those are taken
/// too; anything else not a whole number ≥ 0 is refused.
pub fn optional_count<'de, D: Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
    use serde::de::Error;
    let Some(number) = Option::<serde_json::Number>::deserialize(d)? else {
        return Ok(None);
    };
    if let Some(n) = number.as_u64() {
        return usize::try_from(n)
            .map(Some)
            .map_err(|_| D::Error::custom(format!("{n} is too large")));
    }
    match number.as_f64() {
        // Whole numbers up to 2^53 are exact in f64.
        Some(x) if x.fract() == 0.0 && (0.0..=9_007_199_254_740_992.0).contains(&x) => {
            Ok(Some(x as usize))
        }
        _ => Err(D::Error::custom(format!(
            "invalid value: {number}, expected a whole number ≥ 0"
        ))),
    }
}

/// `deserialize_with` for a required count: like [`optional_count`], present.
pub fn count<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    use serde::de::Error;
    optional_count(d)?.ok_or_else(|| D::Error::custom("expected a whole number ≥ 0, not null"))
}

/// serde_json appends " at line L column C"; the problem carries the path instead.
fn strip_position(message: &str) -> String {
    match message.rfind(" at line ") {
        Some(i) => message[..i].to_string(),
        None => message.to_string(),
    }
}

/// The field a serde error is about: its path, completed with the name serde reports for
/// missing and unknown fields (whose path stops at the enclosing object).
fn field_of(path: &str, message: &str) -> Option<String> {
    let named = ["missing field `", "unknown field `"]
        .iter()
        .find_map(|prefix| message.strip_prefix(prefix))
        .and_then(|rest| rest.split('`').next());
    let base = (path != ".").then(|| path.to_string());
    match (base, named) {
        (Some(base), Some(name)) if !base.ends_with(name) => Some(format!("{base}.{name}")),
        (None, Some(name)) => Some(name.to_string()),
        (base, _) => base,
    }
}

/// A JSON body extractor whose rejections are problem+json.
pub struct ApiJson<T>(pub T);

impl<S, T> FromRequest<S> for ApiJson<T>
where
    S: Send + Sync,
    T: DeserializeOwned,
{
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        check_content_type(req.headers(), &[])?;
        json_body(req, state).await.map(ApiJson)
    }
}

/// The body parsed as JSON (its content type already checked).
pub async fn json_body<S: Send + Sync, T: DeserializeOwned>(
    req: Request,
    state: &S,
) -> Result<T, ApiError> {
    parse_json(&read_body(req, state).await?)
}

/// The whole body, within the configured limit (413 beyond).
pub async fn read_body<S: Send + Sync>(req: Request, state: &S) -> Result<Bytes, ApiError> {
    let limit = req
        .extensions()
        .get::<BodyLimit>()
        .map(|l| l.0)
        .unwrap_or(usize::MAX);
    Bytes::from_request(req, state).await.map_err(|rejection| {
        if rejection.status() == StatusCode::PAYLOAD_TOO_LARGE {
            ApiError::payload_too_large(limit)
        } else {
            ApiError::new(
                Kind::MalformedJson,
                format!("could not read the request body: {rejection}"),
            )
        }
    })
}

/// The configured body limit, made visible to the extractor for its error message.
#[derive(Debug, Clone, Copy)]
pub struct BodyLimit(pub usize);

/// Whether the request's content type is one of `media` (its essence, case-insensitive).
pub fn has_media(headers: &HeaderMap, media: &[&str]) -> bool {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.split(';').next())
        .is_some_and(|essence| media.iter().any(|t| essence.trim().eq_ignore_ascii_case(t)))
}

/// Refuses a body that is neither JSON nor one of `also` (further media types the endpoint
/// takes). A form-encoded body passes, to be told it is not JSON.
pub fn check_content_type(headers: &HeaderMap, also: &[&str]) -> Result<(), ApiError> {
    let Some(value) = headers.get(header::CONTENT_TYPE) else {
        return Ok(());
    };
    let text = value.to_str().unwrap_or("");
    let essence = text
        .split(';')
        .next()
        .unwrap_or("")
        .trim()
        .to_ascii_lowercase();
    let json = essence == "application/json" || essence.ends_with("+json");
    if json || essence == "application/x-www-form-urlencoded" || also.contains(&essence.as_str()) {
        Ok(())
    } else {
        let accepted: Vec<&str> = std::iter::once("application/json")
            .chain(also.iter().copied())
            .collect();
        Err(ApiError::unsupported_media_type(
            text,
            &accepted.join(" or "),
        ))
    }
}

/// Response formats an endpoint can produce.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Json,
    Csv,
    Svg,
    Gcode,
    /// A file as it was sent.
    File,
    Png,
}

impl Format {
    pub fn media_type(self) -> &'static str {
        match self {
            Format::Json => "application/json",
            Format::Csv => "text/csv",
            Format::Svg => "image/svg+xml",
            Format::Gcode => "text/x-gcode",
            Format::File => "application/octet-stream",
            Format::Png => "image/png",
        }
    }
}

/// Picks the response format from the `Accept` header: the offered format with the highest
/// q-value (ties go to the earlier offer; no header or `*/*` means the first offer, JSON).
pub fn negotiate(headers: &HeaderMap, offered: &[Format]) -> Result<Format, ApiError> {
    let Some(accept) = headers.get(header::ACCEPT).and_then(|v| v.to_str().ok()) else {
        return Ok(offered[0]);
    };
    let mut best: Option<(f32, Format)> = None;
    for range in accept.split(',') {
        let mut parts = range.split(';');
        let media = parts.next().unwrap_or("").trim().to_ascii_lowercase();
        let q = parts
            .filter_map(|p| p.trim().strip_prefix("q="))
            .find_map(|q| q.trim().parse::<f32>().ok())
            .unwrap_or(1.0);
        if q <= 0.0 {
            continue;
        }
        for &format in offered {
            let (kind, _) = format.media_type().split_once('/').unwrap();
            let matches = media == format.media_type()
                || media == "*/*"
                || media == format!("{kind}/*")
                || (format == Format::Json && media == "application/problem+json");
            if matches && best.is_none_or(|(bq, _)| q > bq) {
                best = Some((q, format));
            }
        }
    }
    best.map(|(_, f)| f).ok_or_else(|| {
        let offered = offered
            .iter()
            .map(|f| f.media_type())
            .collect::<Vec<_>>()
            .join(", ");
        ApiError::not_acceptable(accept, &offered)
    })
}
