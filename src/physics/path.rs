//! The running integral of a removal rate along the tool's path, for one sample radius r:
//!
//! ```text
//! F(ρ) = ∫_lo^ρ f(x) dx,    f(x) = R(r; x)·ds/dx
//! ```
//!
//! (s the arc length along the surface, so ds/dx = 1 on a plane). A move across a cell
//! [b, b′] at constant speed along the surface in time d removes d·(F(b′) − F(b))/(s(b′) − s(b))
//! at r ([`super::motion`]); a constant feed over [a, b] at τ s/mm removes τ·(F(b) − F(a)).
//!
//! **Pieces.** f is analytic between breakpoints that the kernel names (the pad's rim crossing
//! r, the axis entering the pad, the zero of the sliding speed, a pressure model's edge),
//! where it has square-root kinks (the contact angle θ0 ~ √δ at tangency) or weaker
//! singularities (the sliding speed's zero, ~δ²·ln δ). Each piece [p, q] is halved at its
//! midpoint m, and each half is taken in the distance from its own end e (p or q):
//!
//! ```text
//! x = e ± H·v²,   v ∈ [0, 1],   H = (q − p)/2,   |dx| = 2H·v dv
//! ```
//!
//! so √(x − p) becomes √H·v: the integrand g(v) = f(x(v))·2H·v is analytic at the kink, and
//! δ²·ln δ becomes v⁵·ln v, whose Chebyshev coefficients fall like n⁻¹¹. Reading F at a
//! point costs one square root, no trigonometry. A half's other end is still a kink, at
//! v = √2, which bounds its convergence.
//!
//! **Whole pieces.** A kernel may instead take each piece at once ([`PieceMap::Whole`]), on the
//! rational parametrisation of the circle:
//!
//! ```text
//! x = p + W·s²,   q − x = W·c²,   s = 2t/(1 + t²),   c = (1 − t²)/(1 + t²),   t ∈ [0, 1],
//! W = q − p,   dx = W·8t(1 − t²)/(1 + t²)³ dt,   t = √(x − p)/(√W + √(q − x))
//! ```
//!
//! Both √(x − p) = √W·s and √(q − x) = √W·c are rational in t, so both kinks are regular at
//! once; the map's own poles at t = ±i bound the convergence (Bernstein ρ ≈ 4.6 against the
//! halves' 3.4). It also draws singularities beyond the piece's ends closer (x − p ≈ 4W·t²
//! against H·v²), so it pays where those are far: on curved parts (whose rates are costly) it
//! needs 42 % fewer rates than halves. A plane's rate has δ²·ln δ at the sliding speed's zero,
//! which the whole map leaves as slow as the halves do (47 % more rates over a row), unless the
//! logarithm is taken out first ([`super::sliding_log`]): then a piece at least its own width
//! from the contact angle's pole at x = 0 needs one span of 33 points where its halves need two
//! (34 % fewer rates over the paper's 201 rows). The integrand says which map each piece
//! takes ([`Integrand::piece_map`]). Reading F costs two square roots.
//!
//! **Panels.** g is represented on panels of [0, 1] by its Chebyshev interpolant at
//! Chebyshev–Lobatto points, 9, 17 then 33 (reusing every value), until the last three
//! coefficients are below the tolerance relative to the span's largest |g|, and the panel is
//! halved when 33 points do not suffice (a complex singularity near the piece, such as the pole
//! of the contact angle at x = 0 when r is close to the pad radius). The interpolant's
//! antiderivative is exact in Chebyshev coefficients (C_k = (c_{k−1} − c_{k+1})/2k), so F at any
//! x is one short Clenshaw sum: the cost per row does not depend on how many cells the plan has.
//!
//! **Batches.** The integrand is asked for a panel's new points together ([`Integrand`]), so
//! the flat rate can take their Carlson integrals side by side; and F is read at many ascending
//! points together ([`PathIntegral::at_ascending`]): a span's points get their v together, each
//! panel's run its t together, and their Clenshaw recurrences run 16 side by side (each one a
//! latency-bound chain; AVX-512 or AVX2 where the CPU has it, chosen at run time by
//! [`super::wide`]). Both give the bits of one point at a time.

use std::sync::OnceLock;

/// Path integrals at and above this count are made across threads: each costs some 15 µs
/// (about 150 evaluations of the rate), far more than handing it to another thread.
pub const PARALLEL_MIN_PATHS: usize = 16;

/// Intervals of the coarsest Chebyshev–Lobatto rule a panel tries; each further level doubles
/// them (nested rules: a level reuses every point of the one before).
const FIRST_INTERVALS: usize = 8;
/// How many rules a panel tries: 9, 17 and 33 points (7/13/25/49 and 6/11/21/41 cost more on a
/// plane: docs/PERFORMANCE.md).
const LEVELS: usize = 3;
/// Most Chebyshev points on one panel.
const MAX_POINTS: usize = (FIRST_INTERVALS << (LEVELS - 1)) + 1;
/// Coefficients of a panel's antiderivative (one more than its points).
const MAX_COEFFS: usize = MAX_POINTS + 1;
/// Deepest halving of a span's panels; past it a panel is taken as it is.
const MAX_DEPTH: u32 = 14;
/// Most panels on one span; past it the remaining panels are taken as they are, so no
/// integrand costs more than about this many times 33 evaluations per span.
const MAX_PANELS: usize = 512;
/// How many units of x's rounding, relative to a half-piece's width, a fit need not resolve: below
/// that the values are rounding noise and halving would go on to the deepest level.
const ROUNDING_FLOOR: f64 = 64.0 * f64::EPSILON;

