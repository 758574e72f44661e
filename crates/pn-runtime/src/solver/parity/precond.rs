//! Preconditioners for the reduced operator `S = D_e − B D_o⁻¹ C`.
//!
//! Entries of `S` are computed exactly from the blocks without forming `S`:
//! `S_ij = D_e,ii δ_ij − Σ_k B_ik C̃_kj` with `C̃ = D_o⁻¹ C` (docs/design.md §5).
//! * Jacobi: `diag(S)⁻¹`.
//! * Block-Jacobi: the dense blocks of `S` over groups of even unknowns (by default the even
//!   moments belonging to one grid cell), each inverted once.
//! * ILU(0) of the formed `S`, and the multigrid cycle.
//!
//! [`Built`] and [`Ilu0`] are [`Preconditioner`]s; [`Built::with_fine`] binds a multigrid
//! hierarchy to the finest operator it needs.

use super::split::{ParityError, Split};
use pn_krylov::operator::{Identity, Jacobi, LinearOperator, Preconditioner};
use rayon::prelude::*;
use sprs::CsMat;

/// Which preconditioner the reduced Krylov method uses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Precond {
    /// No preconditioning.
    None,
    /// Jacobi: the exact diagonal of `S`.
    Jacobi,
    /// Block-Jacobi: `block_of[g]` is the block id of global unknown `g` (odd unknowns are
    /// ignored). Build it per cell with [`crate::solver::pn_layout::cell_blocks`].
    BlockJacobi {
        /// Block id of every global unknown.
        block_of: Vec<usize>,
    },
    /// Incomplete LU factorisation with the sparsity of `S` (ILU(0)), from `S` formed once.
    /// For a symmetric `S` the factors satisfy `U = D Lᵀ`, so `M = LU` is symmetric and
    /// usable with CG. The triangular solves are sequential.
    Ilu0,
    /// ILU(0) with the even unknowns renumbered cell by cell (`block_of` as for
    /// block-Jacobi), so that the factorisation sees the couplings within a cell first.
    Ilu0Cells {
        /// Block (cell) id of every global unknown.
        block_of: Vec<usize>,
    },
    /// ILU(0) when `A` has at most `super::ILU_MAX_NONZEROS` stored entries, else Jacobi
    /// (resolved per solve; with a layout, [`super::ParityCg`] resolves it to multigrid
    /// where that wins, see [`super::MG_MIN_NONZEROS`]).
    Auto,
    /// Aggregation multigrid V-cycle ([`crate::solver::multigrid`]); needs the unknowns'
    /// positions, so only a solver given them ([`super::ParityCg::with_geometry`], or
    /// `ParityCg::for_layout` in [`crate::solver::pn_layout`]) can use it.
    Multigrid,
}

impl Precond {
    /// Whether building it forms `S` (so the operator may as well use the formed `S`).
    pub fn forms_s(&self, nnz_a: usize) -> bool {
        matches!(
            self.resolve(nnz_a),
            Precond::Ilu0 | Precond::Ilu0Cells { .. }
        )
    }

    /// `Auto` resolved for a matrix `A` with `nnz_a` stored entries; other kinds unchanged.
    pub fn resolve(&self, nnz_a: usize) -> Precond {
        match self {
            Precond::Auto if nnz_a <= super::ILU_MAX_NONZEROS => Precond::Ilu0,
            Precond::Auto => Precond::Jacobi,
            other => other.clone(),
        }
    }

    /// Short name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            Precond::None => "none",
            Precond::Jacobi => "jacobi",
            Precond::BlockJacobi { .. } => "block-jacobi",
            Precond::Ilu0 => "ilu0",
            Precond::Ilu0Cells { .. } => "ilu0-cells",
            Precond::Auto => "auto",
            Precond::Multigrid => "mg",
        }
    }
}

/// A preconditioner ready to apply: `z = M⁻¹ r`.
pub enum Built {
    /// `z = r`.
    Identity,
    /// `z = r / diag(S)`.
    Diagonal(Jacobi),
    /// Dense inverse blocks.
    Blocks {
        /// Even-local indices of each block.
        members: Vec<Vec<usize>>,
        /// Row-major inverse of each block.
        inverses: Vec<Vec<f64>>,
    },
    /// ILU(0) factors of `S`.
    Ilu(Ilu0),
    /// A multigrid hierarchy; apply it with [`Built::apply_with`].
    Multigrid(crate::solver::multigrid::Multigrid),
    /// ILU(0) factors of `P S Pᵀ`; `perm[new] = old`.
    PermutedIlu {
        /// Factors.
        ilu: Ilu0,
        /// Old (even-local) index of each new index.
        perm: Vec<usize>,
    },
}

