//! What the dwell solvers need of a removal operator M (nm of removal per second of dwell at
//! each station, row i a sample, column j a station): M·t, Mᵀ·y, and column j where holding it
//! is cheap ([`DwellOperator`]). The banded radial operator ([`RemovalOperator`]) is one; an
//! operator without cheap columns still serves, its columns made as M·e_j (whole: dense, so
//! correct for any operator and slow for a large one).
//!
//! `Band` is what the QP reads of one: each column cut to the clear aperture's rows (one
//! contiguous run, since the operator is banded), and those of M·S for a basis S of the dwell.

use std::borrow::Cow;
use std::ops::Range;

use rayon::prelude::*;

use super::basis::Basis;
use crate::physics::raster::RasterOperator;
use crate::physics::RemovalOperator;

/// A linear map from dwell (s, one per station) to removal (nm, one per sample).
pub trait DwellOperator: std::fmt::Debug + Sync {
    /// Samples (rows).
    fn rows(&self) -> usize;
    /// Stations (columns).
    fn cols(&self) -> usize;
    /// M·t: the removal of dwell `dwell_s`, nm.
    fn apply(&self, dwell_s: &[f64]) -> Vec<f64>;
    /// Mᵀ·y, one value per station.
    fn apply_transpose(&self, y: &[f64]) -> Vec<f64>;
    /// Column j as (first row, the consecutive rows' entries from there) when the operator
    /// holds it so; `None` otherwise.
    fn column(&self, _j: usize) -> Option<(usize, &[f64])> {
        None
    }
    /// Σ_i w_i·M_ij² for each column, when the operator can give them without its columns.
    fn weighted_column_norms(&self, _weights: &[f64]) -> Option<Vec<f64>> {
        None
    }
    /// Column j's entries as runs of consecutive rows, each given to `visit` as (first row,
    /// entries), when the operator holds its columns; false (and nothing visited) otherwise.
    fn column_runs(&self, j: usize, visit: &mut dyn FnMut(usize, &[f64])) -> bool {
        match self.column(j) {
            Some((first, values)) => {
                visit(first, values);
                true
            }
            None => false,
        }
    }
}

impl DwellOperator for RasterOperator {
    fn rows(&self) -> usize {
        RasterOperator::rows(self)
    }
    fn cols(&self) -> usize {
        RasterOperator::cols(self)
    }
    fn apply(&self, dwell_s: &[f64]) -> Vec<f64> {
        RasterOperator::apply(self, dwell_s)
    }
    fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
        RasterOperator::apply_transpose(self, y)
    }
    fn weighted_column_norms(&self, weights: &[f64]) -> Option<Vec<f64>> {
        Some(RasterOperator::weighted_column_norms(self, weights))
    }
    fn column_runs(&self, j: usize, visit: &mut dyn FnMut(usize, &[f64])) -> bool {
        RasterOperator::column_runs(self, j, visit);
        true
    }
}

impl DwellOperator for RemovalOperator {
    fn rows(&self) -> usize {
        RemovalOperator::rows(self)
    }
    fn cols(&self) -> usize {
        RemovalOperator::cols(self)
    }
    fn apply(&self, dwell_s: &[f64]) -> Vec<f64> {
        RemovalOperator::apply(self, dwell_s)
    }
    fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
        RemovalOperator::apply_transpose(self, y)
    }
    fn column(&self, j: usize) -> Option<(usize, &[f64])> {
        Some(RemovalOperator::column(self, j))
    }
}

/// Column j of `op` as M·e_j, trimmed to the run from its first to its last non-zero entry.
fn column_by_applying(op: &dyn DwellOperator, j: usize) -> (usize, Vec<f64>) {
    let mut unit = vec![0.0; op.cols()];
    unit[j] = 1.0;
    let column = op.apply(&unit);
    let first = column.iter().position(|&v| v != 0.0).unwrap_or(0);
    let end = column
        .iter()
        .rposition(|&v| v != 0.0)
        .map_or(first, |k| k + 1);
    (first, column[first..end].to_vec())
}

/// Columns cut to the aperture rows: column j covers rows start[j]..end[j] (absolute) with
/// values[j]; both bounds are non-decreasing in j because positions increase. The operator's
/// own columns are borrowed; those of M·S (one per basis function) are computed.
pub(super) struct Band<'a> {
    pub(super) start: Vec<usize>,
    pub(super) end: Vec<usize>,
    pub(super) values: Vec<Cow<'a, [f64]>>,
}

