//! Carlson's symmetric elliptic integrals R_F and R_D, evaluated together.
//!
//! ```text
//! R_F(x, y, z) = ½ ∫₀^∞ dt / √((t+x)(t+y)(t+z))
//! R_D(x, y, z) = 3/2 ∫₀^∞ dt / (√((t+x)(t+y)) (t+z)^{3/2})
//! ```
//!
//! Both are computed by Carlson's duplication theorem (B. C. Carlson, "Numerical computation of
//! real or complex elliptic integrals", Numer. Algorithms 10, 1995; DLMF §19.36(i)): each step
//! replaces (x, y, z) by ((x+λ)/4, (y+λ)/4, (z+λ)/4) with λ = √x√y + √x√z + √y√z, which leaves
//! R_F unchanged and moves R_D by a known term, until the arguments agree closely enough that a
//! fifth-order Taylor series about their mean is exact to the requested tolerance. R_F and R_D
//! share the duplication sequence, so one loop yields both: the removal function always needs
//! the pair at the same arguments.
//!
//! Preconditions (debug-asserted): x, y, z ≥ 0, at most one of x, y zero, z > 0. Every term is
//! positive, so the result is accurate to a few ulps; the iteration count grows like
//! log₄(max/min) of the arguments, which stays small for the arguments the removal function uses.

use crate::wide::lanes;

/// Relative tolerance handed to Carlson's stopping rule; gives results within a few ulps.
const TOLERANCE: f64 = 1.0e-16;

/// How many argument triples [`rf_rd_many`] takes through the duplication side by side.
pub const LANES: usize = 8;

/// `(R_F(x, y, z), R_D(x, y, z))`.
pub fn rf_rd(x: f64, y: f64, z: f64) -> (f64, f64) {
    let (rf, rd) = rf_rd_lanes([x], [y], [z]);
    (rf[0], rd[0])
}

/// [`rf_rd`] of every triple `(x[k], y[k], z[k])` into `rf[k]`, `rd[k]`, bit for bit, [`LANES`]
/// triples at a time: their duplication steps run side by side (in vector registers where the
/// CPU has them), each lane frozen once its own stopping rule holds, so a lane's result does
/// not depend on its neighbours.
pub fn rf_rd_many(x: &[f64], y: &[f64], z: &[f64], rf: &mut [f64], rd: &mut [f64]) {
    let n = x.len();
    assert!(y.len() == n && z.len() == n && rf.len() == n && rd.len() == n);
    crate::wide::widest(Chunks { x, y, z, rf, rd });
}

/// [`rf_rd_many`]'s work, for [`crate::wide::widest`].
struct Chunks<'a> {
    x: &'a [f64],
    y: &'a [f64],
    z: &'a [f64],
    rf: &'a mut [f64],
    rd: &'a mut [f64],
}

impl crate::wide::Wide for Chunks<'_> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        rf_rd_chunks(self.x, self.y, self.z, self.rf, self.rd);
    }
}

#[inline(always)]
fn rf_rd_chunks(x: &[f64], y: &[f64], z: &[f64], rf: &mut [f64], rd: &mut [f64]) {
    let mut k = 0;
    while k < x.len() {
        let m = LANES.min(x.len() - k);
        if m == 1 {
            // A lone triple (a single rate's) costs less alone than in a padded chunk.
            let (f, d) = rf_rd_lanes([x[k]], [y[k]], [z[k]]);
            (rf[k], rd[k]) = (f[0], d[0]);
            break;
        }
        // A short last chunk is padded with R(1, 1, 1), which converges at once.
        let lane = |v: &[f64], l: usize| if l < m { v[k + l] } else { 1.0 };
        let (f, d) = rf_rd_lanes::<LANES>(
            lanes(|l| lane(x, l)),
            lanes(|l| lane(y, l)),
            lanes(|l| lane(z, l)),
        );
        rf[k..k + m].copy_from_slice(&f[..m]);
        rd[k..k + m].copy_from_slice(&d[..m]);
        k += m;
    }
}

