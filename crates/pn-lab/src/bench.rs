//! `pn bench`: a fixed suite of problems solved in one process, so that every speed-up is a
//! ratio measured side by side. Writes `bench.csv` and `bench.md`.
//!
//! Errors are measured against references nobody on the team wrote:
//! * checkerboard: StaRMAP's steady states (`max|ours − ref| / max(ref)`, P_1 and P_5);
//! * point source: the semi-analytic P_N solution (P_N rows), the CDA Green's function
//!   (CDA) and Grosjean's transport approximation (FLD), as the largest relative deviation of
//!   the normalised fluence 4πφ/σ_t² at the cells nearest τ = 1, 2, 4 along +x.

use crate::bench_rows::{
    fld_point_source, grid_label, max_rel_diff, peak_memory, pointsource_options, profile_error,
    reset_peak_memory, row_from, Row, CSV_HEADER,
};
use anyhow::Context;
use pn_drivers::fld_setup::{solve_fld_route, FldSettings};
use pn_drivers::scene_setup::Route;
use pn_formats::Table;
use pn_kernels::{cda_kernel, diffusion_kernel, pn_kernel, Dim, Staggering};
use pn_runtime::fld::{FldParams, Limiter};
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::reference::{cda_point_source, grosjean, pn_point_source};
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::{SolverKind, SolverOptions, SolverTuning};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

/// The options of `pn bench`.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchRequest {
    /// A subset that runs in about a minute (checkerboard P_1/P_3, point source at 40³).
    pub quick: bool,
    /// Output directory for `bench.csv` and `bench.md`.
    pub out: PathBuf,
    /// Folder with the reference data (`checkerboard/starmap_p{1,5}_n71.csv`).
    pub reference: PathBuf,
    /// Point-source resolution (default 80, the paper's; 40 with `quick`).
    pub pointsource_res: Option<usize>,
    /// Skip the baseline CGNR runs on problems with more unknowns than this.
    pub cgnr_max_unknowns: usize,
    /// Expert solver settings (the `pn` binary reads them from the environment).
    pub tuning: SolverTuning,
}

impl Default for BenchRequest {
    /// The full suite into `out/bench`, references from `tests/data`, CGNR up to 3 000 000
    /// unknowns.
    fn default() -> Self {
        Self {
            quick: false,
            out: PathBuf::from("out/bench"),
            reference: PathBuf::from("tests/data"),
            pointsource_res: None,
            cgnr_max_unknowns: 3_000_000,
            tuning: SolverTuning::default(),
        }
    }
}

/// `max|a − b| / max|b|`.
fn run_pipeline(
    tuning: &SolverTuning,
    scene_name: &str,
    opts: &BuiltinOptions,
    method: &str,
    order: usize,
    solver: SolverKind,
    tol: f64,
) -> anyhow::Result<(Solution, String)> {
    let scene = builtin(scene_name, opts)?;
    let dim = scene.problem.grid.dim;
    let choice = if method == "cda" {
        cda_kernel(dim)?
    } else {
        pn_kernel(order, dim, Staggering::Staggered)?
    };
    pn_drivers::progress::print_notes(choice.note.as_slice());
    let sopts = SolverOptions {
        tol,
        tuning: tuning.clone(),
        ..Default::default()
    };
    let sol = solve_problem(&scene.problem, choice.kernel.as_ref(), solver, &sopts)?;
    pn_drivers::progress::print_notes(&sol.stats.notes);
    Ok((sol, grid_label(&scene.problem.grid)))
}

/// The least-squares solvers and the matrix-free baseline, run next to cgnr and parity-cg
/// (and skipped with cgnr on problems above `--cgnr-max-unknowns`).
const LS_SOLVERS: [SolverKind; 3] = [SolverKind::Lsqr, SolverKind::Lsmr, SolverKind::CgnrMf];

