//! `pn tradeoff`: error against time on the point source for method × resolution ×
//! tolerance (docs/tradeoff.md), as `tradeoff.csv` and `tradeoff.png` (log–log, one curve per
//! method). This is the table a user reads to choose N.
//!
//! Methods: CDA (through the P_N pipeline with parity-cg), FLD with the Levermore–Pomraning
//! limiter (nonlinear Gauss–Seidel), and P_1, P_3, P_5 (parity-cg). Seconds are setup plus
//! solve, measured one after the other in this process.
//!
//! Two error columns, both the largest relative deviation of the normalised fluence
//! 4πφ/σ_t² at the cells nearest τ = 1, 2, 4 along +x from the source (as in `pn bench`):
//! * `error_own`: against the method's own continuous solution — the semi-analytic P_N
//!   point source for P_N rows, the CDA Green's function for CDA; empty for FLD, which has
//!   no closed form. It measures the discretisation and solver error alone.
//! * `error_transport`: against Grosjean's transport approximation for every method, so that
//!   methods are compared with each other on one scale (it includes each model's error).

use crate::bench_rows::{fld_point_source, profile_error};
use anyhow::Context;
use plotters::prelude::*;
use pn_formats::plot::{draw_error, finish_chart, framed_chart, white_canvas};
use pn_formats::Table;
use pn_kernels::{cda_kernel, pn_kernel, Dim, Staggering};
use pn_runtime::fld::{solve_fld, FldParams, Limiter};
use pn_runtime::pipeline::solve_problem;
use pn_runtime::reference::{cda_point_source, grosjean, pn_point_source};
use pn_runtime::scenes::{builtin, BuiltinOptions, PointSourceParams};
use pn_runtime::solver::{SolverKind, SolverOptions, SolverTuning};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The options of `pn tradeoff`.
#[derive(Clone, Debug, PartialEq)]
pub struct TradeoffRequest {
    /// A small subset for a smoke test (resolutions 12 and 16; about a minute).
    pub quick: bool,
    /// Output directory for `tradeoff.csv` and `tradeoff.png`.
    pub out: PathBuf,
    /// Resolutions (cells per axis; default 20, 30, 40, 60; 12, 16 with `quick`).
    pub res: Option<Vec<usize>>,
    /// Relative-residual tolerances (default 1e-4, 1e-6).
    pub tol: Option<Vec<f64>>,
    /// Expert solver settings (the `pn` binary reads them from the environment).
    pub tuning: SolverTuning,
}

impl Default for TradeoffRequest {
    /// The full study into `out/tradeoff`.
    fn default() -> Self {
        Self {
            quick: false,
            out: PathBuf::from("out/tradeoff"),
            res: None,
            tol: None,
            tuning: SolverTuning::default(),
        }
    }
}

/// The CSV header (see the module documentation for the two error columns).
pub const CSV_HEADER: &str = "method,order,resolution,tolerance,unknowns,iterations,seconds_setup,seconds_solve,seconds,error_own,own_reference,error_transport,converged";

/// One measured point.
struct Point {
    method: &'static str,
    order: usize,
    res: usize,
    tol: f64,
    unknowns: usize,
    iterations: usize,
    seconds_setup: f64,
    seconds_solve: f64,
    error_own: Option<f64>,
    own_reference: &'static str,
    error_transport: Option<f64>,
    converged: bool,
}

impl Point {
    fn seconds(&self) -> f64 {
        self.seconds_setup + self.seconds_solve
    }

    fn csv(&self) -> String {
        self.cells().join(",")
    }

    /// The cells of [`Point::csv`], one per column of [`CSV_HEADER`].
    fn cells(&self) -> Vec<String> {
        let e = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.4e}"));
        vec![
            self.method.to_string(),
            self.order.to_string(),
            self.res.to_string(),
            format!("{:e}", self.tol),
            self.unknowns.to_string(),
            self.iterations.to_string(),
            format!("{:.6}", self.seconds_setup),
            format!("{:.6}", self.seconds_solve),
            format!("{:.6}", self.seconds()),
            e(self.error_own),
            self.own_reference.to_string(),
            e(self.error_transport),
            self.converged.to_string(),
        ]
    }
}

/// The methods, in plot order: (label, P_N order or 0).
const METHODS: [(&str, usize); 5] = [("cda", 0), ("fld", 0), ("P1", 1), ("P3", 3), ("P5", 5)];

