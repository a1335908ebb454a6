//! Removal on a curved part: a surface of revolution z(r) turning about its axis at ω_w, and a
//! pad of radius r_t that conforms to it, centred on the surface point P₀ at radial position
//! r1 and spinning at ω_t about its axis a (lab frame, counter-clockwise positive seen from
//! the tool, as everywhere in Preston).
//!
//! **Kinematics.** A surface point X at radius r and azimuth φ (measured from the pad centre's
//! meridian) moves with the workpiece at ω_w·ẑ × X; the pad moves there at ω_t·a × (X − P₀).
//! The sliding velocity is the difference, less its part along the surface normal m(X):
//!
//! ```text
//! v = ω_w·ẑ × X − ω_t·a × (X − P₀),     v_t = v − (v·m)·m
//! ```
//!
//! The spin axis a is the surface normal at P₀ (orientation `normal`), or ẑ (orientation
//! `vertical`, for machines without a tilt axis: the pad still conforms to the surface and
//! presses along the normal, but it spins about a vertical axis through P₀). Writing
//! X = (r·cosφ, r·sinφ, z), P₀ = (r1, 0, z₁), a = (a_x, 0, a_z) and m = (−sinθ·cosφ,
//! −sinθ·sinφ, cosθ) (θ the slope angle at r), the components are
//!
//! ```text
//! v = (A·r·sinφ,  B − A·r·cosφ,  C·r·sinφ),   A = ω_t·a_z − ω_w,  B = ω_t·(a_z·r1 + a_x·(z − z₁)),
//! C = −ω_t·a_x,    v·m = D·sinφ,   D = C·r·cosθ − B·sinθ
//! |v_t|² = E·sin²φ + (B − A·r·cosφ)²,   E = (A² + C²)·r² − D²
//! ```
//!
//! On a plane (θ = 0, a = ẑ) this is the flat model's V² = a² + b² − 2ab·cosφ.
//!
//! **Contact.** The pad covers the points within geodesic distance r_t of P₀. On a sphere of
//! radius ρ that is exactly the ball |X − P₀| ≤ c_t with the chord c_t = 2ρ·sin(r_t/(2ρ)). On an
//! asphere Preston uses the same ball with ρ = 1/H, H = (κ_m + κ_s)/2 the mean curvature at P₀
//! (κ_m = z″·cos³θ meridional, κ_s = sinθ/r sagittal). It is exact on planes and spheres; on
//! an asphere, since a geodesic of length s has chord s − κ_n²·s³/24 + O(s⁴) (κ_n the normal
//! curvature along it, κ_n = H + Δ·cos2ψ by Euler with Δ = (κ_m − κ_s)/2), the contact edge
//! lies within r_t³·|Δ|·(2|H| + |Δ|)/24 (leading order) of the geodesic circle.
//! A ring of radius r meets the ball in one arc |φ| ≤ φ₀ with
//!
//! ```text
//! |X − P₀|² = (r − r1)² + (z − z₁)² + 4·r·r1·sin²(φ/2)  ⇒  the flat contact of a pad of radius
//! c_eff = √(c_t² − (z − z₁)²)
//! ```
//!
//! so φ₀ comes in closed form from [`super::contact::half_angle`] (exact at tangency).
//!
//! **The rate.** R(r; r1) = K·P/π·∫₀^φ₀ |v_t| dφ (|v_t| is even in φ), along the normal. The
//! integrand is smooth except where the sliding speed nearly vanishes, so the integral is taken
//! by adaptive Gauss–Kronrod (7, 15) panels, extended to 31 points before one is halved
//! ([`super::kronrod`]), to an absolute tolerance of 1e-10 of the largest speed on the arc
//! times the arc; the band |r − r1| < c_t ≤ r_t stays that of the flat operator. |v_t|
//! depends on φ only through cos φ and sin²φ, so the rule runs in u = sin(φ/2) up to
//! φ = π/2 and in w = cos(φ/2) beyond (cos φ = 1 − 2u² = 2w² − 1,
//! dφ = 2·du/√(1 − u²)): the arc's end is the contact's half-angle as computed, and no node
//! needs a trigonometric function. Where the speed nearly vanishes it does so at φ = 0 or π,
//! as the hyperbola √(δ² + c₂t²) in t = u or w; that hyperbola (times the start of the rest's
//! Taylor series) is integrated in closed form and only the smooth remainder by quadrature,
//! which then needs no bisection down to the hyperbola's waist (`side_integral`).
//!
//! **Pressure.** The pressure models are the plane's taken in the developed plane (the point
//! at arc length s and azimuth φ placed at (s·cos φ, s·sin φ)): the edge is the circle of
//! radius s_m, the pad the disc of radius r_t about (s1, 0). Under a linear pad the integrand
//! is weighted by p/P = level + slope·(s·cos φ − s1), zero beyond the lift line, which cuts
//! the arc at cos φ = u0/s.

