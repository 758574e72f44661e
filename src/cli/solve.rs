//! `pn solve` and `pn converge`: their arguments and the conversion into
//! [`pn_drivers::solve::SolveRequest`].

use clap::{Args, ValueEnum};
use pn_drivers::scene_setup::Dim;
use pn_drivers::scene_setup::{Method, Route, SolveRequest};
use pn_runtime::fld::Limiter;
use pn_runtime::problem::Boundary;
use pn_runtime::scenes::PointSourceShape;
use pn_runtime::solver::SolverKind;
use std::path::PathBuf;

use super::Env;

/// `--method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// The P_N equations.
    Pn,
    /// Classical diffusion.
    Cda,
    /// Flux-limited diffusion.
    Fld,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Pn => Method::Pn,
            MethodArg::Cda => Method::Cda,
            MethodArg::Fld => Method::Fld,
        }
    }
}

/// `--fld-solver`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FldSolverArg {
    /// Red–black Gauss–Seidel/SOR.
    Gs,
    /// Picard iteration with linear solves through the diffusion stencil.
    Picard,
}

impl From<FldSolverArg> for Route {
    fn from(r: FldSolverArg) -> Self {
        match r {
            FldSolverArg::Gs => Route::GaussSeidel,
            FldSolverArg::Picard => Route::Picard,
        }
    }
}

/// Arguments of `pn solve`.
#[derive(Args, Debug, Clone)]
pub struct SolveArgs {
    /// A built-in scene (checkerboard, checkerboard3d, pointsource, slab, milne) or a .toml
    /// scene file.
    pub scene: String,
    /// Everything else (boxed: keeps the `pn` command enum small).
    #[command(flatten)]
    pub flags: Box<SolveFlags>,
}

/// Arguments of `pn converge` (`--res` takes the list of resolutions, each one value for
/// all axes; everything else as in `pn solve`).
#[derive(Args, Debug, Clone)]
pub struct ConvergeArgs {
    /// A built-in scene (checkerboard, checkerboard3d, pointsource, slab, milne) or a .toml
    /// scene file.
    pub scene: String,
    /// The options of `pn solve`; here `--res R1,R2,...` lists the resolutions (coarsest
    /// first, each an integer multiple of the first) and `--out` is the study's directory.
    #[command(flatten)]
    pub flags: Box<SolveFlags>,
}

