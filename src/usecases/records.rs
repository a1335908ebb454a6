//! What Preston remembers: process profiles and their calibrations, parts, and each part's
//! correction cycles (measurement → plan → run → measurement). This module holds the records,
//! the [`Records`] trait a store implements (the use cases never see SQL), and the two rules
//! over them:
//!
//! **A cycle** is a run: its plan's measurement is the measurement *before* (the part's latest
//! when the plan was made), and the first measurement written after the run is the one *after*,
//! unless another run came between them (then the earlier run has no after-measurement of its
//! own). Its figures: RMS before, the plan's predicted RMS after, the RMS after, the convergence
//! ratio RMS before / RMS after, and the removal ratio, actual / predicted removal: the run's
//! dwell fitted to the measured removal (before − after, a free piston) as a calibration of the
//! Preston coefficient, K_fit / K_plan with its standard error.
//!
//! **The profile's current removal rate.** A profile starts at its own process. A calibration
//! asked for (ring tests, `learned = false`) replaces the process. Each completed cycle adds a
//! calibration learned from production; the current Preston coefficient is the inverse-variance
//! weighted mean of the learned coefficients written since the latest calibration asked for,
//!
//!   K = Σ wᵢ Kᵢ / Σ wᵢ,  wᵢ = 1/σᵢ²,  σ_K = (Σ wᵢ)^(−1/2),
//!
//! (equal weights when a standard error is missing), and that calibration's (or the profile's)
//! K when there is none. A learned K more than [`PLAUSIBLE_FACTOR`] times above or below that
//! base K is kept (the cycle's history shows it) but not learned from: such a cycle did not run
//! as planned (a run that never touched the part, swapped measurements, another part's trace),
//! and one such cycle would otherwise make every later plan wrong by the same factor. Production runs are what a plan must predict, so they override a ring
//! test's K rather than being averaged with it; a new ring test (a new pad, a dressed tool)
//! starts the learning again.

use super::Warning;

/// Who wrote a record and when: its id (a UUIDv7, or the name of a process profile), an RFC 3339
/// UTC timestamp, the API key's name (empty without keys) and which code wrote it.
#[derive(Debug, Clone, PartialEq)]
pub struct Stamp {
    pub id: String,
    pub created_at: String,
    pub created_by: String,
    /// Which code wrote it (version, git revision, records schema); empty for a record
    /// written before that was kept.
    pub computed_by: String,
}

/// Bodies are documents in the API's own vocabulary (JSON text written and read by the HTTP
/// layer); the store keeps them as they are.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileRecord {
    pub stamp: Stamp,
    pub body: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationRecord {
    pub stamp: Stamp,
    pub profile: String,
    pub request: String,
    pub result: String,
    /// The calibrated process.
    pub process: String,
    pub preston_coefficient_m2_per_n: f64,
    pub standard_error_m2_per_n: Option<f64>,
    /// The production run it was learned from; `None` for a calibration asked for.
    pub run: Option<String>,
}

/// A learned K teaches the profile only when it is this many standard errors above 0 (about
/// 95 % confidence that the run removed something).
pub const SIGNIFICANT_STANDARD_ERRORS: f64 = 2.0;

impl CalibrationRecord {
    /// Fitted to a production run's removal (not asked for: a ring test).
    pub fn from_run(&self) -> bool {
        self.run.is_some()
    }

    /// Fitted to a production run and significant: the profile learns from it.
    pub fn learned(&self) -> bool {
        self.from_run() && self.significant()
    }

