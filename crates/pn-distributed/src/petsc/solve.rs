//! The distributed parity solve: `S u_e = f` (docs/design.md §5) on PETSc, every process
//! holding the rows of its box ([`crate::LocalReduced`]).
//!
//! * The operator is a PETSc shell matrix whose product is [`crate::LocalReduced::apply_c`] and
//!   [`crate::LocalReduced::apply_b`] around two ghost scatters — bit for bit the same rows on any
//!   number of processes (`operator`).
//! * The preconditioner (`krylov`): the project's multigrid on PCMG (`pcmg`, with the first
//!   coarse operator from the parity blocks, `blocks`) or Jacobi, both with the diagonal of
//!   `S` from the shell; PETSc's GAMG or hypre's BoomerAMG on `S` assembled.
//! * CG where a random-probe test finds `S` symmetric, else GMRES (the Neumann closure's
//!   and the Marshak faces' boundary rows can make `S` nonsymmetric), both stopping on the
//!   unpreconditioned residual ‖f − S u_e‖ ≤ rtol ‖f‖.
//! * Afterwards the eliminated moments `u_o = D_o⁻¹ b_o − C̃ u_e`, the residual of the full
//!   system `‖b − A u‖ / ‖b‖`, and the solution gathered onto process 0 in storage order.

use super::ffi;
use super::objects::{gather, write, Ksp, PVec};
use super::operator::{Parts, Shell};
use super::options::{DistributedOptions, KspChoice};
use super::{check, Mpi};
use crate::numbering::Numbering;
use pn_runtime::problem::Problem;
use pn_runtime::Layout;
use pn_stencil::StencilKernel;
use std::ptr::null_mut;

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
    /// Global reductions (MPI_Allreduce) during the Krylov solve.
    pub reductions: usize,
}

impl RankStats {
    const FIELDS: usize = 10;

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
            self.reductions as f64,
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
            reductions: a[9] as usize,
        }
    }
}

/// What the distributed solve produced.
#[derive(Clone, Debug)]
pub struct DistributedSolution {
    /// The staggered solution in storage order, on process 0 (`None` elsewhere unless
    /// [`DistributedOptions::gather_everywhere`]).
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
    super::krylov::insert_options(opts)?;
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
    let mut shell = shell;
    let pre = super::krylov::prepare(mpi, problem, kernel, layout, &parts, &mut shell, opts)?;
    let nnz_s = pre.formed_nonzeros();
    let symmetric = match opts.ksp {
        KspChoice::Auto => Some(super::krylov::is_symmetric(mpi, &shell)?),
        _ => None,
    };
    let (mut solver, method) = super::krylov::krylov(&shell, pre, symmetric, opts)?;
    let run = (method, symmetric);
    stats.setup_seconds = t1.elapsed().as_secs_f64();
    let reductions_before = mpi.reductions();
    let t2 = std::time::Instant::now();
    // SAFETY: the solver, `f` and `x` are valid; the shell's context lives through the call.
    check(unsafe { ffi::KSPSolve(solver.0, f.0, x.0) }, "KSPSolve")?;
    stats.solve_seconds = t2.elapsed().as_secs_f64();
    stats.reductions = (mpi.reductions() - reductions_before).max(0) as usize;
    let (iterations, reason, rnorm) = super::krylov::result(&solver)?;
    drop(std::mem::replace(&mut solver, Ksp(null_mut())));
    let f_norm = norm(&f)?;
    stats.communication_seconds = shell.comm_seconds.get();
    stats.applications = shell.applications.get();

    let (u, absolute_residual, rhs_norm) = recover_and_gather(
        mpi,
        layout,
        &shell,
        &x,
        [kept_num, elim_num],
        opts.gather_everywhere,
    )?;
    stats.peak_memory_bytes = mpi.peak_memory_bytes();
    let all = mpi.allgather(&stats.to_array())?;
    let nnz = mpi.sum(&[local.nnz_a as f64, nnz_s as f64])?;
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

/// The eliminated moments, the full residual, and the solution on process 0 in storage
/// order: `(u on process 0, ‖b − A u‖, ‖b‖)`.
fn recover_and_gather(
    mpi: &Mpi,
    layout: &Layout,
    shell: &Shell<'_>,
    x: &PVec,
    nums: [&Numbering; 2],
    everywhere: bool,
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
    let gathered = gather(&all, everywhere)?;
    // Process r's block of `gathered` is its kept unknowns, then its eliminated ones, each
    // in its local (ascending storage) order.
    let u = (everywhere || mpi.rank() == 0).then(|| {
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
