//! Parts and their measurements (`ledger::parts`: a measurement that follows a run completes
//! that run's cycle and may teach the profile its Preston coefficient).

use axum::extract::{FromRequest, Path, Query, Request, State};
use axum::http::{HeaderMap, Uri};
use axum::response::Response;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use super::docs::{PartMeasurementRequest, RecordReadProblems, RecordWriteProblems};
use super::dto::{MeasurementDto, PartDto, PartListDto, PartRequest};
use super::{begin, commit, computed_by, fetched, fetched_as, replayed, store, tag, Writer, PARTS};
use crate::http::csv_body::{query_object, CsvForm, CsvOrJson};
use crate::http::dto::WarningDto;
use crate::http::error::ApiError;
use crate::http::extract::ApiJson;
use crate::http::extract::{self, Format};
use crate::http::maps::body::MapSource;
use crate::http::state::AppState;
use crate::ledger::parts::{self, Measured, MeasurementOutcome, NewPart};
use crate::ledger::{self, document, PartBody};
use crate::maps::grid;
use crate::store::sha256_hex;
use crate::usecases::records::{PartRecord, Record, Records};

/// Most parts a page lists.
pub const MAX_PAGE: usize = 100;

pub(super) fn part_dto(part: &PartRecord) -> Result<PartDto, ApiError> {
    let body: PartBody = ledger::stored(&part.body, "a stored part")?;
    let workpiece_radius_mm = body.workpiece_radius_mm.as_f64().ok_or_else(|| {
        ApiError::internal(format!(
            "a stored part's radius {}",
            body.workpiece_radius_mm
        ))
    })?;
    Ok(PartDto {
        id: part.stamp.id.clone(),
        name: part.name.clone(),
        process_profile: part.process_profile.clone(),
        surface: body.surface,
        workpiece_radius_mm,
        clear_aperture: body.clear_aperture,
        created_at: part.stamp.created_at.clone(),
        created_by: part.stamp.created_by.clone(),
        computed_by: computed_by(&part.stamp),
    })
}

#[utoipa::path(post, path = PARTS, tag = "records", operation_id = "createPart", summary = "Create a part",
    params(("Idempotency-Key" = Option<String>, Header, description = "1–255 visible ASCII characters; a retry with the same key and request gets the first answer")), request_body = PartRequest,
    responses((status = 201, description = "Written (or the first answer to this Idempotency-Key)", body = PartDto,
        headers(("Location" = String, description = "The new record"))), RecordWriteProblems))]
/// `POST /v1/parts`
pub async fn create(
    State(state): State<AppState>,
    caller: Writer,
    headers: HeaderMap,
    ApiJson(request): ApiJson<PartRequest>,
) -> Result<Response, ApiError> {
    let body = serde_json::to_value(&request).map_err(|e| ApiError::internal(e.to_string()))?;
    let mut rest = body.as_object().cloned().unwrap_or_default();
    for field in ["name", "process_profile"] {
        rest.remove(field);
    }
    let part = NewPart::new(request.name, request.process_profile, rest)?;
    let store = store(&state)?;
    let write = begin(store, &caller, &headers, "POST /v1/parts", &body)?;
    let render = |part: String| async move { part_dto(&parts::load(store, &part).await?) };
    if let Some(replay) = write.replay().await? {
        return replayed(replay, render).await;
    }
    let taken = format!("a part named `{}` exists", part.name());
    let record = part.record(&state, &write).await?;
    let dto = part_dto(&record)?;
    let id = (PARTS, record.stamp.id.clone());
    let records = [Record::Part(record)];
    commit(write, &records, id, &dto, Some(&taken), render).await
}

/// `GET /v1/parts` query.
#[derive(Debug, Deserialize, Serialize, utoipa::IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct PartQuery {
    /// 1 to 100; default 20.
    #[param(minimum = 1, maximum = 100)]
    pub limit: Option<usize>,
    /// The `next_cursor` of the page before.
    pub cursor: Option<String>,
    /// Only the part with this name.
    pub name: Option<String>,
}

