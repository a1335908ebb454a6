//! Where removal is reported: an evenly spaced radial grid on the workpiece, and the clear
//! aperture (an annulus [inner, outer], possibly a full disc) where uniformity is judged.

use super::process::Process;

/// Why a radial grid or clear aperture was refused. `field` names the offending input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    #[error("{field} must be a finite number")]
    NonFinite { field: &'static str },
    #[error("{field} must not be negative")]
    Negative { field: &'static str },
    #[error("{field} ({value} mm) lies beyond the {} ({} mm)", reach.name, reach.radius_mm)]
    Beyond {
        field: &'static str,
        value: f64,
        reach: Reach,
    },
    #[error("{field} must be greater than {lower}")]
    NotAbove {
        field: &'static str,
        lower: &'static str,
    },
    #[error("count must be at least 1 (1 only when start_mm equals stop_mm, else at least 2)")]
    BadCount,
    #[error("the radial grid [{start} mm, {stop} mm] does not cover the clear aperture [{inner} mm, {outer} mm]")]
    ApertureOutsideGrid {
        start: f64,
        stop: f64,
        inner: f64,
        outer: f64,
    },
}

impl GridError {
    /// The member of the grid or aperture at fault; `None` when the two do not fit together.
    pub fn field(&self) -> Option<&'static str> {
        match self {
            GridError::NonFinite { field }
            | GridError::Negative { field }
            | GridError::Beyond { field, .. }
            | GridError::NotAbove { field, .. } => Some(field),
            GridError::BadCount => Some("count"),
            GridError::ApertureOutsideGrid { .. } => None,
        }
    }
}

/// How far out a grid or aperture may reach, and what that bound is (for messages).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    pub radius_mm: f64,
    /// What the bound is, e.g. "workpiece radius".
    pub name: &'static str,
}

impl Reach {
    pub fn workpiece(process: &Process) -> Reach {
        Reach {
            radius_mm: process.workpiece_radius_mm(),
            name: "workpiece radius",
        }
    }
}

/// A radius for `field`: finite, ≥ 0 and within `reach`.
pub fn check_radius(field: &'static str, value: f64, reach: Reach) -> Result<(), GridError> {
    if !value.is_finite() {
        return Err(GridError::NonFinite { field });
    }
    if value < 0.0 {
        return Err(GridError::Negative { field });
    }
    if value > reach.radius_mm {
        return Err(GridError::Beyond {
            field,
            value,
            reach,
        });
    }
    Ok(())
}

/// `count` radii evenly spaced from `start_mm` to `stop_mm` inclusive, on the workpiece.
#[derive(Debug, Clone, PartialEq)]
pub struct RadialGrid {
    start_mm: f64,
    stop_mm: f64,
    radii_mm: Vec<f64>,
}

impl RadialGrid {
    pub fn new(
        process: &Process,
        start_mm: f64,
        stop_mm: f64,
        count: usize,
    ) -> Result<Self, GridError> {
        Self::within(Reach::workpiece(process), start_mm, stop_mm, count)
    }

    /// A grid whose radii stay within `reach`.
    pub fn within(
        reach: Reach,
        start_mm: f64,
        stop_mm: f64,
        count: usize,
    ) -> Result<Self, GridError> {
        let rm = reach;
        check_radius("start_mm", start_mm, rm)?;
        check_radius("stop_mm", stop_mm, rm)?;
        match count {
            0 => return Err(GridError::BadCount),
            1 if start_mm != stop_mm => return Err(GridError::BadCount),
            1 => {}
            _ if stop_mm <= start_mm => {
                return Err(GridError::NotAbove {
                    field: "stop_mm",
                    lower: "start_mm",
                })
            }
            _ => {}
        }
        let step = if count > 1 {
            (stop_mm - start_mm) / (count - 1) as f64
        } else {
            0.0
        };
        let mut radii_mm: Vec<f64> = (0..count).map(|i| start_mm + step * i as f64).collect();
        radii_mm[count - 1] = stop_mm; // exact end point despite rounding
        Ok(RadialGrid {
            start_mm,
            stop_mm,
            radii_mm,
        })
    }

    /// The default grid: 201 samples from the centre to the edge.
    pub fn default_for(process: &Process) -> Self {
        Self::new(process, 0.0, process.workpiece_radius_mm(), 201)
            .expect("the default grid is valid for every valid process")
    }

    pub fn radii_mm(&self) -> &[f64] {
        &self.radii_mm
    }
    pub fn start_mm(&self) -> f64 {
        self.start_mm
    }
    /// The contiguous range of samples inside `aperture` (the grid ascends).
    pub fn rows_in(&self, aperture: &ClearAperture) -> std::ops::Range<usize> {
        let radii = &self.radii_mm;
        let start = radii.partition_point(|&r| r < aperture.inner_mm());
        let end = radii.partition_point(|&r| r <= aperture.outer_mm());
        start..end.max(start)
    }

