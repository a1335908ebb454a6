//! Independent reference model (std only) of Preston-law removal by a spinning round
//! pad on a flat round part turning on a rotary axis C.
//!
//! Units: mm, s, rad inside (speeds given in r/min, signed, counter-clockwise positive,
//! all seen from the pad side), depth in nm.
//!
//! * Preston: dz/dt = scale · V · P, P = 1 under the pad (uniform pressure), 0 elsewhere;
//!   `scale` is k·p in nm per mm of sliding, so dz/dt [nm/s] = scale · V [mm/s].
//! * Everything is computed in the PART frame. Pad centre c(t) = r1(t)·(cos φ, sin φ),
//!   with dφ/dt = −Ω(t) (the part turning CCW carries the pad CW in the part frame).
//! * Sliding speed at a part point p: V = |(ω2 − Ω)·p − ω2·c| (frame independent),
//!   Ω = part speed, ω2 = pad spin, both in rad/s (rpm · 2π/60).
//! * p is under the pad when |p − c| ≤ r_pad and |p| ≤ R_part.
//! * depth(p) = ∫ scale · V(p, t) · [p under pad at t] dt over the whole motion.

use std::f64::consts::PI;

/// r/min → rad/s: ω = rpm · 2π / 60.
pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * 2.0 * PI / 60.0
}

/// Machine / process constants (constant over the whole motion).
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    pub part_radius_mm: f64,
    pub pad_radius_mm: f64,
    pub tool_rpm: f64,
    pub scale_nm_per_mm: f64,
    /// φ0: pad-centre angle in the part frame at t = 0.
    pub start_angle_rad: f64,
}

/// One piece of the motion; segments run back to back, φ continuous across them
/// (r1 may jump between segments).
///
/// `Clone` but not `Copy` (the `Sectors` variant owns a `Vec`): pass segments by reference
/// or `.clone()` them.
#[derive(Clone, Debug)]
pub enum Segment {
    /// r1 fixed, Ω constant: φ(t) = φ_s − Ω·t.
    Ring {
        r1_mm: f64,
        omega_rpm: f64,
        duration_s: f64,
    },
    /// r1(t) = r1_start + (r1_end − r1_start)·t/T, Ω constant: φ(t) = φ_s − Ω·t.
    Spiral {
        r1_start_mm: f64,
        r1_end_mm: f64,
        omega_rpm: f64,
        duration_s: f64,
    },
    /// r1 fixed, Ω(φ) = mean + amplitude·cos(harmonic·φ + phase) (rpm → rad/s),
    /// dφ/dt = −Ω(φ), integrated by RK4 with the time step. Requires |amplitude| < |mean|.
    Modulated {
        r1_mm: f64,
        mean_omega_rpm: f64,
        amplitude_rpm: f64,
        harmonic: u32,
        phase_rad: f64,
        duration_s: f64,
    },
    /// Per-sector C speed. S = `omega_rpm.len()` ≥ 1 equal sectors of the pad centre's
    /// part-frame angle: sector k holds φ mod 2π ∈ [2πk/S, 2π(k+1)/S). While φ is in sector k
    /// the part turns at Ω = `omega_rpm[k]` (rpm → rad/s; all entries finite, non-zero and
    /// of one sign), so dφ/dt = −Ω is piecewise constant and φ(t) piecewise linear, the
    /// speed changing exactly when φ crosses a multiple of 2π/S. Meanwhile
    /// r1(t) = r1_start + (r1_end − r1_start)·t/T, linear in TIME over the segment
    /// (a ring when r1_start = r1_end).
    ///
    /// Conventions decided here:
    /// * At an edge instant (φ exactly a multiple of 2π/S, a set of measure zero) the speed
    ///   that applies afterwards is that of the sector φ moves INTO: with Ω > 0 (φ falling)
    ///   an edge φ = 2πj/S starts sector j − 1 (mod S); with Ω < 0 (φ rising) it starts
    ///   sector j. So a segment that starts exactly on an edge runs a whole sector first.
    /// * C changes speed only at an edge: a `Sectors` segment that follows another and starts
    ///   strictly inside a sector keeps the speed the previous one had there until the first
    ///   edge (its own `omega_rpm` applies from then on).
    /// * Only edges where the speed actually changes are treated as breakpoints;
    ///   neighbouring sectors with bit-identical `omega_rpm` entries are merged. With all
    ///   entries equal the segment is therefore integrated exactly like `Spiral` (or `Ring`
    ///   when r1_start = r1_end) — bit-for-bit the same result.
    ///
    /// Integration (see `depth_nm`): the breakpoint times are computed in closed form
    /// (φ is linear between them: t_e = t_k + (φ_k − φ_e)/Ω_k, and φ is reset to the exact
    /// edge value 2πj/S at every breakpoint, so no drift accumulates over many turns). The
    /// segment's uniform step grid (dt = T/n, n = ⌈T·steps_per_second⌉, as for every
    /// variant) is kept, and each step that contains breakpoint(s) is cut there; each
    /// constant-speed sub-step is integrated by the same rule as a `Spiral` step (midpoint
    /// rule, rim crossings located by bisection); a step may hold several breakpoints. The
    /// integrand is smooth on every piece, so the scheme stays second order.
    /// Measured against independent references (rings: a φ-quadrature of V/|Ω(φ)| split at
    /// the sector edges and the pad-window edges; spirals: a time quadrature split at an
    /// independently walked set of edges and at bisected rim crossings), pad 10 mm, part
    /// 50 mm, tool 600 / −300 / 200 / 90 rpm, S = 2, 3, 4, 5, 6, 7 and 997, speed ratios up to
    /// 3.75, both signs of Ω, rings and spirals (also over the centre and over the part
    /// edge), 1–3 revolutions. With N = steps per revolution at the FASTEST sector speed
    /// (steps_per_second = N·max|omega_rpm|/60) the error is cleanly second order,
    /// max|err| = C·peak/N² with C = 0.6 … 18 (18: spiral 36 → 44 mm over the part edge;
    /// a plain `Spiral` of that geometry at the fastest speed has C = 34, so C is set by the
    /// geometry, not by the sector cuts): N = 1.2·10⁴ → ≤ 1.3·10⁻⁷·peak, N = 1.6·10⁴ →
    /// ≤ 7.1·10⁻⁸·peak, and the change from N to 4N is ≤ 6.6·10⁻⁸·peak at N = 1.6·10⁴.
    /// The same grid WITHOUT the cuts is only first order (S = 2 ring: 1.2·10⁻⁵·peak at
    /// N = 1.2·10⁴ instead of 2.4·10⁻⁸). Recommended:
    /// steps_per_second = 1.6·10⁴ · max|omega_rpm| / 60 (≲ 1e-7 of the peak).
    Sectors {
        r1_start_mm: f64,
        r1_end_mm: f64,
        omega_rpm: Vec<f64>,
        duration_s: f64,
    },
}

