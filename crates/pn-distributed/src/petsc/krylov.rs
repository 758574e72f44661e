//! The Krylov solver over the shell operator: what each preconditioner needs (the diagonal
//! of `S`, the multigrid hierarchy, or `S` assembled), the symmetry probe that picks CG or
//! GMRES, and PETSc's settings.

use super::check;
use super::ffi::{self, PetscInt};
use super::objects::{write, Ksp, PMat, PVec};
use super::operator::{assemble_s, shell_mult, Parts, Shell};
use super::options::{DistributedOptions, KspChoice, PcChoice};
use super::Mpi;
use anyhow::Context;
use pn_krylov::krylov::SYMMETRY_TOL;
use pn_runtime::problem::Problem;
use pn_runtime::Layout;
use pn_stencil::StencilKernel;
use std::ffi::{c_void, CString};
use std::ptr::null_mut;

/// What the preconditioner was given.
pub(crate) struct Prepared {
    /// `S` assembled (GAMG, hypre) and its local entries.
    formed: Option<(PMat, usize)>,
    /// The multigrid's interpolations and first coarse operator.
    mg: Option<(Vec<PMat>, PMat)>,
}

impl Prepared {
    /// Local entries of the assembled `S` (0 when it was not formed).
    pub(crate) fn formed_nonzeros(&self) -> usize {
        self.formed.as_ref().map_or(0, |f| f.1)
    }
}

/// Prepares `opts.pc`: Jacobi and the multigrid get the diagonal of `S` from the shell
/// (`S` itself is never formed for them), the multigrid its hierarchy, GAMG and hypre `S`.
pub(crate) fn prepare(
    mpi: &Mpi,
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    parts: &Parts,
    shell: &mut Shell<'_>,
    opts: &DistributedOptions,
) -> anyhow::Result<Prepared> {
    let local = &parts.local;
    let mut pre = Prepared {
        formed: None,
        mg: None,
    };
    match opts.pc {
        PcChoice::None => {}
        PcChoice::Gamg | PcChoice::Hypre => {
            pre.formed = Some(assemble_s(
                mpi,
                problem,
                kernel,
                layout,
                &parts.dec,
                local,
                &parts.kept_num,
            )?);
        }
        PcChoice::Jacobi | PcChoice::Mg => {
            let c_ghost = local.ghost_c_rows(problem, kernel, layout)?;
            shell.diagonal = Some(local.diagonal_of_s(&c_ghost));
        }
    }
    if opts.pc == PcChoice::Mg {
        let interps = super::pcmg::interpolations(mpi.rank(), layout, &parts.dec, &parts.keep)?;
        if let Some(p) = interps.first() {
            let first = super::blocks::first_coarse(parts, layout, p)?;
            pre.mg = Some((interps, first));
        }
    }
    Ok(pre)
}

