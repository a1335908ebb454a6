//! The setting every computation shares: the process, the radial grid removal is computed on,
//! and the clear aperture it is judged over, with their defaults.

use super::limits::{ComputeLimits, LimitError};
use crate::physics::{ClearAperture, GridError, Process, ProcessError, ProcessSpec, RadialGrid};
use crate::study::Frame;

/// Default number of radial samples.
pub const DEFAULT_RADIAL_SAMPLES: usize = 201;

/// A radial grid as asked: `count` samples from `start_mm` to `stop_mm` (defaults: 201 samples
/// from 0 to the workpiece radius).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GridSpec {
    pub start_mm: Option<f64>,
    pub stop_mm: Option<f64>,
    pub count: Option<usize>,
}

/// A clear aperture as asked (defaults: the whole workpiece).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ApertureSpec {
    pub inner_mm: Option<f64>,
    pub outer_mm: Option<f64>,
}

/// Why a setting was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingError {
    #[error(transparent)]
    Process(ProcessError),
    #[error(transparent)]
    GridSize(LimitError),
    #[error(transparent)]
    Grid(GridError),
    #[error(transparent)]
    Aperture(GridError),
}

/// A valid process with a radial grid within the limits and a clear aperture the grid spans.
#[derive(Debug, Clone, PartialEq)]
pub struct Setting {
    process: Process,
    grid: RadialGrid,
    aperture: ClearAperture,
}

impl Setting {
    pub fn new(
        process: ProcessSpec,
        grid: GridSpec,
        aperture: ApertureSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, SettingError> {
        let (process, grid) = process_and_grid(process, grid, limits)?;
        let aperture = ClearAperture::new(
            &process,
            aperture.inner_mm.unwrap_or(0.0),
            aperture.outer_mm.unwrap_or(process.workpiece_radius_mm()),
        )
        .map_err(SettingError::Aperture)?;
        aperture
            .check_covered_by(&grid)
            .map_err(SettingError::Aperture)?;
        Ok(Setting {
            process,
            grid,
            aperture,
        })
    }

    pub fn process(&self) -> &Process {
        &self.process
    }

    pub fn grid(&self) -> &RadialGrid {
        &self.grid
    }

    pub fn aperture(&self) -> &ClearAperture {
        &self.aperture
    }

    /// The number of radial samples.
    pub fn samples(&self) -> usize {
        self.grid.radii_mm().len()
    }

    /// The study frame: where removal is computed and judged.
    pub fn frame(&self) -> Frame<'_> {
        Frame {
            grid: &self.grid,
            aperture: &self.aperture,
        }
    }
}

/// A process and a radial grid on it (for computations that judge no aperture).
pub fn process_and_grid(
    process: ProcessSpec,
    grid: GridSpec,
    limits: &ComputeLimits,
) -> Result<(Process, RadialGrid), SettingError> {
    let process = Process::new(process).map_err(SettingError::Process)?;
    let count = grid.count.unwrap_or(DEFAULT_RADIAL_SAMPLES);
    limits
        .check_radial_samples(count)
        .map_err(SettingError::GridSize)?;
    let grid = RadialGrid::new(
        &process,
        grid.start_mm.unwrap_or(0.0),
        grid.stop_mm.unwrap_or(process.workpiece_radius_mm()),
        count,
    )
    .map_err(SettingError::Grid)?;
    Ok((process, grid))
}
