//! Dwell schedules and what they remove.
//!
//! A [`DwellSchedule`] is a list of tool positions r1_j (mm, strictly increasing) with the time
//! t_j (s) the tool spends at each; the cumulative removal is ΔZ(r) = Σ_j R(r; r1_j)·t_j (nm).
//!
//! A [`ConstantFeed`] is the tool travelling along the radius from a to b at feed v (mm/min),
//! i.e. with dwell density τ = 60/v s/mm, whose removal is the integral ΔZ(r) = τ·∫_a^b R(r; x) dx.
//! We discretise it with the composite midpoint rule: n cells of width h = (b − a)/n, one
//! position at each cell centre x_k = a + (k + ½)·h with dwell t_k = τ·h (so the total time is
//! exactly the path's travel time). R(r; ·) is continuous with square-root kinks (tangency at
//! x = r ± r_t, full coverage at x = r_t − r), where the rule converges like h^1.5. At r = 0
//! the kinks merge into a jump at x = r_t (the centre leaves the pad): there any point rule is
//! first order, with error at most h/r_t of the removal, unless r_t falls on a cell centre
//! (where the removal function takes its mid-jump value, see [`super::contact`]) or on a cell
//! boundary, which makes it second order again.

use super::grid::RadialGrid;
use super::operator::RemovalOperator;
use super::process::Process;
use super::removal::RemovalKernel;

/// Why a dwell schedule or feed path was refused. `field` and `index` locate the input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScheduleError {
    #[error("{field} must not be empty")]
    Empty { field: &'static str },
    #[error("positions_mm has {positions} entries but dwell_s has {dwell}: they must match")]
    LengthMismatch { positions: usize, dwell: usize },
    #[error("{field}[{index}] must be a finite number")]
    NonFinite { field: &'static str, index: usize },
    #[error("positions_mm must be strictly increasing; entry {index} is not above the one before")]
    NotIncreasing { index: usize },
    #[error("{field}[{index}] = {value} mm is outside the allowed tool positions [0, {max} mm]")]
    OutOfRange {
        field: &'static str,
        index: usize,
        value: f64,
        max: f64,
    },
    #[error("dwell_s[{index}] must not be negative")]
    NegativeDwell { index: usize },
    #[error("dwell_s[{index}] exceeds {max} s (about 31 years), the longest dwell accepted")]
    DwellTooLong { index: usize, max: f64 },
    #[error("{field} must be greater than {lower}")]
    NotAbove {
        field: &'static str,
        lower: &'static str,
    },
}

impl ScheduleError {
    pub fn field(&self) -> &'static str {
        match self {
            ScheduleError::Empty { field }
            | ScheduleError::NonFinite { field, .. }
            | ScheduleError::OutOfRange { field, .. }
            | ScheduleError::NotAbove { field, .. } => field,
            ScheduleError::LengthMismatch { .. } => "dwell_s",
            ScheduleError::NotIncreasing { .. } => "positions_mm",
            ScheduleError::NegativeDwell { .. } | ScheduleError::DwellTooLong { .. } => "dwell_s",
        }
    }

    /// The offending array element, when the error is about one.
    pub fn index(&self) -> Option<usize> {
        match self {
            ScheduleError::NonFinite { index, .. }
            | ScheduleError::NotIncreasing { index }
            | ScheduleError::OutOfRange { index, .. }
            | ScheduleError::NegativeDwell { index }
            | ScheduleError::DwellTooLong { index, .. } => Some(*index),
            _ => None,
        }
    }
}

/// Longest dwell accepted at one position, s (keeps removal depths finite).
pub const MAX_DWELL_S: f64 = 1e9;

/// Checks that tool positions are finite, within the process's reach and, when `increasing`,
/// strictly increasing.
pub fn check_positions(
    process: &Process,
    field: &'static str,
    positions_mm: &[f64],
    increasing: bool,
) -> Result<(), ScheduleError> {
    if positions_mm.is_empty() {
        return Err(ScheduleError::Empty { field });
    }
    let max = process.max_tool_position_mm();
    for (index, &value) in positions_mm.iter().enumerate() {
        if !value.is_finite() {
            return Err(ScheduleError::NonFinite { field, index });
        }
        if !(0.0..=max).contains(&value) {
            return Err(ScheduleError::OutOfRange {
                field,
                index,
                value,
                max,
            });
        }
        if increasing && index > 0 && value <= positions_mm[index - 1] {
            return Err(ScheduleError::NotIncreasing { index });
        }
    }
    Ok(())
}

/// Tool positions (mm, strictly increasing, within reach) with dwell times (s, ≥ 0).
#[derive(Debug, Clone, PartialEq)]
pub struct DwellSchedule {
    positions_mm: Vec<f64>,
    dwell_s: Vec<f64>,
}

impl DwellSchedule {
    pub fn new(
        process: &Process,
        positions_mm: Vec<f64>,
        dwell_s: Vec<f64>,
    ) -> Result<Self, ScheduleError> {
        check_positions(process, "positions_mm", &positions_mm, true)?;
        if dwell_s.len() != positions_mm.len() {
            return Err(ScheduleError::LengthMismatch {
                positions: positions_mm.len(),
                dwell: dwell_s.len(),
            });
        }
        for (index, &t) in dwell_s.iter().enumerate() {
            if !t.is_finite() {
                return Err(ScheduleError::NonFinite {
                    field: "dwell_s",
                    index,
                });
            }
            if t < 0.0 {
                return Err(ScheduleError::NegativeDwell { index });
            }
            if t > MAX_DWELL_S {
                return Err(ScheduleError::DwellTooLong {
                    index,
                    max: MAX_DWELL_S,
                });
            }
        }
        Ok(DwellSchedule {
            positions_mm,
            dwell_s,
        })
    }