/// The duplication and the series for `L` triples; every lane runs exactly the operations
/// of a lone evaluation.
#[inline(always)]
fn rf_rd_lanes<const L: usize>(x: [f64; L], y: [f64; L], z: [f64; L]) -> ([f64; L], [f64; L]) {
    for l in 0..L {
        debug_assert!(
            x[l] >= 0.0 && y[l] >= 0.0 && z[l] > 0.0,
            "rf_rd({}, {}, {})",
            x[l],
            y[l],
            z[l]
        );
        debug_assert!(x[l] + y[l] > 0.0, "rf_rd: at most one of x, y may be zero");
    }
    let spread = |a: f64, l: usize| (a - x[l]).abs().max((a - y[l]).abs()).max((a - z[l]).abs());
    let a0_f: [f64; L] = lanes(|l| (x[l] + y[l] + z[l]) * (1.0 / 3.0));
    let a0_d: [f64; L] = lanes(|l| (x[l] + y[l] + 3.0 * z[l]) * (1.0 / 5.0));
    // Carlson's Q for each function: once 4^-n Q < |A_n| the series is exact to TOLERANCE
    // (4^-n Q is pow4·Q exactly: both are scaled by powers of two).
    let q_f: [f64; L] = lanes(|l| spread(a0_f[l], l) * (3.0 * TOLERANCE).powf(-1.0 / 6.0));
    let q_d: [f64; L] = lanes(|l| spread(a0_d[l], l) * (0.25 * TOLERANCE).powf(-1.0 / 6.0));

    let (mut xn, mut yn, mut zn) = (x, y, z);
    let (mut a_f, mut a_d) = (a0_f, a0_d);
    let mut pow4 = [1.0; L]; // 4^-n
    let mut rd_sum = [0.0; L];
    // Each lane's state is replaced by a bitwise select on its mask (all ones while the lane
    // is running), and the stopping rule is tested with `|`, not `||`: written with `if` and
    // `||`, the compiler made masked stores and a branch per lane, stalling every step.
    let going = |pow4: &[f64; L], a_f: &[f64; L], a_d: &[f64; L], l: usize| {
        let go = (pow4[l] * q_f[l] >= a_f[l].abs()) | (pow4[l] * q_d[l] >= a_d[l].abs());
        (go as u64).wrapping_neg()
    };
    let mut running: [u64; L] = lanes(|l| going(&pow4, &a_f, &a_d, l));
    while running.iter().fold(0, |any, &m| any | m) != 0 {
        for l in 0..L {
            let (sx, sy, sz) = (xn[l].sqrt(), yn[l].sqrt(), zn[l].sqrt());
            let lambda = sx * sy + sx * sz + sy * sz;
            let on = running[l];
            let pick =
                |new: f64, old: f64| f64::from_bits((new.to_bits() & on) | (old.to_bits() & !on));
            rd_sum[l] = pick(rd_sum[l] + pow4[l] / (sz * (zn[l] + lambda)), rd_sum[l]);
            pow4[l] = pick(pow4[l] * 0.25, pow4[l]);
            xn[l] = pick(0.25 * (xn[l] + lambda), xn[l]);
            yn[l] = pick(0.25 * (yn[l] + lambda), yn[l]);
            zn[l] = pick(0.25 * (zn[l] + lambda), zn[l]);
            a_f[l] = pick(0.25 * (a_f[l] + lambda), a_f[l]);
            a_d[l] = pick(0.25 * (a_d[l] + lambda), a_d[l]);
        }
        for (l, on) in running.iter_mut().enumerate() {
            *on &= going(&pow4, &a_f, &a_d, l);
        }
    }

    // Each series divides once: with t = 1/(A·√A), 1/A = t·√A and 1/√A = t·A; its constants
    // are multiplied as reciprocals.
    let rf = lanes(|l| {
        let root = a_f[l].sqrt();
        let t = 1.0 / (a_f[l] * root);
        let scale = pow4[l] * (t * root);
        let xs = (a0_f[l] - x[l]) * scale;
        let ys = (a0_f[l] - y[l]) * scale;
        let zs = -(xs + ys);
        let e2 = xs * ys - zs * zs;
        let e3 = xs * ys * zs;
        let series = 1.0 - e2 * (1.0 / 10.0) + e3 * (1.0 / 14.0) + e2 * e2 * (1.0 / 24.0)
            - e2 * e3 * (3.0 / 44.0);
        series * (t * a_f[l])
    });
    let rd = lanes(|l| {
        let root = a_d[l].sqrt();
        let t = 1.0 / (a_d[l] * root);
        let scale = pow4[l] * (t * root);
        let xs = (a0_d[l] - x[l]) * scale;
        let ys = (a0_d[l] - y[l]) * scale;
        let zs = -(xs + ys) * (1.0 / 3.0);
        let xy = xs * ys;
        let z2 = zs * zs;
        let e2 = xy - 6.0 * z2;
        let e3 = (3.0 * xy - 8.0 * z2) * zs;
        let e4 = 3.0 * (xy - z2) * z2;
        let e5 = xy * z2 * zs;
        let series = 1.0 - e2 * (3.0 / 14.0) + e3 * (1.0 / 6.0) + e2 * e2 * (9.0 / 88.0)
            - e4 * (3.0 / 22.0)
            - e2 * e3 * (9.0 / 52.0)
            + e5 * (3.0 / 26.0);
        pow4[l] * series * t + 3.0 * rd_sum[l]
    });
    (rf, rd)
}