/// The options of `pn solve` (and `pn converge`).
#[derive(Args, Debug, Clone)]
pub struct SolveFlags {
    /// P_N order (default: the scene's, 5 for checkerboard).
    #[arg(long, allow_negative_numbers = true)]
    pub order: Option<usize>,
    /// Dimension, 2 or 3 (default: the scene's).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u8).range(2..=3))]
    pub dim: Option<u8>,
    /// Cells per axis: one number for all axes, or NX,NY[,NZ].
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub res: Option<Vec<usize>>,
    /// Boundary closure: neumann (extrapolation, reflecting), dirichlet (zero) or marshak
    /// (vacuum; staggered P_N with odd N, assembled solvers), for all faces or per face as
    /// FACES=KIND items, FACES one of x, y, z, xmin, xmax, ymin, ymax, zmin, zmax, plus
    /// optionally a bare kind for the faces not named (default neumann); e.g.
    /// x=marshak or marshak,z=neumann.
    #[arg(long)]
    pub bc: Option<Boundary>,
    /// Tolerance on the relative residual ‖b − Au‖₂/‖b‖₂.
    #[arg(long, default_value = "1e-10", allow_hyphen_values = true)]
    pub tol: f64,
    /// Maximum solver iterations.
    #[arg(long, default_value_t = 100_000, allow_negative_numbers = true)]
    pub max_iter: usize,
    /// Output directory (default: out/<scene>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true, value_parser = super::parse_threads)]
    pub threads: Option<usize>,
    /// Use the collocated stencil (all moments at cell centres; oscillates).
    #[arg(long)]
    pub collocated: bool,
    /// pn (the P_N equations), cda (classical diffusion) or fld (flux-limited diffusion).
    #[arg(long, value_enum, default_value = "pn")]
    pub method: MethodArg,
    /// --method fld: flux limiter (lp, sum, max, kershaw, larsen2 or larsen<n>, cda;
    /// default lp).
    #[arg(long, value_parser = parse_limiter)]
    pub limiter: Option<Limiter>,
    /// --method fld: SOR factor ω in (0, 2) of the Gauss–Seidel route (default 1.5); selects
    /// that route when --fld-solver is not given.
    #[arg(long, allow_hyphen_values = true)]
    pub omega: Option<f64>,
    /// --method fld: picard (Anderson-accelerated Picard steps, each a linear solve through
    /// the diffusion stencil with --solver; default) or gs (red–black Gauss–Seidel/SOR, the
    /// default when --omega is given).
    #[arg(long, value_enum)]
    pub fld_solver: Option<FldSolverArg>,
    /// --method fld: extinction threshold σ_ε (1/length; default 1e-3 / longest domain edge).
    #[arg(long, allow_hyphen_values = true)]
    pub sigma_eps: Option<f64>,
    /// --method fld on pointsource: also solve CDA and the other limiters (lp, sum, max,
    /// kershaw, larsen2) for fld_profile.png/.csv, the FLD paper's Figure 5 (five more solves;
    /// without it the profile shows the run's own limiter beside the closed forms).
    #[arg(long)]
    pub fld_all_limiters: bool,
    /// Linear solver: parity-cg (eliminates the odd moments; preconditioned CG, or GMRES/
    /// BiCGSTAB when the closure makes the even system nonsymmetric; the preconditioner is
    /// multigrid for large systems, ILU(0) for small ones), parity-mg / parity-ilu (force
    /// multigrid / the ILU(0)-or-Jacobi choice) or cgnr (the paper's baseline, CG on
    /// AᵀA u = Aᵀb); also lsqr, lsmr, and the matrix-free cgnr-mf, lsqr-mf, lsmr-mf.
    #[arg(long, default_value = "parity-cg")]
    pub solver: SolverKind,
    /// Raise σ_t to at least this value (required where σ_t reaches 0).
    #[arg(long, allow_hyphen_values = true)]
    pub sigma_t_min: Option<f64>,
    /// Refuse problems whose estimated memory exceeds this (bytes, or with K/M/G/T;
    /// default: 80% of the physical memory).
    #[arg(long, value_parser = pn_runtime::memory_estimate::parse_size)]
    pub max_memory: Option<u64>,
    /// Analytic fields: exact (value at the staggered point, as StaRMAP) or average[:N]
    /// (mean over the cell-sized control volume, N midpoints per axis; default 8 in 2D,
    /// 4 in 3D).
    #[arg(long, default_value = "exact")]
    pub sampling: pn_runtime::field::Sampling,
    /// Also solve at half the resolution and report a Richardson estimate of the
    /// discretization error (error.npy, error.png, report.json); needs even resolutions.
    #[arg(long)]
    pub error_estimate: bool,
    /// pointsource: extinction σ_t (default 8).
    #[arg(long, allow_hyphen_values = true)]
    pub sigma_t: Option<f64>,
    /// pointsource and slab: albedo (default 0.9).
    #[arg(long, allow_hyphen_values = true)]
    pub albedo: Option<f64>,
    /// slab: optical thickness (default 1; σ_t = 1); milne: depth of the half-space
    /// (default 30).
    #[arg(long, allow_hyphen_values = true)]
    pub tau: Option<f64>,
    /// pointsource: Henyey–Greenstein g (default 0, isotropic).
    #[arg(long, allow_hyphen_values = true)]
    pub g: Option<f64>,
    /// pointsource: the domain is [0, 2w]³ (default w = 1).
    #[arg(long, allow_hyphen_values = true)]
    pub half_width: Option<f64>,
    /// pointsource: cell (Q_0^0 = 1/h³ in cell n/2) or gaussian:<std-dev>.
    #[arg(long)]
    pub source: Option<PointSourceShape>,
    /// Solve the linear PDE system written in this text file instead of --method's
    /// equations (docs/pde-text.md; shipped: pdes/cda.pde, sp1.pde, sp3.pde, fpn.pde).
    #[arg(long, value_name = "FILE")]
    pub pde: Option<PathBuf>,
    /// Override a `param` of the --pde file (repeatable), e.g. --pde-param sigma_f=2.
    #[arg(long, value_name = "NAME=VALUE", value_parser = pn_drivers::pde_text::parse_param)]
    pub pde_param: Vec<(String, String)>,
    /// --distributed and its settings.
    #[command(flatten)]
    pub dist: DistributedFlags,
}

