//! Pressure models: how the pad pressure depends on where the tool centre sits.
//!
//! * [`PressureModel::Uniform`] (default, the paper's assumption): the pressure is the nominal
//!   pressure P everywhere under the pad, wherever the pad is, including when it overhangs the
//!   workpiece edge. It models a position-controlled (constant-pressure, e.g. pneumatic
//!   bladder) head and neglects the edge effects that real pads show.
//! * [`PressureModel::ConstantForce`]: the head applies a constant force F = P·π·r_t² (the
//!   nominal pressure times the full pad area). While the pad lies wholly on the workpiece the
//!   pressure is P; once it overhangs (r1 + r_t > r_m) the same force rests on the smaller
//!   contact area A(r1), the lens where the pad disc and the workpiece disc overlap, so
//!   P(r1) = F / A(r1) = P·π·r_t² / A(r1), still uniform over the contact. It assumes a rigid,
//!   flat pad and workpiece (no tilt, no pressure peak at the edge); the pressure grows without
//!   bound as the overlap vanishes, which is why this model keeps the tool centre on the
//!   workpiece (r1 ≤ r_m, see [`super::Process::max_tool_position_mm`]).
//! * [`PressureModel::Linear`]: a rigid pad under the same constant force F, its pressure
//!   linear across the contact C (the lens) in the radial coordinate x through the pad centre:
//!
//!   ```text
//!   p(x) = F/A + b·(x − x_c),   A = ∫_C dA,  x_c = ∫_C x dA / A,  I_c = ∫_C (x − x_c)² dA
//!   ```
//!
//!   The pad carries a share κ (`pad_moment_share`) of the tipping moment about its centre and
//!   the head the rest, ∫_C p·(x − r1) dA = (1 − κ)·F·(x_c − r1), so
//!   b = κ·F·(r1 − x_c)/I_c. κ = 1 is a free gimbal (the resultant acts at the pad centre),
//!   κ = 0 the constant-force model exactly; with no overhang (x_c = r1) both are uniform.
//!   Overhanging, x_c < r1 and the pressure rises toward the edge. Where p would fall below
//!   zero on the inner side (a large overhang) the pad lifts: the pressure is
//!   p = β·(x − x0) on the part of C with x ≥ x0 and zero inside the lift line x0, with β and
//!   x0 from the same two balances, ∫ p dA = F and ∫ p·(x − r1) dA = (1 − κ)·F·(x_c − r1)
//!   (the head's load is that of the whole lens C). The first says β = F/∫(x − x0)dA; the
//!   second puts the centroid of the triangular load, x0 + ∫(x − x0)²dA / ∫(x − x0)dA, at
//!   x* = κ·r1 + (1 − κ)·x_c, which moves monotonically outward with x0 (its derivative is
//!   N·A/D² − 1 ≥ 0 by Cauchy–Schwarz, N and D the two integrals, A the area beyond x0): one
//!   root, found by Newton kept inside a shrinking bracket. At the onset (p = 0 at the inner
//!   rim) both forms agree, so the pressure is continuous in r1. When x* reaches the workpiece
//!   edge no contact can carry the load (the pad tips off); that position is the model's
//!   reach, open ([`linear_reach_mm`]): r_m for κ = 1, up to r_m + r_t as κ → 0.
//!
//! The moments of C (and of C cut at a lift line) are sums of vertical strips of the two
//! discs, each in closed form: for a disc of radius ρ, with v the abscissa from its centre and
//! w = √(ρ² − v²), the antiderivatives of ∫dA, ∫v dA, ∫v² dA over strips are
//! ρ²·φ + v·w, −(2/3)·w³ and ρ⁴·φ/4 − v·w·(w² − v²)/4 with φ = atan2(v, w). The pad's strip
//! lies where its chord is the shorter one, left of the discs' radical line
//! x_i = (r_m² − r_t² + r1²)/(2·r1); the workpiece's right of it.
//!
//! Lens area of two discs with radii R, ρ and centre distance d (|R − ρ| < d < R + ρ):
//!
//! ```text
//! A = ρ²·acos((d² + ρ² − R²)/(2dρ)) + R²·acos((d² + R² − ρ²)/(2dR))
//!     − ½·√((−d + ρ + R)(d + ρ − R)(d − ρ + R)(d + ρ + R))
//! ```
//!
//! with each angle computed as atan2(√(…), d² + ρ² − R²) (the same angle, well conditioned
//! near tangency, where the acos of a cosine near ±1 loses half the digits).

