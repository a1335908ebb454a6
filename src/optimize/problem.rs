//! What the optimizer is asked besides the target: constraints and objective weights, their
//! validation, and the check that a plan keeps every constraint.

use super::kinematics::Floor;
use super::target::MeasuredProfileError;
use crate::machine::{Drive, LimitKind};

/// Default smoothing weight λ (see the module docs of [`super`]). Chosen on the paper's cases:
/// it removes neighbour-to-neighbour oscillation while costing the uniform 100 nm plan of
/// experiment 1 well under 0.1 % of nonuniformity (tests/it/optimize_paper.rs shows both effects).
pub const DEFAULT_SMOOTHING: f64 = 1e-6;
/// Default time weight μ: the mean depth comes out low by about μ of the target.
pub const DEFAULT_TIME_WEIGHT: f64 = 2e-6;

/// A constraint of the plan, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Constraint {
    MinDwell,
    MaxDwell,
    MaxTotalTime,
    MaxFeed,
    MaxDwellChange,
}

impl Constraint {
    pub fn name(self) -> &'static str {
        match self {
            Constraint::MinDwell => "min_dwell_s",
            Constraint::MaxDwell => "max_dwell_s",
            Constraint::MaxTotalTime => "max_total_time_s",
            Constraint::MaxFeed => "max_feed_mm_per_min",
            Constraint::MaxDwellChange => "max_dwell_change_s",
        }
    }
}

/// A limit a plan keeps: one of its constraints, or a machine axis's velocity or
/// acceleration limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    Constraint(Constraint),
    Machine(Drive, LimitKind),
}

impl Bound {
    /// It in words: the constraint's name, or the machine limit described.
    pub fn describe(self) -> String {
        match self {
            Bound::Constraint(c) => c.name().to_string(),
            Bound::Machine(drive, limit) => limit.describe(drive),
        }
    }
}

/// A weight of the objective, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Weight {
    Smoothing,
    TimeWeight,
}

impl Weight {
    pub fn name(self) -> &'static str {
        match self {
            Weight::Smoothing => "smoothing",
            Weight::TimeWeight => "time_weight",
        }
    }
}

/// Why an optimization was refused or did not produce a plan. Each variant says which input
/// is at fault in the optimizer's own terms; callers place it in their request.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OptimizeError {
    /// A constraint's value is out of its domain.
    #[error("{message}")]
    InvalidConstraint {
        constraint: Constraint,
        message: String,
    },
    /// An objective weight is out of its domain.
    #[error("{message}")]
    InvalidWeight { weight: Weight, message: String },
    /// The measured profile target is malformed or does not cover the clear aperture.
    #[error(transparent)]
    Profile(#[from] MeasuredProfileError),
    /// The clear aperture holds no radial sample.
    #[error("the clear aperture holds no radial sample")]
    EmptyAperture,
    /// No candidate position removes material inside the clear aperture.
    #[error("no candidate position removes material inside the clear aperture")]
    NoRemovalInAperture,
    /// The constraints cannot all hold; `fields` are those in conflict.
    #[error("{detail}")]
    Infeasible { fields: Vec<Bound>, detail: String },
    /// The solver ran out of its time budget before converging.
    #[error("the solver reached its time limit of {limit_s} s before converging")]
    TimeLimit { limit_s: f64 },
    /// The solver ran out of iterations before converging.
    #[error("the solver reached its iteration limit ({iterations}) before converging")]
    IterationLimit { iterations: u32 },
    /// The solver stopped without a trustworthy answer (ill-conditioned input).
    #[error("the solver stopped with status {status}: the problem is too badly conditioned to solve reliably")]
    Numerical { status: String },
}

/// Weights of the objective's smoothing and time terms (dimensionless, ≥ 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Objective {
    /// λ: weight of the mean squared dwell curvature over one pad radius.
    pub smoothing: f64,
    /// μ: weight of the total time relative to equal dwell.
    pub time_weight: f64,
}

impl Default for Objective {
    fn default() -> Self {
        Objective {
            smoothing: DEFAULT_SMOOTHING,
            time_weight: DEFAULT_TIME_WEIGHT,
        }
    }
}

impl Objective {
    pub fn validate(&self) -> Result<(), OptimizeError> {
        for (weight, value) in [
            (Weight::Smoothing, self.smoothing),
            (Weight::TimeWeight, self.time_weight),
        ] {
            if !(0.0..=MAX_WEIGHT).contains(&value) {
                let field = weight.name();
                return Err(OptimizeError::InvalidWeight {
                    weight,
                    message: format!("{field} must be a number in [0, {MAX_WEIGHT}]"),
                });
            }
        }
        Ok(())
    }
}

/// Limits on the plan as a caller gives them, in s and mm/min: unchecked (see
/// [`Constraints::new`]). Only `min_dwell_s` (default 0) is always present.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ConstraintsSpec {
    pub min_dwell_s: f64,
    pub max_dwell_s: Option<f64>,
    pub max_total_time_s: Option<f64>,
    pub max_feed_mm_per_min: Option<f64>,
    pub max_dwell_change_s: Option<f64>,
}

