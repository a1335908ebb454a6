//! The setting every computation shares: the process, the radial grid removal is computed on,
//! and the clear aperture it is judged over, with their defaults.

use super::limits::{ComputeLimits, SizeLimitError};
use crate::machine::{Tool, ToolError};
use crate::physics::{ClearAperture, GridError, Process, ProcessError, ProcessSpec, RadialGrid};
use crate::physics::{Orientation, Part};
use crate::study::Frame;
use crate::surface::{Surface, SurfaceError, SurfaceSpec};

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

/// The part and the pad on it as asked: the surface (default a plane), the pad's pivot length
/// (default 0) and spin axis (default along the normal).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PartSpec {
    pub surface: Option<SurfaceSpec>,
    pub pivot_length_mm: Option<f64>,
    pub orientation: Option<Orientation>,
}

/// Why a part or its tool was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PartError {
    #[error(transparent)]
    Surface(SurfaceError),
    #[error(transparent)]
    Tool(ToolError),
}

/// A checked part and the tool that polishes it.
#[derive(Debug, Clone, PartialEq)]
pub struct Mount {
    pub part: Part,
    pub tool: Tool,
    /// Whether the request described the part or the tool at all (rather than taking the
    /// defaults): an optimization then checks its positions against the poses.
    pub described: bool,
}

impl PartSpec {
    /// The surface and the whole tool, checked (though removal needs only the orientation:
    /// what one endpoint refuses, every endpoint refuses).
    pub fn parse(&self) -> Result<Mount, PartError> {
        let surface = Surface::new(self.surface.as_ref().unwrap_or(&SurfaceSpec::Plane))
            .map_err(PartError::Surface)?;
        let orientation = self.orientation.unwrap_or(Orientation::Normal);
        let tool =
            Tool::new(self.pivot_length_mm.unwrap_or(0.0), orientation).map_err(PartError::Tool)?;
        Ok(Mount {
            part: Part {
                surface,
                orientation,
            },
            tool,
            described: *self != PartSpec::default(),
        })
    }
}

/// Why a setting was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingError {
    #[error(transparent)]
    Part(PartError),
    #[error(transparent)]
    Process(ProcessError),
    #[error(transparent)]
    GridSize(SizeLimitError),
    #[error(transparent)]
    Grid(GridError),
    #[error(transparent)]
    Aperture(GridError),
}

/// A valid process on its part, with a radial grid within the limits and a clear aperture the
/// grid spans.
#[derive(Debug, Clone, PartialEq)]
pub struct Setting {
    process: Process,
    mount: Mount,
    grid: RadialGrid,
    aperture: ClearAperture,
}

impl Setting {
    /// `process` on the part `part` describes (the spec's own `part` is replaced).
    pub fn new(
        process: ProcessSpec,
        part: &PartSpec,
        grid: GridSpec,
        aperture: ApertureSpec,
        limits: &ComputeLimits,
    ) -> Result<Self, SettingError> {
        let (process, mount, grid) = process_and_grid(process, part, grid, limits)?;
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
            mount,
            grid,
            aperture,
        })
    }

    pub fn process(&self) -> &Process {
        &self.process
    }

    /// The part and the tool on it.
    pub fn mount(&self) -> &Mount {
        &self.mount
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

/// `process` on the part `part` describes (the spec's own `part` is replaced).
pub fn process_on_part(
    process: ProcessSpec,
    part: &PartSpec,
) -> Result<(Process, Mount), SettingError> {
    let mount = part.parse().map_err(SettingError::Part)?;
    let process = ProcessSpec {
        part: mount.part.clone(),
        ..process
    };
    let process = Process::new(process).map_err(SettingError::Process)?;
    Ok((process, mount))
}

/// A process on its part and a radial grid on it (for computations that judge no aperture).
pub fn process_and_grid(
    process: ProcessSpec,
    part: &PartSpec,
    grid: GridSpec,
    limits: &ComputeLimits,
) -> Result<(Process, Mount, RadialGrid), SettingError> {
    let (process, mount) = process_on_part(process, part)?;
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
    Ok((process, mount, grid))
}
