//! What the grid methods (P_N, CDA, FLD, text PDEs) share: the unknowns of the cropped solve
//! grid and the memory check, the first-scatter source, the solve (each method's own), the
//! transport sweeps, and the stencil solve of P_N, CDA and text PDEs.

use super::super::report::{SolverReport, UnknownStats};
use super::{MsSeconds, MsSolution, PreparedScene};
use crate::first_scatter::first_scatter_problem_with_depth;
use crate::renderer::MsField;
use crate::solve_setup::solve_grid;
use crate::transport_sweep::{transport_sweeps_to_band, SweepSettings};
use crate::DensityGrid;
use anyhow::Result;
use pn_kernels::KernelChoice;
use pn_runtime::memory_estimate;
use pn_runtime::pipeline::solve_problem_from;
use pn_runtime::problem::{Grid, Problem};
use pn_runtime::solver::multigrid::FineCycle;
use pn_runtime::solver::{SolverKind, SolverOptions, SolverTuning};
use pn_runtime::CellMoments;
use std::time::Instant;

/// A grid method's description for [`solve_on_grid`].
pub(super) struct GridMethod<'k> {
    /// The stencil (None: FLD, whose unknowns are the interior cells and which is not
    /// checked against the memory limit).
    pub kernel: Option<&'k KernelChoice>,
    /// The highest band Q_l^m of the first-scatter source the method reads.
    pub max_band: u32,
    /// Whether the solve uses the σ_t threshold of the problem (P_N, CDA, text PDEs; the
    /// report then carries it).
    pub uses_sigma_t_min: bool,
}

/// What a grid method's own solve returns.
pub(super) struct GridSolve {
    /// The solution at the cell centres.
    pub moments: CellMoments,
    /// The staggered solution vector (stencil solves).
    pub staggered: Option<Vec<f64>>,
    /// Solver statistics (the σ_t threshold fields are filled by [`solve_on_grid`]).
    pub report: SolverReport,
}

/// The grid method's solve of the first-scatter problem; pushes its notes.
pub(super) type SolveFn<'f> = dyn Fn(&Problem, &mut Vec<String>) -> Result<GridSolve> + Sync + 'f;

/// Runs a grid method: the cropped solve grid (none for an empty medium: no solution), its
/// unknowns and memory check, the first-scatter source, `solve`, the transport sweeps.
pub(super) fn solve_on_grid(
    p: &PreparedScene<'_>,
    m: &GridMethod<'_>,
    solve: &SolveFn<'_>,
) -> Result<MsSolution> {
    let (scene, density, threads) = (p.scene, p.density, p.options.threads);
    let s = &scene.solve;
    let Some((grid, unknowns)) = unknown_stats(density, s.resolution, s.padding(), m.kernel)?
    else {
        return Ok(MsSolution::default());
    };
    if let Some(k) = m.kernel {
        memory_estimate::check_limit(
            &memory_estimate::estimate(&grid, k.kernel.as_ref()),
            p.options
                .max_memory
                .unwrap_or_else(memory_estimate::default_limit_bytes),
        )?;
    }
    let fs = pn_runtime::with_threads(threads, || {
        first_scatter_problem_with_depth(
            scene,
            density,
            &grid,
            m.max_band,
            p.light_depth.clone(),
            p.light_leg,
        )
    })??;
    let mut seconds = MsSeconds {
        light_depth: fs.seconds_light_depth,
        sources: fs.seconds_sources,
        ..MsSeconds::default()
    };
    let mut notes = Vec::new();
    let t1 = Instant::now();
    let run = pn_runtime::with_threads(threads, || solve(&fs.problem, &mut notes))??;
    seconds.solve = t1.elapsed().as_secs_f64();
    let mut moments = run.moments;
    let mut sweeps = 0;
    if s.sweeps > 0 {
        let t2 = Instant::now();
        moments = pn_runtime::with_threads(threads, || {
            transport_sweeps_to_band(
                &fs.problem,
                &moments,
                SweepSettings {
                    sweeps: s.sweeps,
                    n_mu: s.sweep_nodes(),
                },
                s.sweep_bands,
            )
        })??;
        seconds.sweeps = t2.elapsed().as_secs_f64();
        sweeps = s.sweeps;
    }
    let solver = SolverReport {
        sigma_t_min: m
            .uses_sigma_t_min
            .then_some(fs.problem.sigma_t_min)
            .flatten(),
        sigma_t_min_auto: fs.auto_sigma_t_min && m.uses_sigma_t_min,
        ..run.report
    };
    Ok(MsSolution {
        field: Some(
            MsField::new(grid, moments, scene.phase.clone())?.with_lookup(scene.render.ms_lookup),
        ),
        unknowns: Some(unknowns),
        solver: Some(solver),
        light_depth: Some(fs.depth),
        staggered: run.staggered,
        pop: None,
        sweeps,
        seconds,
        notes,
    })
}

