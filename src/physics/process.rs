//! The polishing process: geometry, speeds, Preston coefficient and pressure, validated once.
//!
//! Speeds come in one lab frame, signed r/min, counter-clockwise positive (seen from the tool
//! side). The source paper (Chen, Wang, Liu 2013) counts the workpiece speed ω1 positive
//! *clockwise* and the tool speed ω2 positive *counter-clockwise*, and writes η = ω1/ω2. So
//!
//! ```text
//! ω1 = −workpiece_rpm · 2π/60,   ω2 = tool_rpm · 2π/60,   η = −workpiece_rpm / tool_rpm
//! ```
//!
//! and η = −1 means workpiece and tool turning the same physical way at the same speed.
//! A [`Process`] can only be built through [`Process::new`], which rejects every input the
//! radial model cannot honour; code holding a `Process` never re-checks it.

use std::f64::consts::PI;

use super::curved::Part;
use super::pressure::{linear_lift_onset_mm, linear_reach_mm, PressureModel, PressureModelKind};
use crate::surface::SurfaceError;

/// Raw process parameters as a caller supplies them (units in the names).
#[derive(Debug, Clone, PartialEq)]
pub struct ProcessSpec {
    pub workpiece_radius_mm: f64,
    pub tool_radius_mm: f64,
    /// Signed, lab frame, counter-clockwise positive.
    pub workpiece_rpm: f64,
    /// Signed, lab frame, counter-clockwise positive.
    pub tool_rpm: f64,
    /// Preston coefficient K in m²/N (= 1/Pa).
    pub preston_coefficient_m2_per_n: f64,
    /// Nominal pad pressure in kPa (with the whole pad on the workpiece).
    pub pressure_kpa: f64,
    pub pressure_model: PressureModel,
    /// The part's surface and the pad's spin axis (default: a plane). On a curved part the
    /// radii stay radial coordinates of surface points; the workpiece radius is the edge's.
    pub part: Part,
}

impl ProcessSpec {
    /// The same process with the tool speed held and the workpiece turning at the speed that
    /// gives the paper's ratio η: workpiece_rpm = −η·tool_rpm.
    pub fn with_eta(&self, eta: f64) -> ProcessSpec {
        ProcessSpec {
            workpiece_rpm: -eta * self.tool_rpm,
            ..self.clone()
        }
    }
}

/// Why a [`ProcessSpec`] does not describe a process the radial model can compute.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProcessError {
    /// The surface does not hold the pad wherever it may go: it must be defined (slope below
    /// 90°) out to the arc length `reach_arc_mm` from the vertex.
    #[error(
        "the surface must hold the pad wherever it may go, out to {reach_arc_mm} mm of arc from \
         the vertex (the workpiece edge plus {overhang} the pad radius along the surface): {error}"
    )]
    SurfaceReach {
        reach_arc_mm: f64,
        overhang: &'static str,
        error: SurfaceError,
    },
    #[error("the surface must reach the workpiece edge: {0}")]
    SurfaceEdge(SurfaceError),
    #[error("{field} must be a finite number")]
    NonFinite { field: &'static str },
    #[error("{field} must be greater than zero")]
    NonPositiveRadius { field: &'static str },
    #[error("pressure_kpa must be greater than zero")]
    NonPositivePressure,
    #[error("preston_coefficient_m2_per_n must not be negative")]
    NegativePrestonCoefficient,
    #[error(
        "workpiece_rpm must not be 0: the radial removal model averages over workpiece \
         revolutions, which a stationary workpiece never makes"
    )]
    StationaryWorkpiece,
    #[error("pad_moment_share must be a number in [0, 1] (the pad's share of the tipping moment)")]
    MomentShare,
    #[error("{field} = {value} is outside the range the model computes, [{min}, {max}] {unit}")]
    OutOfRange {
        field: &'static str,
        value: f64,
        min: f64,
        max: f64,
        unit: &'static str,
    },
}

/// The domain a process must lie in. Far wider than any polishing machine (a 100 m optic,
/// 100,000 r/min, 1 GPa), it keeps every intermediate and every result finite in f64: outside
/// it removal rates can overflow to infinity, which JSON cannot carry.
pub const RADIUS_RANGE_MM: (f64, f64) = (1e-3, 1e5);
pub const RPM_MAX: f64 = 1e5;
pub const PRESTON_COEFFICIENT_MAX_M2_PER_N: f64 = 1e-6;
pub const PRESSURE_MAX_KPA: f64 = 1e6;

