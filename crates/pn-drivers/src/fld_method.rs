//! `pn solve <scene> --method fld`: flux-limited diffusion (Koerner et al. 2014; docs/fld.md)
//! by the red–black Gauss–Seidel solver (`--fld-solver gs`, default) or by Picard iteration
//! through the generated `diffusion_3d` stencil (`--fld-solver picard`), with the outputs of
//! P_N (`fluence.npy`, `moments.npy`, `fluence.png`, `report.json`) and, for the `pointsource`
//! scene, the FLD paper's Figure 5 (`fld_profile.png`, `fld_profile.csv`).
//!
//! **From the scene to the FLD problem** ([`fld_problem`]): σ_t, σ_s (or the albedo) and
//! `Q_0^0` are evaluated at the cell centres (exact for analytic fields, the voxel itself for
//! voxel data at the grid resolution). The FLD extinction is the transport coefficient
//! `σ_t − g σ_s` (`g = λ_1 p_1`, docs/design.md §2.2; σ_t for isotropic scattering), the
//! absorption `σ_t − σ_s`. FLD needs cubic cells (one `h`) and 3D; the outermost cell layer
//! carries the Dirichlet value `φ = ε j̄ h` instead of the scene's `--bc`, and vacuum is handled
//! by `σ_ε` (`--sigma-eps`, default `1e-3/L` with L the longest domain edge) instead of
//! `--sigma-t-min`.
//!
//! **Normalisation.** The FLD solvers work with the fluence `φ = √(4π) L_0^0` and the
//! isotropic emission `q = √(4π) Q_0^0` (docs/design.md §1; the diffusion equation is linear in
//! both, so it reads the same for L_0^0 and Q_0^0). For consistency with `--method pn|cda`,
//! `fluence.npy`, `moments.npy` and `fluence.png` hold **`L_0^0 = φ/√(4π)`**; multiply by
//! `√(4π)` for the fluence.
//!
//! **Tolerance.** `--tol` is the FLD stopping test: the RMS residual over the interior cells
//! below `tol × j̄` (j̄ the RMS source). The `pn solve` default 1e-10 is stricter than the
//! paper's 1e-6 (`--tol 1e-6`); `--max-iter` bounds the Gauss–Seidel iterations or the Picard
//! steps.

mod plot;

use anyhow::{bail, ensure, Context, Result};
use pn_formats::write_outputs;
use pn_formats::{FldSection, Report, RunInfo, SolveReport};
use pn_kernels::{diffusion_kernel, Dim};
use pn_runtime::pipeline::Solution;
use pn_runtime::solver::{SolveStats, SolveStatus, SolverKind};
use pn_runtime::CellMoments;
use pn_runtime::Layout;
use pn_stencil::MomentPlacement;
use std::io::Write;

use crate::fld_setup::{fld_problem, settings_from_request, solve_fld_route, FldRun, SQRT_4PI};
use crate::scene_setup::{scene_from_request, Route, SolveRequest};

/// Wraps an FLD answer as a [`Solution`] (one moment, L_0^0 at the cell centres) so that
/// [`write_outputs`] writes the same files as for P_N.
fn as_solution(grid: &pn_runtime::problem::Grid, run: &FldRun, tol: f64) -> Result<Solution> {
    let s = &run.solution;
    let l00: Vec<f64> = s.phi.iter().map(|v| v / SQRT_4PI).collect();
    let layout = Layout::new(
        grid,
        &[MomentPlacement {
            l: 0,
            m: 0,
            shift: [0, 0, 0],
        }],
    )?;
    let [nx, ny, nz] = grid.res;
    let status = if s.converged {
        SolveStatus::Converged
    } else if s.final_residual().is_finite() {
        SolveStatus::MaxIterations
    } else {
        SolveStatus::Diverged
    };
    let interior = ((nx - 2) * (ny - 2) * (nz - 2)) as f64;
    let rhs_rms = s.rms_source;
    let stats = SolveStats {
        solver: match run.route {
            Route::GaussSeidel => "fld-gs".into(),
            Route::Picard => format!(
                "fld-picard({})",
                run.linear_solver.as_deref().unwrap_or("?")
            ),
        },
        status,
        iterations: s.iterations,
        relative_residual: s.final_residual(),
        // The absolute residual ‖r‖₂ over the interior cells in fluence units.
        absolute_residual: s.final_residual() * rhs_rms * interior.sqrt(),
        rhs_norm: rhs_rms * ((nx * ny * nz) as f64).sqrt(),
        tolerance: tol,
        history: s.residual_history.iter().skip(1).copied().collect(),
        // Nonlinear sweeps, not products with a fixed matrix: not counted.
        operator_applications: 0,
        notes: Vec::new(),
    };
    Ok(Solution {
        layout,
        u: l00.clone(),
        moments: CellMoments {
            res: grid.res,
            per_cell: 1,
            data: l00,
        },
        stats,
        energy: None,
        unknowns: (nx - 2) * (ny - 2) * (nz - 2),
        nonzeros: run.nonzeros,
        seconds_assembly: 0.0,
        seconds_solve: run.seconds,
    })
}