use std::f64::consts::PI;

use super::roots::illinois;
use crate::surface::GL8;

/// How pressure varies with the tool position (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum PressureModel {
    #[default]
    Uniform,
    ConstantForce,
    /// A rigid pad with linear pressure; `pad_moment_share` is κ in [0, 1].
    Linear {
        pad_moment_share: f64,
    },
}

/// A pressure model as a caller names it, before its moment share is checked
/// ([`PressureModel::parse`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PressureModelKind {
    #[default]
    Uniform,
    ConstantForce,
    Linear,
}

impl PressureModel {
    /// Every bit the model's pressures depend on, for cache keys.
    pub fn key_bits(self) -> [u64; 2] {
        match self {
            PressureModel::Uniform => [0, 0],
            PressureModel::ConstantForce => [1, 0],
            PressureModel::Linear { pad_moment_share } => [2, pad_moment_share.to_bits()],
        }
    }
}

/// The pressure under the pad at one tool position r1, relative to the nominal pressure:
/// p(x)/P = max(0, level + slope_per_mm·(x − r1)) at the points of the contact with radial
/// coordinate x. Uniform and constant-force pressures have no slope.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PadPressure {
    pub level: f64,
    pub slope_per_mm: f64,
}

impl PadPressure {
    pub const NOMINAL: PadPressure = PadPressure {
        level: 1.0,
        slope_per_mm: 0.0,
    };
    pub const NONE: PadPressure = PadPressure {
        level: 0.0,
        slope_per_mm: 0.0,
    };

    fn uniform(level: f64) -> PadPressure {
        PadPressure {
            level,
            slope_per_mm: 0.0,
        }
    }

    /// Where the pressure is zero, as x − r1 (mm); `None` for uniform pressure. Inside it
    /// (smaller x) the pad does not press.
    pub fn lift_line_mm(self) -> Option<f64> {
        (self.slope_per_mm > 0.0).then(|| -self.level / self.slope_per_mm)
    }
}

/// Area in mm² where a pad of radius `tool_radius` centred at `position` overlaps a workpiece
/// disc of radius `workpiece_radius` centred at the origin.
pub fn contact_area_mm2(workpiece_radius: f64, tool_radius: f64, position: f64) -> f64 {
    let (big, small, d) = (workpiece_radius, tool_radius, position.abs());
    if d >= big + small {
        return 0.0;
    }
    if d <= (big - small).abs() {
        let r = big.min(small);
        return PI * r * r;
    }
    // √kite is four times the area of the triangle of the centres and a crossing point.
    let kite = (-d + small + big) * (d + small - big) * (d - small + big) * (d + small + big);
    let root = kite.max(0.0).sqrt();
    let angle_small = root.atan2(d * d + small * small - big * big);
    let angle_big = root.atan2(d * d + big * big - small * small);
    small * small * angle_small + big * big * angle_big - 0.5 * root
}

/// The pressure with the pad centred at `position` (see [`PadPressure`]); `None` where no
/// contact carries the load (no overlap, or a linear pad past its reach).
pub fn pad_pressure(
    model: PressureModel,
    workpiece_radius: f64,
    tool_radius: f64,
    position: f64,
) -> Option<PadPressure> {
    if position + tool_radius <= workpiece_radius {
        return Some(PadPressure::NOMINAL);
    }
    match model {
        PressureModel::Uniform => Some(PadPressure::NOMINAL),
        PressureModel::ConstantForce => {
            let area = contact_area_mm2(workpiece_radius, tool_radius, position);
            (area > 0.0).then(|| PadPressure::uniform(PI * tool_radius * tool_radius / area))
        }
        PressureModel::Linear { pad_moment_share } => Contact {
            workpiece_radius,
            tool_radius,
            position,
        }
        .linear(pad_moment_share),
    }
}

