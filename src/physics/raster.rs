//! The raster motion of an X-Y machine and the exact removal it leaves.
//!
//! # The motion
//!
//! The tool's centre visits dwell points p_0, …, p_{n−1} (pixels of the map's lattice) in
//! path order: a serpentine over the rows of a regular grid of points (each row run the
//! other way from the one before), or an order given. Along the polyline through them, with
//! arc length s_k at p_k, it is the one motion of [`super::motion`] with stations at s_k:
//! each point owns the cell between the midpoints of the legs to its neighbours, and its dwell
//! t_k is spent
//!
//! ```text
//! standing at p_k for σ_k·t_k, and crossing the cell at constant speed in w_k·t_k
//! ```
//!
//! (σ = w = ½ at the path's two ends, σ = 0 and w = 1 inside; a lone point stands for its
//! whole dwell). A cell is two straight half-legs, m_{k−1} → p_k → m_k, crossed at the one
//! speed L_k/(w_k·t_k) for the cell's length L_k; the half-legs are the executed blocks (a
//! stop's block stands still), and on a corner of the path (a serpentine's turn to the next
//! row) the two halves run along different axes.
//!
//! # The removal, exactly
//!
//! With the tool's influence function f (nm/s at offsets from its centre, bilinear between
//! samples: [`super::influence`]), the removal at a point q is
//!
//! ```text
//! Z(q) = Σ_k t_k·[ σ_k·f(q − p_k) + Σ_{legs ℓ of k} (w_k·|ℓ|/L_k)·∫₀¹ f(q − p_k − u·ℓ) du ]
//! ```
//!
//! with ℓ the half-leg vectors from p_k to its cell's ends: each line integral exact for the
//! bilinear f (Simpson on the pieces between grid crossings). So column k of the operator
//! (the removal per second of dwell at p_k, on the lattice's pixels) depends only on the
//! pixel offsets from p_k and on the cell's **shape**: its half-legs and its stop share. Every
//! inner point of a serpentine row has one shape (its two half-legs ±ℓ along the row), the
//! turns and the two ends a handful more; the operator holds one kernel per shape and is a sum
//! of convolutions,
//!
//! ```text
//! M·t = Σ_shapes K_shape ⊛ T_shape      (T_shape: the dwell of that shape's points, on the lattice)
//! ```
//!
//! each taken by FFT where that is cheaper than the direct sum of its columns
//! ([`super::convolution`]), else column by column. Both give the same entries: the
//! prediction is exact for the motion and the interpolated f, to rounding.

use rayon::prelude::*;
use rustfft::num_complex::Complex;

use super::convolution::{Convolution, Kernel};
use super::influence::Influence;
use super::motion::Motion;

/// A map's pixel lattice: pixel (i, j) at (x0 + i·h, y0 − j·h), mm (rows top first, as maps
/// are).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattice {
    pub nx: usize,
    pub ny: usize,
    pub pitch_mm: f64,
    pub x0_mm: f64,
    pub y0_mm: f64,
}

impl Lattice {
    pub fn x_mm(&self, i: usize) -> f64 {
        self.x0_mm + i as f64 * self.pitch_mm
    }

    pub fn y_mm(&self, j: usize) -> f64 {
        self.y0_mm - j as f64 * self.pitch_mm
    }

    pub fn pixels(&self) -> usize {
        self.nx * self.ny
    }

    /// Pixel (i, j)'s place in a row-major image.
    pub fn index(&self, [i, j]: [usize; 2]) -> usize {
        j * self.nx + i
    }
}

/// Why dwell points do not make a raster.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RasterError {
    #[error("a raster needs at least one dwell point")]
    Empty,
    #[error("dwell point {point} at pixel ({i}, {j}) is off the {nx} × {ny} lattice")]
    OffLattice {
        point: usize,
        i: usize,
        j: usize,
        nx: usize,
        ny: usize,
    },
    #[error("dwell points {point} and {next} are the same point: a path moves between points")]
    Repeated { point: usize, next: usize },
}

