//! The removal function: R(r; r1) across the radial grid for each requested tool position.

use super::setting::{process_and_grid, PartSpec};
use super::warnings::unit_warnings;
use super::{ComputeLimits, GridSpec, Input, InputError, Warning};
use crate::physics::{check_positions, Process, ProcessSpec, RadialGrid, RemovalKernel};

/// Profiles of one tool at the given positions (any order, within the tool's reach).
#[derive(Debug, Clone, PartialEq)]
pub struct RemovalFunctionCommand {
    process: Process,
    grid: RadialGrid,
    tool_positions_mm: Vec<f64>,
}

impl RemovalFunctionCommand {
    pub fn new(
        process: ProcessSpec,
        part: &PartSpec,
        grid: GridSpec,
        tool_positions_mm: Vec<f64>,
        limits: &ComputeLimits,
    ) -> Result<Self, InputError> {
        let (process, _, grid) = process_and_grid(process, part, grid, limits)?;
        let input = Input::ToolPositions;
        limits
            .check_profiles(tool_positions_mm.len())
            .map_err(InputError::limit(input))?;
        limits
            .check_operator(grid.radii_mm().len(), tool_positions_mm.len())
            .map_err(InputError::limit(input))?;
        check_positions(&process, "tool_positions_mm", &tool_positions_mm, false)
            .map_err(InputError::schedule(input))?;
        Ok(RemovalFunctionCommand {
            process,
            grid,
            tool_positions_mm,
        })
    }

    /// The process on its part.
    pub fn process(&self) -> &Process {
        &self.process
    }
}

/// One profile: the removal rate at each grid radius for a tool centred at `tool_position_mm`.
#[derive(Debug, Clone, PartialEq)]
pub struct RateProfile {
    pub tool_position_mm: f64,
    pub removal_rate_nm_per_min: Vec<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct RemovalFunction {
    /// η; `None` when the tool is stationary.
    pub eta: Option<f64>,
    pub grid: RadialGrid,
    /// Arc length from the vertex of each grid radius, mm; `None` on a plane.
    pub arc_length_mm: Option<Vec<f64>>,
    /// In the order of the command's positions.
    pub profiles: Vec<RateProfile>,
    /// Likely unit mistakes in the process or the positions.
    pub warnings: Vec<Warning>,
}

pub fn removal_function(command: RemovalFunctionCommand) -> RemovalFunction {
    let RemovalFunctionCommand {
        process,
        grid,
        tool_positions_mm,
    } = command;
    let warnings = unit_warnings(&process, &tool_positions_mm);
    let kernel = RemovalKernel::new(&process);
    let radii = grid.radii_mm();
    let rings = kernel.rings(radii);
    let profiles = tool_positions_mm
        .iter()
        .map(|&r1| {
            let mut rates = vec![0.0; radii.len()];
            kernel.fill_column(r1, radii, rings.as_deref(), &mut rates);
            RateProfile {
                tool_position_mm: r1,
                removal_rate_nm_per_min: rates.into_iter().map(|rate| 60.0 * rate).collect(),
            }
        })
        .collect();
    RemovalFunction {
        eta: process.eta().value(),
        arc_length_mm: process.arc_lengths_mm(radii),
        grid,
        profiles,
        warnings,
    }
}