/// What a path integral integrates: f at many points at once (a panel's new Chebyshev
/// points are asked for together, so an integrand can evaluate them side by side).
pub trait Integrand {
    /// f(x) for every x of `xs` into `out` (of the same length).
    fn values(&self, xs: &[f64], out: &mut [f64]);

    /// How the piece [p, q] is best mapped, where the integrand knows its singularities
    /// better than the [`Resolution`]'s one map for every piece.
    fn piece_map(&self, _p: f64, _q: f64) -> Option<PieceMap> {
        None
    }
}

/// A function of one point as an [`Integrand`], evaluated point by point.
pub struct Pointwise<F>(pub F);

impl<F: Fn(f64) -> f64> Integrand for Pointwise<F> {
    fn values(&self, xs: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(xs) {
            *o = (self.0)(x);
        }
    }
}

impl<T: Integrand + ?Sized> Integrand for &T {
    fn values(&self, xs: &[f64], out: &mut [f64]) {
        (**self).values(xs, out)
    }

    fn piece_map(&self, p: f64, q: f64) -> Option<PieceMap> {
        (**self).piece_map(p, q)
    }
}

/// One polynomial panel of a span: v in [lo, hi], the integral from v = 0 to lo, and
/// the antiderivative's Chebyshev coefficients (scaled by the half-width) in `coeffs`.
#[derive(Debug, Clone, Copy)]
struct Panel {
    lo: f64,
    hi: f64,
    base: f64,
    first: u32,
    len: u32,
}

/// How one piece's spans are fitted: the Chebyshev points, the piece's tolerance, and whether
/// the interpolants are kept (for reading F) or only their integrals.
#[derive(Clone, Copy)]
struct Fitting<'a> {
    table: &'a Lobatto,
    tolerance: f64,
    keep: bool,
}

/// How a piece [p, q] between kinks is mapped onto the variable its panels are fitted in (the
/// module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PieceMap {
    /// Two halves, x = e ± H·v² from each end.
    Halves,
    /// The whole piece, x = p + W·s², s = 2t/(1 + t²).
    Whole,
}

/// How finely a path integral resolves its pieces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolution {
    /// The largest trailing Chebyshev coefficient, relative to a span's largest |g|.
    pub tolerance: f64,
    pub map: PieceMap,
}

/// Which part of a piece a span covers, and how.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SpanKind {
    /// The lower half: x = end + width·v².
    Below,
    /// The upper half: x = end − width·v².
    Above,
    /// The whole piece from end = p: x = p + width·s(v)².
    Whole,
}

/// A span of a piece fitted in one variable v ∈ [0, 1]: a half of `width` mm measured from its
/// end `end` toward the piece's middle, or a whole piece of `width` mm from `end`.
#[derive(Debug, Clone, Copy)]
struct Span {
    kind: SpanKind,
    end: f64,
    width: f64,
    /// F at the span's lower x end.
    base: f64,
    /// ∫ over the span.
    total: f64,
    first_panel: u32,
    panels: u32,
}

impl Span {
    /// A span not yet fitted.
    fn new(kind: SpanKind, end: f64, width: f64) -> Span {
        Span {
            kind,
            end,
            width,
            base: 0.0,
            total: 0.0,
            first_panel: 0,
            panels: 0,
        }
    }

    /// The span's lower x end: the piece's start, or its middle for an upper half.
    fn start(&self) -> f64 {
        match self.kind {
            SpanKind::Below | SpanKind::Whole => self.end,
            SpanKind::Above => self.end - self.width,
        }
    }

    /// The span's upper x end.
    fn top(&self) -> f64 {
        match self.kind {
            SpanKind::Below | SpanKind::Whole => self.end + self.width,
            SpanKind::Above => self.end,
        }
    }

    /// Whether v grows with x (all but an upper half).
    fn ascending(&self) -> bool {
        self.kind != SpanKind::Above
    }

    /// The span's variable v at every x of `xs` into `out`, clamped to [0, 1] (one loop per
    /// kind, so each vectorises).
    #[inline(always)]
    fn v_into(&self, xs: &[f64], out: &mut [f64]) {
        let (end, width) = (self.end, self.width);
        let points = out.iter_mut().zip(xs);
        match self.kind {
            SpanKind::Below => {
                points.for_each(|(v, &x)| *v = ((x - end) / width).clamp(0.0, 1.0).sqrt())
            }
            SpanKind::Above => {
                points.for_each(|(v, &x)| *v = ((end - x) / width).clamp(0.0, 1.0).sqrt())
            }
            SpanKind::Whole => points.for_each(|(v, &x)| {
                let near = (x - end).max(0.0).sqrt();
                let far = (end + width - x).max(0.0).sqrt();
                *v = (near / (width.sqrt() + far)).clamp(0.0, 1.0);
            }),
        }
    }
}

/// F(x) = ∫_lo^x f on [lo, hi] (0 below, the total above); see the module docs.
#[derive(Debug, Clone, Default)]
pub struct PathIntegral {
    spans: Vec<Span>,
    panels: Vec<Panel>,
    coeffs: Vec<f64>,
    total: f64,
}

