//! What the distributed solve is asked to do.

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
    /// The project's aggregation multigrid on PETSc's PCMG (geometric 2×2×2 aggregation
    /// per moment grid, Galerkin coarse operators, Chebyshev–Jacobi smoothing).
    Mg,
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
            PcChoice::Mg => "mg",
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
    /// Boxes per axis; `None`: [`crate::Decomposition::balanced`] over the processes.
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
    /// The solution on every process ([`super::DistributedSolution::u`]), not only on
    /// process 0 (a render that goes on with it everywhere).
    pub gather_everywhere: bool,
}