/// Runs `pn solve … --method fld`: solves, writes the outputs and prints a summary line to
/// `stdout`.
pub fn run(a: &SolveRequest, stdout: &mut dyn Write) -> Result<()> {
    let scene = scene_from_request(a)?;
    ensure!(
        !a.fld_all_limiters || scene.name == "pointsource",
        "--fld-all-limiters applies to the pointsource scene only (its fld_profile figure)"
    );
    for n in &scene.notes {
        eprintln!("note: {n}");
    }
    ensure!(
        !a.error_estimate,
        "--error-estimate is not available for --method fld"
    );
    // --sampling average: cell averages of analytic fields (FLD samples at cell centres).
    let sampled = pn_runtime::apply_sampling(&scene.problem, a.sampling);
    let problem = &sampled;
    let fp = fld_problem(problem)?;
    let settings = settings_from_request(a, &fp.grid)?;
    settings
        .params
        .validate(&fp)
        .context("invalid FLD settings (--limiter, --omega, --sigma-eps, --tol)")?;
    if problem.max_source_band() > 0 {
        eprintln!(
            "note: FLD is isotropic: only the source moment Q_0^0 is used, higher source \
             moments are ignored"
        );
    }
    if settings.route == Route::Picard && settings.linear_solver == SolverKind::Cgnr {
        eprintln!(
            "note: the Picard steps are symmetric positive definite; --solver parity-cg \
             (preconditioned CG) needs far fewer iterations than cgnr"
        );
    }
    // The stencil is only used by the Picard route, but the report names it either way.
    let kernel = diffusion_kernel(Dim::Three)?;
    crate::progress::print_notes(kernel.note.as_slice());
    let run =
        pn_runtime::with_threads(a.threads, || solve_fld_route(&fp, &settings, &kernel, None))??;
    crate::progress::print_notes(&run.notes);

    let sol = as_solution(&problem.grid, &run, a.tol)?;
    let info = RunInfo {
        scene: scene.name.clone(),
        method: "fld".into(),
        order: 0,
        layout: "staggered".into(),
        stencil_compiled: kernel.compiled,
        threads: pn_runtime::effective_threads(a.threads),
    };
    let stencil_name = match run.route {
        Route::Picard => kernel.kernel.name().to_string(),
        Route::GaussSeidel => "fld-7point (red-black SOR, matrix-free)".to_string(),
    };
    let mut base = Report::new(&info, problem, &stencil_name, &sol);
    base.boundary =
        "dirichlet (FLD: phi = eps * rms source * h on the outermost cell layer)".into();
    base.residual_norm =
        "FLD: RMS residual over the interior cells / RMS source (nonlinear, D from phi)".into();
    base.sigma_t_min = None;
    let s = &run.solution;
    let report = SolveReport {
        fld: Some(FldSection {
            route: run.route.name().into(),
            limiter: settings.params.limiter.to_string(),
            omega: (run.route == Route::GaussSeidel).then_some(settings.params.omega),
            sigma_eps: settings.params.sigma_eps,
            eps: settings.params.eps,
            rms_source: s.rms_source,
            phi_boundary: s.phi_boundary,
            iterations: s.iterations,
            residual: s.final_residual(),
            tolerance: settings.params.tol,
            converged: s.converged,
            linear_solver: run.linear_solver.clone(),
            linear_iterations: run.linear_iterations.clone(),
            output_normalisation: "fluence.npy, moments.npy and fluence.png hold L_0^0 = \
                                   phi / sqrt(4 pi) (phi the fluence), as for --method pn"
                .into(),
        }),
        ..SolveReport::new(base)
    };
    let out = a.out_dir(&scene.name);
    write_outputs(&out, &problem.grid, &sol, &report)
        .with_context(|| format!("writing results to {}", out.display()))?;
    if scene.name == "pointsource" {
        plot::write_figure5(
            &out,
            &a.pointsource_params(),
            &fp,
            &settings,
            &kernel,
            &run,
            a.fld_all_limiters,
        )
        .context("writing the FLD point-source profile")?;
    }

    let g = &problem.grid;
    writeln!(
        stdout,
        "{} FLD ({}, {} route) 3D {}×{}×{}: {} interior cells, {} {}, relative residual {:.3e}, \
         solve {:.3} s -> {}",
        scene.name,
        settings.params.limiter,
        run.route.name(),
        g.res[0],
        g.res[1],
        g.res[2],
        sol.unknowns,
        s.iterations,
        match run.route {
            Route::GaussSeidel => "iterations".to_string(),
            Route::Picard => format!(
                "Picard steps ({} linear iterations)",
                run.linear_iterations.iter().sum::<usize>()
            ),
        },
        s.final_residual(),
        run.seconds,
        out.display()
    )?;
    if !s.converged {
        bail!(
            "FLD did not converge: relative residual {:.3e} after {} {}, tolerance {:.1e}; \
             results were written to {} with \"converged\": false",
            s.final_residual(),
            s.iterations,
            if run.route == Route::Picard {
                "Picard steps"
            } else {
                "iterations"
            },
            settings.params.tol,
            out.display()
        );
    }
    Ok(())
}
