//! The roofline columns of `pn bench`: for each P_N problem, the operator each solver
//! applies, its modelled bytes per application
//! ([`pn_krylov::operator::LinearOperator::bytes_per_application`]) and the measured
//! median time of one application, to compare with the machine's memory bandwidth
//! ([`pn_runtime::bandwidth`], measured once per `pn bench` run).
//!
//! The operators are rebuilt after the problem's solves (the solver drops them) and timed
//! on their own, outside the Krylov loop: at least [`MIN_REPS`] applications after one
//! warm-up, more (up to [`MAX_REPS`]) while they take less than [`BUDGET_S`] seconds, the
//! median kept. Which operator each solver applies:
//! * `parity-mg`: `S = D_e − B C̃` from the blocks' per-moment stencils (`s-stencil`,
//!   [`pn_runtime::solver::parity::stencil_s`]; `s-matfree` where they cannot be recovered);
//! * `parity-cg` with Jacobi: `S` matrix-free from the stored blocks (`s-matfree`);
//! * `parity-cg` with ILU(0) (small systems, [`Precond::forms_s`]): the formed CSR `S`
//!   (`s-formed`);
//! * `cgnr`, `lsqr`, `lsmr`: products with `A` and `Aᵀ` in compact CSR (`a-csr`; the time is
//!   the mean of one `A x` and one `Aᵀ y`);
//! * `cgnr-mf`: the matrix-free `A` and `Aᵀ` (`a-matfree`); its byte model is the compulsory
//!   traffic (a lower bound), so its ratio is an upper bound.
//!
//! CDA, FLD, the text PDEs and the model rows have no roofline entry.

use crate::bench_rows::{Roofline, Row};
use pn_krylov::operator::{AssembledOperator, LinearOperator};
use pn_runtime::assemble::assemble;
use pn_runtime::assemble_split::{assemble_split, has_parity_structure};
use pn_runtime::bandwidth::median_seconds;
use pn_runtime::problem::Problem;
use pn_runtime::solver::multigrid::Geometry;
use pn_runtime::solver::parity::reduced::ReducedOperator;
use pn_runtime::solver::parity::{Precond, ReducedMode};
use pn_runtime::Layout;
use pn_runtime::MatFreeOperator;
use pn_stencil::StencilKernel;

/// Timed applications at least.
pub(crate) const MIN_REPS: usize = 10;
/// Timed applications at most.
pub(crate) const MAX_REPS: usize = 50;
/// Seconds of timed applications after which no more are added beyond [`MIN_REPS`].
pub(crate) const BUDGET_S: f64 = 0.5;

/// Models and times `op` (with `transpose`: alternately `A x` and `Aᵀ y`, the time per
/// product); `None` when it has no byte model.
fn measure(op: &dyn LinearOperator, transpose: bool, operator: &'static str) -> Option<Roofline> {
    let bytes = op.bytes_per_application()?;
    // Deterministic, non-trivial input (no zeros that a product could skip).
    let x: Vec<f64> = (0..op.cols())
        .map(|i| 1.0 + (i % 7) as f64 * 0.125)
        .collect();
    let mut y = vec![0.0; op.rows()];
    let xt: Vec<f64> = (0..op.rows())
        .map(|i| 1.0 + (i % 5) as f64 * 0.25)
        .collect();
    let mut yt = vec![0.0; op.cols()];
    let seconds = if transpose {
        0.5 * median_seconds(MIN_REPS, MAX_REPS, BUDGET_S, || {
            op.apply(&x, &mut y);
            op.apply_transpose(&xt, &mut yt);
        })
    } else {
        median_seconds(MIN_REPS, MAX_REPS, BUDGET_S, || op.apply(&x, &mut y))
    };
    std::hint::black_box((&y, &yt));
    Some(Roofline {
        operator,
        bytes_per_application: bytes,
        seconds_per_application: seconds,
    })
}