fn checkerboard_rows(args: &BenchRequest, rows: &mut Vec<Row>) -> anyhow::Result<()> {
    let orders: &[usize] = if args.quick { &[1, 3] } else { &[1, 3, 5] };
    let opts = BuiltinOptions::default();
    for &order in orders {
        let reference = match order {
            1 | 5 => Some(pn_runtime::reference::starmap::read_csv(
                &args
                    .reference
                    .join(format!("checkerboard/starmap_p{order}_n71.csv")),
            )?),
            _ => None,
        };
        let start = rows.len();
        for solver in [
            SolverKind::Cgnr,
            SolverKind::ParityIlu,
            SolverKind::ParityMg,
        ]
        .into_iter()
        .chain(LS_SOLVERS)
        {
            reset_peak_memory();
            let (sol, res) = run_pipeline(
                &args.tuning,
                "checkerboard",
                &opts,
                "pn",
                order,
                solver,
                1e-10,
            )?;
            let err = reference.as_ref().and_then(|r| max_rel_diff(&sol.l00(), r));
            let row = row_from(
                "checkerboard",
                "pn",
                order,
                res,
                &sol,
                err,
                if err.is_some() { "starmap" } else { "none" },
            );
            eprintln!("bench: {}", row.csv());
            rows.push(row);
        }
        roofline(&mut rows[start..], "checkerboard", &opts, order)?;
    }
    Ok(())
}

/// The roofline entries of the P_N `rows` of one problem and order (`bench_roofline`):
/// the operators rebuilt and timed after the solves.
fn roofline(
    rows: &mut [Row],
    scene_name: &str,
    opts: &BuiltinOptions,
    order: usize,
) -> anyhow::Result<()> {
    let scene = builtin(scene_name, opts)?;
    let k = pn_kernel(order, scene.problem.grid.dim, Staggering::Staggered)?;
    pn_drivers::progress::print_notes(k.note.as_slice());
    crate::bench_roofline::attach(rows, &scene.problem, k.kernel.as_ref())?;
    for r in rows.iter().filter(|r| r.roofline.is_some()) {
        eprintln!("bench: roofline {}", r.csv());
    }
    Ok(())
}

