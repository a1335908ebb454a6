//! The power spectral density of a map, its azimuthal average and band-limited RMS.
//!
//! The heights h (nm) over the aperture, 0 elsewhere, are multiplied by a window w and placed
//! in an N × N array, N the larger side of the aperture's box of pixels (rounded up to an even
//! size), pitch p (mm). With F its discrete Fourier transform,
//!
//! ```text
//! PSD(f_x, f_y) = |F(h·w)|² · p² / Σw²      [nm²·mm²],   f on the grid k/(N·p) per mm,
//! ```
//!
//! normalised (Σw² rather than N²) so that Σ PSD·Δf² = Σ(h·w)²/Σw², the window-weighted mean
//! square of h: for a stationary surface the same power whatever the window (prysm's
//! convention, after Heinzel, Rüdiger and Schilling's treatment of FFT scalings). The
//! azimuthal average at f_k = k·Δf, Δf = 1/(N·p), is the mean over the grid frequencies
//! whose |f|/Δf rounds to k, k = 1 … N/2 (to Nyquist). A band's RMS is √(Σ PSD·Δf²) over the
//! grid frequencies with f_low ≤ |f| < f_high.
//!
//! The window is the caller's: [`sidick_window`] for a circular aperture (1 − (ρ)^8 within the
//! normalisation circle: flat over most of the part, rolling to 0 at its edge, so the edge
//! does not ring), [`hann_window`] for a rectangle.

use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

/// Sidick's circular window, w = 1 − ρ⁸ (ρ the distance from the aperture's centre over its
/// normalisation radius; 0 beyond ρ = 1).
pub fn sidick_window(rho: f64) -> f64 {
    if rho >= 1.0 {
        0.0
    } else {
        1.0 - rho.powi(8)
    }
}

/// The separable Hann window at fractional positions u, v ∈ [0, 1] across a rectangle.
pub fn hann_window(u: f64, v: f64) -> f64 {
    let h = |t: f64| {
        if (0.0..=1.0).contains(&t) {
            (std::f64::consts::PI * t).sin().powi(2)
        } else {
            0.0
        }
    };
    h(u) * h(v)
}

/// A map's two-dimensional PSD (module docs).
#[derive(Debug, Clone)]
pub struct Spectrum {
    size: usize,
    pixel_mm: f64,
    /// PSD on the N × N frequency grid, row-major, unshifted (index 0 = zero frequency).
    density: Vec<f64>,
}

impl Spectrum {
    /// The PSD of `values` (windowed heights, nm; `columns × rows`, row-major) at pitch
    /// `pixel_mm`; `window_power` = Σw² over the same pixels. `None` for an empty window.
    pub fn new(
        values: &[f64],
        columns: usize,
        rows: usize,
        pixel_mm: f64,
        window_power: f64,
    ) -> Option<Spectrum> {
        if window_power <= 0.0 || columns == 0 || rows == 0 {
            return None;
        }
        let size = columns.max(rows).div_ceil(2) * 2;
        let mut data = vec![Complex::new(0.0, 0.0); size * size];
        for (r, row) in values.chunks(columns).enumerate() {
            for (c, v) in row.iter().enumerate() {
                data[r * size + c] = Complex::new(*v, 0.0);
            }
        }
        let fft = FftPlanner::new().plan_fft_forward(size);
        data.par_chunks_mut(size).for_each(|row| fft.process(row));
        // Columns: transpose, transform the rows, and leave it transposed (|F|² at (kx, ky)
        // is read back through the symmetry of the grid below).
        let mut transposed = vec![Complex::new(0.0, 0.0); size * size];
        for r in 0..size {
            for c in 0..size {
                transposed[c * size + r] = data[r * size + c];
            }
        }
        transposed
            .par_chunks_mut(size)
            .for_each(|row| fft.process(row));
        let scale = pixel_mm * pixel_mm / window_power;
        let density = transposed.iter().map(|z| z.norm_sqr() * scale).collect();
        Some(Spectrum {
            size,
            pixel_mm,
            density,
        })
    }

    /// Δf, per mm.
    pub fn step_per_mm(&self) -> f64 {
        1.0 / (self.size as f64 * self.pixel_mm)
    }

    /// |f| / Δf at each grid point, with its PSD.
    fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        let n = self.size;
        let signed = move |k: usize| {
            if k <= n / 2 {
                k as f64
            } else {
                k as f64 - n as f64
            }
        };
        self.density.iter().enumerate().map(move |(i, d)| {
            let (a, b) = (signed(i / n), signed(i % n));
            ((a * a + b * b).sqrt(), *d)
        })
    }

    /// The azimuthal average: (f_k per mm, PSD nm²·mm²) for k = 1 … N/2.
    pub fn azimuthal(&self) -> Vec<(f64, f64)> {
        let half = self.size / 2;
        let mut sum = vec![0.0; half + 1];
        let mut count = vec![0usize; half + 1];
        for (k, d) in self.points() {
            let k = k.round() as usize;
            if k <= half {
                sum[k] += d;
                count[k] += 1;
            }
        }
        let step = self.step_per_mm();
        (1..=half)
            .map(|k| (k as f64 * step, sum[k] / count[k].max(1) as f64))
            .collect()
    }

    /// The RMS (nm) of the band f_low ≤ |f| < f_high, per mm.
    pub fn band_rms(&self, low_per_mm: f64, high_per_mm: f64) -> f64 {
        let step = self.step_per_mm();
        let (low, high) = (low_per_mm / step, high_per_mm / step);
        let power: f64 = self
            .points()
            .filter(|(k, _)| *k >= low && *k < high)
            .map(|(_, d)| d)
            .sum();
        // Over an empty band the sum is −0: the RMS is 0.
        if power > 0.0 {
            (power * step * step).sqrt()
        } else {
            0.0
        }
    }

    /// The highest frequency on the grid's axes (Nyquist), per mm.
    pub fn nyquist_per_mm(&self) -> f64 {
        0.5 / self.pixel_mm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parseval: the whole band's RMS is the window-weighted RMS of the heights; a sinusoid's
    /// power sits at its frequency.
    #[test]
    fn the_psd_keeps_the_power_where_it_belongs() {
        let (n, p) = (64, 0.5);
        let period_px = 8.0;
        let values: Vec<f64> = (0..n * n)
            .map(|i| 3.0 * (2.0 * std::f64::consts::PI * (i % n) as f64 / period_px).cos())
            .collect();
        let window = n as f64 * n as f64;
        let spectrum = Spectrum::new(&values, n, n, p, window).unwrap();
        let total = spectrum.band_rms(0.0, 10.0);
        let rms = (values.iter().map(|v| v * v).sum::<f64>() / window).sqrt();
        assert!((total - rms).abs() < 1e-12 * rms, "{total} vs {rms}");
        let f = 1.0 / (period_px * p);
        let step = spectrum.step_per_mm();
        let at = spectrum.band_rms(f - step / 2.0, f + step / 2.0);
        assert!((at - rms).abs() < 1e-12 * rms, "{at} vs {rms}");
    }
}
