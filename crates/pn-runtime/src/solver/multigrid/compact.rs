//! The coarse levels' operators in compact storage: CSR with 32-bit column indices and
//! single-precision values (8 bytes per entry instead of 16), products accumulated in double
//! precision.
//!
//! Only the preconditioner reads them: the Krylov method's own products, its residuals and
//! the stopping test stay in double precision with the finest operator, so the answer meets
//! the same tolerance; the rounding of the coarse entries (relative 6e-8) only perturbs the
//! preconditioner (docs/solvers.md, "Coarse levels in single precision"). The V-cycle's
//! traffic on the coarse levels, which after the stencil `S` (`parity::stencil_s`) is most
//! of a cycle's, halves. A symmetric matrix stays exactly symmetric (equal entries round
//! alike).

use rayon::prelude::*;
use sprs::CsMat;

/// Rows per parallel task of [`CompactCsr::apply`].
const ROWS_PER_TASK: usize = 4096;

/// A square CSR matrix with `u32` columns and `f32` values.
pub struct CompactCsr {
    indptr: Vec<usize>,
    indices: Vec<u32>,
    data: Vec<f32>,
}

impl CompactCsr {
    /// Rounds `a` (CSR, fewer than 2³² columns) to compact storage; `None` when it does
    /// not fit (too many columns, or an entry outside `f32`'s range).
    pub fn new(a: &CsMat<f64>) -> Option<Self> {
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
            indices: a.indices().iter().map(|&c| c as u32).collect(),
            data,
        })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.indptr.len() - 1
    }

    /// `y = A x`, accumulated in `f64`.
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(y.len(), self.rows());
        let (ip, ix, dv) = (&self.indptr, &self.indices, &self.data);
        y.par_chunks_mut(ROWS_PER_TASK)
            .enumerate()
            .for_each(|(c, ys)| {
                let base = c * ROWS_PER_TASK;
                for (k, yi) in ys.iter_mut().enumerate() {
                    let r = base + k;
                    let mut s = 0.0;
                    for j in ip[r]..ip[r + 1] {
                        s += f64::from(dv[j]) * x[ix[j] as usize];
                    }
                    *yi = s;
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_agree_with_the_double_matrix_to_single_precision() {
        // [[4, -1, 0], [-1, 4, -1e-3], [0, -1e-3, 2]]
        let a = CsMat::new(
            (3, 3),
            vec![0, 2, 5, 7],
            vec![0, 1, 0, 1, 2, 1, 2],
            vec![4.0, -1.0, -1.0, 4.0, -1e-3, -1e-3, 2.0],
        );
        let c = CompactCsr::new(&a).unwrap();
        let x = [1.0 / 3.0, 2.0, -0.7];
        let mut y = [0.0; 3];
        c.apply(&x, &mut y);
        let mut want = [0.0; 3];
        crate::linalg::spmv(&a, &x, &mut want);
        for (g, w) in y.iter().zip(&want) {
            assert!((g - w).abs() <= 1e-7 * w.abs(), "{g} vs {w}");
        }
        // Out of f32's range, or flushed to zero: refused.
        let big = CsMat::new((1, 1), vec![0, 1], vec![0], vec![1e40]);
        assert!(CompactCsr::new(&big).is_none());
        let tiny = CsMat::new((1, 1), vec![0, 1], vec![0], vec![1e-50]);
        assert!(CompactCsr::new(&tiny).is_none());
    }
}
