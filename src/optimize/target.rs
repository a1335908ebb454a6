//! Targets on the radial grid: a measured profile (radius, depth) resampled by linear
//! interpolation onto the grid's samples inside the clear aperture.

use std::ops::Range;

use super::problem::{OptimizeError, MAX_DEPTH_NM};
use crate::physics::{ClearAperture, RadialGrid};

/// The contiguous range of grid rows inside `aperture` (the grid is ascending).
pub fn aperture_rows(grid: &RadialGrid, aperture: &ClearAperture) -> Range<usize> {
    let radii = grid.radii_mm();
    let start = radii.partition_point(|&r| r < aperture.inner_mm());
    let end = radii.partition_point(|&r| r <= aperture.outer_mm());
    start..end.max(start)
}

/// Linear interpolation of the measured profile (`radius_mm` strictly increasing, same length
/// as `depth_nm`, at least 2 points) at each of `radii_mm`, which must lie within the
/// profile's span. Field names in errors are relative to the profile object.
pub fn resample_profile(
    radius_mm: &[f64],
    depth_nm: &[f64],
    radii_mm: &[f64],
) -> Result<Vec<f64>, OptimizeError> {
    if radius_mm.len() < 2 {
        return Err(OptimizeError::invalid(
            "radius_mm",
            "a profile needs at least 2 points",
        ));
    }
    if depth_nm.len() != radius_mm.len() {
        return Err(OptimizeError::invalid(
            "depth_nm",
            format!(
                "depth_nm has {} entries but radius_mm has {}: they must match",
                depth_nm.len(),
                radius_mm.len()
            ),
        ));
    }
    for (i, (&r, &z)) in radius_mm.iter().zip(depth_nm).enumerate() {
        if !r.is_finite() || r < 0.0 {
            return Err(OptimizeError::invalid(
                format!("radius_mm[{i}]"),
                format!("radius_mm[{i}] must be a finite number ≥ 0 mm"),
            ));
        }
        if i > 0 && r <= radius_mm[i - 1] {
            return Err(OptimizeError::invalid(
                format!("radius_mm[{i}]"),
                format!(
                    "radius_mm must be strictly increasing; entry {i} is not above the one before"
                ),
            ));
        }
        if !(-MAX_DEPTH_NM..=MAX_DEPTH_NM).contains(&z) {
            return Err(OptimizeError::invalid(
                format!("depth_nm[{i}]"),
                format!("depth_nm[{i}] must be a number within ±{MAX_DEPTH_NM} nm"),
            ));
        }
    }
    let (lo, hi) = (radius_mm[0], radius_mm[radius_mm.len() - 1]);
    if let (Some(&first), Some(&last)) = (radii_mm.first(), radii_mm.last()) {
        if first < lo || last > hi {
            return Err(OptimizeError::invalid(
                "radius_mm",
                format!(
                    "the profile spans [{lo}, {hi}] mm but the clear aperture's samples span [{first}, {last}] mm: the profile must cover them"
                ),
            ));
        }
    }
    Ok(radii_mm
        .iter()
        .map(|&r| {
            // Index of the segment [radius_mm[k], radius_mm[k+1]] holding r.
            let k = radius_mm
                .partition_point(|&x| x <= r)
                .clamp(1, radius_mm.len() - 1)
                - 1;
            let (r0, r1) = (radius_mm[k], radius_mm[k + 1]);
            let w = (r - r0) / (r1 - r0);
            depth_nm[k] + w * (depth_nm[k + 1] - depth_nm[k])
        })
        .collect())
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
        let field = |r: Result<Vec<f64>, OptimizeError>| match r {
            Err(OptimizeError::Invalid { field, .. }) => field,
            other => panic!("expected Invalid, got {other:?}"),
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
