//! Bound-constrained least squares without the matrix: projected Newton with conjugate
//! gradients, for dwell maps of up to hundreds of thousands of points, where the operator is
//! only ever applied (M·v by FFT or sparse columns, Mᵀ·y likewise), or, where it is cheaper,
//! its fit held in the dwell's own space as G = MᵀWM ([`super::normal`]): the same gradient
//! and Hessian products, by G instead of M and Mᵀ.
//!
//! # The problem
//!
//! ```text
//! minimise  f(t) = ½·(P·r)ᵀ·W·(P·r)/m  +  ½·λ·Σ_edges (t_a − t_b)²/(E·τ²)  +  μ·Σ t_j/(n·τ)
//! over      l ≤ t ≤ u   (and Σ t ≤ T when asked),      r = M·t − d
//! ```
//!
//! with W the rows' weights (1 inside the clear aperture, 0 outside, so the rows off it are
//! free: dwell may go wherever the machine reaches, and only the aperture judges it), m their
//! sum, and P the W-orthogonal projector that takes the weighted least-squares fit of the
//! free terms B (piston, and tilt on request) off the residual, P = I − B(BᵀWB)⁻¹BᵀW, so the
//! piston and tilt are solved exactly rather than guessed. PᵀWP = WP, so the gradient is
//! g = MᵀWPr/m + λLt/(Eτ²) + μ/(nτ) and the Hessian H = MᵀWPM/m + λL/(Eτ²), applied with one
//! M·v and one Mᵀ·y. The scales (the depth scale s_d and the dwell scale τ, as the radial
//! optimizer takes them) make λ and μ dimensionless; the fit term is divided by s_d².
//!
//! # Why projected Newton
//!
//! The bounds are honoured exactly, every iterate being inside the box (Bertsekas 1982, with
//! the inexact Newton step of Lin & Moré 1999): at t the variables at a bound whose gradient
//! pushes them out are held, the Newton system on the others, H_FF·d = −g_F, is solved by
//! conjugate gradients preconditioned with H's diagonal, and the step is searched along the
//! projection arc t(α) = Π(t + α·d) with Armijo's rule. An interior point method would need
//! a factorisation (or an iterative solve of a far worse conditioned system) at each of its
//! iterations; an active set method, one change of the set per iteration, where a dwell map
//! changes thousands at once. Projected Newton changes the set freely, needs only products
//! with M and Mᵀ, and converges fast once the set settles.
//!
//! # The total time
//!
//! Σ t ≤ T is the one coupling constraint. It is kept by its multiplier ν: the problem with
//! μ/(nτ) + ν in place of μ/(nτ) is solved, warm, for ν found by Illinois regula falsi (the
//! total falls as ν grows), aiming at 1e-9 of T in at most 30 solves; each solve's own
//! tolerance usually stops it within 1e-5 below T.
//!
//! # What is reported
//!
//! The KKT residual in seconds, max_j |Π(t − g/D)_j − t_j|, the most any dwell would move in
//! one diagonally scaled projected-gradient step (0 exactly at the optimum), beside the
//! products with M spent.

use super::normal::Normal;
use super::operator::DwellOperator;
use super::solver::Budget;

/// What the solver is asked.
pub struct BoundedProblem<'a> {
    pub operator: &'a dyn DwellOperator,
    /// d, one per row, nm.
    pub target: &'a [f64],
    /// W, one per row (≥ 0).
    pub weights: &'a [f64],
    /// The free terms' columns over the rows (piston: all ones; tilt: x and y).
    pub free_terms: Vec<Vec<f64>>,
    /// The smoothing's pairs of neighbouring columns.
    pub edges: &'a [(usize, usize)],
    pub smoothing: f64,
    pub time_weight: f64,
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
    pub max_total_s: Option<f64>,
    /// The most work the solve may spend, in products with M (and as many with Mᵀ); a
    /// product with a held G counts as its share of that work (its entries over twice M's).
    pub max_products: usize,
    /// The time it may take; `None`: no limit.
    pub budget: Option<Budget>,
    /// Converged when the KKT residual is below this share of the largest dwell.
    pub tolerance: f64,
}

