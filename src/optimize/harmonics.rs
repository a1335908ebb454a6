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
//! the stations (L their span), so λ weighs the modulation's curvature over one pad radius.
//! μ_m = μ·(1 + (m/m_a)²) with m_a = a_max/(δ_max·Ω0²) the harmonic at which C's
//! acceleration limit, not the modulation bound, sets the amplitude (the servo rule: a
//! modulation δ of harmonic m asks C for m·δ·Ω0² of acceleration). Fitted relative to a
//! dwell t (y_jm = t_j·x_jm), the problem is the same in x with G's columns scaled by t.
//!
//! # Within C's law
//!
//! One law carries every harmonic, so what C allows bounds their sum, not each alone. Relative
//! to the dwell, the sector values are δ_k = Σ_m ‖x_m‖/sinc(mπ/S)·cos(m·c_k − φ_m), so
//! |δ_k| ≤ Σ_m ‖x_m‖/sinc(mπ/S), and from one sector to the next δ changes by at most
//! Σ_m m·Δ·‖x_m‖ (Δ = 2π/S; the sinc cancels against the difference's 2·sin(mΔ/2)). So at
//! every station
//!
//! ```text
//! Σ_m c_m·‖x_jm‖ ≤ 1,   c_m = max(1/(δ·sinc(mπ/S)), m/A)
//! ```
//!
//! keeps the law within |δ_k| ≤ δ = min(δ_max, 1 − Ω0/v_max) (C's velocity Ω0/(1 + δ_k) ≤
//! v_max on the fast side) and, to first order in δ, C's acceleration between sectors,
//! a_k ≈ Ω0²·|δ_{k+1} − δ_k|/Δ ≤ a_max, with A = a_max/Ω0². (Exactly, a_k carries a factor up
//! to 1/(1 − δ)³ (see "What the modulation asks of the dwell"): bounding that everywhere would
//! forbid most of what a large δ_max allows, so the exact limit is checked on the executed
//! motion and a station's modulation scaled down where it breaks, as `usecases::map_optimize`
//! does.) The bound is sufficient, not necessary (the harmonics' peaks seldom meet), and
//! convex: a weighted ℓ1 norm of the harmonics' amplitudes, the
//! group lasso's ball. `UnboundedFit::within` solves the harmonics' problems under it together by ADMM
//! (Boyd et al. 2011): each harmonic's normal matrix, shifted by the penalty ρ, factored once
//! per ρ (ρ balanced in the first half of the iterations, then fixed), the bound's projection
//! per station in closed form (the
//! amplitudes shrunk by τ·c_m, τ from the sorted ratios a_m/c_m, as Duchi et al. project on
//! the ℓ1 ball), ρ balanced between the primal and dual residuals. The answer is the
//! projected iterate, so the bound holds exactly. The bound is what lets the smoothing be light:
//! on prysm's sample (46 mm aperture, by the plan's model) the fit scaled down afterwards to
//! C's limits left 11.2 nm of what is not round at λ = 0.1 and 14.0 at 1e-3 (a rough fit
//! scaled station by station loses the balance between neighbours it relied on); the fit
//! within the bound leaves 10.0 at 0.1 and 9.5 at 1e-3 (inside the edge roll, 36 mm: 3.2 at
//! 0.1 either way, 1.9 within the bound at 1e-3).
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

