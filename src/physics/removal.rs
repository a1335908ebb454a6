//! The removal function R(r; r1): depth removed per unit time at radius r while the tool centre
//! sits at radius r1, averaged over workpiece revolutions (Preston's law dZ/dt = K·P·V).
//!
//! With a = (ω1 + ω2)·r and b = ω2·r1 (paper convention, see [`super::process`]) the sliding
//! speed is V(θ)² = a² + b² − 2ab·cosθ = (a − b)² + 4ab·sin²(θ/2), and
//!
//! ```text
//! R(r; r1) = K·P/(2π) ∫_{−θ0}^{θ0} V dθ = (2·K·P/π) ∫_0^{ψ0} √((a − b)² + 4ab·sin²ψ) dψ,
//! ```
//!
//! ψ0 = θ0/2 from [`super::contact`]. Every piece reduces to
//! G(φ; A, B) = ∫_0^φ √(A + B·sin²ψ) dψ, which Carlson's forms give exactly:
//!
//! ```text
//! G(φ; A, B) = A·s·R_F(A·c², A + B·s², A) + (A·B/3)·s³·R_D(A·c², A + B·s², A),  s = sinφ, c = cosφ
//! G(φ; 0, B) = √B·(1 − cosφ)
//! ```
//!
//! (DLMF 19.25.9 scaled by homogeneity). We pick the arrangement with no cancellation:
//!
//! * ab ≥ 0: G(ψ0; (a−b)², 4ab). B ≥ 0, so both terms are positive.
//! * ab < 0 and ψ0 ≤ π/4: the same; here A + B·s² ≥ a² + b² ≥ A/2, so the R_D term is at most a
//!   modest fraction of the R_F term.
//! * ab < 0 and ψ0 > π/4: substitute χ = π/2 − ψ, V² = (a + b)² − 4ab·sin²χ, and take
//!   G(π/2; (a+b)², −4ab) − G(π/2 − ψ0; (a+b)², −4ab). The integrand grows with χ and the
//!   subtracted part spans less than half the range, so the difference keeps all but ~1.5 bits.
//!
//! The textbook forms E(m) − E(β|m) lose every digit near tangency (ψ0 → 0) and near m → 1;
//! these do not. η = −1 (ω1 + ω2 = 0, a = 0) is a pure translation, V = |ω2|·r1, and takes the
//! fast path R = K·P·|ω2|·r1·θ0/π.

use std::cell::RefCell;
use std::f64::consts::PI;
use std::sync::OnceLock;

use super::carlson::{rf_rd, rf_rd_many};
use super::contact::{half_angle, half_angle_off_axis, HalfAngle};
use super::curved::{CurvedKernel, Ring, Site};
use super::path::{Integrand, Lobatto, PathIntegral, PieceMap, Resolution};
use super::pressure::{contact_area_mm2, pad_pressure, PadPressure, PressureCurve, PressureModel};
use super::process::Process;
use super::roots::illinois;
use super::sliding_log::SlidingLog;

/// How finely a [`PathIntegral`] resolves the rate along the path, relative to the rate's
/// size: the closed form is exact to rounding, the curved kernel's own quadrature to ~1e-10.
/// A curved rate is costly and its pieces' nearest singularities are their own ends, so it is
/// fitted over whole pieces; the flat rate has singularities just beyond its pieces' ends
/// (the contact angle's pole at x = 0) and δ²·ln δ at the sliding speed's zero, so halves,
/// but whole pieces where that logarithm is taken out and the pole is far
/// ([`FlatRow`]'s `piece_map`; [`super::path`] compares the two).
const FLAT_PATH: Resolution = Resolution {
    tolerance: 1e-12,
    map: PieceMap::Halves,
};
const CURVED_PATH: Resolution = Resolution {
    tolerance: 1e-10,
    map: PieceMap::Whole,
};

/// Everything about a process that the removal function needs, precomputed once. On a curved
/// part the rate comes from [`super::curved`]; on a plane from the closed form here.
#[derive(Debug, Clone)]
pub struct RemovalKernel {
    omega_sum: f64,
    omega2: f64,
    tool_radius: f64,
    workpiece_radius: f64,
    pressure_model: PressureModel,
    /// K·P/π in (nm/s) per (mm/s · rad).
    scale: f64,
    translation: bool,
    /// The farthest tool position the process allows, mm (the path's end at the latest).
    reach_mm: f64,
    /// A linear pad's pressure against the arc length of its position (its radius on a
    /// plane), made the first time a path integral needs it (a few ms: single rates solve the
    /// pressure directly).
    curve: OnceLock<PressureCurve>,
    /// The Chebyshev points every path integral is taken with.
    lobatto: &'static Lobatto,
    curved: Option<CurvedKernel>,
}

/// F(ρ) = ∫ R(r; x)·ds for x up to ρ at one radius r ([`RemovalKernel::path_integral`]).
#[derive(Debug, Clone)]
pub enum RunningIntegral {
    /// Adaptive Chebyshev panels between the kinks of R ([`super::path`]).
    Panels(PathIntegral),
    /// Panels of R less its logarithm at the sliding speed's zero, and that logarithm's
    /// integral in closed form ([`super::sliding_log`]).
    PanelsAndLog(PathIntegral, SlidingLog),
    /// The closed form on a plane at η = −1 under uniform pressure (see [`Lens`]).
    Lens(Lens),
}

impl RunningIntegral {
    /// F(x): 0 before the path reaches r's ring, the whole integral after it has passed.
    pub fn at(&self, x: f64) -> f64 {
        match self {
            RunningIntegral::Panels(panels) => panels.at(x),
            RunningIntegral::PanelsAndLog(panels, log) => panels.at(x) + log.integral_to(x),
            RunningIntegral::Lens(lens) => lens.at(x),
        }
    }

    /// F(stop) − F(start): what a constant feed over [start, stop] removes per s/mm of dwell.
    pub fn between(&self, start: f64, stop: f64) -> f64 {
        self.at(stop) - self.at(start)
    }

    /// F at every x of `xs` (ascending) into `out`, as [`Self::at`] would read each.
    pub fn at_ascending(&self, xs: &[f64], out: &mut [f64]) {
        match self {
            RunningIntegral::Panels(panels) => panels.at_ascending(xs, out),
            RunningIntegral::PanelsAndLog(panels, log) => {
                panels.at_ascending(xs, out);
                log.add_integrals(xs, out);
            }
            RunningIntegral::Lens(lens) => {
                for (o, &x) in out.iter_mut().zip(xs) {
                    *o = lens.at(x);
                }
            }
        }
    }
}

/// At η = −1 every point under the pad slides at |ω|·x (a translation), so
/// R(r; x) = K·P/(2π)·|ω|·x·φ(r, x), with φ the angle of the arc of r's ring under a pad
/// centred at x — the same angle as that of the circle of radius x about the axis under a pad
/// centred at r. In polar coordinates ∫_0^ρ φ(r, x)·x dx is the area of the lens where the disc
/// of radius ρ about the axis overlaps the pad's disc centred at distance r:
///
/// ```text
/// F(ρ) = K·P/(2π)·|ω|·A(ρ),   A = lens area of radii ρ and r_t at centre distance r
/// ```
///
/// exact, with no quadrature (the path ends at `end_mm`, the reach or r + r_t).
#[derive(Debug, Clone, Copy)]
pub struct Lens {
    /// K·P/(2π)·|ω|, nm/s per mm².
    rate: f64,
    r_mm: f64,
    tool_radius_mm: f64,
    end_mm: f64,
}

