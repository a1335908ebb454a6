//! The dwell over the angle as well as the radius, on a part turning on C: the plan's
//! modulation, one radial problem per angular harmonic, and the C speed law that executes it.
//!
//! # The model
//!
//! At station j the pad centre spends the dwell t_j (s) in its cell, as the 1-D plan does, and
//! under a C speed law the time it spends over each part-frame angle φ varies: a density
//!
//! ```text
//! u_j(φ) = (1/2π)·(t_j + Σ_m y^c_jm·cos mφ + y^s_jm·sin mφ)      s per rad
//! ```
//!
//! The footprint ρ(r, α) (`physics::polar`) is even in α = θ − φ, so the removal is a circular
//! convolution in the angle, and harmonic m of the removal at radius r is harmonic m of the
//! density times the footprint's cosine coefficient ĝ_m(r; r1) = (1/2π)∫ρ(r, α)·cos mα dα. The
//! plan is block-circulant: each harmonic is its own radial problem, and at m = 0 it is
//! today's 1-D one (ĝ_0 = R). The time per unit angle is 1/Ω, so modulating the density
//! modulates C's speed: Ω(φ) = Ω0·ū_j/u_j(φ) with Ω0 the process's speed (a turn takes as
//! long as at constant speed). The sliding speed depends on Ω, so the removal is not linear
//! in the modulation; to first order in δ = u/ū − 1 the footprint at the modulated speed is
//! ρ − δ·Ω0·∂ρ/∂Ω, and the modulation acts through the kernel h = ρ − Ω0·∂ρ/∂Ω:
//!
//! ```text
//! E^c_m(r) = Σ_j y^c_jm·G_m(r; j),   G_m(r; j) = σ_j·ĥ_m(r; r_j) + w_j·⟨ĥ_m(r; ρ)⟩_cell j
//! ```
//!
//! (likewise for the sines), with σ_j, w_j the station's stop and move shares
//! (`physics::motion`) and the cell's mean by 3-point Gauss–Legendre. The exact prediction of
//! the executed motion (`physics::polar`) is what the plan is judged by.
//!
//! # Each harmonic's problem
//!
//! For m ≥ 1 the coefficients y_m (one per station, seconds) minimise
//!
//! ```text
//! Σ_i w_i·(G_m·y_m − d_m)_i² + λ·s·r_t⁴/L·Σ_k h_k·(y''_k)² + μ_m·s·Σ_j y_jm²
//! ```
//!
//! over the aperture's radii r_i (w_i ∝ r_i: a ring's share of the area), d_m the target's
//! harmonic, s = trace(GᵀWG)/n the operator's scale, y'' the second divided difference over
//! the stations (L their span), so λ weighs the dwell's curvature over one pad radius as the
//! 1-D optimizer's smoothing does. μ_m = μ·(1 + (m/m_a)²) with m_a = a_max/(δ_max·Ω0²) the
//! harmonic at which C's acceleration limit, not the modulation bound, sets the amplitude
//! (seed 000's eq. 4: a modulation δ of harmonic m asks C for m·δ·Ω0² of acceleration): it
//! spends the modulation where C can follow it.
//!
//! # The speed law
//!
//! C's law is per sector (`physics::SectorLaw`: S equal sectors, centres c_k). A law constant
//! on each sector has the harmonics of the density sampled at the centres times
//! sinc(m·π/S), so the sectors take Y_jk = Σ_m (y^c_jm·cos m·c_k + y^s_jm·sin m·c_k)/sinc(mπ/S)
//! (m < S/2), the time over sector k is t_j·(1 + δ_jk)/S with δ_jk = Y_jk/t_j, and the speed
//! factor is f_jk = 1/(1 + δ_jk).
//!
//! # What the modulation asks of the dwell
//!
//! Each bound on C is a floor on t_j (the 1-D problem's own kind of constraint):
//!
//! - the modulation bound |δ| ≤ δ_max (which keeps C turning and the first-order model
//!   close): t_j ≥ max_k |Y_jk|/δ_max;
//! - C's velocity Ω0/(1 + δ) ≤ v_max: t_j ≥ −min_k Y_jk/(1 − Ω0/v_max);
//! - C's acceleration between sectors as the program's model takes it
//!   ([`crate::physics::motion::acceleration`]): with Ω_k = Ω0/(1 + δ_k) and the sectors
//!   lasting Δ/Ω_k,
//!
//!   ```text
//!   a_k = 2·Ω0²·|Y_{k+1} − Y_k|·t² / (Δ·(t + Y_k)·(t + Y_{k+1})·(2t + Y_k + Y_{k+1}))
//!   ```
//!
//!   which falls as t grows; the least t keeping every a_k ≤ a_max is found by bisection.

