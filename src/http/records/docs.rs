//! What the OpenAPI document says of the record operations beyond their wire types: the
//! request bodies that are another endpoint's request less the fields a record supplies (that
//! request's schema less those properties) and the problems they answer (`contract` adds the
//! links between them).

use utoipa::openapi::schema::{AllOfBuilder, ObjectBuilder};
use utoipa::openapi::{Ref, RefOr, Schema};
use utoipa::{PartialSchema, ToSchema};

use super::dto::{
    CalibrationRecordDto, HistoryDto, MeasurementDto, PartDto, PartListDto, PartRequest, PlanDto,
    ProcessProfileDto, ProcessProfileListDto, ProcessProfileRequest, RunRecordDto, RunRequest,
};
use crate::http::calibration::CalibrationRequest;
use crate::http::maps::optimize::{MapOptimizeRequest, MapOptimizeResponse, PolarMachineDto};
use crate::http::maps::program::{MapProgramRequest, MapProgramResponse};
use crate::http::maps::MapAnalysisRequest;
use crate::http::measurement_fit::MeasurementFitRequest;
use crate::http::openapi::any_of;
use crate::http::optimize::{OptimizeRequest, OptimizeResponse};
use crate::http::program::{ProgramRequest, ProgramResponse};

/// A request that is `Base`'s less the properties a record supplies.
macro_rules! less {
    ($name:ident, $base:ty, [$($field:literal),*], [$($optional:literal),*], $doc:literal) => {
        less!($name, $base, [$($field),*], [$($optional),*], [], $doc);
    };
    ($name:ident, $base:ty, [$($field:literal),*], [$($optional:literal),*], [$($required:literal),*], $doc:literal) => {
        #[doc = $doc]
        pub struct $name;

        impl PartialSchema for $name {
            fn schema() -> RefOr<Schema> {
                without(
                    <$base as PartialSchema>::schema(),
                    &[$($field),*],
                    &[$($optional),*],
                    &[$($required),*],
                    $doc,
                )
            }
        }

        impl ToSchema for $name {
            fn schemas(schemas: &mut Vec<(String, RefOr<Schema>)>) {
                <$base as ToSchema>::schemas(schemas);
            }
        }
    };
}

less!(
    ProfileCalibrationRequest,
    CalibrationRequest,
    ["process"],
    [],
    "A `/v1/calibration` request without `process` (the profile's current process is the \
     nominal); `surface` and `tool` default to the profile's."
);
less!(
    PartMeasurementRequest,
    MeasurementFitRequest,
    ["surface"],
    [],
    "A `/v1/measurement/fit` request without `surface` (the part's); `clear_aperture` \
     defaults to the part's. Also as text/csv with the other fields as query parameters; or \
     an interferometer map's file as application/octet-stream (any format \
     `/v1/maps/analysis` reads), with that endpoint's options but `clear_aperture` as query \
     parameters: the map is analysed on the part's clear aperture (a circle, an annulus with \
     an inner radius), its file kept byte for byte (`GET /v1/measurements/{id}/map`)."
);
less!(
    PartMapMeasurementRequest,
    MapAnalysisRequest,
    ["map"],
    [],
    "A map measurement's `/v1/maps/analysis` request as run: its options, less the file \
     (kept as a blob: `GET /v1/measurements/{id}/map`)."
);
less!(
    PartRadialPlanRequest,
    OptimizeRequest,
    ["process", "surface"],
    ["target"],
    "A radial plan: an `/v1/optimize` request without `process` (the profile's current one, at \
     the part's workpiece radius) and `surface` (the part's); `target` defaults to the \
     correction of the part's latest measurement, `clear_aperture` to the part's."
);
less!(
    PolarPlanBody,
    MapOptimizeRequest,
    ["process", "surface"],
    ["map"],
    ["machine"],
    "A polar plan (`machine.kinematics: polar`, required here): a `/v1/maps/optimize` request \
     without `process` (the profile's current one, at the part's workpiece radius) and \
     `surface` (the part's); `map` defaults to the part's latest measurement's map file, with \
     the `pixel_mm` and `alignment` it was analysed with; `clear_aperture` to the part's."
);

/// [`PolarPlanBody`] with `machine.kinematics` required: what tells a polar plan's body from a
/// radial one's.
pub struct PartPolarPlanRequest;

impl PartialSchema for PartPolarPlanRequest {
    fn schema() -> RefOr<Schema> {
        let mut schema = PolarPlanBody::schema();
        if let RefOr::T(Schema::Object(object)) = &mut schema {
            let machine = AllOfBuilder::new()
                .item(Ref::from_schema_name(PolarMachineDto::name()))
                .item(ObjectBuilder::new().required("kinematics"))
                .description(Some(
                    "The machine; `kinematics: polar` makes the plan a polar one.",
                ));
            object.properties.insert("machine".into(), machine.into());
        }
        schema
    }
}