    pub fn stop_mm(&self) -> f64 {
        self.stop_mm
    }
}

/// Radii [inner, outer] where uniformity is judged and targets apply; inner = 0 is a full disc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClearAperture {
    inner_mm: f64,
    outer_mm: f64,
}

impl ClearAperture {
    pub fn new(process: &Process, inner_mm: f64, outer_mm: f64) -> Result<Self, GridError> {
        Self::within(Reach::workpiece(process), inner_mm, outer_mm)
    }

    /// An aperture within `reach`.
    pub fn within(reach: Reach, inner_mm: f64, outer_mm: f64) -> Result<Self, GridError> {
        let rm = reach;
        check_radius("inner_mm", inner_mm, rm)?;
        check_radius("outer_mm", outer_mm, rm)?;
        if outer_mm <= inner_mm {
            return Err(GridError::NotAbove {
                field: "outer_mm",
                lower: "inner_mm",
            });
        }
        Ok(ClearAperture { inner_mm, outer_mm })
    }

    /// The whole workpiece.
    pub fn whole(process: &Process) -> Self {
        ClearAperture {
            inner_mm: 0.0,
            outer_mm: process.workpiece_radius_mm(),
        }
    }

    pub fn inner_mm(&self) -> f64 {
        self.inner_mm
    }
    pub fn outer_mm(&self) -> f64 {
        self.outer_mm
    }

    pub fn contains(&self, r_mm: f64) -> bool {
        (self.inner_mm..=self.outer_mm).contains(&r_mm)
    }

    /// Checks that `grid` spans the aperture, so metrics describe all of it.
    pub fn check_covered_by(&self, grid: &RadialGrid) -> Result<(), GridError> {
        let radii = grid.radii_mm();
        let covered = grid.start_mm() <= self.inner_mm
            && grid.stop_mm() >= self.outer_mm
            && radii.iter().any(|&r| self.contains(r));
        if covered {
            Ok(())
        } else {
            Err(GridError::ApertureOutsideGrid {
                start: grid.start_mm(),
                stop: grid.stop_mm(),
                inner: self.inner_mm,
                outer: self.outer_mm,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::tests::paper_spec;

    fn process() -> Process {
        Process::new(paper_spec(-10.0, 200.0)).unwrap()
    }

    #[test]
    fn grid_is_evenly_spaced_with_exact_ends() {
        let g = RadialGrid::new(&process(), 0.0, 50.0, 201).unwrap();
        assert_eq!(g.radii_mm().len(), 201);
        assert_eq!(g.radii_mm()[0], 0.0);
        assert_eq!(g.radii_mm()[200], 50.0);
        assert!((g.radii_mm()[1] - 0.25).abs() < 1e-15);
        assert_eq!(RadialGrid::default_for(&process()), g);
        let single = RadialGrid::new(&process(), 20.0, 20.0, 1).unwrap();
        assert_eq!(single.radii_mm(), &[20.0]);
    }

    #[test]
    fn grid_rejects_bad_input_naming_the_field() {
        let p = process();
        let err = |s, e, n| RadialGrid::new(&p, s, e, n).unwrap_err().field().unwrap();
        assert_eq!(err(f64::NAN, 50.0, 10), "start_mm");
        assert_eq!(err(0.0, f64::INFINITY, 10), "stop_mm");
        assert_eq!(err(-1.0, 50.0, 10), "start_mm");
        assert_eq!(err(0.0, 50.5, 10), "stop_mm");
        assert_eq!(err(30.0, 20.0, 10), "stop_mm");
        assert_eq!(err(0.0, 50.0, 0), "count");
        assert_eq!(err(0.0, 50.0, 1), "count");
    }

    #[test]
    fn aperture_validation_and_coverage() {
        let p = process();
        assert_eq!(
            ClearAperture::new(&p, 20.0, 10.0)
                .unwrap_err()
                .field()
                .unwrap(),
            "outer_mm"
        );
        assert_eq!(
            ClearAperture::new(&p, 0.0, 60.0)
                .unwrap_err()
                .field()
                .unwrap(),
            "outer_mm"
        );
        let ca = ClearAperture::new(&p, 10.0, 40.0).unwrap();
        assert!(ca.contains(10.0) && ca.contains(40.0) && !ca.contains(40.1));
        let grid = RadialGrid::new(&p, 0.0, 30.0, 31).unwrap();
        assert_eq!(ca.check_covered_by(&grid).unwrap_err().field(), None);
        assert!(ca.check_covered_by(&RadialGrid::default_for(&p)).is_ok());
    }
}
