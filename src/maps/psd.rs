//! The power spectral density of a map, its azimuthal average and band-limited RMS.
//!
//! The heights h (nm) over the aperture, 0 elsewhere, are multiplied by a window w and placed
//! in an N × N array, N the larger side of the aperture's box of pixels rounded up to the
//! next even size with no prime factor above 7 (where FFTs are quickest: 418 = 2·11·19 takes
//! half as long again as 420 = 2²·3·5·7), pitch p (mm). With F its discrete Fourier transform,
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
    /// PSD at (k_y, k_x) for k_x = 0 … N/2 (the other half mirrors it: the heights are real,
    /// so F(−k) = F(k)*), stored by k_x, each a column of N values of k_y, unshifted.
    half: Vec<f64>,
}

/// What a spectrum says: its azimuthal average and the bands' RMS.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// (f_k per mm, PSD nm²·mm²) for k = 1 … N/2.
    pub azimuthal: Vec<(f64, f64)>,
    /// RMS (nm) of each band asked for, in order.
    pub band_rms: Vec<f64>,
}

/// The least even n ≥ `side` with no prime factor above 7.
fn fft_size(side: usize) -> usize {
    let smooth = |mut n: usize| {
        for p in [2, 3, 5, 7] {
            while n % p == 0 {
                n /= p;
            }
        }
        n == 1
    };
    (side.max(2).div_ceil(2)..)
        .map(|half| 2 * half)
        .find(|&n| smooth(n))
        .expect("7-smooth numbers are unbounded")
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
        let size = fft_size(columns.max(rows));
        let width = size / 2 + 1;
        // Rows: the real transform of each row that holds data (the rows of zeros below
        // transform to zeros), keeping k_x = 0 … N/2.
        let forward = realfft::RealFftPlanner::<f64>::new().plan_fft_forward(size);
        let mut transformed = vec![Complex::new(0.0, 0.0); rows * width];
        transformed
            .par_chunks_mut(width)
            .zip(values.par_chunks(columns))
            .for_each(|(out, row)| {
                let mut input = vec![0.0; size];
                input[..columns].copy_from_slice(row);
                forward
                    .process(&mut input, out)
                    .expect("the buffers are the plan's lengths");
            });
        // Columns: each k_x's column of N values of k_y, transformed in place.
        let fft = FftPlanner::new().plan_fft_forward(size);
        let scale = pixel_mm * pixel_mm / window_power;
        let mut half = vec![0.0; width * size];
        half.par_chunks_mut(size).enumerate().for_each(|(kx, out)| {
            let mut column = vec![Complex::new(0.0, 0.0); size];
            for (r, c) in column.iter_mut().take(rows).enumerate() {
                *c = transformed[r * width + kx];
            }
            fft.process(&mut column);
            for (o, z) in out.iter_mut().zip(&column) {
                *o = z.norm_sqr() * scale;
            }
        });
        Some(Spectrum {
            size,
            pixel_mm,
            half,
        })
    }

    /// Δf, per mm.
    pub fn step_per_mm(&self) -> f64 {
        1.0 / (self.size as f64 * self.pixel_mm)
    }

    /// The azimuthal average and the RMS of each band (low, high) per mm, low ≤ |f| < high
    /// (module docs), in one pass over the stored half: a column 0 < k_x < N/2 stands for
    /// itself and its mirror.
    pub fn summary(&self, bands: &[(f64, f64)]) -> Summary {
        let n = self.size;
        let half = n / 2;
        let step = self.step_per_mm();
        let limits: Vec<(f64, f64)> = bands.iter().map(|(l, h)| (l / step, h / step)).collect();
        let mut sum = vec![0.0; half + 1];
        let mut count = vec![0.0; half + 1];
        let mut power = vec![-0.0; bands.len()];
        for (kx, column) in self.half.chunks(n).enumerate() {
            let weight = if kx == 0 || kx == half { 1.0 } else { 2.0 };
            let b = kx as f64;
            for (ky, d) in column.iter().enumerate() {
                let a = if ky <= half {
                    ky as f64
                } else {
                    ky as f64 - n as f64
                };
                let k = (a * a + b * b).sqrt();
                // round() for k ≥ 0 (√ of an integer is never within rounding of a half),
                // without a libm call an element.
                let bin = (k + 0.5) as usize;
                if bin <= half {
                    sum[bin] += weight * d;
                    count[bin] += weight;
                }
                for (p, (low, high)) in power.iter_mut().zip(&limits) {
                    if k >= *low && k < *high {
                        *p += weight * d;
                    }
                }
            }
        }
        Summary {
            azimuthal: (1..=half)
                .map(|k| (k as f64 * step, sum[k] / count[k].max(1.0)))
                .collect(),
            // Over an empty band the sum is −0: the RMS is 0.
            band_rms: power
                .iter()
                .map(|&p| {
                    if p > 0.0 {
                        (p * step * step).sqrt()
                    } else {
                        0.0
                    }
                })
                .collect(),
        }
    }

    /// The RMS (nm) of the band f_low ≤ |f| < f_high, per mm.
    pub fn band_rms(&self, low_per_mm: f64, high_per_mm: f64) -> f64 {
        self.summary(&[(low_per_mm, high_per_mm)]).band_rms[0]
    }

    /// The highest frequency on the grid's axes (Nyquist), per mm.
    pub fn nyquist_per_mm(&self) -> f64 {
        0.5 / self.pixel_mm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transforms_are_sized_where_ffts_are_quick() {
        // 418 = 2·11·19 and 416 = 2⁵·13 pad to 420 = 2²·3·5·7; 7-smooth even sides stay.
        assert_eq!(fft_size(415), 420);
        assert_eq!(fft_size(418), 420);
        assert_eq!(fft_size(420), 420);
        assert_eq!(fft_size(64), 64);
        assert_eq!(fft_size(1), 2);
        assert_eq!(fft_size(1001), 1008);
    }

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