#[utoipa::path(get, path = PARTS, tag = "records", operation_id = "listParts", summary = "List parts, a page at a time",
    params(PartQuery), responses((status = 200, description = "The record", body = PartListDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/parts`
pub async fn list(
    State(state): State<AppState>,
    uri: Uri,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let Query(query) = Query::<PartQuery>::try_from_uri(&uri)
        .map_err(|e| ApiError::invalid("query", e.body_text()))?;
    let limit = query.limit.unwrap_or(20);
    if !(1..=MAX_PAGE).contains(&limit) {
        return Err(ApiError::invalid("limit", "limit is from 1 to 100"));
    }
    let page = store(&state)?
        .parts(query.cursor.as_deref(), limit, query.name.as_deref())
        .await?;
    let ids = page.items.iter().map(|p| p.stamp.id.as_str());
    let etag = tag(
        &state,
        "parts",
        ids.chain([page.next_cursor.as_deref().unwrap_or("")]),
    );
    fetched(&headers, etag, || {
        Ok(PartListDto {
            items: page.items.iter().map(part_dto).collect::<Result<_, _>>()?,
            next_cursor: page.next_cursor.clone(),
        })
    })
}

#[utoipa::path(get, path = "/v1/parts/{id}", tag = "records", operation_id = "getPart", summary = "A part",
    params(("id" = String, Path, description = "The part's id")), responses((status = 200, description = "The record", body = PartDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/parts/{id}`
pub async fn show(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let part = parts::load(store(&state)?, &id).await?;
    fetched(
        &headers,
        tag(&state, "part", [part.stamp.id.as_str()]),
        || part_dto(&part),
    )
}

/// A measurement request (JSON, or text/csv with the query) before the part fills it in.
#[derive(Debug, Deserialize)]
#[serde(transparent)]
pub struct MeasurementBody(Map<String, Value>);

impl CsvForm for MeasurementBody {
    const QUERY_FIELDS: &'static [&'static str] = &[
        "probe_tip_radius_mm",
        "compensation",
        "fit",
        "robust",
        "radial_grid",
        "clear_aperture",
    ];

    fn merge_csv(bytes: &[u8], body: &mut Map<String, Value>) -> Result<(), ApiError> {
        <crate::http::measurement_fit::MeasurementFitRequest as CsvForm>::merge_csv(bytes, body)
    }
}

#[utoipa::path(post, path = "/v1/parts/{id}/measurements", tag = "records", operation_id = "createMeasurement", summary = "Fit and store a measurement of the part: a probe trace (JSON or text/csv) or an interferometer map (its file as application/octet-stream, analysed on the part's clear aperture and kept byte for byte)",
    params(("id" = String, Path, description = "The part's id"), ("Idempotency-Key" = Option<String>, Header, description = "1–255 visible ASCII characters; a retry with the same key and request gets the first answer")), request_body = PartMeasurementRequest,
    responses((status = 201, description = "Written (or the first answer to this Idempotency-Key)", body = MeasurementDto,
        headers(("Location" = String, description = "The new record"))), RecordWriteProblems))]
/// `POST /v1/parts/{id}/measurements`: a probe trace (JSON, or text/csv with the query), or
/// an interferometer map's file as the body (application/octet-stream) with the map analysis's
/// options as query parameters.
pub async fn measure(
    State(state): State<AppState>,
    Path(id): Path<String>,
    caller: Writer,
    headers: HeaderMap,
    request: Request,
) -> Result<Response, ApiError> {
    let store = store(&state)?;
    let is_map = extract::has_media(&headers, &[MAP_FILE]);
    // The operation's query parameters are a trace's and a map's: each only with its body.
    let (theirs, whose) = if is_map {
        (
            MeasurementBody::QUERY_FIELDS,
            "a probe trace sent as text/csv",
        )
    } else {
        (
            MAP_QUERY_FIELDS,
            "a map file sent as application/octet-stream",
        )
    };
    let given: Vec<(String, String)> = Query::try_from_uri(request.uri())
        .map(|Query(q)| q)
        .map_err(|e| ApiError::invalid("query", e.body_text()))?;
    if let Some((name, _)) = given.iter().find(|(n, _)| theirs.contains(&n.as_str())) {
        return Err(ApiError::invalid(
            name.clone(),
            format!("`{name}` configures {whose}, not this body"),
        ));
    }
    let (body, file) = if is_map {
        let options = query_object(given, MAP_QUERY_FIELDS)?;
        let limit = state.limits.max_map_bytes;
        let file = axum::body::to_bytes(request.into_body(), limit)
            .await
            .map_err(|_| ApiError::payload_too_large(limit))?;
        (options, Some(file))
    } else {
        let CsvOrJson(MeasurementBody(body)) = CsvOrJson::from_request(request, &state).await?;
        (body, None)
    };
    // A map's request is its options and its file (by its hash).
    let mut identity = body.clone();
    if let Some(file) = &file {
        identity.insert("map_sha256".into(), sha256_hex(file).into());
    }
    let write = begin(
        store,
        &caller,
        &headers,
        &format!("POST /v1/parts/{id}/measurements"),
        &Value::Object(identity),
    )?;
    let render = |measurement: String| async move {
        measurement_dto(&parts::measurement(store, &measurement).await?)
    };
    if let Some(replay) = write.replay().await? {
        return replayed(replay, render).await;
    }
    let measured = match &file {
        Some(file) => Measured::Map {
            request: body,
            file,
        },
        None => Measured::Trace(body),
    };
    let measured = parts::measure(&state, &write, &id, measured).await?;
    let dto = measurement_dto(&measured)?;
    let record = ("/v1/measurements", dto.id.clone());
    let mut records = vec![Record::Measurement(measured.measurement)];
    records.extend(measured.fitted.map(Record::Calibration));
    commit(write, &records, record, &dto, None, render).await
}