/// Solves the point source with `method` at `n³` cells to `tol`.
fn measure(
    method: &'static str,
    order: usize,
    n: usize,
    tol: f64,
    tuning: &SolverTuning,
) -> anyhow::Result<Point> {
    let params = PointSourceParams::default();
    let h = 2.0 * params.half_width / n as f64;
    let tau_per_cell = params.sigma_t * h;
    let c = n / 2;
    let max_k = n - 1 - c;
    // L_0^0 of the cell source is the unit-power Green's function; the normalised fluence
    // is 4π L_0^0/σ_t² (and 4πφ/σ_t² for FLD's φ), as in `pn bench`.
    let norm = 4.0 * std::f64::consts::PI / (params.sigma_t * params.sigma_t);
    let transport = |t: f64| grosjean(t, params.albedo);
    if method == "fld" {
        let problem = fld_point_source(n, &params)?;
        let mut fp = FldParams::for_grid(Limiter::LevermorePomraning, &problem.grid);
        fp.tol = tol;
        let t0 = Instant::now();
        let sol = solve_fld(&problem, &fp)?;
        let seconds = t0.elapsed().as_secs_f64();
        let at = |k: usize| sol.phi[problem.grid.index(c + k, c, c)] * norm;
        return Ok(Point {
            method,
            order,
            res: n,
            tol,
            unknowns: problem.grid.len(),
            iterations: sol.iterations,
            seconds_setup: 0.0,
            seconds_solve: seconds,
            error_own: None,
            own_reference: "none",
            error_transport: profile_error(tau_per_cell, max_k, at, transport),
            converged: sol.converged,
        });
    }
    let scene = builtin(
        "pointsource",
        &BuiltinOptions {
            dim: Some(Dim::Three),
            res: Some(vec![n]),
            pointsource: params,
            ..Default::default()
        },
    )?;
    let kernel = if method == "cda" {
        cda_kernel(Dim::Three)?
    } else {
        pn_kernel(order, Dim::Three, Staggering::Staggered)?
    };
    pn_drivers::progress::print_notes(kernel.note.as_slice());
    let opts = SolverOptions {
        tol,
        tuning: tuning.clone(),
        ..Default::default()
    };
    let sol = solve_problem(
        &scene.problem,
        kernel.kernel.as_ref(),
        SolverKind::ParityCg,
        &opts,
    )?;
    pn_drivers::progress::print_notes(&sol.stats.notes);
    let l00 = sol.l00();
    let at = |k: usize| l00[((c + k) * n + c) * n + c] * norm;
    let (error_own, own_reference) = if method == "cda" {
        (
            profile_error(tau_per_cell, max_k, at, |t| {
                cda_point_source(t, params.albedo, params.g)
            }),
            "cda_exact",
        )
    } else {
        let modes = pn_point_source(order, params.albedo, params.g)?;
        (
            profile_error(tau_per_cell, max_k, at, |t| modes.fluence(t)),
            "pn_exact",
        )
    };
    Ok(Point {
        method,
        order,
        res: n,
        tol,
        unknowns: sol.unknowns,
        iterations: sol.stats.iterations,
        seconds_setup: sol.seconds_assembly,
        seconds_solve: sol.seconds_solve,
        error_own,
        own_reference,
        error_transport: profile_error(tau_per_cell, max_k, at, transport),
        converged: sol.stats.converged(),
    })
}

/// Colour of method `i` in the plot.
fn colour(i: usize) -> RGBColor {
    [
        RGBColor(120, 120, 120),
        RGBColor(0, 150, 70),
        RGBColor(30, 90, 220),
        RGBColor(220, 120, 0),
        RGBColor(200, 30, 30),
    ][i % 5]
}

/// `(log10 seconds, log10 error vs transport)` of a point.
fn log_xy(p: &Point) -> (f64, f64) {
    (
        p.seconds().max(1e-4).log10(),
        p.error_transport.unwrap_or(f64::NAN).log10(),
    )
}

