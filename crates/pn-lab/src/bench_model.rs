//! `pn bench`, section "Model only what the scene requires" (docs/solvers.md), measured:
//!
//! * **2D problems solve only the 2D moments.** The checkerboard solved as 2D (the 2D
//!   stencil keeps the moments with l+m even and has no ∂z terms, docs/design.md §3) against the
//!   same problem as a one-cell-thick 3D slab (all (N+1)² moments): unknowns, non-zeros,
//!   seconds, and the difference of the answers.
//! * **Isotropic media skip the scattering terms that vanish.** The point source with an
//!   isotropic phase function, with Henyey–Greenstein g = 0 (the same λ_l p_l = δ_l0) and
//!   with g = 0.5: non-zeros and seconds. The stencil's collision weight is
//!   `σ_t − λ_l p_l σ_s` on the diagonal, so a vanishing phase moment removes no entry; the
//!   numbers show that the count does not depend on the phase function.

use crate::bench_rows::{reset_peak_memory, row_from, Row};
use pn_formats::Table;
use pn_kernels::{pn_kernel, Dim, Staggering};
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::problem::{Phase, Problem};
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::{SolverKind, SolverOptions, SolverTuning};
use std::fmt::Write as _;

fn solve(
    problem: &Problem,
    order: usize,
    tol: f64,
    tuning: &SolverTuning,
) -> anyhow::Result<Solution> {
    let k = pn_kernel(order, problem.grid.dim, Staggering::Staggered)?;
    pn_drivers::progress::print_notes(k.note.as_slice());
    let opts = SolverOptions {
        tol,
        tuning: tuning.clone(),
        ..Default::default()
    };
    let sol = solve_problem(problem, k.kernel.as_ref(), SolverKind::ParityCg, &opts)?;
    pn_drivers::progress::print_notes(&sol.stats.notes);
    Ok(sol)
}

fn res_label(p: &Problem) -> String {
    let g = &p.grid;
    g.res[..g.dim.axes()]
        .iter()
        .map(|n| n.to_string())
        .collect::<Vec<_>>()
        .join("x")
}

/// `max|a − b| / max|b|`.
fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    let s = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / s
}

/// Runs the measurements, appends their rows to `rows` (problem names
/// `checkerboard-slab3d`, `pointsource-isotropic`, `pointsource-hg0`, `pointsource-hg0.5`)
/// and returns the Markdown section.
pub(crate) fn model_rows(
    quick: bool,
    tuning: &SolverTuning,
    rows: &mut Vec<Row>,
) -> anyhow::Result<String> {
    let mut md = String::from("\n## Model only what the scene requires\n\n");
    let _ = writeln!(
        md,
        "### 2D problems solve only the 2D moments\n\nCheckerboard 71², parity-cg to 1e-10, \
         solved with the 2D stencil and as a 71×71×1 slab with the 3D stencil (same process).\n"
    );
    let mut t = Table::new(&[
        "N",
        "unknowns 2D / slab",
        "non-zeros 2D / slab",
        "seconds 2D / slab (assemble+solve)",
        "unknown ratio",
        "time ratio",
        "max rel. difference",
    ]);
    let orders: &[usize] = if quick { &[1, 3] } else { &[1, 3, 5] };
    for &order in orders {
        let two = builtin(
            "checkerboard",
            &BuiltinOptions {
                dim: Some(Dim::Two),
                res: Some(vec![71]),
                ..Default::default()
            },
        )?
        .problem;
        let slab = builtin(
            "checkerboard",
            &BuiltinOptions {
                dim: Some(Dim::Three),
                res: Some(vec![71, 71, 1]),
                ..Default::default()
            },
        )?
        .problem;
        reset_peak_memory();
        let s2 = solve(&two, order, 1e-10, tuning)?;
        reset_peak_memory();
        let s3 = solve(&slab, order, 1e-10, tuning)?;
        let row = row_from(
            "checkerboard-slab3d",
            "pn",
            order,
            res_label(&slab),
            &s3,
            None,
            "none",
        );
        eprintln!("bench: {}", row.csv());
        rows.push(row);
        let t2 = s2.seconds_assembly + s2.seconds_solve;
        let t3 = s3.seconds_assembly + s3.seconds_solve;
        t.push_row([
            order.to_string(),
            format!("{} / {}", s2.unknowns, s3.unknowns),
            format!("{} / {}", s2.nonzeros, s3.nonzeros),
            format!("{t2:.3} / {t3:.3}"),
            format!("{:.2}", s3.unknowns as f64 / s2.unknowns as f64),
            format!("{:.2}", t3 / t2.max(1e-9)),
            format!("{:.1e}", max_rel(&s3.l00(), &s2.l00())),
        ])?;
    }
    md += &t.to_markdown();

    let n = if quick { 24 } else { 40 };
    let _ = writeln!(
        md,
        "\n### Isotropic media: vanishing scattering terms\n\nPoint source {n}³, parity-cg to \
         1e-6. The collision weight σ_t − λ_l p_l σ_s sits on the diagonal, so a zero phase \
         moment removes no entry: the non-zeros are the same for every phase function, and \
         isotropic and HG g = 0 give the same system.\n"
    );
    let mut t = Table::new(&[
        "N",
        "phase",
        "unknowns",
        "non-zeros",
        "assemble s",
        "solve s",
        "iterations",
    ]);
    for &order in &orders[..2] {
        for (label, phase) in [
            ("isotropic", Phase::Isotropic),
            ("hg0", Phase::HenyeyGreenstein(0.0)),
            ("hg0.5", Phase::HenyeyGreenstein(0.5)),
        ] {
            let mut p = builtin(
                "pointsource",
                &BuiltinOptions {
                    dim: Some(Dim::Three),
                    res: Some(vec![n]),
                    ..Default::default()
                },
            )?
            .problem;
            p.phase = phase;
            reset_peak_memory();
            let s = solve(&p, order, 1e-6, tuning)?;
            let row = row_from(
                &format!("pointsource-{label}"),
                "pn",
                order,
                res_label(&p),
                &s,
                None,
                "none",
            );
            eprintln!("bench: {}", row.csv());
            rows.push(row);
            t.push_row([
                order.to_string(),
                label.to_string(),
                s.unknowns.to_string(),
                s.nonzeros.to_string(),
                format!("{:.3}", s.seconds_assembly),
                format!("{:.3}", s.seconds_solve),
                s.stats.iterations.to_string(),
            ])?;
        }
    }
    md += &t.to_markdown();
    Ok(md)
}