use faer::linalg::solvers::Solve;
use faer::Mat;
use rayon::prelude::*;

use super::kinematics::MARGIN;
use super::scaling::second_differences;
use crate::physics::polar::{PolarPad, Track};
use crate::physics::Motion;

/// The smoothing weight λ of each harmonic's problem (module docs), as the 1-D optimizer's
/// default weighs the dwell's curvature.
pub const SMOOTHING: f64 = 0.1;
/// The ridge weight μ (module docs): small enough to leave what the pad can see alone.
pub const RIDGE: f64 = 1e-3;

/// The target's harmonics on a radial grid: for each radius, (a_m, b_m) for m = 0 … m_max
/// with the target T(r, θ) = a_0 + Σ a_m·cos mθ + b_m·sin mθ (b_0 = 0).
#[derive(Debug, Clone, PartialEq)]
pub struct Harmonics {
    pub radii_mm: Vec<f64>,
    pub coefficients: Vec<Vec<(f64, f64)>>,
}

impl Harmonics {
    /// The harmonics of samples taken on rings: `rings[i]` holds N equally spaced values at
    /// θ = 2πk/N on the ring of radius `radii_mm[i]` (N > 2·m_max).
    pub fn of_rings(radii_mm: Vec<f64>, rings: &[Vec<f64>], m_max: usize) -> Harmonics {
        let coefficients = rings
            .iter()
            .map(|ring| {
                let n = ring.len() as f64;
                (0..=m_max)
                    .map(|m| {
                        let (mut a, mut b) = (0.0, 0.0);
                        for (k, v) in ring.iter().enumerate() {
                            let (s, c) = (std::f64::consts::TAU * (m * k) as f64 / n).sin_cos();
                            a += v * c;
                            b += v * s;
                        }
                        if m == 0 {
                            (a / n, 0.0)
                        } else {
                            (2.0 * a / n, 2.0 * b / n)
                        }
                    })
                    .collect()
            })
            .collect();
        Harmonics {
            radii_mm,
            coefficients,
        }
    }

    /// The value at (r_i, θ) of harmonics 1 … m_max alone (what is not round).
    pub fn variant_at(&self, i: usize, theta_rad: f64) -> f64 {
        self.coefficients[i]
            .iter()
            .enumerate()
            .skip(1)
            .map(|(m, (a, b))| {
                let (s, c) = (m as f64 * theta_rad).sin_cos();
                a * c + b * s
            })
            .sum()
    }
}

/// The modulation's operators: G_m (rows: radii, columns: stations) for m = 1 … m_max.
#[derive(Debug, Clone)]
pub struct HarmonicOperator {
    rows: usize,
    columns: usize,
    /// `kernel[m − 1]`: G_m of the modulation kernel ĥ_m, row-major.
    kernel: Vec<Vec<f64>>,
    /// `footprint[m]`: the same of the footprint ρ itself (m = 0 … m_max): what a uniform
    /// modulation of amplitude 1 at every station removes (the harmonic budget's unit).
    footprint: Vec<Vec<f64>>,
}