/// The cell of a dwell point: the pixel vectors to its neighbours (each twice a half-leg,
/// so they stay whole) in a canonical order, and its stop share. The key of a kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
struct Shape {
    legs: [Option<[i64; 2]>; 2],
    /// σ in halves: 0 inside, 1 at an end, 2 for a lone point.
    stop_halves: u8,
}

/// One constant-velocity block of the executed motion: the tool's centre from `from_mm` to
/// `to_mm` (equal for a stop) in `duration_s`, spending point `point`'s dwell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    pub point: usize,
    pub from_mm: [f64; 2],
    pub to_mm: [f64; 2],
    pub duration_s: f64,
}

/// A tool path: points in the plane (mm) in path order, and the motion along it (stations at
/// the points' arc lengths). What a program executes; a [`Raster`] is one on a lattice.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    points_mm: Vec<[f64; 2]>,
    motion: Motion,
}

impl Path {
    /// The path through `points_mm` in the order given (finite; no point twice in a row).
    pub fn through(points_mm: Vec<[f64; 2]>) -> Result<Path, RasterError> {
        let along = arc_lengths(&points_mm, dist)?;
        Ok(Path {
            points_mm,
            motion: Motion::radial(along),
        })
    }

    pub fn len(&self) -> usize {
        self.points_mm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points_mm.is_empty()
    }

    pub fn points_mm(&self) -> &[[f64; 2]] {
        &self.points_mm
    }

    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// The executed motion for dwell `dwell_s` (one per point, ≥ 0): the stop at the first
    /// point, each cell's two half-legs, the stop at the last (blocks of 0 s included, so the
    /// blocks of a plan are the same for every dwell).
    pub fn blocks(&self, dwell_s: &[f64]) -> Vec<Block> {
        let n = self.len();
        let motion = &self.motion;
        let point = |k: usize| self.points_mm[k];
        let mut blocks = Vec::with_capacity(2 * n + 2);
        let stop = |k: usize| Block {
            point: k,
            from_mm: point(k),
            to_mm: point(k),
            duration_s: motion.stop_share(k) * dwell_s[k],
        };
        if n == 1 {
            return vec![stop(0)];
        }
        blocks.push(stop(0));
        let mid = |a: usize, b: usize| {
            let (p, q) = (point(a), point(b));
            [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])]
        };
        for (k, &dwell) in dwell_s.iter().enumerate().take(n) {
            let p = point(k);
            let start = if k > 0 { mid(k - 1, k) } else { p };
            let end = if k + 1 < n { mid(k, k + 1) } else { p };
            let (a, b) = (dist(start, p), dist(p, end));
            let time = motion.move_share(k) * dwell;
            for (from, to, len) in [(start, p, a), (p, end, b)] {
                if len > 0.0 {
                    blocks.push(Block {
                        point: k,
                        from_mm: from,
                        to_mm: to,
                        duration_s: time * len / (a + b),
                    });
                }
            }
        }
        blocks.push(stop(n - 1));
        blocks
    }
}

/// The arc length at each point of a path (`step` the length between neighbours), refusing
/// an empty path and a point repeated in a row.
fn arc_lengths<P: Copy + PartialEq>(
    points: &[P],
    step: impl Fn(P, P) -> f64,
) -> Result<Vec<f64>, RasterError> {
    if points.is_empty() {
        return Err(RasterError::Empty);
    }
    let mut along = Vec::with_capacity(points.len());
    let mut s = 0.0;
    for (k, &p) in points.iter().enumerate() {
        if k > 0 {
            let q = points[k - 1];
            if q == p {
                return Err(RasterError::Repeated {
                    point: k - 1,
                    next: k,
                });
            }
            s += step(q, p);
        }
        along.push(s);
    }
    Ok(along)
}

/// The raster: dwell points on a lattice in path order, and the path through them.
#[derive(Debug, Clone, PartialEq)]
pub struct Raster {
    lattice: Lattice,
    points: Vec<[usize; 2]>,
    path: Path,
}

