//! The distributed parity solve: `S u_e = f` (docs/design.md §5) on PETSc, every process
//! holding the rows of its box ([`LocalReduced`]).
//!
//! * The operator is a PETSc shell matrix whose product is [`LocalReduced::apply_c`] and
//!   [`LocalReduced::apply_b`] around two ghost scatters — bit for bit the same rows on any
//!   number of processes.
//! * The preconditioner works on `S` assembled (each process forms its rows from its own
//!   and the neighbouring eliminated rows, [`LocalReduced::formed_rows`]): PETSc's GAMG,
//!   hypre's BoomerAMG, or Jacobi.
//! * CG where the assembled `S` is symmetric (to 1e-10 of its largest entry), else GMRES
//!   (the Neumann closure's and the Marshak faces' boundary rows can make `S`
//!   nonsymmetric), both stopping on the unpreconditioned residual ‖f − S u_e‖ ≤ rtol ‖f‖.
//! * Afterwards the eliminated moments `u_o = D_o⁻¹ b_o − C̃ u_e`, the residual of the full
//!   system `‖b − A u‖ / ‖b‖`, and the solution gathered onto process 0 in storage order.

use super::ffi::{self, PetscInt};
use super::objects::{gather_to_zero, read, write, Ksp, PMat, PVec, Scatter};
use super::{check, Mpi};
use crate::local::{kept_moments, LocalReduced};
use crate::numbering::Numbering;
use crate::partition::Decomposition;
use anyhow::Context;
use pn_runtime::problem::Problem;
use pn_runtime::Layout;
use pn_stencil::StencilKernel;
use std::cell::{Cell, RefCell};
use std::ffi::{c_void, CString};
use std::ptr::null_mut;

/// The Krylov method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KspChoice {
    /// CG when the assembled `S` is symmetric, else GMRES.
    Auto,
    /// Conjugate gradients.
    Cg,
    /// Restarted GMRES (right-preconditioned).
    Gmres,
}

/// The preconditioner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PcChoice {
    /// PETSc's smoothed-aggregation algebraic multigrid on the assembled `S`.
    Gamg,
    /// hypre's BoomerAMG on the assembled `S`.
    Hypre,
    /// The diagonal of `S` (the same on any number of processes).
    Jacobi,
    /// None (`S` is not assembled).
    None,
}

impl PcChoice {
    /// PETSc's name of the preconditioner.
    pub fn petsc_name(self) -> &'static str {
        match self {
            PcChoice::Gamg => "gamg",
            PcChoice::Hypre => "hypre",
            PcChoice::Jacobi => "jacobi",
            PcChoice::None => "none",
        }
    }
}

/// How to solve.
#[derive(Clone, Debug)]
pub struct DistributedOptions {
    /// Boxes per axis; `None`: [`Decomposition::balanced`] over the processes.
    pub procs: Option<[usize; 3]>,
    /// Krylov method.
    pub ksp: KspChoice,
    /// Preconditioner.
    pub pc: PcChoice,
    /// Relative tolerance on the reduced residual.
    pub rtol: f64,
    /// Iteration limit.
    pub max_iter: usize,
    /// More PETSc options (`-ksp_gmres_restart 60 …`), applied last.
    pub petsc_options: Option<String>,
}

/// What one process measured.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RankStats {
    /// Seconds assembling its rows (and the neighbours' eliminated rows for `S`).
    pub assembly_seconds: f64,
    /// Seconds forming `S` and setting up the preconditioner.
    pub setup_seconds: f64,
    /// Seconds in the Krylov solve (communication included).
    pub solve_seconds: f64,
    /// Seconds of those in the operator's ghost scatters.
    pub communication_seconds: f64,
    /// Applications of the shell operator.
    pub applications: usize,
    /// Bytes received per application (both ghost exchanges).
    pub halo_bytes_per_application: usize,
    /// Kept and eliminated unknowns owned.
    pub owned_unknowns: usize,
    /// Ghost unknowns (both classes).
    pub ghost_unknowns: usize,
    /// Peak resident memory in bytes (getrusage, the whole process).
    pub peak_memory_bytes: f64,
}

