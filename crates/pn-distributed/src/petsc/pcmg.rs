//! The project's aggregation multigrid (`pn_runtime`'s `solver::multigrid`) on PETSc's PCMG:
//! 2×2×2 geometric aggregation per moment grid, piecewise-constant interpolation, Galerkin
//! coarse operators `Pᵀ S P` (PETSc's PtAP on the assembled `S`), Jacobi-preconditioned
//! Chebyshev smoothing of degree 2, and the coarsest level solved by a direct LU on every
//! process (PCREDUNDANT).
//!
//! Level `k + 1`'s unknowns are the positions `⌊idx/2⌋` (along axes with more than one cell)
//! of level `k`'s kept moments; a coarse unknown belongs to the process whose box contains
//! it on the halved partition ([`Decomposition::coarsened`]), so that the numbering of every
//! level is computed locally like the finest one's ([`Numbering`]).

use super::check;
use super::ffi::{self, PetscInt};
use super::objects::PMat;
use crate::numbering::Numbering;
use crate::partition::Decomposition;
use pn_runtime::Layout;
use std::ptr::null_mut;

/// Coarsening stops at this many unknowns on the coarsest level (its LU is redundant on
/// every process), or when no axis can be halved.
pub const COARSE_MAX: usize = 2000;

/// The smoothers of the module documentation (overridable with `-mg_levels_…`,
/// `-mg_coarse_…`).
pub(crate) const OPTIONS: &str = "-mg_levels_ksp_type chebyshev -mg_levels_pc_type jacobi \
     -mg_levels_ksp_max_it 2 -mg_coarse_ksp_type preonly -mg_coarse_pc_type redundant \
     -mg_coarse_redundant_pc_type lu";

/// Most levels.
const MAX_LEVELS: usize = 20;

/// The layout of level `k + 1` from level `k`'s (extents halved, rounded up, along the axes
/// `halve`).
fn coarse_layout(fine: &Layout, halve: [bool; 3]) -> Layout {
    let extents: Vec<[usize; 3]> = fine
        .extents
        .iter()
        .map(|e| std::array::from_fn(|d| if halve[d] { e[d].div_ceil(2) } else { e[d] }))
        .collect();
    let mut offsets = vec![0];
    for e in &extents {
        offsets.push(offsets[offsets.len() - 1] + e.iter().product::<usize>());
    }
    Layout {
        moments: fine.moments.clone(),
        extents,
        offsets,
    }
}

/// The interpolation matrices from each level to the next finer one, finest first: entry
/// `k` maps level `k + 1` onto level `k` (rows: level `k`'s kept unknowns on this process).
pub(crate) fn interpolations(
    rank: usize,
    layout: &Layout,
    dec: &Decomposition,
    keep: &[bool],
) -> anyhow::Result<Vec<PMat>> {
    let mut out = Vec::new();
    let (mut fine_layout, mut fine_dec) = (layout.clone(), dec.clone());
    let mut fine_num = Numbering::new(&fine_layout, &fine_dec, keep.to_vec());
    while fine_num.total() > COARSE_MAX && out.len() + 1 < MAX_LEVELS {
        let res = fine_dec.res();
        let halve: [bool; 3] = std::array::from_fn(|d| res[d] > 1);
        if !halve.contains(&true) {
            break;
        }
        let coarse_layout = coarse_layout(&fine_layout, halve);
        let coarse_dec = fine_dec.coarsened();
        let coarse_num = Numbering::new(&coarse_layout, &coarse_dec, keep.to_vec());
        out.push(interpolation(
            rank,
            [&fine_layout, &coarse_layout],
            [&fine_dec, &coarse_dec],
            [&fine_num, &coarse_num],
            halve,
        )?);
        (fine_layout, fine_dec, fine_num) = (coarse_layout, coarse_dec, coarse_num);
    }
    Ok(out)
}

