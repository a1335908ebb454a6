//! The removal operator: the matrix M mapping dwell times t_j (s) at tool positions r1_j to
//! removal depths Σ_j M[i][j]·t_j (nm) at radii r_i, for the motion a plan stands for
//! ([`super::motion`]): column j is the removal per second of dwell at position j,
//!
//! ```text
//! M[i][j] = σ_j·R(r_i; r1_j) + w_j/L_j · (F_i(b_{j+1}) − F_i(b_j))
//! ```
//!
//! with the stop share σ_j, the move share w_j, the cell [b_j, b_{j+1}] of arc length L_j, and
//! F_i the running integral of R(r_i; ·) along the surface ([`super::path`]). Each row's F_i
//! is built once and read at every cell boundary within the pad's reach, so the cost per row
//! is that of resolving R(r_i; ·), not the number of cells.
//!
//! It is not shift invariant (R depends on r and r1, not only on r − r1) but it is banded:
//! R(r; ρ) = 0 when |r − ρ| ≥ r_t, so column j is zero outside the rows within r_t of its cell.
//! With the radii sorted, each column's non-zeros are one contiguous run of rows, and each
//! row's one contiguous run of columns. Rows are independent, so large operators are computed
//! across threads (rayon) row by row. An operator is kept in the layout its first user reads
//! ([`Layout`]): by row, (first column, values), for M·t (a prediction), or by column,
//! compressed sparse column without per-entry row indices, for the optimizer. Rows held, the
//! columns are laid out from them when first asked for (the same entries, bit for bit) and
//! kept beside them; columns held, M·t reads them, and no rows are made. An optimizer reads
//! only the clear aperture's rows: a new operator's other rows are assembled while it solves
//! ([`RemovalOperator::assemble_while`]), and stacked with them after.
//!
//! A row's running integral F_i can also give, for nothing, another figure read from it: the
//! caller's [`RowReading`] (what a constant feed over [a, b] removes at r_i, τ·(F_i(b) −
//! F_i(a)), for the recommendation's equal-dwell pass: `schedule::PassReading`). The operator
//! hands it each row's F and knows nothing of what it reads.

use std::ops::Range;
use std::sync::OnceLock;

use rayon::prelude::*;

use super::motion::Motion;
use super::path::PARALLEL_MIN_PATHS;
use super::removal::{RemovalKernel, RunningIntegral};

/// A single position's operator (a stop: one rate per row) is computed in parallel from this
/// many entries; below it threads cost more than they save. Otherwise every row is a path
/// integral, and [`PARALLEL_MIN_PATHS`] rows go parallel.
const PARALLEL_MIN_ENTRIES: usize = 20_000;

/// Columns laid out together from the rows (see `assemble_reading`).
const GATHER_BLOCK: usize = 16;

/// A figure read from each of the rows `rows()` (a range of an operator's radii) while the
/// operator is assembled, from the row's running integral F (its rows build them anyway).
pub trait RowReading: Sync {
    fn rows(&self) -> Range<usize>;
    /// The figure at radius `r`: from the row's `path` when it built one, else computed alone
    /// (it must then give the bits the path would).
    fn read(&self, kernel: &RemovalKernel, r: f64, path: Option<&RunningIntegral>) -> f64;
}

/// A reading of the rows of a part of an operator: `inner`'s rows among `part`, counted from
/// its first.
struct PartReading<'a> {
    inner: &'a dyn RowReading,
    part: Range<usize>,
}

impl RowReading for PartReading<'_> {
    fn rows(&self) -> Range<usize> {
        let (rows, part) = (self.inner.rows(), &self.part);
        rows.start.clamp(part.start, part.end) - part.start
            ..rows.end.clamp(part.start, part.end) - part.start
    }
    fn read(&self, kernel: &RemovalKernel, r: f64, path: Option<&RunningIntegral>) -> f64 {
        self.inner.read(kernel, r, path)
    }
}

/// `values` cut at the ascending `ends` (the last is its length) into consecutive slices.
fn split_at_offsets<'a>(mut values: &'a mut [f64], ends: &[usize]) -> Vec<&'a mut [f64]> {
    let mut start = 0;
    let mut slices = Vec::with_capacity(ends.len());
    for &end in ends {
        let (slice, rest) = std::mem::take(&mut values).split_at_mut(end - start);
        slices.push(slice);
        values = rest;
        start = end;
    }
    slices
}