fn pointsource_rows(args: &BenchRequest, rows: &mut Vec<Row>) -> anyhow::Result<()> {
    let n = args
        .pointsource_res
        .unwrap_or(if args.quick { 40 } else { 80 });
    anyhow::ensure!(n >= 8, "--pointsource-res must be at least 8");
    let (params, opts) = pointsource_options(n);
    let h = 2.0 * params.half_width / n as f64;
    let tau_per_cell = params.sigma_t * h;
    let c = n / 2;
    let max_k = n - 1 - c;
    let norm = 4.0 * std::f64::consts::PI / (params.sigma_t * params.sigma_t);
    // L_0^0 of the cell source (power √(4π)) is the unit-power Green's function: the
    // normalised fluence is 4π L_0^0 / σ_t² (reference/pointsource/README.md).
    let along_x = |l00: &[f64], k: usize| l00[((c + k) * n + c) * n + c] * norm;
    let orders: &[usize] = if args.quick { &[1, 3] } else { &[1, 3, 5] };
    for &order in orders {
        let modes = pn_point_source(order, params.albedo, params.g)?;
        let start = rows.len();
        for solver in [
            SolverKind::Cgnr,
            SolverKind::ParityIlu,
            SolverKind::ParityMg,
        ]
        .into_iter()
        .chain(LS_SOLVERS)
        {
            let unknowns_estimate = (order + 1) * (order + 1) * (n + 1).pow(3);
            let baseline_like = solver == SolverKind::Cgnr || LS_SOLVERS.contains(&solver);
            if baseline_like && unknowns_estimate > args.cgnr_max_unknowns {
                eprintln!("bench: skipping {} on pointsource P_{order} {n}³ (~{unknowns_estimate} unknowns > --cgnr-max-unknowns)", solver.name());
                continue;
            }
            reset_peak_memory();
            let (sol, res) = run_pipeline(
                &args.tuning,
                "pointsource",
                &opts,
                "pn",
                order,
                solver,
                1e-6,
            )?;
            let l00 = sol.l00();
            let err = profile_error(
                tau_per_cell,
                max_k,
                |k| along_x(&l00, k),
                |t| modes.fluence(t),
            );
            let row = row_from("pointsource", "pn", order, res, &sol, err, "pn_exact");
            eprintln!("bench: {}", row.csv());
            rows.push(row);
        }
        roofline(&mut rows[start..], "pointsource", &opts, order)?;
    }
    // The half-resolution P_5 point source with the default solver (issue 19 sets a target
    // for 40³ next to the 80³ one), so that one run shows both.
    if !args.quick && n > 40 {
        let m = n / 2;
        let (_, half_opts) = pointsource_options(m);
        let (h, cm) = (2.0 * params.half_width / m as f64, m / 2);
        let modes = pn_point_source(5, params.albedo, params.g)?;
        reset_peak_memory();
        let (sol, res) = run_pipeline(
            &args.tuning,
            "pointsource",
            &half_opts,
            "pn",
            5,
            SolverKind::ParityMg,
            1e-6,
        )?;
        let l00 = sol.l00();
        let err = profile_error(
            params.sigma_t * h,
            m - 1 - cm,
            |k| l00[((cm + k) * m + cm) * m + cm] * norm,
            |t| modes.fluence(t),
        );
        let row = row_from("pointsource", "pn", 5, res, &sol, err, "pn_exact");
        eprintln!("bench: {}", row.csv());
        rows.push(row);
    }
    // CDA through the same pipeline (input PDE): the cgnr baseline and multigrid-CG
    // (`parity-mg` solves this scalar system with MG-preconditioned CG on A itself).
    for solver in [SolverKind::Cgnr, SolverKind::ParityMg] {
        if solver == SolverKind::Cgnr && (n + 1).pow(3) > args.cgnr_max_unknowns * 4 {
            continue;
        }
        reset_peak_memory();
        let (sol, res) = run_pipeline(&args.tuning, "pointsource", &opts, "cda", 0, solver, 1e-6)?;
        let l00 = sol.l00();
        let err = profile_error(
            tau_per_cell,
            max_k,
            |k| along_x(&l00, k),
            |t| cda_point_source(t, params.albedo, params.g),
        );
        let row = row_from("pointsource", "cda", 0, res, &sol, err, "cda_exact");
        eprintln!("bench: {}", row.csv());
        rows.push(row);
    }
    fld_rows(args, n, rows)
}

/// FLD on the point source's cells, by both routes (nonlinear Gauss–Seidel, and Picard
/// steps on multigrid CG with Anderson acceleration); φ is the fluence of a unit-power source.
fn fld_rows(args: &BenchRequest, n: usize, rows: &mut Vec<Row>) -> anyhow::Result<()> {
    let (params, _) = pointsource_options(n);
    let h = 2.0 * params.half_width / n as f64;
    let tau_per_cell = params.sigma_t * h;
    let c = n / 2;
    let max_k = n - 1 - c;
    let norm = 4.0 * std::f64::consts::PI / (params.sigma_t * params.sigma_t);
    let problem = fld_point_source(n, &params)?;
    let cells = problem.grid.len();
    let fparams = FldParams::for_grid(Limiter::LevermorePomraning, &problem.grid);
    let dk = diffusion_kernel(Dim::Three)?;
    for route in [Route::GaussSeidel, Route::Picard] {
        reset_peak_memory();
        let t0 = Instant::now();
        let settings = FldSettings {
            params: fparams,
            route,
            linear_solver: SolverKind::ParityCg,
            tuning: args.tuning.clone(),
        };
        let run = solve_fld_route(&problem, &settings, &dk, None)?;
        pn_drivers::progress::print_notes(&run.notes);
        let fsol = run.solution;
        let seconds = t0.elapsed().as_secs_f64();
        let phi = &fsol.phi;
        let err = profile_error(
            tau_per_cell,
            max_k,
            |k| phi[problem.grid.index(c + k, c, c)] * norm,
            |t| grosjean(t, params.albedo),
        );
        let row = Row {
            problem: "pointsource".into(),
            method: "fld-lp".into(),
            solver: match run.linear_solver {
                Some(linear) => format!("picard({linear})"),
                None => "gauss-seidel".into(),
            },
            order: 0,
            resolution: format!("{n}x{n}x{n}"),
            unknowns: cells,
            iterations: fsol.iterations,
            seconds_assemble: 0.0,
            seconds_solve: seconds,
            peak_memory_bytes: peak_memory(),
            error: err,
            reference: "grosjean",
            converged: fsol.converged,
            operator_applications: 0,
            roofline: None,
        };
        eprintln!("bench: {}", row.csv());
        rows.push(row);
    }
    Ok(())
}

