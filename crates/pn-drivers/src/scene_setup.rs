//! What `pn solve`, `pn converge` and the error estimate share: the options of a solve
//! ([`SolveRequest`]), the scene they describe, the stencil they select, the memory check
//! and the solver options. Below [`crate::solve`], [`crate::fld_method`],
//! [`crate::error_estimate`] and [`crate::converge`], so that none of those needs another.

use anyhow::{bail, ensure, Result};
use pn_kernels::{cda_kernel, pn_kernel, KernelChoice, Staggering};
use pn_render::load_scene;
use pn_runtime::apply_sampling;
use pn_runtime::field::Sampling;
use pn_runtime::fld::Limiter;
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::scenes::{
    builtin, resolve_res, BuiltinOptions, PointSourceParams, PointSourceShape, Scene,
};
use pn_runtime::solver::{SolverKind, SolverOptions, SolverTuning};
use std::path::{Path, PathBuf};

/// The dimension of a scene's grid (re-exported for [`SolveRequest::dim`]).
pub use pn_stencil::Dim;

/// The equations a scene is solved with (`pn solve --method`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    /// The P_N equations.
    #[default]
    Pn,
    /// Classical diffusion (CDA).
    Cda,
    /// Flux-limited diffusion.
    Fld,
}

impl Method {
    /// Every method, in the order of the command-line help.
    pub const ALL: [Method; 3] = [Method::Pn, Method::Cda, Method::Fld];

    /// `pn`, `cda` or `fld` (the command-line spelling and the `method` of `report.json`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Pn => "pn",
            Method::Cda => "cda",
            Method::Fld => "fld",
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        match Method::ALL.into_iter().find(|m| m.name() == s) {
            Some(m) => Ok(m),
            None => bail!("unknown method {s:?} (expected pn, cda or fld)"),
        }
    }
}

/// How the nonlinear FLD system is solved (`pn solve --method fld --fld-solver`; it lives in
/// [`pn_render::fld_problem`], shared with `pn render --method fld`).
pub use pn_render::fld_problem::Route;

/// The options of one solve (`pn solve`; `pn converge` with `res` listing the
/// resolutions). `None` means "the scene's value" or the documented default.
#[derive(Clone, Debug, PartialEq)]
pub struct SolveRequest {
    /// A built-in scene (checkerboard, checkerboard3d, pointsource, slab, milne) or a `.toml`
    /// scene file.
    pub scene: String,
    /// P_N order (default: the scene's, 5 for checkerboard).
    pub order: Option<usize>,
    /// Dimension (default: the scene's).
    pub dim: Option<Dim>,
    /// Cells per axis: one number for all axes, or one per axis.
    pub res: Option<Vec<usize>>,
    /// Boundary closure (default: the scene's).
    pub bc: Option<Boundary>,
    /// Tolerance on the relative residual ‖b − Au‖₂/‖b‖₂ (FLD: its own stopping test).
    pub tol: f64,
    /// Maximum solver iterations (FLD: Gauss–Seidel iterations or Picard steps).
    pub max_iter: usize,
    /// Output directory (default: `out/<scene>`).
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// The collocated stencil (all moments at cell centres) instead of the staggered one.
    pub collocated: bool,
    /// P_N, CDA or FLD.
    pub method: Method,
    /// FLD: the flux limiter (default Levermore–Pomraning).
    pub limiter: Option<Limiter>,
    /// FLD Gauss–Seidel: the SOR factor ω in (0, 2) (default 1.5).
    pub omega: Option<f64>,
    /// FLD: the solver route (default Gauss–Seidel).
    pub fld_solver: Option<Route>,
    /// FLD: the extinction threshold σ_ε (default 1e-3 / longest domain edge).
    pub sigma_eps: Option<f64>,
    /// FLD on `pointsource`: also solve CDA and the other limiters for `fld_profile.png`
    /// (five more solves; off by default, when the profile shows the run's own limiter only).
    pub fld_all_limiters: bool,
    /// The linear solver (FLD Picard: of each step).
    pub solver: SolverKind,
    /// Raise σ_t to at least this value (required where σ_t reaches 0).
    pub sigma_t_min: Option<f64>,
    /// Refuse problems whose estimated memory exceeds this many bytes (default: 80% of the
    /// physical memory).
    pub max_memory: Option<u64>,
    /// How analytic fields are sampled on the grid.
    pub sampling: Sampling,
    /// Also solve at half the resolution and report a Richardson error estimate.
    pub error_estimate: bool,
    /// pointsource: extinction σ_t (default 8).
    pub sigma_t: Option<f64>,
    /// pointsource and slab: albedo (default 0.9).
    pub albedo: Option<f64>,
    /// slab: optical thickness τ (default 1); milne: depth of the half-space (default 30).
    pub tau: Option<f64>,
    /// pointsource: Henyey–Greenstein g (default 0).
    pub g: Option<f64>,
    /// pointsource: the domain is [0, 2w]³ (default w = 1).
    pub half_width: Option<f64>,
    /// pointsource: the shape of the source (default one cell).
    pub source: Option<PointSourceShape>,
    /// Expert solver settings (the `pn` binary reads them from the environment).
    pub tuning: SolverTuning,
    /// A PDE text file (docs/pde-text.md) solved instead of `method`'s equations.
    pub pde: Option<PathBuf>,
    /// `NAME=VALUE` overrides of the PDE file's `param`s.
    pub pde_params: Vec<(String, String)>,
    /// `--distributed`: the solve split over MPI processes on PETSc (docs/distributed.md).
    pub distributed: Option<DistributedRequest>,
}

