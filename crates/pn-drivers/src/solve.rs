//! `pn solve`: solves a scene and writes fluence, moments, an image and a report.
//!
//! `pn solve checkerboard` with no further flags is the main job: P_5, 71×71, Neumann
//! (extrapolation) boundary, relative residual 1e-10.

use anyhow::{bail, Context};
use pn_formats::write_outputs;
use pn_formats::{Report, RunInfo, SolveReport, VacuumMeasurements};
use pn_kernels::KernelChoice;
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::problem::Problem;
use std::io::Write;
use std::path::Path;

use crate::scene_setup::{
    check_memory_and_set_sigma_t_min, kernel_for, sampled_problem, scene_from_request, Method,
};
pub use crate::scene_setup::{Route, SolveRequest};
use crate::solve_distributed::SolveFn;

/// Runs `pn solve`: solves `req`, writes `fluence.npy`, `moments.npy`, `fluence.png` and
/// `report.json` (plus the method's and the scene's extra files) into its output directory
/// and prints a summary to `stdout`. A solve that does not converge writes its results and
/// then returns an error.
pub fn run(req: &SolveRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    if let Some(d) = &req.distributed {
        return crate::solve_distributed::run(req, d, &mut |solve| run_with(req, stdout, solve));
    }
    run_with(req, stdout, &|problem, kernel, opts| {
        let sol = pn_runtime::with_threads(req.threads, || {
            solve_problem(problem, kernel, req.solver, opts)
        })??;
        Ok(Some((sol, None)))
    })
}

/// [`run`] with the solve itself given (one process, or the distributed solve).
pub(crate) fn run_with(
    req: &SolveRequest,
    stdout: &mut dyn Write,
    solve: SolveFn<'_>,
) -> anyhow::Result<()> {
    let a = req;
    if a.method == Method::Fld {
        // The memory check before FLD allocates its per-cell arrays.
        let grid = scene_from_request(req)?.problem.grid;
        pn_runtime::memory_estimate::check_limit(
            &pn_runtime::memory_estimate::estimate_fld(&grid),
            a.max_memory
                .unwrap_or_else(pn_runtime::memory_estimate::default_limit_bytes),
        )?;
        return crate::fld_method::run(req, stdout);
    }
    crate::fld_setup::reject_fld_flags(a)?;
    anyhow::ensure!(
        a.tol.is_finite() && a.tol > 0.0,
        "--tol must be positive, got {}",
        a.tol
    );
    anyhow::ensure!(a.max_iter > 0, "--max-iter must be at least 1");
    let mut scene = scene_from_request(req)?;
    for n in &scene.notes {
        eprintln!("note: {n}");
    }
    // `method` is pn or cda here (fld returned above).
    let (choice, order) = kernel_for(a, &scene)?;
    let opts = a.solver_options();
    // Refuse oversized problems before allocating, then the automatic σ_t threshold.
    if let Some(t) = check_memory_and_set_sigma_t_min(a, &mut scene, &choice)? {
        eprintln!("note: σ_t = 0 in part of the domain (vacuum): using --sigma-t-min {t:.3e} (1e-3 × max σ_t); set --sigma-t-min to override");
    }
    crate::error_estimate::check_request(req, &scene.problem.grid)?;
    let sampled = sampled_problem(&scene.problem, a.sampling);
    let problem = &sampled;
    let kernel = choice.kernel.as_ref();
    let Some((sol, distributed)) = solve(problem, kernel, &opts)? else {
        return Ok(());
    };
    crate::progress::print_notes(&sol.stats.notes);

    let info = RunInfo {
        scene: scene.name.clone(),
        method: if a.pde.is_some() {
            "pde".to_string()
        } else {
            a.method.name().to_string()
        },
        order,
        layout: if a.collocated {
            "collocated"
        } else {
            "staggered"
        }
        .into(),
        stencil_compiled: choice.compiled,
        threads: pn_runtime::effective_threads(a.threads),
    };
    let mut report = SolveReport::new(Report::new(&info, problem, kernel.name(), &sol));
    report.distributed = distributed;
    let out = a.out_dir(&scene.name);
    write_results(
        req,
        &scene.name,
        problem,
        &choice,
        order,
        &sol,
        report,
        &out,
        stdout,
    )?;
    if a.pde.is_none() && scene.name == "pointsource" {
        crate::pointsource_extras::write_extras(
            &out,
            &a.pointsource_params(),
            &problem.grid,
            &sol,
            order,
            stdout,
        )?;
    }
    let g = &problem.grid;
    let res = g.res[..g.dim.axes()]
        .iter()
        .map(|n| n.to_string())
        .collect::<Vec<_>>()
        .join("×");
    let what = if a.pde.is_some() {
        format!("PDE {}", kernel.name())
    } else if a.method == Method::Cda {
        "CDA".to_string()
    } else {
        format!("P_{order}")
    };
    writeln!(
        stdout,
        "{} {what} {}D {res} {}: {} unknowns, {} non-zeros, {} iterations, relative residual {:.3e}, \
         assembly {:.3} s, solve {:.3} s -> {}",
        scene.name,
        g.dim.axes(),
        problem.boundary.name(),
        sol.unknowns,
        sol.nonzeros,
        sol.stats.iterations,
        sol.stats.relative_residual,
        sol.seconds_assembly,
        sol.seconds_solve,
        out.display()
    )?;
    if let Some(e) = &sol.energy {
        writeln!(
            stdout,
            "energy: source {:.6e} = absorbed {:.6e} + outflow {:.6e} (relative imbalance {:.2e})",
            e.source_power, e.absorbed_power, e.boundary_outflow, e.relative_imbalance
        )?;
    }
    if !sol.stats.converged() {
        bail!(
            "not converged ({:?}): relative residual {:.3e} after {} iterations, tolerance {:.1e}; \
             results were written to {} with \"converged\": false",
            sol.stats.status,
            sol.stats.relative_residual,
            sol.stats.iterations,
            a.tol,
            out.display()
        );
    }
    Ok(())
}