/// Limits on the plan, each checked on its own ([`Constraints::new`] is the only way to make
/// one outside the optimizer; the default has none). Conflicts between them are
/// [`super::feasibility`]'s to name.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Constraints {
    pub(super) min_dwell_s: f64,
    pub(super) max_dwell_s: Option<f64>,
    pub(super) max_total_time_s: Option<f64>,
    pub(super) max_feed_mm_per_min: Option<f64>,
    pub(super) max_dwell_change_s: Option<f64>,
}

/// Largest time any constraint may name, s (keeps the scaled problem finite).
pub const MAX_TIME_S: f64 = 1e12;
/// Feed limits accepted, mm/min.
pub const FEED_RANGE_MM_PER_MIN: (f64, f64) = (1e-6, 1e9);
/// Largest objective weight accepted.
pub const MAX_WEIGHT: f64 = 1e6;
/// Largest target depth accepted (in magnitude), nm: a metre.
pub const MAX_DEPTH_NM: f64 = 1e9;

/// Relative tolerance to which a returned plan keeps its constraints.
pub const CONSTRAINT_TOLERANCE: f64 = 1e-9;

impl Constraints {
    /// The limits of `spec`, each finite and within its range.
    pub fn new(spec: ConstraintsSpec) -> Result<Constraints, OptimizeError> {
        let constraints = Constraints {
            min_dwell_s: spec.min_dwell_s,
            max_dwell_s: spec.max_dwell_s,
            max_total_time_s: spec.max_total_time_s,
            max_feed_mm_per_min: spec.max_feed_mm_per_min,
            max_dwell_change_s: spec.max_dwell_change_s,
        };
        constraints.validate()?;
        Ok(constraints)
    }

    /// Least dwell at any position, s (0: none).
    pub fn min_dwell_s(&self) -> f64 {
        self.min_dwell_s
    }
    pub fn max_dwell_s(&self) -> Option<f64> {
        self.max_dwell_s
    }
    pub fn max_total_time_s(&self) -> Option<f64> {
        self.max_total_time_s
    }
    pub fn max_feed_mm_per_min(&self) -> Option<f64> {
        self.max_feed_mm_per_min
    }
    pub fn max_dwell_change_s(&self) -> Option<f64> {
        self.max_dwell_change_s
    }

    /// Checks each value on its own (finite, signs).
    pub(super) fn validate(&self) -> Result<(), OptimizeError> {
        // (constraint, value, smallest, largest, whether the smallest is allowed, unit)
        let checks = [
            (
                Constraint::MinDwell,
                Some(self.min_dwell_s),
                0.0,
                MAX_TIME_S,
                true,
                "s",
            ),
            (
                Constraint::MaxDwell,
                self.max_dwell_s,
                0.0,
                MAX_TIME_S,
                false,
                "s",
            ),
            (
                Constraint::MaxTotalTime,
                self.max_total_time_s,
                0.0,
                MAX_TIME_S,
                false,
                "s",
            ),
            (
                Constraint::MaxFeed,
                self.max_feed_mm_per_min,
                FEED_RANGE_MM_PER_MIN.0,
                FEED_RANGE_MM_PER_MIN.1,
                true,
                "mm/min",
            ),
            (
                Constraint::MaxDwellChange,
                self.max_dwell_change_s,
                0.0,
                MAX_TIME_S,
                true,
                "s",
            ),
        ];
        for (constraint, value, lo, hi, closed, unit) in checks {
            let Some(v) = value else { continue };
            let above = if closed { v >= lo } else { v > lo };
            if !(above && v <= hi) {
                let open = if closed { "[" } else { "(" };
                let field = constraint.name();
                return Err(OptimizeError::InvalidConstraint {
                    constraint,
                    message: format!("{field} must be a number in {open}{lo}, {hi}] {unit}"),
                });
            }
        }
        Ok(())
    }

    /// The first constraint `dwell_s` breaks by more than [`CONSTRAINT_TOLERANCE`] relative to
    /// the constraint's own size (to `scale_s` for a bound of zero). `None` when the plan
    /// keeps them all. `floors`:
    /// each position's least dwell, the feed limit's included ([`super::kinematics::floors`]).
    pub fn violation(&self, dwell_s: &[f64], floors: &[Floor], scale_s: f64) -> Option<Breach> {
        let exceeds = |excess: f64, size: f64| {
            let size = if size > 0.0 { size } else { scale_s };
            excess > CONSTRAINT_TOLERANCE * size.max(f64::MIN_POSITIVE)
        };
        for ((j, &t), floor) in dwell_s.iter().enumerate().zip(floors) {
            if !t.is_finite() || exceeds(floor.dwell_s - t, floor.dwell_s) {
                return Some(Breach::new(floor.bound, j, floor.dwell_s - t));
            }
            if let Some(hi) = self.max_dwell_s {
                if exceeds(t - hi, hi) {
                    return Some(Breach::new(Constraint::MaxDwell.into(), j, t - hi));
                }
            }
        }
        if let Some(total) = self.max_total_time_s {
            let sum: f64 = dwell_s.iter().sum();
            if exceeds(sum - total, total) {
                return Some(Breach::new(Constraint::MaxTotalTime.into(), 0, sum - total));
            }
        }
        if let Some(delta) = self.max_dwell_change_s {
            for (j, w) in dwell_s.windows(2).enumerate() {
                let change = (w[1] - w[0]).abs();
                if exceeds(change - delta, delta) {
                    return Some(Breach::new(
                        Constraint::MaxDwellChange.into(),
                        j,
                        change - delta,
                    ));
                }
            }
        }
        None
    }
}

