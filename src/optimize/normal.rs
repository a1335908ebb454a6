//! The weighted least-squares fit in the dwell's own space: G = MᵀWM held as a sparse
//! symmetric matrix, for the bound-constrained solver ([`super::bounded`]) when that is
//! cheaper than products with M.
//!
//! # Why, and when
//!
//! The fit term of the solver's objective, ½·(P·r)ᵀW(P·r) with r = M·t − d and P the
//! W-orthogonal projector that takes the free terms B (piston, tilt) off r, needs only
//!
//! ```text
//! G = MᵀWM (n × n),   U = MᵀWB (n × k),   MᵀWd (n),   BᵀWd (k)
//! ```
//!
//! since MᵀWPr = (G·t − MᵀWd) − U·(BᵀWB)⁻¹·(Uᵀt − BᵀWd) and the Hessian is
//! MᵀWPM = G − U·(BᵀWB)⁻¹·Uᵀ (a rank-k correction of G). A dwell point's column reaches only
//! the pixels under the tool, so G is sparse: G_jk ≠ 0 only for points whose footprints
//! overlap. On the public fluid-jet case (1,501 points, a 36 × 36-pixel column, points 4
//! pixels apart) G has about 0.43 million entries against the 1.9 million of M's columns read
//! twice per product (M·v and Mᵀ·y): a product with G costs a ninth, and the solve never touches the
//! pixels again until the final M·t.
//!
//! G is assembled row by row from M's columns: with each weighted pixel's list of the
//! columns that reach it, row j of G is Σ over j's pixels i of w_i·M_ij·(row i of M), in
//! Σ_i c_i² multiply-adds for c_i the columns reaching pixel i. The form is chosen when M
//! gives its columns, that work is at most [`MAX_WORK`] and the lists and G fit in
//! [`MAX_BYTES`]; otherwise the solver keeps the products (a large map's FFT convolution,
//! whose columns are wide and many).

use rayon::prelude::*;

use super::operator::DwellOperator;

/// The most multiply-adds the assembly may take (about a second on two cores).
pub const MAX_WORK: f64 = 2e9;

/// The most memory the pixel lists and G may hold, bytes.
pub const MAX_BYTES: f64 = 512.0 * 1024.0 * 1024.0;

/// One row j of G as assembled: its columns and values, (MᵀWB)_j· and (MᵀWd)_j.
type NormalRow = (Vec<u32>, Vec<f64>, Vec<f64>, f64);

/// G = MᵀWM (compressed rows, full symmetric), and the fit's other moments (module docs).
#[derive(Debug)]
pub struct Normal {
    starts: Vec<usize>,
    columns: Vec<u32>,
    values: Vec<f64>,
    /// MᵀW·b for each free term b (k vectors of n).
    pub free_moments: Vec<Vec<f64>>,
    /// MᵀW·d.
    pub target_moment: Vec<f64>,
    /// The entries of M's columns, every row's (what M·v and Mᵀ·y each read).
    column_entries: usize,
}