/// The media type of a map file sent to a part's measurements.
const MAP_FILE: &str = "application/octet-stream";

/// The map analysis's options a map measurement takes as query parameters (its clear
/// aperture is the part's).
const MAP_QUERY_FIELDS: &[&str] = &[
    "pixel_mm",
    "alignment",
    "remove_power",
    "zernike",
    "psd",
    "fringe_wavelength_nm",
];

#[utoipa::path(get, path = "/v1/measurements/{id}", tag = "records", operation_id = "getMeasurement", summary = "A stored measurement",
    params(("id" = String, Path, description = "The measurement's id")), responses((status = 200, description = "The record", body = MeasurementDto,
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"), RecordReadProblems))]
/// `GET /v1/measurements/{id}`
pub async fn measurement(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let measured = parts::measurement(store(&state)?, &id).await?;
    let etag = tag(
        &state,
        "measurement",
        [
            measured.measurement.stamp.id.as_str(),
            measured.completes_run.as_deref().unwrap_or(""),
            if measured.measured_before {
                "before"
            } else {
                ""
            },
            measured.fitted.as_ref().map_or("", |c| c.stamp.id.as_str()),
        ],
    );
    fetched(&headers, etag, || measurement_dto(&measured))
}

#[utoipa::path(get, path = "/v1/measurements/{id}/map", tag = "records", operation_id = "getMeasurementMap", summary = "A map measurement's file, byte for byte as uploaded, or its heights as CSV",
    params(("id" = String, Path, description = "The measurement's id")),
    responses((status = 200, description = "The file exactly as uploaded (`Accept: application/octet-stream`, the default), or the map's heights as Preston's text grid (`Accept: text/csv`: `# pixel_mm`, `# wavelength_nm` and `# unit: nm` headers, a row of comma-separated heights per line, top row first, NaN where there is no data; `/v1/maps/analysis` reads it back)",
        content((Vec<u8> = "application/octet-stream"), (String = "text/csv")),
        headers(("ETag" = String, description = "Strong validator: send as If-None-Match"))),
        (status = 304, description = "Not modified (If-None-Match matched)"),
        (status = 406, description = "Not acceptable: the formats are application/octet-stream and text/csv", content_type = "application/problem+json", body = crate::http::error::Problem),
        RecordReadProblems))]
/// `GET /v1/measurements/{id}/map`
pub async fn measurement_map(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let format = extract::negotiate(&headers, &[Format::File, Format::Csv])?;
    let (sha256, file) = parts::measurement_map(store(&state)?, &id).await?;
    let etag = tag(&state, "map", [sha256.as_str(), format.media_type()]);
    fetched_as(&headers, etag, format.media_type(), || match format {
        Format::Csv => {
            let (map, _) =
                MapSource::File(file.into()).read("map", state.compute.max_map_pixels)?;
            Ok(grid::write(&map).into_bytes())
        }
        _ => Ok(file),
    })
}

fn measurement_dto(measured: &MeasurementOutcome) -> Result<MeasurementDto, ApiError> {
    let record = &measured.measurement;
    Ok(MeasurementDto {
        id: record.stamp.id.clone(),
        part_id: record.part.clone(),
        rms_nm: record.rms_nm,
        request: document(&record.request)?,
        result: document(&record.result)?,
        map_sha256: record.map_sha256.clone(),
        completes_run_id: measured.completes_run.clone(),
        learned_calibration_id: measured.learned_calibration().map(str::to_string),
        warnings: WarningDto::all(&measured.warnings()),
        created_at: record.stamp.created_at.clone(),
        created_by: record.stamp.created_by.clone(),
        computed_by: computed_by(&record.stamp),
    })
}