impl Built {
    /// Builds the preconditioner `kind` for the reduced operator of `split`; `formed` is
    /// `S` when the caller has already formed it (ILU reuses it instead of forming again).
    pub fn new(
        kind: &Precond,
        split: &Split,
        formed: Option<&CsMat<f64>>,
    ) -> Result<Self, ParityError> {
        let form = || match formed {
            Some(s) => std::borrow::Cow::Borrowed(s),
            None => std::borrow::Cow::Owned(super::reduced::form(split)),
        };
        match kind {
            Precond::None => Ok(Built::Identity),
            Precond::Jacobi => {
                let j = Jacobi::from_diagonal(&diagonal(split))
                    .map_err(|row| ParityError::SingularBlock { block: row })?;
                Ok(Built::Diagonal(j))
            }
            Precond::BlockJacobi { block_of } => {
                let n = split.even.len() + split.odd.len();
                if block_of.len() != n {
                    return Err(ParityError::BlockMapLength {
                        len: block_of.len(),
                        rows: n,
                    });
                }
                block_inverses(split, block_of)
            }
            Precond::Ilu0 => Ok(Built::Ilu(Ilu0::new(&form())?)),
            Precond::Ilu0Cells { block_of } => {
                let n = split.even.len() + split.odd.len();
                if block_of.len() != n {
                    return Err(ParityError::BlockMapLength {
                        len: block_of.len(),
                        rows: n,
                    });
                }
                let mut perm: Vec<usize> = (0..split.even.len()).collect();
                perm.sort_by_key(|&i| (block_of[split.even[i]], i));
                let mut inv = vec![0usize; perm.len()];
                for (new, &old) in perm.iter().enumerate() {
                    inv[old] = new;
                }
                let s = form();
                let mut tri = sprs::TriMat::with_capacity(s.shape(), s.nnz());
                for (i, row) in s.outer_iterator().enumerate() {
                    for (j, &v) in row.iter() {
                        tri.add_triplet(inv[i], inv[j], v);
                    }
                }
                Ok(Built::PermutedIlu {
                    ilu: Ilu0::new(&tri.to_csr())?,
                    perm,
                })
            }
            Precond::Auto => Built::new(&kind.resolve(split.nnz_a), split, formed),
            Precond::Multigrid => Err(ParityError::Multigrid(
                crate::solver::multigrid::MgError::NoGeometry,
            )),
        }
    }

    /// The multigrid preconditioner for the reduced operator of `split`, with `geometry`
    /// the class and position of every *global* unknown (the even ones are picked).
    pub fn multigrid(
        split: &Split,
        geometry: &crate::solver::multigrid::Geometry,
        opts: &crate::solver::multigrid::MgOptions,
    ) -> Result<Self, ParityError> {
        let op = super::reduced::ReducedOperator::new(split, super::ReducedMode::MatrixFree);
        Self::multigrid_with(split, geometry, opts, &op)
    }

    /// [`Built::multigrid`] with the reduced operator `fine` the solve applies (its setup's
    /// `λ_max` estimate applies it too), so that it is built once.
    pub fn multigrid_with(
        split: &Split,
        geometry: &crate::solver::multigrid::Geometry,
        opts: &crate::solver::multigrid::MgOptions,
        fine: &super::reduced::ReducedOperator<'_>,
    ) -> Result<Self, ParityError> {
        use crate::solver::multigrid::{Geometry, Multigrid, SingleApply};
        let n = split.even.len() + split.odd.len();
        if geometry.len() != n {
            return Err(ParityError::BlockMapLength {
                len: geometry.len(),
                rows: n,
            });
        }
        let even = Geometry {
            class: split.even.par_iter().map(|&g| geometry.class[g]).collect(),
            coords: split.even.par_iter().map(|&g| geometry.coords[g]).collect(),
        };
        let apply = |x: &[f64], y: &mut [f64]| fine.apply(x, y);
        // From the stencils where `S` is applied from them (no pass over the blocks).
        let stencil = fine.stencil();
        let diag = || match stencil {
            Some(st) => st.diagonal(&split.d_e, &split.d_o),
            None => diagonal(split),
        };
        // The finest level in single precision where S has an f32 form (its stencils).
        let single: Option<SingleApply> = match (opts.single_fine, fine.stencil_shared()) {
            (Some(true), Some(st)) => {
                let d_e: Vec<f32> = split.d_e.par_iter().map(|&v| v as f32).collect();
                let d_o: Vec<f32> = split.d_o.par_iter().map(|&v| v as f32).collect();
                let tmp = std::sync::Mutex::new(vec![0.0f32; d_o.len()]);
                Some(Box::new(move |x: &[f32], y: &mut [f32]| {
                    let mut t = tmp.lock().unwrap_or_else(|e| e.into_inner());
                    st.apply_with(&d_e, &d_o, x, y, &mut t);
                }))
            }
            _ => None,
        };
        let mg = Multigrid::build(
            &apply,
            single,
            diag,
            &even,
            |agg| first_coarse(split, stencil, agg, opts),
            opts,
        )?;
        Ok(Built::Multigrid(mg))
    }