    /// Its K is determined: a standard error (finite, > 0) and K at least
    /// [`SIGNIFICANT_STANDARD_ERRORS`] of them above 0. A cycle's calibration that is not is
    /// kept (the cycle's evidence, shown in its history with a warning) but teaches nothing.
    pub fn significant(&self) -> bool {
        let k = self.preston_coefficient_m2_per_n;
        self.standard_error_m2_per_n
            .is_some_and(|se| se.is_finite() && se > 0.0 && k >= SIGNIFICANT_STANDARD_ERRORS * se)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct PartRecord {
    pub stamp: Stamp,
    pub name: String,
    pub process_profile: String,
    pub body: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementRecord {
    pub stamp: Stamp,
    pub part: String,
    pub request: String,
    pub result: String,
    pub rms_nm: f64,
    /// A map's file, as the instrument wrote it: the blob's SHA-256 (none for a probe trace).
    pub map_sha256: Option<String>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PlanRecord {
    pub stamp: Stamp,
    pub part: String,
    pub measurement: Option<String>,
    pub request: String,
    pub result: String,
    pub predicted_rms_after_nm: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct RunRecord {
    pub stamp: Stamp,
    pub part: String,
    pub plan: String,
    pub started_at: String,
    pub finished_at: String,
    pub machine: Option<String>,
    pub notes: Option<String>,
}

/// A measurement without its bodies: what a part's cycles need (a trace's fit is ~100 kB; a
/// part with 100 cycles would read megabytes for a few numbers).
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementHead {
    pub stamp: Stamp,
    pub rms_nm: f64,
}

/// A plan without its bodies.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanHead {
    pub stamp: Stamp,
    pub measurement: Option<String>,
    pub predicted_rms_after_nm: f64,
}

/// A record to write.
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    Profile(ProfileRecord),
    Calibration(CalibrationRecord),
    Part(PartRecord),
    Measurement(MeasurementRecord),
    Plan(PlanRecord),
    Run(RunRecord),
}

/// The answer a POST gave, kept under its Idempotency-Key.
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    pub status: u16,
    pub location: String,
    /// The record the write created (its id): a replay renders it as the first answer did.
    pub record: String,
    /// The first answer's body, for a claim written before claims named their record (empty
    /// since: nothing kept twice).
    pub body: String,
}

/// An Idempotency-Key claimed by a write: its owner (the API key's name), the key, the
/// request's fingerprint and the answer to give again.
#[derive(Debug, Clone, PartialEq)]
pub struct Claim {
    pub owner: String,
    pub key: String,
    pub fingerprint: String,
    pub answer: Replay,
}

/// What became of a write.
#[derive(Debug, Clone, PartialEq)]
pub enum Written {
    /// Committed, records and claim together.
    Committed,
    /// The key was claimed meanwhile by the same request: its first answer.
    Replayed(Replay),
    /// The key was claimed by another request.
    KeyReused,
    /// A unique name is taken (a profile's name, a part's serial): nothing was written.
    Taken,
}

/// Why the store could not answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordsError {
    #[error("the records store is unavailable: {0}")]
    Unavailable(String),
}

/// A page of parts, in the order they were created.
#[derive(Debug, Clone, PartialEq)]
pub struct PartsPage {
    pub items: Vec<PartRecord>,
    /// The last id of a full page: the next page starts after it.
    pub next_cursor: Option<String>,
}

/// What the use cases need of a store. Every write is one transaction, answered only once
/// committed; reads see every committed write.
#[allow(async_fn_in_trait)]
pub trait Records {
    /// Writes the records and the claim (when given) in one transaction.
    async fn write(
        &self,
        records: &[Record],
        claim: Option<&Claim>,
    ) -> Result<Written, RecordsError>;
    /// The fingerprint and answer under an Idempotency-Key.
    async fn claimed(
        &self,
        owner: &str,
        key: &str,
    ) -> Result<Option<(String, Replay)>, RecordsError>;
    async fn profile(&self, name: &str) -> Result<Option<ProfileRecord>, RecordsError>;
    async fn profiles(&self) -> Result<Vec<ProfileRecord>, RecordsError>;
    /// A profile's calibrations, oldest first.
    async fn calibrations(&self, profile: &str) -> Result<Vec<CalibrationRecord>, RecordsError>;
    async fn calibration(&self, id: &str) -> Result<Option<CalibrationRecord>, RecordsError>;
    async fn part(&self, id: &str) -> Result<Option<PartRecord>, RecordsError>;
    /// Parts after `cursor` (an id), at most `limit`, only the one named `name` when given.
    async fn parts(
        &self,
        cursor: Option<&str>,
        limit: usize,
        name: Option<&str>,
    ) -> Result<PartsPage, RecordsError>;
    /// A part's measurements, plans (without their bodies: fetch one with `measurement` or
    /// `plan`) and runs, each oldest first.
    async fn measurements(&self, part: &str) -> Result<Vec<MeasurementHead>, RecordsError>;
    async fn measurement(&self, id: &str) -> Result<Option<MeasurementRecord>, RecordsError>;
    async fn plans(&self, part: &str) -> Result<Vec<PlanHead>, RecordsError>;
    async fn plan(&self, id: &str) -> Result<Option<PlanRecord>, RecordsError>;
    async fn runs(&self, part: &str) -> Result<Vec<RunRecord>, RecordsError>;
    async fn run(&self, id: &str) -> Result<Option<RunRecord>, RecordsError>;
}

/// A profile's current Preston coefficient, and where it comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct CurrentRate<'a> {
    /// The latest calibration asked for, whose process the profile now runs (else its own).
    pub base: Option<&'a CalibrationRecord>,
    /// The learned calibrations combined into `preston_coefficient_m2_per_n`.
    pub learned: Vec<&'a CalibrationRecord>,
    /// `None`: the base's (or the profile's) coefficient stands.
    pub preston_coefficient_m2_per_n: Option<f64>,
    pub standard_error_m2_per_n: Option<f64>,
}