impl Segment {
    /// The fastest |Ω| the segment runs C at, rpm (a modulated one's mean; a sector law's
    /// fastest sector): what the steps per second are counted against.
    pub fn fastest_rpm(&self) -> f64 {
        match *self {
            Segment::Ring { omega_rpm, .. } | Segment::Spiral { omega_rpm, .. } => omega_rpm.abs(),
            Segment::Modulated { mean_omega_rpm, .. } => mean_omega_rpm.abs(),
            Segment::Sectors { ref omega_rpm, .. } => {
                omega_rpm.iter().fold(0.0_f64, |m, w| m.max(w.abs()))
            }
        }
    }

    pub fn duration_s(&self) -> f64 {
        match *self {
            Segment::Ring { duration_s, .. }
            | Segment::Spiral { duration_s, .. }
            | Segment::Modulated { duration_s, .. }
            | Segment::Sectors { duration_s, .. } => duration_s,
        }
    }
}

/// V = |(ω2 − Ω)·p − ω2·c| in mm/s (Ω, ω2 in rad/s; p, c in mm, same frame).
pub fn sliding_speed_mm_s(omega_part: f64, omega_tool: f64, p: (f64, f64), c: (f64, f64)) -> f64 {
    let k = omega_tool - omega_part;
    let (vx, vy) = (k * p.0 - omega_tool * c.0, k * p.1 - omega_tool * c.1);
    (vx * vx + vy * vy).sqrt()
}

/// Ω(φ) = mean + amp·cos(h·φ + phase), all rad/s.
#[derive(Clone, Copy, Debug)]
struct Modulation {
    mean: f64,
    amp: f64,
    h: f64,
    phase: f64,
}

impl Modulation {
    fn omega(&self, phi: f64) -> f64 {
        self.mean + self.amp * (self.h * phi + self.phase).cos()
    }
    /// One classical RK4 step of dφ/dt = −Ω(φ).
    fn rk4(&self, phi: f64, dt: f64) -> f64 {
        let k1 = -self.omega(phi);
        let k2 = -self.omega(phi + 0.5 * dt * k1);
        let k3 = -self.omega(phi + 0.5 * dt * k2);
        let k4 = -self.omega(phi + dt * k3);
        phi + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    }
}

/// A constant-speed stretch of a `Sectors` segment: on [t0, next piece's t0) (segment-local
/// time) Ω = omega [rad/s] and φ(t) = phi0 − omega·(t − t0).
#[derive(Clone, Copy, Debug)]
struct SectorPiece {
    t0: f64,
    phi0: f64,
    omega: f64,
}

/// Breakpoints of a `Sectors` segment starting at angle `phi_start`, lasting `duration`,
/// with sector speeds `omegas` [rad/s, all of one sign, non-zero]. Only edges where the
/// speed changes start a new piece; pieces starting at t ≥ duration are not produced.
fn sector_pieces(
    phi_start: f64,
    omegas: &[f64],
    duration: f64,
    carry: Option<f64>,
) -> Vec<SectorPiece> {
    let s = omegas.len() as i64;
    let width = 2.0 * PI / s as f64;
    let idx = |j: i64| j.rem_euclid(s) as usize;
    // Ω > 0 ⇒ φ decreases.
    let falling = omegas[0] > 0.0;
    // Unwrapped sector index j: sector j covers φ ∈ [j·w, (j+1)·w); the pad is in the open
    // interval it is moving through (see the edge convention on `Segment::Sectors`).
    let u = phi_start / width;
    let mut j = if falling {
        u.ceil() as i64 - 1
    } else {
        u.floor() as i64
    };
    // Strictly inside a sector, the speed the previous segment had there carries on to the
    // sector's edge (C changes speed only at edges); on an edge the new sector starts fresh.
    let inside = u != u.round();
    let first = match carry {
        Some(w) if inside => w,
        _ => omegas[idx(j)],
    };
    let mut pieces = vec![SectorPiece {
        t0: 0.0,
        phi0: phi_start,
        omega: first,
    }];
    if omegas.iter().all(|&w| w == first) {
        return pieces;
    }
    let step = if falling { -1 } else { 1 };
    loop {
        let cur = *pieces.last().unwrap();
        // Walk over sectors at the same speed (terminates: at least two speeds differ).
        while omegas[idx(j + step)] == cur.omega {
            j += step;
        }
        // Edge between sector j and j + step.
        let edge = if falling { j } else { j + 1 };
        let phi_e = edge as f64 * width;
        let t_e = (cur.t0 + (cur.phi0 - phi_e) / cur.omega).max(cur.t0);
        if t_e >= duration {
            return pieces;
        }
        j += step;
        pieces.push(SectorPiece {
            t0: t_e,
            phi0: phi_e,
            omega: omegas[idx(j)],
        });
    }
}

