//! The reduced even-parity operator `S = D_e − B D_o⁻¹ C` (docs/design.md §5).
//!
//! Eliminating the odd unknowns from `[[D_e, B], [C, D_o]] [u_e; u_o] = [b_e; b_o]` gives
//! `S u_e = f` with `f = b_e − B D_o⁻¹ b_o`, and then `u_o = D_o⁻¹ (b_o − C u_e)`. With that
//! back-substitution the odd rows of the full residual vanish and its even rows equal the
//! reduced residual `f − S u_e`, so `‖b − A u‖₂ = ‖f − S u_e‖₂` (up to rounding): the
//! reduced iteration can stop directly on the full system's tolerance.
//!
//! `S` is applied either matrix-free (`D_e x − B (C̃ x)`, two sparse products that together
//! touch the off-diagonal entries of `A` once), from the blocks' stencils when the unknowns'
//! positions are known ([`super::stencil_s`]: no per-entry traffic), or from a CSR matrix
//! formed once.

use super::split::Split;
use super::stencil_s::StencilReduced;
use crate::solver::multigrid::Geometry;
use pn_krylov::linalg::{csr_product_bytes, dot, norm, spmv, spmv_transpose};
use pn_krylov::operator::LinearOperator;
use rayon::prelude::*;
use sprs::CsMat;
use std::sync::Arc;

impl StencilReduced {
    /// Recovers the stencils of `split`'s blocks, with `geometry` the class (moment) and
    /// grid position of every global unknown ([`Geometry::from_layout`]): see
    /// [`StencilReduced::from_blocks`]. A split assembled as stencils
    /// ([`Split::stencil`]) has no blocks to recover them from.
    pub fn build(split: &Split, geometry: &Geometry) -> Option<Self> {
        Self::from_blocks(
            &split.b,
            &split.c_scaled,
            &split.even,
            &split.odd,
            &split.d_o,
            geometry,
        )
    }
}

/// How `S` is applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReducedMode {
    /// `D_e x − B (D_o⁻¹ C x)`: two sparse products per application, nothing stored.
    MatrixFree,
    /// `S` formed once as CSR (one sparse product per application).
    Formed,
    /// `Formed` when the preconditioner forms `S` anyway (ILU), else `MatrixFree`.
    Auto,
}

/// `S`, matrix-free or formed.
pub struct ReducedOperator<'a> {
    split: &'a Split,
    formed: Option<CsMat<f64>>,
    stencil: Option<Arc<StencilReduced>>,
    tmp: std::sync::Mutex<Vec<f64>>,
}

impl<'a> ReducedOperator<'a> {
    /// The operator of `split`, forming `S` when `mode` asks for it.
    pub fn new(split: &'a Split, mode: ReducedMode) -> Self {
        let formed = match mode {
            ReducedMode::MatrixFree | ReducedMode::Auto => None,
            ReducedMode::Formed => Some(form(split)),
        };
        Self {
            split,
            // A split assembled as stencils is applied from them (it holds no blocks).
            stencil: if formed.is_none() {
                split.stencil.clone()
            } else {
                None
            },
            formed,
            tmp: std::sync::Mutex::new(vec![0.0; split.odd.len()]),
        }
    }

    /// Applies the matrix-free `S` from the blocks' per-moment stencils
    /// ([`StencilReduced`]) when `geometry` (every global unknown's moment and position)
    /// lets them be recovered; unchanged when `S` is formed or the blocks are not
    /// stencil-like.
    pub fn with_stencil(mut self, geometry: &Geometry) -> Self {
        if self.formed.is_none() && self.stencil.is_none() {
            self.stencil = StencilReduced::build(self.split, geometry).map(Arc::new);
        }
        self
    }

    /// The stencils `S` is applied from, if any ([`ReducedOperator::with_stencil`]).
    pub fn stencil(&self) -> Option<&StencilReduced> {
        self.stencil.as_deref()
    }

    /// The shared stencils `S` is applied from, if any.
    pub fn stencil_shared(&self) -> Option<Arc<StencilReduced>> {
        self.stencil.clone()
    }

    /// Whether `S` is applied from the blocks' stencils.
    pub fn is_stencil(&self) -> bool {
        self.stencil.is_some()
    }

    /// Number of even unknowns.
    pub fn len(&self) -> usize {
        self.split.even.len()
    }

    /// Whether there are no even unknowns.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether `S` is stored.
    pub fn is_formed(&self) -> bool {
        self.formed.is_some()
    }