impl Lens {
    pub fn at(&self, x: f64) -> f64 {
        let x = x.clamp(0.0, self.end_mm.max(0.0));
        self.rate * contact_area_mm2(x, self.tool_radius_mm, self.r_mm)
    }
}

impl RemovalKernel {
    pub fn new(process: &Process) -> Self {
        RemovalKernel {
            omega_sum: process.omega1_rad_per_s() + process.omega2_rad_per_s(),
            omega2: process.omega2_rad_per_s(),
            tool_radius: process.tool_radius_mm(),
            workpiece_radius: process.workpiece_radius_mm(),
            pressure_model: process.pressure_model(),
            scale: process.preston_rate_scale() / PI,
            translation: process.is_eta_minus_one(),
            reach_mm: process.max_tool_position_mm(),
            curve: OnceLock::new(),
            lobatto: Lobatto::shared(),
            curved: (!process.part().is_flat()).then(|| {
                CurvedKernel::new(
                    process.part().clone(),
                    -process.omega1_rad_per_s(),
                    process.omega2_rad_per_s(),
                    process.tool_radius_mm(),
                    process.workpiece_radius_mm(),
                    process.pressure_model(),
                    process.preston_rate_scale() / PI,
                )
            }),
        }
    }

    pub fn tool_radius_mm(&self) -> f64 {
        self.tool_radius
    }

    /// The same pad with the part turning at `part_speed_rad_per_s` (Ω, lab frame,
    /// counter-clockwise positive) instead of the process's speed: on a plane only the
    /// sliding speed depends on Ω (the contact and the pressure depend on where the pad is),
    /// so only ω1 + ω2 = ω2 − Ω changes; on a curved part, the curved kernel's Ω.
    pub fn with_part_speed(&self, part_speed_rad_per_s: f64) -> RemovalKernel {
        let omega_sum = self.omega2 - part_speed_rad_per_s;
        RemovalKernel {
            omega_sum,
            // η = −1 exactly: the relative motion under the pad is a pure translation.
            translation: omega_sum == 0.0,
            curved: self
                .curved
                .as_ref()
                .map(|curved| curved.with_part_speed(part_speed_rad_per_s)),
            ..self.clone()
        }
    }

    /// The kernel of a curved part, `None` on a plane.
    pub fn curved(&self) -> Option<&CurvedKernel> {
        self.curved.as_ref()
    }

    /// Removal rate in nm/s at radius `r_mm` with the tool centre at `r1_mm` (both ≥ 0).
    pub fn rate_nm_per_s(&self, r_mm: f64, r1_mm: f64) -> f64 {
        self.rate_under(&self.pad_pressure(r1_mm), r_mm, r1_mm)
    }

    /// The pressure with the tool at `r1_mm`, relative to nominal (see [`super::pressure`]);
    /// no pressure where no contact carries the load.
    pub fn pad_pressure(&self, r1_mm: f64) -> PadPressure {
        if self.nominal_everywhere() {
            return PadPressure::NOMINAL;
        }
        if let Some(curved) = &self.curved {
            return curved.pad_pressure(r1_mm);
        }
        pad_pressure(
            self.pressure_model,
            self.workpiece_radius,
            self.tool_radius,
            r1_mm,
        )
        .unwrap_or(PadPressure::NONE)
    }

    /// Whether the pressure is nominal wherever the pad is (uniform pressure), so that no
    /// position need be known to ask it: on a curved part that position is an arc length, on
    /// an asphere a quadrature, and a path asks at every point.
    fn nominal_everywhere(&self) -> bool {
        self.pressure_model == PressureModel::Uniform
    }

    /// The linear pad's pressure curve, made on first use.
    fn curve(&self) -> Option<&PressureCurve> {
        let PressureModel::Linear { pad_moment_share } = self.pressure_model else {
            return None;
        };
        Some(self.curve.get_or_init(|| {
            let edge_arc_mm = self.arc_length_mm(self.workpiece_radius);
            PressureCurve::new(edge_arc_mm, self.tool_radius, pad_moment_share)
        }))
    }

    /// [`Self::pad_pressure`] for the many positions of a path, the pad at `r1_mm` whose arc
    /// length is `arc_mm` (r1 on a plane; the caller has it): from the curve under linear
    /// pressure.
    fn path_pressure(&self, r1_mm: f64, arc_mm: f64) -> PadPressure {
        match self.curve() {
            Some(curve) => curve.at(arc_mm).unwrap_or(PadPressure::NONE),
            None => self.pad_pressure(r1_mm),
        }
    }

    /// Where a linear pad starts to lift, if it does before its reach (a radius).
    fn lift_onset_mm(&self) -> Option<f64> {
        let onset = self.curve()?.lift_onset_mm()?;
        Some(match &self.curved {
            Some(curved) => curved.surface().radius_at_arc_length(onset),
            None => onset,
        })
    }

    /// The rate at `r_mm` with the tool at `r1_mm` under `pressure` (its [`Self::pad_pressure`]).
    ///
    /// With p/P = level + slope·(x − r1) and x = r·cos θ on the ring, the rate is
    /// K·P/π·[(level − slope·r1)·∫V dθ + slope·r·∫cos θ·V dθ] over the arc under the pad and
    /// beyond the lift line x0 (cos θ ≥ x0/r): both integrals from one pair of Carlson's
    /// integrals ([`arc_integrals`]).
    fn rate_under(&self, pressure: &PadPressure, r_mm: f64, r1_mm: f64) -> f64 {
        if let Some(curved) = &self.curved {
            return curved.rate_nm_per_s(&curved.ring(r_mm), &curved.site(r1_mm), pressure);
        }
        if pressure.slope_per_mm == 0.0 {
            if pressure.level == 0.0 {
                return 0.0;
            }
            return self.nominal_rate_nm_per_s(r_mm, r1_mm) * pressure.level;
        }
        match self.pressed_arc(pressure, r_mm, r1_mm) {
            Some(psi) => self.rate_on_arc(pressure, r_mm, r1_mm, psi),
            None => 0.0,
        }
    }

    /// The half-angle of the arc of the ring at `r_mm` under the pad at `r1_mm` where it
    /// presses (short of the lift line); `None` without contact.
    fn pressed_arc(&self, pressure: &PadPressure, r_mm: f64, r1_mm: f64) -> Option<HalfAngle> {
        let mut psi = half_angle(r_mm, r1_mm, self.tool_radius);
        if let Some(lift) = pressure.lift_line_mm() {
            psi = psi.cut_at(r1_mm + lift, r_mm)?;
        }
        psi.is_contact().then_some(psi)
    }