/// Pressure at tool position `position` relative to the nominal pressure, for the models
/// without a slope (a factor ≥ 1 under constant force, exactly 1 under uniform pressure).
/// Positions beyond the last contact give 0.
pub fn pressure_factor(
    model: PressureModel,
    workpiece_radius: f64,
    tool_radius: f64,
    position: f64,
) -> f64 {
    pad_pressure(model, workpiece_radius, tool_radius, position).map_or(0.0, |p| p.level)
}

/// The farthest position of a linear pad, open (see the module docs): where the centroid
/// the load must have, κ·r1 + (1 − κ)·x_c, reaches the workpiece edge.
pub fn linear_reach_mm(workpiece_radius: f64, tool_radius: f64, pad_moment_share: f64) -> f64 {
    let (edge, kappa) = (workpiece_radius, pad_moment_share);
    if kappa >= 1.0 {
        return edge;
    }
    let end = edge + tool_radius;
    if kappa <= 0.0 {
        return end;
    }
    let gap = |r1: f64| {
        let lens = Contact {
            workpiece_radius,
            tool_radius,
            position: r1,
        };
        let m = lens.moments(f64::NEG_INFINITY, f64::INFINITY);
        kappa * r1 + (1.0 - kappa) * (r1 + m.first / m.area) - edge
    };
    // At r_m the gap is (1 − κ)·(x_c − r_m) < 0; at r_m + r_t it is κ·r_t > 0.
    illinois(
        &gap,
        (edge, gap(edge)),
        (end, kappa * tool_radius),
        1e-13 * end,
        0.0,
    )
}

/// The first position where a linear pad starts to lift (its pressure reaches zero at the
/// inner rim), capped at the workpiece edge.
pub fn linear_lift_onset_mm(workpiece_radius: f64, tool_radius: f64, pad_moment_share: f64) -> f64 {
    let reach = linear_reach_mm(workpiece_radius, tool_radius, pad_moment_share);
    lift_onset_mm(workpiece_radius, tool_radius, pad_moment_share, reach)
        .map_or(workpiece_radius, |onset| onset.min(workpiece_radius))
}

/// Where the unlifted linear pressure first reaches zero at the pad's inner rim, before
/// `reach`; `None` when it never does.
fn lift_onset_mm(
    workpiece_radius: f64,
    tool_radius: f64,
    pad_moment_share: f64,
    reach: f64,
) -> Option<f64> {
    let least = |r1: f64| {
        let lens = Contact {
            workpiece_radius,
            tool_radius,
            position: r1,
        };
        let p = lens.unlifted(pad_moment_share);
        p.level - p.slope_per_mm * tool_radius.min(workpiece_radius + r1)
    };
    let start = (workpiece_radius - tool_radius).max(0.0);
    // Just inside the reach (at it the lens may vanish).
    let last = start + (1.0 - 1e-9) * (reach - start);
    let at_last = least(last);
    (at_last < 0.0).then(|| illinois(&least, (start, 1.0), (last, at_last), 1e-13 * reach, 0.0))
}

/// A linear pad's pressure against its position r1, interpolated for the many evaluations a
/// path integral makes: on each smooth piece [a, b] of r1 (the overhang's start r_m − r_t to
/// the lift's onset, then on to 99 % of the way to the reach) the level and slope are
/// Chebyshev series on panels of v = √((r1 − a)/(b − a)) (the square root absorbs the
/// (r1 − a)^(3/2) growth of the overhanging cap), each panel's 33 Chebyshev–Lobatto values
/// fitted until its last three coefficients fall below 2e-13 of the piece's largest level,
/// else halved. Beyond the table (where the load nears the edge and the pressure grows
/// without bound) the pressure is solved directly.
#[derive(Debug, Clone)]
pub struct PressureCurve {
    workpiece_radius: f64,
    tool_radius: f64,
    pad_moment_share: f64,
    /// Where the pad starts to lift, if before the reach (a kink of the pressure).
    lift_onset_mm: Option<f64>,
    pieces: Vec<CurvePiece>,
}

#[derive(Debug, Clone)]
struct CurvePiece {
    start: f64,
    width: f64,
    panels: Vec<CurvePanel>,
}

#[derive(Debug, Clone)]
struct CurvePanel {
    /// The panel's v range.
    lo: f64,
    hi: f64,
    level: Vec<f64>,
    slope: Vec<f64>,
}