/// Kinematics inside one time step, as a function of the local time u ∈ [0, dt].
#[derive(Clone, Copy, Debug)]
enum Step {
    /// φ(u) = phi − omega·u, r1(u) = r + r_rate·u (exact for Ring / Spiral / Sectors pieces).
    Linear {
        phi: f64,
        omega: f64,
        r: f64,
        r_rate: f64,
    },
    /// φ(u) = cubic Hermite through (φ0, −Ω(φ0)) and (φ1, −Ω(φ1)); Ω(u) = Ω(φ(u)).
    Hermite {
        phi0: f64,
        phi1: f64,
        f0: f64,
        f1: f64,
        dt: f64,
        r: f64,
        m: Modulation,
    },
}

impl Step {
    /// (c_x, c_y, Ω) at local time u.
    #[inline]
    fn at(&self, u: f64) -> (f64, f64, f64) {
        match *self {
            Step::Linear {
                phi,
                omega,
                r,
                r_rate,
            } => {
                let (s, c) = (phi - omega * u).sin_cos();
                let rr = r + r_rate * u;
                (rr * c, rr * s, omega)
            }
            Step::Hermite {
                phi0,
                phi1,
                f0,
                f1,
                dt,
                r,
                m,
            } => {
                let s = u / dt;
                let (s2, s3) = (s * s, s * s * s);
                let a = (2.0 * s3 - 3.0 * s2 + 1.0) * phi0
                    + (s3 - 2.0 * s2 + s) * dt * f0
                    + (3.0 * s2 - 2.0 * s3) * phi1
                    + (s3 - s2) * dt * f1;
                let (sn, cs) = a.sin_cos();
                (r * cs, r * sn, m.omega(a))
            }
        }
    }
}

/// Indicator change in [lo, hi] (indicator `in_lo` at lo) by bisection to f64 resolution
/// (≤ 64 halvings); only run in the rare steps where a point crosses the rim.
fn crossing(inside_at: &impl Fn(f64) -> bool, mut lo: f64, mut hi: f64, in_lo: bool) -> f64 {
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if inside_at(mid) == in_lo {
            lo = mid
        } else {
            hi = mid
        }
    }
    0.5 * (lo + hi)
}

/// ∫_0^dt V·[inside] du for a step whose indicator (start, mid, end) = `f` is not constant:
/// cut at the crossing(s) found in each half step, then the midpoint rule on every piece.
/// `inside(c)` and `speed(c, Ω)` are the point's, for the pad centre c = (c_x, c_y).
fn split_step(
    step: &Step,
    dt: f64,
    inside: &impl Fn(f64, f64) -> bool,
    speed: &impl Fn(f64, f64, f64) -> f64,
    f: [bool; 3],
) -> f64 {
    let inside_at = |u: f64| {
        let (cx, cy, _) = step.at(u);
        inside(cx, cy)
    };
    let h = 0.5 * dt;
    let mut cuts = [0.0; 5];
    let mut n = 1;
    if f[0] != f[1] {
        cuts[n] = crossing(&inside_at, 0.0, h, f[0]);
        n += 1;
    }
    cuts[n] = h;
    n += 1;
    if f[1] != f[2] {
        cuts[n] = crossing(&inside_at, h, dt, f[1]);
        n += 1;
    }
    cuts[n] = dt;
    n += 1;
    let mut sum = 0.0;
    for w in cuts[..n].windows(2) {
        let (a, b, u) = (w[0], w[1], 0.5 * (w[0] + w[1]));
        let (cx, cy, om) = step.at(u);
        if b > a && inside(cx, cy) {
            sum += speed(cx, cy, om) * (b - a);
        }
    }
    sum
}

/// A spherical part (see [`depth_nm_on_sphere`]): each point in 3-D with its unit normal.
struct SphereField {
    /// Signed radius R (mm), the centre at (0, 0, R).
    radius: f64,
    points: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    pad_radius: f64,
}

impl SphereField {
    fn new(radius: f64, pad_radius: f64, points: &[(f64, f64)]) -> SphereField {
        let points: Vec<[f64; 3]> = points
            .iter()
            .map(|&(x, y)| [x, y, sphere_sag(radius, x.hypot(y))])
            .collect();
        let normals = points.iter().map(|&p| sphere_normal(radius, p)).collect();
        SphereField {
            radius,
            points,
            normals,
            pad_radius,
        }
    }

    /// The pad centre on the surface at arc length s = |(c_x, c_y)| from the vertex in the
    /// direction of (c_x, c_y), and its unit normal (the spin axis).
    fn centre(&self, cx: f64, cy: f64) -> ([f64; 3], [f64; 3]) {
        let s = cx.hypot(cy);
        let r1 = self.radius.abs() * (s / self.radius.abs()).sin();
        let (x, y) = if s > 0.0 {
            (cx * r1 / s, cy * r1 / s)
        } else {
            (0.0, 0.0)
        };
        let p0 = [x, y, sphere_sag(self.radius, r1)];
        (p0, sphere_normal(self.radius, p0))
    }