/// PETSc's callback for the shell matrix's diagonal (Jacobi).
unsafe extern "C" fn shell_diagonal(a: ffi::Mat, d: ffi::Vec) -> ffi::PetscErrorCode {
    let mut ctx: *mut c_void = null_mut();
    // SAFETY: `a` is the shell matrix made in `krylov`, whose context is a live `Shell`.
    let code = unsafe { ffi::MatShellGetContext(a, (&mut ctx as *mut *mut c_void).cast()) };
    if code != 0 || ctx.is_null() {
        return if code != 0 { code } else { 1 };
    }
    // SAFETY: the context was set from a `&Shell` that outlives the solve.
    let shell = unsafe { &*(ctx as *const Shell<'_>) };
    match &shell.diagonal {
        Some(diag) => match write(d, |v| v.copy_from_slice(diag)) {
            Ok(()) => 0,
            Err(_) => 1,
        },
        None => 1,
    }
}

/// A pseudo-random value in [−1, 1] for storage index `g` (SplitMix64): the same probe on
/// any split.
fn probe_value(g: usize, seed: u64) -> f64 {
    let mut z = (g as u64)
        .wrapping_add(seed)
        .wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Whether `S` is symmetric: the random-probe asymmetry
/// `|xᵀSy − yᵀSx| / (‖x‖‖Sy‖ + ‖y‖‖Sx‖)` of `pn_runtime`'s parity solver below
/// [`SYMMETRY_TOL`], with the probes drawn per storage index (the same on any split).
pub(crate) fn is_symmetric(mpi: &Mpi, shell: &Shell<'_>) -> anyhow::Result<bool> {
    let owned = &shell.local.kept.owned;
    let vec_of = |seed: u64| -> anyhow::Result<PVec> {
        let v = PVec::mpi(owned.len())?;
        v.fill(
            &owned
                .iter()
                .map(|&g| probe_value(g, seed))
                .collect::<Vec<_>>(),
        )?;
        Ok(v)
    };
    let (x, y) = (vec_of(0x5eed_5a17)?, vec_of(0x0dd_ba11)?);
    let (sx, sy) = (PVec::mpi(owned.len())?, PVec::mpi(owned.len())?);
    shell.mult(x.0, sx.0)?;
    shell.mult(y.0, sy.0)?;
    let (xs, ys, sxs, sys) = (x.to_vec()?, y.to_vec()?, sx.to_vec()?, sy.to_vec()?);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).sum::<f64>();
    let sums = mpi.sum(&[
        dot(&xs, &sys),
        dot(&ys, &sxs),
        dot(&xs, &xs),
        dot(&ys, &ys),
        dot(&sxs, &sxs),
        dot(&sys, &sys),
    ])?;
    let scale = (sums[2] * sums[5]).sqrt() + (sums[3] * sums[4]).sqrt();
    Ok(scale == 0.0 || (sums[0] - sums[1]).abs() / scale < SYMMETRY_TOL)
}

/// The Krylov solver over `shell` with the preconditioner `pre` (consumed: PETSc holds its
/// own references) and CG where `symmetric` (or asked for), else GMRES; set up.
pub(crate) fn krylov(
    shell: &Shell<'_>,
    pre: Prepared,
    symmetric: Option<bool>,
    opts: &DistributedOptions,
) -> anyhow::Result<(Ksp, &'static str)> {
    let n = shell.local.kept.owned.len() as PetscInt;
    let mut op = PMat(null_mut());
    let ctx = shell as *const Shell<'_> as *mut c_void;
    // SAFETY: `ctx` points to `shell`, which outlives the solver (the caller drops the
    // solver before `shell`); the callbacks have the signatures of their operations.
    unsafe {
        check(
            ffi::pn_mat_create_shell(n, ctx, &mut op.0),
            "MatCreateShell",
        )?;
        check(
            ffi::pn_mat_shell_set_mult(op.0, shell_mult),
            "MatShellSetOperation",
        )?;
        if shell.diagonal.is_some() {
            check(
                ffi::pn_mat_shell_set_diagonal(op.0, shell_diagonal),
                "MatShellSetOperation (diagonal)",
            )?;
        }
    }
    let method = match (opts.ksp, symmetric) {
        (KspChoice::Cg, _) | (KspChoice::Auto, Some(true)) => "cg",
        _ => "gmres",
    };
    let mut ksp = Ksp(null_mut());
    // SAFETY: `ksp.0` receives the solver.
    check(unsafe { ffi::pn_ksp_create(&mut ksp.0) }, "KSPCreate")?;
    let pmat = pre.formed.as_ref().map_or(op.0, |m| m.0 .0);
    // SAFETY: both matrices are valid; the solver takes references to them.
    check(
        unsafe { ffi::KSPSetOperators(ksp.0, op.0, pmat) },
        "KSPSetOperators",
    )?;
    configure(
        &ksp,
        method,
        pre.mg.map(|(p, first)| (p, op.0, first)),
        opts,
    )?;
    // SAFETY: the solver is configured.
    check(
        unsafe { ffi::KSPSetUp(ksp.0) },
        "KSPSetUp (the preconditioner's setup)",
    )?;
    Ok((ksp, method))
}

/// Sets the method, preconditioner, tolerances and norm, then the user's options.
fn configure(
    ksp: &Ksp,
    method: &str,
    mg: Option<(Vec<PMat>, ffi::Mat, PMat)>,
    opts: &DistributedOptions,
) -> anyhow::Result<()> {
    let cstr = |s: &str| CString::new(s).context("an option with a NUL byte");
    // SAFETY: valid solver and NUL-terminated names.
    check(
        unsafe { ffi::KSPSetType(ksp.0, cstr(method)?.as_ptr()) },
        "KSPSetType",
    )?;
    let mut pc = null_mut();
    // SAFETY: valid solver.
    check(unsafe { ffi::KSPGetPC(ksp.0, &mut pc) }, "KSPGetPC")?;
    match mg {
        Some((p, fine, first)) => super::pcmg::configure(pc, &p, fine, first)?,
        // SAFETY: valid preconditioner and name.
        None => check(
            unsafe { ffi::PCSetType(pc, cstr(opts.pc.petsc_name())?.as_ptr()) },
            "PCSetType",
        )
        .with_context(|| format!("the preconditioner {:?}", opts.pc.petsc_name()))?,
    }
    let max_iter = opts.max_iter.min(i32::MAX as usize) as PetscInt;
    // SAFETY: valid solver.
    unsafe {
        check(
            ffi::KSPSetTolerances(ksp.0, opts.rtol, 0.0, ffi::PETSC_DEFAULT_REAL, max_iter),
            "KSPSetTolerances",
        )?;
        if method == "gmres" {
            check(ffi::KSPSetPCSide(ksp.0, ffi::PC_RIGHT), "KSPSetPCSide")?;
        }
        check(
            ffi::KSPSetNormType(ksp.0, ffi::KSP_NORM_UNPRECONDITIONED),
            "KSPSetNormType",
        )?;
    }
    // SAFETY: valid solver.
    check(
        unsafe { ffi::KSPSetFromOptions(ksp.0) },
        "KSPSetFromOptions",
    )
}

/// Puts the preconditioner's default options, then the user's, into PETSc's options
/// database (before any object is made, so that the matrix products see them too).
pub(crate) fn insert_options(opts: &DistributedOptions) -> anyhow::Result<()> {
    let defaults = match opts.pc {
        // hypre's guidance for 3D problems (its BoomerAMG documentation): strong threshold
        // 0.5 instead of the 2D default 0.25, HMIS coarsening with extended+i interpolation
        // and at most 4 interpolation weights per row, which keep the coarse operators
        // sparse.
        PcChoice::Hypre => {
            "-pc_hypre_type boomeramg -pc_hypre_boomeramg_strong_threshold 0.5 \
             -pc_hypre_boomeramg_coarsen_type HMIS -pc_hypre_boomeramg_interp_type ext+i \
             -pc_hypre_boomeramg_P_max 4"
        }
        PcChoice::Mg => super::pcmg::OPTIONS,
        _ => "",
    };
    let cstr = |s: &str| CString::new(s).context("an option with a NUL byte");
    for (o, what) in [
        (Some(defaults.to_string()), "defaults"),
        (opts.petsc_options.clone(), "--petsc-options"),
    ] {
        let Some(o) = o.filter(|o: &String| !o.is_empty()) else {
            continue;
        };
        // SAFETY: NUL-terminated options string; null means the global options database.
        check(
            unsafe { ffi::PetscOptionsInsertString(null_mut(), cstr(&o)?.as_ptr()) },
            "PetscOptionsInsertString",
        )
        .with_context(|| format!("the PETSc options {o:?} ({what})"))?;
    }
    Ok(())
}

/// Iterations, converged reason and final residual norm of a finished solve.
pub(crate) fn result(ksp: &Ksp) -> anyhow::Result<(usize, i32, f64)> {
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