impl RankStats {
    const FIELDS: usize = 9;

    fn to_array(&self) -> [f64; Self::FIELDS] {
        [
            self.assembly_seconds,
            self.setup_seconds,
            self.solve_seconds,
            self.communication_seconds,
            self.applications as f64,
            self.halo_bytes_per_application as f64,
            self.owned_unknowns as f64,
            self.ghost_unknowns as f64,
            self.peak_memory_bytes,
        ]
    }

    fn from_slice(a: &[f64]) -> Self {
        Self {
            assembly_seconds: a[0],
            setup_seconds: a[1],
            solve_seconds: a[2],
            communication_seconds: a[3],
            applications: a[4] as usize,
            halo_bytes_per_application: a[5] as usize,
            owned_unknowns: a[6] as usize,
            ghost_unknowns: a[7] as usize,
            peak_memory_bytes: a[8],
        }
    }
}

/// What the distributed solve produced.
#[derive(Clone, Debug)]
pub struct DistributedSolution {
    /// The staggered solution in storage order, on process 0 (`None` elsewhere).
    pub u: Option<Vec<f64>>,
    /// Krylov iterations.
    pub iterations: usize,
    /// PETSc's converged reason (positive: converged, negative: diverged or stopped).
    pub reason: i32,
    /// The Krylov method used (`cg`, `gmres`).
    pub ksp: &'static str,
    /// The preconditioner.
    pub pc: &'static str,
    /// Whether the assembled `S` was found symmetric (`None`: not assembled).
    pub symmetric: Option<bool>,
    /// ‖f − S u_e‖ / ‖f‖ at the end.
    pub reduced_relative_residual: f64,
    /// ‖b − A u‖₂ of the whole system.
    pub absolute_residual: f64,
    /// ‖b‖₂.
    pub rhs_norm: f64,
    /// Boxes per axis.
    pub procs: [usize; 3],
    /// Stored entries of `A` on all processes.
    pub nnz_a: usize,
    /// Stored entries of the assembled `S` on all processes (0 when not assembled).
    pub nnz_s: usize,
    /// Every process's measurements, in rank order.
    pub ranks: Vec<RankStats>,
}

impl DistributedSolution {
    /// ‖b − A u‖₂ / ‖b‖₂.
    pub fn relative_residual(&self) -> f64 {
        if self.rhs_norm > 0.0 {
            self.absolute_residual / self.rhs_norm
        } else {
            self.absolute_residual
        }
    }

    /// PETSc's words for [`Self::reason`].
    pub fn reason_text(&self) -> &'static str {
        match self.reason {
            2 => "converged (relative tolerance)",
            3 => "converged (absolute tolerance)",
            r if r > 0 => "converged",
            -3 => "iteration limit reached",
            -4 => "diverged (residual grew past the divergence tolerance)",
            -5 | -6 => "breakdown",
            -7 => "nonsymmetric operator or preconditioner for CG",
            -8 => "indefinite preconditioner",
            -9 => "not a number in the residual",
            -11 => "preconditioner setup failed",
            _ => "stopped",
        }
    }
}

/// One process's share: the partition, its rows and the two numberings.
pub(crate) struct Parts {
    pub(crate) dec: Decomposition,
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
        let local = LocalReduced::build(problem, kernel, layout, &dec, mpi.rank())?;
        let keep = kept_moments(layout);
        let kept_num = Numbering::new(layout, &dec, keep.clone());
        let elim_num = Numbering::new(layout, &dec, keep.iter().map(|k| !k).collect());
        Ok(Self {
            dec,
            local,
            kept_num,
            elim_num,
        })
    }
}