/// Markdown table plus the side-by-side speed-ups of parity-cg over cgnr.
fn markdown(rows: &[Row], quick: bool) -> anyhow::Result<String> {
    let mut md = String::new();
    let _ = writeln!(md, "# pn bench{}\n", if quick { " --quick" } else { "" });
    let mut t = Table::new(&[
        "problem",
        "method",
        "solver",
        "N",
        "resolution",
        "unknowns",
        "iterations",
        "assemble s",
        "solve s",
        "peak MB",
        "error",
        "vs",
    ]);
    for r in rows {
        t.push_row([
            r.problem.clone(),
            r.method.clone(),
            r.solver.clone(),
            r.order.to_string(),
            r.resolution.clone(),
            r.unknowns.to_string(),
            format!(
                "{}{}",
                r.iterations,
                if r.converged { "" } else { " (not converged)" }
            ),
            format!("{:.3}", r.seconds_assemble),
            format!("{:.3}", r.seconds_solve),
            format!("{:.0}", r.peak_memory_bytes as f64 / 1e6),
            r.error.map_or("–".into(), |e| format!("{e:.2e}")),
            r.reference.to_string(),
        ])?;
    }
    md += &t.to_markdown();
    let _ = writeln!(md, "\n## parity-cg vs cgnr (same process)\n");
    let mut t = Table::new(&[
        "problem",
        "N",
        "resolution",
        "cgnr s",
        "parity-cg s",
        "time ratio",
    ]);
    for a in rows
        .iter()
        .filter(|r| r.solver == "cgnr" && r.method == "pn")
    {
        if let Some(b) = same_problem(rows, a, "parity-cg") {
            t.push_row([
                a.problem.clone(),
                a.order.to_string(),
                a.resolution.clone(),
                format!("{:.3}", a.seconds_solve),
                format!("{:.3}", b.seconds_solve),
                format!("{:.1}×", a.seconds_solve / b.seconds_solve.max(1e-9)),
            ])?;
        }
    }
    md += &t.to_markdown();
    Ok(md)
}

/// The row of `solver` on the same problem, method, order and resolution as `like`.
fn same_problem<'a>(rows: &'a [Row], like: &Row, solver: &str) -> Option<&'a Row> {
    rows.iter().find(|b| {
        b.solver == solver
            && b.method == like.method
            && b.problem == like.problem
            && b.order == like.order
            && b.resolution == like.resolution
    })
}