/// How `pn solve --distributed` splits and solves (the `distributed` build feature).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DistributedRequest {
    /// Boxes per axis (`--procs 4x1x1`); `None`: the split with the least box surface.
    pub procs: Option<[usize; 3]>,
    /// The Krylov method: `auto` (CG when `S` is symmetric, else GMRES), `cg`, `gmres`.
    pub ksp: String,
    /// The preconditioner: `gamg`, `hypre`, `jacobi`, `none`.
    pub pc: String,
    /// More PETSc options, e.g. `-pc_gamg_threshold 0.02`.
    pub petsc_options: Option<String>,
}

impl Default for SolveRequest {
    /// The checkerboard with the `pn solve` defaults: P_N at the scene's order, parity-cg to
    /// a relative residual of 1e-10, at most 100 000 iterations, exact sampling.
    fn default() -> Self {
        Self {
            scene: "checkerboard".into(),
            order: None,
            dim: None,
            res: None,
            bc: None,
            tol: 1e-10,
            max_iter: 100_000,
            out: None,
            threads: None,
            collocated: false,
            method: Method::Pn,
            limiter: None,
            omega: None,
            fld_solver: None,
            sigma_eps: None,
            fld_all_limiters: false,
            solver: SolverKind::ParityCg,
            sigma_t_min: None,
            max_memory: None,
            sampling: Sampling::Exact,
            error_estimate: false,
            sigma_t: None,
            albedo: None,
            tau: None,
            g: None,
            half_width: None,
            source: None,
            tuning: SolverTuning::default(),
            pde: None,
            pde_params: Vec::new(),
            distributed: None,
        }
    }
}

impl SolveRequest {
    /// The output directory: `out`, else `out/<scene name>`.
    pub fn out_dir(&self, scene_name: &str) -> PathBuf {
        self.out
            .clone()
            .unwrap_or_else(|| PathBuf::from("out").join(scene_name))
    }

    /// The solver options of this request (tolerance, iteration limit, tuning).
    pub fn solver_options(&self) -> SolverOptions {
        SolverOptions {
            tol: self.tol,
            max_iter: self.max_iter,
            tuning: self.tuning.clone(),
            observer: crate::progress::terminal_observer(true, None),
            ..Default::default()
        }
    }

    /// The `pointsource` parameters: the request's values, the scene's defaults elsewhere.
    pub fn pointsource_params(&self) -> PointSourceParams {
        let d = PointSourceParams::default();
        PointSourceParams {
            sigma_t: self.sigma_t.unwrap_or(d.sigma_t),
            albedo: self.albedo.unwrap_or(d.albedo),
            g: self.g.unwrap_or(d.g),
            half_width: self.half_width.unwrap_or(d.half_width),
            source: self.source.unwrap_or(d.source),
        }
    }
}