/// The smoothing weight λ of each harmonic's problem (module docs): light, for the bound keeps
/// the law within C's limits; it keeps the modulation from jumping between neighbouring
/// stations only where the target leaves it free (module docs, "Within C's law", for what 0.1
/// cost).
pub const SMOOTHING: f64 = 1e-3;
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
        // sin and cos of 2π·i/N, tabulated once for each ring length N (mk is read mod N).
        let mut table: (usize, Vec<(f64, f64)>) = (0, Vec::new());
        let coefficients = rings
            .iter()
            .map(|ring| {
                let len = ring.len();
                if table.0 != len {
                    table = (
                        len,
                        (0..len)
                            .map(|i| (std::f64::consts::TAU * i as f64 / len as f64).sin_cos())
                            .collect(),
                    );
                }
                let n = len as f64;
                (0..=m_max)
                    .map(|m| {
                        let (mut a, mut b) = (0.0, 0.0);
                        for (k, v) in ring.iter().enumerate() {
                            let (s, c) = table.1[(m * k) % len];
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

    /// Harmonic m's regularised normal equations (module docs), on the columns scaled by
    /// `column_scale`: (N, [Gᵀ·W·a_m, Gᵀ·W·b_m]) and N's scale s (the mean diagonal of GᵀWG,
    /// before the smoothing and the ridge); `None` where the pad cannot move the harmonic.
    fn normal_equations(
        &self,
        m: usize,
        fit: &HarmonicFit,
        column_scale: &[f64],
    ) -> Option<NormalEquations> {
        let n = self.columns;
        let (plain, plain_rhs) = &fit.normals[m - 1];
        let mut normal = Mat::from_fn(n, n, |i, j| {
            plain[(i, j)] * column_scale[i] * column_scale[j]
        });
        let scale = (0..n).map(|j| normal[(j, j)]).sum::<f64>() / n as f64;
        if scale.is_nan() || scale <= 0.0 {
            return None;
        }
        let rhs = Mat::from_fn(n, 2, |j, k| plain_rhs[(j, k)] * column_scale[j]);
        // Row k − 1 of D2 is the second divided difference at station k; it stands for the
        // width (h_{k−1} + h_k)/2.
        let stations = fit.stations_mm;
        let span = stations.last().unwrap_or(&0.0) - stations.first().unwrap_or(&0.0);
        let lambda = SMOOTHING * scale * fit.tool_radius_mm.powi(4) / span.max(f64::MIN_POSITIVE);
        for (k, (row, w)) in second_differences(stations)
            .iter()
            .zip(stations.windows(3))
            .enumerate()
        {
            let h = 0.5 * (w[2] - w[0]);
            for (p, cp) in row.iter().enumerate() {
                for (q, cq) in row.iter().enumerate() {
                    normal[(k + p, k + q)] += lambda * h * cp * cq;
                }
            }
        }
        let ridge = RIDGE * scale * (1.0 + (m as f64 / fit.m_accel).powi(2));
        for j in 0..n {
            normal[(j, j)] += ridge;
        }
        Some((normal, rhs, scale))
    }

    /// A fit of `target` with these weights and regularisation: each harmonic's GᵀWG and
    /// GᵀW·[a_m, b_m] made once, for fits on any column scaling.
    pub fn fit_setup<'a>(
        &self,
        target: &Harmonics,
        row_weights: &[f64],
        stations_mm: &'a [f64],
        tool_radius_mm: f64,
        m_accel: f64,
    ) -> HarmonicFit<'a> {
        let n = self.columns;
        let normals = (1..=self.m_max())
            .into_par_iter()
            .map(|m| {
                let g = &self.kernel[m - 1];
                let weighted =
                    Mat::from_fn(self.rows, n, |i, j| g[i * n + j] * row_weights[i].sqrt());
                let normal = weighted.transpose() * &weighted;
                let mut rhs = Mat::<f64>::zeros(n, 2);
                for i in 0..self.rows {
                    let (a, b) = target.coefficients[i][m];
                    let w = row_weights[i];
                    for j in 0..n {
                        rhs[(j, 0)] += g[i * n + j] * w * a;
                        rhs[(j, 1)] += g[i * n + j] * w * b;
                    }
                }
                (normal, rhs)
            })
            .collect();
        HarmonicFit {
            stations_mm,
            tool_radius_mm,
            m_accel,
            normals,
        }
    }

    /// Each harmonic's coefficients x^c_m, x^s_m (one per station; index m − 1) fitting the
    /// target by the regularised problem of the module docs, unbounded, on the columns scaled by
    /// `column_scale` (y = scale·x: ones to fit y in seconds, the dwell to fit the relative
    /// modulation δ, smooth across the stations). It keeps its normal equations, factored, for
    /// the same problem within a bound ([`UnboundedFit::within`]).
    pub fn fit(&self, fit: &HarmonicFit, column_scale: &[f64]) -> UnboundedFit {
        let n = self.columns;
        let solved: Vec<_> = (1..=self.m_max())
            .into_par_iter()
            .map(|m| {
                // None where the pad cannot move the harmonic (or, never seen, N is not
                // positive definite): no modulation.
                let solved =
                    self.normal_equations(m, fit, column_scale)
                        .and_then(|(normal, rhs, scale)| {
                            let x = normal.llt(faer::Side::Lower).ok()?.solve(&rhs);
                            Some((normal, rhs, scale, x))
                        });
                match solved {
                    Some((normal, rhs, scale, x)) => (
                        Some(Scaled {
                            normal: normal * (1.0 / scale),
                            rhs: rhs * (1.0 / scale.sqrt()),
                            root_scale: scale.sqrt(),
                        }),
                        (
                            (0..n).map(|j| x[(j, 0)]).collect(),
                            (0..n).map(|j| x[(j, 1)]).collect(),
                        ),
                    ),
                    None => (None, (vec![0.0; n], vec![0.0; n])),
                }
            })
            .collect();
        let (systems, coefficients) = solved.into_iter().unzip();
        UnboundedFit {
            columns: n,
            systems,
            coefficients,
        }
    }
}

/// A fit without the bound ([`HarmonicOperator::fit`]): its coefficients, and each harmonic's
/// normal equations in the variables ξ = √s·x, whose normal matrix N/s has unit mean diagonal
/// (one ADMM penalty suits them all).
pub struct UnboundedFit {
    columns: usize,
    /// Per harmonic, N/s, b/√s and √s; none where the pad cannot move the harmonic.
    systems: Vec<Option<Scaled>>,
    coefficients: Vec<(Vec<f64>, Vec<f64>)>,
}

impl UnboundedFit {
    /// Each harmonic's coefficients (index m − 1): cosines and sines, one per station.
    pub fn coefficients(&self) -> &[(Vec<f64>, Vec<f64>)] {
        &self.coefficients
    }

    /// The bound in ξ: Σ_m (c_m/√s_m)·‖ξ_jm‖ ≤ 1 (a harmonic the pad cannot move is 0).
    fn weights(&self, bound: &ModulationBound) -> Vec<f64> {
        self.systems
            .iter()
            .zip(&bound.weights)
            .map(|(system, c)| system.as_ref().map_or(f64::INFINITY, |e| c / e.root_scale))
            .collect()
    }

    /// The coefficients in ξ, per harmonic the n cosines then the n sines.
    fn in_scaled(&self) -> Vec<Vec<f64>> {
        self.coefficients
            .iter()
            .zip(&self.systems)
            .map(|((c, s), system)| {
                let root = system.as_ref().map_or(0.0, |e| e.root_scale);
                c.iter().chain(s).map(|v| root * v).collect()
            })
            .collect()
    }

    /// ξ back to the coefficients x = ξ/√s.
    fn unscaled(&self, z: &[Vec<f64>]) -> Vec<(Vec<f64>, Vec<f64>)> {
        let n = self.columns;
        z.iter()
            .zip(&self.systems)
            .map(|(z, system)| {
                let root = system.as_ref().map_or(1.0, |e| e.root_scale);
                (
                    z[..n].iter().map(|v| v / root).collect(),
                    z[n..].iter().map(|v| v / root).collect(),
                )
            })
            .collect()
    }

    /// The same problem with the modulation within `bound` at every station (module docs,
    /// "Within C's law"), by ADMM on the harmonics' problems from the projected unbounded
    /// fit: set up (each harmonic's shifted normal matrix factored), and run for as much work
    /// as the caller gives it ([`WithinFit::run`]). Where the unbounded fit keeps the bound, it
    /// is the answer and nothing is run.
    pub fn within(&self, bound: &ModulationBound) -> WithinFit<'_> {
        let n = self.columns;
        let m_max = self.systems.len();
        let free = (0..n).all(|j| bound.load(&self.coefficients, j) <= 1.0);
        let weights = self.weights(bound);
        let mut z = self.in_scaled();
        project(&mut z, &weights);
        let rho = 1.0;
        WithinFit {
            fit: self,
            factors: if free { Vec::new() } else { self.factor(rho) },
            weights,
            rho,
            previous: z.clone(),
            z,
            u: vec![vec![0.0; 2 * n]; m_max],
            x: vec![vec![0.0; 2 * n]; m_max],
            converged: free,
        }
    }

    /// (N/s + ρ·I) factored, per harmonic.
    fn factor(&self, rho: f64) -> Vec<Option<Factor>> {
        self.systems
            .par_iter()
            .map(|system| Factor::new(&system.as_ref()?.normal, rho))
            .collect()
    }
}

/// A fit within the bound under way ([`UnboundedFit::within`]): ADMM's iterates in ξ, its
/// penalty ρ and the factorisations made for it. Wherever it stops, z keeps the bound.
pub struct WithinFit<'a> {
    fit: &'a UnboundedFit,
    weights: Vec<f64>,
    factors: Vec<Option<Factor>>,
    rho: f64,
    /// Per harmonic, the n cosines then the n sines: x the least-squares step, z its
    /// projection (the answer), u the scaled multiplier, `previous` z before the step.
    x: Vec<Vec<f64>>,
    z: Vec<Vec<f64>>,
    u: Vec<Vec<f64>>,
    previous: Vec<Vec<f64>>,
    converged: bool,
}