/// The solution and how it was reached.
#[derive(Debug, Clone)]
pub struct BoundedSolution {
    pub dwell_s: Vec<f64>,
    /// M·t at the solution, one per row.
    pub removal: Vec<f64>,
    /// The free terms' coefficients at the solution (B's columns' weights in d + B·c ≈ M·t).
    pub free_coefficients: Vec<f64>,
    /// max_j |Π(t − g/D)_j − t_j|, s.
    pub kkt_residual_s: f64,
    pub converged: bool,
    pub newton_iterations: usize,
    pub cg_iterations: usize,
    pub products: usize,
    /// ν, the total time's multiplier (0 when the total does not bind), per s of dwell in
    /// the objective's units.
    pub time_multiplier: f64,
    /// G's stored entries when the fit was held as MᵀWM ([`super::normal`]); `None` when it
    /// was taken by products with M.
    pub normal_entries: Option<usize>,
}

struct Solver<'a> {
    p: &'a BoundedProblem<'a>,
    /// (BᵀWB)⁻¹ (dense, at most 3 × 3).
    gram_inverse: Vec<Vec<f64>>,
    /// The fit in the dwell's space, when it is held ([`super::normal`]); else products
    /// with M.
    normal: Option<Normal>,
    /// The free terms' fit to the target alone, (BᵀWB)⁻¹·BᵀWd.
    target_fit: Vec<f64>,
    /// With the fit held: MᵀWPd = MᵀWd − U·(BᵀWB)⁻¹·BᵀWd, the gradient's constant (empty
    /// otherwise).
    normal_offset: Vec<f64>,
    fit_scale: f64,
    smooth_scale: f64,
    time_scale: f64,
    diagonal: Vec<f64>,
    products: usize,
    /// The work of one product in products with M and Mᵀ: 1, or G's share with the fit held.
    product_work: f64,
    /// The work spent, in products with M and Mᵀ.
    work: f64,
}

impl<'a> Solver<'a> {
    /// (BᵀWB)⁻¹·m for the free terms' moments m.
    fn free_solve(&self, moments: &[f64]) -> Vec<f64> {
        self.gram_inverse
            .iter()
            .map(|row| row.iter().zip(moments).map(|(g, m)| g * m).sum())
            .collect()
    }

    /// c = (BᵀWB)⁻¹BᵀW·r: the free terms' fit to r.
    fn free_fit(&self, r: &[f64]) -> Vec<f64> {
        let p = self.p;
        let moments: Vec<f64> = p
            .free_terms
            .iter()
            .map(|b| {
                b.iter()
                    .zip(r)
                    .zip(p.weights)
                    .map(|((b, r), w)| b * w * r)
                    .sum()
            })
            .collect();
        self.free_solve(&moments)
    }

    /// W·P·r (in place of r), and the free terms' coefficients.
    fn weighted_projection(&self, r: &mut [f64]) -> Vec<f64> {
        let c = self.free_fit(r);
        for (k, b) in self.p.free_terms.iter().enumerate() {
            for (ri, bi) in r.iter_mut().zip(b) {
                *ri -= c[k] * bi;
            }
        }
        for (ri, w) in r.iter_mut().zip(self.p.weights) {
            *ri *= w;
        }
        c
    }