/// The plan's cells as every row reads them: their boundaries b_j, and w_j/L_j per column
/// (the move share over the cell's arc length, so a row's entries take a product each, not a
/// division). Made once per assembly, however many runs of rows it is assembled in.
struct Cells<'m> {
    bounds: &'m [f64],
    per_arc: Vec<f64>,
}

impl<'m> Cells<'m> {
    fn new(kernel: &RemovalKernel, motion: &'m Motion) -> Self {
        let bounds = motion.cell_bounds_mm();
        let arcs: Vec<f64> = bounds.iter().map(|&b| kernel.arc_length_mm(b)).collect();
        let per_arc = arcs
            .windows(2)
            .enumerate()
            .map(|(j, w)| motion.move_share(j) / (w[1] - w[0]))
            .collect();
        Cells { bounds, per_arc }
    }
}

/// Which layout an operator is assembled in (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// By row: what M·t reads (a prediction).
    Rows,
    /// By column: what the optimizer reads.
    Columns,
}

/// The entries by row, in one block: row i's are `values[row_ptr[i]..row_ptr[i + 1]]`, over the
/// consecutive columns from `first_col[i]`.
#[derive(Debug, Clone, PartialEq)]
struct Rows {
    first_col: Vec<usize>,
    row_ptr: Vec<usize>,
    values: Vec<f64>,
}

impl Rows {
    /// Row i as (first column, entries).
    fn row(&self, i: usize) -> (usize, &[f64]) {
        (
            self.first_col[i],
            &self.values[self.row_ptr[i]..self.row_ptr[i + 1]],
        )
    }

    fn iter(&self) -> impl Iterator<Item = (usize, &[f64])> {
        (0..self.first_col.len()).map(|i| self.row(i))
    }
}

/// Banded removal operator, in one or both of its layouts (see the module docs). Rates in nm/s.
#[derive(Debug, Clone)]
pub struct RemovalOperator {
    /// Column j's first row, and where its entries start in the column layout (one more
    /// than there are columns: the last is the number of entries).
    first_row: Vec<usize>,
    col_ptr: Vec<usize>,
    row_count: usize,
    /// The entries by row (assembled so) and by column (assembled so, or laid out from the
    /// rows on first use): at least one is there.
    rows: Option<Rows>,
    columns: OnceLock<Vec<f64>>,
}

/// Two operators are equal when their entries are, whatever layouts each holds.
impl PartialEq for RemovalOperator {
    fn eq(&self, other: &Self) -> bool {
        self.first_row == other.first_row && self.to_dense() == other.to_dense()
    }
}

impl RemovalOperator {
    /// M for `radii_mm` (ascending) and the plan's `motion` (its stations within
    /// the process's reach).
    /// By row; the columns are laid out when first asked for.
    pub fn assemble(kernel: &RemovalKernel, radii_mm: &[f64], motion: &Motion) -> Self {
        Self::assemble_reading(kernel, radii_mm, motion, None, Layout::Rows).0
    }

    /// M, and with `reading` its figure at its rows, read from the rows' own running
    /// integrals ([`RowReading`]): `None` for the reading when the kernel's running
    /// integrals depend on where the path ends ([`RemovalKernel::path_ignores_end`]).
    pub fn assemble_reading(
        kernel: &RemovalKernel,
        radii_mm: &[f64],
        motion: &Motion,
        reading: Option<&dyn RowReading>,
        layout: Layout,
    ) -> (Self, Option<Vec<f64>>) {
        let cells = Cells::new(kernel, motion);
        Self::assemble_on(kernel, radii_mm, motion, &cells, reading, layout)
    }