/// How far a learned K may be from the base K and still be learned from (either way).
pub const PLAUSIBLE_FACTOR: f64 = 5.0;

/// The rule in the module docs, over a profile's calibrations (oldest first) and the profile's
/// own Preston coefficient.
pub fn current_rate(calibrations: &[CalibrationRecord], profile_k: f64) -> CurrentRate<'_> {
    let base_index = calibrations.iter().rposition(|c| !c.from_run());
    let base = base_index.map(|i| &calibrations[i]);
    let base_k = base.map_or(profile_k, |b| b.preston_coefficient_m2_per_n);
    let plausible = |k: f64| k / base_k <= PLAUSIBLE_FACTOR && base_k / k <= PLAUSIBLE_FACTOR;
    let learned: Vec<&CalibrationRecord> = calibrations[base_index.map_or(0, |i| i + 1)..]
        .iter()
        .filter(|c| c.learned() && plausible(c.preston_coefficient_m2_per_n))
        .collect();
    if learned.is_empty() {
        return CurrentRate {
            base,
            learned,
            preston_coefficient_m2_per_n: base.map(|b| b.preston_coefficient_m2_per_n),
            standard_error_m2_per_n: base.and_then(|b| b.standard_error_m2_per_n),
        };
    }
    let weighted = learned
        .iter()
        .all(|c| c.standard_error_m2_per_n.is_some_and(|s| s > 0.0));
    let weight = |c: &CalibrationRecord| match c.standard_error_m2_per_n {
        Some(s) if weighted => 1.0 / (s * s),
        _ => 1.0,
    };
    let total: f64 = learned.iter().map(|c| weight(c)).sum();
    let mean = learned
        .iter()
        .map(|c| weight(c) * c.preston_coefficient_m2_per_n)
        .sum::<f64>()
        / total;
    CurrentRate {
        base,
        preston_coefficient_m2_per_n: Some(mean),
        standard_error_m2_per_n: weighted.then(|| total.powf(-0.5)),
        learned,
    }
}

/// One correction cycle (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle<'a> {
    pub before: Option<&'a MeasurementHead>,
    pub plan: &'a PlanHead,
    pub run: &'a RunRecord,
    pub after: Option<&'a MeasurementHead>,
    /// The calibration fitted to this run's removal, once the cycle is complete (it teaches
    /// the profile only when [`CalibrationRecord::learned`]).
    pub learned: Option<&'a CalibrationRecord>,
}