impl PathIntegral {
    /// The integral of `f` over the pieces between consecutive `breakpoints` (ascending; empty
    /// pieces are skipped), each mapped and resolved as `resolution` says, with the Chebyshev
    /// points of `table` (made once per kernel, not per radius).
    pub fn new<F: Integrand>(
        f: F,
        breakpoints: &[f64],
        resolution: Resolution,
        table: &Lobatto,
    ) -> Self {
        Self::build(f, breakpoints, resolution, table, true)
    }

    /// ∫ f over the pieces alone, as [`Self::new`] resolves it but keeping no interpolant:
    /// each panel's integral is its Clenshaw–Curtis sum, and only the coefficients the
    /// convergence test needs are computed (what a constant-feed pass needs of a radius).
    pub fn total_over<F: Integrand>(
        f: F,
        breakpoints: &[f64],
        resolution: Resolution,
        table: &Lobatto,
    ) -> f64 {
        Self::build(f, breakpoints, resolution, table, false).total
    }

    /// `keep`: store the panels' antiderivatives for [`Self::at`].
    fn build<F: Integrand>(
        f: F,
        breakpoints: &[f64],
        resolution: Resolution,
        table: &Lobatto,
        keep: bool,
    ) -> Self {
        // Room for the usual row (a few pieces, two spans each, one panel of at most 34
        // coefficients a span), so the vectors are not grown a step at a time.
        let spans = 2 * breakpoints.len().saturating_sub(1);
        let mut integral = PathIntegral {
            spans: Vec::with_capacity(spans),
            panels: Vec::with_capacity(if keep { spans } else { 0 }),
            coeffs: Vec::with_capacity(if keep { spans * MAX_COEFFS } else { 0 }),
            total: 0.0,
        };
        for w in breakpoints.windows(2) {
            let (p, q) = (w[0], w[1]);
            if q <= p || q.is_nan() || p.is_nan() {
                continue;
            }
            let half = 0.5 * (q - p);
            let middle = p + half;
            // x = end ± H·v² is only known to |x|·ε: on a short piece far from the origin
            // (a 1 µm pad on a 9 m part) that is the best relative accuracy of any value.
            let fitting = Fitting {
                table,
                tolerance: resolution
                    .tolerance
                    .max(ROUNDING_FLOOR * p.abs().max(q.abs()) / half),
                keep,
            };
            match f.piece_map(p, q).unwrap_or(resolution.map) {
                PieceMap::Halves => {
                    // g(v) = f(x)·2H·v, in that order of products (the bits of every release).
                    let dx = |f: f64, v: f64| f * 2.0 * half * v;
                    let below = |v: f64| (p + half * v * v).min(middle);
                    let above = |v: f64| (q - half * v * v).max(middle);
                    integral.push_span(
                        &f,
                        Span::new(SpanKind::Below, p, half),
                        below,
                        dx,
                        &fitting,
                    );
                    integral.push_span(
                        &f,
                        Span::new(SpanKind::Above, q, half),
                        above,
                        dx,
                        &fitting,
                    );
                }
                PieceMap::Whole => {
                    let width = q - p;
                    // x from the nearer end, so either kink's distance keeps its precision.
                    let x = |t: f64| {
                        let d = 1.0 + t * t;
                        let s2 = 4.0 * t * t / (d * d);
                        if s2 <= 0.5 {
                            (p + width * s2).min(q)
                        } else {
                            let c = (1.0 - t * t) / d;
                            (q - width * c * c).max(p)
                        }
                    };
                    let dx = |f: f64, t: f64| {
                        let d = 1.0 + t * t;
                        f * width * 8.0 * t * (1.0 - t * t) / (d * d * d)
                    };
                    integral.push_span(&f, Span::new(SpanKind::Whole, p, width), x, dx, &fitting);
                }
            }
        }
        integral
    }

    /// Fits f on `span` (its base, total and panels filled in here) in the span's variable v:
    /// g(v) = `dx`(f(`x`(v)), v), f's value times dx/dv.
    fn push_span<F: Integrand>(
        &mut self,
        f: &F,
        mut span: Span,
        x: impl Fn(f64) -> f64,
        dx: impl Fn(f64, f64) -> f64,
        fitting: &Fitting,
    ) {
        let g = |vs: &[f64], out: &mut [f64]| {
            let mut xs = [0.0; MAX_POINTS];
            let xs = &mut xs[..vs.len()];
            for (x_k, &v) in xs.iter_mut().zip(vs) {
                *x_k = x(v);
            }
            f.values(xs, out);
            for (o, &v) in out.iter_mut().zip(vs) {
                *o = dx(*o, v);
            }
        };
        span.first_panel = self.panels.len() as u32;
        span.base = self.total;
        span.total = self.fit_span(&g, fitting);
        span.panels = self.panels.len() as u32 - span.first_panel;
        self.total += span.total;
        self.spans.push(span);
    }