    /// Applications of `S` in single precision by the multigrid's finest level so far.
    pub fn single_applications(&self) -> usize {
        match self {
            Built::Multigrid(mg) => mg.single_fine_applications(),
            _ => 0,
        }
    }

    /// Applications of `S` spent building it (the multigrid's `λ_max` estimate).
    pub fn setup_applications(&self) -> usize {
        match self {
            Built::Multigrid(mg) => mg.setup_fine_applications(),
            _ => 0,
        }
    }

    /// `z = M⁻¹ r` where `fine` applies the reduced operator (used by multigrid's finest
    /// level; the other kinds ignore it).
    pub fn apply_with(&self, fine: &dyn Fn(&[f64], &mut [f64]), r: &[f64], z: &mut [f64]) {
        match self {
            Built::Multigrid(mg) => mg.apply(fine, r, z),
            other => other.apply(r, z),
        }
    }

    /// As a [`Preconditioner`], with `fine` the reduced operator (used by multigrid's
    /// finest level; the other kinds ignore it).
    pub fn with_fine<'a>(&'a self, fine: &'a dyn LinearOperator) -> WithFine<'a> {
        WithFine { built: self, fine }
    }

    /// `z = M⁻¹ r` (for [`Built::Multigrid`] use [`Built::apply_with`]).
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        match self {
            Built::Identity => Identity.apply(r, z),
            Built::Diagonal(j) => j.apply(r, z),
            Built::Blocks { members, inverses } => {
                for (m, inv) in members.iter().zip(inverses) {
                    let k = m.len();
                    for (a, &ia) in m.iter().enumerate() {
                        let mut s = 0.0;
                        for (b, &ib) in m.iter().enumerate() {
                            s += inv[a * k + b] * r[ib];
                        }
                        z[ia] = s;
                    }
                }
            }
            Built::Ilu(f) => f.solve(r, z),
            // The V-cycle needs the finest operator ([`Built::apply_with`]); without it,
            // only its finest-level Jacobi scaling is available.
            Built::Multigrid(mg) => mg.apply_jacobi(r, z),
            Built::PermutedIlu { ilu, perm } => {
                let rp: Vec<f64> = perm.iter().map(|&o| r[o]).collect();
                let mut zp = vec![0.0; rp.len()];
                ilu.solve(&rp, &mut zp);
                for (&o, v) in perm.iter().zip(zp) {
                    z[o] = v;
                }
            }
        }
    }
}

/// A [`Built`] preconditioner bound to the reduced operator ([`Built::with_fine`]).
pub struct WithFine<'a> {
    built: &'a Built,
    fine: &'a dyn LinearOperator,
}

impl Preconditioner for WithFine<'_> {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        match self.built {
            Built::Multigrid(mg) => mg.with_fine(self.fine).apply(r, z),
            other => other.apply(r, z),
        }
    }
}

/// Without the finest operator, a multigrid hierarchy applies only its finest-level
/// Jacobi scaling ([`Built::apply`]); use [`Built::with_fine`] for the cycle.
impl Preconditioner for Built {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        Built::apply(self, r, z);
    }
}

impl Preconditioner for Ilu0 {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        self.solve(r, z);
    }
}

/// Exact `diag(S)` (from the stencils when the split holds them,
/// [`super::stencil_s::StencilReduced::diagonal`]).
pub fn diagonal(split: &Split) -> Vec<f64> {
    if let Some(st) = &split.stencil {
        return st.diagonal(&split.d_e, &split.d_o);
    }
    let (b, c) = split.blocks();
    let bp = b.indptr();
    let bp = bp.raw_storage();
    let (bi, bv) = (b.indices(), b.data());
    let cp = c.indptr();
    let cp = cp.raw_storage();
    let (ci, cv) = (c.indices(), c.data());
    (0..split.even.len())
        .into_par_iter()
        .map(|i| {
            let mut s = split.d_e[i];
            for j in bp[i]..bp[i + 1] {
                let k = bi[j] as usize;
                for l in cp[k]..cp[k + 1] {
                    if ci[l] as usize == i {
                        s -= bv[j] * cv[l];
                    }
                }
            }
            s
        })
        .collect()
}

