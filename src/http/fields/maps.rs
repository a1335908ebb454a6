//! Where a map analysis's inputs sit in its request.

use super::super::error::{ApiError, Kind};
use crate::machine::servo::ServoLimit;
use crate::maps::analysis::AnalysisError;
use crate::maps::difference::DifferenceError;
use crate::physics::SectorLawError;
use crate::usecases::map_analysis::{MapInput, MapInputError};
use crate::usecases::map_difference::DifferenceInputError;
use crate::usecases::map_optimize::{MapOptimizeError, MapOptimizeInputError, ServoError};
use crate::usecases::map_predict::{CLawError, MapPredictInputError};
use crate::usecases::map_program::MapProgramInputError;
use crate::usecases::map_removal_function::FootprintInputError;

fn field(input: MapInput) -> &'static str {
    match input {
        MapInput::PixelSize => "pixel_mm",
        MapInput::Centre => "alignment.centre_x_px",
        MapInput::PartRadius => "alignment.part_radius_mm",
        MapInput::Rotation => "alignment.rotation_deg",
        MapInput::Aperture => "clear_aperture",
        MapInput::Terms => "zernike.terms",
        MapInput::Bands => "psd.bands",
        MapInput::FringeWavelength => "fringe_wavelength_nm",
    }
}

impl From<MapInputError> for ApiError {
    fn from(err: MapInputError) -> Self {
        let at = field(err.input());
        match err {
            MapInputError::TooMuchWork { .. } => ApiError::limit(at, err.to_string()),
            _ => ApiError::invalid(at, err.to_string()),
        }
    }
}

/// A map removal function's own inputs by their fields; the setting's as the radial one's.
impl From<FootprintInputError> for ApiError {
    fn from(err: FootprintInputError) -> Self {
        let at = match &err {
            FootprintInputError::Setting(setting) => return setting.clone().into(),
            FootprintInputError::PositionNotFinite(_)
            | FootprintInputError::PositionOutOfReach { .. } => "tool_position_mm",
            FootprintInputError::Pixel(_) => "pixel_mm",
            FootprintInputError::PartTurning(_) => "process.workpiece_rpm",
            FootprintInputError::TooManyPixels { .. } => {
                return ApiError::limit("pixel_mm", err.to_string())
            }
        };
        ApiError::invalid(at, err.to_string())
    }
}

/// Where a C law's problem sits in a request's `c_law`.
pub(super) fn c_law_field(err: &CLawError) -> String {
    match err {
        CLawError::Rows { .. } => "c_law.speed_factors".to_string(),
        CLawError::Row { station, .. } => format!("c_law.speed_factors[{station}]"),
        CLawError::Law(SectorLawError::NoSectors | SectorLawError::TooManySectors(_)) => {
            "c_law.sectors".to_string()
        }
        CLawError::Law(SectorLawError::Shape { .. }) => "c_law.speed_factors".to_string(),
        CLawError::Law(SectorLawError::Factor {
            station, sector, ..
        }) => format!("c_law.speed_factors[{station}][{sector}]"),
    }
}

/// A polar program's own inputs by their fields; a radial program's as `/v1/program`'s.
impl From<MapProgramInputError> for ApiError {
    fn from(err: MapProgramInputError) -> Self {
        use MapProgramInputError as E;
        let at = match &err {
            E::Law(law) => c_law_field(law),
            E::StartAngle(_) => "start_angle_deg".to_string(),
            E::Servo(servo) => servo_field(servo).to_string(),
            E::TooManyBlocks { .. } => {
                return ApiError::limit("c_law.sectors", err.to_string());
            }
            E::ApproachTooLong { .. } => {
                return ApiError::limit("approach.feed_mm_per_min", err.to_string());
            }
        };
        ApiError::invalid(at, err.to_string())
    }
}