    /// Panels of g over v ∈ [0, 1], depth first so they come out in ascending v (kept only
    /// with `fitting.keep`); returns ∫.
    fn fit_span<G: Fn(&[f64], &mut [f64])>(&mut self, g: &G, fitting: &Fitting) -> f64 {
        let Fitting {
            table,
            tolerance,
            keep,
        } = *fitting;
        let mut total = 0.0;
        let mut scale = 0.0_f64;
        // Depth first, so at most one pending panel per depth besides the two just split: on
        // the call's own stack (no allocation per span).
        let mut stack = [(0.0, 0.0, 0_u32); MAX_DEPTH as usize + 2];
        stack[0] = (0.0, 1.0, 0);
        let mut pending = 1;
        let mut panels = 0;
        while pending > 0 {
            pending -= 1;
            let (lo, hi, depth) = stack[pending];
            let anyway = depth >= MAX_DEPTH || panels >= MAX_PANELS;
            let Some((values, points)) = table.sample(g, lo, hi, &mut scale, tolerance, anyway)
            else {
                let mid = 0.5 * (lo + hi);
                stack[pending] = (mid, hi, depth + 1);
                stack[pending + 1] = (lo, mid, depth + 1);
                pending += 2;
                continue;
            };
            panels += 1;
            if !keep {
                total += 0.5 * (hi - lo) * table.integral(&values, points);
                continue;
            }
            let big = table.antiderivative(&values, points);
            let first = self.coeffs.len() as u32;
            // Trailing coefficients far below the tolerance are dropped: reading F then costs
            // only the terms that matter (each dropped one moves F by less than its size).
            let negligible = 1e-3 * tolerance * scale * (hi - lo);
            let value = append_scaled(&big, points, 0.5 * (hi - lo), negligible, &mut self.coeffs);
            self.panels.push(Panel {
                lo,
                hi,
                base: total,
                first,
                len: self.coeffs.len() as u32 - first,
            });
            total += value;
        }
        total
    }

    /// ∫ f over everything.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// F at every x of `xs` (ascending) into `out`, as [`Self::at`] reads each, but reading
    /// the points of one panel together: their Clenshaw recurrences run side by side
    /// ([`LANES`] at a time) instead of one latency-bound chain after another (an operator row
    /// reads F at every cell boundary in the pad's reach, hundreds of points on a few panels).
    pub fn at_ascending(&self, xs: &[f64], out: &mut [f64]) {
        debug_assert!(xs.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!(xs.len(), out.len(), "one output per point");
        crate::wide::widest(Read {
            path: self,
            xs,
            out,
        });
    }

    /// The points are taken span by span: those in one span are read by [`Self::read_span`],
    /// those past the last span's top (or in a rounding gap after a span) are its total.
    #[inline(always)]
    fn read_ascending(&self, xs: &[f64], out: &mut [f64]) {
        let mut i = 0;
        while i < xs.len() {
            let k = self.spans.partition_point(|span| span.start() <= xs[i]);
            if k == 0 {
                out[i] = 0.0;
                i += 1;
                continue;
            }
            let span = &self.spans[k - 1];
            if xs[i] >= span.top() {
                out[i] = span.base + span.total;
                i += 1;
                continue;
            }
            let next = self.spans.get(k).map_or(f64::INFINITY, Span::start);
            let run = xs[i..].partition_point(|&x| x < span.top() && x < next);
            self.read_span(span, &xs[i..i + run], &mut out[i..i + run]);
            i += run;
        }
    }

    /// F at points of `xs` all inside `span`: their v, then for each run of points on one
    /// panel, the panel's t, Clenshaw's sums side by side, and the span's offsets. `out`
    /// holds v, then t, then F in turn.
    #[inline(always)]
    fn read_span(&self, span: &Span, xs: &[f64], out: &mut [f64]) {
        span.v_into(xs, out);
        let panels =
            &self.panels[span.first_panel as usize..(span.first_panel + span.panels) as usize];
        let mut i = 0;
        while i < out.len() {
            let j = panels.partition_point(|panel| panel.lo <= out[i]).max(1) - 1;
            let panel = &panels[j];
            let upper = panels.get(j + 1).map_or(f64::INFINITY, |next| next.lo);
            let lower = if j == 0 { f64::NEG_INFINITY } else { panel.lo };
            let run = out[i..]
                .iter()
                .position(|&v| v < lower || v >= upper)
                .unwrap_or(out.len() - i);
            let on_panel = &mut out[i..i + run];
            // A panel's width is a power of two (halvings of [0, 1]), so its reciprocal is
            // exact and the product is the quotient, without a division per point.
            let per_width = 1.0 / (panel.hi - panel.lo);
            for v in on_panel.iter_mut() {
                *v = ((2.0 * *v - panel.lo - panel.hi) * per_width).clamp(-1.0, 1.0);
            }
            let coeffs = &self.coeffs[panel.first as usize..(panel.first + panel.len) as usize];
            clenshaw_in_place(coeffs, on_panel);
            for value in on_panel.iter_mut() {
                let from_end = panel.base + *value;
                *value = if span.ascending() {
                    span.base + from_end
                } else {
                    span.base + span.total - from_end
                };
            }
            i += run;
        }
    }

    /// F(x) = ∫_lo^x f.
    pub fn at(&self, x: f64) -> f64 {
        let mut value = [0.0];
        self.at_ascending(&[x], &mut value);
        value[0]
    }
}

/// [`PathIntegral::at_ascending`]'s work, for [`crate::wide::widest`].
struct Read<'a> {
    path: &'a PathIntegral,
    xs: &'a [f64],
    out: &'a mut [f64],
}

impl crate::wide::Wide for Read<'_> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        self.path.read_ascending(self.xs, self.out);
    }
}