impl WithinFit<'_> {
    /// Runs ADMM for at most `work` operations more (each iteration costs 4·M·n²), or until
    /// its primal and dual residuals are within [`ADMM_TOLERANCE`]; ρ is balanced in the first
    /// half of these iterations.
    pub fn run(&mut self, work: f64) {
        if self.converged {
            return;
        }
        let systems = &self.fit.systems;
        let (n, m_max) = (self.fit.columns, systems.len());
        let step = 4.0 * (m_max * n * n) as f64;
        let iterations = ADMM_ITERATIONS.min((work / step.max(1.0)) as usize).max(1);
        let Self {
            fit,
            weights,
            factors,
            rho,
            x,
            z,
            u,
            previous,
            converged,
        } = self;
        for iteration in 0..iterations {
            // x = (N/s + ρI)⁻¹·(b + ρ·(z − u)), harmonic by harmonic.
            let rho_now = *rho;
            x.par_iter_mut()
                .zip(systems)
                .zip(&*factors)
                .zip(z.par_iter().zip(&*u))
                .for_each(|(((x, system), factor), (z, u))| match (system, factor) {
                    (Some(e), Some(factor)) => {
                        for (k, x) in x.iter_mut().enumerate() {
                            *x = e.rhs[(k % n, k / n)] + rho_now * (z[k] - u[k]);
                        }
                        factor.solve(&mut x[..n]);
                        factor.solve(&mut x[n..]);
                    }
                    _ => x.fill(0.0),
                });
            for ((z, previous), (x, u)) in z.iter_mut().zip(&mut *previous).zip(x.iter().zip(&*u)) {
                previous.copy_from_slice(z);
                for ((z, x), u) in z.iter_mut().zip(x).zip(u) {
                    *z = x + u;
                }
            }
            project(z, weights);
            let (mut primal, mut dual, mut x_size, mut z_size, mut multiplier) =
                (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
            for i in 0..m_max {
                for k in 0..2 * n {
                    let gap = x[i][k] - z[i][k];
                    u[i][k] += gap;
                    primal += gap * gap;
                    dual += (z[i][k] - previous[i][k]).powi(2);
                    x_size += x[i][k] * x[i][k];
                    z_size += z[i][k] * z[i][k];
                    multiplier += u[i][k] * u[i][k];
                }
            }
            let (primal, dual) = (primal.sqrt(), rho_now * dual.sqrt());
            if primal <= ADMM_TOLERANCE * x_size.max(z_size).sqrt().max(1e-12)
                && dual <= ADMM_TOLERANCE * (rho_now * multiplier.sqrt()).max(1e-12)
            {
                *converged = true;
                return;
            }
            // Residual balancing (Boyd et al. 2011, §3.4.1) in the first half, each change a
            // new factorisation; u is scaled by 1/ρ.
            if iteration % 10 == 9 && 2 * iteration < iterations {
                let factor_of = if primal > 10.0 * dual {
                    2.0
                } else if dual > 10.0 * primal {
                    0.5
                } else {
                    1.0
                };
                if factor_of != 1.0 {
                    *rho *= factor_of;
                    for ui in u.iter_mut().flatten() {
                        *ui /= factor_of;
                    }
                    *factors = fit.factor(*rho);
                }
            }
        }
    }

    /// The coefficients so far (x = z/√s): within the bound.
    pub fn coefficients(&self) -> Vec<(Vec<f64>, Vec<f64>)> {
        if self.converged && self.factors.is_empty() {
            return self.fit.coefficients.clone();
        }
        self.fit.unscaled(&self.z)
    }
}