use std::f64::consts::{FRAC_1_SQRT_2, PI};

use super::contact::{half_angle_of_squared_reach, HalfAngle};
use super::kronrod::adaptive_gauss_kronrod;
use super::pressure::{pad_pressure, PadPressure, PressureModel};
use crate::surface::Surface;

/// The arc under the pad (its half-angle ψ = φ0/2) and the sliding speed on it:
/// |v_t|² = e·sin²φ + (b − f·cos φ)², with b = B, f = A·r and e = E of the module docs.
struct ArcSpeed {
    psi: HalfAngle,
    b: f64,
    f: f64,
    e: f64,
}

/// The pad's pressure along a ring's arc, relative to nominal: max(0, level + slope·cos φ).
#[derive(Debug, Clone, Copy)]
struct Weight {
    level: f64,
    slope: f64,
}

impl Weight {
    const NOMINAL: Weight = Weight {
        level: 1.0,
        slope: 0.0,
    };

    #[inline(always)]
    fn at(self, cos: f64) -> f64 {
        (self.level + self.slope * cos).max(0.0)
    }
}

/// [`CurvedKernel::arc_rate`]'s work, for [`crate::wide::widest`].
struct ArcRate<'a> {
    kernel: &'a CurvedKernel,
    ring: &'a Ring,
    site: &'a Site,
    end: HalfAngle,
    most: f64,
    weight: Weight,
}

/// The sliding speed's near zero is taken out of a side's integrand in closed form when the
/// hyperbola's waist δ/√c₂ is narrower than this fraction of the side's range.
const NARROW_WAIST: f64 = 1.0;

impl crate::wide::Wide for ArcRate<'_> {
    type Output = f64;

    /// The arc rate itself ([`CurvedKernel::arc_rate`] has the mathematics), inlined into
    /// each build.
    #[inline(always)]
    fn run(self) -> f64 {
        let ArcRate {
            kernel,
            ring,
            site,
            end,
            most,
            weight,
        } = self;
        let Some(speed) = kernel.arc_speed(ring, site) else {
            return 0.0;
        };
        let psi = if end.sin < speed.psi.sin {
            end
        } else {
            speed.psi
        };
        // No sliding speed on the arc exceeds |B| + |A·r| + √|E|.
        let bound = most * (speed.b.abs() + speed.f.abs() + speed.e.abs().sqrt());
        if bound <= 0.0 || !psi.is_contact() {
            return 0.0;
        }
        // Within 1e-10 of the largest speed per radian of arc (dφ ≥ 2·du).
        let density = 2e-10 * bound;
        let near = 0.0..psi.sin.min(FRAC_1_SQRT_2);
        let mut total = side_integral(&speed, weight, 1.0, near, density);
        if psi.sin > FRAC_1_SQRT_2 {
            let far = psi.cos..FRAC_1_SQRT_2;
            total += side_integral(&speed, weight, -1.0, far, density);
        }
        kernel.scale * total
    }
}

