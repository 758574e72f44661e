//! LSQR, LSMR and matrix-free CGNR: a small dense least-squares problem against nalgebra's
//! SVD solution, and the P_N systems against parity-cg (checkerboard P_1, a small point
//! source), assembled and matrix-free.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod common;

use common::rel_diff;
use nalgebra::DMatrix;
use pn_codegen::discretize::pn_ir_for_order;
use pn_krylov::{cgls, lsmr, lsqr};
use pn_runtime::pipeline::solve_problem;
use pn_runtime::problem::Problem;
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::{SolveStatus, SolverKind, SolverOptions};
use pn_stencil::Dim;
use pn_stencil::InterpretedKernel;
use pn_stencil::Staggering as Placement;
use sprs::TriMat;

fn opts(tol: f64) -> SolverOptions {
    SolverOptions {
        tol,
        ..Default::default()
    }
}

/// Deterministic numbers in [−1, 1).
fn random(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s >> 12;
            s ^= s << 25;
            s ^= s >> 27;
            (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        })
        .collect()
}

/// A 40×12 overdetermined system with b in the range of A (consistent): every solver must
/// return the unique least-squares solution, which nalgebra's SVD gives independently.
#[test]
fn overdetermined_consistent_system_matches_dense_solution() {
    let (m, n) = (40, 12);
    let vals = random(m * n, 7);
    let dense = DMatrix::from_row_slice(m, n, &vals);
    let xs = DMatrix::from_column_slice(n, 1, &random(n, 11));
    let b = &dense * &xs;
    let want = dense
        .clone()
        .svd(true, true)
        .solve(&b, 1e-14)
        .expect("SVD solve");
    let mut tri = TriMat::new((m, n));
    for i in 0..m {
        for j in 0..n {
            tri.add_triplet(i, j, vals[i * n + j]);
        }
    }
    let a = tri.to_csr::<usize>();
    let b: Vec<f64> = b.iter().copied().collect();
    // A random 40×12 matrix has cond ≈ 3–5; at ‖r‖/‖b‖ ≤ 1e-13 the solution error is
    // ≲ cond·1e-13, so 1e-10 leaves a wide margin while a wrong recurrence gives O(1).
    let o = opts(1e-13);
    for (name, (x, st)) in [
        ("lsqr", lsqr::lsqr(&a, &b, &o.stopping(), "lsqr")),
        ("lsmr", lsmr::lsmr(&a, &b, &o.stopping(), "lsmr")),
        ("cgls", cgls::cgls(&a, &b, &o.stopping(), "cgls")),
    ] {
        assert_eq!(st.status, SolveStatus::Converged, "{name}: {st:?}");
        assert!(st.relative_residual <= 1e-13, "{name}: {st:?}");
        let err = x
            .iter()
            .zip(want.iter())
            .fold(0.0f64, |e, (u, v)| e.max((u - v).abs()));
        assert!(err < 1e-10, "{name}: max error {err:.3e}");
        // Krylov methods on the normal equations reach the exact solution in ≤ n steps in
        // exact arithmetic; rounding adds a few.
        assert!(
            st.iterations <= 2 * n,
            "{name}: {} iterations",
            st.iterations
        );
    }
}

/// An inconsistent system cannot reach the tolerance: the status says so and the reported
/// residual is the true one (the least-squares minimum).
#[test]
fn inconsistent_system_reports_residual_reached() {
    // A = [[1], [1]], b = [1, −1]: least-squares solution 0, residual ‖b‖.
    let mut tri = TriMat::new((2, 1));
    tri.add_triplet(0, 0, 1.0);
    tri.add_triplet(1, 0, 1.0);
    let a = tri.to_csr::<usize>();
    for (x, st) in [
        lsqr::lsqr(&a, &[1.0, -1.0], &opts(1e-12).stopping(), "lsqr"),
        lsmr::lsmr(&a, &[1.0, -1.0], &opts(1e-12).stopping(), "lsmr"),
    ] {
        assert_ne!(st.status, SolveStatus::Converged);
        assert!((st.relative_residual - 1.0).abs() < 1e-12, "{st:?}");
        assert!(x[0].abs() < 1e-12);
    }
}

fn solve_l00(problem: &Problem, order: usize, kind: SolverKind, tol: f64) -> (Vec<f64>, usize) {
    let k = InterpretedKernel::new(
        pn_ir_for_order(order, problem.grid.dim, Placement::Staggered).unwrap(),
    );
    let sol = solve_problem(problem, &k, kind, &opts(tol)).unwrap();
    assert!(sol.stats.converged(), "{kind:?}: {:?}", sol.stats.status);
    assert!(sol.stats.relative_residual <= tol);
    if let Some(e) = &sol.energy {
        // Energy balance to the order of the residual (the l = 0 rows are part of it).
        assert!(e.relative_imbalance < 1e-6, "{kind:?}: {e:?}");
    }
    (sol.l00(), sol.stats.iterations)
}

/// Every solver gives parity-cg's answer. At relative residual 1e-10 the solutions differ
/// by at most cond(A)·2e-10 relative; these small systems have cond(A) ≲ 1e3, so 1e-6
/// bounds the difference (a wrong operator or solver differs at O(1e-2) or more).
fn same_answer(problem: &Problem, order: usize) {
    let tol = 1e-10;
    let (reference, pit) = solve_l00(problem, order, SolverKind::ParityCg, tol);
    for kind in [
        SolverKind::Lsqr,
        SolverKind::Lsmr,
        SolverKind::CgnrMf,
        SolverKind::LsqrMf,
        SolverKind::LsmrMf,
    ] {
        let (l00, it) = solve_l00(problem, order, kind, tol);
        let d = rel_diff(&l00, &reference);
        eprintln!("{kind:?}: {it} iterations (parity-cg {pit}), difference {d:.2e}");
        assert!(d < 1e-6, "{kind:?} differs from parity-cg by {d:.3e}");
    }
}

#[test]
fn checkerboard_p1_same_as_parity_cg() {
    let o = BuiltinOptions {
        dim: Some(Dim::Two),
        res: Some(vec![31]),
        ..Default::default()
    };
    same_answer(&builtin("checkerboard", &o).unwrap().problem, 1);
}

#[test]
fn small_point_source_same_as_parity_cg() {
    let o = BuiltinOptions {
        dim: Some(Dim::Three),
        res: Some(vec![12]),
        ..Default::default()
    };
    same_answer(&builtin("pointsource", &o).unwrap().problem, 1);
}
