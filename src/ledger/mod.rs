//! The record use cases: what each record endpoint does between its request and the store
//! (`usecases::records` holds the records and the rules over them; `store` keeps them).
//!
//! Stored documents are JSON in the API's own vocabulary, kept as written, so a part's
//! surface, a profile's current process or a plan's dwell can be handed on exactly as a
//! caller of the compute endpoints would send them. A record request is composed from records
//! and the caller's body, then run through the [`Compute`] port, which the HTTP layer
//! implements with the compute endpoints' own parse and run: the request a record keeps is
//! one a compute endpoint accepts, and a problem with it names the request's field. Fields a
//! record supplies may not be sent too ([`without`]).
//!
//! A write is one transaction ([`Write::commit`]) holding its records and, when the caller
//! sent an Idempotency-Key, the claim on it (status, Location and the record's id), so a
//! retry gets the first answer — the record rendered again as it showed it — and never a
//! second record.

mod answers;
pub mod cycles;

pub use answers::{PartBody, ProfileBody};
pub mod parts;
pub mod profiles;
mod write;

use std::fmt;
use std::future::Future;

use serde_json::{Map, Value};

use crate::usecases::records::RecordsError;

pub use write::{Answer, Write};

/// A JSON object: a request body or a stored request.
pub type Document = Map<String, Value>;

/// Why a record use case refused or failed, beside the problems of the computations it runs.
#[derive(Debug, Clone, PartialEq)]
pub enum LedgerError {
    /// A top-level member of the request the caller must change, and why.
    Invalid { field: String, detail: String },
    /// A record the request names does not exist.
    NotFound { what: &'static str, id: String },
    /// A unique name is taken: what the caller is told.
    Taken(String),
    /// The store does not answer.
    Store(RecordsError),
    /// A stored record breaks this layer's own invariants (a document that does not parse, a
    /// cycle's plan gone): a defect, never the caller's.
    Broken(String),
}

impl LedgerError {
    pub fn invalid(field: impl Into<String>, detail: impl Into<String>) -> Self {
        LedgerError::Invalid {
            field: field.into(),
            detail: detail.into(),
        }
    }
}

impl From<RecordsError> for LedgerError {
    fn from(error: RecordsError) -> Self {
        LedgerError::Store(error)
    }
}

/// The computations a record request runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Computation {
    /// A part's measurement: the probe trace fitted to the part's design.
    MeasurementFit,
    /// A profile's calibration, or one learned from a completed cycle.
    Calibration,
    /// A part's plan: its dwell over radius.
    Optimize,
    /// A part's polar plan: its dwell and C's speed law, correcting its measured map.
    MapOptimize,
    /// A part's measurement by an interferometer map: the map analysed on the part.
    MapAnalysis,
    /// A cycle measured by maps before and after: the removal between them.
    MapDifference,
}

/// A map file a computation reads: the request's member it fills (`map`, `before`, `after`)
/// and the file's bytes as the instrument wrote them.
pub type MapFile<'a> = (&'static str, &'a [u8]);

/// Whose setting (process, surface, tool, clear aperture) is checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SettingOwner {
    /// A process profile's, as created.
    Profile,
    /// A part's: its profile's current process at the part's `workpiece_radius_mm`.
    Part,
}

/// The computations, as the HTTP layer runs them.
pub trait Compute: Sync {
    /// A computation's problem, which also renders this layer's errors.
    type Problem: From<LedgerError> + From<RecordsError> + fmt::Display + Send;

    /// Runs `what` on `request` (a compute endpoint's request); its answer as that endpoint's
    /// JSON body.
    fn compute(
        &self,
        what: Computation,
        request: &Document,
    ) -> impl Future<Output = Result<Value, Self::Problem>> + Send;

    /// As [`Self::compute`], with map files beside the request (each member of `files` is
    /// the request's member it fills).
    fn compute_with_maps(
        &self,
        what: Computation,
        request: &Document,
        files: &[MapFile<'_>],
    ) -> impl Future<Output = Result<Value, Self::Problem>> + Send;

    /// Whether `problem` refuses the request itself (a 4xx: the input cannot be computed), as
    /// against a computation that could not run now (overload, a timeout, an internal error).
    fn refuses(problem: &Self::Problem) -> bool;

    /// Checks a setting as every compute endpoint would, without computing.
    fn check_setting(&self, setting: &Document, of: SettingOwner) -> Result<(), Self::Problem>;
}

/// A stored document (JSON text this layer wrote).
pub fn document(text: &str) -> Result<Value, LedgerError> {
    serde_json::from_str(text).map_err(|e| LedgerError::Broken(format!("a stored record: {e}")))
}

/// A stored document (a record's body as written) read as `T`; `what` names it in the error.
pub fn stored<T: serde::de::DeserializeOwned>(text: &str, what: &str) -> Result<T, LedgerError> {
    answers::read(&document(text)?, what)
}

/// A record the request names, or 404.
fn found<T>(record: Option<T>, what: &'static str, id: &str) -> Result<T, LedgerError> {
    record.ok_or_else(|| LedgerError::NotFound {
        what,
        id: id.to_string(),
    })
}

/// A request body that must not name `fields` (the records supply them: each with where from).
/// Its other members stay as sent, nulls included, so the compute endpoint that parses the
/// composed request refuses a member it does not know (`{"": null}` too).
fn without(body: Document, fields: &[(&str, &str)]) -> Result<Document, LedgerError> {
    for (field, from) in fields {
        if body.contains_key(*field) {
            return Err(LedgerError::invalid(
                *field,
                format!("`{field}` comes from {from}: leave it out"),
            ));
        }
    }
    Ok(body)
}

/// `field` of `document` is absent or null (a null member means "not given").
fn absent(document: &Document, field: &str) -> bool {
    document.get(field).is_none_or(Value::is_null)
}

/// Copies `fields` of `from` that are present and not null into `into` where it has none (or
/// null).
fn fill(into: &mut Document, from: &Value, fields: &[&str]) {
    for field in fields {
        if let Some(value) = from.get(*field).filter(|v| !v.is_null()) {
            if absent(into, field) {
                into.insert((*field).to_string(), value.clone());
            }
        }
    }
}
