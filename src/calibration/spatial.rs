//! Standard errors of a least-squares fit to a map whose residuals are correlated from pixel to
//! pixel.
//!
//! An interferometer's map is not independent pixel by pixel: what the model leaves (mid-
//! spatial structure the pad did not put there, the instrument's own ripple, the alignment's
//! interpolation) spans several pixels. The usual variance σ²·(JᵀJ)⁻¹ then counts every
//! pixel as a new measurement and is too small by about the number of pixels one correlated
//! patch holds (4× in standard error for noise smoothed over 2 pixels). With the residual e
//! stationary over the map (its covariance C(h) a function of the pixel offset h alone), a
//! parameter's variance is
//!
//! ```text
//! V_kk = Σ_h k(h)·(Ĉ(h) − Ĉ_far)·Σ_i a_k,i·a_k,(i+h),     a_k = ((JᵀJ)⁻¹·Jᵀ)_k,
//! Ĉ(h) = Σ_i e_i·e_(i+h) / N(h)
//! ```
//!
//! over the pairs of pixels i, i + h both in the fit (N(h) of them): the pooled estimate of the
//! residual's autocovariance, far steadier than the products e_i·e_j of Conley's estimator,
//! weighted by a flat-top kernel k(h) = λ(h_x/B)·λ(h_y/B), λ(t) = 1 for |t| ≤ ½, 2·(1 − |t|)
//! to |t| = 1 (Politis and Romano: it keeps the lags the correlation lives on whole, so its
//! bias is that of the correlation's tail alone, where a Bartlett cone would shrink every lag).
//!
//! **The fit's own shift.** A residual is the noise less its projection on the fitted terms:
//! the piston alone lowers every Ĉ(h) by about the variance of the noise's mean, Σ_h C(h)/n,
//! and summed over the (2B + 1)² lags that is a real share of the answer (14 % of the variance
//! for 2200 pixels of noise smoothed over 2). Ĉ_far, the mean of Ĉ at offsets beyond B to 2B
//! along the rows, the columns and the diagonals (where the noise no longer correlates), is
//! that shift, and is taken off when negative.
//!
//! **Bandwidth.** B = 2·m̂, m̂ the first lag after which the residual's autocorrelation along
//! the rows and columns (pooled) stays below 2·√(log₁₀ n / n) for five lags (Politis's rule:
//! below that it cannot be told from zero with n pixels). B is at most [`MAX_BANDWIDTH`]
//! pixels and a quarter of the map's smaller side.
//!
//! The flat-top kernel is not positive definite: where a variance comes out below the white-
//! noise figure Ĉ(0)·(JᵀJ)⁻¹_kk (the residual anti-correlated at short range, or noise in Ĉ)
//! that figure is kept. Variances are scaled by n/(n − p), the residual's lost degrees of
//! freedom. The estimate needs many correlated patches: with n_eff = n / (pixels per patch)
//! small it is itself noisy and its intervals cover less than they claim (±2σ over 200 seeds of
//! noise smoothed over 2 pixels: about 90 % with 2200 pixels, some 44 patches; 92 % and 96.5 %
//! on two sets of seeds with 8497).

/// The largest bandwidth, pixels (the sum runs over (2B + 1)² offsets per pixel).
pub const MAX_BANDWIDTH: usize = 24;

/// Lags the autocorrelation must stay below its threshold for.
const QUIET_LAGS: usize = 5;

/// Pixels of a map on its grid: column and row indices (any origin), one per fitted value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pixel {
    pub column: i64,
    pub row: i64,
}

/// The pixels' bounding box: its first column and row, and its size (0 × 0 for no pixels).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bounds {
    pub column0: i64,
    pub row0: i64,
    pub columns: usize,
    pub rows: usize,
}

/// The smallest box of whole pixels holding every pixel.
pub fn bounds(pixels: &[Pixel]) -> Bounds {
    let column0 = pixels.iter().map(|p| p.column).min().unwrap_or(0);
    let row0 = pixels.iter().map(|p| p.row).min().unwrap_or(0);
    let extent = |span: Option<i64>| span.map_or(0, |s| s as usize + 1);
    Bounds {
        column0,
        row0,
        columns: extent(pixels.iter().map(|p| p.column - column0).max()),
        rows: extent(pixels.iter().map(|p| p.row - row0).max()),
    }
}

/// The covariance of a fit's parameters with the residual's spatial correlation counted.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialCovariance {
    /// Each parameter's variance.
    pub variance: Vec<f64>,
    /// The bandwidth used, pixels.
    pub bandwidth_px: usize,
    /// How many times larger the first parameter's variance is than if the residuals were
    /// independent (≥ 1 unless they are anti-correlated).
    pub variance_inflation: f64,
}