    /// The formed `S`, if any.
    pub fn formed(&self) -> Option<&CsMat<f64>> {
        self.formed.as_ref()
    }

    /// Stored non-zeros of `S` (when formed).
    pub fn formed_nnz(&self) -> Option<usize> {
        self.formed.as_ref().map(|s| s.nnz())
    }

    /// The bytes one [`ReducedOperator::apply`] moves in the roofline model
    /// ([`crate::bandwidth`]: each array read or written once per pass, as STREAM counts).
    ///
    /// Matrix-free, with `n_e`/`n_o` even/odd unknowns and 32-bit block column indices
    /// ([`super::split::BlockMat`], 12 bytes per entry, 64-bit row pointers), three passes:
    /// * `t = C̃ x`: `12·nnz(C̃) + 8·(n_o + 1)` for the block, `8·n_e` to read `x`, `8·n_o`
    ///   to write `t`;
    /// * `y = B t`: `12·nnz(B) + 8·(n_e + 1)`, `8·n_o` to read `t`, `8·n_e` to write `y`;
    /// * `y = D_e x − y`: `x`, `D_e` and `y` read and `y` written, `32·n_e`;
    ///
    /// in all `12·(nnz(B) + nnz(C̃)) + 8·(n_e + n_o + 2) + 48·n_e + 16·n_o`. Formed, one
    /// product with the CSR `S` (64-bit indices): `16·nnz(S) + 8·(n_e + 1) + 16·n_e`.
    pub fn bytes_per_application(&self) -> u64 {
        let s = self.split;
        let (ne, no) = (s.even.len(), s.odd.len());
        if let Some(f) = &self.formed {
            return csr_product_bytes(f.nnz(), ne, ne, std::mem::size_of::<usize>());
        }
        if let Some(st) = &self.stencil {
            return st.bytes(ne, no);
        }
        let c = csr_product_bytes(s.c_scaled.nnz(), no, ne, 4);
        let b = csr_product_bytes(s.b.nnz(), ne, no, 4);
        c + b + 32 * ne as u64
    }

    /// `y = S x`.
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        if let Some(s) = &self.formed {
            spmv(s, x, y);
            return;
        }
        if let Some(st) = &self.stencil {
            st.apply(&self.split.d_e, &self.split.d_o, x, y);
            return;
        }
        let mut t = self.tmp.lock().unwrap_or_else(|e| e.into_inner());
        spmv(&self.split.c_scaled, x, &mut t);
        spmv(&self.split.b, &t, y);
        y.par_iter_mut()
            .zip(x.par_iter().zip(self.split.d_e.par_iter()))
            .for_each(|(yi, (xi, di))| *yi = di * xi - *yi);
    }

    /// The reduced right-hand side `f = b_e − B D_o⁻¹ b_o`.
    pub fn rhs(&self, b_e: &[f64], b_o: &[f64]) -> Vec<f64> {
        let s = self.split;
        let scaled: Vec<f64> = b_o.iter().zip(&s.d_o).map(|(b, d)| b / d).collect();
        let mut f = vec![0.0; b_e.len()];
        match &s.stencil {
            Some(st) => st.apply_b(&scaled, &mut f),
            None => spmv(&s.b, &scaled, &mut f),
        }
        f.iter_mut().zip(b_e).for_each(|(fi, bi)| *fi = bi - *fi);
        f
    }

    /// Back-substitution `u_o = D_o⁻¹ b_o − C̃ u_e`.
    pub fn recover_odd(&self, u_e: &[f64], b_o: &[f64]) -> Vec<f64> {
        let s = self.split;
        let mut u_o = vec![0.0; b_o.len()];
        match &s.stencil {
            Some(st) => st.apply_c_scaled(&s.d_o, u_e, &mut u_o),
            None => spmv(&s.c_scaled, u_e, &mut u_o),
        }
        u_o.iter_mut()
            .zip(b_o.iter().zip(&s.d_o))
            .for_each(|(u, (b, d))| *u = b / d - *u);
        u_o
    }

    /// Relative asymmetry `max |xᵀSy − yᵀSx| / (‖x‖‖Sy‖ + ‖y‖‖Sx‖)` over a few
    /// deterministic pseudo-random pairs: ~1e-16 for a symmetric `S`.
    pub fn asymmetry(&self, pairs: usize) -> f64 {
        let n = self.len();
        let mut rng = SplitMix(0x5eed_5a17);
        let mut worst = 0.0f64;
        let (mut sx, mut sy) = (vec![0.0; n], vec![0.0; n]);
        for _ in 0..pairs {
            let x: Vec<f64> = (0..n).map(|_| rng.next_signed()).collect();
            let y: Vec<f64> = (0..n).map(|_| rng.next_signed()).collect();
            self.apply(&x, &mut sx);
            self.apply(&y, &mut sy);
            let scale = norm(&x) * norm(&sy) + norm(&y) * norm(&sx);
            if scale > 0.0 {
                worst = worst.max((dot(&x, &sy) - dot(&y, &sx)).abs() / scale);
            }
        }
        worst
    }
}