/// Chebyshev–Lobatto points per panel (degree 32).
const CURVE_POINTS: usize = 33;
/// The fit's tolerance, relative to the piece's largest level: a few times the rounding
/// noise of the solved pressure (~5e-14), so that the fit stops at the noise.
const CURVE_TOLERANCE: f64 = 2e-13;
/// Deepest halving of a panel, and most panels on one piece (past them a panel is kept as
/// it is: the pressure is then near its singular reach, where the table stops anyway).
const CURVE_DEPTH: u32 = 24;
const CURVE_PANELS: usize = 64;

impl PressureCurve {
    pub fn new(workpiece_radius: f64, tool_radius: f64, pad_moment_share: f64) -> PressureCurve {
        let mut curve = PressureCurve {
            workpiece_radius,
            tool_radius,
            pad_moment_share,
            lift_onset_mm: None,
            pieces: Vec::new(),
        };
        let start = (workpiece_radius - tool_radius).max(0.0);
        let reach = linear_reach_mm(workpiece_radius, tool_radius, pad_moment_share);
        let end = start + 0.99 * (reach - start);
        curve.lift_onset_mm = lift_onset_mm(workpiece_radius, tool_radius, pad_moment_share, reach);
        let onset = curve.lift_onset_mm.filter(|&onset| onset < end);
        let mut ends = vec![start];
        ends.extend(onset);
        ends.push(end);
        for piece in ends.windows(2) {
            curve.pieces.push(curve.fit(piece[0], piece[1]));
        }
        curve
    }

    /// Where the pad starts to lift, if it does before its reach.
    pub fn lift_onset_mm(&self) -> Option<f64> {
        self.lift_onset_mm
    }

    /// The pressure with the pad at `position` (see [`pad_pressure`]).
    pub fn at(&self, position: f64) -> Option<PadPressure> {
        if position + self.tool_radius <= self.workpiece_radius {
            return Some(PadPressure::NOMINAL);
        }
        let piece = self
            .pieces
            .iter()
            .rev()
            .find(|p| position >= p.start)
            .filter(|p| position <= p.start + p.width);
        let Some(piece) = piece else {
            return self.exact(position);
        };
        let v = ((position - piece.start) / piece.width)
            .clamp(0.0, 1.0)
            .sqrt();
        let index = piece
            .panels
            .partition_point(|p| p.hi < v)
            .min(piece.panels.len() - 1);
        let panel = &piece.panels[index];
        let t = (2.0 * v - panel.lo - panel.hi) / (panel.hi - panel.lo);
        Some(PadPressure {
            level: clenshaw(&panel.level, t),
            slope_per_mm: clenshaw(&panel.slope, t),
        })
    }

    fn exact(&self, position: f64) -> Option<PadPressure> {
        pad_pressure(
            PressureModel::Linear {
                pad_moment_share: self.pad_moment_share,
            },
            self.workpiece_radius,
            self.tool_radius,
            position,
        )
    }

    /// The panels of the piece [a, b].
    fn fit(&self, a: f64, b: f64) -> CurvePiece {
        let width = b - a;
        let sample = |lo: f64, hi: f64| -> (Vec<f64>, Vec<f64>) {
            (0..CURVE_POINTS)
                .map(|j| {
                    let t = (PI * j as f64 / (CURVE_POINTS - 1) as f64).cos();
                    let v = 0.5 * (lo + hi) + 0.5 * (hi - lo) * t;
                    let p = self.exact(a + width * v * v).unwrap_or(PadPressure::NONE);
                    (p.level, p.slope_per_mm)
                })
                .unzip()
        };
        let mut done: Vec<CurvePanel> = Vec::new();
        // The pressure grows toward the reach: its scale is set by the piece's far end.
        let mut scale = [a, b]
            .iter()
            .filter_map(|&x| self.exact(x))
            .fold(0.0_f64, |m, p| m.max(p.level.abs()));
        let mut stack = vec![(0.0, 1.0, 0)];
        while let Some((lo, hi, depth)) = stack.pop() {
            let (levels, slopes) = sample(lo, hi);
            scale = levels.iter().fold(scale, |m, v| m.max(v.abs()));
            let (level, slope) = (chebyshev(&levels), chebyshev(&slopes));
            let tail = |c: &[f64], unit: f64| c[c.len() - 3..].iter().all(|x| x.abs() <= unit);
            let unit = CURVE_TOLERANCE * scale;
            if depth >= CURVE_DEPTH
                || done.len() + stack.len() >= CURVE_PANELS
                || (tail(&level, unit) && tail(&slope, unit / self.tool_radius))
            {
                done.push(CurvePanel {
                    lo,
                    hi,
                    level,
                    slope,
                });
            } else {
                let mid = 0.5 * (lo + hi);
                stack.push((mid, hi, depth + 1));
                stack.push((lo, mid, depth + 1));
            }
        }
        done.sort_by(|p, q| p.lo.total_cmp(&q.lo));
        CurvePiece {
            start: a,
            width,
            panels: done,
        }
    }
}

