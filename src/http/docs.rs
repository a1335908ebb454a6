//! The OpenAPI document and the interactive docs (Swagger UI), both served from the binary:
//! the UI's files are vendored into it at build time, so nothing is fetched at view time.

use axum::extract::{Path, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Redirect, Response};

use super::error::ApiError;
use super::state::AppState;

/// `GET /openapi.json`: the generated document, byte for byte `openapi/openapi.json`.
pub async fn openapi_json(State(state): State<AppState>) -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        state.openapi_json.to_string(),
    )
        .into_response()
}

pub async fn redirect() -> Redirect {
    Redirect::permanent("/docs/")
}

/// `GET /docs/` and its assets.
pub async fn asset(State(state): State<AppState>, path: Option<Path<String>>) -> Response {
    let tail = path.map(|Path(p)| p).unwrap_or_default();
    match utoipa_swagger_ui::serve(&tail, state.swagger.clone()) {
        Ok(Some(file)) => {
            let mut bytes = file.bytes.into_owned();
            if file.content_type.starts_with("text/html") && !file.gzpipped {
                bytes = titled(&bytes);
            }
            let mut response = (
                StatusCode::OK,
                [(header::CONTENT_TYPE, file.content_type)],
                bytes,
            )
                .into_response();
            if file.gzpipped {
                response
                    .headers_mut()
                    .insert(header::CONTENT_ENCODING, "gzip".parse().unwrap());
            }
            response
        }
        Ok(None) => ApiError::not_found(&format!("/docs/{tail}")).into_response(),
        Err(e) => ApiError::internal(format!("serving docs asset {tail}: {e}")).into_response(),
    }
}

/// The page titled for Preston (the vendored page says "Swagger UI").
fn titled(html: &[u8]) -> Vec<u8> {
    String::from_utf8_lossy(html)
        .replace(
            "<title>Swagger UI</title>",
            "<title>Preston API — interactive docs</title>",
        )
        .into_bytes()
}