impl Raster {
    /// The raster through `points` (pixels of `lattice`) in the order given.
    pub fn along(lattice: Lattice, points: Vec<[usize; 2]>) -> Result<Raster, RasterError> {
        for (point, &[i, j]) in points.iter().enumerate() {
            if i >= lattice.nx || j >= lattice.ny {
                return Err(RasterError::OffLattice {
                    point,
                    i,
                    j,
                    nx: lattice.nx,
                    ny: lattice.ny,
                });
            }
        }
        // Arc lengths from whole pixel steps, so that equal steps are equal to the last bit.
        let along = arc_lengths(&points, |q, p| {
            let (di, dj) = (p[0] as f64 - q[0] as f64, p[1] as f64 - q[1] as f64);
            di.hypot(dj) * lattice.pitch_mm
        })?;
        let points_mm = points
            .iter()
            .map(|&[i, j]| [lattice.x_mm(i), lattice.y_mm(j)])
            .collect();
        Ok(Raster {
            lattice,
            points,
            path: Path {
                points_mm,
                motion: Motion::radial(along),
            },
        })
    }

    /// The serpentine over the rows of `grid` (rows top first; row b holds the points
    /// `present[b·columns + a]`, run left to right, the next row with points right to left,
    /// and so on).
    pub fn serpentine(lattice: Lattice, grid: &PointGrid) -> Result<Raster, RasterError> {
        let mut points = Vec::new();
        let mut forward = true;
        for b in 0..grid.rows {
            let row: Vec<[usize; 2]> = (0..grid.columns)
                .filter(|&a| grid.present[b * grid.columns + a])
                .map(|a| grid.pixel(a, b))
                .collect();
            if row.is_empty() {
                continue;
            }
            if forward {
                points.extend(row);
            } else {
                points.extend(row.into_iter().rev());
            }
            forward = !forward;
        }
        Raster::along(lattice, points)
    }

    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// The dwell points' pixels, in path order.
    pub fn points(&self) -> &[[usize; 2]] {
        &self.points
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The motion along the path (stations at the points' arc lengths, mm).
    pub fn motion(&self) -> &Motion {
        self.path.motion()
    }

    /// The path through the points, mm.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The pixel vector from point k to point `other`.
    fn step(&self, k: usize, other: usize) -> [i64; 2] {
        let (p, q) = (self.points[k], self.points[other]);
        [q[0] as i64 - p[0] as i64, q[1] as i64 - p[1] as i64]
    }

    fn shape(&self, k: usize) -> Shape {
        let n = self.len();
        let before = (k > 0).then(|| self.step(k, k - 1));
        let after = (k + 1 < n).then(|| self.step(k, k + 1));
        // Crossing a cell one way or the other removes alike: the legs' order is canonical.
        let legs = if before <= after {
            [before, after]
        } else {
            [after, before]
        };
        let stop_halves = (2.0 * self.motion().stop_share(k)).round() as u8;
        Shape { legs, stop_halves }
    }

    /// The executed motion for dwell `dwell_s` ([`Path::blocks`]).
    pub fn blocks(&self, dwell_s: &[f64]) -> Vec<Block> {
        self.path.blocks(dwell_s)
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}

/// A regular grid of dwell points on a lattice: point (a, b) at pixel (i0 + a·step,
/// j0 + b·step), those with `present` set (row-major, `columns` per row).
#[derive(Debug, Clone, PartialEq)]
pub struct PointGrid {
    pub i0: usize,
    pub j0: usize,
    pub step: usize,
    pub columns: usize,
    pub rows: usize,
    pub present: Vec<bool>,
}

impl PointGrid {
    pub fn pixel(&self, a: usize, b: usize) -> [usize; 2] {
        [self.i0 + a * self.step, self.j0 + b * self.step]
    }
}

/// One shape's kernel and its points, summed by FFT or point by point.
struct Class {
    kernel: Kernel,
    members: Vec<usize>,
    spectrum: Option<Vec<Complex<f64>>>,
}

/// M: dwell at the raster's points (s) → removal on the lattice's pixels (nm), exact for the
/// motion and the influence function (module docs).
pub struct RasterOperator {
    lattice: Lattice,
    /// Each point's pixel index in a lattice image.
    pixel: Vec<usize>,
    points: Vec<[usize; 2]>,
    classes: Vec<Class>,
    /// Each point's class.
    class_of: Vec<usize>,
    convolution: Option<Convolution>,
}

impl std::fmt::Debug for RasterOperator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "RasterOperator({} points, {} shapes, {:?})",
            self.points.len(),
            self.classes.len(),
            self.convolution
        )
    }
}