/// ∫ weight(cos φ)·|v_t| dφ over one side of the arc, in t = u (`side` +1, φ ≤ π/2) or
/// t = w (`side` −1, φ ≥ π/2) over `range` = [lo, hi] (module docs): cos φ = ±(1 − 2t²),
/// sin²φ = 4t²(1 − t²), |dφ/dt| = 2/√(1 − t²), so the integrand is m(t)·√Q(t²) with
/// m(t) = 2·weight(cos φ)/√(1 − t²) and Q(x) = δ² + c₂·x + c₄·x², δ = B ∓ A·r,
/// c₂ = 4E ± 4A·r·δ, c₄ = 4(A·r)² − 4E.
///
/// Where δ is small the speed nearly vanishes at t = 0 (φ = 0 or π) and √Q is the hyperbola
/// √(δ² + c₂t²) there, which adaptive bisection resolves only by halving down to its waist.
/// Then m(t)·√Q − (m₀ + m₂t²)·√(δ² + c₂t²) (m₀ + m₂t² the start of m's Taylor series) is
/// integrated by quadrature, its near-singular part reduced to O(t⁴), and the part taken
/// out in closed form: with S = √(δ² + c₂t²), k = √c₂ and Λ = ln(k·t + S),
///
/// ```text
/// ∫ S dt = t·S/2 + δ²/(2k)·Λ,    ∫ t²·S dt = t·(2c₂t² + δ²)·S/(8c₂) − δ⁴/(8c₂k)·Λ
/// ```
///
/// The split is exact whatever m₀ and m₂ are; it pays where the waist δ/√c₂ is within the
/// side's range (measured on the sphere benchmark: 4.3 panels a side before, 1.6 after).
/// Elsewhere the integrand is smooth and taken as it is.
#[inline(always)]
fn side_integral(
    speed: &ArcSpeed,
    weight: Weight,
    side: f64,
    range: std::ops::Range<f64>,
    density: f64,
) -> f64 {
    let ArcSpeed { b, f, e, .. } = *speed;
    let std::ops::Range { start: lo, end: hi } = range;
    let integrand = |t: f64| {
        let (t2, rest) = (t * t, 1.0 - t * t);
        let cos = side * (1.0 - 2.0 * t2);
        let along = b - f * cos;
        let speed2 = (e * (4.0 * t2 * rest) + along * along).max(0.0);
        // |v_t|·|dφ/dt| as 2·√(|v_t|²/(1 − t²)), one root.
        2.0 * weight.at(cos) * (speed2 / rest).sqrt()
    };
    let delta = b - side * f;
    let (delta2, c2) = (delta * delta, 4.0 * e + 4.0 * side * f * delta);
    let w0 = weight.at(side);
    let narrow = NARROW_WAIST * hi;
    if !(c2 > 0.0 && w0 > 0.0 && delta2 < narrow * narrow * c2) {
        return adaptive_gauss_kronrod(&integrand, lo, hi, density);
    }
    // m(t) = 2·(w0 − 2·side·slope·t²)·(1 + t²/2 + …).
    let (m0, m2) = (2.0 * w0, w0 - 4.0 * side * weight.slope);
    let hyperbola = |t: f64| (delta2 + c2 * t * t).sqrt();
    let rest = |t: f64| integrand(t) - (m0 + m2 * t * t) * hyperbola(t);
    let k = c2.sqrt();
    let (s_lo, s_hi) = (hyperbola(lo), hyperbola(hi));
    let log = if delta2 > 0.0 {
        ((k * hi + s_hi) / (k * lo + s_lo)).ln()
    } else {
        0.0
    };
    let plain = 0.5 * (hi * s_hi - lo * s_lo) + delta2 / (2.0 * k) * log;
    let squared = (hi * (2.0 * c2 * hi * hi + delta2) * s_hi
        - lo * (2.0 * c2 * lo * lo + delta2) * s_lo)
        / (8.0 * c2)
        - delta2 * delta2 / (8.0 * c2 * k) * log;
    adaptive_gauss_kronrod(&rest, lo, hi, density) + m0 * plain + m2 * squared
}

/// How the pad's spin axis is carried.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Orientation {
    /// Along the surface normal at the pad centre (B follows the normal).
    #[default]
    Normal,
    /// Parallel to the workpiece axis (no tilt axis).
    Vertical,
}

/// The part under the pad: its surface and how the pad's spin axis is carried.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Part {
    pub surface: Surface,
    pub orientation: Orientation,
}

impl Part {
    pub fn flat() -> Part {
        Part::default()
    }

    pub fn is_flat(&self) -> bool {
        self.surface.is_plane()
    }
}

/// The geometry of one ring: a surface point at radius r on the pad centre's meridian, and
/// its arc length from the vertex where a linear pad needs it (NaN otherwise).
#[derive(Debug, Clone, Copy)]
pub struct Ring {
    r: f64,
    z: f64,
    sin: f64,
    cos: f64,
    arc: f64,
}

/// The removal kernel of a curved part (see the module docs). Speeds in rad/s, lab frame.
#[derive(Debug, Clone)]
pub struct CurvedKernel {
    part: Part,
    omega_workpiece: f64,
    omega_tool: f64,
    tool_radius: f64,
    /// Arc length of the workpiece edge, mm (for the edge's pressure).
    edge_arc_mm: f64,
    pressure_model: PressureModel,
    /// K·P/π in (nm/s) per (mm/s · rad).
    scale: f64,
    /// The contact chord where it is the same at every site (a sphere's).
    sphere_chord: Option<f64>,
}

/// A pad position: its centre (and its arc length, as [`Ring`]'s), spin axis and contact chord.
#[derive(Debug, Clone, Copy)]
pub struct Site {
    r1: f64,
    arc1: f64,
    z1: f64,
    axis_x: f64,
    axis_z: f64,
    chord: f64,
    arc_integrand: f64,
}

impl Site {
    /// The centre's arc length from the vertex, mm (NaN unless the pad is linear).
    pub fn arc_mm(&self) -> f64 {
        self.arc1
    }

    /// ds/dr1 at the centre, √(1 + z′²): a path's rate per mm of radius is per mm of arc
    /// times this.
    pub fn arc_integrand(&self) -> f64 {
        self.arc_integrand
    }
}

/// The contact chord c_t = 2·sin(h)/H = r_t·sin(h)/h, h = r_t·H/2, of a pad of radius r_t on a
/// ball of mean curvature H (module docs).
fn chord(tool_radius: f64, mean_curvature: f64) -> f64 {
    let half = 0.5 * tool_radius * mean_curvature;
    // The quotient is 1 − h²/6 + … for tiny h.
    if half.abs() < 1e-8 {
        tool_radius * (1.0 - half * half / 6.0)
    } else {
        tool_radius * half.sin() / half
    }
}