    /// [`Self::rate_under`] over the arc |θ| ≤ 2ψ of the ring (on a plane), `psi` within
    /// [`Self::pressed_arc`].
    fn rate_on_arc(&self, pressure: &PadPressure, r_mm: f64, r1_mm: f64, psi: HalfAngle) -> f64 {
        let b = self.omega2 * r1_mm;
        let arc = if self.translation {
            // V = |b| everywhere: ∫V dθ = θe·|b|, ∫cos θ·V dθ = sin θe·|b|.
            ArcIntegrals {
                speed: 2.0 * psi.radians() * b.abs(),
                cos_speed: 2.0 * psi.sin * psi.cos * b.abs(),
            }
        } else {
            arc_integrals(self.omega_sum * r_mm, b, psi)
        };
        let level = pressure.level - pressure.slope_per_mm * r1_mm;
        (self.scale * (level * arc.speed + pressure.slope_per_mm * r_mm * arc.cos_speed)).max(0.0)
    }

    /// S(α) = ∫_0^α ρ(r, α′) dα′ (nm/s·rad) on a plane: the instantaneous rate ρ at the
    /// point of the ring at `r_mm` whose angle from the direction of the pad centre (at
    /// `r1_mm`) is α′, integrated from 0 to `alpha_rad` ∈ [−π, π]. ρ is even in α′ and 0
    /// beyond the pressed arc, so S is odd and S(±π) = ±π·R(r; r1) ([`Self::rate_nm_per_s`]):
    /// the revolution average is S(π)/π. [`super::polar`] builds the removal of a sweeping
    /// pad from it. `None` on a curved part, whose arc [`super::polar`] integrates itself.
    pub fn swept_rate_integral(&self, r_mm: f64, r1_mm: f64, alpha_rad: f64) -> Option<f64> {
        if self.curved.is_some() {
            return None;
        }
        let pressure = self.pad_pressure(r1_mm);
        if pressure.level == 0.0 && pressure.slope_per_mm == 0.0 {
            return Some(0.0);
        }
        let Some(pressed) = self.pressed_arc(&pressure, r_mm, r1_mm) else {
            return Some(0.0);
        };
        let (sin, cos) = (alpha_rad.abs().min(PI) / 2.0).sin_cos();
        let psi = if sin < pressed.sin {
            HalfAngle { sin, cos }
        } else {
            pressed
        };
        let one_side = if psi.is_contact() {
            PI * self.rate_on_arc(&pressure, r_mm, r1_mm, psi)
        } else {
            0.0
        };
        Some(alpha_rad.signum() * one_side)
    }

    /// Removal rate at nominal pressure, nm/s; [`Self::rate_nm_per_s`] scales it by the
    /// pressure.
    pub fn nominal_rate_nm_per_s(&self, r_mm: f64, r1_mm: f64) -> f64 {
        if let Some(curved) = &self.curved {
            return curved.nominal_rate_nm_per_s(&curved.ring(r_mm), &curved.site(r1_mm));
        }
        if self.translation {
            let psi = half_angle(r_mm, r1_mm, self.tool_radius);
            if !psi.is_contact() {
                return 0.0;
            }
            return self.scale * (2.0 * psi.radians() * (self.omega2 * r1_mm).abs());
        }
        let mut queue = CarlsonQueue::<2>::new();
        let pending = self.queue_nominal(r_mm, r1_mm, 1.0, &mut queue);
        queue.evaluate();
        pending.value(self.scale, &queue)
    }
}

impl RemovalKernel {
    /// Arc length from the vertex to radius `r_mm` along the surface (r on a plane).
    pub fn arc_length_mm(&self, r_mm: f64) -> f64 {
        self.curved
            .as_ref()
            .map_or(r_mm, |curved| curved.surface().arc_length_mm(r_mm))
    }

    /// The removal at radius `r_mm` of the tool moving along the surface: F(ρ) = ∫ R(r; x)·ds
    /// over tool positions x up to ρ ([`super::path`]), with its breakpoints where R has
    /// kinks: the pad's rim crossing r (x = |r − r_t|, r + r_t), the zero of the sliding
    /// speed (x = (ω1 + ω2)·r/ω2 on a plane) and the pad reaching the edge under constant
    /// force, or starting to lift under linear pressure; on a curved part the same events on
    /// the surface ([`CurvedKernel::breakpoints`]). F is built up to `end_mm` (the path's
    /// last point; it stays constant beyond).
    pub fn path_integral(&self, r_mm: f64, end_mm: f64) -> RunningIntegral {
        if let Some(lens) = self.lens(r_mm) {
            return RunningIntegral::Lens(lens);
        }
        self.along_path(r_mm, |rate, points, resolution, log| {
            let (Some(&lo), Some(&hi)) = (points.first(), points.last()) else {
                return RunningIntegral::Panels(PathIntegral::new(
                    rate,
                    &points,
                    resolution,
                    self.lobatto,
                ));
            };
            // Only the linear model needs the cut: its reach is open, and the rate grows
            // without bound toward it (the others keep their panels as they were).
            let linear = matches!(self.pressure_model, PressureModel::Linear { .. });
            let points = if linear && end_mm < hi {
                inside(points, lo, end_mm.max(lo))
            } else {
                points
            };
            let panels = PathIntegral::new(rate, &points, resolution, self.lobatto);
            match log {
                Some(log) => RunningIntegral::PanelsAndLog(panels, log),
                None => RunningIntegral::Panels(panels),
            }
        })
    }

    /// F(stop) − F(start) read from [`Self::path_integral`]`(r, stop)`: what an operator row
    /// reads from its own running integral when that does not depend on where the path ends
    /// ([`Self::path_ignores_end`]), so a pass computed beside an operator and one computed
    /// alone agree bit for bit.
    pub fn path_difference(&self, r_mm: f64, start_mm: f64, stop_mm: f64) -> f64 {
        self.path_integral(r_mm, stop_mm).between(start_mm, stop_mm)
    }

    /// Whether [`Self::path_integral`]`(r, end)` is the same F for every end: all pressure
    /// models but the linear pad's, whose open reach cuts the path at its end.
    pub fn path_ignores_end(&self) -> bool {
        !matches!(self.pressure_model, PressureModel::Linear { .. })
    }

    /// F(stop) − F(start) for [`Self::path_integral`]'s F, without building F: the pieces cut
    /// at `start_mm` and `stop_mm` and integrated alone (what a constant-feed pass needs).
    pub fn path_total(&self, r_mm: f64, start_mm: f64, stop_mm: f64) -> f64 {
        if let Some(lens) = self.lens(r_mm) {
            return lens.at(stop_mm) - lens.at(start_mm);
        }
        self.along_path(r_mm, |rate, points, resolution, log| {
            let (Some(&lo), Some(&hi)) = (points.first(), points.last()) else {
                return 0.0;
            };
            let (a, b) = (lo.max(start_mm), hi.min(stop_mm));
            if b <= a {
                return 0.0;
            }
            let logarithm = log.map_or(0.0, |log| log.integral_to(b) - log.integral_to(a));
            PathIntegral::total_over(rate, &inside(points, a, b), resolution, self.lobatto)
                + logarithm
        })
    }

    /// The closed form at η = −1 on a plane under uniform pressure ([`Lens`]).
    fn lens(&self, r_mm: f64) -> Option<Lens> {
        (self.curved.is_none() && self.translation && self.pressure_model == PressureModel::Uniform)
            .then(|| Lens {
                rate: 0.5 * self.scale * self.omega2.abs(),
                r_mm,
                tool_radius_mm: self.tool_radius,
                end_mm: (r_mm + self.tool_radius).min(self.reach_mm),
            })
    }