/// Builds the scene named or pointed to by the request, with its overrides applied, and
/// checks it.
pub fn scene_from_request(req: &SolveRequest) -> Result<Scene> {
    let scene_arg = &req.scene;
    let dim = req.dim;
    let is_file = scene_arg.ends_with(".toml") || Path::new(scene_arg.as_str()).is_file();
    let ps_flags = req.sigma_t.is_some()
        || req.g.is_some()
        || req.half_width.is_some()
        || req.source.is_some();
    if ps_flags && scene_arg != "pointsource" {
        bail!("--sigma-t, --g, --half-width and --source only apply to the pointsource scene");
    }
    if req.albedo.is_some() && !matches!(scene_arg.as_str(), "pointsource" | "slab") {
        bail!("--albedo only applies to the pointsource and slab scenes");
    }
    if req.tau.is_some() && !matches!(scene_arg.as_str(), "slab" | "milne") {
        bail!("--tau only applies to the slab and milne scenes");
    }
    let mut scene = if is_file {
        let mut s = load_scene(Path::new(scene_arg.as_str()))?;
        let g = &mut s.problem.grid;
        if let Some(d) = dim {
            g.dim = d;
        }
        if req.res.is_some() || dim.is_some() {
            let current: Vec<usize> = g.res[..g.dim.axes()].to_vec();
            g.res = resolve_res(g.dim, 1, Some(req.res.as_deref().unwrap_or(&current)))?;
        }
        s
    } else {
        let opts = BuiltinOptions {
            dim,
            res: req.res.clone(),
            pointsource: req.pointsource_params(),
            slab: pn_runtime::scenes::vacuum::SlabParams {
                tau: req.tau,
                albedo: if scene_arg == "slab" {
                    req.albedo
                } else {
                    None
                },
            },
        };
        builtin(scene_arg, &opts)?
    };
    if let Some(bc) = req.bc {
        scene.problem.boundary = bc;
    }
    if req.sigma_t_min.is_some() {
        scene.problem.sigma_t_min = req.sigma_t_min;
    }
    scene.problem.validate()?;
    Ok(scene)
}

/// The problem to assemble: the scene's problem with `sampling` applied for its grid.
pub fn sampled_problem(problem: &Problem, sampling: Sampling) -> Problem {
    apply_sampling(problem, sampling)
}

/// The stencil and P_N order the request selects (`--method pn` or `cda`; the order is 0
/// for CDA). Prints the choice's note (an interpreted stencil) to stderr.
pub fn kernel_for(req: &SolveRequest, scene: &Scene) -> Result<(KernelChoice, usize)> {
    let (choice, order) = select_kernel(req, scene)?;
    crate::progress::print_notes(choice.note.as_slice());
    Ok((choice, order))
}

fn select_kernel(req: &SolveRequest, scene: &Scene) -> Result<(KernelChoice, usize)> {
    ensure!(
        req.method == Method::Pn || req.method == Method::Cda,
        "--error-estimate and pn converge support --method pn and cda, not {}",
        req.method
    );
    let dim = scene.problem.grid.dim;
    if let Some(path) = &req.pde {
        ensure!(
            req.method == Method::Pn,
            "--pde replaces --method (the PDE file says what is solved)"
        );
        ensure!(
            req.order.is_none() && !req.collocated,
            "--order and --collocated do not apply to --pde (orders and placement are in the PDE file)"
        );
        let pde = crate::pde_text::load(path, &req.pde_params)?;
        return Ok((pn_kernels::pde_kernel(&pde, dim)?, 0));
    }
    let layout = if req.collocated {
        Staggering::Collocated
    } else {
        Staggering::Staggered
    };
    if req.method == Method::Cda {
        ensure!(!req.collocated, "--collocated applies to --method pn only");
        ensure!(req.order.is_none(), "--order applies to --method pn only");
        Ok((cda_kernel(dim)?, 0))
    } else {
        let order = req.order.unwrap_or(scene.default_order);
        Ok((pn_kernel(order, dim, layout)?, order))
    }
}

/// Refuses a problem whose estimated memory for `choice` exceeds `max_memory`,
/// then sets the automatic σ_t threshold where part of the domain is vacuum. Returns that
/// threshold, if one was set.
pub fn check_memory_and_set_sigma_t_min(
    req: &SolveRequest,
    scene: &mut Scene,
    choice: &KernelChoice,
) -> Result<Option<f64>> {
    let estimate = pn_runtime::memory_estimate::estimate_for_solver(
        &scene.problem.grid,
        choice.kernel.as_ref(),
        req.solver,
    );
    pn_runtime::memory_estimate::check_limit(
        &estimate,
        req.max_memory
            .unwrap_or_else(pn_runtime::memory_estimate::default_limit_bytes),
    )?;
    let auto = scene.problem.auto_sigma_t_min();
    if let Some(t) = auto {
        scene.problem.sigma_t_min = Some(t);
    }
    Ok(auto)
}
