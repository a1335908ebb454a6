//! Linear 2-D convolution and correlation on a lattice, by FFT.
//!
//! Images live on an nx × ny lattice (row-major, `nx` per row). A kernel K is given on a box of
//! offsets [di0, di0 + kw) × [dj0, dj0 + kh); the convolution of an image T is
//! (K ⊛ T)[i, j] = Σ T[i − di, j − dj]·K[di, dj], kept on the lattice. Both are embedded in
//! a periodic P_x × P_y grid with P_x ≥ nx + kw − 1 and P_y ≥ ny + kh − 1 (the next sizes
//! of the form 2^a·3^b·5^c·7^d, which rustfft does fastest), so the circular convolution's
//! wrap-around never reaches the lattice: the result is the linear one, to rounding (a
//! relative error of a few 1e-16 times log₂ of the size, on the largest values).
//!
//! The correlation Kᵀ·Y (the adjoint: (Kᵀ Y)[i, j] = Σ Y[i + di, j + dj]·K[di, dj]) uses the
//! conjugate spectrum, since K is real. The 2-D transform runs the rows in parallel, then
//! the columns (transposed, in parallel); spectra stay in that transposed layout, which only
//! the products and the inverse read.

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

/// A kernel on a box of offsets: value (di0 + a, dj0 + b) at `values[b·width + a]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Kernel {
    pub di0: isize,
    pub dj0: isize,
    pub width: usize,
    pub height: usize,
    pub values: Vec<f64>,
}

impl Kernel {
    /// The value at offset (di, dj), 0 outside the box.
    pub fn at(&self, di: isize, dj: isize) -> f64 {
        let (a, b) = (di - self.di0, dj - self.dj0);
        if a < 0 || b < 0 || a >= self.width as isize || b >= self.height as isize {
            0.0
        } else {
            self.values[b as usize * self.width + a as usize]
        }
    }

    /// The entries a product with this kernel reads: width × height.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
}

/// The transforms for one lattice and the largest kernel box it will convolve with.
pub struct Convolution {
    nx: usize,
    ny: usize,
    px: usize,
    py: usize,
    rows: Arc<dyn Fft<f64>>,
    cols: Arc<dyn Fft<f64>>,
    rows_inverse: Arc<dyn Fft<f64>>,
    cols_inverse: Arc<dyn Fft<f64>>,
}

impl std::fmt::Debug for Convolution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Convolution({}×{} in {}×{})",
            self.nx, self.ny, self.px, self.py
        )
    }
}

/// The smallest n' ≥ n of the form 2^a·3^b·5^c·7^d.
pub fn fast_size(n: usize) -> usize {
    (n.max(1)..)
        .find(|&m| {
            let mut k = m;
            for p in [2, 3, 5, 7] {
                while k % p == 0 {
                    k /= p;
                }
            }
            k == 1
        })
        .expect("some size above n is smooth")
}

impl Convolution {
    /// Transforms for an `nx` × `ny` lattice and kernels of at most `kw` × `kh` offsets.
    pub fn new(nx: usize, ny: usize, kw: usize, kh: usize) -> Convolution {
        let (px, py) = (fast_size(nx + kw - 1), fast_size(ny + kh - 1));
        let mut planner = FftPlanner::new();
        Convolution {
            nx,
            ny,
            px,
            py,
            rows: planner.plan_fft_forward(px),
            cols: planner.plan_fft_forward(py),
            rows_inverse: planner.plan_fft_inverse(px),
            cols_inverse: planner.plan_fft_inverse(py),
        }
    }

    /// The periodic grid's size, (P_x, P_y).
    pub fn padded(&self) -> (usize, usize) {
        (self.px, self.py)
    }

    /// About the floating-point work of one transform, for choosing between it and a direct
    /// sum: 5·P·log₂P for P = P_x·P_y.
    pub fn transform_cost(&self) -> f64 {
        let p = (self.px * self.py) as f64;
        5.0 * p * p.log2()
    }

    fn transform(&self, grid: &mut [Complex<f64>], inverse: bool) {
        let (px, py) = (self.px, self.py);
        let (rows, cols) = if inverse {
            (&self.rows_inverse, &self.cols_inverse)
        } else {
            (&self.rows, &self.cols)
        };
        let run = |fft: &Arc<dyn Fft<f64>>, data: &mut [Complex<f64>], n: usize| {
            data.par_chunks_mut(n * 16).for_each_init(
                || vec![Complex::default(); fft.get_inplace_scratch_len()],
                |scratch, chunk| fft.process_with_scratch(chunk, scratch),
            );
        };
        let mut transposed = vec![Complex::default(); px * py];
        if !inverse {
            run(rows, grid, px);
            transpose(grid, &mut transposed, px, py);
            run(cols, &mut transposed, py);
            grid.copy_from_slice(&transposed);
        } else {
            run(cols, grid, py);
            transpose(grid, &mut transposed, py, px);
            run(rows, &mut transposed, px);
            grid.copy_from_slice(&transposed);
        }
    }