/// Work in products with `A` (the target is ≥ 20× fewer for parity-cg than for cgnr to the same
/// tolerance): cgnr counts A and Aᵀ, the parity solvers every application of the reduced
/// operator (multigrid cycle and setup included), which touches A's off-diagonal entries once.
fn work_comparison(rows: &[Row]) -> anyhow::Result<String> {
    let mut md =
        String::from("\n## Work: products with A to the same tolerance (same process)\n\n");
    md.push_str(
        "cgnr: every product with A and Aᵀ; parity: every application of S = D_e − B D_o⁻¹ C \
                 (Krylov, multigrid smoothing and residuals on the finest level, setup, probes) \
                 plus the final residual checks. ILU(0)'s triangular solves are not counted.\n\n",
    );
    let mut t = Table::new(&[
        "problem",
        "N",
        "resolution",
        "cgnr",
        "parity-cg (ILU/Jacobi)",
        "parity-mg",
        "cgnr / parity-cg",
        "cgnr / parity-mg",
    ]);
    for c in rows
        .iter()
        .filter(|r| r.solver == "cgnr" && r.method == "pn")
    {
        let find = |solver: &str| same_problem(rows, c, solver);
        let apps =
            |r: Option<&Row>| r.map_or("–".to_string(), |r| r.operator_applications.to_string());
        let ratio = |r: Option<&Row>| {
            r.map_or("–".to_string(), |r| {
                format!(
                    "{:.1}×",
                    c.operator_applications as f64 / r.operator_applications.max(1) as f64
                )
            })
        };
        let (p, m) = (find("parity-cg"), find("parity-mg"));
        t.push_row([
            c.problem.clone(),
            c.order.to_string(),
            c.resolution.clone(),
            c.operator_applications.to_string(),
            apps(p),
            apps(m),
            ratio(p),
            ratio(m),
        ])?;
    }
    md += &t.to_markdown();
    Ok(md)
}

/// parity-mg (multigrid-preconditioned) against parity-cg (ILU(0)/Jacobi) and cgnr on the
/// same problems, same process: iterations and assembly + solve seconds.
fn mg_comparison(rows: &[Row]) -> anyhow::Result<String> {
    let mut md = String::from("\n## parity-mg vs parity-cg and cgnr (same process)\n\n");
    // Iterations and seconds of parity-cg and of cgnr share a cell each, as `it|s`: two
    // Markdown columns.
    let mut t = Table::new(&[
        "problem",
        "N",
        "resolution",
        "mg it",
        "mg s",
        "parity-cg it | parity-cg s",
        "cgnr it | cgnr s",
        "mg speed-up vs parity-cg",
        "vs cgnr",
    ]);
    let total = |r: &Row| r.seconds_assemble + r.seconds_solve;
    for m in rows
        .iter()
        .filter(|r| r.solver == "parity-mg" && r.method == "pn")
    {
        let find = |solver: &str| same_problem(rows, m, solver);
        let cell = |r: Option<&Row>| {
            r.map_or("–|–".to_string(), |r| {
                format!("{}|{:.3}", r.iterations, total(r))
            })
        };
        let ratio = |r: Option<&Row>| {
            r.map_or("–".to_string(), |r| {
                format!("{:.1}×", total(r) / total(m).max(1e-9))
            })
        };
        let (p, c) = (find("parity-cg"), find("cgnr"));
        if p.is_none() && c.is_none() {
            continue;
        }
        t.push_row([
            m.problem.clone(),
            m.order.to_string(),
            m.resolution.clone(),
            m.iterations.to_string(),
            format!("{:.3}", total(m)),
            cell(p),
            cell(c),
            ratio(p),
            ratio(c),
        ])?;
    }
    md += &t.to_markdown();
    Ok(md)
}