/// Why the covariance cannot be formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SpatialError {
    #[error("the fit needs more pixels ({pixels}) than parameters ({parameters})")]
    TooFewPixels { pixels: usize, parameters: usize },
    #[error("the fit's parameters are not determined by its pixels (JᵀJ is singular)")]
    Singular,
}

/// The sandwich covariance (module docs) of a fit with Jacobian `jacobian` (one row of p
/// derivatives per pixel) and residuals `residual` at `pixels`.
pub fn spatial_covariance(
    pixels: &[Pixel],
    jacobian: &[Vec<f64>],
    residual: &[f64],
) -> Result<SpatialCovariance, SpatialError> {
    let n = pixels.len();
    let p = jacobian.first().map_or(0, Vec::len);
    debug_assert!(jacobian.len() == n && residual.len() == n);
    if n <= p || p == 0 {
        return Err(SpatialError::TooFewPixels {
            pixels: n,
            parameters: p,
        });
    }
    let inverse = invert(&normal_matrix(jacobian)).ok_or(SpatialError::Singular)?;
    let sandwich = Sandwich::new(pixels, &influence(&inverse, jacobian), residual);
    let dof = lost_freedom(n, p);
    let variance: Vec<f64> = (0..p).map(|k| dof * sandwich.variance(k)).collect();
    let variance_inflation = variance[0] / (dof * sandwich.white[0][0]);
    Ok(SpatialCovariance {
        variance,
        bandwidth_px: sandwich.bandwidth_px,
        variance_inflation,
    })
}

/// n/(n − p): what a fit's residual lost to its p parameters over n points, by which its
/// variances are scaled.
pub fn lost_freedom(n: usize, p: usize) -> f64 {
    n as f64 / n.saturating_sub(p).max(1) as f64
}

/// The white-noise covariance Ĉ(0)·Σ_i a_k,i·a_l,i of the functionals with influence rows
/// `influence` of a residual `residual` taken as independent from point to point, Ĉ(0) its
/// mean square.
pub fn independent(influence: &[Vec<f64>], residual: &[f64]) -> Vec<Vec<f64>> {
    let c0 = residual.iter().map(|e| e * e).sum::<f64>() / residual.len().max(1) as f64;
    influence
        .iter()
        .map(|a| {
            influence
                .iter()
                .map(|b| c0 * a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>())
                .collect()
        })
        .collect()
}

/// Each parameter's influence on the fit, a_k = (A·Jᵀ)_k, from the rows `inverse` of
/// A = (JᵀJ)⁻¹ (those of the parameters asked about) and J's rows.
pub fn influence(inverse: &[Vec<f64>], jacobian: &[Vec<f64>]) -> Vec<Vec<f64>> {
    inverse
        .iter()
        .map(|row| {
            jacobian
                .iter()
                .map(|j| row.iter().zip(j).map(|(a, b)| a * b).sum())
                .collect()
        })
        .collect()
}

/// The covariance of linear functionals Σ_i a_k,i·e_i of one map's residual e (a fit's
/// parameters, with a_k their influence rows): Σ_h k(h)·(Ĉ(h) − Ĉ_far)·Σ_i a_k,i·a_l,(i+h)
/// (module docs), unscaled and unfloored, beside the white-noise figure
/// Ĉ(0)·Σ_i a_k,i·a_l,i. A fit over several maps adds each map's.
#[derive(Debug, Clone, PartialEq)]
pub struct Sandwich {
    pub covariance: Vec<Vec<f64>>,
    pub white: Vec<Vec<f64>>,
    /// The bandwidth used, pixels.
    pub bandwidth_px: usize,
}

impl Sandwich {
    /// Over `pixels`, with the influence rows `influence` (each one value per pixel) and the
    /// residual `residual`.
    pub fn new(pixels: &[Pixel], influence: &[Vec<f64>], residual: &[f64]) -> Sandwich {
        let q = influence.len();
        let grid = Grid::new(pixels);
        let bandwidth = bandwidth(&grid, residual);
        let offset = far_covariance(&grid, residual, bandwidth).min(0.0);
        let reach = bandwidth as i64;
        // The upper triangle of the pairs (k, l), k ≤ l.
        let pairs: Vec<(usize, usize)> = (0..q).flat_map(|k| (k..q).map(move |l| (k, l))).collect();
        let mut upper = vec![0.0; pairs.len()];
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let weight = flat_top(dx, bandwidth) * flat_top(dy, bandwidth);
                if weight == 0.0 {
                    continue;
                }
                let mut count = 0usize;
                let mut covariance = 0.0;
                let mut cross = vec![0.0; pairs.len()];
                for (i, pixel) in pixels.iter().enumerate() {
                    let Some(j) = grid.at(pixel.column + dx, pixel.row + dy) else {
                        continue;
                    };
                    count += 1;
                    covariance += residual[i] * residual[j];
                    for (c, &(k, l)) in cross.iter_mut().zip(&pairs) {
                        *c += influence[k][i] * influence[l][j];
                    }
                }
                if count == 0 {
                    continue;
                }
                let scale = weight * (covariance / count as f64 - offset);
                for (u, c) in upper.iter_mut().zip(&cross) {
                    *u += scale * c;
                }
            }
        }
        let mut covariance = vec![vec![0.0; q]; q];
        for (&(k, l), u) in pairs.iter().zip(&upper) {
            covariance[k][l] = *u;
            covariance[l][k] = *u;
        }
        Sandwich {
            covariance,
            white: independent(influence, residual),
            bandwidth_px: bandwidth,
        }
    }

    /// Row k's variance, never below the white-noise figure (module docs).
    pub fn variance(&self, k: usize) -> f64 {
        self.covariance[k][k].max(self.white[k][k])
    }
}

