//! Parallel sparse matrix–vector products and vector kernels for the iterative solvers.

use rayon::prelude::*;
use sprs::CsMat;

/// Rows per rayon task in the matrix–vector product.
const ROWS_PER_TASK: usize = 4096;
/// Vector length below which vector kernels run serially.
const SERIAL_BELOW: usize = 1 << 15;

/// A CSR matrix with 32-bit column indices: 12 instead of 16 bytes per non-zero, which
/// matters because the products are memory-bound. Values are `f64`, or `f32`
/// ([`CompactCsr::rounded_from_csr`]: 8 bytes per non-zero) for operators only a
/// preconditioner reads (the multigrid's coarse levels); products accumulate in `f64`.
pub struct CompactCsr<V = f64> {
    indptr: Vec<usize>,
    indices: Vec<u32>,
    data: Vec<V>,
    cols: usize,
}

impl CompactCsr<f64> {
    /// Copies `a` (CSR), or returns `None` when it has more than `u32::MAX` columns.
    pub fn from_csr(a: &CsMat<f64>) -> Option<Self> {
        assert!(a.is_csr(), "CompactCsr needs a CSR matrix");
        if a.cols() > u32::MAX as usize {
            return None;
        }
        Some(Self {
            indptr: a.indptr().raw_storage().to_vec(),
            indices: a.indices().iter().map(|&i| i as u32).collect(),
            data: a.data().to_vec(),
            cols: a.cols(),
        })
    }

    /// Modelled bytes one product moves ([`csr_product_bytes`] with 4-byte indices).
    pub fn bytes_per_product(&self) -> u64 {
        csr_product_bytes(self.data.len(), self.rows(), self.cols, 4)
    }
}

impl CompactCsr<f32> {
    /// `a` with its values rounded to `f32` (relative 6e-8; a symmetric matrix stays exactly
    /// symmetric, equal entries round alike); `None` when `a` is not CSR, has more than
    /// `u32::MAX` columns, or has an entry outside `f32`'s range (overflowing, or non-zero
    /// and flushed to zero).
    pub fn rounded_from_csr(a: &CsMat<f64>) -> Option<Self> {
        if !a.is_csr() || a.cols() > u32::MAX as usize {
            return None;
        }
        let data: Vec<f32> = a.data().iter().map(|&v| v as f32).collect();
        if data
            .iter()
            .zip(a.data())
            .any(|(&f, &d)| !f.is_finite() || (f == 0.0 && d != 0.0))
        {
            return None;
        }
        Some(Self {
            indptr: a.indptr().raw_storage().to_vec(),
            indices: a.indices().iter().map(|&i| i as u32).collect(),
            data,
            cols: a.cols(),
        })
    }
}

impl<V: Copy + Into<f64> + Sync> CompactCsr<V> {
    /// Rows.
    pub fn rows(&self) -> usize {
        self.indptr.len() - 1
    }

    /// `y = A x`, accumulated in `f64`.
    pub fn mul(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(self.cols, x.len());
        assert_eq!(self.rows(), y.len());
        let (indptr, indices, data) = (&self.indptr, &self.indices, &self.data);
        y.par_chunks_mut(ROWS_PER_TASK)
            .enumerate()
            .for_each(|(c, ys)| {
                let base = c * ROWS_PER_TASK;
                for (k, yi) in ys.iter_mut().enumerate() {
                    let r = base + k;
                    let (lo, hi) = (indptr[r], indptr[r + 1]);
                    *yi = row_dot(&indices[lo..hi], &data[lo..hi], x);
                }
            });
    }
}

/// A matrix prepared for repeated products: compact indices when they fit, else as is.
pub enum CsrOperator {
    /// 32-bit column indices.
    Compact(CompactCsr),
    /// The original matrix.
    Plain(CsMat<f64>),
}

impl CsrOperator {
    /// Prepares `a` (CSR), taking ownership.
    pub fn new(a: CsMat<f64>) -> Self {
        match CompactCsr::from_csr(&a) {
            Some(c) => CsrOperator::Compact(c),
            None => CsrOperator::Plain(a),
        }
    }

