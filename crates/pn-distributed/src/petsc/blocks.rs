//! The parity blocks as PETSc matrices, for the first Galerkin coarse operator without
//! forming `S` (as `pn_runtime`'s multigrid does from its blocks, docs/design.md §5):
//! `Pᵀ S P = Pᵀ D_e P − (Pᵀ B)(C̃ P)`, or `Pᵀ A P` for a system without elimination.
//! `S` has many more entries than `B` and `C̃` together at higher orders, so this is what
//! keeps the multigrid's setup within the memory of the operator itself.

use super::check;
use super::ffi::{self, PetscInt};
use super::objects::{PMat, PVec};
use super::operator::Parts;
use crate::local::LocalRows;
use crate::numbering::Numbering;
use anyhow::Context;
use pn_runtime::Layout;
use std::ptr::null_mut;

/// The distributed numbers of one class's extended local indices (owned, then ghosts).
struct Columns {
    start: usize,
    owned: usize,
    ghosts: Vec<PetscInt>,
}

impl Columns {
    fn new(
        parts: &Parts,
        layout: &Layout,
        num: &Numbering,
        ghosts: &[usize],
    ) -> anyhow::Result<Self> {
        let rank = parts.local.rank;
        let ghosts = ghosts
            .iter()
            .map(|&g| {
                num.global(layout, &parts.dec, g)
                    .map(|(_, n)| n as PetscInt)
                    .context("a ghost of the wrong class (internal error)")
            })
            .collect::<anyhow::Result<_>>()?;
        Ok(Self {
            start: num.rank_start(rank),
            owned: num.local_len(rank),
            ghosts,
        })
    }

    fn number(&self, l: usize) -> PetscInt {
        if l < self.owned {
            (self.start + l) as PetscInt
        } else {
            self.ghosts[l - self.owned]
        }
    }
}

/// `rows` (plus `diag` on the diagonal) as a PETSc AIJ matrix whose rows are this process's
/// `row_start …` and whose columns are numbered by `cols`.
fn aij(
    rows: &LocalRows,
    diag: Option<&[f64]>,
    row_start: usize,
    cols: &Columns,
) -> anyhow::Result<PMat> {
    let n = rows.indptr.len() - 1;
    let (lo, hi) = (cols.start, cols.start + cols.owned);
    let mut d_nnz = vec![PetscInt::from(diag.is_some()); n];
    let mut o_nnz = vec![0 as PetscInt; n];
    for i in 0..n {
        for k in rows.indptr[i]..rows.indptr[i + 1] {
            let c = cols.number(rows.cols[k] as usize) as usize;
            if (lo..hi).contains(&c) {
                d_nnz[i] += 1;
            } else {
                o_nnz[i] += 1;
            }
        }
    }
    let mut m = PMat(null_mut());
    // SAFETY: one count per local row.
    check(
        unsafe {
            ffi::pn_mat_create_aij_rect(
                n as PetscInt,
                cols.owned as PetscInt,
                d_nnz.as_ptr(),
                o_nnz.as_ptr(),
                &mut m.0,
            )
        },
        "MatCreateAIJ (parity block)",
    )?;
    let (mut c, mut v) = (Vec::new(), Vec::new());
    for i in 0..n {
        c.clear();
        v.clear();
        let r = (row_start + i) as PetscInt;
        if let Some(d) = diag {
            c.push(r);
            v.push(d[i]);
        }
        for k in rows.indptr[i]..rows.indptr[i + 1] {
            c.push(cols.number(rows.cols[k] as usize));
            v.push(rows.vals[k]);
        }
        // SAFETY: one row of `c.len()` entries.
        check(
            unsafe {
                ffi::MatSetValues(
                    m.0,
                    1,
                    &r,
                    c.len() as PetscInt,
                    c.as_ptr(),
                    v.as_ptr(),
                    ffi::INSERT_VALUES,
                )
            },
            "MatSetValues (parity block)",
        )?;
    }
    m.assemble()?;
    Ok(m)
}