    /// Geodesic distance |R|·∠(X − O, P₀ − O) ≤ r_pad.
    fn inside(&self, j: usize, cx: f64, cy: f64) -> bool {
        let o = [0.0, 0.0, self.radius];
        let (p0, _) = self.centre(cx, cy);
        let (u, w) = (sub3(self.points[j], o), sub3(p0, o));
        let c = cross3(u, w);
        let angle = dot3(c, c).sqrt().atan2(dot3(u, w));
        self.radius.abs() * angle <= self.pad_radius
    }

    /// |v_t|, v = Ω·ẑ × X − ω2·a × (X − P₀), less its part along the normal at X.
    fn speed(&self, j: usize, cx: f64, cy: f64, omega: f64, w2: f64) -> f64 {
        let x = self.points[j];
        let m = self.normals[j];
        let (p0, a) = self.centre(cx, cy);
        let part = cross3([0.0, 0.0, omega], x);
        let pad = cross3([w2 * a[0], w2 * a[1], w2 * a[2]], sub3(x, p0));
        let v = sub3(part, pad);
        let along = dot3(v, m);
        let t = [
            v[0] - along * m[0],
            v[1] - along * m[1],
            v[2] - along * m[2],
        ];
        dot3(t, t).sqrt()
    }
}

/// z(r) = R − sign(R)·√(R² − r²): the sphere through the origin, its centre at (0, 0, R).
fn sphere_sag(radius: f64, r: f64) -> f64 {
    radius - radius.signum() * (radius * radius - r * r).sqrt()
}

/// The unit normal toward +z at the surface point `p`: (O − X)/R.
fn sphere_normal(radius: f64, p: [f64; 3]) -> [f64; 3] {
    [-p[0] / radius, -p[1] / radius, (radius - p[2]) / radius]
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Shared state of one `depth_nm` run.
struct Field<'a> {
    points: &'a [(f64, f64)],
    on_part: Vec<bool>,
    acc: Vec<f64>,
    inside: Vec<bool>,
    w2: f64,
    rp2: f64,
    sphere: Option<SphereField>,
}

impl Field<'_> {
    /// Is point `j` under the pad centred above (cx, cy)?
    fn inside(&self, j: usize, cx: f64, cy: f64) -> bool {
        match &self.sphere {
            Some(sphere) => sphere.inside(j, cx, cy),
            None => {
                let (x, y) = self.points[j];
                (x - cx) * (x - cx) + (y - cy) * (y - cy) <= self.rp2
            }
        }
    }

    /// The sliding speed at point `j` with the pad centred above (cx, cy), the part at Ω.
    fn speed(&self, j: usize, cx: f64, cy: f64, omega: f64) -> f64 {
        match &self.sphere {
            Some(sphere) => sphere.speed(j, cx, cy, omega, self.w2),
            None => sliding_speed_mm_s(omega, self.w2, self.points[j], (cx, cy)),
        }
    }

    /// Under-pad indicators at the start of `step` (used where r1 may jump: segment starts).
    fn refresh(&mut self, step: &Step) {
        let (cx, cy, _) = step.at(0.0);
        for j in 0..self.points.len() {
            self.inside[j] = self.inside(j, cx, cy);
        }
    }
    /// Adds ∫_0^dt V·[inside] du of one step to every on-part point (see `depth_nm`).
    fn add_step(&mut self, step: &Step, dt: f64) {
        if self.sphere.is_some() {
            return self.add_step_anywhere(step, dt);
        }
        let (w2, rp2) = (self.w2, self.rp2);
        let (mx, my, wm) = step.at(0.5 * dt);
        let (ex, ey, _) = step.at(dt);
        let k = w2 - wm;
        for (j, &(x, y)) in self.points.iter().enumerate() {
            if !self.on_part[j] {
                continue;
            }
            let in0 = self.inside[j];
            let in_m = (x - mx) * (x - mx) + (y - my) * (y - my) <= rp2;
            let in1 = (x - ex) * (x - ex) + (y - ey) * (y - ey) <= rp2;
            if in0 == in_m && in_m == in1 {
                if in_m {
                    let (vx, vy) = (k * x - w2 * mx, k * y - w2 * my);
                    self.acc[j] += (vx * vx + vy * vy).sqrt() * dt;
                }
            } else {
                self.acc[j] += split_step(
                    step,
                    dt,
                    &|cx, cy| (x - cx) * (x - cx) + (y - cy) * (y - cy) <= rp2,
                    &|cx, cy, om| sliding_speed_mm_s(om, w2, (x, y), (cx, cy)),
                    [in0, in_m, in1],
                );
            }
            self.inside[j] = in1;
        }
    }

    /// [`Self::add_step`] by the geometry's own `inside` and `speed` (any surface).
    fn add_step_anywhere(&mut self, step: &Step, dt: f64) {
        let (mx, my, wm) = step.at(0.5 * dt);
        let (ex, ey, _) = step.at(dt);
        for j in 0..self.points.len() {
            if !self.on_part[j] {
                continue;
            }
            let in0 = self.inside[j];
            let in_m = self.inside(j, mx, my);
            let in1 = self.inside(j, ex, ey);
            if in0 == in_m && in_m == in1 {
                if in_m {
                    self.acc[j] += self.speed(j, mx, my, wm) * dt;
                }
            } else {
                self.acc[j] += split_step(
                    step,
                    dt,
                    &|cx, cy| self.inside(j, cx, cy),
                    &|cx, cy, om| self.speed(j, cx, cy, om),
                    [in0, in_m, in1],
                );
            }
            self.inside[j] = in1;
        }
    }
}