    /// Hands `use_it` the rate along the path at radius `r_mm` (per mm of x, with ds/dx on a
    /// curved part), the breakpoints of its smooth pieces, how finely to resolve them, and
    /// the logarithm the rate is given without, if any ([`Self::sliding_log`]).
    fn along_path<T>(
        &self,
        r_mm: f64,
        use_it: impl FnOnce(&dyn Integrand, Vec<f64>, Resolution, Option<SlidingLog>) -> T,
    ) -> T {
        match &self.curved {
            Some(curved) => {
                let ring = curved.ring(r_mm);
                let rate = CurvedRow {
                    kernel: self,
                    curved,
                    ring,
                    sites: RefCell::new(Vec::new()),
                };
                let mut points = curved.breakpoints(&ring, self.reach_mm);
                if let (Some(onset), Some(&lo), Some(&hi)) =
                    (self.lift_onset_mm(), points.first(), points.last())
                {
                    points.push(onset);
                    let pressure = |x: f64, arc: f64| self.path_pressure(x, arc);
                    points.extend(curved.lift_kinks(&ring, onset.max(lo), hi, &pressure));
                    points = inside(points, lo, hi);
                }
                use_it(&rate, points, CURVED_PATH, None)
            }
            None => {
                let points = self.flat_breakpoints(r_mm);
                let log = self.sliding_log(r_mm, &points);
                let rate = FlatRow::new(self, r_mm, log);
                use_it(&rate, points, FLAT_PATH, log)
            }
        }
    }

    /// The logarithm of the plane's rate at the sliding speed's zero x*, to be taken out over
    /// the pieces beside x* among `points` ([`super::sliding_log`]): under uniform pressure
    /// (a level one, so S's weight is the rate's), x* a breakpoint strictly inside, at
    /// ordinary speeds. (At η = −1, with ω2 = 0 or on the axis x* is 0 or not finite, which
    /// [`SlidingLog::new`] refuses.)
    fn sliding_log(&self, r: f64, points: &[f64]) -> Option<SlidingLog> {
        if !self.nominal_everywhere() {
            return None;
        }
        let a = self.omega_sum * r;
        let zero = a / self.omega2;
        let k = points.iter().position(|&x| x == zero)?;
        let (lo, hi) = (*points.get(k.checked_sub(1)?)?, *points.get(k + 1)?);
        if needs_scaling(a, self.omega2 * lo) || needs_scaling(a, self.omega2 * hi) {
            return None;
        }
        SlidingLog::new(a, self.omega2, self.scale, lo, hi)
    }

    /// The support of R(r; ·) on a plane, clipped to the reach, and the kinks inside it.
    fn flat_breakpoints(&self, r: f64) -> Vec<f64> {
        let rt = self.tool_radius;
        let lo = (r - rt).max(0.0);
        let hi = (r + rt).min(self.reach_mm);
        let mut points = vec![lo, hi, rt - r];
        if !self.translation && self.omega2 != 0.0 {
            points.push(self.omega_sum * r / self.omega2);
        }
        if self.pressure_model != PressureModel::Uniform {
            points.push(self.workpiece_radius - rt);
        }
        if let Some(onset) = self.lift_onset_mm() {
            points.push(onset);
            points.extend(self.lift_kinks(r, onset.max(lo), hi));
        }
        inside(points, lo, hi)
    }

    /// Where a lifted pad's rate at radius `r` has kinks in the tool position x (between
    /// `from` and `to`, beyond the lift's onset): where the lift line x0(x) passes the ends of
    /// the ring's arc under the pad (x0 = r·cos θ0) and where it passes the ring itself
    /// (x0 = r, beyond which the ring is lifted clear). Sign changes on a few samples, each
    /// refined by regula falsi.
    fn lift_kinks(&self, r: f64, from: f64, to: f64) -> Vec<f64> {
        if to <= from || r <= 0.0 {
            return Vec::new();
        }
        let rt = self.tool_radius;
        let lift_line = |x: f64| {
            self.path_pressure(x, x)
                .lift_line_mm()
                .map_or(f64::NEG_INFINITY, |u| x + u)
        };
        let past_arc_end = |x: f64| lift_line(x) - (r * r + x * x - rt * rt) / (2.0 * x);
        let past_ring = |x: f64| lift_line(x) - r;
        let mut kinks = crossings(&past_arc_end, from, to);
        kinks.extend(crossings(&past_ring, from, to));
        kinks
    }

    /// What a column fill needs of the sample radii, computed once per operator: the ring
    /// geometry on a curved part (sag and slope), nothing on a plane.
    pub fn rings(&self, radii_mm: &[f64]) -> Option<Vec<Ring>> {
        let curved = self.curved.as_ref()?;
        Some(radii_mm.iter().map(|&r| curved.ring(r)).collect())
    }

    /// Rates in nm/s at `radii_mm` with the tool at `r1_mm` into `out`; `rings` are
    /// [`Self::rings`] of the same radii.
    pub fn fill_column(
        &self,
        r1_mm: f64,
        radii_mm: &[f64],
        rings: Option<&[Ring]>,
        out: &mut [f64],
    ) {
        let pressure = self.pad_pressure(r1_mm);
        match (&self.curved, rings) {
            (Some(curved), Some(rings)) => {
                let site = curved.site(r1_mm);
                for (value, ring) in out.iter_mut().zip(rings) {
                    *value = curved.rate_nm_per_s(ring, &site, &pressure);
                }
            }
            _ => {
                for (value, &r) in out.iter_mut().zip(radii_mm) {
                    *value = self.rate_under(&pressure, r, r1_mm);
                }
            }
        }
    }
}

/// The rate along the path at one radius of a plane, x ↦ R(r; x) under the pad's pressure at
/// x: what [`RemovalKernel::rate_under`] gives point by point, bit for bit, but with the
/// Carlson integrals of a batch of points taken together ([`rf_rd_many`]). Points under a
/// sloped (linear) pressure, at extreme speeds (rescaled) or at η = −1 are taken alone.
struct FlatRow<'a> {
    kernel: &'a RemovalKernel,
    r_mm: f64,
    /// The Carlson arguments of a batch, reused from batch to batch of the row.
    queue: RefCell<CarlsonQueue<FLAT_QUEUE>>,
    /// The logarithm at the sliding speed's zero the rates are given without, if any.
    log: Option<SlidingLog>,
}

impl<'a> FlatRow<'a> {
    /// The rates at radius `r_mm`, less `log`'s part if given.
    fn new(kernel: &'a RemovalKernel, r_mm: f64, log: Option<SlidingLog>) -> Self {
        FlatRow {
            kernel,
            r_mm,
            queue: RefCell::new(CarlsonQueue::new()),
            log,
        }
    }
}

/// The rate along the path at one radius of a curved part, per mm of x (times ds/dx): the
/// pad's sites of a batch first, then each rate. The sites are independent of each other, so
/// their square roots and divisions overlap, where one site before each rate sat on the
/// critical path. Each point gets the arithmetic it got alone.
struct CurvedRow<'a> {
    kernel: &'a RemovalKernel,
    curved: &'a CurvedKernel,
    ring: Ring,
    /// The sites of a batch, reused from batch to batch of the row.
    sites: RefCell<Vec<Site>>,
}

