//! What the iterative methods of `pn_runtime::solver` need from a system: the
//! [`LinearOperator`] trait (products with `A` and `Aᵀ`) and the [`Preconditioner`] trait
//! (`z = M⁻¹ r`).
//!
//! Operators: the assembled CSR matrix ([`AssembledOperator`], and plain `CsMat` for one-off
//! use), the matrix-free operator of `pn_runtime::MatFreeOperator`, the reduced parity operator
//! (`pn_runtime::solver::parity::reduced::ReducedOperator`) and [`Counted`], which counts the
//! products taken with any of them. Preconditioners: [`Identity`], [`Jacobi`], and in
//! `pn_runtime::solver::parity::precond` ILU(0), block-Jacobi and the multigrid cycle
//! (`pn_runtime::solver::multigrid::Multigrid::with_fine`).

use crate::linalg::{csr_product_bytes, transpose_csr, CsrOperator};
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
    /// The bytes one application (`apply`, or `apply_transpose` where it moves the same)
    /// moves to and from memory in the operator's own traffic model, counted as STREAM
    /// counts (`pn_runtime::bandwidth`: every array read or written once, write-allocate not
    /// counted); `None` for an operator without a model. With the measured bandwidth this
    /// gives the roofline of `pn bench`.
    fn bytes_per_application(&self) -> Option<u64> {
        None
    }
}

/// A preconditioner: `z ≈ A⁻¹ r`, a fixed linear map (the Krylov methods of
/// `pn_runtime::solver` apply it once or twice per iteration).
pub trait Preconditioner: Send + Sync {
    /// `z = M⁻¹ r` (`z` is overwritten).
    fn apply(&self, r: &[f64], z: &mut [f64]);
}

/// No preconditioning: `z = r`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Identity;

impl Preconditioner for Identity {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(r);
    }
}

/// Jacobi preconditioning `z = D⁻¹ r` with `D` the diagonal of `A`.
#[derive(Clone, Debug)]
pub struct Jacobi {
    inv_diag: Vec<f64>,
}

impl Jacobi {
    /// From the diagonal of `A`; `Err(row)` for the first zero or non-finite entry.
    pub fn from_diagonal(diag: &[f64]) -> Result<Self, usize> {
        match diag.iter().position(|v| *v == 0.0 || !v.is_finite()) {
            Some(row) => Err(row),
            None => Ok(Self {
                inv_diag: diag.iter().map(|v| 1.0 / v).collect(),
            }),
        }
    }

    /// From the diagonal of a CSR matrix (missing entries are zero, hence an error).
    pub fn for_matrix(a: &CsMat<f64>) -> Result<Self, usize> {
        let mut d = vec![0.0; a.rows()];
        for (i, row) in a.outer_iterator().enumerate() {
            d[i] = row.get(i).copied().unwrap_or(0.0);
        }
        Self::from_diagonal(&d)
    }
}

impl Preconditioner for Jacobi {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        use rayon::prelude::*;
        z.par_iter_mut()
            .zip(r.par_iter().zip(self.inv_diag.par_iter()))
            .for_each(|(zi, (ri, di))| *zi = ri * di);
    }
}

/// An operator that counts the products taken with it (`A x` and `Aᵀ x` alike), so that
/// solvers can report their work in products with `A` ([`crate::SolveStats::operator_applications`]).
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
    fn bytes_per_application(&self) -> Option<u64> {
        self.inner.bytes_per_application()
    }
}

/// `r = b − A x` for any operator.
pub fn op_residual(a: &dyn LinearOperator, x: &[f64], b: &[f64], r: &mut [f64]) {
    use rayon::prelude::*;
    a.apply(x, r);
    r.par_iter_mut()
        .zip(b.par_iter())
        .with_min_len(1 << 14)
        .for_each(|(ri, bi)| *ri = bi - *ri);
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
    /// `A x` ([`csr_product_bytes`], 8-byte indices); the transposed product is a serial
    /// scatter that moves more.
    fn bytes_per_application(&self) -> Option<u64> {
        Some(csr_product_bytes(
            self.nnz(),
            CsMat::rows(self),
            CsMat::cols(self),
            std::mem::size_of::<usize>(),
        ))
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
    /// The mean of the products with `A` and `Aᵀ` (equal for a square `A`: the same
    /// non-zeros, rows and columns swapped), each [`csr_product_bytes`] with 4-byte indices.
    fn bytes_per_application(&self) -> Option<u64> {
        Some((self.a.bytes_per_product() + self.at.bytes_per_product()) / 2)
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
        let counted = Counted::new(&op);
        counted.apply(&[1.0, -1.0, 2.0], &mut y);
        counted.apply_transpose(&[1.0, 2.0], &mut z1);
        assert_eq!(counted.count(), 2);
    }

    #[test]
    fn jacobi_divides_by_the_diagonal_and_refuses_zeros() {
        let a = CsMat::new((2, 2), vec![0, 1, 2], vec![0, 1], vec![2.0, 4.0]);
        let j = Jacobi::for_matrix(&a).unwrap();
        let mut z = vec![0.0; 2];
        j.apply(&[1.0, 1.0], &mut z);
        assert_eq!(z, vec![0.5, 0.25]);
        let singular = CsMat::new((2, 2), vec![0, 1, 1], vec![0], vec![2.0]);
        assert_eq!(Jacobi::for_matrix(&singular).err(), Some(1));
        Identity.apply(&[3.0, 4.0], &mut z);
        assert_eq!(z, vec![3.0, 4.0]);
    }
}