/// A matrix product of PETSc's (`f` is MatMatMult, MatTransposeMatMult or MatPtAP).
fn product(
    f: unsafe extern "C" fn(ffi::Mat, ffi::Mat, i32, f64, *mut ffi::Mat) -> ffi::PetscErrorCode,
    a: &PMat,
    b: &PMat,
    what: &str,
) -> anyhow::Result<PMat> {
    let mut c = PMat(null_mut());
    // SAFETY: `a` and `b` are assembled and conform; PETSc creates `c`.
    check(
        unsafe {
            f(
                a.0,
                b.0,
                ffi::MAT_INITIAL_MATRIX,
                ffi::PETSC_DEFAULT_REAL,
                &mut c.0,
            )
        },
        what,
    )?;
    Ok(c)
}

/// The first coarse operator `Pᵀ S P` for the interpolation `p` from the finest level.
pub(crate) fn first_coarse(parts: &Parts, layout: &Layout, p: &PMat) -> anyhow::Result<PMat> {
    let local = &parts.local;
    let kept = Columns::new(parts, layout, &parts.kept_num, &local.kept.ghosts)?;
    if let Some(direct) = &local.direct {
        let a = aij(direct, Some(&local.d_e), kept.start, &kept)?;
        return product(ffi::MatPtAP, &a, p, "MatPtAP (first coarse operator)");
    }
    let elim = Columns::new(parts, layout, &parts.elim_num, &local.elim.ghosts)?;
    let b = aij(&local.b, None, kept.start, &elim)?;
    let c = aij(&local.c, None, elim.start, &kept)?;
    let cp = product(ffi::MatMatMult, &c, p, "MatMatMult (C̃ P)")?;
    drop(c);
    // Pᵀ explicitly (one entry per column) times B: PETSc's parallel MatTransposeMatMult
    // holds a transpose of B besides it.
    let mut pt = PMat(null_mut());
    // SAFETY: `p` is assembled; PETSc creates its transpose.
    check(
        unsafe { ffi::MatTranspose(p.0, ffi::MAT_INITIAL_MATRIX, &mut pt.0) },
        "MatTranspose (Pᵀ)",
    )?;
    let ptb = product(ffi::MatMatMult, &pt, &b, "MatMatMult (Pᵀ B)")?;
    drop(pt);
    drop(b);
    let m = product(ffi::MatMatMult, &ptb, &cp, "MatMatMult (Pᵀ B C̃ P)")?;
    drop((ptb, cp));
    // Pᵀ D_e P is diagonal (each fine unknown has one aggregate): Pᵀ d_e.
    let d = PVec::mpi(local.d_e.len())?;
    d.fill(&local.d_e)?;
    let (mut right, mut left) = (null_mut(), null_mut());
    // SAFETY: `p` is assembled; PETSc creates both vectors.
    check(
        unsafe { ffi::MatCreateVecs(p.0, &mut right, &mut left) },
        "MatCreateVecs",
    )?;
    let (right, _left) = (PVec(right), PVec(left));
    // SAFETY: the vectors conform to `p` (right: coarse, d: fine) and `m` is square coarse.
    unsafe {
        check(
            ffi::MatMultTranspose(p.0, d.0, right.0),
            "MatMultTranspose (Pᵀ d_e)",
        )?;
        check(ffi::MatScale(m.0, -1.0), "MatScale")?;
        // A coarse row of `Pᵀ B C̃ P` may lack its diagonal entry (at P_4 on some splits):
        // let the diagonal below add it.
        check(
            ffi::MatSetOption(m.0, ffi::MAT_NEW_NONZERO_ALLOCATION_ERR, ffi::PETSC_FALSE),
            "MatSetOption",
        )?;
        check(
            ffi::MatDiagonalSet(m.0, right.0, ffi::ADD_VALUES),
            "MatDiagonalSet",
        )?;
    }
    Ok(m)
}