impl Integrand for CurvedRow<'_> {
    fn values(&self, xs: &[f64], out: &mut [f64]) {
        let mut sites = self.sites.borrow_mut();
        sites.clear();
        sites.extend(xs.iter().map(|&x| self.curved.site(x)));
        for ((o, &x), site) in out.iter_mut().zip(xs).zip(sites.iter()) {
            let pressure = self.kernel.path_pressure(x, site.arc_mm());
            *o = if pressure == PadPressure::NONE {
                0.0
            } else {
                site.arc_integrand() * self.curved.rate_nm_per_s(&self.ring, site, &pressure)
            };
        }
    }
}

/// Points a [`FlatRow`] batch holds: each needs at most two Carlson evaluations.
const FLAT_BATCH: usize = 32;
/// Carlson triples a [`FlatRow`] batch may queue.
const FLAT_QUEUE: usize = 2 * FLAT_BATCH;

/// G(φ; A, B) = ∫_0^φ √(A + B·sin²ψ) dψ of one point (A ≥ 0, A + B·sin²φ > 0), known or
/// waiting for the Carlson pair in `slot`:
/// G = A·s·(R_F + B·s²·R_D/3) at (A·c², A + B·s², A).
#[derive(Clone, Copy)]
enum PendingG {
    Known(f64),
    Slot { slot: usize, s: f64, a: f64, b: f64 },
}

impl PendingG {
    /// G(φ; A, B) for s = sin φ, c = cos φ: known at once when φ = 0 or A = 0, else its Carlson
    /// arguments queued.
    fn queue<const N: usize>(
        s: f64,
        c: f64,
        a: f64,
        b: f64,
        queue: &mut CarlsonQueue<N>,
    ) -> PendingG {
        if s == 0.0 {
            return PendingG::Known(0.0);
        }
        if a == 0.0 {
            // √B·(1 − cosφ), written without cancellation for small φ.
            return PendingG::Known(b.sqrt() * s * s / (1.0 + c));
        }
        let (x, y, z) = Self::arguments(s, c, a, b);
        let slot = queue.push(x, y, z);
        PendingG::Slot { slot, s, a, b }
    }

    fn value<const N: usize>(self, queue: &CarlsonQueue<N>) -> f64 {
        match self {
            PendingG::Known(value) => value,
            PendingG::Slot { slot, s, a, b } => {
                Self::from_pair(s, a, b, queue.rf[slot], queue.rd[slot])
            }
        }
    }

    /// Carlson's arguments of G(φ; A, B): (A·c², A + B·s², A).
    #[inline(always)]
    fn arguments(s: f64, c: f64, a: f64, b: f64) -> (f64, f64, f64) {
        (a * c * c, a + b * (s * s), a)
    }

    /// G(φ; A, B) from R_F and R_D at [`Self::arguments`].
    #[inline(always)]
    fn from_pair(s: f64, a: f64, b: f64, rf: f64, rd: f64) -> f64 {
        s * a * (rf + b * (s * s) * rd * (1.0 / 3.0))
    }
}

/// Carlson argument triples gathered from `N` or fewer, evaluated together.
struct CarlsonQueue<const N: usize> {
    x: [f64; N],
    y: [f64; N],
    z: [f64; N],
    rf: [f64; N],
    rd: [f64; N],
    len: usize,
}

impl<const N: usize> CarlsonQueue<N> {
    fn new() -> Self {
        CarlsonQueue {
            x: [0.0; N],
            y: [0.0; N],
            z: [0.0; N],
            rf: [0.0; N],
            rd: [0.0; N],
            len: 0,
        }
    }

    fn push(&mut self, x: f64, y: f64, z: f64) -> usize {
        let slot = self.len;
        (self.x[slot], self.y[slot], self.z[slot]) = (x, y, z);
        self.len += 1;
        slot
    }

    fn evaluate(&mut self) {
        let n = self.len;
        rf_rd_many(
            &self.x[..n],
            &self.y[..n],
            &self.z[..n],
            &mut self.rf[..n],
            &mut self.rd[..n],
        );
    }
}

/// One point of a [`FlatRow`] batch: its rate known, or its sliding integral pending, to be
/// scaled by `level` (the pressure relative to nominal).
#[derive(Clone, Copy)]
enum PendingRate {
    Known(f64),
    Sliding { sliding: Sliding, level: f64 },
}

impl PendingRate {
    /// The rate, nm/s, once `queue` is evaluated (`scale` the kernel's K·P/π).
    fn value<const N: usize>(self, scale: f64, queue: &CarlsonQueue<N>) -> f64 {
        match self {
            PendingRate::Known(rate) => rate,
            PendingRate::Sliding { sliding, level } => {
                Self::finish(scale, sliding.value(queue), level)
            }
        }
    }

    /// The rate, nm/s, of the sliding integral ∫V dθ at a pressure `level` times nominal.
    #[inline(always)]
    fn finish(scale: f64, sliding: f64, level: f64) -> f64 {
        scale * sliding * level
    }
}

impl Integrand for FlatRow<'_> {
    fn values(&self, xs: &[f64], out: &mut [f64]) {
        let mut queue = self.queue.borrow_mut();
        for (xs, out) in xs.chunks(FLAT_BATCH).zip(out.chunks_mut(FLAT_BATCH)) {
            if !self.direct_batch(xs, out, &mut queue) {
                self.batch_point_by_point(xs, out, &mut queue);
            }
        }
        if let Some(log) = &self.log {
            log.subtract(xs, out);
        }
    }

    /// With the logarithm taken out, a piece is fitted whole (one span, where two halves
    /// need twice the rates) unless it ends at x* with the logarithm left in on it, or lies
    /// closer to the contact angle's pole at x = 0 than its own width (the whole map draws
    /// what lies beyond a piece's ends closer: [`super::path`]).
    fn piece_map(&self, p: f64, q: f64) -> Option<PieceMap> {
        let log = self.log.as_ref()?;
        let (lo, hi) = log.range_mm();
        let zero = log.zero_mm();
        let beside_zero = p == zero || q == zero;
        let log_left_in = beside_zero && (p < lo || q > hi);
        Some(if p >= q - p && !log_left_in {
            PieceMap::Whole
        } else {
            PieceMap::Halves
        })
    }
}

