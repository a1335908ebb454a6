//! Dwell schedules and constant feeds, and what they remove.
//!
//! A [`DwellSchedule`] is a list of tool positions r1_j (mm, strictly increasing) with the time
//! t_j (s) the tool spends in each one's cell; what it removes is the removal of the
//! [`Motion`] it stands for (built once, when the schedule is), through [`RemovalOperator`].
//!
//! A [`ConstantFeed`] is the tool travelling along the surface from a to b at feed v (mm/min
//! of arc), i.e. with dwell density τ = 60/v s per mm of arc. It needs no cells: it removes
//! ΔZ(r) = τ·∫_a^b R(r; ρ(s)) ds, the running integral of [`super::path`] read at both ends.

use std::ops::Range;

use rayon::prelude::*;

use super::grid::RadialGrid;
use super::motion::{Motion, SectorLaw, SectorLawError};
use super::operator::{RemovalOperator, RowReading};
use super::path::PARALLEL_MIN_PATHS;
use super::process::Process;
use super::removal::{RemovalKernel, RunningIntegral};

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
    #[error(
        "{field}[{index}] = {value} mm is outside the allowed tool positions [0, {max} mm{}",
        closing(*open)
    )]
    OutOfRange {
        field: &'static str,
        index: usize,
        value: f64,
        max: f64,
        /// `max` itself is out (a linear pad tips off there).
        open: bool,
    },
    #[error("dwell_s[{index}] must not be negative")]
    NegativeDwell { index: usize },
    #[error("dwell_s[{index}] exceeds {max} s (about 31 years), the longest dwell accepted")]
    DwellTooLong { index: usize, max: f64 },
    #[error("{field} must be a finite number")]
    NotFinite { field: &'static str },
    #[error(
        "feed_mm_per_min is so slow that the pass would take more than {max} s (about 31 years)"
    )]
    TooSlow { max: f64 },
    #[error(
        "{field} = {value} mm is outside the allowed tool positions [0, {max} mm{}",
        closing(*open)
    )]
    OffReach {
        field: &'static str,
        value: f64,
        max: f64,
        open: bool,
    },
    #[error("{field} must be greater than {lower}")]
    NotAbove {
        field: &'static str,
        lower: &'static str,
    },
}

/// The interval's closing bracket: `)` when its upper end is excluded.
fn closing(open: bool) -> &'static str {
    if open {
        "): a linear pad tips off the edge at the upper end"
    } else {
        "]"
    }
}

impl ScheduleError {
    pub fn field(&self) -> &'static str {
        match self {
            ScheduleError::Empty { field }
            | ScheduleError::NonFinite { field, .. }
            | ScheduleError::OutOfRange { field, .. }
            | ScheduleError::NotAbove { field, .. }
            | ScheduleError::NotFinite { field }
            | ScheduleError::OffReach { field, .. } => field,
            ScheduleError::LengthMismatch { .. } => "dwell_s",
            ScheduleError::NotIncreasing { .. } => "positions_mm",
            ScheduleError::NegativeDwell { .. } | ScheduleError::DwellTooLong { .. } => "dwell_s",
            ScheduleError::TooSlow { .. } => "feed_mm_per_min",
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
    let (max, open) = (process.max_tool_position_mm(), process.reach_is_open());
    for (index, &value) in positions_mm.iter().enumerate() {
        if !value.is_finite() {
            return Err(ScheduleError::NonFinite { field, index });
        }
        if !process.holds_position(value) {
            return Err(ScheduleError::OutOfRange {
                field,
                index,
                value,
                max,
                open,
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
    motion: Motion,
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
            motion: Motion::radial(positions_mm),
            dwell_s,
        })
    }

    /// The same plan with C turning by `law` (`Motion::with_sector_law`).
    pub fn with_sector_law(self, law: SectorLaw) -> Result<DwellSchedule, SectorLawError> {
        Ok(DwellSchedule {
            motion: self.motion.with_sector_law(law)?,
            dwell_s: self.dwell_s,
        })
    }

    /// The motion the plan stands for (built once, here).
    pub fn motion(&self) -> &Motion {
        &self.motion
    }
    pub fn positions_mm(&self) -> &[f64] {
        self.motion.radii_mm()
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
        RemovalOperator::assemble(&kernel, grid.radii_mm(), &self.motion).apply(&self.dwell_s)
    }
}

/// The tool travelling from `start_mm` to `stop_mm` (radii, within the reach) at a constant
/// feed along the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantFeed {
    start_mm: f64,
    stop_mm: f64,
    feed_mm_per_min: f64,
}

impl ConstantFeed {
    pub fn new(
        process: &Process,
        start_mm: f64,
        stop_mm: f64,
        feed_mm_per_min: f64,
    ) -> Result<Self, ScheduleError> {
        for (field, value) in [
            ("start_mm", start_mm),
            ("stop_mm", stop_mm),
            ("feed_mm_per_min", feed_mm_per_min),
        ] {
            if !value.is_finite() {
                return Err(ScheduleError::NotFinite { field });
            }
        }
        if feed_mm_per_min <= 0.0 {
            return Err(ScheduleError::NotAbove {
                field: "feed_mm_per_min",
                lower: "0",
            });
        }
        let (max, open) = (process.max_tool_position_mm(), process.reach_is_open());
        for (field, value) in [("start_mm", start_mm), ("stop_mm", stop_mm)] {
            if !process.holds_position(value) {
                return Err(ScheduleError::OffReach {
                    field,
                    value,
                    max,
                    open,
                });
            }
        }
        if stop_mm <= start_mm {
            return Err(ScheduleError::NotAbove {
                field: "stop_mm",
                lower: "start_mm",
            });
        }
        let feed = ConstantFeed {
            start_mm,
            stop_mm,
            feed_mm_per_min,
        };
        // As long as the longest dwell a plan may hold: keeps every depth finite.
        let time = feed.total_time_s(process);
        if time.is_nan() || time > MAX_DWELL_S {
            return Err(ScheduleError::TooSlow { max: MAX_DWELL_S });
        }
        Ok(feed)
    }

