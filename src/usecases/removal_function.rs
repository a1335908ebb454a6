//! The removal function: R(r; r1) across the radial grid for each requested tool position.

use super::setting::process_and_grid;
use super::{ComputeLimits, GridSpec, Input, InputError};
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
        grid: GridSpec,
        tool_positions_mm: Vec<f64>,
        limits: &ComputeLimits,
    ) -> Result<Self, InputError> {
        let (process, grid) = process_and_grid(process, grid, limits)?;
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
}

/// One profile: the removal rate at each grid radius for a tool centred at `tool_position_mm`.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    pub tool_position_mm: f64,
    pub removal_rate_nm_per_min: Vec<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct RemovalFunction {
    /// η; `None` when the tool is stationary.
    pub eta: Option<f64>,
    pub grid: RadialGrid,
    /// In the order of the command's positions.
    pub profiles: Vec<Profile>,
}

pub fn removal_function(command: RemovalFunctionCommand) -> RemovalFunction {
    let RemovalFunctionCommand {
        process,
        grid,
        tool_positions_mm,
    } = command;
    let kernel = RemovalKernel::new(&process);
    let profiles = tool_positions_mm
        .iter()
        .map(|&r1| {
            let factor = kernel.pressure_factor(r1);
            Profile {
                tool_position_mm: r1,
                removal_rate_nm_per_min: grid
                    .radii_mm()
                    .iter()
                    .map(|&r| 60.0 * factor * kernel.nominal_rate_nm_per_s(r, r1))
                    .collect(),
            }
        })
        .collect();
    RemovalFunction {
        eta: process.eta().value(),
        grid,
        profiles,
    }
}