impl FlatRow<'_> {
    /// A batch whose every point is in contact or not, under a level pressure, in the direct
    /// arrangement (ab ≥ 0 or ψ0 ≤ π/4) with A = (a − b)² > 0, at ordinary speeds and off the
    /// axis — most batches of a row — in straight loops over arrays (no enum per point, no
    /// branch): the half-angle and the Carlson arguments, then the rates. Each point gets the
    /// very operations [`Self::batch_point_by_point`] gives it (a point out of contact has
    /// sin ψ0 = 0, so its rate is 0 either way). `false`, with `out` unspecified, when a point
    /// is not of this kind (a batch holding the sliding speed's zero, A = 0, is left to the
    /// general path: its queue then holds one lane fewer, which measured faster than a lane
    /// known at once inside the straight loops).
    fn direct_batch(
        &self,
        xs: &[f64],
        out: &mut [f64],
        queue: &mut CarlsonQueue<FLAT_QUEUE>,
    ) -> bool {
        let k = self.kernel;
        let r = self.r_mm;
        if k.translation || r == 0.0 {
            return false;
        }
        let n = xs.len();
        // Not asked point by point where it is nominal everywhere (a hot loop's worth).
        let mut level = [PadPressure::NOMINAL.level; FLAT_BATCH];
        if !k.nominal_everywhere() {
            for (level, &x) in level.iter_mut().zip(xs) {
                let pressure = k.path_pressure(x, x);
                if pressure.slope_per_mm != 0.0 || pressure.level == 0.0 {
                    return false;
                }
                *level = pressure.level;
            }
        }
        let (rt, a) = (k.tool_radius, k.omega_sum * r);
        let mut sin = [0.0; FLAT_BATCH];
        let mut big_a = [0.0; FLAT_BATCH];
        let mut big_b = [0.0; FLAT_BATCH];
        let mut other = false;
        for i in 0..n {
            let x = xs[i];
            let (s, c) = half_angle_off_axis(r, x, rt);
            let b = k.omega2 * x;
            let ab4 = 4.0 * a * b;
            let aa = (a - b) * (a - b);
            other |= (x == 0.0) | (aa == 0.0) | ((ab4 < 0.0) & (s * s > 0.5)) | needs_scaling(a, b);
            (sin[i], big_a[i], big_b[i]) = (s, aa, ab4);
            (queue.x[i], queue.y[i], queue.z[i]) = PendingG::arguments(s, c, aa, ab4);
        }
        if other {
            return false;
        }
        queue.len = n;
        queue.evaluate();
        for i in 0..n {
            let (s, aa, ab4) = (sin[i], big_a[i], big_b[i]);
            let g = PendingG::from_pair(s, aa, ab4, queue.rf[i], queue.rd[i]);
            out[i] = PendingRate::finish(k.scale, Sliding::direct(g), level[i]);
        }
        true
    }

    /// Any batch, point by point: each point's rate known at once or its Carlson integrals
    /// queued, then the queue evaluated and the rates finished.
    fn batch_point_by_point(
        &self,
        xs: &[f64],
        out: &mut [f64],
        queue: &mut CarlsonQueue<FLAT_QUEUE>,
    ) {
        let k = self.kernel;
        let r = self.r_mm;
        queue.len = 0;
        let mut pending = [PendingRate::Known(0.0); FLAT_BATCH];
        for (p, &x) in pending.iter_mut().zip(xs) {
            let pressure = k.path_pressure(x, x);
            *p = if pressure.slope_per_mm != 0.0 || k.translation {
                PendingRate::Known(k.rate_under(&pressure, r, x))
            } else if pressure.level == 0.0 {
                PendingRate::Known(0.0)
            } else {
                k.queue_nominal(r, x, pressure.level, queue)
            };
        }
        queue.evaluate();
        for (o, p) in out.iter_mut().zip(&pending) {
            *o = p.value(k.scale, queue);
        }
    }
}

impl RemovalKernel {
    /// The rate at nominal pressure on a plane away from η = −1, times `level`, with its
    /// Carlson integrals queued (or known at once where none are needed, or at extreme
    /// speeds, which are rescaled and taken alone).
    fn queue_nominal<const N: usize>(
        &self,
        r: f64,
        x: f64,
        level: f64,
        queue: &mut CarlsonQueue<N>,
    ) -> PendingRate {
        let psi = half_angle(r, x, self.tool_radius);
        if !psi.is_contact() {
            return PendingRate::Known(0.0);
        }
        let (a, b) = (self.omega_sum * r, self.omega2 * x);
        if needs_scaling(a, b) {
            return PendingRate::Known(self.scale * sliding_integral(a, b, psi) * level);
        }
        PendingRate::Sliding {
            sliding: Sliding::queue(a, b, psi, queue),
            level,
        }
    }
}

/// The zeros of `g` on [`from`, `to`] where it changes sign between 8 equal samples (finite
/// values only), each refined by regula falsi.
pub(super) fn crossings(g: &dyn Fn(f64) -> f64, from: f64, to: f64) -> Vec<f64> {
    const SAMPLES: usize = 8;
    let mut zeros = Vec::new();
    let mut a = (from, g(from));
    for i in 1..=SAMPLES {
        let x = from + (to - from) * i as f64 / SAMPLES as f64;
        let b = (x, g(x));
        if a.1.is_finite() && b.1.is_finite() && (a.1 < 0.0) != (b.1 < 0.0) {
            zeros.push(illinois(g, a, b, 1e-14 * to, 0.0));
        }
        a = b;
    }
    zeros
}

/// `points` within [lo, hi] (both kept), ascending, without repeats.
pub(super) fn inside(mut points: Vec<f64>, lo: f64, hi: f64) -> Vec<f64> {
    points.retain(|x| x.is_finite() && *x >= lo && *x <= hi);
    points.extend([lo, hi]);
    points.sort_by(f64::total_cmp);
    points.dedup();
    points
}

/// ∫_0^{θ0} V dθ for V² = (a−b)² + 4ab·sin²(θ/2), θ0 = 2ψ0.
///
/// The integral is homogeneous of degree 1 in (a, b), so extreme (a, b) are first scaled by a
/// power of two to magnitude ~1 (exact): tiny speeds or radii (a tool centre 1e-159 mm from the
/// axis) then cannot underflow the squares below. Ordinary inputs skip the scaling.
fn sliding_integral(a: f64, b: f64, psi: HalfAngle) -> f64 {
    homogeneous(
        a,
        b,
        |a, b| scaled_sliding_integral(a, b, psi),
        |v, up| up(v),
    )
}

/// Whether (a, b) must be scaled before their squares are taken: within 2^±300 neither the
/// squares of speeds nor R_D (of degree −3/2 in them, so ~size⁻³) under- or overflow (nor for
/// a = b = 0).
fn needs_scaling(a: f64, b: f64) -> bool {
    let size = a.abs().max(b.abs());
    size != 0.0 && !(2f64.powi(-300)..=2f64.powi(300)).contains(&size)
}

/// `integral(a, b)` of an integral homogeneous of degree 1 in (a, b), with extreme (a, b)
/// first scaled by a power of two to magnitude ~1 and the result scaled back by `back` (both
/// exact).
fn homogeneous<T>(
    a: f64,
    b: f64,
    integral: impl Fn(f64, f64) -> T,
    back: impl Fn(T, &dyn Fn(f64) -> f64) -> T,
) -> T {
    if !needs_scaling(a, b) {
        return integral(a, b);
    }
    let size = a.abs().max(b.abs());
    // Scale by 2^−e in two halves: for a subnormal size e is below −1022, and 2^−e itself
    // would overflow (0·∞ = NaN at r = 0). Each factor is a power of two, so this is exact.
    let exponent = size.log2().floor() as i32;
    let (half, rest) = (exponent / 2, exponent - exponent / 2);
    let down = |x: f64| x * 2f64.powi(-half) * 2f64.powi(-rest);
    let up = |x: f64| x * 2f64.powi(half) * 2f64.powi(rest);
    back(integral(down(a), down(b)), &up)
}