/// The mean autocovariance at offsets beyond the bandwidth, to twice it (module docs): where
/// the residual no longer correlates, what is left is the fit's own shift.
fn far_covariance(grid: &Grid, residual: &[f64], bandwidth: usize) -> f64 {
    let (near, far) = (bandwidth as i64, (2 * bandwidth) as i64);
    let (mut sum, mut count) = (0.0, 0usize);
    // Along the rows, the columns and both diagonals: a sample of the ring, enough for a
    // mean, at an eighth of the cost of the whole ring.
    for lag in near + 1..=far {
        for (dx, dy) in [(lag, 0), (0, lag), (lag, lag), (lag, -lag)] {
            sum += grid.autocovariance(residual, dx, dy);
            count += 1;
        }
    }
    if count == 0 {
        0.0
    } else {
        sum / count as f64
    }
}

/// λ(h/B) of the module docs.
fn flat_top(lag: i64, bandwidth: usize) -> f64 {
    let t = lag.unsigned_abs() as f64 / bandwidth.max(1) as f64;
    if t <= 0.5 {
        1.0
    } else if t < 1.0 {
        2.0 * (1.0 - t)
    } else {
        0.0
    }
}

/// B = 2·m̂ (module docs).
fn bandwidth(grid: &Grid, residual: &[f64]) -> usize {
    let n = residual.len();
    let most = MAX_BANDWIDTH.min(grid.columns.min(grid.rows) / 4).max(1);
    let threshold = 2.0 * ((n as f64).log10().max(1.0) / n as f64).sqrt();
    let zero = grid.autocovariance(residual, 0, 0);
    if zero <= 0.0 {
        return 1;
    }
    let correlation = |lag: i64| {
        0.5 * (grid.autocovariance(residual, lag, 0) + grid.autocovariance(residual, 0, lag)) / zero
    };
    let last_lag = (most / 2 + QUIET_LAGS) as i64;
    let quiet: Vec<bool> = (1..=last_lag)
        .map(|lag| correlation(lag).abs() < threshold)
        .collect();
    // m̂: the lag before the first run of QUIET_LAGS quiet lags.
    let start = (0..quiet.len())
        .find(|&i| quiet[i..].iter().take(QUIET_LAGS).all(|&q| q) && i + QUIET_LAGS <= quiet.len());
    let m = start.unwrap_or(most / 2);
    (2 * m).clamp(1, most)
}

/// The pixels' positions on a dense grid, for their neighbours.
struct Grid {
    column0: i64,
    row0: i64,
    columns: usize,
    rows: usize,
    /// The pixel's index at each grid cell, or usize::MAX.
    index: Vec<usize>,
}

impl Grid {
    fn new(pixels: &[Pixel]) -> Grid {
        let Bounds {
            column0,
            row0,
            columns,
            rows,
        } = bounds(pixels);
        let mut index = vec![usize::MAX; columns * rows];
        for (i, p) in pixels.iter().enumerate() {
            index[(p.row - row0) as usize * columns + (p.column - column0) as usize] = i;
        }
        Grid {
            column0,
            row0,
            columns,
            rows,
            index,
        }
    }

    fn at(&self, column: i64, row: i64) -> Option<usize> {
        let (c, r) = (column - self.column0, row - self.row0);
        if c < 0 || r < 0 || c as usize >= self.columns || r as usize >= self.rows {
            return None;
        }
        let i = self.index[r as usize * self.columns + c as usize];
        (i != usize::MAX).then_some(i)
    }

    /// Ĉ(h) at the offset (dx, dy): the mean product over the pairs both present.
    fn autocovariance(&self, residual: &[f64], dx: i64, dy: i64) -> f64 {
        let (mut sum, mut pairs) = (0.0, 0usize);
        for r in 0..self.rows as i64 {
            for c in 0..self.columns as i64 {
                let (Some(i), Some(j)) = (
                    self.at(self.column0 + c, self.row0 + r),
                    self.at(self.column0 + c + dx, self.row0 + r + dy),
                ) else {
                    continue;
                };
                sum += residual[i] * residual[j];
                pairs += 1;
            }
        }
        if pairs == 0 {
            0.0
        } else {
            sum / pairs as f64
        }
    }
}