    /// [`Self::assemble_reading`] on the plan's `cells`, made once by the caller.
    fn assemble_on(
        kernel: &RemovalKernel,
        radii_mm: &[f64],
        motion: &Motion,
        cells: &Cells<'_>,
        reading: Option<&dyn RowReading>,
        layout: Layout,
    ) -> (Self, Option<Vec<f64>>) {
        // The rows' paths end where the plan does: read only where that does not matter.
        let reading = reading.filter(|_| kernel.path_ignores_end());
        debug_assert!(radii_mm.windows(2).all(|w| w[0] <= w[1]));
        let n = motion.len();
        let Cells { bounds, per_arc } = cells;
        let (first_row, col_ptr) = column_runs(kernel, radii_mm, motion);
        let entries = *col_ptr.last().unwrap();
        // Each row's columns: those whose rows contain it (a contiguous run, since both ends
        // of the columns' row runs grow with j).
        let row_end = row_ends(&first_row, &col_ptr);
        let spans: Vec<Range<usize>> = (0..radii_mm.len())
            .map(|i| row_columns(i, &first_row, &row_end))
            .collect();
        let mut row_ptr = Vec::with_capacity(spans.len() + 1);
        row_ptr.push(0);
        for span in &spans {
            row_ptr.push(row_ptr.last().unwrap() + span.len());
        }
        // Row i's entries, written in its own slice of one block; what is read there.
        let row = |(i, out): (usize, &mut [f64])| -> f64 {
            let Range {
                start: j_lo,
                end: j_hi,
            } = spans[i];
            let r = radii_mm[i];
            let reading = reading.filter(|p| p.rows().contains(&i));
            // A row with no path of its own has it read alone.
            let alone = |p: &dyn RowReading| p.read(kernel, r, None);
            if j_lo == j_hi {
                return reading.map_or(0.0, alone);
            }
            if n == 1 {
                out[0] = kernel.rate_nm_per_s(r, motion.radii_mm()[0]);
                return reading.map_or(0.0, alone);
            }
            let path = kernel.path_integral(r, bounds[n]);
            let read = reading.map_or(0.0, |p| p.read(kernel, r, Some(&path)));
            // F at the cells' starts, and at the last cell's end; then each cell's entry in its
            // place (cell j reads ends j and j + 1 before entry j overwrites end j).
            path.at_ascending(&bounds[j_lo..j_hi], out);
            let last = path.at(bounds[j_hi]);
            for (k, j) in (j_lo..j_hi).enumerate() {
                let end = out.get(k + 1).copied().unwrap_or(last);
                out[k] = (end - out[k]) * per_arc[j];
            }
            for j in [0, n - 1] {
                if (j_lo..j_hi).contains(&j) {
                    out[j - j_lo] +=
                        motion.stop_share(j) * kernel.rate_nm_per_s(r, motion.radii_mm()[j]);
                }
            }
            read
        };
        // A stop's rows are single rates, unless they are also read (a path each).
        let parallel = if n == 1 && reading.is_none() {
            entries >= PARALLEL_MIN_ENTRIES
        } else {
            radii_mm.len() >= PARALLEL_MIN_PATHS
        };
        let mut values = vec![0.0; entries];
        let slices = split_at_offsets(&mut values, &row_ptr[1..]);
        let read_by_row: Vec<f64> = if parallel {
            slices.into_par_iter().enumerate().map(row).collect()
        } else {
            slices.into_iter().enumerate().map(row).collect()
        };
        let read = reading.map(|p| read_by_row[p.rows()].to_vec());
        let rows = Rows {
            first_col: spans.iter().map(|span| span.start).collect(),
            row_ptr,
            values,
        };
        let (rows, columns) = match layout {
            Layout::Rows => (Some(rows), OnceLock::new()),
            Layout::Columns => (
                None,
                OnceLock::from(columns_from_rows(&rows, &first_row, &col_ptr)),
            ),
        };
        let operator = RemovalOperator {
            first_row,
            col_ptr,
            row_count: radii_mm.len(),
            rows,
            columns,
        };
        (operator, read)
    }