/// `--distributed` and its settings (`pn solve`, `pn render`).
#[derive(Args, Debug, Clone)]
pub struct DistributedFlags {
    /// Split the linear solves over the MPI processes it was started with (`mpirun -np K pn
    /// solve|render … --distributed`; needs a build with `--features distributed`,
    /// docs/distributed.md).
    #[arg(long)]
    pub distributed: bool,
    /// --distributed: boxes per axis, e.g. 4x1x1 (default: the split with the least halo).
    #[arg(long, value_name = "PXxPYxPZ", value_parser = parse_procs, requires = "distributed")]
    pub procs: Option<[usize; 3]>,
    /// --distributed: the Krylov method (auto: CG when the reduced operator is symmetric,
    /// else GMRES).
    #[arg(long, value_enum, default_value = "auto", requires = "distributed")]
    pub ksp: KspArg,
    /// --distributed: the preconditioner (mg: the project's aggregation multigrid on PETSc's
    /// PCMG; gamg, hypre: algebraic multigrid on the assembled reduced operator).
    #[arg(long, value_enum, default_value = "mg", requires = "distributed")]
    pub pc: PcArg,
    /// --distributed: more PETSc options, e.g. "-pc_gamg_threshold 0.02".
    #[arg(
        long,
        value_name = "OPTIONS",
        allow_hyphen_values = true,
        requires = "distributed"
    )]
    pub petsc_options: Option<String>,
}

impl DistributedFlags {
    /// The driver's settings, when `--distributed` is given.
    pub fn request(&self) -> Option<pn_drivers::scene_setup::DistributedRequest> {
        self.distributed
            .then(|| pn_drivers::scene_setup::DistributedRequest {
                procs: self.procs,
                ksp: format!("{:?}", self.ksp).to_lowercase(),
                pc: format!("{:?}", self.pc).to_lowercase(),
                petsc_options: self.petsc_options.clone(),
            })
    }
}

/// `--ksp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum KspArg {
    /// CG where a random-probe test finds the reduced operator symmetric, else GMRES.
    Auto,
    /// Conjugate gradients.
    Cg,
    /// Restarted GMRES.
    Gmres,
}

/// `--pc`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PcArg {
    /// The project's aggregation multigrid on PETSc's PCMG.
    Mg,
    /// PETSc's smoothed-aggregation algebraic multigrid (GAMG).
    Gamg,
    /// hypre's BoomerAMG.
    Hypre,
    /// Jacobi (the same on any number of processes).
    Jacobi,
    /// None.
    None,
}

/// `--procs PXxPYxPZ`.
fn parse_procs(s: &str) -> Result<[usize; 3], String> {
    let parts: Vec<&str> = s.split(['x', 'X']).collect();
    let bad = || format!("--procs wants three positive counts like 4x1x1, got {s:?}");
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut p = [0usize; 3];
    for (d, t) in parts.iter().enumerate() {
        p[d] = t.trim().parse().map_err(|_| bad())?;
        if p[d] == 0 {
            return Err(bad());
        }
    }
    Ok(p)
}

/// `--limiter`: the library's parser (its error names the limiters).
fn parse_limiter(s: &str) -> anyhow::Result<Limiter> {
    s.parse()
}

impl SolveFlags {
    /// The request for `scene` with these flags.
    pub fn request(&self, scene: &str, env: &Env) -> SolveRequest {
        SolveRequest {
            scene: scene.to_string(),
            order: self.order,
            dim: self.dim.map(|d| if d == 2 { Dim::Two } else { Dim::Three }),
            res: self.res.clone(),
            bc: self.bc,
            tol: self.tol,
            max_iter: self.max_iter,
            out: self.out.clone(),
            threads: self.threads,
            collocated: self.collocated,
            method: self.method.into(),
            limiter: self.limiter,
            omega: self.omega,
            fld_solver: self.fld_solver.map(Route::from),
            sigma_eps: self.sigma_eps,
            fld_all_limiters: self.fld_all_limiters,
            solver: self.solver,
            sigma_t_min: self.sigma_t_min,
            max_memory: self.max_memory,
            sampling: self.sampling,
            error_estimate: self.error_estimate,
            sigma_t: self.sigma_t,
            albedo: self.albedo,
            tau: self.tau,
            g: self.g,
            half_width: self.half_width,
            source: self.source,
            tuning: env.tuning.clone(),
            pde: self.pde.clone(),
            pde_params: self.pde_param.clone(),
            distributed: self.dist.request(),
        }
    }
}

impl SolveArgs {
    /// The driver's request.
    pub fn request(&self, env: &Env) -> SolveRequest {
        self.flags.request(&self.scene, env)
    }
}

impl ConvergeArgs {
    /// The driver's request (`res` lists the resolutions).
    pub fn request(&self, env: &Env) -> SolveRequest {
        self.flags.request(&self.scene, env)
    }
}