impl CurvedKernel {
    pub fn new(
        part: Part,
        omega_workpiece: f64,
        omega_tool: f64,
        tool_radius: f64,
        workpiece_radius: f64,
        pressure_model: PressureModel,
        scale: f64,
    ) -> CurvedKernel {
        let edge_arc_mm = part.surface.arc_length_mm(workpiece_radius);
        // A sphere's mean curvature is its curvature everywhere.
        let sphere_chord = part
            .surface
            .is_sphere()
            .then(|| chord(tool_radius, part.surface.vertex_curvature_per_mm()));
        CurvedKernel {
            sphere_chord,
            part,
            omega_workpiece,
            omega_tool,
            tool_radius,
            edge_arc_mm,
            pressure_model,
            scale,
        }
    }

    pub fn surface(&self) -> &Surface {
        &self.part.surface
    }

    /// The arc length of radius `r_mm` if a linear pad needs it, else NaN.
    fn arc_if_linear(&self, r_mm: f64) -> f64 {
        match self.pressure_model {
            PressureModel::Linear { .. } => self.part.surface.arc_length_mm(r_mm),
            _ => f64::NAN,
        }
    }

    /// The ring at radius `r_mm`.
    pub fn ring(&self, r_mm: f64) -> Ring {
        let local = self.part.surface.local(r_mm);
        let (sin, cos) = local.slope_sin_cos();
        Ring {
            r: r_mm,
            z: local.sag_mm,
            sin,
            cos,
            arc: self.arc_if_linear(r_mm),
        }
    }

    /// The pad at radial position `r1_mm`.
    pub fn site(&self, r1_mm: f64) -> Site {
        let surface = &self.part.surface;
        // A sphere's chord is the same everywhere (`Ok`); elsewhere it comes from the
        // surface's curvature z″ here (`Err`), which a sphere's site need not compute.
        let (z1, (arc_integrand, sin1, cos1), known_chord) = match self.sphere_chord {
            Some(chord) => {
                let (sag, frame) = surface.sag_and_frame(r1_mm);
                (sag, frame, Ok(chord))
            }
            None => {
                let local = surface.local(r1_mm);
                let frame = crate::surface::slope_frame(local.slope);
                (local.sag_mm, frame, Err(local.second_derivative))
            }
        };
        let (axis_x, axis_z) = match self.part.orientation {
            Orientation::Normal => (-sin1, cos1),
            Orientation::Vertical => (0.0, 1.0),
        };
        let chord = known_chord.unwrap_or_else(|second_derivative| {
            let meridional = second_derivative * cos1 * cos1 * cos1;
            let sagittal = if r1_mm > 0.0 {
                sin1 / r1_mm
            } else {
                surface.second_derivative(0.0)
            };
            chord(self.tool_radius, 0.5 * (meridional + sagittal))
        });
        Site {
            r1: r1_mm,
            arc1: self.arc_if_linear(r1_mm),
            z1,
            axis_x,
            axis_z,
            chord,
            arc_integrand,
        }
    }

    /// The pressure with the pad at `r1_mm` (see [`PadPressure`]): the flat models with arc
    /// lengths in place of radii (the pad, its centre and the part's edge measured along the
    /// surface, the pad's lens and its moments taken in that developed plane), the linear
    /// pressure varying with the developed radial coordinate u = s(r)·cos φ of the ring point
    /// at arc length s(r) and azimuth φ.
    pub fn pad_pressure(&self, r1_mm: f64) -> PadPressure {
        pad_pressure(
            self.pressure_model,
            self.edge_arc_mm,
            self.tool_radius,
            self.part.surface.arc_length_mm(r1_mm),
        )
        .unwrap_or(PadPressure::NONE)
    }

    /// The rate on `ring` with the pad at `site` under `pressure` (its [`Self::pad_pressure`]):
    /// K·P/π·∫ p(u)/P·|v_t| dφ over the arc under the pad and beyond the lift line
    /// (s·cos φ ≥ u0), nm/s.
    pub fn rate_nm_per_s(&self, ring: &Ring, site: &Site, pressure: &PadPressure) -> f64 {
        if pressure.slope_per_mm == 0.0 {
            return pressure.level * self.nominal_rate_nm_per_s(ring, site);
        }
        let mut end = HalfAngle::FULL;
        if let Some(lift) = pressure.lift_line_mm() {
            let Some(cut) = end.cut_at(site.arc1 + lift, ring.arc) else {
                return 0.0;
            };
            end = cut;
        }
        let level = pressure.level - pressure.slope_per_mm * site.arc1;
        let slope = pressure.slope_per_mm * ring.arc;
        // The weight is largest at φ = 0 (slope > 0).
        let most = level + slope;
        self.arc_rate(ring, site, end, most, Weight { level, slope })
    }

    /// Removal rate at nominal pressure on `ring` with the pad at `site`, nm/s.
    pub fn nominal_rate_nm_per_s(&self, ring: &Ring, site: &Site) -> f64 {
        self.arc_rate(ring, site, HalfAngle::FULL, 1.0, Weight::NOMINAL)
    }