impl RasterOperator {
    /// The operator of `raster`'s motion under `influence`.
    pub fn new(raster: &Raster, influence: &Influence) -> RasterOperator {
        // A shape is summed by FFT when its columns' direct sum costs more than a transform.
        Self::build(raster, influence, |kernel, members, transform_cost| {
            (kernel.len() * members) as f64 > transform_cost
        })
    }

    /// The operator, each shape summed by FFT where `by_fft(kernel, points, transform cost)`.
    fn build(
        raster: &Raster,
        influence: &Influence,
        by_fft: impl Fn(&Kernel, usize, f64) -> bool,
    ) -> RasterOperator {
        let lattice = *raster.lattice();
        let mut shapes: Vec<(Shape, Vec<usize>)> = Vec::new();
        let mut keyed = std::collections::BTreeMap::new();
        for k in 0..raster.len() {
            let shape = raster.shape(k);
            let slot = *keyed.entry(shape).or_insert_with(|| {
                shapes.push((shape, Vec::new()));
                shapes.len() - 1
            });
            shapes[slot].1.push(k);
        }
        let kernels: Vec<Kernel> = shapes
            .par_iter()
            .map(|(shape, _)| kernel(shape, influence, lattice.pitch_mm))
            .collect();
        let cost = Convolution::new(lattice.nx, lattice.ny, 1, 1).transform_cost();
        let by_fft: Vec<bool> = kernels
            .iter()
            .zip(&shapes)
            .map(|(k, (_, members))| by_fft(k, members.len(), cost))
            .collect();
        let convolution = by_fft.iter().any(|&f| f).then(|| {
            let (kw, kh) = kernels
                .iter()
                .zip(&by_fft)
                .filter(|(_, &f)| f)
                .fold((1, 1), |(w, h), (k, _)| (w.max(k.width), h.max(k.height)));
            Convolution::new(lattice.nx, lattice.ny, kw, kh)
        });
        let classes: Vec<Class> = kernels
            .into_iter()
            .zip(shapes)
            .zip(by_fft)
            .map(|((kernel, (_, members)), fft)| {
                let spectrum = match (&convolution, fft) {
                    (Some(c), true) => Some(c.kernel_spectrum(&kernel)),
                    _ => None,
                };
                Class {
                    kernel,
                    members,
                    spectrum,
                }
            })
            .collect();
        let mut class_of = vec![0; raster.len()];
        for (c, class) in classes.iter().enumerate() {
            for &k in &class.members {
                class_of[k] = c;
            }
        }
        RasterOperator {
            lattice,
            pixel: raster.points().iter().map(|&p| lattice.index(p)).collect(),
            points: raster.points().to_vec(),
            classes,
            class_of,
            convolution,
        }
    }

    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// The number of pixels (rows).
    pub fn rows(&self) -> usize {
        self.lattice.pixels()
    }

    /// The number of dwell points (columns).
    pub fn cols(&self) -> usize {
        self.points.len()
    }

    /// The distinct cell shapes, and how many of them are summed by FFT.
    pub fn shapes(&self) -> (usize, usize) {
        let fft = self.classes.iter().filter(|c| c.spectrum.is_some()).count();
        (self.classes.len(), fft)
    }

