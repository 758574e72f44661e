//! `mpirun -np K pn solve … --distributed`: the parity-reduced solve split over MPI processes
//! on PETSc (`pn_distributed`, docs/distributed.md). Every process builds the scene and its
//! box's rows; process 0 gathers the solution and writes the outputs of `pn solve`, with
//! the split and every process's measurements under `"distributed"` in `report.json`.
//!
//! An error on one process prints its message and ends every process (MPI_Abort): the
//! others would otherwise wait for it in their next collective call.

use crate::scene_setup::{DistributedRequest, Method, SolveRequest};
use pn_formats::DistributedSection;
use pn_runtime::pipeline::Solution;

/// What solves the problem for `pn solve` (`crate::solve::run_with`): the solution and the
/// report's distributed section, or `None` on the processes of a distributed solve that
/// write nothing.
pub type SolveFn<'a> = &'a dyn Fn(
    &pn_runtime::Problem,
    &dyn pn_stencil::StencilKernel,
    &pn_runtime::solver::SolverOptions,
)
    -> anyhow::Result<Option<(Solution, Option<DistributedSection>)>>;

/// The rest of `pn solve` given the solve: scene, kernel, outputs and summary.
pub type Command<'a> = &'a mut dyn FnMut(SolveFn<'_>) -> anyhow::Result<()>;

/// A render given the distributed linear solver, on every process (`true` on process 0,
/// which goes on to render and write).
pub type RenderCommand<'a> = &'a mut dyn FnMut(pn_render::LinearSolver, bool) -> anyhow::Result<()>;

/// `mpirun -np K pn render … --distributed`: runs `command` on every process with a linear
/// solver that splits each of the render's P_N, CDA or text-PDE solves over the processes
/// and hands every process the whole solution (so that all go through the same solves, as
/// MPI's collective calls need); process 0 renders and writes. Errors end every process as
/// in [`run`].
pub fn run_render(dist: &DistributedRequest, command: RenderCommand<'_>) -> anyhow::Result<()> {
    imp::run_render(dist, command)
}

/// Runs `command` with the distributed solve (see the module documentation).
pub fn run(
    req: &SolveRequest,
    dist: &DistributedRequest,
    command: Command<'_>,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        req.method != Method::Fld,
        "--distributed solves the linear P_N, CDA and text-PDE systems; FLD is nonlinear and \
         runs on one process (drop --distributed)"
    );
    anyhow::ensure!(
        !req.error_estimate,
        "--error-estimate is not available with --distributed (it solves a second, coarser \
         problem on one process); drop one of the two"
    );
    anyhow::ensure!(
        req.tol.is_finite() && req.tol > 0.0,
        "--tol must be positive, got {}",
        req.tol
    );
    anyhow::ensure!(req.max_iter > 0, "--max-iter must be at least 1");
    imp::run(req, dist, command)
}

#[cfg(not(feature = "distributed"))]
mod imp {
    use super::*;

    pub fn run(_: &SolveRequest, _: &DistributedRequest, _: Command<'_>) -> anyhow::Result<()> {
        bail_no_feature()
    }

    pub fn run_render(_: &DistributedRequest, _: RenderCommand<'_>) -> anyhow::Result<()> {
        bail_no_feature()
    }

    fn bail_no_feature() -> anyhow::Result<()> {
        anyhow::bail!(
            "--distributed needs a pn built with the `distributed` feature (PETSc and MPI): \
             install petsc-dev and openmpi-bin (Debian), then `cargo build --release --features \
             distributed` and start it with `mpirun -np K target/release/pn solve … \
             --distributed` (docs/distributed.md)"
        )
    }
}

#[cfg(feature = "distributed")]
mod imp {
    use super::*;
    use pn_distributed::petsc::{self, DistributedOptions, KspChoice, Mpi, PcChoice};
    use pn_formats::RankSection;
    use pn_runtime::pipeline::solution_from_vector;
    use pn_runtime::solver::{SolveStats, SolveStatus};
    use pn_runtime::{Layout, Problem};
    use pn_stencil::StencilKernel;
    use std::sync::Arc;

    /// Whether an MPI launcher started this process (OpenMPI, MPICH/Hydra and PMIx set
    /// these).
    fn launched_by_mpirun() -> bool {
        ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
            .iter()
            .any(|v| std::env::var_os(v).is_some())
    }

    fn options(
        req: &SolveRequest,
        dist: &DistributedRequest,
    ) -> anyhow::Result<DistributedOptions> {
        let ksp = match dist.ksp.as_str() {
            "auto" => KspChoice::Auto,
            "cg" => KspChoice::Cg,
            "gmres" => KspChoice::Gmres,
            other => anyhow::bail!("unknown --ksp {other:?} (auto, cg, gmres)"),
        };
        let pc = match dist.pc.as_str() {
            "mg" => PcChoice::Mg,
            "gamg" => PcChoice::Gamg,
            "hypre" => PcChoice::Hypre,
            "jacobi" => PcChoice::Jacobi,
            "none" => PcChoice::None,
            other => anyhow::bail!("unknown --pc {other:?} (mg, gamg, hypre, jacobi, none)"),
        };
        Ok(DistributedOptions {
            procs: dist.procs,
            ksp,
            pc,
            rtol: req.tol,
            max_iter: req.max_iter,
            petsc_options: dist.petsc_options.clone(),
            gather_everywhere: false,
        })
    }

    pub fn run(
        req: &SolveRequest,
        dist: &DistributedRequest,
        command: Command<'_>,
    ) -> anyhow::Result<()> {
        let opts = options(req, dist)?;
        let mpi = start("solve")?;
        let outcome = command(&|problem, kernel, _| solve_here(&mpi, req, problem, kernel, &opts));
        finish(&mpi, outcome)
    }