    /// K·P/π·∫₀^min(φ0, φe) weight(cos φ)·|v_t| dφ, φ0 the arc under the pad and φe/2 = `end`;
    /// `most` bounds the weight (for the tolerance).
    ///
    /// |v_t| depends on φ through cos φ and sin²φ alone, so the integral is taken in the
    /// half-angle's sine u = sin(φ/2) (cos φ = 1 − 2u², sin²φ = 4u²(1 − u²),
    /// dφ = 2·du/√(1 − u²)) up to φ = π/2, and beyond in its cosine w = cos(φ/2)
    /// (cos φ = 2w² − 1, dφ = −2·dw/√(1 − w²)): the ends come from the contact's half-angle
    /// as they are, and no node needs a trigonometric function. Both variables stay within
    /// [0, √½], well clear of the Jacobian's singularity at 1.
    fn arc_rate(&self, ring: &Ring, site: &Site, end: HalfAngle, most: f64, weight: Weight) -> f64 {
        crate::wide::widest(ArcRate {
            kernel: self,
            ring,
            site,
            end,
            most,
            weight,
        })
    }
}

impl CurvedKernel {
    /// The arc of `ring` under the pad at `site` and the sliding speed on it (module docs),
    /// or `None` where the pad does not touch the ring.
    fn arc_speed(&self, ring: &Ring, site: &Site) -> Option<ArcSpeed> {
        let psi = covered_arc(ring, site)?;
        let (a, b, e) = self.speed_terms(ring, site);
        Some(ArcSpeed {
            psi,
            b,
            f: a * ring.r,
            e,
        })
    }

    /// The sliding speed's terms A, B and E on `ring` with the pad at `site` (module docs).
    fn speed_terms(&self, ring: &Ring, site: &Site) -> (f64, f64, f64) {
        let dz = ring.z - site.z1;
        let (w, t) = (self.omega_workpiece, self.omega_tool);
        let a = t * site.axis_z - w;
        let b = t * (site.axis_z * site.r1 + site.axis_x * dz);
        let c = -t * site.axis_x;
        let d = c * ring.r * ring.cos - b * ring.sin;
        (a, b, (a * a + c * c) * ring.r * ring.r - d * d)
    }

    /// The tool positions (radii, ascending) that bound the support of R(`ring`; ·), clipped
    /// to `reach_mm`, with the kinks inside it: where the pad's contact ball becomes tangent
    /// to the ring on the pad centre's side (|X − P₀| = c_t at φ = 0) or starts to cover it
    /// whole (at φ = π), where the sliding speed vanishes (B = A·r at φ = 0), and where the pad
    /// reaches the edge under constant force or linear pressure (a linear pad's lift adds its
    /// own, [`Self::lift_kinks`]). On a sphere the tangencies are the arc lengths
    /// s(r) ± r_t and r_t − s(r); they are found as roots, so an asphere's chord is honoured.
    pub fn breakpoints(&self, ring: &Ring, reach_mm: f64) -> Vec<f64> {
        let surface = &self.part.surface;
        let rt = self.tool_radius;
        let r = ring.r;
        // (ring point at φ = 0, or at φ = π for `far`) to the pad centre, less the chord².
        let gap = |x: f64, far: bool| {
            let across = if far { r + x } else { r - x };
            let dz = ring.z - surface.sag_mm(x);
            let chord = self.site(x).chord;
            across * across + dz * dz - chord * chord
        };
        let top = (r + rt).min(reach_mm);
        let mut points = Vec::new();
        // On a sphere the tangencies are where the arc lengths differ by r_t (module docs):
        // each root is first sought in a hair's bracket about that.
        let ring_arc = surface.is_sphere().then(|| surface.arc_length_mm(r));
        let at_arc =
            |arc: fn(f64, f64) -> f64| ring_arc.map(|s| surface.radius_at_arc_length(arc(s, rt)));
        let near = |x| gap(x, false);
        // The pad's near rim: between r − r_t (out of reach) and r (on the ring).
        let low = (r - rt).max(0.0);
        let g_low = gap(low, false);
        let lo = if g_low > 0.0 {
            let guess = at_arc(|s, rt| s - rt);
            root_near(&near, guess, (low, g_low), (r, gap(r, false)))
        } else {
            0.0
        };
        // The far rim, beyond r, unless the reach ends first.
        let g_top = gap(top, false);
        let hi = if g_top > 0.0 && top > r {
            let guess = at_arc(|s, rt| s + rt);
            root_near(&near, guess, (r, gap(r, false)), (top, g_top))
        } else {
            top
        };
        // The whole ring under the pad while the ring's far side is within the chord.
        let g_axis = gap(0.0, true);
        if g_axis < 0.0 {
            let end = rt.min(top);
            let g_end = gap(end, true);
            if g_end > 0.0 {
                let far = |x| gap(x, true);
                let guess = at_arc(|s, rt| rt - s);
                points.push(root_near(&far, guess, (0.0, g_axis), (end, g_end)));
            }
        }
        if self.pressure_model != PressureModel::Uniform && self.edge_arc_mm > rt {
            points.push(surface.radius_at_arc_length(self.edge_arc_mm - rt));
        }
        let mut points = super::removal::inside(points, lo, hi);
        // The sliding speed's zero at φ = 0: a sign change of B − A·r within a piece.
        let slip = |x: f64| {
            let site = self.site(x);
            let (w, t) = (self.omega_workpiece, self.omega_tool);
            let b = t * (site.axis_z * site.r1 + site.axis_x * (ring.z - site.z1));
            b - (t * site.axis_z - w) * r
        };
        let zeros: Vec<f64> = points
            .windows(2)
            .filter_map(|w| {
                let (fa, fb) = (slip(w[0]), slip(w[1]));
                (fa * fb < 0.0).then(|| root(&slip, (w[0], fa), (w[1], fb)))
            })
            .collect();
        points.extend(zeros);
        super::removal::inside(points, lo, hi)
    }
}

