//! Where a map analysis's inputs sit in its request.

use super::super::error::{ApiError, Kind};
use crate::maps::analysis::AnalysisError;
use crate::usecases::map_analysis::{MapInput, MapInputError};

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
