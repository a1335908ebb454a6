//! Uniformity of a removal profile over the clear aperture.
//!
//! Over the radial samples r_i that lie in the aperture [inner, outer] (each sample counts once;
//! on an evenly spaced grid this is the average along the radius, not an area average — the
//! figures the API has always reported; [`UniformityMetrics::weighted`] takes explicit weights,
//! such as a field's area weights, [`crate::field`]):
//!
//! ```text
//! mean = Σ z_i / n      min, max over the samples      pv = max − min
//! rms  = √(Σ (z_i − mean)² / n)                         nonuniformity = pv / mean
//! ```
//!
//! All depths in nm; nonuniformity is a fraction (0.01 = 1 %) and has no value when nothing is
//! removed in the aperture (mean = 0).

use super::grid::{ClearAperture, RadialGrid};
use crate::field::Figures;

/// Uniformity figures of a removal profile over a clear aperture, nm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniformityMetrics {
    pub mean_nm: f64,
    pub min_nm: f64,
    pub max_nm: f64,
    pub pv_nm: f64,
    pub rms_nm: f64,
    /// pv / mean; `None` when the mean removal is zero.
    pub nonuniformity: Option<f64>,
    /// How many radial samples the figures are taken over.
    pub samples: usize,
}

impl UniformityMetrics {
    /// Figures over the samples of `grid` inside `aperture`; `removal_nm` has one value per
    /// grid radius. The caller has checked (e.g. with [`ClearAperture::check_covered_by`]) that
    /// the aperture holds at least one sample.
    pub fn over(grid: &RadialGrid, aperture: &ClearAperture, removal_nm: &[f64]) -> Self {
        assert_eq!(grid.radii_mm().len(), removal_nm.len());
        let inside: Vec<f64> = grid
            .radii_mm()
            .iter()
            .zip(removal_nm)
            .filter(|(&r, _)| aperture.contains(r))
            .map(|(_, &z)| z)
            .collect();
        Self::of_samples(&inside)
    }

    /// Figures over the given depths (at least one), each counting once.
    pub fn of_samples(depths_nm: &[f64]) -> Self {
        Self::from_figures(Figures::unweighted(depths_nm))
    }

    /// Figures over the given depths with `weights` (one each, ≥ 0, at least one above 0):
    /// [`crate::field::Figures`], e.g. with a field's area weights ([`crate::field::Weighting`]).
    pub fn weighted(depths_nm: &[f64], weights: &[f64]) -> Self {
        Self::from_figures(Figures::weighted(depths_nm, weights))
    }

    fn from_figures(figures: Option<Figures>) -> Self {
        let f = figures.expect("metrics need a weighted sample");
        UniformityMetrics {
            mean_nm: f.mean,
            min_nm: f.min,
            max_nm: f.max,
            pv_nm: f.pv,
            rms_nm: f.rms,
            nonuniformity: (f.mean != 0.0).then(|| f.pv / f.mean),
            samples: f.samples,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::{tests::paper_spec, Process};

    #[test]
    fn figures_over_an_annulus() {
        let p = Process::new(paper_spec(-10.0, 200.0)).unwrap();
        let grid = RadialGrid::new(&p, 0.0, 50.0, 6).unwrap(); // 0, 10, …, 50
        let aperture = ClearAperture::new(&p, 10.0, 30.0).unwrap();
        let removal = [99.0, 1.0, 2.0, 3.0, 77.0, 55.0];
        let m = UniformityMetrics::over(&grid, &aperture, &removal);
        assert_eq!(m.samples, 3);
        assert_eq!(
            (m.mean_nm, m.min_nm, m.max_nm, m.pv_nm),
            (2.0, 1.0, 3.0, 2.0)
        );
        assert!((m.rms_nm - (2.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert_eq!(m.nonuniformity, Some(1.0));
    }

    #[test]
    fn nonuniformity_is_absent_without_removal() {
        let m = UniformityMetrics::of_samples(&[0.0, 0.0]);
        assert_eq!(m.nonuniformity, None);
        assert_eq!(m.pv_nm, 0.0);
    }
}