    /// The kernel placed at point k, cut to the lattice: for each of its rows on the lattice,
    /// (the first pixel's index, the kernel's entries from there), consecutive pixels of one
    /// lattice row.
    fn footprint<'a>(
        &'a self,
        kernel: &'a Kernel,
        k: usize,
    ) -> impl Iterator<Item = (usize, &'a [f64])> + 'a {
        let [pi, pj] = self.points[k];
        let (nx, ny) = (self.lattice.nx as isize, self.lattice.ny as isize);
        let left = pi as isize + kernel.di0;
        let (a0, a1) = ((-left).max(0), (nx - left).min(kernel.width as isize));
        (0..kernel.height).filter_map(move |b| {
            let j = pj as isize + kernel.dj0 + b as isize;
            ((0..ny).contains(&j) && a0 < a1).then(|| {
                let row = &kernel.values[b * kernel.width..(b + 1) * kernel.width];
                (
                    (j * nx + left + a0) as usize,
                    &row[a0 as usize..a1 as usize],
                )
            })
        })
    }

    /// Column k's entries on the lattice, one run of consecutive pixels per kernel row, each
    /// given to `visit` as (first pixel, entries).
    pub fn column_runs(&self, k: usize, visit: &mut dyn FnMut(usize, &[f64])) {
        for (first, values) in self.footprint(&self.classes[self.class_of[k]].kernel, k) {
            visit(first, values);
        }
    }

    /// M·t: the removal of dwell `dwell_s` on the lattice's pixels, nm.
    pub fn apply(&self, dwell_s: &[f64]) -> Vec<f64> {
        let mut removal = match &self.convolution {
            Some(conv) => {
                let mut total: Option<Vec<Complex<f64>>> = None;
                for class in &self.classes {
                    let Some(spectrum) = &class.spectrum else {
                        continue;
                    };
                    let mut image = vec![0.0; self.rows()];
                    for &k in &class.members {
                        image[self.pixel[k]] = dwell_s[k];
                    }
                    let mut product = conv.image_spectrum(&image);
                    product
                        .par_iter_mut()
                        .zip(spectrum.par_iter())
                        .for_each(|(p, s)| *p *= s);
                    match &mut total {
                        None => total = Some(product),
                        Some(t) => t.par_iter_mut().zip(&product).for_each(|(a, b)| *a += b),
                    }
                }
                conv.image(total.expect("some shape is summed by FFT"))
            }
            None => vec![0.0; self.rows()],
        };
        for class in self.classes.iter().filter(|c| c.spectrum.is_none()) {
            for &k in &class.members {
                let t = dwell_s[k];
                if t != 0.0 {
                    for (first, values) in self.footprint(&class.kernel, k) {
                        for (r, v) in removal[first..first + values.len()].iter_mut().zip(values) {
                            *r += t * v;
                        }
                    }
                }
            }
        }
        removal
    }

    /// Mᵀ·y: for each point, Σ over pixels of y times its column.
    pub fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.cols()];
        if let Some(conv) = &self.convolution {
            let spectrum_y = conv.image_spectrum(y);
            for class in &self.classes {
                let Some(spectrum) = &class.spectrum else {
                    continue;
                };
                let product: Vec<Complex<f64>> = spectrum_y
                    .par_iter()
                    .zip(spectrum.par_iter())
                    .map(|(a, s)| a * s.conj())
                    .collect();
                let image = conv.image(product);
                for &k in &class.members {
                    out[k] = image[self.pixel[k]];
                }
            }
        }
        self.direct_columns(|k, kernel| {
            self.footprint(kernel, k)
                .map(|(first, values)| dot(&y[first..first + values.len()], values))
                .sum()
        })
        .into_iter()
        .for_each(|(k, v)| out[k] = v);
        out
    }

    /// Σ_i w_i·M_ik² for each point: the diagonal of Mᵀ·W·M.
    pub fn weighted_column_norms(&self, weights: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.cols()];
        if let Some(conv) = &self.convolution {
            let spectrum_w = conv.image_spectrum(weights);
            for class in self.classes.iter().filter(|c| c.spectrum.is_some()) {
                let squared = Kernel {
                    values: class.kernel.values.iter().map(|v| v * v).collect(),
                    ..class.kernel.clone()
                };
                let spectrum = conv.kernel_spectrum(&squared);
                let product: Vec<Complex<f64>> = spectrum_w
                    .iter()
                    .zip(&spectrum)
                    .map(|(a, s)| a * s.conj())
                    .collect();
                let image = conv.image(product);
                for &k in &class.members {
                    out[k] = image[self.pixel[k]].max(0.0);
                }
            }
        }
        self.direct_columns(|k, kernel| {
            self.footprint(kernel, k)
                .map(|(first, values)| {
                    let w = &weights[first..first + values.len()];
                    w.iter().zip(values).map(|(w, v)| w * v * v).sum::<f64>()
                })
                .sum()
        })
        .into_iter()
        .for_each(|(k, v)| out[k] = v);
        out
    }

    /// `read(k, kernel)` for every point whose shape is summed column by column, in parallel.
    fn direct_columns(&self, read: impl Fn(usize, &Kernel) -> f64 + Sync) -> Vec<(usize, f64)> {
        self.classes
            .iter()
            .filter(|c| c.spectrum.is_none())
            .flat_map(|c| c.members.iter().map(move |&k| (k, &c.kernel)))
            .collect::<Vec<_>>()
            .par_iter()
            .map(|&(k, kernel)| (k, read(k, kernel)))
            .collect()
    }
}

