//! Where the axes stand for a pad centred on a surface point (module docs of [`super`]).

use crate::surface::Surface;

/// How the tool spindle is carried: `Normal` (B follows the surface normal) or `Vertical`
/// (B = 0). The same choice sets the pad's spin axis in the removal model.
pub use crate::physics::Orientation;

/// The tool as the machine carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tool {
    pivot_length_mm: f64,
    orientation: Orientation,
}

/// The pivot at the pad face, B following the normal.
impl Default for Tool {
    fn default() -> Self {
        Tool {
            pivot_length_mm: 0.0,
            orientation: Orientation::Normal,
        }
    }
}

/// Why a tool description was refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ToolError {
    #[error("pivot_length_mm must be a finite number from 0 to {max} mm")]
    PivotLength { max: f64 },
}

/// Longest pivot length accepted, mm (a 10 m arm is no polishing machine).
pub const MAX_PIVOT_LENGTH_MM: f64 = 10_000.0;

/// Axis positions: X and Z in mm, B in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub x_mm: f64,
    pub z_mm: f64,
    pub b_deg: f64,
}

impl Pose {
    /// The axis values in the order X, Z, B.
    pub fn axes(&self) -> [f64; 3] {
        [self.x_mm, self.z_mm, self.b_deg]
    }
}

impl Tool {
    /// `pivot_length_mm`: from the pad face centre to the B pivot, along the tool axis (≥ 0).
    pub fn new(pivot_length_mm: f64, orientation: Orientation) -> Result<Tool, ToolError> {
        if !(0.0..=MAX_PIVOT_LENGTH_MM).contains(&pivot_length_mm) {
            return Err(ToolError::PivotLength {
                max: MAX_PIVOT_LENGTH_MM,
            });
        }
        Ok(Tool {
            pivot_length_mm,
            orientation,
        })
    }

    pub fn pivot_length_mm(&self) -> f64 {
        self.pivot_length_mm
    }

    pub fn orientation(&self) -> Orientation {
        self.orientation
    }

    /// The pose that puts the pad's centre on the surface point at radius `r_mm`.
    pub fn pose(&self, surface: &Surface, r_mm: f64) -> Pose {
        self.pose_at(r_mm, surface.sag_mm(r_mm), surface.slope_angle_rad(r_mm))
    }

    /// The pose that puts the pad's centre at radius `r_mm` and height `z_mm`, its axis (when
    /// B follows) at `slope_angle_rad` from Z in the plane through C: the surface's radial
    /// slope there, atan ∂z/∂r.
    pub fn pose_at(&self, r_mm: f64, z_mm: f64, slope_angle_rad: f64) -> Pose {
        let (z, l) = (z_mm, self.pivot_length_mm);
        match self.orientation {
            Orientation::Vertical => Pose {
                x_mm: r_mm,
                z_mm: z + l,
                b_deg: 0.0,
            },
            Orientation::Normal => {
                let theta = slope_angle_rad;
                let (sin, cos) = theta.sin_cos();
                Pose {
                    x_mm: r_mm - l * sin,
                    z_mm: z + l * cos,
                    b_deg: theta.to_degrees(),
                }
            }
        }
    }

    /// Where the pad face centre is for a pose (the inverse of [`Tool::pose`] for the point).
    pub fn pad_centre(&self, pose: &Pose) -> (f64, f64) {
        let (sin, cos) = pose.b_deg.to_radians().sin_cos();
        let l = self.pivot_length_mm;
        match self.orientation {
            Orientation::Vertical => (pose.x_mm, pose.z_mm - l),
            Orientation::Normal => (pose.x_mm + l * sin, pose.z_mm - l * cos),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::SurfaceSpec;

    #[test]
    fn pad_centre_inverts_the_pose() {
        let sphere = Surface::new(&SurfaceSpec::Sphere {
            radius_of_curvature_mm: -80.0,
        })
        .unwrap();
        for orientation in [Orientation::Normal, Orientation::Vertical] {
            let tool = Tool::new(35.0, orientation).unwrap();
            for r in [0.0, 10.0, 40.0, 70.0] {
                let (x, z) = tool.pad_centre(&tool.pose(&sphere, r));
                assert!((x - r).abs() < 1e-12 && (z - sphere.sag_mm(r)).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn pivot_length_is_checked() {
        assert!(Tool::new(-1.0, Orientation::Normal).is_err());
        assert!(Tool::new(f64::NAN, Orientation::Normal).is_err());
        assert!(Tool::new(0.0, Orientation::Normal).is_ok());
    }
}
