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
//! conjugate spectrum, since K is real. Every grid is real, so its spectrum is Hermitian and
//! half of it, P_x/2 + 1 frequencies along the rows, holds all of it (realfft): the rows go
//! real-to-complex in parallel, then the columns complex (transposed, in parallel), about half
//! the work of a complex transform. Spectra stay in that transposed half layout, which only the
//! products and the inverse read; a product of two half spectra is the half spectrum of the
//! product, so convolution and correlation are unchanged.

use std::sync::Arc;

use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
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
    /// P_x/2 + 1: the half spectrum a real row has.
    hx: usize,
    rows: Arc<dyn RealToComplex<f64>>,
    rows_inverse: Arc<dyn ComplexToReal<f64>>,
    cols: Arc<dyn Fft<f64>>,
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
        let mut real = RealFftPlanner::new();
        let mut complex = FftPlanner::new();
        Convolution {
            nx,
            ny,
            px,
            py,
            hx: px / 2 + 1,
            rows: real.plan_fft_forward(px),
            rows_inverse: real.plan_fft_inverse(px),
            cols: complex.plan_fft_forward(py),
            cols_inverse: complex.plan_fft_inverse(py),
        }
    }

    /// The periodic grid's size, (P_x, P_y).
    pub fn padded(&self) -> (usize, usize) {
        (self.px, self.py)
    }

    /// About the floating-point work of one transform, for choosing between it and a direct
    /// sum: 2.5·P·log₂P for P = P_x·P_y (half a complex transform's 5·P·log₂P, the input
    /// being real).
    pub fn transform_cost(&self) -> f64 {
        let p = (self.px * self.py) as f64;
        2.5 * p * p.log2()
    }

    /// The half spectrum of a real P_x × P_y grid (row-major), in the transposed layout:
    /// frequency (a, b) at `a·P_y + b`, a < P_x/2 + 1.
    fn forward(&self, mut grid: Vec<f64>) -> Vec<Complex<f64>> {
        let (px, py, hx) = (self.px, self.py, self.hx);
        let mut half = vec![Complex::default(); hx * py];
        grid.par_chunks_mut(px)
            .zip(half.par_chunks_mut(hx))
            .for_each_init(
                || self.rows.make_scratch_vec(),
                |scratch, (row, out)| {
                    self.rows
                        .process_with_scratch(row, out, scratch)
                        .expect("the rows' lengths are the plan's");
                },
            );
        let mut spectrum = vec![Complex::default(); hx * py];
        transpose(&half, &mut spectrum, hx, py);
        self.columns(&self.cols, &mut spectrum);
        spectrum
    }

    /// The real P_x × P_y grid whose half spectrum is `spectrum` (consumed), unscaled.
    fn inverse(&self, mut spectrum: Vec<Complex<f64>>) -> Vec<f64> {
        let (px, py, hx) = (self.px, self.py, self.hx);
        self.columns(&self.cols_inverse, &mut spectrum);
        let mut half = vec![Complex::default(); hx * py];
        transpose(&spectrum, &mut half, py, hx);
        let mut grid = vec![0.0; px * py];
        half.par_chunks_mut(hx)
            .zip(grid.par_chunks_mut(px))
            .for_each_init(
                || self.rows_inverse.make_scratch_vec(),
                |scratch, (row, out)| {
                    // The spectrum of a real grid has real values at frequency 0 (and P_x/2
                    // for even P_x): what rounding left there is dropped.
                    row[0].im = 0.0;
                    if px % 2 == 0 {
                        row[hx - 1].im = 0.0;
                    }
                    self.rows_inverse
                        .process_with_scratch(row, out, scratch)
                        .expect("the rows' lengths are the plan's and their ends real");
                },
            );
        grid
    }

    /// Every column (a row of the transposed layout, P_y long) through `fft`, in parallel.
    fn columns(&self, fft: &Arc<dyn Fft<f64>>, data: &mut [Complex<f64>]) {
        data.par_chunks_mut(self.py * 16).for_each_init(
            || vec![Complex::default(); fft.get_inplace_scratch_len()],
            |scratch, chunk| fft.process_with_scratch(chunk, scratch),
        );
    }

    /// The spectrum of `kernel`, in the transposed layout (its conjugate is the correlation's).
    pub fn kernel_spectrum(&self, kernel: &Kernel) -> Vec<Complex<f64>> {
        let (px, py) = (self.px, self.py);
        let mut grid = vec![0.0; px * py];
        for b in 0..kernel.height {
            let dj = (kernel.dj0 + b as isize).rem_euclid(py as isize) as usize;
            for a in 0..kernel.width {
                let di = (kernel.di0 + a as isize).rem_euclid(px as isize) as usize;
                grid[dj * px + di] += kernel.values[b * kernel.width + a];
            }
        }
        self.forward(grid)
    }

    /// The spectrum of a lattice image (nx × ny, row-major).
    pub fn image_spectrum(&self, image: &[f64]) -> Vec<Complex<f64>> {
        let mut grid = vec![0.0; self.px * self.py];
        for (j, row) in image.chunks(self.nx).enumerate() {
            grid[j * self.px..j * self.px + row.len()].copy_from_slice(row);
        }
        self.forward(grid)
    }

    /// The lattice image whose spectrum is `spectrum` (consumed).
    pub fn image(&self, spectrum: Vec<Complex<f64>>) -> Vec<f64> {
        let grid = self.inverse(spectrum);
        let scale = 1.0 / (self.px * self.py) as f64;
        let mut image = Vec::with_capacity(self.nx * self.ny);
        for j in 0..self.ny {
            image.extend(
                grid[j * self.px..j * self.px + self.nx]
                    .iter()
                    .map(|v| v * scale),
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