/// What the shell matrix's product needs.
pub(crate) struct Shell<'a> {
    local: &'a LocalReduced,
    kept_ghosts: Scatter,
    elim_ghosts: Scatter,
    /// `t = C̃ x`, distributed like the eliminated unknowns.
    t: PVec,
    x_ext: RefCell<Vec<f64>>,
    t_ext: RefCell<Vec<f64>>,
    comm_seconds: Cell<f64>,
    applications: Cell<usize>,
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
        })
    }

    /// Runs `scatter` from `from`, timing it as communication.
    fn exchange(&self, scatter: &Scatter, from: ffi::Vec) -> anyhow::Result<()> {
        // SAFETY: MPI is initialized while a solve runs.
        let t0 = unsafe { ffi::pn_wtime() };
        scatter.run(from)?;
        // SAFETY: as above.
        let dt = unsafe { ffi::pn_wtime() } - t0;
        self.comm_seconds.set(self.comm_seconds.get() + dt);
        Ok(())
    }

    /// Owned values of `v` followed by the ghosts in `scatter`.
    fn extended(v: ffi::Vec, scatter: &Scatter, ext: &mut Vec<f64>) -> anyhow::Result<()> {
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
        write(self.t.0, |t| self.local.apply_c(&x_ext, t))?;
        self.exchange(&self.elim_ghosts, self.t.0)?;
        let mut t_ext = self.t_ext.borrow_mut();
        Self::extended(self.t.0, &self.elim_ghosts, &mut t_ext)?;
        let n = self.local.kept.owned.len();
        write(y, |y| self.local.apply_b(&x_ext[..n], &t_ext, y))
    }
}

