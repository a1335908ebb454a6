//! Adaptive quadrature of a smooth function on an interval: Gauss–Kronrod (7, 15) panels, a
//! panel extended to 31 points before it is halved, and bisection where that is not enough.
//!
//! **A panel.** On [lo, hi] (centre c, half-width h) the 15-point Kronrod rule
//! K₁₅ = h·Σ wᵢ·g(c + h·xᵢ) is exact for polynomials of degree 22, and the 7-point Gauss rule
//! G₇ on every other of its nodes for degree 13. K₁₅ is accepted when QUADPACK's estimate of its
//! error, s·min(1, (200·|K₁₅ − G₇|/s)^1.5) (s = h·Σ wᵢ·|g(xᵢ) − K₁₅/(2h)|, the integrand's
//! variation about its mean), is within the tolerance: density × (hi − lo).
//!
//! **The extension.** That estimate follows G₇'s error, which for an integrand with a complex
//! singularity at Bernstein distance ρ falls like ρ⁻¹⁴ where K₁₅'s falls like ρ⁻²³ or faster;
//! on the curved rates it refuses panels whose K₁₅ is already far inside the tolerance
//! (measured on the sphere benchmark: 32 % of the first panels refused, and every one of those
//! K₁₅ off by less than 1 % of the tolerance against 32 panels' worth). So a refused panel
//! first takes 16 more nodes (Patterson's construction, here for the Kronrod rule): the zeros
//! of the monic π₁₆ with
//!
//! ```text
//! ∫₋₁¹ p₁₅(x)·π₁₆(x)·xᵏ dx = 0,   k = 0 … 15,    p₁₅ = ∏ (x − xᵢ) over K₁₅'s nodes
//! ```
//!
//! which makes the interpolatory rule on all 31 nodes exact for degree 15 + 2·16 − 1 = 46
//! (its zeros are real, inside (−1, 1), between K₁₅'s nodes, and every weight is positive:
//! computed at 100 digits, checked here by its exactness). The 31-point value P₃₁ is accepted
//! when |P₃₁ − K₁₅| is within the tolerance: the difference bounds K₁₅'s error, and P₃₁'s own
//! is far below it. When it is not, the panel is halved, each half a new panel: a refused
//! panel costs 16 more values where its halves would cost 32.
//!
//! **Lanes.** A panel's 15 nodes and its 16 new ones are each evaluated as one array of 16, so
//! that, inlined into a caller compiled for wider registers ([`super::wide`]), g runs on four
//! (AVX2) or eight (AVX-512) nodes at once; the sums run in an order fixed in the code, so every
//! build gives the same bits.

/// Gauss–Kronrod (7, 15) nodes on [−1, 1] (non-negative half) and weights.
const XGK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const WGK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_18,
    0.140_653_259_715_525_92,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_83,
];
/// Gauss 7-point weights at XGK[1], XGK[3], XGK[5], XGK[7].
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// The 16 nodes the 31-point extension adds (non-negative half, outer first) and the
/// 31-point rule's weights at them (module docs).
const X_ADDED: [f64; 8] = [
    0.998_687_109_678_466_7,
    0.975_383_588_208_893_4,
    0.912_204_882_783_262_8,
    0.807_688_939_172_437_6,
    0.667_348_098_104_300_2,
    0.498_636_786_552_832,
    0.308_579_247_910_587_8,
    0.104_528_273_810_780_71,
];
const W_ADDED: [f64; 8] = [
    0.003_634_931_195_049_884,
    0.021_039_446_258_726_797,
    0.042_193_500_584_546_594,
    0.061_821_985_645_449_856,
    0.077_875_347_115_245_99,
    0.090_261_802_146_558_6,
    0.099_196_857_667_432_91,
    0.104_099_955_472_697_36,
];
/// The 31-point rule's weights at the Kronrod nodes (XGK's order).
const W_KEPT: [f64; 8] = [
    0.011_319_468_444_683_435,
    0.031_577_706_217_045_86,
    0.052_384_370_820_982_69,
    0.070_332_046_410_400_65,
    0.084_498_765_301_243_02,
    0.095_178_029_931_830_68,
    0.102_214_180_005_702_75,
    0.104_743_213_564_805_84,
];