    /// Prepares a copy of `a` (CSR).
    pub fn from_ref(a: &CsMat<f64>) -> Self {
        match CompactCsr::from_csr(a) {
            Some(c) => CsrOperator::Compact(c),
            None => CsrOperator::Plain(a.clone()),
        }
    }

    /// Modelled bytes one product moves ([`csr_product_bytes`]).
    pub fn bytes_per_product(&self) -> u64 {
        match self {
            CsrOperator::Compact(c) => c.bytes_per_product(),
            CsrOperator::Plain(a) => {
                csr_product_bytes(a.nnz(), a.rows(), a.cols(), std::mem::size_of::<usize>())
            }
        }
    }

    /// `y = A x`.
    pub fn mul(&self, x: &[f64], y: &mut [f64]) {
        match self {
            CsrOperator::Compact(c) => c.mul(x, y),
            CsrOperator::Plain(a) => spmv(a, x, y),
        }
    }
}

/// The bytes one CSR product `y = A x` ([`spmv`], [`CompactCsr::mul`]) moves, in the model
/// of the roofline (`pn_runtime::bandwidth`; every array read or written once, as STREAM
/// counts): `nnz` values (8 bytes) and column indices (`index_bytes`), `rows + 1` row
/// pointers (8 bytes), `x` read once (`cols` × 8: the gather is assumed to hit each entry
/// of `x` in memory once, the rest in cache) and `y` written once (`rows` × 8).
pub fn csr_product_bytes(nnz: usize, rows: usize, cols: usize, index_bytes: usize) -> u64 {
    (nnz * (8 + index_bytes) + 8 * (rows + 1) + 8 * cols + 8 * rows) as u64
}

/// `y = A x` for a CSR matrix with any column-index type (`usize`, or `u32` for the
/// parity blocks, `pn_runtime::solver::parity::split::BlockMat`).
pub fn spmv<I: sprs::SpIndex>(a: &sprs::CsMatI<f64, I, usize>, x: &[f64], y: &mut [f64]) {
    assert!(a.is_csr(), "spmv needs a CSR matrix");
    assert_eq!(a.cols(), x.len());
    assert_eq!(a.rows(), y.len());
    let indptr = a.indptr();
    let indptr = indptr.raw_storage();
    let indices = a.indices();
    let data = a.data();
    y.par_chunks_mut(ROWS_PER_TASK)
        .enumerate()
        .for_each(|(c, ys)| {
            let base = c * ROWS_PER_TASK;
            for (k, yi) in ys.iter_mut().enumerate() {
                let r = base + k;
                let (lo, hi) = (indptr[r], indptr[r + 1]);
                *yi = row_dot(&indices[lo..hi], &data[lo..hi], x);
            }
        });
}