    fn laplacian(&self, t: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; t.len()];
        for &(a, b) in self.p.edges {
            let d = t[a] - t[b];
            out[a] += d;
            out[b] -= d;
        }
        out
    }

    /// (G − U·(BᵀWB)⁻¹·Uᵀ)·v, and the free terms' part (BᵀWB)⁻¹·Uᵀv.
    fn normal_hessian(&self, normal: &Normal, v: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mut out = normal.apply(v);
        let moments: Vec<f64> = normal.free_moments.iter().map(|u| dot(u, v)).collect();
        let c = self.free_solve(&moments);
        for (u, ck) in normal.free_moments.iter().zip(&c) {
            for (o, u) in out.iter_mut().zip(u) {
                *o -= ck * u;
            }
        }
        (out, c)
    }

    /// The gradient of f at t (with `nu` added to the time term), the free terms'
    /// coefficients, and M·t when the fit is taken by products (empty otherwise).
    fn evaluate(&mut self, t: &[f64], nu: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let p = self.p;
        self.count_product();
        let (mut g, c, removal) = match &self.normal {
            Some(normal) => {
                // MᵀWP(Mt − d) = Ĝt − MᵀWPd.
                let (mut g, ct) = self.normal_hessian(normal, t);
                for (gj, offset) in g.iter_mut().zip(&self.normal_offset) {
                    *gj -= offset;
                }
                let c = ct
                    .iter()
                    .zip(&self.target_fit)
                    .map(|(a, b)| a - b)
                    .collect();
                (g, c, Vec::new())
            }
            None => {
                let removal = p.operator.apply(t);
                let mut r: Vec<f64> = removal.iter().zip(p.target).map(|(m, d)| m - d).collect();
                let c = self.weighted_projection(&mut r);
                (p.operator.apply_transpose(&r), c, removal)
            }
        };
        let lt = self.laplacian(t);
        let linear = self.time_scale + nu;
        for (j, gj) in g.iter_mut().enumerate() {
            *gj = *gj * self.fit_scale + self.smooth_scale * lt[j] + linear;
        }
        (g, c, removal)
    }

    /// MᵀWPM·v, and M·v when the fit is taken by products (empty otherwise).
    fn fit_hessian(&mut self, v: &[f64]) -> (Vec<f64>, Vec<f64>) {
        self.count_product();
        match &self.normal {
            Some(normal) => (self.normal_hessian(normal, v).0, Vec::new()),
            None => {
                let mv = self.p.operator.apply(v);
                let mut wpmv = mv.clone();
                self.weighted_projection(&mut wpmv);
                (self.p.operator.apply_transpose(&wpmv), mv)
            }
        }
    }

    /// H·v on the free variables (v zero elsewhere).
    fn hessian(&mut self, v: &[f64]) -> Vec<f64> {
        let (mut hv, _) = self.fit_hessian(v);
        let lv = self.laplacian(v);
        for (h, l) in hv.iter_mut().zip(&lv) {
            *h = *h * self.fit_scale + self.smooth_scale * l;
        }
        hv
    }

    /// The free terms' coefficients at t, from M·t when the fit is taken by products.
    fn free_coefficients(&self, t: &[f64], removal: &[f64]) -> Vec<f64> {
        match &self.normal {
            Some(normal) => {
                let moments: Vec<f64> = normal.free_moments.iter().map(|u| dot(u, t)).collect();
                let ct = self.free_solve(&moments);
                ct.iter()
                    .zip(&self.target_fit)
                    .map(|(a, b)| a - b)
                    .collect()
            }
            None => {
                let r: Vec<f64> = removal
                    .iter()
                    .zip(self.p.target)
                    .map(|(m, d)| m - d)
                    .collect();
                self.free_fit(&r)
            }
        }
    }

    fn count_product(&mut self) {
        self.products += 1;
        self.work += self.product_work;
    }

    /// Whether the solve has spent its products or its time.
    fn exhausted(&self) -> bool {
        self.work >= self.p.max_products as f64
            || self
                .p
                .budget
                .as_ref()
                .is_some_and(|b| b.remaining_s().is_err())
    }

    /// D⁻¹·r on the free variables (zero elsewhere, where r is).
    fn precondition(&self, r: &[f64]) -> Vec<f64> {
        r.iter().zip(&self.diagonal).map(|(r, d)| r / d).collect()
    }

    fn project(&self, t: &mut [f64]) {
        for ((t, l), u) in t.iter_mut().zip(&self.p.lower).zip(&self.p.upper) {
            *t = t.clamp(*l, *u);
        }
    }

    fn kkt(&self, t: &[f64], g: &[f64]) -> f64 {
        t.iter()
            .zip(g)
            .zip(&self.diagonal)
            .zip(self.p.lower.iter().zip(&self.p.upper))
            .map(|(((&t, &g), &d), (&l, &u))| ((t - g / d).clamp(l, u) - t).abs())
            .fold(0.0, f64::max)
    }

    /// Projected Newton from `t` at time multiplier `nu`.
    fn solve(&mut self, mut t: Vec<f64>, nu: f64, stats: &mut BoundedSolution) -> Vec<f64> {
        let n = t.len();
        self.project(&mut t);
        let (mut g, mut c, mut removal) = self.evaluate(&t, nu);
        let mut steps = 0usize;
        loop {
            let kkt = self.kkt(&t, &g);
            let largest = t.iter().fold(0.0_f64, |m, &v| m.max(v)).max(1e-300);
            stats.kkt_residual_s = kkt;
            stats.free_coefficients = c.clone();
            if kkt <= self.p.tolerance * largest {
                stats.converged = true;
                return t;
            }
            if self.exhausted() {
                stats.converged = false;
                return t;
            }
            stats.newton_iterations += 1;
            // The free set: not within ε of a bound the gradient pushes against, ε the KKT
            // residual itself (Bertsekas's ε-active set, so the set settles as t converges).
            let free: Vec<bool> = (0..n)
                .map(|j| {
                    let (l, u) = (self.p.lower[j], self.p.upper[j]);
                    let eps = kkt.min(0.5 * (u - l));
                    !((t[j] <= l + eps && g[j] > 0.0) || (t[j] >= u - eps && g[j] < 0.0))
                })
                .collect();
            // Preconditioned CG on H_FF·d = −g_F, to a relative residual of
            // min(0.5, √‖g_F‖/‖g_0‖) (inexact Newton), at most 50 steps.
            let mut d = vec![0.0; n];
            let mut res: Vec<f64> = (0..n).map(|j| if free[j] { -g[j] } else { 0.0 }).collect();
            let norm0 = res.iter().map(|v| v * v).sum::<f64>().sqrt();
            let target_norm = 0.1 * norm0;
            let mut z = self.precondition(&res);
            let mut dir = z.clone();
            let mut rz: f64 = res.iter().zip(&z).map(|(a, b)| a * b).sum();
            for _ in 0..50 {
                if self.exhausted() {
                    break;
                }
                stats.cg_iterations += 1;
                let mut hd = self.hessian(&dir);
                for j in 0..n {
                    if !free[j] {
                        hd[j] = 0.0;
                    }
                }
                let curvature: f64 = dir.iter().zip(&hd).map(|(a, b)| a * b).sum();
                if curvature <= 0.0 {
                    break;
                }
                let alpha = rz / curvature;
                for j in 0..n {
                    d[j] += alpha * dir[j];
                    res[j] -= alpha * hd[j];
                }
                if res.iter().map(|v| v * v).sum::<f64>().sqrt() <= target_norm {
                    break;
                }
                z = self.precondition(&res);
                let rz_next: f64 = res.iter().zip(&z).map(|(a, b)| a * b).sum();
                let beta = rz_next / rz;
                rz = rz_next;
                for j in 0..n {
                    dir[j] = z[j] + beta * dir[j];
                }
            }
            if d.iter().all(|&v| v == 0.0) {
                // No direction from the free set: a projected gradient step instead.
                for j in 0..n {
                    d[j] = -g[j] / self.diagonal[j];
                }
            }
            // Armijo along the projection arc; if the Newton direction gives no decrease,
            // the scaled projected gradient's; if neither does, t is optimal to rounding.
            // f is quadratic, so a step s changes it by exactly gᵀs + ½·sᵀHs, taken from
            // M·s itself (not as a difference of two values of f, which rounding would
            // swamp near the optimum); the gradient moves by H·s.
            let gradient_step: Vec<f64> = (0..n).map(|j| -g[j] / self.diagonal[j]).collect();
            let mut accepted = false;
            'directions: for direction in [&d, &gradient_step] {
                let mut step = 1.0;
                for _ in 0..30 {
                    let mut trial: Vec<f64> = t
                        .iter()
                        .zip(direction.iter())
                        .map(|(t, d)| t + step * d)
                        .collect();
                    self.project(&mut trial);
                    let s: Vec<f64> = trial.iter().zip(&t).map(|(a, b)| a - b).collect();
                    let linear: f64 = g.iter().zip(&s).map(|(g, s)| g * s).sum();
                    if linear < 0.0 {
                        let (hs, ms) = self.fit_hessian(&s);
                        let ls = self.laplacian(&s);
                        let quadratic = 0.5
                            * (self.fit_scale * dot(&s, &hs) + self.smooth_scale * dot(&s, &ls));
                        let change = linear + quadratic;
                        if change <= 1e-4 * linear {
                            for j in 0..n {
                                g[j] += self.fit_scale * hs[j] + self.smooth_scale * ls[j];
                            }
                            for (r, m) in removal.iter_mut().zip(&ms) {
                                *r += m;
                            }
                            t = trial;
                            accepted = true;
                            steps += 1;
                            if steps % 16 == 0 {
                                // Start afresh now and then, so the updates' rounding
                                // does not accumulate.
                                (g, c, removal) = self.evaluate(&t, nu);
                            } else {
                                c = self.free_coefficients(&t, &removal);
                            }
                            break 'directions;
                        }
                    }
                    step *= 0.5;
                }
            }
            if !accepted {
                stats.kkt_residual_s = self.kkt(&t, &g);
                stats.free_coefficients = c;
                stats.converged = stats.kkt_residual_s <= self.p.tolerance * largest;
                return t;
            }
        }
    }
}

