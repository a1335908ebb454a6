//! What a run removed, from the maps before and after it (`maps::difference`).

use super::map_analysis::{
    check_bands, check_on_map, MapInput, MapInputError, MapOrigin, Placement,
};
use super::warnings::map_dropouts;
use super::{ComputeLimits, Warning};
use crate::maps::analysis::{Band, Pixel};
use crate::maps::aperture::{Alignment, Aperture};
use crate::maps::difference::{self, DifferenceError, DifferencePlan, MapDifference};
use crate::maps::HeightMap;

/// A difference as asked (`None`: the default).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MapDifferenceSpec {
    /// The before map's placement; the after map shares its pitch, rotation and mirror.
    pub placement: Placement,
    /// The after map's centre less the before map's, pixels. Default: each map's centre as
    /// given (the same), else fitted to its own boundary.
    pub after_offset_px: Option<(f64, f64)>,
    /// Default: a circle of the part's radius.
    pub aperture: Option<Aperture>,
    /// Default false.
    pub remove_tilt: Option<bool>,
    /// Default `Band::defaults`.
    pub bands: Option<Vec<Band>>,
}

/// Which map an input error is about.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DifferenceInputError {
    #[error("{0}")]
    Before(MapInputError),
    #[error("{0}")]
    After(MapInputError),
    #[error("the after map's offset must be finite pixels")]
    Offset,
    /// The after map, registered by the offset given, does not hold the aperture.
    #[error("{0}")]
    OffsetOffMap(MapInputError),
}

/// A checked difference.
#[derive(Debug, Clone)]
pub struct MapDifferenceCommand {
    before: HeightMap,
    after: HeightMap,
    origins: (MapOrigin, MapOrigin),
    plan: DifferencePlan,
}

/// The difference, and what was read.
#[derive(Debug, Clone)]
pub struct MapDifferenceResult {
    pub origins: (MapOrigin, MapOrigin),
    pub difference: MapDifference,
    pub warnings: Vec<Warning>,
}

impl MapDifferenceCommand {
    pub fn new(
        before: (HeightMap, MapOrigin),
        after: (HeightMap, MapOrigin),
        spec: MapDifferenceSpec,
        _limits: &ComputeLimits,
    ) -> Result<Self, DifferenceInputError> {
        use DifferenceInputError as E;
        let (before, before_origin) = before;
        let (after, after_origin) = after;
        let (before_alignment, _) = spec.placement.place(&before).map_err(E::Before)?;
        let after_alignment = match spec.after_offset_px {
            Some((dx, dy)) => {
                if !(dx.is_finite() && dy.is_finite()) {
                    return Err(E::Offset);
                }
                Alignment {
                    centre_px: (
                        before_alignment.centre_px.0 + dx,
                        before_alignment.centre_px.1 + dy,
                    ),
                    ..before_alignment
                }
            }
            None => {
                // The same given centre, or the after map's own boundary; its pitch is the
                // before map's unless its file states one.
                let placement = Placement {
                    pixel_mm: Some(before_alignment.pixel_mm),
                    part_radius_mm: Some(before_alignment.part_radius_mm),
                    ..spec.placement
                };
                placement.place(&after).map_err(E::After)?.0
            }
        };
        let aperture = spec.aperture.unwrap_or(Aperture::Circle {
            radius_mm: before_alignment.part_radius_mm,
        });
        check_on_map(&before, &before_alignment, &aperture).map_err(E::Before)?;
        check_on_map(&after, &after_alignment, &aperture).map_err(|e| {
            if spec.after_offset_px.is_some() {
                E::OffsetOffMap(e)
            } else {
                E::After(e)
            }
        })?;
        let bands = match spec.bands {
            Some(bands) => check_bands(bands).map_err(E::Before)?,
            None => Band::defaults(
                2.0 * aperture.normalization_radius_mm(),
                before_alignment.pixel_mm,
            ),
        };
        Ok(MapDifferenceCommand {
            before,
            after,
            origins: (before_origin, after_origin),
            plan: DifferencePlan {
                before: before_alignment,
                after: after_alignment,
                aperture,
                remove_tilt: spec.remove_tilt.unwrap_or(false),
                bands,
            },
        })
    }
}

impl DifferenceInputError {
    /// The map at fault (`true`: the after map) and the input.
    pub fn input(&self) -> (bool, MapInput) {
        match self {
            DifferenceInputError::Before(e) => (false, e.input()),
            DifferenceInputError::After(e) => (true, e.input()),
            DifferenceInputError::Offset => (true, MapInput::Centre),
            DifferenceInputError::OffsetOffMap(e) => (true, e.input()),
        }
    }
}

/// The difference.
pub fn map_difference(
    command: MapDifferenceCommand,
) -> Result<MapDifferenceResult, DifferenceError> {
    let difference = difference::difference(&command.before, &command.after, command.plan)?;
    let warnings = map_dropouts(difference.pixels.len(), difference.area_pixels);
    Ok(MapDifferenceResult {
        origins: command.origins,
        difference,
        warnings,
    })
}

/// The removal at the compared pixels alone (`maps::difference::removal_pixels`), without the
/// difference's figures: what a calibration fits.
pub fn map_removal_pixels(command: &MapDifferenceCommand) -> Result<Vec<Pixel>, DifferenceError> {
    difference::removal_pixels(&command.before, &command.after, &command.plan)
}