    /// The spectrum of `kernel`, in the transposed layout (its conjugate is the correlation's).
    pub fn kernel_spectrum(&self, kernel: &Kernel) -> Vec<Complex<f64>> {
        let (px, py) = (self.px, self.py);
        let mut grid = vec![Complex::default(); px * py];
        for b in 0..kernel.height {
            let dj = (kernel.dj0 + b as isize).rem_euclid(py as isize) as usize;
            for a in 0..kernel.width {
                let di = (kernel.di0 + a as isize).rem_euclid(px as isize) as usize;
                grid[dj * px + di].re += kernel.values[b * kernel.width + a];
            }
        }
        self.transform(&mut grid, false);
        grid
    }

    /// The spectrum of a lattice image (nx × ny, row-major).
    pub fn image_spectrum(&self, image: &[f64]) -> Vec<Complex<f64>> {
        let mut grid = vec![Complex::default(); self.px * self.py];
        for (j, row) in image.chunks(self.nx).enumerate() {
            for (i, &v) in row.iter().enumerate() {
                grid[j * self.px + i].re = v;
            }
        }
        self.transform(&mut grid, false);
        grid
    }

    /// The lattice image whose spectrum is `spectrum` (consumed), rounding's imaginary part
    /// dropped.
    pub fn image(&self, mut spectrum: Vec<Complex<f64>>) -> Vec<f64> {
        self.transform(&mut spectrum, true);
        let scale = 1.0 / (self.px * self.py) as f64;
        let mut image = Vec::with_capacity(self.nx * self.ny);
        for j in 0..self.ny {
            image.extend(
                spectrum[j * self.px..j * self.px + self.nx]
                    .iter()
                    .map(|c| c.re * scale),
            );
        }
        image
    }
}

/// `to` = `from`ᵀ for `from` of `rows` rows of `width`.
fn transpose(from: &[Complex<f64>], to: &mut [Complex<f64>], width: usize, rows: usize) {
    const BLOCK: usize = 32;
    for r0 in (0..rows).step_by(BLOCK) {
        for c0 in (0..width).step_by(BLOCK) {
            for r in r0..(r0 + BLOCK).min(rows) {
                for c in c0..(c0 + BLOCK).min(width) {
                    to[c * rows + r] = from[r * width + c];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn direct(kernel: &Kernel, image: &[f64], nx: usize, ny: usize) -> Vec<f64> {
        let mut out = vec![0.0; nx * ny];
        for j in 0..ny as isize {
            for i in 0..nx as isize {
                let mut sum = 0.0;
                for sj in 0..ny as isize {
                    for si in 0..nx as isize {
                        sum += image[(sj * nx as isize + si) as usize] * kernel.at(i - si, j - sj);
                    }
                }
                out[(j * nx as isize + i) as usize] = sum;
            }
        }
        out
    }

    #[test]
    fn the_transform_convolves_and_correlates_as_the_direct_sums() {
        let (nx, ny) = (13, 9);
        let kernel = Kernel {
            di0: -3,
            dj0: -1,
            width: 6,
            height: 4,
            values: (0..24).map(|k| ((k * 37) % 11) as f64 - 3.0).collect(),
        };
        let image: Vec<f64> = (0..nx * ny)
            .map(|k| ((k * 53) % 17) as f64 * 0.25)
            .collect();
        let conv = Convolution::new(nx, ny, kernel.width, kernel.height);
        let spectrum = conv.kernel_spectrum(&kernel);
        let mut product = conv.image_spectrum(&image);
        for (p, k) in product.iter_mut().zip(&spectrum) {
            *p *= k;
        }
        let fast = conv.image(product);
        let slow = direct(&kernel, &image, nx, ny);
        let scale = slow.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for (a, b) in fast.iter().zip(&slow) {
            assert!((a - b).abs() < 1e-12 * scale, "{a} vs {b}");
        }
        // The adjoint: ⟨K ⊛ T, Y⟩ = ⟨T, Kᵀ Y⟩ with Kᵀ by the conjugate spectrum.
        let y: Vec<f64> = (0..nx * ny).map(|k| ((k * 29) % 7) as f64 - 2.0).collect();
        let mut product = conv.image_spectrum(&y);
        for (p, k) in product.iter_mut().zip(&spectrum) {
            *p *= k.conj();
        }
        let adjoint = conv.image(product);
        let lhs: f64 = slow.iter().zip(&y).map(|(a, b)| a * b).sum();
        let rhs: f64 = image.iter().zip(&adjoint).map(|(a, b)| a * b).sum();
        assert!(
            (lhs - rhs).abs() < 1e-10 * lhs.abs().max(1.0),
            "{lhs} vs {rhs}"
        );
    }

    #[test]
    fn fast_sizes_are_smooth_and_least() {
        assert_eq!(fast_size(1), 1);
        assert_eq!(fast_size(11), 12);
        assert_eq!(fast_size(97), 98);
        assert_eq!(fast_size(1021), 1024);
        assert_eq!(fast_size(1101), 1120);
    }
}
