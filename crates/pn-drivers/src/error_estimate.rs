//! `pn solve --error-estimate` and `--sampling` (docs/convergence.md), plus the per-level solve shared
//! with `pn converge`.
//!
//! The estimate solves the same scene (same sampling, same solver settings) at half the
//! resolution, restricts the fine fluence to that grid and applies Richardson extrapolation
//! (`pn_runtime::convergence::richardson`): `u_fine − u ≈ (u_fine − u_coarse)/(2^p − 1)`.
//! The order p is observed from a third solve at a quarter of the resolution when every
//! axis is divisible by 4 and the observed value is plausible (0.5 < p < 4); otherwise the
//! design order p = 2 (docs/design.md §3: second-order staggered differences) is assumed and the
//! report says so.

use crate::scene_setup::{
    check_memory_and_set_sigma_t_min, kernel_for, sampled_problem, scene_from_request, SolveRequest,
};
use anyhow::{ensure, Result};
use pn_formats::cell_shape;
use pn_formats::ErrorEstimate;
use pn_formats::{write_png, Slice};
use pn_runtime::convergence::{l2_diff, observed_order, rel_l2_diff, restrict, richardson};
use pn_runtime::field::Sampling;
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::problem::{Grid, Problem};
use pn_runtime::scenes::Scene;
use std::path::Path;
use std::time::Instant;

/// One solved resolution.
pub struct LevelSolve {
    /// The scene at this resolution.
    pub scene: Scene,
    /// The problem as assembled (sampling applied).
    pub problem: Problem,
    /// The solution.
    pub sol: Solution,
    /// Assembly + solve seconds.
    pub seconds: f64,
}

/// Builds the scene of `req` at `res` (cells per axis, one value or one per axis) and
/// solves it with the request's method, order, sampling and solver settings. A solve that does
/// not reach the tolerance is an error: a study of unconverged solutions measures the solver,
/// not the discretization.
pub fn solve_at(req: &SolveRequest, res: Vec<usize>) -> Result<LevelSolve> {
    let a = req;
    let level = SolveRequest {
        res: Some(res),
        ..req.clone()
    };
    let mut scene = scene_from_request(&level)?;
    let (choice, _) = kernel_for(a, &scene)?;
    check_memory_and_set_sigma_t_min(a, &mut scene, &choice)?;
    let problem = sampled_problem(&scene.problem, a.sampling);
    let opts = a.solver_options();
    let t0 = Instant::now();
    let kernel = choice.kernel.as_ref();
    let sol = pn_runtime::with_threads(a.threads, || {
        solve_problem(&problem, kernel, a.solver, &opts)
    })??;
    crate::progress::print_notes(&sol.stats.notes);
    let seconds = t0.elapsed().as_secs_f64();
    let g = &problem.grid;
    ensure!(
        sol.stats.converged(),
        "the solve at {:?} did not converge (relative residual {:.3e} after {} iterations, \
         tolerance {:.1e}); raise --max-iter or try --solver parity-cg",
        &g.res[..g.dim.axes()],
        sol.stats.relative_residual,
        sol.stats.iterations,
        a.tol
    );
    Ok(LevelSolve {
        scene,
        problem,
        sol,
        seconds,
    })
}

/// Fails early (before the fine solve) when `--error-estimate` cannot work on this grid.
pub fn check_request(req: &SolveRequest, grid: &Grid) -> Result<()> {
    if !req.error_estimate {
        return Ok(());
    }
    let axes = grid.dim.axes();
    for d in 0..axes {
        ensure!(
            grid.res[d].is_multiple_of(2) && grid.res[d] >= 2,
            "--error-estimate solves again at half the resolution, so every axis needs an even \
             number of cells; got {} on axis {d} (e.g. use --res {})",
            grid.res[d],
            grid.res[d] + 1
        );
    }
    Ok(())
}

/// The sampling mode as `report.json` records it: present when it is not the default or
/// with `--error-estimate`.
pub fn sampling_entry(req: &SolveRequest, grid: &Grid) -> Option<String> {
    (req.error_estimate || req.sampling != Sampling::Exact)
        .then(|| req.sampling.resolved(grid.dim.axes()).name())
}

/// An error estimate of a fine solve: its `report.json` section and what `error.npy` and
/// `error.png` hold.
pub struct Estimate {
    /// The section `"error_estimate"` (its per-cell values are the files' contents).
    pub report: ErrorEstimate,
    /// The coarse grid the per-cell estimate lives on.
    grid: Grid,
    /// Title of `error.png`.
    title: String,
}

