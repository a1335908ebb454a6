//! The removal operator: the matrix M with M[i][j] = R(r_i; r1_j) in nm/s, mapping dwell times
//! t_j (s) at tool positions r1_j to removal depths Σ_j M[i][j]·t_j (nm) at radii r_i.
//!
//! It is not shift invariant (R depends on r and r1, not only on r − r1) but it is banded:
//! R(r; r1) = 0 when |r − r1| ≥ r_t. With the radii sorted, each column's non-zeros are one
//! contiguous run of rows, so we store the matrix column by column as (first row, values):
//! compressed sparse column without per-entry row indices. Columns are independent, so
//! assembly of large operators is split across threads (rayon) column by column.

use rayon::prelude::*;

use super::removal::RemovalKernel;

/// Entries at and above this count are assembled in parallel; below it threads cost more
/// than they save (a column of a few hundred entries takes microseconds).
const PARALLEL_MIN_ENTRIES: usize = 20_000;

/// Banded removal operator, column-major (see the module docs). Rates in nm/s.
#[derive(Debug, Clone, PartialEq)]
pub struct RemovalOperator {
    rows: usize,
    first_row: Vec<usize>,
    col_ptr: Vec<usize>,
    values: Vec<f64>,
}

impl RemovalOperator {
    /// Assembles M for `radii_mm` (ascending) and `positions_mm` (any order, ≥ 0).
    pub fn assemble(kernel: &RemovalKernel, radii_mm: &[f64], positions_mm: &[f64]) -> Self {
        debug_assert!(radii_mm.windows(2).all(|w| w[0] <= w[1]));
        let rt = kernel.tool_radius_mm();
        let mut first_row = Vec::with_capacity(positions_mm.len());
        let mut col_ptr = Vec::with_capacity(positions_mm.len() + 1);
        col_ptr.push(0);
        for &r1 in positions_mm {
            // Widen by a hair so rounding in r1 ± r_t never drops a (tiny) non-zero entry.
            let slack = 1e-9 * (r1 + rt);
            let lo = radii_mm.partition_point(|&r| r <= r1 - rt - slack);
            let hi = radii_mm.partition_point(|&r| r < r1 + rt + slack);
            first_row.push(lo);
            col_ptr.push(col_ptr.last().unwrap() + hi.max(lo) - lo);
        }
        let entries = *col_ptr.last().unwrap();
        let mut values = vec![0.0; entries];

        let rings = kernel.rings(radii_mm);
        let fill = |(j, column): (usize, &mut [f64])| {
            let rows = first_row[j]..first_row[j] + column.len();
            let column_rings = rings.as_deref().map(|r| &r[rows.clone()]);
            kernel.fill_column(positions_mm[j], &radii_mm[rows], column_rings, column);
        };
        let columns = split_columns(&mut values, &col_ptr);
        if entries >= PARALLEL_MIN_ENTRIES {
            columns.into_par_iter().enumerate().for_each(fill);
        } else {
            columns.into_iter().enumerate().for_each(fill);
        }

        RemovalOperator {
            rows: radii_mm.len(),
            first_row,
            col_ptr,
            values,
        }
    }

    pub fn rows(&self) -> usize {
        self.rows
    }
    pub fn cols(&self) -> usize {
        self.first_row.len()
    }
    /// Stored entries (the band), not the dense size.
    pub fn stored_entries(&self) -> usize {
        self.values.len()
    }

    /// Heap memory the operator holds, bytes.
    pub fn heap_bytes(&self) -> usize {
        std::mem::size_of::<f64>() * self.values.len()
            + std::mem::size_of::<usize>() * (self.first_row.len() + self.col_ptr.len())
    }

    /// Column j as (first row, rates in nm/s of the consecutive rows from there).
    pub fn column(&self, j: usize) -> (usize, &[f64]) {
        (
            self.first_row[j],
            &self.values[self.col_ptr[j]..self.col_ptr[j + 1]],
        )
    }

    /// Removal depth in nm at each radius for dwell times `dwell_s` (one per column).
    pub fn apply(&self, dwell_s: &[f64]) -> Vec<f64> {
        assert_eq!(dwell_s.len(), self.cols(), "one dwell per tool position");
        let mut out = vec![0.0; self.rows];
        for (j, &t) in dwell_s.iter().enumerate() {
            let (first, column) = self.column(j);
            for (o, &m) in out[first..first + column.len()].iter_mut().zip(column) {
                *o += m * t;
            }
        }
        out
    }