    /// A schedule from parts already known valid (e.g. a valid schedule's dwell scaled by a
    /// positive factor).
    pub(crate) fn new_unchecked(positions_mm: Vec<f64>, dwell_s: Vec<f64>) -> Self {
        debug_assert_eq!(positions_mm.len(), dwell_s.len());
        DwellSchedule {
            positions_mm,
            dwell_s,
        }
    }

    pub fn positions_mm(&self) -> &[f64] {
        &self.positions_mm
    }
    pub fn dwell_s(&self) -> &[f64] {
        &self.dwell_s
    }
    pub fn total_time_s(&self) -> f64 {
        self.dwell_s.iter().sum()
    }

    /// Cumulative removal in nm at every radius of `grid`.
    pub fn removal_nm(&self, process: &Process, grid: &RadialGrid) -> Vec<f64> {
        let kernel = RemovalKernel::new(process);
        RemovalOperator::assemble(&kernel, grid.radii_mm(), &self.positions_mm).apply(&self.dwell_s)
    }
}

/// The tool travelling from `start_mm` to `stop_mm` at a constant radial feed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantFeed {
    pub start_mm: f64,
    pub stop_mm: f64,
    pub feed_mm_per_min: f64,
    /// Number of cells (positions, ≥ 1) the path is discretised into.
    pub positions: usize,
}

impl ConstantFeed {
    /// Dwell density τ = 60 / feed, s per mm of path (of arc on a curved part).
    pub fn dwell_density_s_per_mm(&self) -> f64 {
        60.0 / self.feed_mm_per_min
    }

    /// The midpoint-rule dwell schedule of the path (module docs).
    pub fn schedule(&self, process: &Process) -> Result<DwellSchedule, ScheduleError> {
        if !self.feed_mm_per_min.is_finite() {
            return Err(ScheduleError::NonFinite {
                field: "feed_mm_per_min",
                index: 0,
            });
        }
        if self.feed_mm_per_min <= 0.0 {
            return Err(ScheduleError::NotAbove {
                field: "feed_mm_per_min",
                lower: "0",
            });
        }
        if self.positions == 0 {
            return Err(ScheduleError::NotAbove {
                field: "positions",
                lower: "0",
            });
        }
        if self.stop_mm <= self.start_mm {
            return Err(ScheduleError::NotAbove {
                field: "stop_mm",
                lower: "start_mm",
            });
        }
        let n = self.positions;
        // Cells of equal arc length (equal radius on a plane): constant dwell per unit length
        // along the surface.
        let surface = &process.part().surface;
        let start = process.arc_length_mm(self.start_mm);
        let length = process.arc_length_mm(self.stop_mm) - start;
        // Cell k is [a + k·h, a + (k+1)·h]; its centre computed as one division so that
        // centres that are exact in decimal (e.g. r_t) come out exact.
        let positions: Vec<f64> = (0..n)
            .map(|k| {
                let centre = start + length * (2 * k + 1) as f64 / (2 * n) as f64;
                surface.radius_at_arc_length(centre)
            })
            .collect();
        let dwell = vec![self.dwell_density_s_per_mm() * length / n as f64; n];
        DwellSchedule::new(process, positions, dwell)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::tests::paper_spec;

    fn process() -> Process {
        Process::new(paper_spec(150.0, 150.0)).unwrap()
    }

    #[test]
    fn schedule_rejects_each_bad_input() {
        let p = process();
        let err = |pos: Vec<f64>, dw: Vec<f64>| DwellSchedule::new(&p, pos, dw).unwrap_err();
        assert_eq!(err(vec![], vec![]).field(), "positions_mm");
        assert_eq!(
            err(vec![1.0, 2.0], vec![1.0]),
            ScheduleError::LengthMismatch {
                positions: 2,
                dwell: 1
            }
        );
        let e = err(vec![1.0, f64::NAN], vec![1.0, 1.0]);
        assert_eq!((e.field(), e.index()), ("positions_mm", Some(1)));
        let e = err(vec![1.0, 2.0, 2.0], vec![1.0; 3]);
        assert_eq!((e.field(), e.index()), ("positions_mm", Some(2)));
        let e = err(vec![-1.0, 2.0], vec![1.0; 2]);
        assert_eq!((e.field(), e.index()), ("positions_mm", Some(0)));
        let e = err(vec![1.0, 60.5], vec![1.0; 2]);
        assert_eq!((e.field(), e.index()), ("positions_mm", Some(1)));
        let e = err(vec![1.0, 2.0], vec![1.0, -0.5]);
        assert_eq!((e.field(), e.index()), ("dwell_s", Some(1)));
        let e = err(vec![1.0, 2.0], vec![f64::INFINITY, 1.0]);
        assert_eq!((e.field(), e.index()), ("dwell_s", Some(0)));
    }

    #[test]
    fn constant_feed_uses_cell_centres_and_conserves_time() {
        let feed = ConstantFeed {
            start_mm: 0.0,
            stop_mm: 60.0,
            feed_mm_per_min: 30.0,
            positions: 6,
        };
        let s = feed.schedule(&process()).unwrap();
        assert_eq!(s.positions_mm(), &[5.0, 15.0, 25.0, 35.0, 45.0, 55.0]);
        // 60 mm at 30 mm/min is 120 s, all of it accounted for, 20 s per 10 mm cell.
        assert!((s.total_time_s() - 120.0).abs() < 1e-12);
        assert!(s.dwell_s().iter().all(|&t| t == 20.0));
    }
}
