//! The shell operator: one process's share of the system ([`Parts`]), the shell matrix's
//! product `S x` around two ghost scatters ([`Shell`]), and `S` assembled for the
//! algebraic multigrids.

use super::check;
use super::ffi::{self, PetscInt};
use super::objects::{read, write, PMat, PVec, Scatter};
use super::Mpi;
use crate::local::{kept_moments, kept_moments_retaining, LocalReduced, ZeroEliminatedDiagonal};
use crate::numbering::Numbering;
use crate::partition::Decomposition;
use anyhow::Context;
use pn_runtime::problem::Problem;
use pn_runtime::solver::pn_layout::Retained;
use pn_runtime::Layout;
use pn_stencil::StencilKernel;
use std::cell::{Cell, RefCell};
use std::ffi::c_void;
use std::ptr::null_mut;

/// One process's share: the partition, its rows and the two numberings.
pub(crate) struct Parts {
    pub(crate) dec: Decomposition,
    /// The kept moments.
    pub(crate) keep: Vec<bool>,
    pub(crate) local: LocalReduced,
    pub(crate) kept_num: Numbering,
    pub(crate) elim_num: Numbering,
}

impl Parts {
    /// Splits the grid (`procs`, or the balanced split over the processes) and assembles
    /// this process's rows.
    pub(crate) fn build(
        mpi: &Mpi,
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
        procs: Option<[usize; 3]>,
    ) -> anyhow::Result<Self> {
        let res = problem.grid.res;
        let dec = match procs {
            Some(p) => Decomposition::new(res, p)?,
            None => Decomposition::balanced(res, mpi.size())?,
        };
        anyhow::ensure!(
            dec.ranks() == mpi.size(),
            "--procs {}x{}x{} makes {} boxes but {} processes run (one box per process)",
            dec.procs()[0],
            dec.procs()[1],
            dec.procs()[2],
            dec.ranks(),
            mpi.size()
        );
        // As pn solve's parity solver: where keeping the odd moments (even N) meets a zero
        // absorption on any process, every process keeps the even ones instead.
        let mut keep = kept_moments(layout, kernel);
        let mut built =
            LocalReduced::build_keeping(problem, kernel, layout, &dec, mpi.rank(), &keep);
        let zero = matches!(&built, Err(e) if e.downcast_ref::<ZeroEliminatedDiagonal>().is_some());
        if mpi.sum(&[f64::from(u8::from(zero))])?[0] > 0.0
            && Retained::for_layout(layout) == Retained::Odd
        {
            keep = kept_moments_retaining(layout, kernel, Retained::Even);
            built = LocalReduced::build_keeping(problem, kernel, layout, &dec, mpi.rank(), &keep);
        }
        let local = built?;
        let kept_num = Numbering::new(layout, &dec, keep.clone());
        let elim_num = Numbering::new(layout, &dec, keep.iter().map(|k| !k).collect());
        Ok(Self {
            dec,
            local,
            kept_num,
            elim_num,
            keep,
        })
    }
}

/// What the shell matrix's product needs.
pub(crate) struct Shell<'a> {
    pub(crate) local: &'a LocalReduced,
    pub(crate) kept_ghosts: Scatter,
    pub(crate) elim_ghosts: Scatter,
    /// `t = C̃ x`, distributed like the eliminated unknowns.
    pub(crate) t: PVec,
    x_ext: RefCell<Vec<f64>>,
    t_ext: RefCell<Vec<f64>>,
    pub(crate) comm_seconds: Cell<f64>,
    pub(crate) applications: Cell<usize>,
    /// The diagonal of `S` (for Jacobi smoothing without forming `S`), once computed.
    pub(crate) diagonal: Option<Vec<f64>>,
}

impl<'a> Shell<'a> {
    /// The product's state for `parts`, scattering from vectors distributed like `x`.
    pub(crate) fn new(parts: &'a Parts, layout: &Layout, x: &PVec) -> anyhow::Result<Self> {
        let (local, dec) = (&parts.local, &parts.dec);
        let t = PVec::mpi(local.elim.owned.len())?;
        let kept_ghosts = Scatter::new(
            x,
            &petsc_numbers(&parts.kept_num, layout, dec, &local.kept.ghosts)?,
        )?;
        let elim_ghosts = Scatter::new(
            &t,
            &petsc_numbers(&parts.elim_num, layout, dec, &local.elim.ghosts)?,
        )?;
        Ok(Self {
            local,
            kept_ghosts,
            elim_ghosts,
            t,
            x_ext: RefCell::new(Vec::new()),
            t_ext: RefCell::new(Vec::new()),
            comm_seconds: Cell::new(0.0),
            applications: Cell::new(0),
            diagonal: None,
        })
    }

    /// Runs `scatter` from `from`, timing it as communication.
    pub(crate) fn exchange(&self, scatter: &Scatter, from: ffi::Vec) -> anyhow::Result<()> {
        // SAFETY: MPI is initialized while a solve runs.
        let t0 = unsafe { ffi::pn_wtime() };
        scatter.run(from)?;
        // SAFETY: as above.
        let dt = unsafe { ffi::pn_wtime() } - t0;
        self.comm_seconds.set(self.comm_seconds.get() + dt);
        Ok(())
    }