/// [`sliding_integral`] for max(|a|, |b|) far from under- and overflow.
fn scaled_sliding_integral(a: f64, b: f64, psi: HalfAngle) -> f64 {
    let mut queue = CarlsonQueue::<2>::new();
    let sliding = Sliding::queue(a, b, psi, &mut queue);
    queue.evaluate();
    sliding.value(&queue)
}

/// [`scaled_sliding_integral`] in the arrangement without cancellation (module docs), its
/// Carlson integrals queued: 2·G(ψ0; (a−b)², 4ab), or 2·[G(π/2; (a+b)², −4ab) −
/// G(π/2 − ψ0; (a+b)², −4ab)] when ab < 0 and ψ0 > π/4.
#[derive(Clone, Copy)]
enum Sliding {
    Direct(PendingG),
    Complement { all: PendingG, rest: PendingG },
}

impl Sliding {
    fn queue<const N: usize>(a: f64, b: f64, psi: HalfAngle, queue: &mut CarlsonQueue<N>) -> Self {
        let ab4 = 4.0 * a * b;
        if ab4 >= 0.0 || psi.sin * psi.sin <= 0.5 {
            Sliding::Direct(PendingG::queue(
                psi.sin,
                psi.cos,
                (a - b) * (a - b),
                ab4,
                queue,
            ))
        } else {
            let sum2 = (a + b) * (a + b);
            Sliding::Complement {
                all: PendingG::queue(1.0, 0.0, sum2, -ab4, queue),
                rest: PendingG::queue(psi.cos, psi.sin, sum2, -ab4, queue),
            }
        }
    }

    /// ∫_0^{θ0} V dθ in the direct arrangement, from G(ψ0; (a−b)², 4ab).
    #[inline(always)]
    fn direct(g: f64) -> f64 {
        2.0 * g
    }

    /// ∫_0^{θ0} V dθ, once `queue` is evaluated.
    fn value<const N: usize>(self, queue: &CarlsonQueue<N>) -> f64 {
        match self {
            Sliding::Direct(g) => Self::direct(g.value(queue)),
            Sliding::Complement { all, rest } => 2.0 * (all.value(queue) - rest.value(queue)),
        }
    }
}

/// ∫_0^{θe} V dθ and ∫_0^{θe} cos θ·V dθ over the arc under the pad (θe = 2ψ).
#[derive(Debug, Clone, Copy, PartialEq)]
struct ArcIntegrals {
    speed: f64,
    cos_speed: f64,
}

/// [`ArcIntegrals`] for V² = (a−b)² + 4ab·sin²(θ/2). With ψ = θ/2, cos θ = 1 − 2·sin²ψ and
/// the reduction d(s·c·V)/dψ = (A + 2(B − A)·s² − 3B·s⁴)/V (s = sin ψ, c = cos ψ,
/// V² = A + B·s²) eliminate ∫s⁴/V, leaving
///
/// ```text
/// ∫_0^{2φ} cos θ·V dθ = (2/3)·[A·I0 − (2A + B)·I2 + 2·s·c·V(φ)],
/// I0 = ∫_0^φ dψ/V = s·R_F(A·c², A + B·s², A),   I2 = ∫_0^φ s²/V dψ = (A·s³/3)·R_D(…)
/// ```
///
/// from the same R_F and R_D as ∫V dθ; the arrangements are those of [`sliding_integral`], and
/// extreme speeds are scaled as there ([`homogeneous`]).
fn arc_integrals(a: f64, b: f64, psi: HalfAngle) -> ArcIntegrals {
    homogeneous(
        a,
        b,
        |a, b| scaled_arc_integrals(a, b, psi),
        |v, up| ArcIntegrals {
            speed: up(v.speed),
            cos_speed: up(v.cos_speed),
        },
    )
}

fn scaled_arc_integrals(a: f64, b: f64, psi: HalfAngle) -> ArcIntegrals {
    let ab4 = 4.0 * a * b;
    if ab4 >= 0.0 || psi.sin * psi.sin <= 0.5 {
        let (g, cos_weighted) = g_pair(psi.sin, psi.cos, (a - b) * (a - b), ab4);
        ArcIntegrals {
            speed: 2.0 * g,
            cos_speed: cos_weighted,
        }
    } else {
        // χ = π/2 − ψ: cos θ = −(1 − 2·sin²χ), V² = (a + b)² − 4ab·sin²χ.
        let sum2 = (a + b) * (a + b);
        let (g_all, c_all) = g_pair(1.0, 0.0, sum2, -ab4);
        let (g_rest, c_rest) = g_pair(psi.cos, psi.sin, sum2, -ab4);
        ArcIntegrals {
            speed: 2.0 * (g_all - g_rest),
            cos_speed: c_rest - c_all,
        }
    }
}

/// G(φ; A, B) (see [`g`]) and ∫_0^{2φ} cos θ·√(A + B·sin²(θ/2)) dθ, from one R_F, R_D pair.
fn g_pair(s: f64, c: f64, a: f64, b: f64) -> (f64, f64) {
    if s == 0.0 {
        return (0.0, 0.0);
    }
    let s2 = s * s;
    let v = (a + b * s2).sqrt();
    if a == 0.0 {
        // V = √B·s: I2 = (1 − c)/√B and A·I0 → 0.
        let one_minus_c = s2 / (1.0 + c);
        let root = b.sqrt();
        return (
            root * one_minus_c,
            2.0 / 3.0 * root * (2.0 * s2 * c - one_minus_c),
        );
    }
    let (rf, rd) = rf_rd(a * c * c, a + b * s2, a);
    let i0 = s * rf;
    let i2 = a * s * s2 * rd / 3.0;
    (
        a * i0 + b * i2,
        2.0 / 3.0 * (a * i0 - (2.0 * a + b) * i2 + 2.0 * s * c * v),
    )
}