/// `tradeoff.png`: error against the transport reference vs seconds, log–log. Per method a
/// line through the points of the tightest tolerance (in order of resolution) and markers
/// for every point (filled: tightest tolerance; hollow: the others).
fn write_png(path: &Path, points: &[Point], tols: &[f64]) -> anyhow::Result<()> {
    crate::plot::fonts()?;
    let data: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|p| p.error_transport.map(|e| (p.seconds().max(1e-4), e)))
        .filter(|(_, e)| e.is_finite() && *e > 0.0)
        .collect();
    anyhow::ensure!(!data.is_empty(), "{}: nothing to plot", path.display());
    let (x0, x1) = data.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (y0, y1) = data.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let tight = tols.iter().copied().fold(f64::INFINITY, f64::min);
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let root = white_canvas(path, (1000, 700))?;
    // Log–log through log10 coordinates (plotters' log axes label only whole decades, and
    // the errors often span less than one).
    let (x0, x1) = ((x0 / 1.5).log10(), (x1 * 1.5).log10());
    let (y0, y1) = ((y0 / 1.3).log10(), (y1 * 1.3).log10());
    let title = format!(
        "Point source: error (vs Grosjean) against time; lines and filled: tol {tight:e}, hollow: looser"
    );
    let mut chart = framed_chart(&root, &title, 20)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("seconds (setup + solve)")
        .y_desc("max. relative error of the fluence at τ = 1, 2, 4")
        .axis_desc_style(("sans-serif", 20))
        .label_style(("sans-serif", 16))
        .x_labels(8)
        .y_labels(8)
        .x_label_formatter(&|v| format!("{:.3}", 10f64.powf(*v)))
        .y_label_formatter(&|v| format!("{:.2e}", 10f64.powf(*v)))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, (label, _)) in METHODS.iter().enumerate() {
        let col = colour(i);
        let mine: Vec<&Point> = points
            .iter()
            .filter(|p| p.method == *label && p.error_transport.is_some_and(|e| e > 0.0))
            .collect();
        if mine.is_empty() {
            continue;
        }
        let line: Vec<(f64, f64)> = mine
            .iter()
            .filter(|p| p.tol == tight)
            .map(|p| log_xy(p))
            .collect();
        chart
            .draw_series(LineSeries::new(line, col.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label(*label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
        chart
            .draw_series(mine.iter().map(|p| {
                let xy = log_xy(p);
                let style = if p.tol == tight {
                    col.filled()
                } else {
                    col.stroke_width(2)
                };
                Circle::new(xy, 5, style)
            }))
            .map_err(|e| err(&e))?;
    }
    finish_chart(&mut chart, &root, path, 16, SeriesLabelPosition::UpperRight)
}

/// Runs `pn tradeoff`: writes `tradeoff.csv` and `tradeoff.png` and prints the table to
/// `stdout`.
pub fn run(args: &TradeoffRequest, stdout: &mut dyn std::io::Write) -> anyhow::Result<()> {
    let res = args.res.clone().unwrap_or(if args.quick {
        vec![12, 16]
    } else {
        vec![20, 30, 40, 60]
    });
    let tols = args.tol.clone().unwrap_or(vec![1e-4, 1e-6]);
    anyhow::ensure!(
        res.iter().all(|&n| (8..=200).contains(&n)),
        "--res values must be in 8..=200 (got {res:?})"
    );
    anyhow::ensure!(
        tols.iter().all(|&t| t > 0.0 && t < 1.0),
        "--tol values must be in (0, 1) (got {tols:?})"
    );
    // One untimed small solve first, so that thread-pool start-up and first-touch costs do
    // not land on the first measured point.
    measure("P1", 1, 8, 1e-4, &args.tuning).context("warm-up solve")?;
    let mut points = Vec::new();
    for &(method, order) in &METHODS {
        for &n in &res {
            for &tol in &tols {
                let p = measure(method, order, n, tol, &args.tuning)
                    .with_context(|| format!("{method} at {n}³, tolerance {tol:e}"))?;
                eprintln!("tradeoff: {}", p.csv());
                points.push(p);
            }
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut csv = Table::new(&CSV_HEADER.split(',').collect::<Vec<_>>());
    for p in &points {
        csv.push_row(p.cells())?;
    }
    std::fs::write(args.out.join("tradeoff.csv"), csv.to_csv())
        .with_context(|| format!("writing {}/tradeoff.csv", args.out.display()))?;
    write_png(&args.out.join("tradeoff.png"), &points, &tols)?;
    writeln!(stdout, "{}", markdown(&points)?)?;
    eprintln!(
        "wrote {0}/tradeoff.csv and {0}/tradeoff.png",
        args.out.display()
    );
    Ok(())
}

/// The table as Markdown.
fn markdown(points: &[Point]) -> anyhow::Result<String> {
    let mut t = Table::new(&[
        "method",
        "resolution",
        "tolerance",
        "unknowns",
        "iterations",
        "seconds",
        "error vs own reference",
        "error vs transport (Grosjean)",
    ]);
    for p in points {
        let e = |v: Option<f64>| v.map_or("–".into(), |v| format!("{v:.2e}"));
        t.push_row([
            p.method.to_string(),
            format!("{}³", p.res),
            format!("{:e}", p.tol),
            p.unknowns.to_string(),
            format!("{}{}", p.iterations, if p.converged { "" } else { " (nc)" }),
            format!("{:.3}", p.seconds()),
            format!("{} ({})", e(p.error_own), p.own_reference),
            e(p.error_transport),
        ])?;
    }
    Ok(t.to_markdown())
}