impl ProcessError {
    /// The input field the error is about.
    pub fn field(&self) -> &'static str {
        match self {
            ProcessError::NonFinite { field }
            | ProcessError::NonPositiveRadius { field }
            | ProcessError::OutOfRange { field, .. } => field,
            ProcessError::NonPositivePressure => "pressure_kpa",
            ProcessError::NegativePrestonCoefficient => "preston_coefficient_m2_per_n",
            ProcessError::StationaryWorkpiece => "workpiece_rpm",
            ProcessError::MomentShare => "pad_moment_share",
            ProcessError::SurfaceReach { .. } | ProcessError::SurfaceEdge(_) => {
                "workpiece_radius_mm"
            }
        }
    }
}

impl PressureModel {
    /// The model `kind` names, with the pad's share κ of the tipping moment (default 1, a free
    /// gimbal). κ is used by `Linear` alone, but must lie in [0, 1] whatever the model: a
    /// mistyped κ is refused, never silently dropped.
    pub fn parse(
        kind: PressureModelKind,
        pad_moment_share: Option<f64>,
    ) -> Result<PressureModel, ProcessError> {
        let share = pad_moment_share.unwrap_or(1.0);
        if !(0.0..=1.0).contains(&share) {
            return Err(ProcessError::MomentShare);
        }
        Ok(match kind {
            PressureModelKind::Uniform => PressureModel::Uniform,
            PressureModelKind::ConstantForce => PressureModel::ConstantForce,
            PressureModelKind::Linear => PressureModel::Linear {
                pad_moment_share: share,
            },
        })
    }
}

/// The speed ratio η = ω1/ω2 in the paper's convention.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Eta {
    Defined(f64),
    /// The tool does not spin (tool_rpm = 0): η = ω1/0 has no value. Removal is still defined.
    ToolStationary,
}

impl Eta {
    pub fn value(self) -> Option<f64> {
        match self {
            Eta::Defined(eta) => Some(eta),
            Eta::ToolStationary => None,
        }
    }
}

/// A validated polishing process.
#[derive(Debug, Clone, PartialEq)]
pub struct Process {
    spec: ProcessSpec,
    /// [`Process::max_tool_position_mm`], computed once (a root under linear pressure).
    reach_mm: f64,
    /// [`Process::pass_reach_mm`], computed once (a root under linear pressure).
    pass_reach_mm: f64,
}

pub(crate) const RPM_TO_RAD_PER_S: f64 = 2.0 * PI / 60.0;