/// Inverse dense blocks of `S` over the groups of `block_of`.
fn block_inverses(split: &Split, block_of: &[usize]) -> Result<Built, ParityError> {
    // Group even-local indices by block id (ids are arbitrary; renumber densely).
    let mut id_map = std::collections::HashMap::new();
    let mut members: Vec<Vec<usize>> = Vec::new();
    for (i, &g) in split.even.iter().enumerate() {
        let id = *id_map.entry(block_of[g]).or_insert_with(|| {
            members.push(Vec::new());
            members.len() - 1
        });
        members[id].push(i);
    }
    let mut pos_in_block = vec![(0usize, 0usize); split.even.len()];
    for (bid, m) in members.iter().enumerate() {
        for (p, &i) in m.iter().enumerate() {
            pos_in_block[i] = (bid, p);
        }
    }
    let (b, c) = split.blocks();
    let bp = b.indptr();
    let bp = bp.raw_storage();
    let (bi, bv) = (b.indices(), b.data());
    let cp = c.indptr();
    let cp = cp.raw_storage();
    let (ci, cv) = (c.indices(), c.data());
    let inverses: Result<Vec<Vec<f64>>, ParityError> = members
        .par_iter()
        .enumerate()
        .map(|(bid, m)| {
            let k = m.len();
            let mut blk = vec![0.0; k * k];
            for (a, &i) in m.iter().enumerate() {
                blk[a * k + a] += split.d_e[i];
                for j in bp[i]..bp[i + 1] {
                    let o = bi[j] as usize;
                    for l in cp[o]..cp[o + 1] {
                        let (cb, p) = pos_in_block[ci[l] as usize];
                        if cb == bid {
                            blk[a * k + p] -= bv[j] * cv[l];
                        }
                    }
                }
            }
            let mat = nalgebra::DMatrix::from_row_slice(k, k, &blk);
            let inv = mat
                .try_inverse()
                .ok_or(ParityError::SingularBlock { block: bid })?;
            if inv.iter().any(|v| !v.is_finite()) {
                return Err(ParityError::SingularBlock { block: bid });
            }
            Ok(inv.transpose().as_slice().to_vec()) // column-major transpose = row-major
        })
        .collect();
    Ok(Built::Blocks {
        members,
        inverses: inverses?,
    })
}

/// ILU(0): `L` (unit lower) and `U` stored in one CSR pattern equal to that of `S`.
pub struct Ilu0 {
    indptr: Vec<usize>,
    indices: Vec<usize>,
    values: Vec<f64>,
    /// Position of the diagonal entry in each row.
    diag: Vec<usize>,
}

impl Ilu0 {
    /// Factorises the square CSR matrix `s` (sorted column indices) in place of a copy.
    pub fn new(s: &sprs::CsMat<f64>) -> Result<Self, ParityError> {
        let n = s.rows();
        let indptr = s.indptr().raw_storage().to_vec();
        let indices = s.indices().to_vec();
        let mut values = s.data().to_vec();
        let mut diag = vec![usize::MAX; n];
        for i in 0..n {
            match indices[indptr[i]..indptr[i + 1]]
                .iter()
                .position(|&c| c == i)
            {
                Some(p) => diag[i] = indptr[i] + p,
                None => return Err(ParityError::SingularBlock { block: i }),
            }
        }
        // IKJ variant: row i is reduced by the already factorised rows k < i, keeping only
        // entries inside the pattern (`pos` maps a column to its slot in row i).
        let mut pos = vec![usize::MAX; n];
        for i in 0..n {
            let (start, end) = (indptr[i], indptr[i + 1]);
            for p in start..end {
                pos[indices[p]] = p;
            }
            for p in start..diag[i] {
                let k = indices[p];
                let l = values[p] / values[diag[k]];
                values[p] = l;
                for q in diag[k] + 1..indptr[k + 1] {
                    let slot = pos[indices[q]];
                    if slot != usize::MAX {
                        values[slot] -= l * values[q];
                    }
                }
            }
            for p in start..end {
                pos[indices[p]] = usize::MAX;
            }
            let d = values[diag[i]];
            if d == 0.0 || !d.is_finite() {
                return Err(ParityError::SingularBlock { block: i });
            }
        }
        Ok(Self {
            indptr,
            indices,
            values,
            diag,
        })
    }

