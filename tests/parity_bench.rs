//! `parity-cg` against CGNR on the checkerboard with the real (generated) stencils.
//!
//! The fast test checks the same answer and the work ratio on a small grid; the ignored
//! one prints the table of operator applications and times for 71² P_1/P_3/P_5 at residual 1e-10:
//! `cargo test --release --test parity_bench -- --ignored --nocapture`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod support;

use pn_kernels::{pn_kernel, Dim, Staggering};
use pn_runtime::assemble::{assemble, System};
use pn_runtime::problem::Problem;
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::cgnr::Cgnr;
use pn_runtime::solver::parity::{KrylovMethod, ParityCg, ParityReport, Precond, ReducedMode};
use pn_runtime::solver::pn_layout::{cell_blocks, even_mask};
use pn_runtime::solver::{LinearSolver, SolveStats, SolverOptions};
use pn_runtime::unstagger;
use pn_runtime::Layout;
use std::time::Instant;
use support::rel_diff;

fn checkerboard(res: usize) -> Problem {
    let o = BuiltinOptions {
        dim: Some(Dim::Two),
        res: Some(vec![res]),
        ..Default::default()
    };
    builtin("checkerboard", &o).unwrap().problem
}

fn system(problem: &Problem, order: usize) -> (Layout, System) {
    let k = pn_kernel(order, Dim::Two, Staggering::Staggered).unwrap();
    let layout = Layout::new(&problem.grid, k.kernel.moments()).unwrap();
    let sys = assemble(problem, k.kernel.as_ref(), &layout).unwrap();
    (layout, sys)
}

fn opts(tol: f64) -> SolverOptions {
    SolverOptions {
        tol,
        ..Default::default()
    }
}

/// Fluence (√(4π) L_0^0) at cell centres.
fn fluence(problem: &Problem, layout: &Layout, u: &[f64]) -> Vec<f64> {
    let s = (4.0 * std::f64::consts::PI).sqrt();
    unstagger(&problem.grid, layout, u)
        .component(0)
        .into_iter()
        .map(|v| v * s)
        .collect()
}

/// CGNR's solution, statistics and seconds.
fn cgnr(sys: &System, tol: f64) -> (Vec<f64>, SolveStats, f64) {
    let t = Instant::now();
    let (u, st) = Cgnr.solve(&sys.matrix, &sys.rhs, &opts(tol));
    let secs = t.elapsed().as_secs_f64();
    assert!(st.converged(), "{st:?}");
    (u, st, secs)
}

/// The parity solver's solution, report and seconds (split + setup + iterations).
fn parity(sys: &System, solver: &ParityCg, tol: f64) -> (Vec<f64>, ParityReport, f64) {
    let t = Instant::now();
    let (u, rep) = solver
        .solve_detailed(&sys.matrix, &sys.rhs, &opts(tol))
        .unwrap();
    let secs = t.elapsed().as_secs_f64();
    assert!(rep.stats.converged(), "{:?}", rep.stats);
    (u, rep, secs)
}

/// CGNR work: one A and one Aᵀ per iteration, plus Aᵀb and the final residual.
fn cgnr_applications(s: &SolveStats) -> usize {
    2 * s.iterations + 2
}

