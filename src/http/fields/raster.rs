//! Where the X-Y machine's inputs sit in the map requests (`machine.kinematics: cartesian`).

use super::super::error::ApiError;
use crate::machine::GcodeFormatError;
use crate::physics::raster::RasterError;
use crate::usecases::raster::RasterInputError;
use crate::usecases::raster_optimize::{RasterBound, RasterOptimizeError};
use crate::usecases::raster_predict::RasterPredictError;
use crate::usecases::raster_program::RasterProgramInputError;

impl From<RasterInputError> for ApiError {
    fn from(e: RasterInputError) -> Self {
        let field = match &e {
            RasterInputError::SpotPixel | RasterInputError::SpotPixelRange(_) => {
                "influence.map.pixel_mm"
            }
            RasterInputError::SpotDuration(_) => "influence.duration_s",
            RasterInputError::SpotCentre(_) => "influence.centre_px",
            RasterInputError::SpotEmpty
            | RasterInputError::Influence(_)
            | RasterInputError::SpotRate(_) => "influence.map",
            RasterInputError::Height(_) => "map",
            RasterInputError::MapPixel
            | RasterInputError::Pixel(_)
            | RasterInputError::PixelRange(_) => "pixel_mm",
            RasterInputError::DwellPitch(_) | RasterInputError::TooManyPoints { .. } => {
                "dwell_pitch_mm"
            }
            RasterInputError::TooManyPixels { .. } => "map",
        };
        ApiError::invalid(field, e.to_string())
    }
}

impl From<RasterOptimizeError> for ApiError {
    fn from(e: RasterOptimizeError) -> Self {
        let field = match &e {
            RasterOptimizeError::Input(input) => return input.clone().into(),
            RasterOptimizeError::Bound { bound, .. } => match bound {
                RasterBound::MinDwell => "constraints.min_dwell_s",
                RasterBound::MaxDwell => "constraints.max_dwell_s",
                RasterBound::MaxTotalTime => "constraints.max_total_time_s",
            },
            RasterOptimizeError::FloorAboveCeiling { .. } => "constraints.max_dwell_s",
            RasterOptimizeError::TotalBelowFloors { .. } => "constraints.max_total_time_s",
            RasterOptimizeError::NoAperture => "map",
        };
        ApiError::invalid(field, e.to_string())
    }
}

impl From<RasterPredictError> for ApiError {
    fn from(e: RasterPredictError) -> Self {
        let field = match &e {
            RasterPredictError::Input(input) => return input.clone().into(),
            RasterPredictError::Lengths { .. } => "dwell.dwell_s".to_string(),
            RasterPredictError::Dwell { index, .. } => format!("dwell.dwell_s[{index}]"),
            RasterPredictError::OffLattice { index, .. } | RasterPredictError::Point { index } => {
                format!("dwell.points_mm[{index}]")
            }
            RasterPredictError::Raster(RasterError::Repeated { next, .. }) => {
                format!("dwell.points_mm[{next}]")
            }
            RasterPredictError::Raster(RasterError::OffLattice { point, .. }) => {
                format!("dwell.points_mm[{point}]")
            }
            RasterPredictError::Raster(RasterError::Empty)
            | RasterPredictError::TooManyPoints { .. } => "dwell.points_mm".to_string(),
        };
        ApiError::invalid(field, e.to_string())
    }
}

impl From<RasterProgramInputError> for ApiError {
    fn from(e: RasterProgramInputError) -> Self {
        use RasterProgramInputError as E;
        let detail = e.to_string();
        let field = match e {
            E::Plan(plan) => return plan.into(),
            E::Limits(l) => super::limit_field(l.drive, l.limit),
            E::Format(GcodeFormatError::Decimals) => "format.decimals".to_string(),
            E::Format(GcodeFormatError::Word { word, .. }) => {
                format!("format.tool_spindle.{word}")
            }
            E::Clearance => "approach.clearance_mm".to_string(),
            E::ApproachFeed => "approach.feed_mm_per_min".to_string(),
            E::ToolRpm(_) => "tool_rpm".to_string(),
            E::Surface(e) => return super::surface_error(e),
            E::PointOffSurface { index, .. } => format!("dwell.points_mm[{index}]"),
        };
        ApiError::invalid(field, detail)
    }
}