    pub fn start_mm(&self) -> f64 {
        self.start_mm
    }
    pub fn stop_mm(&self) -> f64 {
        self.stop_mm
    }
    pub fn feed_mm_per_min(&self) -> f64 {
        self.feed_mm_per_min
    }

    /// Dwell density τ = 60 / feed, s per mm of path (of arc on a curved part).
    pub fn dwell_density_s_per_mm(&self) -> f64 {
        60.0 / self.feed_mm_per_min
    }

    /// The path's length along the surface, mm.
    pub fn length_mm(&self, process: &Process) -> f64 {
        process.arc_length_mm(self.stop_mm) - process.arc_length_mm(self.start_mm)
    }

    /// Travel time, s.
    pub fn total_time_s(&self, process: &Process) -> f64 {
        self.dwell_density_s_per_mm() * self.length_mm(process)
    }

    /// The same path at `factor` times the feed.
    pub fn with_feed_scaled(&self, factor: f64) -> ConstantFeed {
        ConstantFeed {
            feed_mm_per_min: self.feed_mm_per_min * factor,
            ..*self
        }
    }

    /// [`Self::removal_nm`] read from each radius's running integral, F(stop) − F(start)
    /// ([`RemovalKernel::path_difference`]): the reading an operator's rows make of their
    /// own, so a pass computed beside an operator ([`PassReading`]) gives
    /// these very bits.
    pub fn removal_read_nm(&self, process: &Process, radii_mm: &[f64]) -> Vec<f64> {
        let kernel = RemovalKernel::new(process);
        let tau = self.dwell_density_s_per_mm();
        per_radius(radii_mm, |r| {
            tau * kernel.path_difference(r, self.start_mm, self.stop_mm)
        })
    }

    /// Removal in nm at each of `radii_mm`: τ·(F(b) − F(a)) with F the running integral of
    /// the removal rate along the surface at that radius.
    pub fn removal_nm(&self, process: &Process, radii_mm: &[f64]) -> Vec<f64> {
        let kernel = RemovalKernel::new(process);
        let tau = self.dwell_density_s_per_mm();
        let rt = process.tool_radius_mm();
        per_radius(radii_mm, |r| {
            // Outside the pad's reach of the path nothing is removed.
            if r + rt <= self.start_mm || r - rt >= self.stop_mm {
                return 0.0;
            }
            tau * kernel.path_total(r, self.start_mm, self.stop_mm)
        })
    }
}

/// A constant feed read beside an operator ([`RowReading`]): what it removes at the operator's
/// rows `rows` (a range of its radii), from each row's running integral as
/// [`ConstantFeed::removal_read_nm`] reads it alone, so both give the same bits.
#[derive(Debug, Clone, PartialEq)]
pub struct PassReading {
    pub feed: ConstantFeed,
    pub rows: Range<usize>,
}

impl RowReading for PassReading {
    fn rows(&self) -> Range<usize> {
        self.rows.clone()
    }

    fn read(&self, kernel: &RemovalKernel, r: f64, path: Option<&RunningIntegral>) -> f64 {
        let (a, b) = (self.feed.start_mm(), self.feed.stop_mm());
        let difference = match path {
            Some(path) => path.between(a, b),
            None => kernel.path_difference(r, a, b),
        };
        self.feed.dwell_density_s_per_mm() * difference
    }
}

/// `at` of every radius, across threads when there are enough path integrals to share.
fn per_radius(radii_mm: &[f64], at: impl Fn(f64) -> f64 + Sync) -> Vec<f64> {
    if radii_mm.len() >= PARALLEL_MIN_PATHS {
        radii_mm.par_iter().map(|&r| at(r)).collect()
    } else {
        radii_mm.iter().map(|&r| at(r)).collect()
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
    fn constant_feed_checks_its_path_and_keeps_time() {
        let p = process();
        let feed = ConstantFeed::new(&p, 0.0, 60.0, 30.0).unwrap();
        // 60 mm at 30 mm/min is 120 s.
        assert!((feed.total_time_s(&p) - 120.0).abs() < 1e-12);
        let err = |a, b, v| ConstantFeed::new(&p, a, b, v).unwrap_err().field();
        assert_eq!(err(0.0, 60.0, 0.0), "feed_mm_per_min");
        assert_eq!(err(0.0, 60.5, 10.0), "stop_mm");
        assert_eq!(err(-1.0, 6.0, 10.0), "start_mm");
        assert_eq!(err(5.0, 5.0, 10.0), "stop_mm");
        assert_eq!(err(f64::NAN, 5.0, 10.0), "start_mm");
        assert_eq!(err(0.0, 60.0, 1e-300), "feed_mm_per_min");
        assert_eq!(err(0.0, 60.0, 5e-324), "feed_mm_per_min");
        // A vanishing path at a vanishing feed takes a finite time and is fine.
        assert!(ConstantFeed::new(&p, 1.0, 1.0 + 1e-12, 1e-10).is_ok());
    }
}