/// Side-by-side tables of the iterative solvers (same process): iterations and seconds of
/// lsqr, lsmr and cgnr against parity-cg, and matrix-free (`cgnr-mf`) against assembled
/// (`cgnr`) CGNR in solve time, setup time and peak memory.
fn solver_comparison(rows: &[Row]) -> anyhow::Result<String> {
    let mut md = String::new();
    let find = |a: &Row, solver: &str| same_problem(rows, a, solver);
    let _ = writeln!(
        md,
        "\n## Solvers: iterations and solve seconds (same process)\n"
    );
    let mut t = Table::new(&[
        "problem",
        "N",
        "resolution",
        "parity-cg",
        "cgnr",
        "cgnr-mf",
        "lsqr",
        "lsmr",
    ]);
    let cell = |r: Option<&Row>| {
        r.map_or("–".to_string(), |r| {
            format!(
                "{} it, {:.3} s{}",
                r.iterations,
                r.seconds_solve,
                if r.converged { "" } else { " (nc)" }
            )
        })
    };
    for a in rows
        .iter()
        .filter(|r| r.solver == "parity-cg" && r.method == "pn" && find(r, "cgnr").is_some())
    {
        t.push_row([
            a.problem.clone(),
            a.order.to_string(),
            a.resolution.clone(),
            cell(Some(a)),
            cell(find(a, "cgnr")),
            cell(find(a, "cgnr-mf")),
            cell(find(a, "lsqr")),
            cell(find(a, "lsmr")),
        ])?;
    }
    md += &t.to_markdown();
    let _ = writeln!(md, "\n## Matrix-free vs assembled CGNR (same process)\n");
    let _ = writeln!(
        md,
        "Setup is assembly (CSR) or the weight tables (matrix-free); peak memory is the \
         process's VmHWM, reset before each problem.\n"
    );
    let mut t = Table::new(&[
        "problem",
        "N",
        "resolution",
        "setup s (asm / mf)",
        "solve s (asm / mf)",
        "solve ratio mf/asm",
        "peak MB (asm / mf)",
        "memory ratio asm/mf",
    ]);
    for a in rows
        .iter()
        .filter(|r| r.solver == "cgnr" && r.method == "pn")
    {
        if let Some(b) = find(a, "cgnr-mf") {
            t.push_row([
                a.problem.clone(),
                a.order.to_string(),
                a.resolution.clone(),
                format!("{:.3} / {:.3}", a.seconds_assemble, b.seconds_assemble),
                format!("{:.3} / {:.3}", a.seconds_solve, b.seconds_solve),
                format!("{:.2}", b.seconds_solve / a.seconds_solve.max(1e-9)),
                format!(
                    "{:.0} / {:.0}",
                    a.peak_memory_bytes as f64 / 1e6,
                    b.peak_memory_bytes as f64 / 1e6
                ),
                format!(
                    "{:.2}",
                    a.peak_memory_bytes as f64 / (b.peak_memory_bytes as f64).max(1.0)
                ),
            ])?;
        }
    }
    md += &t.to_markdown();
    Ok(md)
}

/// The roofline section: for each P_N row with an operator model, the modelled bytes of one
/// application, the median time of one (timed on its own after the solves), the achieved
/// bandwidth and the ratio to the limit set by the measured triad bandwidth.
fn roofline_section(rows: &[Row], bw: &pn_runtime::bandwidth::Bandwidth) -> anyhow::Result<String> {
    let mut md =
        String::from("\n## Roofline: operator applications against the memory bandwidth\n\n");
    let _ = writeln!(
        md,
        "Memory bandwidth, measured once at the start of this run (STREAM-like, \
         `pn_runtime::bandwidth`): {}. The limit below uses the all-thread triad, \
         **{:.2} GB/s**.\n",
        bw.describe(),
        bw.triad_gbs
    );
    md.push_str(
        "Operators: `s-stencil` is S = D_e − B C̃ applied from the blocks' per-moment stencils \
         (parity-mg; `solver::parity::stencil_s`: the vectors, the diagonals and the boundary \
         corrections, no per-entry traffic), `s-matfree` the same from the stored blocks \
         (parity-cg with Jacobi), `s-formed` the CSR S of parity-cg with ILU(0), `a-csr` one \
         product with A or Aᵀ in compact CSR (cgnr, lsqr, lsmr), `a-matfree` the matrix-free A \
         of cgnr-mf (compulsory traffic only, a lower bound). Bytes are modelled (values, \
         column indices and row pointers of every block, each vector read or written once, \
         the temporary of S), the time is the median of at least 10 applications timed \
         after the solves; ratio = time / (bytes / bandwidth): 1 at the limit, ≤ 2 within \
         2× of it, below 1 where the operator fits in cache. bytes/(unknown·it) is the \
         operator's traffic per unknown and iteration (applications × bytes / (unknowns × \
         iterations)).\n\n",
    );
    let mut t = Table::new(&[
        "problem",
        "N",
        "resolution",
        "solver",
        "operator",
        "MB / application",
        "bytes / (unknown·it)",
        "ms / application",
        "GB/s",
        "ratio to limit",
    ]);
    for r in rows {
        let Some(rf) = &r.roofline else { continue };
        t.push_row([
            r.problem.clone(),
            r.order.to_string(),
            r.resolution.clone(),
            r.solver.clone(),
            rf.operator.to_string(),
            format!("{:.2}", rf.bytes_per_application as f64 / 1e6),
            format!("{:.0}", r.bytes_per_unknown_iteration().unwrap_or(f64::NAN)),
            format!("{:.3}", rf.seconds_per_application * 1e3),
            format!("{:.2}", rf.achieved_gbs()),
            format!("{:.2}", rf.ratio(bw.triad_gbs)),
        ])?;
    }
    md += &t.to_markdown();
    Ok(md)
}