impl CurvedKernel {
    /// Where a lifted pad's rate on `ring` has kinks in the tool position x (between `from`
    /// and `to`): where the lift line passes the ends of the ring's arc under the pad and the
    /// ring itself, in the developed plane (u0 = s·cos φ0 and u0 = s); `pressure` is the pad's
    /// at each position.
    pub fn lift_kinks(
        &self,
        ring: &Ring,
        from: f64,
        to: f64,
        pressure: &dyn Fn(f64, f64) -> PadPressure,
    ) -> Vec<f64> {
        if to <= from || ring.r <= 0.0 {
            return Vec::new();
        }
        let lift_line = |x: f64| {
            let arc1 = self.part.surface.arc_length_mm(x);
            pressure(x, arc1)
                .lift_line_mm()
                .map_or(f64::NEG_INFINITY, |u| arc1 + u)
        };
        let arc_end = |x: f64| {
            let psi = covered_arc(ring, &self.site(x)).unwrap_or(HalfAngle::NONE);
            ring.arc * (2.0 * psi.radians()).cos()
        };
        let past_arc_end = |x: f64| lift_line(x) - arc_end(x);
        let past_ring = |x: f64| lift_line(x) - ring.arc;
        let mut kinks = super::removal::crossings(&past_arc_end, from, to);
        kinks.extend(super::removal::crossings(&past_ring, from, to));
        kinks
    }
}

/// The footprint point by point, for a part turning on C under position control
/// ([`super::polar`]): at the point of a ring at the angle α from the pad centre's meridian,
///
/// ```text
/// ρ = K·P·w(cos α)·|v_t|,   |v_t|² = E·sin²α + (B − A·r·cos α)²   on the arc |α| ≤ φ0,
/// ∂|v_t|/∂Ω = (−A·r²·sin²α + (B − A·r·cos α)·r·cos α)/|v_t|
/// ```
///
/// (module docs; only A = ω_t·a_z − Ω depends on the part's speed Ω, and E through A², so
/// ∂E/∂Ω = −2·A·r²), w the pad's pressure relative to nominal in the developed plane,
/// max(0, level + slope·(s·cos α − s1)). Its integral over the half-arc [0, φ0] is π times
/// [`CurvedKernel::rate_nm_per_s`].
impl CurvedKernel {
    /// The same kernel with the part turning at `part_speed_rad_per_s` (Ω, lab frame): the
    /// contact and the pressure depend only on where the pad is.
    pub fn with_part_speed(&self, part_speed_rad_per_s: f64) -> CurvedKernel {
        CurvedKernel {
            omega_workpiece: part_speed_rad_per_s,
            ..self.clone()
        }
    }

    /// The half-angle φ0 (rad) of the arc of `ring` under the pad at `site`, `None` where the
    /// pad does not touch it.
    pub fn pressed_half_angle(&self, ring: &Ring, site: &Site) -> Option<f64> {
        covered_arc(ring, site).map(|psi| 2.0 * psi.radians())
    }

    /// The footprint ρ = K·P·w·|v_t| at the point of `ring` whose angle α from the pad
    /// centre's meridian has the cosine `cos_alpha`, with the pad at `site` under `pressure`,
    /// as its three factors: K·P·w (nm/s per mm/s), |v_t| (mm/s) and ∂|v_t|/∂Ω (mm/s per
    /// rad/s). The caller keeps α on the arc ([`Self::pressed_half_angle`]).
    pub fn footprint(
        &self,
        ring: &Ring,
        site: &Site,
        pressure: &PadPressure,
        cos_alpha: f64,
    ) -> (f64, f64, f64) {
        let weight = if pressure.slope_per_mm == 0.0 {
            pressure.level
        } else {
            (pressure.level + pressure.slope_per_mm * (ring.arc * cos_alpha - site.arc1)).max(0.0)
        };
        if weight == 0.0 {
            return (0.0, 0.0, 0.0);
        }
        let (a, b, e) = self.speed_terms(ring, site);
        let sin2 = (1.0 - cos_alpha * cos_alpha).max(0.0);
        let along = b - a * ring.r * cos_alpha;
        let speed = (e * sin2 + along * along).max(0.0).sqrt();
        let slope = if speed > 0.0 {
            (-a * ring.r * ring.r * sin2 + along * ring.r * cos_alpha) / speed
        } else {
            0.0
        };
        // `scale` is K·P/π.
        (PI * self.scale * weight, speed, slope)
    }