    /// Owned values of `v` followed by the ghosts in `scatter`.
    pub(crate) fn extended(
        v: ffi::Vec,
        scatter: &Scatter,
        ext: &mut Vec<f64>,
    ) -> anyhow::Result<()> {
        ext.clear();
        read(v, |a| ext.extend_from_slice(a))?;
        read(scatter.ghosts.0, |g| ext.extend_from_slice(g))
    }

    /// `y = S x`.
    pub(crate) fn mult(&self, x: ffi::Vec, y: ffi::Vec) -> anyhow::Result<()> {
        self.applications.set(self.applications.get() + 1);
        self.exchange(&self.kept_ghosts, x)?;
        let mut x_ext = self.x_ext.borrow_mut();
        Self::extended(x, &self.kept_ghosts, &mut x_ext)?;
        if self.local.is_direct() {
            return write(y, |y| self.local.apply_direct(&x_ext, y));
        }
        write(self.t.0, |t| self.local.apply_c(&x_ext, t))?;
        self.exchange(&self.elim_ghosts, self.t.0)?;
        let mut t_ext = self.t_ext.borrow_mut();
        Self::extended(self.t.0, &self.elim_ghosts, &mut t_ext)?;
        let n = self.local.kept.owned.len();
        write(y, |y| self.local.apply_b(&x_ext[..n], &t_ext, y))
    }
}

/// PETSc's callback for the shell matrix's product.
pub(crate) unsafe extern "C" fn shell_mult(
    a: ffi::Mat,
    x: ffi::Vec,
    y: ffi::Vec,
) -> ffi::PetscErrorCode {
    let mut ctx: *mut c_void = null_mut();
    // SAFETY: `a` is the shell matrix made in `solve`, whose context is a live `Shell`.
    let code = unsafe { ffi::MatShellGetContext(a, (&mut ctx as *mut *mut c_void).cast()) };
    if code != 0 || ctx.is_null() {
        return if code != 0 { code } else { 1 };
    }
    // SAFETY: the context was set from a `&Shell` that outlives the solve.
    let shell = unsafe { &*(ctx as *const Shell<'_>) };
    match shell.mult(x, y) {
        Ok(()) => 0,
        Err(_) => 1,
    }
}

/// The PETSc numbers of storage indices `gs` in `num`.
fn petsc_numbers(
    num: &Numbering,
    layout: &Layout,
    dec: &Decomposition,
    gs: &[usize],
) -> anyhow::Result<Vec<PetscInt>> {
    anyhow::ensure!(
        num.total() < i32::MAX as usize,
        "{} unknowns of one parity: more than PETSc's 32-bit indices address",
        num.total()
    );
    gs.iter()
        .map(|&g| {
            num.global(layout, dec, g)
                .map(|(_, n)| n as PetscInt)
                .context("a ghost of the wrong parity (internal error)")
        })
        .collect()
}

/// `S` assembled as a PETSc AIJ matrix (for GAMG and hypre) and its local entries.
pub(crate) fn assemble_s(
    mpi: &Mpi,
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    dec: &Decomposition,
    local: &LocalReduced,
    kept_num: &Numbering,
) -> anyhow::Result<(PMat, usize)> {
    let c_ghost = local.ghost_c_rows(problem, kernel, layout)?;
    anyhow::ensure!(
        kept_num.total() < i32::MAX as usize,
        "{} unknowns of one parity: more than PETSc's 32-bit indices address",
        kept_num.total()
    );
    let column = |g: usize| {
        kept_num
            .global(layout, dec, g)
            .map(|(_, n)| n as PetscInt)
            .context("a column of the wrong parity (internal error)")
    };
    let rows = local.formed_rows(&c_ghost, &column)?;
    drop(c_ghost);
    let rank = mpi.rank();
    let (lo, hi) = (
        kept_num.rank_start(rank),
        kept_num.rank_start(rank) + kept_num.local_len(rank),
    );
    let mut d_nnz = Vec::with_capacity(rows.row_len.len());
    let mut o_nnz = Vec::with_capacity(rows.row_len.len());
    let mut at = 0;
    for &len in &rows.row_len {
        let c = &rows.cols[at..at + len as usize];
        let d = c
            .iter()
            .filter(|&&n| (lo..hi).contains(&(n as usize)))
            .count();
        d_nnz.push(d as PetscInt);
        o_nnz.push((c.len() - d) as PetscInt);
        at += len as usize;
    }
    let mut m = PMat(null_mut());
    // SAFETY: the counts hold one entry per local row.
    check(
        unsafe {
            ffi::pn_mat_create_aij(
                d_nnz.len() as PetscInt,
                d_nnz.as_ptr(),
                o_nnz.as_ptr(),
                &mut m.0,
            )
        },
        "MatCreateAIJ",
    )?;
    let nnz = rows.vals.len();
    let mut at = 0;
    for (k, &len) in rows.row_len.iter().enumerate() {
        let r = (lo + k) as PetscInt;
        let (c, v) = (&rows.cols[at..], &rows.vals[at..]);
        // SAFETY: one row with `len` columns and values.
        check(
            unsafe {
                ffi::MatSetValues(
                    m.0,
                    1,
                    &r,
                    len as PetscInt,
                    c.as_ptr(),
                    v.as_ptr(),
                    ffi::INSERT_VALUES,
                )
            },
            "MatSetValues",
        )?;
        at += len as usize;
    }
    drop(rows);
    m.assemble()?;
    Ok((m, nnz))
}