/// Whether a P_N row of `rows` was solved by one of `names`.
fn wants(rows: &[Row], names: &[&str]) -> bool {
    rows.iter()
        .any(|r| r.method == "pn" && names.contains(&r.solver.as_str()))
}

/// Stores `r` in the P_N rows solved by one of `names`.
fn set(rows: &mut [Row], names: &[&str], r: &Option<Roofline>) {
    for row in rows
        .iter_mut()
        .filter(|row| row.method == "pn" && names.contains(&row.solver.as_str()))
    {
        row.roofline = r.clone();
    }
}

/// Measures the operators of the P_N `rows` (all of one problem and order, solved with
/// `kernel` on `problem`) and stores each in its rows' `roofline`. Each operator is built
/// once and dropped before the next.
pub(crate) fn attach(
    rows: &mut [Row],
    problem: &Problem,
    kernel: &dyn StencilKernel,
) -> anyhow::Result<()> {
    let layout = Layout::new(&problem.grid, kernel.moments())?;
    const ASSEMBLED: [&str; 3] = ["cgnr", "lsqr", "lsmr"];
    if wants(rows, &ASSEMBLED) {
        let op = AssembledOperator::new(&assemble(problem, kernel, &layout)?.matrix);
        set(rows, &ASSEMBLED, &measure(&op, true, "a-csr"));
    }
    if wants(rows, &["cgnr-mf"]) {
        let op = MatFreeOperator::new(problem, kernel, &layout)?;
        set(rows, &["cgnr-mf"], &measure(&op, true, "a-matfree"));
    }
    let (mg, cg) = (wants(rows, &["parity-mg"]), wants(rows, &["parity-cg"]));
    if (mg || cg) && has_parity_structure(kernel) {
        let Ok(system) = assemble_split(problem, kernel, &layout)? else {
            return Ok(());
        };
        let split = system.split;
        let free = measure(
            &ReducedOperator::new(&split, ReducedMode::MatrixFree),
            false,
            "s-matfree",
        );
        if mg {
            // parity-mg knows the unknowns' positions and applies S from the blocks'
            // stencils where they can be recovered (solver::parity::stencil_s).
            let geometry = Geometry::from_layout(&layout, None);
            let op = ReducedOperator::new(&split, ReducedMode::MatrixFree).with_stencil(&geometry);
            let stencil = if op.is_stencil() {
                measure(&op, false, "s-stencil")
            } else {
                free.clone()
            };
            set(rows, &["parity-mg"], &stencil);
        }
        if cg {
            // The mode `ParityCg` picks for `parity-ilu` (Precond::Auto, no geometry).
            let formed = if Precond::Auto.forms_s(split.nnz_a) {
                measure(
                    &ReducedOperator::new(&split, ReducedMode::Formed),
                    false,
                    "s-formed",
                )
            } else {
                free
            };
            set(rows, &["parity-cg"], &formed);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench_rows::{row_from, CSV_HEADER};
    use pn_kernels::{pn_kernel, Dim, Staggering};
    use pn_runtime::pipeline::solve_problem;
    use pn_runtime::scenes::{builtin, BuiltinOptions};
    use pn_runtime::solver::{SolverKind, SolverOptions};

    /// On a 15² checkerboard at P_1 every P_N solver of the bench gets a roofline entry of the
    /// operator it applies, with the byte model of the blocks it was built from; the CSV
    /// line has one field per header column, the new columns at the end.
    #[test]
    fn every_pn_solver_gets_its_operator_and_the_csv_its_columns() {
        let opts = BuiltinOptions {
            res: Some(vec![15]),
            ..Default::default()
        };
        let problem = builtin("checkerboard", &opts).unwrap().problem;
        let k = pn_kernel(1, Dim::Two, Staggering::Staggered).unwrap();
        let sopts = SolverOptions {
            tol: 1e-8,
            ..Default::default()
        };
        let mut rows = Vec::new();
        for kind in [
            SolverKind::Cgnr,
            SolverKind::ParityIlu,
            SolverKind::ParityMg,
            SolverKind::Lsqr,
            SolverKind::CgnrMf,
        ] {
            let sol = solve_problem(&problem, k.kernel.as_ref(), kind, &sopts).unwrap();
            rows.push(row_from(
                "checkerboard",
                "pn",
                1,
                "15x15".into(),
                &sol,
                None,
                "none",
            ));
        }
        attach(&mut rows, &problem, k.kernel.as_ref()).unwrap();
        let by = |s: &str| rows.iter().find(|r| r.solver == s).unwrap();
        let op = |s: &str| by(s).roofline.as_ref().unwrap().operator;
        assert_eq!(
            [
                op("cgnr"),
                op("lsqr"),
                op("cgnr-mf"),
                op("parity-mg"),
                op("parity-cg")
            ],
            ["a-csr", "a-csr", "a-matfree", "s-stencil", "s-formed"]
        );
        // The matrix-free S by the formula of ReducedOperator::bytes_per_application.
        let layout = Layout::new(&problem.grid, k.kernel.moments()).unwrap();
        let split = assemble_split(&problem, k.kernel.as_ref(), &layout)
            .unwrap()
            .unwrap()
            .split;
        let (ne, no) = (split.even.len(), split.odd.len());
        let nnz = split.b.nnz() + split.c_scaled.nnz();
        let blocks = 12 * nnz + 8 * (ne + no + 2) + 48 * ne + 16 * no;
        let free = ReducedOperator::new(&split, ReducedMode::MatrixFree);
        assert_eq!(free.bytes_per_application(), blocks as u64);
        // parity-mg's S from the stencils: the vectors, the diagonals and the corrections.
        let geometry = Geometry::from_layout(&layout, None);
        let corrections =
            pn_runtime::solver::parity::stencil_s::StencilReduced::build(&split, &geometry)
                .unwrap()
                .corrections();
        let want = 32 * ne + 24 * no + 16 * corrections;
        let mg = by("parity-mg").roofline.clone().unwrap();
        assert_eq!(mg.bytes_per_application, want as u64);
        assert!(mg.bytes_per_application < free.bytes_per_application());
        assert!(mg.seconds_per_application > 0.0 && mg.achieved_gbs().is_finite());
        assert!((mg.ratio(10.0) * 10.0 - mg.ratio(100.0)).abs() <= 1e-9 * mg.ratio(100.0));
        // CSV: the new columns at the end, filled where there is a model.
        let header: Vec<&str> = CSV_HEADER.split(',').collect();
        assert_eq!(
            header[header.len() - 7..],
            [
                "bytes_per_application",
                "bytes_per_unknown_iteration",
                "seconds_per_application",
                "achieved_gbs",
                "bandwidth_gbs",
                "roofline_ratio",
                "roofline_operator"
            ]
        );
        assert_eq!(
            header[13], "operator_applications",
            "old columns keep their place"
        );
        for r in &rows {
            let line = r.csv_line(Some(12.5));
            let fields: Vec<&str> = line.split(',').collect();
            assert_eq!(fields.len(), header.len(), "{line}");
            let col = |name: &str| fields[header.iter().position(|h| *h == name).unwrap()];
            assert_eq!(col("bandwidth_gbs"), "12.50", "{line}");
            let ratio: f64 = col("roofline_ratio").parse().unwrap();
            assert!(ratio.is_finite() && ratio > 0.0, "{line}");
            let per: f64 = col("bytes_per_unknown_iteration").parse().unwrap();
            assert!(per > 0.0, "{line}");
        }
        // A row without a model leaves the columns empty (bandwidth still given).
        let mut plain = row_from(
            "checkerboard",
            "cda",
            0,
            "15x15".into(),
            &solve_problem(&problem, k.kernel.as_ref(), SolverKind::ParityMg, &sopts).unwrap(),
            None,
            "none",
        );
        plain.roofline = None;
        assert!(plain.csv_line(Some(1.0)).ends_with(",,,,,1.00,,"));
        assert_eq!(plain.csv().split(',').count(), header.len());
    }
}