/// One interpolation matrix (see [`interpolations`]).
fn interpolation(
    rank: usize,
    layouts: [&Layout; 2],
    decs: [&Decomposition; 2],
    nums: [&Numbering; 2],
    halve: [bool; 3],
) -> anyhow::Result<PMat> {
    let [fine, coarse] = layouts;
    let rows = nums[0].owned(fine, rank);
    let (lo, hi) = (
        nums[1].rank_start(rank),
        nums[1].rank_start(rank) + nums[1].local_len(rank),
    );
    let cols: Vec<PetscInt> = rows
        .iter()
        .map(|&g| {
            let (q, idx) = fine.locate(g);
            let c: [usize; 3] = std::array::from_fn(|d| if halve[d] { idx[d] / 2 } else { idx[d] });
            let (_, n) = nums[1]
                .global(coarse, decs[1], coarse.index(q, c))
                .ok_or_else(|| {
                    anyhow::anyhow!("a coarse unknown outside the kept class (internal error)")
                })?;
            Ok(n as PetscInt)
        })
        .collect::<anyhow::Result<_>>()?;
    let d_nnz: Vec<PetscInt> = cols
        .iter()
        .map(|&c| PetscInt::from((lo..hi).contains(&(c as usize))))
        .collect();
    let o_nnz: Vec<PetscInt> = d_nnz.iter().map(|&d| 1 - d).collect();
    let mut m = PMat(null_mut());
    // SAFETY: one count per local row.
    check(
        unsafe {
            ffi::pn_mat_create_aij_rect(
                rows.len() as PetscInt,
                (hi - lo) as PetscInt,
                d_nnz.as_ptr(),
                o_nnz.as_ptr(),
                &mut m.0,
            )
        },
        "MatCreateAIJ (interpolation)",
    )?;
    let start = nums[0].rank_start(rank) as PetscInt;
    for (k, c) in cols.iter().enumerate() {
        let r = start + k as PetscInt;
        // SAFETY: one entry of one row.
        check(
            unsafe { ffi::MatSetValues(m.0, 1, &r, 1, c, &1.0, ffi::INSERT_VALUES) },
            "MatSetValues (interpolation)",
        )?;
    }
    m.assemble()?;
    Ok(m)
}

/// Makes `pc` the multigrid of `interps` (from [`interpolations`]) over the finest level's
/// operator `fine` (the shell, which also gives its diagonal to the Jacobi smoother), with
/// `first` the first coarse operator (`Pᵀ S P`, `super::blocks::first_coarse`) and the
/// further ones formed here (PETSc's PtAP); the smoothers are set by [`OPTIONS`].
pub(crate) fn configure(
    pc: ffi::PC,
    interps: &[PMat],
    fine: ffi::Mat,
    first: PMat,
) -> anyhow::Result<()> {
    let levels = interps.len() + 1;
    // SAFETY: valid preconditioner; PCMG levels are numbered coarsest first.
    unsafe {
        check(ffi::PCSetType(pc, c"mg".as_ptr()), "PCSetType mg")?;
        check(
            ffi::pn_pcmg_set_levels(pc, levels as PetscInt),
            "PCMGSetLevels",
        )?;
        check(
            ffi::PCMGSetGalerkin(pc, ffi::PC_MG_GALERKIN_NONE),
            "PCMGSetGalerkin",
        )?;
        for (k, p) in interps.iter().enumerate() {
            let level = (levels - 1 - k) as PetscInt;
            check(
                ffi::PCMGSetInterpolation(pc, level, p.0),
                "PCMGSetInterpolation",
            )?;
        }
    }
    set_level_operators(pc, levels - 1, fine, fine)?;
    if interps.is_empty() {
        return Ok(());
    }
    set_level_operators(pc, levels - 2, first.0, first.0)?;
    let mut coarse = first;
    for (k, p) in interps.iter().enumerate().skip(1) {
        let mut c = PMat(null_mut());
        // SAFETY: `coarse` is assembled and `p` conforms to it; PETSc creates `c`.
        check(
            unsafe {
                ffi::MatPtAP(
                    coarse.0,
                    p.0,
                    ffi::MAT_INITIAL_MATRIX,
                    ffi::PETSC_DEFAULT_REAL,
                    &mut c.0,
                )
            },
            "MatPtAP (coarse operator)",
        )?;
        set_level_operators(pc, levels - 2 - k, c.0, c.0)?;
        // The level's solver holds its own reference.
        coarse = c;
    }
    Ok(())
}

/// Sets the operators of PCMG level `level` (0: coarsest).
fn set_level_operators(pc: ffi::PC, level: usize, a: ffi::Mat, p: ffi::Mat) -> anyhow::Result<()> {
    let mut ksp = null_mut();
    // SAFETY: valid preconditioner with at least `level + 1` levels; the smoother takes
    // references to the matrices.
    unsafe {
        check(
            ffi::PCMGGetSmoother(pc, level as PetscInt, &mut ksp),
            "PCMGGetSmoother",
        )?;
        check(ffi::KSPSetOperators(ksp, a, p), "KSPSetOperators (level)")
    }
}