/// Solves `problem` from `start` (one dwell per column; projected into the bounds first).
/// `depth_scale` and `dwell_scale` are s_d (nm) and τ (s) of the module docs.
pub fn solve(
    problem: &BoundedProblem,
    start: Vec<f64>,
    depth_scale: f64,
    dwell_scale: f64,
) -> BoundedSolution {
    let n = problem.operator.cols();
    let m: f64 = problem.weights.iter().sum::<f64>().max(1e-300);
    // (BᵀWB)⁻¹ by Gauss–Jordan on a system of at most three unknowns.
    let k = problem.free_terms.len();
    let mut gram = vec![vec![0.0; 2 * k]; k];
    for (a, row) in gram.iter_mut().enumerate() {
        for (b, term) in problem.free_terms.iter().enumerate() {
            row[b] = problem.free_terms[a]
                .iter()
                .zip(term)
                .zip(problem.weights)
                .map(|((x, y), w)| x * y * w)
                .sum();
        }
        row[k + a] = 1.0;
    }
    for col in 0..k {
        let pivot = (col..k)
            .max_by(|&a, &b| gram[a][col].abs().total_cmp(&gram[b][col].abs()))
            .expect("a column has rows");
        gram.swap(col, pivot);
        let p = gram[col][col];
        if p.abs() < 1e-300 {
            // A free term the weights cannot see: leave it out (its row stays zero).
            gram[col].iter_mut().for_each(|v| *v = 0.0);
            continue;
        }
        gram[col].iter_mut().for_each(|v| *v /= p);
        for row in 0..k {
            if row != col {
                let f = gram[row][col];
                let pivot_row = gram[col].clone();
                gram[row]
                    .iter_mut()
                    .zip(pivot_row)
                    .for_each(|(v, pv)| *v -= f * pv);
            }
        }
    }
    let gram_inverse = gram.into_iter().map(|row| row[k..].to_vec()).collect();
    let fit_scale = 1.0 / (m * depth_scale * depth_scale);
    let edges = problem.edges.len().max(1) as f64;
    let smooth_scale = problem.smoothing / (edges * dwell_scale * dwell_scale);
    let time_scale = problem.time_weight / (n.max(1) as f64 * dwell_scale);
    let normal = Normal::assemble(
        problem.operator,
        problem.weights,
        problem.target,
        &problem.free_terms,
    );
    let mut solver = Solver {
        p: problem,
        gram_inverse,
        target_fit: Vec::new(),
        normal_offset: Vec::new(),
        product_work: normal.as_ref().map_or(1.0, Normal::product_work),
        normal,
        fit_scale,
        smooth_scale,
        time_scale,
        diagonal: Vec::new(),
        products: 0,
        work: 0.0,
    };
    solver.target_fit = solver.free_fit(problem.target);
    if let Some(normal) = &solver.normal {
        solver.normal_offset = normal.target_moment.clone();
        for (u, ck) in normal.free_moments.iter().zip(&solver.target_fit) {
            for (o, u) in solver.normal_offset.iter_mut().zip(u) {
                *o -= ck * u;
            }
        }
    }
    // D: H's diagonal, the fit's part without P (which only lowers it), floored so a column
    // the aperture does not see still has a scale.
    let norms = match &solver.normal {
        Some(normal) => normal.diagonal(),
        None => column_norms(problem.operator, problem.weights),
    };
    let mut degree = vec![0.0; n];
    for &(a, b) in problem.edges {
        degree[a] += 1.0;
        degree[b] += 1.0;
    }
    let raw: Vec<f64> = norms
        .iter()
        .zip(&degree)
        .map(|(s, d)| s * fit_scale + smooth_scale * d)
        .collect();
    let floor = 1e-8 * raw.iter().fold(0.0_f64, |m, &v| m.max(v)).max(1e-300);
    solver.diagonal = raw.into_iter().map(|v| v.max(floor)).collect();
    let mut stats = BoundedSolution {
        dwell_s: Vec::new(),
        removal: Vec::new(),
        free_coefficients: Vec::new(),
        kkt_residual_s: f64::INFINITY,
        converged: false,
        newton_iterations: 0,
        cg_iterations: 0,
        products: 0,
        time_multiplier: 0.0,
        normal_entries: None,
    };
    let mut t = solver.solve(start, 0.0, &mut stats);
    let mut spent = 0;
    if let Some(limit) = problem.max_total_s {
        let total = |t: &[f64]| t.iter().sum::<f64>();
        if total(&t) > limit * (1.0 + 1e-9) {
            // Illinois regula falsi on φ(ν) = Σt(ν) − T, which falls as ν grows: a
            // bracket first (ν from the gradient's scale, D·t, growing fourfold), then the
            // secant with the stale end's value halved, each solve warm from the last. Each
            // solve has the whole product budget (so the total-time phase may spend up to
            // `MAX_TOTAL_SOLVES` budgets).
            let phi = |t: &[f64]| t.iter().sum::<f64>() - limit;
            let (mut lo, mut f_lo) = (0.0, phi(&t));
            let mut hi = solver
                .diagonal
                .iter()
                .zip(&t)
                .map(|(d, t)| d * t)
                .sum::<f64>()
                / n as f64;
            let mut solves = 0;
            let mut best = loop {
                spent += std::mem::take(&mut solver.products);
                solver.work = 0.0;
                solves += 1;
                let trial = solver.solve(t.clone(), hi, &mut stats);
                if phi(&trial) <= 0.0 || solves >= MAX_TOTAL_SOLVES || solver.exhausted() {
                    break trial;
                }
                (lo, f_lo) = (hi, phi(&trial));
                t = trial;
                hi *= 4.0;
            };
            let mut f_hi = phi(&best);
            let mut side = 0i8;
            while solves < MAX_TOTAL_SOLVES
                && f_hi.abs() > 1e-9 * limit
                && f_lo > 0.0
                && !solver.exhausted()
            {
                let nu = hi - f_hi * (hi - lo) / (f_hi - f_lo);
                spent += std::mem::take(&mut solver.products);
                solver.work = 0.0;
                solves += 1;
                let trial = solver.solve(best.clone(), nu, &mut stats);
                let f = phi(&trial);
                if f <= 0.0 {
                    (hi, f_hi, best) = (nu, f, trial);
                    if side == -1 {
                        f_lo *= 0.5;
                    }
                    side = -1;
                } else {
                    (lo, f_lo) = (nu, f);
                    if side == 1 {
                        f_hi *= 0.5;
                    }
                    side = 1;
                }
            }
            // The last solve's figures are for its ν; report those of the kept plan.
            let (g, c, _) = solver.evaluate(&best, hi);
            stats.kkt_residual_s = solver.kkt(&best, &g);
            let largest = best.iter().fold(0.0_f64, |m, &v| m.max(v));
            stats.converged = stats.kkt_residual_s <= problem.tolerance * largest;
            stats.free_coefficients = c;
            stats.time_multiplier = hi;
            t = best;
        }
    }
    stats.removal = problem.operator.apply(&t);
    stats.products = spent + solver.products + 1;
    stats.normal_entries = solver.normal.as_ref().map(Normal::entries);
    stats.dwell_s = t;
    stats
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The most solves the total time's multiplier may take.
const MAX_TOTAL_SOLVES: usize = 30;

/// Σ_i w_i·M_ij² per column: the operator's own when it has them, else by M·e_j.
fn column_norms(op: &dyn DwellOperator, weights: &[f64]) -> Vec<f64> {
    if let Some(norms) = op.weighted_column_norms(weights) {
        return norms;
    }
    (0..op.cols())
        .map(|j| {
            let mut unit = vec![0.0; op.cols()];
            unit[j] = 1.0;
            op.apply(&unit)
                .iter()
                .zip(weights)
                .map(|(m, w)| w * m * m)
                .sum()
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

    #[derive(Debug)]
    struct Dense {
        rows: usize,
        cols: usize,
        /// Row-major.
        m: Vec<f64>,
        /// Whether it gives its columns (so the solver may hold the fit as MᵀWM).
        columns: bool,
    }

    impl DwellOperator for Dense {
        fn rows(&self) -> usize {
            self.rows
        }
        fn cols(&self) -> usize {
            self.cols
        }
        fn apply(&self, t: &[f64]) -> Vec<f64> {
            self.m
                .chunks(self.cols)
                .map(|row| row.iter().zip(t).map(|(a, b)| a * b).sum())
                .collect()
        }
        fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
            let mut out = vec![0.0; self.cols];
            for (row, yi) in self.m.chunks(self.cols).zip(y) {
                for (o, a) in out.iter_mut().zip(row) {
                    *o += a * yi;
                }
            }
            out
        }
        fn column_runs(&self, j: usize, visit: &mut dyn FnMut(usize, &[f64])) -> bool {
            if self.columns {
                for i in 0..self.rows {
                    visit(i, std::slice::from_ref(&self.m[i * self.cols + j]));
                }
            }
            self.columns
        }
    }

    /// A blurred 1-D deconvolution (Gaussian columns, 60 rows, 25 columns, the rows past 45
    /// weighted 0), piston and tilt free, smoothing, a time weight, bounds and a total time
    /// that binds: projected Newton's plan against Clarabel's interior point on the same QP
    /// (the free terms as variables), objectives equal to 1e-8 of f(0) and dwell to 1e-3 of the
    /// largest (the problem is ill-conditioned: dwell is less determined than the objective).
    /// Both forms of the fit: products with M, and MᵀWM held.
    #[test]
    fn projected_newton_meets_an_interior_point_solver() {
        for columns in [false, true] {
            meets_an_interior_point_solver(columns);
        }
    }

    fn meets_an_interior_point_solver(columns: bool) {
        let (rows, cols) = (60, 25);
        let m: Vec<f64> = (0..rows * cols)
            .map(|k| {
                let (i, j) = ((k / cols) as f64, (k % cols) as f64 * 2.5);
                3.0 * (-(i - j) * (i - j) / 18.0).exp()
            })
            .collect();
        let op = Dense {
            rows,
            cols,
            m,
            columns,
        };
        let target: Vec<f64> = (0..rows)
            .map(|i| 40.0 + 15.0 * (i as f64 / 7.0).sin() + 0.3 * i as f64)
            .collect();
        let weights: Vec<f64> = (0..rows).map(|i| if i < 45 { 1.0 } else { 0.0 }).collect();
        let x: Vec<f64> = (0..rows).map(|i| i as f64).collect();
        let edges: Vec<(usize, usize)> = (1..cols).map(|j| (j - 1, j)).collect();
        let (depth, dwell) = (20.0, 5.0);
        let mut free_total = 0.0;
        for binding in [false, true] {
            // The total time, when it binds: 0.7 of the plan's without it.
            let max_total = binding.then_some(0.7 * free_total);
            let problem = BoundedProblem {
                operator: &op,
                target: &target,
                weights: &weights,
                free_terms: vec![vec![1.0; rows], x.clone()],
                edges: &edges,
                smoothing: 1e-3,
                time_weight: 1e-3,
                lower: vec![0.5; cols],
                upper: vec![12.0; cols],
                max_total_s: max_total,
                max_products: 20_000,
                budget: None,
                tolerance: 1e-8,
            };
            let ours = solve(&problem, vec![0.5; cols], depth, dwell);
            assert!(ours.converged, "{binding}: {}", ours.kkt_residual_s);
            assert_eq!(ours.normal_entries.is_some(), columns);
            // The removal reported is M·t of the plan.
            for (r, m) in ours.removal.iter().zip(op.apply(&ours.dwell_s)) {
                assert!((r - m).abs() <= 1e-12 * m.abs().max(1.0));
            }
            free_total = ours.dwell_s.iter().sum();
            // Clarabel: v = (t, c0, c1), ½vᵀPv + qᵀv over the same objective.
            let fs = 1.0 / (45.0 * depth * depth);
            let ss = 1e-3 / (edges.len() as f64 * dwell * dwell);
            let ts = 1e-3 / (cols as f64 * dwell);
            let nv = cols + 2;
            let column = |v: usize, i: usize| -> f64 {
                if v < cols {
                    op.m[i * cols + v]
                } else if v == cols {
                    -1.0
                } else {
                    -x[i]
                }
            };
            let mut p = vec![vec![0.0; nv]; nv];
            let mut q = vec![0.0; nv];
            for a in 0..nv {
                for i in 0..rows {
                    q[a] -= fs * weights[i] * column(a, i) * target[i];
                    for (b, pb) in p[a].iter_mut().enumerate() {
                        *pb += fs * weights[i] * column(a, i) * column(b, i);
                    }
                }
            }
            for &(a, b) in &edges {
                p[a][a] += ss;
                p[b][b] += ss;
                p[a][b] -= ss;
                p[b][a] -= ss;
            }
            for qj in q.iter_mut().take(cols) {
                *qj += ts;
            }
            let (mut ar, mut ac, mut av, mut b) = (vec![], vec![], vec![], vec![]);
            for j in 0..cols {
                // −t ≤ −l and t ≤ u.
                ar.extend([2 * j, 2 * j + 1]);
                ac.extend([j, j]);
                av.extend([-1.0, 1.0]);
                b.extend([-0.5, 12.0]);
            }
            let mut cones = vec![SupportedConeT::NonnegativeConeT(2 * cols)];
            if let Some(total) = max_total {
                for j in 0..cols {
                    ar.push(2 * cols);
                    ac.push(j);
                    av.push(1.0);
                }
                b.push(total);
                cones.push(SupportedConeT::NonnegativeConeT(1));
            }
            let a = CscMatrix::new_from_triplets(b.len(), nv, ar, ac, av);
            let (mut pr, mut pc, mut pv) = (vec![], vec![], vec![]);
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
                .tol_gap_abs(1e-12)
                .tol_gap_rel(1e-12)
                .build()
                .unwrap();
            let mut solver = DefaultSolver::new(&pm, &q, &a, &b, &cones, settings).unwrap();
            solver.solve();
            assert_eq!(solver.solution.status, SolverStatus::Solved);
            let reference = &solver.solution.x;
            let objective = |v: &[f64]| -> f64 {
                let mut total = 0.0;
                for i in 0..nv {
                    total += q[i] * v[i];
                    for k in 0..nv {
                        total += 0.5 * p[i][k] * v[i] * v[k];
                    }
                }
                total
            };
            let mut mine = ours.dwell_s.clone();
            mine.extend(&ours.free_coefficients);
            let (f_ours, f_ref) = (objective(&mine), objective(reference));
            // The objective's scale: its value with no dwell, ½·fs·Σ w·d².
            let scale = fs
                * 0.5
                * (0..rows)
                    .map(|i| weights[i] * target[i] * target[i])
                    .sum::<f64>();
            assert!(
                (f_ours - f_ref).abs() <= 1e-8 * scale,
                "{max_total:?}: {f_ours} vs {f_ref}"
            );
            let largest = reference[..cols].iter().fold(0.0_f64, |m, v| m.max(*v));
            for (j, reference) in reference.iter().enumerate().take(cols) {
                assert!(
                    (ours.dwell_s[j] - reference).abs() < 1e-3 * largest,
                    "{max_total:?} {j}: {} vs {reference}",
                    ours.dwell_s[j],
                );
                assert!((0.5..=12.0).contains(&ours.dwell_s[j]));
            }
            if let Some(total) = max_total {
                let sum: f64 = ours.dwell_s.iter().sum();
                assert!(sum <= total && sum >= total * (1.0 - 1e-8), "{sum}");
            }
        }
    }
}