impl Cycle<'_> {
    /// What the caller should know: a complete cycle that taught nothing.
    pub fn warnings(&self) -> Vec<Warning> {
        lesson_warnings(self.before.is_some() && self.after.is_some(), self.learned)
    }

    pub fn rms_before_nm(&self) -> Option<f64> {
        self.before.map(|m| m.rms_nm)
    }

    pub fn rms_after_nm(&self) -> Option<f64> {
        self.after.map(|m| m.rms_nm)
    }

    /// RMS before / RMS after (`None` until measured after, or when the after RMS is 0).
    pub fn convergence_ratio(&self) -> Option<f64> {
        match (self.rms_before_nm(), self.rms_after_nm()) {
            (Some(b), Some(a)) if a > 0.0 => Some(b / a),
            _ => None,
        }
    }
}

/// A part's cycles, oldest first, from its records (each oldest first) and its profile's
/// calibrations.
pub fn cycles<'a>(
    measurements: &'a [MeasurementHead],
    plans: &'a [PlanHead],
    runs: &'a [RunRecord],
    calibrations: &'a [CalibrationRecord],
) -> Vec<Cycle<'a>> {
    runs.iter()
        .enumerate()
        .filter_map(|(i, run)| {
            let plan = plans.iter().find(|p| p.stamp.id == run.plan)?;
            let before = plan
                .measurement
                .as_ref()
                .and_then(|id| measurements.iter().find(|m| &m.stamp.id == id));
            Some(Cycle {
                before,
                plan,
                run,
                after: after_measurement(measurements, runs, i),
                learned: calibrations
                    .iter()
                    .find(|c| c.run.as_deref() == Some(&run.stamp.id)),
            })
        })
        .collect()
}

/// The first measurement after `runs[index]`, unless another run came first.
fn after_measurement<'a>(
    measurements: &'a [MeasurementHead],
    runs: &[RunRecord],
    index: usize,
) -> Option<&'a MeasurementHead> {
    let run = &runs[index].stamp.id;
    let after = measurements.iter().find(|m| &m.stamp.id > run)?;
    let next_run = runs.get(index + 1).map(|r| &r.stamp.id);
    match next_run {
        Some(next) if next < &after.stamp.id => None,
        _ => Some(after),
    }
}

/// What a complete cycle (`complete`: measured before and after) taught, as warnings: its
/// calibration (`fitted`) not significant, or none fitted at all.
pub fn lesson_warnings(complete: bool, fitted: Option<&CalibrationRecord>) -> Vec<Warning> {
    match fitted {
        _ if !complete => Vec::new(),
        Some(c) if c.significant() => Vec::new(),
        Some(c) => vec![Warning::RemovalNotSignificant {
            fitted: Some((c.preston_coefficient_m2_per_n, c.standard_error_m2_per_n)),
        }],
        None => vec![Warning::RemovalNotSignificant { fitted: None }],
    }
}