    /// The squared reach c² = c_t² − (z − z₁)² of the pad at `r1_mm` on `ring` (module docs:
    /// the ring is under the pad where r² + r1² − 2·r·r1·cos α ≤ c²) and its derivative in
    /// r1: 2·(z − z₁)·z′(r1) exactly, plus a changing chord's (an asphere's) by a difference,
    /// one-sided where r1 + h leaves the surface's domain.
    pub fn squared_reach(&self, ring: &Ring, r1_mm: f64) -> (f64, f64) {
        let site = self.site(r1_mm);
        let dz = ring.z - site.z1;
        let chord_slope = if self.sphere_chord.is_some() {
            0.0
        } else {
            let h = 1e-6 * (1.0 + r1_mm.abs());
            let squared = |x: f64| self.site(x).chord.powi(2);
            let (lo, mid, hi) = (squared(r1_mm - h), squared(r1_mm), squared(r1_mm + h));
            if hi.is_finite() {
                (hi - lo) / (2.0 * h)
            } else {
                (mid - lo) / h
            }
        };
        let slope1 = self.part.surface.local(r1_mm).slope;
        (
            site.chord * site.chord - dz * dz,
            chord_slope + 2.0 * dz * slope1,
        )
    }
}

/// The half-angle of `ring`'s arc under the pad at `site` (module docs: the flat contact of
/// the reach √(c_t² − (z − z₁)²)), or `None` where the pad does not touch the ring.
fn covered_arc(ring: &Ring, site: &Site) -> Option<HalfAngle> {
    let dz = ring.z - site.z1;
    let reach2 = site.chord * site.chord - dz * dz;
    if reach2 <= 0.0 {
        return None;
    }
    Some(half_angle_of_squared_reach(ring.r, site.r1, reach2)).filter(|psi| psi.is_contact())
}

/// A root of `f` on a bracket whose ends' values have opposite signs, to a few ulps.
fn root(f: &dyn Fn(f64) -> f64, a: (f64, f64), b: (f64, f64)) -> f64 {
    let ulps = 4.0 * f64::EPSILON * a.0.abs().max(b.0.abs());
    super::roots::illinois(f, a, b, ulps, 0.0)
}