/// The largest `--pointsource-res`: 256³ cells at P_5 is about 600 M unknowns, beyond any
/// machine this suite is meant for (80, the paper's, is the default).
const MAX_POINTSOURCE_RES: usize = 256;

/// Everything `pn bench` can refuse, refused before the first measurement (issue 53): the
/// point-source resolution and the StaRMAP reference files the error columns need.
fn check_request(args: &BenchRequest) -> anyhow::Result<()> {
    if let Some(n) = args.pointsource_res {
        anyhow::ensure!(
            (8..=MAX_POINTSOURCE_RES).contains(&n),
            "--pointsource-res must be in 8..={MAX_POINTSOURCE_RES}, got {n}"
        );
    }
    for order in [1, 5] {
        let file = args
            .reference
            .join(format!("checkerboard/starmap_p{order}_n71.csv"));
        anyhow::ensure!(
            file.is_file(),
            "the reference data {} is missing (pass the folder holding \
             checkerboard/starmap_p1_n71.csv with --reference; the repository's is tests/data)",
            file.display()
        );
    }
    Ok(())
}

/// Runs `pn bench`: writes `bench.csv` and `bench.md` and prints the Markdown to `stdout`.
pub fn run(args: &BenchRequest, stdout: &mut dyn std::io::Write) -> anyhow::Result<()> {
    check_request(args)?;
    // Once per run, before the solves, while the memory is free.
    let bandwidth = pn_runtime::bandwidth::measure_default();
    eprintln!("bench: memory bandwidth {}", bandwidth.describe());
    let mut rows = Vec::new();
    checkerboard_rows(args, &mut rows)?;
    pointsource_rows(args, &mut rows)?;
    let n = args
        .pointsource_res
        .unwrap_or(if args.quick { 40 } else { 80 });
    crate::bench_pde::pde_rows(args.quick, &args.reference, n, &args.tuning, &mut rows)?;
    let model_md = crate::bench_model::model_rows(args.quick, &args.tuning, &mut rows)?;
    // Compiled against interpreted stencils: P_1/P_3/P_5 both ways, P_7 interpreted only
    // (its row shows the interpreter's cost per term beyond the compiled set).
    let kernel_res = if args.quick { 16 } else { 32 };
    let kernels = crate::bench_kernels::kernel_rows(&[1, 3, 5, 7], kernel_res)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut csv = Table::new(&CSV_HEADER.split(',').collect::<Vec<_>>());
    for r in &rows {
        csv.push_row(r.cells(Some(bandwidth.triad_gbs)))?;
    }
    csv.write_csv(&args.out.join("bench.csv"))?;
    crate::bench_kernels::table(&kernels)?.write_csv(&args.out.join("kernels.csv"))?;
    let mut md = markdown(&rows, args.quick)?;
    md.push_str(&solver_comparison(&rows)?);
    md.push_str(&mg_comparison(&rows)?);
    md.push_str(&work_comparison(&rows)?);
    md.push_str(&roofline_section(&rows, &bandwidth)?);
    md.push_str(&model_md);
    md.push_str(&crate::bench_kernels::markdown(&kernels)?);
    std::fs::write(args.out.join("bench.md"), &md)?;
    writeln!(stdout, "{md}")?;
    eprintln!(
        "wrote {}/bench.csv, kernels.csv and bench.md",
        args.out.display()
    );
    Ok(())
}