/// cos(πk/N) for N = 32 and k < 2N: the first 33 are the Chebyshev–Lobatto points, all of
/// them the DCT's cosines. With them, the Clenshaw–Curtis weights of the 9-, 17- and 33-point
/// rules (nested: each uses every other point of the next).
#[derive(Debug, Clone)]
pub struct Lobatto {
    cosines: [f64; 2 * (MAX_POINTS - 1)],
    /// weights[m][k]: the weight of point k of the rule at level m (FIRST_INTERVALS·2^m + 1
    /// points), on [−1, 1].
    weights: [[f64; MAX_POINTS]; LEVELS],
    /// dct[m]: cos(πjk/n) for the rule at level m (n = FIRST_INTERVALS·2^m), as an (n + 1)²
    /// matrix (symmetric in j and k), so a DCT reads consecutive memory.
    dct: [Vec<f64>; LEVELS],
    /// antiderivative[m]: row k (k ≤ n/2) holds the antiderivative's n + 2 Chebyshev
    /// coefficients for node values e_k (the DCT then [`antiderivative_coefficients`], both
    /// linear), so a panel's antiderivative is one product with its node values. Node n − k's
    /// row is row k with the even coefficients (but C_0) negated (cos(πj(n − k)/n) =
    /// (−1)^j·cos(πjk/n), and C_m takes c_{m±1}), so only half the rows are kept.
    antiderivative: [Vec<f64>; LEVELS],
}

impl Lobatto {
    /// The table, made once for the whole program (a few tens of microseconds: every kernel
    /// made its own, once per request) and never changed after.
    pub fn shared() -> &'static Lobatto {
        static TABLE: OnceLock<Lobatto> = OnceLock::new();
        TABLE.get_or_init(Lobatto::default)
    }
}

impl Default for Lobatto {
    fn default() -> Self {
        let n = (MAX_POINTS - 1) as f64;
        let mut cosines = [0.0; 2 * (MAX_POINTS - 1)];
        for (k, c) in cosines.iter_mut().enumerate() {
            *c = (std::f64::consts::PI * k as f64 / n).cos();
        }
        // w_k = (c_k/N)·(1 − Σ_{j=1}^{N/2} b_j/(4j² − 1)·cos(2πjk/N)), c_k = 1 at the two
        // ends and 2 inside, b_j = 1 for j = N/2 and 2 below (Waldvogel 2006).
        let period = 2 * (MAX_POINTS - 1);
        let mut weights = [[0.0; MAX_POINTS]; LEVELS];
        for (m, rule) in weights.iter_mut().enumerate() {
            let intervals = FIRST_INTERVALS << m;
            let stride = (MAX_POINTS - 1) / intervals;
            for (k, w) in rule.iter_mut().enumerate().take(intervals + 1) {
                let mut sum = 0.0;
                for j in 1..=intervals / 2 {
                    let b = if j == intervals / 2 { 1.0 } else { 2.0 };
                    let cos = cosines[(2 * j * k * stride) % period];
                    sum += b / (4.0 * (j * j) as f64 - 1.0) * cos;
                }
                let c = if k == 0 || k == intervals { 1.0 } else { 2.0 };
                *w = c / intervals as f64 * (1.0 - sum);
            }
        }
        let dct = std::array::from_fn(|m| {
            let n = FIRST_INTERVALS << m;
            let stride = (MAX_POINTS - 1) / n;
            let mut matrix = vec![0.0; (n + 1) * (n + 1)];
            for j in 0..=n {
                for k in 0..=n {
                    matrix[j * (n + 1) + k] = cosines[(j * k * stride) % period];
                }
            }
            matrix
        });
        let mut table = Lobatto {
            cosines,
            weights,
            dct,
            antiderivative: Default::default(),
        };
        table.antiderivative = std::array::from_fn(|m| {
            let points = (FIRST_INTERVALS << m) + 1;
            let rows = points / 2 + 1;
            let mut matrix = Vec::with_capacity(rows * (points + 1));
            for k in 0..rows {
                let mut unit = [0.0; MAX_POINTS];
                unit[k] = 1.0;
                let big = antiderivative_coefficients(&table.dct_of_nodes(&unit, points), points);
                matrix.extend_from_slice(&big[..=points]);
            }
            matrix
        });
        table
    }
}