/// PETSc's callback for the shell matrix's product.
unsafe extern "C" fn shell_mult(a: ffi::Mat, x: ffi::Vec, y: ffi::Vec) -> ffi::PetscErrorCode {
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

/// Solves `problem` with `kernel` split over the processes of `mpi` (every process calls
/// this with the same arguments). Errors on one process are returned there only; the
/// caller ends every process ([`Mpi::abort`]).
pub fn solve(
    mpi: &Mpi,
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    opts: &DistributedOptions,
) -> anyhow::Result<DistributedSolution> {
    let mut stats = RankStats::default();
    let t0 = std::time::Instant::now();
    let parts = Parts::build(mpi, problem, kernel, layout, opts.procs)?;
    stats.assembly_seconds = t0.elapsed().as_secs_f64();
    let (local, dec, kept_num, elim_num) =
        (&parts.local, &parts.dec, &parts.kept_num, &parts.elim_num);
    stats.owned_unknowns = local.kept.owned.len() + local.elim.owned.len();
    stats.ghost_unknowns = local.kept.ghosts.len() + local.elim.ghosts.len();
    stats.halo_bytes_per_application = local.halo_bytes_per_application();
    let x = PVec::mpi(local.kept.owned.len())?;
    let shell = Shell::new(&parts, layout, &x)?;
    let f = reduced_rhs(&shell)?;
    let t1 = std::time::Instant::now();
    let formed = match opts.pc {
        PcChoice::None => None,
        _ => Some(assemble_s(
            mpi, problem, kernel, layout, dec, local, kept_num,
        )?),
    };
    let (mut solver, run) = krylov(&shell, formed.as_ref(), opts)?;
    stats.setup_seconds = t1.elapsed().as_secs_f64();
    let t2 = std::time::Instant::now();
    // SAFETY: the solver, `f` and `x` are valid; the shell's context lives through the call.
    check(unsafe { ffi::KSPSolve(solver.0, f.0, x.0) }, "KSPSolve")?;
    stats.solve_seconds = t2.elapsed().as_secs_f64();
    let (iterations, reason, rnorm) = ksp_result(&solver)?;
    drop(std::mem::replace(&mut solver, Ksp(null_mut())));
    let f_norm = norm(&f)?;
    stats.communication_seconds = shell.comm_seconds.get();
    stats.applications = shell.applications.get();

    let (u, absolute_residual, rhs_norm) =
        recover_and_gather(mpi, layout, &shell, &x, [kept_num, elim_num])?;
    stats.peak_memory_bytes = mpi.peak_memory_bytes();
    let all = mpi.allgather(&stats.to_array())?;
    let nnz = mpi.sum(&[
        local.nnz_a as f64,
        formed.as_ref().map_or(0.0, |m| m.1 as f64),
    ])?;
    Ok(DistributedSolution {
        u,
        iterations,
        reason,
        ksp: run.0,
        pc: opts.pc.petsc_name(),
        symmetric: run.1,
        reduced_relative_residual: if f_norm > 0.0 { rnorm / f_norm } else { rnorm },
        absolute_residual,
        rhs_norm,
        procs: dec.procs(),
        nnz_a: nnz[0] as usize,
        nnz_s: nnz[1] as usize,
        ranks: all
            .chunks(RankStats::FIELDS)
            .map(RankStats::from_slice)
            .collect(),
    })
}

/// ‖v‖₂ over all processes.
fn norm(v: &PVec) -> anyhow::Result<f64> {
    let mut n = 0.0;
    // SAFETY: `v` is valid.
    check(unsafe { ffi::VecNorm(v.0, ffi::NORM_2, &mut n) }, "VecNorm")?;
    Ok(n)
}

/// `f = b_e − B D_o⁻¹ b_o` as a distributed vector.
fn reduced_rhs(shell: &Shell<'_>) -> anyhow::Result<PVec> {
    let local = shell.local;
    shell.t.fill(&local.scaled_odd_rhs())?;
    shell.elim_ghosts.run(shell.t.0)?;
    let mut s_ext = Vec::new();
    Shell::extended(shell.t.0, &shell.elim_ghosts, &mut s_ext)?;
    let f = PVec::mpi(local.kept.owned.len())?;
    f.fill(&local.reduced_rhs(&s_ext))?;
    Ok(f)
}

/// `S` assembled as a PETSc AIJ matrix (for the preconditioner) and its local entries.
fn assemble_s(
    mpi: &Mpi,
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    dec: &Decomposition,
    local: &LocalReduced,
    kept_num: &Numbering,
) -> anyhow::Result<(PMat, usize, f64)> {
    let c_ghost = local.ghost_c_rows(problem, kernel, layout)?;
    let rows = local.formed_rows(&c_ghost);
    let rank = mpi.rank();
    let (lo, hi) = (
        kept_num.rank_start(rank),
        kept_num.rank_start(rank) + kept_num.local_len(rank),
    );
    let mut d_nnz = Vec::with_capacity(rows.len());
    let mut o_nnz = Vec::with_capacity(rows.len());
    let mut cols: Vec<Vec<PetscInt>> = Vec::with_capacity(rows.len());
    let mut max_entry = 0.0f64;
    for row in &rows {
        let c = petsc_numbers(
            kept_num,
            layout,
            dec,
            &row.iter().map(|e| e.0).collect::<Vec<_>>(),
        )?;
        let d = c
            .iter()
            .filter(|&&n| (lo..hi).contains(&(n as usize)))
            .count();
        d_nnz.push(d as PetscInt);
        o_nnz.push((c.len() - d) as PetscInt);
        max_entry = row.iter().fold(max_entry, |m, e| m.max(e.1.abs()));
        cols.push(c);
    }
    let mut m = PMat(null_mut());
    // SAFETY: the counts hold one entry per local row.
    check(
        unsafe {
            ffi::pn_mat_create_aij(
                rows.len() as PetscInt,
                d_nnz.as_ptr(),
                o_nnz.as_ptr(),
                &mut m.0,
            )
        },
        "MatCreateAIJ",
    )?;
    let mut nnz = 0;
    for (k, (row, c)) in rows.iter().zip(&cols).enumerate() {
        let r = (lo + k) as PetscInt;
        let v: Vec<f64> = row.iter().map(|e| e.1).collect();
        nnz += v.len();
        // SAFETY: one row with `c.len()` columns and values.
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
            "MatSetValues",
        )?;
    }
    // SAFETY: every value is set.
    check(
        unsafe { ffi::MatAssemblyBegin(m.0, ffi::MAT_FINAL_ASSEMBLY) },
        "MatAssemblyBegin",
    )?;
    // SAFETY: as above.
    check(
        unsafe { ffi::MatAssemblyEnd(m.0, ffi::MAT_FINAL_ASSEMBLY) },
        "MatAssemblyEnd",
    )?;
    let global_max = mpi
        .allgather(&[max_entry])?
        .into_iter()
        .fold(0.0f64, f64::max);
    Ok((m, nnz, global_max))
}