    /// [`Self::assemble_reading`] for a caller that first needs only the rows `first` (an
    /// optimizer reads only the clear aperture's), and `during(operator, rows)` run on an
    /// operator holding them, `rows` being where they are in it. When there are at least
    /// [`PARALLEL_MIN_PATHS`] other rows, it is done in two stages: the rows `first` are
    /// assembled (in both layouts), an operator of their own; then `during` runs on it while
    /// the other rows are assembled beside it (`rayon::join`: on another core when one is
    /// free) and stacked with them into the whole operator, by row. Otherwise the whole is
    /// assembled by column first. Rows are independent, so either way the whole is the
    /// operator one assembly gives, and `during` reads the same entries, bit for bit.
    pub fn assemble_while<R: Send>(
        kernel: &RemovalKernel,
        radii_mm: &[f64],
        motion: &Motion,
        reading: Option<&dyn RowReading>,
        first: Range<usize>,
        during: impl FnOnce(&RemovalOperator, Range<usize>) -> R + Send,
    ) -> (Self, Option<Vec<f64>>, R) {
        if radii_mm.len() - first.len() < PARALLEL_MIN_PATHS {
            let (whole, read) =
                Self::assemble_reading(kernel, radii_mm, motion, reading, Layout::Columns);
            let result = during(&whole, first);
            return (whole, read, result);
        }
        let cells = Cells::new(kernel, motion);
        let part = |rows: Range<usize>| {
            let reading = reading.map(|inner| PartReading {
                inner,
                part: rows.clone(),
            });
            let reading = reading.as_ref().map(|p| p as &dyn RowReading);
            let radii = &radii_mm[rows];
            let layout = Layout::Rows;
            Self::assemble_on(kernel, radii, motion, &cells, reading, layout)
        };
        let (inner, inner_read) = part(first.clone());
        // Laid out here, across threads, before `during` reads them on one.
        inner.column_view();
        let (result, (whole, read)) = rayon::join(
            || during(&inner, 0..inner.rows()),
            || {
                let (below, below_read) = part(0..first.start);
                let (above, above_read) = part(first.end..radii_mm.len());
                let parts = [&below, &inner, &above];
                let whole = Self::stacked(kernel, radii_mm, motion, parts);
                let read = [below_read, inner_read, above_read]
                    .into_iter()
                    .collect::<Option<Vec<Vec<f64>>>>()
                    .map(|parts| parts.concat());
                (whole, read)
            },
        );
        (whole, read, result)
    }

    /// The operator on `radii_mm` whose rows are those of `parts` (each held by row, on
    /// consecutive runs of `radii_mm`, in order), copied into one block.
    fn stacked(
        kernel: &RemovalKernel,
        radii_mm: &[f64],
        motion: &Motion,
        parts: [&RemovalOperator; 3],
    ) -> Self {
        let (first_row, col_ptr) = column_runs(kernel, radii_mm, motion);
        let mut rows = Rows {
            first_col: Vec::with_capacity(radii_mm.len()),
            row_ptr: Vec::with_capacity(radii_mm.len() + 1),
            values: Vec::with_capacity(*col_ptr.last().unwrap_or(&0)),
        };
        rows.row_ptr.push(0);
        for part in parts {
            let held = part.rows.as_ref().expect("parts are assembled by row");
            let offset = rows.values.len();
            rows.first_col.extend_from_slice(&held.first_col);
            rows.row_ptr
                .extend(held.row_ptr[1..].iter().map(|&end| offset + end));
            rows.values.extend_from_slice(&held.values);
        }
        debug_assert_eq!(rows.first_col.len(), radii_mm.len());
        debug_assert_eq!(rows.values.len(), *col_ptr.last().unwrap_or(&0));
        RemovalOperator {
            first_row,
            col_ptr,
            row_count: radii_mm.len(),
            rows: Some(rows),
            columns: OnceLock::new(),
        }
    }

    pub fn rows(&self) -> usize {
        self.row_count
    }
    pub fn cols(&self) -> usize {
        self.first_row.len()
    }
    /// Stored entries (the band), not the dense size.
    pub fn stored_entries(&self) -> usize {
        *self.col_ptr.last().unwrap_or(&0)
    }

    /// Heap memory the operator holds, bytes, both layouts counted whether or not the second
    /// has been made yet (so that a cache's account of it does not grow afterwards).
    pub fn heap_bytes(&self) -> usize {
        2 * std::mem::size_of::<f64>() * self.stored_entries()
            + std::mem::size_of::<usize>()
                * (2 * self.row_count + self.first_row.len() + self.col_ptr.len())
    }

    /// The entries by column, laid out from the rows if the operator was assembled by row.
    fn column_view(&self) -> &[f64] {
        self.columns.get_or_init(|| {
            let rows = self.rows.as_ref().expect("an operator holds a layout");
            columns_from_rows(rows, &self.first_row, &self.col_ptr)
        })
    }

    /// Column j as (first row, rates in nm/s of the consecutive rows from there).
    pub fn column(&self, j: usize) -> (usize, &[f64]) {
        (
            self.first_row[j],
            &self.column_view()[self.col_ptr[j]..self.col_ptr[j + 1]],
        )
    }