/// [`root`] in the bracket a–b, sought first within 1e-9 of the bracket's size about `guess`
/// (two values of f, where the whole bracket takes about ten): the same root to a few ulps
/// when the guess is good, the whole bracket when it is not.
fn root_near(f: &dyn Fn(f64) -> f64, guess: Option<f64>, a: (f64, f64), b: (f64, f64)) -> f64 {
    if let Some(guess) = guess.filter(|g| *g > a.0 && *g < b.0) {
        let hair = 1e-9 * a.0.abs().max(b.0.abs());
        let (lo, hi) = ((guess - hair).max(a.0), (guess + hair).min(b.0));
        let (f_lo, f_hi) = (f(lo), f(hi));
        if (f_lo <= 0.0) != (f_hi <= 0.0) {
            return root(f, (lo, f_lo), (hi, f_hi));
        }
    }
    root(f, a, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// R(r; r1) by adaptive Gauss–Kronrod in φ itself (a sine and cosine per node, QUADPACK's
    /// error estimate), on the same arc and speed as the kernel's, weighted by level + slope·cos φ.
    fn rate_in_the_angle(kernel: &CurvedKernel, ring: &Ring, site: &Site, weight: Weight) -> f64 {
        let Some(ArcSpeed { psi, b, f, e }) = kernel.arc_speed(ring, site) else {
            return 0.0;
        };
        let end = 2.0 * psi.sin.atan2(psi.cos);
        let speed = |phi: f64| {
            let along = b - f * phi.cos();
            let pressure = weight.level + weight.slope * phi.cos();
            pressure * (e * phi.sin().powi(2) + along * along).max(0.0).sqrt()
        };
        let bound = b.abs() + f.abs() + e.abs().sqrt();
        kernel.scale * adaptive_gauss_kronrod(&speed, 0.0, end, 1e-14 * bound)
    }

    /// The rate in the half-angle's sine and cosine (its near zero taken out in closed form)
    /// against quadrature in the angle itself, over rings and pad positions on spheres and an
    /// asphere, both orientations, speeds that put the sliding speed's zero on the arc, near its
    /// end or nowhere, and level and tilted pressure (the subtracted Taylor series then has a
    /// slope term).
    #[test]
    fn rates_in_the_half_angle_match_quadrature_in_the_angle() {
        use crate::surface::{PolynomialTerm, SurfaceSpec};
        let surfaces = [
            SurfaceSpec::Sphere {
                radius_of_curvature_mm: 100.0,
            },
            SurfaceSpec::Sphere {
                radius_of_curvature_mm: -60.0,
            },
            SurfaceSpec::Asphere {
                radius_of_curvature_mm: 100.0,
                conic_constant: -0.5,
                coefficients: vec![PolynomialTerm {
                    power: 4,
                    value: 1e-7,
                }],
            },
        ];
        let speeds = [
            (-10.0, 200.0),
            (15.0, 15.0),
            (20.0, 21.0),
            (-150.0, 150.0),
            (5.0, -80.0),
        ];
        let weights = [
            Weight::NOMINAL,
            Weight {
                level: 1.0,
                slope: 0.5,
            },
            Weight {
                level: 0.6,
                slope: -0.4,
            },
        ];
        let mut worst: f64 = 0.0;
        for spec in &surfaces {
            for orientation in [Orientation::Normal, Orientation::Vertical] {
                for (ww, wt) in speeds {
                    let part = Part {
                        surface: Surface::new(spec).unwrap(),
                        orientation,
                    };
                    let kernel =
                        CurvedKernel::new(part, ww, wt, 10.0, 50.0, PressureModel::Uniform, 1.0);
                    for weight in weights {
                        let most = weight.level + weight.slope.abs();
                        let rates: Vec<(f64, f64)> = (0..=40)
                            .flat_map(|i| (0..=40).map(move |j| (1.25 * i as f64, 1.25 * j as f64)))
                            .map(|(r, r1)| {
                                let (ring, site) = (kernel.ring(r), kernel.site(r1));
                                let end = HalfAngle::FULL;
                                (
                                    kernel.arc_rate(&ring, &site, end, most, weight),
                                    rate_in_the_angle(&kernel, &ring, &site, weight),
                                )
                            })
                            .collect();
                        let scale = rates.iter().map(|r| r.1.abs()).fold(0.0, f64::max);
                        for (got, want) in rates {
                            worst = worst.max((got - want).abs() / scale);
                        }
                    }
                }
            }
        }
        assert!(worst < 1e-10, "worst {worst:e} of the largest rate");
    }

    /// The build the CPU is dispatched to (AVX-512 or AVX2 here) and the portable one give
    /// the same bits: the lane sums run in one order, and nothing is fused.
    #[test]
    fn wide_and_portable_arc_rates_agree_to_the_bit() {
        use crate::wide::Wide;
        let part = Part {
            surface: Surface::new(&crate::surface::SurfaceSpec::Sphere {
                radius_of_curvature_mm: 80.0,
            })
            .unwrap(),
            orientation: Orientation::Normal,
        };
        let kernel = CurvedKernel::new(part, 20.0, 21.0, 10.0, 50.0, PressureModel::Uniform, 1.0);
        let mut compared = 0;
        for i in 0..=60 {
            for j in 0..=60 {
                let (ring, site) = (kernel.ring(0.8 * i as f64), kernel.site(0.8 * j as f64));
                let end = HalfAngle::FULL;
                let weight = Weight {
                    level: 1.0,
                    slope: 0.5,
                };
                let wide = kernel.arc_rate(&ring, &site, end, 1.5, weight);
                let portable = ArcRate {
                    kernel: &kernel,
                    ring: &ring,
                    site: &site,
                    end,
                    most: 1.5,
                    weight,
                }
                .run();
                assert_eq!(wide.to_bits(), portable.to_bits(), "r {i}, r1 {j}");
                compared += usize::from(wide > 0.0);
            }
        }
        assert!(compared > 1000, "{compared} rates in contact");
    }

    /// On a sphere the mean-curvature chord is the geodesic's: 2ρ·sin(r_t/(2ρ)), at the vertex
    /// and off it, concave and convex.
    #[test]
    fn the_contact_chord_on_a_sphere_is_exact() {
        use crate::surface::SurfaceSpec;
        for radius in [60.0, -60.0, 1000.0] {
            let surface = Surface::new(&SurfaceSpec::Sphere {
                radius_of_curvature_mm: radius,
            })
            .unwrap();
            let kernel = CurvedKernel::new(
                Part {
                    surface,
                    orientation: Orientation::Normal,
                },
                1.0,
                2.0,
                8.0,
                40.0,
                PressureModel::Uniform,
                1.0,
            );
            let rho: f64 = f64::abs(radius);
            let exact = 2.0 * rho * (4.0 / rho).sin();
            for r1 in [0.0, 10.0, 45.0] {
                let chord = kernel.site(r1).chord;
                assert!((chord - exact).abs() < 1e-12 * exact, "{radius} {r1}");
            }
        }
    }
}