/// A constraint a plan breaks: which, at which position (the first; 0 for the total time)
/// and by how much, s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Breach {
    pub bound: Bound,
    pub index: usize,
    pub excess_s: f64,
}

impl Breach {
    fn new(bound: Bound, index: usize, excess_s: f64) -> Breach {
        Breach {
            bound,
            index,
            excess_s,
        }
    }
}

impl From<Constraint> for Bound {
    fn from(constraint: Constraint) -> Bound {
        Bound::Constraint(constraint)
    }
}

#[cfg(test)]
mod tests {
    use super::super::kinematics::{floors, PathFeed};
    use super::*;
    use crate::physics::Motion;

    #[test]
    fn each_bad_value_names_its_field() {
        let cases: [(&str, Constraints); 6] = [
            (
                "min_dwell_s",
                Constraints {
                    min_dwell_s: -1.0,
                    ..Default::default()
                },
            ),
            (
                "min_dwell_s",
                Constraints {
                    min_dwell_s: f64::NAN,
                    ..Default::default()
                },
            ),
            (
                "max_dwell_s",
                Constraints {
                    max_dwell_s: Some(0.0),
                    ..Default::default()
                },
            ),
            (
                "max_total_time_s",
                Constraints {
                    max_total_time_s: Some(f64::INFINITY),
                    ..Default::default()
                },
            ),
            (
                "max_feed_mm_per_min",
                Constraints {
                    max_feed_mm_per_min: Some(-5.0),
                    ..Default::default()
                },
            ),
            (
                "max_dwell_change_s",
                Constraints {
                    max_dwell_change_s: Some(-0.1),
                    ..Default::default()
                },
            ),
        ];
        for (field, c) in cases {
            match c.validate() {
                Err(OptimizeError::InvalidConstraint { constraint, .. }) => {
                    assert_eq!(constraint.name(), field)
                }
                other => panic!("{field}: expected InvalidConstraint, got {other:?}"),
            }
        }
        let bad = Objective {
            smoothing: -1.0,
            time_weight: 0.0,
        };
        assert!(
            matches!(bad.validate(), Err(OptimizeError::InvalidWeight { weight, .. }) if weight == Weight::Smoothing)
        );
    }

    #[test]
    fn violation_finds_each_broken_constraint() {
        let c = Constraints {
            min_dwell_s: 1.0,
            max_dwell_s: Some(10.0),
            max_total_time_s: Some(20.0),
            max_feed_mm_per_min: Some(30.0),
            max_dwell_change_s: Some(5.0),
        };
        // Cells of 0.2, 1 and 0.5 mm crossed in t/2, t and t/2: at 0.5 mm/s the first needs
        // 0.8 s (min_dwell_s is more), the others 2 s (and the margin).
        let feed = PathFeed {
            cell_path_mm: &[0.2, 1.0, 0.5],
            max_feed_mm_per_min: 30.0,
        };
        let floors = floors(
            &[],
            Some(feed),
            &Motion::radial(vec![0.0, 1.0, 2.0]),
            c.min_dwell_s,
        );
        assert_eq!(c.violation(&[2.1, 2.1, 2.1], &floors, 1.0), None);
        let broken = |d: [f64; 3]| c.violation(&d, &floors, 1.0).map(|v| v.bound.describe());
        assert_eq!(broken([0.5, 4.0, 4.0]).as_deref(), Some("min_dwell_s"));
        assert_eq!(broken([2.0, 11.0, 6.0]).as_deref(), Some("max_dwell_s"));
        assert_eq!(broken([8.0, 9.0, 8.0]).as_deref(), Some("max_total_time_s"));
        assert_eq!(
            broken([2.1, 1.5, 2.1]).as_deref(),
            Some("max_feed_mm_per_min")
        );
        assert_eq!(
            broken([2.1, 8.0, 2.1]).as_deref(),
            Some("max_dwell_change_s")
        );
        // Within the relative tolerance is kept; just beyond it is not.
        assert_eq!(broken([10.0 * (1.0 + 1e-10), 6.0, 2.1]).as_deref(), None);
        assert_eq!(
            broken([10.0 * (1.0 + 1e-8), 6.0, 2.1]).as_deref(),
            Some("max_dwell_s")
        );
    }
}