/// Σ a_i·b_i in four running sums, so the loop vectorises.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            acc[l] += x[l] * y[l];
        }
    }
    acc.iter().sum::<f64>() + tail
}

/// The removal per second of dwell of a point of `shape`, at pixel offsets from it (lattice
/// pitch `pitch_mm`, rows downwards): σ·f(q) + Σ_legs share·(mean of f along the leg).
fn kernel(shape: &Shape, influence: &Influence, pitch_mm: f64) -> Kernel {
    let h = pitch_mm;
    // Half-leg vectors in mm (x right, y up; a pixel row down is −y).
    let legs: Vec<[f64; 2]> = shape
        .legs
        .iter()
        .flatten()
        .map(|&[di, dj]| [0.5 * di as f64 * h, -0.5 * dj as f64 * h])
        .collect();
    let lengths: Vec<f64> = legs.iter().map(|l| l[0].hypot(l[1])).collect();
    let total: f64 = lengths.iter().sum();
    let sigma = shape.stop_halves as f64 / 2.0;
    let moving = 1.0 - sigma;
    // The offsets where the kernel may be non-zero: the support shifted along every leg.
    let ([xlo, xhi], [ylo, yhi]) = influence.support_mm();
    let (mut ax, mut bx, mut ay, mut by) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    for l in &legs {
        ax = ax.min(l[0]);
        bx = bx.max(l[0]);
        ay = ay.min(l[1]);
        by = by.max(l[1]);
    }
    // q − c ∈ support for c on a leg: q_x ∈ (xlo + ax, xhi + bx); rows: dj = −q_y/h.
    let di0 = ((xlo + ax) / h).floor() as isize;
    let di1 = ((xhi + bx) / h).ceil() as isize;
    let dj0 = (-(yhi + by) / h).floor() as isize;
    let dj1 = (-(ylo + ay) / h).ceil() as isize;
    let (width, height) = ((di1 - di0 + 1) as usize, (dj1 - dj0 + 1) as usize);
    let values: Vec<f64> = (0..width * height)
        .into_par_iter()
        .map(|idx| {
            let (a, b) = (idx % width, idx / width);
            let q = [
                (di0 + a as isize) as f64 * h,
                -((dj0 + b as isize) as f64) * h,
            ];
            let mut v = sigma * influence.at(q[0], q[1]);
            for (l, len) in legs.iter().zip(&lengths) {
                if *len > 0.0 {
                    // The pad centre at u·ℓ: the rate at q − u·ℓ.
                    v += moving * len / total * influence.mean_along(q, [q[0] - l[0], q[1] - l[1]]);
                }
            }
            v
        })
        .collect();
    Kernel {
        di0,
        dj0,
        width,
        height,
        values,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gaussian(pitch: f64, sigma: f64, n: usize, shift: [f64; 2]) -> Influence {
        let half = (n as f64 - 1.0) / 2.0;
        let rates = (0..n * n)
            .map(|k| {
                let (x, y) = (
                    (k % n) as f64 - half + shift[0],
                    (k / n) as f64 - half + shift[1],
                );
                5.0 * (-(x * x + y * y) * pitch * pitch / (2.0 * sigma * sigma)).exp()
            })
            .collect();
        Influence::new(n, n, pitch, [-half * pitch, -half * pitch], rates).unwrap()
    }

    /// Each column summed by FFT equals the direct sum of the same kernel (the operator
    /// forced both ways on one raster), and the transpose is the adjoint.
    #[test]
    fn the_fft_and_direct_sums_agree_and_the_transpose_is_the_adjoint() {
        let lattice = Lattice {
            nx: 40,
            ny: 31,
            pitch_mm: 0.5,
            x0_mm: -10.0,
            y0_mm: 7.5,
        };
        let grid = PointGrid {
            i0: 4,
            j0: 3,
            step: 3,
            columns: 11,
            rows: 9,
            present: (0..99).map(|k| k % 17 != 5).collect(),
        };
        let raster = Raster::serpentine(lattice, &grid).unwrap();
        let influence = gaussian(0.3, 1.2, 21, [0.2, -0.1]);
        let op = RasterOperator::build(&raster, &influence, |_, _, _| true);
        let direct = RasterOperator::build(&raster, &influence, |_, _, _| false);
        let dwell: Vec<f64> = (0..raster.len())
            .map(|k| 1.0 + ((k * 31) % 7) as f64)
            .collect();
        let fast = op.apply(&dwell);
        let slow = direct.apply(&dwell);
        let peak = slow.iter().fold(0.0_f64, |m, v| m.max(*v));
        assert_eq!(op.shapes().0, op.shapes().1);
        assert!(op.shapes().0 >= 5, "{:?}", op.shapes());
        for (a, b) in fast.iter().zip(&slow) {
            assert!((a - b).abs() < 1e-12 * peak);
        }
        let y: Vec<f64> = (0..lattice.pixels())
            .map(|k| ((k * 13) % 5) as f64 - 2.0)
            .collect();
        let (at_fast, at_slow) = (op.apply_transpose(&y), direct.apply_transpose(&y));
        for (a, b) in at_fast.iter().zip(&at_slow) {
            assert!((a - b).abs() < 1e-10 * peak.max(1.0));
        }
        let lhs: f64 = slow.iter().zip(&y).map(|(a, b)| a * b).sum();
        let rhs: f64 = dwell.iter().zip(&at_slow).map(|(a, b)| a * b).sum();
        assert!((lhs - rhs).abs() < 1e-10 * lhs.abs());
        let w: Vec<f64> = (0..lattice.pixels()).map(|k| (k % 3) as f64).collect();
        let (n_fast, n_slow) = (
            op.weighted_column_norms(&w),
            direct.weighted_column_norms(&w),
        );
        for (a, b) in n_fast.iter().zip(&n_slow) {
            assert!((a - b).abs() < 1e-9 * b.max(1.0), "{a} vs {b}");
        }
    }

    #[test]
    fn the_blocks_spend_every_second_and_join_end_to_end() {
        let lattice = Lattice {
            nx: 10,
            ny: 10,
            pitch_mm: 1.0,
            x0_mm: 0.0,
            y0_mm: 9.0,
        };
        let grid = PointGrid {
            i0: 1,
            j0: 1,
            step: 2,
            columns: 4,
            rows: 3,
            present: vec![true; 12],
        };
        let raster = Raster::serpentine(lattice, &grid).unwrap();
        // Row 0 left to right, row 1 right to left.
        assert_eq!(raster.points()[3], [7, 1]);
        assert_eq!(raster.points()[4], [7, 3]);
        let dwell: Vec<f64> = (0..12).map(|k| 1.0 + k as f64).collect();
        let blocks = raster.blocks(&dwell);
        let mut spent = [0.0; 12];
        for b in &blocks {
            spent[b.point] += b.duration_s;
        }
        for (s, t) in spent.iter().zip(&dwell) {
            assert!((s - t).abs() < 1e-12);
        }
        for w in blocks.windows(2) {
            assert_eq!(w[0].to_mm, w[1].from_mm);
        }
        assert!(matches!(
            Raster::along(lattice, vec![[1, 1], [1, 1]]),
            Err(RasterError::Repeated { .. })
        ));
        assert!(matches!(
            Raster::along(lattice, vec![[10, 1]]),
            Err(RasterError::OffLattice { .. })
        ));
    }
}