/// Same answer (both at relative residual 1e-11; 1e-6 of the maximum fluence allows
/// cond(A) up to ~1e4, see pn-runtime/tests/parity.rs) and at least 5× less work with the
/// cheap block-Jacobi preconditioner (10× with the default ILU(0)).
#[test]
fn generated_stencils_same_answer_less_work() {
    let p = checkerboard(31);
    for order in [1, 3] {
        let (layout, sys) = system(&p, order);
        let (uc, sc, _) = cgnr(&sys, 1e-11);
        let fc = fluence(&p, &layout, &uc);
        let blocks = Precond::BlockJacobi {
            block_of: cell_blocks(&layout),
        };
        for (solver, min_ratio) in [
            (ParityCg::new(even_mask(&layout), blocks), 5.0),
            (ParityCg::for_layout(&layout), 10.0),
        ] {
            let (up, rep, _) = parity(&sys, &solver, 1e-11);
            let diff = rel_diff(&fluence(&p, &layout, &up), &fc);
            let ratio = cgnr_applications(&sc) as f64 / rep.a_equivalent_applications() as f64;
            eprintln!(
                "P{order} 31² {}: diff {diff:.2e}, work ratio {ratio:.1}",
                rep.precond
            );
            assert!(diff < 1e-6, "P{order}: fluence differs by {diff:.3e}");
            assert!(
                ratio >= min_ratio,
                "P{order} {}: only {ratio:.1}× fewer applications",
                rep.precond
            );
        }
    }
}

/// The roofline byte models of `pn bench` on the 31² checkerboard (P_1, P_3), counted from
/// the stored arrays themselves: the matrix-free `S` (blocks with 12-byte entries, 64-bit
/// row pointers, 48 bytes per even and 16 per odd unknown of vectors), the formed `S`
/// (16-byte entries) and one compact-CSR product with `A` (cgnr).
#[test]
fn roofline_byte_models_count_the_stored_arrays() {
    use pn_krylov::operator::{AssembledOperator, LinearOperator};
    use pn_runtime::solver::parity::reduced::ReducedOperator;
    use pn_runtime::solver::parity::split::split;
    let p = checkerboard(31);
    for order in [1, 3] {
        let (layout, sys) = system(&p, order);
        let sp = split(&sys.matrix, &even_mask(&layout)).unwrap();
        let (ne, no) = (sp.even.len(), sp.odd.len());
        let blocks = sp.b.data().len() * 8
            + sp.b.indices().len() * 4
            + sp.b.indptr().raw_storage().len() * 8
            + sp.c_scaled.data().len() * 8
            + sp.c_scaled.indices().len() * 4
            + sp.c_scaled.indptr().raw_storage().len() * 8;
        let free = ReducedOperator::new(&sp, ReducedMode::MatrixFree);
        assert_eq!(
            free.bytes_per_application(),
            (blocks + 48 * ne + 16 * no) as u64,
            "P{order}"
        );
        let formed = ReducedOperator::new(&sp, ReducedMode::Formed);
        let s = formed.formed().unwrap();
        assert_eq!(
            formed.bytes_per_application(),
            (s.nnz() * 16 + (ne + 1) * 8 + 16 * ne) as u64,
            "P{order}"
        );
        let n = layout.len();
        assert_eq!(
            AssembledOperator::new(&sys.matrix).bytes_per_application(),
            Some((sys.matrix.nnz() * 12 + (n + 1) * 8 + 16 * n) as u64),
            "P{order}"
        );
    }
}