    /// Mᵀ·y: for each tool position, Σ_i M[i][j]·y_i.
    pub fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
        assert_eq!(y.len(), self.rows, "one value per radius");
        (0..self.cols())
            .map(|j| {
                let (first, column) = self.column(j);
                column.iter().zip(&y[first..]).map(|(m, v)| m * v).sum()
            })
            .collect()
    }

    /// The dense matrix, row-major (for tests and small problems).
    pub fn to_dense(&self) -> Vec<Vec<f64>> {
        let mut dense = vec![vec![0.0; self.cols()]; self.rows];
        for j in 0..self.cols() {
            let (first, column) = self.column(j);
            for (row, &m) in dense[first..].iter_mut().zip(column) {
                row[j] = m;
            }
        }
        dense
    }
}

/// Splits `values` into the disjoint mutable column slices described by `col_ptr`.
fn split_columns<'a>(mut values: &'a mut [f64], col_ptr: &[usize]) -> Vec<&'a mut [f64]> {
    let mut columns = Vec::with_capacity(col_ptr.len().saturating_sub(1));
    for w in col_ptr.windows(2) {
        let (head, tail) = values.split_at_mut(w[1] - w[0]);
        columns.push(head);
        values = tail;
    }
    columns
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::{tests::paper_spec, Process};

    fn kernel(w: f64, t: f64) -> RemovalKernel {
        RemovalKernel::new(&Process::new(paper_spec(w, t)).unwrap())
    }

    fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
            .collect()
    }

    #[test]
    fn band_holds_every_non_zero_and_matches_pointwise_rates() {
        let k = kernel(-10.0, 200.0);
        let radii = linspace(0.0, 50.0, 101);
        // Positions in no particular order, including exact tangency with grid points.
        let positions = [30.0, 0.0, 10.0, 47.3, 60.0, 55.0, 12.5];
        let op = RemovalOperator::assemble(&k, &radii, &positions);
        let dense = op.to_dense();
        for (i, &r) in radii.iter().enumerate() {
            for (j, &r1) in positions.iter().enumerate() {
                assert_eq!(dense[i][j], k.rate_nm_per_s(r, r1), "r {r} r1 {r1}");
            }
        }
        assert!(op.stored_entries() < radii.len() * positions.len());
    }

    #[test]
    fn apply_and_transpose_agree_with_dense_products() {
        let k = kernel(150.0, 150.0);
        let radii = linspace(0.0, 50.0, 61);
        let positions = linspace(0.0, 60.0, 37);
        let op = RemovalOperator::assemble(&k, &radii, &positions);
        let dense = op.to_dense();
        let t: Vec<f64> = (0..37).map(|j| 1.0 + (j as f64 * 0.7).sin()).collect();
        let y: Vec<f64> = (0..61).map(|i| (i as f64 * 0.3).cos()).collect();
        let mt = op.apply(&t);
        let mty = op.apply_transpose(&y);
        for i in 0..61 {
            let want: f64 = (0..37).map(|j| dense[i][j] * t[j]).sum();
            assert!((mt[i] - want).abs() <= 1e-12 * want.abs().max(1e-300));
        }
        for j in 0..37 {
            let want: f64 = (0..61).map(|i| dense[i][j] * y[i]).sum();
            assert!((mty[j] - want).abs() <= 1e-12 * (1.0 + want.abs()));
        }
    }

    #[test]
    fn parallel_and_serial_assembly_are_identical() {
        let k = kernel(-10.0, 200.0);
        let radii = linspace(0.0, 50.0, 401);
        let positions = linspace(0.0, 50.0, 401); // > PARALLEL_MIN_ENTRIES entries
        let op = RemovalOperator::assemble(&k, &radii, &positions);
        assert!(op.stored_entries() >= PARALLEL_MIN_ENTRIES);
        for (j, &r1) in positions.iter().enumerate() {
            let (first, column) = op.column(j);
            for (&m, &r) in column.iter().zip(&radii[first..]) {
                assert_eq!(m, k.rate_nm_per_s(r, r1));
            }
        }
    }
}