/// Chebyshev coefficients of the interpolant through values at the Chebyshev–Lobatto points
/// t_j = cos(πj/N), j = 0..N (a direct DCT-I: N is small).
fn chebyshev(values: &[f64]) -> Vec<f64> {
    let n = values.len() - 1;
    (0..=n)
        .map(|k| {
            let sum: f64 = values
                .iter()
                .enumerate()
                .map(|(j, f)| {
                    let end = if j == 0 || j == n { 0.5 } else { 1.0 };
                    end * f * (PI * (j * k) as f64 / n as f64).cos()
                })
                .sum();
            let end = if k == 0 || k == n { 0.5 } else { 1.0 };
            2.0 / n as f64 * end * sum
        })
        .collect()
}

/// Σ c_k·T_k(t) by Clenshaw's recurrence.
fn clenshaw(c: &[f64], t: f64) -> f64 {
    let (mut b1, mut b2) = (0.0, 0.0);
    for &ck in c.iter().skip(1).rev() {
        let b0 = ck + 2.0 * t * b1 - b2;
        b2 = b1;
        b1 = b0;
    }
    c[0] + t * b1 - b2
}

/// ∫1, ∫u and ∫u² dA over a region, u = x − r1 the abscissa from the pad centre (mm², mm³,
/// mm⁴).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Moments {
    area: f64,
    first: f64,
    second: f64,
}

impl Moments {
    /// These moments, taken in y, in the abscissa u = `edge` − y.
    fn reflected_at(self, edge: f64) -> Moments {
        Moments {
            area: self.area,
            first: edge * self.area - self.first,
            second: edge * edge * self.area - 2.0 * edge * self.first + self.second,
        }
    }
}

impl std::ops::Add for Moments {
    type Output = Moments;
    fn add(self, o: Moments) -> Moments {
        Moments {
            area: self.area + o.area,
            first: self.first + o.first,
            second: self.second + o.second,
        }
    }
}

/// The moments of the strip lo ≤ u ≤ hi of a disc of radius `rho` centred at u = `centre`.
fn strip(rho: f64, centre: f64, lo: f64, hi: f64) -> Moments {
    let (lo, hi) = ((lo - centre).max(-rho), (hi - centre).min(rho));
    if hi <= lo {
        return Moments::default();
    }
    // Antiderivatives in v (from the disc centre): ∫dA, ∫v dA, ∫v² dA.
    let at = |v: f64| {
        let w = ((rho - v) * (rho + v)).max(0.0).sqrt();
        let phi = v.atan2(w);
        let rho2 = rho * rho;
        (
            rho2 * phi + v * w,
            -2.0 / 3.0 * w * w * w,
            0.25 * (rho2 * rho2 * phi - v * w * (w * w - v * v)),
        )
    };
    let ((a0, a1, a2), (b0, b1, b2)) = (at(lo), at(hi));
    let (m0, m1, m2) = (b0 - a0, b1 - a1, b2 - a2);
    // Shift from the disc centre to the pad centre: u = v + centre.
    Moments {
        area: m0,
        first: m1 + centre * m0,
        second: m2 + 2.0 * centre * m1 + centre * centre * m0,
    }
}