impl Normal {
    /// The normal form of `op` under `weights` with target `target` and free terms
    /// `free_terms`, or `None` when `op` does not give its columns or the form would cost
    /// more than [`MAX_WORK`] or [`MAX_BYTES`].
    pub fn assemble(
        op: &dyn DwellOperator,
        weights: &[f64],
        target: &[f64],
        free_terms: &[Vec<f64>],
    ) -> Option<Normal> {
        let (rows, n) = (op.rows(), op.cols());
        if n > u32::MAX as usize {
            return None;
        }
        // Pass 1: how many columns reach each weighted pixel.
        let mut counts = vec![0usize; rows];
        let mut column_entries = 0;
        for j in 0..n {
            let held = op.column_runs(j, &mut |first, values| {
                column_entries += values.len();
                for (i, _) in values.iter().enumerate() {
                    if weights[first + i] > 0.0 {
                        counts[first + i] += 1;
                    }
                }
            });
            if !held {
                return None;
            }
        }
        let work: f64 = counts.iter().map(|&c| (c * c) as f64).sum();
        let entries: usize = counts.iter().sum();
        let g_bound = work.min((n * n) as f64);
        if work > MAX_WORK || (entries as f64 + g_bound) * 12.0 > MAX_BYTES {
            return None;
        }
        // Pass 2: the pixel lists, (column, M_ij) for each weighted pixel.
        let mut starts = Vec::with_capacity(rows + 1);
        starts.push(0);
        for c in &counts {
            starts.push(starts.last().unwrap() + c);
        }
        let mut fill = starts.clone();
        let mut list_columns = vec![0u32; entries];
        let mut list_values = vec![0.0; entries];
        for j in 0..n {
            op.column_runs(j, &mut |first, values| {
                for (i, &v) in values.iter().enumerate() {
                    let row = first + i;
                    if weights[row] > 0.0 {
                        list_columns[fill[row]] = j as u32;
                        list_values[fill[row]] = v;
                        fill[row] += 1;
                    }
                }
            });
        }
        // Rows of G in parallel, each summed into a dense accumulator (one per thread) over
        // the columns its pixels meet.
        let rows_of_g: Vec<NormalRow> = (0..n)
            .into_par_iter()
            .map_init(
                || (vec![0.0; n], Vec::<u32>::new()),
                |(acc, touched), j| {
                    let mut free = vec![0.0; free_terms.len()];
                    let mut target_moment = 0.0;
                    op.column_runs(j, &mut |first, values| {
                        for (i, &v) in values.iter().enumerate() {
                            let row = first + i;
                            let w = weights[row];
                            if w <= 0.0 {
                                continue;
                            }
                            let a = w * v;
                            target_moment += a * target[row];
                            for (f, b) in free.iter_mut().zip(free_terms) {
                                *f += a * b[row];
                            }
                            let (s, e) = (starts[row], starts[row + 1]);
                            for (&k, &m) in list_columns[s..e].iter().zip(&list_values[s..e]) {
                                if acc[k as usize] == 0.0 {
                                    touched.push(k);
                                }
                                acc[k as usize] += a * m;
                            }
                        }
                    });
                    touched.sort_unstable();
                    touched.dedup();
                    let mut columns = Vec::with_capacity(touched.len());
                    let mut values = Vec::with_capacity(touched.len());
                    for &k in touched.iter() {
                        let v = std::mem::take(&mut acc[k as usize]);
                        if v != 0.0 {
                            columns.push(k);
                            values.push(v);
                        }
                    }
                    touched.clear();
                    (columns, values, free, target_moment)
                },
            )
            .collect();
        let mut g_starts = Vec::with_capacity(n + 1);
        g_starts.push(0);
        let mut columns = Vec::new();
        let mut values = Vec::new();
        let mut free_moments = vec![vec![0.0; n]; free_terms.len()];
        let mut target_moment = vec![0.0; n];
        for (j, (c, v, free, d)) in rows_of_g.into_iter().enumerate() {
            columns.extend(c);
            values.extend(v);
            g_starts.push(columns.len());
            for (moment, f) in free_moments.iter_mut().zip(free) {
                moment[j] = f;
            }
            target_moment[j] = d;
        }
        Some(Normal {
            starts: g_starts,
            columns,
            values,
            free_moments,
            target_moment,
            column_entries,
        })
    }

    /// The work of a product with G in products with M and Mᵀ: G's entries over the twice
    /// M's columns' that M·v and Mᵀ·y read.
    pub fn product_work(&self) -> f64 {
        self.values.len() as f64 / (2 * self.column_entries).max(1) as f64
    }

    /// G·v.
    pub fn apply(&self, v: &[f64]) -> Vec<f64> {
        (0..self.starts.len() - 1)
            .into_par_iter()
            .with_min_len(64)
            .map(|j| {
                let (s, e) = (self.starts[j], self.starts[j + 1]);
                self.columns[s..e]
                    .iter()
                    .zip(&self.values[s..e])
                    .map(|(&k, g)| g * v[k as usize])
                    .sum()
            })
            .collect()
    }