impl Process {
    pub fn new(spec: ProcessSpec) -> Result<Self, ProcessError> {
        let finite = [
            ("workpiece_radius_mm", spec.workpiece_radius_mm),
            ("tool_radius_mm", spec.tool_radius_mm),
            ("workpiece_rpm", spec.workpiece_rpm),
            ("tool_rpm", spec.tool_rpm),
            (
                "preston_coefficient_m2_per_n",
                spec.preston_coefficient_m2_per_n,
            ),
            ("pressure_kpa", spec.pressure_kpa),
        ];
        if let Some((field, _)) = finite.iter().find(|(_, v)| !v.is_finite()) {
            return Err(ProcessError::NonFinite { field });
        }
        for (field, radius) in [
            ("workpiece_radius_mm", spec.workpiece_radius_mm),
            ("tool_radius_mm", spec.tool_radius_mm),
        ] {
            if radius <= 0.0 {
                return Err(ProcessError::NonPositiveRadius { field });
            }
        }
        if spec.pressure_kpa <= 0.0 {
            return Err(ProcessError::NonPositivePressure);
        }
        if spec.preston_coefficient_m2_per_n < 0.0 {
            return Err(ProcessError::NegativePrestonCoefficient);
        }
        if spec.workpiece_rpm == 0.0 {
            return Err(ProcessError::StationaryWorkpiece);
        }
        let ranges = [
            (
                "workpiece_radius_mm",
                spec.workpiece_radius_mm,
                RADIUS_RANGE_MM,
                "mm",
            ),
            ("tool_radius_mm", spec.tool_radius_mm, RADIUS_RANGE_MM, "mm"),
            (
                "workpiece_rpm",
                spec.workpiece_rpm,
                (-RPM_MAX, RPM_MAX),
                "r/min",
            ),
            ("tool_rpm", spec.tool_rpm, (-RPM_MAX, RPM_MAX), "r/min"),
            (
                "preston_coefficient_m2_per_n",
                spec.preston_coefficient_m2_per_n,
                (0.0, PRESTON_COEFFICIENT_MAX_M2_PER_N),
                "m²/N",
            ),
            (
                "pressure_kpa",
                spec.pressure_kpa,
                (0.0, PRESSURE_MAX_KPA),
                "kPa",
            ),
        ];
        for (field, value, (min, max), unit) in ranges {
            if !(min..=max).contains(&value) {
                return Err(ProcessError::OutOfRange {
                    field,
                    value,
                    min,
                    max,
                    unit,
                });
            }
        }
        if let PressureModel::Linear { pad_moment_share } = spec.pressure_model {
            if !(0.0..=1.0).contains(&pad_moment_share) {
                return Err(ProcessError::MomentShare);
            }
        }
        let mut process = Process {
            spec,
            reach_mm: f64::NAN,
            pass_reach_mm: f64::NAN,
        };
        process.check_reach()?;
        process.reach_mm = Process::reach_of(&process.spec);
        process.pass_reach_mm = match process.spec.pressure_model {
            PressureModel::Linear { pad_moment_share } => {
                let surface = &process.spec.part.surface;
                surface.radius_at_arc_length(linear_lift_onset_mm(
                    surface.arc_length_mm(process.spec.workpiece_radius_mm),
                    process.spec.tool_radius_mm,
                    pad_moment_share,
                ))
            }
            _ => process.reach_mm,
        };
        Ok(process)
    }

    /// On a curved part, the surface must be defined under the pad at its farthest position.
    fn check_reach(&self) -> Result<(), ProcessError> {
        let surface = &self.spec.part.surface;
        if surface.is_plane() {
            return Ok(());
        }
        let (pads, overhang) = match self.spec.pressure_model {
            PressureModel::Uniform => (2.0, "twice"),
            PressureModel::ConstantForce => (1.0, "once"),
            PressureModel::Linear { .. } => (2.0, "twice"),
        };
        let edge = self.spec.workpiece_radius_mm;
        let fail = |reach_arc_mm, error| ProcessError::SurfaceReach {
            reach_arc_mm,
            overhang,
            error,
        };
        surface
            .check_defined_to(edge)
            .map_err(ProcessError::SurfaceEdge)?;
        let reach_arc_mm = surface.arc_length_mm(edge) + pads * self.spec.tool_radius_mm;
        let reach = surface.radius_at_arc_length(reach_arc_mm);
        let held = surface.check_defined_to(reach).and_then(|()| {
            // The inverse saturates where the meridian turns vertical or the domain ends.
            let back = surface.arc_length_mm(reach);
            if (back - reach_arc_mm).abs() <= 1e-9 * reach_arc_mm {
                Ok(())
            } else {
                Err(SurfaceError::OutOfDomain {
                    radius_mm: reach,
                    domain_mm: surface.domain_mm(),
                })
            }
        });
        held.map_err(|e| fail(reach_arc_mm, e))
    }

    pub fn spec(&self) -> &ProcessSpec {
        &self.spec
    }
    pub fn workpiece_radius_mm(&self) -> f64 {
        self.spec.workpiece_radius_mm
    }
    pub fn tool_radius_mm(&self) -> f64 {
        self.spec.tool_radius_mm
    }
    pub fn pressure_model(&self) -> PressureModel {
        self.spec.pressure_model
    }
    pub fn part(&self) -> &Part {
        &self.spec.part
    }

    /// Arc length along the surface from the vertex to radius `r_mm` (r on a plane).
    pub fn arc_length_mm(&self, r_mm: f64) -> f64 {
        self.spec.part.surface.arc_length_mm(r_mm)
    }

    /// Arc lengths of `radii_mm`, mm; `None` on a plane (where they are the radii).
    pub fn arc_lengths_mm(&self, radii_mm: &[f64]) -> Option<Vec<f64>> {
        let surface = &self.spec.part.surface;
        (!surface.is_plane()).then(|| radii_mm.iter().map(|&r| surface.arc_length_mm(r)).collect())
    }