/// The Krylov solver over the shell operator, with the method and preconditioner of
/// `opts`; returns it and (method name, symmetry of `S` where assembled).
fn krylov(
    shell: &Shell<'_>,
    formed: Option<&(PMat, usize, f64)>,
    opts: &DistributedOptions,
) -> anyhow::Result<(Ksp, (&'static str, Option<bool>))> {
    let n = shell.local.kept.owned.len() as PetscInt;
    let mut op = PMat(null_mut());
    let ctx = shell as *const Shell<'_> as *mut c_void;
    // SAFETY: `ctx` points to `shell`, which outlives the solver (the caller drops the
    // solver before `shell`).
    check(
        unsafe { ffi::pn_mat_create_shell(n, ctx, &mut op.0) },
        "MatCreateShell",
    )?;
    // SAFETY: `shell_mult` has the signature of MATOP_MULT.
    check(
        unsafe { ffi::MatShellSetOperation(op.0, ffi::MATOP_MULT, shell_mult) },
        "MatShellSetOperation",
    )?;
    let symmetric = match formed {
        Some((m, _, max)) => {
            let mut flag = 0;
            // SAFETY: `m` is assembled.
            check(
                unsafe { ffi::MatIsSymmetric(m.0, 1e-10 * max, &mut flag) },
                "MatIsSymmetric",
            )?;
            Some(flag != 0)
        }
        None => None,
    };
    let method = match (opts.ksp, symmetric) {
        (KspChoice::Cg, _) | (KspChoice::Auto, Some(true)) => "cg",
        _ => "gmres",
    };
    let mut ksp = Ksp(null_mut());
    // SAFETY: `ksp.0` receives the solver.
    check(unsafe { ffi::pn_ksp_create(&mut ksp.0) }, "KSPCreate")?;
    let pmat = formed.map_or(op.0, |m| m.0 .0);
    // SAFETY: both matrices are valid; the solver takes references to them.
    check(
        unsafe { ffi::KSPSetOperators(ksp.0, op.0, pmat) },
        "KSPSetOperators",
    )?;
    configure(&ksp, method, opts)?;
    // SAFETY: the solver is configured.
    check(
        unsafe { ffi::KSPSetUp(ksp.0) },
        "KSPSetUp (the preconditioner's setup)",
    )?;
    Ok((ksp, (method, symmetric)))
}

/// Sets the method, preconditioner, tolerances and norm, then the user's options.
fn configure(ksp: &Ksp, method: &str, opts: &DistributedOptions) -> anyhow::Result<()> {
    let cstr = |s: &str| CString::new(s).context("an option with a NUL byte");
    // SAFETY: valid solver and NUL-terminated names.
    check(
        unsafe { ffi::KSPSetType(ksp.0, cstr(method)?.as_ptr()) },
        "KSPSetType",
    )?;
    let mut pc = null_mut();
    // SAFETY: valid solver.
    check(unsafe { ffi::KSPGetPC(ksp.0, &mut pc) }, "KSPGetPC")?;
    // SAFETY: valid preconditioner and name.
    check(
        unsafe { ffi::PCSetType(pc, cstr(opts.pc.petsc_name())?.as_ptr()) },
        "PCSetType",
    )
    .with_context(|| format!("the preconditioner {:?}", opts.pc.petsc_name()))?;
    let max_iter = opts.max_iter.min(i32::MAX as usize) as PetscInt;
    // SAFETY: valid solver.
    check(
        unsafe { ffi::KSPSetTolerances(ksp.0, opts.rtol, 0.0, ffi::PETSC_DEFAULT_REAL, max_iter) },
        "KSPSetTolerances",
    )?;
    if method == "gmres" {
        // SAFETY: valid solver.
        check(
            unsafe { ffi::KSPSetPCSide(ksp.0, ffi::PC_RIGHT) },
            "KSPSetPCSide",
        )?;
    }
    // SAFETY: valid solver.
    check(
        unsafe { ffi::KSPSetNormType(ksp.0, ffi::KSP_NORM_UNPRECONDITIONED) },
        "KSPSetNormType",
    )?;
    if let Some(o) = &opts.petsc_options {
        // SAFETY: NUL-terminated options string; null means the global options database.
        check(
            unsafe { ffi::PetscOptionsInsertString(null_mut(), cstr(o)?.as_ptr()) },
            "PetscOptionsInsertString",
        )
        .with_context(|| format!("the PETSc options {o:?}"))?;
    }
    // SAFETY: valid solver.
    check(
        unsafe { ffi::KSPSetFromOptions(ksp.0) },
        "KSPSetFromOptions",
    )
}

/// Iterations, converged reason and final residual norm of a finished solve.
fn ksp_result(ksp: &Ksp) -> anyhow::Result<(usize, i32, f64)> {
    let (mut its, mut reason, mut rnorm) = (0, 0, 0.0);
    // SAFETY: valid solver after KSPSolve.
    unsafe {
        check(
            ffi::KSPGetIterationNumber(ksp.0, &mut its),
            "KSPGetIterationNumber",
        )?;
        check(
            ffi::KSPGetConvergedReason(ksp.0, &mut reason),
            "KSPGetConvergedReason",
        )?;
        check(
            ffi::KSPGetResidualNorm(ksp.0, &mut rnorm),
            "KSPGetResidualNorm",
        )?;
    }
    Ok((its.max(0) as usize, reason, rnorm))
}

/// The eliminated moments, the full residual, and the solution on process 0 in storage
/// order: `(u on process 0, ‖b − A u‖, ‖b‖)`.
fn recover_and_gather(
    mpi: &Mpi,
    layout: &Layout,
    shell: &Shell<'_>,
    x: &PVec,
    nums: [&Numbering; 2],
) -> anyhow::Result<(Option<Vec<f64>>, f64, f64)> {
    let local = shell.local;
    shell.kept_ghosts.run(x.0)?;
    let mut ue_ext = Vec::new();
    Shell::extended(x.0, &shell.kept_ghosts, &mut ue_ext)?;
    let u_o = local.recover_odd(&ue_ext);
    shell.t.fill(&u_o)?;
    shell.elim_ghosts.run(shell.t.0)?;
    let mut uo_ext = Vec::new();
    Shell::extended(shell.t.0, &shell.elim_ghosts, &mut uo_ext)?;
    let (r2, b2) = local.residual_squares(&ue_ext, &uo_ext);
    let sums = mpi.sum(&[r2, b2])?;

    let n_e = local.kept.owned.len();
    let all = PVec::mpi(n_e + u_o.len())?;
    write(all.0, |a| {
        a[..n_e].copy_from_slice(&ue_ext[..n_e]);
        a[n_e..].copy_from_slice(&u_o);
    })?;
    let gathered = gather_to_zero(&all)?;
    // Process r's block of `gathered` is its kept unknowns, then its eliminated ones, each
    // in its local (ascending storage) order.
    let u = (mpi.rank() == 0).then(|| {
        let mut u = vec![0.0; layout.len()];
        let mut at = 0;
        for r in 0..mpi.size() {
            for g in nums[0]
                .owned(layout, r)
                .into_iter()
                .chain(nums[1].owned(layout, r))
            {
                u[g] = gathered[at];
                at += 1;
            }
        }
        u
    });
    Ok((u, sums[0].sqrt(), sums[1].sqrt()))
}