/// JᵀJ.
fn normal_matrix(jacobian: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let p = jacobian[0].len();
    let mut normal = vec![vec![0.0; p]; p];
    for row in jacobian {
        for k in 0..p {
            for l in 0..p {
                normal[k][l] += row[k] * row[l];
            }
        }
    }
    normal
}

/// The inverse of a small symmetric positive-definite matrix by Gauss–Jordan with partial
/// pivoting; `None` when a pivot vanishes (relative to the matrix's scale).
fn invert(matrix: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let p = matrix.len();
    let scale = (0..p).map(|k| matrix[k][k].abs()).fold(0.0, f64::max);
    let mut a: Vec<Vec<f64>> = matrix
        .iter()
        .enumerate()
        .map(|(k, row)| {
            let mut extended = row.clone();
            extended.extend((0..p).map(|l| f64::from(u8::from(k == l))));
            extended
        })
        .collect();
    for column in 0..p {
        let pivot =
            (column..p).max_by(|&x, &y| a[x][column].abs().total_cmp(&a[y][column].abs()))?;
        let size = a[pivot][column].abs();
        if size.is_nan() || size <= 1e-13 * scale {
            return None;
        }
        a.swap(column, pivot);
        let lead = a[column][column];
        for value in a[column].iter_mut() {
            *value /= lead;
        }
        for row in 0..p {
            if row != column {
                let factor = a[row][column];
                if factor != 0.0 {
                    let source = a[column].clone();
                    for (value, s) in a[row].iter_mut().zip(&source) {
                        *value -= factor * s;
                    }
                }
            }
        }
    }
    Some(a.into_iter().map(|row| row[p..].to_vec()).collect())
}

/// A removal map fitted by a predicted one: measured = ratio·predicted + piston + tilt.
#[derive(Debug, Clone, PartialEq)]
pub struct RatioFit {
    /// Measured over predicted removal (K_fit / K of the prediction).
    pub ratio: f64,
    /// Its standard error with the residual's spatial correlation counted (module docs).
    pub standard_error: f64,
    /// The standard error were the residuals independent from pixel to pixel.
    pub independent_standard_error: f64,
    pub piston_nm: f64,
    /// The plane's slopes, nm per mm along x and y.
    pub tilt_nm_per_mm: (f64, f64),
    pub residual_rms_nm: f64,
    pub bandwidth_px: usize,
}

/// Fits `measured` (nm, at `pixels`, `pixel_mm` apart) by `ratio`·`predicted` plus a piston
/// and a tilt (the maps' zero and alignment, free), by least squares.
pub fn fit_ratio(
    pixels: &[Pixel],
    pixel_mm: f64,
    predicted: &[f64],
    measured: &[f64],
) -> Result<RatioFit, SpatialError> {
    let jacobian: Vec<Vec<f64>> = pixels
        .iter()
        .zip(predicted)
        .map(|(p, &g)| vec![g, 1.0, p.column as f64 * pixel_mm, p.row as f64 * pixel_mm])
        .collect();
    if pixels.len() <= 4 {
        return Err(SpatialError::TooFewPixels {
            pixels: pixels.len(),
            parameters: 4,
        });
    }
    let inverse = invert(&normal_matrix(&jacobian)).ok_or(SpatialError::Singular)?;
    let projected: Vec<f64> = (0..4)
        .map(|k| {
            jacobian
                .iter()
                .zip(measured)
                .map(|(row, m)| row[k] * m)
                .sum()
        })
        .collect();
    let beta: Vec<f64> = inverse
        .iter()
        .map(|row| row.iter().zip(&projected).map(|(a, b)| a * b).sum())
        .collect();
    let residual: Vec<f64> = jacobian
        .iter()
        .zip(measured)
        .map(|(row, m)| m - row.iter().zip(&beta).map(|(j, b)| j * b).sum::<f64>())
        .collect();
    let n = residual.len();
    let sum_of_squares: f64 = residual.iter().map(|e| e * e).sum();
    let sandwich = Sandwich::new(pixels, &influence(&inverse[..1], &jacobian), &residual);
    let dof = lost_freedom(n, 4);
    Ok(RatioFit {
        ratio: beta[0],
        standard_error: (dof * sandwich.variance(0)).sqrt(),
        independent_standard_error: (sum_of_squares / (n - 4) as f64 * inverse[0][0]).sqrt(),
        piston_nm: beta[1],
        tilt_nm_per_mm: (beta[2], beta[3]),
        residual_rms_nm: (sum_of_squares / n as f64).sqrt(),
        bandwidth_px: sandwich.bandwidth_px,
    })
}
