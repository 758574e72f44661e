//! Galerkin coarse operators `A_c = Pᵀ A P` for the piecewise-constant aggregation `P`.
//!
//! With `P` the aggregation of [`super::aggregate`](mod@super::aggregate), entry `(I, J)` of `Pᵀ A P` is the sum
//! of `A_ij` over `i ∈ I`, `j ∈ J`. The finest level of the parity systems is built from
//! the parity blocks without forming `S` ([`crate::solver::parity::galerkin`], with the
//! row builder [`build_rows`] of this module).

use super::aggregate::Aggregation;
use rayon::prelude::*;
use sprs::CsMat;

/// Row sums into a dense accumulator over the columns, remembering which were touched,
/// so that a row costs its number of contributions plus a sort of its distinct columns.
pub struct RowAccumulator {
    values: Vec<f64>,
    mark: Vec<bool>,
    touched: Vec<u32>,
    /// A row given in order by [`RowAccumulator::push_sorted`].
    sorted: Vec<(u32, f64)>,
}

impl RowAccumulator {
    fn new(n_cols: usize) -> Self {
        Self {
            values: vec![0.0; n_cols],
            mark: vec![false; n_cols],
            touched: Vec::new(),
            sorted: Vec::new(),
        }
    }

    /// Adds `v` to column `j`.
    #[inline]
    pub fn add(&mut self, j: u32, v: f64) {
        let ju = j as usize;
        if !self.mark[ju] {
            self.mark[ju] = true;
            self.touched.push(j);
        }
        self.values[ju] += v;
    }

    /// Appends column `j` with value `v` to a row that takes no [`RowAccumulator::add`]:
    /// the caller gives each column once, in ascending order.
    #[inline]
    pub fn push_sorted(&mut self, j: u32, v: f64) {
        debug_assert!(self.touched.is_empty() && self.sorted.last().is_none_or(|l| l.0 < j));
        self.sorted.push((j, v));
    }

    /// Moves the row (sorted columns) into `cols`/`vals` and resets the accumulator.
    fn drain(&mut self, cols: &mut Vec<usize>, vals: &mut Vec<f64>) {
        if !self.sorted.is_empty() {
            assert!(self.touched.is_empty(), "push_sorted and add in one row");
            for (j, v) in self.sorted.drain(..) {
                cols.push(j as usize);
                vals.push(v);
            }
            return;
        }
        self.touched.sort_unstable();
        for &j in &self.touched {
            let ju = j as usize;
            cols.push(ju);
            vals.push(self.values[ju]);
            self.values[ju] = 0.0;
            self.mark[ju] = false;
        }
        self.touched.clear();
    }
}

/// Builds a CSR matrix with `n_rows × n_cols` from a row generator: `row(i, acc)` adds
/// `(column, value)` contributions in any order; duplicates are summed, columns sorted.
/// Rows are split into a few large parallel tasks, each with one dense accumulator.
pub fn build_rows(
    n_rows: usize,
    n_cols: usize,
    row: impl Fn(usize, &mut RowAccumulator) + Sync,
) -> CsMat<f64> {
    build_rows_with(n_rows, n_cols, || (), |i, acc, _| row(i, acc))
}

/// [`build_rows`] with a scratch value per parallel task, made by `scratch` and handed to
/// every row of the task (`row(i, acc, scratch)`).
pub fn build_rows_with<T>(
    n_rows: usize,
    n_cols: usize,
    scratch: impl Fn() -> T + Sync,
    row: impl Fn(usize, &mut RowAccumulator, &mut T) + Sync,
) -> CsMat<f64> {
    let tasks = (4 * rayon::current_num_threads()).clamp(1, n_rows.max(1));
    let per = n_rows.div_ceil(tasks).max(1);
    let chunks: Vec<(Vec<usize>, Vec<usize>, Vec<f64>)> = (0..n_rows.div_ceil(per))
        .into_par_iter()
        .map(|c| {
            let (mut nnz, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
            let mut acc = RowAccumulator::new(n_cols);
            let mut own = scratch();
            for i in c * per..((c + 1) * per).min(n_rows) {
                row(i, &mut acc, &mut own);
                let start = cols.len();
                acc.drain(&mut cols, &mut vals);
                nnz.push(cols.len() - start);
            }
            (nnz, cols, vals)
        })
        .collect();
    let total: usize = chunks.iter().map(|c| c.1.len()).sum();
    let mut indptr = Vec::with_capacity(n_rows + 1);
    let (mut indices, mut data) = (Vec::with_capacity(total), Vec::with_capacity(total));
    indptr.push(0);
    let mut acc = 0usize;
    for (nnz, cols, vals) in chunks {
        for k in nnz {
            acc += k;
            indptr.push(acc);
        }
        indices.extend(cols);
        data.extend(vals);
    }
    CsMat::new((n_rows, n_cols), indptr, indices, data)
}

/// `Pᵀ A P` for a CSR matrix `a` (the coarse levels, or a scalar system such as CDA).
pub fn coarse_from_csr(a: &CsMat<f64>, ag: &Aggregation) -> CsMat<f64> {
    let nc = ag.coarse_len();
    let ap = a.indptr();
    let ap = ap.raw_storage();
    let (ai, av) = (a.indices(), a.data());
    build_rows(nc, nc, |ci, acc| {
        for &i in &ag.members[ag.ptr[ci]..ag.ptr[ci + 1]] {
            let i = i as usize;
            for p in ap[i]..ap[i + 1] {
                acc.add(ag.agg[ai[p]], av[p]);
            }
        }
    })
}