    /// Removal depth in nm at each radius for dwell times `dwell_s` (one per column), each
    /// radius's products summed in column order from whichever layout the operator holds
    /// (the same bits either way).
    pub fn apply(&self, dwell_s: &[f64]) -> Vec<f64> {
        assert_eq!(dwell_s.len(), self.cols(), "one dwell per tool position");
        if let Some(rows) = &self.rows {
            return rows
                .iter()
                .map(|(j_lo, row)| {
                    let mut sum = 0.0;
                    for (&m, &t) in row.iter().zip(&dwell_s[j_lo..]) {
                        sum += m * t;
                    }
                    sum
                })
                .collect();
        }
        let mut out = vec![0.0; self.row_count];
        for (j, &t) in dwell_s.iter().enumerate() {
            let (first, column) = self.column(j);
            for (o, &m) in out[first..first + column.len()].iter_mut().zip(column) {
                *o += m * t;
            }
        }
        out
    }

    /// Mᵀ·y: for each tool position, Σ_i M[i][j]·y_i (summed in row order).
    pub fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
        assert_eq!(y.len(), self.row_count, "one value per radius");
        (0..self.cols())
            .map(|j| {
                let (first, column) = self.column(j);
                let mut sum = 0.0;
                for (m, v) in column.iter().zip(&y[first..]) {
                    sum += m * v;
                }
                sum
            })
            .collect()
    }

    /// The dense matrix, row-major (for tests and small problems).
    pub fn to_dense(&self) -> Vec<Vec<f64>> {
        let mut dense = vec![vec![0.0; self.cols()]; self.row_count];
        if let Some(rows) = &self.rows {
            for ((j_lo, row), out) in rows.iter().zip(&mut dense) {
                out[j_lo..j_lo + row.len()].copy_from_slice(row);
            }
        } else {
            for j in 0..self.cols() {
                let (first, column) = self.column(j);
                for (out, &m) in dense[first..].iter_mut().zip(column) {
                    out[j] = m;
                }
            }
        }
        dense
    }
}

/// The entries of `rows` by column (`first_row` and `col_ptr` as the operator's): a block of
/// columns at a time, each row touching the block copying its few entries there, so the rows
/// are read in order instead of one entry from every row per column (blocks in parallel for a
/// large operator).
fn columns_from_rows(rows: &Rows, first_row: &[usize], col_ptr: &[usize]) -> Vec<f64> {
    let n = first_row.len();
    let entries = *col_ptr.last().unwrap_or(&0);
    let row_end = row_ends(first_row, col_ptr);
    let mut values = vec![0.0; entries];
    let gather = |(b, block): (usize, &mut [f64])| {
        let (j0, j1) = (b * GATHER_BLOCK, ((b + 1) * GATHER_BLOCK).min(n));
        let base = col_ptr[j0];
        for (i, (j_lo, row)) in rows
            .iter()
            .enumerate()
            .take(row_end[j1 - 1])
            .skip(first_row[j0])
        {
            let (from, to) = (j_lo.max(j0), (j_lo + row.len()).min(j1));
            for (j, &value) in (from..to).zip(&row[from - j_lo..to - j_lo]) {
                // Entry (i, j) sits at col_ptr[j] − first_row[j] + i.
                block[col_ptr[j] - first_row[j] + i - base] = value;
            }
        }
    };
    let block_ends: Vec<usize> = (1..=n.div_ceil(GATHER_BLOCK))
        .map(|b| col_ptr[(b * GATHER_BLOCK).min(n)])
        .collect();
    let blocks = split_at_offsets(&mut values, &block_ends);
    if entries >= PARALLEL_MIN_ENTRIES {
        blocks
            .into_par_iter()
            .enumerate()
            .with_min_len(4)
            .for_each(gather);
    } else {
        blocks.into_iter().enumerate().for_each(gather);
    }
    values
}

/// Each column's first row and where its entries start (one more than there are columns: the
/// last is the number of entries). Column j covers the rows within r_t of its cell [b_j,
/// b_{j+1}] (of its position for a single one), widened by a hair so rounding never drops a
/// (tiny) non-zero entry: whether a row is in a column's run depends on its radius alone.
fn column_runs(
    kernel: &RemovalKernel,
    radii_mm: &[f64],
    motion: &Motion,
) -> (Vec<usize>, Vec<usize>) {
    let n = motion.len();
    let bounds = motion.cell_bounds_mm();
    let rt = kernel.tool_radius_mm();
    let mut first_row = Vec::with_capacity(n);
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0);
    for j in 0..n {
        let (a, b) = if n == 1 {
            (motion.radii_mm()[0], motion.radii_mm()[0])
        } else {
            (bounds[j], bounds[j + 1])
        };
        let slack = 1e-9 * (b + rt);
        let lo = radii_mm.partition_point(|&r| r <= a - rt - slack);
        let hi = radii_mm.partition_point(|&r| r < b + rt + slack);
        first_row.push(lo);
        col_ptr.push(col_ptr.last().unwrap() + hi.max(lo) - lo);
    }
    (first_row, col_ptr)
}