/// Completes `report` with the sections of this run (sampling, error estimate, the
/// `slab`/`milne` measurements), computed before anything is written, then writes the
/// result files with `report.json` once, and the error estimate's files. When a section
/// cannot be computed, the solve's files are still written (with the sections completed
/// before it) and the error is returned.
#[expect(
    clippy::too_many_arguments,
    reason = "the solve's pieces, passed through from the driver"
)]
fn write_results(
    req: &SolveRequest,
    scene: &str,
    problem: &Problem,
    choice: &KernelChoice,
    order: usize,
    sol: &Solution,
    mut report: SolveReport,
    out: &Path,
    stdout: &mut dyn Write,
) -> anyhow::Result<()> {
    let write = |report: &SolveReport| {
        write_outputs(out, &problem.grid, sol, report)
            .with_context(|| format!("writing results to {}", out.display()))
    };
    let estimate = match crate::error_estimate::estimate_for(req, problem, sol) {
        Ok(e) => e,
        Err(e) => {
            write(&report)?;
            return Err(e);
        }
    };
    report.sampling = crate::error_estimate::sampling_entry(req, &problem.grid);
    report.error_estimate = estimate.as_ref().map(|e| e.report.clone());
    // The extras compare with the P_N/CDA references (order 0: none, as for a text PDE,
    // which gets the measurements only, and only when it closes the faces itself).
    let kernel = choice.kernel.as_ref();
    let vacuum = if crate::vacuum_extras::applies(scene)
        && (req.pde.is_none() || kernel.boundary_conditions().is_some())
    {
        crate::vacuum_extras::measure(scene, problem, kernel, req.albedo, sol, order, stdout)
    } else {
        Ok(VacuumMeasurements::default())
    };
    if let Ok(v) = &vacuum {
        report.vacuum = v.clone();
    }
    write(&report)?;
    if let Some(e) = &estimate {
        e.write_files(out)?;
    }
    vacuum.map(|_| ())
}