impl Estimate {
    /// Writes `error.npy` and `error.png` into `out` (which exists) and prints the summary
    /// line to stderr.
    pub fn write_files(&self, out: &Path) -> Result<()> {
        let est = &self.report;
        write_error_files(out, &self.grid, &est.estimate.per_cell, &self.title)?;
        eprintln!(
            "error estimate (Richardson, p = {:.2}, {}): relative L2 {:.3e}, max {:.3e} \
             ({:.3e} of max L_0^0); extra cost {:.3} s -> {}",
            est.estimate.order,
            est.estimate.order_source,
            est.estimate.rel_l2,
            est.estimate.max_abs,
            est.estimate.rel_max,
            est.extra_seconds,
            out.join("error.npy").display()
        );
        Ok(())
    }
}

/// With `--error-estimate`, after the fine solve `sol` of `problem`: runs the coarse
/// solve(s) and returns the estimate (nothing is written here). `None` without the flag.
pub fn estimate_for(
    req: &SolveRequest,
    problem: &Problem,
    sol: &Solution,
) -> Result<Option<Estimate>> {
    if !req.error_estimate {
        return Ok(None);
    }
    if req.scene == "pointsource" {
        eprintln!(
            "note: the pointsource scene centres its source on cell n/2, i.e. at w + w/n, \
             which moves by h/2 between n and n/2 cells; the estimate includes that shift"
        );
    }
    estimate(req, problem, sol).map(Some)
}

fn estimate(req: &SolveRequest, problem: &Problem, sol: &Solution) -> Result<Estimate> {
    let g = &problem.grid;
    let axes = g.dim.axes();
    let half: Vec<usize> = g.res[..axes].iter().map(|n| n / 2).collect();
    let coarse = solve_at(req, half)?;
    let mut extra_seconds = coarse.seconds;
    let fine_seconds = sol.seconds_assembly + sol.seconds_solve;
    let cg = coarse.problem.grid.clone();
    let u_fine = restrict(&sol.l00(), g.res, cg.res)?;
    let u_coarse = coarse.sol.l00();
    let d12 = rel_l2_diff(&u_coarse, &u_fine);
    let mut level_differences = vec![d12];
    let mut observed = None;
    if g.res[..axes].iter().all(|n| n.is_multiple_of(4)) {
        let quarter: Vec<usize> = g.res[..axes].iter().map(|n| n / 4).collect();
        let q = solve_at(req, quarter)?;
        extra_seconds += q.seconds;
        let qres = q.problem.grid.res;
        let f_q = restrict(&sol.l00(), g.res, qres)?;
        let c_q = restrict(&u_coarse, cg.res, qres)?;
        let u_q = q.sol.l00();
        // The order from absolute norms (relative ones would be normalised by different
        // levels); the reported difference is relative to the finer level, like d12.
        let (a, b) = (l2_diff(&c_q, &u_q), l2_diff(&f_q, &c_q));
        level_differences.push(rel_l2_diff(&u_q, &c_q));
        observed = observed_order([4.0, 2.0, 1.0], a, b);
    }
    let (p, source) = match observed {
        Some(p) if p > 0.5 && p < 4.0 => (p, "observed (three levels: n, n/2, n/4)".to_string()),
        Some(p) => (
            2.0,
            format!("assumed 2 (the observed order {p:.2} from n, n/2, n/4 is implausible)"),
        ),
        None if level_differences.len() > 1 => (
            2.0,
            "assumed 2 (not measurable from n, n/2, n/4: differences do not decrease)".into(),
        ),
        None => (
            2.0,
            "assumed 2 (the design order; the resolution is not divisible by 4, so no \
             third level)"
                .into(),
        ),
    };
    let est = richardson(&u_fine, &u_coarse, 2.0, p, &source);
    let report = ErrorEstimate {
        quantity: "L_0^0 (fluence.npy) of the fine solution, on the half-resolution grid".into(),
        coarse_resolution: cg.res,
        estimate: est,
        observed_order: observed,
        level_differences,
        extra_seconds,
        extra_cost_fraction: if fine_seconds > 0.0 {
            extra_seconds / fine_seconds
        } else {
            0.0
        },
    };
    Ok(Estimate {
        report,
        grid: cg,
        title: format!("{} |error| estimate, p = {p:.2}", req.scene),
    })
}

/// `error.npy` (signed estimate per coarse cell) and `error.png` (|estimate|, log scale;
/// 3D: the middle z slice).
fn write_error_files(out: &Path, grid: &Grid, per_cell: &[f64], title: &str) -> Result<()> {
    pn_formats::write_npy(&out.join("error.npy"), &cell_shape(grid), per_cell)?;
    let [nx, ny, nz] = grid.res;
    let k = nz / 2;
    let vals: Vec<f64> = (0..nx)
        .flat_map(|i| (0..ny).map(move |j| (i, j)))
        .map(|(i, j)| per_cell[(i * ny + j) * nz + k].abs())
        .collect();
    write_png(
        &out.join("error.png"),
        &Slice {
            nx,
            ny,
            values: &vals,
            min: [grid.min[0], grid.min[1]],
            max: [grid.max[0], grid.max[1]],
            title: title.into(),
        },
    )
}