/// One past each column's last row.
fn row_ends(first_row: &[usize], col_ptr: &[usize]) -> Vec<usize> {
    (0..first_row.len())
        .map(|j| first_row[j] + col_ptr[j + 1] - col_ptr[j])
        .collect()
}

/// The columns whose runs of rows hold row `i`: a contiguous run, since both ends of those runs
/// grow with the column (empty, at where it would start, when none does).
fn row_columns(i: usize, first_row: &[usize], row_end: &[usize]) -> Range<usize> {
    let j_lo = row_end.partition_point(|&end| end <= i);
    let j_hi = first_row.partition_point(|&first| first <= i);
    j_lo..j_hi.max(j_lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::{tests::paper_spec, Process};

    fn kernel(w: f64, t: f64) -> RemovalKernel {
        RemovalKernel::new(&Process::new(paper_spec(w, t)).unwrap())
    }

    fn motion(positions_mm: &[f64]) -> Motion {
        Motion::radial(positions_mm.to_vec())
    }

    fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
            .collect()
    }

    /// Column j is σ_j·R(r; r_j) + w_j·(F(b_{j+1}) − F(b_j))/L_j, and zero outside its band.
    #[test]
    fn columns_are_the_motion_of_their_cells() {
        let k = kernel(-10.0, 200.0);
        let radii = linspace(0.0, 50.0, 101);
        // Uneven spacing, a position on the axis and one at tangency with a grid radius.
        let positions = [0.0, 10.0, 12.5, 30.0, 47.3, 55.0, 60.0];
        let op = RemovalOperator::assemble(&k, &radii, &motion(&positions));
        let dense = op.to_dense();
        let bounds = [0.0, 5.0, 11.25, 21.25, 38.65, 51.15, 57.5, 60.0];
        for (i, &r) in radii.iter().enumerate() {
            let path = k.path_integral(r, f64::INFINITY);
            for j in 0..positions.len() {
                let share = if j == 0 || j == 6 { 0.5 } else { 1.0 };
                let mut want = share * (path.at(bounds[j + 1]) - path.at(bounds[j]))
                    / (bounds[j + 1] - bounds[j]);
                if share == 0.5 {
                    want += 0.5 * k.rate_nm_per_s(r, positions[j]);
                }
                assert!(
                    (dense[i][j] - want).abs() <= 1e-15 * want.abs(),
                    "r {r} j {j}"
                );
            }
        }
        assert!(op.stored_entries() < radii.len() * positions.len());
        // A single position is a stop: the removal function itself.
        let single = RemovalOperator::assemble(&k, &radii, &motion(&[12.5])).to_dense();
        for (i, &r) in radii.iter().enumerate() {
            assert_eq!(single[i][0], k.rate_nm_per_s(r, 12.5));
        }
    }

    #[test]
    fn apply_and_transpose_agree_with_dense_products() {
        let k = kernel(150.0, 150.0);
        let radii = linspace(0.0, 50.0, 61);
        let positions = linspace(0.0, 60.0, 37);
        let op = RemovalOperator::assemble(&k, &radii, &motion(&positions));
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

    /// The columns laid out from the rows hold the same entries, bit for bit, in a small
    /// (serial) and a large (parallel, many blocks) operator, and an empty column is empty;
    /// one assembled by column gives the same products.
    #[test]
    fn columns_laid_out_from_the_rows_are_the_rows() {
        let k = kernel(-10.0, 200.0);
        for (rows, cols) in [(37, 23), (401, 301)] {
            let radii = linspace(0.0, 50.0, rows);
            // Positions beyond the pad's reach of every radius leave their columns empty.
            let mut positions = linspace(0.0, 50.0, cols);
            positions.push(75.0);
            let op = RemovalOperator::assemble(&k, &radii, &motion(&positions));
            assert!(op.stored_entries() >= PARALLEL_MIN_ENTRIES || rows < 100);
            let dense = op.to_dense();
            let mut seen = 0;
            for j in 0..op.cols() {
                let (first, column) = op.column(j);
                for (i, row) in dense.iter().enumerate() {
                    let want = row[j];
                    let got = if (first..first + column.len()).contains(&i) {
                        column[i - first]
                    } else {
                        0.0
                    };
                    assert_eq!(got.to_bits(), want.to_bits(), "({i}, {j})");
                }
                seen += column.len();
            }
            assert_eq!(seen, op.stored_entries());
            assert!(op.column(cols).1.is_empty());
            // Assembled by column: the rows made from the columns are the rows, and M·t and
            // Mᵀ·y are the same bits from either layout.
            let by_column = RemovalOperator::assemble_reading(
                &k,
                &radii,
                &motion(&positions),
                None,
                Layout::Columns,
            )
            .0;
            assert!(by_column.rows.is_none());
            let t: Vec<f64> = (0..op.cols()).map(|j| 1.0 + (j as f64).sin()).collect();
            let y: Vec<f64> = (0..rows).map(|i| (i as f64 * 0.3).cos()).collect();
            let bits = |v: Vec<f64>| v.into_iter().map(f64::to_bits).collect::<Vec<_>>();
            assert_eq!(bits(by_column.apply(&t)), bits(op.apply(&t)));
            assert_eq!(
                bits(by_column.apply_transpose(&y)),
                bits(op.apply_transpose(&y))
            );
            assert_eq!(by_column.to_dense(), dense);
            assert_eq!(by_column, op);
        }
    }

    /// Assembled while its first rows are read, the whole operator is the one assembly gives,
    /// bit for bit, and `during` reads those rows of it: rows in the middle, a prefix, a
    /// suffix, none; and with too few other rows to stage, the whole by column.
    #[test]
    fn an_operator_assembled_while_its_first_rows_are_read_is_the_whole() {
        let k = kernel(-10.0, 200.0);
        let radii = linspace(0.0, 50.0, 201);
        let positions = linspace(0.0, 50.0, 151);
        let one = RemovalOperator::assemble(&k, &radii, &motion(&positions));
        let dense = one.to_dense();
        let bits = |rows: &[Vec<f64>]| -> Vec<Vec<u64>> {
            rows.iter()
                .map(|row| row.iter().map(|v| v.to_bits()).collect())
                .collect()
        };
        for first in [40..161, 0..161, 40..201, 100..100, 0..195, 0..201] {
            let staged = radii.len() - first.len() >= PARALLEL_MIN_PATHS;
            let (whole, passed, seen) = RemovalOperator::assemble_while(
                &k,
                &radii,
                &motion(&positions),
                None,
                first.clone(),
                |operator, rows| {
                    // The solver reads columns: they are laid out already.
                    assert!(operator.columns.get().is_some());
                    (operator.rows(), operator.to_dense()[rows].to_vec())
                },
            );
            assert!(passed.is_none());
            assert_eq!(bits(&whole.to_dense()), bits(&dense), "first {first:?}");
            // The same columns' runs: the columns laid out from the stacked rows are the
            // columns of one assembly.
            assert_eq!(whole, one);
            for j in 0..positions.len() {
                let (a, b) = (whole.column(j), one.column(j));
                assert_eq!(a.0, b.0, "first {first:?}, column {j}");
                assert_eq!(bits(&[a.1.to_vec()]), bits(&[b.1.to_vec()]), "column {j}");
            }
            assert_eq!(whole.rows.is_some(), staged, "first {first:?}");
            let (rows, seen) = seen;
            assert_eq!(rows, if staged { first.len() } else { radii.len() });
            assert_eq!(bits(&seen), bits(&dense[first.clone()]), "first {first:?}");
        }
    }

    /// Rows are independent: the rows of a large (parallel) operator equal those of the same
    /// plan on fewer radii (serial), bit for bit.
    #[test]
    fn parallel_and_serial_assembly_are_identical() {
        let k = kernel(-10.0, 200.0);
        let radii = linspace(0.0, 50.0, 401);
        let positions = linspace(0.0, 50.0, 401);
        let op = RemovalOperator::assemble(&k, &radii, &motion(&positions)).to_dense();
        let few =
            RemovalOperator::assemble(&k, &radii[..PARALLEL_MIN_PATHS - 1], &motion(&positions));
        assert_eq!(few.to_dense()[..], op[..PARALLEL_MIN_PATHS - 1]);
    }
}