impl<'a> Band<'a> {
    pub(super) fn new(op: &'a dyn DwellOperator, rows: &Range<usize>) -> Self {
        let n = op.cols();
        let (mut start, mut end, mut values) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for j in 0..n {
            let (first, column) = match op.column(j) {
                Some((first, column)) => (first, Cow::Borrowed(column)),
                None => {
                    let (first, column) = column_by_applying(op, j);
                    (first, Cow::Owned(column))
                }
            };
            // Clamped into the aperture rows; an empty column gets start = end.
            let lo = first.clamp(rows.start, rows.end);
            let hi = (first + column.len()).clamp(rows.start, rows.end);
            start.push(lo);
            end.push(hi.max(lo));
            values.push(match column {
                _ if hi <= lo => Cow::Borrowed(&[][..]),
                Cow::Borrowed(c) => Cow::Borrowed(&c[lo - first..hi - first]),
                Cow::Owned(c) => Cow::Owned(c[lo - first..hi - first].to_vec()),
            });
        }
        Band { start, end, values }
    }

    /// The columns of M·S: column k is Σ_j S_jk·M_j over the positions B_k reaches.
    pub(super) fn through(&self, basis: &Basis) -> Band<'a> {
        if basis.is_positions() {
            return Band {
                start: self.start.clone(),
                end: self.end.clone(),
                values: self.values.clone(),
            };
        }
        let columns: Vec<(usize, usize, Cow<'a, [f64]>)> = (0..basis.size())
            .into_par_iter()
            .map(|k| {
                let reach = basis.support(k);
                let lo = self.start[reach.start];
                let hi = self.end[reach.end - 1].max(lo);
                let mut column = vec![0.0; hi - lo];
                for j in reach {
                    let Some((_, w)) = basis.terms(j).find(|&(v, _)| v == k) else {
                        continue;
                    };
                    let from = self.start[j] - lo;
                    for (o, m) in column[from..].iter_mut().zip(self.values[j].iter()) {
                        *o += w * m;
                    }
                }
                (lo, hi, Cow::Owned(column))
            })
            .collect();
        let mut band = Band {
            start: Vec::with_capacity(columns.len()),
            end: Vec::with_capacity(columns.len()),
            values: Vec::with_capacity(columns.len()),
        };
        for (lo, hi, column) in columns {
            band.start.push(lo);
            band.end.push(hi);
            band.values.push(column);
        }
        band
    }

    pub(super) fn dot(&self, j: usize, k: usize) -> f64 {
        let lo = self.start[j].max(self.start[k]);
        let hi = self.end[j].min(self.end[k]);
        if hi <= lo {
            return 0.0;
        }
        let a = &self.values[j][lo - self.start[j]..hi - self.start[j]];
        let b = &self.values[k][lo - self.start[k]..hi - self.start[k]];
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }

    pub(super) fn column_sum(&self, j: usize) -> f64 {
        self.values[j].iter().sum()
    }

    /// Σ_i M_ij·y_i with y indexed from the first aperture row.
    pub(super) fn dot_rows(&self, j: usize, y: &[f64], row0: usize) -> f64 {
        let from = self.start[j] - row0;
        self.values[j]
            .iter()
            .zip(&y[from..])
            .map(|(m, v)| m * v)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::tests::paper_spec;
    use crate::physics::{Motion, Process, RemovalKernel};

    /// The operator seen only through M·t and Mᵀ·y.
    #[derive(Debug)]
    struct Opaque(RemovalOperator);

    impl DwellOperator for Opaque {
        fn rows(&self) -> usize {
            self.0.rows()
        }
        fn cols(&self) -> usize {
            self.0.cols()
        }
        fn apply(&self, dwell_s: &[f64]) -> Vec<f64> {
            self.0.apply(dwell_s)
        }
        fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
            self.0.apply_transpose(y)
        }
    }

    /// An operator without cheap columns gives the band its columns give, entry for entry
    /// (M·e_j sums one product per row: the entry itself), through a spline basis too.
    #[test]
    fn columns_made_by_applying_are_the_held_ones() {
        let process = Process::new(paper_spec(-10.0, 200.0)).unwrap();
        let radii: Vec<f64> = (0..=100).map(|i| 0.5 * i as f64).collect();
        let motion = Motion::radial((0..=60).map(|j| 50.0 * j as f64 / 60.0).collect());
        let held = RemovalOperator::assemble(&RemovalKernel::new(&process), &radii, &motion);
        let opaque = Opaque(held.clone());
        let rows = 10..81;
        let (a, b) = (Band::new(&held, &rows), Band::new(&opaque, &rows));
        for j in 0..motion.len() {
            let (x, y) = (&a.values[j], &b.values[j]);
            // Made columns span every aperture row; held ones their run within it.
            let offset = a.start[j] - b.start[j];
            assert_eq!(&y[offset..offset + x.len()], &x[..], "column {j}");
            let outside = y[..offset].iter().chain(&y[offset + x.len()..]);
            assert!(outside.copied().all(|v| v == 0.0));
        }
        let basis = Basis::spline(motion.radii_mm(), 10.0).unwrap();
        let (sa, sb) = (a.through(&basis), b.through(&basis));
        for k in 0..basis.size() {
            let sum = |band: &Band, k: usize| band.values[k].iter().sum::<f64>();
            assert!((sum(&sa, k) - sum(&sb, k)).abs() <= 1e-12 * sum(&sa, k).abs());
        }
    }
}
