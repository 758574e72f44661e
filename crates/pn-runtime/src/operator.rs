//! The [`LinearOperator`] trait: what a Krylov solver needs from `A` (products with `A` and
//! `Aᵀ`), implemented for the assembled CSR matrix ([`AssembledOperator`], and plain
//! `CsMat` for one-off use) and for the matrix-free operator of [`crate::matfree`].

use crate::linalg::{transpose_csr, CsrOperator};
use sprs::CsMat;

/// A square or rectangular linear operator `A: R^cols → R^rows`.
pub trait LinearOperator: Send + Sync {
    /// Number of rows (length of `A x`).
    fn rows(&self) -> usize;
    /// Number of columns (length of `x`).
    fn cols(&self) -> usize;
    /// `y = A x` (`y` is overwritten).
    fn apply(&self, x: &[f64], y: &mut [f64]);
    /// `y = Aᵀ x` (`y` is overwritten).
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]);
}

/// An operator that counts the products taken with it (`A x` and `Aᵀ x` alike), so that
/// solvers can report their work in products with `A` ([`crate::solver::SolveStats::operator_applications`]).
pub struct Counted<'a> {
    inner: &'a dyn LinearOperator,
    count: std::sync::atomic::AtomicUsize,
}

impl<'a> Counted<'a> {
    /// Wraps `inner` with a zero count.
    pub fn new(inner: &'a dyn LinearOperator) -> Self {
        Self {
            inner,
            count: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    /// Products taken so far.
    pub fn count(&self) -> usize {
        self.count.load(std::sync::atomic::Ordering::Relaxed)
    }

    fn tick(&self) {
        self.count
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
}

impl LinearOperator for Counted<'_> {
    fn rows(&self) -> usize {
        self.inner.rows()
    }
    fn cols(&self) -> usize {
        self.inner.cols()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.tick();
        self.inner.apply(x, y);
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) {
        self.tick();
        self.inner.apply_transpose(x, y);
    }
}

/// `r = b − A x` for any operator.
pub fn op_residual(a: &dyn LinearOperator, x: &[f64], b: &[f64], r: &mut [f64]) {
    a.apply(x, r);
    r.iter_mut().zip(b).for_each(|(ri, bi)| *ri = bi - *ri);
}

/// Products with a CSR matrix directly (`Aᵀx` through sprs' transposed view, serial).
/// Prefer [`AssembledOperator`] for repeated transposed products.
impl LinearOperator for CsMat<f64> {
    fn rows(&self) -> usize {
        CsMat::rows(self)
    }
    fn cols(&self) -> usize {
        CsMat::cols(self)
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        crate::linalg::spmv(self, x, y);
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for (r, row) in self.outer_iterator().enumerate() {
            let xr = x[r];
            for (c, &v) in row.iter() {
                y[c] += v * xr;
            }
        }
    }
}

/// An assembled matrix prepared for repeated products with `A` and `Aᵀ`: both kept in
/// compact CSR form (32-bit column indices) so that both products are row-parallel. This is
/// what the CGNR baseline does; it stores the non-zeros twice.
pub struct AssembledOperator {
    a: CsrOperator,
    at: CsrOperator,
    rows: usize,
    cols: usize,
}

impl AssembledOperator {
    /// Copies `a` (CSR) and its transpose.
    pub fn new(a: &CsMat<f64>) -> Self {
        Self {
            a: CsrOperator::from_ref(a),
            at: CsrOperator::new(transpose_csr(a)),
            rows: a.rows(),
            cols: a.cols(),
        }
    }
}

impl LinearOperator for AssembledOperator {
    fn rows(&self) -> usize {
        self.rows
    }
    fn cols(&self) -> usize {
        self.cols
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.a.mul(x, y);
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) {
        self.at.mul(x, y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csr_and_assembled_agree() {
        // [[1, 2, 0], [0, 3, 4]]
        let a = CsMat::new(
            (2, 3),
            vec![0, 2, 4],
            vec![0, 1, 1, 2],
            vec![1.0, 2.0, 3.0, 4.0],
        );
        let op = AssembledOperator::new(&a);
        let mut y = vec![0.0; 2];
        op.apply(&[1.0, -1.0, 2.0], &mut y);
        assert_eq!(y, vec![-1.0, 5.0]);
        let mut z1 = vec![0.0; 3];
        let mut z2 = vec![0.0; 3];
        op.apply_transpose(&[1.0, 2.0], &mut z1);
        LinearOperator::apply_transpose(&a, &[1.0, 2.0], &mut z2);
        assert_eq!(z1, vec![1.0, 8.0, 8.0]);
        assert_eq!(z1, z2);
    }
}