impl Lobatto {
    /// g at the Chebyshev–Lobatto points of [lo, hi] (every `stride`-th of `values`, stride
    /// = 32/(points − 1)), 9, 17 or 33 of them: the first count whose interpolant resolves g
    /// (last three Chebyshev coefficients within `tolerance`·scale, `scale` the largest |g|
    /// seen on the span so far); `None` when 33 do not, unless `anyway`.
    fn sample<G: Fn(&[f64], &mut [f64])>(
        &self,
        g: &G,
        lo: f64,
        hi: f64,
        scale: &mut f64,
        tolerance: f64,
        anyway: bool,
    ) -> Option<([f64; MAX_POINTS], usize)> {
        let mut values = [f64::NAN; MAX_POINTS];
        let (centre, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let mut points = FIRST_INTERVALS + 1;
        loop {
            let stride = (MAX_POINTS - 1) / (points - 1);
            // The level's new points, all at once: every point of the first rule, then the
            // odd ones of each finer rule (its even ones are the coarser rule's).
            let (first, step) = if points == FIRST_INTERVALS + 1 {
                (0, stride)
            } else {
                (stride, 2 * stride)
            };
            let (mut new, mut vs, mut count) = ([0; MAX_POINTS], [0.0; MAX_POINTS], 0);
            for k in (first..MAX_POINTS).step_by(step) {
                new[count] = k;
                vs[count] = centre + half * self.cosines[k];
                count += 1;
            }
            let mut got = [0.0; MAX_POINTS];
            g(&vs[..count], &mut got[..count]);
            for (&k, &value) in new[..count].iter().zip(&got[..count]) {
                values[k] = value;
                *scale = scale.max(value.abs());
            }
            let nodes = gathered(&values, points);
            let tail = (points - 3..points)
                .map(|j| self.coefficient(&nodes, points, j).abs())
                .fold(0.0_f64, f64::max);
            // A bound below the normal range cannot be met by rounding (a process so weak its
            // rates are subnormal): such a panel is as resolved as f64 allows.
            let bound = (tolerance * *scale).max(f64::MIN_POSITIVE);
            if tail <= bound || (anyway && points == MAX_POINTS) {
                return Some((values, points));
            }
            if points == MAX_POINTS {
                return None;
            }
            points = 2 * points - 1;
        }
    }

    /// Coefficient j of the interpolant through the `points` node values `nodes` (DCT-I):
    /// c_j = (2/n)·Σ'' g_k·cos(πjk/n), the sum's two end terms halved, and c_j halved again
    /// for j = 0 and n.
    fn coefficient(&self, nodes: &[f64; MAX_POINTS], points: usize, j: usize) -> f64 {
        let n = points - 1;
        let cos = &self.dct[level(n)][j * points..(j + 1) * points];
        let mut sum = 0.5 * (nodes[0] + nodes[n] * cos[n]);
        for k in 1..n {
            sum += nodes[k] * cos[k];
        }
        finish_coefficient(sum, n, j)
    }

    /// All coefficients of the interpolant through the consecutive node values `nodes`:
    /// g = Σ c_j·T_j exactly at the `points` nodes (made once, for the antiderivative tables).
    fn dct_of_nodes(&self, nodes: &[f64; MAX_POINTS], points: usize) -> [f64; MAX_POINTS] {
        std::array::from_fn(|j| {
            if j < points {
                self.coefficient(nodes, points, j)
            } else {
                0.0
            }
        })
    }

    /// The Chebyshev coefficients of ∫_{−1}^t of the interpolant through the `points` node
    /// values held in `values` (every 32/(points − 1)-th): the node values times the level's
    /// antiderivative table, every coefficient summed side by side in the widest build.
    fn antiderivative(&self, values: &[f64; MAX_POINTS], points: usize) -> [f64; MAX_COEFFS] {
        crate::wide::widest(Antiderivative {
            table: self,
            values,
            points,
        })
    }

    /// [`Self::antiderivative`], compiled into each wide build.
    #[inline(always)]
    fn antiderivative_product(
        &self,
        values: &[f64; MAX_POINTS],
        points: usize,
    ) -> [f64; MAX_COEFFS] {
        let nodes = gathered(values, points);
        let n = points - 1;
        let width = points + 1;
        let matrix = &self.antiderivative[level(n)];
        let mut sums = [0.0; MAX_COEFFS];
        // Nodes k and n − k together: their sum weighs row k's odd coefficients, their
        // difference its even ones (the middle node alone: its even ones are zero).
        for k in 0..=n / 2 {
            let (even, odd) = if 2 * k == n {
                (0.0, nodes[k])
            } else {
                (nodes[k] - nodes[n - k], nodes[k] + nodes[n - k])
            };
            let row = &matrix[k * width..(k + 1) * width];
            for (m, (s, &t)) in sums.iter_mut().zip(row).enumerate() {
                *s += t * if m % 2 == 0 { even } else { odd };
            }
        }
        // C_0 puts the value at t = −1 at zero, as in [`antiderivative_coefficients`].
        sums[0] = -(1..width)
            .map(|k| if k % 2 == 0 { sums[k] } else { -sums[k] })
            .sum::<f64>();
        sums
    }

    /// ∫_{−1}^{1} of the interpolant through the `points` nodes (Clenshaw–Curtis).
    fn integral(&self, values: &[f64; MAX_POINTS], points: usize) -> f64 {
        let stride = (MAX_POINTS - 1) / (points - 1);
        let rule = &self.weights[level(points - 1)];
        (0..points).map(|k| rule[k] * values[k * stride]).sum()
    }
}

/// [`Lobatto::antiderivative`]'s work, for [`crate::wide::widest`].
struct Antiderivative<'a> {
    table: &'a Lobatto,
    values: &'a [f64; MAX_POINTS],
    points: usize,
}

impl crate::wide::Wide for Antiderivative<'_> {
    type Output = [f64; MAX_COEFFS];

    #[inline(always)]
    fn run(self) -> Self::Output {
        self.table.antiderivative_product(self.values, self.points)
    }
}

/// The level of the rule with `intervals` intervals (0 for the coarsest).
fn level(intervals: usize) -> usize {
    (intervals / FIRST_INTERVALS).trailing_zeros() as usize
}

/// c_j from its DCT sum over n intervals.
fn finish_coefficient(sum: f64, n: usize, j: usize) -> f64 {
    let value = 2.0 * sum / n as f64;
    if j == 0 || j == n {
        0.5 * value
    } else {
        value
    }
}

/// The values of the `points` nodes, consecutive (`values` holds them every 32/(points − 1)).
#[inline(always)]
fn gathered(values: &[f64; MAX_POINTS], points: usize) -> [f64; MAX_POINTS] {
    let stride = (MAX_POINTS - 1) / (points - 1);
    std::array::from_fn(|k| if k < points { values[k * stride] } else { 0.0 })
}