    /// G's diagonal: Σ_i w_i·M_ij² for each column.
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.starts.len() - 1)
            .map(|j| {
                let (s, e) = (self.starts[j], self.starts[j + 1]);
                self.columns[s..e]
                    .binary_search(&(j as u32))
                    .map_or(0.0, |at| self.values[s + at])
            })
            .collect()
    }

    /// G's stored entries.
    pub fn entries(&self) -> usize {
        self.values.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small operator that holds its columns as runs of rows (two runs each, to exercise
    /// the pieces), with rows weighted 0, 1 and 2.5.
    #[derive(Debug)]
    struct Runs {
        rows: usize,
        columns: Vec<Vec<(usize, Vec<f64>)>>,
    }

    impl DwellOperator for Runs {
        fn rows(&self) -> usize {
            self.rows
        }
        fn cols(&self) -> usize {
            self.columns.len()
        }
        fn apply(&self, t: &[f64]) -> Vec<f64> {
            let mut out = vec![0.0; self.rows];
            for (column, tj) in self.columns.iter().zip(t) {
                for (first, values) in column {
                    for (i, v) in values.iter().enumerate() {
                        out[first + i] += v * tj;
                    }
                }
            }
            out
        }
        fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
            self.columns
                .iter()
                .map(|column| {
                    column
                        .iter()
                        .map(|(first, values)| {
                            values
                                .iter()
                                .enumerate()
                                .map(|(i, v)| v * y[first + i])
                                .sum::<f64>()
                        })
                        .sum()
                })
                .collect()
        }
        fn column_runs(&self, j: usize, visit: &mut dyn FnMut(usize, &[f64])) -> bool {
            for (first, values) in &self.columns[j] {
                visit(*first, values);
            }
            true
        }
    }

    /// G·v, the moments and the diagonal equal MᵀW(M·v), MᵀWb and MᵀWd taken through the
    /// operator's own products, to 1e-13 of their scale (sums of a few hundred products of
    /// O(1) numbers in another order).
    #[test]
    fn the_normal_form_is_the_products_through_m() {
        let (rows, cols) = (90, 23);
        let columns: Vec<Vec<(usize, Vec<f64>)>> = (0..cols)
            .map(|j| {
                let a = (j * 3) % 70;
                vec![
                    (
                        a,
                        (0..7).map(|i| ((i + j) as f64 * 0.7).sin() + 1.1).collect(),
                    ),
                    (
                        a + 12,
                        (0..5).map(|i| ((i * j) as f64 * 0.3).cos()).collect(),
                    ),
                ]
            })
            .collect();
        let op = Runs { rows, columns };
        let weights: Vec<f64> = (0..rows)
            .map(|i| [0.0, 1.0, 2.5][i % 3] * f64::from(i < 80))
            .collect();
        let target: Vec<f64> = (0..rows).map(|i| (i as f64 * 0.2).sin() * 30.0).collect();
        let free = vec![
            vec![1.0; rows],
            (0..rows).map(|i| i as f64 - 40.0).collect(),
        ];
        let normal = Normal::assemble(&op, &weights, &target, &free).unwrap();
        let weighted = |y: &[f64]| -> Vec<f64> {
            let wy: Vec<f64> = y.iter().zip(&weights).map(|(a, w)| a * w).collect();
            op.apply_transpose(&wy)
        };
        let close = |ours: &[f64], theirs: &[f64]| {
            let scale = theirs.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
            for (a, b) in ours.iter().zip(theirs) {
                assert!((a - b).abs() <= 1e-13 * scale, "{a} vs {b}");
            }
        };
        let v: Vec<f64> = (0..cols).map(|j| (j as f64 * 1.3).cos() + 0.2).collect();
        close(&normal.apply(&v), &weighted(&op.apply(&v)));
        close(&normal.target_moment, &weighted(&target));
        for (moment, b) in normal.free_moments.iter().zip(&free) {
            close(moment, &weighted(b));
        }
        let diagonal: Vec<f64> = (0..cols)
            .map(|j| {
                let mut unit = vec![0.0; cols];
                unit[j] = 1.0;
                weighted(&op.apply(&unit))[j]
            })
            .collect();
        close(&normal.diagonal(), &diagonal);
    }

    /// An operator that does not give its columns has no normal form.
    #[test]
    fn without_columns_there_is_no_normal_form() {
        #[derive(Debug)]
        struct Opaque;
        impl DwellOperator for Opaque {
            fn rows(&self) -> usize {
                3
            }
            fn cols(&self) -> usize {
                2
            }
            fn apply(&self, t: &[f64]) -> Vec<f64> {
                vec![t[0], t[1], t[0] + t[1]]
            }
            fn apply_transpose(&self, y: &[f64]) -> Vec<f64> {
                vec![y[0] + y[2], y[1] + y[2]]
            }
        }
        assert!(Normal::assemble(&Opaque, &[1.0; 3], &[0.0; 3], &[]).is_none());
    }
}