/// One harmonic's N/s + ρ·I = L·Lᵀ, L row-major, and its solves by substitution. Faer
/// factors it; the substitutions are written out because ADMM makes two per harmonic and
/// iteration on n ≈ 100 with one right-hand side each, where faer's solve spent more on its
/// set-up than on its arithmetic (13 ms of a plan's 25 iterations, against about 1 here).
struct Factor {
    n: usize,
    lower: Vec<f64>,
}

impl Factor {
    fn new(normal: &Mat<f64>, rho: f64) -> Option<Factor> {
        let n = normal.nrows();
        let shifted = normal + Mat::<f64>::identity(n, n) * rho;
        let llt = shifted.llt(faer::Side::Lower).ok()?;
        let l = llt.L();
        let lower = (0..n * n)
            .map(|k| {
                let (i, j) = (k / n, k % n);
                if j <= i {
                    l[(i, j)]
                } else {
                    0.0
                }
            })
            .collect();
        Some(Factor { n, lower })
    }

    /// b ← (L·Lᵀ)⁻¹·b: L·y = b forward, then Lᵀ·x = y backward (column i of Lᵀ is row i
    /// of L, so the backward pass reads rows too).
    fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            let row = &self.lower[i * n..i * n + i];
            let sum: f64 = row.iter().zip(&b[..i]).map(|(l, y)| l * y).sum();
            b[i] = (b[i] - sum) / self.lower[i * n + i];
        }
        for i in (0..n).rev() {
            b[i] /= self.lower[i * n + i];
            let xi = b[i];
            let row = &self.lower[i * n..i * n + i];
            for (y, l) in b[..i].iter_mut().zip(row) {
                *y -= l * xi;
            }
        }
    }
}