/// `Σ_k vals[k] · x[cols[k]]` (one sparse row times `x`) with four partial sums: a single
/// running sum waits for each addition to finish (about 4 cycles), which made the products
/// of the multigrid's coarse levels (~30 entries per row) bound by that latency rather than
/// by memory; four independent sums let the gathers overlap. Only the order of the
/// additions changes (rounding at the 1e-16 level).
#[inline]
pub fn row_dot<I: sprs::SpIndex, V: Copy + Into<f64>>(cols: &[I], vals: &[V], x: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (c4, v4) = (cols.chunks_exact(4), vals.chunks_exact(4));
    let mut tail = 0.0;
    for (&c, &v) in c4.remainder().iter().zip(v4.remainder()) {
        tail += v.into() * x[c.index()];
    }
    for (c, v) in c4.zip(v4) {
        for l in 0..4 {
            acc[l] += v[l].into() * x[c[l].index()];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// `y = Aᵀ x` for a CSR matrix with any column-index type (a serial scatter over the rows;
/// for repeated transposed products store the transpose, [`transpose_csr`]).
pub fn spmv_transpose<I: sprs::SpIndex>(a: &sprs::CsMatI<f64, I, usize>, x: &[f64], y: &mut [f64]) {
    assert!(a.is_csr(), "spmv_transpose needs a CSR matrix");
    assert_eq!(a.rows(), x.len());
    assert_eq!(a.cols(), y.len());
    y.iter_mut().for_each(|v| *v = 0.0);
    for (r, row) in a.outer_iterator().enumerate() {
        let xr = x[r];
        for (c, &v) in row.iter() {
            y[c] += v * xr;
        }
    }
}

/// Values per parallel task of [`dot`]: a fixed split, so that the sum's association — and
/// so its rounding — does not depend on how the threads happened to share the work. (With
/// rayon's adaptive split, the same CG solve of the 32³ cloud at P_9 took 129 to 216
/// iterations from run to run.)
pub const REDUCE_CHUNK: usize = 1 << 14;

/// Euclidean dot product (`b` in `f64`, or `f32` read as `f64`: GMRES's single-precision
/// basis). Deterministic ([`chunked_sum`]).
pub fn dot<V: Copy + Into<f64> + Sync>(a: &[f64], b: &[V]) -> f64 {
    chunked_sum(a, b, lane_dot)
}

/// `Σ_chunks f(a_chunk, b_chunk)` over the paired chunks of [`REDUCE_CHUNK`] values, the
/// partial sums added in order: the same bits on any number of threads (in parallel from
/// `SERIAL_BELOW` values on).
pub fn chunked_sum<A: Sync, B: Sync>(
    a: &[A],
    b: &[B],
    f: impl Fn(&[A], &[B]) -> f64 + Sync,
) -> f64 {
    if a.len() < SERIAL_BELOW {
        return a
            .chunks(REDUCE_CHUNK)
            .zip(b.chunks(REDUCE_CHUNK))
            .map(|(x, y)| f(x, y))
            .sum();
    }
    let parts: Vec<f64> = a
        .par_chunks(REDUCE_CHUNK)
        .zip(b.par_chunks(REDUCE_CHUNK))
        .map(|(x, y)| f(x, y))
        .collect();
    parts.iter().sum()
}

/// `⟨a, b⟩` serially, with eight independent partial sums (so that the sum vectorises
/// instead of waiting on one accumulator's latency); either side in `f64` or `f32` (read as
/// `f64`).
#[inline]
pub fn lane_dot<U: Copy + Into<f64>, V: Copy + Into<f64>>(a: &[U], b: &[V]) -> f64 {
    const LANES: usize = 8;
    let mut acc = [0.0f64; LANES];
    let (ac, bc) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f64 = ac
        .remainder()
        .iter()
        .zip(bc.remainder())
        .map(|(&x, &y)| x.into() * y.into())
        .sum();
    for (x, y) in ac.zip(bc) {
        for l in 0..LANES {
            acc[l] += x[l].into() * y[l].into();
        }
    }
    acc.iter().sum::<f64>() + tail
}

/// Euclidean norm.
pub fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// `y += alpha x` (`x` in `f64`, or `f32` read as `f64`).
pub fn axpy<V: Copy + Into<f64> + Sync>(alpha: f64, x: &[V], y: &mut [f64]) {
    if y.len() < SERIAL_BELOW {
        y.iter_mut()
            .zip(x)
            .for_each(|(yi, xi)| *yi += alpha * (*xi).into());
    } else {
        y.par_iter_mut()
            .zip(x)
            .for_each(|(yi, xi)| *yi += alpha * (*xi).into());
    }
}

/// `p = s + beta p`.
pub fn xpby(s: &[f64], beta: f64, p: &mut [f64]) {
    if p.len() < SERIAL_BELOW {
        p.iter_mut()
            .zip(s)
            .for_each(|(pi, si)| *pi = si + beta * *pi);
    } else {
        p.par_iter_mut()
            .zip(s)
            .for_each(|(pi, si)| *pi = si + beta * *pi);
    }
}

/// `v` cut into consecutive runs of the lengths `lens` (from the start; what is left after
/// the last run is not returned), so that parallel tasks can each fill their own run.
/// Panics when the lengths add up to more than `v.len()`.
pub fn split_runs<T>(v: &mut [T], lens: impl IntoIterator<Item = usize>) -> Vec<&mut [T]> {
    let mut rest = v;
    lens.into_iter()
        .map(|len| {
            let (run, tail) = std::mem::take(&mut rest).split_at_mut(len);
            rest = tail;
            run
        })
        .collect()
}

/// `r = b − A x`.
pub fn residual(a: &CsMat<f64>, x: &[f64], b: &[f64], r: &mut [f64]) {
    spmv(a, x, r);
    r.iter_mut().zip(b).for_each(|(ri, bi)| *ri = bi - *ri);
}

/// The transpose of a CSR matrix, again in CSR form.
pub fn transpose_csr(a: &CsMat<f64>) -> CsMat<f64> {
    a.transpose_view().to_csr()
}

/// Solves the small dense system `a x = rhs` (rows of `a`) by Gaussian elimination with
/// partial pivoting; `None` when a pivot is at or below `min_pivot` in magnitude (the caller
/// states what counts as singular relative to its own scale) or the solution is not finite.
/// For the few-unknown systems of the solvers (Gram matrices, boundary conditions,
/// Anderson acceleration), not for anything large.
pub fn solve_small_dense(
    mut a: Vec<Vec<f64>>,
    mut rhs: Vec<f64>,
    min_pivot: f64,
) -> Option<Vec<f64>> {
    let n = rhs.len();
    for col in 0..n {
        let p = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        let pivot = a[p][col].abs();
        if pivot <= min_pivot || pivot.is_nan() {
            return None;
        }
        a.swap(col, p);
        rhs.swap(col, p);
        let (pivot_rows, rest) = a.split_at_mut(col + 1);
        let pivot = &pivot_rows[col];
        for (k, row) in rest.iter_mut().enumerate() {
            let f = row[col] / pivot[col];
            for (x, p) in row[col..n].iter_mut().zip(&pivot[col..n]) {
                *x -= f * p;
            }
            rhs[col + 1 + k] -= f * rhs[col];
        }
    }
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|c| a[r][c] * rhs[c]).sum();
        rhs[r] = (rhs[r] - s) / a[r][r];
    }
    rhs.iter().all(|v| v.is_finite()).then_some(rhs)
}

/// The floating-point types the preconditioner's finest level runs in: `f64`, or `f32` where
/// a single-precision cycle is enough (`solver::multigrid`, `MgOptions::single_fine`).
pub trait Real:
    Copy
    + Send
    + Sync
    + Default
    + PartialEq
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::AddAssign
    + std::ops::SubAssign
    + 'static
{
    /// `v` rounded to this type.
    fn of(v: f64) -> Self;
    /// This value as `f64`.
    fn wide(self) -> f64;
}

impl Real for f64 {
    #[inline]
    fn of(v: f64) -> Self {
        v
    }
    #[inline]
    fn wide(self) -> f64 {
        self
    }
}

impl Real for f32 {
    #[inline]
    fn of(v: f64) -> Self {
        v as f32
    }
    #[inline]
    fn wide(self) -> f64 {
        self as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_runs_cuts_consecutive_runs() {
        let mut v: Vec<u32> = (0..10).collect();
        let runs = split_runs(&mut v, [3, 0, 4]);
        let runs: Vec<Vec<u32>> = runs.into_iter().map(|r| r.to_vec()).collect();
        assert_eq!(runs, vec![vec![0, 1, 2], vec![], vec![3, 4, 5, 6]]);
    }

    /// `dot` gives the same bits on 1, 2 and 3 threads (and on the caller's pool), and
    /// equals the plain sum to rounding, on lengths below and above the parallel threshold.
    #[test]
    fn dot_is_deterministic_across_thread_counts() {
        for n in [1000, SERIAL_BELOW + 12_345, 5 * REDUCE_CHUNK + 3] {
            let a: Vec<f64> = (0..n)
                .map(|i| ((i * 7919) % 1013) as f64 / 97.0 - 5.0)
                .collect();
            let b: Vec<f32> = (0..n).map(|i| ((i as f32) * 0.37).sin()).collect();
            let here = dot(&a, &b);
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let there = pool.install(|| dot(&a, &b));
                assert_eq!(here.to_bits(), there.to_bits(), "n {n}, {threads} threads");
            }
            let plain: f64 = a.iter().zip(&b).map(|(x, &y)| x * y as f64).sum();
            let scale: f64 = a.iter().zip(&b).map(|(x, &y)| (x * y as f64).abs()).sum();
            assert!((here - plain).abs() <= 1e-13 * scale, "{here} vs {plain}");
        }
    }

    /// `row_dot` (four partial sums) against the plain sum, for row lengths around the
    /// multiple of four.
    #[test]
    fn row_dot_equals_the_plain_sum() {
        let x: Vec<f64> = (0..50).map(|i| (i as f64).sin()).collect();
        for len in 0..12 {
            let cols: Vec<u32> = (0..len).map(|k| (k * 7 % 50) as u32).collect();
            let vals: Vec<f32> = (0..len).map(|k| 0.5 - k as f32 * 0.25).collect();
            let plain: f64 = cols
                .iter()
                .zip(&vals)
                .map(|(&c, &v)| v as f64 * x[c as usize])
                .sum();
            assert!((row_dot(&cols, &vals, &x) - plain).abs() < 1e-14);
        }
    }

    #[test]
    fn small_dense_solve_pivots_and_refuses_singular_systems() {
        // A zero in the first pivot position: partial pivoting swaps the rows.
        let x =
            solve_small_dense(vec![vec![0.0, 2.0], vec![1.0, 1.0]], vec![4.0, 3.0], 0.0).unwrap();
        assert!(
            (x[0] - 1.0).abs() < 1e-15 && (x[1] - 2.0).abs() < 1e-15,
            "{x:?}"
        );
        let singular = vec![vec![1.0, 2.0], vec![2.0, 4.0]];
        assert!(solve_small_dense(singular, vec![1.0, 0.0], 1e-13).is_none());
        assert!(solve_small_dense(vec![vec![0.0]], vec![1.0], 0.0).is_none());
        assert!(solve_small_dense(vec![vec![1.0]], vec![f64::NAN], 0.0).is_none());
        assert_eq!(solve_small_dense(vec![], vec![], 0.0), Some(vec![]));
    }

    #[test]
    fn rounded_products_agree_with_the_double_matrix_to_single_precision() {
        // [[4, -1, 0], [-1, 4, -1e-3], [0, -1e-3, 2]]
        let a = CsMat::new(
            (3, 3),
            vec![0, 2, 5, 7],
            vec![0, 1, 0, 1, 2, 1, 2],
            vec![4.0, -1.0, -1.0, 4.0, -1e-3, -1e-3, 2.0],
        );
        let c = CompactCsr::rounded_from_csr(&a).unwrap();
        let x = [1.0 / 3.0, 2.0, -0.7];
        let mut y = [0.0; 3];
        c.mul(&x, &mut y);
        let mut want = [0.0; 3];
        spmv(&a, &x, &mut want);
        for (g, w) in y.iter().zip(&want) {
            assert!((g - w).abs() <= 1e-7 * w.abs(), "{g} vs {w}");
        }
        // Out of f32's range, or flushed to zero: refused.
        let big = CsMat::new((1, 1), vec![0, 1], vec![0], vec![1e40]);
        assert!(CompactCsr::rounded_from_csr(&big).is_none());
        let tiny = CsMat::new((1, 1), vec![0, 1], vec![0], vec![1e-50]);
        assert!(CompactCsr::rounded_from_csr(&tiny).is_none());
    }

    #[test]
    fn spmv_and_transpose() {
        // [[1, 2, 0], [0, 3, 4]]
        let a = CsMat::new(
            (2, 3),
            vec![0, 2, 4],
            vec![0, 1, 1, 2],
            vec![1.0, 2.0, 3.0, 4.0],
        );
        let mut y = vec![0.0; 2];
        spmv(&a, &[1.0, 1.0, 1.0], &mut y);
        assert_eq!(y, vec![3.0, 7.0]);
        let at = transpose_csr(&a);
        let mut z = vec![0.0; 3];
        spmv(&at, &[1.0, 1.0], &mut z);
        assert_eq!(z, vec![1.0, 5.0, 4.0]);
        let mut zt = vec![0.0; 3];
        spmv_transpose(&a, &[1.0, 1.0], &mut zt);
        assert_eq!(zt, z);
        let c = CompactCsr::from_csr(&at).unwrap();
        let mut w = vec![0.0; 3];
        c.mul(&[1.0, 1.0], &mut w);
        assert_eq!(w, z);
    }
}
