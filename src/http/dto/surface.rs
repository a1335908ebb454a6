//! The design surface as requests give it.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::extract::count;
use crate::surface::{PolynomialTerm, SurfaceSpec};

/// The design surface. z runs along the rotation axis, positive toward the tool; R > 0 puts
/// the centre of curvature on the tool side (concave as the tool sees it), R < 0 convex.
/// Sag z(r) = c·r²/(1 + √(1 − (1+k)·c²·r²)) + Σ aᵢ·|r|^i with c = 1/R (ISO 10110-12); the
/// square root must stay real over the part.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SurfaceDto {
    /// A plane.
    Plane {},
    /// A sphere of vertex radius R (mm, ≠ 0).
    Sphere {
        radius_of_curvature_mm: f64,
        /// d: the vertex's distance from the C axis along +x, mm (≥ 0; default 0), so the sag
        /// in C's frame is z(x + d, y) − z(d). A part decentred (d > 0) is not round about C:
        /// only `/v1/maps/optimize`, `/v1/maps/predict` and `/v1/maps/program` take it, Z and
        /// B following it within each turn as on segments. 0 is today's part of revolution.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        #[schema(minimum = 0.0)]
        decenter_mm: Option<f64>,
    },
    /// An even asphere with optional polynomial terms of any power 1–40.
    Asphere {
        /// Vertex radius R, mm (≠ 0).
        radius_of_curvature_mm: f64,
        /// Conic constant k (0 sphere, −1 paraboloid, < −1 hyperboloid). Default 0.
        #[serde(default)]
        conic_constant: f64,
        /// Polynomial terms aᵢ·|r|^i, each power once. Default none.
        #[serde(default)]
        coefficients: Vec<CoefficientDto>,
        /// d: the vertex's distance from the C axis along +x, mm (≥ 0; default 0), as a
        /// sphere's.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        #[schema(minimum = 0.0)]
        decenter_mm: Option<f64>,
    },
}

impl SurfaceDto {
    /// The decentre asked, if any (0 included).
    pub fn decenter_mm(&self) -> Option<f64> {
        match self {
            SurfaceDto::Plane {} => None,
            SurfaceDto::Sphere { decenter_mm, .. } | SurfaceDto::Asphere { decenter_mm, .. } => {
                *decenter_mm
            }
        }
    }
}

/// One polynomial term aᵢ·|r|^i.
#[derive(Debug, Clone, Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CoefficientDto {
    /// The power i, 1 to 40.
    #[serde(deserialize_with = "count")]
    #[schema(value_type = u32, minimum = 1, maximum = 40)]
    pub power: usize,
    /// aᵢ in mm^(1−i).
    pub value: f64,
}

impl From<&SurfaceDto> for SurfaceSpec {
    fn from(s: &SurfaceDto) -> Self {
        match s {
            SurfaceDto::Plane {} => SurfaceSpec::Plane,
            SurfaceDto::Sphere {
                radius_of_curvature_mm,
                ..
            } => SurfaceSpec::Sphere {
                radius_of_curvature_mm: *radius_of_curvature_mm,
            },
            SurfaceDto::Asphere {
                radius_of_curvature_mm,
                conic_constant,
                coefficients,
                ..
            } => SurfaceSpec::Asphere {
                radius_of_curvature_mm: *radius_of_curvature_mm,
                conic_constant: *conic_constant,
                coefficients: coefficients
                    .iter()
                    .map(|c| PolynomialTerm {
                        // Beyond u32 is beyond 1–40: refused by the surface check.
                        power: u32::try_from(c.power).unwrap_or(u32::MAX),
                        value: c.value,
                    })
                    .collect(),
            },
        }
    }
}
