//! How large a computation may be: grid sizes, operator sizes, the solver's time budget.

use std::time::Duration;

/// Sizes and times the use cases refuse to exceed. The service configures them (flags and
/// environment variables); the defaults are the documented ones.
#[derive(Debug, Clone, PartialEq)]
pub struct ComputeLimits {
    /// Largest radial grid (samples).
    pub max_radial_samples: usize,
    /// Most tool positions in one computation (dwell or removal-function profiles).
    pub max_positions: usize,
    /// Most removal-function profiles.
    pub max_profiles: usize,
    /// Largest removal operator, radial samples × tool positions.
    pub max_operator_entries: usize,
    /// Most candidate positions in one optimization (bounds the rows of its QP and the rare
    /// fallback to a variable per position, whose Hessian is dense within the band).
    pub max_optimize_positions: usize,
    /// Most η values in one sweep.
    pub max_etas: usize,
    /// Most points in one measured trace.
    pub max_trace_points: usize,
    /// Longest a dwell optimization may spend in the solver (feasibility LP and QP together).
    pub solver_time_limit: Duration,
    /// Most pixels in one interferometer map.
    pub max_map_pixels: usize,
    /// Most work in one Zernike fit: the aperture's valid pixels × terms² (the Gram matrix's
    /// multiply-adds; 5·10¹⁰ is about 5 s on 2 cores).
    pub max_zernike_work: f64,
}

impl Default for ComputeLimits {
    fn default() -> Self {
        ComputeLimits {
            max_radial_samples: 10_001,
            max_positions: 10_001,
            max_profiles: 201,
            max_operator_entries: 25_000_000,
            max_optimize_positions: 2001,
            max_etas: 201,
            max_trace_points: 100_000,
            solver_time_limit: Duration::from_secs(10),
            max_map_pixels: 16_777_216,
            max_zernike_work: 5e10,
        }
    }
}

/// A size beyond the limits, with the numbers a message needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SizeLimitError {
    #[error("{count} radial samples; this server allows at most {max}")]
    RadialSamples { count: usize, max: usize },
    #[error("{count} positions; this server allows at most {max}")]
    Positions { count: usize, max: usize },
    #[error(
        "{samples} radial samples × {positions} tool positions: this server allows at most {max} \
         removal-operator entries"
    )]
    OperatorEntries {
        samples: usize,
        positions: usize,
        max: usize,
    },
    #[error("{count} profiles; this server allows at most {max}")]
    Profiles { count: usize, max: usize },
    #[error("{count} positions to optimize; this server allows at most {max}")]
    OptimizePositions { count: usize, max: usize },
    #[error("{count} η values; this server allows 1 to {max}")]
    Etas { count: usize, max: usize },
    #[error("{count} trace points; this server allows at most {max}")]
    TracePoints { count: usize, max: usize },
    #[error("{count} runs; a calibration takes 1 to {max}")]
    Runs { count: usize, max: usize },
}

impl ComputeLimits {
    pub fn check_radial_samples(&self, count: usize) -> Result<(), SizeLimitError> {
        let max = self.max_radial_samples;
        (count <= max)
            .then_some(())
            .ok_or(SizeLimitError::RadialSamples { count, max })
    }

    /// An operator of `samples` radial samples × `positions` tool positions.
    pub fn check_operator(&self, samples: usize, positions: usize) -> Result<(), SizeLimitError> {
        self.check_positions(positions)?;
        if samples.saturating_mul(positions) > self.max_operator_entries {
            return Err(SizeLimitError::OperatorEntries {
                samples,
                positions,
                max: self.max_operator_entries,
            });
        }
        Ok(())
    }

    /// Tool positions in one computation (a dwell plan, removal-function profiles).
    pub fn check_positions(&self, count: usize) -> Result<(), SizeLimitError> {
        let max = self.max_positions;
        (count <= max)
            .then_some(())
            .ok_or(SizeLimitError::Positions { count, max })
    }

    pub fn check_profiles(&self, count: usize) -> Result<(), SizeLimitError> {
        let max = self.max_profiles;
        (count <= max)
            .then_some(())
            .ok_or(SizeLimitError::Profiles { count, max })
    }

    pub fn check_optimize_positions(&self, count: usize) -> Result<(), SizeLimitError> {
        let max = self.max_optimize_positions;
        (count <= max)
            .then_some(())
            .ok_or(SizeLimitError::OptimizePositions { count, max })
    }

    pub fn check_etas(&self, count: usize) -> Result<(), SizeLimitError> {
        let max = self.max_etas;
        (1..=max)
            .contains(&count)
            .then_some(())
            .ok_or(SizeLimitError::Etas { count, max })
    }

    pub fn check_trace_points(&self, count: usize) -> Result<(), SizeLimitError> {
        let max = self.max_trace_points;
        (count <= max)
            .then_some(())
            .ok_or(SizeLimitError::TracePoints { count, max })
    }
}