#[cfg(test)]
mod tests {
    use super::rf_rd;

    /// Identities below hold exactly, so only rounding separates the two sides.
    fn close(got: f64, want: f64) {
        close_to(got, want, 4e-15);
    }

    fn close_to(got: f64, want: f64, rel: f64) {
        assert!(
            (got - want).abs() <= rel * want.abs(),
            "got {got:e}, want {want:e}"
        );
    }

    /// Carlson's published check values (Numer. Algorithms 10, 1995, §3), given there to 14
    /// significant digits, hence the 1e-13 tolerance.
    #[test]
    fn matches_carlsons_check_values() {
        close_to(rf_rd(1.0, 2.0, 0.5).0, rf_rd(0.5, 1.0, 2.0).0, 4e-15); // symmetry
        close_to(rf_rd(0.0, 1.0, 2.0).0, 1.311_028_777_146_1, 1e-13);
        close_to(rf_rd(2.0, 3.0, 4.0).0, 0.584_082_841_677_15, 1e-13);
        close_to(rf_rd(0.0, 2.0, 1.0).1, 1.797_210_352_103_4, 1e-13);
        close_to(rf_rd(2.0, 3.0, 4.0).1, 0.165_105_272_942_61, 1e-13);
    }

    /// Exact identities: R_F(x,x,x) = x^-1/2, R_D(x,x,x) = x^-3/2, and
    /// R_F(0, 1, 1) = π/2 (the complete integral K(0)).
    #[test]
    fn satisfies_exact_identities() {
        for x in [1e-8, 0.3, 1.0, 7.5, 1e9] {
            let (rf, rd) = rf_rd(x, x, x);
            close(rf, 1.0 / x.sqrt());
            close(rd, 1.0 / (x * x.sqrt()));
        }
        close(rf_rd(0.0, 1.0, 1.0).0, std::f64::consts::FRAC_PI_2);
        // R_D(0, 1, 1) = 3π/4 (DLMF 19.20.4 with K(0) = E(0) = π/2).
        close(rf_rd(0.0, 1.0, 1.0).1, 0.75 * std::f64::consts::PI);
    }

    /// Many triples at once give what each gives alone, bit for bit, whatever their
    /// neighbours (triples needing from none to many duplication steps share chunks, and a
    /// short last chunk is padded).
    #[test]
    fn many_at_once_is_each_alone() {
        use super::rf_rd_many;
        let mut args = Vec::new();
        for k in 0..45 {
            let t = k as f64;
            args.push((
                (t * 0.37).sin().abs() * 10f64.powi(k % 9 - 4),
                1.0 + t,
                0.5 + (t * 0.11).cos().abs() * 10f64.powi(-(k % 5)),
            ));
        }
        args.push((0.0, 2.0, 1.0));
        args.push((3.0, 3.0, 3.0));
        let (x, y, z): (Vec<f64>, Vec<f64>, Vec<f64>) = (
            args.iter().map(|a| a.0).collect(),
            args.iter().map(|a| a.1).collect(),
            args.iter().map(|a| a.2).collect(),
        );
        let (mut rf, mut rd) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        rf_rd_many(&x, &y, &z, &mut rf, &mut rd);
        for k in 0..x.len() {
            let (f, d) = rf_rd(x[k], y[k], z[k]);
            assert_eq!(
                (rf[k].to_bits(), rd[k].to_bits()),
                (f.to_bits(), d.to_bits()),
                "{k}"
            );
        }
    }

    /// Homogeneity: R_F(λ·) = λ^-1/2 R_F(·), R_D(λ·) = λ^-3/2 R_D(·).
    #[test]
    fn is_homogeneous() {
        let (rf, rd) = rf_rd(0.2, 1.7, 3.1);
        for lambda in [1e-6, 0.5, 4.0, 1e6] {
            let (rf2, rd2) = rf_rd(0.2 * lambda, 1.7 * lambda, 3.1 * lambda);
            close(rf2, rf / lambda.sqrt());
            close(rd2, rd / (lambda * lambda.sqrt()));
        }
    }
}