/// `S` as an operator for the Krylov methods; the transposed product
/// `Sᵀ y = D_e y − C̃ᵀ (Bᵀ y)` (or with the formed `S`) is a serial scatter, for occasional
/// use only.
impl LinearOperator for ReducedOperator<'_> {
    fn rows(&self) -> usize {
        self.len()
    }
    fn cols(&self) -> usize {
        self.len()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        ReducedOperator::apply(self, x, y);
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) {
        if let Some(s) = &self.formed {
            spmv_transpose(s, x, y);
            return;
        }
        let mut t = vec![0.0; self.split.odd.len()];
        let (b, c) = self.split.blocks();
        spmv_transpose(&b, x, &mut t);
        spmv_transpose(&c, &t, y);
        y.iter_mut()
            .zip(x.iter().zip(&self.split.d_e))
            .for_each(|(yi, (xi, di))| *yi = di * xi - *yi);
    }
    /// [`ReducedOperator::bytes_per_application`] (of `apply`; the transposed product is a
    /// serial scatter for occasional use).
    fn bytes_per_application(&self) -> Option<u64> {
        Some(ReducedOperator::bytes_per_application(self))
    }
}

/// Rows of `S` per parallel task in [`form`].
const FORM_CHUNK: usize = 1024;

/// `S = D_e − B C̃` as CSR with sorted column indices (the diagonal always stored), formed
/// row by row in parallel: row i is `D_e,ii e_i − Σ_k B_ik C̃_k,:`.
pub fn form(split: &Split) -> CsMat<f64> {
    let n = split.even.len();
    let (b, c) = split.blocks();
    let bp = b.indptr();
    let bp = bp.raw_storage();
    let (bi, bv) = (b.indices(), b.data());
    let cp = c.indptr();
    let cp = cp.raw_storage();
    let (ci, cv) = (c.indices(), c.data());
    let chunks: Vec<(Vec<usize>, Vec<usize>, Vec<f64>)> = (0..n.div_ceil(FORM_CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut nnz, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
            let mut row: Vec<(usize, f64)> = Vec::new();
            for i in c * FORM_CHUNK..((c + 1) * FORM_CHUNK).min(n) {
                row.clear();
                row.push((i, split.d_e[i]));
                for p in bp[i]..bp[i + 1] {
                    let k = bi[p] as usize;
                    for q in cp[k]..cp[k + 1] {
                        row.push((ci[q] as usize, -bv[p] * cv[q]));
                    }
                }
                row.sort_unstable_by_key(|e| e.0);
                let start = cols.len();
                for &(j, v) in &row {
                    match vals.last_mut() {
                        // A duplicate column within this row: sum.
                        Some(last) if cols.len() > start && cols.last() == Some(&j) => *last += v,
                        _ => {
                            cols.push(j);
                            vals.push(v);
                        }
                    }
                }
                nnz.push(cols.len() - start);
            }
            (nnz, cols, vals)
        })
        .collect();
    let total: usize = chunks.iter().map(|c| c.1.len()).sum();
    let mut indptr = Vec::with_capacity(n + 1);
    let (mut indices, mut data) = (Vec::with_capacity(total), Vec::with_capacity(total));
    indptr.push(0);
    let mut end = 0usize;
    for (nnz, cols, vals) in chunks {
        for k in nnz {
            end += k;
            indptr.push(end);
        }
        indices.extend(cols);
        data.extend(vals);
    }
    CsMat::new((n, n), indptr, indices, data)
}