/// The moments in y (∫ y^k dA, k = 0, 1, 2) of the cap of a disc of radius ρ within `depth`
/// of its edge, y the depth below the edge. With y = ρ·(1 − cos β) the chord is 2ρ·sin β, so the moments are
/// 2ρ^(2+k)·∫_0^α (2·sin²(β/2))^k·sin²β dβ, 1 − cos α = depth/ρ: positive integrands, taken by
/// 8-point Gauss–Legendre on panels at most 0.8 rad wide (exact to rounding for these entire
/// functions). Unlike differences of the strip antiderivatives about the disc's centre, this
/// keeps its digits for a small cap of a large disc (a pad at the edge of a big part).
fn edge_cap(rho: f64, depth: f64) -> Moments {
    let alpha = 2.0 * (0.5 * depth / rho).clamp(0.0, 1.0).sqrt().asin();
    let panels = (alpha / 0.8).ceil().max(1.0);
    let width = alpha / panels;
    let mut sums = [0.0; 3];
    for panel in 0..panels as usize {
        let (mid, half) = ((panel as f64 + 0.5) * width, 0.5 * width);
        for &(node, weight) in &GL8 {
            for beta in [mid - half * node, mid + half * node] {
                let (sin, sin_half) = (beta.sin(), (0.5 * beta).sin());
                let y = 2.0 * rho * sin_half * sin_half;
                let base = weight * half * 2.0 * rho * rho * sin * sin;
                sums[0] += base;
                sums[1] += base * y;
                sums[2] += base * y * y;
            }
        }
    }
    Moments {
        area: sums[0],
        first: sums[1],
        second: sums[2],
    }
}

/// The contact of a pad at `position` with the workpiece disc (the lens where they overlap).
struct Contact {
    workpiece_radius: f64,
    tool_radius: f64,
    position: f64,
}

impl Contact {
    /// The moments of the contact's part with lo ≤ u ≤ hi.
    fn moments(&self, lo: f64, hi: f64) -> Moments {
        let (big, small, r1) = (self.workpiece_radius, self.tool_radius, self.position);
        // Left of the radical line the pad's chord is the shorter one, right of it the
        // workpiece's (for r1 > 0; at r1 = 0 the smaller disc's everywhere).
        let split = if r1 > 0.0 {
            (big * big - small * small + r1 * r1) / (2.0 * r1) - r1
        } else if small <= big {
            f64::INFINITY
        } else {
            f64::NEG_INFINITY
        };
        let pad = strip(small, 0.0, lo, hi.min(split));
        // The workpiece's part is a cap at its edge (nothing here cuts it from outside).
        debug_assert!(hi == f64::INFINITY || hi >= big - r1);
        let inner = (r1 + lo.max(split)).max(-big);
        if inner >= big {
            return pad;
        }
        pad + edge_cap(big, big - inner).reflected_at(big - r1)
    }

    /// The linear pressure over the whole contact, whatever its sign (the two balances).
    fn unlifted(&self, kappa: f64) -> PadPressure {
        self.unlifted_with(kappa, &self.moments(f64::NEG_INFINITY, f64::INFINITY))
    }

    /// [`Self::unlifted`] given the whole contact's moments `m`.
    fn unlifted_with(&self, kappa: f64, m: &Moments) -> PadPressure {
        let force = PI * self.tool_radius * self.tool_radius;
        if m.area <= 0.0 {
            return PadPressure::NONE;
        }
        let centroid = m.first / m.area;
        let spread = m.second - m.first * centroid;
        let slope = if spread > 0.0 {
            -kappa * force * centroid / spread
        } else {
            0.0
        };
        PadPressure {
            level: force / m.area - slope * centroid,
            slope_per_mm: slope,
        }
    }