/// The run a new measurement completes: the part's latest run, when no measurement was written
/// after it yet.
pub fn run_completed_by_new_measurement<'a>(
    measurements: &[MeasurementHead],
    plans: &'a [PlanHead],
    runs: &'a [RunRecord],
) -> Option<(&'a RunRecord, &'a PlanHead)> {
    let run = runs.last()?;
    if measurements.iter().any(|m| m.stamp.id > run.stamp.id) {
        return None;
    }
    let plan = plans.iter().find(|p| p.stamp.id == run.plan)?;
    Some((run, plan))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamp(id: &str) -> Stamp {
        Stamp {
            id: id.into(),
            created_at: "2026-11-25T00:00:00Z".into(),
            created_by: String::new(),
            computed_by: String::new(),
        }
    }

    fn calibration(id: &str, k: f64, se: Option<f64>, run: Option<&str>) -> CalibrationRecord {
        CalibrationRecord {
            stamp: stamp(id),
            profile: "p".into(),
            request: "{}".into(),
            result: "{}".into(),
            process: "{}".into(),
            preston_coefficient_m2_per_n: k,
            standard_error_m2_per_n: se,
            run: run.map(str::to_string),
        }
    }

    #[test]
    fn the_current_rate_is_the_weighted_mean_of_what_was_learned_since_the_last_ring_test() {
        assert_eq!(current_rate(&[], 1e-13).preston_coefficient_m2_per_n, None);
        let ring = calibration("1", 1.3e-13, Some(1e-16), None);
        let first = calibration("2", 1.0e-13, Some(2e-15), Some("r1"));
        let second = calibration("3", 1.2e-13, Some(1e-15), Some("r2"));
        let only_ring = [ring.clone()];
        assert_eq!(
            current_rate(&only_ring, 1e-13).preston_coefficient_m2_per_n,
            Some(1.3e-13)
        );
        let all = [first.clone(), ring.clone(), second.clone()];
        // The learned value before the ring test is forgotten; one learned after it rules.
        let rate = current_rate(&all, 1e-13);
        assert_eq!(rate.base, Some(&ring));
        assert_eq!(rate.preston_coefficient_m2_per_n, Some(1.2e-13));
        assert_eq!(rate.standard_error_m2_per_n, Some(1e-15));
        // A cycle that removed nothing (K 1/100 of the base) is not learned from.
        let nothing = calibration("4", 1.3e-15, Some(1e-17), Some("r3"));
        let learned = [ring, first, second, nothing];
        let rate = current_rate(&learned, 1e-13);
        assert_eq!(rate.learned.len(), 2);
        // Weights 1/4 and 1 (in units of 1e30): (0.25·1.0 + 1·1.2)/1.25 = 1.16.
        let k = rate.preston_coefficient_m2_per_n.unwrap();
        assert!((k - 1.16e-13).abs() < 1e-26, "{k}");
        let se = rate.standard_error_m2_per_n.unwrap();
        assert!((se - 1e-15 / 1.25f64.sqrt()).abs() < 1e-28, "{se}");
        // A cycle's calibration under 2 standard errors, or without one, is kept but teaches
        // nothing; it does not end the learning either (it is no ring test).
        for weak in [
            calibration("5", 1.9e-15, Some(1e-15), Some("r4")),
            calibration("5", 2e-13, None, Some("r4")),
            calibration("5", 2e-13, Some(0.0), Some("r4")),
            calibration("5", -1e-13, Some(1e-15), Some("r4")),
        ] {
            assert!(weak.from_run() && !weak.significant() && !weak.learned());
            let with = [
                learned[0].clone(),
                learned[1].clone(),
                learned[2].clone(),
                weak,
            ];
            let rate = current_rate(&with, 1e-13);
            assert_eq!(rate.learned.len(), 2);
            assert_eq!(rate.preston_coefficient_m2_per_n, Some(k));
        }
        let exactly_two = calibration("6", 2e-15, Some(1e-15), Some("r5"));
        assert!(exactly_two.significant());
    }

    /// A complete cycle warns when it taught nothing, with the fit's K and standard error
    /// when one fitted; a cycle not measured before says nothing.
    #[test]
    fn a_cycle_that_taught_nothing_says_why() {
        let weak = calibration("1", 1e-15, Some(1e-15), Some("r1"));
        let strong = calibration("2", 1e-13, Some(1e-15), Some("r2"));
        assert_eq!(lesson_warnings(true, Some(&strong)), vec![]);
        assert_eq!(lesson_warnings(false, None), vec![]);
        assert_eq!(
            lesson_warnings(true, Some(&weak)),
            vec![Warning::RemovalNotSignificant {
                fitted: Some((1e-15, Some(1e-15)))
            }]
        );
        let none = lesson_warnings(true, None);
        assert_eq!(none, vec![Warning::RemovalNotSignificant { fitted: None }]);
        assert!(
            none[0].to_string().contains("no K above 0 fits it"),
            "{}",
            none[0]
        );
    }
}
