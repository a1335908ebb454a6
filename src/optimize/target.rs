//! Targets on the radial grid: a measured profile (radius, depth), checked once and resampled
//! by linear interpolation onto the grid's samples inside the clear aperture.

use std::ops::Range;

use super::problem::MAX_DEPTH_NM;
use crate::field::{Field, FieldError};
use crate::physics::{ClearAperture, RadialGrid};

/// The contiguous range of grid rows inside `aperture` (the grid is ascending).
pub fn aperture_rows(grid: &RadialGrid, aperture: &ClearAperture) -> Range<usize> {
    grid.rows_in(aperture)
}

/// Which array of a measured profile an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProfileArray {
    Radius,
    Depth,
}

/// Why a measured profile was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeasuredProfileError {
    #[error("a profile needs at least 2 points")]
    TooFewPoints,
    #[error("depth_nm has {depth} entries but radius_mm has {radius}: they must match")]
    LengthMismatch { depth: usize, radius: usize },
    #[error("radius_mm[{index}] must be a finite number ≥ 0 mm")]
    BadRadius { index: usize },
    #[error("radius_mm must be strictly increasing; entry {index} is not above the one before")]
    NotIncreasing { index: usize },
    #[error("depth_nm[{index}] must be a number within ±{max} nm")]
    BadDepth { index: usize, max: f64 },
    #[error("the profile spans [{lo}, {hi}] mm but the clear aperture's samples span [{first}, {last}] mm: the profile must cover them")]
    NotCovering {
        lo: f64,
        hi: f64,
        first: f64,
        last: f64,
    },
}

impl MeasuredProfileError {
    /// The array at fault and, when one element is, its index.
    pub fn location(&self) -> (ProfileArray, Option<usize>) {
        match *self {
            MeasuredProfileError::TooFewPoints | MeasuredProfileError::NotCovering { .. } => {
                (ProfileArray::Radius, None)
            }
            MeasuredProfileError::LengthMismatch { .. } => (ProfileArray::Depth, None),
            MeasuredProfileError::BadRadius { index }
            | MeasuredProfileError::NotIncreasing { index } => (ProfileArray::Radius, Some(index)),
            MeasuredProfileError::BadDepth { index, .. } => (ProfileArray::Depth, Some(index)),
        }
    }
}

/// A measured profile as a field: `radius_mm` strictly increasing, same length as `depth_nm`,
/// at least 2 points, depths within ±[`MAX_DEPTH_NM`]; checked once.
pub fn measured_profile(
    radius_mm: Vec<f64>,
    depth_nm: Vec<f64>,
) -> Result<Field, MeasuredProfileError> {
    // Point by point, radius before depth, so the first fault in the request is the one named.
    if radius_mm.len() < 2 {
        return Err(MeasuredProfileError::TooFewPoints);
    }
    if depth_nm.len() != radius_mm.len() {
        return Err(MeasuredProfileError::LengthMismatch {
            depth: depth_nm.len(),
            radius: radius_mm.len(),
        });
    }
    for (i, (&r, &z)) in radius_mm.iter().zip(&depth_nm).enumerate() {
        if !r.is_finite() || r < 0.0 {
            return Err(MeasuredProfileError::BadRadius { index: i });
        }
        if i > 0 && r <= radius_mm[i - 1] {
            return Err(MeasuredProfileError::NotIncreasing { index: i });
        }
        if !(-MAX_DEPTH_NM..=MAX_DEPTH_NM).contains(&z) {
            return Err(MeasuredProfileError::BadDepth {
                index: i,
                max: MAX_DEPTH_NM,
            });
        }
    }
    Ok(Field::radial(radius_mm, depth_nm)?)
}

/// Linear interpolation of the measured profile (`radius_mm` strictly increasing, same length
/// as `depth_nm`, at least 2 points) at each of `radii_mm`, which must lie within the
/// profile's span.
pub fn resample_profile(
    radius_mm: &[f64],
    depth_nm: &[f64],
    radii_mm: &[f64],
) -> Result<Vec<f64>, MeasuredProfileError> {
    Ok(measured_profile(radius_mm.to_vec(), depth_nm.to_vec())?.resample(radii_mm)?)
}

impl From<FieldError> for MeasuredProfileError {
    /// The field's checks in the profile's words (its arrays are `radius_mm` and `depth_nm`).
    fn from(e: FieldError) -> Self {
        match e {
            // A measured profile is a radial field: the polar variants cannot occur.
            FieldError::TooFewPoints | FieldError::NoAngles | FieldError::NotRadial => {
                MeasuredProfileError::TooFewPoints
            }
            FieldError::LengthMismatch { values, samples } => {
                MeasuredProfileError::LengthMismatch {
                    depth: values,
                    radius: samples,
                }
            }
            FieldError::BadRadius { index } => MeasuredProfileError::BadRadius { index },
            FieldError::NotIncreasing { index } => MeasuredProfileError::NotIncreasing { index },
            FieldError::BadValue { index } => MeasuredProfileError::BadDepth {
                index,
                max: MAX_DEPTH_NM,
            },
            FieldError::NotCovering {
                lo,
                hi,
                first,
                last,
            } => MeasuredProfileError::NotCovering {
                lo,
                hi,
                first,
                last,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_linearly_and_hits_the_nodes() {
        let radius = [0.0, 10.0, 30.0];
        let depth = [100.0, 200.0, 0.0];
        let got = resample_profile(&radius, &depth, &[0.0, 5.0, 10.0, 20.0, 30.0]).unwrap();
        assert_eq!(got, vec![100.0, 150.0, 200.0, 100.0, 0.0]);
    }

    #[test]
    fn refuses_profiles_that_do_not_cover_or_are_malformed() {
        let field = |r: Result<Vec<f64>, MeasuredProfileError>| match r {
            Err(e) => {
                let (array, index) = e.location();
                let name = match array {
                    ProfileArray::Radius => "radius_mm",
                    ProfileArray::Depth => "depth_nm",
                };
                index.map_or(name.to_string(), |i| format!("{name}[{i}]"))
            }
            other => panic!("expected an error, got {other:?}"),
        };
        assert_eq!(
            field(resample_profile(&[1.0, 2.0], &[0.0, 0.0], &[0.5])),
            "radius_mm"
        );
        assert_eq!(field(resample_profile(&[1.0], &[0.0], &[1.0])), "radius_mm");
        assert_eq!(
            field(resample_profile(&[1.0, 2.0], &[0.0], &[1.0])),
            "depth_nm"
        );
        assert_eq!(
            field(resample_profile(&[1.0, 1.0], &[0.0, 0.0], &[1.0])),
            "radius_mm[1]"
        );
        assert_eq!(
            field(resample_profile(&[1.0, 2.0], &[0.0, f64::NAN], &[1.0])),
            "depth_nm[1]"
        );
    }
}