/// What a harmonic fit fits and how (module docs, "Each harmonic's problem").
/// Made by [`HarmonicOperator::fit_setup`]; the smoothing is [`SMOOTHING`].
#[derive(Debug)]
pub struct HarmonicFit<'a> {
    /// The stations' radii (the smoothing's divided differences), mm.
    stations_mm: &'a [f64],
    /// r_t, mm: the smoothing weighs the curvature over one pad radius.
    tool_radius_mm: f64,
    /// m_a (∞ without an acceleration limit).
    m_accel: f64,
    /// Per harmonic, GᵀWG and GᵀW·[a_m, b_m] on unscaled columns.
    normals: Vec<(Mat<f64>, Mat<f64>)>,
}

/// One harmonic's regularised normal equations: N, [Gᵀ·W·a, Gᵀ·W·b] and N's scale.
type NormalEquations = (Mat<f64>, Mat<f64>, f64);

/// One harmonic's normal equations in the scaled variables ξ = √s·x: N/s and b/√s.
struct Scaled {
    normal: Mat<f64>,
    rhs: Mat<f64>,
    root_scale: f64,
}

/// ADMM's relative tolerance on its primal and dual residuals: the plan is judged by the
/// exact prediction, and a modulation right to 1e-5 of its size is far inside what a law of
/// sectors carries.
const ADMM_TOLERANCE: f64 = 1e-5;
/// The most ADMM iterations (each costs 4·M·n² operations; it stops well before on every case
/// tried).
const ADMM_ITERATIONS: usize = 3000;
/// The work of a plan's fit within C's law, in operations (25 iterations on 101 stations and
/// 32 harmonics, about 8 ms on two cores).
pub const ADMM_WORK: f64 = 3e7;
/// The part of it each candidate mean dwell is given when they are compared (3 iterations
/// there); the one kept goes on from where it stopped.
pub const ADMM_SCREEN_WORK: f64 = 5e6;

/// Projects each station's harmonics (`x[m]`: harmonic m's n cosines then its n sines;
/// station j's are entries j and n + j) onto
/// Σ_m c_m·‖x_jm‖ ≤ 1 (`weights[m]` = c_m): a weighted ℓ1 ball on the harmonics' amplitudes,
/// each shrunk by τ·c_m (Duchi et al.'s projection, with weights).
fn project(x: &mut [Vec<f64>], weights: &[f64]) {
    let n = x.first().map_or(0, |m| m.len() / 2);
    let mut amplitudes = vec![0.0; x.len()];
    let mut order: Vec<usize> = (0..x.len()).collect();
    let all_finite = weights.iter().all(|c| c.is_finite());
    for j in 0..n {
        let mut total = 0.0;
        for (m, xm) in x.iter().enumerate() {
            amplitudes[m] = xm[j].hypot(xm[n + j]);
            if weights[m].is_finite() {
                total += weights[m] * amplitudes[m];
            }
        }
        if total <= 1.0 && all_finite {
            continue;
        }
        // τ solves Σ c_m·max(a_m − τ·c_m, 0) = 1; the active harmonics are those with the
        // largest a_m/c_m.
        order.sort_by(|&a, &b| {
            (amplitudes[b] / weights[b]).total_cmp(&(amplitudes[a] / weights[a]))
        });
        let (mut sum, mut squares, mut tau) = (0.0, 0.0, 0.0);
        if total > 1.0 {
            for (k, &m) in order.iter().enumerate() {
                if !weights[m].is_finite() {
                    break;
                }
                sum += weights[m] * amplitudes[m];
                squares += weights[m] * weights[m];
                tau = (sum - 1.0) / squares;
                let next = order
                    .get(k + 1)
                    .map_or(0.0, |&i| amplitudes[i] / weights[i]);
                if tau >= next {
                    break;
                }
            }
        }
        for (m, xm) in x.iter_mut().enumerate() {
            let a = amplitudes[m];
            let keep = if !weights[m].is_finite() || a == 0.0 {
                0.0
            } else {
                (a - tau * weights[m]).max(0.0) / a
            };
            xm[j] *= keep;
            xm[n + j] *= keep;
        }
    }
}