/// Removal depth [nm] at each part-frame point (x, y) [mm] after the whole motion.
///
/// Each segment of duration T is cut into n = ceil(T·steps_per_second) equal steps dt = T/n.
/// In a step the under-pad indicator is sampled at start, midpoint and end. If all three
/// agree, the step contributes scale·V(t_mid)·dt·[inside] (midpoint rule). Otherwise the rim
/// crossing in each half step where the indicator changes is found by bisection to f64
/// resolution, and every resulting piece [a, b] contributes scale·V((a+b)/2)·(b − a)·[inside
/// at (a+b)/2].
///
/// `Sectors` segments use the same grid, but a step containing a sector edge where Ω
/// changes is cut at that edge's exact (closed-form) time, and each sub-step is treated as
/// a step of its own by the rule above — so the jump of Ω (hence of V) never falls inside
/// a midpoint-rule interval and the scheme stays second order (see `Segment::Sectors`).
///
/// Expected error: O(dt²) globally (≈ dt²/24·∫|d²(V·[in])/dt²| on smooth stretches; V(t)
/// varies on the time scale of one C revolution, so the error goes as (Ω·dt)²; rim jumps
/// cost only round-off since crossings are located exactly; the |V| kink at a stagnation
/// point V = 0 is the worst spot but still O(dt²)). Modulated φ(t): RK4 O(dt⁴) + cubic
/// Hermite inside a step O(dt⁴). Measured: max|err| ≲ 12·peak/(steps per C revolution)²
/// (e.g. 1.6e3 steps/rev → 4.7e-6·peak, 1.6e4 → 3.2e-8·peak). For `Sectors`, count the
/// steps per revolution at the fastest sector speed (measured ≲ 18·peak/N², see there).
/// Exception: a grazing contact shorter than half a step, with the indicator the same at
/// start, midpoint and end, is missed — this only affects points within O(dt²) of the
/// footprint's extreme radii |r1 − r_pad| and r1 + r_pad, where the depth is small anyway.
pub fn depth_nm(
    setup: &Setup,
    motion: &[Segment],
    points: &[(f64, f64)],
    steps_per_second: f64,
) -> Vec<f64> {
    depth_nm_over(setup, None, motion, points, steps_per_second)
}

/// [`depth_nm`] on a sphere of signed radius `sphere_radius_mm` (R > 0: the centre of
/// curvature on the pad's side, at (0, 0, R); z = R − sign(R)·√(R² − r²)), the points given
/// by their projection (x, y). The motion's r1 is the pad centre's ARC LENGTH from the
/// vertex along its meridian (a spiral then moves at constant speed along the surface). The
/// pad conforms to the sphere: it covers the points within geodesic distance r_pad of its
/// centre P₀ (the surface point at arc length r1(t) in the direction φ),
/// spins about the normal there, and the sliding speed at X is the tangential part of
/// Ω·ẑ × X − ω2·a × (X − P₀), the depth taken along the normal. Same stepping, same error.
pub fn depth_nm_on_sphere(
    setup: &Setup,
    sphere_radius_mm: f64,
    motion: &[Segment],
    points: &[(f64, f64)],
    steps_per_second: f64,
) -> Vec<f64> {
    depth_nm_over(
        setup,
        Some(sphere_radius_mm),
        motion,
        points,
        steps_per_second,
    )
}

fn depth_nm_over(
    setup: &Setup,
    sphere_radius_mm: Option<f64>,
    motion: &[Segment],
    points: &[(f64, f64)],
    steps_per_second: f64,
) -> Vec<f64> {
    assert!(
        steps_per_second > 0.0 && steps_per_second.is_finite(),
        "steps_per_second must be > 0"
    );
    let rpart2 = setup.part_radius_mm * setup.part_radius_mm;
    let mut field = Field {
        points,
        on_part: points
            .iter()
            .map(|&(x, y)| x * x + y * y <= rpart2)
            .collect(),
        acc: vec![0.0f64; points.len()],
        inside: vec![false; points.len()],
        w2: rpm_to_rad_s(setup.tool_rpm),
        rp2: setup.pad_radius_mm * setup.pad_radius_mm,
        sphere: sphere_radius_mm
            .map(|radius| SphereField::new(radius, setup.pad_radius_mm, points)),
    };
    let mut phi = setup.start_angle_rad;
    // The speed of the sector the pad is over at the end of the last `Sectors` segment.
    let mut carry: Option<f64> = None;
    for seg in motion {
        let dur = seg.duration_s();
        assert!(
            dur >= 0.0 && dur.is_finite(),
            "segment duration must be finite and >= 0"
        );
        if let Segment::Sectors { omega_rpm, .. } = seg {
            // Validate even when the segment is empty.
            assert!(!omega_rpm.is_empty(), "Sectors needs at least one sector");
            assert!(
                omega_rpm.iter().all(|w| w.is_finite() && *w != 0.0)
                    && (omega_rpm.iter().all(|&w| w > 0.0) || omega_rpm.iter().all(|&w| w < 0.0)),
                "Sectors speeds must be finite, non-zero and of one sign"
            );
        }
        let n = (dur * steps_per_second).ceil() as usize;
        if n == 0 {
            continue;
        }
        let dt = dur / n as f64;
        if let Segment::Sectors {
            r1_start_mm,
            r1_end_mm,
            omega_rpm,
            duration_s,
        } = seg
        {
            let (end, last) = sectors_segment(
                &mut field,
                phi,
                *r1_start_mm,
                *r1_end_mm,
                omega_rpm,
                *duration_s,
                (n, dt),
                carry,
            );
            phi = end;
            carry = Some(last);
            continue;
        }
        carry = None;
        let mut phi_run = phi; // running φ for Modulated
        let modu = match *seg {
            Segment::Modulated {
                mean_omega_rpm,
                amplitude_rpm,
                harmonic,
                phase_rad,
                ..
            } => {
                assert!(
                    amplitude_rpm.abs() < mean_omega_rpm.abs(),
                    "Modulated needs |amplitude| < |mean|"
                );
                let (mean, amp) = (rpm_to_rad_s(mean_omega_rpm), rpm_to_rad_s(amplitude_rpm));
                Some(Modulation {
                    mean,
                    amp,
                    h: harmonic as f64,
                    phase: phase_rad,
                })
            }
            _ => None,
        };
        for i in 0..n {
            let t0 = i as f64 * dt;
            let step = match *seg {
                Segment::Ring {
                    r1_mm, omega_rpm, ..
                } => {
                    let w = rpm_to_rad_s(omega_rpm);
                    Step::Linear {
                        phi: phi - w * t0,
                        omega: w,
                        r: r1_mm,
                        r_rate: 0.0,
                    }
                }
                Segment::Spiral {
                    r1_start_mm,
                    r1_end_mm,
                    omega_rpm,
                    duration_s,
                } => {
                    let w = rpm_to_rad_s(omega_rpm);
                    let rate = (r1_end_mm - r1_start_mm) / duration_s;
                    Step::Linear {
                        phi: phi - w * t0,
                        omega: w,
                        r: r1_start_mm + rate * t0,
                        r_rate: rate,
                    }
                }
                Segment::Modulated { r1_mm, .. } => {
                    let m = modu.unwrap();
                    let phi1 = m.rk4(phi_run, dt);
                    let (phi0, f0, f1) = (phi_run, -m.omega(phi_run), -m.omega(phi1));
                    phi_run = phi1;
                    Step::Hermite {
                        phi0,
                        phi1,
                        f0,
                        f1,
                        dt,
                        r: r1_mm,
                        m,
                    }
                }
                Segment::Sectors { .. } => unreachable!("handled above"),
            };
            if i == 0 {
                // r1 may jump between segments: refresh the indicators at the segment start.
                field.refresh(&step);
            }
            field.add_step(&step, dt);
        }
        phi = match *seg {
            Segment::Ring { omega_rpm, .. } | Segment::Spiral { omega_rpm, .. } => {
                phi - rpm_to_rad_s(omega_rpm) * dur
            }
            Segment::Modulated { .. } => phi_run,
            Segment::Sectors { .. } => unreachable!("handled above"),
        };
    }
    let scale = setup.scale_nm_per_mm;
    field.acc.iter().map(|a| a * scale).collect()
}