    /// The radius `by_mm` farther out along the surface than `r_mm` (r + by on a plane).
    pub fn radius_past_mm(&self, r_mm: f64, by_mm: f64) -> f64 {
        // On a plane both maps are the identity, so this is exactly r + by there.
        let surface = &self.spec.part.surface;
        surface.radius_at_arc_length(surface.arc_length_mm(r_mm) + by_mm)
    }

    /// Workpiece speed in the paper's convention (clockwise positive), rad/s.
    pub fn omega1_rad_per_s(&self) -> f64 {
        -self.spec.workpiece_rpm * RPM_TO_RAD_PER_S
    }

    /// Tool speed in the paper's convention (counter-clockwise positive), rad/s.
    pub fn omega2_rad_per_s(&self) -> f64 {
        self.spec.tool_rpm * RPM_TO_RAD_PER_S
    }

    /// η = ω1/ω2 = −workpiece_rpm / tool_rpm.
    pub fn eta(&self) -> Eta {
        if self.spec.tool_rpm == 0.0 {
            Eta::ToolStationary
        } else {
            Eta::Defined(-self.spec.workpiece_rpm / self.spec.tool_rpm)
        }
    }

    /// True when η = −1 exactly: the relative motion under the pad is a pure translation.
    pub fn is_eta_minus_one(&self) -> bool {
        self.spec.workpiece_rpm == self.spec.tool_rpm
    }

    /// The farthest tool-centre radius the model accepts, mm. Under uniform pressure the pad may
    /// run off the edge until it no longer touches (r_m + r_t); under constant force the pressure
    /// grows without bound as the overlap vanishes, so the centre must stay on the workpiece.
    /// A linear pad tips off where its load would have to act at the edge
    /// ([`super::pressure::linear_reach_mm`]: r_m for a free gimbal): positions must stay below
    /// it ([`Self::reach_is_open`]). On a curved part the overhang r_t is measured along the
    /// surface.
    pub fn max_tool_position_mm(&self) -> f64 {
        self.reach_mm
    }

    fn reach_of(spec: &ProcessSpec) -> f64 {
        let (edge, rt) = (spec.workpiece_radius_mm, spec.tool_radius_mm);
        let surface = &spec.part.surface;
        let edge_arc = surface.arc_length_mm(edge);
        match spec.pressure_model {
            PressureModel::Uniform => surface.radius_at_arc_length(edge_arc + rt),
            PressureModel::ConstantForce => edge,
            PressureModel::Linear { pad_moment_share } => {
                let reach_arc = linear_reach_mm(edge_arc, rt, pad_moment_share);
                // A free gimbal's reach is the edge itself, kept exact.
                if reach_arc == edge_arc {
                    edge
                } else {
                    surface.radius_at_arc_length(reach_arc)
                }
            }
        }
    }

    /// Whether [`Self::max_tool_position_mm`] itself is out of reach (under linear pressure the
    /// load there would rest on the edge alone).
    pub fn reach_is_open(&self) -> bool {
        matches!(self.spec.pressure_model, PressureModel::Linear { .. })
    }

    /// Whether the tool centre may sit at `position_mm`: from the axis to the reach (the reach
    /// itself excluded when it is open).
    pub fn holds_position(&self, position_mm: f64) -> bool {
        let max = self.reach_mm;
        position_mm >= 0.0 && (position_mm < max || (position_mm == max && !self.reach_is_open()))
    }

    /// Where constant-feed passes (equal dwell, the η window) may run to at most, mm: the reach,
    /// except that a linear pad stops where it starts to lift, at the edge at the latest (its
    /// removal at the rim grows without bound toward the reach).
    pub fn pass_reach_mm(&self) -> f64 {
        self.pass_reach_mm
    }