/// Values at a rule's nodes' non-negative half (outer first) in a panel's lane order: node k
/// in lanes k (below the centre, times `below`) and `mirror` − k (above it). The Kronrod nodes
/// (the centre last, `mirror` 14) leave a 16th lane of 0, so a panel is four AVX2 registers
/// (that lane's node is the centre again, with weight 0); the added nodes fill all 16
/// (`mirror` 15).
const fn lanes(half: [f64; 8], below: f64, mirror: usize) -> [f64; 16] {
    let mut out = [0.0; 16];
    let mut k = 0;
    while k < 8 {
        out[k] = below * half[k];
        out[mirror - k] = half[k];
        k += 1;
    }
    out
}
/// The 15 Kronrod nodes on [−1, 1] in lane order, and their Kronrod and Gauss weights (zero
/// where the Gauss rule has no node), and the 31-point rule's weights at them.
const NODES: [f64; 16] = lanes(XGK, -1.0, 14);
const KRONROD: [f64; 16] = lanes(WGK, 1.0, 14);
const GAUSS: [f64; 16] = lanes([0.0, WG[0], 0.0, WG[1], 0.0, WG[2], 0.0, WG[3]], 1.0, 14);
const KEPT: [f64; 16] = lanes(W_KEPT, 1.0, 14);
/// The 16 added nodes on [−1, 1] in lane order, and the 31-point rule's weights at them.
const ADDED: [f64; 16] = lanes(X_ADDED, -1.0, 15);
const ADDED_WEIGHTS: [f64; 16] = lanes(W_ADDED, 1.0, 15);

/// g at `centre` + `half`·node for the 16 nodes, as one array (module docs: lanes).
#[inline(always)]
fn values_at<G: Fn(f64) -> f64>(g: &G, centre: f64, half: f64, nodes: &[f64; 16]) -> [f64; 16] {
    let mut values = [0.0; 16];
    for (value, node) in values.iter_mut().zip(nodes) {
        *value = g(centre + half * node);
    }
    values
}

/// One panel of ∫ g over [lo, hi]: the Kronrod value and what QUADPACK's error estimate needs.
#[inline(always)]
fn gk15<G: Fn(f64) -> f64>(g: &G, lo: f64, hi: f64) -> Panel {
    let centre = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    let values = values_at(g, centre, half, &NODES);
    let kronrod = lane_sum(|i| KRONROD[i] * values[i]);
    let gauss = lane_sum(|i| GAUSS[i] * values[i]);
    // QUADPACK's estimate: |K − G| scaled by the integrand's variation about its mean, which
    // is far less pessimistic than |K − G| itself for smooth integrands.
    let mean = 0.5 * kronrod;
    let spread = lane_sum(|i| KRONROD[i] * (values[i] - mean).abs()) * half.abs();
    Panel {
        centre,
        half,
        values,
        value: kronrod * half,
        difference: ((kronrod - gauss) * half).abs(),
        spread,
    }
}

/// A Kronrod panel: where it is, its values at the nodes (lane order), its value, |K − G| and
/// the integrand's variation about its mean (QUADPACK's `resasc`), the last three times the
/// half-width.
struct Panel {
    centre: f64,
    half: f64,
    values: [f64; 16],
    value: f64,
    difference: f64,
    spread: f64,
}

impl Panel {
    /// The 31-point value P₃₁ of the panel (module docs): its 15 values and g at the 16 nodes
    /// the extension adds.
    #[inline(always)]
    fn extended<G: Fn(f64) -> f64>(&self, g: &G) -> f64 {
        let added = values_at(g, self.centre, self.half, &ADDED);
        let kept = lane_sum(|i| KEPT[i] * self.values[i]);
        let new = lane_sum(|i| ADDED_WEIGHTS[i] * added[i]);
        (kept + new) * self.half
    }