    /// Checks for a launcher and starts PETSc and MPI.
    fn start(command: &str) -> anyhow::Result<Arc<Mpi>> {
        anyhow::ensure!(
            launched_by_mpirun(),
            "--distributed needs an MPI launcher: start it as `mpirun -np K pn {command} … \
             --distributed` (K processes; `mpirun -np 1` for one)"
        );
        Ok(Arc::new(Mpi::init()?))
    }

    /// An error on one of several processes ends them all (see the module documentation).
    fn finish(mpi: &Mpi, outcome: anyhow::Result<()>) -> anyhow::Result<()> {
        match outcome {
            Ok(()) => Ok(()),
            Err(e) if mpi.size() > 1 => {
                eprintln!("error (process {} of {}): {e:#}", mpi.rank(), mpi.size());
                mpi.abort(1)
            }
            Err(e) => Err(e),
        }
    }

    pub fn run_render(dist: &DistributedRequest, command: RenderCommand<'_>) -> anyhow::Result<()> {
        let base = options(&SolveRequest::default(), dist)?;
        let mpi = start("render")?;
        let root = mpi.rank() == 0;
        let shared = Arc::clone(&mpi);
        let solver = pn_render::LinearSolver(Arc::new(move |problem, kernel, sopts, _guesses| {
            let opts = DistributedOptions {
                rtol: sopts.tol,
                max_iter: sopts.max_iter,
                gather_everywhere: true,
                ..base.clone()
            };
            let layout = Layout::new(&problem.grid, kernel.moments())?;
            let d = petsc::solve(&shared, problem, kernel, &layout, &opts)?;
            let u = d
                .u
                .clone()
                .ok_or_else(|| anyhow::anyhow!("the solution was not gathered (internal error)"))?;
            let stats = stats_of(&d, sopts.tol);
            let seconds = slowest_seconds(&d);
            solution_from_vector(problem, layout, u, stats, d.nnz_a, seconds)
        }));
        let outcome = command(solver, root);
        finish(&mpi, outcome)
    }

    /// This process's part of the solve; the solution and the report's section on process 0.
    fn solve_here(
        mpi: &Mpi,
        req: &SolveRequest,
        problem: &Problem,
        kernel: &dyn StencilKernel,
        opts: &DistributedOptions,
    ) -> anyhow::Result<Option<(Solution, Option<DistributedSection>)>> {
        problem.validate()?;
        problem.check_not_singular()?;
        let layout = Layout::new(&problem.grid, kernel.moments())?;
        let d = pn_runtime::with_threads(req.threads, || {
            petsc::solve(mpi, problem, kernel, &layout, opts)
        })??;
        let Some(u) = d.u.clone() else {
            return Ok(None);
        };
        let stats = stats_of(&d, req.tol);
        let seconds = slowest_seconds(&d);
        let sol = solution_from_vector(problem, layout, u, stats, d.nnz_a, seconds)?;
        Ok(Some((sol, Some(section(&d)))))
    }

    /// The solve's statistics in the form of the one-process solvers'.
    fn stats_of(d: &petsc::DistributedSolution, tol: f64) -> SolveStats {
        let status = if d.reason > 0 {
            SolveStatus::Converged
        } else if d.reason == -3 {
            SolveStatus::MaxIterations
        } else {
            SolveStatus::Diverged
        };
        SolveStats {
            solver: format!("petsc-{}+{}", d.ksp, d.pc),
            status,
            iterations: d.iterations,
            relative_residual: d.relative_residual(),
            absolute_residual: d.absolute_residual,
            rhs_norm: d.rhs_norm,
            tolerance: tol,
            history: Vec::new(),
            operator_applications: d.ranks.first().map_or(0, |r| r.applications),
            notes: vec![format!(
                "distributed: {} processes as {}×{}×{} boxes, {} with {} ({}), reduced residual {:.3e}",
                d.ranks.len(),
                d.procs[0],
                d.procs[1],
                d.procs[2],
                d.ksp,
                d.pc,
                d.reason_text(),
                d.reduced_relative_residual
            )],
        }
    }

    /// The slowest process's assembly and setup-plus-solve seconds.
    fn slowest_seconds(d: &petsc::DistributedSolution) -> [f64; 2] {
        let slowest = |f: fn(&petsc::RankStats) -> f64| d.ranks.iter().map(f).fold(0.0, f64::max);
        [
            slowest(|r| r.assembly_seconds),
            slowest(|r| r.setup_seconds + r.solve_seconds),
        ]
    }

    fn section(d: &petsc::DistributedSolution) -> DistributedSection {
        DistributedSection {
            processes: d.ranks.len(),
            procs: d.procs,
            ksp: d.ksp.into(),
            pc: d.pc.into(),
            symmetric: d.symmetric,
            converged_reason: d.reason,
            converged_reason_text: d.reason_text().into(),
            reduced_relative_residual: d.reduced_relative_residual,
            nonzeros_reduced: d.nnz_s,
            ranks: d
                .ranks
                .iter()
                .map(|r| RankSection {
                    assembly_seconds: r.assembly_seconds,
                    setup_seconds: r.setup_seconds,
                    solve_seconds: r.solve_seconds,
                    communication_seconds: r.communication_seconds,
                    operator_applications: r.applications,
                    halo_bytes_per_application: r.halo_bytes_per_application,
                    owned_unknowns: r.owned_unknowns,
                    ghost_unknowns: r.ghost_unknowns,
                    peak_memory_bytes: r.peak_memory_bytes,
                    reductions: r.reductions,
                })
                .collect(),
        }
    }
}