/// SplitMix64: a tiny deterministic generator for the symmetry probe.
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [−1, 1).
    fn next_signed(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::super::split::split;
    use super::*;

    /// A 1D staggered P_1-like system: even centres 0..3, odd faces between them, interior
    /// transport skew (C = −Bᵀ), so S must be symmetric and both modes must agree.
    fn system() -> CsMat<f64> {
        // Unknowns: e0 o0 e1 o1 e2 (alternating), faces only between centres.
        let mut tri = sprs::TriMat::new((5, 5));
        for (i, d) in [1.0, 2.0, 0.5, 2.0, 1.5].into_iter().enumerate() {
            tri.add_triplet(i, i, d);
        }
        for k in [1, 3] {
            tri.add_triplet(k - 1, k, 1.0); // B: e_left ← o
            tri.add_triplet(k + 1, k, -1.0); // B: e_right ← o
            tri.add_triplet(k, k - 1, -1.0); // C = −Bᵀ
            tri.add_triplet(k, k + 1, 1.0);
        }
        tri.to_csr()
    }

    #[test]
    fn matrix_free_equals_formed_and_is_symmetric() {
        let a = system();
        let s = split(&a, &[true, false, true, false, true]).unwrap();
        let free = ReducedOperator::new(&s, ReducedMode::MatrixFree);
        let formed = ReducedOperator::new(&s, ReducedMode::Formed);
        let x = [0.3, -1.0, 2.0];
        let (mut y1, mut y2) = (vec![0.0; 3], vec![0.0; 3]);
        free.apply(&x, &mut y1);
        formed.apply(&x, &mut y2);
        // By hand: S = D_e + B D_o⁻¹ Bᵀ with D_o = 2: S = [[1.5, −.5, 0], [−.5, 1.5, −.5], [0, −.5, 2]].
        let want = [1.5 * 0.3 + 0.5, -0.5 * 0.3 - 1.5 - 1.0, 0.5 + 4.0];
        for i in 0..3 {
            assert!(
                (y1[i] - want[i]).abs() < 1e-14 && (y2[i] - want[i]).abs() < 1e-14,
                "{y1:?} {y2:?}"
            );
        }
        assert!(free.asymmetry(3) < 1e-15);
    }

    /// The byte model by hand on the 5-unknown system: 3 even and 2 odd unknowns, B and C̃
    /// with 4 entries each. Matrix-free: blocks 12·8 = 96, row pointers 8·(4 + 3) = 56,
    /// vectors x (C̃ pass) 24 + t written 16 + t read 16 + y written 24 + the update's
    /// x, D_e, y read and y written 4·24 = 96; 328 in all. Formed S (7 entries: a
    /// tridiagonal 3×3), 16·7 + 8·4 + 24 + 24 = 192.
    #[test]
    fn byte_model_matches_a_hand_count() {
        let s = split(&system(), &[true, false, true, false, true]).unwrap();
        assert_eq!((s.b.nnz(), s.c_scaled.nnz()), (4, 4));
        let free = ReducedOperator::new(&s, ReducedMode::MatrixFree);
        assert_eq!(free.bytes_per_application(), 328);
        assert_eq!(LinearOperator::bytes_per_application(&free), Some(328));
        let formed = ReducedOperator::new(&s, ReducedMode::Formed);
        assert_eq!(formed.formed_nnz(), Some(7));
        assert_eq!(formed.bytes_per_application(), 192);
    }

    #[test]
    fn transposed_product_matches_the_formed_transpose() {
        // A nonsymmetric variant (C ≠ −Bᵀ), so that Sᵀ ≠ S.
        let mut a = system().to_dense();
        a[[1, 0]] = -2.0;
        let a = CsMat::csr_from_dense(a.view(), 0.0);
        let s = split(&a, &[true, false, true, false, true]).unwrap();
        let x = [0.3, -1.0, 2.0];
        let st = form(&s).transpose_view().to_csr();
        let mut want = vec![0.0; 3];
        spmv(&st, &x, &mut want);
        for mode in [ReducedMode::MatrixFree, ReducedMode::Formed] {
            let op = ReducedOperator::new(&s, mode);
            let mut got = vec![0.0; 3];
            LinearOperator::apply_transpose(&op, &x, &mut got);
            for i in 0..3 {
                assert!(
                    (got[i] - want[i]).abs() < 1e-14,
                    "{mode:?}: {got:?} vs {want:?}"
                );
            }
        }
        let mut sx = vec![0.0; 3];
        LinearOperator::apply(
            &ReducedOperator::new(&s, ReducedMode::MatrixFree),
            &x,
            &mut sx,
        );
        assert!(
            sx.iter().zip(&want).any(|(a, b)| (a - b).abs() > 1e-3),
            "S is symmetric"
        );
    }
}