    /// The linear pressure, lifted where it would be negative (see the module docs).
    fn linear(&self, kappa: f64) -> Option<PadPressure> {
        let m = self.moments(f64::NEG_INFINITY, f64::INFINITY);
        let full = self.unlifted_with(kappa, &m);
        if full.level <= 0.0 && full.slope_per_mm <= 0.0 {
            return None;
        }
        let inner = -self.tool_radius.min(self.workpiece_radius + self.position);
        let outer = self.tool_radius.min(self.workpiece_radius - self.position);
        if full.slope_per_mm <= 0.0 || full.level + full.slope_per_mm * inner >= 0.0 {
            return Some(full);
        }
        let force = PI * self.tool_radius * self.tool_radius;
        let target = (1.0 - kappa) * m.first / m.area;
        if target >= outer {
            return None;
        }
        // Newton on the centroid c(u0) = u0 + N/D of the triangular load beyond the lift line
        // u0 (N = ∫(u − u0)² dA, D = ∫(u − u0) dA over u ≥ u0), c′ = N·A/D² − 1 ≥ 0, kept in
        // a bracket that shrinks with every step (bisection when Newton would leave it).
        let (mut lo, mut hi) = (inner, outer);
        let mut u0 = (-full.level / full.slope_per_mm).clamp(inner, outer);
        let tolerance = 1e-15 * self.tool_radius;
        for _ in 0..100 {
            let cut = self.moments(u0, f64::INFINITY);
            let d = cut.first - u0 * cut.area;
            let n = cut.second - 2.0 * u0 * cut.first + u0 * u0 * cut.area;
            if d <= 0.0 {
                hi = u0;
                u0 = 0.5 * (lo + hi);
                continue;
            }
            let gap = u0 + n / d - target;
            if gap < 0.0 {
                lo = u0;
            } else {
                hi = u0;
            }
            let slope = n * cut.area / (d * d) - 1.0;
            let newton = u0 - gap / slope;
            let next = if slope > 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            let step = (next - u0).abs();
            u0 = next;
            if step <= tolerance || hi - lo <= tolerance {
                break;
            }
        }
        let cut = self.moments(u0, f64::INFINITY);
        let lever = cut.first - u0 * cut.area;
        (lever > 0.0).then(|| {
            let beta = force / lever;
            PadPressure {
                level: -beta * u0,
                slope_per_mm: beta,
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute-force overlap area by counting cell centres of a fine square grid.
    fn counted_area(big: f64, small: f64, d: f64) -> f64 {
        let n = 2000;
        let (x0, x1) = (d - small, d + small);
        let h = (x1 - x0) / n as f64;
        let mut inside = 0usize;
        for i in 0..n {
            let x = x0 + (i as f64 + 0.5) * h;
            for j in 0..n {
                let y = -small + (j as f64 + 0.5) * h;
                if (x - d) * (x - d) + y * y <= small * small && x * x + y * y <= big * big {
                    inside += 1;
                }
            }
        }
        inside as f64 * h * h
    }

    #[test]
    fn lens_area_matches_a_brute_force_count() {
        // A 2000² grid over the pad resolves the area to ~1e-3 relative (boundary cells).
        for d in [41.0, 45.0, 50.0, 55.0, 59.0] {
            let exact = contact_area_mm2(50.0, 10.0, d);
            let counted = counted_area(50.0, 10.0, d);
            assert!(
                (exact - counted).abs() < 2e-3 * exact,
                "d {d}: {exact} vs {counted}"
            );
        }
    }

    #[test]
    fn area_limits_are_exact() {
        assert_eq!(contact_area_mm2(50.0, 10.0, 30.0), PI * 100.0);
        assert_eq!(contact_area_mm2(50.0, 10.0, 40.0), PI * 100.0);
        assert_eq!(contact_area_mm2(50.0, 10.0, 60.0), 0.0);
        // Tool larger than the workpiece: the whole workpiece is covered.
        assert_eq!(contact_area_mm2(5.0, 10.0, 2.0), PI * 25.0);
        // Equal discs one radius apart: the lens is (2π/3 − √3/2)·r² exactly.
        let lens = contact_area_mm2(10.0, 10.0, 10.0);
        let want = (2.0 * PI / 3.0 - 3f64.sqrt() / 2.0) * 100.0;
        assert!((lens - want).abs() < 1e-12 * want, "{lens} vs {want}");
    }

    #[test]
    fn constant_force_raises_pressure_only_when_overhanging() {
        let f = |d| pressure_factor(PressureModel::ConstantForce, 50.0, 10.0, d);
        assert_eq!(f(0.0), 1.0);
        assert_eq!(f(40.0), 1.0);
        assert!(f(45.0) > 1.0 && f(50.0) > f(45.0));
        assert_eq!(
            pressure_factor(PressureModel::Uniform, 50.0, 10.0, 50.0),
            1.0
        );
    }
}