    /// `z = (LU)⁻¹ r`.
    pub fn solve(&self, r: &[f64], z: &mut [f64]) {
        let n = r.len();
        for i in 0..n {
            let mut s = r[i];
            for p in self.indptr[i]..self.diag[i] {
                s -= self.values[p] * z[self.indices[p]];
            }
            z[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = z[i];
            for p in self.diag[i] + 1..self.indptr[i + 1] {
                s -= self.values[p] * z[self.indices[p]];
            }
            z[i] = s / self.values[self.diag[i]];
        }
    }
}

/// The first Galerkin operator of the multigrid for the reduced operator of `split`: from
/// the stencils straight into the structured level's weights where the options store coarse
/// levels as `f32` stencils unsparsified and every coarse row has a position map
/// ([`super::stencil_s::StencilReduced::coarse_parts`]: no CSR of the level is formed);
/// else as CSR from the stencils or the blocks.
fn first_coarse(
    split: &Split,
    stencil: Option<&super::stencil_s::StencilReduced>,
    agg: &crate::solver::multigrid::aggregate::Aggregation,
    opts: &crate::solver::multigrid::MgOptions,
) -> crate::solver::multigrid::FirstCoarse {
    use crate::solver::multigrid::stencil_level::{parts_asymmetry, StencilLevel};
    use crate::solver::multigrid::{FineCycle, FirstCoarse, COARSE_SYMMETRY_TOL};
    let Some(st) = stencil else {
        return FirstCoarse::Csr(super::galerkin::coarse_from_split(split, agg));
    };
    if opts.stencil_coarse && !opts.double_coarse {
        if let Some(parts) = st.coarse_parts(&split.d_e, &split.d_o, agg) {
            // Only the cycle that depends on it reads the asymmetry (as for the CSR).
            let asym = match opts.fine_cycle {
                FineCycle::AdditiveIfSymmetric => parts_asymmetry(&parts, COARSE_SYMMETRY_TOL),
                _ => 0.0,
            };
            if let Some(level) = StencilLevel::from_parts(parts) {
                return FirstCoarse::Stencil(level, asym);
            }
        }
    }
    FirstCoarse::Csr(st.coarse(&split.d_e, &split.d_o, agg))
}

#[cfg(test)]
mod tests {
    use super::super::split::split;
    use super::*;

    #[test]
    fn diagonal_and_blocks_match_dense_s() {
        // e0 o0 e1 o1 e2 as in `reduced`: S = [[1.5, −.5, 0], [−.5, 1.5, −.5], [0, −.5, 2]].
        let mut tri = sprs::TriMat::new((5, 5));
        for (i, d) in [1.0, 2.0, 0.5, 2.0, 1.5].into_iter().enumerate() {
            tri.add_triplet(i, i, d);
        }
        for k in [1, 3] {
            tri.add_triplet(k - 1, k, 1.0);
            tri.add_triplet(k + 1, k, -1.0);
            tri.add_triplet(k, k - 1, -1.0);
            tri.add_triplet(k, k + 1, 1.0);
        }
        let a: sprs::CsMat<f64> = tri.to_csr();
        let s = split(&a, &[true, false, true, false, true]).unwrap();
        assert_eq!(diagonal(&s), vec![1.5, 1.5, 2.0]);
        // Block {e0, e1} and block {e2}: inverse of [[1.5, −.5], [−.5, 1.5]] is [[.75, .25], [.25, .75]].
        let b = Built::new(
            &Precond::BlockJacobi {
                block_of: vec![7, 0, 7, 0, 3],
            },
            &s,
            None,
        )
        .unwrap();
        let mut z = vec![0.0; 3];
        b.apply(&[1.0, 0.0, 4.0], &mut z);
        let want = [0.75, 0.25, 2.0];
        for i in 0..3 {
            assert!((z[i] - want[i]).abs() < 1e-14, "{z:?}");
        }
    }

    #[test]
    fn ilu0_is_exact_for_tridiagonal() {
        // ILU(0) of a tridiagonal matrix has no fill to drop: it is the exact LU.
        let mut tri = sprs::TriMat::new((4, 4));
        for i in 0..4 {
            tri.add_triplet(i, i, 3.0);
            if i > 0 {
                tri.add_triplet(i, i - 1, -1.0);
            }
            if i < 3 {
                tri.add_triplet(i, i + 1, -0.5);
            }
        }
        let s: sprs::CsMat<f64> = tri.to_csr();
        let f = Ilu0::new(&s).unwrap();
        let x = [1.0, -2.0, 0.5, 4.0];
        let mut r = vec![0.0; 4];
        pn_krylov::linalg::spmv(&s, &x, &mut r);
        let mut z = vec![0.0; 4];
        f.solve(&r, &mut z);
        for i in 0..4 {
            assert!((z[i] - x[i]).abs() < 1e-14, "{z:?}");
        }
    }
}