    /// Whether QUADPACK's error estimate, s·min(1, (200·d/s)^1.5) (d = |K − G|, s the spread;
    /// d itself when either is zero), is within `tolerance`. Decided without the power: for
    /// 200·d < s, s·(200·d/s)^1.5 ≤ t ⟺ (200·d)³ ≤ t²·s (both sides squared, times s), which
    /// leaves a panel no square root or division on its critical path.
    fn within(&self, tolerance: f64) -> bool {
        let (d, s) = (self.difference, self.spread);
        if s > 0.0 && d > 0.0 {
            let scaled = 200.0 * d;
            if scaled >= s {
                s <= tolerance
            } else {
                scaled * scaled * scaled <= tolerance * tolerance * s
            }
        } else {
            d <= tolerance
        }
    }
}

/// Σ term(i) over the 16 lanes, summed as four lanes of four (an order fixed in the code, so
/// the wide and the narrow build agree to the bit).
#[inline(always)]
fn lane_sum(term: impl Fn(usize) -> f64) -> f64 {
    let mut lanes = [0.0; 4];
    for row in 0..4 {
        for (lane, sum) in lanes.iter_mut().enumerate() {
            *sum += term(4 * row + lane);
        }
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
}

/// Most panels one integral may be split into (each a 15-point rule, perhaps extended); far
/// more than any integrand here needs.
const MAX_PANELS: usize = 2000;
/// Deepest bisection: a panel 2⁻⁶⁰ of the interval is taken as it is (far below any
/// tolerance; it also bounds the stack of pending panels, kept on the call's own stack).
const MAX_DEPTH: usize = 60;

/// The 15-point Kronrod rule on [`lo`, `hi`]: (node, weight) pairs (16 lanes, one of weight 0),
/// exact for polynomials of degree 22. For integrands that many functions share (a footprint's
/// Fourier coefficients), where one set of nodes must serve them all.
pub(super) fn kronrod_rule(lo: f64, hi: f64) -> impl Iterator<Item = (f64, f64)> {
    let (centre, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    NODES
        .iter()
        .zip(KRONROD)
        .map(move |(x, w)| (centre + half * x, half * w))
}

/// ∫ g over [`a`, `b`] by adaptive bisection of Gauss–Kronrod (7, 15) panels (module docs):
/// a panel's K₁₅ is accepted when QUADPACK's error estimate is within `density` times its
/// width, else its 31-point value when that differs from K₁₅ by no more, or either at the
/// deepest bisection or when the panel can no longer be split in floating point.
#[inline(always)]
pub(crate) fn adaptive_gauss_kronrod<G: Fn(f64) -> f64>(
    g: &G,
    a: f64,
    b: f64,
    density: f64,
) -> f64 {
    // Depth first: at most one pending panel per depth, plus the one being split.
    let mut stack = [(0.0, 0.0, 0); MAX_DEPTH + 2];
    stack[0] = (a, b, 0);
    let mut pending = 1;
    let mut total = 0.0;
    let mut panels = 0;
    while pending > 0 {
        pending -= 1;
        let (lo, hi, depth) = stack[pending];
        if hi <= lo {
            continue;
        }
        panels += 1;
        let panel = gk15(g, lo, hi);
        let tolerance = density * (hi - lo);
        if panel.within(tolerance) {
            total += panel.value;
            continue;
        }
        let extended = panel.extended(g);
        let mid = 0.5 * (lo + hi);
        if (extended - panel.value).abs() <= tolerance
            || mid <= lo
            || mid >= hi
            || panels >= MAX_PANELS
            || depth >= MAX_DEPTH
        {
            total += extended;
        } else {
            stack[pending] = (mid, hi, depth + 1);
            stack[pending + 1] = (lo, mid, depth + 1);
            pending += 2;
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Σ w·P_d(x) over a rule's nodes (lane order, both halves) against ∫₋₁¹ P_d dx (2 for
    /// d = 0, else 0), P_d Legendre's polynomial (by its recurrence; |P_d| ≤ 1 on [−1, 1], so
    /// the sums are well conditioned): the worst error over degrees `degrees`.
    fn worst_moment(
        rule: &[([f64; 16], [f64; 16])],
        degrees: std::ops::RangeInclusive<usize>,
    ) -> f64 {
        let legendre = |d: usize, x: f64| {
            let (mut previous, mut current) = (1.0, x);
            if d == 0 {
                return 1.0;
            }
            for n in 1..d {
                let next =
                    ((2 * n + 1) as f64 * x * current - n as f64 * previous) / (n + 1) as f64;
                (previous, current) = (current, next);
            }
            current
        };
        degrees
            .map(|d| {
                let sum: f64 = rule
                    .iter()
                    .flat_map(|(nodes, weights)| nodes.iter().zip(weights))
                    .map(|(&x, w)| w * legendre(d, x))
                    .sum();
                let exact = if d == 0 { 2.0 } else { 0.0 };
                (sum - exact).abs()
            })
            .fold(0.0, f64::max)
    }

    /// The rules' constants: G₇ exact to degree 13, K₁₅ to 22 and the 31-point extension to 46
    /// (to rounding: sums of 31 terms of at most a weight each, so 1e-15; a constant wrong in
    /// its 16th digit shows at 1e-16 to 1e-15), and none of them at the next even degree (an
    /// error of 1e-4 or more).
    #[test]
    fn the_rules_are_exact_to_their_degrees() {
        let gauss = [(NODES, GAUSS)];
        let kronrod = [(NODES, KRONROD)];
        let extended = [(NODES, KEPT), (ADDED, ADDED_WEIGHTS)];
        for (rule, degree) in [(&gauss[..], 13), (&kronrod[..], 22), (&extended[..], 46)] {
            let exact = worst_moment(rule, 0..=degree);
            assert!(exact < 1e-15, "degree {degree}: {exact:e}");
            let next_even = degree + 2 - degree % 2;
            let beyond = worst_moment(rule, next_even..=next_even);
            assert!(beyond > 1e-5, "degree {next_even}: {beyond:e}");
        }
        // The weights sum to the interval's length, and the added nodes are new and inside.
        let total: f64 = KEPT.iter().chain(&ADDED_WEIGHTS).sum();
        assert!((total - 2.0).abs() < 1e-15, "{total}");
        for x in ADDED {
            assert!(
                x.abs() < 1.0 && NODES.iter().all(|k| (k - x).abs() > 1e-3),
                "{x}"
            );
        }
    }

    #[test]
    fn gauss_kronrod_is_exact_for_polynomials_and_adapts_to_kinks() {
        // K15 integrates degree 22 exactly.
        let p = |x: f64| 3.0 * x.powi(22) - x.powi(7) + 2.0;
        let exact = 3.0 / 23.0 * 2f64.powi(23) - 2f64.powi(8) / 8.0 + 4.0;
        let got = adaptive_gauss_kronrod(&p, 0.0, 2.0, 1e-12 / 2.0);
        assert!((got - exact).abs() < 1e-12 * exact, "{got} vs {exact}");
        // A kink inside: ∫₀³ |x − 1| dx = ½ + 2.
        let got = adaptive_gauss_kronrod(&|x: f64| (x - 1.0).abs(), 0.0, 3.0, 1e-13 / 3.0);
        assert!((got - 2.5).abs() < 1e-12, "{got}");
    }

    /// Where QUADPACK's estimate refuses a panel whose K₁₅ is already good, the 31-point value
    /// is taken and the panel not halved: ∫₀¹ 1/(1 + 4x²) dx = atan(2)/2 (poles at ±i/2) to
    /// 1e-11 in 32 values (the 16 lanes of the panel and the 16 added), where its halves would
    /// take 48 more.
    #[test]
    fn a_refused_panel_is_extended_before_it_is_halved() {
        let calls = std::cell::Cell::new(0);
        let runge = |x: f64| {
            calls.set(calls.get() + 1);
            1.0 / (1.0 + 4.0 * x * x)
        };
        let exact = 2f64.atan() / 2.0;
        let got = adaptive_gauss_kronrod(&runge, 0.0, 1.0, 1e-11);
        assert!((got - exact).abs() < 1e-11, "{got} vs {exact}");
        assert_eq!(calls.get(), 32, "values taken");
    }
}