/// 3-point Gauss–Legendre nodes on [0, 1] and weights (summing to 1).
const CELL_NODES: [(f64, f64); 3] = [
    (0.112_701_665_379_258_3, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

impl HarmonicOperator {
    /// The operators of `motion`'s stations at the radii `radii_mm`, for m up to `m_max`.
    pub fn new(pad: &PolarPad, motion: &Motion, radii_mm: &[f64], m_max: usize) -> Self {
        let n = motion.len();
        let bounds = motion.cell_bounds_mm();
        // Where each station's dwell is spent: (r1, weight), the stop and the cell's nodes.
        let places: Vec<Vec<(f64, f64)>> = (0..n)
            .map(|j| {
                let mut at = vec![(motion.radii_mm()[j], motion.stop_share(j))];
                if motion.move_share(j) > 0.0 {
                    // At constant speed along the surface (a plane's radius, linear).
                    let track = Track::new(pad.surface(), bounds[j], bounds[j + 1], 1.0);
                    at.extend(
                        CELL_NODES
                            .iter()
                            .map(|(x, w)| (track.at(*x), w * motion.move_share(j))),
                    );
                }
                at.retain(|p| p.1 > 0.0);
                at
            })
            .collect();
        // Row by row: each row's columns for every harmonic.
        let rows: Vec<(Vec<f64>, Vec<f64>)> = radii_mm
            .par_iter()
            .map(|&r| {
                let mut kernel = vec![0.0; m_max * n];
                let mut footprint = vec![0.0; (m_max + 1) * n];
                for (j, station) in places.iter().enumerate() {
                    for &(r1, weight) in station {
                        let (rho, h) = pad.angular_spectrum(r, r1, m_max);
                        for m in 0..=m_max {
                            footprint[m * n + j] += weight * rho[m];
                            if m > 0 {
                                kernel[(m - 1) * n + j] += weight * h[m];
                            }
                        }
                    }
                }
                (kernel, footprint)
            })
            .collect();
        let rows_n = radii_mm.len();
        let mut kernel = vec![vec![0.0; rows_n * n]; m_max];
        let mut footprint = vec![vec![0.0; rows_n * n]; m_max + 1];
        for (i, (k, f)) in rows.iter().enumerate() {
            for m in 0..m_max {
                kernel[m][i * n..(i + 1) * n].copy_from_slice(&k[m * n..(m + 1) * n]);
            }
            for m in 0..=m_max {
                footprint[m][i * n..(i + 1) * n].copy_from_slice(&f[m * n..(m + 1) * n]);
            }
        }
        HarmonicOperator {
            rows: rows_n,
            columns: n,
            kernel,
            footprint,
        }
    }

    pub fn m_max(&self) -> usize {
        self.kernel.len()
    }

    /// Σ_j G_m(r_i; j)·y_j of the modulation kernel, m ≥ 1.
    pub fn apply(&self, m: usize, y: &[f64]) -> Vec<f64> {
        let g = &self.kernel[m - 1];
        (0..self.rows)
            .map(|i| {
                g[i * self.columns..(i + 1) * self.columns]
                    .iter()
                    .zip(y)
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect()
    }

    /// Σ_j ĝ_m(r_i; j)·t_j of the footprint: harmonic m's removal per unit of relative
    /// modulation at every station, with the dwell `dwell_s` (m = 0: the 1-D removal).
    pub fn footprint_apply(&self, m: usize, dwell_s: &[f64]) -> Vec<f64> {
        let g = &self.footprint[m];
        (0..self.rows)
            .map(|i| {
                g[i * self.columns..(i + 1) * self.columns]
                    .iter()
                    .zip(dwell_s)
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect()
    }

    /// Each harmonic's coefficients x^c_m, x^s_m (one per station; index m − 1) fitting
    /// `target` (its rows the operator's radii) with the weights `row_weights` (zero outside
    /// the aperture), by the regularised problem of the module docs on the columns scaled by
    /// `column_scale` (y = scale·x: ones to fit y in seconds, the dwell to fit the relative
    /// modulation δ, smooth across the stations). `stations_mm` and
    /// `tool_radius_mm` scale the smoothing; `m_accel` is m_a (∞ without an acceleration limit).
    pub fn fit(
        &self,
        target: &Harmonics,
        row_weights: &[f64],
        column_scale: &[f64],
        stations_mm: &[f64],
        tool_radius_mm: f64,
        m_accel: f64,
    ) -> Vec<(Vec<f64>, Vec<f64>)> {
        let n = self.columns;
        // Row k − 1 of D2 is the second divided difference at station k; it stands for the
        // width (h_{k−1} + h_k)/2.
        let curvature = second_differences(stations_mm);
        let widths: Vec<f64> = stations_mm
            .windows(3)
            .map(|w| 0.5 * (w[2] - w[0]))
            .collect();
        let span = stations_mm.last().unwrap_or(&0.0) - stations_mm.first().unwrap_or(&0.0);
        (1..=self.m_max())
            .into_par_iter()
            .map(|m| {
                let g = &self.kernel[m - 1];
                // Normal equations: GᵀWG, GᵀW·d for the cosines and the sines.
                let weighted = Mat::from_fn(self.rows, n, |i, j| {
                    g[i * n + j] * column_scale[j] * row_weights[i].sqrt()
                });
                let mut normal = weighted.transpose() * &weighted;
                let scale = (0..n).map(|j| normal[(j, j)]).sum::<f64>() / n as f64;
                if scale.is_nan() || scale <= 0.0 {
                    // The pad cannot move this harmonic anywhere: no modulation.
                    return (vec![0.0; n], vec![0.0; n]);
                }
                let mut rhs = Mat::<f64>::zeros(n, 2);
                for i in 0..self.rows {
                    let (a, b) = target.coefficients[i][m];
                    let w = row_weights[i];
                    for j in 0..n {
                        let column = g[i * n + j] * column_scale[j];
                        rhs[(j, 0)] += column * w * a;
                        rhs[(j, 1)] += column * w * b;
                    }
                }
                let lambda =
                    SMOOTHING * scale * tool_radius_mm.powi(4) / span.max(f64::MIN_POSITIVE);
                for (k, (row, h)) in curvature.iter().zip(&widths).enumerate() {
                    for (p, cp) in row.iter().enumerate() {
                        for (q, cq) in row.iter().enumerate() {
                            normal[(k + p, k + q)] += lambda * h * cp * cq;
                        }
                    }
                }
                let ridge = RIDGE * scale * (1.0 + (m as f64 / m_accel).powi(2));
                for j in 0..n {
                    normal[(j, j)] += ridge;
                }
                let solution = match normal.llt(faer::Side::Lower) {
                    Ok(llt) => llt.solve(&rhs),
                    Err(_) => return (vec![0.0; n], vec![0.0; n]),
                };
                (
                    (0..n).map(|j| solution[(j, 0)]).collect(),
                    (0..n).map(|j| solution[(j, 1)]).collect(),
                )
            })
            .collect()
    }
}

/// C's limits as the law must keep them, rad/s and rad/s² (`None`: unlimited).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CLimits {
    pub max_velocity_rad_per_s: Option<f64>,
    pub max_acceleration_rad_per_s2: Option<f64>,
    /// δ_max: the most the time over a sector may differ from its mean, relative (in (0, 1)).
    pub max_modulation: f64,
}

/// Which bound sets a station's floor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LawBound {
    Modulation,
    Velocity,
    Acceleration,
}

/// The modulation at the sectors: Y_jk (s) for each station, from the harmonics' coefficients
/// (module docs, "The speed law").
pub fn sector_modulation(
    coefficients: &[(Vec<f64>, Vec<f64>)],
    stations: usize,
    sectors: usize,
) -> Vec<Vec<f64>> {
    let basis = SectorBasis::new(sectors, coefficients.len());
    (0..stations)
        .map(|j| {
            let station: Vec<(f64, f64)> = coefficients.iter().map(|(c, s)| (c[j], s[j])).collect();
            basis.values(&station)
        })
        .collect()
}

/// A law constant on each of S sectors against its harmonics m = 1 … m_max: cos(m·c_k) and
/// sin(m·c_k) at the sectors' centres c_k, and sinc(mπ/S), tabulated once.
pub struct SectorBasis {
    m_max: usize,
    /// [k·m_max + m − 1].
    cos: Vec<f64>,
    sin: Vec<f64>,
    sinc: Vec<f64>,
}

impl SectorBasis {
    pub fn new(sectors: usize, m_max: usize) -> SectorBasis {
        let width = std::f64::consts::TAU / sectors as f64;
        let (mut cos, mut sin) = (Vec::with_capacity(sectors * m_max), Vec::new());
        for k in 0..sectors {
            for m in 1..=m_max {
                let (sn, cs) = (m as f64 * (k as f64 + 0.5) * width).sin_cos();
                cos.push(cs);
                sin.push(sn);
            }
        }
        let sinc = (1..=m_max)
            .map(|m| {
                let x = m as f64 * width / 2.0;
                x.sin() / x
            })
            .collect();
        SectorBasis {
            m_max,
            cos,
            sin,
            sinc,
        }
    }

    fn sectors(&self) -> usize {
        self.cos.len() / self.m_max.max(1)
    }

    /// The sector values Y_k = Σ_m (c_m·cos m·c_k + s_m·sin m·c_k)/sinc(mπ/S) whose law
    /// carries the harmonics `harmonics` ((c_m, s_m), m = 1 …).
    pub fn values(&self, harmonics: &[(f64, f64)]) -> Vec<f64> {
        let scaled: Vec<(f64, f64)> = harmonics
            .iter()
            .zip(&self.sinc)
            .map(|(&(c, s), sinc)| (c / sinc, s / sinc))
            .collect();
        (0..self.sectors())
            .map(|k| {
                let at = k * self.m_max;
                scaled
                    .iter()
                    .enumerate()
                    .map(|(i, (c, s))| c * self.cos[at + i] + s * self.sin[at + i])
                    .sum()
            })
            .collect()
    }

    /// The harmonics (c_m, s_m), m = 1 … m_max, of the law constant at `values` on each
    /// sector: sinc(mπ/S)·(2/S)·Σ_k Y_k·(cos, sin)(m·c_k) (the inverse of [`Self::values`]
    /// for m < S/2).
    pub fn harmonics(&self, values: &[f64]) -> Vec<(f64, f64)> {
        let mut out = vec![(0.0, 0.0); self.m_max];
        for (k, &y) in values.iter().enumerate() {
            let at = k * self.m_max;
            for (i, h) in out.iter_mut().enumerate() {
                h.0 += y * self.cos[at + i];
                h.1 += y * self.sin[at + i];
            }
        }
        let scale = 2.0 / values.len() as f64;
        for (h, sinc) in out.iter_mut().zip(&self.sinc) {
            h.0 *= scale * sinc;
            h.1 *= scale * sinc;
        }
        out
    }
}

/// The least dwell (s) at which a station's modulation `y` (Y_k at its S sectors) keeps C's
/// `limits` at the process's speed `omega0` (|Ω0|, rad/s), and the bound that sets it; `None`
/// when C's velocity limit is below Ω0 itself (no dwell helps).
pub fn law_floor(y: &[f64], omega0: f64, limits: &CLimits) -> Option<(f64, LawBound)> {
    let largest = y.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    if largest == 0.0 {
        return Some((0.0, LawBound::Modulation));
    }
    let mut floor = (largest / limits.max_modulation, LawBound::Modulation);
    if let Some(v) = limits.max_velocity_rad_per_s {
        let headroom = 1.0 - omega0 / (v * (1.0 - MARGIN));
        if headroom <= 0.0 {
            return None;
        }
        let lowest = y.iter().cloned().fold(0.0_f64, f64::min);
        let t = -lowest / headroom;
        if t > floor.0 {
            floor = (t, LawBound::Velocity);
        }
    }
    if let Some(a) = limits.max_acceleration_rad_per_s2 {
        let a = a * (1.0 - MARGIN);
        let width = std::f64::consts::TAU / y.len() as f64;
        let worst = |t: f64| {
            (0..y.len())
                .map(|k| {
                    let (p, q) = (y[k], y[(k + 1) % y.len()]);
                    2.0 * omega0 * omega0 * (q - p).abs() * t * t
                        / (width * (t + p) * (t + q) * (2.0 * t + p + q))
                })
                .fold(0.0, f64::max)
        };
        if worst(floor.0) > a {
            let (mut lo, mut hi) = (floor.0, 2.0 * floor.0);
            while worst(hi) > a {
                lo = hi;
                hi *= 2.0;
            }
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if worst(mid) > a {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            floor = (hi, LawBound::Acceleration);
        }
    }
    Some(floor)
}

/// The largest share s ∈ [0, 1] of a station's modulation `y` that its dwell `dwell_s` can
/// carry within C's limits: the least floor of s·y ([`law_floor`]) at most the dwell (by
/// bisection; 1 when the whole of it can).
pub fn law_share(y: &[f64], dwell_s: f64, omega0: f64, limits: &CLimits) -> f64 {
    let fits = |s: f64| {
        let scaled: Vec<f64> = y.iter().map(|v| v * s).collect();
        law_floor(&scaled, omega0, limits).is_some_and(|(floor, _)| floor <= dwell_s)
    };
    if fits(1.0) {
        return 1.0;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The speed factors f_jk = 1/(1 + Y_jk/t_j) of the law (1 where a station has no dwell).
pub fn speed_factors(modulation: &[Vec<f64>], dwell_s: &[f64]) -> Vec<Vec<f64>> {
    modulation
        .iter()
        .zip(dwell_s)
        .map(|(y, &t)| {
            y.iter()
                .map(|&v| if t > 0.0 { 1.0 / (1.0 + v / t) } else { 1.0 })
                .collect()
        })
        .collect()
}