/// The cropped solve grid and the unknowns with and without cropping, at the solve and at
/// the density resolution (None: an empty medium).
fn unknown_stats(
    density: &DensityGrid,
    res: [usize; 3],
    margin: usize,
    kernel: Option<&KernelChoice>,
) -> Result<Option<(Grid, UnknownStats)>> {
    let (solved, grid) = unknowns_on(density, res, margin, true, kernel)?;
    let Some(grid) = grid else {
        return Ok(None);
    };
    let (uncropped, _) = unknowns_on(density, res, margin, false, kernel)?;
    let (fine, _) = unknowns_on(density, density.res, margin, true, kernel)?;
    let (fine_full, _) = unknowns_on(density, density.res, margin, false, kernel)?;
    let stats = UnknownStats {
        solved,
        uncropped,
        cropped_at_density_resolution: fine,
        uncropped_at_density_resolution: fine_full,
        solve_grid_res: grid.res,
        solve_grid_min: grid.min,
        solve_grid_max: grid.max,
    };
    Ok(Some((grid, stats)))
}

/// Unknowns of `kernel` (or interior FLD cells) on the grid of the given resolution.
fn unknowns_on(
    density: &DensityGrid,
    res: [usize; 3],
    margin: usize,
    crop: bool,
    kernel: Option<&KernelChoice>,
) -> Result<(u128, Option<Grid>)> {
    let Some(sg) = solve_grid(density, res, margin, crop)? else {
        return Ok((0, None));
    };
    let n = match kernel {
        Some(k) => memory_estimate::estimate(&sg.grid, k.kernel.as_ref()).unknowns,
        None => sg.grid.res.iter().map(|&r| (r - 2) as u128).product(),
    };
    Ok((n, Some(sg.grid)))
}

/// The stencil solve of P_N, CDA and text PDEs: parity multigrid on `kernel` from the
/// earlier channels' solutions, with the render tuning ([`render_tuning`]).
pub(super) fn stencil_solve(
    p: &PreparedScene<'_>,
    kernel: &KernelChoice,
    problem: &Problem,
    notes: &mut Vec<String>,
) -> Result<GridSolve> {
    let tol = p.scene.solve.tolerance;
    // What the stencil library says of its choice (an interpreted stencil, say).
    notes.extend(kernel.note.iter().cloned());
    let opts = SolverOptions {
        tol,
        observer: p.options.observer.clone(),
        tuning: render_tuning(&p.options.tuning),
        ..Default::default()
    };
    // Always multigrid: parity-cg's automatic choice for small systems, ILU(0)-preconditioned
    // CG, stagnates on render grids where the hull absorber jumps to σ_t·h = 3 within one
    // cell of a near-vacuum (12³ sphere: residual 7.6e-2 after 100 000 iterations, where
    // multigrid converges in 195; docs/vacuum.md).
    let sol = match &p.options.linear_solver {
        Some(solve) => (solve.0)(problem, kernel.kernel.as_ref(), &opts, p.guesses)?,
        None => solve_problem_from(
            problem,
            kernel.kernel.as_ref(),
            SolverKind::ParityMg,
            &opts,
            p.guesses,
        )?,
    };
    notes.extend(sol.stats.notes.iter().cloned());
    if !sol.stats.converged() {
        notes.push(format!(
            "warning: the solver stopped ({:?}) at relative residual {:.3e} after {} iterations",
            sol.stats.status, sol.stats.relative_residual, sol.stats.iterations
        ));
    }
    let report = SolverReport {
        solver: sol.stats.solver.clone(),
        stencil: kernel.kernel.name().to_string(),
        iterations: sol.stats.iterations,
        relative_residual: sol.stats.relative_residual,
        tolerance: tol,
        converged: sol.stats.converged(),
        sigma_t_min: None,
        sigma_t_min_auto: false,
    };
    Ok(GridSolve {
        moments: sol.moments,
        staggered: Some(sol.u),
        report,
    })
}

/// The solver tuning of render solves: `tuning` with the multigrid's finest level
/// multiplicative (Chebyshev smoothing around the coarse correction) unless a fine cycle was
/// asked for (`PN_MG_ADDITIVE`). The solver's own default joins the finest level additively
/// where the operator is symmetric, which is best on homogeneous media (80³ P_1 point source,
/// docs/solvers.md); render media are clouds in near-vacuum with the hull absorber around
/// them, where the additive form needs 3–4× the iterations. Measured 2026-12-04
/// (`PN_SOLVER_PROFILE=1 pn render <scene> --order N --solve-res R`, CG iterations and
/// iterate seconds, additive → multiplicative): P_3 @ 16³ puff 224 → 66 (0.34 → 0.21 s),
/// nebula 209 → 65 (0.32 → 0.20 s), cumulus 254 → 74 (0.39 → 0.23 s); P_5 @ 32³ puff 351 →
/// 102 (5.3 → 4.2 s), nebula 320 → 98 (3.9 → 3.3 s), cumulus 400 → 115 (5.8 → 4.4 s), cloud
/// 348 → 102 (4.9 → 4.4 s).
fn render_tuning(tuning: &SolverTuning) -> SolverTuning {
    let mut mg = tuning.multigrid.clone().unwrap_or_default();
    if mg.fine_cycle == FineCycle::AdditiveIfSymmetric {
        mg.fine_cycle = FineCycle::Multiplicative;
    }
    SolverTuning {
        multigrid: Some(mg),
        ..tuning.clone()
    }
}