    /// K·P in (nm/s) per (mm/s) of sliding speed at nominal pressure: K [1/Pa] · P [Pa] turns a
    /// speed into a removal rate; 1 mm/s = 1e6 nm/s.
    pub(crate) fn preston_rate_scale(&self) -> f64 {
        self.spec.preston_coefficient_m2_per_n * self.spec.pressure_kpa * 1.0e3 * 1.0e6
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub fn paper_spec(workpiece_rpm: f64, tool_rpm: f64) -> ProcessSpec {
        ProcessSpec {
            workpiece_radius_mm: 50.0,
            tool_radius_mm: 10.0,
            workpiece_rpm,
            tool_rpm,
            preston_coefficient_m2_per_n: 1e-13,
            pressure_kpa: 10.0,
            pressure_model: PressureModel::Uniform,
            part: Part::flat(),
        }
    }

    fn rejected(mutate: impl Fn(&mut ProcessSpec)) -> ProcessError {
        let mut spec = paper_spec(-10.0, 200.0);
        mutate(&mut spec);
        Process::new(spec).expect_err("spec should be rejected")
    }

    #[test]
    fn derives_the_papers_convention() {
        let p = Process::new(paper_spec(-10.0, 200.0)).unwrap();
        assert_eq!(p.eta(), Eta::Defined(0.05));
        assert!((p.omega1_rad_per_s() - 10.0 * RPM_TO_RAD_PER_S).abs() < 1e-15);
        assert!((p.omega2_rad_per_s() - 200.0 * RPM_TO_RAD_PER_S).abs() < 1e-12);
        assert!(!p.is_eta_minus_one());
        let p = Process::new(paper_spec(150.0, 150.0)).unwrap();
        assert_eq!(p.eta(), Eta::Defined(-1.0));
        assert!(p.is_eta_minus_one());
    }

    #[test]
    fn eta_with_a_stationary_tool_is_undefined_not_nan() {
        let p = Process::new(paper_spec(30.0, 0.0)).unwrap();
        assert_eq!(p.eta(), Eta::ToolStationary);
        assert_eq!(p.eta().value(), None);
    }

    #[test]
    fn rejects_each_non_finite_field_by_name() {
        type Setter = fn(&mut ProcessSpec, f64);
        let fields: [(&str, Setter); 6] = [
            ("workpiece_radius_mm", |s, v| s.workpiece_radius_mm = v),
            ("tool_radius_mm", |s, v| s.tool_radius_mm = v),
            ("workpiece_rpm", |s, v| s.workpiece_rpm = v),
            ("tool_rpm", |s, v| s.tool_rpm = v),
            ("preston_coefficient_m2_per_n", |s, v| {
                s.preston_coefficient_m2_per_n = v
            }),
            ("pressure_kpa", |s, v| s.pressure_kpa = v),
        ];
        for (name, set) in fields {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let err = rejected(|s| set(s, bad));
                assert_eq!(err, ProcessError::NonFinite { field: name });
                assert_eq!(err.field(), name);
            }
        }
    }

    #[test]
    fn rejects_non_positive_radii() {
        for bad in [0.0, -1.0] {
            assert_eq!(
                rejected(|s| s.workpiece_radius_mm = bad),
                ProcessError::NonPositiveRadius {
                    field: "workpiece_radius_mm"
                }
            );
            assert_eq!(
                rejected(|s| s.tool_radius_mm = bad),
                ProcessError::NonPositiveRadius {
                    field: "tool_radius_mm"
                }
            );
        }
    }

    #[test]
    fn rejects_non_positive_pressure() {
        for bad in [0.0, -5.0] {
            let err = rejected(|s| s.pressure_kpa = bad);
            assert_eq!(err, ProcessError::NonPositivePressure);
            assert_eq!(err.field(), "pressure_kpa");
        }
    }

    #[test]
    fn rejects_negative_preston_coefficient_but_accepts_zero() {
        let err = rejected(|s| s.preston_coefficient_m2_per_n = -1e-13);
        assert_eq!(err, ProcessError::NegativePrestonCoefficient);
        assert_eq!(err.field(), "preston_coefficient_m2_per_n");
        let mut spec = paper_spec(-10.0, 200.0);
        spec.preston_coefficient_m2_per_n = 0.0;
        assert!(Process::new(spec).is_ok());
    }

    #[test]
    fn rejects_a_stationary_workpiece() {
        let err = rejected(|s| s.workpiece_rpm = 0.0);
        assert_eq!(err, ProcessError::StationaryWorkpiece);
        assert_eq!(err.field(), "workpiece_rpm");
        // -0.0 is zero too.
        assert_eq!(
            rejected(|s| s.workpiece_rpm = -0.0),
            ProcessError::StationaryWorkpiece
        );
    }
}