/// Integrates one `Sectors` segment (n ≥ 1 steps of dt = T/n) starting at angle `phi`, the
/// sector it starts within at `carry` (rad/s) when the previous segment left it so; returns
/// φ at its end and the speed then. Steps containing breakpoints are cut there (see
/// `depth_nm`).
#[allow(clippy::too_many_arguments)]
fn sectors_segment(
    field: &mut Field<'_>,
    phi: f64,
    r1_start_mm: f64,
    r1_end_mm: f64,
    omega_rpm: &[f64],
    duration_s: f64,
    (n, dt): (usize, f64),
    carry: Option<f64>,
) -> (f64, f64) {
    let omegas: Vec<f64> = omega_rpm.iter().map(|&w| rpm_to_rad_s(w)).collect();
    let pieces = sector_pieces(phi, &omegas, duration_s, carry);
    // Same r1(t) law and arithmetic as `Spiral` (r = r1_start + rate·t).
    let rate = (r1_end_mm - r1_start_mm) / duration_s;
    let step_at = |pc: &SectorPiece, a: f64| Step::Linear {
        phi: pc.phi0 - pc.omega * (a - pc.t0),
        omega: pc.omega,
        r: r1_start_mm + rate * a,
        r_rate: rate,
    };
    let mut p = 0;
    for i in 0..n {
        let t0 = i as f64 * dt;
        let t1 = t0 + dt;
        while p + 1 < pieces.len() && pieces[p + 1].t0 <= t0 {
            p += 1;
        }
        if i == 0 {
            // r1 may jump between segments: refresh the indicators at the segment start.
            field.refresh(&step_at(&pieces[p], t0));
        }
        if p + 1 < pieces.len() && pieces[p + 1].t0 < t1 {
            // Ω jumps inside this step: one sub-step per constant-speed stretch.
            let mut a = t0;
            while p + 1 < pieces.len() && pieces[p + 1].t0 < t1 {
                let b = pieces[p + 1].t0;
                if b > a {
                    field.add_step(&step_at(&pieces[p], a), b - a);
                    a = b;
                }
                p += 1;
            }
            if t1 > a {
                field.add_step(&step_at(&pieces[p], a), t1 - a);
            }
        } else {
            field.add_step(&step_at(&pieces[p], t0), dt);
        }
    }
    // Pieces all start before T, so the last one is the one running at T.
    let last = *pieces.last().unwrap();
    (last.phi0 - last.omega * (duration_s - last.t0), last.omega)
}