impl ToSchema for PartPolarPlanRequest {
    fn schemas(schemas: &mut Vec<(String, RefOr<Schema>)>) {
        <MapOptimizeRequest as ToSchema>::schemas(schemas);
    }
}
less!(
    PlanRadialProgramRequest,
    ProgramRequest,
    ["process", "surface", "dwell"],
    [],
    "A radial plan's: a `/v1/program` request without `process`, `surface` and `dwell` (the \
     plan's); `machine` defaults to the plan's."
);
less!(
    PlanPolarProgramRequest,
    MapProgramRequest,
    ["process", "surface", "dwell", "c_law"],
    [],
    "A polar plan's: a `/v1/maps/program` request without `process`, `surface`, `dwell` and \
     `c_law` (the plan's); `machine` defaults to the plan's."
);
any_of!(
    PartPlanRequest,
    [PartRadialPlanRequest, PartPolarPlanRequest],
    "A radial plan's request, or a polar plan's (`machine.kinematics: polar`)."
);
any_of!(
    PlanProgramRequest,
    [PlanRadialProgramRequest, PlanPolarProgramRequest],
    "The program's options: as `/v1/program` takes them for a radial plan, as \
     `/v1/maps/program` for a polar plan."
);
less!(
    PolarPlanRequestAsRun,
    MapOptimizeRequest,
    [],
    ["map"],
    "A polar plan's `/v1/maps/optimize` request as run; without `map` when the records supplied \
     it: the file of the plan's measurement (`GET /v1/measurements/{id}/map`)."
);
any_of!(
    PlanRequestAsRun,
    [OptimizeRequest, PolarPlanRequestAsRun],
    "A radial plan's `/v1/optimize` request, or a polar plan's `/v1/maps/optimize` request."
);
any_of!(
    PlanResult,
    [OptimizeResponse, MapOptimizeResponse],
    "A radial plan's `/v1/optimize` answer, or a polar plan's `/v1/maps/optimize` answer."
);
any_of!(
    PlanProgramResponse,
    [ProgramResponse, MapProgramResponse],
    "As `/v1/program` answers a radial plan, as `/v1/maps/program` a polar plan."
);

/// `schema` less the properties `fields`, with `optional` no longer required and `required`
/// required.
fn without(
    schema: RefOr<Schema>,
    fields: &[&str],
    optional: &[&str],
    required: &[&str],
    doc: &str,
) -> RefOr<Schema> {
    match schema {
        RefOr::T(Schema::Object(mut object)) => {
            for field in fields {
                object.properties.shift_remove(*field);
            }
            object
                .required
                .retain(|r| !fields.contains(&r.as_str()) && !optional.contains(&r.as_str()));
            object
                .required
                .extend(required.iter().map(|r| r.to_string()));
            object.description = Some(doc.to_string());
            RefOr::T(Schema::Object(object))
        }
        other => other,
    }
}

/// The schemas the record operations refer to (for the OpenAPI document).
pub fn schemas(schemas: &mut Vec<(String, RefOr<Schema>)>) {
    fn add<T: ToSchema>(schemas: &mut Vec<(String, RefOr<Schema>)>) {
        schemas.push((T::name().into_owned(), T::schema()));
        T::schemas(schemas);
    }
    add::<ProcessProfileRequest>(schemas);
    add::<ProcessProfileDto>(schemas);
    add::<ProcessProfileListDto>(schemas);
    add::<CalibrationRecordDto>(schemas);
    add::<PartRequest>(schemas);
    add::<PartDto>(schemas);
    add::<PartListDto>(schemas);
    add::<MeasurementDto>(schemas);
    add::<PlanDto>(schemas);
    add::<RunRequest>(schemas);
    add::<RunRecordDto>(schemas);
    add::<HistoryDto>(schemas);
    add::<ProfileCalibrationRequest>(schemas);
    add::<PartMeasurementRequest>(schemas);
    add::<PartMapMeasurementRequest>(schemas);
    add::<PartPlanRequest>(schemas);
    add::<PlanProgramRequest>(schemas);
    add::<PlanRequestAsRun>(schemas);
    add::<PlanResult>(schemas);
    add::<PlanProgramResponse>(schemas);
}

/// What a record write may answer besides 201.
#[derive(utoipa::IntoResponses)]
#[allow(dead_code)]
pub enum RecordWriteProblems {
    /// Malformed JSON
    #[response(status = 400, content_type = "application/problem+json")]
    Malformed(crate::http::error::Problem),
    /// No valid API key (only when the service has keys configured)
    #[response(status = 401, content_type = "application/problem+json")]
    Unauthorized(crate::http::error::Problem),
    /// The API key is read-only
    #[response(status = 403, content_type = "application/problem+json")]
    Forbidden(crate::http::error::Problem),
    /// The record the path names does not exist
    #[response(status = 404, content_type = "application/problem+json")]
    NotFound(crate::http::error::Problem),
    /// Body too large
    #[response(status = 413, content_type = "application/problem+json")]
    TooLarge(crate::http::error::Problem),
    /// A unique name is taken
    #[response(status = 409, content_type = "application/problem+json")]
    Conflict(crate::http::error::Problem),
    /// Invalid input, naming the field (an Idempotency-Key reused with another request too)
    #[response(status = 422, content_type = "application/problem+json")]
    Invalid(crate::http::error::Problem),
    /// The client's rate limit is spent
    #[response(status = 429, content_type = "application/problem+json")]
    RateLimited(crate::http::error::Problem),
    /// The records store is unavailable, or the service is overloaded; retry after Retry-After
    #[response(status = 503, content_type = "application/problem+json")]
    Unavailable(crate::http::error::Problem),
}

/// What a record read may answer besides 200.
#[derive(utoipa::IntoResponses)]
#[allow(dead_code)]
pub enum RecordReadProblems {
    /// No valid API key (only when the service has keys configured)
    #[response(status = 401, content_type = "application/problem+json")]
    Unauthorized(crate::http::error::Problem),
    /// No such record
    #[response(status = 404, content_type = "application/problem+json")]
    NotFound(crate::http::error::Problem),
    /// Invalid query or body, naming the field
    #[response(status = 422, content_type = "application/problem+json")]
    Invalid(crate::http::error::Problem),
    /// The client's rate limit is spent
    #[response(status = 429, content_type = "application/problem+json")]
    RateLimited(crate::http::error::Problem),
    /// The records store is unavailable, or the service is overloaded; retry after Retry-After
    #[response(status = 503, content_type = "application/problem+json")]
    Unavailable(crate::http::error::Problem),
}