/// A polar prediction's own inputs by their fields; the plan's and the setting's as
/// `/v1/predict`'s.
impl From<MapPredictInputError> for ApiError {
    fn from(err: MapPredictInputError) -> Self {
        use MapPredictInputError as E;
        let at = match &err {
            E::Setting(setting) => return setting.clone().into(),
            E::Law(law) => c_law_field(law),
            E::StartAngle(_) => "start_angle_deg".to_string(),
            E::Pixel(_) => "pixel_mm".to_string(),
            E::Segments(_) => "process.pressure_model".to_string(),
            E::TooManyPixels { .. } | E::TooMuchWork { .. } | E::SegmentsTooMuchWork { .. } => {
                return ApiError::limit("pixel_mm", err.to_string())
            }
        };
        ApiError::invalid(at, err.to_string())
    }
}

/// A difference's input errors: the before map's placement is the request's `alignment`,
/// the after map's its `after_offset_px` (or `alignment` again); each map named by its field.
impl From<DifferenceInputError> for ApiError {
    fn from(err: DifferenceInputError) -> Self {
        let (after, input) = err.input();
        let at = match (&err, after, input) {
            (DifferenceInputError::Offset | DifferenceInputError::OffsetOffMap(_), ..) => {
                "after_offset_px"
            }
            // The after map's centre is fitted, or the before map's shifted: the map is at fault.
            (_, true, MapInput::Centre) => "after",
            (_, _, input) => field(input),
        };
        let message = if after {
            format!("the after map: {err}")
        } else {
            err.to_string()
        };
        ApiError::invalid(at, message)
    }
}

impl From<DifferenceError> for ApiError {
    fn from(err: DifferenceError) -> Self {
        let at = match err {
            DifferenceError::TooLittleOverlap(_) => "after_offset_px",
            DifferenceError::NoRadialProfile => "clear_aperture",
        };
        ApiError::invalid(at, err.to_string())
    }
}

/// Found by computing: the aperture's pixels cannot carry the fit asked for.
impl From<AnalysisError> for ApiError {
    fn from(err: AnalysisError) -> Self {
        let at = match err {
            AnalysisError::Zernike(_) => "zernike.terms",
            AnalysisError::NoRadialProfile => "clear_aperture",
        };
        ApiError::new(Kind::InvalidInput, err.to_string()).at(at)
    }
}

/// A map correction's own inputs by their fields; the plan's and the setting's as
/// `/v1/optimize`'s, the map's placement as the analysis's.
impl From<MapOptimizeInputError> for ApiError {
    fn from(err: MapOptimizeInputError) -> Self {
        use MapOptimizeInputError as E;
        let at = match &err {
            E::Setting(setting) => return setting.clone().into(),
            E::Map(map) => return map.clone().into(),
            E::Sectors(_) => "c_law.sectors",
            E::MaxHarmonic { .. } => "c_law.max_harmonic",
            E::MaxModulation(_) => "c_law.max_modulation",
            E::Pixel(_) => "removal_pixel_mm",
            E::CTooSlow { .. } => "machine.c.max_velocity_deg_per_min",
            E::MapTooSmall { .. } | E::SegmentsMapTooSmall { .. } => "map",
            E::TooMuchWork { .. } => return ApiError::limit("c_law.max_harmonic", err.to_string()),
            E::Segments(_) => "process.pressure_model",
            E::Servo(servo) => servo_field(servo),
        };
        ApiError::invalid(at, err.to_string())
    }
}

/// The limit of Z that a plan's rings on segments break.
fn servo_field(err: &ServoError) -> &'static str {
    match err {
        ServoError::Speed { limit, .. } => match limit {
            ServoLimit::Velocity => "machine.z.max_velocity_mm_per_min",
            ServoLimit::Acceleration => "machine.z.max_acceleration_mm_per_s2",
        },
        ServoError::Travel(_) => "machine.z.max_mm",
    }
}

/// A correction found too large to compute names the sectors that cut it; else as the
/// optimizer's problems.
impl From<MapOptimizeError> for ApiError {
    fn from(err: MapOptimizeError) -> Self {
        match err {
            MapOptimizeError::Optimize(e) => e.into(),
            MapOptimizeError::TooManyBlocks { .. } => {
                ApiError::limit("c_law.sectors", err.to_string())
            }
            MapOptimizeError::ExactMapTooCostly { .. } => {
                ApiError::limit("removal_model", err.to_string())
            }
            MapOptimizeError::ProgramLimits(found) => {
                super::machine_limits_error(&found, "plan's program would")
            }
        }
    }
}