/// Applications and times against CGNR: checkerboard 71², P_1/P_3/P_5, residual 1e-10.
#[test]
#[ignore]
fn checkerboard_71_table() {
    let p = checkerboard(71);
    let tol = 1e-10;
    println!(
        "| N | unknowns | solver | precond | method | iterations | A-applications | seconds (setup) | work ratio | time ratio | max fluence diff |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for order in [1usize, 3, 5] {
        let (layout, sys) = system(&p, order);
        let (uc, sc, c_secs) = cgnr(&sys, tol);
        let fc = fluence(&p, &layout, &uc);
        let ca = cgnr_applications(&sc);
        println!(
            "| {order} | {} | cgnr | – | cgnr | {} | {ca} | {c_secs:.3} | 1 | 1 | 0 |",
            layout.len(),
            sc.iterations
        );
        let blocks = || Precond::BlockJacobi {
            block_of: cell_blocks(&layout),
        };
        let even = || even_mask(&layout);
        let solvers = [
            ParityCg::new(even(), Precond::Jacobi),
            ParityCg::new(even(), blocks()),
            ParityCg::new(even(), blocks()).with_mode(ReducedMode::Formed),
            ParityCg::for_layout(&layout),
            ParityCg::for_layout(&layout).with_mode(ReducedMode::MatrixFree),
            ParityCg::new(
                even(),
                Precond::Ilu0Cells {
                    block_of: cell_blocks(&layout),
                },
            ),
            ParityCg::for_layout(&layout).with_method(Some(KrylovMethod::Gmres)),
            ParityCg::for_layout(&layout).with_method(Some(KrylovMethod::Cg)),
        ];
        for solver in solvers {
            let (up, rep, secs) = parity(&sys, &solver, tol);
            let diff = rel_diff(&fluence(&p, &layout, &up), &fc);
            let pa = rep.a_equivalent_applications();
            println!(
                "| {order} | {} | parity-cg{} | {} | {} | {} | {pa} | {secs:.3} ({:.3}) | {:.1} | {:.1} | {diff:.1e} |",
                layout.len(),
                if rep.formed { " (S formed)" } else { "" },
                rep.precond,
                rep.method.name(),
                rep.stats.iterations,
                rep.seconds_setup,
                ca as f64 / pa as f64,
                c_secs / secs,
            );
        }
        println!(
            "asymmetry of S for P{order}: {:.1e}",
            ParityCg::for_layout(&layout)
                .solve_detailed(&sys.matrix, &sys.rhs, &opts(tol))
                .unwrap()
                .1
                .asymmetry
        );
    }
}

/// Point source (σ_t = 8, albedo 0.9, 3D) to relative residual 1e-6: CGNR vs parity-cg
/// (default preconditioner). `PARITY_PS_RES` (default 40) sets the resolution.
#[test]
#[ignore]
fn pointsource_table() {
    let res: usize = std::env::var("PARITY_PS_RES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(40);
    let orders: Vec<usize> = std::env::var("PARITY_PS_ORDERS")
        .ok()
        .map(|v| v.split(',').filter_map(|o| o.parse().ok()).collect())
        .unwrap_or(vec![1, 3]);
    let o = BuiltinOptions {
        dim: Some(Dim::Three),
        res: Some(vec![res]),
        ..Default::default()
    };
    let p = builtin("pointsource", &o).unwrap().problem;
    let tol = 1e-6;
    println!("| N | res | unknowns | cgnr it | cgnr s | parity precond | method | parity it | work ratio | parity s (setup) | time ratio | max fluence diff |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for order in orders {
        let k = pn_kernel(order, Dim::Three, Staggering::Staggered).unwrap();
        let layout = Layout::new(&p.grid, k.kernel.moments()).unwrap();
        let sys = assemble(&p, k.kernel.as_ref(), &layout).unwrap();
        let (uc, sc, c_secs) = cgnr(&sys, tol);
        let solvers = [
            ParityCg::for_layout(&layout),
            ParityCg::new(even_mask(&layout), Precond::Jacobi),
            ParityCg::new(
                even_mask(&layout),
                Precond::BlockJacobi {
                    block_of: cell_blocks(&layout),
                },
            ),
        ];
        for solver in solvers {
            let (up, rep, secs) = parity(&sys, &solver, tol);
            // Both stop at 1e-6: the fluences agree to about that, not to 1e-10.
            let diff = rel_diff(&fluence(&p, &layout, &up), &fluence(&p, &layout, &uc));
            println!(
                "| {order} | {res} | {} | {} | {c_secs:.2} | {} | {} | {} | {:.1} | {secs:.2} ({:.2}) | {:.1} | {diff:.1e} |",
                layout.len(),
                sc.iterations,
                rep.precond,
                rep.method.name(),
                rep.stats.iterations,
                cgnr_applications(&sc) as f64 / rep.a_equivalent_applications() as f64,
                rep.seconds_setup,
                c_secs / secs,
            );
        }
    }
}