/// Mean of `depth_nm` over `samples` points (r cos(2πk/N), r sin(2πk/N)), k = 0..N−1.
/// For a constant-Ω ring of q revolutions this equals rate(r)·T exactly (up to time-stepping
/// error) when q·N is an integer; otherwise the error is at most ~frac(q·N)/N of one
/// revolution's worth of removal-angle discretisation (O(1/N)).
pub fn azimuthal_mean_nm(
    setup: &Setup,
    motion: &[Segment],
    radius_mm: f64,
    samples: usize,
    steps_per_second: f64,
) -> f64 {
    assert!(samples > 0);
    let angles = (0..samples).map(|k| 2.0 * PI * k as f64 / samples as f64);
    let pts: Vec<(f64, f64)> = angles
        .map(|a| (radius_mm * a.cos(), radius_mm * a.sin()))
        .collect();
    depth_nm(setup, motion, &pts, steps_per_second)
        .iter()
        .sum::<f64>()
        / samples as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    fn setup() -> Setup {
        Setup {
            part_radius_mm: 50.0,
            pad_radius_mm: 10.0,
            tool_rpm: 600.0,
            scale_nm_per_mm: 0.01,
            start_angle_rad: 0.3,
        }
    }
    fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
        let n = n + n % 2;
        let h = (b - a) / n as f64;
        let s: f64 = (1..n)
            .map(|i| f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
            .sum();
        (f(a) + f(b) + s) * h / 3.0
    }
    /// θ0 = arccos((r² + r1² − rp²)/(2 r r1)) clamped: π if arg ≤ −1, 0 if arg ≥ 1.
    fn theta0(r: f64, r1: f64, rp: f64) -> f64 {
        let arg = (r * r + r1 * r1 - rp * rp) / (2.0 * r * r1);
        if arg <= -1.0 {
            PI
        } else if arg >= 1.0 {
            0.0
        } else {
            arg.acos()
        }
    }
    /// Revolution-averaged rate [nm/s]: scale/(2π) ∫_{−θ0}^{θ0} V(θ) dθ,
    /// V² = (ω2−Ω)² r² + ω2² r1² − 2 r r1 ω2 (ω2−Ω) cos θ. Composite Simpson, 20000 panels.
    fn ring_rate(s: &Setup, omega_rpm: f64, r1: f64, r: f64) -> f64 {
        let (w, w2) = (rpm_to_rad_s(omega_rpm), rpm_to_rad_s(s.tool_rpm));
        let th0 = theta0(r, r1, s.pad_radius_mm);
        let v = |t: f64| {
            ((w2 - w).powi(2) * r * r + w2 * w2 * r1 * r1 - 2.0 * r * r1 * w2 * (w2 - w) * t.cos())
                .max(0.0)
                .sqrt()
        };
        s.scale_nm_per_mm / (2.0 * PI) * simpson(v, -th0, th0, 20000)
    }
    const RADII: [f64; 7] = [5.0, 10.5, 13.0, 17.0, 20.0, 24.0, 29.5];
    #[test]
    fn one_revolution_ring_matches_closed_form() {
        let s = setup();
        let (r1, om) = (20.0, 37.0);
        let t = 60.0 / om;
        let motion = [Segment::Ring {
            r1_mm: r1,
            omega_rpm: om,
            duration_s: t,
        }];
        let peak = RADII
            .iter()
            .map(|&r| ring_rate(&s, om, r1, r) * t)
            .fold(0.0, f64::max);
        for &r in &RADII {
            let pts: Vec<(f64, f64)> = (0..5)
                .map(|k| {
                    let a = 1.1 * k as f64 - 0.4;
                    (r * a.cos(), r * a.sin())
                })
                .collect();
            let want = ring_rate(&s, om, r1, r) * t;
            for d in depth_nm(&s, &motion, &pts, 20_000.0) {
                assert!((d - want).abs() <= 1e-7 * peak, "r={r} d={d} want={want}");
            }
        }
    }
    #[test]
    fn azimuthal_mean_non_integer_revolutions() {
        let s = setup();
        let (r1, om): (f64, f64) = (18.0, -23.0); // clockwise C, 2.375 revolutions, 8 samples: 2.375·8 = 19
        let t = 2.375 * 60.0 / om.abs();
        let motion = [Segment::Ring {
            r1_mm: r1,
            omega_rpm: om,
            duration_s: t,
        }];
        for &r in &[9.0, 15.0, 21.0, 27.5] {
            let want = ring_rate(&s, om, r1, r) * t;
            let got = azimuthal_mean_nm(&s, &motion, r, 8, 20_000.0);
            assert!(
                (got - want).abs() <= 1e-7 * want.max(1.0),
                "r={r} got={got} want={want}"
            );
        }
    }
    #[test]
    fn pure_translation_speed_is_omega_r1() {
        let s = setup();
        let w = rpm_to_rad_s(s.tool_rpm);
        for &(p, c) in &[((3.0, -4.0), (20.0, 1.0)), ((-7.5, 2.0), (-1.0, -15.0))] {
            let c: (f64, f64) = c;
            assert!((sliding_speed_mm_s(w, w, p, c) - w.abs() * c.0.hypot(c.1)).abs() < 1e-12);
        }
        // One revolution at Ω = ω2: depth = scale·|ω2|·r1·(2θ0/|Ω|) = scale·r1·2θ0.
        let (r1, om) = (20.0, s.tool_rpm);
        let motion = [Segment::Ring {
            r1_mm: r1,
            omega_rpm: om,
            duration_s: 60.0 / om,
        }];
        for &r in &[12.0, 20.0, 27.0] {
            let d = depth_nm(&s, &motion, &[(0.0, r)], 20_000.0)[0];
            let want = s.scale_nm_per_mm * r1 * 2.0 * theta0(r, r1, s.pad_radius_mm);
            assert!((d - want).abs() < 1e-9 * want, "r={r} d={d} want={want}");
        }
    }
    #[test]
    fn pad_moves_clockwise_in_part_frame_and_segments_agree() {
        let s = Setup {
            start_angle_rad: 0.0,
            ..setup()
        };
        // Half a revolution CCW: φ goes 0 → −π, so (0, −20) is swept, (0, +20) is not.
        let half = [Segment::Ring {
            r1_mm: 20.0,
            omega_rpm: 30.0,
            duration_s: 1.0,
        }];
        let d = depth_nm(&s, &half, &[(0.0, -20.0), (0.0, 20.0)], 10_000.0);
        assert!(d[0] > 0.0 && d[1] == 0.0);
        // Spiral with r1_start = r1_end and Modulated with amplitude 0 reproduce a Ring.
        let pts = [(15.0, 3.0), (-20.0, 1.0), (4.0, -26.0)];
        let ring = depth_nm(
            &s,
            &[Segment::Ring {
                r1_mm: 20.0,
                omega_rpm: 41.0,
                duration_s: 2.3,
            }],
            &pts,
            5_000.0,
        );
        let spir = depth_nm(
            &s,
            &[Segment::Spiral {
                r1_start_mm: 20.0,
                r1_end_mm: 20.0,
                omega_rpm: 41.0,
                duration_s: 2.3,
            }],
            &pts,
            5_000.0,
        );
        let modu = [Segment::Modulated {
            r1_mm: 20.0,
            mean_omega_rpm: 41.0,
            amplitude_rpm: 0.0,
            harmonic: 3,
            phase_rad: 0.5,
            duration_s: 2.3,
        }];
        let modu = depth_nm(&s, &modu, &pts, 5_000.0);
        for j in 0..3 {
            assert!(
                (ring[j] - spir[j]).abs() < 1e-12 * ring[j].max(1.0)
                    && (ring[j] - modu[j]).abs() < 1e-9 * ring[j].max(1.0)
            );
        }
    }
    #[test]
    fn modulated_one_revolution_matches_phi_integral() {
        // Period of φ for Ω = m + a cos(hφ + ψ) (rad/s, h ≥ 1): ∫_0^{2π} dφ/Ω = 2π/√(m² − a²).
        // depth(p at angle α) = scale ∫_{α−θ0}^{α+θ0} V(φ)/|Ω(φ)| dφ with c = r1(cos φ, sin φ).
        let s = setup();
        let (r1, mean, amp, h, ps) = (20.0, 30.0, 12.0, 2u32, 0.7);
        let (m, a) = (rpm_to_rad_s(mean), rpm_to_rad_s(amp));
        let t = 2.0 * PI / (m * m - a * a).sqrt();
        let motion = [Segment::Modulated {
            r1_mm: r1,
            mean_omega_rpm: mean,
            amplitude_rpm: amp,
            harmonic: h,
            phase_rad: ps,
            duration_s: t,
        }];
        let w2 = rpm_to_rad_s(s.tool_rpm);
        for &(r, al) in &[(13.0, 0.2), (20.0, 2.0), (26.0, -1.3)] {
            let p = (r * f64::cos(al), r * f64::sin(al));
            let th0 = theta0(r, r1, s.pad_radius_mm);
            let om = |ph: f64| m + a * (h as f64 * ph + ps).cos();
            let f = |ph: f64| {
                sliding_speed_mm_s(om(ph), w2, p, (r1 * ph.cos(), r1 * ph.sin())) / om(ph).abs()
            };
            let want = s.scale_nm_per_mm * simpson(f, al - th0, al + th0, 20000);
            let got = depth_nm(&s, &motion, &[p], 20_000.0)[0];
            assert!(
                (got - want).abs() < 1e-7 * want,
                "r={r} got={got} want={want}"
            );
        }
    }
    #[test]
    fn sectors_match_hand_timed_rings() {
        // S = 2: sector 0 = φ mod 2π ∈ [0, π) at 30 rpm = π rad/s, sector 1 = [π, 2π) at
        // 75 rpm = 2.5π rad/s; φ0 = 0.3 and Ω > 0, so φ falls:
        //   φ 0.3 → 0 (sector 0) in 0.3/π s; 0 → −π (sector 1) in π/(2.5π) = 0.4 s;
        //   −π → −2π (sector 0) in 1 s; then 0.2 s more in sector 1.
        let s = setup();
        let pts: Vec<(f64, f64)> = (0..24)
            .map(|k| {
                let (r, a) = (8.0 + 0.9 * k as f64, 0.77 * k as f64);
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let durs = [0.3 / PI, 0.4, 1.0, 0.2];
        let rpms = [30.0, 75.0, 30.0, 75.0];
        let hand: Vec<Segment> = (0..4)
            .map(|k| Segment::Ring {
                r1_mm: 20.0,
                omega_rpm: rpms[k],
                duration_s: durs[k],
            })
            .collect();
        let sec = [Segment::Sectors {
            r1_start_mm: 20.0,
            r1_end_mm: 20.0,
            omega_rpm: vec![30.0, 75.0],
            duration_s: durs.iter().sum(),
        }];
        let sps = 1.6e4 * 75.0 / 60.0;
        let (a, b) = (
            depth_nm(&s, &sec, &pts, sps),
            depth_nm(&s, &hand, &pts, sps),
        );
        let peak = b.iter().cloned().fold(0.0, f64::max);
        assert!(peak > 0.0);
        for j in 0..pts.len() {
            assert!(
                (a[j] - b[j]).abs() < 1e-9 * peak,
                "{j}: {} vs {}",
                a[j],
                b[j]
            );
        }
        // All speeds equal: exactly the Spiral (same steps, same arithmetic).
        let spiral = [Segment::Spiral {
            r1_start_mm: 12.0,
            r1_end_mm: 30.0,
            omega_rpm: -23.0,
            duration_s: 3.0,
        }];
        let equal = [Segment::Sectors {
            r1_start_mm: 12.0,
            r1_end_mm: 30.0,
            omega_rpm: vec![-23.0; 5],
            duration_s: 3.0,
        }];
        assert_eq!(
            depth_nm(&s, &spiral, &pts, 2_000.0),
            depth_nm(&s, &equal, &pts, 2_000.0)
        );
    }
}