/// The coefficients of ∫_{−1}^t Σ c_k·T_k (the first `n` of `c`): C_k = (c_{k−1} − c_{k+1})/2k,
/// and C_0 so that the value at t = −1 is zero (T_k(−1) = (−1)^k).
fn antiderivative_coefficients(c: &[f64; MAX_POINTS], n: usize) -> [f64; MAX_COEFFS] {
    let at = |k: usize| if k < n { c[k] } else { 0.0 };
    let mut big = [0.0; MAX_COEFFS];
    big[1] = at(0) - 0.5 * at(2);
    for (k, value) in big.iter_mut().enumerate().take(n + 1).skip(2) {
        *value = (at(k - 1) - at(k + 1)) / (2 * k) as f64;
    }
    big[0] = -(1..=n)
        .map(|k| if k % 2 == 0 { big[k] } else { -big[k] })
        .sum::<f64>();
    big
}

/// Appends the first `points + 1` of the antiderivative coefficients `big` times `half` (the
/// panel's half-width, so the result is in the panel's own variable), less trailing ones of
/// size at most `negligible`, and returns the integral over the panel.
fn append_scaled(
    big: &[f64; MAX_COEFFS],
    points: usize,
    half: f64,
    negligible: f64,
    out: &mut Vec<f64>,
) -> f64 {
    let big = &big[..=points];
    let total: f64 = big.iter().sum::<f64>() * half;
    let kept = big
        .iter()
        .rposition(|v| (v * half).abs() > negligible)
        .map_or(1, |k| k + 1);
    out.extend(big[..kept].iter().map(|v| v * half));
    total
}

/// Points whose Clenshaw recurrences [`PathIntegral::at_ascending`] runs side by side.
const LANES: usize = 16;

/// Σ a_k·T_k(t) by Clenshaw's recurrence at every t of `ts`, replacing each t by its sum:
/// [`LANES`] recurrences side by side.
#[inline(always)]
fn clenshaw_in_place(a: &[f64], ts: &mut [f64]) {
    let mut blocks = ts.chunks_exact_mut(LANES);
    for block in &mut blocks {
        let t: [f64; LANES] = (&*block).try_into().unwrap();
        block.copy_from_slice(&clenshaw_lanes(a, t));
    }
    // The last few points run as one padded block: one at a time, each would be a chain of
    // its own, as long as a whole block's.
    let rest = blocks.into_remainder();
    if !rest.is_empty() {
        let mut t = [0.0; LANES];
        t[..rest.len()].copy_from_slice(rest);
        let sums = clenshaw_lanes(a, t);
        rest.copy_from_slice(&sums[..rest.len()]);
    }
}