/// Removal rate in nm/min at radius `r_mm` with the tool centre at `r1_mm`.
pub fn removal_rate_nm_per_min(process: &Process, r_mm: f64, r1_mm: f64) -> f64 {
    60.0 * RemovalKernel::new(process).rate_nm_per_s(r_mm, r1_mm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::path::Pointwise;

    /// The lens closed form at η = −1 equals the adaptive running integral of the rate, on
    /// rings on the axis, inside the pad's radius, at it, in the middle and at the edge, read
    /// before, inside and after each ring's support and at the reach.
    #[test]
    fn at_eta_minus_one_the_running_integral_is_a_lens_area() {
        use crate::physics::process::tests::paper_spec;
        let kernel = RemovalKernel::new(&Process::new(paper_spec(200.0, 200.0)).unwrap());
        let reach = kernel.reach_mm;
        for r in [0.0, 0.3, 4.0, 10.0, 10.5, 25.0, 47.0, 50.0] {
            let RunningIntegral::Lens(lens) = kernel.path_integral(r, reach) else {
                panic!("η = −1 on a plane has the closed form");
            };
            let panels = PathIntegral::new(
                Pointwise(|x| kernel.rate_nm_per_s(r, x)),
                &kernel.flat_breakpoints(r),
                Resolution {
                    tolerance: 1e-13,
                    ..FLAT_PATH
                },
                kernel.lobatto,
            );
            let whole = panels.total();
            for x in [
                0.0,
                0.5 * r,
                r - 9.9,
                r - 3.0,
                r,
                r + 0.01,
                r + 7.0,
                r + 10.0,
                reach,
                99.0,
            ] {
                let (want, got) = (panels.at(x), lens.at(x));
                assert!(
                    (got - want).abs() <= 1e-12 * whole,
                    "r {r}, x {x}: lens {got}, panels {want}"
                );
            }
        }
    }

    /// The batched rate along a path is the pointwise rate, bit for bit: both rotation
    /// senses (both of the arrangements for ab < 0), η = −1, constant force past the edge
    /// and a linear pad (taken point by point), on the axis, at tangency and off the reach.
    #[test]
    fn a_row_in_batches_is_the_rate_point_by_point() {
        use crate::physics::process::tests::paper_spec;
        use crate::physics::ProcessSpec;
        let specs = [
            paper_spec(-10.0, 200.0),
            paper_spec(30.0, -200.0),
            paper_spec(-190.0, 200.0),
            paper_spec(150.0, 150.0),
            ProcessSpec {
                pressure_model: PressureModel::ConstantForce,
                ..paper_spec(-10.0, 200.0)
            },
            ProcessSpec {
                pressure_model: PressureModel::Linear {
                    pad_moment_share: 0.5,
                },
                ..paper_spec(-10.0, 200.0)
            },
        ];
        for spec in specs {
            let kernel = RemovalKernel::new(&Process::new(spec.clone()).unwrap());
            for r in [0.0_f64, 0.3, 9.99, 10.0, 17.0, 44.5, 50.0] {
                let xs: Vec<f64> = (0..=77)
                    .map(|k| k as f64 * 49.9 / 77.0)
                    .chain([r, (r - 10.0).abs(), r + 10.0])
                    .collect();
                let mut batch = vec![f64::NAN; xs.len()];
                FlatRow::new(&kernel, r, None).values(&xs, &mut batch);
                for (&x, &got) in xs.iter().zip(&batch) {
                    let want = kernel.rate_under(&kernel.path_pressure(x, x), r, x);
                    assert_eq!(got.to_bits(), want.to_bits(), "{spec:?}: r {r}, x {x}");
                }
            }
        }
    }

    /// At r = 0 the pad slides at |ω2|·r1 everywhere on the circle, so R = K·P·|ω2|·r1 exactly,
    /// also for a tool centre so close to the axis that the squares of the speeds underflow.
    #[test]
    fn the_centre_is_exact_down_to_tiny_tool_offsets() {
        use crate::physics::process::tests::paper_spec;
        let kernel = RemovalKernel::new(&Process::new(paper_spec(-10.0, 200.0)).unwrap());
        let per_mm = kernel.rate_nm_per_s(0.0, 1.0);
        for r1 in [5.0, 1e-3, 1e-100, 2.6e-159, 1e-300] {
            let rate = kernel.rate_nm_per_s(0.0, r1);
            assert!(
                (rate - per_mm * r1).abs() <= 1e-14 * per_mm * r1,
                "r1 = {r1}: {rate} vs {}",
                per_mm * r1
            );
        }
    }

    /// A subnormal or tiny sliding speed at the centre (found by schemathesis: tool 2.2e-313
    /// and 2.5e-105 r/min): neither the rescaling nor R_D (~speed⁻³) may overflow, and
    /// R = K·P·|ω2|·r1 there still (to the precision a subnormal result has), never NaN.
    #[test]
    fn the_centre_is_finite_for_subnormal_sliding_speeds() {
        use crate::physics::process::tests::paper_spec;
        use crate::physics::ProcessSpec;
        for tool_rpm in [
            -2.2250738585e-313,
            1e-320,
            -5e-324,
            -2.4936325394808987e-105,
            1e-95,
        ] {
            let process = Process::new(ProcessSpec {
                workpiece_rpm: -1e5,
                tool_rpm,
                ..paper_spec(-10.0, 200.0)
            })
            .unwrap();
            let kernel = RemovalKernel::new(&process);
            let r1 = 7.94e-7;
            let rate = kernel.rate_nm_per_s(0.0, r1);
            let expected = process.preston_rate_scale() * process.omega2_rad_per_s().abs() * r1;
            assert!(rate.is_finite() && rate >= 0.0, "tool {tool_rpm}: {rate}");
            assert!(
                (rate - expected).abs() <= 1e-2 * expected.max(f64::MIN_POSITIVE) + 1e-322,
                "tool {tool_rpm}: {rate} vs {expected}"
            );
        }
    }

    /// Over every decade of tool speed the API accepts (down to subnormal) and tool offsets
    /// from 1e-300 mm, with r at the centre, inside and at the edge of the pad, the rate is
    /// finite and non-negative: no overflow in the rescaling or in R_F/R_D.
    #[test]
    fn the_rate_is_finite_over_every_decade_of_speed() {
        use crate::physics::ProcessSpec;
        for tool_exp in (-323..=5).step_by(4) {
            for workpiece_rpm in [-1e5, -1.0, 1e-300, 3.0] {
                let process = Process::new(ProcessSpec {
                    workpiece_rpm,
                    tool_rpm: -(10f64.powi(tool_exp)),
                    ..crate::physics::process::tests::paper_spec(-10.0, 200.0)
                })
                .unwrap();
                let kernel = RemovalKernel::new(&process);
                for r1 in [1e-300f64, 1e-100, 7.94e-7, 0.5, 9.0, 45.0] {
                    for r in [0.0, 1e-200, r1, r1 + 5.0, (r1 + 9.999).min(50.0)] {
                        let rate = kernel.rate_nm_per_s(r, r1);
                        assert!(
                            rate.is_finite() && rate >= 0.0,
                            "tool 1e{tool_exp}, workpiece {workpiece_rpm}, r {r}, r1 {r1}: {rate}"
                        );
                    }
                }
            }
        }
    }

    /// G(φ; A, B) alone, as [`PendingG`] computes it.
    fn g(s: f64, c: f64, a: f64, b: f64) -> f64 {
        let mut queue = CarlsonQueue::<1>::new();
        let g = PendingG::queue(s, c, a, b, &mut queue);
        queue.evaluate();
        g.value(&queue)
    }

    /// G against a composite Simpson rule on a smooth integrand (error ~h⁴ ≈ 1e-13).
    #[test]
    fn g_matches_simpson() {
        for (phi, a, b) in [
            (0.3_f64, 2.0, 5.0),
            (1.2, 0.5, 3.0),
            (std::f64::consts::FRAC_PI_2, 1.0, 0.0),
            (0.7, 4.0, -3.0),
            (1.5, 0.3, 2.0),
        ] {
            let n = 2000;
            let h = phi / n as f64;
            let f = |x: f64| (a + b * x.sin().powi(2)).sqrt();
            let mut sum = f(0.0) + f(phi);
            for i in 1..n {
                sum += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
            }
            let simpson = sum * h / 3.0;
            let got = g(phi.sin(), phi.cos(), a, b);
            assert!((got - simpson).abs() < 1e-11 * simpson, "{phi} {a} {b}");
        }
    }

    #[test]
    fn g_with_zero_a_is_exact() {
        let got = g(0.6, 0.8, 0.0, 4.0);
        assert!((got - 2.0 * 0.2).abs() < 1e-15);
    }
}