/// What C's law allows a station's modulation, relative to its dwell: Σ_m c_m·‖x_m‖ ≤ 1 over
/// the harmonics' amplitudes ‖x_m‖ = ‖(x^c_m, x^s_m)‖ (module docs, "Within C's law").
#[derive(Debug, Clone, PartialEq)]
pub struct ModulationBound {
    /// c_m, m = 1 … m_max.
    pub weights: Vec<f64>,
}

impl ModulationBound {
    /// Σ_m c_m·‖x_jm‖ at station `j` of the harmonics' coefficients `x` ((x^c_m, x^s_m),
    /// index m − 1): at most 1 within the bound.
    pub fn load(&self, x: &[(Vec<f64>, Vec<f64>)], j: usize) -> f64 {
        x.iter()
            .zip(&self.weights)
            .map(|((c, s), w)| w * c[j].hypot(s[j]))
            .sum()
    }

    /// The bound that keeps C's law within `limits` at |Ω0| = `omega0` with `sectors` sectors:
    /// c_m = max(1/(δ·sinc(mπ/S)), m/A), δ = min(δ_max, 1 − Ω0/v_max) and A = a_max/Ω0² (module
    /// docs: C's acceleration to first order);
    /// `None` when C's velocity limit is below Ω0 itself.
    pub fn new(limits: &CLimits, omega0: f64, sectors: usize, m_max: usize) -> Option<Self> {
        let mut delta = limits.max_modulation;
        if let Some(v) = limits.max_velocity_rad_per_s {
            let headroom = 1.0 - omega0 / (v * (1.0 - MARGIN));
            if headroom <= 0.0 {
                return None;
            }
            delta = delta.min(headroom);
        }
        let reach = limits
            .max_acceleration_rad_per_s2
            .map_or(f64::INFINITY, |a| a * (1.0 - MARGIN) / (omega0 * omega0));
        let width = std::f64::consts::TAU / sectors as f64;
        let weights = (1..=m_max)
            .map(|m| {
                let x = m as f64 * width / 2.0;
                (x / (delta * x.sin())).max(m as f64 / reach)
            })
            .collect();
        Some(ModulationBound { weights })
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

#[cfg(test)]
mod tests {
    use super::*;
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{
        DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
    };

    /// The projection onto Σ_m c_m·‖x_m‖ ≤ 1 lands on the bound from outside and leaves a
    /// point inside alone; and it is the nearest point of the ball: no feasible point among
    /// 2,000 random ones on or in the ball is nearer (the ball is convex, so the nearest point
    /// is unique and every other is at least as far; 1e-12 for rounding).
    #[test]
    fn the_projection_is_the_nearest_point_of_the_bound() {
        let mut rng = fastrand::Rng::with_seed(7);
        // The last harmonic is one the pad cannot move: the projection sets it to 0.
        let weights = [2.0, 0.7, 5.0, 1.3, f64::INFINITY];
        let norm = |x: &[Vec<f64>], j: usize| -> f64 {
            x.iter()
                .zip(&weights)
                .filter(|(_, c)| c.is_finite())
                .map(|(m, c)| c * m[j].hypot(m[3 + j]))
                .sum()
        };
        for scale in [0.05, 3.0] {
            let x: Vec<Vec<f64>> = (0..weights.len())
                .map(|_| (0..6).map(|_| scale * (rng.f64() - 0.5)).collect())
                .collect();
            let mut z = x.clone();
            project(&mut z, &weights);
            let last = weights.len() - 1;
            for j in 0..3 {
                assert!(z[last][j] == 0.0 && z[last][3 + j] == 0.0);
                let before = norm(&x, j);
                if before <= 1.0 {
                    assert!((0..last).all(|m| z[m][j] == x[m][j] && z[m][3 + j] == x[m][3 + j]));
                    continue;
                }
                assert!((norm(&z, j) - 1.0).abs() < 1e-12, "{}", norm(&z, j));
                let distance = |y: &[[f64; 2]]| -> f64 {
                    y.iter()
                        .enumerate()
                        .map(|(m, v)| (v[0] - x[m][j]).powi(2) + (v[1] - x[m][3 + j]).powi(2))
                        .sum::<f64>()
                };
                let nearest: Vec<[f64; 2]> =
                    (0..weights.len()).map(|m| [z[m][j], z[m][3 + j]]).collect();
                for _ in 0..2000 {
                    let mut y: Vec<[f64; 2]> = (0..weights.len())
                        .map(|m| {
                            let jiggle = 0.3 * scale;
                            [
                                z[m][j] + jiggle * (rng.f64() - 0.5),
                                z[m][3 + j] + jiggle * (rng.f64() - 0.5),
                            ]
                        })
                        .collect();
                    // Feasible: the immovable harmonic 0, the others scaled into the ball.
                    y[last] = [0.0, 0.0];
                    let size: f64 = y
                        .iter()
                        .zip(&weights)
                        .take(last)
                        .map(|(v, c)| c * v[0].hypot(v[1]))
                        .sum();
                    if size > 1.0 {
                        y.iter_mut().for_each(|v| {
                            v[0] /= size;
                            v[1] /= size;
                        });
                    }
                    assert!(distance(&y) >= distance(&nearest) - 1e-12);
                }
            }
        }
    }

    /// The fit within the bound is the solution of the same problem as a second-order cone
    /// program, solved by Clarabel (an interior-point method, nothing shared with ADMM but the
    /// normal equations): variables x^c, x^s per harmonic and station and an amplitude u ≥
    /// ‖(x^c, x^s)‖ per pair, Σ_m c_m·u_jm ≤ 1 per station. On a random operator of 3
    /// harmonics over 9 stations and 20 rings, with a target the bound cuts to about a third,
    /// the objective agrees to 1e-6, and the variables to 2e-3 of the solution's size: ADMM
    /// stops at 1e-5 relative residuals, and with the light smoothing the problem is nearly
    /// flat along some directions, where the variables move (7e-4 measured) without changing
    /// the objective.
    #[test]
    fn the_fit_within_the_bound_is_the_cone_program_s_solution() {
        let mut rng = fastrand::Rng::with_seed(11);
        let (rows, n, m_max) = (20, 9, 3);
        let kernel: Vec<Vec<f64>> = (0..m_max)
            .map(|m| {
                (0..rows * n)
                    .map(|k| {
                        let (i, j) = (k / n, k % n);
                        let d = i as f64 / rows as f64 - j as f64 / n as f64;
                        (-(d * d) * 40.0).exp() / (1.0 + m as f64) + 0.05 * rng.f64()
                    })
                    .collect()
            })
            .collect();
        let operator = HarmonicOperator {
            rows,
            columns: n,
            kernel,
            footprint: Vec::new(),
        };
        let radii: Vec<f64> = (0..rows).map(|i| 1.0 + i as f64).collect();
        let target = Harmonics {
            radii_mm: radii.clone(),
            coefficients: (0..rows)
                .map(|_| {
                    (0..=m_max)
                        .map(|_| (10.0 * (rng.f64() - 0.5), 10.0 * (rng.f64() - 0.5)))
                        .collect()
                })
                .collect(),
        };
        let stations: Vec<f64> = (0..n).map(|j| 2.0 * j as f64).collect();
        let fit = operator.fit_setup(&target, &radii, &stations, 3.0, f64::INFINITY);
        let scale = vec![1.0; n];
        let bound = ModulationBound {
            weights: vec![1.0, 1.5, 2.0],
        };
        let free = operator.fit(&fit, &scale);
        let size: f64 = (0..n)
            .map(|j| {
                free.coefficients()
                    .iter()
                    .zip(&bound.weights)
                    .map(|((c, s), w)| w * c[j].hypot(s[j]))
                    .sum::<f64>()
            })
            .fold(0.0, f64::max);
        assert!(size > 2.0, "the bound must bind: {size}");
        let mut within = free.within(&bound);
        within.run(1e12);
        let admm = within.coefficients();
        // The cone program: v = [x (2·M·n: harmonic, then cosines and sines), u (M·n)].
        let nx = 2 * m_max * n;
        let nv = nx + m_max * n;
        let mut p = vec![vec![0.0; nv]; nv];
        let mut q = vec![0.0; nv];
        for m in 1..=m_max {
            let (normal, rhs, _) = operator.normal_equations(m, &fit, &scale).unwrap();
            for part in 0..2 {
                let at = (m - 1) * 2 * n + part * n;
                for a in 0..n {
                    q[at + a] = -rhs[(a, part)];
                    for b in 0..n {
                        p[at + a][at + b] = normal[(a, b)];
                    }
                }
            }
        }
        let mut triplets = (Vec::new(), Vec::new(), Vec::new());
        let mut b = Vec::new();
        let mut cones = Vec::new();
        let mut push = |entries: &[(usize, f64)], rhs: f64, b: &mut Vec<f64>| {
            let row = b.len();
            for &(col, v) in entries {
                triplets.0.push(row);
                triplets.1.push(col);
                triplets.2.push(v);
            }
            b.push(rhs);
        };
        for j in 0..n {
            let entries: Vec<(usize, f64)> = (0..m_max)
                .map(|m| (nx + m * n + j, bound.weights[m]))
                .collect();
            push(&entries, 1.0, &mut b);
        }
        cones.push(SupportedConeT::NonnegativeConeT(n));
        for m in 0..m_max {
            for j in 0..n {
                // (u, x^c, x^s) in the cone: s = b − A·v = (u, x^c, x^s).
                push(&[(nx + m * n + j, -1.0)], 0.0, &mut b);
                push(&[(m * 2 * n + j, -1.0)], 0.0, &mut b);
                push(&[(m * 2 * n + n + j, -1.0)], 0.0, &mut b);
                cones.push(SupportedConeT::SecondOrderConeT(3));
            }
        }
        let a = CscMatrix::new_from_triplets(b.len(), nv, triplets.0, triplets.1, triplets.2);
        let (mut pr, mut pc, mut pv) = (Vec::new(), Vec::new(), Vec::new());
        for (r, row) in p.iter().enumerate() {
            for (c, &v) in row.iter().enumerate() {
                if c >= r && v != 0.0 {
                    pr.push(r);
                    pc.push(c);
                    pv.push(v);
                }
            }
        }
        let pm = CscMatrix::new_from_triplets(nv, nv, pr, pc, pv);
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .tol_gap_abs(1e-10)
            .tol_gap_rel(1e-10)
            .build()
            .unwrap();
        let mut solver = DefaultSolver::new(&pm, &q, &a, &b, &cones, settings).unwrap();
        solver.solve();
        assert_eq!(solver.solution.status, SolverStatus::Solved);
        let x = &solver.solution.x;
        // ADMM's answer keeps the bound (to rounding).
        for j in 0..n {
            let size: f64 = admm
                .iter()
                .zip(&bound.weights)
                .map(|((c, s), w)| w * c[j].hypot(s[j]))
                .sum();
            assert!(size <= 1.0 + 1e-12, "station {j}: {size}");
        }
        let objective = |v: &dyn Fn(usize) -> f64| -> f64 {
            let mut total = 0.0;
            for (i, row) in p.iter().enumerate().take(nx) {
                total += q[i] * v(i);
                for (k, entry) in row.iter().enumerate().take(nx) {
                    total += 0.5 * entry * v(i) * v(k);
                }
            }
            total
        };
        let admm_at = |i: usize| {
            let (m, rest) = (i / (2 * n), i % (2 * n));
            if rest < n {
                admm[m].0[rest]
            } else {
                admm[m].1[rest - n]
            }
        };
        let (ours, theirs) = (objective(&admm_at), objective(&|i| x[i]));
        assert!(
            (ours - theirs).abs() <= 1e-6 * theirs.abs(),
            "{ours} against {theirs}"
        );
        let largest = x[..nx].iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        for (i, &theirs) in x.iter().enumerate().take(nx) {
            assert!(
                (admm_at(i) - theirs).abs() <= 2e-3 * largest,
                "variable {i}: ADMM {} against the cone program's {theirs}",
                admm_at(i)
            );
        }
    }
}