/// Clenshaw's recurrence at `L` points at once, each lane on its own.
#[inline(always)]
fn clenshaw_lanes<const L: usize>(a: &[f64], t: [f64; L]) -> [f64; L] {
    let (mut b1, mut b2) = ([0.0; L], [0.0; L]);
    let two_t = t.map(|t| 2.0 * t);
    for &ak in a[1..].iter().rev() {
        for l in 0..L {
            // a_k − b_{k+2} is ready a step early, so only a product and a sum lie on the
            // recurrence's critical path.
            let b0 = (ak - b2[l]) + two_t[l] * b1[l];
            b2[l] = b1[l];
            b1[l] = b0;
        }
    }
    std::array::from_fn(|l| a[0] + t[l] * b1[l] - b2[l])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both maps of a piece at `tolerance`: every test holds for either.
    fn both(tolerance: f64) -> [Resolution; 2] {
        [PieceMap::Halves, PieceMap::Whole].map(|map| Resolution { tolerance, map })
    }

    #[test]
    fn integrates_polynomials_and_square_root_kinks_exactly() {
        for resolution in both(1e-14) {
            polynomials_and_kinks(resolution);
        }
    }

    fn polynomials_and_kinks(resolution: Resolution) {
        // ∫_0^x (3t² + 1) dt = x³ + x.
        let f = PathIntegral::new(
            Pointwise(|t| 3.0 * t * t + 1.0),
            &[0.0, 2.0],
            resolution,
            &Lobatto::default(),
        );
        for x in [0.0_f64, 0.3, 1.0, 1.7, 2.0, 5.0] {
            let want = x.min(2.0).powi(3) + x.min(2.0);
            assert!((f.at(x) - want).abs() < 1e-13 * 10.0, "{x}: {}", f.at(x));
        }
        assert_eq!(f.at(-1.0), 0.0);
        // √(x(1 − x)) on [0, 1] (a square-root kink at each end) and √(x − 1) on [1, 3]:
        // F(1) = π/8, F(3) = π/8 + (2/3)·2^{3/2}.
        let g = |x: f64| {
            if x <= 1.0 {
                (x * (1.0 - x)).max(0.0).sqrt()
            } else {
                (x - 1.0).sqrt()
            }
        };
        let f = PathIntegral::new(
            Pointwise(g),
            &[0.0, 1.0, 3.0],
            resolution,
            &Lobatto::default(),
        );
        let pi8 = std::f64::consts::PI / 8.0;
        assert!((f.at(1.0) - pi8).abs() < 1e-14, "{}", f.at(1.0) - pi8);
        let total = pi8 + 2.0 / 3.0 * 2f64.powf(1.5);
        assert!((f.total() - total).abs() < 1e-13, "{}", f.total() - total);
        // Inside a piece: ∫_1^2 √(x − 1) = 2/3.
        assert!((f.at(2.0) - f.at(1.0) - 2.0 / 3.0).abs() < 1e-13);
    }

    /// The Clenshaw–Curtis weights integrate the rule's polynomials exactly (∫T_j over [−1, 1]
    /// is 2/(1 − j²) for even j, 0 for odd), and a total with no interpolant kept equals the
    /// interpolant's own to rounding.
    #[test]
    fn totals_without_an_interpolant_agree() {
        let table = Lobatto::default();
        for points in (0..LEVELS).map(|m| (FIRST_INTERVALS << m) + 1) {
            let stride = (MAX_POINTS - 1) / (points - 1);
            for j in 0..points {
                let mut values = [f64::NAN; MAX_POINTS];
                for k in 0..points {
                    values[k * stride] =
                        (j as f64 * (k as f64 * std::f64::consts::PI / (points - 1) as f64)).cos();
                }
                let want = if j % 2 == 0 {
                    2.0 / (1.0 - (j * j) as f64)
                } else {
                    0.0
                };
                let got = table.integral(&values, points);
                assert!(
                    (got - want).abs() < 1e-14,
                    "{points} points, T_{j}: {got} vs {want}"
                );
            }
        }
        let g = |x: f64| (x * (3.0 - x)).max(0.0).sqrt() * (1.0 + x).ln() + 1.0 / (x + 0.05);
        for resolution in both(1e-13) {
            let kept = PathIntegral::new(Pointwise(g), &[0.0, 1.3, 3.0], resolution, &table);
            let total =
                PathIntegral::total_over(Pointwise(g), &[0.0, 1.3, 3.0], resolution, &table);
            assert!(
                (kept.total() - total).abs() <= 1e-14 * total,
                "{resolution:?}: {} vs {total}",
                kept.total()
            );
        }
    }

    #[test]
    fn a_short_piece_far_from_the_origin_stops_at_rounding() {
        // A 2 µm contact at r ≈ 9143.786 mm: x is known to 1e-12 mm, 5e-10 of the piece, so
        // 1e-12 relative cannot be reached. Each half used to be halved to the deepest level
        // (2^14 panels of 33 points), and one recommendation ran for minutes.
        let (p, q) = (9_143.785_284_385_247, 9_143.787_284_385_247);
        for resolution in both(1e-12) {
            let f = PathIntegral::new(
                Pointwise(|x: f64| ((x - p) * (q - x)).max(0.0).sqrt()),
                &[p, q],
                resolution,
                &Lobatto::default(),
            );
            assert!(
                f.panels.len() <= 8,
                "{resolution:?}: {} panels",
                f.panels.len()
            );
            // ∫ √((x − p)(q − x)) = π/8·(q − p)²; the rounding of x is 1e-9 of the width.
            let want = std::f64::consts::PI / 8.0 * (q - p) * (q - p);
            assert!(
                (f.total() - want).abs() < 1e-8 * want,
                "{resolution:?}: {}",
                f.total() / want - 1.0
            );
        }
    }

    /// Reading many points at once gives exactly what reading each does: before, on and
    /// after every piece, at the spans' ends and middles, and on panels of every kind.
    #[test]
    fn reading_in_ascending_runs_is_reading_each_point() {
        let g = |x: f64| (x * (3.0 - x)).max(0.0).sqrt() * (1.0 + x).ln() + 1.0 / (x + 0.05);
        for resolution in both(1e-13) {
            let f = PathIntegral::new(
                Pointwise(g),
                &[0.0, 1.3, 3.0],
                resolution,
                &Lobatto::default(),
            );
            let mut xs: Vec<f64> = (0..=997).map(|k| -0.2 + 3.5 * k as f64 / 997.0).collect();
            xs.extend([0.0, 0.65, 1.3, 2.15, 3.0, 3.0, 1.3]);
            xs.sort_by(f64::total_cmp);
            let mut out = vec![f64::NAN; xs.len()];
            f.at_ascending(&xs, &mut out);
            for (&x, &got) in xs.iter().zip(&out) {
                assert_eq!(got.to_bits(), f.at(x).to_bits(), "{resolution:?}, x = {x}");
            }
            // The portable build (the wide ones are dispatched to on this CPU) agrees bit for bit.
            let mut portable = vec![f64::NAN; xs.len()];
            f.read_ascending(&xs, &mut portable);
            for ((&x, &got), &want) in xs.iter().zip(&out).zip(&portable) {
                assert_eq!(got.to_bits(), want.to_bits(), "portable, x = {x}");
            }
            // Panels of every kind: halves split more finely than whole pieces.
            let least = match resolution.map {
                PieceMap::Halves => 4,
                PieceMap::Whole => 2,
            };
            assert!(
                f.panels.len() > least,
                "{resolution:?}: {} panels",
                f.panels.len()
            );
        }
    }

    #[test]
    fn halves_panels_near_a_nearby_pole() {
        for resolution in both(1e-13) {
            near_a_pole(resolution);
        }
    }

    fn near_a_pole(resolution: Resolution) {
        // 1/(x + 1e-3) on [0, 1]: a pole 1e-3 from the end; ∫ = ln(1001/1) .
        let f = PathIntegral::new(
            Pointwise(|x| 1.0 / (x + 1e-3)),
            &[0.0, 1.0],
            resolution,
            &Lobatto::default(),
        );
        let want = (1.001f64 / 1e-3).ln();
        assert!(
            (f.total() - want).abs() < 1e-11 * want,
            "{}",
            f.total() - want
        );
        let want_half = (0.501f64 / 1e-3).ln();
        assert!(
            (f.at(0.5) - want_half).abs() < 1e-11 * want,
            "{}",
            f.at(0.5) - want_half
        );
    }
}
